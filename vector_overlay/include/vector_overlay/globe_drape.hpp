#pragma once
// The globe's side of texture draping (docs/globe.md, "Draping"): its layers as the drape of both
// frames rasterises them (overlay::DrapeSource), in longitude and latitude. The globe's terrain
// tiles are linear in both (tile.hpp), so a texture over a tile's box, or over the data's, is
// sampled by the terrain as a projected chunk samples its own.
#include <cstdint>
#include <vector>

#include "vector_overlay/footprints.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/texture_drape.hpp"

namespace gis::globe {

/// The level whose tolerance (simplifyTolerance) is within an eighth of a texel `texelDegrees`
/// (degrees of latitude): what a drape's texel takes the areas' rings and the lines' shapes at.
/// A tile's own texture of 256² texels takes its own level.
int drapeLevel(double texelDegrees);

/// `layers` (layer i writes mask bit i; null entries draw nothing) as a drape draws them:
/// - the areas that meet the box: their rings at drapeLevel, generalised together
///   (GlobeLayer::areasIn: shared borders stay shared), triangulated even-odd in the plane of
///   longitude and latitude (overlay::evenOddFootprint);
/// - the lines: the shapes (lineShapesIn) of the level's tiles that meet the box, lines in pixels
///   as wide as widthPixels texels (within their least and largest widths: a texture cannot
///   follow the view);
/// each where it meets the box, also a turn east or west (shapes across ±180° are unwrapped).
/// Straight in longitude and latitude between the rings' points, which are densified along
/// geodesics (GlobeLayer::build): the edges differ from the reference's by less than a texel.
class GlobeDrapeSource final : public overlay::DrapeSource {
 public:
  explicit GlobeDrapeSource(std::vector<const GlobeLayer*> layers) : layers_(std::move(layers)) {}

  [[nodiscard]] std::size_t layerCount() const override { return layers_.size(); }
  void triangles(std::size_t layer, const glm::dvec2& lo, const glm::dvec2& hi, const glm::dvec2& texel,
                 const TriangleSink& emit) const override;

  /// The layers drawn (in order).
  [[nodiscard]] const std::vector<const GlobeLayer*>& layers() const { return layers_; }

 private:
  std::vector<const GlobeLayer*> layers_;
};

}  // namespace gis::globe
