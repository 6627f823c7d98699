// Imagery overviews on the globe (docs/globe.md, "Imagery"): a far tile of large imagery reads an
// overview level, so what it reads follows its texels, not the imagery's size. An 8192² GeoTIFF in
// UTM 33N (10 m cells, no overviews of its own) gets its overviews built once into the cache and
// reused by the next open; a far tile reads about its texels² source pixels where the same read
// forced to the full resolution reads the whole image; its texels match a box filter of the full
// resolution within 3/255; tiles at or finer than the full resolution read exactly what they read
// before overviews (the band VRT warped as one VRT); imagery with overviews of its own uses them.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include "globe/globe_imagery.hpp"
#include "test_paths.hpp"

namespace gis::globe {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr double kCell = 10.0;      ///< metres
constexpr double kPeriod = 4096.0;  ///< cells: the pattern's waves

/// The pattern: slow waves along the columns, the rows and the diagonal. Rounded to bytes, they
/// reach 0 and 255 over about a hundred cells, so that the 0 / 100 percentile stretch is the
/// identity; smooth, so that any sensible filter of a far texel's footprint agrees within a DN.
std::uint8_t cellValue(int band, int col, int row) {
  static const std::vector<std::uint8_t> wave = [] {
    std::vector<std::uint8_t> w(static_cast<std::size_t>(kPeriod));
    for (std::size_t t = 0; t < w.size(); ++t)
      w[t] = static_cast<std::uint8_t>(
          std::lround(127.5 + 127.5 * std::cos(2.0 * kPi * static_cast<double>(t) / kPeriod)));
    return w;
  }();
  const int t = band == 0 ? col : band == 1 ? row : col + row;
  return wave[static_cast<std::size_t>(t % static_cast<int>(kPeriod))];
}

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

/// (lon, lat) → UTM 33N.
struct ToUtm {
  ToUtm() {
    wgs.SetFromUserInput("EPSG:4326");
    utm.SetFromUserInput("EPSG:32633");
    wgs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    t = OGRCreateCoordinateTransformation(&wgs, &utm);
  }
  ~ToUtm() { OGRCoordinateTransformation::DestroyCT(t); }
  ToUtm(const ToUtm&) = delete;
  ToUtm& operator=(const ToUtm&) = delete;
  std::array<double, 2> operator()(double lon, double lat) const {
    t->Transform(1, &lon, &lat);
    return {lon, lat};
  }
  OGRSpatialReference wgs, utm;
  OGRCoordinateTransformation* t = nullptr;
};

/// A 3-band byte GeoTIFF of the pattern, tiled and deflated (fast to write and read), whose
/// north-west corner is at (west, north) in UTM 33N.
void writeImagery(const std::string& path, int width, int height, double west, double north) {
  const char* const options[] = {"TILED=YES", "COMPRESS=DEFLATE", "ZLEVEL=1", "PREDICTOR=2", nullptr};
  GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(path.c_str(), width, height, 3, GDT_Byte,
                                                                             const_cast<char**>(options));
  ASSERT_NE(ds, nullptr);
  double gt[6] = {west, kCell, 0.0, north, 0.0, -kCell};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.SetFromUserInput("EPSG:32633");
  ds->SetSpatialRef(&srs);
  constexpr int kRows = 256;
  std::vector<std::uint8_t> rows(static_cast<std::size_t>(width) * kRows * 3);
  for (int r0 = 0; r0 < height; r0 += kRows) {
    const int n = std::min(kRows, height - r0);
    for (int b = 0; b < 3; ++b)
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < width; ++c)
          rows[(static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c)) * 3 +
               static_cast<std::size_t>(b)] = cellValue(b, c, r0 + r);
    int bandMap[3] = {1, 2, 3};
    ASSERT_EQ(
        ds->RasterIO(GF_Write, 0, r0, width, n, rows.data(), width, n, GDT_Byte, 3, bandMap, 3, 3L * width, 1, nullptr),
        CE_None);
  }
  GDALClose(GDALDataset::ToHandle(ds));
}

/// The tile of `level` holding (lon, lat).
TileKey tileAt(int level, double lon, double lat) {
  const double size = 180.0 / static_cast<double>(1 << level);
  return {level, static_cast<int>(std::floor((lon + 180.0) / size)), static_cast<int>(std::floor((lat + 90.0) / size))};
}

