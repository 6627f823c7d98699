// Classification error against distance, for float reversed-Z depth (GL_DEPTH32F_STENCIL8, the
// product's) and a 24-bit buffer (GL_DEPTH24_STENCIL8, reversed-Z too: the stored near / z is
// quantised in steps of 2^-24, the precision of a classic 24-bit buffer with the far plane at
// infinity). docs/depth-precision.md quotes the table this test prints and writes.
//
// One scene, built for a camera 1 km from its target and scaled to 100 m … 1000 km (terrain,
// features, road widths, relief), so that only precision changes between the distances: a gently
// rolling terrain with a flat lake (where the caps lie a pad above the terrain everywhere) under
// random areas and roads, seen steep (80°), oblique (35°) and grazing (5°), with the default
// camera's 1 m near plane and with the one the viewer's camera controller picks (half the height
// above ground, in [0.05 m, 1000 m]). Each frame goes through the real terrain and overlay
// renderers into both formats, and the D32F one again with too little padding (controls):
// - D32F: the GPU mask against the CPU reference on its own depth buffer;
// - D24: the same, which is not the truth: the reference unprojects the quantised depths, so it
//   inherits their error;
// - D24 vs truth: the D24 GPU mask against the reference on the D32F depth buffer of the same
//   frame (same camera, same pixels), away from the truth's edges.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "overlay_compare.hpp"
#include "random_features.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/quadtree.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_paths.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::test {
namespace {

using overlay_test::Comparison;
using overlay_test::percent;

constexpr int kWidth = 256;
constexpr int kHeight = 192;
constexpr int kPosts = 129;
constexpr double kFovY = 45.0 * std::numbers::pi / 180.0;
constexpr double kAspect = static_cast<double>(kWidth) / kHeight;
constexpr double kBuiltFor = 1000.0;  // the scene's distance before scaling
constexpr double kFixed24Step = 1.0 / 16777215.0;
const double kDistances[] = {100.0, 1e3, 1e4, 1e5, 1e6};

struct ViewAngle {
  const char* name;
  double degreesDown;
};
// Steep views are the hardest for the pad: along a ray that falls at angle a, the cap lies
// pad / sin(a) from the terrain under it.
const ViewAngle kAngles[] = {{"steep", 80.0}, {"oblique", 35.0}, {"grazing", 5.0}};

/// Features for the scene at 1 km, around the target (the frame origin).
struct UnitFeatures {
  std::vector<geo::Feature> areas, roads;
};

UnitFeatures unitFeatures() {
  std::mt19937 rng(29);
  const glm::dvec2 lo(-1500.0, -1500.0), hi(1500.0, 1500.0);
  UnitFeatures f;
  f.areas = randomPolygons(rng, lo, hi, 14);
  f.roads = randomLines(rng, lo, hi, 24);
  return f;
}

std::vector<geo::Feature> scaled(std::vector<geo::Feature> features, double s) {
  for (geo::Feature& f : features) {
    for (geo::Polygon& p : f.polygons) {
      for (glm::dvec2& v : p.outer) v *= s;
      for (auto& hole : p.holes) {
        for (glm::dvec2& v : hole) v *= s;
      }
    }
    for (geo::LineString& l : f.lines) {
      for (glm::dvec2& v : l) v *= s;
    }
    const auto width = f.attributes.find("width_m");
    if (width != f.attributes.end()) {  // 3x wider than random_features' roads: a few pixels at least
      width->second = 3.0 * static_cast<double>(std::get<std::int64_t>(width->second)) * s;
    }
  }
  return features;
}

struct Scene {
  std::shared_ptr<terrain::TerrainQuadtree> tree;
  std::optional<terrain::TerrainEngine> engine;
  std::vector<overlay::OverlayLayer> layers;
  std::vector<const overlay::OverlayLayer*> drawn;
};

Scene buildScene(double distance, const UnitFeatures& unit) {
  const double s = distance / kBuiltFor;
  // 8 distances across, relief 4 % of the distance (the grazing eye stays above it), the flat
  // lake of makeStiffTerrain (centred on post (0.7 w, 0.3 h), radius 0.1 w) at the origin.
  const double spacing = 8.0 * distance / (kPosts - 1), mid = 0.5 * (kPosts - 1);
  const glm::dvec2 lake(0.7 * kPosts - mid, mid - 0.3 * kPosts);
  auto grid = makeStiffTerrain({.width = kPosts,
                                .height = kPosts,
                                .spacing = spacing,
                                .seed = 7,
                                .cliffs = false,
                                .spike = false,
                                .holes = false,
                                .lowest = 0.0,
                                .highest = 40.0 * s,
                                .centre = -spacing * lake});
  Scene scene;
  scene.tree = std::make_shared<terrain::TerrainQuadtree>(grid, 16);
  const terrain::QuadtreeHeightBounds bounds(scene.tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(scene.tree, nullptr);
  EXPECT_TRUE(engine.ok());
  if (!engine) return scene;
  scene.engine = std::move(*engine);
  overlay::LayerBuildOptions options;
  options.footprints.chordTolerance = 0.02 * s;
  overlay::CellGrid cells;
  cells.origin = grid->postPosition(0, grid->height - 1);
  cells.cellSize = 16 * grid->step.x;
  cells.columns = cells.rows = (grid->width - 1) / 16;
  options.footprints.cells = cells;
  overlay::LayerStyle area, road;
  road.widthAttribute = "width_m";
  road.join = overlay::LineJoin::Miter;
  road.cap = overlay::LineCap::Square;
  Result<overlay::OverlayLayer> areas =
      overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, area, scaled(unit.areas, s), bounds, options);
  Result<overlay::OverlayLayer> roads =
      overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, road, scaled(unit.roads, s), bounds, options);
  EXPECT_TRUE(areas.ok() && roads.ok());
  if (!areas || !roads) return scene;
  scene.layers.push_back(std::move(*areas));
  scene.layers.push_back(std::move(*roads));
  for (const overlay::OverlayLayer& l : scene.layers) scene.drawn.push_back(&l);
  return scene;
}

