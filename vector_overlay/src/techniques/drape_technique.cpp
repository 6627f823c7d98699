// Texture draping, the baseline of other GIS viewers (osgEarth, MapLibre, deck.gl): the layers
// rasterised once into one texture over the terrain's extent, sampled by the terrain shader
// (TextureDrape). Rasterised again at the next frame after any change.
#include <array>

#include "techniques/techniques.hpp"

namespace gis::overlay {
namespace {

class SingleDrape final : public OverlayTechnique {
 public:
  SingleDrape(const DrapeExtent& extent, int size) : extent_(extent), size_(size) {}

  std::optional<SurfaceDrape> prepareFrame(gfx::StateCache& cache, const TechniqueFrame& frame,
                                           TechniqueFrameStats& stats) override {
    if (dirty_ || !drape_) {
      const FootprintDrapeSource footprints(frame.layers);
      Result<TextureDrape> built =
          TextureDrape::build(cache, frame.drapeSource ? *frame.drapeSource : footprints, extent_, size_);
      drape_.reset();
      if (built) drape_ = std::move(*built);
      dirty_ = false;
      stats.texturesBuilt = drape_ ? 1 : 0;
      stats.textureSeconds = drape_ ? drape_->stats().buildSeconds : 0.0;
    }
    if (!drape_) return std::nullopt;
    SurfaceDrape d;
    d.color = drape_->colorTexture();
    d.mask = drape_->maskTexture();
    d.origin = drape_->extent().origin;
    d.size = drape_->extent().size;
    return d;
  }

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    (void)cache;
    (void)frame;
    (void)stats;
  }

  void invalidate() override { dirty_ = true; }
  [[nodiscard]] std::size_t gpuBytes() const override { return drape_ ? drape_->stats().gpuBytes : 0; }
  [[nodiscard]] const TextureDrape* textureDrape() const override { return drape_ ? &*drape_ : nullptr; }

 private:
  DrapeExtent extent_;
  int size_ = 2048;
  std::optional<TextureDrape> drape_;
  bool dirty_ = true;
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  result.value = std::make_unique<SingleDrape>(options.extent, options.textureSize > 0 ? options.textureSize : 2048);
  return result;
}

constexpr std::array kSizes{512, 1024, 2048, 4096, 8192};

}  // namespace

const TechniqueInfo kDrapeTechnique{
    "drape",
    "texture draping",
    "the layers rasterised into one N x N texture over the terrain (the baseline of other viewers)",
    "#d62728",
    PieceConstruction::Ours,
    2048,
    kSizes,
    &create};

}  // namespace gis::overlay
