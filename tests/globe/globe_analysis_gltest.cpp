// Lasso selection and layer overlap on the globe (docs/globe.md) against their CPU twins on the
// same depth buffer: 0 differing pixels away from edges from space, across the antimeridian, over
// both poles and from 1 m above the ground, for every operator.
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "globe/globe_terrain.hpp"
#include "globe_scene.hpp"
#include "scene/globe_selection.hpp"
#include "scene/lasso_file.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/globe_selection.hpp"
#include "vector_overlay/selection_renderer.hpp"
#include "vector_overlay/selection_states.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::globe {
namespace {

class GlobeAnalysisGl : public test::GlTest {
 protected:
  static void SetUpTestSuite() {
    test::GlTest::SetUpTestSuite();
    grid() = test::globe_scene::syntheticGrid(0.5);
  }
  static std::shared_ptr<const GeoGrid>& grid() {
    static std::shared_ptr<const GeoGrid> g;
    return g;
  }

  static GlobeView view(const Geodetic& eye, const Geodetic& target, double fov = 45.0) {
    return GlobeView::looking(toEcef(eye), toEcef(target), fov, 256, 256, grid()->heightAt(eye.lon, eye.lat));
  }

  /// The terrain of the view in `target`, stencil 0; the tiles drawn.
  std::vector<DrawnTile> drawTerrain(GlobeTerrain& terrain, const gfx::RenderTarget& target, const GlobeView& v) {
    const std::vector<DrawnTile> tiles = terrain.select(v);
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F, 0.0F, 0.0F, 1.0F), gfx::kReversedZFar, 0});
    gfx::enableMaskWrites(target.framebuffer(), false);
    terrain.draw(cache_, v, tiles);
    gfx::enableMaskWrites(target.framebuffer(), true);
    return tiles;
  }
};

struct Case {
  std::string label;
  Geodetic eye, target;
  double fov = 45.0;
};

