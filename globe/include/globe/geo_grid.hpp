#pragma once
// Heights on the globe (docs/globe.md): a grid of posts in longitude and latitude, heights in
// metres above the ellipsoid, read bilinearly. What the globe's terrain samples its tiles from
// and what the overlay's height bounds are taken from (the bounds contract in ellipsoidal
// heights).
#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/dem_source.hpp"
#include "globe/tile.hpp"

namespace gis::globe {

/// What a DEM's heights are measured from (docs/globe.md, "Heights above the ellipsoid"). The
/// globe draws heights above the WGS 84 ellipsoid; a DEM of geoid (orthometric) heights H is
/// converted post by post to h = H + N(lon, lat) by PROJ, with the geoid grid of proj-data.
/// Auto: the DEM's vertical CRS when its CRS is compound (or ellipsoidal heights for a 3D
/// geographic CRS), otherwise EGM96 (SRTM, Copernicus and most lon/lat DEMs hold geoid
/// heights), said in an Info diagnostic.
enum class VerticalDatum { Auto, Ellipsoid, Egm96, Egm2008 };

/// "auto", "ellipsoid", "egm96", "egm2008" (as the scene file spells them); nullopt otherwise.
std::optional<VerticalDatum> parseVerticalDatum(const std::string& text);

/// Whether a GeoGrid holds its heights in memory or pages them from a file in the cache.
enum class GridPaging { Auto, Always, Never };

struct GeoGridReadOptions {
  VerticalDatum vertical = VerticalDatum::Auto;
  /// Auto: paged when the DEM would take more than memoryBudgetMb in memory (about 20 bytes a
  /// post); Never: such a DEM is refused (an error, nothing allocated); Always: paged.
  GridPaging paging = GridPaging::Auto;
  double memoryBudgetMb = 0.0;  ///< 0: no limit
  /// A paged grid: the directory its file goes in (made once, reused while the DEM and these
  /// options are the same), asked for only when the grid is paged (null: the working directory),
  /// and how much of the budget its cached blocks may take (0: a third of memoryBudgetMb, at
  /// least 16 MB).
  std::function<std::string()> cacheDir;
  double pageBudgetMb = 0.0;
  int blockPosts = 256;  ///< a paged grid's blocks, posts a side (a power of two, 16 … 4096)
  /// The scene file, named in the memory error.
  std::string sceneFile;
};

class GeoGrid {
 public:
  /// `heights` row-major, row 0 at `north`; post (c, r) at (west + c · step, north − r · step).
  /// A grid whose columns span 360° (width · step ≥ 360) wraps around in longitude. Elsewhere
  /// outside the grid the height is 0 (the ellipsoid).
  GeoGrid(int width, int height, double west, double north, double step, std::vector<float> heights);

  /// A DEM as the projected path reads it (geo::DemSpec: one file, several, folders of tiles, a
  /// VRT; the CRS and height-unit overrides; the band), in any CRS GDAL knows, warped (bilinear,
  /// nodata kept out of heights) onto one north-up grid in WGS 84 longitude/latitude at the
  /// sources' finest resolution, then converted to heights above the ellipsoid as
  /// `options.vertical` says. Read whole, or (options.paging) written once block by block into a
  /// file in options.cacheDir and paged from it: blocks are read when heightAt or bounds need
  /// them and the least recently used go beyond the page budget; a min/max pyramid over the
  /// blocks stays in memory. A paged grid's heights, bounds and poles are those of the grid read
  /// whole, bit for bit.
  static Result<GeoGrid> fromDem(const geo::DemSpec& spec, const GeoGridReadOptions& options = {});

