// A GIS client draws a scene file headless through gis::scene: it loads the scene, places the
// camera the scene file names (or the overview), draws one still frame, and reads it back with
// a bit per scene layer. Writes client_scene.ppm; exits 0 when every layer that loaded covers
// pixels and GL reported no error.
//   client_scene SCENE.json
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "gfx/context.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "scene/frame_readback.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"

namespace {

void print(const gis::Diagnostics& diagnostics) {
  for (const gis::Diagnostic& d : diagnostics.items()) std::fprintf(stderr, "%s\n", d.toString().c_str());
}

void writePpm(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << width << ' ' << height << "\n255\n";
  out.write(reinterpret_cast<const char*>(rgb.data()), static_cast<std::streamsize>(rgb.size()));
}

}  // namespace

int main(int argc, char** argv) {
  using namespace gis;
  if (argc != 2) {
    std::fprintf(stderr, "usage: client_scene SCENE.json\n");
    return 2;
  }
  const std::string sceneFile = argv[1];
  Result<scene::SceneDescription> description = scene::loadSceneFile(sceneFile);
  print(description.diagnostics);
  if (!description) return 1;
  Result<scene::LoadedScene> loaded = scene::loadScene(*description);
  print(loaded.diagnostics);
  if (!loaded) return 1;
  Result<scene::Camera> camera = scene::stillCamera("", *description, sceneFile, *loaded);
  print(camera.diagnostics);
  if (!camera) return 1;

  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  if (!context) {
    std::fprintf(stderr, "no OpenGL 4.5 context\n");
    return 1;
  }
  int status = 0;
  {
    Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*loaded);
    print(renderer.diagnostics);
    if (!renderer) return 1;
    constexpr int kWidth = 320, kHeight = 240;
    gfx::StateCache cache;
    gfx::RenderTarget target(kWidth, kHeight, 0, true);
    scene::RenderSettings settings;
    settings.waitForTiles = true;
    renderer->render(cache, target.framebuffer(), kWidth, kHeight, *camera, settings);
    const scene::FrameImages frame = scene::readFrame(cache, *loaded, *renderer, target);
    writePpm("client_scene.ppm", kWidth, kHeight, frame.rgb);
    for (const scene::LoadedLayer& layer : loaded->layers) {
      const std::size_t bit = layer.description.fileIndex;
      std::size_t pixels = 0;
      for (std::uint8_t m : frame.mask) pixels += bit < 8 && ((m >> bit) & 1u) != 0u ? 1u : 0u;
      std::printf("client_scene: layer %s %zu pixels\n", layer.description.name.c_str(), pixels);
      if (pixels == 0) status = 1;
    }
  }
  const std::size_t errors = (*context)->debug().errorCount();
  std::printf("client_scene: %zu layers, %zu GL errors\n", loaded->layers.size(), errors);
  return status == 0 && errors == 0 && !loaded->layers.empty() ? 0 : 1;
}
