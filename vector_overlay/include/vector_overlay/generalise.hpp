#pragma once
// Generalisation for view-dependent detail (tiled_layer.hpp): line and ring simplification
// with a known ground error, and the parts of a line that can reach a tile.
//
// The error bound. simplifyPolyline keeps a subset of the points (both ends always) such that
// every dropped point lies within `epsilon` of the kept segment that replaces its run, measured
// to the segment (not to its infinite line). Moving each point of the original run to its
// nearest point on that segment is then a homotopy that stays within epsilon of the original
// curve, so:
// - a ring's winding number (and even-odd parity) is unchanged at every point farther than
//   epsilon from the original ring: a polygon covers the same ground outside a band of
//   epsilon around its boundary, whatever self-crossings the simplification makes;
// - a line's round-joined, round-capped footprint of width w (the points within w/2 of the
//   centre line) moves by at most epsilon (Hausdorff distance). Miter and bevel joins and flat
//   or square caps depend on the directions of the segments, which simplification changes:
//   their footprint moves by at most epsilon + lineShapeSlack(shape) (see there).
#include <cmath>
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "geo/feature.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay {

struct LineShape;

/// The Douglas–Peucker core of every generalisation in both frames (this file's, the globe's
/// rings in longitude and latitude and its lines on the ellipsoid): marks in `keep` the points
/// of (first, last) that the span keeps, the ends being kept by the caller. `distance(k, a, b)`
/// is how far point k lies from the chord between points a and b as the frame measures it: a
/// point farther than `epsilon` is kept and splits the span; infinity keeps a point whatever
/// the tolerance (a pole), NaN keeps the first such point at once. Indices are the caller's (a
/// ring's last span may end at its size, standing for point 0). An explicit stack: lines of
/// millions of points do not recurse that deep.
template <typename Distance>
void markDouglasPeucker(std::size_t first, std::size_t last, double epsilon, std::vector<char>& keep,
                        Distance&& distance) {
  std::vector<std::pair<std::size_t, std::size_t>> stack{{first, last}};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    if (b <= a + 1) continue;
    double worst = -1.0;
    std::size_t at = a;
    for (std::size_t k = a + 1; k < b; ++k) {
      const double d = distance(k, a, b);
      if (std::isnan(d)) {
        worst = d;
        at = k;
        break;
      }
      if (d > worst) {
        worst = d;
        at = k;
      }
    }
    if (!(worst <= epsilon)) {
      keep[at] = 1;
      stack.emplace_back(a, at);
      stack.emplace_back(at, b);
    }
  }
}

/// How far point p lies from the segment a–b as a frame measures it, in epsilon's unit; empty:
/// the plane's distance to the segment (a projected frame). The globe measures its rings in
/// longitude and latitude along the ellipsoid (globe_polygon.cpp).
using SegmentDistance = std::function<double(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b)>;

/// Douglas–Peucker with the distance to the segment: the kept points, ends included. Fewer than
/// 3 points are returned unchanged; epsilon <= 0 returns the points unchanged.
std::vector<glm::dvec2> simplifyPolyline(std::span<const glm::dvec2> points, double epsilon,
                                         const SegmentDistance& distance = {});

/// A closed ring (not repeating its first point) simplified as above, cut at its first point
/// and at the point farthest from it. Keeps at least 3 points and returns the ring unchanged
/// when the simplified one would have no area (so a usable ring stays usable).
geo::Ring simplifyRing(const geo::Ring& ring, double epsilon, const SegmentDistance& distance = {});

/// How far beyond epsilon a line's footprint can move when its centre line is simplified by
/// epsilon: 0 for round joins and caps; otherwise the reach of a miter (miterLimit · w/2), a
/// bevel or a square cap (w/2 · √2) beyond the round footprint, which simplification may add
/// or take away.
double lineShapeSlack(LineJoin join, LineCap cap, double miterLimit, double width);

/// The feature's geometry simplified by epsilon (polygons' rings, lines), with its fid; the
/// attributes are dropped (the caller keeps its style). epsilon <= 0 copies the geometry.
geo::Feature generaliseGeometry(const geo::Feature& feature, double epsilon);

/// The features' geometry simplified by epsilon as one coverage (their fids kept, attributes
/// dropped): the rings' borders shared by several rings (a layer's neighbouring polygons, a hole
/// and the island in it) are simplified once, so that neighbours still meet exactly and no crack
/// or overlap opens between them. A ring is cut at its nodes — a point where the rings sharing its
/// edges change, or a point of three rings or more — and each chain between two nodes is
/// simplified as simplifyPolyline does, from a canonical direction, so every ring holding the
/// chain gets the same points. A ring that would lose its area keeps all its points, and so do
/// its neighbours along it. Points are matched exactly (a shared border is the same coordinates
/// in both rings, as a GIS coverage stores it). Lines are simplified as generaliseGeometry does.
/// Each ring stays within epsilon of its own, so the error bound above holds per feature.
/// `distance`: the frame's measure (SegmentDistance), the same for every ring.
std::vector<geo::Feature> generaliseCoverage(std::span<const geo::Feature* const> features, double epsilon,
                                             const SegmentDistance& distance = {});

/// generaliseCoverage at several tolerances over the same features: the shared borders are found
/// once (the costly part: every edge and point hashed), and each tolerance then simplifies the
/// chains between the nodes (the globe's levels of detail). The features must outlive it.
class CoverageGeneraliser {
 public:
  explicit CoverageGeneraliser(std::span<const geo::Feature* const> features, SegmentDistance distance = {});
  CoverageGeneraliser(const CoverageGeneraliser&) = delete;
  CoverageGeneraliser& operator=(const CoverageGeneraliser&) = delete;
  ~CoverageGeneraliser();
  /// What generaliseCoverage(features, epsilon, distance) gives. `wanted` (per feature, optional):
  /// a feature whose entry is 0 comes back with its fid only, and costs nothing.
  /// `dropWithinEpsilon`: a ring sharing no border that lies wholly within epsilon of one chord
  /// (an island smaller than the error) comes back empty instead of simplified to a triangle:
  /// what it covers lies within epsilon of its boundary, which the error bound allows. Off by
  /// default, so that a usable ring stays usable (a projected tile reports its features).
  [[nodiscard]] std::vector<geo::Feature> at(double epsilon, const std::vector<char>* wanted = nullptr,
                                             bool dropWithinEpsilon = false) const;

 private:
  struct Topology;
  std::unique_ptr<Topology> t_;
};

/// Appends to `out` the runs of `line` that can reach the box [lo, hi] once widened by `reach`
/// (how far any of its shapes reaches from the line: half the width, more for miters and square
/// caps): the maximal runs of segments whose box widened by reach meets the box. A run's cut end
/// is an end of a segment that does not reach the box, so it and its cap lie farther than reach
/// from it; the joins inside a run are the line's. So inside the box the runs' footprints cover
/// exactly what the whole line's covers.
void appendRunsNear(std::span<const glm::dvec2> line, const glm::dvec2& lo, const glm::dvec2& hi, double reach,
                    std::vector<geo::LineString>& out);

/// Appends to `out` the parts of `line` inside the box [lo, hi] (closed), cut where its segments
/// cross the box's edges; parts of less than two distinct points are left out, and a single
/// point is kept when it lies inside. Each part follows the line: its round-joined,
/// round-capped footprint is the line's inside the box shrunk by the half width, plus caps at
/// the cuts that lie within the line's footprint (a disc on the centre line).
void appendClipped(std::span<const glm::dvec2> line, const glm::dvec2& lo, const glm::dvec2& hi,
                   std::vector<geo::LineString>& out);

}  // namespace gis::overlay
