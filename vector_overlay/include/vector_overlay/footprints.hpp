#pragma once
// Footprints: the 2D shapes of the pieces that become stencil polyhedra (DESIGN §5).
//
// Coverage semantics (what a layer covers on the ground; the CPU reference implements the
// same rules independently, see cpu_reference.hpp):
// - A polygon feature covers the union of its polygons; a polygon covers, after repair (ring
//   orientation fixed, duplicate and collinear points dropped, self-intersections resolved by
//   the even-odd rule, rings whose points are all collinear dropped), the points inside an odd
//   number of its own rings (outer and holes). Overlapping parts of an (invalid) multipolygon
//   stay covered, as GIS viewers paint them and as MakeValid repairs them.
// - A line feature of width w covers the union of
//   - every segment's rectangle: points whose projection onto the segment falls within it and
//     whose distance to it is ≤ w/2 (zero-length segments have none);
//   - at every interior vertex, its join: round = the disc of radius w/2; bevel = the triangle
//     (vertex, the outer corner of the incoming rectangle, the outer corner of the outgoing
//     one); miter = the quadrilateral (vertex, outer corner in, miter point, outer corner out)
//     when the miter length w/2 / sin(θ/2) (θ the angle between the segments) is at most
//     miterLimit · w/2, else the bevel; nothing on a straight continuation;
//   - at both ends, its cap: round = the disc of radius w/2; square = the rectangle extending
//     the end segment by w/2; flat = nothing. A line of one point (after dropping repeated
//     points) with round or square caps covers the disc or the square of side w around it
//     (axis-aligned). At a hairpin (180°) the bevel is flat and the miter infinite: only a
//     round join adds anything there.
// - Arcs are polygons whose vertices lie on the circle, with at most `chordTolerance` between
//   chord and arc (so the drawn shape lies inside the exact one, within that tolerance).
//
// Pieces: a polygon feature becomes one piece per grid cell it meets (its triangulation
// clipped to the cell); a line feature one piece per segment, per join and per cap, each split
// at cell borders (so every piece lies in its cell). A round join whose two segments are at
// least w/2 long is drawn as its outer wedge only, and a round cap whose end segment is at least
// w/2 long as its outer half disc: the rectangles hold the rest of the disc, so the union (the
// coverage above) is the same with far fewer triangles. Every piece is a region with a
// triangulation of its interior and its boundary edges; the polyhedra builder extrudes it
// between height bounds.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "geo/vector.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay {

/// A regular grid of square cells (the terrain quadtree's cells at some level), used to split
/// pieces so that each piece gets the height bounds of the cells it covers. Pieces are also
/// clipped to the grid's extent (there is no terrain to drape on outside it).
struct CellGrid {
  glm::dvec2 origin{0.0};  ///< minimum corner (frame coordinates)
  double cellSize = 1.0;   ///< metres
  int columns = 1;
  int rows = 1;
  [[nodiscard]] int cellIndex(int column, int row) const { return row * columns + column; }
};

struct FootprintOptions {
  /// Metres between arc and chord, at most. Arcs get at most 16384 chords per full circle (a
  /// non-positive or non-finite tolerance gets that many); below r · 1.9e-8 it is not met.
  double chordTolerance = 0.02;
  /// Split and clip at these cells; none = one piece per polygon feature, unclipped.
  std::optional<CellGrid> cells;
};

enum class PieceKind : std::uint8_t { PolygonPart, Segment, Join, Cap };

struct Footprint {
  std::uint32_t feature = 0;  ///< index of the feature in its layer
  std::int32_t cell = -1;     ///< CellGrid::cellIndex, or −1 without a grid
  PieceKind kind = PieceKind::PolygonPart;
  std::vector<glm::dvec2> vertices;                     ///< frame coordinates
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise, tiling the region
  /// Directed edges with the region on their left: exactly the triangle edges not shared by two
  /// triangles of this footprint (so the extruded walls close the polyhedron).
  std::vector<std::array<std::uint32_t, 2>> boundary;
};

/// The pieces of a polygon feature (all its polygons), PolygonPart; without a grid one piece
/// for the whole feature. Problems that a GIS tool repairs are repaired silently (orientation,
/// duplicates, unclosed rings); a polygon that cannot be used (an outer ring with fewer than 3
/// distinct points or zero area, NaN/Inf or |coordinate| > 1e15 in any ring) is skipped with
/// an Error diagnostic naming the layer, the feature id and the problem; the feature's other
/// polygons still count. A hole with fewer than 3 distinct points or zero area is dropped with
/// a Warning (it changes no coverage). An invalid grid skips the feature with an Error.
std::vector<Footprint> polygonFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                         const std::string& layerName, const FootprintOptions& options,
                                         Diagnostics& diagnostics);

/// Line geometry of a line layer (or a polygon outline): width in metres and style.
struct LineShape {
  double width = 10.0;
  LineJoin join = LineJoin::Round;
  LineCap cap = LineCap::Round;
  double miterLimit = 4.0;
};

/// The pieces of a line feature (all its lines). A feature with a non-positive, non-finite or
/// absurd (> 1e15 m) width (or an invalid grid) is skipped with a diagnostic; so is a single line with a NaN/Inf
/// or |coordinate| > 1e15, the feature's other lines still count.
std::vector<Footprint> lineFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                      const std::string& layerName, const LineShape& shape,
                                      const FootprintOptions& options, Diagnostics& diagnostics);

}  // namespace gis::overlay
