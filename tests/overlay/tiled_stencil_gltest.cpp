// Our stencil polyhedra in view-dependent tiles (technique "stencil-tiles", tiled_layer.hpp)
// against the CPU reference computed from the SOURCE geometry on the same depth buffer:
// - 0 wrong pixels away from edges at random cameras from 30 m to 12 km over a stiff terrain,
//   while coarse, generalised levels are drawn (the lines are dense: simplification removes
//   most of their points there) and tiles out of view are left out;
// - flights: a tile still building is stood in for by its parent (no wait), and the next still
//   image is exact again;
// - a GPU budget for one frame: tiles are evicted, images stay exact; a budget smaller than one
//   frame's tiles: the detail coarsens until they fit (the budget is a promise);
// - an edit of one feature shows in the next frame;
// - lines are at least a pixel wide (min_width_px, the default, as the scene builds them): far
//   roads stay lines instead of dots, exactly as the reference draws them.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>

#include <unistd.h>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "overlay_compare.hpp"
#include "random_features.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 224;
constexpr int kHeight = 160;

/// Lines with a point every 3 m wiggling by ±1.5 m around smooth curves: dense where seen
/// close, and generalised to a few points per tile from afar.
std::vector<geo::Feature> denseLines(std::mt19937& rng, const glm::dvec2& lo, const glm::dvec2& hi, int count) {
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), turn(-0.02, 0.02), wiggle(-1.5, 1.5);
  std::vector<geo::Feature> out;
  for (int i = 0; i < count; ++i) {
    geo::Feature f;
    f.fid = 1000 + i;
    f.attributes["width_m"] = std::int64_t{3 + (i % 4) * 5};
    glm::dvec2 p(ux(rng), uy(rng));
    double heading = 6.283 * i / count;
    geo::LineString line;
    for (int k = 0; k < 700; ++k) {
      heading += turn(rng);
      p += 3.0 * glm::dvec2(std::cos(heading), std::sin(heading));
      line.push_back(p + glm::dvec2(-std::sin(heading), std::cos(heading)) * wiggle(rng));
    }
    f.lines.push_back(std::move(line));
    out.push_back(std::move(f));
  }
  return out;
}

class TiledStencilGlTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    tree_ = std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 257, .height = 257, .seed = 9}), 16);
    bounds_ = std::make_shared<terrain::QuadtreeHeightBounds>(tree_, 1.0);
    Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree_, nullptr);
    ASSERT_TRUE(engine.ok());
    engine_.emplace(std::move(*engine));
    const terrain::TerrainGrid& grid = tree_->grid();
    lo_ = glm::min(grid.postPosition(0, 0), grid.postPosition(grid.width - 1, grid.height - 1));
    hi_ = glm::max(grid.postPosition(0, 0), grid.postPosition(grid.width - 1, grid.height - 1));
    std::mt19937 rng(41);
    std::vector<geo::Feature> roads = randomLines(rng, lo_, hi_, 10);
    for (geo::Feature& f : denseLines(rng, lo_, hi_, 12)) roads.push_back(std::move(f));
    options_.deferPieces = true;
    options_.minWidthInPixels = true;  // as the scene builds a tiled technique's layers
    overlay::CellGrid cells;
    cells.origin = lo_;
    cells.cellSize = 16 * grid.step.x;
    cells.columns = cells.rows = (grid.width - 1) / 16;
    options_.footprints.cells = cells;
    overlay::LayerStyle road;
    road.widthAttribute = "width_m";
    overlay::LayerStyle areas;
    areas.outlineWidthMetres = 0.0F;
    Result<overlay::OverlayLayer> polygons = overlay::OverlayLayer::build(
        "areas", overlay::LayerKind::Polygon, areas, randomPolygons(rng, lo_, hi_, 14), *bounds_, options_);
    Result<overlay::OverlayLayer> lines =
        overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, road, roads, *bounds_, options_);
    ASSERT_TRUE(polygons.ok() && lines.ok());
    EXPECT_EQ(polygons->stats().pieces + lines->stats().pieces, 0u) << "deferred: no pieces at load";
    polygons_.emplace(std::move(*polygons));
    lines_.emplace(std::move(*lines));
  }

  /// The technique with small tiles, so that this 5 km terrain has 4 levels (ε 80, 40, 20 m and
  /// the source geometry).
  std::unique_ptr<overlay::OverlayTechnique> technique(std::size_t budget = std::size_t{1} << 30U,
                                                       const std::string& cache = {}, const std::string& key = {},
                                                       std::size_t hostBytesInFlight = std::size_t{128} << 20U) {
    overlay::TechniqueOptions o;
    o.extent = overlay::DrapeExtent{lo_, hi_ - lo_};
    o.bounds = bounds_.get();
    o.build = options_;
    o.build.deferPieces = false;
    o.tiling.finestTileCells = 2;
    o.tiling.tileResolution = 64;
    o.tiling.gpuBudgetBytes = budget;
    o.tiling.hostBytesInFlight = hostBytesInFlight;
    o.tiling.cacheDirectory = cache;
    o.tiling.cacheKey = key;
    o.tiling.cacheRevision = bounds_->revision();
    const overlay::TechniqueInfo* info = overlay::findTechnique("stencil-tiles");
    EXPECT_NE(info, nullptr);
    Result<std::unique_ptr<overlay::OverlayTechnique>> t = info->create(o);
    EXPECT_TRUE(t.ok());
    return std::move(*t);
  }

  struct Frame {
    overlay_test::Comparison comparison;
    overlay::TechniqueFrameStats stats;
  };

  Frame draw(overlay::OverlayTechnique& t, const glm::dvec3& eye, const glm::dvec3& target, bool wait,
             bool judge = true) {
    const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
    const double nearPlane = std::clamp(0.5 * (eye.z - bounds_->globalBounds().hi), 1.0, 50.0);
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, nearPlane) * gfx::lookAt(eye, target, glm::dvec3(0, 0, 1));
    terrain::LodOptions lod;
    lod.pixelTolerance = 0.5;
    const terrain::LodSelection selection = terrain::selectLod(*tree_, {eye, viewProj, kHeight, fov}, lod);
    gfx::beginRenderPass(cache_, target_, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
    gfx::enableMaskWrites(target_.framebuffer(), false);
    engine_->draw(cache_, viewProj, eye, selection, 1.0);
    gfx::enableMaskWrites(target_.framebuffer(), true);
    const std::vector<const overlay::OverlayLayer*> layers{&*polygons_, &*lines_};
    overlay::TechniqueFrame frame;
    frame.target = {target_.framebuffer(), kWidth, kHeight};
    frame.view = {viewProj, eye, nearPlane, fov, aspect};
    frame.layers = layers;
    frame.waitForTiles = wait;
    Frame out;
    t.draw(cache_, frame, out.stats);
    if (judge) out.comparison = overlay_test::compare(target_, viewProj, layers, "stencil-tiles");
    return out;
  }

  std::shared_ptr<terrain::TerrainQuadtree> tree_;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds_;
  std::optional<terrain::TerrainEngine> engine_;
  glm::dvec2 lo_{0.0}, hi_{0.0};
  overlay::LayerBuildOptions options_;
  std::optional<overlay::OverlayLayer> polygons_, lines_;
  gfx::RenderTarget target_{kWidth, kHeight, 0, true};
};

