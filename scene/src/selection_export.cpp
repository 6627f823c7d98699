#include "scene/selection_export.hpp"

#include <cctype>

#include "geo/export.hpp"

namespace gis::scene {

std::string layerSlug(const std::string& name) {
  std::string s;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    s += std::isalnum(u) != 0 ? static_cast<char>(std::tolower(u)) : '_';
  }
  return s.empty() ? "layer" : s;
}

std::string selectedLayerFileName(const std::string& name) { return "selected_" + layerSlug(name) + ".geojson"; }

Diagnostics exportSelectedFeatures(std::span<const SelectedLayerFeatures> layers, const std::filesystem::path& combined,
                                   const std::optional<std::filesystem::path>& perLayerDir) {
  Diagnostics all;
  std::vector<geo::ExportSource> sources;
  sources.reserve(layers.size());
  for (const SelectedLayerFeatures& layer : layers) {
    geo::ExportSource source;
    source.path = layer.source;
    source.layer = layer.sourceLayer;
    source.label = layer.name;
    source.features.reserve(layer.features.size());
    for (const SelectedFeatureId& f : layer.features) {
      source.features.push_back({f.fid, {{"selection_fully_inside", std::int64_t{f.fullyInside ? 1 : 0}}}});
    }
    if (perLayerDir) {
      all.append(geo::exportFeaturesGeoJson(source, (*perLayerDir / selectedLayerFileName(layer.name)).string()));
    }
    sources.push_back(std::move(source));
  }
  all.append(geo::exportFeaturesGeoJsonCombined(sources, combined.string()));
  return all;
}

}  // namespace gis::scene
