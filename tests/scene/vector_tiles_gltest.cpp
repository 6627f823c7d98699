// Olinda's tracts drawn from Mapbox Vector Tiles (an MBTiles file that GDAL writes from the
// sample at zoom 17, as a tile server would serve them) against the CPU reference computed from
// the source Shapefile: the tiles' quantisation (0.09 m at zoom 17, stated by the reader) is far
// below a pixel at these cameras, so the layer mask has no wrong pixel away from the source's
// edges (1 px), from afar, oblique and close up.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "olinda_cameras.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "test_paths.hpp"
#include "vector_files.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 256;
constexpr int kHeight = 192;
const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";

/// The tracts as MBTiles of zoom 17 (GDAL's MVT writer, 4096 units a tile), layer "tracts".
std::string tractsAsMbtiles() {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "tracts_z17.mbtiles").string();
  translateVector(kSamples + "olinda1.shp", out,
                  {"-f", "MBTiles", "-preserve_fid", "-dsco", "MINZOOM=17", "-dsco", "MAXZOOM=17", "-nln", "tracts"});
  return out;
}

class VectorTilesGlTest : public GlTest {};

TEST_F(VectorTilesGlTest, TractsFromMbtilesMatchTheReferenceOfTheSourceAwayFromEdges) {
  Result<scene::SceneDescription> source = scene::loadSceneFile(kSamples + "scene.json");
  ASSERT_TRUE(source.ok());
  ASSERT_GE(source->layers.size(), 1u);
  ASSERT_EQ(source->layers[0].name, "census tracts");
  scene::SceneDescription tiled = *source;
  tiled.layers[0].source = tractsAsMbtiles();
  tiled.layers[0].sourceLayer = "tracts";

  Result<scene::LoadedScene> fromSource = scene::loadScene(*source);
  ASSERT_TRUE(fromSource.ok());
  Result<scene::LoadedScene> fromTiles = scene::loadScene(tiled);
  ASSERT_TRUE(fromTiles.ok());
  bool said = false;
  for (const Diagnostic& d : fromTiles.diagnostics.items())
    said = said || d.message.find("quantised") != std::string::npos;
  EXPECT_TRUE(said) << "the reader states the tiles' quantisation";

  Result<scene::SceneRenderer> sourceRenderer = scene::SceneRenderer::create(*fromSource);
  ASSERT_TRUE(sourceRenderer.ok());
  Result<scene::SceneRenderer> tileRenderer = scene::SceneRenderer::create(*fromTiles);
  ASSERT_TRUE(tileRenderer.ok());
  ASSERT_EQ(tileRenderer->overlayLayers().size(), sourceRenderer->overlayLayers().size());
  EXPECT_EQ(tileRenderer->overlayLayers()[0].geometry().features().size(), 470u);
  // The reference: the source's geometry, not the tiles'.
  std::vector<overlay::ReferenceLayer> reference;
  for (const overlay::OverlayLayer& l : sourceRenderer->overlayLayers())
    reference.push_back(overlay::referenceLayerOf(l));

  const std::vector<scene::Camera> cameras = olindaCameras(*fromSource);

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  settings.lodTolerancePixels = 0.5;
  const double aspect = static_cast<double>(kWidth) / kHeight;
  std::size_t covered = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    tileRenderer->render(cache_, target.framebuffer(), kWidth, kHeight, cameras[c], settings);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    const overlay::DepthImage image{kWidth, kHeight, depth, cameras[c].projection(aspect) * cameras[c].view()};
    const std::vector<std::uint32_t> expected = overlay::referenceMask(image, reference);
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, reference);
    std::size_t judged = 0, wrong = 0;
    for (std::size_t i = 0; i < mask.size(); ++i) {
      if (!(depth[i] > 0.0F) || edges[i] != 0) continue;
      ++judged;
      covered += (expected[i] & 1u) != 0 ? 1u : 0u;
      wrong += mask[i] != expected[i] ? 1u : 0u;
    }
    std::printf("camera %zu: %zu of %zu pixels wrong away from the source's edges\n", c, wrong, judged);
    EXPECT_EQ(wrong, 0u) << "camera " << c;
    EXPECT_GT(judged, 5000u);
  }
  EXPECT_GT(covered, 20000u) << "the tracts cover the views";
}

}  // namespace
}  // namespace gis::test