TEST_F(TiledStencilGlTest, ExactAgainstTheSourceAtEveryDetail) {
  std::unique_ptr<overlay::OverlayTechnique> t = technique();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const HeightBounds global = bounds_->globalBounds();
  int coarse = 0, finest = 0;
  std::size_t culled = 0, covered = 0, edgeWrong = 0;
  for (int c = 0; c < 24; ++c) {
    SCOPED_TRACE("camera " + std::to_string(c));
    // From 30 m over the top of the terrain to 12 km, looking at a random point of it.
    const double height = global.hi + 30.0 * std::pow(400.0, u(rng));
    const glm::dvec2 at = lo_ + (hi_ - lo_) * glm::dvec2(u(rng), u(rng));
    const double back = (height - global.lo) * (0.3 + 2.0 * u(rng)), heading = 6.283 * u(rng);
    const glm::dvec3 eye(at - back * glm::dvec2(std::cos(heading), std::sin(heading)), height);
    const Frame f = draw(*t, eye, glm::dvec3(at, 0.5 * (global.lo + global.hi)), true);
    std::printf(
        "camera %d: eye %.0f m up, %zu tiles drawn (finest level %d), %zu covered pixels, %zu wrong away "
        "from edges, %zu on edges\n",
        c, height - global.hi, f.stats.tilesDrawn, f.stats.finestTileLevel, f.comparison.covered, f.comparison.wrong,
        f.comparison.edgeWrong);
    EXPECT_EQ(f.comparison.wrong, 0u);
    EXPECT_EQ(f.stats.tilesMissing, 0u) << "a still image waits for its tiles";
    coarse += f.stats.finestTileLevel >= 0 && f.stats.finestTileLevel < 3 ? 1 : 0;
    finest += f.stats.finestTileLevel == 3 ? 1 : 0;
    culled += f.stats.tilesCulled;
    covered += f.comparison.covered;
    edgeWrong += f.comparison.edgeWrong;
  }
  EXPECT_GT(coarse, 0) << "some views are drawn from generalised levels only";
  EXPECT_GT(finest, 0) << "some views need the source geometry";
  EXPECT_GT(culled, 0u) << "some views leave tiles out";
  EXPECT_GT(covered, 20000u);
  EXPECT_LE(edgeWrong, covered / 20);
}

TEST_F(TiledStencilGlTest, FlightsDrawParentsWhileTilesBuildAndStillsAreExact) {
  std::unique_ptr<overlay::OverlayTechnique> t = technique();
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const double top = bounds_->globalBounds().hi;
  // From afar first (coarse tiles resident), then straight down close: the fine tiles are not
  // built yet, their ancestors stand in, nothing waits.
  (void)draw(*t, glm::dvec3(centre - glm::dvec2(3000.0, 3000.0), top + 6000.0), glm::dvec3(centre, 0.0), true, false);
  const Frame flight =
      draw(*t, glm::dvec3(centre - glm::dvec2(150.0, 100.0), top + 60.0), glm::dvec3(centre, 0.0), false, false);
  EXPECT_GT(flight.stats.tilesMissing, 0u);
  EXPECT_GT(flight.stats.tilesDrawn, 0u);
  // The same view as a still: exact.
  const Frame still =
      draw(*t, glm::dvec3(centre - glm::dvec2(150.0, 100.0), top + 60.0), glm::dvec3(centre, 0.0), true);
  EXPECT_EQ(still.stats.tilesMissing, 0u);
  EXPECT_EQ(still.comparison.wrong, 0u);
  EXPECT_GT(still.comparison.covered, 100u);
}

TEST_F(TiledStencilGlTest, CoarseTilesKeepNoFootprintsAndStandInOnlyWhereTheyNeedNone) {
  std::unique_ptr<overlay::OverlayTechnique> t = technique();
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const double top = bounds_->globalBounds().hi;
  // From afar: coarse tiles, far from the eye, keep no footprints on the host.
  const Frame far =
      draw(*t, glm::dvec3(centre - glm::dvec2(3000.0, 3000.0), top + 6000.0), glm::dvec3(centre, 0.0), true);
  EXPECT_EQ(far.comparison.wrong, 0u);
  EXPECT_GT(far.stats.tilesLean, 0u);
  // A flight frame down among them, the eye a few metres over the ground, inside their boxes:
  // they cannot stand in (their pieces would be drawn z-fail, which needs the footprints), so
  // the frame waits for its own tiles, and is exact.
  const std::array<glm::dvec2, 1> spot{centre};
  const double ground = bounds_->boundsOver(spot).hi;
  ASSERT_LT(ground + 3.0, top);
  const glm::dvec3 eye(centre, ground + 3.0);
  const Frame low = draw(*t, eye, eye + glm::dvec3(400.0, 250.0, -40.0), false);
  EXPECT_EQ(low.stats.tilesMissing, 0u) << "nothing could stand in: waited";
  EXPECT_EQ(low.comparison.wrong, 0u);
  EXPECT_GT(low.comparison.covered, 0u);
}

