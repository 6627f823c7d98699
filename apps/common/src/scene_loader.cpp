#include "app/scene_loader.hpp"

#include <chrono>
#include <cmath>

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
  Result<terrain::TerrainGrid> grid = terrain::gridFromRaster(std::move(*dem), *frame);  // takes the samples
  if (!grid) return fail(std::move(grid.diagnostics));
  dem.value.reset();

  std::size_t nodata = 0;
  for (float h : grid->heights) nodata += std::isnan(h) ? 1u : 0u;
  if (nodata > 0) {
    diagnostics.add({Severity::Info, description.dem, "", "", std::to_string(nodata) + " nodata posts left as holes"});
  }
  auto quadtree =
      std::make_shared<const terrain::TerrainQuadtree>(std::make_shared<const terrain::TerrainGrid>(std::move(*grid)));
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(quadtree, description.verticalExaggeration);
  LoadedScene scene{description, std::move(*frame), quadtree, bounds, std::nullopt, {}, nodata, 0.0};

  if (description.imagery) {
    // Resampled once into the scene frame's CRS, so texture coordinates are affine in the frame.
    Result<geo::Raster> imagery =
        geo::readRasterInCrs(*description.imagery, description.imageryBands, scene.frame.crsWkt());
    diagnostics.append(imagery.diagnostics);
    if (imagery) {
      Result<terrain::Orthophoto> photo = terrain::makeOrthophoto(*imagery);
      diagnostics.append(photo.diagnostics);
      if (photo) {
        geo::GeoTransform t = imagery->info.geoTransform;
        t.c[0] -= scene.frame.origin().x;
        t.c[3] -= scene.frame.origin().y;
        scene.orthophoto = terrain::FrameOrthophoto{std::move(*photo), t};
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

void terrainBox(const LoadedScene& scene, double exaggeration, glm::dvec3& boxMin, glm::dvec3& boxMax) {
  const terrain::TerrainGrid& g = scene.quadtree->grid();
  const glm::dvec2 a = g.postPosition(0, 0), b = g.postPosition(g.width - 1, g.height - 1);
  const terrain::NodeInfo& root = scene.quadtree->info(scene.quadtree->root());
  const double z0 = root.minHeight * exaggeration, z1 = root.maxHeight * exaggeration;
  boxMin = glm::dvec3(glm::min(a, b), std::min(z0, z1));
  boxMax = glm::dvec3(glm::max(a, b), std::max(z0, z1));
}

}  // namespace gis::app
