// The globe's DEM reading (globe::GeoGrid::fromDem, docs/globe.md "Heights above the ellipsoid"
// and "DEM mosaics"): geoid heights converted to ellipsoidal ones by PROJ with proj-data's EGM96
// grid, checked against PROJ's own transformation of each post (1 cm); a mosaic of two tiles
// against one raster holding both; a DEM in UTM; the memory budget; the scene key.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <system_error>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include "globe/geo_grid.hpp"
#include "scene/scene.hpp"

namespace gis::globe {
namespace {

namespace fs = std::filesystem;

/// This process's scratch folder, removed when it ends (ctest runs each test in a process of
/// its own: they were left behind in the temporary folder, hundreds of them).
fs::path scratch() {
  struct Scratch {
    fs::path dir = fs::temp_directory_path() / ("globe_dem_test_" + std::to_string(::getpid()));
    Scratch() { fs::create_directories(dir); }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
    ~Scratch() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  };
  static const Scratch scratch;
  return scratch.dir;
}

/// A north-up Float32 GeoTIFF: `width` × `height` cells of `step` from (west, north), in `crs`,
/// cell (c, r) = value(c, r).
template <typename F>
std::string writeTiff(const fs::path& path, const char* crs, double west, double north, double step, int width,
                      int height, F value) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  GDALDataset* ds = driver->Create(path.string().c_str(), width, height, 1, GDT_Float32, nullptr);
  double gt[6] = {west, step, 0.0, north, 0.0, -step};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.SetFromUserInput(crs);
  ds->SetSpatialRef(&srs);
  std::vector<float> samples(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) samples[static_cast<std::size_t>(r * width + c)] = value(c, r);
  EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, width, height, samples.data(), width, height, GDT_Float32, 0,
                                           0, nullptr),
            CE_None);
  GDALClose(GDALDataset::ToHandle(ds));
  return path.string();
}

Result<GeoGrid> read(const std::vector<std::string>& paths, VerticalDatum datum, double budgetMb = 0.0,
                     GridPaging paging = GridPaging::Never) {
  geo::DemSpec spec;
  spec.paths = paths;
  GeoGridReadOptions options;
  options.vertical = datum;
  options.memoryBudgetMb = budgetMb;
  options.paging = paging;
  options.sceneFile = "test-scene.json";
  return GeoGrid::fromDem(spec, options);
}

/// PROJ's own EGM96 undulation at (lon, lat): EGM96 height 0 taken to the ellipsoid.
double projUndulation(double lon, double lat) {
  static OGRCoordinateTransformation* const t = [] {
    OGRSpatialReference src, dst;
    src.SetFromUserInput("EPSG:4326+5773");
    dst.SetFromUserInput("EPSG:4979");
    src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    dst.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    return OGRCreateCoordinateTransformation(&src, &dst);
  }();
  double x = lon, y = lat, z = 0.0;
  const bool ok = t != nullptr && t->Transform(1, &x, &y, &z) != 0;
  return ok ? z : std::nan("");
}

const fs::path& dir() {
  static const fs::path d = scratch();
  return d;
}

/// 0 m everywhere near Recife (−35°, −8°): 20 × 20 cells of 0.01°.
std::string recifeZero() {
  return writeTiff(dir() / "recife_zero.tif", "EPSG:4326", -35.1, -7.9, 0.01, 20, 20, [](int, int) { return 0.0F; });
}

