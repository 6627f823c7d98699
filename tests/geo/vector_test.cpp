// Vector reading: the Olinda samples (counts checked with ogrinfo/ogr2ogr), reprojection
// against an independent UTM (GeographicLib), broken input, holes and multi-polygons, and
// geodesic densification.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <glm/geometric.hpp>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/TransverseMercator.hpp>

#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "test_paths.hpp"
#include "vector_files.hpp"

namespace {

using gis::geo::Feature;
using gis::geo::GeometryKind;
using gis::geo::SceneFrame;
using gis::geo::VectorLayer;
using gis::geo::VectorReadOptions;

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";
const std::string kData = std::string(STENCIL_GIS_TEST_DATA_DIR) + "/";

/// A file in this program's output folder (made if missing: a fresh build has none).
std::string outputFile(const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}
const std::string kDem = kSamples + "olinda_dem_utm25s.tif";
const std::string kTracts = kSamples + "olinda1.shp";
const std::string kBoundaries = kSamples + "olinda_tract_boundaries.geojson";
/// The sample's lines as first shipped: 8 more that are two copies of one point (ids 1413–1420).
const std::string kMessyBoundaries = kData + "olinda_streets_with_point_lines.geojson";

constexpr double kInf = std::numeric_limits<double>::infinity();

SceneFrame olindaFrame() {
  gis::Result<gis::geo::RasterInfo> info = gis::geo::inspectRaster(kDem);
  EXPECT_TRUE(info.ok());
  gis::Result<SceneFrame> frame = SceneFrame::forRaster(*info);
  EXPECT_TRUE(frame.ok());
  return *frame;
}

/// Options that read the vertices exactly as stored (no geodesic densification).
VectorReadOptions undensified() {
  VectorReadOptions o;
  o.maxGeodesicSegmentMetres = kInf;
  o.geodesicToleranceMetres = kInf;
  return o;
}

std::size_t ringCount(const VectorLayer& layer) {
  std::size_t n = 0;
  for (const Feature& f : layer.features)
    for (const gis::geo::Polygon& p : f.polygons) n += 1 + p.holes.size();
  return n;
}

/// Calls fn(a, b) for every edge: ring edges including the closing one, line segments.
template <typename Fn>
void forEachEdge(const VectorLayer& layer, Fn fn) {
  auto ring = [&fn](const gis::geo::Ring& r) {
    for (std::size_t i = 0; i < r.size(); ++i) fn(r[i], r[(i + 1) % r.size()]);
  };
  for (const Feature& f : layer.features) {
    for (const gis::geo::Polygon& p : f.polygons) {
      ring(p.outer);
      for (const gis::geo::Ring& h : p.holes) ring(h);
    }
    for (const gis::geo::LineString& l : f.lines)
      for (std::size_t i = 0; i + 1 < l.size(); ++i) fn(l[i], l[i + 1]);
  }
}

std::vector<std::string> errorFeatures(const gis::Diagnostics& d) {
  std::vector<std::string> out;
  for (const gis::Diagnostic& x : d.items())
    if (x.severity == gis::Severity::Error) out.push_back(x.feature);
  return out;
}

// ---- Olinda census tracts (shapefile, geographic GRS80) --------------------------------------

TEST(VectorOlinda, TractPolygonsCountsAndAttributes) {
  const SceneFrame frame = olindaFrame();
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(kTracts, frame, undensified());
  ASSERT_TRUE(layer.ok());
  EXPECT_TRUE(layer.diagnostics.empty()) << layer.diagnostics.items().front().toString();
  EXPECT_EQ(layer->name, "olinda1");
  EXPECT_EQ(layer->path, kTracts);
  EXPECT_EQ(layer->kind, GeometryKind::Polygon);
  EXPECT_NE(layer->sourceCrsWkt.find("GRS80"), std::string::npos);
  ASSERT_EQ(layer->features.size(), 470u);  // PROVENANCE.md, ogrinfo: Feature Count: 470

  // PROVENANCE.md says 12,705 vertices, which counts every ring's closing duplicate. ogr2ogr to
  // WKT shows 470 single-ring polygons (no holes, no multi-parts), every ring closed, no other
  // repeated vertex; the reader drops the closing point, so 12,705 − 470 = 12,235 remain.
  EXPECT_EQ(ringCount(*layer), 470u);
  EXPECT_EQ(layer->vertexCount(), 12705u - 470u);

  std::size_t withName = 0;
  std::size_t nullName = 0;
  std::set<std::string> names;
  for (const Feature& f : layer->features) {
    ASSERT_EQ(f.polygons.size(), 1u);
    EXPECT_TRUE(f.lines.empty());
    const auto it = f.attributes.find("NM_BAIR");
    ASSERT_NE(it, f.attributes.end());
    if (const auto* s = std::get_if<std::string>(&it->second)) {
      ++withName;
      names.insert(*s);
    } else {
      EXPECT_TRUE(std::holds_alternative<std::monostate>(it->second));
      ++nullName;
    }
    EXPECT_TRUE(std::holds_alternative<std::int64_t>(f.attributes.at("V014")));  // Integer64
    EXPECT_TRUE(std::holds_alternative<double>(f.attributes.at("ID")));          // Real
    EXPECT_TRUE(std::holds_alternative<std::string>(f.attributes.at("TIPO")));   // String
  }
  // ogrinfo -sql "... WHERE NM_BAIR IS NULL": 12 features; 31 distinct names otherwise.
  EXPECT_EQ(nullName, 12u);
  EXPECT_EQ(withName, 458u);
  EXPECT_EQ(names.size(), 31u);
  EXPECT_TRUE(names.count("Ouro Preto"));
  // Feature 0 as ogrinfo -fid 0 prints it.
  const Feature& f0 = layer->features.front();
  EXPECT_EQ(f0.fid, 0);
  EXPECT_EQ(std::get<std::string>(f0.attributes.at("NM_BAIR")), "Ouro Preto");
  EXPECT_EQ(std::get<std::int64_t>(f0.attributes.at("V014")), 1119);
  EXPECT_EQ(std::get<double>(f0.attributes.at("ID")), 28801.0);
  EXPECT_EQ(std::get<std::string>(f0.attributes.at("CD_GEOCODI")), "260960005000001");
  EXPECT_EQ(f0.polygons[0].outer.size(), 26u);  // 27 points in the WKT, last = first
}

TEST(VectorOlinda, TractVerticesAreInTheDemExtentAndMatchIndependentUtm) {
  const SceneFrame frame = olindaFrame();
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(kTracts, frame, undensified());
  ASSERT_TRUE(layer.ok());

  // The DEM covers ±4,995 m around the frame origin; the tracts lie within it ± 2 km.
  constexpr double kHalfExtent = 4994.67 + 2000.0;
  forEachEdge(*layer, [&](const glm::dvec2& a, const glm::dvec2&) {
    ASSERT_LT(std::abs(a.x), kHalfExtent);
    ASSERT_LT(std::abs(a.y), kHalfExtent);
  });

  // Independent projection: GeographicLib's transverse Mercator with the parameters of UTM
  // zone 25 S on GRS80 (the shapefile's and the DEM's ellipsoid, no datum shift between the
  // two "unknown" GRS80 datums). PROJ and GeographicLib agree far below 1 mm here.
  constexpr double kTolMetres = 1e-3;
  const GeographicLib::TransverseMercator tm(6378137.0, 1.0 / 298.257222101, 0.9996);
  GDALAllRegister();
  GDALDatasetUniquePtr ds(GDALDataset::Open(kTracts.c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(ds);
  OGRLayer* src = ds->GetLayer(0);
  std::size_t compared = 0;
  for (const Feature& f : layer->features) {
    OGRFeatureUniquePtr sf(src->GetFeature(f.fid));
    ASSERT_TRUE(sf);
    const OGRLinearRing* ring = sf->GetGeometryRef()->toPolygon()->getExteriorRing();
    ASSERT_EQ(static_cast<std::size_t>(ring->getNumPoints()), f.polygons[0].outer.size() + 1);
    for (std::size_t i = 0; i < f.polygons[0].outer.size(); ++i) {
      double x = 0.0;
      double y = 0.0;
      tm.Forward(-33.0, ring->getY(static_cast<int>(i)), ring->getX(static_cast<int>(i)), x, y);
      const glm::dvec2 expected(x + 500000.0, y + 10000000.0);
      const glm::dvec2 got = f.polygons[0].outer[i] + glm::dvec2(frame.origin());
      ASSERT_LT(glm::length(got - expected), kTolMetres) << "feature " << f.fid << " vertex " << i;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 12235u);
}

TEST(VectorOlinda, DefaultOptionsAddNoPointsToShortEdgesAndASpacingCanBeAsked) {
  const SceneFrame frame = olindaFrame();
  // By tolerance (1 mm): the tracts' edges (at most a few hundred metres) bow by micrometres in
  // the frame and gain no point.
  gis::Result<VectorLayer> byDefault = gis::geo::readVectorLayer(kTracts, frame);
  ASSERT_TRUE(byDefault.ok());
  EXPECT_EQ(byDefault->features.size(), 470u);
  EXPECT_EQ(byDefault->vertexCount(), 12235u);
  // By length, when asked: pieces ≤ 100 m on the ellipsoid; in the frame that is ≤ 100 m × the
  // UTM scale factor here (k ≈ 1.00014 at 210 km from the central meridian): 100.05 m stated.
  VectorReadOptions every100m;
  every100m.maxGeodesicSegmentMetres = 100.0;
  gis::Result<VectorLayer> dense = gis::geo::readVectorLayer(kTracts, frame, every100m);
  ASSERT_TRUE(dense.ok());
  EXPECT_GT(dense->vertexCount(), 12235u);  // some tract edges are longer than 100 m
  double longest = 0.0;
  forEachEdge(*dense,
              [&](const glm::dvec2& a, const glm::dvec2& b) { longest = std::max(longest, glm::length(b - a)); });
  EXPECT_LE(longest, 100.05);
  EXPECT_GT(longest, 50.0);  // and not absurdly dense
}

// ---- Olinda tract boundaries (GeoJSON, CRS84 lines) ------------------------------------------

TEST(VectorOlinda, BoundaryLines) {
  const SceneFrame frame = olindaFrame();
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(kBoundaries, frame, undensified());
  ASSERT_TRUE(layer.ok());
  EXPECT_EQ(layer->name, "olinda_tract_boundaries");
  EXPECT_EQ(layer->kind, GeometryKind::Line);
  // The file has 1,413 line strings with 7,970 vertices (PROVENANCE.md; ogr2ogr to WKT agrees);
  // nine lines repeat a vertex once, and the reader keeps one copy. The shipped sample loads
  // clean: no message at all.
  EXPECT_EQ(layer->features.size(), 1413u);
  EXPECT_EQ(layer->vertexCount(), 7970u - 9u);
  EXPECT_TRUE(layer.diagnostics.items().empty());

  // As first shipped, the file also had eight lines (ids 1413..1420) that are two copies of one
  // point: lines with fewer than 2 distinct points are rejected, one error each, naming it.
  gis::Result<VectorLayer> messy = gis::geo::readVectorLayer(kMessyBoundaries, frame, undensified());
  ASSERT_TRUE(messy.ok());
  EXPECT_EQ(messy->features.size(), 1413u);
  EXPECT_EQ(messy->vertexCount(), 7986u - 16u - 9u);
  const std::vector<std::string> bad = errorFeatures(messy.diagnostics);
  EXPECT_EQ(bad, (std::vector<std::string>{"1413", "1414", "1415", "1416", "1417", "1418", "1419", "1420"}));
  for (const gis::Diagnostic& d : messy.diagnostics.items()) {
    EXPECT_EQ(d.file, kMessyBoundaries);
    EXPECT_EQ(d.layer, "olinda_tract_boundaries");
    EXPECT_NE(d.message.find("distinct"), std::string::npos) << d.message;
  }

  std::map<double, int> widths;
  for (const Feature& f : layer->features) {
    EXPECT_TRUE(f.polygons.empty());
    ASSERT_EQ(f.lines.size(), 1u);
    EXPECT_GE(f.lines[0].size(), 2u);
    ++widths[std::get<double>(f.attributes.at("width_m"))];
  }
  // PROVENANCE.md: width_m is 12 for the 5 longest lines, else 7.
  EXPECT_EQ(widths, (std::map<double, int>{{7.0, 1408}, {12.0, 5}}));
}

// ---- broken and odd input --------------------------------------------------------------------

TEST(VectorBroken, GoodFeaturesLoadAndEachBadOneIsNamed) {
  const SceneFrame frame = olindaFrame();
  const std::string path = kData + "broken_features.geojson";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(layer.ok());
  EXPECT_EQ(layer->name, "broken_features");
  EXPECT_EQ(layer->kind, GeometryKind::Mixed);
  std::vector<std::int64_t> good;
  for (const Feature& f : layer->features) good.push_back(f.fid);
  EXPECT_EQ(good, (std::vector<std::int64_t>{1, 6, 9}));
  EXPECT_EQ(layer->features[2].polygons.size(), 2u);  // the good multipolygon

  // What each bad feature must say (a part of the message).
  const std::map<std::string, std::string> expected = {
      {"2", "non-finite"},                       // NaN vertex
      {"3", "distinct"},                         // ring with 2 distinct points
      {"4", "unsupported geometry type Point"},  // a point
      {"5", "no geometry"},                      // null geometry
      {"7", "outside the range"},                // 1e300 as lon/lat
      {"8", "non-finite"},                       // 1e999 parses as infinity
      {"10", "distinct"},                        // line with 1 distinct point
      {"11", "unsupported geometry type"},       // geometry collection
      {"12", "hole 1"},                          // good outer ring, 2-point hole
  };
  std::map<std::string, std::string> got;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    EXPECT_EQ(d.severity, gis::Severity::Error);
    EXPECT_EQ(d.file, path);
    EXPECT_EQ(d.layer, "broken_features");
    got[d.feature] = d.message;
    const std::string s = d.toString();
    EXPECT_NE(s.find(path), std::string::npos);
    EXPECT_NE(s.find("broken_features'"), std::string::npos);
    EXPECT_NE(s.find("feature " + d.feature), std::string::npos);
  }
  EXPECT_EQ(got.size(), expected.size());
  for (const auto& [fid, part] : expected) {
    ASSERT_TRUE(got.count(fid)) << "no diagnostic for feature " << fid;
    EXPECT_NE(got[fid].find(part), std::string::npos) << "feature " << fid << ": " << got[fid];
  }
}

TEST(VectorEncoding, Latin1AttributesWithoutADeclaredEncodingArriveAsUtf8WithAWarning) {
  // A Shapefile without .cpg whose text is Latin-1 ("São Paulo" with 0xE3): the attribute reaches
  // us readable, in UTF-8, and the reader says what it assumed, naming file and layer.
  const SceneFrame frame = olindaFrame();
  const std::filesystem::path dir = std::filesystem::path(STENCIL_GIS_TEST_OUTPUT_DIR) / "latin1";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "bairros.shp").string();
  gis::test::writeUndeclaredEncodingShapefile(path, 32725, {{{292000, 9114000}, {295500, 9114000}, {295500, 9117500}}},
                                              "S\xe3o Paulo");
  ASSERT_FALSE(std::filesystem::exists(dir / "bairros.cpg"));
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->features.size(), 1u);
  EXPECT_EQ(std::get<std::string>(layer->features[0].attributes.at("nome")), "S\xc3\xa3o Paulo");
  bool warned = false;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    warned = warned || (d.severity == gis::Severity::Warning && d.file == path && d.layer == "bairros" &&
                        d.message.find("read as Latin-1") != std::string::npos);
  }
  EXPECT_TRUE(warned);
  // UTF-8 text is left alone and says nothing.
  gis::test::writeUndeclaredEncodingShapefile(path, 32725, {{{292000, 9114000}, {295500, 9114000}, {295500, 9117500}}},
                                              "S\xc3\xa3o Paulo");
  gis::Result<VectorLayer> utf8 = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(utf8.ok());
  EXPECT_EQ(std::get<std::string>(utf8->features[0].attributes.at("nome")), "S\xc3\xa3o Paulo");
  EXPECT_EQ(utf8.diagnostics.count(gis::Severity::Warning), 0u);
}