std::vector<Case> views() {
  const double fieldHeight = test::globe_scene::syntheticGrid(0.5)->heightAt(8.5, 47.3);
  const double eyeHeight = test::globe_scene::syntheticGrid(0.5)->heightAt(8.5, 47.30407);
  return {
      {"space 10,000 km", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
      {"oblique 800 km", {-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
      {"antimeridian oblique", {165.0, -40.0, 6e5}, {-178.0, -21.0, 0.0}},
      {"north pole from above", {0.0, 90.0, 3e6}, {0.0, 90.0, 0.0}},
      {"south pole low", {45.0, -86.0, 20000.0}, {-135.0, -89.0, 0.0}},
      {"1 m above the ground", {8.5, 47.30407, eyeHeight + 1.0}, {8.5005, 47.304, fieldHeight}, 60.0},
      // Inside the 70 stacked strips: their pieces hold the eye (drawn z-fail, clipped at the
      // near plane and closed there for the open faces' count).
      {"inside the strips, 1 m up",
       {8.5005, 47.305, test::globe_scene::syntheticGrid(0.5)->heightAt(8.5005, 47.305) + 1.0},
       {8.5005, 47.3085, fieldHeight},
       60.0},
  };
}

/// Two layers that overlap everywhere the cases look: the test scene's features, and boxes over
/// them (across ±180° too, over the north pole, a cap around the south pole), and a strip over the
/// field stacked 70 times, so one pixel lies in more pieces of one layer than a group counts.
struct Layers {
  GlobeLayer a, b;
};

Layers makeLayers() {
  Result<GlobeLayer> a =
      GlobeLayer::build("features", test::globe_scene::features(), glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  geo::Feature boxes;
  boxes.polygons.push_back(test::globe_scene::box(-70.0, -40.0, -50.0, -10.0));
  boxes.polygons.push_back(test::globe_scene::box(160.0, -30.0, 200.0, -10.0));
  boxes.polygons.push_back(test::globe_scene::box(-20.0, 60.0, 40.0, 85.0));
  geo::Polygon southCap;  // around the south pole, no pole point (closed along it)
  for (int k = 0; k < 36; ++k) southCap.outer.emplace_back(180.0 - k * 10.0, -84.0 + 2.0 * std::sin(k * 0.5));
  boxes.polygons.push_back(southCap);
  geo::Feature strip;  // over the field, stacked: more pieces over a pixel than a group counts
  strip.polygons.push_back(test::globe_scene::box(8.5003, 47.2999, 8.5008, 47.3100));
  std::vector<geo::Feature> features(70, strip);
  features.push_back(boxes);
  Result<GlobeLayer> b = GlobeLayer::build("boxes", features, glm::vec4(0.9F, 0.4F, 0.1F, 0.5F));
  EXPECT_TRUE(a.ok() && b.ok());
  return {std::move(*a), std::move(*b)};
}

TEST_F(GlobeAnalysisGl, OverlapOfTwoLayersMatchesTheReferenceForEveryOperator) {
  const Layers layers = makeLayers();
  GlobeTerrain terrain(grid());
  GlobeOverlayRenderer overlay;
  const std::vector<Case> cases = views();
  const std::array<overlay::OverlapOp, 4> ops{overlay::OverlapOp::And, overlay::OverlapOp::Or, overlay::OverlapOp::Xor,
                                              overlay::OverlapOp::Subtract};
  for (const Case& c : cases) {
    const GlobeView v = view(c.eye, c.target, c.fov);
    gfx::RenderTarget target(v.width, v.height, 0, true);
    const std::vector<DrawnTile> tiles = drawTerrain(terrain, target, v);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> expected = overlay::referenceMask(
        depthImageOf(v, depth), referenceLayersOf({&layers.a, &layers.b}, depthImageOf(v, depth)));
    const std::vector<std::uint8_t> edges =
        overlay::edgePixels(depthImageOf(v, depth), referenceLayersOf({&layers.a, &layers.b}, depthImageOf(v, depth)));
    std::size_t both = 0;
    for (const std::uint32_t e : expected) both += e == 3U ? 1U : 0U;
    // One operator per view (each in more than one view), marked anew each time: the cover zeroes.
    const overlay::OverlapOp op = ops[static_cast<std::size_t>(&c - cases.data()) % ops.size()];
    const GLuint zero[4] = {0, 0, 0, 0};
    glClearNamedFramebufferuiv(target.framebuffer(), GL_COLOR, 1, zero);  // the mask attachment
    // The stencil core of both frames on the tiles' chunks; every other view counts in groups of
    // 63 pieces, as a layer that may overlap deeper than the count holds is drawn.
    overlay::OverlayRenderer& overlays = *overlay.renderer();
    overlay::OverlaySettings settings = overlaySettingsOf({});
    settings.forceGroups = (&c - cases.data()) % 2 == 0;
    const overlay::AnalysisMarks marks =
        overlays.markOverlap(cache_, overlayViewOf(v), overlay.chunks(v, tiles, *grid(), layers.a),
                             overlay.chunks(v, tiles, *grid(), layers.b), settings);
    const std::vector<std::uint8_t> flags = gfx::readStencil(target);
    overlays.coverOverlap(cache_, marks, op, glm::vec4(1.0F, 0.0F, 1.0F, 0.6F), 1.0F);
    const std::vector<std::uint32_t> shown = gfx::readMask(target);
    const std::vector<std::uint8_t> after = gfx::readStencil(target);
    std::size_t wrongFlags = 0, wrongShown = 0, edgeWrong = 0, left = 0, holds = 0;
    for (std::size_t i = 0; i < flags.size(); ++i) {
      left += after[i] != 0 ? 1U : 0U;
      const bool a = (flags[i] & overlay::kOverlapFlagA) != 0, b = (flags[i] & overlay::kOverlapFlagB) != 0;
      const bool ea = (expected[i] & 1U) != 0, eb = (expected[i] & 2U) != 0;
      const bool want = overlay::overlapHolds(op, ea, eb);
      holds += want ? 1U : 0U;
      if (a == ea && b == eb && (shown[i] != 0) == want) continue;
      if (edges[i] != 0) {
        ++edgeWrong;
        continue;
      }
      wrongFlags += a != ea || b != eb ? 1U : 0U;
      wrongShown += (shown[i] != 0) != want ? 1U : 0U;
      if (wrongFlags + wrongShown < 4) {
        ADD_FAILURE() << c.label << ": pixel (" << i % 256 << ", " << i / 256 << ") flags " << int(flags[i])
                      << ", reference " << expected[i] << ", shown " << shown[i];
      }
    }
    std::printf("%-24s %-8s groups %3zu pieces %5zu both %6zu shown %6zu wrong %zu/%zu edge %zu\n", c.label.c_str(),
                overlay::overlapOpName(op), marks.a.groups + marks.b.groups,
                marks.a.zPassPieces + marks.a.zFailPieces + marks.b.zPassPieces + marks.b.zFailPieces, both, holds,
                wrongFlags, wrongShown, edgeWrong);
    EXPECT_EQ(wrongFlags, 0U) << c.label;
    EXPECT_EQ(wrongShown, 0U) << c.label;
    EXPECT_EQ(left, 0U) << c.label << ": the cover leaves the stencil 0";
    EXPECT_GE(marks.a.groups + marks.b.groups, 2U) << c.label;
    EXPECT_GT(both, 100U) << c.label << ": the view must show the layers overlapping";
    // Every piece closed: front and back faces cancel on every pixel, the pieces drawn z-fail
    // (which may hold the eye) clipped at the near plane and closed there, none left out.
    for (const GlobeLayer* layer : {&layers.a, &layers.b}) {
      const overlay::AnalysisMarks counted =
          overlays.countOpenFaces(cache_, overlayViewOf(v), overlay.chunks(v, tiles, *grid(), *layer), settings);
      const std::vector<std::uint8_t> counts = gfx::readStencil(target);
      overlays.coverOpenFaces(cache_, counted, glm::vec4(0.0F, 1.0F, 0.0F, 1.0F));
      std::size_t open = 0;
      for (const std::uint8_t n : counts) open += n != 0 ? 1U : 0U;
      EXPECT_EQ(open, 0U) << c.label << " " << layer->name() << ": open volumes";
      EXPECT_GT(counted.a.zPassPieces, 0U) << c.label;
      EXPECT_EQ(counted.uncountedPieces, 0U) << c.label << " " << layer->name() << ": pieces left out of the count";
      if (c.label.starts_with("inside") && layer == &layers.b) {
        EXPECT_GE(counted.a.zFailPieces, 70U) << c.label << ": the strips hold the eye";
      }
      const std::vector<std::uint8_t> cleared = gfx::readStencil(target);
      EXPECT_EQ(std::count(cleared.begin(), cleared.end(), std::uint8_t{0}),
                static_cast<std::ptrdiff_t>(cleared.size()));
    }
  }
}

/// A lasso of `n` points on an ellipse (pixels) in a view of 256².
std::vector<glm::dvec2> ellipse(double cx, double cy, double rx, double ry, int n = 24) {
  std::vector<glm::dvec2> points;
  for (int k = 0; k < n; ++k) {
    const double t = 2.0 * 3.14159265358979323846 * k / n;
    points.emplace_back(cx + rx * std::cos(t), cy + ry * std::sin(t));
  }
  return points;
}

TEST_F(GlobeAnalysisGl, LassoSelectionMatchesItsTwinForEveryOperator) {
  Result<overlay::SelectionRenderer> created = overlay::SelectionRenderer::create();
  ASSERT_TRUE(created.ok());
  overlay::SelectionRenderer& selection = *created;
  GlobeTerrain terrain(grid());
  const std::vector<Case> cases = views();
  // A lasso drawn from space over South America, evaluated in every view (it selects nothing in
  // most of them but the oblique one: the twin must agree there too).
  const GlobeView space = view(cases[0].eye, cases[0].target);
  const overlay::Lasso fromSpace = lassoIn(space, ellipse(128.0, 128.0, 40.0, 70.0));
  for (const Case& c : cases) {
    const GlobeView v = view(c.eye, c.target, c.fov);
    gfx::RenderTarget target(v.width, v.height, 0, true);
    drawTerrain(terrain, target, v);
    const std::vector<float> depth = gfx::readDepth(target);
    using Op = overlay::SelectionOp;
    const overlay::Lasso big = lassoIn(v, ellipse(120.0, 130.0, 90.0, 70.0));
    const overlay::Lasso left = lassoIn(v, {{10.0, 20.0}, {150.0, 40.0}, {90.0, 240.0}, {20.0, 200.0}});
    const overlay::Lasso star = lassoIn(v, {{128.0, 5.0}, {160.0, 250.0}, {10.0, 90.0}, {250.0, 90.0}, {96.0, 250.0}});
    const std::vector<std::pair<std::string, std::vector<overlay::SelectionStep>>> chains{
        {"single", {{Op::Single, big}}},
        {"or", {{Op::Single, big}, {Op::Or, left}}},
        {"and", {{Op::Single, big}, {Op::And, left}}},
        {"xor star", {{Op::Single, big}, {Op::Xor, star}}},
        {"subtract", {{Op::Single, big}, {Op::Subtract, left}}},
        {"invert", {{Op::Single, big}, {Op::Subtract, star}, {Op::Invert, {}}}},
        {"from space", {{Op::Single, fromSpace}, {Op::Or, left}}},
    };
    for (const auto& [name, steps] : chains) {
      const Diagnostics d = selection.setSteps(steps);
      EXPECT_FALSE(d.hasErrors()) << c.label << " " << name;
      const overlay::SelectionFrameStats s = selection.select(cache_, overlayViewOf(v));
      const std::vector<std::uint8_t> stencil = gfx::readStencil(target);
      selection.clear(cache_);
      const std::vector<std::uint8_t> twin = overlay::selectionMask(depthImageOf(v, depth), steps);
      const std::vector<std::uint32_t> bits(twin.begin(), twin.end());
      const std::vector<std::uint8_t> edges = overlay::maskEdges(bits, depthImageOf(v, depth));
      std::size_t selected = 0, wrong = 0, edgeWrong = 0;
      for (std::size_t i = 0; i < twin.size(); ++i) {
        const bool gpu = (stencil[i] & overlay::kSelectedBit) != 0;
        selected += twin[i] != 0 ? 1U : 0U;
        if (gpu == (twin[i] != 0)) continue;
        if (edges[i] != 0) {
          ++edgeWrong;
        } else if (wrong++ < 3) {
          ADD_FAILURE() << c.label << " " << name << ": pixel (" << i % 256 << ", " << i / 256 << ") GPU " << gpu
                        << ", twin " << int(twin[i]) << ", depth " << depth[i];
        }
      }
      std::printf("%-24s %-10s volumes %zu selected %6zu wrong %zu edge %zu\n", c.label.c_str(), name.c_str(),
                  s.volumes, selected, wrong, edgeWrong);
      EXPECT_EQ(wrong, 0U) << c.label << " " << name;
      if (name == "single") {
        EXPECT_GT(selected, 2000U) << c.label << ": the lasso must select ground";
      }
    }
  }
}

TEST(GlobeLogicalSelection, FeaturesAreSelectedWhereTheirGroundIsAndFullyInsideWhenAllOfItIs) {
  scene::LoadedGlobeScene scene;
  scene.heights = test::globe_scene::syntheticGrid(2.0);
  Result<GlobeLayer> layer =
      GlobeLayer::build("features", test::globe_scene::features(), glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  ASSERT_TRUE(layer.ok());
  scene.layers.push_back(std::move(*layer));
  scene.layerFileIndex.push_back(0);
  // From 10,000 km over South America: a lasso around the whole wedge (feature 0) and into
  // nothing else; a second, small one inside the wedge only.
  const GlobeView space = GlobeView::looking(toEcef(-60.0, -20.0, 1e7), toEcef(-60.0, -20.0, 0.0), 45.0, 256, 256);
  const auto pixelOf = [&](double lon, double lat) {
    const glm::dvec4 c = space.viewProj() * glm::dvec4(toEcef(lon, lat, 0.0), 1.0);
    return glm::dvec2((c.x / c.w + 1.0) * 128.0, (1.0 - c.y / c.w) * 128.0);
  };
  std::vector<glm::dvec2> around;
  for (const auto& [lon, lat] : std::vector<std::pair<double, double>>{
           {-90.0, 20.0}, {-25.0, 5.0}, {-28.0, -30.0}, {-70.0, -63.0}, {-88.0, -15.0}})
    around.push_back(pixelOf(lon, lat));
  const std::vector<overlay::SelectionStep> whole{{overlay::SelectionOp::Single, lassoIn(space, around)}};
  const scene::GlobeSelection all = scene::selectOnGlobe(scene, whole, space, 20000.0);
  ASSERT_EQ(all.layers.size(), 1U);
  ASSERT_EQ(all.layers[0].features.size(), 1U);
  EXPECT_EQ(all.layers[0].features[0].feature, 0U);
  EXPECT_TRUE(all.layers[0].features[0].fullyInside);
  EXPECT_GT(all.layers[0].features[0].samples, 1000U);
  const std::vector<overlay::SelectionStep> part{
      {overlay::SelectionOp::Single,
       lassoIn(space, {pixelOf(-62.0, -18.0), pixelOf(-58.0, -18.0), pixelOf(-58.0, -22.0), pixelOf(-62.0, -22.0)})}};
  const scene::GlobeSelection some = scene::selectOnGlobe(scene, part, space, 20000.0);
  ASSERT_EQ(some.layers[0].features.size(), 1U);
  EXPECT_FALSE(some.layers[0].features[0].fullyInside);
  EXPECT_LT(some.layers[0].features[0].selectedSamples, some.layers[0].features[0].samples / 10);
  // Inverted: everything but the small lasso — every feature, none of them whole but the others.
  std::vector<overlay::SelectionStep> inverted = part;
  inverted.push_back({overlay::SelectionOp::Invert, {}});
  const scene::GlobeSelection rest = scene::selectOnGlobe(scene, inverted, space, 20000.0);
  ASSERT_EQ(rest.layers[0].features.size(), 6U);
  EXPECT_EQ(rest.layers[0].fullyInside, 5U);
}

TEST(GlobeLassoFile, CamerasInLonLatArePlacedOnTheGlobeAndFrameCoordinatesAreRefused) {
  const auto ground = test::globe_scene::syntheticGrid(2.0);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "globe_lasso_file_test";
  std::filesystem::create_directories(dir);
  const nlohmann::json camera = {{"eye", {{"lon", -60.0}, {"lat", -20.0}, {"h", 1e7}}},
                                 {"target", {{"lon", -60.0}, {"lat", -20.0}, {"h", 0.0}}},
                                 {"width", 200},
                                 {"height", 100}};
  std::ofstream(dir / "camera.json") << camera.dump();
  const nlohmann::json lassos = {
      {"lassos",
       {{{"op", "single"}, {"points", {{10, 10}, {100, 10}, {50, 80}}}},
        {{"op", "or"}, {"camera", "camera.json"}, {"points", {{10, 10}, {100, 10}, {50, 80}}}},
        {{"op", "and"},
         {"camera", {{"eye_xyz", {1.0, 2.0, 3.0}}, {"target_xyz", {0.0, 0.0, 0.0}}}},
         {"points", {{10, 10}, {100, 10}, {50, 80}}}}}}};
  std::ofstream(dir / "lassos.json") << lassos.dump();
  const GlobeView current = GlobeView::looking(toEcef(10.0, 45.0, 2e6), toEcef(10.0, 45.0, 0.0), 45.0, 320, 240);
  const Result<scene::SelectionRequest> read =
      scene::loadGlobeLassoFile((dir / "lassos.json").string(), current, *ground);
  ASSERT_TRUE(read.ok());
  ASSERT_EQ(read->steps.size(), 2U) << "the lasso with a camera in frame coordinates is left out";
  EXPECT_TRUE(read.diagnostics.hasErrors());
  EXPECT_NE(read.diagnostics.items().back().toString().find("lasso 3"), std::string::npos);
  // The first lasso: the current view; the second: the camera file's, with its viewport.
  EXPECT_EQ(read->steps[0].lasso.width, 320);
  EXPECT_EQ(read->steps[1].lasso.width, 200);
  EXPECT_EQ(read->steps[1].lasso.height, 100);
  // Each reaches its eye's horizon, not through the globe: from 10,000 km up, about 15,000 km.
  EXPECT_NEAR(read->steps[1].lasso.distance, horizonReach(toEcef(-60.0, -20.0, 1e7), 10000.0), 1e5);
  EXPECT_GT(read->steps[1].lasso.distance, 1.45e7);
  EXPECT_LT(read->steps[1].lasso.distance, 1.6e7);
  // The camera file's view looks straight down at (−60°, −20°): that point projects to the centre.
  const glm::dvec4 clip = read->steps[1].lasso.viewProj * glm::dvec4(toEcef(-60.0, -20.0, 0.0), 1.0);
  EXPECT_NEAR(clip.x / clip.w, 0.0, 1e-9);
  EXPECT_NEAR(clip.y / clip.w, 0.0, 1e-9);
  const glm::dvec4 current0 = read->steps[0].lasso.viewProj * glm::dvec4(toEcef(10.0, 45.0, 0.0), 1.0);
  EXPECT_NEAR(current0.x / current0.w, 0.0, 1e-9);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gis::globe
