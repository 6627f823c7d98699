#pragma once
// Cameras in the scene frame and camera files (docs/design.md §8):
//   {"eye": {"lon","lat","h"}, "target": {"lon","lat","h"}, "fov_y_deg"}  — heights in the DEM's
//   vertical units — or frame coordinates "eye_xyz", "target_xyz" (preferred when both exist).
#include <optional>
#include <string>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"

namespace gis::scene {

/// A camera as a file states it, before it is placed in a frame.
struct CameraSpec {
  std::optional<glm::dvec3> eyeLonLatH;
  std::optional<glm::dvec3> targetLonLatH;
  std::optional<glm::dvec3> eyeXyz;
  std::optional<glm::dvec3> targetXyz;
  double fovYDeg = 45.0;
  std::optional<double> nearPlane;  ///< "near", metres
};

/// A camera placed in the scene frame.
struct Camera {
  glm::dvec3 eye{0.0};
  glm::dvec3 target{0.0, 1.0, 0.0};
  glm::dvec3 up{0.0, 0.0, 1.0};
  double fovYDeg = 45.0;
  double nearPlane = 1.0;  ///< metres; reversed-Z float depth keeps precision far beyond it

  [[nodiscard]] glm::dmat4 view() const;
  /// Infinite reversed-Z projection for the given aspect (width / height).
  [[nodiscard]] glm::dmat4 projection(double aspect) const;
};

/// A camera object of a camera file, a scene file (`where` = "camera."), a lasso or a script.
/// Keys it does not understand are warnings naming their path (`where` + key); the keys
/// camera.json holds besides (width, height, view, proj, depth, crs, crs_wkt, origin, frame,
/// view_proj_ecef, eye_ecef: what overlay_render and the viewer write) are read as a camera too.
Result<CameraSpec> parseCameraSpec(const nlohmann::json& j, const std::string& file, const std::string& where = {});
Result<CameraSpec> loadCameraFile(const std::string& path);

/// Places a spec in the frame (lon/lat/h converted through the frame). Fails if neither
/// frame nor geographic coordinates are given for eye or target.
Result<Camera> placeCamera(const CameraSpec& spec, const geo::SceneFrame& frame, const std::string& file);

/// An oblique overview of a box (frame coordinates): from the south, 40° down, the box filling the view.
Camera overviewCamera(const glm::dvec3& boxMin, const glm::dvec3& boxMax, double fovYDeg = 45.0);

/// `camera` moved, keeping its direction, so that the box's corners project into `region`
/// (pixels x0, y0, x1, y1, origin top-left) of a `viewport` with `margin` (a fraction of the
/// region) to spare: as large as fits and centred in it. A viewer's home view in the part of the
/// window its panel leaves free. Returns `camera` unchanged when the region or box is empty.
Camera frameBoxInRegion(const Camera& camera, const glm::dvec3& boxMin, const glm::dvec3& boxMax,
                        const glm::ivec2& viewport, const glm::dvec4& region, double margin = 0.05);

/// camera.json as overlay_render writes it: width, height, column-major view and proj, depth
/// convention, frame (crs, origin) and the camera itself in both forms (readable as --camera).
nlohmann::json cameraToJson(const Camera& camera, const geo::SceneFrame& frame, int width, int height);

/// A 4 × 4 matrix as camera.json writes it: 16 numbers, column-major (both frames' camera.json).
nlohmann::json matrixToJson(const glm::dmat4& m);

}  // namespace gis::scene