TEST(GlobeDem, Egm96HeightsBecomeTheUndulation) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Egm96);
  ASSERT_TRUE(grid.ok()) << grid.diagnostics.items().front().toString();
  ASSERT_EQ(grid->width(), 20);
  ASSERT_EQ(grid->height(), 20);
  double worst = 0.0;
  for (int r = 0; r < grid->height(); ++r) {
    for (int c = 0; c < grid->width(); ++c) {
      const double lon = grid->west() + c * grid->step(), lat = grid->north() - r * grid->step();
      const double n = projUndulation(lon, lat);
      ASSERT_TRUE(std::isfinite(n));
      const double h = grid->heights()[static_cast<std::size_t>(r * grid->width() + c)];
      worst = std::max(worst, std::abs(h - n));
    }
  }
  const double centre = grid->heightAt(-35.0, -8.0);
  std::printf("EGM96 undulation at (-35, -8): %.3f m (PROJ %.3f m); worst post |h - N| = %.2e m\n", centre,
              projUndulation(-35.0, -8.0), worst);
  EXPECT_LT(worst, 0.01);  // float heights: far below 1 cm
  EXPECT_GT(centre, -10.0);
  EXPECT_LT(centre, 0.0);
  EXPECT_NE(grid->verticalSource().find("EGM96"), std::string::npos);
}

TEST(GlobeDem, EllipsoidHeightsStay) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(grid.ok());
  for (const float h : grid->heights()) EXPECT_EQ(h, 0.0F);
  EXPECT_EQ(grid->verticalSource(), "ellipsoid");
}

TEST(GlobeDem, AutoWithoutVerticalCrsIsEgm96AndSaysSo) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Auto);
  ASSERT_TRUE(grid.ok());
  EXPECT_NEAR(grid->heightAt(-35.0, -8.0), projUndulation(-35.0, -8.0), 0.01);
  bool said = false;
  for (const Diagnostic& d : grid.diagnostics.items()) said = said || d.message.find("EGM96") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(GlobeDem, AutoUsesACompoundCrsVerticalPart) {
  const std::string path =
      writeTiff(dir() / "compound.tif", "EPSG:4326+5773", -35.1, -7.9, 0.01, 20, 20, [](int, int) { return 10.0F; });
  Result<GeoGrid> grid = read({path}, VerticalDatum::Auto);
  ASSERT_TRUE(grid.ok()) << grid.diagnostics.items().front().toString();
  EXPECT_NEAR(grid->heightAt(-35.0, -8.0), 10.0 + projUndulation(-35.0, -8.0), 0.01);
}

TEST(GlobeDem, Egm2008NeedsItsGrid) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Egm2008);
  const bool installed =
      fs::exists("/usr/share/proj/us_nga_egm08_25.tif") || fs::exists("/usr/share/proj/egm08_25.gtx");
  if (installed) {
    EXPECT_TRUE(grid.ok());
  } else {
    ASSERT_FALSE(grid.ok());
    bool named = false;
    for (const Diagnostic& d : grid.diagnostics.items())
      named = named || d.message.find("us_nga_egm08_25.tif") != std::string::npos;
    EXPECT_TRUE(named) << grid.diagnostics.items().front().toString();
  }
}

/// Heights varying in both directions, so a seam misplaced by a post would show.
float relief(double lon, double lat) { return static_cast<float>(100.0 * std::sin(40.0 * lon) + 37.0 * lat * lat); }

