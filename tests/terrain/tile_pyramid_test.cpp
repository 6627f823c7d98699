// The tile pyramid on disk and its pager: the streamed build gives exactly the in-memory
// quadtree (node ranges, geometric errors, tiles, cell ranges); a pyramid is reused only for the
// same DEM and rejected when truncated or stale; tiles page in asynchronously under a CPU budget;
// while they load the LOD selection draws their parents, and once loaded it is the in-memory
// selection, chunk for chunk.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "paged_terrain.hpp"
#include "terrain/lod.hpp"
#include "test_paths.hpp"
#include "test_terrain.hpp"

namespace gis::test {
namespace {

using terrain::NodeId;

std::string outputDir(const std::string& name) { return std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/" + name; }

std::vector<NodeId> allNodes(const terrain::TerrainQuadtree& tree) {
  std::vector<NodeId> out;
  for (int level = 0; level <= tree.rootLevel(); ++level) {
    for (int y = 0; y < tree.nodesPerSide(level); ++y) {
      for (int x = 0; x < tree.nodesPerSide(level); ++x) out.push_back({level, x, y});
    }
  }
  return out;
}

class TilePyramidTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // Not square, not a power of two plus one (padded with nodata), with cliffs, a spike, a
    // flat lake and holes; 16-cell chunks, at most 4 pinned tiles a side: levels 0–2 are paged.
    grid_ = makeStiffTerrain({.width = 301, .height = 229, .seed = 5});
    terrain_ = makePagedTerrain(*grid_, outputDir("pyramid"), 16, 4, std::size_t{1} << 30);
  }
  static void TearDownTestSuite() { terrain_ = {}; }
  void SetUp() override { ASSERT_TRUE(terrain_.paged && terrain_.memory); }