TEST(VectorSources, SeveralLayersAndNoneNamedIsAnErrorListingThem) {
  // A GeoPackage of two layers: taking the first would drop the second without a word.
  const SceneFrame frame = olindaFrame();
  const std::string path = outputFile("two_layers.gpkg");
  std::filesystem::remove(path);
  GDALAllRegister();
  GDALDataset* ds =
      GetGDALDriverManager()->GetDriverByName("GPKG")->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
  ASSERT_NE(ds, nullptr);
  OGRSpatialReference srs;
  srs.importFromEPSG(32725);
  for (const char* name : {"bairros", "lotes"}) {
    OGRLayer* layer = ds->CreateLayer(name, &srs, wkbPolygon, nullptr);
    ASSERT_NE(layer, nullptr);
    OGRFeature* f = OGRFeature::CreateFeature(layer->GetLayerDefn());
    OGRGeometry* g = nullptr;
    OGRGeometryFactory::createFromWkt("POLYGON ((292000 9114000, 295000 9114000, 295000 9117000, 292000 9114000))",
                                      nullptr, &g);
    f->SetGeometryDirectly(g);
    EXPECT_EQ(layer->CreateFeature(f), OGRERR_NONE);
    OGRFeature::DestroyFeature(f);
  }
  GDALClose(GDALDataset::ToHandle(ds));
  gis::Result<VectorLayer> unnamed = gis::geo::readVectorLayer(path, frame);
  ASSERT_FALSE(unnamed.ok());
  const gis::Diagnostic& e = unnamed.diagnostics.items().front();
  EXPECT_EQ(e.file, path);
  EXPECT_NE(e.message.find("2 layers (bairros, lotes)"), std::string::npos) << e.message;
  gis::geo::VectorReadOptions second;
  second.layer = "lotes";
  gis::Result<VectorLayer> named = gis::geo::readVectorLayer(path, frame, second);
  ASSERT_TRUE(named.ok());
  EXPECT_EQ(named->name, "lotes");
  EXPECT_EQ(named->features.size(), 1u);
}

