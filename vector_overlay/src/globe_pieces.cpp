// The pieces of a globe layer over one tile (globe_overlay.hpp): its polygons clipped to the
// tile's cells in longitude and latitude, each cell's part made a footprint by the shared builder
// in the cell's gnomonic plane, and extruded along the normals in the shared piece layout.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>
#include <utility>

#include "globe_detail.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/validation.hpp"

namespace gis::globe {

namespace {

using Pt = glm::dvec2;
using Ring = std::vector<Pt>;
using detail::PieceVertex;
using detail::TilePieces;

/// Cells a side a tile's pieces are cut into, and the spacing (in posts) of the points added
/// inside caps (every post on levels 0–3, whose posts are far apart).
constexpr int kCellsPerSide = 2;
constexpr int kCapPointStep = 4;
/// The point of edge p → q's plane on the ellipsoid at chord parameter t (longitude unwrapped
/// near p's).
Pt tracePoint(const Pt& p, const Pt& q, const detail::EdgePlane& e, const glm::dvec3& b, double t) {
  glm::dvec3 f = e.a + (b - e.a) * t;
  Geodetic g = toGeodetic(f);
  for (int k = 0; k < 3; ++k) {
    f -= e.n * g.h;  // stay in the plane: move along its normal n, which it holds
    g = toGeodetic(f);
  }
  const double guess = p.x + (q.x - p.x) * t;
  return {g.lon + 360.0 * std::round((guess - g.lon) / 360.0), g.lat};
}

/// Where edge p → q meets the line coordinate[axis] = c (p and q on either side of it).
Pt crossing(const Pt& p, const Pt& q, int axis, double c) {
  if (p.y == q.y) {
    // Along a pole, or a run along a clip line (a parallel): linear in longitude. (A polygon's
    // own edges reach here only on the equator, whose geodesic it is.)
    return axis == 0 ? Pt(c, p.y) : p;
  }
  const detail::EdgePlane e = detail::edgePlane(p, q);
  const glm::dvec3 b = toEcef(q.x, q.y, 0.0);
  double t0 = 0.0, t1 = 1.0;
  const bool rising = q[axis] > p[axis];
  Pt at = p;
  for (int k = 0; k < 60 && t1 - t0 > 1e-15; ++k) {
    const double t = 0.5 * (t0 + t1);
    at = tracePoint(p, q, e, b, t);
    if ((at[axis] < c) == rising) {
      t0 = t;
    } else {
      t1 = t;
    }
  }
  at[axis] = c;
  if (axis == 1 && p.x == q.x) at.x = p.x;  // along a meridian
  return at;
}

/// Sutherland–Hodgman against one side of an axis-parallel line: keeps coordinate[axis] ≥ c
/// (above) or ≤ c.
Ring clipSide(const Ring& in, int axis, double c, bool above) {
  Ring out;
  if (in.empty()) return out;
  const auto inside = [&](const Pt& p) { return above ? p[axis] >= c : p[axis] <= c; };
  Pt s = in.back();
  for (const Pt& e : in) {
    if (inside(e)) {
      if (!inside(s)) out.push_back(crossing(s, e, axis, c));
      out.push_back(e);
    } else if (inside(s)) {
      out.push_back(crossing(s, e, axis, c));
    }
    s = e;
  }
  return out;
}

Ring clipRect(const Ring& in, const LonLatRect& r) {
  Ring out = clipSide(in, 0, r.west, true);
  out = clipSide(out, 0, r.east, false);
  out = clipSide(out, 1, r.south, true);
  out = clipSide(out, 1, r.north, false);
  return out;
}

bool overlaps(const LonLatRect& a, const LonLatRect& b) {
  return a.west <= b.east && b.west <= a.east && a.south <= b.north && b.south <= a.north;
}

/// How far (degrees of latitude) the wall of a chord one post long on parallel `lat` strays from
/// the parallel.
double parallelStray(double lat, double postStep) {
  if (detail::isPole(lat) || std::abs(lat) > 90.0) return 0.0;
  const Pt p(0.0, lat), q(postStep, lat);
  const detail::EdgePlane e = detail::edgePlane(p, q);
  const Pt mid = tracePoint(p, q, e, toEcef(q.x, q.y, 0.0), 0.5);
  return std::abs(mid.y - lat);
}

/// The segments of rings with even-odd multiplicity: segments on one of the cell's four lines
/// (runs along the clip boundary, which Sutherland–Hodgman may lay over each other) are cut at
/// every end on that line and kept where an odd number covers them; others are kept unless they
/// come in pairs. Done in longitude and latitude, where such runs are exactly on one line: in
/// the gnomonic plane their points are collinear only up to rounding, so the shared builder
/// would see them cross.
std::vector<std::pair<Pt, Pt>> oddSegments(const std::vector<Ring>& rings, const LonLatRect& cell) {
  std::vector<std::pair<Pt, Pt>> out;
  // lines: 0 west, 1 east (constant lon), 2 south, 3 north (constant lat)
  std::array<std::vector<std::pair<double, double>>, 4> onLine;
  const std::array<double, 4> value{cell.west, cell.east, cell.south, cell.north};
  std::map<std::pair<std::pair<double, double>, std::pair<double, double>>, int> others;
  for (const Ring& ring : rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) {
      Pt a = ring[i], b = ring[(i + 1) % ring.size()];
      if (a == b) continue;
      bool placed = false;
      for (int l = 0; l < 4 && !placed; ++l) {
        const int axis = l < 2 ? 0 : 1;
        if (a[axis] == value[static_cast<std::size_t>(l)] && b[axis] == value[static_cast<std::size_t>(l)]) {
          onLine[static_cast<std::size_t>(l)].emplace_back(std::min(a[1 - axis], b[1 - axis]),
                                                           std::max(a[1 - axis], b[1 - axis]));
          placed = true;
        }
      }
      if (placed) continue;
      if (std::make_pair(b.x, b.y) < std::make_pair(a.x, a.y)) std::swap(a, b);
      others[{{a.x, a.y}, {b.x, b.y}}] ^= 1;
    }
  }
  for (const auto& [seg, odd] : others) {
    if (odd != 0) out.emplace_back(Pt(seg.first.first, seg.first.second), Pt(seg.second.first, seg.second.second));
  }
  for (std::size_t l = 0; l < 4; ++l) {
    const int axis = l < 2 ? 0 : 1;
    std::vector<double> cuts;
    for (const auto& [s0, s1] : onLine[l]) {
      cuts.push_back(s0);
      cuts.push_back(s1);
    }
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      const double mid = 0.5 * (cuts[k] + cuts[k + 1]);
      int count = 0;
      for (const auto& [s0, s1] : onLine[l]) count += (s0 < mid && mid < s1) ? 1 : 0;
      if ((count & 1) == 0) continue;
      Pt a, b;
      a[axis] = b[axis] = value[l];
      a[1 - axis] = cuts[k];
      b[1 - axis] = cuts[k + 1];
      out.emplace_back(a, b);
    }
  }
  return out;
}

