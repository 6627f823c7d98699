// Raster reading: the Olinda DEM and Landsat scene against gdalinfo / PROVENANCE.md, band
// order and interleaving against a synthetic GeoTIFF, nodata, and bad input.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include "geo/raster.hpp"
#include "test_paths.hpp"

namespace {

using gis::geo::Raster;
using gis::geo::RasterInfo;

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";
const std::string kDem = kSamples + "olinda_dem_utm25s.tif";
const std::string kLandsat = kSamples + "L7_ETMs.tif";

std::string outputPath(const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

/// Writes a GeoTIFF (EPSG:32725) of `bands` bands; sample(band, col, row) gives the values.
template <typename Sample>
void writeGeoTiff(const std::string& path, int w, int h, int bands, GDALDataType type, Sample sample,
                  std::vector<std::optional<double>> nodata = {}) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), w, h, bands, type, nullptr);
  ASSERT_NE(ds, nullptr);
  std::array<double, 6> gt{290000.0, 30.0, 0.0, 9120000.0, 0.0, -30.0};
  ds->SetGeoTransform(gt.data());
  OGRSpatialReference srs;
  srs.importFromEPSG(32725);
  ds->SetSpatialRef(&srs);
  for (int b = 1; b <= bands; ++b) {
    std::vector<double> data;
    for (int row = 0; row < h; ++row)
      for (int col = 0; col < w; ++col) data.push_back(sample(b, col, row));
    GDALRasterBand* band = ds->GetRasterBand(b);
    if (static_cast<std::size_t>(b) <= nodata.size() && nodata[static_cast<std::size_t>(b - 1)])
      band->SetNoDataValue(*nodata[static_cast<std::size_t>(b - 1)]);
    ASSERT_EQ(band->RasterIO(GF_Write, 0, 0, w, h, data.data(), w, h, GDT_Float64, 0, 0, nullptr), CE_None);
  }
  GDALClose(GDALDataset::ToHandle(ds));
}

TEST(Raster, OlindaDemSizeGeotransformAndHeights) {
  gis::Result<Raster> dem = gis::geo::readRaster(kDem);
  ASSERT_TRUE(dem.ok());
  EXPECT_FALSE(dem.diagnostics.hasErrors());
  const RasterInfo& info = dem->info;
  EXPECT_EQ(info.path, kDem);
  EXPECT_EQ(info.width, 111);
  EXPECT_EQ(info.height, 111);
  EXPECT_EQ(info.bandCount, 1);
  EXPECT_EQ(dem->channels(), 1);
  EXPECT_EQ(dem->bands, std::vector<int>{1});
  ASSERT_EQ(dem->samples.size(), 111u * 111u);
  EXPECT_TRUE(info.crsIsProjected);
  EXPECT_FALSE(info.crsIsGeographic);
  EXPECT_FALSE(info.nodata.has_value());  // gdalinfo prints no NoData Value

  // gdalinfo: Origin = (288776.250000803149305,9120760.750028736889362),
  // Pixel Size = (89.994067349451157,-89.994067349451157), printed to 15 decimals.
  const auto& c = info.geoTransform.c;
  EXPECT_NEAR(c[0], 288776.250000803149305, 1e-8);
  EXPECT_NEAR(c[3], 9120760.750028736889362, 1e-8);
  EXPECT_NEAR(c[1], 89.994067349451157, 1e-12);
  EXPECT_NEAR(c[5], -89.994067349451157, 1e-12);
  EXPECT_EQ(c[2], 0.0);
  EXPECT_EQ(c[4], 0.0);
  // Lower right corner as gdalinfo prints it (3 decimals: 1 mm).
  const glm::dvec2 lr = info.geoTransform.pixelToCrs(111, 111);
  EXPECT_NEAR(lr.x, 298765.591, 1e-3);
  EXPECT_NEAR(lr.y, 9110771.409, 1e-3);
  const glm::dvec2 centre00 = info.pixelCentre(0, 0);
  EXPECT_NEAR(centre00.x, c[0] + 0.5 * c[1], 1e-9);
  EXPECT_NEAR(centre00.y, c[3] + 0.5 * c[5], 1e-9);

  // PROVENANCE.md and gdalinfo -stats: heights -1 .. 88 m (whole metres in a float file).
  const auto [lo, hi] = std::minmax_element(dem->samples.begin(), dem->samples.end());
  EXPECT_FLOAT_EQ(*lo, -1.0f);
  EXPECT_FLOAT_EQ(*hi, 88.0f);
  EXPECT_TRUE(std::none_of(dem->samples.begin(), dem->samples.end(), [](float v) { return std::isnan(v); }));
}