TEST(VectorSources, ACrsThatCannotBeReadIsAnErrorNotWgs84) {
  // A GeoJSON whose crs member names EPSG:999999: GDAL says "crs not found" and reads WGS 84.
  const SceneFrame frame = olindaFrame();
  const std::string path = outputFile("unknown_crs.geojson");
  std::ofstream(path) << R"({"type": "FeatureCollection",
    "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::999999"}},
    "features": [{"type": "Feature", "properties": {},
                  "geometry": {"type": "Polygon", "coordinates": [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0],
                                                                   [-34.86, -8.01]]]}}]})";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_FALSE(layer.ok());
  const gis::Diagnostic& e = layer.diagnostics.items().front();
  EXPECT_EQ(e.severity, gis::Severity::Error);
  EXPECT_EQ(e.file, path);
  EXPECT_NE(e.message.find("crs not found"), std::string::npos) << e.message;
}

TEST(VectorSources, GdalsOwnWordsReachTheDiagnosticsAndBigGeoJsonOpens) {
  const SceneFrame frame = olindaFrame();
  // The reader lifts GDAL's GeoJSON object limit unless the user set one.
  const char* limit = CPLGetConfigOption("OGR_GEOJSON_MAX_OBJ_SIZE", nullptr);
  ASSERT_NE(limit, nullptr);
  if (std::getenv("OGR_GEOJSON_MAX_OBJ_SIZE") == nullptr) {
    EXPECT_STREQ(limit, "0");
  }
  // One feature of 2 MB (a line of 80,000 points) over a 1 MB limit: the error carries GDAL's
  // explanation and its remedy (GDAL streams a collection, the limit is per object).
  const std::string path = outputFile("big.geojson");
  {
    std::ofstream out(path);
    out.precision(10);
    out << R"({"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, )"
        << R"("geometry": {"type": "LineString", "coordinates": [)";
    for (int i = 0; i < 80000; ++i) out << (i > 0 ? "," : "") << "[" << -34.86 + 1e-7 * i << ", -8.005]";
    out << "]}}]}";
  }
  const std::string saved = limit;
  CPLSetConfigOption("OGR_GEOJSON_MAX_OBJ_SIZE", "1");
  gis::Result<VectorLayer> refused = gis::geo::readVectorLayer(path, frame);
  CPLSetConfigOption("OGR_GEOJSON_MAX_OBJ_SIZE", saved.c_str());
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.diagnostics.items().front().message.find("OGR_GEOJSON_MAX_OBJ_SIZE"), std::string::npos)
      << refused.diagnostics.items().front().message;
  gis::Result<VectorLayer> opened = gis::geo::readVectorLayer(path, frame);
  EXPECT_TRUE(opened.ok());
}

