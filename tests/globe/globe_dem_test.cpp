// The globe's DEM reading (globe::GeoGrid::fromDem, docs/globe.md "Heights above the ellipsoid"
// and "DEM mosaics"): geoid heights converted to ellipsoidal ones by PROJ with proj-data's EGM96
// grid, checked against PROJ's own transformation of each post (1 cm); a mosaic of two tiles
// against one raster holding both; a DEM in UTM; the memory budget; the scene key.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include "globe/geo_grid.hpp"
#include "scene/scene.hpp"

namespace gis::globe {
namespace {

namespace fs = std::filesystem;

fs::path scratch() {
  const fs::path dir = fs::temp_directory_path() / ("globe_dem_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
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

Result<GeoGrid> read(const std::vector<std::string>& paths, VerticalDatum datum, double budgetMb = 0.0) {
  geo::DemSpec spec;
  spec.paths = paths;
  GeoGridReadOptions options;
  options.vertical = datum;
  options.memoryBudgetMb = budgetMb;
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

TEST(GlobeDem, BeyondTheMemoryBudgetIsRefused) {
  Result<GeoGrid> grid = read({recifeZero()}, VerticalDatum::Ellipsoid, 0.001);
  ASSERT_FALSE(grid.ok());
  const std::string message = grid.diagnostics.items().back().toString();
  EXPECT_NE(message.find("test-scene.json"), std::string::npos) << message;
  EXPECT_NE(message.find("recife_zero.tif"), std::string::npos) << message;
  EXPECT_NE(message.find("memory_budget_mb"), std::string::npos) << message;
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
