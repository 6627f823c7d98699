#pragma once
// Loads what a scene file names (CPU side): the frame, the terrain mesh, the orthophoto and the
// vector layers, collecting every message. Only a DEM that cannot be read fails the scene;
// broken imagery or layers are reported and left out, the rest still renders.
#include <memory>
#include <optional>
#include <vector>

#include "app/scene.hpp"
#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/vector.hpp"
#include "terrain/orthophoto.hpp"
#include "terrain/terrain_mesh.hpp"

namespace gis::app {

struct LoadedLayer {
  LayerDescription description;
  geo::VectorLayer data;
  std::size_t skippedFeatures = 0;  ///< features left out for errors (named in diagnostics)
};

struct LoadedScene {
  SceneDescription description;
  geo::SceneFrame frame;
  terrain::TerrainMesh mesh;
  std::optional<terrain::Orthophoto> orthophoto;
  std::vector<LoadedLayer> layers;
  std::size_t demWidth = 0;
  std::size_t demHeight = 0;
  double loadSeconds = 0.0;
};

Result<LoadedScene> loadScene(const SceneDescription& description);

/// The box that holds the terrain (frame coordinates).
void terrainBox(const LoadedScene& scene, glm::dvec3& boxMin, glm::dvec3& boxMax);

}  // namespace gis::app
