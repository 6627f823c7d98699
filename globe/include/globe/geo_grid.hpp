#pragma once
// Heights on the globe (docs/globe.md): a grid of posts in longitude and latitude, heights in
// metres above the ellipsoid, read bilinearly. What the globe's terrain samples its tiles from
// and what the overlay's height bounds are taken from (the bounds contract in ellipsoidal
// heights).
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "core/diagnostics.hpp"
#include "globe/tile.hpp"

namespace gis::globe {

class GeoGrid {
 public:
  /// `heights` row-major, row 0 at `north`; post (c, r) at (west + c · step, north − r · step).
  /// A grid whose columns span 360° (width · step ≥ 360) wraps around in longitude. Elsewhere
  /// outside the grid the height is 0 (the ellipsoid).
  GeoGrid(int width, int height, double west, double north, double step, std::vector<float> heights);

  /// A geographic raster (any CRS GDAL knows; reprojected to WGS 84 lon/lat if needed), heights
  /// taken as above the ellipsoid (docs/globe.md says what that means for geoid heights).
  static Result<GeoGrid> fromRaster(const std::string& path);

  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }
  [[nodiscard]] double west() const { return west_; }
  [[nodiscard]] double north() const { return north_; }
  [[nodiscard]] double step() const { return step_; }
  [[nodiscard]] bool wraps() const { return wraps_; }
  [[nodiscard]] const std::vector<float>& heights() const { return heights_; }

  /// Bilinear height at (lon, lat), degrees. A pure function of its arguments: the same post
  /// coordinates give the same height in every tile.
  [[nodiscard]] double heightAt(double lonDeg, double latDeg) const;
  /// The least and greatest height heightAt can return anywhere in the box (any longitudes,
  /// unwrapped ones too): from a min/max pyramid over the posts it may read. Conservative.
  [[nodiscard]] std::pair<double, double> bounds(const LonLatRect& box) const;

 private:
  void buildPyramid();
  [[nodiscard]] double post(int c, int r) const;
  /// Min/max over post columns [c0, c1] (may exceed the grid: wrapped or 0) and rows [r0, r1].
  [[nodiscard]] std::pair<double, double> postRange(long c0, long c1, long r0, long r1) const;

  int width_ = 0, height_ = 0;
  double west_ = 0.0, north_ = 0.0, step_ = 1.0;
  bool wraps_ = false;
  std::vector<float> heights_;
  std::array<double, 2> poleHeight_{0.0, 0.0};  ///< north, south
  /// Level k: blocks of 2^k × 2^k posts, (min, max) each, row-major.
  std::vector<std::vector<std::pair<float, float>>> pyramid_;
  std::vector<std::pair<int, int>> pyramidSize_;
};

}  // namespace gis::globe
