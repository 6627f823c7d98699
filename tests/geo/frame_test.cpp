// SceneFrame, CrsTransform and utmZoneOf against gdalinfo's numbers for the Olinda DEM,
// against GeographicLib, and against themselves (round trips with many random points).
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <glm/geometric.hpp>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/UTMUPS.hpp>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "test_paths.hpp"

namespace {

using gis::geo::CrsTransform;
using gis::geo::RasterInfo;
using gis::geo::SceneFrame;

const std::string kDem = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/olinda_dem_utm25s.tif";

/// Degrees from gdalinfo's D°M'S" with hemisphere letter.
double dms(int d, int m, double s, char hemisphere) {
  const double v = d + m / 60.0 + s / 3600.0;
  return (hemisphere == 'W' || hemisphere == 'S') ? -v : v;
}

/// Distance in metres between two lon/lat points (WGS 84; the ellipsoid hardly matters for
/// turning a tiny angular error into metres).
double groundDistance(double lon1, double lat1, double lon2, double lat2) {
  double s12 = 0.0;
  GeographicLib::Geodesic::WGS84().Inverse(lat1, lon1, lat2, lon2, s12);
  return s12;
}

std::string outputPath(const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

/// Writes a small single-band Float32 GeoTIFF; `epsg` 0 means no CRS.
void writeGeoTiff(const std::string& path, int epsg, const std::array<double, 6>& gt, int w, int h) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), w, h, 1, GDT_Float32, nullptr);
  ASSERT_NE(ds, nullptr);
  std::array<double, 6> g = gt;
  ds->SetGeoTransform(g.data());
  if (epsg != 0) {
    OGRSpatialReference srs;
    srs.importFromEPSG(epsg);
    ds->SetSpatialRef(&srs);
  }
  std::vector<float> data(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 1.0f);
  ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, w, h, data.data(), w, h, GDT_Float32, 0, 0, nullptr),
            CE_None);
  GDALClose(GDALDataset::ToHandle(ds));
}

SceneFrame olindaFrame() {
  gis::Result<RasterInfo> info = gis::geo::inspectRaster(kDem);
  EXPECT_TRUE(info.ok());
  gis::Result<SceneFrame> frame = SceneFrame::forRaster(*info);
  EXPECT_TRUE(frame.ok());
  return *frame;
}

// gdalinfo olinda_dem_utm25s.tif (GDAL 3.6.2): projected corners to 3 decimals and their
// lon/lat to 0.01".
struct Corner {
  const char* name;
  double x, y;
  double lon, lat;
};
const Corner kCorners[] = {
    {"upper left", 288776.250, 9120760.750, dms(34, 54, 58.20, 'W'), dms(7, 56, 59.36, 'S')},
    {"lower left", 288776.250, 9110771.409, dms(34, 54, 59.71, 'W'), dms(8, 2, 24.47, 'S')},
    {"upper right", 298765.591, 9120760.750, dms(34, 49, 32.08, 'W'), dms(7, 57, 0.83, 'S')},
    {"lower right", 298765.591, 9110771.409, dms(34, 49, 33.52, 'W'), dms(8, 2, 25.96, 'S')},
    {"center", 293770.921, 9115766.079, dms(34, 52, 15.88, 'W'), dms(7, 59, 42.66, 'S')},
};

TEST(SceneFrame, OlindaDemFrameHasItsCentreAsOrigin) {
  const SceneFrame frame = olindaFrame();
  // gdalinfo prints the centre to 3 decimals: rounding error <= 0.5 mm.
  constexpr double kTolMetres = 1e-3;
  EXPECT_NEAR(frame.origin().x, 293770.921, kTolMetres);
  EXPECT_NEAR(frame.origin().y, 9115766.079, kTolMetres);
  EXPECT_EQ(frame.origin().z, 0.0);
  EXPECT_FALSE(frame.crsWkt().empty());
  EXPECT_NE(frame.crsWkt().find("Transverse Mercator"), std::string::npos);
  EXPECT_EQ(frame.up(glm::dvec3(0.0)), glm::dvec3(0.0, 0.0, 1.0));
}

