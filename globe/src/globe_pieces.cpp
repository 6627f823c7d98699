// The pieces of a globe layer over one tile (globe_overlay.hpp): its polygons clipped to the
// tile's cells, capped with a constrained Delaunay triangulation and extruded along the normals.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include "cgal_globe.hpp"
#include "globe/globe_overlay.hpp"
#include "globe_detail.hpp"

namespace gis::globe {

namespace {

using Pt = glm::dvec2;
using Ring = std::vector<Pt>;

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

struct VertexInfo {
  int index = -1;
  bool placed = false;  ///< lonLat set (a point we inserted; else one the triangulation made)
  glm::dvec2 lonLat{0.0};
};
struct FaceInfo {
  int parity = -1;  ///< −1 unvisited, 0 outside, 1 inside
};
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<VertexInfo, Kernel>;
using Fbi = CGAL::Triangulation_face_base_with_info_2<FaceInfo, Kernel>;
using Fb = CGAL::Constrained_triangulation_face_base_2<Kernel, Fbi>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;

/// The segments of rings with even-odd multiplicity: segments on one of the cell's four lines
/// (runs along the clip boundary, which Sutherland–Hodgman may lay over each other) are cut at
/// every end on that line and kept where an odd number covers them; others are kept unless they
/// come in pairs.
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

/// Every segment of the rings once (a segment two rings share, or one ring runs twice, once):
/// the constraints of a union.
std::vector<std::pair<Pt, Pt>> allSegments(const std::vector<Ring>& rings) {
  std::set<std::pair<std::pair<double, double>, std::pair<double, double>>> seen;
  std::vector<std::pair<Pt, Pt>> out;
  for (const Ring& ring : rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) {
      Pt a = ring[i], b = ring[(i + 1) % ring.size()];
      if (a == b) continue;
      if (std::make_pair(b.x, b.y) < std::make_pair(a.x, a.y)) std::swap(a, b);
      if (seen.insert({{a.x, a.y}, {b.x, b.y}}).second) out.emplace_back(a, b);
    }
  }
  return out;
}

/// Whether a point lies in any of a set of simple rings (plane coordinates): the union's
/// inside, through a grid of buckets over the rings' boxes.
class RingUnion {
 public:
  explicit RingUnion(std::vector<std::vector<glm::dvec2>> rings) : rings_(std::move(rings)) {
    lo_ = glm::dvec2(std::numeric_limits<double>::max());
    hi_ = glm::dvec2(-std::numeric_limits<double>::max());
    for (const auto& r : rings_) {
      glm::dvec2 a(std::numeric_limits<double>::max()), b(-std::numeric_limits<double>::max());
      for (const glm::dvec2& p : r) {
        a = glm::min(a, p);
        b = glm::max(b, p);
      }
      boxes_.emplace_back(a, b);
      lo_ = glm::min(lo_, a);
      hi_ = glm::max(hi_, b);
    }
    side_ = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(rings_.size())) * 2.0), 1, 64);
    buckets_.assign(static_cast<std::size_t>(side_) * static_cast<std::size_t>(side_), {});
    for (std::size_t k = 0; k < rings_.size(); ++k) {
      const glm::ivec2 a = cellOf(boxes_[k].first), b = cellOf(boxes_[k].second);
      for (int y = a.y; y <= b.y; ++y) {
        for (int x = a.x; x <= b.x; ++x) buckets_[static_cast<std::size_t>(y * side_ + x)].push_back(k);
      }
    }
  }

  [[nodiscard]] bool contains(const glm::dvec2& p) const {
    if (rings_.empty() || p.x < lo_.x || p.y < lo_.y || p.x > hi_.x || p.y > hi_.y) return false;
    const glm::ivec2 c = cellOf(p);
    for (const std::size_t k : buckets_[static_cast<std::size_t>(c.y * side_ + c.x)]) {
      const auto& [a, b] = boxes_[k];
      if (p.x < a.x || p.y < a.y || p.x > b.x || p.y > b.y) continue;
      const std::vector<glm::dvec2>& r = rings_[k];
      bool in = false;
      for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
        if ((r[i].y > p.y) != (r[j].y > p.y) && p.x < r[j].x + (r[i].x - r[j].x) * (p.y - r[j].y) / (r[i].y - r[j].y)) {
          in = !in;
        }
      }
      if (in) return true;
    }
    return false;
  }

 private:
  [[nodiscard]] glm::ivec2 cellOf(const glm::dvec2& p) const {
    const glm::dvec2 size = glm::max(hi_ - lo_, glm::dvec2(1e-300));
    const glm::dvec2 t = (p - lo_) / size * static_cast<double>(side_);
    return {std::clamp(static_cast<int>(t.x), 0, side_ - 1), std::clamp(static_cast<int>(t.y), 0, side_ - 1)};
  }
  std::vector<std::vector<glm::dvec2>> rings_;
  std::vector<std::pair<glm::dvec2, glm::dvec2>> boxes_;
  glm::dvec2 lo_{0.0}, hi_{0.0};
  int side_ = 1;
  std::vector<std::vector<std::size_t>> buckets_;
};

