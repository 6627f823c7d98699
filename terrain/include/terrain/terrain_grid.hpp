#pragma once
// The DEM as a regular grid of posts in the scene frame: post (c, r) stands at
// origin + (c·step.x, r·step.y) (step.y < 0 for north-up rasters); heights are unexaggerated
// metres, NaN where the DEM has nodata.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "geo/dem_source.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"

namespace gis::terrain {

struct TerrainGrid {
  int width = 0;
  int height = 0;
  glm::dvec2 origin{0.0};  ///< frame coordinates of post (0, 0)
  glm::dvec2 step{1.0, -1.0};
  std::vector<float> heights;  ///< row-major, row 0 first

  [[nodiscard]] float at(int col, int row) const {
    return heights[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col)];
  }
  [[nodiscard]] glm::dvec2 postPosition(double col, double row) const { return origin + glm::dvec2(col, row) * step; }
  /// Continuous post coordinates (col, row) of a frame point.
  [[nodiscard]] glm::dvec2 gridCoordinates(const glm::dvec2& frameXy) const { return (frameXy - origin) / step; }
};

/// Checks that a DEM fits the frame (below) and returns its grid without heights. Fails, naming
/// the file, on a geotransform that is not finite, rotated or not north-up, on fewer than 2 × 2
/// posts, and on an extent beyond kMaxDemExtent.
Result<TerrainGrid> gridGeometry(const geo::RasterInfo& dem, const geo::SceneFrame& frame);

/// The widest DEM, in CRS units (metres): 100,000 km, more than twice around the Earth. A wider
/// one has a wrong geotransform, and its frame coordinates would leave the ±1e15 m the overlay
/// accepts.
inline constexpr double kMaxDemExtent = 1e8;

/// The largest |height| a post may have: 10,000 km. Beyond it (or infinite) a sample is not a
/// height but an undeclared nodata value (−3.4e38 is common) or a wrong unit, and would break
/// the bounds and the float arithmetic of the renderer.
inline constexpr float kMaxPostHeight = static_cast<float>(geo::kMaxPlausibleHeight);

/// Makes every non-finite or implausible (|h| > kMaxPostHeight) sample NaN, that is nodata;
/// returns how many it changed.
std::size_t implausibleHeightsToNodata(std::span<float> heights);

/// The Warning for `count` implausible samples of the DEM `path` (implausibleHeightsToNodata).
Diagnostic implausibleHeightsWarning(const std::string& path, std::size_t count);

/// The grid of a DEM whose CRS is the frame's and whose geotransform is north-up without
/// rotation (the case of a frame made by SceneFrame::forRaster from a projected DEM).
/// Fails with a message otherwise. Implausible samples become nodata, with a Warning.
Result<TerrainGrid> gridFromRaster(const geo::Raster& dem, const geo::SceneFrame& frame);
/// The same, taking over the samples of a one-band raster instead of copying them (a DEM of
/// 16385² posts is 1 GiB of floats).
Result<TerrainGrid> gridFromRaster(geo::Raster&& dem, const geo::SceneFrame& frame);

/// The grid of a DEM in any CRS, tiled or not (geo::FrameDem: resampled once into the frame
/// when it is not already a north-up grid in the frame's CRS), read in strips of rows.
/// Implausible samples become nodata, with a Warning naming `dem`'s files.
Result<TerrainGrid> gridFromDem(geo::FrameDem& dem, const geo::SceneFrame& frame);

}  // namespace gis::terrain
