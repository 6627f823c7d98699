// FrameRenderer in a projected frame: SceneRenderer's terrain quadtree and overlay technique.
#include <algorithm>
#include <chrono>
#include <limits>
#include <set>

#include "frame_renderers.hpp"
#include "scene/scene_renderer.hpp"
#include "scene/selection_export.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/texture_drape.hpp"

namespace gis::scene::detail {

namespace {

using nlohmann::json;

json countsJson(const gfx::PipelineCounts& c) {
  return {{"vertices_submitted", c.verticesSubmitted},
          {"primitives_submitted", c.primitivesSubmitted},
          {"vertex_shader_invocations", c.vertexShaderInvocations},
          {"clipping_input_primitives", c.clippingInputPrimitives},
          {"clipping_output_primitives", c.clippingOutputPrimitives},
          {"fragment_shader_invocations", c.fragmentShaderInvocations},
          {"samples_passed", c.samplesPassed}};
}

OverlayBuildSettings buildSettings(const StillSettings& settings) {
  OverlayBuildSettings build;
  build.technique = settings.technique;
  build.textureSize = settings.textureSize;
  build.cellPosts = settings.cellPosts;
  build.adaptiveSplit = settings.adaptiveSplit;
  build.uniteLines = settings.uniteLines;
  return build;
}

class ProjectedFrameRenderer final : public FrameRenderer {
 public:
  ProjectedFrameRenderer(LoadedScene& scene, SceneRenderer renderer, const StillSettings& settings)
      : scene_(scene), renderer_(std::move(renderer)), settings_(settings) {}

  void drawStill(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera) override {
    RenderSettings settings;
    settings.lodTolerancePixels = settings_.lodTolerancePixels;
    settings.measure = true;
    settings.waitForTiles = true;  // a still image: every tile the view needs
    settings.tileProgress = settings_.tileProgress;
    stats_ = renderer_.render(cache, target.framebuffer(), target.width(), target.height(), std::get<Camera>(camera),
                              settings);
  }

  FrameFigures drawFrame(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera,
                         const FrameOptions& options) override {
    RenderSettings settings;
    settings.lodTolerancePixels =
        options.lodTolerancePixels > 0.0 ? options.lodTolerancePixels : settings_.lodTolerancePixels;
    settings.waitForTiles = options.waitForTiles;
    settings.overlays = options.overlays;
    settings.measure = options.measure;
    settings.overlay = options.overlay;
    settings.imagery = options.imagery;
    settings.elevationRamp = options.elevationRamp;
    settings.sky = options.sky;
    settings.wireframe = options.wireframe;
    const FrameStats stats = renderer_.render(cache, target.framebuffer(), target.width(), target.height(),
                                              std::get<Camera>(camera), settings);
    FrameFigures f;
    f.terrain = {stats.terrainDraw.chunks,
                 stats.terrainDraw.triangles,
                 stats.terrainDraw.chunksBuilt,
                 stats.selectMilliseconds,
                 options.measure ? stats.terrain.counts.fragmentShaderInvocations : 0,
                 stats.finestLevel,
                 stats.tilesMissing,
                 stats.tilesArrived,
                 stats.pager.residentBytes + stats.pager.pinnedBytes};
    f.terrainGpuMs = stats.terrain.gpuMilliseconds;
    for (const overlay::LayerFrameStats& l : stats.layers) {
      f.addLayerPasses(l);
      f.zFailPieces += l.zFailPieces;
      f.drawnPieces += l.zPassPieces + l.zFailPieces;
    }
    f.tilesBuilt = stats.overlayTiles.tilesBuilt;
    f.texturesBuilt = stats.texturesBuilt;
    f.textureSeconds = stats.textureSeconds;
    f.tilesMissing = stats.overlayTiles.tilesMissing;
    f.terrainPending = stats.pager.pending;
    f.terrainResidentTiles = stats.pager.residentTiles;
    f.deferredLayers = stats.overlayTiles.deferredLayers;
    f.deferredBytes = stats.overlayTiles.deferredBytes;
    f.draped = stats.draped;
    if (stats.draped) f.drapeBytes = renderer_.techniqueGpuBytes();
    return f;
  }

