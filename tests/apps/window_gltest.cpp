// The same scene drawn through a GLFW window context (GLX under Xvfb) and through the headless
// EGL context must give the same picture: everything above gfx works with either context.
// Run under xvfb-run by CTest.
#include <cstdlib>

#include <gtest/gtest.h>

#include "gfx/context.hpp"
#include "gfx/render_target.hpp"
#include "gfx/window_context.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

constexpr int kSize = 128;

std::vector<std::uint8_t> renderOlinda(bool window) {
  gfx::ContextOptions options;
  options.width = kSize;
  options.height = kSize;
  options.vsync = false;
  Result<std::unique_ptr<gfx::Context>> context =
      window ? gfx::createWindowContext(options) : gfx::createHeadlessContext(options);
  EXPECT_TRUE(context.ok()) << (context.diagnostics.empty() ? "" : context.diagnostics.items().front().toString());
  if (!context) return {};
  Result<scene::SceneDescription> description =
      scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  Result<scene::LoadedScene> scene = scene::loadScene(*description);
  EXPECT_TRUE(scene.ok());
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*scene);
  EXPECT_TRUE(renderer.ok());
  glm::dvec3 lo, hi;
  scene::terrainBox(*scene, 1.0, lo, hi);
  gfx::StateCache cache;
  gfx::RenderTarget target(kSize, kSize);
  renderer->render(cache, target.framebuffer(), kSize, kSize, scene::overviewCamera(lo, hi), {});
  std::vector<std::uint8_t> pixels = gfx::readColorRgba8(target);
  EXPECT_EQ((*context)->debug().errorCount(), 0u);
  if (window) {
    // Also into the window's own back buffer, as the viewer draws.
    renderer->render(cache, 0, kSize, kSize, scene::overviewCamera(lo, hi), {});
    (*context)->swapBuffers();
    EXPECT_EQ((*context)->debug().errorCount(), 0u);
  }
  return pixels;
}

TEST(WindowContext, DrawsTheSamePictureAsTheHeadlessContext) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";
  ASSERT_TRUE(gfx::windowSystemAvailable());
  const std::vector<std::uint8_t> windowed = renderOlinda(true);
  const std::vector<std::uint8_t> headless = renderOlinda(false);
  ASSERT_EQ(windowed.size(), headless.size());
  ASSERT_FALSE(windowed.empty());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < windowed.size(); ++i) differing += std::abs(int(windowed[i]) - int(headless[i])) > 1;
  EXPECT_EQ(differing, 0u);
}

}  // namespace
}  // namespace gis::test
