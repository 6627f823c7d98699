// Line footprints: one convex shape per segment rectangle, join and cap (footprints.hpp gives
// the shapes). Lines in metres: the union of a feature's shapes (line_union.cpp), split at the
// cell borders and clipped to the grid's extent, so that every footprint lies in its cell (a
// join or cap of a 5 km wide road is not small) and gets that cell's height bounds; without
// uniteLines every shape is its own piece, split the same way. Lines in pixels: a piece per
// shape, unsplit (their shapes change with the view).
#include <algorithm>
#include <cmath>
#include <exception>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include "footprint_geometry.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay {
namespace {

/// Same bound as for polygons, for coordinates and widths: beyond it, products overflow.
constexpr double kMaxCoordinate = 1e15;

/// Finite and within ±kMaxCoordinate: a point a line may have, before and after widening.
bool inRange(const glm::dvec2& p) {
  return detail::finite(p) && std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate;
}

glm::dvec2 perp(const glm::dvec2& d) { return {-d.y, d.x}; }

glm::dvec2 unit(const glm::dvec2& d) {
  // hypot avoids overflow and underflow for extreme lengths
  const double length = std::hypot(d.x, d.y);
  return {d.x / length, d.y / length};
}

/// A vertex of a line piece: centre + direction · h, h the half width at the centre (the
/// anchor is the centre's height for lines in pixels).
struct Pt {
  glm::dvec2 centre{0.0};
  glm::dvec2 direction{0.0};
  double anchor = 0.0;
  bool operator==(const Pt&) const = default;
};

/// The points of a polygon around one centre: centre + directions[k] · h.
std::vector<Pt> around(const glm::dvec2& centre, double anchor, const std::vector<glm::dvec2>& directions) {
  std::vector<Pt> pts;
  pts.reserve(directions.size());
  for (const glm::dvec2& d : directions) pts.push_back({centre, d, anchor});
  return pts;
}

class PieceSink {
 public:
  /// h: the half width in metres (for lines in pixels, the largest).
  PieceSink(std::uint32_t feature, const FootprintOptions& options, bool scalable, double h,
            std::vector<Footprint>& out)
      : feature_(feature), options_(options), scalable_(scalable), h_(h), out_(out) {}

  /// Adds the convex polygon (counter-clockwise at every width up to h) as one footprint, or
  /// one per cell (metre widths only); when lines are united, keeps it for unite().
  void add(PieceKind kind, std::vector<Pt> shape) {
    ++source_;
    if (scalable_) {
      addScalable(kind, std::move(shape));
      return;
    }
    std::vector<glm::dvec2> pts;
    pts.reserve(shape.size());
    for (const Pt& p : shape) pts.push_back(p.centre + h_ * p.direction);
    detail::dropRepeatedPoints(pts);
    if (pts.size() < 3) return;
    if (uniting()) {
      pending_.push_back(std::move(pts));
      return;
    }
    if (!options_.cells) {
      detail::triangulateConvex(pts, builder_);
      if (!builder_.empty()) push(builder_.finish(feature_, -1, kind));
      return;
    }
    detail::splitIntoCells(detail::makeClipPolygon(pts), *options_.cells,
                           [&](int cell, const std::vector<glm::dvec2>& part) {
                             detail::triangulateConvex(part, builder_);
                             if (!builder_.empty()) push(builder_.finish(feature_, cell, kind));
                           });
  }

  /// Whether the shapes are kept for one union (lines in metres with uniteLines).
  [[nodiscard]] bool uniting() const { return !scalable_ && options_.uniteLines; }

  /// The shapes added since the last call (uniting: those of the current line).
  [[nodiscard]] const std::vector<std::vector<glm::dvec2>>& pending() const { return pending_; }

  /// Keeps (true) or drops the pending shapes.
  void settle(bool keep) {
    if (keep) {
      for (auto& part : pending_) parts_.push_back(std::move(part));
    }
    pending_.clear();
  }

