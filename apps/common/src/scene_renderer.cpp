#include "app/scene_renderer.hpp"

#include <chrono>
#include <numbers>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::app {

Result<SceneRenderer> SceneRenderer::create(const LoadedScene& scene) {
  Result<terrain::TerrainEngine> engine =
      terrain::TerrainEngine::create(scene.quadtree, scene.orthophoto ? &*scene.orthophoto : nullptr,
                                     static_cast<std::size_t>(scene.description.gpuBudgetMb * 1024.0 * 1024.0));
  Result<SceneRenderer> result;
  result.diagnostics = engine.diagnostics;
  if (!engine) return result;
  SceneRenderer renderer;
  renderer.terrain_ = std::move(*engine);
  renderer.timer_.emplace();
  renderer.statistics_.emplace();
  result.value = std::move(renderer);
  return result;
}

FrameStats SceneRenderer::render(gfx::StateCache& cache, GLuint framebuffer, int width, int height,
                                 const Camera& camera, const RenderSettings& settings) {
  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, framebuffer, width, height, {kBackground, gfx::kReversedZFar, 0});
  const double aspect = static_cast<double>(width) / static_cast<double>(std::max(height, 1));
  const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();

  FrameStats stats;
  const auto selectStart = std::chrono::steady_clock::now();
  terrain::LodView view;
  view.eye = camera.eye;
  view.viewProj = viewProj;
  view.viewportHeight = height;
  view.fovYRadians = camera.fovYDeg * std::numbers::pi / 180.0;
  terrain::LodOptions options;
  options.pixelTolerance = settings.lodTolerancePixels;
  options.exaggeration = settings.verticalExaggeration;
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
  terrain_->setWireframe(settings.wireframe);
  stats.terrainDraw = terrain_->draw(cache, viewProj, camera.eye, selection_, settings.verticalExaggeration);
  if (settings.measure) {
    statistics_->end();
    timer_->end();
    stats.terrain.gpuMilliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
    stats.terrain.counts = statistics_->result();
  }
  return stats;
}

}  // namespace gis::app