  [[nodiscard]] bool hasImagery() const override { return renderer_.terrainEngine().hasImagery(); }
  bool setTechnique(const overlay::TechniqueInfo& technique, int textureSize, Diagnostics& diagnostics) override {
    settings_.technique = &technique;
    settings_.textureSize = textureSize;
    diagnostics.append(rebuild());
    return true;
  }
  Diagnostics restyle(std::span<const LayerDescription> layers) override {
    for (LoadedLayer& layer : scene_.layers) {
      for (const LayerDescription& d : layers)
        if (d.fileIndex == layer.description.fileIndex) layer.description = d;
    }
    return rebuild();
  }
  void setExaggeration(double exaggeration) override {
    // The bounds own it; the renderer refreshes the pieces' heights at the next frame (no
    // rebuild of the footprints).
    scene_.bounds->setExaggeration(exaggeration);
  }
  [[nodiscard]] DrawnLayerSource drawnLayerSource(std::size_t drawn) const override {
    const auto& [layer, outline] = renderer_.overlaySources().at(drawn);
    return {scene_.layers.at(layer).description.fileIndex, outline};
  }
  [[nodiscard]] bool drawnLayerShown(std::size_t drawn) const override { return renderer_.shown(drawn); }
  void setDrawnLayerShown(std::size_t drawn, bool shown) override { renderer_.setShown(drawn, shown); }
  [[nodiscard]] std::shared_ptr<const geo::Feature> drawnLayerFeature(std::size_t drawn,
                                                                      std::size_t feature) const override {
    const std::vector<geo::Feature>& features = renderer_.overlayLayers().at(drawn).features();
    if (feature >= features.size()) return nullptr;
    // The renderer's layer owns it: a shared pointer that does not.
    return {std::shared_ptr<const geo::Feature>(), &features[feature]};
  }
  [[nodiscard]] const std::vector<geo::Feature>* drawnLayerFeatures(std::size_t drawn) const override {
    return &renderer_.overlayLayers().at(drawn).features();
  }
  [[nodiscard]] std::vector<std::size_t> featuresAt(std::size_t drawn, const glm::dvec3& world,
                                                    const FrameCamera& camera, int width, int height) const override {
    const Camera& c = std::get<Camera>(camera);
    const overlay::OverlayLayer& layer = renderer_.overlayLayers().at(drawn);
    const overlay::PixelScale scale =
        overlay::pixelScaleOf(c.projection(static_cast<double>(width) / height) * c.view(), height);
    const overlay::ReferenceLayer ref = overlay::referenceLayerOf(layer);
    std::vector<std::size_t> out;
    for (std::size_t f = 0; f < layer.features().size(); ++f) {
      if (overlay::featureCovers(ref, f, glm::dvec2(world), scale)) out.push_back(f);
    }
    return out;
  }
  [[nodiscard]] LayerSummary layerSummary(std::size_t fileIndex) const override {
    for (std::size_t i = 0; i < scene_.layers.size(); ++i) {
      if (scene_.layers[i].description.fileIndex == fileIndex) return renderer_.layerSummary(scene_, i);
    }
    return {};
  }
  [[nodiscard]] const overlay::TextureDrape* textureDrape() const override { return renderer_.textureDrape(); }
  [[nodiscard]] json terrainJson() const override {
    const terrain::TerrainGrid& grid = scene_.quadtree->grid();
    return {{"dem_size", {grid.width, grid.height}},
            {"gpu_bytes", renderer_.terrainEngine().gpuBytes()},
            {"paged", scene_.paged()},
            {"pyramid_build_seconds", scene_.pyramidBuild ? json(scene_.pyramidBuild->seconds) : json(nullptr)},
            {"tile_cache_budget_bytes", scene_.paged() ? scene_.quadtree->pager()->budgetBytes() : std::size_t{0}}};
  }
  [[nodiscard]] LayersBuilt layersBuilt() const override {
    LayersBuilt built;
    if (settings_.technique->usesTextures()) return built;  // the layers are rasterised, not drawn
    for (const overlay::OverlayLayer& l : renderer_.overlayLayers()) {
      built.gpuBytes += l.stats().gpuBytes;
      built.buildSeconds += l.stats().buildSeconds;
      built.triangles += l.stats().triangles;
    }
    return built;
  }
  [[nodiscard]] std::size_t techniqueGpuBytes() const override { return renderer_.techniqueGpuBytes(); }
  [[nodiscard]] bool drapesOneTexture() const override { return renderer_.textureDrape() != nullptr; }
  [[nodiscard]] int referenceKind() const override {
    // A tiled technique draws lines in pixels at the view's widths; the techniques that build at
    // load draw them at widths in metres.
    return settings_.technique->construction == overlay::PieceConstruction::Tiled ? 0 : 1;
  }
  std::optional<double> editFirstFeature() override {
    if (renderer_.overlayLayers().empty() || renderer_.overlayLayers()[0].features().empty()) return std::nullopt;
    overlay::OverlayLayer& layer = renderer_.overlayLayer(0);
    geo::Feature feature = layer.features().front();
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    const auto extend = [&](const std::vector<glm::dvec2>& points) {
      for (const glm::dvec2& p : points) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
    };
    if (!feature.polygons.empty() && !feature.polygons.front().outer.empty()) {
      feature.polygons.front().outer.front() += glm::dvec2(10.0, 0.0);
      for (const geo::Polygon& p : feature.polygons) extend(p.outer);
    } else if (!feature.lines.empty() && !feature.lines.front().empty()) {
      feature.lines.front().front() += glm::dvec2(10.0, 0.0);
      for (const geo::LineString& l : feature.lines) extend(l);
    } else {
      return std::nullopt;
    }
    const double margin = 2.0 * layer.style().maxWidthMetres + 20.0;  // widths and outlines
    const auto start = std::chrono::steady_clock::now();
    (void)layer.replaceFeature(0, feature);
    renderer_.featureChanged(0, 0, lo - margin, hi + margin);
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }

