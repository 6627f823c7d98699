#pragma once
// The features a lasso selection holds on the globe (docs/globe.md): the logical twin of the
// selection's pixels, as scene_selection.hpp is in a projected frame. Each feature is sampled on
// the ground — its areas' rings and a grid inside them, its lines along their points — at heights
// from the DEM, and each sample is tested against the lasso chain (overlay::selectedAt) in ECEF.
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "globe/globe_view.hpp"
#include "scene/globe_scene.hpp"
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

}  // namespace gis::scene