  static inline std::shared_ptr<terrain::TerrainGrid> grid_;
  static inline PagedTerrain terrain_;
};

TEST_F(TilePyramidTest, BuildEqualsTheInMemoryQuadtree) {
  const terrain::TerrainQuadtree& mem = *terrain_.memory;
  const terrain::TerrainQuadtree& paged = *terrain_.paged;
  ASSERT_EQ(paged.rootLevel(), mem.rootLevel());
  ASSERT_EQ(paged.chunkCells(), mem.chunkCells());
  EXPECT_EQ(paged.pinnedLevel(), mem.rootLevel() - 2);
  EXPECT_EQ(paged.grid().width, mem.grid().width);
  EXPECT_EQ(paged.grid().height, mem.grid().height);
  EXPECT_EQ(paged.grid().origin.x, mem.grid().origin.x);
  EXPECT_EQ(paged.grid().origin.y, mem.grid().origin.y);
  EXPECT_EQ(paged.grid().step.x, mem.grid().step.x);
  EXPECT_EQ(paged.grid().step.y, mem.grid().step.y);
  std::size_t nodata = 0;
  for (float h : mem.grid().heights) nodata += std::isnan(h) ? 1u : 0u;
  EXPECT_GT(nodata, 0u);
  EXPECT_EQ(terrain_.file->nodataPosts(), nodata);

  std::size_t tiles = 0;
  for (const NodeId& n : allNodes(mem)) {
    const terrain::NodeInfo &a = mem.info(n), &b = paged.info(n);
    ASSERT_EQ(a.hasData, b.hasData) << n.level << "/" << n.x << "/" << n.y;
    EXPECT_EQ(a.minHeight, b.minHeight);
    EXPECT_EQ(a.maxHeight, b.maxHeight);
    EXPECT_EQ(a.geometricError, b.geometricError) << n.level << "/" << n.x << "/" << n.y;
    ASSERT_EQ(terrain_.file->hasTile(n), a.hasData);
    if (!a.hasData) continue;
    ++tiles;
    std::vector<float> tile(terrain_.file->tilePosts());
    Diagnostics d;
    ASSERT_TRUE(terrain_.file->readTile(n, tile, d));
    const terrain::TileData expected = mem.chunkPosts(n);
    for (std::size_t k = 0; k < tile.size(); ++k) {
      const float e = (*expected)[k];
      ASSERT_TRUE(std::isnan(e) ? std::isnan(tile[k]) : tile[k] == e) << "tile " << n.level << "/" << n.x << "/" << n.y;
    }
  }
  EXPECT_GT(tiles, 100u);

  // Cell ranges of the pinned level: min/max of the posts of each closed cell.
  const int s = 1 << paged.pinnedLevel();
  const terrain::TilePyramidFile& f = *terrain_.file;
  ASSERT_EQ(f.cellRangeWidth(), (grid_->width - 1 + s - 1) / s);
  ASSERT_EQ(f.cellRangeHeight(), (grid_->height - 1 + s - 1) / s);
  for (int cy = 0; cy < f.cellRangeHeight(); ++cy) {
    for (int cx = 0; cx < f.cellRangeWidth(); ++cx) {
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      for (int r = cy * s; r <= std::min(cy * s + s, grid_->height - 1); ++r) {
        for (int c = cx * s; c <= std::min(cx * s + s, grid_->width - 1); ++c) {
          const float h = mem.post(c, r);
          if (std::isnan(h)) continue;
          lo = std::min(lo, h);
          hi = std::max(hi, h);
        }
      }
      const auto i = static_cast<std::size_t>(cy * f.cellRangeWidth() + cx);
      ASSERT_EQ(f.cellLo()[i], lo) << cx << " " << cy;
      ASSERT_EQ(f.cellHi()[i], hi) << cx << " " << cy;
    }
  }
}

TEST_F(TilePyramidTest, PostsAndSurfacesMatchThroughThePager) {
  const terrain::TerrainQuadtree& mem = *terrain_.memory;
  const terrain::TerrainQuadtree& paged = *terrain_.paged;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> col(-2.0, grid_->width + 1.0), row(-2.0, grid_->height + 1.0);
  for (int k = 0; k < 2000; ++k) {
    const int c = static_cast<int>(col(rng)), r = static_cast<int>(row(rng));
    const float a = mem.post(c, r), b = paged.post(c, r);
    ASSERT_TRUE(std::isnan(a) ? std::isnan(b) : a == b) << c << " " << r;
    const int level = std::uniform_int_distribution<int>(0, mem.rootLevel())(rng);
    const double x = col(rng), y = row(rng);
    const double sa = mem.levelSurface(level, x, y), sb = paged.levelSurface(level, x, y);
    ASSERT_TRUE(std::isnan(sa) ? std::isnan(sb) : sa == sb) << level << " " << x << " " << y;
  }
}

TEST_F(TilePyramidTest, ReusedOnlyForTheSameIntactSource) {
  const std::string dir = outputDir("validation-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string copy = dir + "/copy.sgpyr";
  std::filesystem::copy_file(terrain_.pyramidPath, copy, std::filesystem::copy_options::overwrite_existing);
  EXPECT_TRUE(terrain::TilePyramidFile::open(copy, terrain_.source).ok());

  auto reason = [](const Result<std::shared_ptr<const terrain::TilePyramidFile>>& r) {
    return r.diagnostics.empty() ? std::string() : r.diagnostics.items().front().message;
  };
  terrain::PyramidSource changed = terrain_.source;
  changed.modifiedNs += 1;
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, changed)).find("changed"), std::string::npos);
  changed = terrain_.source;
  changed.band = 2;
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, changed)).find("band"), std::string::npos);
  changed = terrain_.source;
  changed.demPath += ".other";
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, changed)).find("built from"), std::string::npos);

  std::filesystem::resize_file(copy, std::filesystem::file_size(copy) - 100);
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, terrain_.source)).find("truncated"), std::string::npos);
  std::ofstream(copy, std::ios::trunc) << "not a pyramid, just text that is long enough? no.";
  EXPECT_FALSE(terrain::TilePyramidFile::open(copy, terrain_.source).ok());
  EXPECT_FALSE(terrain::TilePyramidFile::open(dir + "/missing.sgpyr", terrain_.source).ok());
  std::filesystem::remove_all(dir);
}

