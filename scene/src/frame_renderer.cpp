#include "scene/frame_renderer.hpp"

#include "frame_renderers.hpp"

namespace gis::scene {

void FrameFigures::addLayerPasses(const overlay::LayerFrameStats& passes) {
  layers.push_back({passes.markFragments, passes.coverFragments, passes.gpuMilliseconds,
                    passes.zPassPieces + passes.zFailPieces, passes.zFailPieces});
  overlayGpuMs += passes.gpuMilliseconds;
  markFragments += passes.markFragments;
  coverFragments += passes.coverFragments;
  markTriangles += passes.markTriangles;
  coverTriangles += passes.coverTriangles;
  markGpuMs += passes.markMilliseconds;
  coverGpuMs += passes.coverMilliseconds;
}

Result<std::unique_ptr<FrameRenderer>> FrameRenderer::create(Scene& scene, const StillSettings& settings) {
  if (scene.onGlobe()) return detail::makeGlobeRenderer(scene.globe(), settings);
  return detail::makeProjectedRenderer(scene.projected(), settings);
}

namespace detail {

nlohmann::json tilesJson(const overlay::TechniqueFrameStats& t, std::size_t gpuBytes) {
  return {{"drawn", t.tilesDrawn},      {"wanted", t.tilesWanted},           {"culled", t.tilesCulled},
          {"built", t.tilesBuilt},      {"read_from_disk", t.tilesFromDisk}, {"resident", t.tilesResident},
          {"lean", t.tilesLean},        {"finest_level", t.finestTileLevel}, {"error_px", t.tileErrorPixels},
          {"drawn_bytes", t.tileBytes}, {"peak_bytes", t.tilePeakBytes},     {"host_peak_bytes", t.tileHostPeakBytes},
          {"gpu_bytes", gpuBytes}};
}

}  // namespace detail

}  // namespace gis::scene
