#include "geo/raster.hpp"

#include <cmath>
#include <limits>
#include <new>

#include <gdalwarper.h>

#include "geo/gdal_support.hpp"

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

using detail::DatasetPtr;

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

/// Replaces the band's nodata value by NaN in samples[first], samples[first + stride], ...
void nodataToNan(GDALRasterBand& band, std::vector<float>& samples, std::size_t first, std::size_t stride) {
  int hasNodata = 0;
  const double nodata = band.GetNoDataValue(&hasNodata);
  if (hasNodata == 0 || std::isnan(nodata)) return;  // NaN nodata is NaN already
  // A nodata value a float cannot hold cannot occur among float samples either.
  if (std::isfinite(nodata) && std::abs(nodata) > static_cast<double>(std::numeric_limits<float>::max())) return;
  const auto value = static_cast<float>(nodata);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = first; i < samples.size(); i += stride) {
    if (samples[i] == value) samples[i] = nan;
  }
}

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
  for (std::size_t k = 0; k < nb; ++k) nodataToNan(*ds->GetRasterBand(bands[k]), raster.samples, k, nb);
  r.value = std::move(raster);
  return r;
}

}  // namespace

struct RasterStripReader::State {
  DatasetPtr dataset;
  GDALRasterBand* band = nullptr;
  RasterInfo info;
};

RasterStripReader::RasterStripReader(std::unique_ptr<State> state) : state_(std::move(state)) {}
RasterStripReader::RasterStripReader(RasterStripReader&&) noexcept = default;
RasterStripReader& RasterStripReader::operator=(RasterStripReader&&) noexcept = default;
RasterStripReader::~RasterStripReader() = default;

const RasterInfo& RasterStripReader::info() const { return state_->info; }

Result<RasterStripReader> RasterStripReader::open(const std::string& path, int band) {
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openRaster(path, error);
  if (!ds) return Result<RasterStripReader>::failure(rasterError(path, error));
  Result<RasterStripReader> r;
  auto state = std::make_unique<State>();
  state->info = describe(*ds, path, r.diagnostics);
  if (band < 1 || band > state->info.bandCount) {
    return Result<RasterStripReader>::failure(
        rasterError(path, "band " + std::to_string(band) + " does not exist (the raster has " +
                              std::to_string(state->info.bandCount) + ", numbered from 1)"));
  }
  state->band = ds->GetRasterBand(band);
  state->dataset = std::move(ds);
  r.value = RasterStripReader(std::move(state));
  return r;
}

bool RasterStripReader::read(int row0, int rows, std::vector<float>& out, Diagnostics& diagnostics) {
  detail::QuietGdal quiet;
  const RasterInfo& info = state_->info;
  if (row0 < 0 || rows < 0 || row0 + rows > info.height) {
    diagnostics.add(rasterError(info.path, "rows " + std::to_string(row0) + "+" + std::to_string(rows) +
                                               " are outside the raster's " + std::to_string(info.height)));
    return false;
  }
  out.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(info.width));
  if (rows == 0) return true;
  const CPLErr err = state_->band->RasterIO(GF_Read, 0, row0, info.width, rows, out.data(), info.width, rows,
                                            GDT_Float32, 0, 0, nullptr);
  if (err != CE_None) {
    diagnostics.add(rasterError(info.path, "cannot read rows " + std::to_string(row0) + "+" + std::to_string(rows) +
                                               ": " + detail::QuietGdal::lastMessage("RasterIO failed")));
    return false;
  }
  nodataToNan(*state_->band, out, 0, 1);
  return true;
}

}  // namespace gis::geo
