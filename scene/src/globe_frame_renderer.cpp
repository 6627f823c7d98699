// FrameRenderer on the globe: globe::GlobeRenderer's tiles of the geographic quadtree and its
// overlay (docs/globe.md).
#include <algorithm>
#include <chrono>
#include <cmath>

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
      : scene_(scene), renderer_(scene.heights), settings_(settings) {
    renderer_.setImagery(scene.imagery);
    overlaySettings_ = globeOverlaySettings(scene.description);
    overlaySettings_.technique = technique;
    overlaySettings_.textureSize = settings.textureSize;
    for (const globe::GlobeLayer& l : scene.layers) layers_.push_back(&l);
  }

  void drawStill(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera) override {
    const globe::GlobeView& view = std::get<globe::GlobeView>(camera);
    const globe::GlobeFrameTarget into{target.framebuffer(), target.width(), target.height(), true};
    overlaySettings_.passes = {};  // every saving on
    // A still waits for every drawn tile's imagery (built a few tiles a frame).
    for (int k = 0; k < 4096 && scene_.imagery; ++k) {
      if (renderer_.render(cache, into, view, {}).terrain.imageryPending == 0) break;
    }
    stats_ = renderer_.render(cache, into, view, layers_, true, overlaySettings_);
    // What drew each layer with pieces (its tiles in view, or its pieces built whole): their GPU
    // bytes. Not the layers the lookup or a drape drew (asking for their chunks would build them).
    stillLayerBytes_.assign(scene_.layers.size(), 0);
    const std::size_t pieced =
        stats_.overlay.draped || layers_.size() != scene_.layers.size()
            ? 0
            : scene_.layers.size() - std::min(stats_.overlay.deferredLayers, scene_.layers.size());
    for (std::size_t l = 0; l < pieced; ++l) {
      for (const overlay::OverlayLayer* chunk :
           renderer_.overlay().chunks(view, renderer_.tiles(), renderer_.heights(), scene_.layers[l]))
        stillLayerBytes_[l] += chunk->stats().gpuBytes;
    }
  }

  FrameFigures drawFrame(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera,
                         const FrameOptions& options) override {
    const globe::GlobeFrameTarget into{target.framebuffer(), target.width(), target.height(), true};
    const std::vector<const globe::GlobeLayer*> none;
    overlaySettings_.passes = options.overlay;  // the savings as asked (the ablation's switches)
    overlaySettings_.waitForTiles = options.waitForTiles;
    const globe::GlobeFrameStats stats =
        renderer_.render(cache, into, std::get<globe::GlobeView>(camera), options.overlays ? layers_ : none,
                         options.measure, overlaySettings_);
    // Each layer's mark and cover counted apart, as in a projected frame.
    FrameFigures f;
    f.terrain.tiles = stats.terrain.tiles;
    f.terrain.triangles = stats.terrain.triangles;
    f.terrain.built = stats.terrain.uploads;
    f.terrain.selectMs = stats.selectMilliseconds;
    f.terrain.fragments = stats.terrainFragments;
    f.terrainGpuMs = stats.terrainGpuMilliseconds;
    for (const overlay::LayerFrameStats& l : stats.overlay.layers) f.addLayerPasses(l);
    f.zFailPieces = stats.overlay.zFailPieces;
    f.drawnPieces = stats.overlay.pieces;
    f.tilesBuilt = stats.overlay.builtTiles;
    f.texturesBuilt = stats.overlay.texturesBuilt;
    f.textureSeconds = stats.overlay.textureSeconds;
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
            {"meshes_on_gpu", renderer_.terrain().stats().resident},
            {"imagery_bytes", renderer_.terrain().stats().imageryBytes}};
  }
  [[nodiscard]] LayersBuilt layersBuilt() const override { return {}; }  // built by the frames, in tiles
  [[nodiscard]] std::size_t techniqueGpuBytes() const override { return lastResidentBytes_; }
  [[nodiscard]] bool drapesOneTexture() const override { return renderer_.overlay().textureDrape() != nullptr; }
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
    if (boxes) (void)renderer_.overlay().featureChanged(layer, *boxes);
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
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
  [[nodiscard]] overlay::OverlayRenderer* analysisPasses() override { return renderer_.overlay().renderer(); }
  [[nodiscard]] std::vector<const overlay::OverlayLayer*> chunksOf(std::size_t drawn,
                                                                   const FrameCamera& camera) override {
    return renderer_.overlay().chunks(std::get<globe::GlobeView>(camera), renderer_.tiles(), renderer_.heights(),
                                      scene_.layers.at(drawn));
  }
  [[nodiscard]] ReferenceAnswer referenceOf(std::span<const std::size_t> drawn,
                                            const overlay::DepthImage& image) const override {
    std::vector<const globe::GlobeLayer*> layers;
    for (const std::size_t j : drawn) layers.push_back(&scene_.layers.at(j));
    if (wholeLoad()) {
      // Built whole, lines in pixels are drawn at their least widths (in metres).
      const overlay::PixelScale least;
      return {overlay::referenceMask(image, globe::LayerCoverage(layers, least)),
              overlay::edgePixels(image, globe::edgeLayersOf(layers, least))};
    }
    return {overlay::referenceMask(image, globe::coverageOf(layers, image)),
            overlay::edgePixels(image, globe::edgeLayersOf(layers, image))};
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
                        {"polygons", scene_.layers[l].polygons().size()},
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
      if (const overlay::TextureDrape* single = renderer_.overlay().textureDrape()) {
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
  globe::GlobeRenderer renderer_;
  StillSettings settings_;
  globe::GlobeOverlaySettings overlaySettings_;
  std::vector<const globe::GlobeLayer*> layers_;
  globe::GlobeFrameStats stats_;
  std::size_t lastResidentBytes_ = 0;
  std::vector<std::size_t> stillLayerBytes_;  ///< per layer: the GPU bytes of what drew it in the last still

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
