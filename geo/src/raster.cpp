#include "geo/raster.hpp"

#include <cmath>
#include <limits>
#include <new>

#include <gdalwarper.h>

#include "gdal_support.hpp"

namespace gis::geo {

glm::dvec2 GeoTransform::pixelToCrs(double col, double row) const {
  return {c[0] + col * c[1] + row * c[2], c[3] + col * c[4] + row * c[5]};
}

std::optional<glm::dvec2> GeoTransform::crsToPixel(const glm::dvec2& p) const {
  const double det = c[1] * c[5] - c[2] * c[4];
  if (det == 0.0 || !std::isfinite(det)) return std::nullopt;
  const double dx = p.x - c[0];
  const double dy = p.y - c[3];
  return glm::dvec2((c[5] * dx - c[2] * dy) / det, (-c[4] * dx + c[1] * dy) / det);
}

namespace {

struct DatasetDeleter {
  void operator()(GDALDataset* ds) const {
    if (ds != nullptr) GDALClose(GDALDataset::ToHandle(ds));
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetDeleter>;

Diagnostic rasterError(const std::string& path, std::string message) {
  return {Severity::Error, path, "", "", std::move(message)};
}

/// Opens a raster read-only; null with `error` set on failure. Call inside a QuietGdal.
DatasetPtr openRaster(const std::string& path, std::string& error) {
  detail::ensureGdalRegistered();
  DatasetPtr ds(GDALDataset::FromHandle(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!ds) error = "cannot open raster: " + detail::QuietGdal::lastMessage("not a raster GDAL can read");
  return ds;
}

RasterInfo describe(GDALDataset& ds, const std::string& path, Diagnostics& diagnostics) {
  RasterInfo info;
  info.path = path;
  info.width = ds.GetRasterXSize();
  info.height = ds.GetRasterYSize();
  info.bandCount = ds.GetRasterCount();
  std::array<double, 6> gt{};
  if (ds.GetGeoTransform(gt.data()) == CE_None) {
    info.geoTransform.c = gt;
  } else {
    diagnostics.add({Severity::Warning, path, "", "", "raster has no geotransform; using pixel coordinates"});
  }
  if (const OGRSpatialReference* srs = ds.GetSpatialRef(); srs != nullptr && !srs->IsEmpty()) {
    info.crsWkt = detail::toWkt(*srs);
    info.crsIsGeographic = srs->IsGeographic() != 0;
    info.crsIsProjected = srs->IsProjected() != 0;
  }
  if (info.bandCount > 0) {
    int hasNodata = 0;
    const double nodata = ds.GetRasterBand(1)->GetNoDataValue(&hasNodata);
    if (hasNodata != 0) info.nodata = nodata;
  }
  return info;
}

Result<Raster> readSamples(GDALDataset& dataset, const std::string& path, const std::vector<int>& bands);

}  // namespace

Result<RasterInfo> inspectRaster(const std::string& path) {
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openRaster(path, error);
  if (!ds) return Result<RasterInfo>::failure(rasterError(path, error));
  Result<RasterInfo> r;
  r.value = describe(*ds, path, r.diagnostics);
  return r;
}

Result<Raster> readRaster(const std::string& path, const std::vector<int>& bands) {
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openRaster(path, error);
  if (!ds) return Result<Raster>::failure(rasterError(path, error));
  return readSamples(*ds, path, bands);
}

Result<Raster> readRasterInCrs(const std::string& path, const std::vector<int>& bands, const std::string& targetCrs) {
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openRaster(path, error);
  if (!ds) return Result<Raster>::failure(rasterError(path, error));
  const OGRSpatialReference* source = ds->GetSpatialRef();
  if (source == nullptr || source->IsEmpty()) return Result<Raster>::failure(rasterError(path, "raster has no CRS"));
  const detail::SrsPtr target = detail::parseSrs(targetCrs, error);
  if (!target) return Result<Raster>::failure(rasterError(path, error));
  if (source->IsSame(target.get()) != 0) return readSamples(*ds, path, bands);
  // Resampled once into the target CRS (bilinear, 1/8 pixel approximation error).
  const std::string targetWkt = detail::toWkt(*target);
  DatasetPtr warped(GDALDataset::FromHandle(GDALAutoCreateWarpedVRT(GDALDataset::ToHandle(ds.get()), nullptr,
                                                                    targetWkt.c_str(), GRA_Bilinear, 0.125, nullptr)));
  if (!warped) {
    return Result<Raster>::failure(
        rasterError(path, "cannot reproject into the scene CRS: " + detail::QuietGdal::lastMessage("warp failed")));
  }
  return readSamples(*warped, path, bands);
}

namespace {

Result<Raster> readSamples(GDALDataset& dataset, const std::string& path, const std::vector<int>& bands) {
  GDALDataset* ds = &dataset;
  Result<Raster> r;
  Raster raster;
  raster.info = describe(*ds, path, r.diagnostics);
  const RasterInfo& info = raster.info;
  if (bands.empty()) return Result<Raster>::failure(rasterError(path, "no bands requested"));
  for (const int b : bands) {
    if (b < 1 || b > info.bandCount) {
      return Result<Raster>::failure(rasterError(
          path, "band " + std::to_string(b) + " does not exist (the raster has " + std::to_string(info.bandCount) +
                    " band" + (info.bandCount == 1 ? "" : "s") + ", numbered from 1)"));
    }
  }
  if (info.width <= 0 || info.height <= 0) return Result<Raster>::failure(rasterError(path, "raster is empty"));
  raster.bands = bands;

  const std::size_t nb = bands.size();
  const std::size_t pixels = static_cast<std::size_t>(info.width) * static_cast<std::size_t>(info.height);
  if (pixels > std::numeric_limits<std::size_t>::max() / (nb * sizeof(float)))
    return Result<Raster>::failure(rasterError(path, "raster too large to read"));
  try {
    raster.samples.resize(pixels * nb);
  } catch (const std::bad_alloc&) {
    return Result<Raster>::failure(rasterError(path, "not enough memory to read the raster"));
  }

  // Pixel-interleaved into one buffer: pixel stride = nb floats, line stride = width pixels.
  const auto pixelSpace = static_cast<GSpacing>(nb * sizeof(float));
  const auto lineSpace = pixelSpace * static_cast<GSpacing>(info.width);
  const auto bandSpace = static_cast<GSpacing>(sizeof(float));
  std::vector<int> bandMap(bands);
  const CPLErr err =
      ds->RasterIO(GF_Read, 0, 0, info.width, info.height, raster.samples.data(), info.width, info.height, GDT_Float32,
                   static_cast<int>(nb), bandMap.data(), pixelSpace, lineSpace, bandSpace, nullptr);
  if (err != CE_None) {
    return Result<Raster>::failure(
        rasterError(path, "cannot read samples: " + detail::QuietGdal::lastMessage("RasterIO failed")));
  }

  // Nodata → NaN, per band (imagery bands may define nodata too).
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t k = 0; k < nb; ++k) {
    int hasNodata = 0;
    const double nodata = ds->GetRasterBand(bands[k])->GetNoDataValue(&hasNodata);
    if (hasNodata == 0 || std::isnan(nodata)) continue;  // NaN nodata is NaN already
    // A nodata value a float cannot hold cannot occur among float samples either.
    if (std::isfinite(nodata) && std::abs(nodata) > static_cast<double>(std::numeric_limits<float>::max())) continue;
    const auto value = static_cast<float>(nodata);
    for (std::size_t i = k; i < raster.samples.size(); i += nb) {
      if (raster.samples[i] == value) raster.samples[i] = nan;
    }
  }
  r.value = std::move(raster);
  return r;
}

}  // namespace

}  // namespace gis::geo
