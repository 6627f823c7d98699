// No cracks: stiff terrain (400 m cliffs between neighbouring posts, a 900 m spike) drawn
// headless with mixed levels of detail, from cameras whose every view ray must hit the terrain
// (looking down from inside the DEM, no horizon, no DEM border in view). Any background pixel
// is a crack. Over the trials, neighbours of every level pair (l, l+1) occur.
#include <functional>
#include <map>
#include <random>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "paged_terrain.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_paths.hpp"
#include "test_terrain.hpp"

namespace gis::test {
namespace {

constexpr int kSize = 192;

class TerrainCracksGlTest : public GlTest {};

TEST_F(TerrainCracksGlTest, NoBackgroundLeaksAtLodBoundariesOfEveryLevelPair) {
  auto tree = std::make_shared<const terrain::TerrainQuadtree>(
      makeStiffTerrain({.width = 513, .height = 513, .seed = 8, .holes = false}), 16);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  ASSERT_TRUE(engine.ok());
  gfx::RenderTarget target(kSize, kSize);
  const terrain::TerrainGrid& grid = tree->grid();
  const glm::dvec2 lo = grid.postPosition(0, grid.height - 1), hi = grid.postPosition(grid.width - 1, 0);
  const double margin = 200.0;
  const terrain::NodeInfo& root = tree->info(tree->root());
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> ux(lo.x + margin, hi.x - margin), uy(lo.y + margin, hi.y - margin);
  std::uniform_real_distribution<double> above(50.0, 2500.0), pitch(55.0, 89.0), yaw(0.0, 360.0);
  const double fov = 30.0;
  std::set<int> pairs;
  int trials = 0, leaks = 0;
  while (trials < 60) {
    const glm::dvec3 eye(ux(rng), uy(rng), root.maxHeight + above(rng));
    const double p = glm::radians(pitch(rng)), y = glm::radians(yaw(rng));
    const glm::dvec3 forward(std::cos(p) * std::sin(y), std::cos(p) * std::cos(y), -std::sin(p));
    const glm::dmat4 view = glm::lookAtRH(eye, eye + forward, glm::dvec3(0, 0, 1));
    const glm::dmat4 proj = gfx::reversedInfinitePerspective(glm::radians(fov), 1.0, 1.0);
    // Every corner ray (with a 10 % widening) must go down and reach z = min inside the DEM.
    const glm::dmat4 inverseView = glm::inverse(view);
    bool allInside = true;
    const double t = std::tan(glm::radians(fov) / 2.0) * 1.1;
    for (const auto& [sx, sy] :
         {std::pair{-1.0, -1.0}, std::pair{1.0, -1.0}, std::pair{-1.0, 1.0}, std::pair{1.0, 1.0}}) {
      const glm::dvec3 dir = glm::dvec3(inverseView * glm::dvec4(sx * t, sy * t, -1.0, 0.0));
      if (dir.z >= -1e-6) {
        allInside = false;
        break;
      }
      const glm::dvec3 hit = eye + dir * ((root.minHeight - eye.z) / dir.z);
      allInside = allInside && hit.x > lo.x + 1 && hit.x < hi.x - 1 && hit.y > lo.y + 1 && hit.y < hi.y - 1;
    }
    if (!allInside) continue;
    ++trials;

    terrain::LodView lodView;
    lodView.eye = eye;
    lodView.viewProj = proj * view;
    lodView.viewportHeight = kSize;
    lodView.fovYRadians = glm::radians(fov);
    terrain::LodOptions options;
    const double tolerances[] = {0.25, 1.0, 4.0, 16.0, 64.0};
    options.pixelTolerance = tolerances[std::uniform_int_distribution<int>(0, 4)(rng)];
    // Half the trials with tiles "still loading": a random, parent-first resident set.
    std::map<std::uint64_t, bool> resident;
    std::bernoulli_distribution loaded(0.7);
    std::function<bool(const terrain::NodeId&)> isResident = [&](const terrain::NodeId& n) -> bool {
      if (n.level == tree->rootLevel()) return true;
      auto it = resident.find(n.key());
      if (it == resident.end()) it = resident.emplace(n.key(), isResident(n.parent()) && loaded(rng)).first;
      return it->second;
    };
    if (trials % 2 == 0) options.resident = isResident;
    const terrain::LodSelection selection = terrain::selectLod(*tree, lodView, options);
    for (const terrain::SelectedChunk& c : selection.chunks) {
      if (c.stitchMask != 0) pairs.insert(c.id.level);
    }
    gfx::beginRenderPass(cache_, target, {glm::vec4(1, 0, 1, 1), gfx::kReversedZFar, 0});
    engine->draw(cache_, lodView.viewProj, eye, selection, 1.0);
    const std::vector<float> depth = gfx::readDepth(target);
    const auto background = static_cast<int>(std::count(depth.begin(), depth.end(), 0.0F));
    leaks += background;
    EXPECT_EQ(background, 0) << "trial " << trials << ": " << selection.chunks.size() << " chunks, tolerance "
                             << options.pixelTolerance;
  }
  EXPECT_EQ(leaks, 0);
  // (The root has no neighbours of its own level, so pairs reach up to (root − 2, root − 1).)
  for (int level = 0; level + 1 < tree->rootLevel(); ++level) {
    EXPECT_TRUE(pairs.count(level)) << "no boundary between levels " << level << " and " << level + 1 << " was drawn";
  }
}

// A paged DEM: from the first frame (only the pinned levels resident) through every round of
// tile loads, the parents drawn meanwhile leave no cracks; once loaded, the image is the
// in-memory terrain's, pixel for pixel.
TEST_F(TerrainCracksGlTest, PagedTerrainHasNoCracksWhileLoadingAndMatchesWhenLoaded) {
  auto grid = makeStiffTerrain({.width = 385, .height = 385, .seed = 9, .holes = false});
  const PagedTerrain t =
      makePagedTerrain(*grid, std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/paged", 16, 4, std::size_t{64} << 20);
  ASSERT_TRUE(t.paged && t.memory);
  Result<terrain::TerrainEngine> memoryEngine = terrain::TerrainEngine::create(t.memory, nullptr);
  ASSERT_TRUE(memoryEngine.ok());
  gfx::RenderTarget target(kSize, kSize);
  const terrain::TerrainGrid& g = t.memory->grid();
  const glm::dvec2 lo = g.postPosition(0, g.height - 1), hi = g.postPosition(g.width - 1, 0);
  const glm::dvec2 centre = 0.5 * (lo + hi);
  const terrain::NodeInfo& root = t.memory->info(t.memory->root());
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> offset(-600.0, 600.0), above(300.0, 1500.0);
  int rounds = 0;
  for (int trial = 0; trial < 6; ++trial) {
    auto tree = std::make_shared<terrain::TerrainQuadtree>(std::make_shared<terrain::TilePager>(t.file, 64u << 20));
    Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
    ASSERT_TRUE(engine.ok());
    // Straight down from above the middle: every pixel sees terrain.
    const glm::dvec3 eye(centre.x + offset(rng), centre.y + offset(rng), root.maxHeight + above(rng));
    const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(glm::radians(30.0), 1.0, 1.0) *
                                glm::lookAtRH(eye, eye - glm::dvec3(0, 0, 1), glm::dvec3(0, 1, 0));
    terrain::LodView view{eye, viewProj, kSize, glm::radians(30.0)};
    terrain::LodOptions options;
    options.pixelTolerance = 0.5;
    options.resident = [&](const terrain::NodeId& n) { return engine->hasChunk(n) || tree->resident(n); };
    auto drawDepth = [&](terrain::TerrainEngine& e, const terrain::LodSelection& s) {
      gfx::beginRenderPass(cache_, target, {glm::vec4(1, 0, 1, 1), gfx::kReversedZFar, 0});
      e.draw(cache_, viewProj, eye, s, 1.0);
      return gfx::readDepth(target);
    };
    terrain::LodSelection s = terrain::selectLod(*tree, view, options);
    EXPECT_FALSE(s.missing.empty()) << "the first frame should want tiles";
    for (;;) {
      const std::vector<float> depth = drawDepth(*engine, s);
      EXPECT_EQ(std::count(depth.begin(), depth.end(), 0.0F), 0) << "trial " << trial << " round " << rounds;
      if (s.missing.empty()) break;
      tree->pager()->request(s.missing);
      tree->pager()->waitIdle();
      s = terrain::selectLod(*tree, view, options);
      ++rounds;
    }
    const std::vector<float> paged = gfx::readDepth(target);
    const std::vector<std::uint8_t> pagedColour = gfx::readColorRgba8(target);
    terrain::LodOptions memoryOptions;
    memoryOptions.pixelTolerance = options.pixelTolerance;
    const std::vector<float> memory = drawDepth(*memoryEngine, terrain::selectLod(*t.memory, view, memoryOptions));
    EXPECT_EQ(paged, memory) << "trial " << trial;
    EXPECT_EQ(pagedColour, gfx::readColorRgba8(target)) << "trial " << trial;
  }
  EXPECT_GT(rounds, 6);
}

}  // namespace
}  // namespace gis::test
