// Lines in pixels on the globe (globe_overlay.hpp, docs/globe.md "Lines in pixels"): pieces whose
// width the volume shader sets per frame, as a projected frame's (footprints.hpp, LineShape).
//
// Each vertex of such a piece belongs to a centre, a point of the line at the cap's height; the
// shader moves it by direction · h, h the half width at the centre's anchor (the point raised to
// the anchor ground). The shapes are the shared ones (overlay::lineShapes, as a projected frame's
// lines in pixels) in the tangent plane at each point (globeStations): a band's corners at its
// ends ± the side of the slab the reference tests (nearLine), its half width going linearly from
// one end's to the other's; joins and caps by the line's style (round ones as wedges and half
// discs up to 2 px, as whole discs beyond); at a point added along a geodesic the bands meet on
// the bisector of their sides.
//
// The pieces are built at the class's largest half width H: the bottom lowered by H² / 2R (a
// corner in the tangent plane rises above the ground by that much), the top raised by the sag of
// the longest chord, the ground's bounds taken over the piece's box grown by H at a level coarse
// enough for every tile the piece reaches (the terrain's bounds contract: globe_terrain.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

#include "globe/ellipsoid.hpp"
#include "globe_detail.hpp"
#include "vector_overlay/globe_overlay.hpp"

namespace gis::globe {

namespace {

using detail::PieceVertex;
using detail::TilePieces;

constexpr double kDegree = 3.14159265358979323846 / 180.0;

/// Degrees of latitude and longitude (at the box's highest latitude) that `metres` at least spans.
std::pair<double, double> degreesFor(double metres, const LonLatRect& box) {
  const double dLat = metres / 110000.0;
  const double high = std::max(std::abs(box.south), std::abs(box.north)) + dLat;
  return {high >= 89.9 ? 360.0 : dLat / std::cos(high * kDegree), dLat};
}

/// A vertex of a piece of a line in pixels: its centre (lon/lat), direction and which cap.
struct Corner {
  std::size_t centre = 0;  ///< index into the run's centres
  glm::dvec3 direction{0.0};
};

/// One closed volume: its footprint's corners (counter-clockwise seen from above), fanned.
using Shape = std::vector<Corner>;

class PieceWriter {
 public:
  PieceWriter(TilePieces& out, const GlobeLine& line, const TileKey& key, const GeoGrid& heights, double capHalf)
      : out_(out), line_(line), key_(key), heights_(heights), capHalf_(capHalf) {}

