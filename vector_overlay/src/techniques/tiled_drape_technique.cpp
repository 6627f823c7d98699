// Draping per quadtree tile, as osgEarth and iTowns do (TiledDrape): a texture per drawn terrain
// tile, rasterised when the tile is first drawn and kept while it is in use.
#include <array>
#include <unordered_map>

#include "techniques/techniques.hpp"

namespace gis::overlay {
namespace {

class PerTileDrape final : public OverlayTechnique {
 public:
  explicit PerTileDrape(TiledDrape tiles) : tiles_(std::move(tiles)) {}

  std::optional<SurfaceDrape> prepareFrame(gfx::StateCache& cache, const TechniqueFrame& frame,
                                           TechniqueFrameStats& stats) override {
    if (dirty_) tiles_.invalidate();
    dirty_ = false;
    tiles_.beginFrame(frame.tiles.size());
    TiledDrape::FrameStats tileStats;
    frameTiles_.clear();
    const FootprintDrapeSource footprints(frame.layers);
    const DrapeSource& source = frame.drapeSource ? *frame.drapeSource : footprints;
    for (const DrawnTile& t : frame.tiles) {
      frameTiles_[t.key] = tiles_.tile(cache, source, t.key, DrapeExtent{t.lo, t.hi - t.lo}, tileStats);
    }
    stats.texturesBuilt = tileStats.tilesBuilt;
    stats.textureSeconds = tileStats.buildSeconds;
    SurfaceDrape d;
    d.colorArray = tiles_.colorArray();
    d.maskArray = tiles_.maskArray();
    d.tileOf = [this](std::uint64_t key) -> std::optional<std::tuple<int, glm::dvec2, glm::dvec2>> {
      const auto found = frameTiles_.find(key);
      if (found == frameTiles_.end()) return std::nullopt;
      return std::tuple{found->second.layer, found->second.extent.origin, found->second.extent.size};
    };
    return d;
  }

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    (void)cache;
    (void)frame;
    (void)stats;
  }

  void invalidate() override { dirty_ = true; }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override { tiles_.invalidate(lo, hi); }
  [[nodiscard]] std::size_t gpuBytes() const override { return tiles_.gpuBytes(); }

 private:
  TiledDrape tiles_;
  std::unordered_map<std::uint64_t, TiledDrape::Tile> frameTiles_;  ///< this frame's, per terrain tile
  bool dirty_ = false;
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  Result<TiledDrape> tiles = TiledDrape::create(options.textureSize > 0 ? options.textureSize : 256);
  result.diagnostics = std::move(tiles.diagnostics);
  if (tiles) result.value = std::make_unique<PerTileDrape>(std::move(*tiles));
  return result;
}

constexpr std::array kSizes{128, 256, 512, 1024};

}  // namespace

const TechniqueInfo kTiledDrapeTechnique{"drape-tiles",
                                         "per tile",
                                         "an N x N texture per drawn terrain tile, as osgEarth and iTowns drape",
                                         "#9467bd",
                                         PieceConstruction::Ours,
                                         256,
                                         kSizes,
                                         &create};

}  // namespace gis::overlay