TEST(SceneFrame, OlindaCornersLandWhereGdalinfoSays) {
  const SceneFrame frame = olindaFrame();
  // lon/lat → frame: gdalinfo's lon/lat are rounded to 0.01" (≈ 0.15 m), so 0.5 m.
  constexpr double kLonLatToFrameTol = 0.5;
  // frame → lon/lat: the projected corners are exact to 0.5 mm, so the lon/lat must round to
  // what gdalinfo printed: at most 0.005" off, plus a hair for the millimetre.
  constexpr double kToLonLatTolDeg = 0.0055 / 3600.0;
  for (const Corner& c : kCorners) {
    SCOPED_TRACE(c.name);
    const auto f = frame.fromLonLat(c.lon, c.lat, 12.0);
    ASSERT_TRUE(f.has_value());
    const glm::dvec3 p = frame.frameToProjected(*f);
    EXPECT_NEAR(p.x, c.x, kLonLatToFrameTol);
    EXPECT_NEAR(p.y, c.y, kLonLatToFrameTol);
    EXPECT_DOUBLE_EQ(p.z, 12.0);  // heights pass through

    const auto ll = frame.toLonLat(frame.projectedToFrame(glm::dvec3(c.x, c.y, 3.0)));
    ASSERT_TRUE(ll.has_value());
    EXPECT_NEAR(ll->x, c.lon, kToLonLatTolDeg);
    EXPECT_NEAR(ll->y, c.lat, kToLonLatTolDeg);
    EXPECT_DOUBLE_EQ(ll->z, 3.0);
  }
}

TEST(SceneFrame, OlindaCornersMatchTheRasterGeotransform) {
  gis::Result<RasterInfo> info = gis::geo::inspectRaster(kDem);
  ASSERT_TRUE(info.ok());
  const SceneFrame frame = olindaFrame();
  constexpr double kTolMetres = 1e-3;  // gdalinfo's 3 decimals
  const glm::dvec2 ul = info->geoTransform.pixelToCrs(0, 0);
  const glm::dvec2 lr = info->geoTransform.pixelToCrs(info->width, info->height);
  EXPECT_NEAR(ul.x, kCorners[0].x, kTolMetres);
  EXPECT_NEAR(ul.y, kCorners[0].y, kTolMetres);
  EXPECT_NEAR(lr.x, kCorners[3].x, kTolMetres);
  EXPECT_NEAR(lr.y, kCorners[3].y, kTolMetres);
  // The frame origin is the middle of the corners.
  EXPECT_NEAR(frame.origin().x, 0.5 * (ul.x + lr.x), 1e-6);
  EXPECT_NEAR(frame.origin().y, 0.5 * (ul.y + lr.y), 1e-6);
}

/// lon/lat → frame → lon/lat and frame → lon/lat → frame for random points in a box.
void expectRoundTrips(const SceneFrame& frame, double lon0, double lon1, double lat0, double lat1, int count,
                      unsigned seed) {
  constexpr double kTolMetres = 1e-3;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lonDist(lon0, lon1);
  std::uniform_real_distribution<double> latDist(lat0, lat1);
  std::uniform_real_distribution<double> hDist(-100.0, 3000.0);
  double worstLonLat = 0.0;
  double worstFrame = 0.0;
  for (int i = 0; i < count; ++i) {
    const double lon = lonDist(rng);
    const double lat = latDist(rng);
    const double h = hDist(rng);
    const auto f = frame.fromLonLat(lon, lat, h);
    ASSERT_TRUE(f.has_value()) << lon << ", " << lat;
    const auto back = frame.toLonLat(*f);
    ASSERT_TRUE(back.has_value());
    const double err = groundDistance(lon, lat, back->x, back->y);
    worstLonLat = std::max(worstLonLat, err);
    EXPECT_LT(err, kTolMetres) << "lon/lat round trip at " << lon << ", " << lat;
    EXPECT_DOUBLE_EQ(back->z, h);

    // And the other way, starting from the frame point of this one.
    const glm::dvec3 start = *f + glm::dvec3(0.37, -0.21, 0.0);
    const auto ll = frame.toLonLat(start);
    ASSERT_TRUE(ll.has_value());
    const auto again = frame.fromLonLat(ll->x, ll->y, ll->z);
    ASSERT_TRUE(again.has_value());
    const double ferr = glm::length(glm::dvec2(*again) - glm::dvec2(start));
    worstFrame = std::max(worstFrame, ferr);
    EXPECT_LT(ferr, kTolMetres) << "frame round trip at " << start.x << ", " << start.y;
  }
  ::testing::Test::RecordProperty("worst_lonlat_roundtrip_m", std::to_string(worstLonLat));
  ::testing::Test::RecordProperty("worst_frame_roundtrip_m", std::to_string(worstFrame));
}

