// LOD selection without GL: for many random cameras (vertical exaggeration 1, 0.5 and 3), the
// cut tiles the terrain exactly once, neighbours differ by at most one level with stitch masks
// saying so, every drawn chunk meets the pixel tolerance (or is as fine as the data allows), and
// culled chunks lie outside the frustum.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <utility>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "terrain/lod.hpp"
#include "test_terrain.hpp"

namespace gis::test {
namespace {

using terrain::NodeId;

struct RandomView {
  terrain::LodView view;
};

terrain::LodView randomView(std::mt19937& rng, const terrain::TerrainQuadtree& tree) {
  const auto extent = tree.frameExtent(tree.root());
  const glm::dvec2 lo = extent[0], hi = extent[1];
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), height(5.0, 8000.0), fov(20.0, 80.0);
  terrain::LodView v;
  v.eye = glm::dvec3(ux(rng), uy(rng), height(rng));
  glm::dvec3 target(ux(rng), uy(rng), 0.0);
  if (glm::length(glm::dvec2(target - v.eye)) < 1.0) target.x += 100.0;
  v.fovYRadians = glm::radians(fov(rng));
  v.viewportHeight = 1000;
  const double aspect = 1.2;
  v.viewProj =
      gfx::reversedInfinitePerspective(v.fovYRadians, aspect, 1.0) * gfx::lookAt(v.eye, target, glm::dvec3(0, 0, 1));
  return v;
}

/// Level of the cut leaf covering each finest-level node cell.
std::map<std::pair<int, int>, int> coverage(const terrain::TerrainQuadtree& tree, const terrain::LodSelection& s,
                                            int& overlaps) {
  std::map<std::pair<int, int>, int> level;
  overlaps = 0;
  for (const NodeId& n : s.cut) {
    const int span = 1 << n.level;
    for (int y = n.y * span; y < (n.y + 1) * span; ++y) {
      for (int x = n.x * span; x < (n.x + 1) * span; ++x) overlaps += !level.emplace(std::pair{x, y}, n.level).second;
    }
  }
  (void)tree;
  return level;
}

bool pointOutsideClip(const glm::dmat4& viewProj, const glm::dvec3& p) {
  const glm::dvec4 c = viewProj * glm::dvec4(p, 1.0);
  return c.w <= 0.0 || c.x < -c.w || c.x > c.w || c.y < -c.w || c.y > c.w || c.z > c.w || c.z < 0.0;
}

class LodTest : public ::testing::Test {
 protected:
  LodTest() : tree_(makeStiffTerrain({.width = 513, .height = 513, .seed = 11}), 32) {}
  terrain::TerrainQuadtree tree_;
};

/// Random views at one vertical exaggeration: the cut tiles the terrain exactly once, is
/// balanced, every drawn chunk meets the pixel tolerance by an independent computation of its
/// screen-space error, stitch masks name exactly the coarser neighbours, and culled chunks are
/// outside the frustum.
void checkRandomViews(const terrain::TerrainQuadtree& tree, double exaggeration, int trials, unsigned seed) {
  std::mt19937 rng(seed);
  const int side = tree.nodesPerSide(0);
  std::size_t refinedSomewhere = 0, culledSomewhere = 0, stitched = 0;
  // The box of a node's full-resolution heights as drawn (exaggerated, either sign).
  auto heights = [&](const terrain::NodeInfo& info) {
    const double a = info.minHeight * exaggeration, b = info.maxHeight * exaggeration;
    return std::pair{std::min(a, b), std::max(a, b)};
  };
  for (int trial = 0; trial < trials; ++trial) {
    const terrain::LodView view = randomView(rng, tree);
    terrain::LodOptions options;
    options.pixelTolerance = 1.5;
    options.exaggeration = exaggeration;
    const terrain::LodSelection s = terrain::selectLod(tree, view, options);
    int overlaps = 0;
    const auto level = coverage(tree, s, overlaps);
    ASSERT_EQ(overlaps, 0) << "trial " << trial;
    ASSERT_EQ(level.size(), static_cast<std::size_t>(side * side)) << "trial " << trial;
    for (const auto& [cell, l] : level) {
      for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
        const auto it = level.find({cell.first + dx, cell.second + dy});
        if (it != level.end()) {
          ASSERT_LE(std::abs(it->second - l), 1) << "unbalanced, trial " << trial;
        }
      }
    }
    const double ppr = view.viewportHeight / (2.0 * std::tan(view.fovYRadians / 2.0));
    for (const terrain::SelectedChunk& c : s.chunks) {
      refinedSomewhere += c.id.level < tree.rootLevel();
      stitched += c.stitchMask != 0;
      // Independent screen-space error: the geometric error bounds the 3D distance to the full
      // resolution; drawn with exaggeration k the distance bound is error · max(|k|, 1) (the
      // vertical part scales by |k|, the horizontal part does not). Over the distance from the
      // eye to the node's exaggerated box.
      const auto e = tree.frameExtent(c.id);
      const terrain::NodeInfo& info = tree.info(c.id);
      const auto [zlo, zhi] = heights(info);
      const glm::dvec3 q = glm::clamp(view.eye, glm::dvec3(e[0], zlo), glm::dvec3(e[1], zhi));
      const double d = glm::length(view.eye - q);
      const double error = info.geometricError * std::max(std::abs(exaggeration), 1.0);
      const double sse = d > 0 ? error * ppr / d : (error > 0 ? 1e300 : 0.0);
      if (c.id.level > 0) {
        EXPECT_LE(sse, options.pixelTolerance * (1 + 1e-9)) << "trial " << trial << " exaggeration " << exaggeration;
      }
      EXPECT_NEAR(c.screenError, sse, 1e-9 * (1.0 + sse)) << "trial " << trial << " exaggeration " << exaggeration;
      // The stitch mask says exactly which neighbours are one level coarser.
      const int span = 1 << c.id.level;
      const std::array<std::pair<int, int>, 4> probe{
          std::pair{c.id.x * span - 1, c.id.y * span}, std::pair{(c.id.x + 1) * span, c.id.y * span},
          std::pair{c.id.x * span, c.id.y * span - 1}, std::pair{c.id.x * span, (c.id.y + 1) * span}};
      const std::array<int, 4> bits{terrain::kEdgeWest, terrain::kEdgeEast, terrain::kEdgeNorth, terrain::kEdgeSouth};
      for (std::size_t k = 0; k < 4; ++k) {
        const auto it = level.find(probe[k]);
        const bool coarser = it != level.end() && it->second == c.id.level + 1;
        EXPECT_EQ((c.stitchMask & bits[k]) != 0, coarser);
      }
    }
    // Culled chunks: every sampled point of their (exaggerated) box is outside the clip volume.
    for (const NodeId& n : s.cut) {
      const terrain::NodeInfo& info = tree.info(n);
      if (!info.hasData) continue;
      const bool drawn = std::any_of(s.chunks.begin(), s.chunks.end(), [&](const auto& c) { return c.id == n; });
      if (drawn) continue;
      ++culledSomewhere;
      const auto e = tree.frameExtent(n);
      const auto [zlo, zhi] = heights(info);
      for (int i = 0; i <= 6; ++i) {
        for (int j = 0; j <= 6; ++j) {
          for (int k = 0; k <= 2; ++k) {
            const glm::dvec3 p(e[0].x + (e[1].x - e[0].x) * i / 6.0, e[0].y + (e[1].y - e[0].y) * j / 6.0,
                               zlo + (zhi - zlo) * k / 2.0);
            ASSERT_TRUE(pointOutsideClip(view.viewProj, p)) << "culled chunk in view, trial " << trial;
          }
        }
      }
    }
  }
  EXPECT_GT(refinedSomewhere, 0u);
  EXPECT_GT(culledSomewhere, 0u);
  EXPECT_GT(stitched, 0u);
}

