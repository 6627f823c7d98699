// FrameRenderer on the globe: globe::GlobeRenderer's tiles of the geographic quadtree and its
// overlay (docs/globe.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include "frame_renderers.hpp"
#include "scene/globe_renderer.hpp"
#include "vector_overlay/globe_selection.hpp"
#include "vector_overlay/texture_drape.hpp"

namespace gis::scene::detail {

namespace {

using nlohmann::json;

class GlobeFrameRenderer final : public FrameRenderer {
 public:
  GlobeFrameRenderer(LoadedGlobeScene& scene, globe::GlobeTechnique technique, const StillSettings& settings)
      : scene_(scene), renderer_(std::make_unique<globe::GlobeRenderer>(scene.heights)), settings_(settings) {
    renderer_->setImagery(scene.imagery);
    overlaySettings_ = globeOverlaySettings(scene.description);
    overlaySettings_.technique = technique;
    overlaySettings_.textureSize = settings.textureSize;
    layersBuilt();
  }

  void drawStill(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera) override {
    const globe::GlobeView& view = std::get<globe::GlobeView>(camera);
    const globe::GlobeFrameTarget into{target.framebuffer(), target.width(), target.height(), true};
    overlaySettings_.passes = {};  // every saving on
    // A still waits for every drawn tile's imagery (built a few tiles a frame).
    for (int k = 0; k < 4096 && scene_.imagery; ++k) {
      if (renderer_->render(cache, into, view, {}).terrain.imageryPending == 0) break;
    }
    stats_ = renderer_->render(cache, into, view, layers_, true, overlaySettings_);
    // What drew each layer with pieces (its tiles in view, or its pieces built whole): their GPU
    // bytes. Not the layers the lookup or a drape drew (asking for their chunks would build them).
    stillLayerBytes_.assign(scene_.layers.size(), 0);
    const std::size_t pieced =
        stats_.overlay.draped || layers_.size() != scene_.layers.size()
            ? 0
            : scene_.layers.size() - std::min(stats_.overlay.deferredLayers, scene_.layers.size());
    for (std::size_t l = 0; l < pieced; ++l) {
      for (const overlay::OverlayLayer* chunk :
           renderer_->overlay().chunks(view, renderer_->tiles(), renderer_->heights(), scene_.layers[l]))
        stillLayerBytes_[l] += chunk->stats().gpuBytes;
    }
  }