  /// Uniting: the union of every kept shape as one footprint per fine cell (or one without a
  /// grid), each with the index of the cell of `cells` that holds it.
  void unite() {
    if (parts_.empty()) return;
    const std::vector<detail::Triangle> region = detail::unionTriangles(parts_);
    parts_.clear();
    const int k = std::max(1, options_.lineCellDivisions);
    if (!options_.cells || k == 1) {
      detail::emitRegion(region, options_.cells, feature_, PieceKind::Line, 0, out_);
      return;
    }
    const CellGrid& coarse = *options_.cells;
    const CellGrid fine{coarse.origin, coarse.cellSize / k, coarse.columns * k, coarse.rows * k};
    const std::size_t first = out_.size();
    detail::emitRegion(region, fine, feature_, PieceKind::Line, 0, out_);
    for (std::size_t i = first; i < out_.size(); ++i) {
      const int column = out_[i].cell % fine.columns, row = out_[i].cell / fine.columns;
      out_[i].cell = coarse.cellIndex(column / k, row / k);
    }
  }

 private:
  /// One piece, unsplit, with its vertices' centres and directions (footprints.hpp).
  void addScalable(PieceKind kind, std::vector<Pt> shape) {
    shape.erase(std::unique(shape.begin(), shape.end()), shape.end());
    while (shape.size() > 1 && shape.front() == shape.back()) shape.pop_back();
    std::vector<glm::dvec2> pts;
    pts.reserve(shape.size());
    for (const Pt& p : shape) pts.push_back(p.centre + h_ * p.direction);
    if (pts.size() < 3) return;
    detail::triangulateConvex(pts, builder_);
    if (builder_.empty()) return;
    Footprint fp = builder_.finish(feature_, -1, kind);
    fp.centres.reserve(fp.vertices.size());
    fp.directions.reserve(fp.vertices.size());
    for (const glm::dvec2& v : fp.vertices) {
      const auto found = std::find(pts.begin(), pts.end(), v);
      if (found != pts.end()) {
        const Pt& p = shape[static_cast<std::size_t>(found - pts.begin())];
        fp.centres.emplace_back(p.centre, p.anchor);
        fp.directions.push_back(p.direction);
      } else {
        // The fan's inner point (triangulateConvex, all sides with collinear points): the mean
        // of the vertices, exact at every width for the pieces around one centre.
        glm::dvec3 centre(0.0);
        glm::dvec2 direction(0.0);
        for (const Pt& p : shape) {
          centre += glm::dvec3(p.centre, p.anchor);
          direction += p.direction;
        }
        const auto n = static_cast<double>(shape.size());
        fp.centres.push_back(centre / n);
        fp.directions.push_back(direction / n);
      }
    }
    push(std::move(fp));
  }

  void push(Footprint fp) {
    fp.source = source_;
    out_.push_back(std::move(fp));
  }

  std::uint32_t source_ = 0;  ///< shapes added so far (the current one's number)
  std::uint32_t feature_;
  const FootprintOptions& options_;
  bool scalable_;
  double h_;
  std::vector<Footprint>& out_;
  detail::FootprintBuilder builder_;
  std::vector<std::vector<glm::dvec2>> pending_;  ///< uniting: the current line's shapes
  std::vector<std::vector<glm::dvec2>> parts_;    ///< uniting: the feature's shapes so far
};

/// Lines in pixels at most this wide get wedges at joins and half discs at caps (lineFootprints).
constexpr double kWedgeWidthPixels = 2.0;

/// Unit directions to points on a circle from angle a0 to a1 (radians, a1 > a0:
/// counter-clockwise), both ends included, `full` chords per full circle.
std::vector<glm::dvec2> arc(double a0, double a1, int full) {
  const int m = std::max(1, static_cast<int>(std::ceil((a1 - a0) / (2.0 * std::numbers::pi) * full)));
  std::vector<glm::dvec2> directions;
  directions.reserve(static_cast<std::size_t>(m + 1));
  for (int k = 0; k <= m; ++k) {
    const double a = a0 + (a1 - a0) * k / m;
    directions.emplace_back(std::cos(a), std::sin(a));
  }
  return directions;
}

/// Unit directions of the regular polygon of `full` vertices whose first vertex lies in the
/// unit direction `direction`.
std::vector<glm::dvec2> disc(const glm::dvec2& direction, int full) {
  // discPolygon's points are centre + r · (unit vector): with centre 0 and r = 1 exactly those.
  return detail::discPolygon(glm::dvec2(0.0), 1.0, direction, full);
}

/// Geometry of one line: its vertices (repeated points dropped) with their anchor heights.
struct Builder {
  PieceSink& sink;
  const LineShape& shape;
  double h;  ///< half width in metres (the largest, for lines in pixels)
  int full;  ///< chords per full circle of radius h
  /// Lines in pixels: whole discs for round joins and caps. The half widths of a segment's ends
  /// differ, so its trapezoid need not hold the inner part of the disc at either end.
  bool wholeDiscs;