TEST_F(TilePyramidTest, ADamagedPyramidIsFoundAndRebuiltFromTheDem) {
  namespace fs = std::filesystem;
  const std::string dir = outputDir("damaged-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string copy = dir + "/copy.sgpyr";
  const auto restore = [&] { fs::copy_file(terrain_.pyramidPath, copy, fs::copy_options::overwrite_existing); };
  const auto flip = [&](std::uint64_t at) {
    std::fstream f(copy, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(static_cast<std::streamoff>(at));
    const char c = static_cast<char>(f.get() ^ 0x04);
    f.seekp(static_cast<std::streamoff>(at));
    f.put(c);
  };
  auto reason = [](const Result<std::shared_ptr<const terrain::TilePyramidFile>>& r) {
    return r.diagnostics.empty() ? std::string() : r.diagnostics.items().front().message;
  };
  // The header and the node table with the cell ranges: refused when opened (the loader rebuilds).
  restore();
  flip(100);
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, terrain_.source)).find("damaged"), std::string::npos);
  restore();
  flip(fs::file_size(copy) - 6);
  EXPECT_NE(reason(terrain::TilePyramidFile::open(copy, terrain_.source)).find("damaged"), std::string::npos);

  // Tiles (written one after another behind the 4 KB header): found when read.
  restore();
  const std::uint64_t tileBytes = terrain_.file->tilePosts() * sizeof(float);
  for (std::uint64_t k = 0; k < 6; ++k) flip(4096 + k * 7 * tileBytes + 13 * k + 5);
  Result<std::shared_ptr<const terrain::TilePyramidFile>> opened =
      terrain::TilePyramidFile::open(copy, terrain_.source);
  ASSERT_TRUE(opened.ok()) << reason(opened);
  const terrain::TilePyramidFile& damaged = **opened;
  const terrain::TerrainQuadtree& mem = *terrain_.memory;
  std::size_t refused = 0;
  for (const NodeId& n : allNodes(mem)) {
    if (!damaged.hasTile(n)) continue;
    std::vector<float> tile(damaged.tilePosts());
    Diagnostics d;
    if (!damaged.readTile(n, tile, d)) ++refused;
  }
  EXPECT_EQ(refused, 6u) << "without a way to rebuild, each damaged tile is refused";
  // With one (the loader's), the first damaged tile read rebuilds the file; every tile then
  // reads as the clean pyramid's.
  damaged.setRebuild([&] { return terrain::buildTilePyramid(terrain_.source, *terrain_.frame, copy).ok(); });
  std::size_t warnings = 0;
  for (const NodeId& n : allNodes(mem)) {
    if (!damaged.hasTile(n)) continue;
    std::vector<float> tile(damaged.tilePosts()), clean(damaged.tilePosts());
    Diagnostics d, none;
    ASSERT_TRUE(damaged.readTile(n, tile, d)) << n.level << "/" << n.x << "/" << n.y;
    ASSERT_TRUE(terrain_.file->readTile(n, clean, none));
    for (const Diagnostic& m : d.items()) {
      EXPECT_EQ(m.severity, Severity::Warning) << m.toString();
      warnings += m.message.find("rebuilt from the DEM") != std::string::npos ? 1U : 0U;
    }
    for (std::size_t k = 0; k < tile.size(); ++k)
      ASSERT_TRUE(std::isnan(clean[k]) ? std::isnan(tile[k]) : tile[k] == clean[k]) << n.level << "/" << n.x;
  }
  EXPECT_EQ(warnings, 1u);
  fs::remove_all(dir);
}