class GlobeImageryOverviews : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    GDALAllRegister();
    // Near UTM 33N's central meridian (15° E), so a texel's footprint is a box in the image.
    const ToUtm toUtm;
    const std::array<double, 2> centre = toUtm(15.0, 46.3);
    west_ = std::floor(centre[0] / 1000.0) * 1000.0 - kWidth * kCell / 2.0;
    north_ = std::floor(centre[1] / 1000.0) * 1000.0 + kWidth * kCell / 2.0;
    // A folder of this process's own: CTest runs each test in a process, several at a time.
    dir_ = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("run-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    large_ = (dir_ / "large_utm.tif").string();
    const auto start = std::chrono::steady_clock::now();
    writeImagery(large_, kWidth, kWidth, west_, north_);
    std::printf("wrote %s (%d x %d, 3 bands) in %.1f s\n", large_.c_str(), kWidth, kWidth, seconds(start));
  }

  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  static ImageryOptions options(bool overviews = true) {
    ImageryOptions o;
    o.lowPercentile = 0.0;  // the pattern's bytes as they are
    o.highPercentile = 100.0;
    o.overviews = overviews;
    o.cacheDir = [] { return (dir_ / "cache").string(); };
    return o;
  }

  static std::shared_ptr<GlobeImagery> open(const std::string& path, const ImageryOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    Result<std::shared_ptr<GlobeImagery>> imagery = GlobeImagery::open(path, {1, 2, 3}, o);
    for (const Diagnostic& d : imagery.diagnostics.items()) std::printf("  %s\n", d.toString().c_str());
    std::printf("opened %s in %.2f s\n", path.c_str(), seconds(start));
    EXPECT_TRUE(imagery.ok());
    return imagery.ok() ? *imagery : nullptr;
  }

  static constexpr int kWidth = 8192;
  static inline double west_ = 0.0, north_ = 0.0;
  static inline fs::path dir_;
  static inline std::string large_;
};

TEST_F(GlobeImageryOverviews, BuiltOnceIntoTheCacheAndReused) {
  const std::shared_ptr<GlobeImagery> first = open(large_, options());
  ASSERT_TRUE(first);
  EXPECT_EQ(first->overviews(), ImageryOverviews::Built);
  EXPECT_EQ(first->overviewLevels(), 5);  // 2, 4, 8, 16, 32: the coarsest 256²
  const std::string file = first->overviewFile();
  ASSERT_TRUE(fs::exists(file));
  ASSERT_TRUE(fs::exists(file + ".ovr"));
  const auto written = fs::last_write_time(file + ".ovr");
  std::printf("cache: %s (%.1f MB of overviews)\n", file.c_str(),
              static_cast<double>(fs::file_size(file + ".ovr")) / (1024.0 * 1024.0));
  // Nothing but the two files and their digests is left in the cache (no temporary).
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_ / "cache")) ++entries;
  EXPECT_EQ(entries, 3u);
  ASSERT_TRUE(fs::exists(file + ".sum"));

  const std::shared_ptr<GlobeImagery> second = open(large_, options());
  ASSERT_TRUE(second);
  EXPECT_EQ(second->overviews(), ImageryOverviews::Cached);
  EXPECT_EQ(second->overviewFile(), file);
  EXPECT_EQ(second->overviewLevels(), 5);
  EXPECT_EQ(fs::last_write_time(file + ".ovr"), written);

  // Other bands are other overviews.
  ImageryOptions o = options();
  Result<std::shared_ptr<GlobeImagery>> grey = GlobeImagery::open(large_, {2}, o);
  ASSERT_TRUE(grey.ok());
  EXPECT_EQ((*grey)->overviews(), ImageryOverviews::Built);
  EXPECT_NE((*grey)->overviewFile(), file);

  // No cache directory: none built, far views read the full resolution (said in an Info).
  o.cacheDir = nullptr;
  Result<std::shared_ptr<GlobeImagery>> uncached = GlobeImagery::open(large_, {1, 2, 3}, o);
  ASSERT_TRUE(uncached.ok());
  EXPECT_EQ((*uncached)->overviews(), ImageryOverviews::None);
  EXPECT_EQ((*uncached)->overviewLevels(), 0);
  EXPECT_FALSE(uncached.diagnostics.items().empty());
}

