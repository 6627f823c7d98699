#include "scene/globe_selection.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "globe/ellipsoid.hpp"

namespace gis::scene {

namespace {

constexpr double kMetresPerDegree = 111320.0;  ///< along a meridian, near enough for a sample grid

/// Samples and selected samples per feature of one layer.
struct Tally {
  std::size_t samples = 0, selected = 0;
  double spacing = 0.0;
};

class Sampler {
 public:
  Sampler(const globe::GeoGrid& ground, std::span<const overlay::SelectionStep> steps)
      : ground_(ground), steps_(steps) {}

  /// Tests the ground point at (lon, lat).
  void sample(Tally& t, double lon, double lat) {
    const glm::dvec3 p = globe::toEcef(lon, lat, ground_.heightAt(lon, lat));
    ++t.samples;
    ++tested_;
    if (overlay::selectedAt(steps_, p)) ++t.selected;
  }
  /// Samples along p → q (unwrapped degrees) every `spacing` metres, p included, q not.
  void along(Tally& t, const glm::dvec2& p, const glm::dvec2& q, double spacing) {
    const double cosLat = std::max(std::cos(0.5 * (p.y + q.y) * 3.14159265358979323846 / 180.0), 1e-6);
    const double metres = kMetresPerDegree * std::hypot((q.x - p.x) * cosLat, q.y - p.y);
    const int n = std::max(1, static_cast<int>(std::ceil(metres / spacing)));
    for (int k = 0; k < n; ++k) {
      const double f = static_cast<double>(k) / n;
      sample(t, p.x + (q.x - p.x) * f, p.y + (q.y - p.y) * f);
    }
  }
  [[nodiscard]] std::size_t tested() const { return tested_; }
  [[nodiscard]] const globe::GeoGrid& ground() const { return ground_; }

 private:
  const globe::GeoGrid& ground_;
  std::span<const overlay::SelectionStep> steps_;
  std::size_t tested_ = 0;
};

/// An area: its rings and a grid inside it, at `spacing` metres or coarser to keep within `most`.
void sampleArea(Sampler& s, const globe::GlobePolygon& polygon, Tally& t, double spacing, std::size_t most) {
  const globe::LonLatRect& b = polygon.box;
  const double midLat = 0.5 * (b.south + b.north);
  const double cosLat = std::max(std::cos(midLat * 3.14159265358979323846 / 180.0), 1e-3);
  const double width = (b.east - b.west) * kMetresPerDegree * cosLat, height = (b.north - b.south) * kMetresPerDegree;
  double perimeter = 0.0;
  for (const auto& ring : polygon.rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const glm::dvec2& p = ring[i];
      const glm::dvec2& q = ring[(i + 1) % ring.size()];
      perimeter += kMetresPerDegree * std::hypot((q.x - p.x) * cosLat, q.y - p.y);
    }
  }
  // Grid and boundary samples within `most`: (w / s)(h / s) + perimeter / s ≤ most.
  const double m = static_cast<double>(most);
  double s2 = spacing;
  if (width * height / (s2 * s2) + perimeter / s2 > m) {
    s2 = (perimeter + std::sqrt(perimeter * perimeter + 4.0 * m * width * height)) / (2.0 * m);
  }
  t.spacing = std::max(t.spacing, s2);
  for (const auto& ring : polygon.rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) s.along(t, ring[i], ring[(i + 1) % ring.size()], s2);
  }
  const double dLat = s2 / kMetresPerDegree;
  for (double lat = b.south + 0.5 * dLat; lat < b.north; lat += dLat) {
    const double dLon = dLat / std::max(std::cos(lat * 3.14159265358979323846 / 180.0), 1e-3);
    for (double lon = b.west + 0.5 * dLon; lon < b.east; lon += dLon) {
      const glm::dvec3 p = globe::toEcef(lon, lat, s.ground().heightAt(lon, lat));
      if (globe::contains(polygon, p, lon, lat)) s.sample(t, lon, lat);
    }
  }
}

}  // namespace

