#pragma once
// The CPU reference (docs/design.md §7): from a depth buffer and the camera that made it, which layers
// cover each pixel's terrain point, following the coverage rules of footprints.hpp exactly
// (point in polygon with the even-odd rule; distance to segments with the same joins and caps,
// arcs exact). It is the ground truth of the GL tests, the error metric of the benchmark and
// the engine of picking. Simple and obviously right first; a grid index keeps it usable.
// Independent of the GPU code and of the footprint construction (it never builds footprints).
// Precisely:
// - a polygon layer uses its features' `polygons` (a line layer their `lines`; the other kind of
//   geometry is ignored); a polygon covers the points inside an odd number of its rings (raw
//   rings: orientation, repeated points and self-intersections need no repair), a feature the
//   union of its polygons. A polygon whose outer ring has no area (fewer than 3 distinct points,
//   or all points exactly on one line) or that has a non-finite coordinate or one beyond 1e15 m
//   is skipped, holes included;
// - a line feature covers the union of the rectangles, joins and caps of footprints.hpp after
//   dropping consecutive repeated points (a line with a non-finite point, or one beyond 1e15 m,
//   covers nothing; so does a width that is not positive, finite and at most 1e15 m);
//   "nothing on a straight continuation" holds for every join, round included, and means the
//   three points are exactly collinear (exact orientation predicate on the double coordinates)
//   and the line goes on forward; a full reversal gets a disc (round) or nothing (bevel, and
//   miter whose length is then infinite);
// - lines in pixels (LineShape::widthPixels) get each vertex's half width from the camera of
//   the depth image (pixelScaleOf with the image's height): segments become trapezoids, joins
//   and caps take their vertex's half width.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "geo/feature.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay {

/// A depth buffer and the camera that produced it.
struct DepthImage {
  int width = 0;
  int height = 0;
  /// width × height depths, row 0 = the TOP row of the image (as gfx::readDepth returns them),
  /// reversed-Z (GL_ZERO_TO_ONE, infinite far plane): 0 = background (nothing drawn; so is any
  /// value that is not a positive number). A span of another size is a caller error (asserted;
  /// empty results in release builds).
  std::span<const float> depth;
  /// World coordinates minus `origin` → clip space, exactly the matrix the image was drawn with
  /// (double).
  glm::dmat4 viewProj{1.0};
  /// Subtracted from world points before viewProj: 0 in a projected frame (frame coordinates);
  /// the eye on the globe, which draws relative to it (ECEF; viewProj is then eye-relative).
  glm::dvec3 origin{0.0};
};

/// Frame coordinates of the terrain point seen through the centre of pixel (x, y) (x from the
/// left, y from the top row), or nullopt for background or a pixel outside the image. The
/// centre's NDC is (2(x + 0.5)/width − 1, 1 − 2(y + 0.5)/height, depth), mapped back through
/// the inverse of viewProj in double. Float depth limits the precision to about 2^-24 of the
/// distance from the eye.
std::optional<glm::dvec3> unprojectPixel(const DepthImage& image, int x, int y);

/// The world point a depth sample (reversed-Z, as stored) shows through the centre of pixel
/// (x, y) of the image's camera (its size, viewProj and origin; its depth values are not read):
/// what unprojectPixel does with a depth read elsewhere (the viewer's cursor). Nothing for
/// background (a depth that is not positive) or a point at infinity.
std::optional<glm::dvec3> unprojectDepth(const DepthImage& camera, int x, int y, float depth);

/// Calls visit(i, point) for every pixel i (row 0 = top, i = row · width + column) that shows
/// ground, with its world point (unprojectPixel).
void forEachGroundPixel(const DepthImage& image, const std::function<void(std::size_t, const glm::dvec3&)>& visit);

/// What the reference asks of a frame's layers, in any frame: the one seam between the reference's
/// per-pixel core (referenceMask, edgePixels) and a frame's coverage rules. The projected frame
/// answers in its plane from ReferenceLayers (planeLayersOf), the globe on the ellipsoid
/// (globe::referenceLayersOf).
class FrameLayers {
 public:
  virtual ~FrameLayers() = default;
  FrameLayers() = default;
  FrameLayers(const FrameLayers&) = delete;
  FrameLayers& operator=(const FrameLayers&) = delete;
  /// The layers' mask bits at a world point (bit i: layer i covers it; i < 32).
  [[nodiscard]] virtual std::uint32_t bits(const glm::dvec3& world) const = 0;
  /// Whether the bits may not be the same all over a pixel's footprint (its corner probes on the
  /// ground, in order round it) whose centre has `centreBits` (true where unsure).
  [[nodiscard]] virtual bool straddles(const std::array<glm::dvec3, 4>& footprint, std::uint32_t centreBits) const = 0;
};
/// Makes a frame's layers for the world box [lo, hi] that every point the reference will ask
/// about lies in (an index need hold only what reaches it).
using FrameLayersMaker = std::function<std::unique_ptr<FrameLayers>(const glm::dvec3& lo, const glm::dvec3& hi)>;