TEST(VectorBroken, ABadPartIsLeftOutAndTheOtherPartsDraw) {
  // A multi-polygon and a multi-line with one part beyond the range of latitude each, and one of
  // nothing but bad parts: the good parts load, each bad part is named in a Warning; only the
  // feature with no good part is left out (an Error).
  const SceneFrame frame = olindaFrame();
  const std::string path = outputFile("bad_parts.geojson");
  std::ofstream(path) << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "id": 1, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0], [-34.86, -8.01]]],
      [[[-34.86, 95.0], [-34.85, 95.0], [-34.85, 96.0], [-34.86, 95.0]]]]}},
    {"type": "Feature", "id": 2, "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": [
      [[-34.86, 99.0], [-34.85, 99.0]], [[-34.86, -8.01], [-34.85, -8.0]], [[-34.86, -8.02], [-34.85, -8.02]]]}},
    {"type": "Feature", "id": 3, "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": [
      [[-34.86, 99.0], [-34.85, 99.0]], [[-34.86, 98.0], [-34.85, 98.0]]]}}]})";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->features.size(), 2u);
  EXPECT_EQ(layer->features[0].fid, 1);
  EXPECT_EQ(layer->features[0].polygons.size(), 1u);
  EXPECT_EQ(layer->features[1].fid, 2);
  EXPECT_EQ(layer->features[1].lines.size(), 2u);
  std::map<std::string, std::string> warnings, errors;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    (d.severity == gis::Severity::Warning ? warnings : errors)[d.feature] = d.message;
  }
  EXPECT_NE(warnings["1"].find("part 2 of 2"), std::string::npos) << warnings["1"];
  EXPECT_NE(warnings["1"].find("left out"), std::string::npos);
  EXPECT_NE(warnings["2"].find("part 1 of 3"), std::string::npos) << warnings["2"];
  EXPECT_NE(errors["3"].find("part 2 of 2"), std::string::npos) << errors["3"];
  EXPECT_EQ(layer.diagnostics.count(gis::Severity::Error), 1u);
}

TEST(VectorBroken, NonObjectEntriesOfAGeoJsonAreNamed) {
  // GDAL skips them without a word; each is named with its place in the "features" array.
  const SceneFrame frame = olindaFrame();
  const std::string path = outputFile("non_objects.geojson");
  const std::string feature =
      R"({"type": "Feature", "properties": {"note": [1, {"a": 2}]}, "geometry": {"type": "LineString",
          "coordinates": [[-34.86, -8.01], [-34.85, -8.0]]}})";
  std::ofstream(path) << R"({"type": "FeatureCollection", "name": "x", "features": [)" << feature
                      << R"(, 5, "text", null, [1, 2], )" << feature << "]}";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(layer.ok());
  EXPECT_EQ(layer->features.size(), 2u);
  std::vector<std::string> named;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    if (d.severity == gis::Severity::Error) named.push_back(d.feature + " " + d.message);
  }
  EXPECT_EQ(named, (std::vector<std::string>{"features[1] a number, not a feature object: left out",
                                             "features[2] a string, not a feature object: left out",
                                             "features[3] null, not a feature object: left out",
                                             "features[4] an array, not a feature object: left out"}));
}