  [[nodiscard]] std::size_t drawnLayerCount() const override { return renderer_.overlayLayers().size(); }
  [[nodiscard]] std::string drawnLayerName(std::size_t drawn) const override {
    return renderer_.overlayLayers().at(drawn).name();
  }
  [[nodiscard]] DrawnLayerBuilt drawnLayerBuilt(std::size_t drawn) const override {
    const overlay::OverlayLayer& l = renderer_.overlayLayers().at(drawn);
    const overlay::LayerStats& s = l.stats();
    return {l.name(), s.features, s.skippedFeatures, s.pieces, s.triangles, s.gpuBytes, s.buildSeconds};
  }
  [[nodiscard]] std::optional<std::size_t> fillLayerNamed(std::string_view name) const override {
    return scene::fillLayerNamed(scene_, renderer_, name);
  }
  [[nodiscard]] overlay::OverlayRenderer* analysisPasses() override { return &renderer_.overlayRenderer(); }
  [[nodiscard]] std::vector<const overlay::OverlayLayer*> chunksOf(std::size_t drawn, const FrameCamera&) override {
    return renderer_.drawnChunks(drawn);
  }
  [[nodiscard]] ReferenceAnswer referenceOf(std::span<const std::size_t> drawn,
                                            const overlay::DepthImage& image) const override {
    std::vector<overlay::ReferenceLayer> layers;
    for (const std::size_t j : drawn) layers.push_back(overlay::referenceLayerOf(renderer_.overlayLayers().at(j)));
    return {overlay::referenceMask(image, layers), overlay::edgePixels(image, layers)};
  }

  [[nodiscard]] FrameImages readFrame(gfx::StateCache& cache, const gfx::RenderTarget& target) const override {
    return scene::readFrame(cache, scene_, renderer_, target);
  }

