#include "scene/scene_renderer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <thread>

#include <glm/common.hpp>
#include <glm/matrix.hpp>

#include "core/log.hpp"
#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::scene {

overlay::OverlayView overlayViewOf(const Camera& camera, double aspect) {
  overlay::OverlayView v;
  v.viewProj = camera.projection(aspect) * camera.view();
  v.eye = camera.eye;
  v.nearPlane = camera.nearPlane;
  v.fovYRadians = camera.fovYDeg * std::numbers::pi / 180.0;
  v.aspect = aspect;
  return v;
}

namespace {

/// The terrain's view of a technique's drape.
terrain::TerrainEngine::Drape terrainDrapeOf(overlay::SurfaceDrape drape) {
  terrain::TerrainEngine::Drape d;
  d.color = drape.color;
  d.mask = drape.mask;
  d.origin = drape.origin;
  d.size = drape.size;
  d.colorArray = drape.colorArray;
  d.maskArray = drape.maskArray;
  if (drape.tileOf) {
    d.tileOf = [tileOf = std::move(drape.tileOf)](const terrain::NodeId& id) { return tileOf(id.key()); };
  }
  return d;
}

}  // namespace

Diagnostics SceneRenderer::buildOverlays(const LoadedScene& scene, const OverlayBuildSettings& settings) {
  Diagnostics diagnostics;
  technique_.reset();  // first: a tiled technique's workers read the layers
  layers_.clear();
  sources_.clear();
  const terrain::TerrainGrid& grid = scene.quadtree->grid();
  overlay::LayerBuildOptions options;
  techniqueInfo_ = settings.technique != nullptr ? settings.technique : &overlay::defaultTechnique();
  options.paperVariant = techniqueInfo_->construction == overlay::PieceConstruction::Paper;
  const bool tiled = techniqueInfo_->construction == overlay::PieceConstruction::Tiled;
  options.adaptiveSplit = settings.adaptiveSplit;
  // The terrain's bounds may be read from several threads at once.
  options.threads = std::max(1U, std::thread::hardware_concurrency());
  options.footprints.chordTolerance = settings.chordToleranceMetres;
  options.footprints.uniteLines = settings.uniteLines;
  options.footprints.lineCellDivisions = std::max(1, settings.cellPosts / std::max(1, settings.lineCellPosts));
  const glm::dvec2 a = grid.postPosition(0, 0), b = grid.postPosition(grid.width - 1, grid.height - 1);
  overlay::CellGrid cells;
  cells.origin = glm::min(a, b);
  cells.cellSize = settings.cellPosts * std::max(std::abs(grid.step.x), std::abs(grid.step.y));
  const glm::dvec2 extent = glm::max(a, b) - cells.origin;
  cells.columns = std::max(1, static_cast<int>(std::ceil(extent.x / cells.cellSize)));
  cells.rows = std::max(1, static_cast<int>(std::ceil(extent.y / cells.cellSize)));
  options.footprints.cells = cells;
  technique_.reset();
  overlay::TechniqueOptions techniqueOptions;
  techniqueOptions.textureSize = settings.textureSize;
  techniqueOptions.extent = overlay::DrapeExtent{cells.origin, glm::max(extent, glm::dvec2(1e-3))};
  techniqueOptions.bounds = scene.bounds.get();
  techniqueOptions.build = options;
  techniqueOptions.tiling.gpuBudgetBytes =
      static_cast<std::size_t>(std::max(1.0, scene.description.gpuBudgetMb) * 1024.0 * 1024.0);
  const std::string cacheDirectory = settings.tileCache ? cacheDirectoryFor(scene.description) : std::string();
  if (!cacheDirectory.empty()) {
    techniqueOptions.tiling.cacheDirectory = (std::filesystem::path(cacheDirectory) / "vector-tiles").string();
    techniqueOptions.tiling.cacheKey = terrainCacheKey(scene);
    techniqueOptions.tiling.cacheRevision = scene.bounds->revision();
  }
  // A tiled technique builds the pieces per tile (`deferred` and `auto` only for the layers they
  // do not look up): the layers keep their features only, checked at load (or as checked last
  // time, with the cache).
  options.deferPieces = tiled;
  if (tiled && !cacheDirectory.empty())
    options.checkCacheDirectory = (std::filesystem::path(cacheDirectory) / "vector-checks").string();
  // It also draws lines at least LayerStyle::minWidthPixels wide (each tile at the widths its
  // view needs); the whole-load techniques draw the widths in metres.
  options.minWidthInPixels = tiled;
  Result<std::unique_ptr<overlay::OverlayTechnique>> technique = techniqueInfo_->create(techniqueOptions);
  diagnostics.append(technique.diagnostics);
  if (technique) technique_ = std::move(*technique);
  for (const std::size_t i : drawOrderOf(scene.layers)) {
    const LoadedLayer& source = scene.layers[i];
    if (!source.description.visible) continue;
    const overlay::LayerStyle& style = source.description.style;
    // The library names layer and feature; the file is the scene's business.
    auto named = [&source](Diagnostics built) {
      Diagnostics out;
      for (Diagnostic d : std::move(built).items()) {
        if (d.file.empty()) d.file = source.description.source;
        out.add(std::move(d));
      }
      return out;
    };
    Result<overlay::OverlayLayer> layer = overlay::OverlayLayer::build(source.description.name, source.description.kind,
                                                                       style, source.features, *scene.bounds, options);
    diagnostics.append(named(std::move(layer.diagnostics)));
    if (!layer) continue;
    layers_.push_back(std::move(*layer));
    sources_.emplace_back(i, false);
    if (source.description.kind == overlay::LayerKind::Polygon &&
        (style.outlineWidthMetres > 0.0F || style.outlineWidthPixels > 0.0F)) {
      overlay::LayerStyle outline = style;
      outline.color = style.outlineColor;
      outline.opacity = 1.0F;
      outline.colorAttribute.clear();
      outline.widthMetres = style.outlineWidthMetres;
      outline.widthPixels = style.outlineWidthPixels;
      outline.widthAttribute.clear();
      outline.join = overlay::LineJoin::Round;
      outline.cap = overlay::LineCap::Round;
      Result<overlay::OverlayLayer> lines =
          overlay::OverlayLayer::build(source.description.name + " (outline)", overlay::LayerKind::Line, outline,
                                       source.features.outlines(), *scene.bounds, options);
      diagnostics.append(named(std::move(lines.diagnostics)));
      if (!lines) continue;
      layers_.push_back(std::move(*lines));
      sources_.emplace_back(i, true);
    }
  }
  shown_.assign(layers_.size(), true);
  // One line per layer that lost anything, with the counts (each feature is named above).
  for (std::size_t i = 0; i < scene.layers.size(); ++i) {
    const LayerSummary summary = layerSummary(scene, i);
    if (summary.skipped() == 0 && summary.nothingToDraw == 0) continue;
    diagnostics.add({Severity::Warning, scene.layers[i].description.source, scene.layers[i].description.name, "",
                     std::to_string(summary.skipped()) + " of " + std::to_string(summary.features) +
                         " features skipped for errors (" + std::to_string(summary.skippedReading) + " when read, " +
                         std::to_string(summary.skippedBuilding) + " when built), " +
                         std::to_string(summary.nothingToDraw) + " with nothing to draw"});
  }
  return diagnostics;
}

