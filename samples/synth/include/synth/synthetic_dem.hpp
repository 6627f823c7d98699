#pragma once
// Deterministic synthetic DEMs for the terrain engine's stiff cases and the benchmark: fractal
// relief (hash-based gradient-noise fBm) plus vertical cliffs, isolated spikes, perfectly flat
// plains and nodata holes, all placed from the seed at fractions of the size. Every post is
// evaluated on its own, so rasters of any size are written in blocks of rows with little memory.
//
// Post coordinates: post (col, row) is the centre of pixel (col, row); col grows east, row grows
// south, (0, 0) is the top-left post. Feature positions below are in these coordinates.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/diagnostics.hpp"

namespace gis::synth {

/// The nodata value written into the GeoTIFF (readers such as gis::geo::readRaster give NaN).
inline constexpr double kSyntheticNodata = -32768.0;
/// Every valid height lies in this range (Dead Sea shore .. Everest).
inline constexpr double kSyntheticMinHeight = -430.0;
inline constexpr double kSyntheticMaxHeight = 8850.0;

struct SyntheticDemOptions {
  int size = 1025;              ///< posts per side (the raster is size x size), 33 .. 65537
  double spacing = 20.0;        ///< pixel size in CRS units (metres for the default CRS)
  std::uint64_t seed = 1;       ///< same seed (and options) -> identical file
  double reliefMetres = 600.0;  ///< height range of the fractal relief, 0 .. 3000
  bool cliffs = true;
  bool spikes = true;
  bool plains = true;
  bool nodataHoles = true;
  bool nodataBorder = false;                       ///< everything outside an irregular closed boundary is nodata
  std::string crs = "EPSG:32633";                  ///< anything OGR understands; empty = no CRS
  double originX = 500000.0, originY = 5000000.0;  ///< top-left corner of the top-left pixel
};

/// An SRTM-like tile in longitude/latitude (EPSG:4326): 3" posts, the top-left corner at 6°E
/// 50°N — what `terrain_synth --crs EPSG:4326` writes unless told otherwise.
inline constexpr double kGeographicSpacing = 1.0 / 1200.0;
inline constexpr double kGeographicOriginX = 6.0, kGeographicOriginY = 50.0;
inline SyntheticDemOptions geographicDemOptions(int size, std::uint64_t seed) {
  SyntheticDemOptions o;
  o.size = size;
  o.seed = seed;
  o.crs = "EPSG:4326";
  o.spacing = kGeographicSpacing;
  o.originX = kGeographicOriginX;
  o.originY = kGeographicOriginY;
  return o;
}

/// A straight vertical cliff across the whole raster: every post on the high side is raised by
/// `jumpMetres`, so neighbouring posts on both sides differ by at least 300 m.
struct SyntheticCliff {
  double col = 0.0, row = 0.0;              ///< a point on the line
  double normalCol = 1.0, normalRow = 0.0;  ///< unit normal, pointing to the high side
  double jumpMetres = 0.0;
  bool axisAligned = false;  ///< the line lies between two post columns or two post rows
  double startCol = 0.0, startRow = 0.0, endCol = 0.0, endRow = 0.0;  ///< where it meets the raster edge

  [[nodiscard]] double signedDistance(double c, double r) const {
    return (c - col) * normalCol + (r - row) * normalRow;
  }
  [[nodiscard]] bool highSide(int c, int r) const { return signedDistance(c, r) > 0.0; }
};

/// A single post `height` metres high; its 8 neighbours are at most `neighbourMax`, which is at
/// least 500 m lower.
struct SyntheticSpike {
  int col = 0, row = 0;
  float height = 0.0F;
  float neighbourMax = 0.0F;
};

enum class PlainShape { Disc, Rectangle };

/// A region where every post is exactly `height` (a lake, a levelled field); around it the relief
/// blends smoothly into the plain.
struct SyntheticPlain {
  PlainShape shape = PlainShape::Disc;
  double col = 0.0, row = 0.0;               ///< centre
  double radius = 0.0;                       ///< Disc
  double halfWidth = 0.0, halfHeight = 0.0;  ///< Rectangle (columns, rows)
  float height = 0.0F;
  std::size_t posts = 0;  ///< posts inside (filled in by writeSyntheticDem)