TEST_F(LodTest, RandomViewsGiveBalancedExactTilingsWithinTolerance) { checkRandomViews(tree_, 1.0, 200, 99); }

TEST_F(LodTest, ExaggeratedRandomViewsStayWithinTolerance) {
  // Below 1 the error stays (the horizontal part of the 3D distance does not shrink), above 1
  // it scales with the exaggeration.
  checkRandomViews(tree_, 0.5, 80, 7);
  checkRandomViews(tree_, 3.0, 80, 8);
}

TEST(Lod, CliffNodesAreNotKeptAtFullResolutionFarAway) {
  // 10 km of stiff terrain (400 m and 250 m cliffs, no spike) seen from 100 km at 40°: 1 px is
  // about 73 m. A cliff costs a node about a cell diagonal per level (57 m at level 1), not its
  // height: no node needs full resolution. (The old vertical error, 400 m or 5.5 px, kept every
  // node touching a cliff at level 0 at any distance.)
  const terrain::TerrainQuadtree tree(makeStiffTerrain({.width = 513, .height = 513, .seed = 11, .spike = false}), 32);
  terrain::LodView view;
  const auto extent = tree.frameExtent(tree.root());
  const glm::dvec2 centre = 0.5 * (extent[0] + extent[1]);
  view.eye = glm::dvec3(centre, 100000.0);
  view.fovYRadians = glm::radians(40.0);
  view.viewportHeight = 1000;
  view.viewProj = gfx::reversedInfinitePerspective(view.fovYRadians, 1.2, 1.0) *
                  gfx::lookAt(view.eye, glm::dvec3(centre, 0.0), glm::dvec3(0, 1, 0));
  const terrain::LodSelection s = terrain::selectLod(tree, view, {});
  ASSERT_FALSE(s.chunks.empty());
  for (const terrain::SelectedChunk& c : s.chunks) EXPECT_GT(c.id.level, 0) << c.id.x << " " << c.id.y;
}