  /// The cap at `end`, the line leaving it in the unit direction `outward`. A round cap whose
  /// end segment is at least w/2 long needs only the outer half disc: the rectangle holds the
  /// other half (same union, half the triangles).
  void cap(const glm::dvec2& end, double anchor, const glm::dvec2& outward, double segmentLength) const {
    const glm::dvec2 n = perp(outward);
    switch (shape.cap) {
      case LineCap::Round:
        if (segmentLength >= h && !wholeDiscs) {
          const double a = std::atan2(outward.y, outward.x);
          sink.add(PieceKind::Cap,
                   around(end, anchor, arc(a - 0.5 * std::numbers::pi, a + 0.5 * std::numbers::pi, full)));
        } else {
          sink.add(PieceKind::Cap, around(end, anchor, disc(n, full)));
        }
        break;
      case LineCap::Square:
        sink.add(PieceKind::Cap, around(end, anchor, {-n, outward - n, outward + n, n}));
        break;
      case LineCap::Flat:
        break;
    }
  }

  /// The join at vertex v between the segments prev → v and v → next.
  void join(const glm::dvec2& prev, const glm::dvec2& v, double anchor, const glm::dvec2& next) const {
    const glm::dvec2 d0 = unit(v - prev);
    const glm::dvec2 d1 = unit(next - v);
    const int turn = detail::orientation(prev, v, next);
    if (turn == 0 && d0.x * d1.x + d0.y * d1.y > 0.0) return;  // straight continuation
    if (shape.join == LineJoin::Round) {
      // With both segments at least w/2 long, the two rectangles hold all of the disc but the
      // outer wedge between their end edges: draw that wedge only (same union, far fewer
      // triangles). Otherwise, and for hairpins, the whole disc.
      const double l0 = glm::length(v - prev), l1 = glm::length(next - v);
      if (turn != 0 && l0 >= h && l1 >= h && !wholeDiscs) {
        const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
        const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
        double a0 = std::atan2(out0.y, out0.x), a1 = std::atan2(out1.y, out1.x);
        if (turn < 0) std::swap(a0, a1);  // counter-clockwise from a0 to a1
        if (a1 < a0) a1 += 2.0 * std::numbers::pi;
        std::vector<glm::dvec2> directions{glm::dvec2(0.0)};
        const std::vector<glm::dvec2> rim = arc(a0, a1, full);
        directions.insert(directions.end(), rim.begin(), rim.end());
        sink.add(PieceKind::Join, around(v, anchor, directions));
      } else {
        sink.add(PieceKind::Join, around(v, anchor, disc(perp(d0), full)));
      }
      return;
    }
    // A hairpin (180°) has a flat bevel and an infinite miter: nothing besides the rectangles.
    if (turn == 0) return;
    // Outer normals: on the right of a left turn, on the left of a right turn.
    const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
    const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
    // θ the angle between the segments at v. With s = d0 + d1: |s| = 2 sin(θ/2), accurate also
    // for nearly reversed directions (where 1 + cos(turn) would cancel to zero).
    // Miter length h / sin(θ/2) ≤ miterLimit · h  ⇔  miterLimit · sin(θ/2) ≥ 1.
    const glm::dvec2 s = d0 + d1;
    const double sinHalfTheta = 0.5 * std::hypot(s.x, s.y);
    // Built by push_back: assigning an initializer list here trips GCC 12's -Warray-bounds at -O3
    // (a false positive in vector::operator=).
    std::vector<glm::dvec2> directions;
    directions.reserve(4);
    directions.push_back(glm::dvec2(0.0));
    directions.push_back(out0);
    if (shape.join == LineJoin::Miter && shape.miterLimit * sinHalfTheta >= 1.0) {
      // The intersection of the two outer offset lines lies on the outer bisector (out0 + out1,
      // of length |s|) at distance h / sin(θ/2) = 2h / |s| from v.
      const glm::dvec2 miter = (2.0 / (s.x * s.x + s.y * s.y)) * (out0 + out1);
      if (detail::finite(miter) && detail::finite(v + h * miter)) directions.push_back(miter);
    }
    directions.push_back(out1);
    if (turn < 0) std::reverse(directions.begin() + 1, directions.end());
    sink.add(PieceKind::Join, around(v, anchor, directions));
  }
};

}  // namespace

