#pragma once
// DEMs as people have them (docs/terrain.md, "DEMs in any CRS, mosaics"): one file, a list of
// files, a folder of tiles or a GDAL VRT; SRTM .hgt, GeoTIFF or anything GDAL reads; in any CRS
// GDAL knows; heights in metres, feet or with a scale and offset. A DemSource opens the tiles and
// says where they lie; a FrameDem reads them as one north-up grid of posts in the scene frame,
// resampled once (bilinear) unless they already are such a grid.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"

namespace gis::geo {

/// Where a DEM comes from and how to read it.
struct DemSpec {
  /// Files (GeoTIFF, SRTM .hgt, GDAL VRT, ...) and folders of such tiles (searched recursively).
  std::vector<std::string> paths;
  int band = 1;
  /// The CRS of every tile, overriding what the files say (needed for files without one);
  /// empty = the files' own.
  std::string crs;
  /// The heights' unit ("m", "ft", "us-ft"), overriding the files' metadata; empty = theirs.
  std::string heightUnit;
  /// Post spacing of the resampled grid in metres; 0 = the finest source spacing.
  double resolutionMetres = 0.0;
};

/// The largest |height| that is a height (as terrain::kMaxPostHeight): 10,000 km.
inline constexpr double kMaxPlausibleHeight = 1e7;

/// Metres per unit of a vertical unit name as GDAL and PROJ spell them ("m", "metre", "ft",
/// "foot", "US survey foot", "ftUS", ...); 0 for a name it does not know.
double metresPerHeightUnit(const std::string& unit);

class FrameDem;

/// Writes flat ground (height 0) covering a longitude/latitude box — a square around it with a
/// margin of a tenth of its size (at least 100 m) — as a GeoTIFF in the UTM zone of its centre,
/// 257 posts a side:
/// the terrain under vector data opened without a DEM. `path` may be a /vsimem/ file.
Result<std::string> writeFlatDem(const std::string& path, const std::array<double, 4>& lonLatBox);

/// The tiles of a DEM, opened and grouped: tiles of one CRS, resolution, height unit and nodata
/// value form one mosaic (a GDAL VRT); groups of different CRSs or resolutions are kept apart and
/// the finest wins where they overlap.
class DemSource {
 public:
  /// Opens every tile. A tile that cannot be used (unreadable, no georeferencing, no CRS, band
  /// missing) is named in a Warning and left out while others remain; with none left the
  /// problems are Errors. An empty folder is an Error naming it.
  static Result<DemSource> open(const DemSpec& spec);

  DemSource(DemSource&&) noexcept;
  DemSource& operator=(DemSource&&) noexcept;
  ~DemSource();

  [[nodiscard]] const DemSpec& spec() const;
  /// Where the data lie, for SceneFrame::forRaster: the tiles' own CRS and extent when they all
  /// share one CRS, else their extent in WGS 84 longitude/latitude.
  [[nodiscard]] const RasterInfo& extent() const;
  /// The files read, in order.
  [[nodiscard]] const std::vector<std::string>& files() const;
  /// The mosaics (groups of tiles), finest first, with their sizes and CRSs.
  [[nodiscard]] std::vector<RasterInfo> groups() const;
  /// Names the DEM in messages: its one path, or the first path and the tile count.
  [[nodiscard]] const std::string& label() const;
  /// Identity of the DEM as it is now (every file's path, size and modification time, and the
  /// spec), for caches built from it.
  [[nodiscard]] const std::string& fingerprint() const;

 private:
  friend class FrameDem;

  /// Writes flat ground (height 0) covering a longitude/latitude box — a square around it with a
  /// margin of a tenth of its size (at least 100 m) — as a GeoTIFF in the UTM zone of its centre,
  /// 257 posts a side:
  /// the terrain under vector data opened without a DEM. `path` may be a /vsimem/ file.
  Result<std::string> writeFlatDem(const std::string& path, const std::array<double, 4>& lonLatBox);
  struct State;
  explicit DemSource(std::shared_ptr<State> state);
  std::shared_ptr<State> state_;
};

/// A DEM as a north-up grid of posts in the scene frame's CRS. When the DEM is a single raster
/// already in the frame's CRS and north-up, its posts are read as they are; otherwise each post's
/// height is the bilinear interpolation of the four source posts around it, and a post is a hole
/// when any of those four is nodata (a hole is never blended into a height). Heights are metres.
class FrameDem {
 public:
  static Result<FrameDem> open(const DemSource& source, const SceneFrame& frame);

  FrameDem(FrameDem&&) noexcept;
  FrameDem& operator=(FrameDem&&) noexcept;
  ~FrameDem();

  /// The grid: size, geotransform in the frame's projected CRS (not minus the origin), the
  /// frame's CRS, NaN as nodata.
  [[nodiscard]] const RasterInfo& info() const;
  /// False when the posts are the source's own.
  [[nodiscard]] bool resampled() const;
  /// Post spacing in metres.
  [[nodiscard]] double spacing() const;
  /// The source's fingerprint plus the grid's.
  [[nodiscard]] std::string fingerprint() const;

  /// Rows [row0, row0 + rows) of heights into `out` (resized to rows × width): NaN for holes,
  /// +infinity where a source post was infinite or beyond kMaxPlausibleHeight (an undeclared
  /// nodata value). False with a message naming the file on a read error.
  bool read(int row0, int rows, std::vector<float>& out, Diagnostics& diagnostics);

 private:
  struct State;
  explicit FrameDem(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace gis::geo
