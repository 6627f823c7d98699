#pragma once
// Internals shared by the globe overlay's sources.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "globe/ellipsoid.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/line_shapes.hpp"

namespace gis::globe::detail {

inline bool isPole(double latDeg) { return std::abs(latDeg) >= 90.0; }

/// A line's band (direction u, slab normal m) ends at each of its points in the vertical plane
/// (holding the normal n there) through its side there: the plane a join's or cap's edge at the
/// point lies in (pointShape's bandSide). Its normal, pointing along the band (not unit).
inline glm::dvec3 bandEndNormal(const glm::dvec3& u, const glm::dvec3& m, const glm::dvec3& n) {
  const glm::dvec3 side = glm::normalize(m - n * glm::dot(n, m));
  return u - side * glm::dot(side, u) - n * glm::dot(n, u);
}

/// How far from an eye the ground of a tile (within its heights) grown by a margin can be: what
/// lines in pixels take their widths from there (lineWidthClass, and the lookup's reach class).
class TileReach {
 public:
  TileReach(const TileKey& key, const GeoGrid& heights) : TileReach(key.rect(), heights) {}
  /// Any box of longitude and latitude (unwrapped), within the grid's heights over it.
  TileReach(const LonLatRect& rect, const GeoGrid& heights);
  /// The farthest point of the tile grown by `margin` metres from `eye`, or farther.
  [[nodiscard]] double farthest(const glm::dvec3& eye, double margin) const;