TEST(Raster, InspectGivesTheSameInfoWithoutSamples) {
  gis::Result<RasterInfo> info = gis::geo::inspectRaster(kDem);
  gis::Result<Raster> dem = gis::geo::readRaster(kDem);
  ASSERT_TRUE(info.ok() && dem.ok());
  EXPECT_EQ(info->width, dem->info.width);
  EXPECT_EQ(info->height, dem->info.height);
  EXPECT_EQ(info->geoTransform.c, dem->info.geoTransform.c);
  EXPECT_EQ(info->crsWkt, dem->info.crsWkt);
  EXPECT_FALSE(info->crsWkt.empty());
}

TEST(Raster, GeoTransformInverse) {
  gis::geo::GeoTransform gt;
  gt.c = {1000.0, 2.0, 0.5, 5000.0, -0.25, -3.0};  // rotated and sheared
  for (const glm::dvec2 px : {glm::dvec2(0.0, 0.0), glm::dvec2(10.5, 3.25), glm::dvec2(-7.0, 99.0)}) {
    const auto back = gt.crsToPixel(gt.pixelToCrs(px.x, px.y));
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(back->x, px.x, 1e-9);
    EXPECT_NEAR(back->y, px.y, 1e-9);
  }
  gt.c = {0.0, 1.0, 2.0, 0.0, 2.0, 4.0};  // singular
  EXPECT_FALSE(gt.crsToPixel(glm::dvec2(1.0, 1.0)).has_value());
}

TEST(Raster, LandsatTrueColourBands) {
  gis::Result<Raster> img = gis::geo::readRaster(kLandsat, {3, 2, 1});
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->info.width, 349);
  EXPECT_EQ(img->info.height, 352);
  EXPECT_EQ(img->info.bandCount, 6);
  EXPECT_EQ(img->channels(), 3);
  EXPECT_EQ(img->bands, (std::vector<int>{3, 2, 1}));
  ASSERT_EQ(img->samples.size(), 349u * 352u * 3u);
  // 8-bit bands: every sample a whole number in [0, 255].
  for (const float v : img->samples) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 255.0f);
    ASSERT_EQ(v, std::floor(v));
  }
  // Channel k of the interleaved read is band bands[k] read alone.
  for (int k = 0; k < 3; ++k) {
    gis::Result<Raster> single = gis::geo::readRaster(kLandsat, {img->bands[static_cast<std::size_t>(k)]});
    ASSERT_TRUE(single.ok());
    for (int row = 0; row < img->info.height; row += 17)
      for (int col = 0; col < img->info.width; col += 13)
        ASSERT_EQ(img->at(col, row, k), single->at(col, row)) << k << " " << col << " " << row;
  }
  // The bands really differ (a mix-up of band numbers would not be noticed otherwise).
  double diff = 0.0;
  for (std::size_t i = 0; i < img->samples.size(); i += 3) diff += std::abs(img->samples[i] - img->samples[i + 2]);
  EXPECT_GT(diff, 0.0);
}