/// Whether segment a → b runs along the cell's south or north line (a parallel, not a pole).
bool onCellParallel(const Pt& a, const Pt& b, const LonLatRect& cell) {
  return a.y == b.y && (a.y == cell.south || a.y == cell.north) && !detail::isPole(a.y);
}

/// The longitudes of the tile grid's posts strictly between lo and hi, increasing.
std::vector<double> postsBetween(double lo, double hi, double postStep) {
  std::vector<double> xs;
  for (double x = (std::floor((lo + 180.0) / postStep) + 1.0) * postStep - 180.0; x < hi; x += postStep) {
    if (x > lo && (xs.empty() || x > xs.back())) xs.push_back(x);
  }
  return xs;
}

/// Points along segments on the cell's south and north lines every post of the tile's grid:
/// their walls (chords) then stray from the parallel by parallelStray at most.
std::vector<std::pair<Pt, Pt>> splitParallels(const std::vector<std::pair<Pt, Pt>>& segments, const LonLatRect& cell,
                                              double postStep) {
  std::vector<std::pair<Pt, Pt>> out;
  for (const auto& [a, b] : segments) {
    if (!onCellParallel(a, b, cell)) {
      out.emplace_back(a, b);
      continue;
    }
    const double lo = std::min(a.x, b.x), hi = std::max(a.x, b.x);
    double prev = lo;
    for (const double x : postsBetween(lo, hi, postStep)) {
      out.emplace_back(Pt(prev, a.y), Pt(x, a.y));
      prev = x;
    }
    out.emplace_back(Pt(prev, a.y), Pt(hi, a.y));
  }
  return out;
}

