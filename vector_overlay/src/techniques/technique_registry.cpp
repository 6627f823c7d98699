// The one list of overlay techniques (technique.hpp): the programs enumerate it.
#include <cassert>
#include <vector>

#include "gfx/state_cache.hpp"
#include "techniques/techniques.hpp"

namespace gis::overlay {

namespace {

/// The frame's target with a viewport over all of it, as prepare() and draw() bind it.
gfx::DrawTarget frameTarget(const TechniqueFrame& frame) {
  return {frame.target.framebuffer, {0, 0, frame.target.width, frame.target.height}};
}

}  // namespace

std::optional<SurfaceDrape> OverlayTechnique::prepare(gfx::StateCache& cache, const TechniqueFrame& frame,
                                                      TechniqueFrameStats& stats) {
  cache.bindDrawTarget(frameTarget(frame));
  std::optional<SurfaceDrape> drape = prepareFrame(cache, frame, stats);
  assert(cache.drawTarget() == frameTarget(frame) && "passes into other targets are gfx::RenderPasses");
  return drape;
}

void OverlayTechnique::draw(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) {
  cache.bindDrawTarget(frameTarget(frame));
  drawFrame(cache, frame, stats);
  assert(cache.drawTarget() == frameTarget(frame) && "passes into other targets are gfx::RenderPasses");
}

std::span<const TechniqueInfo> techniques() {
  // Default first. A new technique: its file in techniques/, its entry declared in
  // techniques.hpp and listed here. (Built at first use, after every file's initialisation.)
  static const std::vector<TechniqueInfo> all{kTiledStencilTechnique, kStencilTechnique,    kPaperTechnique,
                                              kDrapeTechnique,        kTiledDrapeTechnique, kDeferredTechnique,
                                              kAutoTechnique};
  return all;
}

const TechniqueInfo* findTechnique(std::string_view name) {
  for (const TechniqueInfo& info : techniques()) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

const TechniqueInfo& defaultTechnique() { return techniques().front(); }

std::string techniqueNameList() {
  std::string list;
  const std::span<const TechniqueInfo> all = techniques();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i > 0) list += i + 1 == all.size() ? " or " : ", ";
    list += all[i].name;
  }
  return list;
}

}  // namespace gis::overlay
