// The quadtree's per-node facts, checked by brute force against the posts: height ranges,
// geometric error as a true upper bound of the 3D distance to the full-resolution surface, and
// stitched edges that meet the coarser neighbour's edge exactly.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "terrain/quadtree.hpp"
#include "test_terrain.hpp"
#include "triangle_distance.hpp"

namespace gis::test {
namespace {

using terrain::NodeId;
using terrain::TerrainQuadtree;

// Heights are floats of up to ~1 km: 1 mm covers float rounding in the interpolation.
constexpr double kHeightTolerance = 1e-3;

std::vector<NodeId> allNodes(const TerrainQuadtree& tree) {
  std::vector<NodeId> nodes;
  for (int level = 0; level <= tree.rootLevel(); ++level) {
    for (int y = 0; y < tree.nodesPerSide(level); ++y) {
      for (int x = 0; x < tree.nodesPerSide(level); ++x) nodes.push_back({level, x, y});
    }
  }
  return nodes;
}

TEST(Quadtree, LevelsCoverThePaddedGrid) {
  TerrainQuadtree square(makeStiffTerrain({.width = 257, .height = 257}), 64);
  EXPECT_EQ(square.rootLevel(), 2);  // 256 cells = 64 · 2²
  TerrainQuadtree oblong(makeStiffTerrain({.width = 300, .height = 120}), 64);
  EXPECT_EQ(oblong.rootLevel(), 3);  // 299 cells → 512
  EXPECT_EQ(oblong.nodeCount(), 1u + 4u + 16u + 64u);
}

TEST(Quadtree, NodeRangesAreThoseOfTheirPosts) {
  TerrainQuadtree tree(makeStiffTerrain({.width = 300, .height = 181, .seed = 3}), 32);
  for (const NodeId& n : allNodes(tree)) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    const glm::ivec2 p0 = tree.vertexPost(n, 0, 0), p1 = tree.vertexPost(n, tree.chunkCells(), tree.chunkCells());
    for (int r = p0.y; r <= p1.y; ++r) {
      for (int c = p0.x; c <= p1.x; ++c) {
        const float h = tree.post(c, r);
        if (std::isnan(h)) continue;
        lo = std::min(lo, h);
        hi = std::max(hi, h);
      }
    }
    const terrain::NodeInfo& info = tree.info(n);
    ASSERT_EQ(info.hasData, lo <= hi) << n.level << " " << n.x << " " << n.y;
    if (!info.hasData) continue;
    EXPECT_EQ(info.minHeight, lo);
    EXPECT_EQ(info.maxHeight, hi);
  }
}

/// The drawn surface of one level (cells with four valid corners, the project's diagonal) in
/// metres: x = col · |step.x|, y = row · |step.y| (a reflection of the frame, distances alike).
class LevelMesh {
 public:
  LevelMesh(const TerrainQuadtree& tree, int level)
      : tree_(tree),
        stride_(1 << level),
        spacing_(glm::abs(tree.grid().step)),
        cells_((tree.chunkCells() << (tree.rootLevel() - level))) {}

  [[nodiscard]] glm::dvec3 point(double col, double row, double h) const {
    return {col * spacing_.x, row * spacing_.y, h};
  }