/// A ring with the points splitParallels adds on the cell's lines, in the ring's order.
Ring withParallelPosts(const Ring& ring, const LonLatRect& cell, double postStep) {
  Ring out;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const Pt& a = ring[i];
    const Pt& b = ring[(i + 1) % ring.size()];
    out.push_back(a);
    if (a == b || !onCellParallel(a, b, cell)) continue;
    std::vector<double> xs = postsBetween(std::min(a.x, b.x), std::max(a.x, b.x), postStep);
    if (b.x < a.x) std::reverse(xs.begin(), xs.end());
    for (const double x : xs) out.emplace_back(x, a.y);
  }
  return out;
}

/// A cell's gnomonic projection (the central one from the earth's centre onto the plane at the
/// cell's middle): the plane the shared builder triangulates the cell's caps in
/// (overlay::evenOddFootprint, docs/frames.md). There a straight line is the image of every
/// chord, so a cap's flat triangles, seen from the centre, tile the cell without folding (in
/// longitude and latitude, long thin triangles would fold over each other).
class Gnomonic {
 public:
  explicit Gnomonic(const LonLatRect& cell)
      : midLon_(0.5 * (cell.west + cell.east)),
        axis_(glm::normalize(toEcef(midLon_, 0.5 * (cell.south + cell.north), 0.0))) {
    const glm::dmat3 enu = enuBasis(midLon_, 0.5 * (cell.south + cell.north));
    e1_ = glm::normalize(enu[0] - glm::dot(enu[0], axis_) * axis_);
    e2_ = glm::cross(axis_, e1_);
  }
  [[nodiscard]] glm::dvec2 project(const Pt& lonLat) const {
    const glm::dvec3 p = toEcef(lonLat.x, lonLat.y, 0.0);
    const glm::dvec3 d = p / glm::dot(p, axis_);
    return {glm::dot(d, e1_), glm::dot(d, e2_)};
  }
  [[nodiscard]] Pt unproject(const glm::dvec2& q) const {
    const glm::dvec3 d = axis_ + e1_ * q.x + e2_ * q.y;
    const double t =
        1.0 / std::sqrt((d.x * d.x + d.y * d.y) / (kSemiMajor * kSemiMajor) + d.z * d.z / (kSemiMinor * kSemiMinor));
    const Geodetic g = toGeodetic(d * t);
    return {g.lon + 360.0 * std::round((midLon_ - g.lon) / 360.0), g.lat};
  }

 private:
  double midLon_;
  glm::dvec3 axis_, e1_{0.0}, e2_{0.0};
};

/// The longitude and latitude of the points a cell's footprint is made from, by their place in
/// the gnomonic plane: a point we gave keeps its own (projecting it back could move it by a
/// rounding), a point the triangulation made (a crossing of a line's shapes) is projected back.
class PlanePoints {
 public:
  explicit PlanePoints(const Gnomonic& g) : g_(&g) {}
  glm::dvec2 add(const Pt& lonLat) {
    const glm::dvec2 q = g_->project(lonLat);
    given_.try_emplace(key(q), lonLat);
    return q;
  }
  [[nodiscard]] Pt lonLat(const glm::dvec2& q) const {
    const auto it = given_.find(key(q));
    return it != given_.end() ? it->second : g_->unproject(q);
  }

 private:
  static std::pair<double, double> key(const glm::dvec2& q) { return {q.x + 0.0, q.y + 0.0}; }
  const Gnomonic* g_;
  std::map<std::pair<double, double>, Pt> given_;
};

