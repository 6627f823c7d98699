#pragma once
// Raster reading through GDAL: DEMs (any GDAL format, GeoTIFF first) and multi-band imagery.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"

namespace gis::geo {

/// GDAL's affine geotransform: x = c0 + col·c1 + row·c2, y = c3 + col·c4 + row·c5, where
/// (col, row) are pixel-corner coordinates (0,0 = top-left corner of the top-left pixel).
struct GeoTransform {
  std::array<double, 6> c{0.0, 1.0, 0.0, 0.0, 0.0, 1.0};

  [[nodiscard]] glm::dvec2 pixelToCrs(double col, double row) const;
  /// No NaN or infinite coefficient.
  [[nodiscard]] bool finite() const {
    return std::all_of(c.begin(), c.end(), [](double v) { return std::isfinite(v); });
  }
  /// Inverse of pixelToCrs; nullopt if the transform is singular.
  [[nodiscard]] std::optional<glm::dvec2> crsToPixel(const glm::dvec2& p) const;
};

/// What a raster file is, without its samples.
struct RasterInfo {
  std::string path;
  int width = 0;
  int height = 0;
  int bandCount = 0;
  GeoTransform geoTransform;
  std::string crsWkt;  ///< empty when the file has no CRS
  bool crsIsGeographic = false;
  bool crsIsProjected = false;
  std::optional<double> nodata;  ///< of the first band

  /// CRS coordinates of the centre of pixel (col, row).
  [[nodiscard]] glm::dvec2 pixelCentre(int col, int row) const { return geoTransform.pixelToCrs(col + 0.5, row + 0.5); }
};

/// Samples of selected bands, pixel-interleaved, top row first:
/// samples[(row * width + col) * bands.size() + b]. Nodata samples are NaN.
struct Raster {
  RasterInfo info;
  std::vector<int> bands;  ///< 1-based band numbers as read, in order
  std::vector<float> samples;

  [[nodiscard]] int channels() const { return static_cast<int>(bands.size()); }
  [[nodiscard]] float at(int col, int row, int channel = 0) const {
    return samples[(static_cast<std::size_t>(row) * static_cast<std::size_t>(info.width) +
                    static_cast<std::size_t>(col)) *
                       bands.size() +
                   static_cast<std::size_t>(channel)];
  }
};

/// Opens a raster and reports its size, geotransform, CRS and nodata.
Result<RasterInfo> inspectRaster(const std::string& path);

/// Reads the given bands (1-based; e.g. {3, 2, 1} for Landsat true colour). A band number out
/// of range is an error naming the file and the band.
Result<Raster> readRaster(const std::string& path, const std::vector<int>& bands = {1});

/// Reads the bands resampled (bilinear, once) into another CRS (e.g. the scene frame's); the
/// result's geotransform and CRS are those of the target grid. Reads directly when the CRSs
/// are the same.
Result<Raster> readRasterInCrs(const std::string& path, const std::vector<int>& bands, const std::string& targetCrs);

/// Reads one band of a raster in strips of rows, for rasters too big to hold at once (the tile
/// pyramid builder streams a 16385² DEM through it). Nodata samples are NaN.
class RasterStripReader {
 public:
  static Result<RasterStripReader> open(const std::string& path, int band = 1);
  RasterStripReader(RasterStripReader&&) noexcept;
  RasterStripReader& operator=(RasterStripReader&&) noexcept;
  ~RasterStripReader();

  [[nodiscard]] const RasterInfo& info() const;
  /// Rows [row0, row0 + rows) into `out` (resized to rows × width); false with a message
  /// naming the file on a read error.
  bool read(int row0, int rows, std::vector<float>& out, Diagnostics& diagnostics);

 private:
  struct State;
  explicit RasterStripReader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace gis::geo
