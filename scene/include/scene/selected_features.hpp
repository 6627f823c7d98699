#pragma once
// What a lasso selects, in either frame (docs/frames.md, "One scene, one set of programs"): the
// features per layer of the scene file, as overlay_render's stats.json, the viewer's panel, its
// highlights and its state list them. Each frame finds them its own way (scene_selection.hpp,
// globe_selection.hpp) and says them once in this form; the frame's own answer rides along for
// the export, which re-reads the features from their sources.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <variant>
#include <vector>
#include "core/diagnostics.hpp"
#include "scene/globe_selection.hpp"
#include "scene/scene_selection.hpp"
#include "vector_overlay/logical_selection.hpp"

namespace gis::scene {

class SceneRenderer;

/// What a lasso selects: per layer of the scene file that has selected features.
struct SelectedFeatures {
  struct Layer {
    std::string name;            ///< the scene file's
    std::size_t sceneLayer = 0;  ///< its index in the scene file's layers (SceneDescription::layers)
    std::size_t drawnLayer = 0;  ///< the frame's layer that selected it (a projected fill, a globe layer)
    std::vector<overlay::FeatureSelection> features;
    std::vector<std::int64_t> fids;  ///< per feature: its FID in the source (−1 if unknown)
    std::size_t fullyInside = 0;
  };
  std::vector<Layer> layers;
  double sampleSpacing = 0.0;     ///< metres
  std::size_t testedSamples = 0;  ///< over every feature, selected or not
  double seconds = 0.0;           ///< what finding them took
  /// Selected DEM posts (a projected scene's DEM held in memory only).
  std::optional<overlay::PostSelection> posts;
  /// The frame's own answer, for the export.
  std::variant<SceneSelection, GlobeSelection> selection;

  [[nodiscard]] std::size_t featureCount() const;
};

/// A projected scene's selection in the common form (`renderer` drew the layers it selected on).
SelectedFeatures selectedFeaturesOf(const LoadedScene& scene, const SceneRenderer& renderer, SceneSelection chosen,
                                    double seconds);
/// A globe scene's selection in the common form.
SelectedFeatures selectedFeaturesOf(const LoadedGlobeScene& scene, GlobeSelection chosen, double seconds);

}  // namespace gis::scene
