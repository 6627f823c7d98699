// The overlay methods against the CPU reference on Olinda, from afar, oblique and close up:
// - our stencil polyhedra and the seed paper's construction: no wrong pixel away from edges;
// Texture draping (the baseline):
// - the GPU mask the terrain pass writes from the drape is exactly the drape texel under each
//   pixel's terrain point (pixels whose point lies within 1/1000 texel of a texel border are not
//   judged: float uv rounding);
// - its error against the CPU reference (away from feature edges) shrinks as the texture grows,
//   and is not zero at coarse sizes seen close up, where our stencil polyhedra have none on the
//   same depth.
// Draping per tile: its error shrinks as the tiles grow; tiles are rasterised once and kept
// while the view needs them.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "olinda_cameras.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "test_paths.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 256;
constexpr int kHeight = 192;

struct Judged {
  std::size_t terrain = 0;      ///< pixels with terrain, away from feature edges
  std::size_t wrong = 0;        ///< against the CPU reference
  std::size_t unlikeTexel = 0;  ///< the GPU mask is not the texel under the point
};

/// Olinda, and three cameras: the overview, oblique 1.7 km away, and 150 m over the town
/// looking along the coast.
class MethodsGlTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    Result<scene::SceneDescription> description =
        scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
    ASSERT_TRUE(description.ok());
    Result<scene::LoadedScene> loaded = scene::loadScene(*description);
    ASSERT_TRUE(loaded.ok());
    scene_ = std::move(*loaded);
    cameras_ = olindaCameras(*scene_);
  }

  std::optional<scene::LoadedScene> scene_;
  std::vector<scene::Camera> cameras_;
};