/// The terrain's height under a frame point (bilinear between posts).
double groundAt(const terrain::TerrainGrid& grid, const glm::dvec2& xy) {
  const glm::dvec2 g = glm::clamp(grid.gridCoordinates(xy), glm::dvec2(0.0), glm::dvec2(grid.width - 1.001));
  const int c = static_cast<int>(g.x), r = static_cast<int>(g.y);
  const double u = g.x - c, v = g.y - r;
  return (1 - v) * ((1 - u) * grid.at(c, r) + u * grid.at(c + 1, r)) +
         v * ((1 - u) * grid.at(c, r + 1) + u * grid.at(c + 1, r + 1));
}

/// The near plane the viewer's camera controller picks (apps/common/src/camera_controller.cpp,
/// nearFor): half the eye's height above the ground, at most half the orbit distance, clamped to
/// [0.05 m, 1000 m].
double controllerNear(double heightAboveGround, double distance) {
  return std::clamp(0.5 * std::min(heightAboveGround, distance), 0.05, 1000.0);
}

Comparison count(const std::vector<std::uint32_t>& gpu, const std::vector<std::uint32_t>& expected,
                 const std::vector<std::uint8_t>& edges) {
  Comparison c;
  for (std::size_t i = 0; i < gpu.size(); ++i) {
    c.covered += expected[i] != 0 ? 1u : 0u;
    if (gpu[i] != expected[i]) ++(edges[i] != 0 ? c.edgeWrong : c.wrong);
  }
  return c;
}

void add(Comparison& total, const Comparison& c) {
  total.covered += c.covered;
  total.wrong += c.wrong;
  total.edgeWrong += c.edgeWrong;
}

// The table's formats, per frame. The controls draw the D32F frame again with less padding
// than the renderer's, to show the comparison finds what too little padding does.
enum Measure : std::size_t { kD32F, kD24, kD24VsTruth, kD24Aware, kD24AwareVsTruth, kNoPad, kPadOneStep, kMeasures };
const char* const kMeasureNames[kMeasures] = {
    "D32F",         "D24 linear pad",  "D24 linear vs truth", "D24 d2 pad", "D24 d2 pad vs truth",
    "D32F, no pad", "D32F, pad 1e-7 s"};