PixelScale pixelScaleOf(const glm::dmat4& viewProj, int viewportHeight) {
  // Rows x, y and w of the matrix (glm is column-major: m[column][row]).
  const auto row = [&viewProj](int r) {
    return glm::dvec4(viewProj[0][r], viewProj[1][r], viewProj[2][r], viewProj[3][r]);
  };
  const glm::dvec4 x = row(0), y = row(1), w = row(3);
  PixelScale scale;
  const glm::dmat3 a = glm::transpose(glm::dmat3(glm::dvec3(x), glm::dvec3(y), glm::dvec3(w)));
  if (glm::determinant(a) != 0.0) scale.eye = -(glm::inverse(a) * glm::dvec3(x.w, y.w, w.w));
  // Pixel size at distance d: 2 d / (height · s), s the rate of clip y across the view
  // direction per unit of w (the part of row y orthogonal to row w: a sub-pixel shift of the
  // matrix, which adds a multiple of row w, leaves it alone).
  const glm::dvec3 wDir(w), yDir(y);
  const glm::dvec3 across = yDir - (glm::dot(yDir, wDir) / glm::dot(wDir, wDir)) * wDir;
  const double yScale = glm::length(across) / glm::length(wDir);
  if (viewportHeight > 0 && yScale > 0.0 && std::isfinite(yScale)) {
    scale.metresPerPixel = 2.0 / (static_cast<double>(viewportHeight) * yScale);
  }
  return scale;
}