TEST(VectorValidity, InvalidPolygonsAreRepairedWhereTheIntentIsClearAndSaidOrRefused) {
  const SceneFrame frame = olindaFrame();
  const std::string path = outputFile("invalid_polygons.geojson");
  // 1: a bow-tie; 2: a hole wholly outside its shell; 3: a ring collinear in lon/lat; 4: two
  // overlapping squares; 5: a good square and a collinear part; 6: valid.
  std::ofstream(path) << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "id": 1, "properties": {}, "geometry": {"type": "Polygon", "coordinates":
      [[[-34.86, -8.01], [-34.85, -8.0], [-34.85, -8.01], [-34.86, -8.0], [-34.86, -8.01]]]}},
    {"type": "Feature", "id": 2, "properties": {}, "geometry": {"type": "Polygon", "coordinates":
      [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0], [-34.86, -8.0], [-34.86, -8.01]],
       [[-34.84, -8.01], [-34.83, -8.01], [-34.83, -8.0], [-34.84, -8.01]]]}},
    {"type": "Feature", "id": 3, "properties": {}, "geometry": {"type": "Polygon", "coordinates":
      [[[-34.86, -8.01], [-34.85, -8.0], [-34.84, -7.99], [-34.86, -8.01]]]}},
    {"type": "Feature", "id": 4, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0], [-34.86, -8.0], [-34.86, -8.01]]],
      [[[-34.855, -8.005], [-34.845, -8.005], [-34.845, -7.995], [-34.855, -7.995], [-34.855, -8.005]]]]}},
    {"type": "Feature", "id": 5, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0], [-34.86, -8.0], [-34.86, -8.01]]],
      [[[-34.84, -8.01], [-34.83, -8.0], [-34.82, -7.99], [-34.84, -8.01]]]]}},
    {"type": "Feature", "id": 6, "properties": {}, "geometry": {"type": "Polygon", "coordinates":
      [[[-34.86, -8.01], [-34.85, -8.01], [-34.85, -8.0], [-34.86, -8.01]]]}}]})";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  ASSERT_TRUE(layer.ok());
  std::map<std::int64_t, const Feature*> byFid;
  for (const Feature& f : layer->features) byFid[f.fid] = &f;
  std::map<std::string, std::vector<std::string>> warnings, errors;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    (d.severity == gis::Severity::Warning ? warnings : errors)[d.feature].push_back(d.message);
  }
  auto said = [](const std::vector<std::string>& messages, const std::string& text) {
    return std::any_of(messages.begin(), messages.end(),
                       [&](const std::string& m) { return m.find(text) != std::string::npos; });
  };
  // The bow-tie draws by the even-odd rule, and says so with GEOS's reason.
  ASSERT_TRUE(byFid.count(1));
  EXPECT_TRUE(said(warnings["1"], "not valid by OGC rules (GEOS: Self-intersection")) << warnings["1"].size();
  EXPECT_TRUE(said(warnings["1"], "even-odd"));
  // The hole outside its shell is left out: one polygon, no holes.
  ASSERT_TRUE(byFid.count(2));
  EXPECT_TRUE(byFid[2]->polygons[0].holes.empty());
  EXPECT_TRUE(said(warnings["2"], "hole 1 lies wholly outside its shell"));
  // The collinear ring is refused: an Error, no feature.
  EXPECT_FALSE(byFid.count(3));
  EXPECT_TRUE(said(errors["3"], "has no area"));
  // Overlapping parts: drawn as their union, said.
  ASSERT_TRUE(byFid.count(4));
  EXPECT_EQ(byFid[4]->polygons.size(), 2u);
  EXPECT_TRUE(said(warnings["4"], "drawn as their union"));
  // The good square of 5 stays; its collinear part is named and left out.
  ASSERT_TRUE(byFid.count(5));
  EXPECT_EQ(byFid[5]->polygons.size(), 1u);
  EXPECT_TRUE(said(warnings["5"], "polygon 2 of 2: its exterior ring has no area"));
  // The valid triangle says nothing.
  ASSERT_TRUE(byFid.count(6));
  EXPECT_TRUE(warnings["6"].empty());
  EXPECT_EQ(layer.diagnostics.count(gis::Severity::Error), 1u);
}

TEST(VectorBroken, UnreadableSourcesFailWithAMessage) {
  const SceneFrame frame = olindaFrame();
  for (const std::string& path : {kData + "does_not_exist.geojson", kDem, kData + "garbage.geojson", std::string(""),
                                  kSamples + "PROVENANCE.md"}) {
    SCOPED_TRACE(path);
    gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
    EXPECT_FALSE(layer.ok());
    ASSERT_TRUE(layer.diagnostics.hasErrors());
    EXPECT_EQ(layer.diagnostics.items().front().file, path);
    EXPECT_FALSE(layer.diagnostics.items().front().message.empty());
    EXPECT_FALSE(gis::geo::listVectorLayers(path).ok());
  }
}

TEST(VectorSources, ASinkTakesTheFeaturesAsReadAndTheLayerSaysTheSame) {
  // Broken features (said, left out) beside good ones: streamed to a sink, the same features in
  // the same order, the same messages and kind, and none kept in the layer.
  const SceneFrame frame = olindaFrame();
  const std::string path = kData + "broken_features.geojson";
  const gis::Result<VectorLayer> kept = gis::geo::readVectorLayer(path, frame);
  std::vector<Feature> streamed;
  gis::geo::VectorReadOptions options;
  options.sink = [&](Feature&& f) { streamed.push_back(std::move(f)); };
  std::vector<double> fractions;  // the progress of the read
  options.progress = [&](double f) { fractions.push_back(f); };
  const gis::Result<VectorLayer> sunk = gis::geo::readVectorLayer(path, frame, options);
  ASSERT_TRUE(kept.ok() && sunk.ok());
  ASSERT_GE(fractions.size(), 2u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.front(), 0.0);
  EXPECT_EQ(fractions.back(), 1.0);
  EXPECT_TRUE(sunk->features.empty());
  EXPECT_EQ(sunk->kind, kept->kind);
  ASSERT_EQ(streamed.size(), kept->features.size());
  for (std::size_t i = 0; i < streamed.size(); ++i) {
    EXPECT_EQ(streamed[i].fid, kept->features[i].fid);
    EXPECT_EQ(streamed[i].lines, kept->features[i].lines);
    EXPECT_EQ(streamed[i].attributes, kept->features[i].attributes);
    ASSERT_EQ(streamed[i].polygons.size(), kept->features[i].polygons.size());
    for (std::size_t k = 0; k < streamed[i].polygons.size(); ++k)
      EXPECT_EQ(streamed[i].polygons[k].outer, kept->features[i].polygons[k].outer);
  }
  ASSERT_EQ(sunk.diagnostics.items().size(), kept.diagnostics.items().size());
  for (std::size_t i = 0; i < kept.diagnostics.items().size(); ++i)
    EXPECT_EQ(sunk.diagnostics.items()[i].toString(), kept.diagnostics.items()[i].toString());
  // A layer with nothing good says so through a sink too.
  std::size_t none = 0;
  gis::geo::VectorReadOptions counting;
  counting.sink = [&](Feature&&) { ++none; };
  const gis::Result<VectorLayer> empty = gis::geo::readVectorLayer(kData + "empty_layer.geojson", frame, counting);
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(none, 0u);
  EXPECT_EQ(empty->kind, GeometryKind::Empty);
  ASSERT_EQ(empty.diagnostics.items().size(), 1u);
  EXPECT_NE(empty.diagnostics.items()[0].message.find("no features"), std::string::npos);
}