TEST_F(TilePyramidTest, PagerLoadsAsynchronouslyUnderItsBudget) {
  const std::size_t tileBytes = terrain_.file->tilePosts() * sizeof(float);
  terrain::TilePager pager(terrain_.file, 40 * tileBytes);
  std::vector<NodeId> wanted;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      if (terrain_.file->hasTile({0, x, y})) wanted.push_back({0, x, y});
    }
  }
  ASSERT_GT(wanted.size(), 100u);
  for (const NodeId& n : wanted) EXPECT_FALSE(pager.resident(n));
  const std::vector<NodeId> first(wanted.begin(), wanted.begin() + 30);
  pager.request(first);
  pager.waitIdle();
  for (const NodeId& n : first) {
    ASSERT_TRUE(pager.resident(n));
    const terrain::TileData t = pager.find(n);
    ASSERT_TRUE(t);
    const terrain::TileData expected = terrain_.memory->chunkPosts(n);
    for (std::size_t k = 0; k < t->size(); ++k) {
      ASSERT_TRUE(std::isnan((*expected)[k]) ? std::isnan((*t)[k]) : (*t)[k] == (*expected)[k]);
    }
  }
  // More than the budget: the least recently used go, the budget holds after update().
  pager.request(wanted);
  pager.waitIdle();
  const terrain::TilePagerStats s = pager.stats();
  EXPECT_LE(s.residentBytes, 40 * tileBytes);
  EXPECT_GT(s.evictions, 0u);
  EXPECT_EQ(s.pending, 0u);
  EXPECT_EQ(s.readErrors, 0u);
  EXPECT_TRUE(pager.resident(wanted.back()));  // the most recent stay
  EXPECT_FALSE(pager.resident(wanted.front()));
  // Pinned levels need no paging; nodes without data are trivially resident.
  EXPECT_TRUE(pager.resident(terrain_.paged->root()));
  EXPECT_NE(pager.pinnedTile(terrain_.paged->root()), nullptr);
}

terrain::LodView randomView(std::mt19937& rng, const terrain::TerrainQuadtree& tree) {
  const auto extent = tree.frameExtent(tree.root());
  std::uniform_real_distribution<double> ux(extent[0].x, extent[1].x), uy(extent[0].y, extent[1].y);
  std::uniform_real_distribution<double> height(20.0, 3000.0);
  terrain::LodView v;
  v.eye = glm::dvec3(ux(rng), uy(rng), height(rng));
  v.fovYRadians = glm::radians(50.0);
  v.viewProj = gfx::reversedInfinitePerspective(v.fovYRadians, 1.2, 1.0) *
               gfx::lookAt(v.eye, glm::dvec3(ux(rng), uy(rng), 0.0), glm::dvec3(0, 0, 1));
  return v;
}

TEST_F(TilePyramidTest, ParentsAreDrawnWhileTilesLoadThenTheSelectionConverges) {
  std::mt19937 rng(31);
  std::size_t sawMissing = 0;
  for (int trial = 0; trial < 20; ++trial) {
    // A fresh pager per view: nothing but the pinned levels is resident at first.
    auto tree = std::make_shared<terrain::TerrainQuadtree>(
        std::make_shared<terrain::TilePager>(terrain_.file, std::size_t{256} << 20));
    const terrain::LodView view = randomView(rng, *tree);
    terrain::LodOptions options;
    options.pixelTolerance = 1.0;
    const terrain::LodSelection target = terrain::selectLod(*terrain_.memory, view, options);
    terrain::LodSelection s = terrain::selectLod(*tree, view, options);
    int rounds = 0;
    while (!s.missing.empty()) {
      ++sawMissing;
      // Meanwhile the cut is still an exact tiling of resident nodes.
      std::size_t cells = 0;
      for (const NodeId& n : s.cut) {
        ASSERT_TRUE(tree->resident(n));
        cells += std::size_t{1} << (2 * n.level);
      }
      ASSERT_EQ(cells, static_cast<std::size_t>(tree->nodesPerSide(0) * tree->nodesPerSide(0)));
      for (const NodeId& n : s.missing) ASSERT_FALSE(tree->resident(n));
      tree->pager()->request(s.missing);
      tree->pager()->waitIdle();
      s = terrain::selectLod(*tree, view, options);
      ASSERT_LT(++rounds, 20);
    }
    ASSERT_EQ(s.chunks.size(), target.chunks.size()) << "trial " << trial;
    for (std::size_t k = 0; k < s.chunks.size(); ++k) {
      EXPECT_EQ(s.chunks[k].id, target.chunks[k].id);
      EXPECT_EQ(s.chunks[k].stitchMask, target.chunks[k].stitchMask);
    }
  }
  EXPECT_GT(sawMissing, 10u);
}

}  // namespace
}  // namespace gis::test
