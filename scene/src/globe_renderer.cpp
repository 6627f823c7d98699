#include "scene/globe_renderer.hpp"

#include <chrono>
#include <optional>

#include "gfx/camera.hpp"
#include "gfx/queries.hpp"
#include "gfx/render_target.hpp"

namespace gis::globe {

GlobeRenderer::GlobeRenderer(std::shared_ptr<const GeoGrid> heights, TerrainOptions terrain)
    : heights_(heights), terrain_(std::move(heights), terrain) {}

GlobeFrameStats GlobeRenderer::render(gfx::StateCache& cache, const GlobeFrameTarget& target, const GlobeView& view,
                                      const std::vector<const GlobeLayer*>& layers, bool timed,
                                      const GlobeOverlaySettings& settings) {
  GlobeFrameStats stats;
  const auto start = std::chrono::steady_clock::now();
  tiles_ = terrain_.select(view);
  const std::vector<DrawnTile>& tiles = tiles_;
  stats.selectMilliseconds =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats.selectedTiles = tiles.size();

  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, target.framebuffer, target.width, target.height,
                       {target.clearColor, gfx::kReversedZFar, 0});
  std::optional<gfx::GpuTimer> terrainTimer;
  if (timed) terrainTimer.emplace();
  // Texture draping: the textures the frame's tiles lack, rasterised before the terrain, which
  // then draws the layers (and their bits into the mask) itself.
  const bool draped = !layers.empty() && drapes(settings.technique);
  std::optional<overlay::SurfaceDrape> drape;
  if (draped) {
    GlobeOverlaySettings drawn = settings;
    drawn.targetFramebuffer = target.framebuffer;
    drape = overlay_.prepareDrape(cache, view, tiles, layers, drawn);
    stats.overlay = overlay_.stats();
  }
  if (target.hasMask) gfx::enableMaskWrites(target.framebuffer, drape.has_value());
  std::optional<gfx::PipelineStatistics> terrainCounts;
  if (terrainTimer) {
    terrainTimer->begin();
    terrainCounts.emplace();
    terrainCounts->begin();
  }
  terrain_.draw(cache, view, tiles, drape ? &*drape : nullptr);
  if (terrainTimer) {
    terrainCounts->end();
    terrainTimer->end();
    stats.terrainFragments = terrainCounts->result().fragmentShaderInvocations;
  }
  stats.terrain = terrain_.stats();
  if (!layers.empty() && !draped) {
    if (target.hasMask) gfx::enableMaskWrites(target.framebuffer, true);
    // Timed, each layer's mark and cover are measured apart by the stencil core (and the lookup),
    // as in a projected frame; the frame's figures are their sums.
    GlobeOverlaySettings drawn = settings;
    drawn.targetFramebuffer = target.framebuffer;
    drawn.measure = timed;
    overlay_.draw(cache, view, tiles, *heights_, layers, drawn);
    stats.overlay = overlay_.stats();
    if (timed) {
      for (const overlay::LayerFrameStats& l : stats.overlay.layers) {
        stats.overlayGpuMilliseconds += l.gpuMilliseconds;
        stats.overlayFragments += l.markFragments + l.coverFragments;
        stats.overlayPrimitives += l.markTriangles + l.coverTriangles;
      }
      overlay_.measured(stats.overlayGpuMilliseconds);
    }
  }
  if (terrainTimer) stats.terrainGpuMilliseconds = static_cast<double>(terrainTimer->nanoseconds().value_or(0)) * 1e-6;
  return stats;
}

}  // namespace gis::globe
