#pragma once
// The deferred per-pixel lookup in any frame (the technique `deferred`, docs/frames.md): a
// layer's index (vector_overlay/src/deferred_index.hpp) built in one or more *charts*, and the
// pass that reads the terrain's depth and colours the pixels whose ground point a feature
// covers. What a frame gives is its charts:
//
// - A projected frame has one chart, its own plane: a ground point's chart coordinates are its
//   (x, y).
// - The globe has six, the faces of a cube about the earth's centre. A ground point is moved
//   along the ellipsoid's normal onto the ellipsoid, then projected from the centre onto the
//   plane touching the middle of the face it lies in (gnomonic), in metres at that middle. A
//   chord of the ellipsoid is a straight line there, and the globe's edges (the planes through a
//   chord that hold the ends' mean normal, globe_overlay.hpp) stray from their chord's line by
//   less than 10⁻⁴ m for a 1 km edge, so the index's straight edges are the reference's.
//
// Precision, in every chart: the pass finds a pixel's place as integer cells of the index plus a
// float remainder, from an *anchor* near the view. In the frame's plane the anchor is the eye
// (the ground point relative to the eye, as reconstructed from depth, is small near the eye).
// On a face it is the point of the face nearest below the eye, and the ground point's offset
// from it is found from quantities that are all small near the eye (the gnomonic map written
// relative to the anchor), so its error grows with the distance from the eye, as the depth's.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "geo/feature.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/near_clip.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::overlay {

/// Where a deferred index is built (the frame seam of the per-pixel lookup): above.
struct DeferredChart {
  /// -1: the frame's plane. 0–5: the cube face about +x, −x, +y, −y, +z, −z.
  int face = -1;
  glm::dvec3 axis{0.0, 0.0, 1.0};   ///< the face's middle direction
  glm::dvec3 east{1.0, 0.0, 0.0};   ///< the chart's x direction
  glm::dvec3 north{0.0, 1.0, 0.0};  ///< the chart's y direction
  double scale = 1.0;               ///< chart units per unit of the gnomonic plane
  glm::dvec3 radii{1.0};            ///< the ellipsoid the ground is moved onto along its normal

  /// The frame's own plane.
  static DeferredChart plane() { return {}; }
  /// Face `face` (0–5) of the cube about an ellipsoid with these semi-axes (a, a, b), in metres at
  /// the face's middle (scale a).
  static DeferredChart cubeFace(int face, const glm::dvec3& radii);
  /// The face (0–5) a point lies in: its largest coordinate's axis and sign (ties: the first).
  static int faceOf(const glm::dvec3& point);
  /// How far (in gnomonic units, 1 being the face's edge) a face's index reaches beyond the face:
  /// a ground point found in the face next door by float rounding (the pass picks the face from
  /// its float position: half a metre) or by its height (its foot lies along the ellipsoid's
  /// normal, which leans from the centre's ray by 0.2° at most: 30 m below a summit) is still
  /// inside. 6.4 km, far above both; every primitive within it is indexed in both faces, so a
  /// wide margin costs memory where data lies along a face's edge (a twentieth was 319 km:
  /// central Europe twice over).
  static constexpr double kFaceMargin = 1e-3;

  /// A point's chart coordinates by central projection (a face), or its (x, y) (the plane). A
  /// point of the ellipsoid, or a point along a chord between two of its points (on the chord's
  /// line in the chart).
  [[nodiscard]] glm::dvec2 project(const glm::dvec3& point) const;
  /// A ground point's chart coordinates: on a face, its foot on the ellipsoid (along the normal)
  /// projected as the pass does it; in the plane, its (x, y).
  [[nodiscard]] glm::dvec2 ofGround(const glm::dvec3& world) const;
  /// The chart's point as a point of the ellipsoid (a face) or of the plane at height 0.
  [[nodiscard]] glm::dvec3 unproject(const glm::dvec2& chart) const;
};

/// Lines in pixels in the lookup, in either frame. A line w pixels wide is w/2 times the metres of
/// a pixel at its anchor's distance from the eye wide each side, within its least and largest half
/// widths, so how far it reaches follows the view. An index bins a layer's lines at a *reach*, the
/// widest half width it draws them with exactly: the base reach × 2^c for a class c picked per
/// view, the smallest holding the widest half width any of them can take there (each frame bounds
/// its farthest anchor its own way); an index per class. A layer whose lines in pixels never pass
/// the base reach (or that has none) is binned at its lines' own widths (kNatural); in a view wider
/// than every class it is kBeyond (its pieces draw it).
struct PixelLineWidths {
  double pixelsHalf = 0.0;   ///< the largest widthPixels / 2 of the layer's lines in pixels
  double leastHalf = 0.0;    ///< the largest least half width (metres) of those
  double largestHalf = 0.0;  ///< the largest largest half width (metres) of those
  /// The widest half width one of them takes with its anchor `distance` metres from the eye.
  [[nodiscard]] double widestAt(double metresPerPixel, double distance) const {
    return std::min(largestHalf, std::max(leastHalf, pixelsHalf * metresPerPixel * distance));
  }
};

