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
// - Each candidate's cost is its GPU time (a timer query around its passes, read a few frames
//   later without waiting; with OverlaySettings::measure, the passes' own timers), averaged over
//   its last measurements (each new one weighs half).
// - The stencil polyhedra draw first; the deferred candidate draws the next frame to be measured;
//   then the cheaper one draws and the other is measured again every kProbeEvery frames. (Probing
//   sooner after the camera moves, every 6 frames, made the flights on Olinda 1.2× slower on
//   llvmpipe: each probe of the dearer candidate costs a whole frame.)
#include <algorithm>
#include <array>
#include <deque>
#include <optional>

#include "gfx/queries.hpp"
#include "techniques/techniques.hpp"

namespace gis::overlay {
namespace {

constexpr int kProbeEvery = 24;
constexpr double kBaseReach = 8.0;  ///< metres: the narrowest reach class of lines in pixels

class AutoTechnique final : public OverlayTechnique {
 public:
  AutoTechnique(std::unique_ptr<OverlayTechnique> stencil, std::unique_ptr<DeferredLookup> deferred,
                std::size_t gpuBudget)
      : stencil_(std::move(stencil)), deferred_(std::move(deferred)), indexBudget_(gpuBudget / 4) {}

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    harvest();
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
    ++frameNumber_;
    // 0: all stencil; 1: deferred from `split` on.
    int plan = 0;
    if (split < n) {
      if (!cost_[0] || !cost_[1]) {
        plan = cost_[0] && !probedAt_[1] ? 1 : 0;
      } else {
        const int cheaper = *cost_[1] < *cost_[0] ? 1 : 0;
        const int other = 1 - cheaper;
        const std::uint64_t last = probedAt_[static_cast<std::size_t>(other)].value_or(0);
        plan = frameNumber_ - last >= static_cast<std::uint64_t>(kProbeEvery) ? other : cheaper;
      }
      probedAt_[static_cast<std::size_t>(plan)] = frameNumber_;
    }
    lastSplit_ = plan == 1 ? split : n;

    std::vector<const OverlayLayer*> first(frame.layers.begin(), frame.layers.end());
    std::vector<const OverlayLayer*> second(n, nullptr);
    for (std::size_t i = lastSplit_; i < n; ++i) std::swap(first[i], second[i]);
    TechniqueFrame part = frame;
    // Measured passes time themselves (one timer query may run at a time).
    const bool ownTimer = !frame.settings.measure;
    Timing timing;
    timing.plan = plan;
    if (ownTimer) timing.timer.begin();
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
    if (ownTimer) {
      timing.timer.end();
      timings_.push_back(std::move(timing));
    } else {
      double ms = 0.0;
      for (const LayerFrameStats& s : stats.layers) ms += s.gpuMilliseconds;
      record(plan, ms);
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
  struct Timing {
    gfx::GpuTimer timer;
    int plan = 0;
  };

  /// Averages the measurements that have arrived.
  void harvest() {
    while (!timings_.empty()) {
      const std::optional<std::uint64_t> ns = timings_.front().timer.nanoseconds(false);
      if (!ns && timings_.size() < 8) break;
      const std::uint64_t value = ns ? *ns : timings_.front().timer.nanoseconds(true).value_or(0);
      record(timings_.front().plan, static_cast<double>(value) * 1e-6);
      timings_.pop_front();
    }
  }

  void record(int plan, double ms) {
    std::optional<double>& c = cost_[static_cast<std::size_t>(plan)];
    c = c ? 0.5 * *c + 0.5 * ms : ms;
  }

  std::unique_ptr<OverlayTechnique> stencil_;
  std::unique_ptr<DeferredLookup> deferred_;
  std::size_t indexBudget_;
  std::deque<Timing> timings_;
  std::array<std::optional<double>, 2> cost_;
  std::uint64_t frameNumber_ = 0;
  std::array<std::optional<std::uint64_t>, 2> probedAt_;  ///< the last frame each candidate drew
  std::size_t lastSplit_ = 0;
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  Result<std::unique_ptr<OverlayTechnique>> result;
  Result<std::unique_ptr<OverlayTechnique>> stencil = kTiledStencilTechnique.create(options);
  Result<std::unique_ptr<DeferredLookup>> deferred = createDeferredLookup(options, kBaseReach);
  result.diagnostics = std::move(stencil.diagnostics);
  result.diagnostics.append(deferred.diagnostics);
  if (!stencil || !deferred) return result;
  result.value =
      std::make_unique<AutoTechnique>(std::move(*stencil), std::move(*deferred), options.tiling.gpuBudgetBytes);
  return result;
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
    &create};

}  // namespace gis::overlay
