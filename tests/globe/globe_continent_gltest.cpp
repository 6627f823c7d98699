// The globe overlay on a real continental scene (docs/globe.md, docs/globe-scene.md): the DCW
// borders of Chile, Fiji and Antarctica over a DEM shaped by GSHHG's coastlines, made by
// scripts/globe_scene.sh from Debian's packages, read as a scene, drawn from space, over the
// coast from 5 km, across the antimeridian and over the south pole, and compared pixel by pixel
// with the CPU reference on the same depth buffer.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "scene/globe_renderer.hpp"
#include "scene/globe_scene.hpp"
#include "test_paths.hpp"

namespace gis::globe {
namespace {

class GlobeContinentGl : public test::GlTest {};

TEST_F(GlobeContinentGl, ExactOverRealBordersFromSpaceToTheCoast) {
  const std::filesystem::path out = std::filesystem::path(STENCIL_GIS_TEST_OUTPUT_DIR) / "scene";
  std::filesystem::create_directories(out);
  const std::string script = std::string(STENCIL_GIS_SAMPLES_DIR) + "/../scripts/globe_scene.sh";
  const std::string command =
      "COUNTRIES=CL,FJ,AQ RES=1 bash '" + script + "' '" + out.string() + "' > '" + out.string() + "/script.log' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command << " (see script.log)";

  Result<scene::SceneDescription> description = scene::loadSceneFile((out / "scene.json").string());
  ASSERT_TRUE(description.ok());
  Result<std::string> reason = scene::globeReason(*description);
  ASSERT_TRUE(reason.ok());
  EXPECT_FALSE(reason->empty()) << "the scene is drawn on the globe";
  Result<scene::LoadedGlobeScene> loaded = scene::loadGlobeScene(*description);
  ASSERT_TRUE(loaded.ok());
  ASSERT_EQ(loaded->layers.size(), 1u);
  std::size_t vertices = 0;
  for (const GlobePolygon& p : loaded->layers[0].polygons()) {
    for (const auto& ring : p.rings) vertices += ring.size();
  }
  std::printf("%zu polygons, %zu vertices (densified) in the countries layer\n", loaded->layers[0].polygons().size(),
              vertices);
  EXPECT_GT(vertices, 50000u);

  const std::vector<const GlobeLayer*> layers{&loaded->layers[0]};
  GlobeRenderer renderer(loaded->heights);
  struct Case {
    std::string label;
    Geodetic eye, target;
    std::size_t minCovered;
  };
  const std::vector<Case> cases{
      {"Chile from 8,000 km", {-70.0, -35.0, 8e6}, {-70.0, -35.0, 0.0}, 300},
      {"Chilean coast from 5 km", {-71.9, -33.25, 5000.0}, {-71.55, -33.0, 0.0}, 1000},
      {"Tierra del Fuego, 60 km", {-68.6, -56.3, 6e4}, {-68.8, -55.3, 0.0}, 1000},
      {"Fiji across 180°, 400 km", {178.5, -19.5, 4e5}, {179.9, -16.9, 0.0}, 100},
      {"south pole from 3,000 km", {0.0, -90.0, 3e6}, {0.0, -90.0, 0.0}, 20000},
      {"Antarctic coast, oblique", {-60.0, -58.0, 8e5}, {-60.0, -68.0, 0.0}, 1000},
  };
  for (const Case& c : cases) {
    const GlobeView view = GlobeView::looking(toEcef(c.eye), toEcef(c.target), 45.0, 256, 256,
                                              loaded->heights->heightAt(c.eye.lon, c.eye.lat));
    gfx::RenderTarget target(256, 256, 0, true);
    const GlobeFrameStats stats = renderer.render(cache_, {target.framebuffer(), 256, 256, true}, view, layers);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> gpu = gfx::readMask(target);
    const std::vector<std::uint32_t> expected =
        overlay::referenceMask(depthImageOf(view, depth), referenceLayersOf(layers, depthImageOf(view, depth)));
    const std::vector<std::uint8_t> edges =
        overlay::edgePixels(depthImageOf(view, depth), referenceLayersOf(layers, depthImageOf(view, depth)));
    std::size_t covered = 0, wrong = 0, edgeWrong = 0;
    for (std::size_t i = 0; i < gpu.size(); ++i) {
      covered += expected[i] != 0 ? 1U : 0U;
      if (gpu[i] == expected[i]) continue;
      if (edges[i] != 0) {
        ++edgeWrong;
      } else if (wrong++ < 5) {
        ADD_FAILURE() << c.label << ": pixel (" << i % 256 << ", " << i / 256 << ") GPU " << gpu[i] << ", reference "
                      << expected[i];
      }
    }
    std::printf("%-28s tiles %4zu pieces %5zu (z-fail %zu) covered %6zu wrong %zu edge-wrong %zu\n", c.label.c_str(),
                stats.terrain.tiles, stats.overlay.pieces, stats.overlay.zFailPieces, covered, wrong, edgeWrong);
    EXPECT_EQ(wrong, 0u) << c.label;
    EXPECT_GE(covered, c.minCovered) << c.label << ": the view must show the borders";
  }
}

}  // namespace
}  // namespace gis::globe