TEST_F(TiledStencilGlTest, ABudgetForOneFrameEvictsAndStaysExact) {
  const double top = bounds_->globalBounds().hi;
  const auto at = [&](int k) { return lo_ + (hi_ - lo_) * glm::dvec2(0.2 + 0.2 * k, 0.3 + 0.1 * k); };
  // The largest of the four frames at full detail.
  std::size_t largest = 0;
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique();
    for (int k = 0; k < 4; ++k)
      largest = std::max(largest, draw(*t, glm::dvec3(at(k) - glm::dvec2(400.0, 300.0), top + 300.0),
                                       glm::dvec3(at(k), 0.0), true, false)
                                      .stats.tileBytes);
  }
  ASSERT_GT(largest, 0u);
  std::unique_ptr<overlay::OverlayTechnique> t = technique(largest);
  std::size_t evicted = 0;
  for (int k = 0; k < 4; ++k) {
    const Frame f = draw(*t, glm::dvec3(at(k) - glm::dvec2(400.0, 300.0), top + 300.0), glm::dvec3(at(k), 0.0), true);
    EXPECT_EQ(f.comparison.wrong, 0u);
    EXPECT_EQ(f.stats.tileErrorPixels, 0.5) << "every frame fits: full detail";
    evicted += f.stats.tilesEvicted;
    EXPECT_LE(t->gpuBytes(), largest) << "the budget is kept";
  }
  EXPECT_GT(evicted, 0u);
}

TEST_F(TiledStencilGlTest, ABudgetBelowOneFrameCoarsensTheDetailAndIsKept) {
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const glm::dvec3 eye(centre - glm::dvec2(900.0, 700.0), bounds_->globalBounds().hi + 500.0);
  std::unique_ptr<overlay::OverlayTechnique> full = technique();
  const Frame exact = draw(*full, eye, glm::dvec3(centre, 0.0), true);
  ASSERT_EQ(exact.comparison.wrong, 0u);
  const std::size_t budget = exact.stats.tileBytes / 3;
  std::unique_ptr<overlay::OverlayTechnique> t = technique(budget);
  bool first = true;
  for (const bool still : {true, false, false}) {
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), still);
    std::printf(
        "budget %zu of %zu bytes: %zu drawn at %.1f px, %zu wrong away from edges of %zu covered; at most %zu "
        "resident, %zu tiles built (full detail: %zu)\n",
        budget, exact.stats.tileBytes, f.stats.tileBytes, f.stats.tileErrorPixels, f.comparison.wrong,
        f.comparison.covered, f.stats.tilePeakBytes, f.stats.tilesBuilt, exact.stats.tilesBuilt);
    if (first) {
      // A detail is given up once its tiles pass the budget, not built in full first: the GPU
      // held at most the budget and the tiles that were building then (2 workers).
      EXPECT_LT(f.stats.tilePeakBytes, budget + exact.stats.tileBytes / 3);
      first = false;
    }
    EXPECT_GE(f.stats.tilePeakBytes, f.stats.tileBytes);
    EXPECT_LE(f.stats.tileBytes, budget);
    EXPECT_LE(t->gpuBytes(), budget) << "the budget is kept, also after the frame";
    EXPECT_GT(f.stats.tileErrorPixels, 0.5) << "coarser detail instead";
    // Coarser outlines: wrong pixels only near edges (within the coarser error), a few percent.
    EXPECT_LT(f.comparison.wrong, f.comparison.covered / 10);
  }
}

