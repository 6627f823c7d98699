#pragma once
// The features a lasso selection holds on the globe (docs/globe.md): the logical twin of the
// selection's pixels, as scene_selection.hpp is in a projected frame. Each feature is sampled on
// the ground — its areas' rings and a grid inside them, its lines along their points — at heights
// from the DEM, and each sample is tested against the lasso chain (overlay::selectedAt) in ECEF.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include "globe/globe_view.hpp"
#include "scene/globe_scene.hpp"
#include "scene/selection_export.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/logical_selection.hpp"

namespace gis::scene {

struct GlobeLayerSelection {
  std::size_t layer = 0;  ///< index in LoadedGlobeScene::layers (fills and line layers; outlines are left out)
  std::vector<overlay::FeatureSelection> features;  ///< the selected ones, in feature order
  std::size_t fullyInside = 0;
};

struct GlobeSelection {
  std::vector<GlobeLayerSelection> layers;
  double sampleSpacing = 0.0;     ///< metres asked for
  std::size_t testedSamples = 0;  ///< over every feature, selected or not
};

/// The features the steps select. A feature is selected when one of its samples is, and fully
/// inside when all are. Samples are `sampleSpacing` metres apart (by default the footprint of a
/// pixel at the view's target), coarser for a feature that would need more than
/// `maxSamplesPerFeature` (FeatureSelection::spacing says how coarse).
GlobeSelection selectOnGlobe(const LoadedGlobeScene& scene, std::span<const overlay::SelectionStep> steps,
                             const globe::GlobeView& view, std::optional<double> sampleSpacing = std::nullopt,
                             std::size_t maxSamplesPerFeature = std::size_t{1} << 16);

/// The layer of the scene file a globe layer was built from (a fill and its outline share one);
/// null when none is (never for a loaded scene's layers).
const LayerDescription* sceneLayerOf(const LoadedGlobeScene& scene, std::size_t globeLayer);

/// The selected features per layer of the scene file, in the scene's order, as the export takes
/// them: the globe layers of one file layer (its fill and its outline) united, a feature fully
/// inside when every one of them that selects it says so; fids from LoadedGlobeScene::layerFeatures.
std::vector<SelectedLayerFeatures> selectedSourceFeatures(const LoadedGlobeScene& scene,
                                                          const GlobeSelection& selection);

/// The GeoJSON export of the selected features, as a projected scene's (exportSelectedFeatures):
/// one RFC 7946 FeatureCollection at `combined` and, when `perLayerDir` is given,
/// selected_<slug>.geojson per layer there in the source's own CRS.
Diagnostics exportGlobeSelection(const LoadedGlobeScene& scene, const GlobeSelection& selection,
                                 const std::filesystem::path& combined,
                                 const std::optional<std::filesystem::path>& perLayerDir = std::nullopt);

}  // namespace gis::scene
