// How the camera follows the mouse and keys, in each frame's own way (docs/viewer.md): a projected
// scene orbits about the terrain at the view's centre, pans and zooms at the cursor
// (scene::CameraController); the globe is grabbed, orbited about its target and zoomed to the
// cursor from space to a metre above the ground (scene::GlobeCameraController). Both fly with
// W A S D and a drag to look. Everything else the mouse and keys do is the tools' (viewer_input.cpp),
// the same in both frames.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "viewer.hpp"

namespace gis::viewer {
namespace {

constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;
/// The globe's orbit (right drag, Ctrl+left drag): radians of heading and pitch per pixel.
constexpr double kOrbitPerPixel = 0.005;
constexpr double kLookPerPixel = 0.003;  ///< the globe's fly: radians the view turns per pixel dragged
/// The globe's arrow keys: heading and pitch steps, radians.
constexpr double kArrowHeading = 10.0 * kRadiansPerDegree;
constexpr double kArrowPitch = 5.0 * kRadiansPerDegree;

/// The pose that looks at `target` from `eye` (ECEF): its distance, and heading and pitch in the
/// target's east-north-up frame (scene::GlobePose).
scene::GlobePose poseLooking(const glm::dvec3& eye, const glm::dvec3& target) {
  scene::GlobePose p;
  p.target = globe::toGeodetic(target);
  const glm::dvec3 d = eye - target;
  p.distance = glm::length(d);
  if (!(p.distance > 0.0)) return p;
  const glm::dmat3 enu = globe::enuBasis(p.target.lon, p.target.lat);
  const glm::dvec3 local(glm::dot(d, enu[0]), glm::dot(d, enu[1]), glm::dot(d, enu[2]));
  p.pitch = std::asin(std::clamp(local.z / p.distance, -1.0, 1.0));
  // The view looks along −d: its heading is that of (−east, −north). Looking straight down (within
  // the rounding of the ECEF points) it has none: north up.
  p.heading = std::hypot(local.x, local.y) <= 1e-9 * p.distance ? 0.0 : std::atan2(-local.x, -local.y);
  return p;
}

}  // namespace

void Viewer::navigate(const InputFrame& in, bool pressed, bool dragStarts) {
  const glm::dvec2 pixel = in.cursor, last = lastPixel_;
  const glm::ivec2 fb = framebufferSize();
  const bool fly = flying();
  const bool leftDrags = in.left && leftDown_ && !lassoTool_ && dragged_;
  const bool otherDrags = (in.right && rightDown_) || (in.middle && middleDown_);
  if (globe_) {
    scene::GlobeCameraController& c = *globe_->controller;
    const bool orbit = otherDrags || (leftDrags && in.modifiers.ctrl);
    // The globe follows a drag from the press on (the first move is the one from the press).
    const glm::dvec2 from = dragStarts ? pressCursor_ : last;
    const glm::dvec2 move = pixel - from;
    if (fly && (orbit || leftDrags)) {
      // Every drag turns the view about the eye.
      if (move != glm::dvec2(0.0)) c.look(move.x * kLookPerPixel, move.y * kLookPerPixel);
    } else if (orbit) {
      if (move != glm::dvec2(0.0)) c.orbit(move.x * kOrbitPerPixel, move.y * kOrbitPerPixel);
    } else if (leftDrags) {
      if (from != pixel) c.grab(from, pixel, fb);
    }
    if (in.scroll != 0.0) c.zoomToCursor(in.scroll, pixel, fb);
    return;
  }
  // Orbit about the terrain at the centre of the view: reversed-Z depth is near / distance along
  // the view axis.
  if (pressed && !lassoTool_ && !fly) {
    if (const std::optional<float> depth = depthAt(fb.x / 2, fb.y / 2)) {
      controller_->pivotAt(camera().nearPlane / static_cast<double>(*depth));
    }
  }
  if (leftDrags) {
    if (fly) {
      controller_->look(pixel - last);
    } else {
      controller_->orbit(pixel - last);
    }
  } else if (otherDrags && !(in.left && lassoTool_)) {
    if (fly) {
      controller_->look(pixel - last);
    } else {
      controller_->pan(last, pixel, fb);
    }
  }
  if (in.scroll != 0.0) controller_->zoomAt(in.scroll, pixel, fb, pointAt(pixel));
}

bool Viewer::flying() const {
  if (globe_) return globe_->fly;
  return controller_ && controller_->mode() == scene::CameraController::Mode::Fly;
}

void Viewer::setFlying(bool fly) {
  if (globe_) {
    globe_->fly = fly;
  } else {
    controller_->setMode(fly ? scene::CameraController::Mode::Fly : scene::CameraController::Mode::Orbit);
  }
  message(fly ? "fly: W A S D move, Q E down and up, Shift faster, drag to look" : "orbit");
}

void Viewer::flyBy(const glm::dvec3& move, double seconds) {
  if (globe_) {
    globe_->controller->fly(move, seconds);
  } else {
    controller_->fly(move, seconds);
  }
}

bool Viewer::navigationKey(int key) {
  if (!globe_) return false;
  scene::GlobeCameraController& c = *globe_->controller;
  const glm::ivec2 fb = framebufferSize();
  switch (key) {
    case GLFW_KEY_LEFT:
      c.orbit(-kArrowHeading, 0.0);
      return true;
    case GLFW_KEY_RIGHT:
      c.orbit(kArrowHeading, 0.0);
      return true;
    case GLFW_KEY_UP:
      c.orbit(0.0, -kArrowPitch);
      return true;
    case GLFW_KEY_DOWN:
      c.orbit(0.0, kArrowPitch);
      return true;
    case GLFW_KEY_PAGE_UP:
      c.zoomToCursor(1.0, glm::dvec2(fb) * 0.5, fb);
      return true;
    case GLFW_KEY_PAGE_DOWN:
      c.zoomToCursor(-1.0, glm::dvec2(fb) * 0.5, fb);
      return true;
    default:
      return false;
  }
}

void Viewer::globeHome() {
  GlobeMode& g = *globe_;
  const glm::ivec2 fb = framebufferSize();
  const std::optional<scene::CameraSpec>& spec = globeScene().description.camera;
  if (spec && spec->eyeLonLatH && spec->targetLonLatH) {
    // The scene's own camera, as its author placed it, seen in the part of the window the panel
    // leaves free.
    const globe::GlobeView v = scene::globeStillView(globeScene(), std::max(fb.x, 1), std::max(fb.y, 1));
    g.controller->setPose(poseLooking(v.eye, v.target));
    g.controller->centreIn(glm::ivec2(std::max(fb.x, 1), std::max(fb.y, 1)), freeRegion());
    return;
  }
  const std::array<double, 4>& e = globeScene().extent;
  // Framed in the part of the window the panel leaves free, as in a projected frame.
  g.controller->home(e[0], e[1], e[2], e[3], glm::ivec2(std::max(fb.x, 1), std::max(fb.y, 1)), freeRegion());
}

}  // namespace gis::viewer