TEST(VectorBroken, AnEmptyLayerLoadsWithAWarning) {
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(kData + "empty_layer.geojson", olindaFrame());
  ASSERT_TRUE(layer.ok());
  EXPECT_TRUE(layer->features.empty());
  EXPECT_EQ(layer->kind, gis::geo::GeometryKind::Empty);
  ASSERT_EQ(layer.diagnostics.items().size(), 1u);
  EXPECT_EQ(layer.diagnostics.items()[0].severity, gis::Severity::Warning);
  EXPECT_EQ(layer.diagnostics.items()[0].layer, "empty_layer");
  EXPECT_NE(layer.diagnostics.items()[0].message.find("no features"), std::string::npos);
}

TEST(VectorBroken, MissingLayerAndBadOptions) {
  const SceneFrame frame = olindaFrame();
  gis::Result<std::vector<std::string>> layers = gis::geo::listVectorLayers(kTracts);
  ASSERT_TRUE(layers.ok());
  EXPECT_EQ(*layers, std::vector<std::string>{"olinda1"});

  VectorReadOptions o;
  o.layer = "olinda1";
  EXPECT_TRUE(gis::geo::readVectorLayer(kTracts, frame, o).ok());
  o.layer = "no_such_layer";
  gis::Result<VectorLayer> missing = gis::geo::readVectorLayer(kTracts, frame, o);
  EXPECT_FALSE(missing.ok());
  ASSERT_TRUE(missing.diagnostics.hasErrors());
  EXPECT_EQ(missing.diagnostics.items().front().layer, "no_such_layer");
  EXPECT_NE(missing.diagnostics.items().front().message.find("olinda1"), std::string::npos);

  VectorReadOptions zero;
  zero.maxGeodesicSegmentMetres = 0.0;
  EXPECT_FALSE(gis::geo::readVectorLayer(kTracts, frame, zero).ok());
  VectorReadOptions noTolerance;
  noTolerance.geodesicToleranceMetres = 0.0;
  EXPECT_FALSE(gis::geo::readVectorLayer(kTracts, frame, noTolerance).ok());
}

TEST(VectorBroken, LayerWithoutCrsNeedsAnAssumedCrs) {
  const SceneFrame frame = olindaFrame();
  const std::string path = kData + "no_crs_utm25s.csv";
  gis::Result<VectorLayer> none = gis::geo::readVectorLayer(path, frame);
  EXPECT_FALSE(none.ok());
  ASSERT_TRUE(none.diagnostics.hasErrors());
  EXPECT_EQ(none.diagnostics.items().front().layer, "no_crs_utm25s");
  EXPECT_NE(none.diagnostics.items().front().message.find("no CRS"), std::string::npos);

  VectorReadOptions o;
  o.assumedCrs = "not a CRS";
  EXPECT_FALSE(gis::geo::readVectorLayer(path, frame, o).ok());

  o.assumedCrs = "EPSG:31985";  // SIRGAS 2000 / UTM 25 S: same projection, GRS80
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame, o);
  ASSERT_TRUE(layer.ok());
  EXPECT_FALSE(layer.diagnostics.hasErrors());
  EXPECT_EQ(layer->kind, GeometryKind::Mixed);
  ASSERT_EQ(layer->features.size(), 3u);
  // The plain square: projected source, no densification, the same numbers minus the origin
  // (SIRGAS 2000 and the DEM's GRS80 datum are both WGS 84 to within the transform's
  // "ballpark": 1 mm stated).
  const gis::geo::Ring& square = layer->features[0].polygons.at(0).outer;
  ASSERT_EQ(square.size(), 4u);
  const glm::dvec2 origin(frame.origin());
  EXPECT_LT(glm::length(square[0] + origin - glm::dvec2(293000.0, 9115000.0)), 1e-3);
  EXPECT_LT(glm::length(square[2] + origin - glm::dvec2(293500.0, 9115500.0)), 1e-3);
  // The circle (CURVEPOLYGON) becomes a polygon of many vertices, all 200 m from its centre.
  const gis::geo::Ring& circle = layer->features[1].polygons.at(0).outer;
  EXPECT_GT(circle.size(), 16u);
  for (const glm::dvec2& p : circle)
    EXPECT_NEAR(glm::length(p + origin - glm::dvec2(294000.0, 9116200.0)), 200.0, 1e-3);
  // The 3D line is flattened to 2D.
  ASSERT_EQ(layer->features[2].lines.size(), 1u);
  EXPECT_EQ(layer->features[2].lines[0].size(), 3u);
  EXPECT_EQ(std::get<std::string>(layer->features[2].attributes.at("name")), "3D line");
}

// ---- holes and multi-polygons ----------------------------------------------------------------

/// Even-odd point-in-ring test.
bool inside(const gis::geo::Ring& ring, const glm::dvec2& p) {
  bool in = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const glm::dvec2& a = ring[i];
    const glm::dvec2& b = ring[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
  }
  return in;
}