TEST_F(GlobeImageryOverviews, DamagedOverviewsAreRebuiltWithAWarning) {
  // The cached VRT, its overviews and their digests damaged as a disk or a crash damages files:
  // each time the next open says so once, builds them again, and a far tile (read from the
  // coarsest overview) is the undamaged one's byte for byte.
  const std::shared_ptr<GlobeImagery> clean = open(large_, options());
  ASSERT_TRUE(clean);
  const std::string file = clean->overviewFile();
  const TileKey far = tileAt(6, 15.0, 46.3);
  const std::optional<TileImage> truth = clean->tileImage(far);
  ASSERT_TRUE(truth);
  const auto flipAt = [](const fs::path& path, std::uintmax_t offset) {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(static_cast<std::streamoff>(offset));
    char c = 0;
    f.get(c);
    f.seekp(static_cast<std::streamoff>(offset));
    f.put(static_cast<char>(c ^ 0x04));
  };
  const std::vector<std::pair<const char*, std::function<void()>>> damages = {
      {"a bit in the overviews", [&] { flipAt(file + ".ovr", fs::file_size(file + ".ovr") - 5000); }},
      {"the overviews cut short", [&] { fs::resize_file(file + ".ovr", fs::file_size(file + ".ovr") / 2); }},
      {"a bit in the VRT", [&] { flipAt(file, 40); }},
      {"a bit in the digests", [&] { flipAt(file + ".sum", 3); }},
  };
  for (const auto& [what, damage] : damages) {
    SCOPED_TRACE(what);
    damage();
    Result<std::shared_ptr<GlobeImagery>> again = GlobeImagery::open(large_, {1, 2, 3}, options());
    ASSERT_TRUE(again.ok());
    std::size_t warnings = 0;
    for (const Diagnostic& d : again.diagnostics.items())
      warnings += d.severity == Severity::Warning && d.toString().find("cache file damaged") != std::string::npos &&
                          d.toString().find(file) != std::string::npos
                      ? 1U
                      : 0U;
    EXPECT_EQ(warnings, 1U);
    EXPECT_EQ((*again)->overviews(), ImageryOverviews::Built);
    const std::optional<TileImage> image = (*again)->tileImage(far);
    ASSERT_TRUE(image);
    EXPECT_TRUE(image->rgba == truth->rgba) << "the far tile as before the damage";
  }
  // Whole again: found in the cache.
  const std::shared_ptr<GlobeImagery> last = open(large_, options());
  ASSERT_TRUE(last);
  EXPECT_EQ(last->overviews(), ImageryOverviews::Cached);
}

