// Line footprints: one convex piece per segment rectangle, join and cap (footprints.hpp gives
// the shapes). With a cell grid every piece — segments, joins and caps alike — is split at the
// cell borders and clipped to the grid's extent, so that every footprint lies in its cell (a
// join or cap of a 5 km wide road is not small) and gets that cell's height bounds.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "footprint_geometry.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay {
namespace {

/// Same bound as for polygons, for coordinates and widths: beyond it, products overflow.
constexpr double kMaxCoordinate = 1e15;

glm::dvec2 perp(const glm::dvec2& d) { return {-d.y, d.x}; }

glm::dvec2 unit(const glm::dvec2& d) {
  // hypot avoids overflow and underflow for extreme lengths
  const double length = std::hypot(d.x, d.y);
  return {d.x / length, d.y / length};
}

class PieceSink {
 public:
  PieceSink(std::uint32_t feature, const FootprintOptions& options, std::vector<Footprint>& out)
      : feature_(feature), options_(options), out_(out) {}

  /// Adds the convex polygon (counter-clockwise) as one footprint, or one per cell.
  void add(PieceKind kind, std::vector<glm::dvec2> pts) {
    detail::dropRepeatedPoints(pts);
    if (pts.size() < 3) return;
    if (!options_.cells) {
      detail::triangulateConvex(pts, builder_);
      if (!builder_.empty()) out_.push_back(builder_.finish(feature_, -1, kind));
      return;
    }
    detail::splitIntoCells(detail::makeClipPolygon(pts), *options_.cells,
                           [&](int cell, const std::vector<glm::dvec2>& part) {
                             detail::triangulateConvex(part, builder_);
                             if (!builder_.empty()) out_.push_back(builder_.finish(feature_, cell, kind));
                           });
  }

  void disc(PieceKind kind, const glm::dvec2& centre, double radius, const glm::dvec2& direction) {
    add(kind, detail::discPolygon(centre, radius, direction, options_.chordTolerance));
  }

 private:
  std::uint32_t feature_;
  const FootprintOptions& options_;
  std::vector<Footprint>& out_;
  detail::FootprintBuilder builder_;
};

/// Points on the circle (centre, r) from angle a0 to a1 (radians, a1 > a0: counter-clockwise),
/// both ends included, with chords no farther than `tolerance` from the arc.
std::vector<glm::dvec2> arc(const glm::dvec2& centre, double r, double a0, double a1, double tolerance) {
  const int full = detail::circleSegments(r, tolerance);
  const int m = std::max(1, static_cast<int>(std::ceil((a1 - a0) / (2.0 * std::numbers::pi) * full)));
  std::vector<glm::dvec2> pts;
  pts.reserve(static_cast<std::size_t>(m + 1));
  for (int k = 0; k <= m; ++k) {
    const double a = a0 + (a1 - a0) * k / m;
    pts.push_back(centre + r * glm::dvec2(std::cos(a), std::sin(a)));
  }
  return pts;
}

/// The cap at `end`, the line leaving it in the unit direction `outward`. A round cap whose end
/// segment is at least w/2 long needs only the outer half disc: the rectangle holds the other
/// half (same union, half the triangles).
void addCap(PieceSink& sink, const LineShape& shape, double h, const glm::dvec2& end, const glm::dvec2& outward,
            double segmentLength, double tolerance) {
  const glm::dvec2 n = perp(outward);
  switch (shape.cap) {
    case LineCap::Round:
      if (segmentLength >= h) {
        const double a = std::atan2(outward.y, outward.x);
        sink.add(PieceKind::Cap, arc(end, h, a - 0.5 * std::numbers::pi, a + 0.5 * std::numbers::pi, tolerance));
      } else {
        sink.disc(PieceKind::Cap, end, h, n);
      }
      break;
    case LineCap::Square:
      sink.add(PieceKind::Cap, {end - h * n, end + h * outward - h * n, end + h * outward + h * n, end + h * n});
      break;
    case LineCap::Flat:
      break;
  }
}

/// The join at vertex v between the segments prev → v and v → next.
void addJoin(PieceSink& sink, const LineShape& shape, double h, const glm::dvec2& prev, const glm::dvec2& v,
             const glm::dvec2& next, double tolerance) {
  const glm::dvec2 d0 = unit(v - prev);
  const glm::dvec2 d1 = unit(next - v);
  const int turn = detail::orientation(prev, v, next);
  if (turn == 0 && d0.x * d1.x + d0.y * d1.y > 0.0) return;  // straight continuation
  if (shape.join == LineJoin::Round) {
    // With both segments at least w/2 long, the two rectangles hold all of the disc but the
    // outer wedge between their end edges: draw that wedge only (same union, far fewer
    // triangles). Otherwise, and for hairpins, the whole disc.
    const double l0 = glm::length(v - prev), l1 = glm::length(next - v);
    if (turn != 0 && l0 >= h && l1 >= h) {
      const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
      const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
      double a0 = std::atan2(out0.y, out0.x), a1 = std::atan2(out1.y, out1.x);
      if (turn < 0) std::swap(a0, a1);  // counter-clockwise from a0 to a1
      if (a1 < a0) a1 += 2.0 * std::numbers::pi;
      std::vector<glm::dvec2> pts{v};
      const std::vector<glm::dvec2> rim = arc(v, h, a0, a1, tolerance);
      pts.insert(pts.end(), rim.begin(), rim.end());
      sink.add(PieceKind::Join, std::move(pts));
    } else {
      sink.disc(PieceKind::Join, v, h, perp(d0));
    }
    return;
  }
  // A hairpin (180°) has a flat bevel and an infinite miter: nothing besides the rectangles.
  if (turn == 0) return;
  // Outer normals: on the right of a left turn, on the left of a right turn.
  const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
  const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
  const glm::dvec2 corner0 = v + h * out0;
  const glm::dvec2 corner1 = v + h * out1;
  // θ the angle between the segments at v. With s = d0 + d1: |s| = 2 sin(θ/2), accurate also
  // for nearly reversed directions (where 1 + cos(turn) would cancel to zero).
  // Miter length h / sin(θ/2) ≤ miterLimit · h  ⇔  miterLimit · sin(θ/2) ≥ 1.
  const glm::dvec2 s = d0 + d1;
  const double sinHalfTheta = 0.5 * std::hypot(s.x, s.y);
  std::vector<glm::dvec2> pts;
  if (shape.join == LineJoin::Miter && shape.miterLimit * sinHalfTheta >= 1.0) {
    // The intersection of the two outer offset lines lies on the outer bisector (out0 + out1,
    // of length |s|) at distance h / sin(θ/2) = 2h / |s| from v.
    const glm::dvec2 miter = v + (2.0 * h / (s.x * s.x + s.y * s.y)) * (out0 + out1);
    if (detail::finite(miter)) pts = {v, corner0, miter, corner1};
  }
  if (pts.empty()) {
    pts = {v, corner0, corner1};
  }
  if (turn < 0) std::reverse(pts.begin() + 1, pts.end());
  sink.add(PieceKind::Join, std::move(pts));
}

}  // namespace