TEST(VectorHoles, PolygonsAndHolesAreCountedPerFeature) {
  const SceneFrame frame = olindaFrame();
  const std::string path = kData + "holes_and_multipolygons.geojson";
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame, undensified());
  ASSERT_TRUE(layer.ok());
  EXPECT_TRUE(layer->features.size() == 4 && layer.diagnostics.empty());
  EXPECT_EQ(layer->kind, GeometryKind::Polygon);

  struct Expect {
    std::size_t polygons;
    std::vector<std::size_t> holesPerPolygon;
    std::vector<std::size_t> outerSizes;  // vertices without the closing one
  };
  // As written in the file (see its "what" attributes).
  const std::vector<Expect> expected = {
      {1, {1}, {4}},
      {1, {2}, {4}},
      {3, {0, 1, 0}, {3, 4, 5}},
      {2, {0, 0}, {4, 4}},
  };
  std::size_t polygons = 0;
  std::size_t holes = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE("feature " + std::to_string(layer->features[i].fid));
    const Feature& f = layer->features[i];
    ASSERT_EQ(f.polygons.size(), expected[i].polygons);
    for (std::size_t k = 0; k < f.polygons.size(); ++k) {
      EXPECT_EQ(f.polygons[k].holes.size(), expected[i].holesPerPolygon[k]);
      EXPECT_EQ(f.polygons[k].outer.size(), expected[i].outerSizes[k]);
      EXPECT_NE(f.polygons[k].outer.front(), f.polygons[k].outer.back());  // not closed
      for (const gis::geo::Ring& h : f.polygons[k].holes) {
        EXPECT_NE(h.front(), h.back());
        for (const glm::dvec2& p : h) EXPECT_TRUE(inside(f.polygons[k].outer, p));  // hole in its outer ring
      }
      ++polygons;
      holes += f.polygons[k].holes.size();
    }
  }
  EXPECT_EQ(polygons, 7u);
  EXPECT_EQ(holes, 4u);
  // Feature 2's triangle hole: 3 vertices.
  EXPECT_EQ(layer->features[1].polygons[0].holes[1].size(), 3u);
}

// ---- geodesic densification ------------------------------------------------------------------

TEST(Densify, ThousandKilometreEdgeIn50kmPiecesOnTheGeodesic) {
  const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
  const glm::dvec2 a(-34.9, -8.0);  // lon, lat
  double latB = 0.0;
  double lonB = 0.0;
  wgs.Direct(a.y, a.x, 57.0, 1.0e6, latB, lonB);  // 1000 km north-east
  const glm::dvec2 b(lonB, latB);
  const std::vector<glm::dvec2> pts =
      gis::geo::densifyGeodesic(a, b, 50000.0, wgs.EquatorialRadius(), wgs.Flattening());
  ASSERT_GE(pts.size(), 20u);  // at least ceil(1000/50) pieces, a included, b excluded
  EXPECT_LE(pts.size(), 21u);
  EXPECT_EQ(pts.front(), a);
  EXPECT_NE(pts.back(), b);

  // Pieces ≤ 50 km (+1 mm for rounding), and the sum of the pieces equals the geodesic
  // distance within 1 mm: points off the geodesic would make the path longer.
  constexpr double kTolMetres = 1e-3;
  double total = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const glm::dvec2& p = pts[i];
    const glm::dvec2& q = i + 1 < pts.size() ? pts[i + 1] : b;
    double s = 0.0;
    wgs.Inverse(p.y, p.x, q.y, q.x, s);
    EXPECT_LE(s, 50000.0 + kTolMetres);
    total += s;
    // Each point splits the geodesic a→b exactly.
    double sa = 0.0;
    double sb = 0.0;
    wgs.Inverse(a.y, a.x, p.y, p.x, sa);
    wgs.Inverse(p.y, p.x, b.y, b.x, sb);
    EXPECT_NEAR(sa + sb, 1.0e6, kTolMetres);
  }
  EXPECT_NEAR(total, 1.0e6, kTolMetres);

  // Short edges stay as they are; degenerate input does not crash.
  EXPECT_EQ(
      gis::geo::densifyGeodesic(a, a + glm::dvec2(1e-4, 0.0), 100.0, wgs.EquatorialRadius(), wgs.Flattening()).size(),
      1u);
  EXPECT_EQ(gis::geo::densifyGeodesic(a, a, 100.0, wgs.EquatorialRadius(), wgs.Flattening()).size(), 1u);
  EXPECT_EQ(gis::geo::densifyGeodesic(a, glm::dvec2(std::nan(""), 0.0), 100.0, wgs.EquatorialRadius(), wgs.Flattening())
                .size(),
            1u);
  EXPECT_EQ(gis::geo::densifyGeodesic(a, b, 100.0, -1.0, 0.0).size(), 1u);  // invalid ellipsoid
}

TEST(Densify, LongEdgesInCrs84AreDensifiedAlongTheGeodesic) {
  const SceneFrame frame = olindaFrame();
  const std::string path = kData + "long_edge_crs84.geojson";
  VectorReadOptions o;
  o.maxGeodesicSegmentMetres = 1000.0;
  o.geodesicToleranceMetres = kInf;  // by length alone
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame, o);
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->features.size(), 2u);
  EXPECT_FALSE(layer.diagnostics.hasErrors());

  const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
  auto pieces = [&](glm::dvec2 a, glm::dvec2 b) {
    double s = 0.0;
    wgs.Inverse(a.y, a.x, b.y, b.x, s);
    return static_cast<std::size_t>(std::ceil(s / 1000.0));
  };
  // The line: one 110 km edge → ceil(s/1 km) pieces, end point included.
  const gis::geo::LineString& line = layer->features[0].lines.at(0);
  const glm::dvec2 a(-35.4, -8.0);
  const glm::dvec2 b(-34.4, -8.0);
  EXPECT_EQ(line.size(), pieces(a, b) + 1);
  // The triangle: the three edges including the closing one.
  const glm::dvec2 t0(-35.0, -8.1);
  const glm::dvec2 t1(-34.8, -8.1);
  const glm::dvec2 t2(-34.9, -7.9);
  EXPECT_EQ(layer->features[1].polygons.at(0).outer.size(), pieces(t0, t1) + pieces(t1, t2) + pieces(t2, t0));

  // Every vertex of the line, back in lon/lat, lies on the geodesic from a to b (1 cm: the
  // frame's GRS80 and the file's WGS 84 differ by 0.1 mm in the semi-minor axis) — and the
  // geodesic along the 8° S parallel bulges towards the pole, away from the parallel itself.
  double sab = 0.0;
  wgs.Inverse(a.y, a.x, b.y, b.x, sab);
  double maxOffParallel = 0.0;
  for (const glm::dvec2& v : line) {
    const auto ll = frame.toLonLat(glm::dvec3(v, 0.0));
    ASSERT_TRUE(ll.has_value());
    double s1 = 0.0;
    double s2 = 0.0;
    wgs.Inverse(a.y, a.x, ll->y, ll->x, s1);
    wgs.Inverse(ll->y, ll->x, b.y, b.x, s2);
    EXPECT_NEAR(s1 + s2, sab, 1e-2);
    maxOffParallel = std::max(maxOffParallel, (-8.0 - ll->y) * 111000.0);
  }
  EXPECT_GT(maxOffParallel, 10.0);  // about 30 m: (d²/8R)·tan 8°
}

