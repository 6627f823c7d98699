#include "scene/camera.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "gfx/camera.hpp"
#include "scene/json_file.hpp"

namespace gis::scene {
namespace {

using nlohmann::json;

std::optional<glm::dvec3> readLonLatH(const json& j, const std::string& key, const std::string& file,
                                      Diagnostics& diag) {
  if (!j.contains(key)) return std::nullopt;
  const json& p = j.at(key);
  try {
    return glm::dvec3(p.at("lon").get<double>(), p.at("lat").get<double>(), p.value("h", 0.0));
  } catch (const json::exception& e) {
    diag.add({Severity::Error, file, "", "", "camera '" + key + "': expected {\"lon\", \"lat\", \"h\"}: " + e.what()});
    return std::nullopt;
  }
}

std::optional<glm::dvec3> readXyz(const json& j, const std::string& key, const std::string& file, Diagnostics& diag) {
  if (!j.contains(key)) return std::nullopt;
  try {
    const auto v = j.at(key).get<std::vector<double>>();
    if (v.size() != 3) throw std::runtime_error("needs 3 numbers");
    return glm::dvec3(v[0], v[1], v[2]);
  } catch (const std::exception& e) {
    diag.add({Severity::Error, file, "", "", "camera '" + key + "': expected [x, y, z]: " + e.what()});
    return std::nullopt;
  }
}

}  // namespace

json matrixToJson(const glm::dmat4& m) {
  json a = json::array();
  const double* v = glm::value_ptr(m);
  for (int i = 0; i < 16; ++i) a.push_back(v[i]);
  return a;
}

glm::dmat4 Camera::view() const { return gfx::lookAt(eye, target, up); }

glm::dmat4 Camera::projection(double aspect) const {
  return gfx::reversedInfinitePerspective(fovYDeg * std::numbers::pi / 180.0, aspect, nearPlane);
}

Result<CameraSpec> parseCameraSpec(const json& j, const std::string& file, const std::string& where) {
  Result<CameraSpec> result;
  if (!j.is_object()) return Result<CameraSpec>::failure({Severity::Error, file, "", "", "camera: expected an object"});
  warnUnknownKeys(
      j,
      {"eye", "target", "eye_xyz", "target_xyz", "fov_y_deg", "near",
       // What camera.json holds besides, for people and scripts (read back as --camera).
       "width", "height", "view", "proj", "depth", "crs", "crs_wkt", "origin", "frame", "view_proj_ecef", "eye_ecef"},
      file, where, result.diagnostics);
  for (const char* point : {"eye", "target"}) {
    if (j.contains(point))
      warnUnknownKeys(j[point], {"lon", "lat", "h"}, file, where + point + ".", result.diagnostics);
  }
  CameraSpec spec;
  spec.eyeLonLatH = readLonLatH(j, "eye", file, result.diagnostics);
  spec.targetLonLatH = readLonLatH(j, "target", file, result.diagnostics);
  spec.eyeXyz = readXyz(j, "eye_xyz", file, result.diagnostics);
  spec.targetXyz = readXyz(j, "target_xyz", file, result.diagnostics);
  if (j.contains("fov_y_deg")) {
    if (!j["fov_y_deg"].is_number() || !(j["fov_y_deg"].get<double>() > 0.0 && j["fov_y_deg"].get<double>() < 180.0)) {
      result.diagnostics.add({Severity::Error, file, "", "", "camera 'fov_y_deg': expected a number in (0, 180)"});
    } else {
      spec.fovYDeg = j["fov_y_deg"].get<double>();
    }
  }
  if (j.contains("near")) {
    if (!j["near"].is_number() || !(j["near"].get<double>() > 0.0)) {
      result.diagnostics.add({Severity::Error, file, "", "", "camera 'near': expected a positive number (metres)"});
    } else {
      spec.nearPlane = j["near"].get<double>();
    }
  }
  if (!spec.eyeXyz && !spec.eyeLonLatH) {
    result.diagnostics.add({Severity::Error, file, "", "", "camera: needs 'eye' (lon/lat/h) or 'eye_xyz'"});
  }
  if (!spec.targetXyz && !spec.targetLonLatH) {
    result.diagnostics.add({Severity::Error, file, "", "", "camera: needs 'target' (lon/lat/h) or 'target_xyz'"});
  }
  if (!result.diagnostics.hasErrors()) result.value = spec;
  return result;
}

Result<CameraSpec> loadCameraFile(const std::string& path) {
  Diagnostics diagnostics;
  const std::optional<json> j = readJsonFile(path, diagnostics);
  if (!j) {
    Result<CameraSpec> failed;
    failed.diagnostics = std::move(diagnostics);
    return failed;
  }
  return parseCameraSpec(*j, path);
}

Result<Camera> placeCamera(const CameraSpec& spec, const geo::SceneFrame& frame, const std::string& file) {
  auto place = [&](const std::optional<glm::dvec3>& xyz, const std::optional<glm::dvec3>& lonLatH,
                   const char* what) -> std::optional<glm::dvec3> {
    if (xyz) return xyz;
    if (lonLatH) return frame.fromLonLat(lonLatH->x, lonLatH->y, lonLatH->z);
    (void)what;
    return std::nullopt;
  };
  const std::optional<glm::dvec3> eye = place(spec.eyeXyz, spec.eyeLonLatH, "eye");
  const std::optional<glm::dvec3> target = place(spec.targetXyz, spec.targetLonLatH, "target");
  if (!eye || !target) {
    return Result<Camera>::failure(
        {Severity::Error, file, "", "", "camera: eye or target cannot be placed in the frame"});
  }
  if (glm::length(*target - *eye) <= 0.0) {
    return Result<Camera>::failure({Severity::Error, file, "", "", "camera: eye and target coincide"});
  }
  Camera camera;
  camera.eye = *eye;
  camera.target = *target;
  camera.fovYDeg = spec.fovYDeg;
  if (spec.nearPlane) camera.nearPlane = *spec.nearPlane;
  Result<Camera> result;
  result.value = camera;
  return result;
}

Camera overviewCamera(const glm::dvec3& boxMin, const glm::dvec3& boxMax, double fovYDeg) {
  const glm::dvec3 centre = (boxMin + boxMax) * 0.5;
  // Fit the box's horizontal half-diagonal into the vertical field of view at 40° down; the
  // near half of the box then fills the lower part of the picture, the far edge stays in view.
  const double radius = 0.5 * glm::length(glm::dvec2(boxMax - boxMin));
  const double distance = 0.8 * radius / std::tan(0.5 * fovYDeg * std::numbers::pi / 180.0) + (boxMax.z - boxMin.z);
  const double pitch = 40.0 * std::numbers::pi / 180.0;
  Camera camera;
  camera.target = centre;
  camera.eye = centre + glm::dvec3(0.0, -std::cos(pitch), std::sin(pitch)) * distance;
  camera.fovYDeg = fovYDeg;
  camera.nearPlane = std::max(0.1, distance * 1e-3);
  return camera;
}

Camera frameBoxInRegion(const Camera& camera, const glm::dvec3& boxMin, const glm::dvec3& boxMax,
                        const glm::ivec2& viewport, const glm::dvec4& region, double margin) {
  const glm::dvec2 regionSize(region.z - region.x, region.w - region.y);
  if (viewport.x <= 0 || viewport.y <= 0 || !(regionSize.x > 0.0) || !(regionSize.y > 0.0) ||
      !(glm::length(boxMax - boxMin) > 0.0)) {
    return camera;
  }
  const glm::dvec2 fit = regionSize * (1.0 - 2.0 * margin);
  const glm::dvec2 regionCentre(0.5 * (region.x + region.z), 0.5 * (region.y + region.w));
  const double aspect = static_cast<double>(viewport.x) / viewport.y;
  Camera c = camera;
  // Two nested searches. Outside, the distance to the target, bisected in log space (the box's
  // screen size shrinks as it grows). Inside, the box centred in the region at that distance by
  // sliding the camera across the view (a perspective slide is nearly linear: a few steps).
  const glm::dvec3 forward = glm::normalize(c.target - c.eye);
  const glm::dvec3 right = glm::normalize(glm::cross(forward, c.up));
  const glm::dvec3 up = glm::cross(right, forward);
  struct Fit {
    bool visible = false;  ///< every corner in front of the eye
    glm::dvec2 lo{0.0}, hi{0.0};
  };
  const auto project = [&](const Camera& cam) {
    Fit f;
    const glm::dmat4 viewProj = cam.projection(aspect) * cam.view();
    f.lo = glm::dvec2(std::numeric_limits<double>::infinity());
    f.hi = -f.lo;
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) != 0 ? boxMax.x : boxMin.x, (k & 2) != 0 ? boxMax.y : boxMin.y,
                              (k & 4) != 0 ? boxMax.z : boxMin.z);
      const glm::dvec4 clip = viewProj * glm::dvec4(corner, 1.0);
      if (clip.w <= 1e-9 * glm::length(boxMax - boxMin)) return f;
      const glm::dvec2 pixel((clip.x / clip.w * 0.5 + 0.5) * viewport.x, (0.5 - clip.y / clip.w * 0.5) * viewport.y);
      f.lo = glm::min(f.lo, pixel);
      f.hi = glm::max(f.hi, pixel);
    }
    f.visible = true;
    return f;
  };
  const glm::dvec3 centre = 0.5 * (boxMin + boxMax);
  // At `distance`: the camera looking along `forward` with the box centred; its fill of the region.
  // A slide along the view's right moves every corner's screen x the other way and leaves its
  // screen y (and depth) alone, and a slide along its up the same for y: each axis is centred by
  // its own bisection.
  const double size = glm::length(boxMax - boxMin);
  const auto place = [&](double distance, Camera& cam) {
    const auto at = [&](double sx, double sy) {
      Camera moved = cam;
      moved.target = centre + sx * right + sy * up;
      moved.eye = moved.target - forward * distance;
      return moved;
    };
    const auto centreOf = [&](double sx, double sy, int axis) {
      const Fit f = project(at(sx, sy));
      return f.visible ? 0.5 * (f.lo[axis] + f.hi[axis]) : std::numeric_limits<double>::quiet_NaN();
    };
    double sx = 0.0, sy = 0.0;
    for (int axis = 0; axis < 2; ++axis) {
      // x decreases as the camera slides right; y (down the screen) increases as it slides up.
      double lo = -10.0 * size, hi = 10.0 * size;
      for (int step = 0; step < 60; ++step) {
        const double mid = 0.5 * (lo + hi);
        const double got = axis == 0 ? centreOf(mid, sy, 0) : centreOf(sx, mid, 1);
        if (!std::isfinite(got)) return std::numeric_limits<double>::infinity();
        const bool pastCentre = axis == 0 ? got < regionCentre.x : got > regionCentre.y;
        (pastCentre ? hi : lo) = mid;
      }
      (axis == 0 ? sx : sy) = 0.5 * (lo + hi);
    }
    cam = at(sx, sy);
    const Fit f = project(cam);
    if (!f.visible) return std::numeric_limits<double>::infinity();
    return std::max((f.hi.x - f.lo.x) / fit.x, (f.hi.y - f.lo.y) / fit.y);
  };
  double near = 1e-3 * size, far = 1e3 * size;
  Camera best = c;
  place(far, best);
  for (int iteration = 0; iteration < 60; ++iteration) {
    const double mid = std::sqrt(near * far);
    Camera cam = c;
    if (place(mid, cam) > 1.0) {
      near = mid;  // too large: farther
    } else {
      far = mid;
      best = cam;
    }
  }
  c = best;
  c.nearPlane = std::max(0.1, glm::length(c.target - c.eye) * 1e-3);
  return c;
}

