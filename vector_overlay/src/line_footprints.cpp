// Line footprints: one convex piece per segment rectangle, join and cap (footprints.hpp gives
// the shapes). With a cell grid every piece — segments, joins and caps alike — is split at the
// cell borders and clipped to the grid's extent, so that every footprint lies in its cell (a
// join or cap of a 5 km wide road is not small) and gets that cell's height bounds.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

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

/// The cap at `end`, the line leaving it in the unit direction `outward`.
void addCap(PieceSink& sink, const LineShape& shape, double h, const glm::dvec2& end, const glm::dvec2& outward) {
  const glm::dvec2 n = perp(outward);
  switch (shape.cap) {
    case LineCap::Round:
      sink.disc(PieceKind::Cap, end, h, n);
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
             const glm::dvec2& next) {
  const glm::dvec2 d0 = unit(v - prev);
  const glm::dvec2 d1 = unit(next - v);
  const int turn = detail::orientation(prev, v, next);
  if (turn == 0 && d0.x * d1.x + d0.y * d1.y > 0.0) return;  // straight continuation
  if (shape.join == LineJoin::Round) {
    sink.disc(PieceKind::Join, v, h, perp(d0));
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
    addCap(sink, shape, h, line.front(), unit(line[0] - line[1]));
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
      const glm::dvec2 a = line[i];
      const glm::dvec2 b = line[i + 1];
      const glm::dvec2 n = h * perp(unit(b - a));
      sink.add(PieceKind::Segment, {a - n, b - n, b + n, a + n});
      if (i + 2 < line.size()) addJoin(sink, shape, h, a, b, line[i + 2]);
    }
    addCap(sink, shape, h, line.back(), unit(line[line.size() - 1] - line[line.size() - 2]));
  }
  return result;
}

}  // namespace gis::overlay
