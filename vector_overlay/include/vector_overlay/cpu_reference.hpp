#pragma once
// The CPU reference (DESIGN §7): from a depth buffer and the camera that made it, which layers
// cover each pixel's terrain point, following the coverage rules of footprints.hpp exactly
// (point in polygon with the even-odd rule; distance to segments with the same joins and caps,
// arcs exact). It is the ground truth of the GL tests, the error metric of the benchmark and
// the engine of picking. Simple and obviously right first; a grid index keeps it usable.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "geo/vector.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay {

/// A depth buffer and the camera that produced it.
struct DepthImage {
  int width = 0;
  int height = 0;
  /// width × height depths, row 0 = the TOP row of the image (as gfx::readDepth returns them),
  /// reversed-Z (GL_ZERO_TO_ONE, infinite far plane): 0 = background (nothing drawn).
  std::span<const float> depth;
  /// Frame coordinates → clip space, exactly the matrix the image was drawn with (double).
  glm::dmat4 viewProj{1.0};
};

/// Frame coordinates of the terrain point seen through the centre of pixel (x, y) (x from the
/// left, y from the top row), or nullopt for background.
std::optional<glm::dvec3> unprojectPixel(const DepthImage& image, int x, int y);

/// A layer as the reference sees it: its features and how they are drawn.
struct ReferenceLayer {
  std::string name;
  LayerKind kind = LayerKind::Polygon;
  const std::vector<geo::Feature>* features = nullptr;
  /// Per feature: its line shape (lines; empty for polygon layers) and whether it is shown
  /// (empty = all shown).
  std::vector<LineShape> shapes;
  std::vector<bool> visible;
};

/// Per pixel (row 0 = top), bit i set when layer i (i < 32) covers the pixel's terrain point.
std::vector<std::uint32_t> referenceMask(const DepthImage& image, std::span<const ReferenceLayer> layers);

/// Per pixel, 1 where the pixel's footprint straddles a feature edge: the mask bits at the
/// pixel centre differ from those at some point of the pixel's square (its corners and edge
/// midpoints, unprojected on the plane through the centre point with the surface's local
/// orientation from neighbouring depths). Such pixels may legitimately differ between the GPU
/// and the reference; every other pixel must agree exactly.
std::vector<std::uint8_t> edgePixels(const DepthImage& image, std::span<const ReferenceLayer> layers);

struct PickedFeature {
  std::size_t layer = 0;
  std::size_t feature = 0;  ///< index in the layer's features
};

/// The features under pixel (x, y), in layer order then feature order; empty on background.
std::vector<PickedFeature> pick(const DepthImage& image, std::span<const ReferenceLayer> layers, int x, int y);

/// Whether a layer covers a frame point (x, y) (the rules above); the index of the first
/// covering feature, if any.
std::optional<std::size_t> coveringFeature(const ReferenceLayer& layer, const glm::dvec2& point);

}  // namespace gis::overlay
