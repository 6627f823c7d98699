// `auto`: per view, the cheaper of the two exact techniques, chosen from measured costs. Our
// stencil polyhedra in view tiles (stencil-tiles) draw the first layers and the deferred
// per-pixel lookup the last ones, from a split point k; both are exact, so any k gives the same
// mask, and the colours keep the draw order because the stencil layers all come first.
//
// The rule:
// - The candidates are k = n (every layer by the stencil polyhedra) and the smallest k such that
//   the deferred technique can draw every visible layer from k on (DeferredLookup::canDraw: its
//   index fits a quarter of the GPU budget, and lines in pixels keep within one of its reach
//   classes in this view: 8 m × 2^c up to 32 km, an index per class made when a view needs it).
//   With no such k below n, there is nothing to choose.
// - Which of the two draws a frame: the plan chooser both frames share (plan_chooser.hpp: their
//   measured GPU times, the dearer measured again one frame in 24).
// `deferred` is the same split without the choice: the lookup draws every layer from k on, and
// the stencil polyhedra in view tiles the layers before k (those it cannot draw exactly in this
// view or within its budget), as on the globe.
#include <algorithm>
#include <array>
#include <optional>

#include "techniques/techniques.hpp"
#include "vector_overlay/deferred_lookup.hpp"
#include "vector_overlay/plan_chooser.hpp"

namespace gis::overlay {
namespace {

class AutoTechnique final : public OverlayTechnique {
 public:
  /// `choose`: `auto` (the chooser takes the plan); else `deferred` (the lookup wherever it can).
  AutoTechnique(std::unique_ptr<OverlayTechnique> stencil, std::unique_ptr<DeferredLookup> deferred,
                std::size_t gpuBudget, bool choose)
      : stencil_(std::move(stencil)), deferred_(std::move(deferred)), indexBudget_(gpuBudget / 4), choose_(choose) {}

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    const std::size_t n = frame.layers.size();
    // The smallest k from which the deferred technique can draw every visible layer.
    std::size_t split = n;
    while (split > 0) {
      const OverlayLayer* layer = frame.layers[split - 1];
      if (layer != nullptr && !deferred_->canDraw(*layer, frame.view, frame.target.height, indexBudget_)) break;
      --split;
    }
    const bool anyDeferred = std::any_of(frame.layers.begin() + static_cast<std::ptrdiff_t>(split), frame.layers.end(),
                                         [](const OverlayLayer* l) { return l != nullptr; });
    if (!anyDeferred) split = n;
    // 0: all stencil; 1: deferred from `split` on.
    const int plan = choose_ ? chooser_.choose(split < n) : (split < n ? 1 : 0);
    lastSplit_ = plan == 1 ? split : n;

    std::vector<const OverlayLayer*> first(frame.layers.begin(), frame.layers.end());
    std::vector<const OverlayLayer*> second(n, nullptr);
    for (std::size_t i = lastSplit_; i < n; ++i) std::swap(first[i], second[i]);
    TechniqueFrame part = frame;
    // Measured passes time themselves (one timer query may run at a time).
    const bool ownTimer = choose_ && !frame.settings.measure;
    if (ownTimer) chooser_.begin(plan);
    part.layers = first;
    stencil_->draw(cache, part, stats);
    if (plan == 1) {
      TechniqueFrameStats deferredStats;
      part.layers = second;
      deferred_->draw(cache, part, deferredStats);
      stats.layers.resize(n);
      for (std::size_t i = lastSplit_; i < n && i < deferredStats.layers.size(); ++i) {
        stats.layers[i] = deferredStats.layers[i];
        stats.deferredLayers += frame.layers[i] != nullptr ? 1U : 0U;
      }
    }
    stats.deferredBytes = deferred_->gpuBytes();  // its indices stay built whichever plan drew
    if (ownTimer) {
      chooser_.end();
    } else if (choose_) {
      double ms = 0.0;
      for (const LayerFrameStats& s : stats.layers) ms += s.gpuMilliseconds;
      chooser_.record(plan, ms);
    }
  }

  [[nodiscard]] std::vector<const OverlayLayer*> drawnChunks(std::size_t layer) const override {
    // Layers drawn by the deferred technique have no pieces.
    return layer < lastSplit_ ? stencil_->drawnChunks(layer) : std::vector<const OverlayLayer*>{};
  }
  void invalidate() override {
    stencil_->invalidate();
    deferred_->invalidate();
  }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override {
    stencil_->invalidate(lo, hi);
    deferred_->invalidate(lo, hi);
  }
  void stopReading() override {
    stencil_->stopReading();
    deferred_->stopReading();
  }
  void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) override {
    stencil_->featureChanged(layer, feature, lo, hi);
    deferred_->featureChanged(layer, feature, lo, hi);
  }
  [[nodiscard]] std::size_t gpuBytes() const override { return stencil_->gpuBytes() + deferred_->gpuBytes(); }
  [[nodiscard]] Diagnostics drawDiagnostics() const override { return stencil_->drawDiagnostics(); }

 private:
  std::unique_ptr<OverlayTechnique> stencil_;
  std::unique_ptr<DeferredLookup> deferred_;
  std::size_t indexBudget_;
  bool choose_;
  PlanChooser chooser_;
  std::size_t lastSplit_ = 0;
};

Result<std::unique_ptr<OverlayTechnique>> make(const TechniqueOptions& options, bool choose) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  Result<std::unique_ptr<OverlayTechnique>> stencil = kTiledStencilTechnique.create(options);
  Result<std::unique_ptr<DeferredLookup>> deferred = createDeferredLookup(options, ReachClasses::kBaseReach);
  result.diagnostics = std::move(stencil.diagnostics);
  result.diagnostics.append(deferred.diagnostics);
  if (!stencil || !deferred) return result;
  result.value =
      std::make_unique<AutoTechnique>(std::move(*stencil), std::move(*deferred), options.tiling.gpuBudgetBytes, choose);
  return result;
}

Result<std::unique_ptr<OverlayTechnique>> createAuto(const TechniqueOptions& options) { return make(options, true); }
Result<std::unique_ptr<OverlayTechnique>> createDeferred(const TechniqueOptions& options) {
  return make(options, false);
}

}  // namespace

const TechniqueInfo kAutoTechnique{
    "auto",
    "auto (cheaper of the two)",
    "per view, stencil-tiles or the deferred lookup for the last layers, whichever measured cheaper",
    "#17becf",
    PieceConstruction::Tiled,
    0,
    {},
    &createAuto};

const TechniqueInfo kDeferredTechnique{
    "deferred",
    "deferred per-pixel lookup",
    "per pixel, the ground point from the depth buffer tested against a quadtree of the layer's edges and lines; "
    "the layers it cannot draw in a view by their pieces in view tiles",
    "#8c564b",
    PieceConstruction::Tiled,
    0,
    {},
    &createDeferred,
    true};

}  // namespace gis::overlay