json cameraToJson(const Camera& camera, const geo::SceneFrame& frame, int width, int height) {
  json j;
  j["width"] = width;
  j["height"] = height;
  j["view"] = matrixToJson(camera.view());
  j["proj"] = matrixToJson(camera.projection(static_cast<double>(width) / static_cast<double>(height)));
  j["depth"] = {{"convention", "reversed-z"},
                {"clip_control", "GL_LOWER_LEFT, GL_ZERO_TO_ONE"},
                {"format", "float32 GL_DEPTH32F_STENCIL8"},
                {"near", camera.nearPlane},
                {"far", "infinite"},
                {"background", 0.0},
                {"note", "depth = near / distance along the view axis; view and proj map frame coordinates"}};
  const std::optional<int> epsg = frame.epsg();
  j["crs"] = epsg ? json("EPSG:" + std::to_string(*epsg)) : json(frame.crsWkt());
  j["crs_wkt"] = frame.crsWkt();
  j["origin"] = {frame.origin().x, frame.origin().y, frame.origin().z};
  j["eye_xyz"] = {camera.eye.x, camera.eye.y, camera.eye.z};
  j["target_xyz"] = {camera.target.x, camera.target.y, camera.target.z};
  if (const auto e = frame.toLonLat(camera.eye)) j["eye"] = {{"lon", e->x}, {"lat", e->y}, {"h", e->z}};
  if (const auto t = frame.toLonLat(camera.target)) j["target"] = {{"lon", t->x}, {"lat", t->y}, {"h", t->z}};
  j["fov_y_deg"] = camera.fovYDeg;
  j["near"] = camera.nearPlane;
  return j;
}

}  // namespace gis::scene
