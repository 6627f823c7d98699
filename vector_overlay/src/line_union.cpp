// The union of a line feature's convex pieces (segment rectangles, joins, caps) as one region:
// every piece's edges go into one constrained Delaunay triangulation with exact constructions
// (the pieces cross each other at every join, and CGAL's inexact crossing points could bend a
// constraint: polygon_footprints.cpp); a face is inside when its winding number — the number of
// pieces around it, counted by a flood fill from the infinite face that adds or removes one
// piece across each piece edge by its direction — is positive. Then the union's boundary alone
// is triangulated again (even-odd, no crossings left), so no vertex inside the region remains.
#include <climits>
#include <exception>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cgal.hpp"

#include "footprint_geometry.hpp"

namespace gis::overlay::detail {
namespace {

struct PairHash {
  std::size_t operator()(const std::pair<double, double>& p) const {
    const std::size_t a = std::hash<double>{}(p.first), b = std::hash<double>{}(p.second);
    return a ^ (b + 0x9e3779b97f4a7c15ULL + (a << 6) + (a >> 2));
  }
};

struct WindingInfo {
  int winding = INT_MIN;  ///< INT_MIN: not reached yet
};

using UnionKernel = CGAL::Epeck;
using UnionTriangulation = CGAL::Constrained_triangulation_plus_2<CGAL::Constrained_Delaunay_triangulation_2<
    UnionKernel,
    CGAL::Triangulation_data_structure_2<
        CGAL::Triangulation_vertex_base_2<UnionKernel>,
        CGAL::Constrained_triangulation_face_base_2<
            UnionKernel, CGAL::Triangulation_face_base_with_info_2<WindingInfo, UnionKernel>>>,
    CGAL::Exact_intersections_tag>>;

/// A coordinate rounded to double: an input coordinate is its interval's single value; a
/// constructed one (a crossing) is evaluated exactly first (polygon_footprints.cpp's toDouble).
double rounded(const UnionKernel::FT& c) {
  const std::pair<double, double> i = CGAL::to_interval(c);
  return i.first == i.second ? i.first : CGAL::to_double(CGAL::exact(c));
}

glm::dvec2 rounded(const UnionKernel::Point_2& p) { return {rounded(p.x()), rounded(p.y())}; }

/// Change of the winding number from face f across its edge i into the neighbour: f lies on the
/// left of va → vb (va = vertex ccw(i), vb = vertex cw(i)); a piece edge running va → vb has the
/// piece on f's side (−1 on leaving it), one running vb → va on the other side (+1).
int windingChange(const UnionTriangulation& cdt, UnionTriangulation::Face_handle f, int i) {
  if (!f->is_constrained(i)) return 0;
  const auto va = f->vertex(UnionTriangulation::ccw(i));
  const auto vb = f->vertex(UnionTriangulation::cw(i));
  int change = 0;
  for (auto c = cdt.contexts_begin(va, vb); c != cdt.contexts_end(va, vb); ++c) {
    change += *c->current() == vb ? 1 : -1;
  }
  return change;
}

void markWinding(UnionTriangulation& cdt) {
  using Face = UnionTriangulation::Face_handle;
  floodFromOutside(
      cdt, [](Face f) { f->info().winding = 0; }, [](Face f) { return f->info().winding != INT_MIN; },
      [&](Face f, int i, Face g) { g->info().winding = f->info().winding + windingChange(cdt, f, i); });
}

}  // namespace

std::vector<Triangle> unionTriangles(const std::vector<std::vector<glm::dvec2>>& parts,
                                     const std::vector<glm::dvec2>& points) {
  UnionTriangulation cdt;
  std::vector<UnionKernel::Point_2> corners;
  for (const auto& part : parts) {
    for (const auto& p : part) corners.emplace_back(p.x, p.y);
  }
  cdt.insert(corners.begin(), corners.end());
  // Each input point's vertex, found by its coordinates (input points are exact doubles):
  // inserting the point again would locate it through exact comparisons of equal coordinates.
  std::unordered_map<std::pair<double, double>, UnionTriangulation::Vertex_handle, PairHash> vertexAt;
  vertexAt.reserve(corners.size());
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    const glm::dvec2 q = rounded(v->point());
    vertexAt.emplace(std::pair{q.x + 0.0, q.y + 0.0}, v);  // + 0.0: −0 and 0 are one key
  }
  std::vector<UnionTriangulation::Vertex_handle> handles;
  for (const auto& part : parts) {
    handles.clear();
    for (const auto& p : part) handles.push_back(vertexAt.at(std::pair{p.x + 0.0, p.y + 0.0}));
    for (std::size_t i = 0; i < handles.size(); ++i) {
      const auto va = handles[i];
      const auto vb = handles[(i + 1) % handles.size()];
      if (va != vb) cdt.insert_constraint(va, vb);
    }
  }
  if (cdt.dimension() < 2) return {};
  markWinding(cdt);
  // The boundary: edges between a face inside and one outside, directed with the inside on
  // their left, as rings for the even-odd triangulation (any decomposition of the edges into
  // closed loops gives every point the same parity: the number of edges a ray from it crosses).
  std::multimap<std::pair<double, double>, glm::dvec2> next;  // start → end, rounded
  std::vector<Triangle> inside;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (f->info().winding <= 0) continue;
    Triangle t;
    for (int i = 0; i < 3; ++i) t[static_cast<std::size_t>(i)] = rounded(f->vertex(i)->point());
    inside.push_back(t);
    for (int i = 0; i < 3; ++i) {
      if (f->neighbor(i)->info().winding > 0 && !cdt.is_infinite(f->neighbor(i))) continue;
      const glm::dvec2 a = rounded(f->vertex(UnionTriangulation::ccw(i))->point());
      const glm::dvec2 b = rounded(f->vertex(UnionTriangulation::cw(i))->point());
      if (a != b) next.emplace(std::pair{a.x, a.y}, b);
    }
  }
  std::vector<std::vector<glm::dvec2>> rings;
  while (!next.empty()) {
    std::vector<glm::dvec2> ring;
    auto edge = next.begin();
    const glm::dvec2 start(edge->first.first, edge->first.second);
    glm::dvec2 at = start;
    bool closed = false;
    while (edge != next.end()) {
      ring.push_back(at);
      at = edge->second;
      next.erase(edge);
      if (at == start) {
        closed = true;
        break;
      }
      edge = next.find(std::pair{at.x, at.y});
    }
    if (!closed) return inside;  // rounding broke a loop: keep the union's own triangles
    if (ring.size() >= 3) rings.push_back(std::move(ring));
  }
  // The boundary triangulated alone: fewer triangles. Rounding could make two boundary edges
  // cross (they touched exactly); then the union's own triangles are kept.
  std::optional<std::vector<Triangle>> clean = evenOddTrianglesIfExact(rings, points);
  return clean ? std::move(*clean) : inside;
}

}  // namespace gis::overlay::detail