/// One row of the table: a distance, a choice of near plane and a format, summed over the angles.
struct Row {
  double distance = 0.0;
  std::string nearPlane;  ///< "1 m" or "viewer"
  std::string format;
  Comparison c;
  nlohmann::json frames = nlohmann::json::array();
};

class DepthPrecisionGlTest : public GlTest {
 protected:
  struct Frame {
    std::array<Comparison, kMeasures> c;
    std::vector<double> d24StepRatios;  ///< |z24 − z32| / (the 24-bit step at z32), per terrain pixel
  };

  /// Draws one frame into both targets (and the controls into the D32F one) and compares.
  Frame measure(Scene& scene, const overlay::OverlayView& view, const std::string& label) {
    const terrain::LodSelection selection =
        terrain::selectLod(*scene.tree, {view.eye, view.viewProj, kHeight, kFovY}, {});
    auto draw = [&](gfx::RenderTarget& target, const overlay::OverlaySettings& settings) {
      overlay_test::drawTerrainAndLayers(cache_, target, *scene.engine, *overlays_, selection, view, scene.drawn,
                                         settings);
    };
    gfx::RenderTarget& d32 = *d32Target_;
    gfx::RenderTarget& d24 = *d24Target_;
    Frame f;
    draw(d32, {});
    const std::vector<float> depth32 = gfx::readDepth(d32);
    const overlay::DepthImage image32{kWidth, kHeight, depth32, view.viewProj};
    const std::vector<overlay::ReferenceLayer> ref = overlay_test::referenceLayers(scene.drawn);
    const std::vector<std::uint32_t> truth = overlay::referenceMask(image32, ref);
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image32, ref);
    f.c[kD32F] = count(gfx::readMask(d32), truth, edges);

    // The renderer pads for the 24-bit steps (distance²) unless told not to: first without, the
    // physics of a linear pad on a fixed-point buffer, then as a client gets it.
    draw(d24, {.padForDepthFormat = false});
    f.c[kD24] = overlay_test::compare(d24, view.viewProj, scene.drawn, label, false);
    f.c[kD24VsTruth] = count(gfx::readMask(d24), truth, edges);
    draw(d24, {});
    f.c[kD24Aware] = overlay_test::compare(d24, view.viewProj, scene.drawn, label, false);
    f.c[kD24AwareVsTruth] = count(gfx::readMask(d24), truth, edges);
    const std::vector<float> depth24 = gfx::readDepth(d24);
    for (std::size_t i = 0; i < depth32.size(); ++i) {
      if (depth32[i] <= 0.0F || depth24[i] <= 0.0F || edges[i] != 0) continue;
      const double z32 = view.nearPlane / depth32[i], z24 = view.nearPlane / depth24[i];
      f.d24StepRatios.push_back(std::abs(z24 - z32) / (z32 * z32 / view.nearPlane * kFixed24Step));
    }

    draw(d32, {.padBase = 0.0, .padPerMetre = 0.0});
    f.c[kNoPad] = count(gfx::readMask(d32), truth, edges);
    draw(d32, {.padBase = 0.0, .padPerMetre = 1e-7});  // below one float step (2^-23 ≈ 1.2e-7) per metre
    f.c[kPadOneStep] = count(gfx::readMask(d32), truth, edges);
    return f;
  }

  // Made in the test body, with the context current.
  std::optional<overlay::OverlayRenderer> overlays_;
  std::optional<gfx::RenderTarget> d32Target_, d24Target_;
};

