#pragma once
// The geometric error of one simplification step of the quadtree: how far the surface of a
// level-l node (its posts every second child-level post) lies from the level-(l−1) surface
// below it. The quadtree, the tile-pyramid builder and the tests share this one definition.
#include <span>

#include <glm/vec2.hpp>

namespace gis::terrain {

/// An upper bound of the Hausdorff distance (3D, metres) between the coarse surface of a node
/// and its child-level surface, from the node's (2n + 1)² child-level posts (row-major, NaN at
/// nodata) and the horizontal spacing of those posts (metres, x and y).
///
/// Per coarse cell K (2 × 2 child cells) the bound is min(v, D + x): v, the largest vertical
/// difference at the child posts (exact, both surfaces are linear on the child triangles);
/// D, the diagonal of K; x, how far the child heights in K reach beyond the range of K's coarse
/// corners. Every child-surface point over K has a coarse-surface point in K at the same height
/// within D horizontally (intermediate values), or within D + x if its height is outside the
/// corners' range; every coarse point has a child point at the same height in K, since the
/// corners are child posts. So a vertical cliff costs about one coarse cell, not its height.
/// Where nodata changes what is drawn (a coarse cell with a nodata corner over drawn child
/// cells, or a drawn coarse cell over a child-level hole) the edge of the data moves by up to D,
/// and the bound is at least D: the screen-space error then bounds how far a DEM's nodata border
/// or a hole's rim moves on screen, as it bounds the surface elsewhere.
double simplificationError(std::span<const float> childPosts, int n, const glm::dvec2& childSpacing);

/// The same bound for a surface drawn with vertical exaggeration k: error(k) ≤ max(|k|, 1) ·
/// error(1), as min(|k|·v, D + |k|·x) ≤ max(|k|, 1) · min(v, D + x).
inline double exaggeratedError(double error, double exaggeration) {
  const double k = exaggeration < 0.0 ? -exaggeration : exaggeration;
  return error * (k > 1.0 ? k : 1.0);
}

}  // namespace gis::terrain
