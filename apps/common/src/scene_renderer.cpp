#include "app/scene_renderer.hpp"

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"

namespace gis::app {

Result<SceneRenderer> SceneRenderer::create(const LoadedScene& scene) {
  Result<terrain::TerrainRenderer> terrain =
      terrain::TerrainRenderer::create(scene.mesh, scene.orthophoto ? &*scene.orthophoto : nullptr);
  Result<SceneRenderer> result;
  result.diagnostics = terrain.diagnostics;
  if (!terrain) return result;
  SceneRenderer renderer;
  renderer.terrain_ = std::move(*terrain);
  renderer.timer_.emplace();
  renderer.statistics_.emplace();
  result.value = std::move(renderer);
  return result;
}

FrameStats SceneRenderer::render(gfx::StateCache& cache, GLuint framebuffer, int width, int height,
                                 const Camera& camera, bool measure) {
  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, framebuffer, width, height, {kBackground, gfx::kReversedZFar, 0});
  const double aspect = static_cast<double>(width) / static_cast<double>(std::max(height, 1));
  const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();

  FrameStats stats;
  if (measure) {
    timer_->begin();
    statistics_->begin();
  }
  terrain_->draw(cache, viewProj);
  if (measure) {
    statistics_->end();
    timer_->end();
    stats.terrain.gpuMilliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
    stats.terrain.counts = statistics_->result();
  }
  return stats;
}

}  // namespace gis::app