TEST_F(MethodsGlTest, StencilMethodsAreExactAndTheDrapeErrorShrinksWithItsTexture) {
  std::optional<scene::LoadedScene>& scene = scene_;
  const std::vector<scene::Camera>& cameras = cameras_;

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  settings.lodTolerancePixels = 0.5;
  const double aspect = static_cast<double>(kWidth) / kHeight;

  // Our method on the same cameras, for the contrast, and the paper's construction.
  Result<scene::SceneRenderer> stencil = scene::SceneRenderer::create(*scene);
  ASSERT_TRUE(stencil.ok());
  scene::OverlayBuildSettings paperBuild;
  paperBuild.technique = overlay::findTechnique("paper");
  ASSERT_NE(paperBuild.technique, nullptr);
  Result<scene::SceneRenderer> paper = scene::SceneRenderer::create(*scene, paperBuild);
  ASSERT_TRUE(paper.ok());
  const auto judge = [&](scene::SceneRenderer& renderer, const scene::Camera& camera,
                         const overlay::TextureDrape* drape) {
    // Each technique against the reference of its own layers: ours draws lines at least a pixel
    // wide (min_width_px), the whole-load techniques at their width in metres.
    std::vector<overlay::ReferenceLayer> ref;
    for (const overlay::OverlayLayer& l : renderer.overlayLayers()) ref.push_back(overlay::referenceLayerOf(l));
    renderer.render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();
    const overlay::DepthImage image{kWidth, kHeight, depth, viewProj};
    const std::vector<std::uint32_t> reference = overlay::referenceMask(image, ref);
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
    const std::vector<std::uint32_t> texels = drape ? drape->readMask() : std::vector<std::uint32_t>{};
    const glm::dmat4 inverse = glm::inverse(viewProj);
    Judged j;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
        if (!(depth[i] > 0.0F)) continue;
        if (drape) {
          const glm::dvec4 p = inverse * glm::dvec4(2.0 * (x + 0.5) / kWidth - 1.0, 1.0 - 2.0 * (y + 0.5) / kHeight,
                                                    static_cast<double>(depth[i]), 1.0);
          const glm::dvec2 ground = glm::dvec2(p) / p.w;
          const glm::dvec2 t = (ground - drape->extent().origin) / drape->extent().size * double(drape->size());
          const glm::dvec2 fromBorder = glm::abs(t - glm::round(t));
          if (std::min(fromBorder.x, fromBorder.y) > 1e-3) {
            j.unlikeTexel += drape->maskAt(texels, ground) != mask[i] ? 1u : 0u;
          }
        }
        if (edges[i] != 0) continue;
        ++j.terrain;
        j.wrong += mask[i] != reference[i] ? 1u : 0u;
      }
    }
    return j;
  };

  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const Judged ours = judge(*stencil, cameras[c], nullptr);
    std::printf("camera %zu: stencil polyhedra %zu of %zu pixels wrong away from edges\n", c, ours.wrong, ours.terrain);
    EXPECT_EQ(ours.wrong, 0u);
    // Boxes of other features behind the terrain once erased marks here (their depth-fail zeroed).
    const Judged papers = judge(*paper, cameras[c], nullptr);
    std::printf("camera %zu: the paper's construction %zu of %zu pixels wrong away from edges\n", c, papers.wrong,
                papers.terrain);
    EXPECT_EQ(papers.wrong, 0u);
    double previous = 1.0;
    for (const int size : {256, 1024, 4096}) {
      scene::OverlayBuildSettings build;
      build.technique = overlay::findTechnique("drape");
      build.textureSize = size;
      Result<scene::SceneRenderer> draped = scene::SceneRenderer::create(*scene, build);
      ASSERT_TRUE(draped.ok());
      draped->render(cache_, target.framebuffer(), kWidth, kHeight, cameras[c], settings);  // builds the drape
      ASSERT_NE(draped->textureDrape(), nullptr);
      const Judged j = judge(*draped, cameras[c], draped->textureDrape());
      const double error = static_cast<double>(j.wrong) / static_cast<double>(std::max<std::size_t>(j.terrain, 1));
      std::printf("camera %zu: drape %d² (%.2f m texels): %zu of %zu pixels wrong (%.3f %%), %zu unlike the texel\n", c,
                  size, draped->textureDrape()->extent().size.x / size, j.wrong, j.terrain, 100.0 * error,
                  j.unlikeTexel);
      EXPECT_GT(j.terrain, 5000u);
      EXPECT_EQ(j.unlikeTexel, 0u);
      if (size == 256 && c > 0) {
        // Seen from afar a pixel is as big as a texel; close up, a 40 m texel cannot hold 6 m outlines.
        EXPECT_GT(j.wrong, 0u) << "close up, a coarse drape must show its texels";
      }
      EXPECT_LE(error, previous) << "a larger texture must not be further off";
      if (previous > 0.0 && c > 0) {
        EXPECT_LT(error, previous);
      }
      previous = error;
    }
  }
}

TEST_F(MethodsGlTest, TiledDrapeErrorShrinksWithItsTilesAndTilesAreKept) {
  std::optional<scene::LoadedScene>& scene = scene_;

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  settings.lodTolerancePixels = 0.5;
  const double aspect = static_cast<double>(kWidth) / kHeight;
  Result<scene::SceneRenderer> stencil = scene::SceneRenderer::create(*scene);
  ASSERT_TRUE(stencil.ok());
  std::vector<overlay::ReferenceLayer> ref;
  for (const overlay::OverlayLayer& l : stencil->overlayLayers()) ref.push_back(overlay::referenceLayerOf(l));

  for (const scene::Camera& camera : {cameras_[1], cameras_[2]}) {  // close up: the coarse tiles show
    double previous = 1.0;
    for (const int size : {64, 256, 1024}) {
      scene::OverlayBuildSettings build;
      build.technique = overlay::findTechnique("drape-tiles");
      build.textureSize = size;
      Result<scene::SceneRenderer> tiled = scene::SceneRenderer::create(*scene, build);
      ASSERT_TRUE(tiled.ok());
      const scene::FrameStats first = tiled->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
      EXPECT_TRUE(first.draped);
      EXPECT_GT(first.texturesBuilt, 0u);
      // The same view again: every tile is resident.
      const scene::FrameStats again = tiled->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
      EXPECT_EQ(again.texturesBuilt, 0u);
      EXPECT_GT(tiled->techniqueGpuBytes(), 0u);
      const std::vector<float> depth = gfx::readDepth(target);
      const std::vector<std::uint32_t> mask = gfx::readMask(target);
      const overlay::DepthImage image{kWidth, kHeight, depth, camera.projection(aspect) * camera.view()};
      const std::vector<std::uint32_t> reference = overlay::referenceMask(image, ref);
      const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
      std::size_t judged = 0, wrong = 0;
      for (std::size_t i = 0; i < mask.size(); ++i) {
        if (!(depth[i] > 0.0F) || edges[i] != 0) continue;
        ++judged;
        wrong += mask[i] != reference[i] ? 1u : 0u;
      }
      const double error = static_cast<double>(wrong) / static_cast<double>(std::max<std::size_t>(judged, 1));
      std::printf("drape tiles %d²: %zu of %zu pixels wrong away from edges (%.3f %%), %zu tiles\n", size, wrong,
                  judged, 100.0 * error, first.texturesBuilt);
      EXPECT_GT(judged, 5000u);
      if (size == 64) {
        EXPECT_GT(wrong, 0u) << "close up, 64² tiles must show their texels";
      }
      EXPECT_LT(error, previous) << "larger tiles must be closer";
      previous = error;
    }
  }
}