/// Appends the piece of `rings` (clipped to `cell`, widened) to `out`, in colour `group`: an
/// area's rings by the even-odd rule, a line's shapes (`united`) as their union, which leaves
/// out the walls and caps inside it. The cap is the shared builder's footprint in the cell's
/// gnomonic plane (overlay::evenOddFootprint, unionFootprint), with points every few posts
/// inside it so that no cap triangle is longer than a few posts; each of its vertices is lifted
/// to the bounds' heights along the ellipsoid's normal there, in the shared piece layout
/// (overlay::appendPieceIndices).
/// How a piece is bounded and covered (a tile's own, or a whole-load build's).
struct PieceRule {
  /// Bounds for the terrain drawn at the tile's level or any finer one (a whole-load tile), else
  /// at its level.
  bool finerLevels = false;
  /// The seed paper's construction: these bounds (its feature's) instead of its own, and a box.
  const std::pair<double, double>* featureBounds = nullptr;
};

/// `rule`: the piece's bounds, and with the seed paper's construction its covering box.
void addPiece(TilePieces& out, const std::vector<Ring>& rings, const LonLatRect& cell, const LonLatRect& widened,
              const GeoGrid& heights, double postStep, int level, bool united, std::uint32_t group,
              const PieceRule& rule) {
  const Gnomonic gnomonic(cell);
  PlanePoints plane(gnomonic);
  std::vector<glm::dvec2> capPoints;
  const double step = postStep * (level < 4 ? 1 : kCapPointStep);
  for (double y = cell.south + step; y < cell.north - 0.5 * step; y += step) {
    for (double x = cell.west + step; x < cell.east - 0.5 * step; x += step) capPoints.push_back(plane.add({x, y}));
  }
  overlay::Footprint f;
  if (united) {
    std::vector<std::vector<glm::dvec2>> parts;
    for (const Ring& ring : rings) {
      std::vector<glm::dvec2> part;
      for (const Pt& p : withParallelPosts(ring, widened, postStep)) part.push_back(plane.add(p));
      if (part.size() >= 3) parts.push_back(std::move(part));
    }
    if (parts.empty()) return;
    f = overlay::unionFootprint(parts, capPoints);
  } else {
    std::vector<std::array<glm::dvec2, 2>> edges;
    for (const auto& [a, b] : splitParallels(oddSegments(rings, widened), widened, postStep)) {
      edges.push_back({plane.add(a), plane.add(b)});
    }
    if (edges.empty()) return;
    f = overlay::evenOddFootprint(edges, capPoints);
  }
  if (f.triangles.empty()) return;
  std::vector<Pt> lonLat;
  lonLat.reserve(f.vertices.size());
  for (const glm::dvec2& q : f.vertices) lonLat.push_back(plane.lonLat(q));

  // Bounds: the ground drawn under the piece (the terrain's contract holds over any box within a
  // drawn tile: here the box of the piece's own points, within the widened cell), the top raised
  // by the sag of the longest cap edge. A small piece (a street in a large cell) gets the bounds
  // of the ground it covers, not of the whole cell.
  LonLatRect box{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                 -std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()};
  for (const Pt& p : lonLat) {
    box.west = std::min(box.west, p.x);
    box.east = std::max(box.east, p.x);
    box.south = std::min(box.south, p.y);
    box.north = std::max(box.north, p.y);
  }
  box = {std::max(box.west, widened.west), std::max(box.south, widened.south), std::min(box.east, widened.east),
         std::min(box.north, widened.north)};
  std::pair<double, double> bounds = groundBounds(heights, box, level);
  for (int finer = level + 1; rule.finerLevels && finer <= kMaxLevel; ++finer) {
    const std::pair<double, double> b = groundBounds(heights, box, finer);
    bounds = {std::min(bounds.first, b.first), std::max(bounds.second, b.second)};
  }
  if (rule.featureBounds != nullptr) bounds = *rule.featureBounds;
  const double lo = bounds.first, ground1 = bounds.second;
  double longest = 0.0;
  for (const auto& t : f.triangles) {
    for (std::size_t i = 0; i < 3; ++i) {
      const Pt& p = lonLat[t[i]];
      const Pt& q = lonLat[t[(i + 1) % 3]];
      longest = std::max(longest, glm::length(toEcef(p.x, p.y, ground1) - toEcef(q.x, q.y, ground1)));
    }
  }
  const double hi = ground1 + triangleSag(longest * 1.01);

  // Vertices: footprint vertex k is 2k (bottom) and 2k + 1 (top).
  const auto base = static_cast<std::uint32_t>(out.vertices.size());
  TilePieces::Piece piece;
  piece.group = group;
  piece.lo = lo;
  piece.hi = hi;
  piece.ground = ground1;
  piece.boxLo = glm::dvec3(std::numeric_limits<double>::max());
  piece.boxHi = glm::dvec3(-std::numeric_limits<double>::max());
  for (const Pt& p : lonLat) {
    const glm::vec3 n(surfaceNormal(p.x, p.y));
    for (const double h : {lo, hi}) {
      const glm::dvec3 at = toEcef(p.x, p.y, h);
      piece.boxLo = glm::min(piece.boxLo, at);
      piece.boxHi = glm::max(piece.boxHi, at);
      out.vertices.push_back(
          PieceVertex{glm::vec4(glm::vec3(at - out.origin), h == lo ? -1.0F : 1.0F), glm::vec4(n, 0.0F)});
    }
  }
  piece.firstIndex = static_cast<std::uint32_t>(out.indices.size());
  piece.bottomCount = overlay::appendPieceIndices(f, out.indices);
  for (std::size_t k = piece.firstIndex; k < out.indices.size(); ++k) out.indices[k] += base;
  piece.indexCount = static_cast<std::uint32_t>(out.indices.size()) - piece.firstIndex;
  if (rule.featureBounds != nullptr) {
    // Its box, a little larger than the piece (the caps' pads grow with the distance from the
    // eye), whose corners move out along their diagonals with the pads and the caps' reach.
    const double margin = 0.05 + 1e-4 * glm::length(piece.boxHi - piece.boxLo);
    const auto boxBase = static_cast<std::uint32_t>(out.vertices.size());
    for (std::uint32_t k = 0; k < 8; ++k) {
      const glm::dvec3 sign((k & 1U) != 0 ? 1.0 : -1.0, (k & 2U) != 0 ? 1.0 : -1.0, (k & 4U) != 0 ? 1.0 : -1.0);
      const glm::dvec3 corner((k & 1U) != 0 ? piece.boxHi.x : piece.boxLo.x,
                              (k & 2U) != 0 ? piece.boxHi.y : piece.boxLo.y,
                              (k & 4U) != 0 ? piece.boxHi.z : piece.boxLo.z);
      out.vertices.push_back(PieceVertex{glm::vec4(glm::vec3(corner + sign * margin - out.origin), 1.0F),
                                         glm::vec4(glm::vec3(sign), 0.0F)});
    }
    piece.boxFirstIndex = static_cast<std::uint32_t>(out.indices.size());
    for (const std::uint32_t k : overlay::kBoxFaces) out.indices.push_back(boxBase + k);
  }
  out.pieces.push_back(piece);
}