  /// Exact distance from p to the mesh if below `limit`, else `limit`. Cells are visited in
  /// rings around p's cell until a ring is farther horizontally than the best distance so far.
  [[nodiscard]] double distance(const glm::dvec3& p, double limit) const {
    const glm::dvec2 cell = spacing_ * static_cast<double>(stride_);
    const int c0 = static_cast<int>(std::floor(p.x / cell.x)), r0 = static_cast<int>(std::floor(p.y / cell.y));
    double best = limit;
    for (int ring = 0; (ring - 1) * std::min(cell.x, cell.y) < best; ++ring) {
      bool inside = false;
      for (int r = r0 - ring; r <= r0 + ring; ++r) {
        for (int c = c0 - ring; c <= c0 + ring; ++c) {
          if (std::max(std::abs(c - c0), std::abs(r - r0)) != ring) continue;
          if (c < 0 || r < 0 || c >= cells_ || r >= cells_) continue;
          inside = true;
          const double a = post(c, r), b = post(c + 1, r), d = post(c, r + 1), e = post(c + 1, r + 1);
          if (std::isnan(a) || std::isnan(b) || std::isnan(d) || std::isnan(e)) continue;
          const glm::dvec3 lo(c * cell.x, r * cell.y, std::min({a, b, d, e}));
          const glm::dvec3 hi((c + 1) * cell.x, (r + 1) * cell.y, std::max({a, b, d, e}));
          if (glm::length(p - glm::clamp(p, lo, hi)) >= best) continue;
          const glm::dvec3 pa(lo.x, lo.y, a), pb(hi.x, lo.y, b), pd(lo.x, hi.y, d), pe(hi.x, hi.y, e);
          best = std::min(best, glm::length(p - closestPointOnTriangle(p, pa, pd, pe)));
          best = std::min(best, glm::length(p - closestPointOnTriangle(p, pa, pe, pb)));
        }
      }
      if (!inside) break;
    }
    return best;
  }

 private:
  [[nodiscard]] double post(int c, int r) const { return tree_.post(c * stride_, r * stride_); }

  const TerrainQuadtree& tree_;
  int stride_;
  glm::dvec2 spacing_;
  int cells_;
};

/// Number of nodata posts (or posts outside the grid) in the closed rectangle of posts
/// [c0, c1] × [r0, r1], from a summed-area table.
class NodataCount {
 public:
  explicit NodataCount(const TerrainQuadtree& tree)
      : side_((tree.chunkCells() << tree.rootLevel()) + 2), sums_(static_cast<std::size_t>(side_ * side_), 0) {
    for (int r = 0; r + 1 < side_; ++r) {
      for (int c = 0; c + 1 < side_; ++c) {
        sums_[at(c + 1, r + 1)] =
            sums_[at(c, r + 1)] + sums_[at(c + 1, r)] - sums_[at(c, r)] + (std::isnan(tree.post(c, r)) ? 1 : 0);
      }
    }
  }
  [[nodiscard]] int operator()(int c0, int r0, int c1, int r1) const {
    return sums_[at(c1 + 1, r1 + 1)] - sums_[at(c0, r1 + 1)] - sums_[at(c1 + 1, r0)] + sums_[at(c0, r0)];
  }