TEST_F(TiledStencilGlTest, TheDiskCacheTellsWhatFitsTheBudgetBeforeAnythingIsRead) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("tiled_stencil_budget_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const glm::dvec3 eye(centre - glm::dvec2(900.0, 700.0), bounds_->globalBounds().hi + 500.0);
  std::size_t full = 0;
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain A");
    full = draw(*t, eye, glm::dvec3(centre, 0.0), true, false).stats.tileBytes;
  }
  // A second run under a third of that: the files say the full detail does not fit, so it is
  // not read; the coarser one that fits is (built, as the first run did not draw it).
  std::unique_ptr<overlay::OverlayTechnique> t = technique(full / 3, dir.string(), "terrain A");
  const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
  std::printf("budget %zu of %zu bytes: at most %zu resident, drawn at %.1f px, %zu tiles read of %zu\n", full / 3,
              full, f.stats.tilePeakBytes, f.stats.tileErrorPixels, f.stats.tilesFromDisk, f.stats.tilesBuilt);
  EXPECT_LE(f.stats.tilePeakBytes, full / 3) << "nothing beyond the budget was read";
  EXPECT_GT(f.stats.tileErrorPixels, 0.5);
  EXPECT_EQ(f.comparison.wrong, 0u);
  std::filesystem::remove_all(dir);
}

TEST_F(TiledStencilGlTest, EditsShowInTheNextFrame) {
  std::unique_ptr<overlay::OverlayTechnique> t = technique();
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const glm::dvec3 eye(centre - glm::dvec2(1500.0, 1200.0), bounds_->globalBounds().hi + 1500.0);
  ASSERT_EQ(draw(*t, eye, glm::dvec3(centre, 0.0), true).comparison.wrong, 0u);
  const auto boxOf = [](const geo::Feature& f) {
    glm::dvec2 a(std::numeric_limits<double>::infinity()), b(-std::numeric_limits<double>::infinity());
    for (const geo::LineString& l : f.lines)
      for (const glm::dvec2& p : l) a = glm::min(a, p), b = glm::max(b, p);
    return std::pair{a - 50.0, b + 50.0};
  };
  // 1. Road 0 moved through the centre of the view: updated in the resident tiles that hold it or
  //    that it reaches now (featureChanged), drawn in the next frame of a flight.
  t->stopReading();
  geo::Feature moved = lines_->features()[0];
  moved.lines = {{centre - glm::dvec2(600.0, 0.0), centre, centre + glm::dvec2(300.0, 500.0)}};
  auto [lo0, hi0] = boxOf(lines_->features()[0]);
  const auto [lo1, hi1] = boxOf(moved);
  ASSERT_FALSE(lines_->replaceFeature(0, moved).hasErrors());
  t->featureChanged(1, 0, glm::min(lo0, lo1), glm::max(hi0, hi1));
  const Frame after = draw(*t, eye, glm::dvec3(centre, 0.0), false);
  EXPECT_EQ(after.comparison.wrong, 0u);
  EXPECT_EQ(after.stats.tilesMissing, 0u) << "the tiles were updated, not dropped";
  // 2. A dense road removed, then shown again wider: the same.
  t->stopReading();
  lines_->removeFeature(12);
  t->featureChanged(1, 12, lo_, hi_);
  EXPECT_EQ(draw(*t, eye, glm::dvec3(centre, 0.0), false).comparison.wrong, 0u);
  t->stopReading();
  geo::Feature wide = lines_->features()[12];
  wide.attributes["width_m"] = std::int64_t{60};
  ASSERT_FALSE(lines_->replaceFeature(12, wide).hasErrors());
  t->featureChanged(1, 12, lo_, hi_);
  EXPECT_EQ(draw(*t, eye, glm::dvec3(centre, 0.0), false).comparison.wrong, 0u);
  // 3. invalidate() of a box drops the tiles there; a frame with nothing to stand in waits.
  t->invalidate(centre - 100.0, centre + 100.0);
  const Frame rebuilt = draw(*t, eye, glm::dvec3(centre, 0.0), false);
  EXPECT_EQ(rebuilt.comparison.wrong, 0u);
  EXPECT_GT(rebuilt.stats.tilesBuilt, 0u);
}

