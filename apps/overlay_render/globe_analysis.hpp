#pragma once
// overlay_render's lasso selection and layer overlap on the globe (docs/globe.md): drawn over a
// frame GlobeRenderer has drawn, read back, and checked against the CPU twin on the same depth.
#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "globe/globe_renderer.hpp"
#include "scene/globe_scene.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::app {

struct GlobeAnalysisRequest {
  std::string lasso;    ///< a lasso file (scene/lasso_file.hpp); empty: none
  std::string overlap;  ///< "A,B": two layers' names; empty: none
  overlay::OverlapOp overlapOp = overlay::OverlapOp::And;
  bool openVolumes = false;  ///< where a layer's volumes are not closed
};

/// Draws what `request` asks for over the frame in `target` (drawn from `view`): the overlap
/// (overlap.png, stats "overlap"), the open volumes (open_volumes.png, stats "open_volumes") and
/// then the selection (selection.png, stats "selection"),
/// colouring the frame as the projected path does. Its messages (the lasso file's, the export's)
/// are logged and added to `diagnostics`, for stats.json. Returns 0, 1 (a file could not be
/// written or read) or 2 (a layer named that is not in the scene).
int drawGlobeAnalyses(const GlobeAnalysisRequest& request, gfx::StateCache& cache, const gfx::RenderTarget& target,
                      globe::GlobeRenderer& renderer, const scene::LoadedGlobeScene& scene,
                      const globe::GlobeView& view, const std::filesystem::path& out, nlohmann::json& stats,
                      Diagnostics& diagnostics);

}  // namespace gis::app