TEST_F(GlobeImageryOverviews, FarTileReadsAboutItsTexels) {
  const std::shared_ptr<GlobeImagery> imagery = open(large_, options());
  ASSERT_TRUE(imagery);
  ASSERT_NE(imagery->overviews(), ImageryOverviews::None);
  // A level-6 tile (2.8° a side) holds the whole image (0.74° × 1.06°): 256 texels of 0.011°
  // against cells of about 1e-4°, read from the coarsest overview.
  const TileKey far = tileAt(6, 15.0, 46.3);
  const int size = imagery->textureSize(far);
  ASSERT_EQ(size, 256);
  EXPECT_EQ(imagery->levelFor(far), imagery->overviewLevels());
  auto start = std::chrono::steady_clock::now();
  const std::uint64_t before = imagery->sourcePixelsRead();
  const std::optional<TileImage> image = imagery->tileImage(far);
  const std::uint64_t read = imagery->sourcePixelsRead() - before;
  const double overviewSeconds = seconds(start);
  ASSERT_TRUE(image);

  const auto texels = static_cast<std::uint64_t>(size) * static_cast<std::uint64_t>(size);
  std::printf(
      "far tile %d/%d/%d, %d² texels: %llu source pixels read from overview level %d in %.3f s (%.2f texels², "
      "the image has %d²)\n",
      far.level, far.x, far.y, size, static_cast<unsigned long long>(read), imagery->levelFor(far), overviewSeconds,
      static_cast<double>(read) / static_cast<double>(texels), kWidth);
  EXPECT_LE(read, 2 * texels);  // the whole image is 1,024 texels²

  // Texels against a box filter of the full resolution over each texel's footprint (its corners
  // in UTM: a box in the image's cells, the grid's convergence there is 0.2 mrad), inside the
  // image by two texels. Tolerance: 3/255 a channel with the overviews.
  const ToUtm toUtm;
  const LonLatRect r = far.rect();
  const double d = far.size() / size;
  const auto boxAverage = [&](int band, double x0, double x1, double y0, double y1) {
    double sum = 0.0, weight = 0.0;
    for (int row = static_cast<int>(std::floor(y0)); row < static_cast<int>(std::ceil(y1)); ++row) {
      const double wy = std::min<double>(row + 1, y1) - std::max<double>(row, y0);
      for (int col = static_cast<int>(std::floor(x0)); col < static_cast<int>(std::ceil(x1)); ++col) {
        const double w = wy * (std::min<double>(col + 1, x1) - std::max<double>(col, x0));
        sum += w * cellValue(band, col, row);
        weight += w;
      }
    }
    return sum / weight;
  };
  std::size_t checked = 0, wrong = 0;
  double worst = 0.0, meanDiff = 0.0;
  for (int row = 0; row < size; ++row) {    // from the north
    for (int col = 0; col < size; ++col) {  // from the west
      double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
      for (const double lon : {r.west + col * d, r.west + (col + 1) * d}) {
        for (const double lat : {r.north - row * d, r.north - (row + 1) * d}) {
          const std::array<double, 2> e = toUtm(lon, lat);
          const double x = (e[0] - west_) / kCell, y = (north_ - e[1]) / kCell;
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
      }
      const double marginX = 2.0 * (x1 - x0), marginY = 2.0 * (y1 - y0);
      if (x0 < marginX || y0 < marginY || x1 > kWidth - marginX || y1 > kWidth - marginY) continue;
      const std::size_t at =
          (static_cast<std::size_t>(size - 1 - row) * static_cast<std::size_t>(size) + static_cast<std::size_t>(col)) *
          4;
      ++checked;
      double diff = 0.0;
      for (int b = 0; b < 3; ++b) {
        const double want = boxAverage(b, x0, x1, y0, y1);
        diff = std::max(diff, std::abs(image->rgba[at + static_cast<std::size_t>(b)] - want));
      }
      EXPECT_EQ(image->rgba[at + 3], 255);
      worst = std::max(worst, diff);
      meanDiff += diff;
      if (diff > 3.0) ++wrong;
    }
  }
  std::printf(
      "far tile against a box filter of the full resolution: %zu texels checked, %zu beyond 3/255 (worst %.2f, mean "
      "%.2f)\n",
      checked, wrong, worst, checked > 0 ? meanDiff / static_cast<double>(checked) : 0.0);
  EXPECT_GE(checked, 4000u);
  EXPECT_EQ(wrong, 0u);
}

TEST_F(GlobeImageryOverviews, WithoutOverviewsATileReadsEveryCellItCovers) {
  // A level-10 tile (0.18° a side, inside the image: about 1,370 × 1,950 cells): 256 texels of
  // about 6 cells, read from overview 2 (cells 4 times the full resolution's), and forced to the
  // full resolution (what every tile read before overviews).
  const TileKey mid = tileAt(10, 15.0, 46.3);
  const ToUtm toUtm;
  const LonLatRect r = mid.rect();
  const std::array<double, 2> sw = toUtm(r.west, r.south), ne = toUtm(r.east, r.north);
  const double covered = (ne[0] - sw[0]) / kCell * (ne[1] - sw[1]) / kCell;  // cells under the tile
  std::uint64_t reads[2] = {0, 0};
  int levels[2] = {0, 0};
  for (const bool overviews : {true, false}) {
    const std::shared_ptr<GlobeImagery> imagery = open(large_, options(overviews));
    ASSERT_TRUE(imagery);
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(imagery->tileImage(mid));
    reads[overviews ? 0 : 1] = imagery->sourcePixelsRead();
    levels[overviews ? 0 : 1] = imagery->levelFor(mid);
    std::printf(
        "level-10 tile, %s: %llu source pixels read from level %d in %.2f s (%.2f of the %.0f cells it covers)\n",
        overviews ? "overviews" : "full resolution", static_cast<unsigned long long>(reads[overviews ? 0 : 1]),
        levels[overviews ? 0 : 1], seconds(start), static_cast<double>(reads[overviews ? 0 : 1]) / covered, covered);
  }
  EXPECT_EQ(levels[0], 2);
  EXPECT_EQ(levels[1], 0);
  EXPECT_LE(static_cast<double>(reads[0]), 6.0 * 256 * 256);  // texels of < 2 level cells: < 4 texels², margins
  EXPECT_GE(static_cast<double>(reads[1]), covered);
}

/// What a tile read before overviews: the chosen bands as a VRT, warped into lon/lat as one
/// warped VRT (the same options), the texels' window read bilinear (GlobeImagery::tileImage's
/// arithmetic); the identity stretch.
std::vector<std::uint8_t> readAsBefore(const std::string& path, const TileKey& key, int size) {
  GDALDatasetH src = GDALOpen(path.c_str(), GA_ReadOnly);
  std::vector<std::string> args{"-of", "VRT", "-b", "1", "-b", "2", "-b", "3"};
  const auto argv = [](std::vector<std::string>& a) {
    std::vector<char*> out;
    for (std::string& s : a) out.push_back(s.data());
    out.push_back(nullptr);
    return out;
  };
  std::vector<char*> translateArgv = argv(args);
  GDALTranslateOptions* translate = GDALTranslateOptionsNew(translateArgv.data(), nullptr);
  GDALDatasetH bands = GDALTranslate("", src, translate, nullptr);
  GDALTranslateOptionsFree(translate);
  std::vector<std::string> warpArgs{"-of",       "VRT", "-t_srs", "EPSG:4326", "-r",     "bilinear",
                                    "-dstalpha", "-et", "0.05",   "-ot",       "Float32"};
  std::vector<char*> warpArgv = argv(warpArgs);
  GDALWarpAppOptions* warpOptions = GDALWarpAppOptionsNew(warpArgv.data(), nullptr);
  GDALDatasetH warped = GDALWarp("", nullptr, 1, &bands, warpOptions, nullptr);
  GDALWarpAppOptionsFree(warpOptions);
  double gt[6];
  GDALGetGeoTransform(warped, gt);
  const int width = GDALGetRasterXSize(warped), height = GDALGetRasterYSize(warped);
  const LonLatRect r = key.rect();
  const double d = key.size() / size;
  const double x0 = gt[0], y0 = gt[3], x1 = gt[0] + width * gt[1], y1 = gt[3] + height * gt[5];
  const int c0 = std::max(0, static_cast<int>(std::ceil((x0 - r.west) / d - 0.5)));
  const int c1 = std::min(size - 1, static_cast<int>(std::floor((x1 - r.west) / d - 0.5)));
  const int r0 = std::max(0, static_cast<int>(std::ceil((r.north - y0) / d - 0.5)));
  const int r1 = std::min(size - 1, static_cast<int>(std::floor((r.north - y1) / d - 0.5)));
  const int bw = c1 - c0 + 1, bh = r1 - r0 + 1;
  const double fx0 = std::clamp((r.west + c0 * d - x0) / gt[1], 0.0, static_cast<double>(width));
  const double fx1 = std::clamp((r.west + (c1 + 1) * d - x0) / gt[1], 0.0, static_cast<double>(width));
  const double fy0 = std::clamp((r.north - r0 * d - y0) / gt[5], 0.0, static_cast<double>(height));
  const double fy1 = std::clamp((r.north - (r1 + 1) * d - y0) / gt[5], 0.0, static_cast<double>(height));
  GDALRasterIOExtraArg extra;
  INIT_RASTERIO_EXTRA_ARG(extra);
  extra.eResampleAlg = GRIORA_Bilinear;
  extra.bFloatingPointWindowValidity = TRUE;
  extra.dfXOff = fx0;
  extra.dfYOff = fy0;
  extra.dfXSize = fx1 - fx0;
  extra.dfYSize = fy1 - fy0;
  const int ix0 = static_cast<int>(std::floor(fx0)), iy0 = static_cast<int>(std::floor(fy0));
  const int ix1 = std::min(width, static_cast<int>(std::ceil(fx1))),
            iy1 = std::min(height, static_cast<int>(std::ceil(fy1)));
  std::vector<float> buffer(static_cast<std::size_t>(bw) * static_cast<std::size_t>(bh) * 4);
  int bandMap[4] = {1, 2, 3, 4};
  const CPLErr err = GDALDatasetRasterIOEx(warped, GF_Read, ix0, iy0, ix1 - ix0, iy1 - iy0, buffer.data(), bw, bh,
                                           GDT_Float32, 4, bandMap, 16, 16L * bw, 4, &extra);
  EXPECT_EQ(err, CE_None);
  GDALClose(warped);
  GDALClose(bands);
  GDALClose(src);
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(size) * static_cast<std::size_t>(size) * 4, 0);
  for (int row = 0; row < bh; ++row) {
    for (int col = 0; col < bw; ++col) {
      const float* v =
          buffer.data() +
          (static_cast<std::size_t>(row) * static_cast<std::size_t>(bw) + static_cast<std::size_t>(col)) * 4;
      std::uint8_t* t =
          rgba.data() + (static_cast<std::size_t>(size - 1 - (r0 + row)) * static_cast<std::size_t>(size) +
                         static_cast<std::size_t>(c0 + col)) *
                            4;
      const float alpha = std::clamp(v[3], 0.0F, 255.0F);
      if (!(alpha > 0.0F)) continue;
      for (int ch = 0; ch < 3; ++ch)
        t[ch] = static_cast<std::uint8_t>(std::lround(std::clamp(v[ch] / 255.0F, 0.0F, 1.0F) * 255.0F));
      t[3] = static_cast<std::uint8_t>(std::lround(alpha));
    }
  }
  return rgba;
}

