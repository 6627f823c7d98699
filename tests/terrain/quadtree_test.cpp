// The quadtree's per-node facts, checked by brute force against the posts: height ranges,
// geometric error as a true upper bound of the distance to the full-resolution surface, and
// stitched edges that meet the coarser neighbour's edge exactly.
#include <gtest/gtest.h>

#include "terrain/quadtree.hpp"
#include "test_terrain.hpp"

namespace gis::test {
namespace {

using terrain::NodeId;
using terrain::TerrainQuadtree;

// Heights are floats of up to ~1 km: 1 mm covers float rounding in the interpolation.
constexpr double kHeightTolerance = 1e-3;

std::vector<NodeId> allNodes(const TerrainQuadtree& tree) {
  std::vector<NodeId> nodes;
  for (int level = 0; level <= tree.rootLevel(); ++level) {
    for (int y = 0; y < tree.nodesPerSide(level); ++y) {
      for (int x = 0; x < tree.nodesPerSide(level); ++x) nodes.push_back({level, x, y});
    }
  }
  return nodes;
}

TEST(Quadtree, LevelsCoverThePaddedGrid) {
  TerrainQuadtree square(makeStiffTerrain({.width = 257, .height = 257}), 64);
  EXPECT_EQ(square.rootLevel(), 2);  // 256 cells = 64 · 2²
  TerrainQuadtree oblong(makeStiffTerrain({.width = 300, .height = 120}), 64);
  EXPECT_EQ(oblong.rootLevel(), 3);  // 299 cells → 512
  EXPECT_EQ(oblong.nodeCount(), 1u + 4u + 16u + 64u);
}

TEST(Quadtree, NodeRangesAreThoseOfTheirPosts) {
  TerrainQuadtree tree(makeStiffTerrain({.width = 300, .height = 181, .seed = 3}), 32);
  for (const NodeId& n : allNodes(tree)) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    const glm::ivec2 p0 = tree.vertexPost(n, 0, 0), p1 = tree.vertexPost(n, tree.chunkCells(), tree.chunkCells());
    for (int r = p0.y; r <= p1.y; ++r) {
      for (int c = p0.x; c <= p1.x; ++c) {
        const float h = tree.post(c, r);
        if (std::isnan(h)) continue;
        lo = std::min(lo, h);
        hi = std::max(hi, h);
      }
    }
    const terrain::NodeInfo& info = tree.info(n);
    ASSERT_EQ(info.hasData, lo <= hi) << n.level << " " << n.x << " " << n.y;
    if (!info.hasData) continue;
    EXPECT_EQ(info.minHeight, lo);
    EXPECT_EQ(info.maxHeight, hi);
  }
}

TEST(Quadtree, GeometricErrorBoundsTheDistanceToFullResolution) {
  for (unsigned seed : {1u, 2u, 3u}) {
    TerrainQuadtree tree(makeStiffTerrain({.width = 257, .height = 257, .seed = seed}), 16);
    std::size_t tight = 0;
    for (const NodeId& n : allNodes(tree)) {
      const terrain::NodeInfo& info = tree.info(n);
      if (!info.hasData) continue;
      double worst = 0.0;
      const glm::ivec2 p0 = tree.vertexPost(n, 0, 0), p1 = tree.vertexPost(n, tree.chunkCells(), tree.chunkCells());
      for (int r = p0.y; r <= p1.y; ++r) {
        for (int c = p0.x; c <= p1.x; ++c) {
          const double full = tree.post(c, r), coarse = tree.levelSurface(n.level, c, r);
          if (std::isnan(full) || std::isnan(coarse)) continue;
          worst = std::max(worst, std::abs(full - coarse));
        }
      }
      ASSERT_LE(worst, info.geometricError + kHeightTolerance) << "level " << n.level;
      tight += worst >= 0.5 * info.geometricError;
      if (n.level > 0) {
        for (const NodeId& c : n.children()) EXPECT_GE(info.geometricError, tree.info(c).geometricError);
      } else {
        EXPECT_EQ(info.geometricError, 0.0F);
      }
    }
    EXPECT_GT(tight, 0u) << "the bound should be tight for some nodes";
  }
}

TEST(Quadtree, FlatTerrainHasNoError) {
  auto grid = makeStiffTerrain({.width = 129, .height = 129, .cliffs = false, .spike = false, .holes = false});
  std::fill(grid->heights.begin(), grid->heights.end(), 12.5F);
  TerrainQuadtree tree(grid, 16);
  for (const NodeId& n : allNodes(tree)) EXPECT_EQ(tree.info(n).geometricError, 0.0F);
}

TEST(Quadtree, StitchedEdgesMeetTheCoarserNeighbourExactly) {
  TerrainQuadtree tree(makeStiffTerrain({.width = 257, .height = 257, .seed = 5, .holes = false}), 16);
  const int n = tree.chunkCells();
  for (int level = 0; level < tree.rootLevel(); ++level) {
    for (int y = 0; y < tree.nodesPerSide(level); ++y) {
      for (int x = 0; x < tree.nodesPerSide(level); ++x) {
        const NodeId node{level, x, y};
        const glm::ivec2 p0 = tree.vertexPost(node, 0, 0), p1 = tree.vertexPost(node, n, n);
        for (int k = 0; k <= 4 * n; ++k) {
          const double t = p0.x + (p1.x - p0.x) * k / (4.0 * n);
          const double u = p0.y + (p1.y - p0.y) * k / (4.0 * n);
          // north edge (row p0.y), west edge (col p0.x), and the opposite ones
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeNorth, t, p0.y), tree.levelSurface(level + 1, t, p0.y),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeSouth, t, p1.y), tree.levelSurface(level + 1, t, p1.y),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeWest, p0.x, u), tree.levelSurface(level + 1, p0.x, u),
                      kHeightTolerance);
          EXPECT_NEAR(tree.chunkSurface(node, terrain::kEdgeEast, p1.x, u), tree.levelSurface(level + 1, p1.x, u),
                      kHeightTolerance);
        }
      }
    }
  }
}

}  // namespace
}  // namespace gis::test
