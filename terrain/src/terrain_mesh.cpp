#include "terrain/terrain_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

namespace gis::terrain {
namespace {

std::size_t postIndex(int col, int row, int width) {
  return static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col);
}

}  // namespace

Result<TerrainMesh> buildFullResolutionMesh(const geo::Raster& dem, const geo::SceneFrame& frame,
                                            const MeshOptions& options) {
  const geo::RasterInfo& info = dem.info;
  const int w = info.width;
  const int h = info.height;
  if (w < 2 || h < 2) {
    return Result<TerrainMesh>::failure({Severity::Error, info.path, "", "", "DEM needs at least 2x2 posts"});
  }
  Result<geo::CrsTransform> toFrame = frame.transformFrom(info.crsWkt);
  if (!toFrame) {
    Result<TerrainMesh> r;
    r.diagnostics = toFrame.diagnostics;
    return r;
  }

  // Post positions in the frame (double), NaN height where the DEM has nodata.
  const std::size_t postCount = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  std::vector<glm::dvec2> xy(postCount);
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) xy[postIndex(col, row, w)] = info.pixelCentre(col, row);
  }
  toFrame->transform(xy.data(), xy.size());

  TerrainMesh mesh;
  std::vector<glm::dvec3> posts(postCount);
  double minH = std::numeric_limits<double>::infinity();
  double maxH = -minH;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < postCount; ++i) {
    const double z = static_cast<double>(dem.samples[i * dem.bands.size()]) * options.verticalExaggeration;
    const glm::dvec3 p = frame.projectedToFrame(glm::dvec3(xy[i], 0.0));
    posts[i] = glm::dvec3(p.x, p.y, z);
    if (!std::isfinite(z) || !std::isfinite(p.x) || !std::isfinite(p.y)) {
      posts[i].z = std::numeric_limits<double>::quiet_NaN();
      ++mesh.skippedNodataPosts;
      continue;
    }
    minH = std::min(minH, z);
    maxH = std::max(maxH, z);
    lo = glm::min(lo, glm::dvec2(p));
    hi = glm::max(hi, glm::dvec2(p));
  }
  if (!std::isfinite(minH)) {
    return Result<TerrainMesh>::failure({Severity::Error, info.path, "", "", "DEM holds no valid sample"});
  }
  mesh.minHeight = minH;
  mesh.maxHeight = maxH;
  mesh.frameMin = lo;
  mesh.frameMax = hi;
  mesh.centre = glm::dvec3((lo + hi) * 0.5, (minH + maxH) * 0.5);

  auto post = [&](int col, int row) -> const glm::dvec3& {
    return posts[postIndex(std::clamp(col, 0, w - 1), std::clamp(row, 0, h - 1), w)];
  };
  mesh.vertices.resize(postCount);
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      const glm::dvec3& p = post(col, row);
      // Central differences; a nodata neighbour falls back to the post itself.
      auto valid = [&](const glm::dvec3& q) { return std::isfinite(q.z) ? q : p; };
      const glm::dvec3 dx = valid(post(col + 1, row)) - valid(post(col - 1, row));
      const glm::dvec3 dy = valid(post(col, row - 1)) - valid(post(col, row + 1));
      glm::dvec3 n = glm::cross(dx, dy);
      n = glm::length(n) > 0.0 ? glm::normalize(n) : glm::dvec3(0.0, 0.0, 1.0);
      if (n.z < 0.0) n = -n;
      TerrainVertex& v = mesh.vertices[postIndex(col, row, w)];
      v.position = glm::vec3(std::isfinite(p.z) ? p - mesh.centre : glm::dvec3(p.x, p.y, 0.0) - mesh.centre);
      v.normal = glm::vec3(n);
      v.imageryUv = glm::vec2(-1.0F);
    }
  }

  // Winding: counter-clockwise seen from above whatever the geotransform's orientation.
  const auto& c = info.geoTransform.c;
  const bool northUp = c[1] * c[5] - c[2] * c[4] < 0.0;
  mesh.indices.reserve(static_cast<std::size_t>(w - 1) * static_cast<std::size_t>(h - 1) * 6);
  for (int row = 0; row + 1 < h; ++row) {
    for (int col = 0; col + 1 < w; ++col) {
      const auto a = static_cast<std::uint32_t>(postIndex(col, row, w));
      const auto b = static_cast<std::uint32_t>(postIndex(col + 1, row, w));
      const auto d = static_cast<std::uint32_t>(postIndex(col, row + 1, w));
      const auto e = static_cast<std::uint32_t>(postIndex(col + 1, row + 1, w));
      if (!std::isfinite(posts[a].z) || !std::isfinite(posts[b].z) || !std::isfinite(posts[d].z) ||
          !std::isfinite(posts[e].z)) {
        continue;
      }
      const std::uint32_t tri[6] = {a, d, e, a, e, b};
      for (int k = 0; k < 6; ++k) {
        // Mirror each triangle's last two vertices when the grid runs south-up.
        const int src = northUp ? k : (k % 3 == 0 ? k : (k % 3 == 1 ? k + 1 : k - 1));
        mesh.indices.push_back(tri[src]);
      }
    }
  }
  Result<TerrainMesh> result;
  if (mesh.skippedNodataPosts > 0) {
    result.diagnostics.add(
        {Severity::Info, info.path, "", "", std::to_string(mesh.skippedNodataPosts) + " nodata posts left as holes"});
  }
  result.value = std::move(mesh);
  return result;
}

}  // namespace gis::terrain