 private:
  LonLatRect rect_;
  glm::dvec3 middle_{0.0};
  double top_ = 0.0;
};
/// d in (−180, 180].
double wrap180(double d);

/// How far (degrees of longitude, latitude) `metres` and `extraDegrees` of latitude reach around
/// `box`: the latitude by metres / 1.1e5 plus the extra, the longitude by that over the cosine of
/// the highest latitude it reaches (to 89°), at most 360°.
inline glm::dvec2 degreesAround(const LonLatRect& box, double metres, double extraDegrees = 0.0) {
  const double dLat = metres / 1.1e5 + extraDegrees;
  const double high = std::min(89.0, std::max(std::abs(box.south), std::abs(box.north)) + dLat);
  return {std::min(360.0, dLat / std::cos(high * 3.14159265358979323846 / 180.0)), dLat};
}

/// The plane an edge is drawn in: through a (its first end on the ellipsoid), holding the mean
/// normal n of its ends; m = n × (b − a) points north of an eastward edge.
struct EdgePlane {
  glm::dvec3 a{0.0}, n{0.0, 0.0, 1.0}, m{0.0};
};
EdgePlane edgePlane(const glm::dvec2& p, const glm::dvec2& q);

struct IndexedEdge {
  double lon0 = 0.0, lon1 = 0.0;  ///< [lon0, lon1): the meridians it crosses
  bool eastward = true;
  int pole = 0;  ///< +1 / −1: along the north / south pole
  EdgePlane plane;
};

/// A polygon's edges that cross meridians, in buckets of longitude.
struct PolygonIndex {
  double west = 0.0, bucketWidth = 1.0;
  std::vector<IndexedEdge> edges;
  std::vector<std::vector<std::uint32_t>> buckets;
  [[nodiscard]] std::size_t bucketOf(double lon) const {
    const double f = std::floor((lon - west) / bucketWidth);
    return static_cast<std::size_t>(std::clamp(f, 0.0, static_cast<double>(buckets.size() - 1)));
  }
};
std::shared_ptr<const PolygonIndex> buildIndex(const GlobePolygon& polygon);
/// Layers built so far in this process (GlobeLayer::serial).
extern std::atomic<std::uint64_t> layerBuilds;

/// Whether a point (ECEF, and its lon/lat) is within the line's half width of it (GlobeLayer::contains),
/// a line in pixels seen with `scale`.
bool nearLine(const GlobeLayer& layer, const GlobeLine& line, const glm::dvec3& point, double lonDeg, double latDeg,
              const overlay::PixelScale& scale);
/// A run of a line as the shared shape rules see it (overlay::lineShapes, docs/frames.md): each
/// station a point of the run, its plane the tangent plane there (basis e1, e2 with e1 × e2 the
/// normal), its pieces' directions those of the slabs the reference tests (nearLine: the plane
/// through the chord and the ends' mean normal). Points at the same place count once.
struct GlobeStations {
  std::vector<overlay::LineStation> stations;
  std::vector<std::size_t> point;  ///< per station: its point's index in the run
  std::vector<glm::dvec3> centre;  ///< per station: the point on the ellipsoid (ECEF)
  std::vector<glm::dvec3> normal;  ///< per station: the ellipsoid's normal there
  std::vector<glm::dvec3> e1, e2;  ///< per station: its plane's basis
  std::vector<char> pole;          ///< per station: at a pole (no join or cap: the pieces meet there)
  /// A corner's direction (ECEF, in the tangent plane at its station, in half widths).
  [[nodiscard]] glm::dvec3 direction(const overlay::ShapeCorner& c) const {
    return e1[c.station] * c.direction.x + e2[c.station] * c.direction.y;
  }
};
/// The stations of points[first..last] of a line whose points are `points` (unwrapped lon/lat):
/// a point is given where `given` says (all of them when it is empty; stations not given meet
/// smoothly: overlay::LineStation::given); the points just outside the run, when the line has
/// them, give its end stations their joins (the run is cut out of the line there).
GlobeStations globeStations(const std::vector<glm::dvec2>& points, std::size_t first, std::size_t last,
                            const std::vector<char>& given);
/// The shape rules of a line on the globe: its join, cap and miter limit, arcs of `chords` per
/// circle (rounded up to a multiple of 4), and round joins and caps as outer wedges and half discs
/// whatever the pieces' lengths (wedgeLength 0): a point within the half width of the line is
/// within it of its nearest point on the line, inside a piece (in that piece's band) or at a point
/// (in the outer wedge there, or behind an end in the half disc), so bands, wedges and half discs
/// cover what the discs do, though a band alone need not hold its join's inner half. A run's
/// pieces all reach its tile (lineRunsIn), so the nearest point of a point in the tile is in the
/// run. Lines in pixels change width along a band by far less than a pixel per pixel, which moves
/// this by a thousandth of a pixel (footprints.hpp). The projected frame keeps its rule (wedges
/// only next to pieces at least a half width long), whose frames are pinned bit for bit.
overlay::LineShapeRules globeShapeRules(const GlobeLine& line, double halfWidth, int chords, bool wholeDiscs);

/// What a line adds at its point k (of `points`, unwrapped lon/lat) besides its bands:
/// footprints.hpp's join (at a point the source gave, `given`; a bevel at a point added along a
/// geodesic) or cap (at an end), in the tangent plane there. Nothing, a disc of the half width,
/// or a convex polygon whose corners are the point plus the half width times `directions`
/// (counter-clockwise about the normal; a zero direction is the point itself); `border` marks
/// the polygon's edges i → i + 1 that bound the line (not the band's end it rests on). A flat
/// cap is None with the band's end as its one border.
struct PointShape {
  enum class Kind { None, Disc, Polygon } kind = Kind::None;
  std::vector<glm::dvec3> directions;
  std::vector<char> border;
  /// How far it reaches from its point, in half widths: 1 for a disc, 0 for none.
  double reach = 0.0;
};
PointShape pointShape(const GlobeLine& line, const std::vector<glm::dvec2>& points, std::size_t k, bool given);
/// A grid of about `n` cells over `width` × `height` degrees, as square in degrees as they allow
/// (the reference's buckets of a line's pieces and of a layer's lines).
struct GridShape {
  std::size_t columns = 1, rows = 1;
  double cellWidth = 1.0, cellHeight = 1.0;
};
inline GridShape gridShape(std::size_t n, double width, double height) {
  width = std::max(width, 1e-9);
  height = std::max(height, 1e-9);
  GridShape g;
  g.columns =
      std::clamp<std::size_t>(static_cast<std::size_t>(std::lround(std::sqrt(static_cast<double>(n) * width / height))),
                              1, std::max<std::size_t>(n, 1));
  g.rows = std::max<std::size_t>(1, n / g.columns);
  g.cellWidth = width / static_cast<double>(g.columns);
  g.cellHeight = height / static_cast<double>(g.rows);
  return g;
}
/// The cell of `count` cells of `size` from `from` that `at` falls in, clamped to them.
inline std::size_t cellIndex(double at, double from, double size, std::size_t count) {
  return static_cast<std::size_t>(std::clamp(std::floor((at - from) / size), 0.0, static_cast<double>(count - 1)));
}

/// What reachBeyond reads of a line, or the bound over a layer's lines (LineGrid::widths): widths
/// in pixels, the largest and least half widths, how far its shapes reach in half widths.
struct LineReach {
  double widthPixels = 0.0, maxHalfWidth = 0.0, halfWidth = 0.0, reach = 1.0;
};

/// Boxes (unwrapped lon/lat) in a grid over their union, for the boxes meeting a rectangle
/// (GlobeLayer::areasIn, linesNear): each cell holds the boxes meeting it; a box meeting more
/// than a quarter of the cells is in `everywhere` instead; an empty box (west > east) in none.
struct BoxGrid {
  LonLatRect box{0.0, 0.0, -1.0, -1.0};
  GridShape shape;
  std::vector<std::vector<std::uint32_t>> cells;
  std::vector<std::uint32_t> everywhere;
  static BoxGrid of(const std::vector<LonLatRect>& boxes);
  /// The boxes that may meet `rect` or `rect` moved 360° east or west (a superset: test them),
  /// each once, in increasing order.
  [[nodiscard]] std::vector<std::uint32_t> meeting(const LonLatRect& rect) const;
};

/// A layer's lines by their boxes (GlobeLine::box), for the reference (a line without buckets in
/// no cell).
struct LineGrid : BoxGrid {
  /// The most any line may reach beyond its box for a scale (reachBeyond's bound over them).
  LineReach widths;
  static LineGrid of(const std::vector<GlobeLine>& lines);
  /// Calls visit(line index) for every line whose box widened by `extra` metres may hold the
  /// point (a line may be visited more than once); stops when visit returns true, and returns
  /// whether it did.
  template <typename Visit>
  bool visit(double lonDeg, double latDeg, double extra, Visit&& visit) const;
};

/// What tiles asked for lately (GlobeLayer's prepared areas and lines, the lines' generalised
/// centrelines), by key, the least recently asked for leaving first beyond a byte bound.
/// Thread-safe.
template <typename Value>
class RecentlyUsed {
 public:
  explicit RecentlyUsed(std::size_t bytes) : budget_(bytes) {}
  /// The value kept for `key` (now the most recent), or null.
  std::shared_ptr<const Value> find(std::uint64_t key) {
    const std::lock_guard<std::mutex> lock(mutex_);
    const auto found = byKey_.find(key);
    if (found == byKey_.end()) return nullptr;
    recent_.splice(recent_.begin(), recent_, found->second.at);
    return found->second.value;
  }
  /// Keeps `value` (`bytes` large) for `key` and returns it, or the value another thread kept
  /// for it meanwhile.
  std::shared_ptr<const Value> keep(std::uint64_t key, std::shared_ptr<const Value> value, std::size_t bytes) {
    const std::lock_guard<std::mutex> lock(mutex_);
    const auto [at, made] = byKey_.try_emplace(key);
    if (!made) return at->second.value;
    recent_.push_front(key);
    at->second = {std::move(value), bytes, recent_.begin()};
    bytes_ += bytes;
    while (bytes_ > budget_ && recent_.size() > 1) {
      const auto last = byKey_.find(recent_.back());
      bytes_ -= last->second.bytes;
      byKey_.erase(last);
      recent_.pop_back();
    }
    return at->second.value;
  }