/// A tile's pieces as world pieces of the overlay pipeline, in its layer's colour groups.
overlay::LayerGeometry worldPiecesOf(const GlobeLayer& layer, TilePieces pieces) {
  using Vertex = overlay::LayerGeometry::Vertex;
  std::vector<Vertex> vertices(pieces.vertices.size());
  std::vector<glm::vec4> normals(pieces.vertices.size());
  for (std::size_t i = 0; i < pieces.vertices.size(); ++i) {
    const glm::vec4& p = pieces.vertices[i].position;
    vertices[i] = Vertex{p.x, p.y, p.z, p.w, {0, 0, 0, 255}};
    normals[i] = pieces.vertices[i].normal;
  }
  std::vector<overlay::LayerGeometry::WorldPiece> world;
  world.reserve(pieces.pieces.size());
  for (const TilePieces::Piece& p : pieces.pieces)
    world.push_back({p.firstIndex, p.bottomCount, p.indexCount, p.boxLo, p.boxHi, p.group, p.boxFirstIndex});
  overlay::LayerGeometry::WorldLines lines;
  if (!pieces.scaling.empty()) {
    lines.scaling = std::move(pieces.scaling);
    lines.widthPixels = layer.lineWidthPixels();
    lines.maxWidth = 2.0 * pieces.maxHalfWidth;
  }
  const std::vector<glm::vec4> fallback{layer.color()};
  return overlay::LayerGeometry::ofWorldPieces(
      layer.name(), pieces.origin, std::move(vertices), std::move(normals), std::move(pieces.indices), world,
      layer.colors().empty() ? fallback : layer.colors(), std::move(lines), pieces.paper);
}

