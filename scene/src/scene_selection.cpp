#include "scene/scene_selection.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>

#include "geo/export.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::scene {

std::size_t SceneSelection::featureCount() const {
  std::size_t n = 0;
  for (const LayerSelection& l : layers) n += l.features.size();
  return n;
}

std::string layerSlug(const std::string& name) {
  std::string s;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    s += std::isalnum(u) != 0 ? static_cast<char>(std::tolower(u)) : '_';
  }
  return s.empty() ? "layer" : s;
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
  Diagnostics all;
  std::vector<geo::ExportSource> sources;
  for (const LayerSelection& l : selection.layers) {
    const LoadedLayer& layer = scene.layers[l.sceneLayer];
    const overlay::OverlayLayer& drawn = renderer.overlayLayers()[l.overlayLayer];
    geo::ExportSource source;
    source.path = layer.description.source;
    source.layer = layer.description.sourceLayer;
    source.label = layer.description.name;
    for (const overlay::FeatureSelection& f : l.features) {
      source.features.push_back(
          {drawn.features()[f.feature].fid, {{"selection_fully_inside", std::int64_t{f.fullyInside ? 1 : 0}}}});
    }
    if (perLayerDir) {
      all.append(geo::exportFeaturesGeoJson(
          source, (*perLayerDir / ("selected_" + layerSlug(layer.description.name) + ".geojson")).string()));
    }
    sources.push_back(std::move(source));
  }
  all.append(geo::exportFeaturesGeoJsonCombined(sources, combined.string()));
  return all;
}

}  // namespace gis::scene