/// How a piece's rings make its inside: even-odd (an area, its holes included), or the union of
/// simple rings (a line's shapes, which overlap: bands, discs and sectors).
enum class Fill { EvenOdd, Union };

/// A cell's gnomonic projection (the central one from the earth's centre onto the plane at the
/// cell's middle): there a straight line is the image of every chord, so a cap's flat triangles,
/// seen from the centre, tile the cell without folding (in longitude and latitude, long thin
/// triangles would fold over each other).
class Gnomonic {
 public:
  explicit Gnomonic(const LonLatRect& cell)
      : midLon_(0.5 * (cell.west + cell.east)),
        axis_(glm::normalize(toEcef(midLon_, 0.5 * (cell.south + cell.north), 0.0))) {
    const glm::dmat3 enu = enuBasis(midLon_, 0.5 * (cell.south + cell.north));
    e1_ = glm::normalize(enu[0] - glm::dot(enu[0], axis_) * axis_);
    e2_ = glm::cross(axis_, e1_);
  }
  [[nodiscard]] Cdt::Point project(const Pt& lonLat) const {
    const glm::dvec3 p = toEcef(lonLat.x, lonLat.y, 0.0);
    const glm::dvec3 d = p / glm::dot(p, axis_);
    return {glm::dot(d, e1_), glm::dot(d, e2_)};
  }
  [[nodiscard]] Pt unproject(const Cdt::Point& q) const {
    const glm::dvec3 d = axis_ + e1_ * q.x() + e2_ * q.y();
    const double t =
        1.0 / std::sqrt((d.x * d.x + d.y * d.y) / (kSemiMajor * kSemiMajor) + d.z * d.z / (kSemiMinor * kSemiMinor));
    const Geodetic g = toGeodetic(d * t);
    return {g.lon + 360.0 * std::round((midLon_ - g.lon) / 360.0), g.lat};
  }

 private:
  double midLon_;
  glm::dvec3 axis_, e1_{0.0}, e2_{0.0};
};

/// A point of a triangulation: where it is in the projection, and its longitude and latitude.
struct Node {
  Cdt::Point at;
  Pt lonLat;
};

/// The constrained triangulation of `segments` and `points` in the projection, every vertex
/// with its longitude and latitude (those given, or the projection's of a crossing).
void triangulate(Cdt& cdt, const Gnomonic& g, const std::vector<std::pair<Node, Node>>& segments,
                 const std::vector<Pt>& points) {
  const auto insert = [&](const Node& n) {
    const Cdt::Vertex_handle v = cdt.insert(n.at);
    if (!v->info().placed) {
      v->info().placed = true;
      v->info().lonLat = n.lonLat;
    }
    return v;
  };
  for (const auto& [a, b] : segments) {
    if (a.at == b.at) continue;
    const Cdt::Vertex_handle va = insert(a), vb = insert(b);
    if (va != vb) cdt.insert_constraint(va, vb);
  }
  for (const Pt& p : points) insert({g.project(p), p});
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    if (!v->info().placed) {
      v->info().placed = true;
      v->info().lonLat = g.unproject(v->point());
    }
  }
}