/// How a tile's pieces are built.
enum class Build {
  Tile,   ///< for the terrain drawn at its level: generalised for it, lines in pixels of a class
  Whole,  ///< at full detail, widths in metres, bounded for its level and every finer one
  Paper,  ///< as Whole, the seed paper's way: a bound pair per feature, a piece per line shape, boxes
};

/// Per feature of the layer, its box (unwrapped longitudes): its areas' and its lines' grown by
/// what their shapes reach.
std::unordered_map<std::uint32_t, LonLatRect> featureBoxes(const GlobeLayer& layer) {
  std::unordered_map<std::uint32_t, LonLatRect> boxes;
  const auto add = [&](std::uint32_t feature, const LonLatRect& box) {
    const auto [at, made] = boxes.try_emplace(feature, box);
    if (!made) {
      LonLatRect& b = at->second;
      b = {std::min(b.west, box.west), std::min(b.south, box.south), std::max(b.east, box.east),
           std::max(b.north, box.north)};
    }
  };
  for (std::size_t k = 0; k < layer.areaCount(); ++k) add(layer.area(k).feature, layer.area(k).box);
  if (layer.hasLines()) {
    for (const GlobeLine& line : layer.lines()) {
      const glm::dvec2 grow = detail::degreesAround(line.box, line.halfWidth * line.shapeReach());
      add(line.feature, line.box.expanded(grow.x, grow.y));
    }
  }
  return boxes;
}