 private:
  [[nodiscard]] std::size_t at(int c, int r) const { return static_cast<std::size_t>(r * side_ + c); }
  int side_;
  std::vector<int> sums_;
};

// The geometric error bounds the 3D (Hausdorff) distance between a node's surface and the
// full-resolution surface, both ways: every point of the node's level surface has a point of the
// full-resolution mesh within the error, and every full-resolution point one of the level
// surface. Sampled at every full-resolution post and at the centroids of both full-resolution
// triangles of every cell, in the node's level cells without nodata (a hole is not drawn at the
// fine levels but may be filled at a coarse one: nothing to compare there).
TEST(Quadtree, GeometricErrorBoundsTheDistanceToFullResolution) {
  constexpr std::array<std::array<double, 2>, 3> kSamples{{{0.0, 0.0}, {1.0 / 3.0, 2.0 / 3.0}, {2.0 / 3.0, 1.0 / 3.0}}};
  for (unsigned seed : {1u, 2u, 3u}) {
    TerrainQuadtree tree(makeStiffTerrain({.width = 257, .height = 257, .seed = seed}), 16);
    const LevelMesh full(tree, 0);
    const NodataCount nodata(tree);
    std::size_t tight = 0, belowVertical = 0;
    for (const NodeId& n : allNodes(tree)) {
      const terrain::NodeInfo& info = tree.info(n);
      if (!info.hasData) continue;
      if (n.level == 0) {
        EXPECT_EQ(info.geometricError, 0.0F);
        continue;
      }
      for (const NodeId& c : n.children()) EXPECT_GE(info.geometricError, tree.info(c).geometricError);
      const LevelMesh level(tree, n.level);
      const double limit = info.geometricError + 2.0 * kHeightTolerance;  // reported when exceeded
      const int stride = 1 << n.level;
      double worst = 0.0, worstVertical = 0.0;
      for (int cj = 0; cj < tree.chunkCells(); ++cj) {
        for (int ci = 0; ci < tree.chunkCells(); ++ci) {
          const glm::ivec2 p0 = tree.vertexPost(n, ci, cj);
          if (nodata(p0.x, p0.y, p0.x + stride, p0.y + stride) != 0) continue;
          for (int r = p0.y; r < p0.y + stride; ++r) {
            for (int c = p0.x; c < p0.x + stride; ++c) {
              for (const auto& [fx, fy] : kSamples) {
                const double col = c + fx, row = r + fy;
                const double fine = tree.levelSurface(0, col, row), coarse = tree.levelSurface(n.level, col, row);
                const double vertical = std::abs(fine - coarse);
                worstVertical = std::max(worstVertical, vertical);
                const double toFull = full.distance(level.point(col, row, coarse), std::min(limit, vertical));
                const double toLevel = level.distance(full.point(col, row, fine), std::min(limit, vertical));
                ASSERT_LE(toFull, info.geometricError + kHeightTolerance)
                    << "level " << n.level << " node " << n.x << " " << n.y << " at " << col << " " << row;
                ASSERT_LE(toLevel, info.geometricError + kHeightTolerance)
                    << "level " << n.level << " node " << n.x << " " << n.y << " at " << col << " " << row;
                worst = std::max({worst, toFull, toLevel});
              }
            }
          }
        }
      }
      tight += worst >= 0.5 * info.geometricError;
      belowVertical += info.geometricError < 0.5 * worstVertical;
    }
    EXPECT_GT(tight, 0u) << "the bound should be tight for some nodes, seed " << seed;
    EXPECT_GT(belowVertical, 0u) << "cliff nodes should have errors far below their vertical distance, seed " << seed;
  }
}

TEST(Quadtree, FlatTerrainHasNoError) {
  auto grid = makeStiffTerrain({.width = 129, .height = 129, .cliffs = false, .spike = false, .holes = false});
  std::fill(grid->heights.begin(), grid->heights.end(), 12.5F);
  TerrainQuadtree tree(grid, 16);
  for (const NodeId& n : allNodes(tree)) EXPECT_EQ(tree.info(n).geometricError, 0.0F);
}

TEST(Quadtree, StitchedEdgesMeetTheCoarserNeighbourExactly) {
  TerrainQuadtree tree(makeStiffTerrain({.width = 257, .height = 257, .seed = 5, .holes = false}), 16);
  const int n = tree.chunkCells();
  for (int level = 0; level < tree.rootLevel(); ++level) {
    for (int y = 0; y < tree.nodesPerSide(level); ++y) {
      for (int x = 0; x < tree.nodesPerSide(level); ++x) {
        const NodeId node{level, x, y};
        const glm::ivec2 p0 = tree.vertexPost(node, 0, 0), p1 = tree.vertexPost(node, n, n);
        for (int k = 0; k <= 4 * n; ++k) {
          const double t = p0.x + (p1.x - p0.x) * k / (4.0 * n);
          const double u = p0.y + (p1.y - p0.y) * k / (4.0 * n);
          // north edge (row p0.y), west edge (col p0.x), and the opposite ones
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeNorth, t, p0.y), tree.levelSurface(level + 1, t, p0.y),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeSouth, t, p1.y), tree.levelSurface(level + 1, t, p1.y),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeWest, p0.x, u), tree.levelSurface(level + 1, p0.x, u),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeEast, p1.x, u), tree.levelSurface(level + 1, p1.x, u),
                      kHeightTolerance);
        }
      }
    }
  }
}

}  // namespace
}  // namespace gis::test
