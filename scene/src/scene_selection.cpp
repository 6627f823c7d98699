#include "scene/scene_selection.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "vector_overlay/cpu_reference.hpp"

namespace gis::scene {

std::size_t SceneSelection::featureCount() const {
  std::size_t n = 0;
  for (const LayerSelection& l : layers) n += l.features.size();
  return n;
}

SceneSelection selectInScene(const LoadedScene& scene, const SceneRenderer& renderer,
                             std::span<const overlay::SelectionStep> steps, const Camera& camera, int width, int height,
                             std::optional<double> sampleSpacing) {
  SceneSelection out;
  const double aspect = static_cast<double>(width) / height;
  const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();
  const double pixelAtTarget =
      glm::length(camera.target - camera.eye) * 2.0 * std::tan(camera.fovYDeg * std::numbers::pi / 360.0) / height;
  overlay::FeatureSelectionOptions options;
  options.sampleSpacing = sampleSpacing.value_or(std::max(0.25, 0.5 * pixelAtTarget));
  options.scale = overlay::pixelScaleOf(viewProj, height);
  const overlay::HeightBounds global = scene.bounds->globalBounds();
  options.minHeight = global.lo;
  options.maxHeight = global.hi;
  out.sampleSpacing = options.sampleSpacing;
  options.testedSamples = &out.testedSamples;
  const auto heightAt = [&scene](const glm::dvec2& p) { return scene.bounds->fullResolutionHeightAt(p); };
  // The full-resolution surface's posts around a box bound it there (padded for the rounding of
  // its interpolation); off the DEM there is no terrain.
  const terrain::TerrainGrid& dem = scene.quadtree->grid();
  options.heightBounds = [&scene, &dem](const glm::dvec2& lo, const glm::dvec2& hi) {
    const glm::dvec2 a = dem.gridCoordinates(lo), b = dem.gridCoordinates(hi);
    const glm::dvec2 glo = glm::min(a, b), ghi = glm::max(a, b);
    if (ghi.x < 0.0 || ghi.y < 0.0 || glo.x > dem.width - 1 || glo.y > dem.height - 1) return HeightBounds{1.0, 0.0};
    const std::array<glm::dvec2, 4> corners = {lo, glm::dvec2(hi.x, lo.y), hi, glm::dvec2(lo.x, hi.y)};
    HeightBounds z = scene.bounds->boundsOverLevels(corners, 0, 0);
    z.lo -= 1e-3 + 1e-6 * std::abs(z.lo);
    z.hi += 1e-3 + 1e-6 * std::abs(z.hi);
    return z;
  };
  for (std::size_t j = 0; j < renderer.overlaySources().size(); ++j) {
    if (renderer.overlaySources()[j].second) continue;  // an outline: its fill has the features
    LayerSelection layer;
    layer.sceneLayer = renderer.overlaySources()[j].first;
    layer.overlayLayer = j;
    layer.features =
        overlay::selectFeatures(overlay::referenceLayerOf(renderer.overlayLayers()[j]), steps, heightAt, options);
    for (const overlay::FeatureSelection& f : layer.features) layer.fullyInside += f.fullyInside ? 1u : 0u;
    out.layers.push_back(std::move(layer));
  }
  const terrain::TerrainGrid& grid = scene.quadtree->grid();
  if (!grid.heights.empty()) {
    overlay::PostGrid g;
    g.width = grid.width;
    g.height = grid.height;
    g.origin = grid.origin;
    g.step = grid.step;
    const double exaggeration = scene.bounds->exaggeration();
    g.heightAt = [&grid, exaggeration](int c, int r) { return static_cast<double>(grid.at(c, r)) * exaggeration; };
    out.posts = overlay::selectPosts(g, steps);
  }
  return out;
}

Diagnostics exportSelection(const LoadedScene& scene, const SceneRenderer& renderer, const SceneSelection& selection,
                            const std::filesystem::path& combined,
                            const std::optional<std::filesystem::path>& perLayerDir) {
  std::vector<SelectedLayerFeatures> layers;
  layers.reserve(selection.layers.size());
  for (const LayerSelection& l : selection.layers) {
    const LayerDescription& description = scene.layers[l.sceneLayer].description;
    const overlay::OverlayLayer& drawn = renderer.overlayLayers()[l.overlayLayer];
    SelectedLayerFeatures layer{description.name, description.source, description.sourceLayer, {}};
    layer.features.reserve(l.features.size());
    for (const overlay::FeatureSelection& f : l.features) {
      layer.features.push_back({drawn.features()[f.feature].fid, f.fullyInside});
    }
    layers.push_back(std::move(layer));
  }
  return exportSelectedFeatures(layers, combined, perLayerDir);
}

}  // namespace gis::scene
