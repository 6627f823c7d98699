#include "app/scene_loader.hpp"

#include <chrono>

#include "core/log.hpp"
#include "geo/raster.hpp"

namespace gis::app {

Result<LoadedScene> loadScene(const SceneDescription& description) {
  const auto start = std::chrono::steady_clock::now();
  Diagnostics diagnostics;
  auto fail = [&](Diagnostics&& more) {
    Result<LoadedScene> r;
    r.diagnostics = std::move(diagnostics);
    r.diagnostics.append(more);
    return r;
  };

  Result<geo::Raster> dem = geo::readRaster(description.dem, {description.demBand});
  if (!dem) return fail(std::move(dem.diagnostics));
  diagnostics.append(dem.diagnostics);
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->info);
  if (!frame) return fail(std::move(frame.diagnostics));

  terrain::MeshOptions meshOptions;
  meshOptions.verticalExaggeration = description.verticalExaggeration;
  Result<terrain::TerrainMesh> mesh = terrain::buildFullResolutionMesh(*dem, *frame, meshOptions);
  if (!mesh) return fail(std::move(mesh.diagnostics));
  diagnostics.append(mesh.diagnostics);

  LoadedScene scene{description,
                    std::move(*frame),
                    std::move(*mesh),
                    std::nullopt,
                    {},
                    static_cast<std::size_t>(dem->info.width),
                    static_cast<std::size_t>(dem->info.height),
                    0.0};

  if (description.imagery) {
    Result<geo::Raster> imagery = geo::readRaster(*description.imagery, description.imageryBands);
    diagnostics.append(imagery.diagnostics);
    if (imagery) {
      Result<terrain::Orthophoto> photo = terrain::makeOrthophoto(*imagery);
      diagnostics.append(photo.diagnostics);
      if (photo) {
        diagnostics.append(terrain::assignImageryUv(scene.mesh, imagery->info, scene.frame));
        scene.orthophoto = std::move(*photo);
      }
    }
  }

  for (const LayerDescription& layer : description.layers) {
    geo::VectorReadOptions options;
    options.layer = layer.sourceLayer;
    Result<geo::VectorLayer> data = geo::readVectorLayer(layer.source, scene.frame, options);
    // Name our layer in every message about it, beside the file's own layer name.
    for (const Diagnostic& d : data.diagnostics.items()) {
      Diagnostic named = d;
      named.layer = layer.name + (d.layer.empty() || d.layer == layer.name ? "" : " (" + d.layer + ")");
      diagnostics.add(std::move(named));
    }
    if (!data) continue;
    LoadedLayer loaded{layer, std::move(*data), data.diagnostics.count(Severity::Error)};
    scene.layers.push_back(std::move(loaded));
  }
  scene.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  Result<LoadedScene> result;
  result.diagnostics = std::move(diagnostics);
  result.value = std::move(scene);
  return result;
}

void terrainBox(const LoadedScene& scene, glm::dvec3& boxMin, glm::dvec3& boxMax) {
  boxMin = glm::dvec3(scene.mesh.frameMin, scene.mesh.minHeight);
  boxMax = glm::dvec3(scene.mesh.frameMax, scene.mesh.maxHeight);
}

}  // namespace gis::app