/// The boundary of the union of simple rings, as segments (`segments`: theirs, split at the
/// posts on the cell's lines). The rings' segments are triangulated, and a face is inside when
/// its centroid is in one of the rings (taken with the same points on the cell's lines): the
/// constraints part every ring's inside from its outside, so a whole face is in or out of each.
/// The edges between inside and outside faces are the boundary; overlaps inside leave none.
/// Its points are the triangulation's own (a crossing projected back from lon/lat could land on
/// a point beside it and close the boundary there).
std::vector<std::pair<Node, Node>> unionBoundary(const std::vector<std::pair<Node, Node>>& segments,
                                                 const std::vector<Ring>& rings, const LonLatRect& widened,
                                                 double postStep, const Gnomonic& g) {
  Cdt cdt;
  triangulate(cdt, g, segments, {});
  std::vector<std::vector<glm::dvec2>> plane;
  for (const Ring& ring : rings) {
    std::vector<glm::dvec2> r;
    for (const Pt& p : withParallelPosts(ring, widened, postStep)) {
      const Cdt::Point q = g.project(p);
      r.emplace_back(q.x(), q.y());
    }
    if (r.size() >= 3) plane.push_back(std::move(r));
  }
  const RingUnion inUnion(std::move(plane));
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) {
    glm::dvec2 c(0.0);
    if (!cdt.is_infinite(f)) {
      for (int i = 0; i < 3; ++i) c += glm::dvec2(f->vertex(i)->point().x(), f->vertex(i)->point().y()) / 3.0;
    }
    f->info().parity = !cdt.is_infinite(f) && inUnion.contains(c) ? 1 : 0;
  }
  std::vector<std::pair<Node, Node>> boundary;
  const auto node = [](const Cdt::Vertex_handle& v) { return Node{v->point(), v->info().lonLat}; };
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (f->info().parity != 1) continue;
    for (int i = 0; i < 3; ++i) {
      if (f->neighbor(i)->info().parity == 1) continue;
      boundary.emplace_back(node(f->vertex((i + 1) % 3)), node(f->vertex((i + 2) % 3)));
    }
  }
  return boundary;
}

/// Appends the piece of `rings` (clipped to `cell`, widened) to `out`, in colour `group`.
void addPiece(TilePieces& out, const std::vector<Ring>& rings, const LonLatRect& cell, const LonLatRect& widened,
              const GeoGrid& heights, double postStep, int level, Fill fill, std::uint32_t group) {
  const Gnomonic gnomonic(cell);
  std::vector<std::pair<Node, Node>> segments;
  for (const auto& [a, b] :
       splitParallels(fill == Fill::Union ? allSegments(rings) : oddSegments(rings, widened), widened, postStep)) {
    segments.push_back({{gnomonic.project(a), a}, {gnomonic.project(b), b}});
  }
  // A union is capped as the area its boundary encloses: no triangle for the overlaps inside.
  if (fill == Fill::Union && !segments.empty()) segments = unionBoundary(segments, rings, widened, postStep, gnomonic);
  if (segments.empty()) return;
  // Points inside the cap every few posts: no cap triangle is longer than a few posts.
  std::vector<Pt> capPoints;
  const double step = postStep * (level < 4 ? 1 : kCapPointStep);
  for (double y = cell.south + step; y < cell.north - 0.5 * step; y += step) {
    for (double x = cell.west + step; x < cell.east - 0.5 * step; x += step) capPoints.emplace_back(x, y);
  }
  Cdt cdt;
  triangulate(cdt, gnomonic, segments, capPoints);
  // Even-odd: a face is inside when an odd number of constraints part it from the outside.
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info().parity = -1;
  std::vector<Cdt::Face_handle> queue{cdt.infinite_face()};
  cdt.infinite_face()->info().parity = 0;
  while (!queue.empty()) {
    const Cdt::Face_handle f = queue.back();
    queue.pop_back();
    for (int i = 0; i < 3; ++i) {
      const Cdt::Face_handle g = f->neighbor(i);
      if (g->info().parity >= 0) continue;
      g->info().parity = cdt.is_constrained(Cdt::Edge(f, i)) ? 1 - f->info().parity : f->info().parity;
      queue.push_back(g);
    }
  }

  // Bounds: the ground drawn under the piece (the terrain's contract holds over any box within a
  // drawn tile: here the box of the piece's own points, within the widened cell), the top raised
  // by the sag of the longest cap edge. A small piece (a street in a large cell) gets the bounds
  // of the ground it covers, not of the whole cell.
  LonLatRect box{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                 -std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()};
  for (const auto& [a, b] : segments) {
    for (const Pt& p : {a.lonLat, b.lonLat}) {
      box.west = std::min(box.west, p.x);
      box.east = std::max(box.east, p.x);
      box.south = std::min(box.south, p.y);
      box.north = std::max(box.north, p.y);
    }
  }
  box = {std::max(box.west, widened.west), std::max(box.south, widened.south), std::min(box.east, widened.east),
         std::min(box.north, widened.north)};
  const std::pair<double, double> bounds = groundBounds(heights, box, level);
  const double lo = bounds.first, ground1 = bounds.second;
  double longest = 0.0;
  std::vector<Cdt::Face_handle> inside;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (f->info().parity != 1) continue;
    inside.push_back(f);
    for (int i = 0; i < 3; ++i) {
      const Pt& p = f->vertex(i)->info().lonLat;
      const Pt& q = f->vertex((i + 1) % 3)->info().lonLat;
      longest = std::max(longest, glm::length(toEcef(p.x, p.y, ground1) - toEcef(q.x, q.y, ground1)));
    }
  }
  if (inside.empty()) return;
  const double hi = ground1 + triangleSag(longest * 1.01);

  // Vertices: two per triangulation vertex (bottom, top).
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) v->info().index = -1;
  const auto base = static_cast<std::uint32_t>(out.vertices.size());
  TilePieces::Piece piece;
  piece.group = group;
  piece.lo = lo;
  piece.hi = hi;
  piece.boxLo = glm::dvec3(std::numeric_limits<double>::max());
  piece.boxHi = glm::dvec3(-std::numeric_limits<double>::max());
  const auto vertexOf = [&](const Cdt::Vertex_handle& v) {
    if (v->info().index < 0) {
      v->info().index = static_cast<int>(out.vertices.size() - base) / 2;
      const double lon = v->info().lonLat.x, lat = v->info().lonLat.y;
      const glm::vec3 n(surfaceNormal(lon, lat));
      for (const double h : {lo, hi}) {
        const glm::dvec3 p = toEcef(lon, lat, h);
        piece.boxLo = glm::min(piece.boxLo, p);
        piece.boxHi = glm::max(piece.boxHi, p);
        out.vertices.push_back(
            PieceVertex{glm::vec4(glm::vec3(p - out.origin), h == lo ? -1.0F : 1.0F), glm::vec4(n, 0.0F)});
      }
    }
    return base + 2 * static_cast<std::uint32_t>(v->info().index);
  };
  piece.firstIndex = static_cast<std::uint32_t>(out.indices.size());
  for (const auto& f : inside) {
    const std::uint32_t a = vertexOf(f->vertex(0)), b = vertexOf(f->vertex(1)), c = vertexOf(f->vertex(2));
    out.indices.insert(out.indices.end(), {a, c, b});  // bottom: facing down
  }
  piece.bottomCount = static_cast<std::uint32_t>(out.indices.size()) - piece.firstIndex;
  for (const auto& f : inside) {
    for (int i = 0; i < 3; ++i) {
      if (f->neighbor(i)->info().parity == 1 && !cdt.is_infinite(f->neighbor(i))) continue;
      // Edge i runs from vertex i+1 to vertex i+2 with the face on its left: the wall faces right.
      const std::uint32_t a = vertexOf(f->vertex((i + 1) % 3)), b = vertexOf(f->vertex((i + 2) % 3));
      out.indices.insert(out.indices.end(), {a, b, b + 1, a, b + 1, a + 1});
    }
  }
  for (const auto& f : inside) {
    const std::uint32_t a = vertexOf(f->vertex(0)), b = vertexOf(f->vertex(1)), c = vertexOf(f->vertex(2));
    out.indices.insert(out.indices.end(), {a + 1, b + 1, c + 1});
  }
  piece.indexCount = static_cast<std::uint32_t>(out.indices.size()) - piece.firstIndex;
  out.pieces.push_back(piece);
}

}  // namespace