/// Per pixel (row 0 = top), the bits of the layers `make` gives at the pixel's ground point
/// (unprojectPixel); 0 on background, empty for an image that is not valid.
std::vector<std::uint32_t> referenceMask(const DepthImage& image, const FrameLayersMaker& make);

/// Per pixel, 1 where the mask differs within its 3 × 3 neighbourhood or ground meets background
/// there: the edge band a mask alone shows (a selection's, or the start of a layer's).
std::vector<std::uint8_t> maskEdges(std::span<const std::uint32_t> mask, const DepthImage& image);

/// A layer as the reference sees it: its features and how they are drawn.
struct ReferenceLayer {
  std::string name;
  LayerKind kind = LayerKind::Polygon;
  const std::vector<geo::Feature>* features = nullptr;
  /// Per feature: its line shape (lines; empty for polygon layers) and whether it is shown
  /// (empty = all shown). A feature beyond the end of `shapes` is drawn with LineShape{}, beyond
  /// the end of `visible` shown. A shape whose width is not positive and finite draws nothing.
  std::vector<LineShape> shapes;
  std::vector<bool> visible;
};

/// The projected frame's layers as the reference asks them (FrameLayers): indexed over the
/// region it is given, in the frame's plane, lines in pixels at `scale`. The layers must outlive
/// what the maker makes.
FrameLayersMaker planeLayersOf(std::span<const ReferenceLayer> layers, const PixelScale& scale);

/// Per pixel (row 0 = top), bit i set when layer i (i < 32) covers the pixel's terrain point;
/// layers from the 33rd on are ignored. 0 on background. (referenceMask of planeLayersOf at the
/// image's pixel scale.)
std::vector<std::uint32_t> referenceMask(const DepthImage& image, std::span<const ReferenceLayer> layers);

/// Per pixel, 1 where the pixel's footprint straddles a feature edge: the mask bits at the
/// pixel centre differ from those at some point of the pixel's square (its corners and edge
/// midpoints, unprojected on the plane through the centre point with the surface's local
/// orientation from neighbouring depths). Such pixels may legitimately differ between the GPU
/// and the reference; every other pixel must agree exactly. Precisely, a pixel is an edge pixel
/// when
/// - it touches a depth discontinuity: it or one of its 8 neighbours is background and the
///   other not, or the window-depth step to that neighbour exceeds 4 times the smaller of the
///   steps just beyond the pair on the same line (plus 1e-5 of the depth): the GPU may see
///   other terrain there; or
/// - a probe ray misses the local plane in front of the eye (the square reaches over the
///   plane's horizon); or
/// - the mask bits at one of the 8 probe points differ from those at the centre; or
/// - (for features narrower than the probe spacing) the footprint, the quadrilateral of the 4
///   corner probes, meets a piece of a layer that does not cover the centre (exact), or, for a
///   layer that covers the centre, no single piece of it contains the footprint and a 9 × 9
///   sampling of the footprint finds a point it does not cover.
/// Not included: the chord tolerance of drawn arcs (footprints.hpp): pixels must be much larger
/// than it for the GPU to agree exactly elsewhere.
std::vector<std::uint8_t> edgePixels(const DepthImage& image, std::span<const ReferenceLayer> layers);

/// The edge band of the layers `make` gives, in any frame: the rules of edgePixels above (depth
/// discontinuities, probes beyond the local plane's horizon, probes whose bits differ from the
/// centre's, footprints the layers straddle). The edgePixels above is this with planeLayersOf.
std::vector<std::uint8_t> edgePixels(const DepthImage& image, const FrameLayersMaker& make);

struct PickedFeature {
  std::size_t layer = 0;
  std::size_t feature = 0;  ///< index in the layer's features
};

/// The features under pixel (x, y), in layer order then feature order (every covering feature
/// of every layer, the 33rd layer on included); empty on background.
std::vector<PickedFeature> pick(const DepthImage& image, std::span<const ReferenceLayer> layers, int x, int y);

/// Whether feature `i` of the layer covers a frame point (x, y) by the rules above (false when
/// it is hidden). Lines in pixels take their widths from `scale`.
bool featureCovers(const ReferenceLayer& layer, std::size_t i, const glm::dvec2& point, const PixelScale& scale = {});

/// Whether a layer covers a frame point (x, y) (the rules above); the index of the first
/// visible covering feature, if any. Unindexed: evaluates every feature. Lines in pixels take
/// their widths from `scale` (with the default, zero scale they have no width).
std::optional<std::size_t> coveringFeature(const ReferenceLayer& layer, const glm::dvec2& point,
                                           const PixelScale& scale = {});

}  // namespace gis::overlay