struct ReachClasses {
  static constexpr double kBaseReach = 8.0;  ///< metres: the narrowest class's reach
  static constexpr int kNatural = -1;        ///< binned at the lines' own widths
  static constexpr int kBeyond = 1000;       ///< wider than every class
  /// The narrowest class's reach; infinity: no classes (every layer kNatural).
  double base = kBaseReach;
  /// The widest class: the projected frame's views see tens of kilometres (12: 32 km), the
  /// globe's from space thousands (14: 131 km; wider lines keep their pieces).
  int largest = 12;

  /// The reach class c bins lines at (kNatural: infinity, their own widths).
  [[nodiscard]] double reach(int c) const {
    return c == kNatural ? std::numeric_limits<double>::infinity() : std::ldexp(base, c);
  }
  /// The class a layer whose lines in pixels have widths `w` is drawn exactly with in a view whose
  /// pixels are `metresPerPixel` wide a metre away: `farthest(reach)` bounds the distance from the
  /// eye of every anchor that can colour a drawn pixel when the lines are binned at `reach`.
  [[nodiscard]] int classFor(const PixelLineWidths& w, double metresPerPixel,
                             const std::function<double(double reach)>& farthest) const;
  /// What a line layer's index at class c takes, estimated before it is built (both frames'
  /// lookups decide with it whether to build one within their budget): 64 bytes an entry, an
  /// entry per leaf a primitive (a disc or band) meets. At the lines' own widths some 6; binned
  /// at a reach R some 6 + 30 R / (R + 256 m): as many as its box, grown by R, meets of leaves
  /// down to R / 2 (some 36) once R is well above a piece's length (a few hundred metres).
  /// Measured (deferred_index_test): roads at classes 3 and 7 take 0.9 and 1.0 times this; the
  /// seed paper's roads on the globe at class 7 1.3 times (the old estimate of 6 put them at a
  /// seventh of their 100 MB).
  [[nodiscard]] double lineIndexBytes(std::size_t primitives, int c) const {
    constexpr double kEntryBytes = 64.0, kPiece = 256.0;
    const double r = reach(c);
    const double entries = std::isfinite(r) ? 6.0 + 30.0 * r / (r + kPiece) : 6.0;
    return static_cast<double>(primitives) * kEntryBytes * entries;
  }
};

/// A line's primitive in space, for a frame whose lines are not bands in its charts (the globe:
/// a band of constant width in metres is none in a gnomonic face). The pass tests a pixel's
/// ground point against it in space, relative to a corner of its leaf, as the globe's reference
/// does, across `normal` (the walls are vertical):
/// - a disc is the cylinder of radius r0 around `normal` through `a`;
/// - a band the slab |(p − a)·normal| ≤ r0 + (r1 − r0) s / length, s = (p − a)·along clamped to
///   [0, length] (`normal` is then the slab's), between its ends' planes: through a and through
///   its end b, each holding the ellipsoid's normal there and the slab's side there (endA and endB
///   their unit normals, pointing along the band; the pass finds them from the normals itself);
/// - a convex shape (a join other than round, a square cap) the prism over the polygon
///   a + r0 · corners[k] (counter-clockwise about `normal`, in the plane square to it).
/// A line in pixels (`pixels`) takes its half widths per frame from its feature's rule
/// (Part::lineWidths) at its anchors: `a` (and a band's end) raised by anchor0 (anchor1) along the
/// ellipsoid's normal there; r0 and r1 are then the largest it is binned at.
struct WorldLinePrimitive {
  enum class Kind : std::uint8_t { Band, Disc, Convex };
  Kind kind = Kind::Disc;
  bool pixels = false;
  std::uint32_t feature = 0;
  glm::dvec3 a{0.0};       ///< frame coordinates: the band's start, the disc's centre, the shape's point
  glm::dvec3 along{0.0};   ///< band: unit direction
  double length = 0.0;     ///< band
  glm::dvec3 normal{0.0};  ///< disc, convex: its axis; band: the slab's normal
  double r0 = 0.0, r1 = 0.0;
  double anchor0 = 0.0, anchor1 = 0.0;  ///< pixels: the anchors' heights
  glm::dvec3 endA{0.0}, endB{0.0};      ///< band: its ends' planes' normals (above)
  std::array<glm::dvec3, 4> corners{};  ///< convex: in half widths from `a`
  std::uint32_t count = 0;              ///< convex: corners used (3 or 4)
  /// In the chart, holding the chart coordinates of every ground point it covers.
  std::array<glm::dvec2, 2> box{glm::dvec2(0.0), glm::dvec2(0.0)};
};

