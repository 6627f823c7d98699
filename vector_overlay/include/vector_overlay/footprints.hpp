#pragma once
// Footprints: the 2D shapes of the pieces that become stencil polyhedra (docs/design.md §5).
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
// clipped to the cell). A line feature in metres is built from one convex shape per segment,
// join and cap; each shape is its own piece, split at cell borders. With
// FootprintOptions::uniteLines the feature becomes one piece per grid cell it meets instead:
// the union of its shapes, triangulated and clipped to the cell, with no walls inside it and
// no caps stacked where shapes overlap. A round join whose two segments are at
// least w/2 long is drawn as its outer wedge only, and a round cap whose end segment is at least
// w/2 long as its outer half disc: the rectangles hold the rest of the disc, so the union (the
// coverage above) is the same with far fewer triangles. Every piece is a region with a
// triangulation of its interior and its boundary edges; the polyhedra builder extrudes it
// between height bounds.
//
// Lines in pixels (LineShape::widthPixels) change shape every frame, so their pieces are not
// split at cells (one piece per segment, join and cap, with the bounds of its largest extent).
// Every piece is star-shaped around its vertex (a trapezoid between two, for segments), so the
// shape at any smaller width lies inside the one at the largest width; the wedge and half-disc
// choices above, made at the largest width, hold at every smaller one; arcs get
// `chordTolerancePixels` between chord and arc on screen.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"
#include "geo/feature.hpp"
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
  /// Lines in pixels: pixels between arc and chord, at most (the arc's radius counted in pixels).
  double chordTolerancePixels = 0.05;
  /// Split and clip at these cells; none = one piece per polygon feature, unclipped.
  std::optional<CellGrid> cells;
  /// Lines in metres: one piece per cell for the union of a feature's segment, join and cap
  /// shapes (PieceKind::Line); false (the default): a piece per shape (per cell), overlapping.
  /// Off by default: measured on Olinda it draws 12 % more fragments than a piece per shape
  /// (each small shape gets the tight bounds of its own few posts) and builds 35× slower
  /// (docs/overlay.md).
  bool uniteLines = false;
  /// United lines are cut at cells this many times finer than `cells` (each fine cell lies in
  /// one cell of `cells`, whose index the piece keeps): a union is as tight as the bounds of
  /// the ground it covers, and a thin line crossing a large cell gets the bounds of the strip
  /// it crosses, not of the whole cell.
  int lineCellDivisions = 8;
  /// Lines in metres: the segments' rectangles only, no joins and no caps (a line of one point
  /// gives nothing). What is left out lies within w/2 of a vertex of the line, so the footprint
  /// moves by at most w/2: for generalised tiles of lines thinner than their error
  /// (tiled_layer.hpp).
  bool segmentsOnly = false;
};

/// What a footprint was made from: a polygon, a line's segment, join or cap shape, or the
/// union of a line feature's shapes.
enum class PieceKind : std::uint8_t { PolygonPart, Segment, Join, Cap, Line };

struct Footprint {
  std::uint32_t feature = 0;  ///< index of the feature in its layer
  std::int32_t cell = -1;     ///< CellGrid::cellIndex, or −1 without a grid (or over several cells)
  /// The shape this footprint was cut from (a polygon of the feature, or a line's segment, join
  /// or cap, counted per feature): the parts of one shape in different cells share it.
  std::uint32_t source = 0;
  PieceKind kind = PieceKind::PolygonPart;
  std::vector<glm::dvec2> vertices;                     ///< frame coordinates
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise, tiling the region
  /// Directed edges with the region on their left: exactly the triangle edges not shared by two
  /// triangles of this footprint (so the extruded walls close the polyhedron).
  std::vector<std::array<std::uint32_t, 2>> boundary;
  /// Lines in pixels (LineShape): vertex k is centres[k] + directions[k] · h, h the half width
  /// at centres[k] (x, y and the anchor height); `vertices` hold them at the largest width.
  /// Empty for every other footprint.
  std::vector<glm::dvec3> centres;
  std::vector<glm::dvec2> directions;
  [[nodiscard]] bool scalable() const { return !centres.empty(); }
};

/// The pieces of a polygon feature (all its polygons), PolygonPart; without a grid one piece
/// for the whole feature. Problems that a GIS tool repairs are repaired silently (orientation,
/// duplicates, unclosed rings); a polygon that cannot be used (an outer ring with fewer than 3
/// distinct points or zero area, NaN/Inf or |coordinate| > 1e15 in any ring) is skipped with
/// an Error diagnostic naming the layer, the feature id and the problem; the feature's other
/// polygons still count. A hole with fewer than 3 distinct points or zero area is dropped with
/// a Warning (it changes no coverage). An invalid grid skips the feature with an Error.
/// The feature's polygons that polygonFootprints would triangulate (outer ring first, usable
/// holes after it, rings repaired), with the same diagnostics for the others; no triangulation.
std::vector<std::vector<geo::Ring>> usablePolygons(const geo::Feature& feature, const std::string& layerName,
                                                   Diagnostics& diagnostics);