TEST(SceneFrame, RoundTripsWithinOneMillimetreOverOlinda) {
  expectRoundTrips(olindaFrame(), -34.95, -34.80, -8.07, -7.93, 2000, 20240601u);
}

TEST(SceneFrame, RoundTripsWithinOneMillimetreInFarCornersOfTheZone) {
  // UTM zone 25 spans 36° W .. 30° W; the south frame is used from the equator to 80° S.
  const SceneFrame frame = olindaFrame();
  expectRoundTrips(frame, -36.0, -35.5, -80.0, -79.0, 300, 1u);  // far south-west
  expectRoundTrips(frame, -30.5, -30.0, -80.0, -79.0, 300, 2u);  // far south-east
  expectRoundTrips(frame, -36.0, -35.5, -1.0, 0.0, 300, 3u);     // equator, west edge
  expectRoundTrips(frame, -30.5, -30.0, -1.0, 0.0, 300, 4u);     // equator, east edge
  expectRoundTrips(frame, -36.0, -30.0, -80.0, 0.0, 1000, 5u);   // anywhere in the zone
}

TEST(SceneFrame, FromEpsgMatchesGeographicLibUtm) {
  // Independent implementation of UTM: GeographicLib (Krüger series). Both agree far below
  // a millimetre inside the zone; 1 mm stated.
  constexpr double kTolMetres = 1e-3;
  const glm::dvec3 origin(290000.0, 9110000.0, 5.0);
  gis::Result<SceneFrame> frame = SceneFrame::fromCrs("EPSG:32725", origin);
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(frame->epsg(), 32725);
  std::mt19937 rng(7u);
  std::uniform_real_distribution<double> lonDist(-36.0, -30.0);
  std::uniform_real_distribution<double> latDist(-79.0, -0.01);
  for (int i = 0; i < 500; ++i) {
    const double lon = lonDist(rng);
    const double lat = latDist(rng);
    int zone = 0;
    bool north = true;
    double x = 0.0;
    double y = 0.0;
    GeographicLib::UTMUPS::Forward(lat, lon, zone, north, x, y, 25);
    ASSERT_FALSE(north);
    const auto f = frame->fromLonLat(lon, lat, 0.0);
    ASSERT_TRUE(f.has_value());
    EXPECT_NEAR(f->x + origin.x, x, kTolMetres) << lon << ", " << lat;
    EXPECT_NEAR(f->y + origin.y, y, kTolMetres) << lon << ", " << lat;
    EXPECT_DOUBLE_EQ(f->z, -origin.z);
  }
}

TEST(SceneFrame, NonFinitePointsAreRejectedNotCrashed) {
  const SceneFrame frame = olindaFrame();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(frame.fromLonLat(nan, -8.0, 0.0).has_value());
  EXPECT_FALSE(frame.fromLonLat(-34.9, inf, 0.0).has_value());
  EXPECT_FALSE(frame.toLonLat(glm::dvec3(nan, 0.0, 0.0)).has_value());
  EXPECT_FALSE(frame.fromLonLat(-34.9, 95.0, 0.0).has_value());  // latitude beyond the pole
}