  /// What the heights were converted from, for messages and stats ("ellipsoid", "EGM96 ...").
  [[nodiscard]] const std::string& verticalSource() const { return base_ ? base_->verticalSource() : verticalSource_; }

  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }
  [[nodiscard]] double west() const { return west_; }
  [[nodiscard]] double north() const { return north_; }
  [[nodiscard]] double step() const { return step_; }
  [[nodiscard]] bool wraps() const { return wraps_; }
  /// The posts, row-major, as read (not exaggerated; empty for a paged grid).
  [[nodiscard]] const std::vector<float>& heights() const { return base_ ? base_->heights() : heights_; }
  [[nodiscard]] bool paged() const { return base_ ? base_->paged() : paged_ != nullptr; }
  /// Bytes of heights and bounds held in memory now (a paged grid: its cached blocks and the
  /// pyramid over them).
  [[nodiscard]] std::size_t residentBytes() const;
  /// A paged grid: blocks read from its file so far, and whether the file was made by this read
  /// (false: found in the cache).
  [[nodiscard]] std::size_t blocksRead() const;
  /// A paged grid: posts read one by one from its file. A block is read whole only once its posts
  /// have been asked for 64 times while it was not cached; until then each post heightAt needs is
  /// read alone. So a far view, whose tiles take a few posts from each of many blocks, reads
  /// about its tiles' posts, not the DEM; a near view reads the few blocks it needs.
  [[nodiscard]] std::size_t postsRead() const;
  [[nodiscard]] bool pageFileMade() const;
  /// A paged grid: blocks found damaged in its file and read again from the DEM (each verified
  /// against its checksum before any of its posts is used; docs/cache.md).
  [[nodiscard]] std::size_t blocksRepaired() const;

  /// Bilinear height at (lon, lat), degrees. A pure function of its arguments: the same post
  /// coordinates give the same height in every tile.
  [[nodiscard]] double heightAt(double lonDeg, double latDeg) const;
  /// A digest of what the grid holds (its posts, size and place), for caches of what is built
  /// from it; none for a paged grid (its posts are not all at hand).
  [[nodiscard]] std::optional<std::uint64_t> contentDigest() const;
  /// The least and greatest height heightAt can return anywhere in the box (any longitudes,
  /// unwrapped ones too): from a min/max pyramid over the posts it may read. Conservative.
  [[nodiscard]] std::pair<double, double> bounds(const LonLatRect& box) const;

  /// The vertical exaggeration of the globe (docs/globe.md, "Vertical exaggeration"): `grid`'s
  /// heights times `factor` (> 0 and finite; else, or 1, `grid` itself), sharing its posts.
  /// Everything the globe reads heights from (its terrain, the overlay's height bounds, the
  /// anchors of lines in pixels, the camera's ground) then sees the exaggerated surface, each
  /// point s + h·n of the ellipsoid moved to s + factor·h·n along its normal, so longitude and
  /// latitude, and with them what a layer covers, stay as they are.
  static std::shared_ptr<const GeoGrid> exaggerated(std::shared_ptr<const GeoGrid> grid, double factor);
  /// The factor heights are multiplied by (1: as read), and the grid as read.
  [[nodiscard]] double exaggeration() const { return base_ ? exaggeration_ : 1.0; }
  [[nodiscard]] const GeoGrid& unexaggerated() const { return base_ ? *base_ : *this; }

  /// A paged grid's storage (geo_grid.cpp).
  struct Paged;

 private:
  /// `base` exaggerated by `factor` (exaggerated()): its place, none of its posts.
  GeoGrid(std::shared_ptr<const GeoGrid> base, double factor);
  /// A paged grid over `paged` (its poles and block pyramid read with it).
  GeoGrid(int width, int height, double west, double north, double step, std::shared_ptr<const Paged> paged);
  void buildPyramid();
  [[nodiscard]] double post(int c, int r) const;
  /// Min/max over post columns [c0, c1] (may exceed the grid: wrapped or 0) and rows [r0, r1].
  [[nodiscard]] std::pair<double, double> postRange(long c0, long c1, long r0, long r1) const;

  int width_ = 0, height_ = 0;
  double west_ = 0.0, north_ = 0.0, step_ = 1.0;
  bool wraps_ = false;
  std::vector<float> heights_;
  std::string verticalSource_ = "ellipsoid";
  std::array<double, 2> poleHeight_{0.0, 0.0};  ///< north, south
  /// Level k: blocks of 2^k × 2^k posts, (min, max) each, row-major.
  std::vector<std::vector<std::pair<float, float>>> pyramid_;
  std::vector<std::pair<int, int>> pyramidSize_;
  std::shared_ptr<const Paged> paged_;  ///< null: heights_ and pyramid_ hold everything
  /// An exaggerated grid: the grid it reads (its heights times exaggeration_); null otherwise.
  std::shared_ptr<const GeoGrid> base_;
  double exaggeration_ = 1.0;
};

}  // namespace gis::globe