  FrameFigures drawFrame(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera,
                         const FrameOptions& options) override {
    const globe::GlobeFrameTarget into{target.framebuffer(), target.width(), target.height(), true};
    std::vector<const globe::GlobeLayer*> shown;
    for (std::size_t l = 0; l < layers_.size() && options.overlays; ++l) {
      if (shown_[l] != 0) shown.push_back(layers_[l]);
    }
    if (options.imagery != imageryShown_) {
      // The imagery switched off: the terrain tinted by height (its textures let go); on again:
      // read anew, a few tiles a frame.
      imageryShown_ = options.imagery;
      renderer_->setImagery(imageryShown_ ? scene_.imagery : nullptr);
    }
    overlaySettings_.passes = options.overlay;  // the savings as asked (the ablation's switches)
    overlaySettings_.waitForTiles = options.waitForTiles;
    const globe::GlobeFrameStats stats =
        renderer_->render(cache, into, std::get<globe::GlobeView>(camera), shown, options.measure, overlaySettings_);
    // Each layer's mark and cover counted apart, as in a projected frame.
    FrameFigures f;
    f.terrain.tiles = stats.terrain.tiles;
    f.terrain.triangles = stats.terrain.triangles;
    f.terrain.built = stats.terrain.uploads;
    f.terrain.selectMs = stats.selectMilliseconds;
    f.terrain.fragments = stats.terrainFragments;
    f.terrainGpuMs = stats.terrainGpuMilliseconds;
    // One entry per drawn layer, as in a projected frame (a hidden one drew nothing).
    for (std::size_t l = 0, k = 0; l < layers_.size(); ++l) {
      const bool drawn = options.overlays && shown_[l] != 0;
      f.addLayerPasses(drawn && k < stats.overlay.layers.size() ? stats.overlay.layers[k] : overlay::LayerFrameStats{});
      if (drawn) ++k;
    }
    f.zFailPieces = stats.overlay.zFailPieces;
    f.drawnPieces = stats.overlay.pieces;
    f.tilesBuilt = stats.overlay.builtTiles;
    f.texturesBuilt = stats.overlay.texturesBuilt;
    f.textureSeconds = stats.overlay.textureSeconds;
    f.overlayGpuMs = stats.overlayGpuMilliseconds;  // the lookup's pass with the pieces'
    f.tilesMissing = stats.overlay.missingTiles;
    f.terrainPending = stats.terrain.imageryPending;
    f.deferredLayers = stats.overlay.deferredLayers;
    f.deferredPending = stats.overlay.deferredPending;
    f.deferredBytes = stats.overlay.deferredBytes;
    f.draped = stats.overlay.draped;
    f.drapeBytes = stats.overlay.drapeGpuBytes;
    // What the GPU holds for the layers: the tiles' pieces, the drape's textures, the lookup's
    // indices, and a layer built whole (all of whose chunks every frame draws).
    lastResidentBytes_ = stats.overlay.residentBytes + stats.overlay.drapeGpuBytes + stats.overlay.deferredHeldBytes +
                         (wholeLoad() && options.overlays ? stats.overlay.drawnBytes : 0);
    return f;
  }
  [[nodiscard]] json terrainJson() const override {
    const globe::GeoGrid& heights = *scene_.heights;
    return {{"dem_size", {heights.width(), heights.height()}},
            {"step_deg", heights.step()},
            {"paged", heights.paged()},
            {"resident_bytes", heights.residentBytes()},
            {"meshes_on_gpu", renderer_->terrain().stats().resident},
            {"imagery_bytes", renderer_->terrain().stats().imageryBytes}};
  }
  [[nodiscard]] LayersBuilt layersBuilt() const override { return {}; }  // built by the frames, in tiles
  [[nodiscard]] std::size_t techniqueGpuBytes() const override { return lastResidentBytes_; }
  [[nodiscard]] bool drapesOneTexture() const override { return renderer_->overlay().textureDrape() != nullptr; }
  [[nodiscard]] int referenceKind() const override { return wholeLoad() ? 1 : 0; }
  std::optional<double> editFirstFeature() override {
    if (scene_.layers.empty() || scene_.layerFeatures.empty() || scene_.layerFeatures[0].size() == 0)
      return std::nullopt;
    globe::GlobeLayer& layer = scene_.layers[0];
    geo::Feature feature = *scene_.layerFeatures[0].get(0);
    glm::dvec2* first = !feature.polygons.empty() && !feature.polygons[0].outer.empty() ? &feature.polygons[0].outer[0]
                        : !feature.lines.empty() && !feature.lines[0].empty()           ? &feature.lines[0][0]
                                                                                        : nullptr;
    if (first == nullptr) return std::nullopt;
    first->x += 10.0 / (111320.0 * std::max(std::cos(first->y * 3.14159265358979323846 / 180.0), 1e-6));
    const auto start = std::chrono::steady_clock::now();
    const Result<std::vector<globe::LonLatRect>> boxes = layer.replaceFeature(0, feature);
    if (boxes) (void)renderer_->overlay().featureChanged(layer, *boxes);
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }

  [[nodiscard]] bool hasImagery() const override { return scene_.imagery != nullptr; }
  bool setTechnique(const overlay::TechniqueInfo& technique, int textureSize, Diagnostics& diagnostics) override {
    const std::optional<globe::GlobeTechnique> drawn = globeTechniqueNamed(technique.name);
    if (!drawn) {
      diagnostics.add({Severity::Error, scene_.description.path, "", "",
                       "method '" + std::string(technique.name) + "' is not available on the globe"});
      return false;
    }
    settings_.technique = &technique;
    settings_.textureSize = textureSize;
    overlaySettings_.technique = *drawn;
    overlaySettings_.textureSize = textureSize;  // the renderer takes both at its next frame
    return true;
  }
  Diagnostics restyle(std::span<const LayerDescription> layers) override {
    // The globe layers again from the features as read (shared, not read again), each source
    // layer with its style as edited; which scene layers are hidden stays. Each build is new to
    // the renderer (GlobeLayer::serial): its tiles are built again, in the new colours and widths.
    for (LoadedLayer& source : scene_.sourceLayers) {
      for (const LayerDescription& d : layers)
        if (d.fileIndex == source.description.fileIndex) source.description = d;
    }
    for (LayerDescription& described : scene_.description.layers) {
      for (const LayerDescription& d : layers)
        if (d.fileIndex == described.fileIndex) described = d;
    }
    return rebuildLayers();
  }
  void setExaggeration(double exaggeration) override {
    // The globe's heights own it: its terrain and the layers' tiles (their bounds, and the anchors
    // of lines in pixels) are made again from the exaggerated heights.
    if (exaggeration == scene_.heights->exaggeration()) return;
    scene_.heights = globe::GeoGrid::exaggerated(scene_.heights, exaggeration);
    renderer_ = std::make_unique<globe::GlobeRenderer>(scene_.heights);
    renderer_->setImagery(imageryShown_ ? scene_.imagery : nullptr);
    (void)rebuildLayers();  // said when the layers were first built
  }
  [[nodiscard]] DrawnLayerSource drawnLayerSource(std::size_t drawn) const override {
    // A fill and its outline share their scene layer, the outline after the fill.
    const std::size_t fileIndex = scene_.layerFileIndex.at(drawn);
    return {fileIndex, drawn > 0 && scene_.layerFileIndex[drawn - 1] == fileIndex};
  }
  [[nodiscard]] bool drawnLayerShown(std::size_t drawn) const override { return shown_.at(drawn) != 0; }
  void setDrawnLayerShown(std::size_t drawn, bool shown) override { shown_.at(drawn) = static_cast<char>(shown); }
  [[nodiscard]] std::shared_ptr<const geo::Feature> drawnLayerFeature(std::size_t drawn,
                                                                      std::size_t feature) const override {
    if (drawn >= scene_.layerFeatures.size() || feature >= scene_.layerFeatures[drawn].size()) return nullptr;
    return scene_.layerFeatures[drawn].get(feature);
  }
  [[nodiscard]] const std::vector<geo::Feature>* drawnLayerFeatures(std::size_t drawn) const override {
    return drawn < scene_.layerFeatures.size() ? &scene_.layerFeatures[drawn].all() : nullptr;
  }
  [[nodiscard]] std::vector<std::size_t> featuresAt(std::size_t drawn, const glm::dvec3& world,
                                                    const FrameCamera& camera, int /*width*/,
                                                    int /*height*/) const override {
    const globe::Geodetic at = globe::toGeodetic(world);
    std::vector<std::size_t> out;
    for (const std::uint32_t f : globe::featuresAt(scene_.layers.at(drawn), world, at.lon, at.lat,
                                                   globe::pixelScaleOf(std::get<globe::GlobeView>(camera))))
      out.push_back(f);
    return out;
  }
  [[nodiscard]] LayerSummary layerSummary(std::size_t fileIndex) const override {
    // What was read (the same LoadedLayer as a projected scene's); the globe builds by tiles.
    LayerSummary summary;
    for (const LoadedLayer& source : scene_.sourceLayers) {
      if (source.description.fileIndex != fileIndex) continue;
      summary.features = source.features.size() + source.skippedFeatures;
      summary.skippedReading = source.skippedFeatures;
    }
    return summary;
  }
  [[nodiscard]] const overlay::TextureDrape* textureDrape() const override {
    return renderer_->overlay().textureDrape();
  }

  [[nodiscard]] std::size_t drawnLayerCount() const override { return scene_.layers.size(); }
  [[nodiscard]] std::string drawnLayerName(std::size_t drawn) const override { return scene_.layers.at(drawn).name(); }
  [[nodiscard]] DrawnLayerBuilt drawnLayerBuilt(std::size_t drawn) const override {
    // Its pieces are built by the frames, per tile (or once, whole, at the first).
    DrawnLayerBuilt built;
    built.name = scene_.layers.at(drawn).name();
    built.features = drawn < scene_.layerFeatures.size() ? scene_.layerFeatures[drawn].size() : 0;
    return built;
  }
  [[nodiscard]] std::optional<std::size_t> fillLayerNamed(std::string_view name) const override {
    // A fill has its scene layer's name; its outline is named "<name> (outline)".
    for (std::size_t l = 0; l < scene_.layers.size(); ++l) {
      if (scene_.layers[l].name() == name) return l;
    }
    return std::nullopt;
  }
  [[nodiscard]] overlay::OverlayRenderer* analysisPasses() override { return renderer_->overlay().renderer(); }
  [[nodiscard]] std::vector<const overlay::OverlayLayer*> chunksOf(std::size_t drawn,
                                                                   const FrameCamera& camera) override {
    return renderer_->overlay().chunks(std::get<globe::GlobeView>(camera), renderer_->tiles(), renderer_->heights(),
                                       scene_.layers.at(drawn));
  }
  [[nodiscard]] ReferenceAnswer referenceOf(std::span<const std::size_t> drawn,
                                            const overlay::DepthImage& image) const override {
    std::vector<const globe::GlobeLayer*> layers;
    for (const std::size_t j : drawn) layers.push_back(&scene_.layers.at(j));
    // Built whole, lines in pixels are drawn at their least widths (in metres).
    const overlay::FrameLayersMaker reference =
        wholeLoad() ? globe::referenceLayersOf(layers, overlay::PixelScale{}) : globe::referenceLayersOf(layers, image);
    return {overlay::referenceMask(image, reference), overlay::edgePixels(image, reference)};
  }

