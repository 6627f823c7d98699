#pragma once
// A DEM pre-built into a tiled pyramid on disk, for DEMs larger than the memory budget.
//
// One file holds, for every quadtree node with data, its tile: the (N + 1)² posts of its level
// (every 2^l-th full-resolution post), plus the node table (min/max/geometric error, exactly as
// TerrainQuadtree computes them in memory) and the height ranges of the cells of the pinned level
// (the coarsest levels, always in memory), which the height bounds use below that level. The
// builder streams the DEM in strips of rows, so building needs a few tens of MB whatever the
// DEM's size. The file names its source (path, size, modification time, band) and is rebuilt
// when that changes.
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/dem_source.hpp"
#include "geo/frame.hpp"
#include "terrain/quadtree.hpp"
#include "terrain/terrain_grid.hpp"

namespace gis::terrain {

/// What a pyramid was built from; a pyramid is reused only for the same source.
struct PyramidSource {
  geo::DemSpec dem;     ///< the DEM's files and how they are read (any CRS, mosaics: geo::DemSource)
  std::string demPath;  ///< names the DEM: the absolute path of one file, or a DemSource's label
  int band = 1;
  std::uint64_t bytes = 0;      ///< of all its files
  std::int64_t modifiedNs = 0;  ///< one file: its modification time; several: a hash of the fingerprint
  int chunkCells = TerrainQuadtree::kDefaultChunkCells;
  int pinnedTilesPerSide = 32;  ///< the pinned level is the finest with at most this many tiles a side

  /// The identity of one DEM file as it is now (size and modification time); fails if it cannot
  /// be read.
  static Result<PyramidSource> of(const std::string& demPath, int band,
                                  int chunkCells = TerrainQuadtree::kDefaultChunkCells);
  /// The identity of an opened DEM (its files, sizes, times and how it is read).
  static PyramidSource of(const geo::DemSource& dem, int chunkCells = TerrainQuadtree::kDefaultChunkCells);
};

struct PyramidBuildStats {
  double seconds = 0.0;
  std::uint64_t fileBytes = 0;
  std::size_t tiles = 0;
};

/// Called with the fraction done (0 … 1) while building.
using PyramidProgress = std::function<void(double fraction)>;

/// Builds the pyramid of `source` into `path` (written to a temporary file beside it and renamed
/// when complete, so a crash never leaves a half-built pyramid that looks valid). The DEM is read
/// in the frame (geo::FrameDem: resampled once when its CRS or grid is not the frame's).
Result<PyramidBuildStats> buildTilePyramid(const PyramidSource& source, const geo::SceneFrame& frame,
                                           const std::string& path, const PyramidProgress& progress = {});
/// The same from a DEM already opened in the frame.
Result<PyramidBuildStats> buildTilePyramid(geo::FrameDem& dem, const PyramidSource& source,
                                           const geo::SceneFrame& frame, const std::string& path,
                                           const PyramidProgress& progress = {});

class TilePyramidFile {
 public:
  /// Opens a pyramid; fails with the reason (missing, truncated, older format, other source) so
  /// that the caller can rebuild it.
  static Result<std::shared_ptr<const TilePyramidFile>> open(const std::string& path, const PyramidSource& expected);
  ~TilePyramidFile();
  TilePyramidFile(const TilePyramidFile&) = delete;
  TilePyramidFile& operator=(const TilePyramidFile&) = delete;

  /// The DEM's grid without heights.
  [[nodiscard]] const TerrainGrid& geometry() const { return geometry_; }
  [[nodiscard]] int chunkCells() const { return chunkCells_; }
  [[nodiscard]] int rootLevel() const { return rootLevel_; }
  /// Levels at or above this one are small enough to stay in memory.
  [[nodiscard]] int pinnedLevel() const { return pinnedLevel_; }
  /// Node table in TerrainQuadtree's order (level 0 first, row-major within a level).
  [[nodiscard]] const std::vector<NodeInfo>& nodes() const { return nodes_; }
  [[nodiscard]] std::size_t nodeIndex(const NodeId& n) const;
  [[nodiscard]] bool hasTile(const NodeId& n) const { return tileOffsets_[nodeIndex(n)] != 0; }
  /// Posts per tile: (N + 1)².
  [[nodiscard]] std::size_t tilePosts() const {
    return static_cast<std::size_t>(chunkCells_ + 1) * static_cast<std::size_t>(chunkCells_ + 1);
  }
  /// Reads a node's tile (row-major (N + 1)² heights, NaN at nodata), verified against its
  /// checksum. Thread-safe. A tile that is damaged makes the pyramid rebuild itself (setRebuild)
  /// once, with a warning, and is read from the new file; without a rebuild, or if that fails,
  /// an error and false.
  bool readTile(const NodeId& n, std::span<float> out, Diagnostics& diagnostics) const;
  /// How to build this pyramid's file again from its DEM (the loader's buildTilePyramid), for a
  /// damaged tile found while reading.
  void setRebuild(std::function<bool()> rebuild) const;

  /// Height ranges of the cells of the pinned level (2^pinnedLevel posts a side, closed: a
  /// cell includes the posts on its border), row-major; lo > hi for cells without data.
  [[nodiscard]] int cellRangeWidth() const { return cellRangeWidth_; }
  [[nodiscard]] int cellRangeHeight() const { return cellRangeHeight_; }
  [[nodiscard]] const std::vector<float>& cellLo() const { return cellLo_; }
  [[nodiscard]] const std::vector<float>& cellHi() const { return cellHi_; }

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::uint64_t fileBytes() const { return fileBytes_; }
  /// Nodata posts of the DEM (holes; not counting the padding to a power of two).
  [[nodiscard]] std::uint64_t nodataPosts() const { return nodataPosts_; }
  /// Of those, the samples that were infinite or implausible (implausibleHeightsToNodata).
  [[nodiscard]] std::uint64_t implausiblePosts() const { return implausiblePosts_; }

 private:
  TilePyramidFile() = default;
  std::string path_;
  int fd_ = -1;
  std::uint64_t fileBytes_ = 0;
  std::uint64_t nodataPosts_ = 0;
  std::uint64_t implausiblePosts_ = 0;
  TerrainGrid geometry_;
  int chunkCells_ = 0, rootLevel_ = 0, pinnedLevel_ = 0;
  std::vector<std::size_t> levelOffset_;
  std::vector<NodeInfo> nodes_;
  std::vector<std::uint64_t> tileOffsets_;  ///< 0 = no tile (no data)
  std::vector<std::uint64_t> tileDigests_;
  PyramidSource source_;
  mutable std::mutex rebuildMutex_;
  mutable std::function<bool()> rebuild_;
  mutable int rebuilds_ = 0;
  int cellRangeWidth_ = 0, cellRangeHeight_ = 0;
  std::vector<float> cellLo_, cellHi_;
};

/// Root level of a quadtree of N-cell chunks over a grid (as TerrainQuadtree computes it).
int quadtreeRootLevel(int width, int height, int chunkCells);
/// The pinned level for a root level: the finest with at most `tilesPerSide` tiles a side.
int pinnedLevelFor(int rootLevel, int tilesPerSide);

}  // namespace gis::terrain
