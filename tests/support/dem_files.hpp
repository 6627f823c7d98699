#pragma once
// DEM files as users have them, written for tests: GeoTIFFs in any CRS and unit, and SRTM .hgt
// tiles (GDAL's SRTMHGT driver, Int16, voids -32768) named and placed as NASA's are.
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

namespace gis::test {

struct DemFileOptions {
  int width = 0, height = 0;
  std::array<double, 6> geoTransform{};
  std::string crs;  ///< OGR user input; empty = no CRS
  GDALDataType type = GDT_Float32;
  std::optional<double> nodata;
  std::string unit;  ///< the band's unit type ("ft", "m", ...); empty = none
  std::optional<double> scale, offset;
};

/// Writes a GeoTIFF; value(col, row) gives each sample (as stored, before scale and unit).
inline void writeDemFile(const std::string& path, const DemFileOptions& o,
                         const std::function<double(int col, int row)>& value) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), o.width, o.height, 1, o.type, nullptr);
  ASSERT_NE(ds, nullptr) << path;
  ds->SetGeoTransform(const_cast<double*>(o.geoTransform.data()));
  if (!o.crs.empty()) {
    OGRSpatialReference srs;
    ASSERT_EQ(srs.SetFromUserInput(o.crs.c_str()), OGRERR_NONE) << o.crs;
    ds->SetSpatialRef(&srs);
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  if (o.nodata) band->SetNoDataValue(*o.nodata);
  if (!o.unit.empty()) band->SetUnitType(o.unit.c_str());
  if (o.scale) band->SetScale(*o.scale);
  if (o.offset) band->SetOffset(*o.offset);
  std::vector<double> data(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height));
  for (int r = 0; r < o.height; ++r) {
    for (int c = 0; c < o.width; ++c)
      data[static_cast<std::size_t>(r) * static_cast<std::size_t>(o.width) + static_cast<std::size_t>(c)] = value(c, r);
  }
  ASSERT_EQ(
      band->RasterIO(GF_Write, 0, 0, o.width, o.height, data.data(), o.width, o.height, GDT_Float64, 0, 0, nullptr),
      CE_None);
  GDALClose(GDALDataset::ToHandle(ds));
}

/// The name NASA gives the SRTM tile whose south-west corner is (lon, lat): "N49E006.hgt".
inline std::string hgtName(int lonWest, int latSouth) {
  char name[32];
  std::snprintf(name, sizeof(name), "%c%02d%c%03d.hgt", latSouth >= 0 ? 'N' : 'S', std::abs(latSouth),
                lonWest >= 0 ? 'E' : 'W', std::abs(lonWest));
  return name;
}

/// Writes the SRTM tile of the 1° cell with south-west corner (lonWest, latSouth) into `dir`:
/// `posts`² posts (1201 for 3", 3601 for 1"), the outer rows and columns shared with the
/// neighbours, heights rounded to whole metres from height(lon, lat), -32768 where
/// height is NaN (a void). Returns the path.
inline std::string writeHgtTile(const std::string& dir, int lonWest, int latSouth, int posts,
                                const std::function<double(double lon, double lat)>& height) {
  GDALAllRegister();
  const std::string path = dir + "/" + hgtName(lonWest, latSouth);
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* hgt = GetGDALDriverManager()->GetDriverByName("SRTMHGT");
  EXPECT_NE(mem, nullptr);
  EXPECT_NE(hgt, nullptr);
  if (mem == nullptr || hgt == nullptr) return path;
  GDALDataset* ds = mem->Create("", posts, posts, 1, GDT_Int16, nullptr);
  const double step = 1.0 / (posts - 1);
  std::array<double, 6> gt{lonWest - 0.5 * step, step, 0.0, latSouth + 1.0 + 0.5 * step, 0.0, -step};
  ds->SetGeoTransform(gt.data());
  OGRSpatialReference srs;
  srs.importFromEPSG(4326);
  ds->SetSpatialRef(&srs);
  std::vector<std::int16_t> data(static_cast<std::size_t>(posts) * static_cast<std::size_t>(posts));
  for (int r = 0; r < posts; ++r) {
    for (int c = 0; c < posts; ++c) {
      const double h = height(lonWest + c * step, latSouth + 1.0 - r * step);
      data[static_cast<std::size_t>(r) * static_cast<std::size_t>(posts) + static_cast<std::size_t>(c)] =
          std::isnan(h) ? std::int16_t{-32768} : static_cast<std::int16_t>(std::lround(h));
    }
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(-32768.0);
  EXPECT_EQ(band->RasterIO(GF_Write, 0, 0, posts, posts, data.data(), posts, posts, GDT_Int16, 0, 0, nullptr), CE_None);
  GDALDataset* out = hgt->CreateCopy(path.c_str(), ds, FALSE, nullptr, nullptr, nullptr);
  EXPECT_NE(out, nullptr) << "SRTMHGT CreateCopy " << path << ": " << CPLGetLastErrorMsg();
  if (out != nullptr) GDALClose(GDALDataset::ToHandle(out));
  GDALClose(GDALDataset::ToHandle(ds));
  return path;
}

/// Bilinear interpolation of a raster's posts (pixel centres) at continuous post coordinates
/// (u, v); NaN when outside or when any of the four posts is NaN.
inline double bilinearAt(const std::vector<float>& posts, int width, int height, double u, double v) {
  if (!(u >= 0.0 && v >= 0.0 && u <= width - 1 && v <= height - 1)) return std::nan("");
  const int c = std::min(static_cast<int>(u), width - 2), r = std::min(static_cast<int>(v), height - 2);
  const double fu = u - c, fv = v - r;
  auto at = [&](int cc, int rr) {
    return static_cast<double>(
        posts[static_cast<std::size_t>(rr) * static_cast<std::size_t>(width) + static_cast<std::size_t>(cc)]);
  };
  const double h00 = at(c, r), h10 = at(c + 1, r), h01 = at(c, r + 1), h11 = at(c + 1, r + 1);
  return (h00 * (1 - fu) + h10 * fu) * (1 - fv) + (h01 * (1 - fu) + h11 * fu) * fv;
}

}  // namespace gis::test