  [[nodiscard]] FrameImages readFrame(gfx::StateCache& cache, const gfx::RenderTarget& target) const override {
    return scene::readFrame(cache, target, scene_.layerFileIndex);
  }

  [[nodiscard]] SelectedFeatures selectFeatures(std::span<const overlay::SelectionStep> steps,
                                                const FrameCamera& camera, int /*width*/, int /*height*/,
                                                std::optional<double> sampleSpacing) const override {
    const auto start = std::chrono::steady_clock::now();
    GlobeSelection chosen = selectOnGlobe(scene_, steps, std::get<globe::GlobeView>(camera), sampleSpacing);
    return selectedFeaturesOf(scene_, std::move(chosen),
                              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  [[nodiscard]] Diagnostics exportSelection(const SelectedFeatures& selected, const std::filesystem::path& combined,
                                            const std::filesystem::path& perLayerDir) const override {
    return exportGlobeSelection(scene_, std::get<GlobeSelection>(selected.selection), combined, perLayerDir);
  }

  [[nodiscard]] Diagnostics techniqueDiagnostics() const override { return {}; }

  void reportStill(const FrameImages& images, json& stats) const override {
    const globe::GeoGrid& heights = *scene_.heights;
    stats["frame"] = "globe";
    stats["globe_reason"] = scene_.reason;
    stats["dem"] = {{"width", heights.width()},
                    {"height", heights.height()},
                    {"step_deg", heights.step()},
                    {"vertical_datum", heights.verticalSource()},
                    {"vertical_exaggeration", heights.exaggeration()},
                    {"paged", heights.paged()},
                    {"resident_bytes", heights.residentBytes()},
                    {"blocks_read", heights.blocksRead()},
                    {"posts_read", heights.postsRead()}};
    stats["terrain"] = {
        {"posts", static_cast<std::size_t>(heights.width()) * static_cast<std::size_t>(heights.height())},
        {"gpu_bytes", stats_.terrain.meshBytes + stats_.terrain.imageryBytes},
        {"tiles", stats_.terrain.tiles},
        {"triangles", stats_.terrain.triangles},
        {"select_ms", stats_.selectMilliseconds},
        {"gpu_ms", stats_.terrainGpuMilliseconds},
        {"fragments", stats_.terrainFragments},
        {"imagery_source_pixels_read", scene_.imagery ? scene_.imagery->sourcePixelsRead() : 0U}};
    stats["passes"] = {
        {"terrain", {{"gpu_ms", stats_.terrainGpuMilliseconds}, {"fragments", stats_.terrainFragments}}}};
    const globe::GlobeOverlayStats& o = stats_.overlay;
    stats["overlay"] = {{"pieces", o.pieces},
                        {"z_fail_pieces", o.zFailPieces},
                        {"culled_pieces", o.culledPieces},
                        {"triangles", o.triangles},
                        {"tiles_built", o.builtTiles},
                        {"deferred_layers", o.deferredLayers},
                        {"deferred_index_bytes", o.deferredBytes},
                        {"deferred_pending", o.deferredPending},
                        {"gpu_ms", stats_.overlayGpuMilliseconds},
                        {"fragments", stats_.overlayFragments},
                        {"primitives", stats_.overlayPrimitives}};
    json layers = json::array();
    for (std::size_t l = 0; l < scene_.layers.size(); ++l) {
      // Its passes in this frame, as a projected layer's "passes" entry.
      const overlay::LayerFrameStats f = l < o.layers.size() ? o.layers[l] : overlay::LayerFrameStats{};
      const json passes = json::array({{{"name", scene_.layers[l].name()},
                                        {"gpu_bytes", l < stillLayerBytes_.size() ? stillLayerBytes_[l] : 0U},
                                        {"z_pass_pieces", f.zPassPieces},
                                        {"z_fail_pieces", f.zFailPieces},
                                        {"culled_pieces", f.culledPieces},
                                        {"gpu_ms", f.gpuMilliseconds},
                                        {"mark_fragments", f.markFragments},
                                        {"cover_fragments", f.coverFragments}}});
      layers.push_back({{"name", scene_.layers[l].name()},
                        {"polygons", scene_.layers[l].areaCount()},
                        {"mask_bit", scene_.layerFileIndex[l]},
                        {"covered_pixels", l < images.coveredPixels.size() ? images.coveredPixels[l] : 0U},
                        {"passes", passes}});
    }
    stats["layers"] = layers;
    // The deferred lookup, as a projected scene's "deferred" block.
    if (o.deferredLayers > 0 || o.deferredBytes > 0)
      stats["deferred"] = {
          {"layers", o.deferredLayers}, {"gpu_bytes", o.deferredBytes}, {"pending", o.deferredPending}};
    if (o.draped || globe::drapes(overlaySettings_.technique)) {
      // Draping: the textures (in longitude and latitude), as a projected scene's "drape" block.
      json drape = {{"tiles_built", o.texturesBuilt}, {"gpu_bytes", o.drapeGpuBytes}, {"build_s", o.textureSeconds}};
      if (const overlay::TextureDrape* single = renderer_->overlay().textureDrape()) {
        drape.update(
            {{"size", single->size()},
             {"triangles", single->stats().triangles},
             {"texel_deg", {single->extent().size.x / single->size(), single->extent().size.y / single->size()}}});
      } else {
        drape["tile_size"] = settings_.textureSize > 0 ? settings_.textureSize : 256;
      }
      stats["drape"] = drape;
      return;
    }
    // The layers' tiles (over the terrain's drawn tiles), as a projected scene's "tiles" block, and
    // what the globe's disk cache did.
    json tiles = tilesJson(o.tiles, o.residentBytes);
    tiles.update({{"missing", o.missingTiles},
                  {"built_anew", o.builtTiles},
                  {"written_to_disk", o.writtenTiles},
                  {"repaired", o.repairedTiles},
                  {"evicted", o.evictedTiles},
                  {"gpu_budget_bytes", overlaySettings_.gpuBudgetBytes}});
    stats["tiles"] = tiles;
  }

 private:
  LoadedGlobeScene& scene_;
  std::unique_ptr<globe::GlobeRenderer> renderer_;
  StillSettings settings_;
  globe::GlobeOverlaySettings overlaySettings_;
  std::vector<const globe::GlobeLayer*> layers_;
  std::vector<char> shown_;   ///< per layer
  bool imageryShown_ = true;  ///< FrameOptions::imagery as the last frame had it
  globe::GlobeFrameStats stats_;
  std::size_t lastResidentBytes_ = 0;
  std::vector<std::size_t> stillLayerBytes_;  ///< per layer: the GPU bytes of what drew it in the last still

  /// After the scene's layers were built (again): every layer, shown unless its scene layer was
  /// hidden.
  void layersBuilt(const std::set<std::size_t>& hiddenFiles = {}) {
    layers_.clear();
    shown_.clear();
    for (std::size_t l = 0; l < scene_.layers.size(); ++l) {
      layers_.push_back(&scene_.layers[l]);
      shown_.push_back(static_cast<char>(!hiddenFiles.contains(scene_.layerFileIndex[l])));
    }
  }
  Diagnostics rebuildLayers() {
    std::set<std::size_t> hidden;
    for (std::size_t l = 0; l < layers_.size(); ++l)
      if (shown_[l] == 0) hidden.insert(scene_.layerFileIndex[l]);
    Diagnostics d;
    buildGlobeLayers(scene_, d);
    layersBuilt(hidden);
    return d;
  }

  /// The layers are built whole, once (lines in pixels at their least widths in metres).
  [[nodiscard]] bool wholeLoad() const {
    return overlaySettings_.technique == globe::GlobeTechnique::Stencil ||
           overlaySettings_.technique == globe::GlobeTechnique::Paper;
  }
};

}  // namespace

Result<std::unique_ptr<FrameRenderer>> makeGlobeRenderer(LoadedGlobeScene& scene, const StillSettings& settings) {
  Result<std::unique_ptr<FrameRenderer>> out;
  // Every technique of the registry draws on the globe; one it could not draw is refused, never
  // silently replaced by another.
  const std::optional<globe::GlobeTechnique> technique = globeTechniqueNamed(settings.technique->name);
  if (!technique) {
    out.diagnostics.add({Severity::Error, scene.description.path, "", "",
                         "the scene is drawn on the globe (" + scene.reason + "): method '" +
                             std::string(settings.technique->name) + "' is not available there"});
    return out;
  }
  out.value.emplace(std::make_unique<GlobeFrameRenderer>(scene, *technique, settings));
  return out;
}

}  // namespace gis::scene::detail