GlobeSelection selectOnGlobe(const LoadedGlobeScene& scene, std::span<const overlay::SelectionStep> steps,
                             const globe::GlobeView& view, std::optional<double> sampleSpacing,
                             std::size_t maxSamplesPerFeature) {
  GlobeSelection out;
  out.sampleSpacing = sampleSpacing.value_or(std::max(view.pixelSizeAt(glm::length(view.target - view.eye)), 0.01));
  Sampler sampler(*scene.heights, steps);
  for (std::size_t l = 0; l < scene.layers.size(); ++l) {
    // An outline follows its fill (the same place in the scene file): its features are the fill's.
    if (l > 0 && l < scene.layerFileIndex.size() && scene.layerFileIndex[l] == scene.layerFileIndex[l - 1]) continue;
    const globe::GlobeLayer& layer = scene.layers[l];
    std::map<std::size_t, Tally> tallies;
    for (std::size_t p = 0; p < layer.areaCount(); ++p) {
      const globe::GlobePolygon& polygon = layer.polygons()[p];
      sampleArea(sampler, polygon, tallies[polygon.feature], out.sampleSpacing, maxSamplesPerFeature);
    }
    for (const globe::GlobeLine& line : layer.lines()) {
      Tally& t = tallies[line.feature];
      double metres = 0.0;
      for (std::size_t i = 0; i + 1 < line.surface.size(); ++i)
        metres += glm::length(line.surface[i + 1] - line.surface[i]);
      const double spacing = std::max(out.sampleSpacing, metres / static_cast<double>(maxSamplesPerFeature));
      t.spacing = std::max(t.spacing, spacing);
      for (std::size_t i = 0; i + 1 < line.points.size(); ++i)
        sampler.along(t, line.points[i], line.points[i + 1], spacing);
      if (!line.points.empty()) sampler.sample(t, line.points.back().x, line.points.back().y);
    }
    GlobeLayerSelection selected;
    selected.layer = l;
    for (const auto& [feature, t] : tallies) {
      if (t.selected == 0) continue;
      overlay::FeatureSelection f;
      f.feature = feature;
      f.fullyInside = t.selected == t.samples;
      f.samples = t.samples;
      f.selectedSamples = t.selected;
      f.spacing = t.spacing;
      selected.fullyInside += f.fullyInside ? 1U : 0U;
      selected.features.push_back(f);
    }
    out.layers.push_back(std::move(selected));
  }
  out.testedSamples = sampler.tested();
  return out;
}

const LayerDescription* sceneLayerOf(const LoadedGlobeScene& scene, std::size_t globeLayer) {
  if (globeLayer >= scene.layerFileIndex.size()) return nullptr;
  for (const LayerDescription& d : scene.description.layers) {
    if (d.fileIndex == scene.layerFileIndex[globeLayer]) return &d;
  }
  return nullptr;
}

std::vector<SelectedLayerFeatures> selectedSourceFeatures(const LoadedGlobeScene& scene,
                                                          const GlobeSelection& selection) {
  // Per file layer (by its place in the scene file): feature index → fully inside.
  std::map<std::size_t, std::map<std::size_t, bool>> united;
  for (const GlobeLayerSelection& l : selection.layers) {
    if (sceneLayerOf(scene, l.layer) == nullptr) continue;
    std::map<std::size_t, bool>& features = united[scene.layerFileIndex[l.layer]];
    for (const overlay::FeatureSelection& f : l.features) {
      const auto [at, added] = features.emplace(f.feature, f.fullyInside);
      if (!added) at->second = at->second && f.fullyInside;
    }
  }
  std::vector<SelectedLayerFeatures> out;
  for (const LayerDescription& d : scene.description.layers) {
    const auto found = united.find(d.fileIndex);
    if (found == united.end()) continue;
    // The features' fids: any of this file layer's globe layers holds them (they share one list).
    const overlay::SharedFeatures* features = nullptr;
    for (std::size_t l = 0; l < scene.layerFileIndex.size() && features == nullptr; ++l) {
      if (scene.layerFileIndex[l] == d.fileIndex && l < scene.layerFeatures.size()) features = &scene.layerFeatures[l];
    }
    SelectedLayerFeatures layer{d.name, d.source, d.sourceLayer, {}};
    for (const auto& [feature, fullyInside] : found->second) {
      if (features == nullptr || feature >= features->size()) continue;
      layer.features.push_back({features->get(feature)->fid, fullyInside});
    }
    out.push_back(std::move(layer));
  }
  return out;
}

Diagnostics exportGlobeSelection(const LoadedGlobeScene& scene, const GlobeSelection& selection,
                                 const std::filesystem::path& combined,
                                 const std::optional<std::filesystem::path>& perLayerDir) {
  return exportSelectedFeatures(selectedSourceFeatures(scene, selection), combined, perLayerDir);
}

}  // namespace gis::scene