TilePieces buildTilePieces(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights, int widthClass) {
  TilePieces out;
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
  const auto addPolygon = [&](const GlobePolygon& polygon, bool line) {
    for (int turn = -1; turn <= 1; ++turn) {
      const double shift = 360.0 * turn;
      const LonLatRect tileRect{rect.west + shift - lonMargin, rect.south - latMargin, rect.east + shift + lonMargin,
                                rect.north + latMargin};
      if (!overlaps(tileRect, polygon.box)) continue;
      std::vector<Ring> inTile;
      for (const Ring& ring : polygon.ringsAt(key.level)) {
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
          if (line) {
            std::vector<Ring>& united = lineCells[{polygon.group, cy * kCellsPerSide + cx}];
            for (Ring& r : inCell) united.push_back(std::move(r));
            continue;
          }
          addPiece(out, inCell, cell, widened, heights, postStep, key.level, Fill::EvenOdd, polygon.group);
        }
      }
    }
  };
  const std::vector<GlobePolygon>& polygons = layer.polygons();
  for (std::size_t k = 0; k < layer.areaCount(); ++k) addPolygon(polygons[k], false);
  for (const GlobePolygon& polygon : layer.lineShapesIn(key, widthClass)) addPolygon(polygon, true);
  for (const auto& [groupCell, rings] : lineCells) {
    const auto [cell, widened] = cellRects(groupCell.second % kCellsPerSide, groupCell.second / kCellsPerSide);
    addPiece(out, rings, cell, widened, heights, postStep, key.level, Fill::Union, groupCell.first);
  }
  detail::addScalableLines(out, layer, key, heights, widthClass);
  if (!out.scaling.empty()) out.scaling.resize(out.vertices.size(), glm::vec4(0.0F));
  return out;
}

}  // namespace gis::globe
