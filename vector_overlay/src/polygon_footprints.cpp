// Polygon footprints: all rings of a feature go into one constrained Delaunay triangulation
// (CGAL, exact predicates, intersecting constraints allowed); the faces inside an odd number of
// rings are found by a flood fill from the infinite face that changes parity across a
// constrained edge when an odd number of ring edges run along it; the inside triangles are
// split at the grid cells (footprint_geometry.hpp) and merged into one footprint per cell.
//
// Crossing rings: with inexact constructions (Epick, Exact_predicates_tag) CGAL 5.5 rounds the
// crossing points and, when a rounded point falls outside the two triangles of the crossed edge,
// snaps the constraint to a vertex of that edge — possibly far from the ring (seen on lattice
// rings with many concurrent crossings), which would flip the coverage of whole regions. So the
// fast triangulation is accepted only when every constraint still runs exactly along its ring
// edge (always true without crossings); otherwise the feature is triangulated again with exact
// constructions (Epeck, Exact_intersections_tag: each crossing computed once from the original
// ring edges) and the crossing points are rounded to double at the end.
#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <map>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "cgal.hpp"

#include "footprint_geometry.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay {
namespace {

using detail::Triangle;

struct FaceInfo {
  int parity = -1;  ///< −1 not reached yet; 0 outside; 1 inside (odd number of rings)
};

// The "plus" hierarchy remembers which input edges run along each constrained edge: two rings
// sharing an edge (a hole touching its shell, neighbouring parts of a multipolygon, a spike
// going out and back) cancel under the even-odd rule, which a plain constrained flag cannot tell.
template <typename K, typename IntersectionTag>
using EvenOddTriangulation = CGAL::Constrained_triangulation_plus_2<CGAL::Constrained_Delaunay_triangulation_2<
    K,
    CGAL::Triangulation_data_structure_2<
        CGAL::Triangulation_vertex_base_2<K>,
        CGAL::Constrained_triangulation_face_base_2<K, CGAL::Triangulation_face_base_with_info_2<FaceInfo, K>>>,
    IntersectionTag>>;

using FastTriangulation = EvenOddTriangulation<CGAL::Epick, CGAL::Exact_predicates_tag>;
using ExactTriangulation = EvenOddTriangulation<CGAL::Epeck, CGAL::Exact_intersections_tag>;

/// Largest usable |coordinate|: far beyond any frame; products of larger coordinates could
/// overflow in the area and intersection formulas.
constexpr double kMaxCoordinate = 1e15;

enum class RingCheck { Ok, NonFinite, TooFewPoints, ZeroArea };

/// Repairs a ring in place (repeated points, closing point) and says whether it can be used.
RingCheck checkRing(geo::Ring& ring) {
  for (const auto& p : ring) {
    if (!detail::finite(p) || std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate) {
      return RingCheck::NonFinite;
    }
  }
  detail::dropRepeatedPoints(ring);
  if (ring.size() < 3) return RingCheck::TooFewPoints;
  // Distinct points (not only consecutive ones): a ring A B A B has two.
  std::vector<glm::dvec2> sorted = ring;
  std::sort(sorted.begin(), sorted.end(),
            [](const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  if (std::unique(sorted.begin(), sorted.end()) - sorted.begin() < 3) return RingCheck::TooFewPoints;
  const glm::dvec2 a = ring[0];
  std::size_t j = 1;
  while (ring[j] == a) ++j;
  const glm::dvec2 b = ring[j];
  for (const auto& c : ring) {
    if (detail::orientation(a, b, c) != 0) return RingCheck::Ok;
  }
  return RingCheck::ZeroArea;
}

std::string describe(RingCheck check) {
  switch (check) {
    case RingCheck::NonFinite:
      return "has a NaN, infinite or out-of-range coordinate";
    case RingCheck::TooFewPoints:
      return "has fewer than 3 distinct points";
    case RingCheck::ZeroArea:
      return "has zero area (all points collinear)";
    case RingCheck::Ok:
      break;
  }
  return "is valid";
}

/// Marks every face with the parity of the number of rings around it.
template <typename Tr>
void markParity(Tr& cdt) {
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info().parity = -1;
  using Face = typename Tr::Face_handle;
  detail::floodFromOutside(
      cdt, [](Face f) { f->info().parity = 0; }, [](Face f) { return f->info().parity != -1; },
      [&](Face f, int i, Face g) {
        int flip = 0;
        if (f->is_constrained(i)) {
          const auto va = f->vertex(Tr::cw(i));
          const auto vb = f->vertex(Tr::ccw(i));
          flip = static_cast<int>(cdt.number_of_enclosing_constraints(va, vb) % 2);
        }
        g->info().parity = f->info().parity ^ flip;
      });
}

/// Whether every constraint of the triangulation runs exactly along its input segment: its
/// vertices are collinear with the segment's ends and within its bounding box.
bool constraintsExact(const FastTriangulation& cdt) {
  for (auto c = cdt.constraints_begin(); c != cdt.constraints_end(); ++c) {
    const auto first = cdt.vertices_in_constraint_begin(*c);
    const auto last = cdt.vertices_in_constraint_end(*c);
    if (first == last) continue;
    const auto& a = (*first)->point();
    auto back = last;
    --back;
    const auto& b = (*back)->point();
    for (auto it = first; it != last; ++it) {
      const auto& p = (*it)->point();
      if (CGAL::orientation(a, b, p) != CGAL::COLLINEAR) return false;
      if (p.x() < std::min(a.x(), b.x()) || p.x() > std::max(a.x(), b.x()) || p.y() < std::min(a.y(), b.y()) ||
          p.y() > std::max(a.y(), b.y())) {
        return false;
      }
    }
  }
  return true;
}

/// A vertex in double. Lazy exact coordinates are evaluated exactly first: their interval
/// approximation may be some ulps off (20 − 7e-15 for an exact 20), and a vertex rounded
/// differently than its exact value could fall into the wrong cell.
inline glm::dvec2 toDouble(const CGAL::Epick::Point_2& p) { return {p.x(), p.y()}; }
inline glm::dvec2 toDouble(const CGAL::Epeck::Point_2& p) {
  return {CGAL::to_double(CGAL::exact(p.x())), CGAL::to_double(CGAL::exact(p.y()))};
}

/// The triangles of `cdt` inside an odd number of its constraints, with their vertices rounded
/// to double; nullopt when `requireExact` and a constraint had to bend.
template <typename Tr>
std::optional<std::vector<Triangle>> oddFaces(Tr& cdt, bool requireExact) {
  if constexpr (std::is_same_v<Tr, FastTriangulation>) {
    if (requireExact && !constraintsExact(cdt)) return std::nullopt;
  }
  std::vector<Triangle> inside;
  if (cdt.dimension() < 2) return inside;
  markParity(cdt);
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (f->info().parity != 1) continue;
    Triangle t;
    for (int i = 0; i < 3; ++i) {
      const auto& p = f->vertex(i)->point();
      t[static_cast<std::size_t>(i)] = toDouble(p);
    }
    inside.push_back(t);
  }
  return inside;
}

/// Triangulates the rings (with `extra` points added) and returns the triangles inside an odd
/// number of them, with their vertices rounded to double; nullopt when `requireExact` and a
/// constraint had to bend.
template <typename Tr>
std::optional<std::vector<Triangle>> insideTriangles(const std::vector<geo::Ring>& rings, bool requireExact,
                                                     const std::vector<glm::dvec2>& extra = {}) {
  using Point = typename Tr::Point;
  Tr cdt;
  // All points first, spatially sorted by CGAL: inserting them along the rings would make every
  // new point of a convex ring conflict with a long fan of triangles (quadratic time).
  std::vector<Point> points;
  for (const auto& ring : rings) {
    for (const auto& p : ring) points.emplace_back(p.x, p.y);
  }
  for (const auto& p : extra) points.emplace_back(p.x, p.y);
  cdt.insert(points.begin(), points.end());
  std::vector<typename Tr::Vertex_handle> handles;
  for (const auto& ring : rings) {
    handles.clear();
    typename Tr::Face_handle hint;  // per ring: inserting constraints may destroy faces
    for (const auto& p : ring) {
      const auto v = cdt.insert(Point(p.x, p.y), hint);  // finds the vertex already there
      hint = v->face();
      handles.push_back(v);
    }
    for (std::size_t i = 0; i < handles.size(); ++i) {
      const auto va = handles[i];
      const auto vb = handles[(i + 1) % handles.size()];
      if (va != vb) cdt.insert_constraint(va, vb);
    }
  }
  return oddFaces(cdt, requireExact);
}

/// The same for loose edges (each a constraint of its own: an edge given twice cancels).
template <typename Tr>
std::optional<std::vector<Triangle>> insideTriangles(const std::vector<std::array<glm::dvec2, 2>>& edges,
                                                     bool requireExact, const std::vector<glm::dvec2>& extra) {
  using Point = typename Tr::Point;
  Tr cdt;
  std::vector<Point> points;
  for (const auto& e : edges) {
    points.emplace_back(e[0].x, e[0].y);
    points.emplace_back(e[1].x, e[1].y);
  }
  for (const auto& p : extra) points.emplace_back(p.x, p.y);
  cdt.insert(points.begin(), points.end());
  typename Tr::Vertex_handle last;  // a vertex's face stays valid as constraints go in; a face may not
  for (const auto& e : edges) {
    if (e[0] == e[1]) continue;
    const auto va = cdt.insert(Point(e[0].x, e[0].y), last != nullptr ? last->face() : typename Tr::Face_handle());
    const auto vb = cdt.insert(Point(e[1].x, e[1].y), va->face());  // both find the vertices already there
    if (va != vb) cdt.insert_constraint(va, vb);
    last = vb;
  }
  return oddFaces(cdt, requireExact);
}

/// A region's triangles as one footprint (emitRegion without a grid).
Footprint footprintOf(const std::vector<Triangle>& inside) {
  std::vector<Footprint> out;
  detail::emitRegion(inside, std::nullopt, 0, PieceKind::PolygonPart, 0, out);
  return out.empty() ? Footprint{} : std::move(out.front());
}

}  // namespace

namespace detail {

std::optional<std::vector<Triangle>> evenOddTrianglesIfExact(const std::vector<std::vector<glm::dvec2>>& rings,
                                                             const std::vector<glm::dvec2>& points) {
  return insideTriangles<FastTriangulation>(rings, true, points);
}

}  // namespace detail

Footprint evenOddFootprint(const std::vector<std::array<glm::dvec2, 2>>& edges, const std::vector<glm::dvec2>& points) {
  auto fast = insideTriangles<FastTriangulation>(edges, true, points);
  return footprintOf(fast ? *fast : *insideTriangles<ExactTriangulation>(edges, false, points));
}

Footprint unionFootprint(const std::vector<std::vector<glm::dvec2>>& parts, const std::vector<glm::dvec2>& points) {
  std::vector<std::vector<glm::dvec2>> ccw;
  ccw.reserve(parts.size());
  for (const auto& part : parts) {
    double area = 0.0;
    for (std::size_t i = 0, j = part.size() - 1; i < part.size(); j = i++) {
      area += part[j].x * part[i].y - part[i].x * part[j].y;
    }
    if (area == 0.0 || part.size() < 3) continue;
    ccw.push_back(part);
    if (area < 0.0) std::reverse(ccw.back().begin(), ccw.back().end());
  }
  return footprintOf(detail::unionTriangles(ccw, points));
}

std::vector<std::vector<geo::Ring>> usablePolygons(const geo::Feature& feature, const std::string& layerName,
                                                   Diagnostics& diagnostics) {
  // Validation and repair, ring by ring. Each polygon's rings are read with the even-odd rule;
  // the feature covers the union of its polygons (overlapping parts of an invalid
  // multipolygon stay covered, as a GIS viewer paints them), so each polygon is triangulated
  // and emitted on its own.
  std::vector<std::vector<geo::Ring>> polygonRings;
  for (std::size_t k = 0; k < feature.polygons.size(); ++k) {
    const geo::Polygon& polygon = feature.polygons[k];
    const std::string name = "polygon " + std::to_string(k);
    geo::Ring outer = polygon.outer;
    const RingCheck outerCheck = checkRing(outer);
    if (outerCheck != RingCheck::Ok) {
      diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid,
                                           name + ": outer ring " + describe(outerCheck) + "; polygon skipped"));
      continue;
    }
    std::vector<geo::Ring> holes;
    bool usable = true;
    for (std::size_t h = 0; h < polygon.holes.size() && usable; ++h) {
      geo::Ring hole = polygon.holes[h];
      const RingCheck check = checkRing(hole);
      const std::string ringName = name + ": hole " + std::to_string(h) + " " + describe(check);
      if (check == RingCheck::NonFinite) {
        diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid, ringName + "; polygon skipped"));
        usable = false;
      } else if (check != RingCheck::Ok) {
        // A hole without area changes no point's parity: dropping it keeps the coverage.
        diagnostics.add(detail::featureError(Severity::Warning, layerName, feature.fid, ringName + "; hole dropped"));
      } else {
        holes.push_back(std::move(hole));
      }
    }
    if (!usable) continue;
    std::vector<geo::Ring> rings{std::move(outer)};
    for (auto& hole : holes) rings.push_back(std::move(hole));
    polygonRings.push_back(std::move(rings));
  }
  return polygonRings;
}

