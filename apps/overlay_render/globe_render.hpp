#pragma once
// overlay_render for a scene drawn on the globe (docs/globe.md): color.png, depth.tiff, mask.png,
// camera.json (ECEF) and stats.json.
#include <string>

#include "scene/scene.hpp"

namespace gis::app {

struct GlobeRenderOptions {
  std::string out;
  int width = 1024, height = 768;
  bool overlays = true;
};

/// Loads and draws the scene on the globe (`reason` says why it is drawn there); the process's
/// exit code.
int runGlobeRender(const scene::SceneDescription& description, const std::string& reason,
                   const GlobeRenderOptions& options);

}  // namespace gis::app
