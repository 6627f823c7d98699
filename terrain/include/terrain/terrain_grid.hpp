#pragma once
// The DEM as a regular grid of posts in the scene frame: post (c, r) stands at
// origin + (c·step.x, r·step.y) (step.y < 0 for north-up rasters); heights are unexaggerated
// metres, NaN where the DEM has nodata.
#include <cstddef>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
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

/// Checks that a DEM fits the frame (below) and returns its grid without heights.
Result<TerrainGrid> gridGeometry(const geo::RasterInfo& dem, const geo::SceneFrame& frame);

/// The grid of a DEM whose CRS is the frame's and whose geotransform is north-up without
/// rotation (the case of a frame made by SceneFrame::forRaster from a projected DEM).
/// Fails with a message otherwise.
Result<TerrainGrid> gridFromRaster(const geo::Raster& dem, const geo::SceneFrame& frame);
/// The same, taking over the samples of a one-band raster instead of copying them (a DEM of
/// 16385² posts is 1 GiB of floats).
Result<TerrainGrid> gridFromRaster(geo::Raster&& dem, const geo::SceneFrame& frame);

}  // namespace gis::terrain