 private:
  struct Entry {
    std::shared_ptr<const Value> value;
    std::size_t bytes = 0;
    std::list<std::uint64_t>::iterator at;
  };
  std::size_t budget_;
  std::mutex mutex_;
  std::list<std::uint64_t> recent_;  ///< most recent first
  std::unordered_map<std::uint64_t, Entry> byKey_;
  std::size_t bytes_ = 0;
};

/// GlobeLayer::prepared_: the areas, lines and centrelines its tiles asked for lately.
struct Prepared {
  RecentlyUsed<GlobePolygon> areas{std::size_t{64} << 20};
  RecentlyUsed<GlobeLine> lines{std::size_t{64} << 20};
  /// Keyed line × (kMaxLevel + 1) + level.
  RecentlyUsed<std::vector<glm::dvec2>> centres{std::size_t{32} << 20};
};

/// A line's shapes at its points (GlobeLine::joins).
struct LineJoins {
  std::vector<PointShape> at;
};
/// Whether a point (ECEF) is in the shape around `centre` (on the ellipsoid, with its normal),
/// measured across the normal (the walls are vertical).
bool inPointShape(const PointShape& shape, const glm::dvec3& centre, const glm::dvec3& normal, double halfWidth,
                  const glm::dvec3& point);

/// A vertex of a piece as the builder makes it: its position relative to its tile's origin
/// (TilePieces::origin) and its side, and the surface normal the caps are padded along.
struct PieceVertex {
  glm::vec4 position{0.0F};  ///< x, y, z − TilePieces::origin (ECEF metres); w: −1 bottom, +1 top, 0 none
  glm::vec4 normal{0.0F};    ///< w: a line in pixels' anchor lies this far along it
};
static_assert(sizeof(PieceVertex) == 32);

/// The pieces of one layer over one tile as the builder makes them (buildTilePieces makes them a
/// LayerGeometry of world pieces).
struct TilePieces {
  struct Piece {
    std::uint32_t firstIndex = 0;
    std::uint32_t bottomCount = 0;      ///< bottom cap's indices, first
    std::uint32_t indexCount = 0;       ///< all: bottom cap, walls, top cap
    glm::dvec3 boxLo{0.0}, boxHi{0.0};  ///< ECEF, unpadded
    double lo = 0.0, hi = 0.0;          ///< heights of its caps
    double ground = 0.0;                ///< the highest ground it holds (hi less its caps' sag)
    std::uint32_t boxFirstIndex = 0;    ///< TilePieces::paper: its box's 36 indices
    std::uint32_t group = 0;            ///< its polygon's colour (its vertices' colour when drawn)
  };
  glm::dvec3 origin{0.0};  ///< ECEF: the vertices' positions are relative to it (the tile's middle)
  std::vector<PieceVertex> vertices;
  /// Lines in pixels, per vertex when any piece is one: direction (ECEF) and least half width
  /// (LayerGeometry::WorldLines); the pieces are built at maxHalfWidth.
  std::vector<glm::vec4> scaling;
  double maxHalfWidth = 0.0;
  std::vector<std::uint32_t> indices;
  std::vector<Piece> pieces;
  bool paper = false;  ///< the seed paper's construction: each piece with its box
};

/// Appends to `out` the pieces of the layer's lines that width class `widthClass` draws in
/// pixels over tile `key` (globe_pixel_lines.cpp).
void addScalableLines(TilePieces& out, const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                      int widthClass);
/// How much further than its least half width a line in pixels may reach a point seen with `scale`.
double reachBeyond(const LineReach& line, const overlay::PixelScale& scale, const glm::dvec3& point);
inline double reachBeyond(const GlobeLine& line, const overlay::PixelScale& scale, const glm::dvec3& point) {
  return reachBeyond(LineReach{line.widthPixels, line.maxHalfWidth, line.halfWidth, line.reach}, scale, point);
}

template <typename Visit>
bool LineGrid::visit(double lonDeg, double latDeg, double extra, Visit&& visit) const {
  for (const std::uint32_t j : everywhere) {
    if (visit(j)) return true;
  }
  if (cells.empty()) return false;
  const double dLat = extra / 110000.0;
  if (latDeg < box.south - dLat || latDeg > box.north + dLat) return false;
  const double high = std::abs(latDeg) + dLat;
  const double dLon = high >= 89.9 ? 360.0 : dLat / std::cos(high * 3.14159265358979323846 / 180.0);
  const std::size_t r0 = cellIndex(latDeg - dLat, box.south, shape.cellHeight, shape.rows),
                    r1 = cellIndex(latDeg + dLat, box.south, shape.cellHeight, shape.rows);
  // The point's longitude in every turn the boxes span (they are unwrapped).
  for (double lon = lonDeg - 360.0 * std::ceil((lonDeg - box.west + dLon) / 360.0); lon <= box.east + dLon;
       lon += 360.0) {
    if (lon + dLon < box.west) continue;
    const std::size_t c0 = cellIndex(lon - dLon, box.west, shape.cellWidth, shape.columns),
                      c1 = cellIndex(lon + dLon, box.west, shape.cellWidth, shape.columns);
    for (std::size_t r = r0; r <= r1; ++r) {
      for (std::size_t c = c0; c <= c1; ++c) {
        for (const std::uint32_t j : cells[r * shape.columns + c]) {
          if (visit(j)) return true;
        }
      }
    }
  }
  return false;
}

}  // namespace gis::globe::detail
