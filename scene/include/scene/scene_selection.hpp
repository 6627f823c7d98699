#pragma once
// The logical side of a lasso selection on a loaded scene, shared by overlay_render and the
// viewer: which features of each layer and which DEM posts the steps select (the CPU twin,
// vector_overlay/logical_selection.hpp), and their export as GeoJSON.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "scene/camera.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "scene/selection_export.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/logical_selection.hpp"

namespace gis::scene {

struct LayerSelection {
  std::size_t sceneLayer = 0;    ///< index in LoadedScene::layers
  std::size_t overlayLayer = 0;  ///< the fill's index in SceneRenderer::overlayLayers()
  std::vector<overlay::FeatureSelection> features;
  std::size_t fullyInside = 0;
};

struct SceneSelection {
  std::vector<LayerSelection> layers;  ///< every drawn scene layer, in scene order
  double sampleSpacing = 0.0;          ///< metres, of the feature sampling
  std::size_t testedSamples = 0;       ///< samples tested over every feature, selected or not
  /// Selected DEM posts; none for a paged DEM (its posts are not all in memory).
  std::optional<overlay::PostSelection> posts;
  [[nodiscard]] std::size_t featureCount() const;
};

/// The features and posts the steps select. Features are sampled at `sampleSpacing` metres, by
/// default half a pixel's footprint at the camera's target in a view `height` pixels high; the
/// samples are classified by blocks against the volumes with the DEM's full-resolution height
/// bounds (logical_selection.hpp), so the work follows the lassos' walls, not the features' area.
SceneSelection selectInScene(const LoadedScene& scene, const SceneRenderer& renderer,
                             std::span<const overlay::SelectionStep> steps, const Camera& camera, int width, int height,
                             std::optional<double> sampleSpacing = std::nullopt);

/// The GeoJSON export of the selected features (selection_export.hpp, exportSelectedFeatures):
/// one RFC 7946 FeatureCollection at `combined` and, when `perLayerDir` is given,
/// selected_<slug>.geojson per layer there in the source's own CRS.
Diagnostics exportSelection(const LoadedScene& scene, const SceneRenderer& renderer, const SceneSelection& selection,
                            const std::filesystem::path& combined,
                            const std::optional<std::filesystem::path>& perLayerDir = std::nullopt);

}  // namespace gis::scene
