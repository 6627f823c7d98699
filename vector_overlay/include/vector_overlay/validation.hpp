#pragma once
// Invariants of stencil polyhedra, checked on the triangles as they are drawn: the stencil count
// of a pixel is right only when every piece is closed (each edge met as often in one direction
// as in the other, so that the winding number is defined everywhere), wound outward (front faces outside: positive
// volume) and bounded (finite coordinates, lo ≤ hi, the footprint inside its cell). Used by the tests, the fuzzers and
// OverlayLayer::validate; cheap enough to run over a whole layer.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vector_overlay/footprints.hpp"
#include "vector_overlay/overlay_layer.hpp"

namespace gis::overlay {

/// The triangles of a footprint extruded into a piece, as the layer draws them: vertex 2k is
/// footprint vertex k at the bottom, 2k + 1 the same at the top. Appends the bottom cap
/// (clockwise seen from above, so facing down), then the walls (a quad per boundary edge, facing
/// away from the region), then the top cap (counter-clockwise); returns the number of indices of
/// the bottom cap.
std::uint32_t appendPieceIndices(const Footprint& footprint, std::vector<std::uint32_t>& indices);

struct ValidationOptions {
  /// When set, every vertex must lie in the grid's extent, and in its cell for a piece with a
  /// cell (within `tolerance`).
  std::optional<CellGrid> grid;
  /// Largest coordinate magnitude accepted (frame metres; the readers reject beyond 1e15).
  double maxCoordinate = 1e15;
  /// Relative slack of the volume identity and of the containment tests (times the cell size).
  double tolerance = 1e-6;
  /// Caps are drawn moved out by a padding (OverlaySettings::padBase and up); the volume is
  /// checked with this one, so that a flat piece (lo == hi) still has an orientation.
  double pad = 0.05;
};

/// What is wrong with a polyhedron as drawn; empty when it is closed, outward and bounded:
/// - every index refers to a footprint vertex; every coordinate, lo and hi finite and within
///   maxCoordinate; lo ≤ hi;
/// - no cap triangle is clockwise (negative area beyond rounding);
/// - closed: in the drawn mesh every directed edge (a, b) appears as often as (b, a) (so the
///   footprint's boundary is exactly its unshared triangle edges; parts touching at a vertex
///   share a wall edge, which is fine);
/// - outward: the signed volume of the mesh, caps moved out by options.pad, equals the
///   footprint area · (hi − lo + 2 pad), not negative;
/// - inside the grid (and its cell) when options.grid is set.
std::vector<std::string> polyhedronProblems(const Polyhedron& polyhedron, const ValidationOptions& options = {});

}  // namespace gis::overlay