  [[nodiscard]] SelectedFeatures selectFeatures(std::span<const overlay::SelectionStep> steps,
                                                const FrameCamera& camera, int width, int height,
                                                std::optional<double> sampleSpacing) const override {
    const auto start = std::chrono::steady_clock::now();
    SceneSelection chosen =
        selectInScene(scene_, renderer_, steps, std::get<Camera>(camera), width, height, sampleSpacing);
    return selectedFeaturesOf(scene_, renderer_, std::move(chosen),
                              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  [[nodiscard]] Diagnostics exportSelection(const SelectedFeatures& selected, const std::filesystem::path& combined,
                                            const std::filesystem::path& perLayerDir) const override {
    return scene::exportSelection(scene_, renderer_, std::get<SceneSelection>(selected.selection), combined,
                                  perLayerDir);
  }

  [[nodiscard]] Diagnostics techniqueDiagnostics() const override { return renderer_.techniqueDiagnostics(); }

  void reportStill(const FrameImages& images, json& stats) const override {
    stats["frame"] = "projected";
    stats["terrain"] = terrainJson(images);
    stats["layers"] = layersJson(images);
    stats["passes"] = {
        {"terrain", {{"gpu_ms", stats_.terrain.gpuMilliseconds}, {"pipeline", countsJson(stats_.terrain.counts)}}}};
    const overlay::TechniqueInfo& technique = *settings_.technique;
    if (const overlay::TextureDrape* drape = renderer_.textureDrape()) {
      stats["drape"] = {{"size", drape->stats().size},
                        {"triangles", drape->stats().triangles},
                        {"gpu_bytes", drape->stats().gpuBytes},
                        {"build_s", drape->stats().buildSeconds},
                        {"texel_m", {drape->extent().size.x / drape->size(), drape->extent().size.y / drape->size()}}};
    } else if (technique.construction == overlay::PieceConstruction::Tiled) {
      // The tiles' own bytes (`auto` holds the lookup's indices too: in "deferred").
      const std::size_t bytes = renderer_.techniqueGpuBytes();
      stats["tiles"] = tilesJson(stats_.overlayTiles, bytes - std::min(bytes, stats_.overlayTiles.deferredBytes));
    } else if (technique.usesTextures()) {
      stats["drape"] = {{"tile_size", settings_.textureSize > 0 ? settings_.textureSize : technique.defaultTextureSize},
                        {"tiles_built", stats_.texturesBuilt},
                        {"gpu_bytes", renderer_.techniqueGpuBytes()},
                        {"build_s", stats_.textureSeconds}};
    }
    // The deferred lookup (`deferred`, `auto`): the layers it drew and its indices' bytes.
    const overlay::TechniqueFrameStats& t = stats_.overlayTiles;
    if (t.deferredLayers > 0 || t.deferredBytes > 0)
      stats["deferred"] = {{"layers", t.deferredLayers}, {"gpu_bytes", t.deferredBytes}};
  }

 private:
  LoadedScene& scene_;
  SceneRenderer renderer_;
  StillSettings settings_;
  FrameStats stats_;

  /// The layers built again (another technique, or their styles). A scene layer with a hidden
  /// drawn layer stays hidden, all of it (an outline a restyle adds included), as on the globe.
  Diagnostics rebuild() {
    std::set<std::size_t> hidden;
    for (std::size_t j = 0; j < renderer_.overlaySources().size(); ++j)
      if (!renderer_.shown(j)) hidden.insert(renderer_.overlaySources()[j].first);
    Diagnostics d = renderer_.buildOverlays(scene_, buildSettings(settings_));
    for (std::size_t j = 0; j < renderer_.overlaySources().size(); ++j) {
      if (hidden.contains(renderer_.overlaySources()[j].first)) renderer_.setShown(j, false);
    }
    return d;
  }

  /// stats.json's "terrain": the DEM, its quadtree and this frame's LOD.
  [[nodiscard]] json terrainJson(const FrameImages& images) const {
    const terrain::TerrainQuadtree& tree = *scene_.quadtree;
    const terrain::TerrainGrid& grid = tree.grid();
    const terrain::NodeInfo& rootInfo = tree.info(tree.root());
    std::size_t terrainPixels = 0;
    for (const float depth : images.depth) terrainPixels += depth > 0.0F ? 1 : 0;
    return {{"posts", static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height)},
            {"paged", tree.paged()},
            {"dem_size", {grid.width, grid.height}},
            {"nodata_posts", scene_.nodataPosts},
            {"quadtree_levels", tree.rootLevel() + 1},
            {"chunk_cells", tree.chunkCells()},
            {"lod_tolerance_px", settings_.lodTolerancePixels},
            {"vertical_exaggeration", scene_.bounds->exaggeration()},
            {"chunks", stats_.terrainDraw.chunks},
            {"chunks_culled", stats_.terrainCulled},
            {"finest_level", stats_.finestLevel},
            {"coarsest_level", stats_.coarsestLevel},
            {"triangles", stats_.terrainDraw.triangles},
            {"select_ms", stats_.selectMilliseconds},
            {"gpu_bytes", renderer_.terrainEngine().gpuBytes()},
            {"min_height", rootInfo.minHeight},
            {"max_height", rootInfo.maxHeight},
            {"imagery", scene_.orthophoto.has_value()},
            {"pixels", terrainPixels}};
  }

  /// A "passes" entry per overlay layer built from scene layer `i`, with this frame's figures.
  [[nodiscard]] json passesJson(std::size_t i) const {
    json passes = json::array();
    for (std::size_t j = 0; j < renderer_.overlaySources().size(); ++j) {
      if (renderer_.overlaySources()[j].first != i) continue;
      const overlay::OverlayLayer& built = renderer_.overlayLayers()[j];
      const overlay::LayerFrameStats f = j < stats_.layers.size() ? stats_.layers[j] : overlay::LayerFrameStats{};
      // What drew the layer: the layer itself, or the tiles a tiled technique drew for it.
      overlay::LayerStats drawn;
      for (const overlay::OverlayLayer* chunk : renderer_.drawnChunks(j)) {
        drawn.pieces += chunk->stats().pieces;
        drawn.triangles += chunk->stats().triangles;
        drawn.gpuBytes += chunk->stats().gpuBytes;
      }
      passes.push_back({{"name", built.name()},
                        {"pieces", drawn.pieces},
                        {"triangles", drawn.triangles},
                        {"gpu_bytes", drawn.gpuBytes},
                        {"build_seconds", built.stats().buildSeconds},
                        {"z_pass_pieces", f.zPassPieces},
                        {"z_fail_pieces", f.zFailPieces},
                        {"culled_pieces", f.culledPieces},
                        {"cover", f.rectangleCover ? "rectangle" : "pieces"},
                        {"gpu_ms", f.gpuMilliseconds},
                        {"mark_fragments", f.markFragments},
                        {"cover_fragments", f.coverFragments}});
    }
    return passes;
  }

  /// stats.json's "layers": one per layer of the scene file.
  [[nodiscard]] json layersJson(const FrameImages& images) const {
    json layers = json::array();
    for (std::size_t i = 0; i < scene_.layers.size(); ++i) {
      const LoadedLayer& layer = scene_.layers[i];
      const std::size_t bit = layer.description.fileIndex;
      std::size_t coveredPixels = 0;
      for (const std::uint8_t m : images.mask) {
        coveredPixels += bit < 8 && ((static_cast<unsigned>(m) >> bit) & 1U) != 0U ? 1U : 0U;
      }
      const LayerSummary summary = renderer_.layerSummary(scene_, i);
      layers.push_back({{"name", layer.description.name},
                        {"kind", layer.description.kind == overlay::LayerKind::Polygon ? "polygon" : "line"},
                        {"source", layer.description.source},
                        {"features", summary.features},
                        {"vertices", layer.vertexCount()},
                        {"skipped_features", summary.skipped()},
                        {"skipped_when_read", summary.skippedReading},
                        {"skipped_when_built", summary.skippedBuilding},
                        {"features_with_nothing_to_draw", summary.nothingToDraw},
                        {"drawn_features", summary.drawnFeatures},
                        {"drawn", summary.built},
                        {"mask_bit", bit < 8 ? json(bit) : json(nullptr)},
                        {"covered_pixels", coveredPixels},
                        {"passes", passesJson(i)}});
    }
    return layers;
  }
};

}  // namespace

Result<std::unique_ptr<FrameRenderer>> makeProjectedRenderer(LoadedScene& scene, const StillSettings& settings) {
  Result<SceneRenderer> renderer = SceneRenderer::create(scene, buildSettings(settings));
  Result<std::unique_ptr<FrameRenderer>> out;
  out.diagnostics = std::move(renderer.diagnostics);
  if (renderer) out.value.emplace(std::make_unique<ProjectedFrameRenderer>(scene, std::move(*renderer), settings));
  return out;
}

}  // namespace gis::scene::detail