TEST(Raster, TopRowFirstPixelInterleaved) {
  // value = 100·band + 10·row + col, so every sample says where it came from.
  const std::string path = outputPath("pattern.tif");
  constexpr int kW = 5;
  constexpr int kH = 4;
  writeGeoTiff(path, kW, kH, 3, GDT_Float32, [](int b, int col, int row) { return 100.0 * b + 10.0 * row + col; });
  gis::Result<Raster> r = gis::geo::readRaster(path, {2, 3, 1, 2});
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->samples.size(), std::size_t{kW * kH * 4});
  const int bands[] = {2, 3, 1, 2};
  for (int row = 0; row < kH; ++row)
    for (int col = 0; col < kW; ++col)
      for (int k = 0; k < 4; ++k) {
        const auto expected = static_cast<float>(100 * bands[k] + 10 * row + col);
        EXPECT_EQ(r->at(col, row, k), expected);
        EXPECT_EQ(r->samples[static_cast<std::size_t>((row * kW + col) * 4 + k)], expected);
      }
}

TEST(Raster, BadBandNumbersNameFileAndBand) {
  for (const int band : {7, 0, -1}) {
    gis::Result<Raster> r = gis::geo::readRaster(kLandsat, {3, band});
    EXPECT_FALSE(r.ok());
    ASSERT_TRUE(r.diagnostics.hasErrors());
    const gis::Diagnostic& d = r.diagnostics.items().back();
    EXPECT_EQ(d.file, kLandsat);
    EXPECT_NE(d.message.find("band " + std::to_string(band)), std::string::npos) << d.message;
    EXPECT_NE(d.toString().find("L7_ETMs.tif"), std::string::npos);
  }
  EXPECT_FALSE(gis::geo::readRaster(kLandsat, {}).ok());
}

TEST(Raster, MissingAndBrokenFilesFailWithTheirName) {
  const std::string missing = kSamples + "does_not_exist.tif";
  for (const std::string& path :
       {missing, std::string(STENCIL_GIS_TEST_DATA_DIR) + "/garbage.geojson", kSamples + "PROVENANCE.md"}) {
    SCOPED_TRACE(path);
    gis::Result<Raster> r = gis::geo::readRaster(path);
    EXPECT_FALSE(r.ok());
    ASSERT_TRUE(r.diagnostics.hasErrors());
    EXPECT_EQ(r.diagnostics.items().front().file, path);
    EXPECT_FALSE(r.diagnostics.items().front().message.empty());
    gis::Result<RasterInfo> i = gis::geo::inspectRaster(path);
    EXPECT_FALSE(i.ok());
    EXPECT_TRUE(i.diagnostics.hasErrors());
  }
}

TEST(Raster, NodataBecomesNaN) {
  // A float DEM with nodata on the diagonal.
  const std::string path = outputPath("nodata_dem.tif");
  constexpr double kNodata = -9999.0;
  writeGeoTiff(path, 4, 3, 1, GDT_Float32, [](int, int col, int row) { return col == row ? kNodata : 1.5 * col + row; },
               {kNodata});
  gis::Result<Raster> r = gis::geo::readRaster(path);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(r->info.nodata.has_value());
  EXPECT_EQ(*r->info.nodata, kNodata);
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) {
      if (col == row) {
        EXPECT_TRUE(std::isnan(r->at(col, row))) << col << "," << row;
      } else {
        EXPECT_FLOAT_EQ(r->at(col, row), static_cast<float>(1.5 * col + row));
      }
    }
}

TEST(Raster, NodataInImageryBandsBecomesNaN) {
  // GeoTIFF has one nodata value for all bands: 0 here; each band has its zeros elsewhere.
  const std::string path = outputPath("nodata_rgb.tif");
  writeGeoTiff(path, 6, 2, 3, GDT_Byte, [](int b, int col, int row) { return col == b ? 0.0 : 10.0 * b + row; },
               {0.0, 0.0, 0.0});
  gis::Result<Raster> r = gis::geo::readRaster(path, {3, 1});
  ASSERT_TRUE(r.ok());
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 6; ++col)
      for (int k = 0; k < 2; ++k) {
        const int band = r->bands[static_cast<std::size_t>(k)];
        if (col == band) {
          EXPECT_TRUE(std::isnan(r->at(col, row, k))) << band << " " << col << "," << row;
        } else {
          EXPECT_EQ(r->at(col, row, k), static_cast<float>(10 * band + row));
        }
      }
}

}  // namespace