TEST(GlobeDem, TwoTilesEqualOneRaster) {
  const double step = 0.01;
  const auto at = [&](double west, int c0) {
    return [=](int c, int r) { return relief(west + (c0 + c + 0.5) * step, -7.8 - (r + 0.5) * step); };
  };
  const std::string whole = writeTiff(dir() / "whole.tif", "EPSG:4326", -35.2, -7.8, step, 40, 30, at(-35.2, 0));
  fs::create_directories(dir() / "tiles");
  writeTiff(dir() / "tiles" / "west.tif", "EPSG:4326", -35.2, -7.8, step, 20, 30, at(-35.2, 0));
  writeTiff(dir() / "tiles" / "east.tif", "EPSG:4326", -35.0, -7.8, step, 20, 30, at(-35.2, 20));
  Result<GeoGrid> one = read({whole}, VerticalDatum::Ellipsoid);
  Result<GeoGrid> two = read({(dir() / "tiles").string()}, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(one.ok());
  ASSERT_TRUE(two.ok()) << two.diagnostics.items().front().toString();
  ASSERT_EQ(one->width(), two->width());
  ASSERT_EQ(one->height(), two->height());
  EXPECT_NEAR(one->west(), two->west(), 1e-12);
  EXPECT_NEAR(one->north(), two->north(), 1e-12);
  for (const double lon : {-35.15, -35.005, -34.995, -34.85})
    std::printf("  at (%.3f, -7.9): one %.3f, two %.3f\n", lon, one->heightAt(lon, -7.9), two->heightAt(lon, -7.9));
  double worst = 0.0;
  int samples = 0;
  for (int k = 0; k <= 400; ++k) {  // across the seam at −35°, every 0.0005°
    for (const double lat : {-7.805, -7.9, -7.9537, -8.0, -8.095}) {
      const double lon = -35.1 + k * 0.0005;
      worst = std::max(worst, std::abs(one->heightAt(lon, lat) - two->heightAt(lon, lat)));
      ++samples;
    }
  }
  std::printf("two tiles against one raster: %d samples across the seam, worst |difference| %.2e m\n", samples, worst);
  EXPECT_LT(worst, 1e-4);
}

TEST(GlobeDem, ProjectedDemIsWarpedToLonLat) {
  // 100 m everywhere, in UTM 25S around Recife, 90 m cells.
  const std::string path =
      writeTiff(dir() / "utm.tif", "EPSG:32725", 270000.0, 9120000.0, 90.0, 100, 100, [](int, int) { return 100.0F; });
  Result<GeoGrid> grid = read({path}, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(grid.ok()) << grid.diagnostics.items().front().toString();
  EXPECT_NEAR(grid->step() * 111320.0, 90.0, 5.0);  // about the source's resolution
  const double lon = grid->west() + 0.5 * (grid->width() - 1) * grid->step();
  const double lat = grid->north() - 0.5 * (grid->height() - 1) * grid->step();
  EXPECT_NEAR(grid->heightAt(lon, lat), 100.0, 1e-3);
}

TEST(GlobeDem, BeyondTheMemoryBudgetIsRefusedWhenPagingIsNever) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Ellipsoid, 0.001, GridPaging::Never);
  ASSERT_FALSE(grid.ok());
  const std::string message = grid.diagnostics.items().back().toString();
  EXPECT_NE(message.find("test-scene.json"), std::string::npos) << message;
  EXPECT_NE(message.find("recife_zero.tif"), std::string::npos) << message;
  EXPECT_NE(message.find("memory_budget_mb"), std::string::npos) << message;
}

/// A DEM from 10° W to 10° E and 85° N to the north pole, 0.01° posts (2,000 × 500), with relief,
/// a hole of nodata and values GDAL reads as nodata.
std::string polarDem() {
  static const std::string path =
      writeTiff(dir() / "polar.tif", "EPSG:4326", -10.0, 90.0, 0.01, 2000, 500, [](int c, int r) {
        if (c > 300 && c < 340 && r > 100 && r < 130) return std::numeric_limits<float>::quiet_NaN();
        return static_cast<float>(500.0 * std::sin(c * 0.013) * std::cos(r * 0.021) +
                                  40.0 * std::sin(c * 0.31 + r * 0.17));
      });
  return path;
}

Result<GeoGrid> readPaged(const fs::path& cache, double pageBudgetMb, int block,
                          VerticalDatum datum = VerticalDatum::Egm96) {
  geo::DemSpec spec;
  spec.paths = {polarDem()};
  GeoGridReadOptions options;
  options.vertical = datum;
  options.paging = GridPaging::Always;
  options.pageBudgetMb = pageBudgetMb;
  options.blockPosts = block;
  options.cacheDir = [cache] { return cache.string(); };
  return GeoGrid::fromDem(spec, options);
}