std::vector<Footprint> lineFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                      const std::string& layerName, const LineShape& shape,
                                      const FootprintOptions& options, Diagnostics& diagnostics) {
  std::vector<Footprint> result;
  if (!(std::isfinite(shape.width) && shape.width > 0.0 && shape.width <= kMaxCoordinate)) {
    diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid,
                                         "line width " + std::to_string(shape.width) +
                                             " is not a positive finite number of at most 1e15 m; feature skipped"));
    return result;
  }
  if (options.cells) {
    std::string message;
    if (!detail::validGrid(*options.cells, message)) {
      diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid, message + "; feature skipped"));
      return result;
    }
  }
  const double h = 0.5 * shape.width;
  PieceSink sink(featureIndex, options, result);

  for (std::size_t k = 0; k < feature.lines.size(); ++k) {
    geo::LineString line = feature.lines[k];
    const bool usable = std::all_of(line.begin(), line.end(), [](const glm::dvec2& p) {
      return detail::finite(p) && std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate;
    });
    if (!usable) {
      diagnostics.add(detail::featureError(
          Severity::Error, layerName, feature.fid,
          "line " + std::to_string(k) + " has a NaN, infinite or out-of-range coordinate; line skipped"));
      continue;
    }
    line.erase(std::unique(line.begin(), line.end()), line.end());
    if (line.empty()) continue;
    if (line.size() == 1) {
      const glm::dvec2 p = line[0];
      if (shape.cap == LineCap::Round) {
        sink.disc(PieceKind::Cap, p, h, glm::dvec2(1.0, 0.0));
      } else if (shape.cap == LineCap::Square) {
        sink.add(PieceKind::Cap,
                 {p + glm::dvec2(-h, -h), p + glm::dvec2(h, -h), p + glm::dvec2(h, h), p + glm::dvec2(-h, h)});
      }
      continue;
    }
    const double tolerance = options.chordTolerance;
    addCap(sink, shape, h, line.front(), unit(line[0] - line[1]), glm::length(line[1] - line[0]), tolerance);
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
      const glm::dvec2 a = line[i];
      const glm::dvec2 b = line[i + 1];
      const glm::dvec2 n = h * perp(unit(b - a));
      sink.add(PieceKind::Segment, {a - n, b - n, b + n, a + n});
      if (i + 2 < line.size()) addJoin(sink, shape, h, a, b, line[i + 2], tolerance);
    }
    addCap(sink, shape, h, line.back(), unit(line[line.size() - 1] - line[line.size() - 2]),
           glm::length(line[line.size() - 1] - line[line.size() - 2]), tolerance);
  }
  return result;
}

}  // namespace gis::overlay
