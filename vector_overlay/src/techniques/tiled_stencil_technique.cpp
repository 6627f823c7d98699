// Our stencil polyhedra in view-dependent tiles (tiled_layer.hpp): per layer a LayerTiling, whose
// tiles the residency of both frames (tile_residency.hpp) builds on worker threads and keeps on
// the GPU under a budget, with flights and stills; edits update one feature in the resident
// tiles. Nothing is built for the whole dataset: the layers come with their features only
// (PieceConstruction::Tiled).
#include <algorithm>
#include <memory>
#include <optional>
#include <vector>

#include "techniques/techniques.hpp"
#include "vector_overlay/tile_residency.hpp"

namespace gis::overlay {
namespace {

class TiledStencil final : public OverlayTechnique {
 public:
  TiledStencil(OverlayRenderer renderer, const TechniqueOptions& options)
      : renderer_(std::move(renderer)),
        bounds_(options.bounds),
        build_(options.build),
        tiling_(options.tiling),
        residency_(renderer_, options.tiling) {}
  ~TiledStencil() override { residency_.cancel(); }

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    if (layers_.size() != frame.layers.size()) {
      residency_.cancel();  // a job of a layer that leaves would read its tiling
      layers_.resize(frame.layers.size());
    }
    for (std::size_t i = 0; i < frame.layers.size(); ++i) {
      const OverlayLayer* layer = frame.layers[i];
      if (layer == nullptr || layers_[i].source == layer) continue;
      // Another layer in this place: its tiles are stale.
      residency_.clear();
      lastChunks_.clear();
      for (auto& l : layers_) l.source = nullptr, l.tiling.reset();
      break;
    }
    std::vector<const TileSource*> sources(frame.layers.size(), nullptr);
    for (std::size_t i = 0; i < frame.layers.size(); ++i) {
      const OverlayLayer* layer = frame.layers[i];
      if (layer == nullptr) continue;
      if (!layers_[i].tiling) {
        layers_[i].source = layer;
        if (bounds_ == nullptr) continue;
        layers_[i].tiling = std::make_unique<LayerTiling>(layer->geometry(), *bounds_, build_, tiling_);
      }
      sources[i] = layers_[i].tiling.get();
    }
    std::vector<std::vector<const OverlayLayer*>> chunks = residency_.frame(frame, sources, stats);
    stats.layers = renderer_.draw(cache, frame.view, chunks, frame.settings);
    lastChunks_ = std::move(chunks);
  }

  [[nodiscard]] std::vector<const OverlayLayer*> drawnChunks(std::size_t layer) const override {
    return layer < lastChunks_.size() ? lastChunks_[layer] : std::vector<const OverlayLayer*>{};
  }
  void invalidate() override {
    residency_.clear();
    lastChunks_.clear();
  }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override {
    residency_.cancel();
    lastChunks_.clear();
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      auto* tiles = residency_.tiles(i);
      if (!layers_[i].tiling || tiles == nullptr) continue;
      for (auto it = tiles->begin(); it != tiles->end();) {
        auto [tileLo, tileHi] = layers_[i].tiling->extent(it->second.key);
        // Lines drawn wider than in metres reach beyond the tile by up to their class's width.
        const double grow = it->second.key.width > 0 ? widthClassCap(it->second.key.width) : 0.0;
        tileLo -= grow;
        tileHi += grow;
        const bool meets = !(hi.x < tileLo.x || hi.y < tileLo.y || lo.x > tileHi.x || lo.y > tileHi.y);
        it = meets ? tiles->erase(it) : std::next(it);
      }
    }
  }
  void stopReading() override { residency_.cancel(); }
  void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) override {
    // Only the feature, in each resident tile that has it or that it reaches now: one feature's
    // pieces rebuilt per tile, not the tiles.
    residency_.cancel();
    auto* tiles = residency_.tiles(layer);
    if (layer >= layers_.size() || !layers_[layer].tiling || tiles == nullptr) return invalidate(lo, hi);
    LayerTiling& tiling = *layers_[layer].tiling;
    const auto index = static_cast<std::uint32_t>(feature);
    tiling.update(index);
    for (auto it = tiles->begin(); it != tiles->end();) {
      TileResidency::Resident& t = it->second;
      const FeatureStyle style = tiling.tileStyle(t.key, index);
      std::optional<geo::Feature> g = tiling.featureFor(t.key, index);
      const auto local = std::find(t.featureIndex.begin(), t.featureIndex.end(), index);
      // A tile with nothing yet, or one whose thin lines are drawn as rectangles only, is built
      // again when the feature reaches it (a wide line would need its joins).
      const bool holds = local != t.featureIndex.end();
      const bool rebuild =
          (g || holds) &&
          (!t.layer || t.layer->geometry().arraysReleased() ||
           (g && t.layer->geometry().options().footprints.segmentsOnly && tiling.widestReach() > 0.25 * t.error));
      if (rebuild) {
        it = tiles->erase(it);
        continue;
      }
      if (local != t.featureIndex.end()) {
        const auto at = static_cast<std::size_t>(local - t.featureIndex.begin());
        if (g) {
          residency_.reportOnce(t.layer->setFeature(at, std::move(*g), style));
        } else {
          t.layer->removeFeature(at);
        }
      } else if (g) {
        residency_.reportOnce(t.layer->setFeature(t.layer->sharedFeatures().size(), std::move(*g), style));
        t.featureIndex.push_back(index);
      }
      ++it;
    }
  }
  [[nodiscard]] std::size_t gpuBytes() const override { return residency_.gpuBytes(); }
  [[nodiscard]] Diagnostics drawDiagnostics() const override { return residency_.said(); }

 private:
  struct LayerState {
    const OverlayLayer* source = nullptr;
    std::unique_ptr<LayerTiling> tiling;
  };

  OverlayRenderer renderer_;
  const HeightBoundsProvider* bounds_;
  LayerBuildOptions build_;
  TilingOptions tiling_;
  std::vector<LayerState> layers_;
  std::vector<std::vector<const OverlayLayer*>> lastChunks_;  ///< per layer, as last drawn
  TileResidency residency_;                                   // last: stopped first
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  if (options.bounds == nullptr) {
    result.diagnostics.add({Severity::Error, "", "", "",
                            "the technique stencil-tiles builds its pieces per tile and needs the terrain's height "
                            "bounds (TechniqueOptions::bounds)"});
    return result;
  }
  Result<OverlayRenderer> renderer = OverlayRenderer::create();
  result.diagnostics = std::move(renderer.diagnostics);
  if (renderer) result.value = std::make_unique<TiledStencil>(std::move(*renderer), options);
  return result;
}

}  // namespace

const TechniqueInfo kTiledStencilTechnique{
    "stencil-tiles",
    "stencil polyhedra in view tiles",
    "our stencil polyhedra, built per view-dependent tile on worker threads (generalised within 0.5 px)",
    "#2ca02c",
    PieceConstruction::Tiled,
    0,
    {},
    &create};

}  // namespace gis::overlay