std::size_t countWith(const Diagnostics& d, const std::string& text) {
  std::size_t n = 0;
  for (const Diagnostic& item : d.items()) n += item.toString().find(text) != std::string::npos ? 1U : 0U;
  return n;
}

/// Whether (lon, lat) lies within two posts of polarDem's hole (where GDAL's bilinear warp keeps or
/// drops a post beside nodata by the rounding of its window: geo_grid.cpp, readWindow).
bool besideTheHole(double lon, double lat) {
  const double c = (lon + 10.0) / 0.01, r = (90.0 - lat) / 0.01;
  return c > 298.0 && c < 343.0 && r > 98.0 && r < 133.0;
}

TEST(GlobeDem, PagedGridIsTheWholeGridBitForBit) {
  // The same DEM read whole and paged in blocks of 64 posts with room for about four of them:
  // every height, every bound and the pole's height are the same (beside the nodata hole, where
  // GDAL's warp may keep or drop a post: left out); the blocks read come and go within the
  // budget; the warnings are the same.
  const Result<GeoGrid> whole = read({polarDem()}, VerticalDatum::Egm96);
  const fs::path cache = dir() / "cache_bit_for_bit";
  fs::remove_all(cache);
  const Result<GeoGrid> paged = readPaged(cache, 0.08, 64);
  ASSERT_TRUE(whole.ok() && paged.ok());
  ASSERT_TRUE(paged->paged());
  EXPECT_FALSE(whole->paged());
  EXPECT_TRUE(paged->pageFileMade());
  EXPECT_EQ(countWith(whole.diagnostics, "without a height"), 1U);
  EXPECT_EQ(countWith(paged.diagnostics, "without a height"), 1U);
  std::size_t checked = 0, bounded = 0;
  EXPECT_EQ(countWith(paged.diagnostics, "is paged on the globe"), 1U);
  ASSERT_EQ(paged->width(), whole->width());
  ASSERT_EQ(paged->height(), whole->height());
  EXPECT_EQ(paged->heightAt(0.0, 90.0), whole->heightAt(0.0, 90.0));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lon(-10.5, 10.5), lat(84.5, 90.0), size(0.0, 1.0);
  std::size_t differing = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = lon(rng), y = lat(rng);
    if (besideTheHole(x, y)) continue;
    ++checked;
    if (paged->heightAt(x, y) != whole->heightAt(x, y) && differing++ < 5) {
      ADD_FAILURE() << "at (" << x << ", " << y << "): paged " << paged->heightAt(x, y) << ", whole "
                    << whole->heightAt(x, y);
    }
  }
  EXPECT_EQ(differing, 0U) << "heights";
  EXPECT_GT(checked, 19000U);
  std::size_t boundsDiffering = 0;
  for (int i = 0; i < 3000; ++i) {
    const double x = lon(rng), y = lat(rng), span = std::pow(10.0, -3.0 + 4.0 * size(rng));
    const LonLatRect box{x, y, x + span, std::min(90.0, y + 0.25 * span)};
    if (box.west < -6.55 && box.east > -7.05 && box.south < 89.03 && box.north > 88.65) continue;  // the hole
    ++bounded;
    boundsDiffering += paged->bounds(box) != whole->bounds(box) ? 1U : 0U;
  }
  EXPECT_EQ(boundsDiffering, 0U) << "bounds";
  EXPECT_GT(bounded, 2000U);
  std::printf(
      "paged against whole: %zu heights and %zu bounds compared, %zu blocks read, %zu bytes resident "
      "(whole: %zu)\n",
      checked, bounded, paged->blocksRead(), paged->residentBytes(), whole->residentBytes());
  // 32 × 8 blocks of 64 posts; the budget holds one (57 KB with its levels).
  EXPECT_GT(paged->blocksRead(), 256U) << "blocks come and go";
  EXPECT_LT(paged->residentBytes(), static_cast<std::size_t>(0.08 * 1024 * 1024) + 64U * 1024U);
  EXPECT_GT(whole->residentBytes(), 8U * 1000U * 1000U);
}