/// A tile's pieces, built as `build` says.
TilePieces piecesOf(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights, int widthClass, Build build) {
  const bool wholeLoad = build != Build::Tile;
  const bool paper = build == Build::Paper;
  // The seed paper's bound pair per feature: the terrain drawn over the feature's box at the
  // tile's level and every finer one (made as the tile meets the feature).
  std::unordered_map<std::uint32_t, LonLatRect> boxes;
  if (paper) boxes = featureBoxes(layer);
  std::unordered_map<std::uint32_t, std::pair<double, double>> featureBounds;
  const auto ruleFor = [&](std::uint32_t feature) {
    PieceRule rule;
    rule.finerLevels = wholeLoad;
    if (!paper) return rule;
    auto found = featureBounds.find(feature);
    if (found == featureBounds.end()) {
      const LonLatRect box = boxes.at(feature);
      std::pair<double, double> b = groundBounds(heights, box, key.level);
      for (int finer = key.level + 1; finer <= kMaxLevel; ++finer) {
        const std::pair<double, double> f = groundBounds(heights, box, finer);
        b = {std::min(b.first, f.first), std::max(b.second, f.second)};
      }
      found = featureBounds.emplace(feature, b).first;
    }
    rule.featureBounds = &found->second;
    return rule;
  };
  TilePieces out;
  out.paper = paper;
  const LonLatRect rect = key.rect();
  out.origin = toEcef(0.5 * (rect.west + rect.east), 0.5 * (rect.south + rect.north), 0.0);
  const double postStep = key.postStep();
  // Neighbouring pieces overlap by a little more than float rounding at the distances this
  // level is drawn from (meridians), and than a parallel's chords stray (parallels).
  const double lonMargin = postStep * 1e-3;
  const double cellSize = key.size() / kCellsPerSide;
  // One margin for the tile and its cells, so that the tile's clip lines are its outer cells'
  // lines (runs along them are split at posts there).
  double latMargin = 0.0;
  for (int k = 0; k <= kCellsPerSide; ++k)
    latMargin = std::max(latMargin, parallelStray(rect.south + k * cellSize, postStep));
  latMargin = 2.0 * latMargin + lonMargin;
  // Cell (cx, cy) of the tile, and the same widened by the margins.
  const auto cellRects = [&](int cx, int cy) {
    const LonLatRect cell{rect.west + cx * cellSize, rect.south + cy * cellSize, rect.west + (cx + 1) * cellSize,
                          rect.south + (cy + 1) * cellSize};
    return std::make_pair(
        cell, LonLatRect{cell.west - lonMargin, cell.south - latMargin, cell.east + lonMargin, cell.north + latMargin});
  };
  // A line's shapes (bands, discs, sectors) overlap: per cell, those of one colour are united
  // into one piece, which leaves out the walls and caps inside the union.
  std::map<std::pair<std::uint32_t, int>, std::vector<Ring>> lineCells;  // (colour, cell) → rings
  const auto addPolygon = [&](const GlobePolygon& polygon, const std::vector<Ring>& rings, bool line) {
    for (int turn = -1; turn <= 1; ++turn) {
      const double shift = 360.0 * turn;
      const LonLatRect tileRect{rect.west + shift - lonMargin, rect.south - latMargin, rect.east + shift + lonMargin,
                                rect.north + latMargin};
      if (!overlaps(tileRect, polygon.box)) continue;
      std::vector<Ring> inTile;
      for (const Ring& ring : rings) {
        Ring clipped = clipRect(ring, tileRect);
        if (clipped.size() >= 3) inTile.push_back(std::move(clipped));
      }
      if (inTile.empty()) continue;
      for (int cy = 0; cy < kCellsPerSide; ++cy) {
        for (int cx = 0; cx < kCellsPerSide; ++cx) {
          const auto [cell, widened] = cellRects(cx, cy);
          LonLatRect shifted = widened;
          shifted.west += shift;
          shifted.east += shift;
          std::vector<Ring> inCell;
          for (const Ring& ring : inTile) {
            Ring clipped = clipRect(ring, shifted);
            if (clipped.size() < 3) continue;
            for (Pt& p : clipped) {
              // Back into the tile's turn, onto the cell's lines exactly where it was on them.
              const bool onWest = p.x == shifted.west, onEast = p.x == shifted.east;
              p.x -= shift;
              if (onWest) p.x = widened.west;
              if (onEast) p.x = widened.east;
            }
            inCell.push_back(std::move(clipped));
          }
          if (inCell.empty()) continue;
          if (line && !paper) {
            std::vector<Ring>& united = lineCells[{polygon.group, cy * kCellsPerSide + cx}];
            for (Ring& r : inCell) united.push_back(std::move(r));
            continue;
          }
          addPiece(out, inCell, cell, widened, heights, postStep, key.level, false, polygon.group,
                   ruleFor(polygon.feature));
        }
      }
    }
  };
  const int detail = wholeLoad ? kMaxLevel : key.level;
  // The areas that reach the tile, read and generalised for it now.
  for (const GlobePolygon& area : layer.areasIn(rect.expanded(lonMargin, latMargin), detail))
    addPolygon(area, area.rings, false);
  for (const GlobePolygon& polygon : layer.lineShapesIn(key, wholeLoad ? 0 : widthClass, 0.0, detail))
    addPolygon(polygon, polygon.rings, true);
  for (const auto& [groupCell, rings] : lineCells) {
    const auto [cell, widened] = cellRects(groupCell.second % kCellsPerSide, groupCell.second / kCellsPerSide);
    addPiece(out, rings, cell, widened, heights, postStep, key.level, true, groupCell.first, ruleFor(0));
  }
  if (!wholeLoad) detail::addScalableLines(out, layer, key, heights, widthClass);
  if (!out.scaling.empty()) out.scaling.resize(out.vertices.size(), glm::vec4(0.0F));
  return out;
}

}  // namespace

overlay::LayerGeometry buildTilePieces(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                                       int widthClass) {
  return worldPiecesOf(layer, piecesOf(layer, key, heights, widthClass, Build::Tile));
}