TEST_F(MethodsGlTest, TilesReadTheirFeaturesFromDiskAndDrawWhatTheyDrawFromMemory) {
  // The scene of SetUp keeps its layers' features in the layer cache (read one at a time by the
  // tiles that need them); this one holds them in memory.
  Result<scene::SceneDescription> description =
      scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  ASSERT_TRUE(description.ok());
  scene::LoadOptions inMemory;
  inMemory.layerCache = false;
  Result<scene::LoadedScene> memory = scene::loadScene(*description, inMemory);
  ASSERT_TRUE(memory.ok());
  ASSERT_EQ(memory->layers.size(), scene_->layers.size());
  for (std::size_t l = 0; l < scene_->layers.size(); ++l) {
    EXPECT_TRUE(scene_->layers[l].features.onDisk()) << scene_->layers[l].description.name;
    EXPECT_FALSE(memory->layers[l].features.onDisk());
    EXPECT_EQ(scene_->layers[l].vertexCount(), memory->layers[l].vertexCount());
  }
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;
  settings.lodTolerancePixels = 0.5;
  scene::OverlayBuildSettings build;
  build.tileCache = false;  // every tile built from its features, none read built
  Result<scene::SceneRenderer> fromDisk = scene::SceneRenderer::create(*scene_, build);
  Result<scene::SceneRenderer> fromMemory = scene::SceneRenderer::create(*memory, build);
  ASSERT_TRUE(fromDisk.ok() && fromMemory.ok());
  ASSERT_EQ(fromDisk.diagnostics.items().size(), fromMemory.diagnostics.items().size());
  for (std::size_t i = 0; i < fromDisk.diagnostics.items().size(); ++i)
    EXPECT_EQ(fromDisk.diagnostics.items()[i].toString(), fromMemory.diagnostics.items()[i].toString());
  std::size_t covered = 0;
  for (const scene::Camera& camera : cameras_) {
    EXPECT_GT(fromDisk->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings).overlayTiles.tilesBuilt,
              0u);
    const std::vector<std::uint32_t> disk = gfx::readMask(target);
    fromMemory->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
    const std::vector<std::uint32_t> held = gfx::readMask(target);
    EXPECT_EQ(disk, held) << "the same tiles from features on disk and in memory";
    for (const std::uint32_t m : held) covered += m != 0 ? 1u : 0u;
  }
  EXPECT_GT(covered, 1000u);
  // Drawing read only the features the tiles needed: none of the layers was read whole.
  for (const scene::LoadedLayer& layer : scene_->layers)
    EXPECT_TRUE(layer.features.onDisk()) << layer.description.name << " was read into memory";
}

}  // namespace
}  // namespace gis::test
