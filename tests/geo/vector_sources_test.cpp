// Vector sources read by spatial filter (VectorReadOptions::filter): the Olinda tracts as a
// Shapefile (the sample), and as GeoPackage, FlatGeobuf and GeoJSON written from it by GDAL; the
// Olinda streets in longitude/latitude (the box mapped into a geographic CRS). Each filtered read
// holds every feature that meets the box, identical to the unfiltered read, and far fewer than
// the whole layer. PostGIS has its own test (postgis_source_test, with a real server).
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gdal_utils.h>
#include <gtest/gtest.h>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "source_checks.hpp"

namespace gis::test {
namespace {

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";
const std::string kDem = kSamples + "olinda_dem_utm25s.tif";
const std::string kTracts = kSamples + "olinda1.shp";
const std::string kStreets = kSamples + "olinda_tract_boundaries.geojson";

geo::SceneFrame olindaFrame() {
  Result<geo::RasterInfo> info = geo::inspectRaster(kDem);
  EXPECT_TRUE(info.ok());
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(*info);
  EXPECT_TRUE(frame.ok());
  return *frame;
}

/// The sample written by GDAL (as ogr2ogr would) in another format, into this test's folder.
std::string translated(const std::string& source, const std::string& driver, const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const std::string out = (dir / name).string();
  std::filesystem::remove(out);
  std::vector<std::string> args = {"-f", driver, "-preserve_fid"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  GDALAllRegister();
  GDALVectorTranslateOptions* options = GDALVectorTranslateOptionsNew(argv.data(), nullptr);
  EXPECT_NE(options, nullptr);
  GDALDatasetH in = GDALOpenEx(source.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
  EXPECT_NE(in, nullptr);
  int error = 0;
  GDALDatasetH written = GDALVectorTranslate(out.c_str(), nullptr, 1, &in, options, &error);
  EXPECT_NE(written, nullptr) << driver;
  EXPECT_EQ(error, 0) << driver;
  GDALClose(written);
  GDALClose(in);
  GDALVectorTranslateOptionsFree(options);
  return out;
}

struct Source {
  std::string label;
  std::string path;
};

TEST(SpatialFilter, EveryFormatReadsTheFeaturesMeetingTheBox) {
  const geo::SceneFrame frame = olindaFrame();
  const std::vector<Source> sources = {
      {"Shapefile", kTracts},
      {"GeoPackage", translated(kTracts, "GPKG", "tracts.gpkg")},
      {"FlatGeobuf", translated(kTracts, "FlatGeobuf", "tracts.fgb")},
      {"GeoJSON", translated(kTracts, "GeoJSON", "tracts.geojson")},
  };
  for (const Source& source : sources) {
    SCOPED_TRACE(source.label);
    Result<geo::VectorLayer> all = geo::readVectorLayer(source.path, frame);
    ASSERT_TRUE(all.ok()) << said(all.diagnostics);
    EXPECT_EQ(all->features.size(), 470u);
    for (const double fraction : {0.05, 0.3}) {
      geo::VectorReadOptions options;
      options.filter = middleOf(*all, fraction);
      Result<geo::VectorLayer> filtered = geo::readVectorLayer(source.path, frame, options);
      ASSERT_TRUE(filtered.ok()) << said(filtered.diagnostics);
      const FilterCheck check = expectFilteredReadHoldsTheBox(*all, *filtered, *options.filter);
      std::printf("%-10s box %.2f of the extent: %zu features meet it, %zu read of %zu\n", source.label.c_str(),
                  fraction, check.meeting, check.read, all->features.size());
      EXPECT_GT(check.meeting, 0u);
      // The filter works on boxes: a feature whose box meets the box may come too, but far
      // from all of them.
      EXPECT_LE(check.read, 3 * check.meeting + 10) << "fraction " << fraction;
      EXPECT_LT(check.read, all->features.size() / 2) << "fraction " << fraction;
    }
  }
}

TEST(SpatialFilter, ABoxMapsIntoALonLatSource) {
  const geo::SceneFrame frame = olindaFrame();
  Result<geo::VectorLayer> all = geo::readVectorLayer(kStreets, frame);
  ASSERT_TRUE(all.ok());
  ASSERT_GT(all->features.size(), 1000u);
  geo::VectorReadOptions options;
  options.filter = middleOf(*all, 0.2);
  Result<geo::VectorLayer> filtered = geo::readVectorLayer(kStreets, frame, options);
  ASSERT_TRUE(filtered.ok());
  const FilterCheck check = expectFilteredReadHoldsTheBox(*all, *filtered, *options.filter);
  std::printf("streets (lon/lat): %zu meet the box, %zu read of %zu\n", check.meeting, check.read,
              all->features.size());
  EXPECT_GT(check.meeting, 10u);
  EXPECT_LT(check.read, all->features.size() / 4);
}

TEST(SpatialFilter, ABoxOutsideTheDataReadsNothingAndABadBoxIsAnError) {
  const geo::SceneFrame frame = olindaFrame();
  geo::VectorReadOptions far;
  far.filter = Box{glm::dvec2(5e5, 5e5), glm::dvec2(6e5, 6e5)};
  Result<geo::VectorLayer> none = geo::readVectorLayer(kTracts, frame, far);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->features.empty());
  geo::VectorReadOptions bad;
  bad.filter = Box{glm::dvec2(0.0, 0.0), glm::dvec2(std::numeric_limits<double>::quiet_NaN(), 1.0)};
  Result<geo::VectorLayer> refused = geo::readVectorLayer(kTracts, frame, bad);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(said(refused.diagnostics).find("spatial filter"), std::string::npos) << said(refused.diagnostics);
}

}  // namespace
}  // namespace gis::test