TEST(GlobeDem, AFarViewReadsItsPostsAndANearOneItsBlocks) {
  // A far view's tiles take a post here and there from every block: each is read alone (the DEM
  // is 32 × 8 blocks of 64 posts; 33 × 33 posts over all of it touch every block a few times).
  // A near view's tile takes every post of a few blocks: those are read whole, once.
  const fs::path cache = dir() / "cache_far_near";
  fs::remove_all(cache);
  const Result<GeoGrid> paged = readPaged(cache, 16.0, 64);
  const Result<GeoGrid> whole = read({polarDem()}, VerticalDatum::Egm96);
  ASSERT_TRUE(paged.ok() && whole.ok() && paged->paged());
  std::size_t differing = 0, samples = 0;
  for (int j = 0; j <= 32; ++j) {
    for (int i = 0; i <= 32; ++i) {
      const double x = -10.0 + 20.0 * i / 32.0, y = 85.0 + 4.99 * j / 32.0;
      if (besideTheHole(x, y)) continue;
      ++samples;
      differing += paged->heightAt(x, y) != whole->heightAt(x, y) ? 1U : 0U;
    }
  }
  EXPECT_EQ(differing, 0U);
  std::printf("far: %zu samples, %zu posts read alone, %zu blocks read\n", samples, paged->postsRead(),
              paged->blocksRead());
  EXPECT_EQ(paged->blocksRead(), 0U) << "no block is read whole for a few of its posts";
  EXPECT_LE(paged->postsRead(), 4 * samples + 16);
  // Near: 200 × 200 samples over 1° × 0.5° (100 × 50 posts: 2 × 1 to 3 × 2 blocks).
  const std::size_t postsBefore = paged->postsRead();
  for (int j = 0; j < 200; ++j) {
    for (int i = 0; i < 200; ++i) {
      const double x = 2.0 + i / 200.0, y = 86.0 + 0.5 * j / 200.0;
      differing += paged->heightAt(x, y) != whole->heightAt(x, y) ? 1U : 0U;
    }
  }
  EXPECT_EQ(differing, 0U);
  std::printf("near: 40,000 samples, %zu more posts read alone, %zu blocks read\n", paged->postsRead() - postsBefore,
              paged->blocksRead());
  EXPECT_GE(paged->blocksRead(), 2U);
  EXPECT_LE(paged->blocksRead(), 6U);
  EXPECT_LE(paged->postsRead() - postsBefore, 6U * 64U);
}

