#pragma once
// Lasso files (docs/command-line.md, "Lasso files"): a list of lassos with their operators and the
// cameras they were drawn with, plus how the selection is shown. Read by `overlay_render --lasso`.
//
//   {"lassos": [{"op": "single", "points": [[x, y], ...], "camera": {...} or "camera.json",
//                "width": W, "height": H, "distance": metres}, {"op": "invert"}, ...],
//    "highlight": {"color": "#ff3319", "opacity": 0.45},
//    "show_volumes": {"color": "#3399ff", "opacity": 0.25},
//    "scheme": "runs" | "report", "sample_spacing_m": 2}
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec4.hpp>
#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_view.hpp"
#include "scene/camera.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace gis::scene {

struct SelectionRequest {
  std::vector<overlay::SelectionStep> steps;
  overlay::SelectionStyle highlight;
  std::optional<glm::vec4> showVolumes;  ///< colour with opacity in alpha; none = not drawn
  overlay::SelectionScheme scheme = overlay::SelectionScheme::Runs;
  std::optional<double> sampleSpacing;  ///< metres, for the logical selection of features
};

/// A lasso's camera once placed: its clip transform for a viewport, and its near plane (a lasso's
/// distance must lie beyond it). Projected scenes place a scene::Camera; globe scenes a
/// globe::GlobeView (scene/globe_scene.hpp).
struct LassoCamera {
  std::function<glm::dmat4(int width, int height)> viewProj;
  double nearPlane = 1.0;
  /// The lasso's reach when its entry gives no "distance" (on the globe: globe::horizonReach).
  double distance = std::numeric_limits<double>::infinity();
};
/// Places a camera as a lasso entry states it (`spec`: a camera object, or a camera file's
/// content; `where` names it in messages); nothing, with the reason in `diagnostics`, if it cannot.
using LassoCameraPlacer =
    std::function<std::optional<LassoCamera>(const nlohmann::json& spec, const std::string& where, Diagnostics&)>;

/// Reads a lasso file. A lasso's camera is an object (a camera file's content), a path to a
/// camera file (relative to the lasso file; a camera.json of overlay_render also gives the
/// viewport), or absent: then `current` with a viewport of `width` × `height`. A lasso entry
/// that cannot be used (no such operator, fewer than 3 points, a camera that cannot be placed) is
/// an error naming the file and "lasso N" (from 1) and is left out of the chain; an unreadable or
/// malformed file fails as a whole.
Result<SelectionRequest> loadLassoFile(const std::string& path, const geo::SceneFrame& frame, const Camera& current,
                                       int width, int height);

/// The same from parsed JSON; `file` names it in messages, `baseDir` resolves camera paths.
Result<SelectionRequest> parseLassoFile(const nlohmann::json& j, const std::string& file, const std::string& baseDir,
                                        const geo::SceneFrame& frame, const Camera& current, int width, int height);
/// The same in any frame: `current` for lassos without a camera, `place` for those with one.
Result<SelectionRequest> parseLassoFile(const nlohmann::json& j, const std::string& file, const std::string& baseDir,
                                        const LassoCamera& current, const LassoCameraPlacer& place, int width,
                                        int height);
/// Reads a lasso file of a scene drawn on the globe: lassos without a camera were drawn in
/// `current`; a lasso's camera states its eye and target in lon/lat/h (a globe camera.json of
/// overlay_render does), placed as globe::GlobeView::looking over `ground` (its near plane from
/// the eye's height there, or the camera's "near"). A lasso without "distance" reaches the
/// horizon of its eye over `ground` (globe::horizonReach), not through the globe.
Result<SelectionRequest> loadGlobeLassoFile(const std::string& path, const globe::GlobeView& current,
                                            const globe::GeoGrid& ground);
/// Reads a lasso file in any frame.
Result<SelectionRequest> loadLassoFile(const std::string& path, const LassoCamera& current,
                                       const LassoCameraPlacer& place, int width, int height);

}  // namespace gis::scene
