// Neighbouring polygons of one layer drawn without outlines (issue 41, point 4): the first 40
// census tracts of the Olinda sample, whose borders are shared, seen top-down at 480 × 360 and
// from random top-down and oblique cameras. The view-dependent tiles generalise the tracts; with
// each feature's rings simplified on their own, shared borders stopped meeting and pixels between
// two tracts were drawn by neither (12 on the top-down view) — pixels away from every edge of the
// reference, whose mask is the same on both sides of a border. The tiles now generalise a tile's
// tracts together (generaliseCoverage), so every technique draws 0 wrong pixels away from edges.
// The same tracts and the same views on the globe (the scene's "frame": "globe"; each camera
// moved from the scene's frame to longitude, latitude and height) draw 0 wrong pixels away from
// edges against the globe's geodetic reference: both frames, one set of views.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "globe/ellipsoid.hpp"
#include "overlay_compare.hpp"
#include "scene/globe_renderer.hpp"
#include "scene/globe_scene.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "vector_files.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";

/// The first 40 tracts of olinda1.shp, as GeoJSON in the test's output folder. The file is named
/// after the running test: ctest runs this file's tests in parallel, and two tests writing one
/// file while the other reads it read an empty layer.
std::string firstFortyTracts() {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  const std::string out = (dir / ("tracts_40_" + test + ".geojson")).string();
  translateVector(kSamples + "olinda1.shp", out, {"-f", "GeoJSON", "-sql", "SELECT * FROM olinda1 WHERE FID < 40"});
  return out;
}

/// The scene of the 40 tracts without outlines, in the projected frame or on the globe.
scene::SceneDescription fortyTractsScene(scene::FrameKind frame) {
  Result<scene::SceneDescription> olinda = scene::loadSceneFile(kSamples + "scene.json");
  EXPECT_TRUE(olinda.ok());
  scene::SceneDescription description = *olinda;
  description.layers.resize(1);
  description.layers[0].source = firstFortyTracts();
  description.layers[0].sourceLayer.clear();
  description.layers[0].style.outlineWidthMetres = 0.0F;
  description.layers[0].style.outlineWidthPixels = 0.0F;
  description.imagery.reset();
  description.cacheDisabled = true;
  description.frame = frame;
  return description;
}

struct View {
  scene::Camera camera;
  int width, height;
  std::string label;
};

/// The views of both frames' tests, in the projected scene's frame: top-down over the tracts at
/// the issue's 480 × 360 and from two and four times as high, then 40 random top-down and oblique
/// views at 256 × 192.
std::vector<View> fortyTractViews(const scene::LoadedScene& loaded) {
  const std::vector<geo::Feature>& tracts = loaded.layers.at(0).features.all();
  EXPECT_EQ(tracts.size(), 40U);
  glm::dvec2 lo(1e300), hi(-1e300);
  for (const geo::Feature& f : tracts)
    for (const geo::Polygon& p : f.polygons)
      for (const glm::dvec2& v : p.outer) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
      }
  const glm::dvec2 centre = 0.5 * (lo + hi);
  const double extent = std::max(hi.x - lo.x, hi.y - lo.y);
  std::vector<View> views;
  {
    View v{{}, 480, 360, "top-down over the tracts"};
    v.camera.fovYDeg = 40.0;
    v.camera.eye = glm::dvec3(centre + glm::dvec2(0.0, -1.0), 0.75 * extent / std::tan(0.35) + 50.0);
    v.camera.target = glm::dvec3(centre, 0.0);
    views.push_back(v);
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
    const double ground = loaded.bounds->fullResolutionHeightAt(t);
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
  return views;
}

class SharedBordersGlTest : public GlTest {};

TEST_F(SharedBordersGlTest, NeighbouringTractsWithoutOutlinesLeaveNoCracks) {
  Result<scene::LoadedScene> loaded = scene::loadScene(fortyTractsScene(scene::FrameKind::Projected));
  ASSERT_TRUE(loaded.ok());
  const std::vector<View> views = fortyTractViews(*loaded);

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

TEST_F(SharedBordersGlTest, OnTheGlobeTheSameTractsAndViewsLeaveNoCracks) {
  Result<scene::LoadedScene> projected = scene::loadScene(fortyTractsScene(scene::FrameKind::Projected));
  ASSERT_TRUE(projected.ok());
  const std::vector<View> views = fortyTractViews(*projected);
  Result<scene::LoadedGlobeScene> onGlobe = scene::loadGlobeScene(fortyTractsScene(scene::FrameKind::Globe));
  ASSERT_TRUE(onGlobe.ok());
  ASSERT_EQ(onGlobe->layers.size(), 1U);  // no outline layer
  const std::vector<const globe::GlobeLayer*> layers{&onGlobe->layers[0]};
  globe::GlobeRenderer renderer(onGlobe->heights);
  std::size_t covered = 0, wrong = 0, edgeWrong = 0;
  for (const View& v : views) {
    // The camera on the globe: its eye and target moved from the scene's frame.
    const std::optional<glm::dvec3> eye = projected->frame.toLonLat(v.camera.eye);
    const std::optional<glm::dvec3> target = projected->frame.toLonLat(v.camera.target);
    ASSERT_TRUE(eye && target) << v.label;
    const globe::GlobeView view =
        globe::GlobeView::looking(globe::toEcef(eye->x, eye->y, eye->z), globe::toEcef(target->x, target->y, target->z),
                                  v.camera.fovYDeg, v.width, v.height, onGlobe->heights->heightAt(eye->x, eye->y));
    gfx::RenderTarget frame(v.width, v.height, 0, true);
    renderer.render(cache_, {frame.framebuffer(), v.width, v.height, true}, view, layers);
    const std::vector<float> depth = gfx::readDepth(frame);
    const std::vector<std::uint32_t> gpu = gfx::readMask(frame);
    const overlay::DepthImage image = globe::depthImageOf(view, depth);
    const std::vector<std::uint32_t> expected = overlay::referenceMask(image, globe::coverageOf(layers, image));
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, globe::edgeLayersOf(layers, image));
    std::size_t viewWrong = 0;
    for (std::size_t i = 0; i < gpu.size(); ++i) {
      covered += expected[i] != 0 ? 1U : 0U;
      if (gpu[i] == expected[i]) continue;
      if (edges[i] != 0) {
        ++edgeWrong;
      } else if (viewWrong++ < 3) {
        ADD_FAILURE() << v.label << ": pixel (" << i % static_cast<std::size_t>(v.width) << ", "
                      << i / static_cast<std::size_t>(v.width) << ") drawn " << gpu[i] << ", reference " << expected[i];
      }
    }
    wrong += viewWrong;
  }
  std::printf("globe: %zu views, %zu covered pixels, %zu wrong away from edges, %zu on edges\n", views.size(), covered,
              wrong, edgeWrong);
  EXPECT_EQ(wrong, 0U);
  EXPECT_LE(edgeWrong, covered / 100);
  EXPECT_GT(covered, 300000U);
}

}  // namespace
}  // namespace gis::test
