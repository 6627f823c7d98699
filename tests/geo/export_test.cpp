// GeoJSON export of selected features, read back with OGR and compared with the source files:
// the Olinda tracts (a shapefile whose GRS80 CRS has no EPSG code, so GDAL's driver alone would
// drop it), the Olinda street lines (GeoJSON, WGS 84), a CSV in an assumed UTM CRS with a curve,
// and a small file written here whose attributes clash with the others' in type.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gdal_version.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <GeographicLib/TransverseMercator.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <nlohmann/json.hpp>

#include "geo/export.hpp"
#include "test_paths.hpp"

namespace {

using gis::geo::ExportedFeature;
using gis::geo::ExportSource;

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";
const std::string kData = std::string(STENCIL_GIS_TEST_DATA_DIR) + "/";
const std::string kTracts = kSamples + "olinda1.shp";
const std::string kBoundaries = kSamples + "olinda_tract_boundaries.geojson";
const std::string kCsvUtm = kData + "no_crs_utm25s.csv";

/// Coordinates of the single-source export are the source's doubles (GDAL writes 17 significant
/// digits); the combined export writes 15 decimals of a degree.
constexpr double kSameTol = 1e-9;
constexpr double kDegTol = 1e-9;  // about 0.1 mm

std::string outPath(const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

GDALDatasetUniquePtr openVector(const std::string& path) {
  GDALAllRegister();
  return GDALDatasetUniquePtr(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
}

std::vector<ExportedFeature> selection(const std::vector<std::int64_t>& fids) {
  std::vector<ExportedFeature> out;
  for (const std::int64_t fid : fids) out.push_back({fid, {}});
  return out;
}

std::string describe(const gis::Diagnostics& d) {
  std::string s;
  for (const gis::Diagnostic& x : d.items()) s += x.toString() + "\n";
  return s;
}

std::vector<const gis::Diagnostic*> withSeverity(const gis::Diagnostics& d, gis::Severity severity) {
  std::vector<const gis::Diagnostic*> out;
  for (const gis::Diagnostic& x : d.items())
    if (x.severity == severity) out.push_back(&x);
  return out;
}

/// Rings and line strings of a (multi)polygon or (multi)line string, in order.
std::vector<std::vector<glm::dvec2>> parts(const OGRGeometry& g) {
  std::vector<std::vector<glm::dvec2>> out;
  auto curve = [&out](const OGRSimpleCurve& c) {
    std::vector<glm::dvec2> pts;
    for (int i = 0; i < c.getNumPoints(); ++i) pts.emplace_back(c.getX(i), c.getY(i));
    out.push_back(std::move(pts));
  };
  auto polygon = [&curve](const OGRPolygon& p) {
    for (const OGRLinearRing* ring : p) curve(*ring);
  };
  switch (wkbFlatten(g.getGeometryType())) {
    case wkbPolygon:
      polygon(*g.toPolygon());
      break;
    case wkbMultiPolygon:
      for (const OGRPolygon* p : *g.toMultiPolygon()) polygon(*p);
      break;
    case wkbLineString:
      curve(*g.toLineString());
      break;
    case wkbMultiLineString:
      for (const OGRLineString* l : *g.toMultiLineString()) curve(*l);
      break;
    default:
      ADD_FAILURE() << "unexpected geometry " << g.getGeometryName();
  }
  return out;
}

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Largest distance between corresponding vertices; infinity when the structure differs. With
/// `reversedRingsOk`, a ring may also match the reversed other one (RFC 7946's right-hand rule).
double maxVertexDistance(const std::vector<std::vector<glm::dvec2>>& a, const std::vector<std::vector<glm::dvec2>>& b,
                         bool reversedRingsOk = false) {
  if (a.size() != b.size()) return kInf;
  double worst = 0.0;
  for (std::size_t p = 0; p < a.size(); ++p) {
    if (a[p].size() != b[p].size()) return kInf;
    const std::size_t n = a[p].size();
    double forward = 0.0;
    double backward = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      forward = std::max(forward, glm::length(a[p][i] - b[p][i]));
      backward = std::max(backward, glm::length(a[p][i] - b[p][n - 1 - i]));
    }
    worst = std::max(worst, reversedRingsOk ? std::min(forward, backward) : forward);
  }
  return worst;
}

/// GeoJSON has no schema: a reader picks Integer for integers that fit in 32 bits.
OGRFieldType typeFamily(OGRFieldType t) { return t == OFTInteger64 ? OFTInteger : t; }

/// Every attribute of `src` is in `out` (case-sensitive name) with the same type and value.
void expectSameAttributes(const OGRFeature& src, const OGRFeature& out) {
  for (int i = 0; i < src.GetFieldCount(); ++i) {
    const OGRFieldDefn* field = src.GetFieldDefnRef(i);
    const int j = out.GetDefnRef()->GetFieldIndexCaseSensitive(field->GetNameRef());
    ASSERT_GE(j, 0) << field->GetNameRef();
    EXPECT_EQ(typeFamily(out.GetFieldDefnRef(j)->GetType()), typeFamily(field->GetType())) << field->GetNameRef();
    ASSERT_EQ(out.IsFieldSetAndNotNull(j), src.IsFieldSetAndNotNull(i)) << field->GetNameRef();
    if (!src.IsFieldSetAndNotNull(i)) continue;
    switch (field->GetType()) {
      case OFTInteger:
      case OFTInteger64:
        EXPECT_EQ(out.GetFieldAsInteger64(j), src.GetFieldAsInteger64(i)) << field->GetNameRef();
        break;
      case OFTReal:
        EXPECT_EQ(out.GetFieldAsDouble(j), src.GetFieldAsDouble(i)) << field->GetNameRef();
        break;
      default:
        EXPECT_STREQ(out.GetFieldAsString(j), src.GetFieldAsString(i)) << field->GetNameRef();
    }
  }
}

// ---- one source, original CRS ------------------------------------------------------------------

TEST(ExportGeoJson, TractsRoundTripWithGeometryAttributesAndTheirCrsWithoutEpsgCode) {
  ExportSource source{kTracts, "", "", "Tracts", {}};
  for (std::int64_t fid = 0; fid < 470; ++fid)
    source.features.push_back({fid, {{"selection_fully_inside", std::int64_t{fid % 2}}, {"score", 0.5 * double(fid)}}});
  const std::string out = outPath("tracts.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(source, out);
  EXPECT_TRUE(d.empty()) << describe(d);

  // GDAL's driver alone writes no "crs" for this CRS (no authority code); ours carries its WKT.
  EXPECT_NE(readText(out).find("\"crs\": { \"type\": \"name\""), std::string::npos);

  GDALDatasetUniquePtr src = openVector(kTracts);
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(src && got);
  OGRLayer* srcLayer = src->GetLayer(0);
  OGRLayer* gotLayer = got->GetLayer(0);
  EXPECT_STREQ(gotLayer->GetName(), "olinda1");
  ASSERT_EQ(gotLayer->GetFeatureCount(), 470);

  ASSERT_NE(gotLayer->GetSpatialRef(), nullptr);
  EXPECT_TRUE(gotLayer->GetSpatialRef()->IsSame(srcLayer->GetSpatialRef()));
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  EXPECT_FALSE(gotLayer->GetSpatialRef()->IsSame(&wgs84));  // what a reader would assume without "crs"

  std::size_t vertices = 0;
  std::size_t nulls = 0;
  for (const OGRFeatureUniquePtr& f : *gotLayer) {
    const OGRFeatureUniquePtr s(srcLayer->GetFeature(f->GetFID()));  // the FID is the feature "id"
    ASSERT_TRUE(s) << f->GetFID();
    expectSameAttributes(*s, *f);
    if (s->IsFieldNull(s->GetFieldIndex("NM_BAIR"))) ++nulls;
    const auto a = parts(*s->GetGeometryRef());
    EXPECT_LE(maxVertexDistance(a, parts(*f->GetGeometryRef())), kSameTol) << "fid " << f->GetFID();
    for (const auto& p : a) vertices += p.size();

    const int inside = f->GetFieldIndex("selection_fully_inside");
    const int score = f->GetFieldIndex("score");
    ASSERT_GE(inside, 0);
    ASSERT_GE(score, 0);
    EXPECT_EQ(f->GetFieldDefnRef(inside)->GetType(), OFTInteger);
    EXPECT_EQ(f->GetFieldAsInteger64(inside), f->GetFID() % 2);
    EXPECT_EQ(f->GetFieldDefnRef(score)->GetType(), OFTReal);
    EXPECT_EQ(f->GetFieldAsDouble(score), 0.5 * double(f->GetFID()));
  }
  EXPECT_EQ(vertices, 12705u);  // PROVENANCE.md, closing points included
  EXPECT_EQ(nulls, 12u);        // NM_BAIR null stays null
}

TEST(ExportGeoJson, StreetLinesKeepTheirIdPropertyAndCrs84) {
  const ExportSource source{kBoundaries, "olinda_tract_boundaries", "", "Streets", selection({0, 5, 100, 1412})};
  const std::string out = outPath("streets.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(source, out);
  EXPECT_TRUE(d.empty()) << describe(d);
  EXPECT_NE(readText(out).find("urn:ogc:def:crs:OGC:1.3:CRS84"), std::string::npos);

  GDALDatasetUniquePtr src = openVector(kBoundaries);
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(src && got);
  OGRLayer* gotLayer = got->GetLayer(0);
  ASSERT_EQ(gotLayer->GetFeatureCount(), 4);
  EXPECT_TRUE(gotLayer->GetSpatialRef()->IsSame(src->GetLayer(0)->GetSpatialRef()));
  std::vector<GIntBig> fids;
  for (const OGRFeatureUniquePtr& f : *gotLayer) {
    fids.push_back(f->GetFID());
    const OGRFeatureUniquePtr s(src->GetLayer(0)->GetFeature(f->GetFID()));
    ASSERT_TRUE(s);
    expectSameAttributes(*s, *f);
    EXPECT_EQ(f->GetFieldAsInteger64("id"), f->GetFID());
    EXPECT_EQ(f->GetFieldDefnRef(f->GetFieldIndex("class"))->GetType(), OFTString);
    EXPECT_EQ(f->GetFieldDefnRef(f->GetFieldIndex("width_m"))->GetType(), OFTReal);
    EXPECT_LE(maxVertexDistance(parts(*s->GetGeometryRef()), parts(*f->GetGeometryRef())), kSameTol);
  }
  EXPECT_EQ(fids, (std::vector<GIntBig>{0, 5, 100, 1412}));
}

TEST(ExportGeoJson, AssumedUtmCrsIsWrittenAsEpsgUrnAndCurvesAsSegments) {
  const ExportSource source{kCsvUtm, "", "EPSG:31985", "", selection({1, 2, 3})};
  const std::string out = outPath("csv_utm.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(source, out);
  const auto warnings = withSeverity(d, gis::Severity::Warning);
  EXPECT_FALSE(d.hasErrors()) << describe(d);
  ASSERT_EQ(warnings.size(), 1u) << describe(d);
  EXPECT_EQ(warnings[0]->feature, "2");  // the CURVEPOLYGON
  EXPECT_NE(warnings[0]->message.find("curve"), std::string::npos);
  EXPECT_NE(readText(out).find("\"urn:ogc:def:crs:EPSG::31985\""), std::string::npos);

  GDALDatasetUniquePtr src = openVector(kCsvUtm);
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(src && got);
  OGRSpatialReference utm;
  utm.importFromEPSG(31985);
  EXPECT_TRUE(got->GetLayer(0)->GetSpatialRef()->IsSame(&utm));
  ASSERT_EQ(got->GetLayer(0)->GetFeatureCount(), 3);
  for (const OGRFeatureUniquePtr& f : *got->GetLayer(0)) {
    const OGRFeatureUniquePtr s(src->GetLayer(0)->GetFeature(f->GetFID()));
    ASSERT_TRUE(s);
    expectSameAttributes(*s, *f);
    const std::unique_ptr<OGRGeometry> linear(s->GetGeometryRef()->getLinearGeometry());
    EXPECT_LE(maxVertexDistance(parts(*linear), parts(*f->GetGeometryRef())), kSameTol);
    EXPECT_EQ(f->GetGeometryRef()->Is3D(), s->GetGeometryRef()->Is3D());
  }
}

// ---- errors and edge cases -------------------------------------------------------------------

TEST(ExportGeoJson, MissingFidsAreErrorsNamingThemAndTheOthersAreWritten) {
  const ExportSource source{kTracts, "", "", "Tracts", selection({3, 99999, 7, -5})};
  const std::string out = outPath("missing.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(source, out);
  const auto errors = withSeverity(d, gis::Severity::Error);
  ASSERT_EQ(errors.size(), 2u) << describe(d);
  EXPECT_EQ(errors[0]->file, kTracts);
  EXPECT_EQ(errors[0]->layer, "olinda1");
  EXPECT_EQ(errors[0]->feature, "99999");
  EXPECT_EQ(errors[1]->feature, "-5");
  EXPECT_NE(errors[0]->toString().find("99999"), std::string::npos);

  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(got);
  std::vector<GIntBig> fids;
  for (const OGRFeatureUniquePtr& f : *got->GetLayer(0)) fids.push_back(f->GetFID());
  EXPECT_EQ(fids, (std::vector<GIntBig>{3, 7}));
}

TEST(ExportGeoJson, UnwritableOutputIsAnError) {
  const ExportSource source{kTracts, "", "", "Tracts", selection({1})};
  const std::string out = outPath("no_such_dir/out.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(source, out);
  const auto errors = withSeverity(d, gis::Severity::Error);
  ASSERT_EQ(errors.size(), 1u) << describe(d);
  EXPECT_EQ(errors[0]->file, out);
  EXPECT_FALSE(std::filesystem::exists(out));

  const std::array<ExportSource, 1> sources{source};
  const gis::Diagnostics dc = gis::geo::exportFeaturesGeoJsonCombined(sources, out);
  ASSERT_EQ(withSeverity(dc, gis::Severity::Error).size(), 1u) << describe(dc);
  EXPECT_EQ(dc.items().front().file, out);

  // A directory in the way is not deleted.
  const std::string dir = outPath("a_directory");
  std::filesystem::create_directories(dir);
  EXPECT_TRUE(gis::geo::exportFeaturesGeoJson(source, dir).hasErrors());
  EXPECT_TRUE(std::filesystem::is_directory(dir));
}

TEST(ExportGeoJson, UnreadableSourceIsAnErrorAndNothingIsWritten) {
  const std::string out = outPath("from_missing_source.geojson");
  std::filesystem::remove(out);
  const ExportSource missing{kData + "does_not_exist.geojson", "", "", "", selection({1})};
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson(missing, out);
  ASSERT_TRUE(d.hasErrors());
  EXPECT_EQ(d.items().front().file, missing.path);
  EXPECT_FALSE(std::filesystem::exists(out));

  const ExportSource noLayer{kTracts, "no_such_layer", "", "", selection({1})};
  const gis::Diagnostics dl = gis::geo::exportFeaturesGeoJson(noLayer, out);
  ASSERT_TRUE(dl.hasErrors());
  EXPECT_EQ(dl.items().front().layer, "no_such_layer");
}

TEST(ExportGeoJson, ExistingOutputIsReplacedButNeverTheSource) {
  const std::string out = outPath("replaced.geojson");
  ASSERT_FALSE(gis::geo::exportFeaturesGeoJson({kTracts, "", "", "", selection({0, 1, 2})}, out).hasErrors());
  ASSERT_FALSE(gis::geo::exportFeaturesGeoJson({kTracts, "", "", "", selection({5})}, out).hasErrors());
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->GetLayer(0)->GetFeatureCount(), 1);
  got.reset();

  // Exporting a file's features onto itself would delete them before reading.
  const std::string copy = outPath("self.geojson");
  std::filesystem::copy_file(kBoundaries, copy, std::filesystem::copy_options::overwrite_existing);
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson({copy, "", "", "", selection({0})}, copy);
  EXPECT_TRUE(d.hasErrors());
  EXPECT_EQ(readText(copy), readText(kBoundaries));
}

TEST(ExportGeoJson, EmptySelectionWritesAnEmptyFeatureCollection) {
  const std::string out = outPath("empty.geojson");
  EXPECT_TRUE(gis::geo::exportFeaturesGeoJson({kTracts, "", "", "", {}}, out).empty());
  const nlohmann::json single = nlohmann::json::parse(readText(out));
  EXPECT_EQ(single["type"], "FeatureCollection");
  EXPECT_TRUE(single["features"].is_array() && single["features"].empty());
  EXPECT_TRUE(single.contains("crs"));

  const std::string combined = outPath("empty_combined.geojson");
  EXPECT_TRUE(gis::geo::exportFeaturesGeoJsonCombined({}, combined).empty());
  const nlohmann::json none = nlohmann::json::parse(readText(combined));
  EXPECT_EQ(none["type"], "FeatureCollection");
  EXPECT_TRUE(none["features"].is_array() && none["features"].empty());
}

TEST(ExportGeoJson, StringsThatLookLikeJsonStayStringsOrAreReported) {
  const std::string path = outPath("json_like.geojson");
  std::ofstream(path) << R"({"type": "FeatureCollection", "features": [
{"type": "Feature", "id": 1, "properties": {"tags": "[1, 2]"}, "geometry": {"type": "Point", "coordinates": [1, 2]}},
{"type": "Feature", "id": 2, "properties": {"tags": "[not json]"}, "geometry": {"type": "Point", "coordinates": [1, 3]}}
]})";
  const std::string out = outPath("json_like_out.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJson({path, "", "", "", selection({1, 2})}, out);
  const nlohmann::json json = nlohmann::json::parse(readText(out));
  ASSERT_EQ(json["features"].size(), 2u);
  EXPECT_TRUE(json["features"][1]["properties"]["tags"].is_string());
  if (GDAL_VERSION_NUM >= GDAL_COMPUTE_VERSION(3, 8, 0)) {
    EXPECT_TRUE(d.empty()) << describe(d);  // AUTODETECT_JSON_STRINGS=NO
    EXPECT_EQ(json["features"][0]["properties"]["tags"], "[1, 2]");
  } else {
    // The driver turns it into an array and has no option against it: a warning says so.
    const auto warnings = withSeverity(d, gis::Severity::Warning);
    ASSERT_EQ(warnings.size(), 1u) << describe(d);
    EXPECT_EQ(warnings[0]->feature, "1");
    EXPECT_NE(warnings[0]->message.find("'tags'"), std::string::npos);
    EXPECT_TRUE(json["features"][0]["properties"]["tags"].is_array());
  }
}

// ---- several sources in one RFC 7946 file ----------------------------------------------------

/// A small CRS84 file whose attributes clash with the samples': width_m is a string here and a
/// real number in the street lines, V014 an Integer here and an Integer64 in the tracts, and
/// selection_layer is an original attribute.
std::string writeClashingFile() {
  const std::string path = outPath("clashing.geojson");
  std::ofstream(path) << R"({"type": "FeatureCollection", "features": [
{"type": "Feature", "id": 1, "properties": {"width_m": "wide", "V014": 12, "selection_layer": "old"},
 "geometry": {"type": "Polygon", "coordinates": [[[-34.87, -8.0], [-34.869, -8.0], [-34.869, -7.999], [-34.87, -8.0]]]}}
]})";
  return path;
}

TEST(ExportGeoJson, CombinedFileIsWgs84WithUnionOfFieldsAndSelectionProperties) {
  std::vector<ExportSource> sources;
  sources.push_back({kTracts, "", "", "Tracts", {}});
  for (const std::int64_t fid : {0, 10, 469})
    sources.back().features.push_back({fid, {{"selection_fully_inside", std::int64_t{fid == 10}}}});
  sources.push_back({kBoundaries, "", "", "Streets", selection({0, 7})});
  sources.push_back({kCsvUtm, "", "EPSG:31985", "", selection({1, 2, 3})});
  sources.push_back({writeClashingFile(), "", "", "Clash", selection({1})});
  const std::string out = outPath("combined.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJsonCombined(sources, out);
  EXPECT_FALSE(d.hasErrors()) << describe(d);
  const auto warnings = withSeverity(d, gis::Severity::Warning);
  ASSERT_EQ(warnings.size(), 2u) << describe(d);  // selection_layer replaced; the curve
  EXPECT_EQ(warnings[0]->file, sources[3].path);
  EXPECT_NE(warnings[0]->message.find("selection_layer"), std::string::npos);
  EXPECT_EQ(warnings[1]->feature, "2");

  // RFC 7946: no "crs" member; OGR reads it as WGS 84.
  const std::string text = readText(out);
  EXPECT_EQ(text.find("\"crs\""), std::string::npos);
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(got);
  OGRLayer* layer = got->GetLayer(0);
  OGRSpatialReference epsg4326;
  epsg4326.importFromEPSG(4326);
  epsg4326.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  EXPECT_TRUE(layer->GetSpatialRef()->IsSame(&epsg4326));
  ASSERT_EQ(layer->GetFeatureCount(), 3 + 2 + 3 + 1);

  // Independent check of the UTM source: GeographicLib's UTM 25 S on GRS80 (SIRGAS 2000 and
  // WGS 84 coincide here: PROJ applies no shift).
  const GeographicLib::TransverseMercator tm(6378137.0, 1.0 / 298.257222101, 0.9996);
  auto utmToLonLat = [&tm](std::vector<std::vector<glm::dvec2>> p) {
    for (auto& part : p)
      for (glm::dvec2& v : part) {
        double lat = 0.0;
        double lon = 0.0;
        tm.Reverse(-33.0, v.x - 500000.0, v.y - 10000000.0, lat, lon);
        v = glm::dvec2(lon, lat);
      }
    return p;
  };

  std::map<std::string, std::vector<std::int64_t>> fidsByLabel;
  std::vector<GIntBig> ids;  // the feature "id" numbers the file's features
  for (const OGRFeatureUniquePtr& f : *layer) {
    ids.push_back(f->GetFID());
    ASSERT_TRUE(f->IsFieldSetAndNotNull(f->GetFieldIndex("selection_layer")));
    ASSERT_TRUE(f->IsFieldSetAndNotNull(f->GetFieldIndex("selection_fid")));
    const std::string label = f->GetFieldAsString("selection_layer");
    const std::int64_t fid = f->GetFieldAsInteger64("selection_fid");
    fidsByLabel[label].push_back(fid);
    const ExportSource* source = nullptr;
    for (const ExportSource& s : sources)
      if ((s.label.empty() ? "no_crs_utm25s" : s.label) == label) source = &s;
    ASSERT_NE(source, nullptr) << label;
    GDALDatasetUniquePtr src = openVector(source->path);
    const OGRFeatureUniquePtr s(src->GetLayer(0)->GetFeature(fid));
    ASSERT_TRUE(s);

    // Geometry: lon/lat (x = longitude), equal to the source after reprojection; rings may be
    // reversed (right-hand rule).
    const std::unique_ptr<OGRGeometry> linear(s->GetGeometryRef()->getLinearGeometry());
    auto expected = parts(*linear);
    if (source->path == kCsvUtm) expected = utmToLonLat(expected);
    const auto actual = parts(*f->GetGeometryRef());
    EXPECT_LE(maxVertexDistance(expected, actual, true), kDegTol) << label << " " << fid;
    for (const auto& p : actual)
      for (const glm::dvec2& v : p) {
        EXPECT_NEAR(v.x, -34.87, 0.1);
        EXPECT_NEAR(v.y, -8.0, 0.1);
      }

    // Attributes: the originals, converted where the union says so.
    if (label == "Tracts") {
      expectSameAttributes(*s, *f);
      EXPECT_EQ(f->GetFieldAsInteger64("selection_fully_inside"), fid == 10 ? 1 : 0);
    }
    if (label == "Streets") {
      EXPECT_EQ(f->GetFieldAsInteger64(f->GetDefnRef()->GetFieldIndexCaseSensitive("id")),
                s->GetFieldAsInteger64("id"));
      EXPECT_STREQ(f->GetFieldAsString("class"), s->GetFieldAsString("class"));
      EXPECT_STREQ(f->GetFieldAsString("width_m"), s->GetFieldAsString("width_m"));  // now a string
    }
    if (label == "no_crs_utm25s") expectSameAttributes(*s, *f);
    if (label == "Clash") {
      EXPECT_STREQ(f->GetFieldAsString("width_m"), "wide");
      EXPECT_EQ(f->GetFieldAsInteger64("V014"), 12);
    }
  }
  EXPECT_EQ(fidsByLabel["Tracts"], (std::vector<std::int64_t>{0, 10, 469}));
  EXPECT_EQ(fidsByLabel["Streets"], (std::vector<std::int64_t>{0, 7}));
  EXPECT_EQ(fidsByLabel["no_crs_utm25s"], (std::vector<std::int64_t>{1, 2, 3}));
  EXPECT_EQ(fidsByLabel["Clash"], (std::vector<std::int64_t>{1}));
  EXPECT_EQ(ids, (std::vector<GIntBig>{0, 1, 2, 3, 4, 5, 6, 7, 8}));

  // The JSON itself: width_m is a string everywhere (Real vs String), both "ID" (tracts) and
  // "id" (streets) are kept, and the selection properties are typed.
  const nlohmann::json json = nlohmann::json::parse(text);
  for (const nlohmann::json& feature : json["features"]) {
    const nlohmann::json& p = feature["properties"];
    EXPECT_TRUE(p["selection_layer"].is_string());
    EXPECT_TRUE(p["selection_fid"].is_number_integer());
    if (p.contains("width_m") && !p["width_m"].is_null()) {
      EXPECT_TRUE(p["width_m"].is_string()) << p;
    }
    if (p["selection_layer"] == "Tracts") {
      EXPECT_TRUE(p["ID"].is_number_float() && !p.contains("id")) << p;
    }
    if (p["selection_layer"] == "Streets") {
      EXPECT_TRUE(p["id"].is_number_integer() && !p.contains("ID")) << p;
    }
  }
}

TEST(ExportGeoJson, CombinedReportsSourcesItCannotUseAndWritesTheRest) {
  std::vector<ExportSource> sources;
  sources.push_back({kData + "does_not_exist.shp", "", "", "Gone", selection({1})});
  sources.push_back({kCsvUtm, "", "", "NoCrs", selection({1})});  // no CRS, none assumed
  sources.push_back({kBoundaries, "", "", "Streets", selection({3, 123456})});
  const std::string out = outPath("combined_partial.geojson");
  const gis::Diagnostics d = gis::geo::exportFeaturesGeoJsonCombined(sources, out);
  const auto errors = withSeverity(d, gis::Severity::Error);
  ASSERT_EQ(errors.size(), 3u) << describe(d);
  EXPECT_EQ(errors[0]->file, sources[0].path);
  EXPECT_EQ(errors[1]->file, kCsvUtm);
  EXPECT_NE(errors[1]->message.find("no CRS"), std::string::npos);
  EXPECT_EQ(errors[2]->file, kBoundaries);
  EXPECT_EQ(errors[2]->layer, "olinda_tract_boundaries");
  EXPECT_EQ(errors[2]->feature, "123456");
  GDALDatasetUniquePtr got = openVector(out);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->GetLayer(0)->GetFeatureCount(), 1);
}

}  // namespace