std::vector<Footprint> polygonFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                         const std::string& layerName, const FootprintOptions& options,
                                         Diagnostics& diagnostics) {
  std::vector<Footprint> result;
  if (options.cells) {
    std::string message;
    if (!detail::validGrid(*options.cells, message)) {
      diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid, message + "; feature skipped"));
      return result;
    }
  }

  const std::vector<std::vector<geo::Ring>> polygonRings = usablePolygons(feature, layerName, diagnostics);
  for (std::size_t k = 0; k < polygonRings.size(); ++k) {
    const std::vector<geo::Ring>& rings = polygonRings[k];
    // Triangulation and even-odd marking.
    std::vector<Triangle> inside;
    try {
      auto fast = insideTriangles<FastTriangulation>(rings, true);
      inside = fast ? std::move(*fast) : std::move(*insideTriangles<ExactTriangulation>(rings, false));
    } catch (const std::exception& e) {
      diagnostics.add(detail::featureError(Severity::Error, layerName, feature.fid,
                                           std::string("triangulation failed (") + e.what() + "); polygon skipped"));
      continue;
    }

    detail::emitRegion(inside, options.cells, featureIndex, PieceKind::PolygonPart, static_cast<std::uint32_t>(k),
                       result);
  }
  return result;
}

}  // namespace gis::overlay