/// A layer's per-pixel lookup: its index in each chart it is drawn in, with the boxes (frame
/// coordinates, 3D) holding every ground point the index can colour.
class DeferredLayer {
 public:
  /// What a frame gives of a layer in one chart.
  struct Part {
    DeferredChart chart;
    /// One per feature of the layer (its index in the layer: what the colours are per): its
    /// polygons in chart coordinates (even-odd over each polygon's rings, a union over the
    /// feature's polygons, as the CPU reference draws them), or none.
    std::vector<geo::Feature> features;
    /// Or (a frame's lines in space, WorldLinePrimitive): the primitives that reach the chart; the
    /// part is then a line layer's, `features` unused.
    std::vector<WorldLinePrimitive> worldLines;
    /// Lines in space, per feature: its rule for lines in pixels (widthPixels / 2, the least and
    /// the largest half width in metres), or none (0, widths in metres); missing: none.
    std::vector<glm::dvec3> lineWidths;
    /// Lines in pixels are binned at most this wide (half width, metres; wider ones are drawn
    /// this wide): what their chart boxes were grown by.
    double maxReach = std::numeric_limits<double>::infinity();
    /// Where ground points can be, in chart coordinates (min, max): the index covers no more.
    std::array<glm::dvec2, 2> region{glm::dvec2(0.0), glm::dvec2(0.0)};
    /// The ground's heights there (the cover boxes' bottom and top).
    double lowest = -1e4, highest = 1e4;
    /// Lines in space: the heights (±, above the ellipsoid) of the ground a leaf's content is
    /// decided for (deferred::BuildOptions::heightRange); negative: the larger of |lowest| and
    /// |highest|.
    double heightRange = -1.0;
  };

  DeferredLayer();
  ~DeferredLayer();
  DeferredLayer(DeferredLayer&&) noexcept;
  DeferredLayer& operator=(DeferredLayer&&) noexcept;

  /// A layer's index in each part's chart (colours per feature, straight alpha): its polygons, or
  /// its lines in space (Part::worldLines). The projected frame's technique builds its lines'
  /// indices itself (deferred_technique.cpp).
  static DeferredLayer build(std::span<const Part> parts, std::span<const glm::vec4> colors);

  [[nodiscard]] bool empty() const;
  /// Bytes of its indices (what the pass uploads).
  [[nodiscard]] std::size_t bytes() const;
  /// Which build this is: no other layer of the process has it (the pass's arena is keyed by it).
  [[nodiscard]] std::uint64_t serial() const;

  struct Impl;
  [[nodiscard]] const Impl& impl() const { return *impl_; }
  explicit DeferredLayer(std::unique_ptr<Impl> impl);

 private:
  std::unique_ptr<Impl> impl_;
};

/// The lookup's pass (overlay_deferred.frag): every layer in one pass over the screen rectangles
/// its cover boxes project to, each pixel (each sample with MSAA) reading the depth of the bound
/// target's terrain, finding its ground point in each layer's index of the chart it lies in, and
/// taking the first covering feature's colour, the layers composited in order; the mask gets each
/// covering layer's bit.
class DeferredPass {
 public:
  /// Needs a current GL 4.5 context.
  static Result<DeferredPass> create();
  DeferredPass(DeferredPass&&) noexcept;
  DeferredPass& operator=(DeferredPass&&) noexcept;
  ~DeferredPass();

  /// Draws layers[i] with mask bit i (a null entry is hidden); `stats[i]` gets what it did (the
  /// first drawn layer holds the pass's counts and times when `measure`).
  void draw(gfx::StateCache& cache, const DrawTarget& target, const OverlayView& view,
            std::span<const DeferredLayer* const> layers, bool measure, std::vector<LayerFrameStats>& stats);
  /// GPU bytes: the layers' arena and the depth copy.
  [[nodiscard]] std::size_t gpuBytes() const;

  struct State;

 private:
  explicit DeferredPass(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace gis::overlay