WholeLoadTile buildWholeLoadPieces(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights, bool paper) {
  TilePieces pieces = piecesOf(layer, key, heights, 0, paper ? Build::Paper : Build::Whole);
  WholeLoadTile out;
  out.key = key;
  out.highestLow = -std::numeric_limits<double>::infinity();
  out.lowestHigh = std::numeric_limits<double>::infinity();
  for (const TilePieces::Piece& p : pieces.pieces) {
    out.highestLow = std::max(out.highestLow, p.lo);
    out.lowestHigh = std::min(out.lowestHigh, p.ground);
  }
  out.empty = pieces.pieces.empty();
  out.geometry = worldPiecesOf(layer, std::move(pieces));
  return out;
}

CoarseDrawnTiles::CoarseDrawnTiles(const std::vector<DrawnTile>& drawn) {
  for (const DrawnTile& d : drawn) {
    if (d.key.level >= kWholeLoadLevel) continue;  // the pieces' own bounds hold it
    keys_.insert(d.key);
    levels_ |= 1U << static_cast<unsigned>(d.key.level);
  }
}

std::uint32_t CoarseDrawnTiles::levelsMeeting(const LonLatRect& box, int level) const {
  std::uint32_t found = 0;
  for (int l = 0; l < std::min(level, kWholeLoadLevel); ++l) {
    if ((levels_ & (1U << static_cast<unsigned>(l))) == 0) continue;
    const TileKey any{l, 0, 0};
    const double s = any.size();
    bool meets = false;
    for (int turn = -1; turn <= 1 && !meets; ++turn) {
      const double shift = 360.0 * turn;
      const double west = box.west + shift, east = box.east + shift;
      if (east < -180.0 || west > 180.0) continue;
      // The tiles whose closed rectangles can meet the box: one more each side than its own
      // columns and rows (rounding), each tested as the rectangles are, then looked up.
      const int x0 = std::max(0, static_cast<int>(std::floor((west + 180.0) / s)) - 1);
      const int x1 = std::min(any.columns() - 1, static_cast<int>(std::floor((east + 180.0) / s)) + 1);
      const int y0 = std::max(0, static_cast<int>(std::floor((box.south + 90.0) / s)) - 1);
      const int y1 = std::min(any.rows() - 1, static_cast<int>(std::floor((box.north + 90.0) / s)) + 1);
      for (int y = y0; y <= y1 && !meets; ++y) {
        for (int x = x0; x <= x1 && !meets; ++x) {
          const TileKey key{l, x, y};
          const LonLatRect r = key.rect();
          meets =
              west <= r.east && r.west <= east && box.south <= r.north && r.south <= box.north && keys_.contains(key);
        }
      }
    }
    if (meets) found |= 1U << static_cast<unsigned>(l);
  }
  return found;
}

std::uint32_t coarserLevelsOver(const WholeLoadTile& tile, const CoarseDrawnTiles& drawn) {
  if (tile.empty) return 0;
  // The pieces reach a little beyond their tile (the cells' margins): grown by a hundredth of it.
  const LonLatRect box = tile.key.rect().expanded(0.01 * tile.key.size(), 0.01 * tile.key.size());
  return drawn.levelsMeeting(box, tile.key.level);
}

glm::dvec2 wholeLoadCapReach(const WholeLoadTile& tile, std::uint32_t levels, const GeoGrid& heights) {
  glm::dvec2 reach(0.0);
  if (tile.empty) return reach;
  const LonLatRect box = tile.key.rect().expanded(0.01 * tile.key.size(), 0.01 * tile.key.size());
  // The surface a drawn tile of level L lays over the box lies within groundBounds at L (the
  // terrain's contract: the box lies within that tile and a strip of its neighbours).
  for (int level = 0; level < 32; ++level) {
    if ((levels & (1U << static_cast<unsigned>(level))) == 0) continue;
    const std::pair<double, double> b = groundBounds(heights, box, level);
    reach = glm::max(reach, glm::dvec2(tile.highestLow - b.first, b.second - tile.lowestHigh));
  }
  return reach;
}

}  // namespace gis::globe
