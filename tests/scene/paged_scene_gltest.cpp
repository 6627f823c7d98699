// A scene whose DEM is paged: the loader builds the tile pyramid into the scene's cache
// directory once, reuses it on the next load, and the rendered image (still images wait for
// their tiles) is the in-memory terrain's, pixel for pixel, from several cameras.
#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "terrain/tile_pager.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

class PagedSceneGlTest : public GlTest {};

TEST_F(PagedSceneGlTest, PyramidIsBuiltOnceAndRendersLikeMemory) {
  Result<scene::SceneDescription> description =
      scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  ASSERT_TRUE(description.ok());
  description->layers.clear();
  description->chunkCells = 16;  // a deeper tree for a small DEM
  description->cacheDir = std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/cache-" + std::to_string(::getpid());
  std::filesystem::remove_all(description->cacheDir);

  scene::LoadOptions memoryOptions, pagedOptions;
  memoryOptions.paging = scene::TerrainPaging::Never;
  pagedOptions.paging = scene::TerrainPaging::Always;
  pagedOptions.progress = [](double) {};
  Result<scene::LoadedScene> memory = scene::loadScene(*description, memoryOptions);
  Result<scene::LoadedScene> paged = scene::loadScene(*description, pagedOptions);
  ASSERT_TRUE(memory.ok() && paged.ok());
  EXPECT_FALSE(memory->paged());
  ASSERT_TRUE(paged->paged());
  EXPECT_TRUE(paged->pyramidBuild.has_value()) << "first load builds the pyramid";
  EXPECT_TRUE(std::filesystem::exists(paged->pyramidPath));
  EXPECT_EQ(std::filesystem::path(paged->pyramidPath).parent_path(), std::filesystem::path(description->cacheDir));
  EXPECT_EQ(paged->nodataPosts, memory->nodataPosts);
  Result<scene::LoadedScene> again = scene::loadScene(*description, pagedOptions);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->pyramidBuild.has_value()) << "second load reuses it";

  Result<scene::SceneRenderer> memoryRenderer = scene::SceneRenderer::create(*memory);
  Result<scene::SceneRenderer> pagedRenderer = scene::SceneRenderer::create(*paged);
  ASSERT_TRUE(memoryRenderer.ok() && pagedRenderer.ok());
  gfx::RenderTarget target(256, 192);
  glm::dvec3 lo, hi;
  scene::terrainBox(*memory, 1.0, lo, hi);
  scene::RenderSettings settings;
  settings.lodTolerancePixels = 0.5;
  settings.waitForTiles = true;
  const glm::dvec3 centre = 0.5 * (lo + hi);
  for (const glm::dvec3& offset : {glm::dvec3(0, -1800, 900), glm::dvec3(700, 300, 250), glm::dvec3(-400, -60, 60)}) {
    scene::Camera camera = scene::overviewCamera(lo, hi);
    camera.eye = centre + offset;
    camera.target = centre;
    memoryRenderer->render(cache_, target.framebuffer(), 256, 192, camera, settings);
    const std::vector<std::uint8_t> expected = gfx::readColorRgba8(target);
    const scene::FrameStats s = pagedRenderer->render(cache_, target.framebuffer(), 256, 192, camera, settings);
    EXPECT_EQ(s.tilesMissing, 0u);
    EXPECT_EQ(s.terrainDraw.chunksMissing, 0u);
    EXPECT_EQ(gfx::readColorRgba8(target), expected) << "eye offset " << offset.x << " " << offset.y;
  }
  std::filesystem::remove_all(description->cacheDir);
}

}  // namespace
}  // namespace gis::test
