#include "globe/globe_renderer.hpp"

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
  const std::vector<DrawnTile> tiles = terrain_.select(view);
  stats.selectMilliseconds =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats.selectedTiles = tiles.size();

  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, target.framebuffer, target.width, target.height,
                       {target.clearColor, gfx::kReversedZFar, 0});
  std::optional<gfx::GpuTimer> terrainTimer, overlayTimer;
  if (timed) {
    terrainTimer.emplace();
    overlayTimer.emplace();
  }
  if (target.hasMask) gfx::enableMaskWrites(target.framebuffer, false);
  if (terrainTimer) terrainTimer->begin();
  terrain_.draw(cache, view, tiles);
  if (terrainTimer) terrainTimer->end();
  stats.terrain = terrain_.stats();
  if (!layers.empty()) {
    if (target.hasMask) gfx::enableMaskWrites(target.framebuffer, true);
    if (overlayTimer) overlayTimer->begin();
    overlay_.draw(cache, view, tiles, *heights_, layers, settings);
    if (overlayTimer) overlayTimer->end();
    stats.overlay = overlay_.stats();
  }
  if (terrainTimer) stats.terrainGpuMilliseconds = static_cast<double>(terrainTimer->nanoseconds().value_or(0)) * 1e-6;
  if (overlayTimer && !layers.empty())
    stats.overlayGpuMilliseconds = static_cast<double>(overlayTimer->nanoseconds().value_or(0)) * 1e-6;
  return stats;
}

}  // namespace gis::globe
