// Vector sources read by spatial filter (VectorReadOptions::filter): the Olinda tracts as a
// Shapefile (the sample), and as GeoPackage, FlatGeobuf and GeoJSON written from it by GDAL; the
// Olinda streets in longitude/latitude (the box mapped into a geographic CRS). Each filtered read
// holds every feature that meets the box, identical to the unfiltered read, and far fewer than
// the whole layer. PostGIS has its own test (postgis_source_test, with a real server).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "source_checks.hpp"
#include "test_paths.hpp"

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
std::string translated(const std::string& source, const std::string& driver, const std::string& name,
                       std::vector<std::string> args = {}) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  const std::string out = (dir / name).string();
  std::filesystem::remove_all(out);
  args.insert(args.begin(), {"-f", driver, "-preserve_fid"});
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

/// Distance from p to the nearest edge of the feature's rings and lines.
double distanceToEdges(const glm::dvec2& p, const geo::Feature& f) {
  double best = std::numeric_limits<double>::infinity();
  auto edges = [&](const std::vector<glm::dvec2>& r, bool closed) {
    for (std::size_t i = 0; i + (closed ? 0 : 1) < r.size(); ++i) {
      const glm::dvec2 a = r[i], d = r[(i + 1) % r.size()] - a;
      const double t = glm::dot(d, d) > 0.0 ? std::clamp(glm::dot(p - a, d) / glm::dot(d, d), 0.0, 1.0) : 0.0;
      best = std::min(best, glm::length(p - (a + t * d)));
    }
  };
  for (const geo::Polygon& polygon : f.polygons) {
    edges(polygon.outer, true);
    for (const auto& hole : polygon.holes) edges(hole, true);
  }
  for (const geo::LineString& line : f.lines) edges(line, false);
  return best;
}

double area(const geo::Feature& f) {
  auto ringArea = [](const std::vector<glm::dvec2>& r) {
    double sum = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      const glm::dvec2 a = r[i], b = r[(i + 1) % r.size()];
      sum += a.x * b.y - a.y * b.x;
    }
    return 0.5 * std::abs(sum);
  };
  double total = 0.0;
  for (const geo::Polygon& p : f.polygons) {
    total += ringArea(p.outer);
    for (const auto& hole : p.holes) total -= ringArea(hole);
  }
  return total;
}

TEST(VectorTiles, MbtilesAndATileFolderGiveEachTractOnceWithinTheStatedQuantisation) {
  const geo::SceneFrame frame = olindaFrame();
  Result<geo::VectorLayer> source = geo::readVectorLayer(kTracts, frame);
  ASSERT_TRUE(source.ok());
  std::map<std::int64_t, const geo::Feature*> byFid;
  for (const geo::Feature& f : source->features) byFid[f.fid] = &f;
  const std::vector<std::string> zoom15 = {"-dsco", "MINZOOM=15", "-dsco", "MAXZOOM=15", "-nln", "tracts"};
  const std::vector<Source> tiles = {{"MBTiles", translated(kTracts, "MBTiles", "tracts.mbtiles", zoom15)},
                                     {"MVT folder", translated(kTracts, "MVT", "tracts_tiles", zoom15)}};
  // Zoom 15: 2π · 6378137 m / 2^15 / 4096 = 0.2986 m a unit; half a unit each way, and half a
  // unit more along a tile edge where an edge crosses it.
  const double bound = 0.5 * 0.29858 * (std::numbers::sqrt2 + 1.0);
  for (const Source& t : tiles) {
    SCOPED_TRACE(t.label);
    geo::VectorReadOptions options;
    options.layer = "tracts";
    Result<geo::VectorLayer> read = geo::readVectorLayer(t.path, frame, options);
    ASSERT_TRUE(read.ok()) << said(read.diagnostics);
    EXPECT_NEAR(read->quantisationMetres, bound, 1e-4);
    EXPECT_NE(said(read.diagnostics).find("quantised"), std::string::npos) << said(read.diagnostics);
    EXPECT_EQ(read.diagnostics.count(Severity::Error), 0u) << said(read.diagnostics);
    // Each tract once (the tiles hold 824 pieces of the 470), with its source id.
    ASSERT_EQ(read->features.size(), 470u);
    double worst = 0.0, worstBack = 0.0, worstArea = 0.0;
    for (const geo::Feature& f : read->features) {
      const auto found = byFid.find(f.fid);
      ASSERT_NE(found, byFid.end()) << "feature " << f.fid;
      const geo::Feature& s = *found->second;
      double perimeter = 0.0;
      for (const geo::Polygon& p : s.polygons) {
        for (std::size_t i = 0; i < p.outer.size(); ++i)
          perimeter += glm::length(p.outer[(i + 1) % p.outer.size()] - p.outer[i]);
      }
      // Every tile vertex near the source's outline and every source vertex near the tiles':
      // no clip edge left inside, nothing lost.
      for (const geo::Polygon& p : f.polygons) {
        for (const glm::dvec2& v : p.outer) worst = std::max(worst, distanceToEdges(v, s));
      }
      for (const geo::Polygon& p : s.polygons) {
        for (const glm::dvec2& v : p.outer) worstBack = std::max(worstBack, distanceToEdges(v, f));
      }
      worstArea = std::max(worstArea, std::abs(area(f) - area(s)) / perimeter);
    }
    std::printf(
        "%s: vertices within %.3f m of the source outline, source vertices within %.3f m of the "
        "tiles'; area change at most %.3f m x perimeter (bound %.3f m)\n",
        t.label.c_str(), worst, worstBack, worstArea, bound);
    // 1 % for the UTM scale factor (the bound is on the ground).
    EXPECT_LE(worst, 1.01 * bound);
    EXPECT_LE(worstBack, 1.01 * bound);
    EXPECT_LE(worstArea, 1.01 * bound);
  }
}

