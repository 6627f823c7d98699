#pragma once
// The CGAL headers the overlay uses, included once with our strict warnings silenced (CGAL's
// headers are not written for -Wconversion -Wshadow -Wold-style-cast).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_face_base_2.h>
#include <CGAL/Constrained_triangulation_plus_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_data_structure_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_2.h>
#pragma GCC diagnostic pop

#include <queue>

namespace gis::overlay::detail {

/// Visits the faces of a triangulation outward-in, breadth first from the infinite face:
/// `enter(from, i, to)` is called once for each face `to` first reached across edge i of face
/// `from` (`seen(face)` says whether a face was reached), and sets what `to` carries (its
/// parity, its winding number) from `from`'s. The infinite face is entered first by `start`.
template <typename Tr, typename Start, typename Seen, typename Enter>
void floodFromOutside(Tr& cdt, Start&& start, Seen&& seen, Enter&& enter) {
  std::queue<typename Tr::Face_handle> queue;
  start(cdt.infinite_face());
  queue.push(cdt.infinite_face());
  while (!queue.empty()) {
    const auto f = queue.front();
    queue.pop();
    for (int i = 0; i < 3; ++i) {
      const auto g = f->neighbor(i);
      if (seen(g)) continue;
      enter(f, i, g);
      queue.push(g);
    }
  }
}

}  // namespace gis::overlay::detail