LayerSummary SceneRenderer::layerSummary(const LoadedScene& scene, std::size_t sceneLayer) const {
  LayerSummary summary;
  if (sceneLayer >= scene.layers.size()) return summary;
  const LoadedLayer& source = scene.layers[sceneLayer];
  summary.skippedReading = source.skippedFeatures;
  summary.features = source.features.size() + source.skippedFeatures;
  std::vector<bool> skipped(source.features.size(), false), drawn(skipped.size(), false), empty(skipped.size(), false);
  for (std::size_t j = 0; j < sources_.size(); ++j) {
    if (sources_[j].first != sceneLayer) continue;
    summary.built = true;
    summary.pieces += layers_[j].stats().pieces;
    summary.triangles += layers_[j].stats().triangles;
    const std::vector<overlay::FeatureOutcome>& outcomes = layers_[j].featureOutcomes();
    for (std::size_t f = 0; f < outcomes.size() && f < skipped.size(); ++f) {
      skipped[f] = skipped[f] || outcomes[f] == overlay::FeatureOutcome::Skipped;
      drawn[f] = drawn[f] || outcomes[f] == overlay::FeatureOutcome::Drawn;
      empty[f] = empty[f] || outcomes[f] == overlay::FeatureOutcome::NothingToDraw;
    }
  }
  for (std::size_t f = 0; f < skipped.size(); ++f) {
    summary.skippedBuilding += skipped[f] ? 1u : 0u;
    summary.drawnFeatures += drawn[f] ? 1u : 0u;
    summary.nothingToDraw += !skipped[f] && !drawn[f] && empty[f] ? 1u : 0u;
  }
  return summary;
}