TEST_F(GlobeImageryOverviews, FineTilesReadAsBeforeOverviews) {
  const std::shared_ptr<GlobeImagery> imagery = open(large_, options());
  ASSERT_TRUE(imagery);
  ASSERT_GT(imagery->overviewLevels(), 0);
  // Level 14: texels finer than the cells; level 12: texels up to 1.7 cells (still the full
  // resolution: the first overview's cells are coarser than a texel); level 11 reads overview 1.
  for (const int level : {14, 12}) {
    const TileKey key = tileAt(level, 15.0, 46.3);
    ASSERT_EQ(imagery->levelFor(key), 0) << level;
    const std::uint64_t before = imagery->sourcePixelsRead();
    const std::optional<TileImage> image = imagery->tileImage(key);
    ASSERT_TRUE(image) << level;
    const std::vector<std::uint8_t> want = readAsBefore(large_, key, image->size);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < want.size(); ++i) differ += want[i] != image->rgba[i] ? 1U : 0U;
    std::printf(
        "level %d tile, %d² texels of %.2f cells: %zu of %zu bytes differ from the read before overviews; "
        "%llu source pixels read\n",
        level, image->size, key.size() / image->size / imagery->step(), differ, want.size(),
        static_cast<unsigned long long>(imagery->sourcePixelsRead() - before));
    EXPECT_EQ(differ, 0u) << level;
  }
  EXPECT_EQ(imagery->levelFor(tileAt(11, 15.0, 46.3)), 1);
}