/// The largest distance from points sampled densely along the geodesic a→b, mapped by
/// `project`, to the mapped polyline through `pts` and b.
double departureFromGeodesic(const glm::dvec2& a, const glm::dvec2& b, const std::vector<glm::dvec2>& pts,
                             const gis::geo::GeodesicProjection& project) {
  std::vector<glm::dvec2> polyline;
  for (const glm::dvec2& p : pts) polyline.push_back(*project(p));
  polyline.push_back(*project(b));
  const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
  const GeographicLib::GeodesicLine line = wgs.InverseLine(a.y, a.x, b.y, b.x);
  constexpr int kAlong = 4000;
  double worst = 0.0;
  for (int i = 0; i <= kAlong; ++i) {
    double lat = 0.0, lon = 0.0;
    line.Position(line.Distance() * i / kAlong, lat, lon);
    const glm::dvec2 q = *project(glm::dvec2(lon, lat));
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k + 1 < polyline.size(); ++k) {
      const glm::dvec2 u = polyline[k], d = polyline[k + 1] - u;
      const double t = std::clamp(glm::dot(q - u, d) / glm::dot(d, d), 0.0, 1.0);
      nearest = std::min(nearest, glm::length(q - (u + t * d)));
    }
    worst = std::max(worst, nearest);
  }
  return worst;
}

TEST(Densify, ByToleranceTheProjectedEdgeStaysWithinItOfTheProjectedGeodesic) {
  const SceneFrame frame = olindaFrame();  // UTM 25 S
  gis::Result<gis::geo::CrsTransform> toFrame = frame.transformFrom("OGC:CRS84");
  ASSERT_TRUE(toFrame.ok());
  const gis::geo::GeodesicProjection project = [&](const glm::dvec2& p) { return toFrame->transform(p); };
  const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
  const glm::dvec2 a(-34.9, -8.0);
  constexpr double kTolerance = 1e-3;
  for (const double length : {1.0e3, 1.0e4, 1.0e5, 1.0e6}) {
    for (const double bearing : {0.0, 57.0, 90.0, 135.0, 270.0}) {
      double latB = 0.0, lonB = 0.0;
      wgs.Direct(a.y, a.x, bearing, length, latB, lonB);
      const glm::dvec2 b(lonB, latB);
      const std::vector<glm::dvec2> pts =
          gis::geo::densifyGeodesicWithin(a, b, kTolerance, wgs.EquatorialRadius(), wgs.Flattening(), project);
      ASSERT_FALSE(pts.empty());
      EXPECT_EQ(pts.front(), a);
      // Within the tolerance (plus 1 %: the check samples a quarter, half and three quarters of
      // each piece, the test 4,000 points of the edge).
      const double departure = departureFromGeodesic(a, b, pts, project);
      EXPECT_LE(departure, 1.01 * kTolerance) << length << " m at " << bearing << "°";
      // Far fewer points than every 100 m: a 1 km edge needs none, a 1,000 km one about one per
      // km (the bow grows with the square of the length).
      if (length <= 1.0e3) {
        EXPECT_EQ(pts.size(), 1u) << bearing << "°";
      }
      EXPECT_LT(static_cast<double>(pts.size()), length / 100.0 / 2.0 + 1.0) << length << " m at " << bearing << "°";
      // And the undensified chord of a long edge is far off: the points are needed.
      if (length >= 1.0e5) {
        EXPECT_GT(departureFromGeodesic(a, b, {a}, project), 10.0 * kTolerance);
      }
    }
  }
}

TEST(Densify, AnEdgeRoundMostOfTheEarthFarFromTheZoneStopsAtTheRefinementBudget) {
  // 89.9° W to 179.9° E along 8° S (the fuzzer's input): the geodesic runs far outside UTM 25 S,
  // where 1 mm is never reached. The refinement stops at 2^16 spans (it took 2^24 points, out of
  // memory under the fuzzer); the points are still in order along the geodesic.
  const SceneFrame frame = olindaFrame();
  gis::Result<gis::geo::CrsTransform> toFrame = frame.transformFrom("OGC:CRS84");
  ASSERT_TRUE(toFrame.ok());
  const gis::geo::GeodesicProjection project = [&](const glm::dvec2& p) { return toFrame->transform(p); };
  const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
  const glm::dvec2 a(-89.9, -8.0), b(179.9, -8.0);
  const std::vector<glm::dvec2> pts =
      gis::geo::densifyGeodesicWithin(a, b, 1e-3, wgs.EquatorialRadius(), wgs.Flattening(), project);
  ASSERT_FALSE(pts.empty());
  EXPECT_EQ(pts.front(), a);
  EXPECT_LE(pts.size(), std::size_t{1} << 16U);
  std::printf("a 270° edge far from the zone: %zu points\n", pts.size());
  double previous = -1.0;
  for (const glm::dvec2& p : pts) {
    double s = 0.0;
    wgs.Inverse(a.y, a.x, p.y, p.x, s);
    EXPECT_GE(s, previous) << "out of order";
    previous = s;
  }
}

TEST(Densify, ShortLonLatEdgesGainNoPointsAtTheDefaultTolerance) {
  // The Olinda tract outlines (lon/lat, edges of metres to a few hundred metres) read as they are
  // stored; every 100 m they used to gain points.
  const SceneFrame frame = olindaFrame();
  gis::Result<VectorLayer> stored = gis::geo::readVectorLayer(kBoundaries, frame, undensified());
  gis::Result<VectorLayer> byDefault = gis::geo::readVectorLayer(kBoundaries, frame);
  VectorReadOptions every100m = undensified();
  every100m.maxGeodesicSegmentMetres = 100.0;
  gis::Result<VectorLayer> byLength = gis::geo::readVectorLayer(kBoundaries, frame, every100m);
  ASSERT_TRUE(stored.ok() && byDefault.ok() && byLength.ok());
  EXPECT_EQ(byDefault->vertexCount(), stored->vertexCount());
  EXPECT_GT(byLength->vertexCount(), stored->vertexCount());
}

}  // namespace