TEST_F(TiledStencilGlTest, ASecondRunReadsItsTilesFromDisk) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("tiled_stencil_gltest_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const glm::dvec3 eye(centre - glm::dvec2(900.0, 700.0), bounds_->globalBounds().hi + 700.0);
  const glm::dvec3 far(centre - glm::dvec2(3000.0, 3000.0), bounds_->globalBounds().hi + 6000.0);
  std::vector<std::uint32_t> first, firstFar;
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain A");
    const Frame f = draw(*t, far, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(f.comparison.wrong, 0u);
    firstFar = gfx::readMask(target_);
    const Frame g = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(g.comparison.wrong, 0u);
    EXPECT_GT(f.stats.tilesBuilt + g.stats.tilesBuilt, 0u);
    EXPECT_EQ(f.stats.tilesFromDisk + g.stats.tilesFromDisk, 0u);
    first = gfx::readMask(target_);
  }
  // Room on the host for one tile at a time: each read waits for the one before to be uploaded,
  // and the images are the same.
  {
    std::unique_ptr<overlay::OverlayTechnique> t =
        technique(std::size_t{1} << 30U, dir.string(), "terrain A", std::size_t{1});
    const Frame farther = draw(*t, far, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(farther.stats.tilesFromDisk, farther.stats.tilesBuilt);
    EXPECT_GT(farther.stats.tilesFromDisk, 1u);
    EXPECT_EQ(gfx::readMask(target_), firstFar);
    EXPECT_GT(farther.stats.tileLargestReadBytes, 0u);
    EXPECT_EQ(farther.stats.tileHostPeakBytes, farther.stats.tileLargestReadBytes) << "one tile at a time";
  }
  // The same layers and terrain: every tile read, the same images; from afar the coarse tiles
  // are read lean (their GPU arrays and boxes only).
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain A");
    const Frame farther = draw(*t, far, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(farther.comparison.wrong, 0u);
    EXPECT_EQ(farther.stats.tilesFromDisk, farther.stats.tilesBuilt);
    EXPECT_GT(farther.stats.tilesLean, 0u);
    EXPECT_EQ(gfx::readMask(target_), firstFar);
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(f.comparison.wrong, 0u);
    EXPECT_EQ(f.stats.tilesFromDisk, f.stats.tilesBuilt);
    EXPECT_EQ(gfx::readMask(target_), first);
    EXPECT_GE(f.stats.tileHostPeakBytes, f.stats.tileLargestReadBytes);
    EXPECT_GT(f.stats.tileLargestReadBytes, 0u);
    // After an edit the files no longer hold the roads: theirs are not read again (the areas'
    // still are).
    t->stopReading();
    geo::Feature moved = lines_->features()[1];
    for (glm::dvec2& p : moved.lines[0]) p += glm::dvec2(40.0, 0.0);
    ASSERT_FALSE(lines_->replaceFeature(1, moved).hasErrors());
    t->featureChanged(1, 1, lo_, hi_);
    t->invalidate();
    const Frame edited = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(edited.comparison.wrong, 0u);
    EXPECT_LT(edited.stats.tilesFromDisk, edited.stats.tilesBuilt);
  }
  // Another terrain (the scene's key), or other features: built again, not read.
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain B");
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(f.stats.tilesFromDisk, 0u);
    EXPECT_EQ(f.comparison.wrong, 0u);
  }
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain A");
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_GT(f.stats.tilesBuilt, 0u);
    EXPECT_LT(f.stats.tilesFromDisk, f.stats.tilesBuilt) << "the roads changed: their tiles are built again";
    EXPECT_EQ(f.comparison.wrong, 0u);
  }
  // A damaged file is not used: built again (and written again).
  std::size_t damaged = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.path().extension() != ".tile") continue;
    // Cut short in the lean section (which a far view would read) or in the whole one.
    const std::uintmax_t size = std::filesystem::file_size(entry.path());
    std::filesystem::resize_file(entry.path(), damaged % 2 == 0 ? size / 2 : std::min<std::uintmax_t>(size, 60));
    ++damaged;
  }
  ASSERT_GT(damaged, 0u);
  {
    std::unique_ptr<overlay::OverlayTechnique> t = technique(std::size_t{1} << 30U, dir.string(), "terrain A");
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(f.stats.tilesFromDisk, 0u);
    EXPECT_EQ(f.comparison.wrong, 0u);
  }
  std::filesystem::remove_all(dir);
}

