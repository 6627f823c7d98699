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
#include "vector_overlay/line_shapes.hpp"

namespace gis::overlay {
namespace {

/// Same bound as for polygons, for coordinates and widths: beyond it, products overflow.
constexpr double kMaxCoordinate = 1e15;

/// Finite and within ±kMaxCoordinate: a point a line may have, before and after widening.
bool inRange(const glm::dvec2& p) {
  return detail::finite(p) && std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate;
}

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
  LineShapeRules rules;
  rules.join = shape.join;
  rules.cap = shape.cap;
  rules.miterLimit = shape.miterLimit;
  rules.wedgeLength = h;
  rules.halfWidth = h;
  rules.chords = full;
  rules.wholeDiscs = wholeDiscs;
  rules.ends = !options.segmentsOnly;
  std::vector<LineStation> stations;

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
    // The stations in the plane: each piece's direction at both its ends, the turns exact.
    stations.assign(line.size(), LineStation{});
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
      const glm::dvec2 d = unit(line[i + 1] - line[i]);
      const double length = glm::length(line[i + 1] - line[i]);
      stations[i].out = d;
      stations[i].outLength = length;
      stations[i + 1].in = d;
      stations[i + 1].inLength = length;
      if (i > 0) stations[i].turn = detail::orientation(line[i - 1], line[i], line[i + 1]);
    }
    lineShapes(stations, rules, [&](PieceKind kind, std::vector<ShapeCorner> corners) {
      std::vector<Pt> pts;
      pts.reserve(corners.size());
      for (const ShapeCorner& c : corners) pts.push_back({line[c.station], c.direction, anchor[c.station]});
      sink.add(kind, std::move(pts));
    });
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