TEST(SceneFrame, CopiesAndMovesBehaveTheSame) {
  const SceneFrame frame = olindaFrame();
  SceneFrame copy = frame;
  SceneFrame assigned = *SceneFrame::fromCrs("EPSG:32631", glm::dvec3(0.0));
  assigned = copy;
  SceneFrame moved = std::move(copy);
  const auto a = frame.fromLonLat(-34.87, -7.99, 0.0);
  const auto b = assigned.fromLonLat(-34.87, -7.99, 0.0);
  const auto c = moved.fromLonLat(-34.87, -7.99, 0.0);
  ASSERT_TRUE(a && b && c);
  EXPECT_EQ(*a, *b);
  EXPECT_EQ(*a, *c);
  EXPECT_EQ(frame.crsWkt(), moved.crsWkt());
  EXPECT_EQ(frame.origin(), assigned.origin());
}

TEST(SceneFrame, FromCrsRejectsGeographicAndUnknownCrs) {
  gis::Result<SceneFrame> geographic = SceneFrame::fromCrs("EPSG:4326", glm::dvec3(0.0));
  EXPECT_FALSE(geographic.ok());
  ASSERT_TRUE(geographic.diagnostics.hasErrors());
  EXPECT_NE(geographic.diagnostics.items().front().message.find("not projected"), std::string::npos)
      << geographic.diagnostics.items().front().message;

  gis::Result<SceneFrame> nonsense = SceneFrame::fromCrs("nonsense", glm::dvec3(0.0));
  EXPECT_FALSE(nonsense.ok());
  ASSERT_TRUE(nonsense.diagnostics.hasErrors());
  EXPECT_NE(nonsense.diagnostics.items().front().message.find("nonsense"), std::string::npos)
      << nonsense.diagnostics.items().front().message;

  EXPECT_FALSE(SceneFrame::fromCrs("", glm::dvec3(0.0)).ok());
  EXPECT_FALSE(SceneFrame::fromCrs("EPSG:999999", glm::dvec3(0.0)).ok());
}

TEST(SceneFrame, ForRasterOnGeographicRasterPicksUtmZoneOfItsCentre) {
  struct Case {
    const char* name;
    double west, north;  // upper-left corner, 0.2° x 0.1° raster
    int expectedEpsg;
  };
  const Case cases[] = {
      {"olinda_wgs84.tif", -34.95, -7.95, 32725},
      {"germany_wgs84.tif", 10.4, 50.1, 32632},
      {"norway_wgs84.tif", 5.2, 60.5, 32632},  // Bergen: the Norway exception (not 31)
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = outputPath(c.name);
    writeGeoTiff(path, 4326, {c.west, 0.002, 0.0, c.north, 0.0, -0.001}, 100, 100);
    gis::Result<RasterInfo> info = gis::geo::inspectRaster(path);
    ASSERT_TRUE(info.ok());
    EXPECT_TRUE(info->crsIsGeographic);
    gis::Result<SceneFrame> frame = SceneFrame::forRaster(*info);
    ASSERT_TRUE(frame.ok());
    EXPECT_EQ(frame->epsg(), c.expectedEpsg);
    // The origin is the centre of the extent, projected with GeographicLib's UTM.
    const double lonC = c.west + 0.1;
    const double latC = c.north - 0.05;
    int zone = 0;
    bool north = true;
    double x = 0.0;
    double y = 0.0;
    GeographicLib::UTMUPS::Forward(latC, lonC, zone, north, x, y);
    EXPECT_EQ((north ? 32600 : 32700) + zone, c.expectedEpsg);
    EXPECT_NEAR(frame->origin().x, x, 1e-3);
    EXPECT_NEAR(frame->origin().y, y, 1e-3);
    EXPECT_EQ(frame->origin().z, 0.0);
  }
}