TEST_F(TiledStencilGlTest, FarLinesAreAtLeastOnePixelWide) {
  std::unique_ptr<overlay::OverlayTechnique> t = technique();
  const glm::dvec2 centre = 0.5 * (lo_ + hi_);
  const double top = bounds_->globalBounds().hi;
  std::size_t widened = 0;
  // From afar the 3–18 m roads are thinner than a pixel (about 25–60 m here).
  for (const double up : {3000.0, 9000.0}) {
    SCOPED_TRACE("eye " + std::to_string(up) + " m up");
    const glm::dvec3 eye(centre - glm::dvec2(0.6 * up, 0.5 * up), top + up);
    const glm::dmat4 viewProj = [&] {
      const double aspect = static_cast<double>(kWidth) / kHeight;
      const double nearPlane = std::clamp(0.5 * (eye.z - bounds_->globalBounds().hi), 1.0, 50.0);
      return gfx::reversedInfinitePerspective(glm::radians(50.0), aspect, nearPlane) *
             gfx::lookAt(eye, glm::dvec3(centre, 0.0), glm::dvec3(0, 0, 1));
    }();
    const Frame f = draw(*t, eye, glm::dvec3(centre, 0.0), true);
    EXPECT_EQ(f.comparison.wrong, 0u);
    // The roads as the reference draws them, and in metres only (min_width_px 0).
    const std::vector<float> depth = gfx::readDepth(target_);
    const overlay::DepthImage image{kWidth, kHeight, depth, viewProj};
    overlay::ReferenceLayer roads = overlay::referenceLayerOf(*lines_);
    std::vector<overlay::ReferenceLayer> drawn{roads};
    for (overlay::LineShape& shape : roads.shapes) {
      ASSERT_GT(shape.minWidth, 0.0) << "round lines in metres get a least width in pixels";
      shape.width = shape.minWidth;
      shape.widthPixels = shape.minWidth = 0.0;
    }
    std::vector<overlay::ReferenceLayer> metres{roads};
    const std::vector<std::uint32_t> wide = overlay::referenceMask(image, drawn);
    const std::vector<std::uint32_t> thin = overlay::referenceMask(image, metres);
    std::size_t wideCount = 0, thinCount = 0, thinNotWide = 0;
    for (std::size_t i = 0; i < wide.size(); ++i) {
      wideCount += wide[i] != 0 ? 1u : 0u;
      thinCount += thin[i] != 0 ? 1u : 0u;
      thinNotWide += thin[i] != 0 && wide[i] == 0 ? 1u : 0u;
    }
    std::printf("eye %.0f m up: road pixels %zu at min_width_px 1, %zu in metres; %zu tiles drawn\n", up, wideCount,
                thinCount, f.stats.tilesDrawn);
    EXPECT_EQ(thinNotWide, 0u) << "a least width only widens";
    // From 3 km the 18 m roads are about a pixel wide already; from 9 km none is.
    EXPECT_GT(2 * wideCount, 3 * thinCount) << "far roads are lines, not dots";
    if (up > 5000.0) {
      EXPECT_GT(wideCount, 3 * thinCount) << "far roads are lines, not dots";
    }
    widened += wideCount - thinCount;
  }
  EXPECT_GT(widened, 500u);
  // Flying in again: tiles of a wider class than needed are still exact.
  const glm::dvec3 near(centre - glm::dvec2(700.0, 500.0), top + 600.0);
  EXPECT_EQ(draw(*t, near, glm::dvec3(centre, 0.0), true).comparison.wrong, 0u);
}

}  // namespace
}  // namespace gis::test
