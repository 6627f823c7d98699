#pragma once
// The convex shapes a line is drawn with, once for both frames (footprints.hpp states the
// coverage they make: a rectangle per segment, a join at every interior point, a cap at each end).
//
// The frame is a seam (docs/frames.md): a frame gives each point of a line a plane of its own —
// the projected frame its one plane, the globe the tangent plane at the point — and the
// directions of the line's pieces there (LineStation). The rules below make every shape as a
// list of corners, each a point of the line and a direction in that point's plane, in half
// widths (ShapeCorner); the frame lifts a corner to centre + direction · h in its own way (a
// point of its plane, or a point of the tangent plane put on the ellipsoid). Lines in pixels keep
// the corners as they are: their width is set per frame, so each corner stays its centre and
// direction (Footprint::centres, directions).
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "vector_overlay/footprints.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay {

/// A point of a line as its shapes see it, in the point's own plane (right-handed, seen from
/// above).
struct LineStation {
  glm::dvec2 in{0.0};                      ///< unit direction of the piece arriving here; zero at a line's start
  glm::dvec2 out{0.0};                     ///< unit direction of the piece leaving; zero at a line's end
  double inLength = 0.0, outLength = 0.0;  ///< those pieces' lengths (metres)
  /// +1 the line turns left here, −1 right, 0 it goes straight on or turns back (the frame's own
  /// predicate: the projected frame's is exact).
  int turn = 0;
  /// False: a point the frame added inside a piece of the source (the globe's points along a
  /// geodesic, where the turn is a rounding): no join; the pieces on both sides share their
  /// corners here, on the bisector of their sides (a miter, within h θ² / 8 of both).
  bool given = true;
};

/// A corner of a shape: the point `station` of the line moved by `direction` (in that station's
/// plane) times the half width there.
struct ShapeCorner {
  std::uint32_t station = 0;
  glm::dvec2 direction{0.0};
};

struct LineShapeRules {
  LineJoin join = LineJoin::Round;
  LineCap cap = LineCap::Round;
  double miterLimit = 4.0;
  /// Segments at least this long (metres) hold the inner part of a round join's or cap's disc, so
  /// the join is only the outer wedge and the cap only the outer half disc: the half width (the
  /// largest, for lines in pixels), or more where a frame's planes bend.
  double wedgeLength = 1.0;
  /// The half width (the largest): a miter point that would lie beyond the finite numbers at it
  /// is left out (a bevel).
  double halfWidth = 1.0;
  int chords = 32;          ///< of an arc, per full circle
  bool wholeDiscs = false;  ///< whole discs at round joins and caps (lines in pixels over 2 px)
  bool ends = true;         ///< joins and caps; false: the segments' rectangles only
};

/// Calls add(kind, corners) for every shape of the line through `stations` (consecutive stations
/// joined by a segment), in order: the first station's cap (or its join, when it has a piece
/// arriving: a run cut out of a longer line), then per segment its rectangle and the join at its
/// end, and the last station's cap (or join). Corners run counter-clockwise and make a convex
/// shape, star-shaped around its stations at every width up to the largest. A line of one station
/// (no directions) gets its round cap's disc or its square cap's axis-aligned square.
void lineShapes(std::span<const LineStation> stations, const LineShapeRules& rules,
                const std::function<void(PieceKind, std::vector<ShapeCorner>)>& add);

}  // namespace gis::overlay