TEST(VectorTiles, LinesComeOnceWithTheirTilePiecesAsParts) {
  const geo::SceneFrame frame = olindaFrame();
  Result<geo::VectorLayer> source = geo::readVectorLayer(kStreets, frame);
  ASSERT_TRUE(source.ok());
  std::map<std::int64_t, const geo::Feature*> byFid;
  for (const geo::Feature& f : source->features) byFid[f.fid] = &f;
  const std::string tiles = translated(kStreets, "MBTiles", "streets.mbtiles",
                                       {"-dsco", "MINZOOM=16", "-dsco", "MAXZOOM=16", "-nln", "streets"});
  geo::VectorReadOptions options;
  options.layer = "streets";
  Result<geo::VectorLayer> read = geo::readVectorLayer(tiles, frame, options);
  ASSERT_TRUE(read.ok()) << said(read.diagnostics);
  const double bound = read->quantisationMetres;
  EXPECT_NEAR(bound, 0.5 * 0.14929 * (std::numbers::sqrt2 + 1.0), 1e-4);
  // Each street once under its source id.
  EXPECT_EQ(read->features.size(), source->features.size());
  double worst = 0.0, worstBack = 0.0;
  std::size_t parts = 0;
  for (const geo::Feature& f : read->features) {
    const auto found = byFid.find(f.fid);
    ASSERT_NE(found, byFid.end()) << "feature " << f.fid;
    parts += f.lines.size();
    // Tile vertices near the source line; source vertices near the tiles' lines.
    for (const auto& line : f.lines) {
      for (const glm::dvec2& v : line) worst = std::max(worst, distanceToEdges(v, *found->second));
    }
    for (const auto& line : found->second->lines) {
      for (const glm::dvec2& v : line) worstBack = std::max(worstBack, distanceToEdges(v, f));
    }
  }
  std::printf(
      "streets from MBTiles: %zu features in %zu parts; vertices within %.3f m of the source, source "
      "vertices within %.3f m of the tiles' (bound %.3f m)\n",
      read->features.size(), parts, worst, worstBack, bound);
  EXPECT_GT(parts, read->features.size()) << "some streets cross tiles";
  EXPECT_LE(worst, 1.01 * bound);
  EXPECT_LE(worstBack, 1.01 * bound);
}

}  // namespace
}  // namespace gis::test
