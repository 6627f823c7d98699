#include "scene/selected_features.hpp"

#include <utility>

#include "scene/scene_renderer.hpp"

namespace gis::scene {

std::size_t SelectedFeatures::featureCount() const {
  std::size_t n = 0;
  for (const Layer& l : layers) n += l.features.size();
  return n;
}

SelectedFeatures selectedFeaturesOf(const LoadedScene& scene, const SceneRenderer& renderer, SceneSelection chosen,
                                    double seconds) {
  SelectedFeatures out;
  out.seconds = seconds;
  for (const LayerSelection& l : chosen.layers) {
    const overlay::OverlayLayer& drawn = renderer.overlayLayers()[l.overlayLayer];
    SelectedFeatures::Layer layer{
        scene.layers[l.sceneLayer].description.name, l.sceneLayer, l.overlayLayer, l.features, {}, l.fullyInside};
    for (const overlay::FeatureSelection& f : l.features) layer.fids.push_back(drawn.features()[f.feature].fid);
    out.layers.push_back(std::move(layer));
  }
  out.sampleSpacing = chosen.sampleSpacing;
  out.testedSamples = chosen.testedSamples;
  out.posts = chosen.posts;
  out.selection = std::move(chosen);
  return out;
}

SelectedFeatures selectedFeaturesOf(const LoadedGlobeScene& scene, GlobeSelection chosen, double seconds) {
  SelectedFeatures out;
  out.seconds = seconds;
  for (const GlobeLayerSelection& l : chosen.layers) {
    const LayerDescription* described = sceneLayerOf(scene, l.layer);
    if (described == nullptr) continue;  // never for a loaded scene's layers
    const overlay::SharedFeatures* features =
        l.layer < scene.layerFeatures.size() ? &scene.layerFeatures[l.layer] : nullptr;
    SelectedFeatures::Layer layer{
        described->name, static_cast<std::size_t>(described - scene.description.layers.data()), l.layer, l.features, {},
        l.fullyInside};
    for (const overlay::FeatureSelection& f : l.features) {
      layer.fids.push_back(features != nullptr && f.feature < features->size() ? features->get(f.feature)->fid : -1);
    }
    out.layers.push_back(std::move(layer));
  }
  out.sampleSpacing = chosen.sampleSpacing;
  out.testedSamples = chosen.testedSamples;
  out.selection = std::move(chosen);
  return out;
}

}  // namespace gis::scene