TEST_F(DepthPrecisionGlTest, ClassificationErrorAgainstDistanceForFloatAnd24BitDepth) {
  Result<overlay::OverlayRenderer> created = overlay::OverlayRenderer::create();
  ASSERT_TRUE(created.ok());
  overlays_ = std::move(*created);
  d32Target_.emplace(kWidth, kHeight, 0, true, gfx::DepthFormat::Float32);
  d24Target_.emplace(kWidth, kHeight, 0, true, gfx::DepthFormat::Fixed24);
  ASSERT_TRUE(d32Target_->complete() && d24Target_->complete());
  ASSERT_EQ(d24Target_->depthFormat(), gfx::DepthFormat::Fixed24);
  const UnitFeatures unit = unitFeatures();
  const overlay::OverlaySettings settings;
  std::vector<Row> rows;
  std::vector<double> d24StepRatios;
  for (const double distance : kDistances) {
    Scene scene = buildScene(distance, unit);
    ASSERT_TRUE(scene.engine && scene.drawn.size() == 2);
    const terrain::TerrainGrid& grid = scene.tree->grid();
    const glm::dvec3 target(0.0, 0.0, groundAt(grid, glm::dvec2(0.0)));
    for (const char* nearChoice : {"1 m", "viewer"}) {
      std::array<Row, kMeasures> here;
      for (std::size_t m = 0; m < kMeasures; ++m) here[m] = {distance, nearChoice, kMeasureNames[m], {}, {}};
      for (const ViewAngle& angle : kAngles) {
        // From the north-east, over the lake's edge, towards the larger part of the terrain.
        const double down = angle.degreesDown * std::numbers::pi / 180.0, yaw = 0.6;
        const glm::dvec3 eye = target + distance * glm::dvec3(std::cos(down) * std::cos(yaw),
                                                              std::cos(down) * std::sin(yaw), std::sin(down));
        const double near =
            std::string(nearChoice) == "1 m" ? 1.0 : controllerNear(eye.z - groundAt(grid, glm::dvec2(eye)), distance);
        const glm::dmat4 viewProj =
            gfx::reversedInfinitePerspective(kFovY, kAspect, near) * gfx::lookAt(eye, target, {0, 0, 1});
        const std::string label =
            std::to_string(static_cast<long>(distance)) + " m " + angle.name + " near " + std::to_string(near) + " m";
        const Frame f = measure(scene, {viewProj, eye, near, kFovY, kAspect}, label);
        EXPECT_EQ(f.c[kD32F].wrong, 0u) << label << ": float reversed-Z must classify every pixel away from edges";
        EXPECT_GT(f.c[kD32F].covered, 1000u) << label;
        d24StepRatios.insert(d24StepRatios.end(), f.d24StepRatios.begin(), f.d24StepRatios.end());
        for (std::size_t m = 0; m < kMeasures; ++m) {
          add(here[m].c, f.c[m]);
          here[m].frames.push_back({{"view", angle.name},
                                    {"near_m", near},
                                    {"covered", f.c[m].covered},
                                    {"wrong", f.c[m].wrong},
                                    {"edge_wrong", f.c[m].edgeWrong}});
        }
      }
      for (Row& r : here) rows.push_back(std::move(r));
    }
  }

  std::printf("%10s  %-6s  %-16s  %8s  %7s  %8s  %10s\n", "distance", "near", "format", "covered", "wrong", "wrong %",
              "edge wrong");
  nlohmann::json out = nlohmann::json::array();
  for (const Row& r : rows) {
    std::printf("%10.0f  %-6s  %-16s  %8zu  %7zu  %8.3f  %10zu\n", r.distance, r.nearPlane.c_str(), r.format.c_str(),
                r.c.covered, r.c.wrong, percent(r.c.wrong, r.c.covered), r.c.edgeWrong);
    out.push_back({{"distance_m", r.distance},
                   {"near", r.nearPlane},
                   {"format", r.format},
                   {"covered", r.c.covered},
                   {"wrong", r.c.wrong},
                   {"wrong_percent", percent(r.c.wrong, r.c.covered)},
                   {"edge_wrong", r.c.edgeWrong},
                   {"frames", r.frames}});
  }
  std::sort(d24StepRatios.begin(), d24StepRatios.end());
  const double medianRatio = d24StepRatios.empty() ? 0.0 : d24StepRatios[d24StepRatios.size() / 2];
  std::printf("D24 depth against D32F: median |z24 - z32| = %.3f steps of z^2 / (near 2^24) over %zu pixels\n",
              medianRatio, d24StepRatios.size());
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "depth_precision.json") << nlohmann::json{{"width", kWidth},
                                                                {"height", kHeight},
                                                                {"fov_y_deg", 45.0},
                                                                {"pad_base_m", settings.padBase},
                                                                {"pad_per_metre", settings.padPerMetre},
                                                                {"median_d24_error_steps", medianRatio},
                                                                {"rows", out}}
                                                     .dump(2)
                                              << "\n";
  std::printf("written: %s\n", (dir / "depth_precision.json").c_str());

  // Beyond the loop's checks (docs/depth-precision.md explains the numbers): only what the
  // physics says, not counts.
  auto row = [&](double distance, const std::string& nearPlane, Measure m) -> const Comparison& {
    return std::find_if(rows.begin(), rows.end(),
                        [&](const Row& r) {
                          return r.distance == distance && r.nearPlane == nearPlane && r.format == kMeasureNames[m];
                        })
        ->c;
  };
  auto wrongPercent = [&](double distance, const std::string& nearPlane, Measure m) {
    return percent(row(distance, nearPlane, m).wrong, row(distance, nearPlane, m).covered);
  };
  for (const double distance : kDistances) {
    for (const std::string nearPlane : {"1 m", "viewer"}) {
      const std::string at = std::to_string(static_cast<long>(distance)) + " m, near " + nearPlane;
      EXPECT_LE(row(distance, nearPlane, kD32F).edgeWrong, row(distance, nearPlane, kD32F).covered / 200) << at;
      // The comparison does see too little padding, at every distance.
      EXPECT_GT(wrongPercent(distance, nearPlane, kNoPad), 0.5) << at;
      EXPECT_GT(row(distance, nearPlane, kPadOneStep).wrong, 0u) << at;
      // A larger near plane makes the 24-bit steps finer.
      EXPECT_LE(wrongPercent(distance, "viewer", kD24VsTruth), wrongPercent(distance, "1 m", kD24VsTruth)) << at;
    }
  }
  // 24-bit: at 100 m the step (under 1.5 cm out to the farthest terrain, 660 m) is below the pad.
  EXPECT_EQ(row(100.0, "1 m", kD24VsTruth).wrong, 0u);
  EXPECT_EQ(row(100.0, "viewer", kD24VsTruth).wrong, 0u);
  // With a 1 m near plane the step outgrows the pad at about 1 km: errors grow with distance.
  EXPECT_GT(wrongPercent(1e4, "1 m", kD24VsTruth), 5.0);
  for (std::size_t i = 1; i + 1 < std::size(kDistances); ++i) {
    EXPECT_LT(wrongPercent(kDistances[i], "1 m", kD24VsTruth), wrongPercent(kDistances[i + 1], "1 m", kD24VsTruth))
        << kDistances[i];
  }
  // The viewer's near plane, at most 1000 m, holds it only to some 40 km.
  EXPECT_GT(wrongPercent(1e6, "viewer", kD24VsTruth), 1.0);
  // With the renderer's padding for fixed-point buffers (distance² / (near · 2^23)), a 24-bit
  // buffer classifies exactly what it holds: with the viewer's near plane at every distance, with
  // 1 m out to 100 km (beyond, its depth steps reach kilometres: the terrain itself is wrong).
  for (const double distance : kDistances) {
    const std::string at = std::to_string(static_cast<long>(distance)) + " m";
    EXPECT_EQ(row(distance, "viewer", kD24Aware).wrong, 0u) << at;
    EXPECT_EQ(row(distance, "viewer", kD24AwareVsTruth).wrong, 0u) << at;
    if (distance <= 1e5) {
      EXPECT_EQ(row(distance, "1 m", kD24Aware).wrong, 0u) << at;
    }
    if (distance <= 1e4) {
      EXPECT_EQ(row(distance, "1 m", kD24AwareVsTruth).wrong, 0u) << at;
    }
  }
  // The 24-bit depths are the float ones rounded to the step: off by a quarter step at the median.
  EXPECT_GT(medianRatio, 0.15);
  EXPECT_LT(medianRatio, 0.35);
}

}  // namespace
}  // namespace gis::test
