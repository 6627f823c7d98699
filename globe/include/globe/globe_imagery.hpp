#pragma once
// Imagery on the globe's terrain (docs/globe.md, "Imagery"): a raster in any CRS GDAL knows
// (Landsat in UTM, an orthophoto in a national grid, ...), warped once into WGS 84
// longitude/latitude (a GDAL warped VRT, bilinear, opened once) and read per terrain tile into
// the tile's longitude/latitude box (RasterIO, bilinear): the texels a tile's posts (i, j) sample
// at texture coordinates (i, j) / 32. A coarse tile reads an overview level warped the same way
// (the source's own overviews, or ones built once into the cache), so what a tile costs follows
// its texels, not the imagery's size. Reading needs no GL; GlobeTerrain uploads and caches the
// textures with its meshes.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "globe/tile.hpp"

namespace gis::globe {

struct ImageryOptions {
  /// Per-band linear stretch between these percentiles of the valid samples, as the projected
  /// frame's orthophoto (terrain::StretchOptions): 0 and 100 keep the samples' full range.
  double lowPercentile = 2.0;
  double highPercentile = 98.0;
  int maxTexels = 256;  ///< a tile's texture is at most this many texels a side
  int minTexels = 32;   ///< ... and at least this many
  /// A tile whose texels are coarser than the imagery reads the overview level whose cell is the
  /// largest not coarser than a texel; false: every tile reads the full resolution (comparisons).
  bool overviews = true;
  /// Imagery without overviews of its own more than this many cells wide or high gets them built
  /// once (a VRT of the chosen bands and its .ovr, averaged) in cacheDir, reused while the file
  /// (path, size, time) and the bands are the same.
  int buildOverviewsAbove = 4096;
  /// The directory those overviews go in, asked for only when they are needed (null: none are
  /// built, and such imagery is read at full resolution from afar too).
  std::function<std::string()> cacheDir;
};

/// Where a GlobeImagery's overview levels come from.
enum class ImageryOverviews {
  None,    ///< full resolution only (small imagery, overviews off, or no cache directory)
  Source,  ///< the source's own (GTiff internal or .ovr)
  Built,   ///< built by this open into the cache directory
  Cached,  ///< built by an earlier run, found in the cache directory
};

/// A tile's texels: RGBA8, `size` × `size`, row 0 along the tile's south side, column 0 along its
/// west side; texel (c, r) is the imagery at the centre of that cell of the tile's box. Alpha is
/// the imagery's coverage there (0 outside it or on its nodata).
struct TileImage {
  int size = 0;
  std::vector<std::uint8_t> rgba;
};

class GlobeImagery {
 public:
  /// Opens the imagery's bands (1 = grey, or 3 = red, green, blue; 1-based numbers). Errors name
  /// the file.
  static Result<std::shared_ptr<GlobeImagery>> open(const std::string& path, const std::vector<int>& bands,
                                                    const ImageryOptions& options = {});
  ~GlobeImagery();
  GlobeImagery(const GlobeImagery&) = delete;
  GlobeImagery& operator=(const GlobeImagery&) = delete;

  [[nodiscard]] const std::string& path() const;
  /// Where the imagery lies in longitude/latitude (the warped grid's box).
  [[nodiscard]] const LonLatRect& box() const;
  /// The warped grid's cell size, degrees.
  [[nodiscard]] double step() const;
  /// Texels a side for a tile: about two per imagery cell across it, a power of two within
  /// [minTexels, maxTexels].
  [[nodiscard]] int textureSize(const TileKey& key) const;
  /// Whether the tile's box meets the imagery's.
  [[nodiscard]] bool covers(const TileKey& key) const;
  /// The tile's texels; nullopt where the imagery does not reach the tile (or a read failed).
  /// Thread-safe: the one GDAL dataset is read under a lock.
  [[nodiscard]] std::optional<TileImage> tileImage(const TileKey& key) const;

  /// Where the overview levels come from, how many there are beyond the full resolution, and the
  /// cache's VRT (empty unless Built or Cached).
  [[nodiscard]] ImageryOverviews overviews() const;
  [[nodiscard]] int overviewLevels() const;
  [[nodiscard]] const std::string& overviewFile() const;
  /// The level a tile reads: 0 the full resolution, k the k-th overview.
  [[nodiscard]] int levelFor(const TileKey& key) const;
  /// Source pixels the warps have read for tiles so far (the cells read from every chosen band,
  /// over their number): about a far tile's texels, not the imagery's size.
  [[nodiscard]] std::uint64_t sourcePixelsRead() const;

 private:
  struct State;
  explicit GlobeImagery(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace gis::globe
