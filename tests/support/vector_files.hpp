#pragma once
// Vector files as GIS users exchange them, written for tests: a Shapefile whose attributes are
// Latin-1 with no .cpg (no declared encoding), as many older Brazilian and European files are;
// and any vector file translated by GDAL (ogr2ogr's options).
#include <filesystem>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

namespace gis::test {

/// Translates the vector file `in` into `out` (replaced) with ogr2ogr's `options` ("-f", "GeoJSON",
/// "-sql", …), as GDALVectorTranslate does; failures are test failures.
inline void translateVector(const std::string& in, const std::string& out, std::vector<std::string> options) {
  std::filesystem::remove(out);
  std::vector<char*> argv;
  for (std::string& a : options) argv.push_back(a.data());
  argv.push_back(nullptr);
  GDALAllRegister();
  GDALVectorTranslateOptions* parsed = GDALVectorTranslateOptionsNew(argv.data(), nullptr);
  GDALDatasetH source = GDALOpenEx(in.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
  EXPECT_NE(source, nullptr) << in;
  int error = 0;
  GDALDatasetH written = GDALVectorTranslate(out.c_str(), nullptr, 1, &source, parsed, &error);
  EXPECT_NE(written, nullptr) << out;
  GDALClose(written);
  GDALClose(source);
  GDALVectorTranslateOptionsFree(parsed);
}

/// Writes `path` (a .shp) in EPSG:`epsg` with one polygon feature per ring of `rings` and a
/// String field "nome" holding `name` byte for byte (Latin-1 bytes stay Latin-1), and no .cpg.
inline void writeUndeclaredEncodingShapefile(const std::string& path, int epsg,
                                             const std::vector<std::vector<std::array<double, 2>>>& rings,
                                             const std::string& name) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("ESRI Shapefile");
  ASSERT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
  ASSERT_NE(ds, nullptr) << path;
  OGRSpatialReference srs;
  srs.importFromEPSG(epsg);
  const char* const options[] = {"ENCODING=", nullptr};  // write the bytes as given, declare nothing
  const std::string layerName = std::filesystem::path(path).stem().string();
  OGRLayer* layer = ds->CreateLayer(layerName.c_str(), &srs, wkbPolygon, const_cast<char**>(options));
  ASSERT_NE(layer, nullptr);
  OGRFieldDefn field("nome", OFTString);
  ASSERT_EQ(layer->CreateField(&field), OGRERR_NONE);
  for (const auto& ring : rings) {
    OGRFeature* feature = OGRFeature::CreateFeature(layer->GetLayerDefn());
    feature->SetField("nome", name.c_str());
    OGRLinearRing r;
    for (const auto& p : ring) r.addPoint(p[0], p[1]);
    r.closeRings();
    OGRPolygon polygon;
    polygon.addRing(&r);
    feature->SetGeometry(&polygon);
    EXPECT_EQ(layer->CreateFeature(feature), OGRERR_NONE);
    OGRFeature::DestroyFeature(feature);
  }
  GDALClose(GDALDataset::ToHandle(ds));
  std::filesystem::remove(std::filesystem::path(path).replace_extension(".cpg"));
}

}  // namespace gis::test
