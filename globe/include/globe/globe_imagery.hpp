#pragma once
// Imagery on the globe's terrain (docs/globe.md, "Imagery"): a raster in any CRS GDAL knows
// (Landsat in UTM, an orthophoto in a national grid, ...), warped once into WGS 84
// longitude/latitude (a GDAL warped VRT, bilinear, opened once) and read per terrain tile into
// the tile's longitude/latitude box (RasterIO, bilinear): the texels a tile's posts (i, j) sample
// at texture coordinates (i, j) / 32. Reading needs no GL; GlobeTerrain uploads and caches the
// textures with its meshes.
#include <cstdint>
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

 private:
  struct State;
  explicit GlobeImagery(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace gis::globe