TEST(GlobeDem, APagedGridIsWrittenOnceAndFoundInTheCache) {
  const fs::path cache = dir() / "cache_reuse";
  fs::remove_all(cache);
  const Result<GeoGrid> first = readPaged(cache, 1.0, 256, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(first.ok());
  EXPECT_TRUE(first->pageFileMade());
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(cache)) files += entry.path().extension() == ".grid" ? 1U : 0U;
  EXPECT_EQ(files, 1U);
  const Result<GeoGrid> second = readPaged(cache, 1.0, 256, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(second.ok());
  EXPECT_FALSE(second->pageFileMade()) << "found in the cache";
  EXPECT_EQ(countWith(second.diagnostics, "without a height"), 1U) << "the holes are still said";
  EXPECT_EQ(second->heightAt(3.3, 87.2), first->heightAt(3.3, 87.2));
  EXPECT_EQ(second->heightAt(0.0, 90.0), first->heightAt(0.0, 90.0));
  // Another block size is another file.
  const Result<GeoGrid> third = readPaged(cache, 1.0, 128, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(third.ok());
  EXPECT_TRUE(third->pageFileMade());
}

/// The one .grid file in `cache`.
fs::path gridFile(const fs::path& cache) {
  for (const auto& entry : fs::directory_iterator(cache))
    if (entry.path().extension() == ".grid") return entry.path();
  return {};
}

/// Overwrites `bytes` bytes of `file` at `offset` with what `damage` makes of them.
void damageFile(const fs::path& file, std::uintmax_t offset, std::size_t bytes,
                const std::function<void(std::vector<char>&)>& damage) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  std::vector<char> data(bytes);
  f.seekg(static_cast<std::streamoff>(offset));
  f.read(data.data(), static_cast<std::streamsize>(bytes));
  damage(data);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(data.data(), static_cast<std::streamsize>(bytes));
}

TEST(GlobeDem, ADamagedPagedGridIsRepairedAndDrawsTheSameHeights) {
  // The grid's file damaged as a disk or a crash damages files: a bit flipped in a block's posts,
  // a zeroed 4 KB run across rows' digests and posts, a bit in the header, in the table, a file
  // cut short. Each time every height read (posts alone for a far view, whole blocks near) is the
  // undamaged grid's, the damage is said once, and the next open finds a whole file.
  const fs::path cache = dir() / "cache_damage";
  fs::remove_all(cache);
  const Result<GeoGrid> clean = readPaged(cache, 16.0, 64, VerticalDatum::Ellipsoid);
  ASSERT_TRUE(clean.ok());
  const fs::path file = gridFile(cache);
  ASSERT_FALSE(file.empty());
  const std::uintmax_t size = fs::file_size(file);
  std::vector<std::pair<double, double>> samples;
  std::mt19937 rng(40);
  std::uniform_real_distribution<double> lon(-10.0, 10.0), lat(85.0, 90.0);
  for (int i = 0; i < 3000; ++i) samples.emplace_back(lon(rng), lat(rng));
  std::vector<double> truth;
  for (const auto& [x, y] : samples) truth.push_back(clean->heightAt(x, y));
  const auto boundsOf = [](const GeoGrid& g) {
    std::vector<std::pair<double, double>> out;
    for (double w = -10.0; w < 10.0; w += 1.3)
      for (double s = 85.0; s < 90.0; s += 0.35) out.push_back(g.bounds({w, s, w + 0.9, s + 0.5}));
    return out;
  };
  const auto cleanBounds = boundsOf(*clean);
  // Every post, at its centre (where heightAt is the post's own height).
  const auto everyPost = [](const GeoGrid& g) {
    std::vector<double> out;
    out.reserve(2000U * 500U);
    for (int r = 0; r < 500; ++r)
      for (int c = 0; c < 2000; ++c) out.push_back(g.heightAt(-10.0 + (c + 0.5) * 0.01, 90.0 - (r + 0.5) * 0.01));
    return out;
  };
  const std::vector<double> cleanPosts = everyPost(*clean);
  // 1000 × 1000 posts in blocks of 64: header 128 B, table 16 · 256 B, rows' digests 256 · 512 B.
  const std::uintmax_t rowDigests = 128 + 256 * 16, blocks = rowDigests + 256 * 64 * 8;
  struct Case {
    const char* what;
    std::function<void()> damage;
    bool rebuilt;  ///< found at open (header, table, size): the file is written again
  };
  const auto flip = [](std::vector<char>& d) { d[d.size() / 2] = static_cast<char>(d[d.size() / 2] ^ 0x10); };
  const auto zero = [](std::vector<char>& d) { std::fill(d.begin(), d.end(), 0); };
  const std::vector<Case> cases = {
      {"a bit in block 37's posts", [&] { damageFile(file, blocks + 37 * 64 * 64 * 4 + 1000, 8, flip); }, false},
      {"a bit in block 0's posts", [&] { damageFile(file, blocks + 4 * 64 * 3, 4, flip); }, false},
      {"4 KB zeroed in rows' digests", [&] { damageFile(file, rowDigests + 5 * 4096, 4096, zero); }, false},
      {"4 KB zeroed in the posts", [&] { damageFile(file, blocks + 100 * 4096 + 512, 4096, zero); }, false},
      {"a bit in the header", [&] { damageFile(file, 20, 1, flip); }, true},
      {"a bit in the table", [&] { damageFile(file, 128 + 16 * 100, 8, flip); }, true},
      {"cut short", [&] { fs::resize_file(file, size - 1000); }, true},
      {"empty", [&] { fs::resize_file(file, 0); }, true},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    c.damage();
    const Result<GeoGrid> damaged = readPaged(cache, 16.0, 64, VerticalDatum::Ellipsoid);
    ASSERT_TRUE(damaged.ok());
    EXPECT_EQ(countWith(damaged.diagnostics, "cache file damaged"), c.rebuilt ? 1U : 0U);
    EXPECT_EQ(damaged->pageFileMade(), c.rebuilt);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < samples.size(); ++i)
      wrong += damaged->heightAt(samples[i].first, samples[i].second) != truth[i] ? 1U : 0U;
    EXPECT_EQ(wrong, 0U) << "heights read post by post";
    EXPECT_EQ(boundsOf(*damaged), cleanBounds) << "bounds and heights of whole blocks";
    for (std::size_t i = 0; i < samples.size(); ++i)
      wrong += damaged->heightAt(samples[i].first, samples[i].second) != truth[i] ? 1U : 0U;
    EXPECT_EQ(wrong, 0U) << "heights from whole blocks";
    EXPECT_TRUE(everyPost(*damaged) == cleanPosts) << "every post";
    if (!c.rebuilt) {
      EXPECT_GE(damaged->blocksRepaired(), 1U);
    }
    EXPECT_EQ(fs::file_size(file), size);
    // Repaired in place, or written again: the next open reads every block without repair.
    const Result<GeoGrid> again = readPaged(cache, 16.0, 64, VerticalDatum::Ellipsoid);
    ASSERT_TRUE(again.ok());
    EXPECT_FALSE(again->pageFileMade());
    EXPECT_EQ(boundsOf(*again), cleanBounds);
    EXPECT_EQ(again->blocksRepaired(), 0U);
  }
}