std::vector<Footprint> lineFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                      const std::string& layerName, const LineShape& shape,
                                      const FootprintOptions& options, Diagnostics& diagnostics) {
  std::vector<Footprint> result;
  if (!(std::isfinite(shape.width) && shape.width > 0.0 && shape.width <= kMaxCoordinate)) {
    std::ostringstream message;
    message << "line width " << shape.width << " m is not a positive finite number of at most 1e15 m; feature skipped";
    diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid, message.str()));
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
  const bool scalable = shape.inPixels();
  PieceSink sink(featureIndex, options, scalable, h, result);
  // Lines in pixels: chords counted on screen, where the radius is widthPixels / 2 at most,
  // and in metres at the least width (where that is wider than widthPixels on screen).
  const int full =
      scalable
          ? std::max(detail::circleSegments(0.5 * shape.widthPixels, options.chordTolerancePixels),
                     shape.minWidth > 0.0 ? detail::circleSegments(0.5 * shape.minWidth, options.chordTolerance) : 0)
          : detail::circleSegments(h, options.chordTolerance);
  // Lines in pixels need whole discs where the width changes fast along a segment. The half
  // width changes by at most k = widthPixels / 2 · metresPerPixel per metre (≤ 0.04 for a pixel
  // under 0.05 of the distance, times 1.5 for slopes up to 48°), so a trapezoid narrowing away
  // from a join lacks at most k² h / 2 of the disc's inner half: 4·10⁻⁴ px for widths up to
  // 2 px, far inside the pixels the reference calls edges. Such lines take the wedges and half
  // discs of lines in metres (a quarter of the triangles on dense lines).
  const bool wholeDiscs = scalable && shape.widthPixels > kWedgeWidthPixels;
  const Builder build{sink, shape, h, full, wholeDiscs};

  for (std::size_t k = 0; k < feature.lines.size(); ++k) {
    const geo::LineString& raw = feature.lines[k];
    if (!std::all_of(raw.begin(), raw.end(), inRange)) {
      diagnostics.add(detail::featureError(
          Severity::Error, layerName, feature.fid,
          "line " + std::to_string(k) + " has a NaN, infinite or out-of-range coordinate; line skipped"));
      continue;
    }
    // Repeated points dropped, each kept point with its anchor height.
    std::vector<glm::dvec2> line;
    std::vector<double> anchor;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (!line.empty() && raw[i] == line.back()) continue;
      line.push_back(raw[i]);
      anchor.push_back(shape.anchorHeight(k, i));
    }
    if (line.empty()) continue;
    // Widened, a line near ±1e15 can reach beyond it (unclipped: without a grid, or a grid out
    // there): such a line is skipped like one with an out-of-range point.
    const std::size_t firstPiece = result.size();
    auto dropIfBeyond = [&] {
      // Uniting with a grid: the union is clipped to the grid (validGrid keeps it in range).
      const bool within =
          sink.uniting()
              ? options.cells ||
                    std::all_of(sink.pending().begin(), sink.pending().end(),
                                [](const auto& part) { return std::all_of(part.begin(), part.end(), inRange); })
              : std::all_of(
                    result.begin() + static_cast<std::ptrdiff_t>(firstPiece), result.end(),
                    [](const Footprint& f) { return std::all_of(f.vertices.begin(), f.vertices.end(), inRange); });
      sink.settle(within);
      if (within) return;
      result.erase(result.begin() + static_cast<std::ptrdiff_t>(firstPiece), result.end());
      diagnostics.add(
          detail::featureError(Severity::Error, layerName, feature.fid,
                               "line " + std::to_string(k) + " reaches beyond ±1e15 m once widened; line skipped"));
    };
    if (line.size() == 1 && options.segmentsOnly) continue;
    if (line.size() == 1) {
      if (shape.cap == LineCap::Round) {
        sink.add(PieceKind::Cap, around(line[0], anchor[0], disc(glm::dvec2(1.0, 0.0), full)));
      } else if (shape.cap == LineCap::Square) {
        sink.add(PieceKind::Cap, around(line[0], anchor[0], {{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}));
      }
      dropIfBeyond();
      continue;
    }
    const std::size_t last = line.size() - 1;
    const bool ends = !options.segmentsOnly;
    if (ends) build.cap(line[0], anchor[0], unit(line[0] - line[1]), glm::length(line[1] - line[0]));
    for (std::size_t i = 0; i < last; ++i) {
      const glm::dvec2 a = line[i];
      const glm::dvec2 b = line[i + 1];
      const glm::dvec2 n = perp(unit(b - a));
      sink.add(PieceKind::Segment,
               {{a, -n, anchor[i]}, {b, -n, anchor[i + 1]}, {b, n, anchor[i + 1]}, {a, n, anchor[i]}});
      if (ends && i + 2 < line.size()) build.join(a, b, anchor[i + 1], line[i + 2]);
    }
    if (ends) {
      build.cap(line[last], anchor[last], unit(line[last] - line[last - 1]), glm::length(line[last] - line[last - 1]));
    }
    dropIfBeyond();
  }
  try {
    sink.unite();
  } catch (const std::exception& e) {
    diagnostics.add(
        detail::featureError(Severity::Error, layerName, feature.fid,
                             std::string("union of the line's shapes failed (") + e.what() + "); feature skipped"));
    result.clear();
  }
  return result;
}

}  // namespace gis::overlay
