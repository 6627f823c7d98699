// The deferred per-pixel technique: no polyhedra and no stencil. Per layer a quadtree index
// of its polygons' edges and its lines' primitives (deferred_index.hpp) in the frame's plane, and
// the lookup's pass of both frames (deferred_lookup.hpp) over the screen tiles the layer's
// content can project to: each pixel (each sample with MSAA) reads the terrain's depth, finds its
// ground point in the index and is coloured when a feature covers it (the first covering
// feature's colour), adding the layer's bit to the mask. Cost grows with pixels × entries per
// leaf, not with triangles.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <unordered_map>

#include "../deferred_pass.hpp"
#include "techniques/techniques.hpp"

namespace gis::overlay {
namespace {

/// A layer's index at a reach class (ReachClasses, deferred_lookup.hpp): kNatural for lines binned
/// at their own largest width (or none in pixels), c ≥ 0 for lines in pixels binned at the base
/// reach × 2^c.
using IndexKey = std::pair<const OverlayLayer*, int>;

struct IndexKeyHash {
  std::size_t operator()(const IndexKey& k) const {
    return std::hash<const void*>()(k.first) ^ (std::hash<int>()(k.second) << 1U);
  }
};

class DeferredTechnique final : public DeferredLookup {
 public:
  DeferredTechnique(DeferredPass pass, const HeightBoundsProvider* bounds, double maxReach,
                    std::optional<std::array<glm::dvec2, 2>> region)
      : classes_{maxReach, 12}, region_(region), bounds_(bounds), pass_(std::move(pass)) {}

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    stats.layers.assign(frame.layers.size(), LayerFrameStats{});
    lastLayers_.assign(frame.layers.begin(), frame.layers.end());
    const OverlayView& view = frame.view;
    // Every layer drawn in one pass (the frame's one chart, its plane): one depth read and
    // reconstruction per pixel, the layers composited in order in the shader.
    std::vector<const DeferredLayer*> drawn(frame.layers.size(), nullptr);
    for (std::size_t i = 0; i < frame.layers.size(); ++i) {
      if (frame.layers[i] == nullptr) continue;
      // A view wider than every class (auto would not have chosen it) draws with the widest.
      const IndexKey key{frame.layers[i],
                         std::min(reachClass(*frame.layers[i], view, frame.target.height), classes_.largest)};
      auto built = layers_.find(key);
      if (built == layers_.end()) built = layers_.emplace(key, indexOf(*key.first, classes_.reach(key.second))).first;
      drawn[i] = &built->second;
    }
    pass_.draw(cache, frame.target, view, drawn, frame.settings.measure, stats.layers);
    stats.deferredLayers = static_cast<std::size_t>(
        std::count_if(drawn.begin(), drawn.end(), [](const DeferredLayer* d) { return d != nullptr; }));
    stats.deferredBytes = pass_.gpuBytes();
  }

