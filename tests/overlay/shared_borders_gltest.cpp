// Neighbouring polygons of one layer drawn without outlines (issue 41, point 4): the first 40
// census tracts of the Olinda sample, whose borders are shared, seen top-down at 480 × 360 and
// from random top-down and oblique cameras. The view-dependent tiles generalise the tracts; with
// each feature's rings simplified on their own, shared borders stopped meeting and pixels between
// two tracts were drawn by neither (12 on the top-down view) — pixels away from every edge of the
// reference, whose mask is the same on both sides of a border. The tiles now generalise a tile's
// tracts together (generaliseCoverage), so every technique draws 0 wrong pixels away from edges.
// The same tracts and the same views on the globe (the scene's "frame": "globe"; each camera
// moved from the scene's frame to longitude, latitude and height) draw 0 wrong pixels away from
// edges against the globe's geodetic reference: both frames, one set of views, one test (the
// scene drawn through scene::FrameRenderer and judged by its reference, frame_accuracy.hpp), with
// stencil-tiles, auto and stencil in each.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "frame_accuracy.hpp"
#include "gl_test.hpp"
#include "globe/ellipsoid.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/frame_scene.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "test_paths.hpp"
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
  std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  std::replace(test.begin(), test.end(), '/', '_');  // a parameterised test's name
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

/// A view of the tests in the frame of `scene`: the camera itself in the projected frame; on the
/// globe its eye and target moved from the projected scene's frame to longitude, latitude and
/// height.
scene::FrameCamera cameraIn(const scene::Scene& scene, const scene::LoadedScene& projected, const View& v) {
  if (!scene.onGlobe()) return v.camera;
  const std::optional<glm::dvec3> eye = projected.frame.toLonLat(v.camera.eye);
  const std::optional<glm::dvec3> target = projected.frame.toLonLat(v.camera.target);
  EXPECT_TRUE(eye && target) << v.label;
  if (!eye || !target) return globe::GlobeView{};
  return globe::GlobeView::looking(globe::toEcef(eye->x, eye->y, eye->z),
                                   globe::toEcef(target->x, target->y, target->z), v.camera.fovYDeg, v.width, v.height,
                                   scene.globe().heights->heightAt(eye->x, eye->y));
}

class SharedBordersGlTest : public GlTest, public ::testing::WithParamInterface<scene::FrameKind> {};

TEST_P(SharedBordersGlTest, NeighbouringTractsWithoutOutlinesLeaveNoCracks) {
  // The views, from the projected scene; the scene drawn in the frame under test.
  Result<scene::LoadedScene> projected = scene::loadScene(fortyTractsScene(scene::FrameKind::Projected));
  ASSERT_TRUE(projected.ok());
  const std::vector<View> views = fortyTractViews(*projected);
  Result<scene::Scene> loaded = scene::Scene::load(fortyTractsScene(GetParam()));
  ASSERT_TRUE(loaded.ok());
  ASSERT_EQ(loaded->onGlobe(), GetParam() == scene::FrameKind::Globe);
  const char* frame = loaded->onGlobe() ? "globe" : "projected";

  for (const char* method : {"stencil-tiles", "auto", "stencil"}) {
    SCOPED_TRACE(method);
    scene::StillSettings settings;
    settings.technique = overlay::findTechnique(method);
    ASSERT_NE(settings.technique, nullptr);
    Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(*loaded, settings);
    ASSERT_TRUE(renderer.ok());
    ASSERT_EQ((*renderer)->drawnLayerCount(), 1U);  // no outline layer
    FrameAccuracy total;
    for (const View& v : views) {
      total += judgeStill(cache_, **renderer, cameraIn(*loaded, *projected, v), v.width, v.height,
                          std::string(frame) + ", " + method + ", " + v.label);
    }
    std::printf("%s, %s: %zu views, %zu covered pixels, %zu wrong away from edges, %zu on edges\n", frame, method,
                views.size(), total.covered, total.wrong, total.edgeWrong);
    EXPECT_EQ(total.wrong, 0U);
    EXPECT_LE(total.edgeWrong, total.covered / 100);
    EXPECT_GT(total.covered, 300000U);
  }
}

INSTANTIATE_TEST_SUITE_P(BothFrames, SharedBordersGlTest, kBothFrames, frameName);

}  // namespace
}  // namespace gis::test