std::vector<Footprint> polygonFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                         const std::string& layerName, const FootprintOptions& options,
                                         Diagnostics& diagnostics);

/// Line geometry of a line layer (or a polygon outline): width in metres and style.
///
/// Widths in pixels (`widthPixels` > 0): at every vertex of the line the half width is
/// min(widthPixels / 2 · metresPerPixel · d, width / 2), d the distance from the eye to the
/// vertex raised to its anchor height (the terrain there, `anchorHeights`), metresPerPixel the
/// size of a pixel at 1 m from the eye (PixelScale). Along a segment the half width goes
/// linearly from one end's to the other's (a trapezoid instead of a rectangle); joins and caps
/// use their vertex's half width. So `width` is the largest width in metres: far away such a
/// line gets thinner than widthPixels on screen. The line's polyhedra are built at that largest
/// width (bounds, culling and the eye test stay conservative) and shrunk per frame.
///
/// A least width (`minWidth` > 0, the style's `min_width_px` over a width in metres): the half
/// width is max(min(widthPixels / 2 · metresPerPixel · d, width / 2), minWidth / 2), so the
/// line is minWidth wide near the eye and widthPixels wide on screen where that is wider, up to
/// `width`. Every piece is star-shaped around its centres, so any width up to `width` lies
/// inside the pieces built at `width`.
struct LineShape {
  double width = 10.0;
  LineJoin join = LineJoin::Round;
  LineCap cap = LineCap::Round;
  double miterLimit = 4.0;
  double widthPixels = 0.0;  ///< > 0: width in pixels, `width` the largest in metres
  double minWidth = 0.0;     ///< lines in pixels: the least width in metres
  /// Per line of the feature, per vertex (as given, repeated points included): the height at
  /// which the distance to the eye is measured. Missing entries count as 0.
  std::vector<std::vector<double>> anchorHeights;
  [[nodiscard]] bool inPixels() const { return widthPixels > 0.0; }
  [[nodiscard]] double anchorHeight(std::size_t line, std::size_t vertex) const {
    return line < anchorHeights.size() && vertex < anchorHeights[line].size() ? anchorHeights[line][vertex] : 0.0;
  }
};

/// A region in a map plane as one footprint (feature 0, no cell), for a frame that cuts its
/// features into cells itself and triangulates each cell's part in a plane of its own (the globe:
/// gnomonic about the cell, docs/frames.md): the points inside an odd number of `edges` (each a
/// constraint of its own; an edge given twice, or runs laid over each other along a cell's
/// border, cancel), triangulated as polygonFootprints triangulates a polygon, with those of
/// `points` that fall inside added as vertices (to keep the cap's triangles short where the plane
/// curves away from the surface). No triangles when the region has no area. Throws what CGAL
/// throws.
Footprint evenOddFootprint(const std::vector<std::array<glm::dvec2, 2>>& edges, const std::vector<glm::dvec2>& points);
/// The same for the union of simple closed `parts` (a line's shapes: bands, joins and caps,
/// which overlap; either orientation), as a line's united pieces are made (FootprintOptions::
/// uniteLines): no walls or caps inside the union.
Footprint unionFootprint(const std::vector<std::vector<glm::dvec2>>& parts, const std::vector<glm::dvec2>& points);

/// How big a pixel is in the frame: its size in metres at 1 m from the eye (2 tan(fovY / 2) /
/// viewport height for a perspective camera).
struct PixelScale {
  glm::dvec3 eye{0.0};
  double metresPerPixel = 0.0;
};

/// The pixel scale of a perspective camera given by its frame → clip matrix (the eye is where
/// clip x, y and w vanish) and the viewport height in pixels.
PixelScale pixelScaleOf(const glm::dmat4& viewProj, int viewportHeight);

/// The half width of a line with `shape` at a vertex raised to its anchor height (LineShape):
/// width / 2 for metre widths, clamped to [minWidth / 2, width / 2] for lines in pixels.
inline double halfWidthAt(const LineShape& shape, const PixelScale& scale, const glm::dvec3& anchor) {
  if (!shape.inPixels()) return 0.5 * shape.width;
  const glm::dvec3 d = anchor - scale.eye;
  const double distance = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  return std::max(std::min(0.5 * shape.widthPixels * scale.metresPerPixel * distance, 0.5 * shape.width),
                  0.5 * shape.minWidth);
}

/// The pieces of a line feature (all its lines). A feature with a non-positive, non-finite or
/// absurd (> 1e15 m) width (or an invalid grid) is skipped with a diagnostic; so is a single line with a NaN/Inf
/// or |coordinate| > 1e15, or one that reaches beyond ±1e15 once widened (unclipped); the
/// feature's other lines still count.
std::vector<Footprint> lineFootprints(const geo::Feature& feature, std::uint32_t featureIndex,
                                      const std::string& layerName, const LineShape& shape,
                                      const FootprintOptions& options, Diagnostics& diagnostics);

}  // namespace gis::overlay