TEST(GlobeDem, BeyondTheMemoryBudgetADemIsPaged) {
  geo::DemSpec spec;
  spec.paths = {polarDem()};
  GeoGridReadOptions options;
  options.vertical = VerticalDatum::Ellipsoid;
  options.memoryBudgetMb = 16.0;  // 1 M posts take about 20 MB whole
  const fs::path cache = dir() / "cache_auto";
  options.cacheDir = [cache] { return cache.string(); };
  const Result<GeoGrid> grid = GeoGrid::fromDem(spec, options);
  ASSERT_TRUE(grid.ok());
  EXPECT_TRUE(grid->paged());
  EXPECT_EQ(countWith(grid.diagnostics, "is paged on the globe"), 1U);
  EXPECT_LT(grid->residentBytes(), 6U * 1024U * 1024U) << "within a third of the budget";
}

TEST(GlobeDem, SceneKey) {
  Result<scene::SceneDescription> ok =
      scene::parseScene(R"({"terrain": {"dem": "a.tif", "vertical_datum": "egm96"}})", "/tmp/s.json");
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(ok->demVerticalDatum, "egm96");
  Result<scene::SceneDescription> dflt = scene::parseScene(R"({"terrain": {"dem": "a.tif"}})", "/tmp/s.json");
  EXPECT_EQ(dflt->demVerticalDatum, "auto");
  Result<scene::SceneDescription> bad =
      scene::parseScene(R"({"terrain": {"dem": "a.tif", "vertical_datum": "navd88"}})", "/tmp/s.json");
  ASSERT_TRUE(bad.diagnostics.hasErrors());
  const std::string message = bad.diagnostics.items().front().toString();
  EXPECT_NE(message.find("/tmp/s.json"), std::string::npos);
  EXPECT_NE(message.find("terrain.vertical_datum"), std::string::npos);
}

}  // namespace
}  // namespace gis::globe
