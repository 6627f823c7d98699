#pragma once
// The two implementations of FrameRenderer (frame_renderer.hpp), one per frame, and what both
// report alike.
#include <memory>

#include <nlohmann/json.hpp>

#include "scene/frame_renderer.hpp"

namespace gis::scene::detail {

Result<std::unique_ptr<FrameRenderer>> makeProjectedRenderer(LoadedScene& scene, const StillSettings& settings);
Result<std::unique_ptr<FrameRenderer>> makeGlobeRenderer(LoadedGlobeScene& scene, const StillSettings& settings);

/// stats.json's "tiles" block of a frame drawn in view-dependent tiles (overlay::TileResidency, in
/// both frames): what was drawn, wanted, built, read and kept, and `gpuBytes` resident.
nlohmann::json tilesJson(const overlay::TechniqueFrameStats& t, std::size_t gpuBytes);

}  // namespace gis::scene::detail