TEST_F(LodTest, SmallerToleranceNeverGivesFewerChunks) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 30; ++trial) {
    const terrain::LodView view = randomView(rng, tree_);
    std::size_t previous = 0;
    for (double tol : {8.0, 4.0, 2.0, 1.0, 0.5}) {
      terrain::LodOptions o;
      o.pixelTolerance = tol;
      const std::size_t count = terrain::selectLod(tree_, view, o).cut.size();
      EXPECT_GE(count, previous);
      previous = count;
    }
  }
}

TEST_F(LodTest, TilesStillLoadingAreReplacedByTheirParents) {
  std::mt19937 rng(17);
  std::bernoulli_distribution loaded(0.6);
  std::map<std::uint64_t, bool> resident;
  terrain::LodOptions options;
  options.pixelTolerance = 0.5;
  // As a pager loads them: a tile arrives only after its parent; the top two levels stay.
  std::function<bool(const NodeId&)> isResident = [&](const NodeId& n) -> bool {
    if (n.level >= tree_.rootLevel() - 1) return true;
    auto it = resident.find(n.key());
    if (it == resident.end()) it = resident.emplace(n.key(), isResident(n.parent()) && loaded(rng)).first;
    return it->second;
  };
  options.resident = isResident;
  for (int trial = 0; trial < 50; ++trial) {
    const terrain::LodSelection s = terrain::selectLod(tree_, randomView(rng, tree_), options);
    int overlaps = 0;
    const auto level = coverage(tree_, s, overlaps);
    EXPECT_EQ(overlaps, 0);
    EXPECT_EQ(level.size(), static_cast<std::size_t>(tree_.nodesPerSide(0) * tree_.nodesPerSide(0)));
    for (const NodeId& n : s.cut) EXPECT_TRUE(options.resident(n)) << "a non-resident node was selected";
  }
}

}  // namespace
}  // namespace gis::test
