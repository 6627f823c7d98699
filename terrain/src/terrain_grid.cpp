#include "terrain/terrain_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <sstream>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace gis::terrain {

Result<TerrainGrid> gridGeometry(const geo::RasterInfo& info, const geo::SceneFrame& frame) {
  const auto& c = info.geoTransform.c;
  auto fail = [&](const std::string& message) {
    return Result<TerrainGrid>::failure({Severity::Error, info.path, "", "", message});
  };
  if (!info.geoTransform.finite()) return fail("the DEM's geotransform has a NaN or infinite value");
  if (c[2] != 0.0 || c[4] != 0.0) return fail("rotated geotransforms are not supported by the terrain quadtree");
  if (!(c[1] > 0.0) || !(c[5] < 0.0)) return fail("the terrain quadtree needs a north-up raster");
  if (info.width < 2 || info.height < 2) return fail("DEM needs at least 2x2 posts");
  const double spanX = c[1] * info.width, spanY = -c[5] * info.height;
  if (!(spanX <= kMaxDemExtent && spanY <= kMaxDemExtent)) {
    std::ostringstream message;
    message << "the DEM spans " << spanX << " x " << spanY
            << " CRS units, more than 1e8 (100,000 km): its geotransform is wrong";
    return fail(message.str());
  }
  // The frame must be the DEM's own CRS: the grid is then regular in the frame.
  Result<geo::CrsTransform> toFrame = frame.transformFrom(info.crsWkt);
  if (!toFrame) {
    Result<TerrainGrid> r;
    r.diagnostics = toFrame.diagnostics;
    return r;
  }
  const glm::dvec2 p0 = info.pixelCentre(0, 0);
  const glm::dvec2 p1 = info.pixelCentre(info.width - 1, info.height - 1);
  const std::optional<glm::dvec2> q0 = toFrame->transform(p0);
  const std::optional<glm::dvec2> q1 = toFrame->transform(p1);
  if (!q0 || !q1 || glm::length(*q0 - p0) > 1e-6 || glm::length(*q1 - p1) > 1e-6) {
    return fail("the DEM's CRS differs from the scene frame's; reproject the DEM first");
  }
  TerrainGrid grid;
  grid.width = info.width;
  grid.height = info.height;
  grid.origin = glm::dvec2(frame.projectedToFrame(glm::dvec3(p0, 0.0)));
  grid.step = glm::dvec2(c[1], c[5]);
  Result<TerrainGrid> r;
  r.value = std::move(grid);
  return r;
}

std::size_t implausibleHeightsToNodata(std::span<float> heights) {
  std::size_t changed = 0;
  for (float& h : heights) {
    // NaN is nodata already; ±inf and |h| > kMaxPostHeight fail the test.
    if (!std::isnan(h) && !(std::abs(h) <= kMaxPostHeight)) {
      h = std::numeric_limits<float>::quiet_NaN();
      ++changed;
    }
  }
  return changed;
}

Diagnostic implausibleHeightsWarning(const std::string& path, std::size_t count) {
  return {Severity::Warning, path, "", "",
          std::to_string(count) + " post" + (count == 1 ? " has" : "s have") +
              " an infinite height or one beyond ±10,000 km (an undeclared nodata value, or a wrong unit?): " +
              (count == 1 ? "it is" : "they are") + " left as holes"};
}

namespace {

void checkHeights(const std::string& path, Result<TerrainGrid>& r) {
  const std::size_t changed = implausibleHeightsToNodata(r->heights);
  if (changed > 0) r.diagnostics.add(implausibleHeightsWarning(path, changed));
}

}  // namespace

Result<TerrainGrid> gridFromRaster(const geo::Raster& dem, const geo::SceneFrame& frame) {
  Result<TerrainGrid> r = gridGeometry(dem.info, frame);
  if (!r) return r;
  r->heights.resize(static_cast<std::size_t>(r->width) * static_cast<std::size_t>(r->height));
  const std::size_t stride = dem.bands.size();
  for (std::size_t i = 0; i < r->heights.size(); ++i) r->heights[i] = dem.samples[i * stride];
  checkHeights(dem.info.path, r);
  return r;
}

Result<TerrainGrid> gridFromRaster(geo::Raster&& dem, const geo::SceneFrame& frame) {
  if (dem.bands.size() != 1) return gridFromRaster(static_cast<const geo::Raster&>(dem), frame);
  Result<TerrainGrid> r = gridGeometry(dem.info, frame);
  if (!r) return r;
  r->heights = std::move(dem.samples);
  checkHeights(dem.info.path, r);
  return r;
}

Result<TerrainGrid> gridFromDem(geo::FrameDem& dem, const geo::SceneFrame& frame) {
  Result<TerrainGrid> r = gridGeometry(dem.info(), frame);
  if (!r) return r;
  const std::size_t width = static_cast<std::size_t>(r->width);
  try {
    r->heights.resize(width * static_cast<std::size_t>(r->height));
  } catch (const std::bad_alloc&) {
    return Result<TerrainGrid>::failure({Severity::Error, dem.info().path, "", "",
                                         "not enough memory for the DEM's posts (page it: paging \"always\")"});
  }
  // Strips of about 16 M posts bound the source window read at once.
  const int strip = std::max(1, static_cast<int>((std::size_t{16} << 20) / width));
  std::vector<float> rows;
  for (int r0 = 0; r0 < r->height; r0 += strip) {
    const int count = std::min(strip, r->height - r0);
    if (!dem.read(r0, count, rows, r.diagnostics)) {
      Result<TerrainGrid> failed;
      failed.diagnostics = std::move(r.diagnostics);
      return failed;
    }
    std::copy(rows.begin(), rows.end(),
              r->heights.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(r0) * width));
  }
  checkHeights(dem.info().path, r);
  return r;
}

}  // namespace gis::terrain
