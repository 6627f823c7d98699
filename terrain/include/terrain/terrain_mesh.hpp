#pragma once
// The DEM as a triangle mesh in the scene frame. For now one full-resolution mesh (the quadtree
// of chunks replaces it in the terrain-engine issue); vertices are float relative to the mesh
// centre, the centre itself is double.
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"

namespace gis::terrain {

struct TerrainVertex {
  glm::vec3 position;  ///< relative to TerrainMesh::centre, metres
  glm::vec3 normal;
  glm::vec2 imageryUv;  ///< into the orthophoto; outside [0,1] where the imagery has no data
};

struct TerrainMesh {
  glm::dvec3 centre{0.0};  ///< frame coordinates
  std::vector<TerrainVertex> vertices;
  std::vector<std::uint32_t> indices;  ///< triangles, counter-clockwise seen from above
  double minHeight = 0.0;              ///< of the drawn vertices (exaggeration applied)
  double maxHeight = 0.0;
  glm::dvec2 frameMin{0.0};  ///< horizontal extent in frame coordinates
  glm::dvec2 frameMax{0.0};
  std::size_t skippedNodataPosts = 0;

  [[nodiscard]] std::size_t triangleCount() const { return indices.size() / 3; }
};

struct MeshOptions {
  double verticalExaggeration = 1.0;
};

/// One vertex per DEM post (at the post's pixel centre), two triangles per cell; cells touching
/// a nodata post are left out. Fails if the DEM CRS cannot be transformed into the frame or the
/// DEM holds no valid sample.
Result<TerrainMesh> buildFullResolutionMesh(const geo::Raster& dem, const geo::SceneFrame& frame,
                                            const MeshOptions& options = {});

}  // namespace gis::terrain
