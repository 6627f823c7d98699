#pragma once
// overlay_render for a scene drawn on the globe (docs/globe.md): color.png, depth.tiff, mask.png,
// camera.json (ECEF) and stats.json.
#include <string>

#include "globe/globe_overlay.hpp"
#include "globe_analysis.hpp"
#include "scene/scene.hpp"

namespace gis::app {

struct GlobeRenderOptions {
  std::string out;
  int width = 1024, height = 768;
  bool overlays = true;
  GlobeAnalysisRequest analyses;  ///< --lasso, --overlap
  std::string camera;             ///< --camera: a camera file (eye and target in lon/lat/h); empty: the scene's
  globe::GlobeTechnique technique = globe::GlobeTechnique::StencilTiles;  ///< --method
  std::string method = "stencil-tiles";                                   ///< its name
  int msaa = 0;                                                           ///< --msaa: samples per pixel (0 or 1: none)
  int textureSize = 0;  ///< --drape-size: texels a side of a drape's texture (0: the technique's default)
};

/// Loads and draws the scene on the globe (`reason` says why it is drawn there); the process's
/// exit code.
int runGlobeRender(const scene::SceneDescription& description, const std::string& reason,
                   const GlobeRenderOptions& options);

}  // namespace gis::app