TEST(SceneFrame, ForRasterWithoutCrsNamesTheFile) {
  const std::string path = outputPath("no_crs.tif");
  writeGeoTiff(path, 0, {1000.0, 10.0, 0.0, 2000.0, 0.0, -10.0}, 8, 8);
  gis::Result<RasterInfo> info = gis::geo::inspectRaster(path);
  ASSERT_TRUE(info.ok());
  EXPECT_TRUE(info->crsWkt.empty());
  gis::Result<SceneFrame> frame = SceneFrame::forRaster(*info);
  EXPECT_FALSE(frame.ok());
  ASSERT_TRUE(frame.diagnostics.hasErrors());
  EXPECT_EQ(frame.diagnostics.items().front().file, path);
  EXPECT_NE(frame.diagnostics.items().front().toString().find(path), std::string::npos);
}

TEST(CrsTransform, FromWgs84IntoTheOlindaFrame) {
  const SceneFrame frame = olindaFrame();
  gis::Result<CrsTransform> t = frame.transformFrom("EPSG:4326");
  ASSERT_TRUE(t.ok());
  EXPECT_TRUE(t->sourceIsGeographic());
  EXPECT_DOUBLE_EQ(t->sourceSemiMajor(), 6378137.0);
  EXPECT_NEAR(t->sourceFlattening(), 1.0 / 298.257223563, 1e-15);
  // Traditional axis order: x = longitude. The DEM's centre (gdalinfo, 0.01") lands on the
  // projected centre within 0.5 m.
  const auto p = t->transform(glm::dvec2(kCorners[4].lon, kCorners[4].lat));
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->x, kCorners[4].x, 0.5);
  EXPECT_NEAR(p->y, kCorners[4].y, 0.5);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<glm::dvec2> pts = {{-34.9, -8.0}, {nan, -8.0}, {-34.8, inf}, {-34.8, -7.9}};
  EXPECT_FALSE(t->transform(pts.data(), pts.size()));
  EXPECT_TRUE(std::isfinite(pts[0].x) && std::isfinite(pts[0].y));
  EXPECT_TRUE(std::isnan(pts[1].x) && std::isnan(pts[1].y));
  EXPECT_TRUE(std::isnan(pts[2].x) && std::isnan(pts[2].y));
  EXPECT_TRUE(std::isfinite(pts[3].x) && std::isfinite(pts[3].y));
  EXPECT_FALSE(t->transform(glm::dvec2(nan, nan)).has_value());
  EXPECT_TRUE(t->transform(nullptr, 0));

  gis::Result<CrsTransform> projected = frame.transformFrom("EPSG:31985");
  ASSERT_TRUE(projected.ok());
  EXPECT_FALSE(projected->sourceIsGeographic());

  gis::Result<CrsTransform> bad = frame.transformFrom("not a crs");
  EXPECT_FALSE(bad.ok());
  EXPECT_TRUE(bad.diagnostics.hasErrors());
}

TEST(UtmZone, KnownPoints) {
  struct Case {
    const char* name;
    double lon, lat;
    int zone;
    bool north;
    int epsg;
  };
  const Case cases[] = {
      {"Olinda", -34.87, -7.99, 25, false, 32725},
      {"Greenwich", -0.0015, 51.4779, 30, true, 32630},
      {"just east of Greenwich", 0.5, 51.5, 31, true, 32631},
      {"New York", -74.0, 40.7, 18, true, 32618},
      {"Bergen (Norway exception)", 5.32, 60.39, 32, true, 32632},
      {"Longyearbyen (Svalbard exception)", 15.6, 78.2, 33, true, 32633},
      {"antimeridian west", -180.0, -10.0, 1, false, 32701},
      {"Wellington", 174.78, -41.29, 60, false, 32760},
      {"equator is north", 10.0, 0.0, 32, true, 32632},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const gis::geo::UtmZone z = gis::geo::utmZoneOf(c.lon, c.lat);
    EXPECT_EQ(z.zone, c.zone);
    EXPECT_EQ(z.north, c.north);
    EXPECT_EQ(z.epsgWgs84(), c.epsg);
  }
  EXPECT_EQ(gis::geo::utmZoneOf(std::numeric_limits<double>::quiet_NaN(), 0.0).zone, 0);
}

}  // namespace
