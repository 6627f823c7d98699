// Neighbouring polygons of one layer drawn without outlines (issue 41, point 4): the first 40
// census tracts of the Olinda sample, whose borders are shared, seen top-down at 480 × 360 and
// from random top-down and oblique cameras. The view-dependent tiles generalise the tracts; with
// each feature's rings simplified on their own, shared borders stopped meeting and pixels between
// two tracts were drawn by neither (12 on the top-down view) — pixels away from every edge of the
// reference, whose mask is the same on both sides of a border. The tiles now generalise a tile's
// tracts together (generaliseCoverage), so every technique draws 0 wrong pixels away from edges.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gl_test.hpp"
#include "overlay_compare.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "vector_files.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";

/// The first 40 tracts of olinda1.shp, as GeoJSON in the test's output folder.
std::string firstFortyTracts() {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "tracts_40.geojson").string();
  translateVector(kSamples + "olinda1.shp", out, {"-f", "GeoJSON", "-sql", "SELECT * FROM olinda1 WHERE FID < 40"});
  return out;
}

class SharedBordersGlTest : public GlTest {};

TEST_F(SharedBordersGlTest, NeighbouringTractsWithoutOutlinesLeaveNoCracks) {
  Result<scene::SceneDescription> olinda = scene::loadSceneFile(kSamples + "scene.json");
  ASSERT_TRUE(olinda.ok());
  scene::SceneDescription description = *olinda;
  ASSERT_GE(description.layers.size(), 1U);
  description.layers.resize(1);
  description.layers[0].source = firstFortyTracts();
  description.layers[0].sourceLayer.clear();
  description.layers[0].style.outlineWidthMetres = 0.0F;
  description.layers[0].style.outlineWidthPixels = 0.0F;
  description.imagery.reset();
  description.cacheDisabled = true;
  Result<scene::LoadedScene> loaded = scene::loadScene(description);
  ASSERT_TRUE(loaded.ok());

  // The tracts' box, from the features as read.
  const std::vector<geo::Feature>& tracts = loaded->layers.at(0).features.all();
  ASSERT_EQ(tracts.size(), 40U);
  glm::dvec2 lo(1e300), hi(-1e300);
  for (const geo::Feature& f : tracts)
    for (const geo::Polygon& p : f.polygons)
      for (const glm::dvec2& v : p.outer) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
      }
  const glm::dvec2 centre = 0.5 * (lo + hi);
  const double extent = std::max(hi.x - lo.x, hi.y - lo.y);

  struct View {
    scene::Camera camera;
    int width, height;
    std::string label;
  };
  std::vector<View> views;
  {
    // The issue's view: top-down over the 40 tracts at 480 × 360.
    View v{{}, 480, 360, "top-down over the tracts"};
    v.camera.fovYDeg = 40.0;
    v.camera.eye = glm::dvec3(centre + glm::dvec2(0.0, -1.0), 0.75 * extent / std::tan(0.35) + 50.0);
    v.camera.target = glm::dvec3(centre, 0.0);
    views.push_back(v);
    // And from two and four times as high (coarser tiles).
    for (const double f : {2.0, 4.0}) {
      View w = v;
      w.camera.eye.z *= f;
      w.label += " x" + std::to_string(static_cast<int>(f));
      views.push_back(w);
    }
  }
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), unit(0.0, 1.0);
  for (int k = 0; k < 40; ++k) {
    View v{{}, 256, 192, (k % 2 == 0 ? "top-down #" : "oblique #") + std::to_string(k)};
    v.camera.fovYDeg = 40.0;
    const glm::dvec2 t(ux(rng), uy(rng));
    const double ground = loaded->bounds->fullResolutionHeightAt(t);
    const double g = std::isnan(ground) ? 0.0 : ground;
    if (k % 2 == 0) {
      v.camera.eye = glm::dvec3(t + glm::dvec2(0.0, -1.0), g + 200.0 + 2500.0 * unit(rng));
    } else {
      const double a = 6.283 * unit(rng), d = 400.0 + 2000.0 * unit(rng);
      v.camera.eye = glm::dvec3(t + d * glm::dvec2(std::cos(a), std::sin(a)), g + 0.5 * d);
    }
    v.camera.target = glm::dvec3(t, g);
    views.push_back(v);
  }

  for (const char* method : {"stencil-tiles", "auto", "stencil"}) {
    SCOPED_TRACE(method);
    scene::OverlayBuildSettings build;
    build.technique = overlay::findTechnique(method);
    ASSERT_NE(build.technique, nullptr);
    build.tileCache = false;
    Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*loaded, build);
    ASSERT_TRUE(renderer.ok());
    std::vector<const overlay::OverlayLayer*> layers;
    for (const overlay::OverlayLayer& l : renderer->overlayLayers()) layers.push_back(&l);
    scene::RenderSettings settings;
    settings.waitForTiles = true;
    std::size_t covered = 0, wrong = 0, edgeWrong = 0;
    for (const View& v : views) {
      gfx::RenderTarget target(v.width, v.height, 0, true);
      renderer->render(cache_, target.framebuffer(), v.width, v.height, v.camera, settings);
      const double aspect = static_cast<double>(v.width) / v.height;
      const overlay_test::Comparison c = overlay_test::compare(target, v.camera.projection(aspect) * v.camera.view(),
                                                               layers, std::string(method) + ", " + v.label);
      covered += c.covered;
      wrong += c.wrong;
      edgeWrong += c.edgeWrong;
    }
    std::printf("%s: %zu views, %zu covered pixels, %zu wrong away from edges, %zu on edges\n", method, views.size(),
                covered, wrong, edgeWrong);
    EXPECT_EQ(wrong, 0U);
    EXPECT_LE(edgeWrong, covered / 100);
    EXPECT_GT(covered, 300000U);
  }
}

}  // namespace
}  // namespace gis::test
