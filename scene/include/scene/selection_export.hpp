#pragma once
// The GeoJSON export of a lasso's selected features, whatever frame selected them: a projected
// scene (scene_selection.hpp) and the globe (globe_selection.hpp) each say which features of which
// source layer are selected, and this writes the same files for both (docs/command-line.md).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"

namespace gis::scene {

/// One selected feature of a source layer.
struct SelectedFeatureId {
  std::int64_t fid = -1;  ///< OGR FID, as the reader gave it (geo::Feature::fid)
  bool fullyInside = false;
};

/// The selected features of one layer of the scene file.
struct SelectedLayerFeatures {
  std::string name;         ///< the scene's layer name: "selection_layer", and the per-layer file's name
  std::string source;       ///< the vector file (or connection string) the features were read from
  std::string sourceLayer;  ///< OGR layer name; empty = the first
  std::vector<SelectedFeatureId> features;
};

/// A file name from a layer name: lower-case letters, digits and underscores.
std::string layerSlug(const std::string& name);

/// "selected_<slug>.geojson": the per-layer file the export writes for a layer named `name`.
std::string selectedLayerFileName(const std::string& name);

/// Writes every selected feature into one RFC 7946 FeatureCollection at `combined` (WGS 84
/// lon/lat, with selection_layer, selection_fid, selection_fully_inside) and, when `perLayerDir`
/// is given, selectedLayerFileName(name) per layer there in the source's own CRS (with
/// selection_fully_inside). Features are re-read by FID from their source files, so geometry and
/// attributes are the file's own.
Diagnostics exportSelectedFeatures(std::span<const SelectedLayerFeatures> layers, const std::filesystem::path& combined,
                                   const std::optional<std::filesystem::path>& perLayerDir = std::nullopt);

}  // namespace gis::scene