Result<SceneRenderer> SceneRenderer::create(const LoadedScene& scene, const OverlayBuildSettings& overlays) {
  Result<terrain::TerrainEngine> engine =
      terrain::TerrainEngine::create(scene.quadtree, scene.orthophoto ? &*scene.orthophoto : nullptr,
                                     static_cast<std::size_t>(scene.description.gpuBudgetMb * 1024.0 * 1024.0));
  Result<SceneRenderer> result;
  result.diagnostics = engine.diagnostics;
  if (!engine) return result;
  SceneRenderer renderer;
  renderer.terrain_ = std::move(*engine);
  renderer.bounds_ = scene.bounds;
  Result<overlay::OverlayRenderer> overlayRenderer = overlay::OverlayRenderer::create();
  result.diagnostics.append(overlayRenderer.diagnostics);
  if (!overlayRenderer) return result;
  renderer.overlay_ = std::move(*overlayRenderer);
  result.diagnostics.append(renderer.buildOverlays(scene, overlays));
  renderer.timer_.emplace();
  renderer.statistics_.emplace();
  result.value = std::move(renderer);
  return result;
}

void SceneRenderer::drawSky(gfx::StateCache& cache, const Camera& camera, double aspect, int width, int height) {
  if (!sky_) {
    Result<gfx::Program> program = gfx::Program::build({{"sample_copy.vert", {}}, {"sky.frag", {}}});
    for (const Diagnostic& d : program.diagnostics.items()) logError(d.toString());
    if (!program) return;
    sky_ = std::move(*program);
    emptyVao_ = gfx::createVertexArray();
  }
  gfx::PipelineState state;
  state.depth = gfx::DepthState{false, false, gfx::CompareFunc::Always, false};
  state.raster.cull = gfx::CullMode::None;
  cache.apply(state);
  // The view's rotation alone: rays relative to the eye, no large translation in float.
  glm::dmat4 rotation = camera.view();
  rotation[3] = glm::dvec4(0.0, 0.0, 0.0, 1.0);
  sky_->set("u_rayFromClip", glm::mat4(glm::inverse(camera.projection(aspect) * rotation)));
  sky_->set("u_viewport", glm::vec2(static_cast<float>(width), static_cast<float>(height)));
  cache.useProgram(*sky_);
  cache.bindVertexArray(emptyVao_.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
}

FrameStats SceneRenderer::render(gfx::StateCache& cache, GLuint framebuffer, int width, int height,
                                 const Camera& camera, const RenderSettings& settings) {
  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, framebuffer, width, height, {kBackground, gfx::kReversedZFar, 0});
  const double aspect = static_cast<double>(width) / static_cast<double>(std::max(height, 1));
  const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();
  if (settings.sky) drawSky(cache, camera, aspect, width, height);

  FrameStats stats;
  const auto selectStart = std::chrono::steady_clock::now();
  terrain::LodView view;
  view.eye = camera.eye;
  view.viewProj = viewProj;
  view.viewportHeight = height;
  view.fovYRadians = camera.fovYDeg * std::numbers::pi / 180.0;
  terrain::LodOptions options;
  options.pixelTolerance = settings.lodTolerancePixels;
  const double exaggeration = bounds_->exaggeration();
  options.exaggeration = exaggeration;
  const terrain::TerrainQuadtree& tree = terrain_->tree();
  terrain::TilePager* pager = tree.pager();
  if (pager != nullptr) {
    // Drawable: on the GPU already, or its posts in memory.
    options.resident = [&](const terrain::NodeId& n) { return terrain_->hasChunk(n) || tree.resident(n); };
    stats.tilesArrived = pager->update();
  }
  selection_ = terrain::selectLod(tree, view, options);
  if (pager != nullptr) {
    // A still image waits for its tiles (each round refines one level further); a flight asks
    // for them and draws the coarser parents meanwhile.
    while (settings.waitForTiles && !selection_.missing.empty()) {
      pager->request(selection_.missing);
      pager->waitIdle();
      selection_ = terrain::selectLod(tree, view, options);
    }
    pager->request(selection_.missing);
    stats.tilesMissing = selection_.missing.size();
    stats.pager = pager->stats();
  }
  stats.selectMilliseconds =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - selectStart).count();
  stats.terrainCulled = selection_.culled;
  stats.finestLevel = terrain_->tree().rootLevel();
  for (const terrain::SelectedChunk& c : selection_.chunks) {
    stats.finestLevel = std::min(stats.finestLevel, c.id.level);
    stats.coarsestLevel = std::max(stats.coarsestLevel, c.id.level);
  }

  if (settings.measure) {
    timer_->begin();
    statistics_->begin();
  }
  // Another exaggeration since the layers read their bounds: read them again (heights only).
  bool stale = false;
  for (overlay::OverlayLayer& layer : layers_) {
    if (!layer.boundsStale()) continue;
    layer.refreshBounds(*bounds_);
    stale = true;
  }
  if (stale && technique_) technique_->invalidate();
  // The technique's frame: prepared before the terrain (drapes), drawn after it.
  const bool overlays = settings.overlays && !layers_.empty() && technique_;
  overlay::TechniqueFrame frame;
  frame.target = overlay::DrawTarget{framebuffer, width, height};
  frame.view = overlayViewOf(camera, aspect);
  std::vector<const overlay::OverlayLayer*> shownLayers;
  shownLayers.reserve(layers_.size());
  for (std::size_t j = 0; j < layers_.size(); ++j) shownLayers.push_back(shown_[j] ? &layers_[j] : nullptr);
  frame.layers = shownLayers;
  std::vector<overlay::DrawnTile> tiles;
  tiles.reserve(selection_.chunks.size());
  for (const terrain::SelectedChunk& c : selection_.chunks) {
    const auto [lo, hi] = tree.frameExtent(c.id);
    tiles.push_back({c.id.key(), lo, hi});
  }
  frame.tiles = tiles;
  frame.settings = settings.overlay;
  frame.settings.measure = settings.measure;
  frame.waitForTiles = settings.waitForTiles;
  frame.tileProgress = settings.tileProgress;
  overlay::TechniqueFrameStats techniqueStats;
  std::optional<overlay::SurfaceDrape> drape;
  if (overlays) drape = technique_->prepare(cache, frame, techniqueStats);
  stats.texturesBuilt = techniqueStats.texturesBuilt;
  stats.textureSeconds = techniqueStats.textureSeconds;
  stats.draped = drape.has_value();
  terrain_->setDrape(drape ? std::optional(terrainDrapeOf(std::move(*drape))) : std::nullopt);
  // The terrain shader writes the mask only from a drape; otherwise the overlay passes do.
  gfx::enableMaskWrites(framebuffer, stats.draped);
  terrain_->setWireframe(settings.wireframe);
  terrain_->setImagery(settings.imagery);
  terrain_->setElevationRamp(settings.elevationRamp);
  stats.terrainDraw = terrain_->draw(cache, viewProj, camera.eye, selection_, exaggeration);
  if (settings.measure) {
    statistics_->end();
    timer_->end();
    stats.terrain.gpuMilliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
    stats.terrain.counts = statistics_->result();
  }
  gfx::enableMaskWrites(framebuffer, true);
  if (overlays) {
    technique_->draw(cache, frame, techniqueStats);
    stats.layers = std::move(techniqueStats.layers);
    stats.overlayTiles = std::move(techniqueStats);
  }
  return stats;
}

}  // namespace gis::scene