  [[nodiscard]] bool contains(int c, int r) const {
    const double dc = c - col, dr = r - row;
    if (shape == PlainShape::Disc) return dc * dc + dr * dr <= radius * radius;
    return (dc < 0 ? -dc : dc) <= halfWidth && (dr < 0 ? -dr : dr) <= halfHeight;
  }
};

/// A nodata region with an irregular edge around (col, row): every post within `innerRadius` is
/// nodata, no post beyond `outerRadius` belongs to it.
struct SyntheticHole {
  double col = 0.0, row = 0.0;
  double innerRadius = 0.0, outerRadius = 0.0;
  std::size_t posts = 0;  ///< nodata posts of this hole (filled in by writeSyntheticDem)
};

/// With nodataBorder: the data lies inside an irregular closed boundary around (col, row);
/// every post within `innerRadius` is inside, every post beyond `outerRadius` is nodata (this
/// includes the outer rows and columns of the raster).
struct SyntheticBorder {
  bool enabled = false;
  double col = 0.0, row = 0.0;
  double innerRadius = 0.0, outerRadius = 0.0;
  std::size_t posts = 0;  ///< nodata posts outside the boundary (filled in by writeSyntheticDem)
};

/// What was placed where, and what was written.
struct SyntheticDemSummary {
  std::string path;
  int size = 0;
  double spacing = 0.0;
  std::uint64_t seed = 0;
  std::string crs;
  std::array<double, 6> geoTransform{};  ///< GDAL order; pixel size = spacing, north up
  double nodata = kSyntheticNodata;

  std::vector<SyntheticCliff> cliffs;
  std::vector<SyntheticSpike> spikes;
  std::vector<SyntheticPlain> plains;
  std::vector<SyntheticHole> holes;
  SyntheticBorder border;

  // Filled in by writeSyntheticDem:
  std::size_t validPosts = 0;
  std::size_t nodataPosts = 0;
  double minHeight = 0.0;  ///< of the valid posts, as stored (Float32)
  double maxHeight = 0.0;

  /// CRS coordinates of post (col, row), i.e. of the centre of that pixel.
  [[nodiscard]] std::array<double, 2> postToCrs(double col, double row) const {
    return {geoTransform[0] + (col + 0.5) * geoTransform[1], geoTransform[3] + (row + 0.5) * geoTransform[5]};
  }
};

/// Empty when the options are usable, else what is wrong with them (e.g. "size must be ...").
std::string checkSyntheticDemOptions(const SyntheticDemOptions& options);

/// True when `crs` (OGR user input) is a geographic (longitude/latitude) CRS.
bool isGeographicCrs(const std::string& crs);

/// The terrain as a function of the post: plans the features from the seed, then gives any
/// post's height without generating the others. writeSyntheticDem stores exactly these values.
class SyntheticTerrain {
 public:
  /// Fails (no value, one error) on options checkSyntheticDemOptions rejects.
  static Result<SyntheticTerrain> create(const SyntheticDemOptions& options);

  /// Height of post (col, row) in metres; NaN for nodata. Thread-safe.
  [[nodiscard]] float heightAt(int col, int row) const;
  /// Placed features (post counts and heights are left at zero; see writeSyntheticDem).
  [[nodiscard]] const SyntheticDemSummary& layout() const;
  [[nodiscard]] const SyntheticDemOptions& options() const;

  struct Model;

 private:
  explicit SyntheticTerrain(std::shared_ptr<const Model> model) : model_(std::move(model)) {}
  std::shared_ptr<const Model> model_;
};

/// Writes the DEM as a single-band Float32 GeoTIFF (tiled 256 x 256, DEFLATE with the floating
/// point predictor, BigTIFF when needed, nodata -32768) in blocks of rows, calling `progress`
/// with the fraction done (0 .. 1) after each block. Errors name the file; a partly written file
/// is removed.
Result<SyntheticDemSummary> writeSyntheticDem(const std::string& path, const SyntheticDemOptions& options,
                                              const std::function<void(double)>& progress = {});

}  // namespace gis::synth
