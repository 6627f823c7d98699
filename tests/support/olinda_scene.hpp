#pragma once
// The Olinda sample scene loaded and uploaded for GL tests, drawn by a chosen overlay technique.
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "test_paths.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {

/// The scene, its renderer and its overlay layers in draw order; empty optionals after a
/// (reported) failure.
struct OlindaScene {
  std::optional<scene::LoadedScene> scene;
  std::optional<scene::SceneRenderer> renderer;
  std::vector<const overlay::OverlayLayer*> layers;
};

/// Loads samples/olinda/scene.json (needs the GL context) with `technique` (null: the default;
/// another than the default keeps no tiles on disk).
inline OlindaScene loadOlinda(const overlay::TechniqueInfo* technique = nullptr) {
  OlindaScene o;
  Result<scene::SceneDescription> description =
      scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  EXPECT_TRUE(description.ok());
  if (!description) return o;
  Result<scene::LoadedScene> scene = scene::loadScene(*description);
  EXPECT_TRUE(scene.ok());
  if (!scene) return o;
  o.scene = std::move(*scene);
  scene::OverlayBuildSettings settings;
  if (technique != nullptr) {
    settings.technique = technique;
    settings.tileCache = false;
  }
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*o.scene, settings);
  EXPECT_TRUE(renderer.ok());
  if (!renderer) return o;
  o.renderer = std::move(*renderer);
  for (const overlay::OverlayLayer& l : o.renderer->overlayLayers()) o.layers.push_back(&l);
  return o;
}

}  // namespace gis::test