  /// Writes one piece from `shapes` over the run's centres `points` (lon/lat), `normals` and
  /// `anchors` (the anchor heights).
  void write(const std::vector<Shape>& shapes, const std::vector<glm::dvec2>& points,
             const std::vector<glm::dvec3>& normals, const std::vector<double>& anchors, double chord) {
    out_.scaling.resize(out_.vertices.size(), glm::vec4(0.0F));  // the pieces in metres before
    // The box of the centres used, grown by the half width.
    LonLatRect box{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
    for (const Shape& s : shapes) {
      for (const Corner& c : s) {
        const glm::dvec2 p = points[c.centre];
        box.west = std::min(box.west, p.x);
        box.east = std::max(box.east, p.x);
        box.south = std::min(box.south, p.y);
        box.north = std::max(box.north, p.y);
      }
    }
    const double reach = capHalf_ * line_.shapeReach();
    const auto [dLon, dLat] = degreesFor(reach + 1.0, box);
    box = box.expanded(dLon, dLat);
    box.south = std::max(box.south, -90.0);
    box.north = std::min(box.north, 90.0);
    // Coarse enough for every tile the box reaches: the drawn tiles' levels fall by at most one
    // from a tile to its neighbour, so by log2(d / size) + 1 over d beyond the tile.
    const LonLatRect rect = key_.rect();
    const double beyond =
        std::max({rect.west - box.west, box.east - rect.east, rect.south - box.south, box.north - rect.north, 0.0});
    const int drop = beyond > 0.0 ? static_cast<int>(std::ceil(std::log2(beyond / key_.size() + 1.0))) + 1 : 0;
    const auto [ground0, ground1] = groundBounds(heights_, box, std::max(0, key_.level - drop));
    const double lo = ground0 - 1.01 * reach * reach / (2.0 * kMinCurvatureRadius) - 1.0;
    const double hi = ground1 + triangleSag(1.01 * std::max(chord, 2.0 * reach));

    TilePieces::Piece piece;
    piece.group = line_.group;
    piece.lo = lo;
    piece.hi = hi;
    piece.boxLo = glm::dvec3(std::numeric_limits<double>::max());
    piece.boxHi = glm::dvec3(-std::numeric_limits<double>::max());
    // Vertices: per corner, bottom then top; the indices as buildTilePieces writes a piece.
    std::vector<std::array<std::uint32_t, 3>> triangles;  // of corners, counter-clockwise
    std::vector<std::array<std::uint32_t, 2>> boundary;
    const auto first = static_cast<std::uint32_t>(out_.vertices.size());
    std::uint32_t corner = 0;
    for (const Shape& s : shapes) {
      const auto n = static_cast<std::uint32_t>(s.size());
      for (std::uint32_t i = 1; i + 1 < n; ++i) triangles.push_back({corner, corner + i, corner + i + 1});
      for (std::uint32_t i = 0; i < n; ++i) boundary.push_back({corner + i, corner + (i + 1) % n});
      for (const Corner& c : s) {
        const glm::dvec2 p = points[c.centre];
        const glm::dvec3& normal = normals[c.centre];
        for (const double h : {lo, hi}) {
          const glm::dvec3 at = toEcef(p.x, p.y, h);
          for (const double scale : {0.0, capHalf_}) {
            piece.boxLo = glm::min(piece.boxLo, at + c.direction * scale);
            piece.boxHi = glm::max(piece.boxHi, at + c.direction * scale);
          }
          out_.vertices.push_back(PieceVertex{glm::vec4(glm::vec3(at - out_.origin), h == lo ? -1.0F : 1.0F),
                                              glm::vec4(glm::vec3(normal), static_cast<float>(anchors[c.centre] - h))});
          out_.scaling.push_back(glm::vec4(glm::vec3(c.direction), static_cast<float>(line_.halfWidth)));
        }
      }
      corner += n;
    }
    piece.firstIndex = static_cast<std::uint32_t>(out_.indices.size());
    const auto bottom = [&](std::uint32_t c) { return first + 2 * c; };
    for (const auto& t : triangles) out_.indices.insert(out_.indices.end(), {bottom(t[0]), bottom(t[2]), bottom(t[1])});
    piece.bottomCount = static_cast<std::uint32_t>(out_.indices.size()) - piece.firstIndex;
    for (const auto& [i, j] : boundary) {
      const std::uint32_t a = bottom(i), b = bottom(j);
      out_.indices.insert(out_.indices.end(), {a, b, b + 1, a, b + 1, a + 1});
    }
    for (const auto& t : triangles)
      out_.indices.insert(out_.indices.end(), {bottom(t[0]) + 1, bottom(t[1]) + 1, bottom(t[2]) + 1});
    piece.indexCount = static_cast<std::uint32_t>(out_.indices.size()) - piece.firstIndex;
    out_.pieces.push_back(piece);
  }

 private:
  TilePieces& out_;
  const GlobeLine& line_;
  TileKey key_;
  const GeoGrid& heights_;
  double capHalf_;
};

/// The number of sides of a disc of the line seen as small as widthPixels and as large as its
/// width in metres: chords within chordTolerancePixels (0.05 px) and 2 cm of the circle.
/// How closely arcs follow the circle: 0.05 px where the width in pixels holds
/// (chordTolerancePixels), and in metres (where the least width holds) the chord tolerance, or at
/// coarse levels a quarter of the level's, as the lines in metres (lineShapesIn).
struct ArcTolerance {
  double pixels = 0.05;
  double metres = 0.02;
  /// Sides of a disc within both.
  [[nodiscard]] int sides(const GlobeLine& line) const {
    const auto count = [](double tolerance, double radius) {
      if (!(radius > 0.0)) return 8;
      const double t = std::min(tolerance, 0.5 * radius);
      return static_cast<int>(std::ceil(3.14159265358979323846 / std::acos(1.0 - t / radius)));
    };
    return std::clamp(std::max(count(pixels, 0.5 * line.widthPixels), count(metres, line.halfWidth)), 8, 256);
  }
};

/// Lines in pixels at most this wide get wedges at joins and half discs at caps (footprints.hpp:
/// the width changes too slowly along a piece for the disc's inner part to stick out).
constexpr double kWedgeWidthPixels = 2.0;

/// Consecutive pieces of a run drawn as one (their bounds together): fewer draws, little looser.
constexpr std::size_t kBandsPerPiece = 4;

}  // namespace

namespace detail {

TileReach::TileReach(const LonLatRect& rect, const GeoGrid& heights) : rect_(rect) {
  const auto [ground0, ground1] = heights.bounds(rect_);
  middle_ = toEcef(0.5 * (rect_.west + rect_.east), 0.5 * (rect_.south + rect_.north), 0.0);
  top_ = kSemiMajor + std::max({std::abs(ground0), std::abs(ground1), 0.0});
}

double TileReach::farthest(const glm::dvec3& eye, double margin) const {
  // Within the chord from its middle to any point of it (an angle of at most half its sides, plus
  // the margin), and the heights.
  const double angle =
      std::min(0.5 * (rect_.east - rect_.west + rect_.north - rect_.south) * kDegree + margin / kSemiMinor,
               3.14159265358979323846);
  return glm::length(eye - middle_) + 2.0 * top_ * std::sin(0.5 * angle) + top_ - kSemiMinor + 1.0;
}

}  // namespace detail

int lineWidthClass(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                   const overlay::PixelScale& scale) {
  if (!(layer.lineWidthPixels() > 0.0) || !(scale.metresPerPixel > 0.0) || !layer.hasLines()) return 0;
  const detail::TileReach tile(key, heights);
  const auto farthest = [&](double m) { return tile.farthest(scale.eye, m); };
  const double need = layer.lineWidthPixels() * scale.metresPerPixel * farthest(0.0);
  if (!(need > 2.0 * layer.leastLineHalfWidth())) return 0;  // every line is as wide in metres
  int c = std::clamp(static_cast<int>(std::ceil(std::log2(need))) + 8, 1, 60);
  while (c < 60 && lineClassWidth(c) < 2.0 * layer.widestLineHalfWidth() &&
         layer.lineWidthPixels() * scale.metresPerPixel * farthest(0.5 * lineClassWidth(c)) > lineClassWidth(c))
    ++c;
  return c;
}

namespace detail {

void addScalableLines(TilePieces& out, const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                      int widthClass) {
  if (widthClass <= 0) return;
  const GeoGrid* anchor = layer.anchorGround();
  if (!layer.hasLines()) return;
  // The lines near the tile at the class's width, read and prepared as asked for.
  const double classReach = 0.5 * lineClassWidth(widthClass) * layer.lineShapeReach();
  for (const std::uint32_t j : layer.linesNear(key, classReach)) {
    const GlobeLayer::TileLine tileLine = layer.lineAt(j, key.level);
    if (!tileLine.line) continue;
    const GlobeLine& line = *tileLine.line;
    if (!GlobeLayer::scalesLine(line, widthClass)) continue;
    const double capHalf = std::min(0.5 * lineClassWidth(widthClass), line.maxHalfWidth);
    out.maxHalfWidth = std::max(out.maxHalfWidth, capHalf);
    const std::vector<glm::dvec2>& all = *tileLine.points;
    const bool generalised = tileLine.generalised;
    ArcTolerance tolerance;
    if (generalised) tolerance.metres = std::max(tolerance.metres, 0.25 * GlobeLayer::lineTolerance(line, key.level));
    const overlay::LineShapeRules rules =
        globeShapeRules(line, capHalf, tolerance.sides(line), line.widthPixels > kWedgeWidthPixels);
    PieceWriter writer(out, line, key, heights, capHalf);
    for (const auto& [first, last] : GlobeLayer::lineRunsIn(tileLine, key, capHalf * line.shapeReach())) {
      const GlobeStations st = globeStations(all, first, last, generalised ? std::vector<char>{} : line.given);
      const std::size_t n = st.stations.size();
      std::vector<glm::dvec2> points(n);
      std::vector<double> anchors(n);
      for (std::size_t s = 0; s < n; ++s) {
        points[s] = all[first + st.point[s]];
        // As the reference keeps them (GlobeLine::anchors).
        anchors[s] = anchor != nullptr
                         ? static_cast<double>(static_cast<float>(anchor->heightAt(points[s].x, points[s].y)))
                         : 0.0;
      }
      std::vector<Shape> shapes;
      std::size_t bands = 0;
      double longest = 0.0;
      overlay::lineShapes(st.stations, rules, [&](overlay::PieceKind kind, std::vector<overlay::ShapeCorner> corners) {
        if (corners.empty()) return;
        if (kind != overlay::PieceKind::Segment && st.pole[corners[0].station] != 0) return;
        if (kind == overlay::PieceKind::Segment) {
          if (bands == kBandsPerPiece) {
            writer.write(shapes, points, st.normal, anchors, longest);
            shapes.clear();
            bands = 0;
            longest = 0.0;
          }
          ++bands;
          longest = std::max(longest, st.stations[corners[0].station].outLength);
        }
        Shape shape;
        shape.reserve(corners.size());
        for (const overlay::ShapeCorner& c : corners) shape.push_back({c.station, st.direction(c)});
        shapes.push_back(std::move(shape));
      });
      if (!shapes.empty()) writer.write(shapes, points, st.normal, anchors, longest);
    }
  }
}

}  // namespace detail

}  // namespace gis::globe