TEST_F(GlobeImageryOverviews, SmallImageryAndTheSourcesOwnOverviews) {
  // 2048²: below the threshold, no overviews built; once it has its own, they are used.
  const std::string small = (dir_ / "small_utm.tif").string();
  constexpr double kInset = (kWidth - 2048) / 2.0 * kCell;  // centred as the large one
  writeImagery(small, 2048, 2048, west_ + kInset, north_ - kInset);
  const std::shared_ptr<GlobeImagery> plain = open(small, options());
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->overviews(), ImageryOverviews::None);
  EXPECT_EQ(plain->overviewLevels(), 0);
  {
    GDALDataset* ds = GDALDataset::Open(small.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE);
    ASSERT_NE(ds, nullptr);
    int factors[3] = {2, 4, 8};
    ASSERT_EQ(ds->BuildOverviews("AVERAGE", 3, factors, 0, nullptr, nullptr, nullptr, nullptr), CE_None);
    GDALClose(GDALDataset::ToHandle(ds));
  }
  const std::shared_ptr<GlobeImagery> own = open(small, options());
  ASSERT_TRUE(own);
  EXPECT_EQ(own->overviews(), ImageryOverviews::Source);
  EXPECT_EQ(own->overviewLevels(), 3);
  EXPECT_TRUE(own->overviewFile().empty());
  const TileKey far = tileAt(7, 15.0, 46.3);  // 1.4°: texels of 0.0055°, cells of about 1e-4°
  EXPECT_EQ(own->levelFor(far), 3);
  const std::optional<TileImage> image = own->tileImage(far);
  ASSERT_TRUE(image);
  const auto texels = static_cast<std::uint64_t>(image->size) * static_cast<std::uint64_t>(image->size);
  std::printf("own overviews: far tile %d² read %llu source pixels (of 2048²)\n", image->size,
              static_cast<unsigned long long>(own->sourcePixelsRead()));
  EXPECT_LE(own->sourcePixelsRead(), 2 * texels);
}

}  // namespace
}  // namespace gis::globe