  void invalidate() override { dropAll(); }
  void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) override {
    (void)lo;
    (void)hi;
    dropAll();
  }
  void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) override {
    // That layer's index is made again at the next frame, from its features as they are then.
    (void)feature;
    if (layer >= lastLayers_.size() || lastLayers_[layer] == nullptr) return invalidate(lo, hi);
    const OverlayLayer* changed = lastLayers_[layer];
    reach_.erase(changed);
    std::erase_if(layers_, [changed](const auto& entry) { return entry.first.first == changed; });
  }
  [[nodiscard]] std::size_t gpuBytes() const override { return pass_.gpuBytes(); }

  [[nodiscard]] bool canDraw(const OverlayLayer& layer, const OverlayView& view, int height,
                             std::size_t maxIndexBytes) override {
    const int c = reachClass(layer, view, height);
    if (c == ReachClasses::kBeyond) return false;
    const auto built = layers_.find({&layer, c});
    if (built != layers_.end()) return built->second.bytes() <= maxIndexBytes;
    const LayerReach& r = reachInfo(layer);
    // Lines binned at a reach meet many more leaves than at their own widths.
    const double binned = c == ReachClasses::kNatural ? 0.0 : classes_.lineIndexBytes(r.primitives, c);
    return std::max(static_cast<double>(r.estimatedBytes), binned) <= static_cast<double>(maxIndexBytes);
  }

 private:
  /// What canDraw needs of a layer, found once.
  struct LayerReach {
    PixelLineWidths widths;       ///< of its lines in pixels (none: pixelsHalf 0)
    glm::dvec3 lo{0.0}, hi{0.0};  ///< the layer's extent, with the terrain's heights
    std::size_t estimatedBytes = 0;
    std::size_t primitives = 0;  ///< of a line layer: a disc and a band per vertex, about

    /// The farthest corner of its extent from the eye: no anchor is farther.
    [[nodiscard]] double farthest(const OverlayView& view) const {
      double far = 0.0;
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 c((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y, (k & 4) != 0 ? hi.z : lo.z);
        far = std::max(far, glm::length(c - view.eye));
      }
      return far;
    }
  };

  [[nodiscard]] LayerReach reachOf(const OverlayLayer& layer) const {
    LayerReach r;
    for (const FeatureStyle& f : layer.featureStyles()) {
      if (layer.kind() != LayerKind::Line || !f.shape.inPixels()) continue;
      PixelLineWidths& w = r.widths;
      w.pixelsHalf = std::max(w.pixelsHalf, 0.5 * f.shape.widthPixels);
      w.leastHalf = std::max(w.leastHalf, 0.5 * f.shape.minWidth);
      w.largestHalf = std::max(w.largestHalf, 0.5 * f.shape.width);
    }
    const SharedFeatures& features = layer.sharedFeatures();
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < features.size(); ++i) {
      const auto [a, b] = features.box(i, layer.kind() == LayerKind::Line);
      if (!(a.x <= b.x && a.y <= b.y)) continue;
      lo = glm::min(lo, a);
      hi = glm::max(hi, b);
    }
    const HeightBounds h = bounds_ != nullptr ? bounds_->globalBounds() : HeightBounds{-1e4, 1e4};
    const double grow = std::min(r.widths.largestHalf, classes_.reach(classes_.largest));  // as the lines are binned
    r.lo = glm::dvec3(lo - glm::dvec2(grow), h.lo);
    r.hi = glm::dvec3(hi + glm::dvec2(grow), h.hi);
    // About 160 bytes a source vertex (entries, leaves and grid) on the samples measured.
    r.estimatedBytes = features.vertexCount() * 160;
    if (layer.kind() == LayerKind::Line) r.primitives = 2 * features.vertexCount();
    return r;
  }

  const LayerReach& reachInfo(const OverlayLayer& layer) {
    auto found = reach_.find(&layer);
    if (found == reach_.end()) found = reach_.emplace(&layer, reachOf(layer)).first;
    return found->second;
  }

  /// The class whose index draws the layer exactly in this view (ReachClasses::classFor): the
  /// farthest corner of its extent bounds every anchor's distance.
  int reachClass(const OverlayLayer& layer, const OverlayView& view, int height) {
    if (!std::isfinite(classes_.base)) return ReachClasses::kNatural;
    const LayerReach& r = reachInfo(layer);
    const double far = r.farthest(view);
    return classes_.classFor(r.widths, pixelScaleOf(view.viewProj, height).metresPerPixel,
                             [far](double) { return far; });
  }

  void dropAll() {
    lastLayers_.clear();
    reach_.clear();
    layers_.clear();
  }

  [[nodiscard]] DeferredLayer indexOf(const OverlayLayer& layer, double maxReach) const {
    std::vector<glm::vec4> colors;
    colors.reserve(layer.featureStyles().size());
    for (const FeatureStyle& s : layer.featureStyles()) colors.push_back(s.color);
    deferred::BuildOptions options;
    options.maxReach = maxReach;
    options.region = region_;
    deferred::Index index = deferred::build(referenceLayerOf(layer), colors, options);
    std::vector<std::array<glm::dvec3, 2>> cover;
    for (const auto& box : index.cover) {
      HeightBounds h{-1e5, 1e5};
      if (bounds_ != nullptr) {
        const std::array<glm::dvec2, 4> corners{box[0], glm::dvec2(box[1].x, box[0].y), box[1],
                                                glm::dvec2(box[0].x, box[1].y)};
        h = bounds_->boundsOver(corners);
        if (!h.valid()) h = {-1e5, 1e5};
      }
      cover.push_back({glm::dvec3(box[0], h.lo), glm::dvec3(box[1], h.hi)});
    }
    return deferredLayerOf(DeferredChart::plane(), std::move(index), std::move(cover));
  }

  ReachClasses classes_;
  /// The terrain's extent (the build's cell grid): ground points lie there, so the indices cover
  /// no more (deferred::BuildOptions::region).
  std::optional<std::array<glm::dvec2, 2>> region_;
  const HeightBoundsProvider* bounds_;
  DeferredPass pass_;
  std::unordered_map<IndexKey, DeferredLayer, IndexKeyHash> layers_;
  std::unordered_map<const OverlayLayer*, LayerReach> reach_;
  std::vector<const OverlayLayer*> lastLayers_;  ///< the last frame's layers (featureChanged's indices)
};

Result<std::unique_ptr<DeferredTechnique>> make(const TechniqueOptions& options, double maxReach) {
  Result<std::unique_ptr<DeferredTechnique>> result;
  Result<DeferredPass> pass = DeferredPass::create();
  result.diagnostics.append(pass.diagnostics);
  if (!pass) return result;
  // Ground points lie on the terrain, within the cell grid the stencil technique clips its pieces
  // to: an index covers no more, so that one feature reaching far beyond (a line 1e15 m wide)
  // costs what one covering the terrain does.
  std::optional<std::array<glm::dvec2, 2>> region;
  if (const std::optional<CellGrid>& cells = options.build.footprints.cells) {
    region = std::array<glm::dvec2, 2>{cells->origin,
                                       cells->origin + cells->cellSize * glm::dvec2(cells->columns, cells->rows)};
  }
  result.value = std::make_unique<DeferredTechnique>(std::move(*pass), options.bounds, maxReach, region);
  return result;
}

}  // namespace

Result<std::unique_ptr<DeferredLookup>> createDeferredLookup(const TechniqueOptions& options, double maxReach) {
  Result<std::unique_ptr<DeferredTechnique>> made = make(options, maxReach);
  Result<std::unique_ptr<DeferredLookup>> result;
  result.diagnostics = std::move(made.diagnostics);
  if (made) result.value = std::move(*made);
  return result;
}

}  // namespace gis::overlay
