#include "scene/camera_controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

namespace gis::scene {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMinDistance = 1.0;
constexpr double kMaxDistance = 1e7;
// Plane hits farther than this many orbit distances are taken at this reach: near the horizon the
// hit runs off to infinity and a pan or zoom would throw the view away.
constexpr double kPlaneReach = 50.0;
// A stalled frame (debugger, window drag) must not fly the eye kilometres away.
constexpr double kMaxFlySeconds = 1.0;
// The shown camera snaps to the goal once within this: 1e-5 of the distance or radian is ~1/80 pixel
// at 45° over 1000 pixels.
constexpr double kSettle = 1e-5;
constexpr double kSettleFovDeg = 1e-3;
// Depth points farther than this are no terrain (a cleared depth buffer read back, say).
constexpr double kMaxFocusDistance = 1e9;
constexpr double kMinNear = 0.05;
constexpr double kMaxNear = 1000.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool finite(const glm::dvec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const OrbitPose& p) {
  return finite(p.target) && std::isfinite(p.yaw) && std::isfinite(p.pitch) && std::isfinite(p.distance) &&
         std::isfinite(p.fovYDeg);
}

double wrapAngle(double a) { return std::remainder(a, 2.0 * kPi); }

double sanitizedFov(double fovYDeg) { return std::isfinite(fovYDeg) ? std::clamp(fovYDeg, 1.0, 179.0) : 45.0; }

/// Unit vector from the target to the eye.
glm::dvec3 backward(double yaw, double pitch) {
  return glm::dvec3(std::cos(pitch) * std::sin(yaw), -std::cos(pitch) * std::cos(yaw), std::sin(pitch));
}

glm::dvec3 rightOf(double yaw) { return glm::dvec3(std::cos(yaw), std::sin(yaw), 0.0); }

/// right × forward: orthogonal to the view and defined for every pitch, straight down included (then
/// it points along the heading).
glm::dvec3 upOf(double yaw, double pitch) {
  return glm::dvec3(-std::sin(pitch) * std::sin(yaw), std::sin(pitch) * std::cos(yaw), std::cos(pitch));
}

glm::dvec3 eyeOf(const OrbitPose& p) { return p.target + p.distance * backward(p.yaw, p.pitch); }

/// Heading of a vertical view from the camera's up vector: looking down, up points along the heading;
/// looking up, against it.
double yawFromUp(const glm::dvec3& up, double eyeAboveTarget) {
  const double s = eyeAboveTarget >= 0.0 ? 1.0 : -1.0;
  if (!finite(up) || std::hypot(up.x, up.y) < 1e-12) return 0.0;
  return std::atan2(-s * up.x, s * up.y);
}

/// The pose of an eye looking at a target; `yawHint` gives the heading of a vertical view. A distance
/// out of [1, 1e7] is clamped keeping the eye (`keepEye`) or the target.
std::optional<OrbitPose> poseFrom(const glm::dvec3& eye, const glm::dvec3& target, double fovYDeg, double yawHint,
                                  bool keepEye) {
  if (!finite(eye) || !finite(target)) return std::nullopt;
  const glm::dvec3 d = eye - target;
  const double length = glm::length(d);
  if (!std::isfinite(length)) return std::nullopt;
  OrbitPose p;
  p.fovYDeg = sanitizedFov(fovYDeg);
  const double horizontal = std::hypot(d.x, d.y);
  const double hint = std::isfinite(yawHint) ? wrapAngle(yawHint) : 0.0;
  if (length > 0.0) {
    p.pitch = std::atan2(d.z, horizontal);
    p.yaw = horizontal > 1e-9 * length ? std::atan2(d.x, -d.y) : hint;
  } else {
    p.yaw = hint;
    p.pitch = kPi / 4.0;
  }
  p.distance = std::clamp(length, kMinDistance, kMaxDistance);
  p.target = keepEye && p.distance != length ? eye - p.distance * backward(p.yaw, p.pitch) : target;
  return p;
}

/// Moves `t` of the way from `a` to `b`: yaw the short way round, distance in log space (zooming feels
/// uniform), and the target or, when flying, the eye along a straight line.
OrbitPose interpolate(const OrbitPose& a, const OrbitPose& b, double t, bool eyeAnchored) {
  if (!(t > 0.0)) return a;
  if (t >= 1.0) return b;
  OrbitPose p;
  p.yaw = wrapAngle(a.yaw + t * wrapAngle(b.yaw - a.yaw));
  p.pitch = a.pitch + t * (b.pitch - a.pitch);
  p.distance = std::clamp(std::exp(std::log(a.distance) + t * (std::log(b.distance) - std::log(a.distance))),
                          kMinDistance, kMaxDistance);
  p.fovYDeg = a.fovYDeg + t * (b.fovYDeg - a.fovYDeg);
  if (eyeAnchored) {
    const glm::dvec3 eye = glm::mix(eyeOf(a), eyeOf(b), t);
    p.target = eye - p.distance * backward(p.yaw, p.pitch);
  } else {
    p.target = glm::mix(a.target, b.target, t);
  }
  return p;
}

bool closeEnough(const OrbitPose& a, const OrbitPose& b) {
  const double tolerance = kSettle * std::max(b.distance, 1.0);
  return glm::length(a.target - b.target) <= tolerance && glm::length(eyeOf(a) - eyeOf(b)) <= tolerance &&
         std::abs(wrapAngle(a.yaw - b.yaw)) <= kSettle && std::abs(a.pitch - b.pitch) <= kSettle &&
         std::abs(std::log(a.distance / b.distance)) <= kSettle && std::abs(a.fovYDeg - b.fovYDeg) <= kSettleFovDeg;
}

/// Highest finite ground at and around (within `radius` of) `xy`: the eye then also keeps its distance
/// from a cliff face beside it. NaN off the terrain.
double groundNear(const HeightAt& height, const glm::dvec3& eye, double radius) {
  if (!height) return kNaN;
  const glm::dvec2 xy(eye.x, eye.y);
  const glm::dvec2 around[] = {glm::dvec2(0.0), glm::dvec2(radius, 0.0), glm::dvec2(-radius, 0.0),
                               glm::dvec2(0.0, radius), glm::dvec2(0.0, -radius)};
  double best = kNaN;
  for (const glm::dvec2& offset : around) {
    const double h = height(xy + offset);
    if (std::isfinite(h) && !(h <= best)) best = h;
  }
  return best;
}

/// Raises the eye to `floor` if it is lower. Orbit keeps the target (the eye rises straight up and the
/// view tilts down, as when a hill comes between); flying raises the whole view.
void lift(OrbitPose& p, double floor, bool eyeAnchored) {
  if (!std::isfinite(floor)) return;
  // The eye recomputed from the pose can land a rounding error short of the floor, and an eye short by
  // 1e-14 would be lifted again every frame and never rest: repeat with doubling steps until it is on.
  for (int round = 0; round < 8; ++round) {
    glm::dvec3 eye = eyeOf(p);
    const double shortfall = floor - eye.z;
    if (!(shortfall > 0.0)) return;
    const double step = std::ldexp(shortfall, round);
    if (eyeAnchored) {
      if (!std::isfinite(p.target.z + step)) return;
      p.target.z += step;
    } else {
      eye.z += step;
      const std::optional<OrbitPose> lifted = poseFrom(eye, p.target, p.fovYDeg, p.yaw, true);
      if (!lifted) return;
      p = *lifted;
    }
  }
}

double nearFor(const OrbitPose& p, double ground) {
  const double above = std::isfinite(ground) ? eyeOf(p).z - ground : p.distance;
  return std::clamp(0.5 * std::min(above, p.distance), kMinNear, kMaxNear);
}

Camera cameraOf(const OrbitPose& p, double nearPlane) {
  Camera c;
  c.eye = eyeOf(p);
  c.target = p.target;
  c.up = upOf(p.yaw, p.pitch);
  c.fovYDeg = p.fovYDeg;
  c.nearPlane = nearPlane;
  return c;
}

std::pair<glm::dvec3, glm::dvec3> rayOf(const OrbitPose& p, const glm::dvec2& pixel, const glm::ivec2& viewport) {
  const double width = static_cast<double>(std::max(viewport.x, 1));
  const double height = static_cast<double>(std::max(viewport.y, 1));
  const glm::dvec2 centre = finite(pixel) ? pixel + 0.5 : glm::dvec2(0.5 * width, 0.5 * height);
  // Clamped so that absurd pixels still give a finite direction (almost perpendicular to the view).
  const double ndcX = std::clamp(2.0 * centre.x / width - 1.0, -1e6, 1e6);
  const double ndcY = std::clamp(1.0 - 2.0 * centre.y / height, -1e6, 1e6);
  const double tanHalf = std::tan(0.5 * p.fovYDeg * kPi / 180.0);
  const glm::dvec3 direction = -backward(p.yaw, p.pitch) + rightOf(p.yaw) * (ndcX * tanHalf * width / height) +
                               upOf(p.yaw, p.pitch) * (ndcY * tanHalf);
  return {eyeOf(p), glm::normalize(direction)};
}

/// Where a ray meets the plane z = planeZ, at most `reach` along it; beyond (or missing the plane) the
/// plane point below the ray's point at `reach`, which is continuous across the horizon.
glm::dvec3 planePoint(const std::pair<glm::dvec3, glm::dvec3>& ray, double planeZ, double reach) {
  const auto& [origin, direction] = ray;
  const double t = (planeZ - origin.z) / direction.z;
  if (direction.z != 0.0 && t > 0.0 && t <= reach) {
    return glm::dvec3(origin.x + t * direction.x, origin.y + t * direction.y, planeZ);
  }
  return glm::dvec3(origin.x + reach * direction.x, origin.y + reach * direction.y, planeZ);
}

ControllerSettings sanitized(ControllerSettings s) {
  const ControllerSettings defaults;
  auto positive = [](double value, double fallback) { return std::isfinite(value) && value > 0.0 ? value : fallback; };
  auto nonNegative = [](double value, double fallback) {
    return std::isfinite(value) ? std::max(value, 0.0) : fallback;
  };
  s.orbitRadiansPerPixel =
      std::isfinite(s.orbitRadiansPerPixel) ? s.orbitRadiansPerPixel : defaults.orbitRadiansPerPixel;
  s.lookRadiansPerPixel = std::isfinite(s.lookRadiansPerPixel) ? s.lookRadiansPerPixel : defaults.lookRadiansPerPixel;
  s.zoomPerWheelStep = positive(s.zoomPerWheelStep, defaults.zoomPerWheelStep);
  s.flySpeedPerSecond = nonNegative(s.flySpeedPerSecond, defaults.flySpeedPerSecond);
  s.minFlySpeed = nonNegative(s.minFlySpeed, defaults.minFlySpeed);
  s.smoothing = nonNegative(s.smoothing, defaults.smoothing);
  s.groundClearance = nonNegative(s.groundClearance, defaults.groundClearance);
  s.minPitch = std::isfinite(s.minPitch) ? std::clamp(s.minPitch, -kPi / 2.0, kPi / 2.0) : defaults.minPitch;
  s.maxPitch = std::isfinite(s.maxPitch) ? std::clamp(s.maxPitch, -kPi / 2.0, kPi / 2.0) : defaults.maxPitch;
  if (s.maxPitch < s.minPitch) std::swap(s.minPitch, s.maxPitch);
  return s;
}

}  // namespace

CameraController::CameraController(const Camera& home, ControllerSettings settings) : settings_(sanitized(settings)) {
  setHome(home);
  jumpTo(home_);
  const glm::dvec3 eye = eyeOf(goal_);
  goalAboveGround_ = eye.z > goal_.target.z ? eye.z - goal_.target.z : goal_.distance;
}

std::optional<OrbitPose> CameraController::poseOf(const Camera& c) const {
  const double yawHint = yawFromUp(c.up, c.eye.z - c.target.z);
  return poseFrom(c.eye, c.target, c.fovYDeg, yawHint, eyeAnchored());
}

void CameraController::setHome(const Camera& home) {
  if (poseOf(home)) home_ = home;
}

void CameraController::goHome() {
  if (const std::optional<OrbitPose> pose = poseOf(home_)) setGoal(*pose);
}

void CameraController::setHeading(double yaw) {
  if (!std::isfinite(yaw)) return;
  OrbitPose g = goal_;
  const glm::dvec3 eye = eyeOf(g);
  g.yaw = wrapAngle(yaw);
  if (eyeAnchored()) g.target = eye - g.distance * backward(g.yaw, g.pitch);
  setGoal(g);
}

void CameraController::jumpTo(const Camera& c) {
  const std::optional<OrbitPose> pose = poseOf(c);
  if (!pose) return;
  animation_.reset();
  shown_ = goal_ = *pose;
  const double nearPlane = std::isfinite(c.nearPlane) && c.nearPlane > 0.0 ? std::clamp(c.nearPlane, kMinNear, kMaxNear)
                                                                           : nearFor(*pose, kNaN);
  shownNear_ = goalNear_ = nearPlane;
}

void CameraController::animateTo(const Camera& c, double seconds) {
  if (!(seconds > 0.0 && std::isfinite(seconds))) {
    jumpTo(c);
    return;
  }
  const std::optional<OrbitPose> pose = poseOf(c);
  if (!pose) return;
  goal_ = *pose;
  animation_ = Animation{shown_, seconds, 0.0, eyeAnchored()};
}

void CameraController::setGoal(const OrbitPose& goal) {
  if (!finite(goal)) return;
  animation_.reset();
  goal_ = goal;
}

void CameraController::orbit(const glm::dvec2& deltaPixels) {
  const glm::dvec2 turn = deltaPixels * settings_.orbitRadiansPerPixel;
  if (!finite(turn) || turn == glm::dvec2(0.0)) return;  // idle input must not end an animation
  OrbitPose g = goal_;
  g.yaw = wrapAngle(g.yaw - turn.x);
  // A pitch left outside the limits by fly mode may come back but not go further out.
  g.pitch = std::clamp(g.pitch + turn.y, std::min(settings_.minPitch, g.pitch), std::max(settings_.maxPitch, g.pitch));
  setGoal(g);
}

void CameraController::pivotAt(double distance) {
  if (animation_ || !(shown_ == goal_) || !std::isfinite(distance)) return;
  if (distance < kMinDistance || distance > kMaxDistance) return;
  OrbitPose p = shown_;
  const glm::dvec3 eye = eyeOf(p);
  p.target = eye - distance * backward(p.yaw, p.pitch);
  p.distance = distance;
  shown_ = goal_ = p;
}

void CameraController::pan(const glm::dvec2& from, const glm::dvec2& to, const glm::ivec2& viewport) {
  if (!finite(from) || !finite(to) || from == to) return;
  OrbitPose g = goal_;
  const double reach = kPlaneReach * g.distance;
  const glm::dvec3 grabbed = planePoint(rayOf(g, from, viewport), g.target.z, reach);
  const glm::dvec3 under = planePoint(rayOf(g, to, viewport), g.target.z, reach);
  // Translating the whole view by grabbed − under moves the plane point under `to` onto `grabbed`.
  g.target += glm::dvec3(grabbed.x - under.x, grabbed.y - under.y, 0.0);
  setGoal(g);
}

void CameraController::zoomAt(double wheelSteps, const glm::dvec2& cursor, const glm::ivec2& viewport,
                              std::optional<glm::dvec3> pointUnderCursor) {
  if (!std::isfinite(wheelSteps) || wheelSteps == 0.0 || !finite(cursor)) return;
  OrbitPose g = goal_;
  const auto [eye, direction] = rayOf(g, cursor, viewport);
  glm::dvec3 focus;
  if (pointUnderCursor && finite(*pointUnderCursor) && glm::length(*pointUnderCursor - eye) <= kMaxFocusDistance) {
    focus = *pointUnderCursor;
    // The point comes from the frame last drawn, and the goal may be ahead of it: shift the goal so that
    // the point lies on its cursor ray (a no-op once the view has settled).
    g.target += focus - (eye + direction * glm::length(focus - eye));
  } else {
    const double t = (g.target.z - eye.z) / direction.z;
    const double depth = t > 0.0 ? std::min(t, kPlaneReach * g.distance) : g.distance;
    focus = eye + direction * depth;
  }
  // Scaling the view about the focus keeps the orientation and the focus on the same ray from the eye.
  const double distance =
      std::clamp(g.distance * std::pow(settings_.zoomPerWheelStep, wheelSteps), kMinDistance, kMaxDistance);
  g.target = focus + (g.target - focus) * (distance / g.distance);
  g.distance = distance;
  setGoal(g);
}

void CameraController::fly(const glm::dvec3& move, double seconds) {
  if (!finite(move) || move == glm::dvec3(0.0) || !(seconds > 0.0)) return;  // called every frame, keys or not
  OrbitPose g = goal_;
  const glm::dvec3 m = glm::clamp(move, glm::dvec3(-1.0), glm::dvec3(1.0));
  const double speed = std::max(settings_.flySpeedPerSecond * goalAboveGround_, settings_.minFlySpeed);
  const glm::dvec3 step = rightOf(g.yaw) * m.x - backward(g.yaw, g.pitch) * m.y + glm::dvec3(0.0, 0.0, m.z);
  g.target += step * (speed * std::min(seconds, kMaxFlySeconds));
  setGoal(g);
}

void CameraController::look(const glm::dvec2& deltaPixels) {
  const glm::dvec2 turn = deltaPixels * settings_.lookRadiansPerPixel;
  if (!finite(turn) || turn == glm::dvec2(0.0)) return;
  OrbitPose g = goal_;
  const glm::dvec3 eye = eyeOf(g);
  g.yaw = wrapAngle(g.yaw - turn.x);
  g.pitch = std::clamp(g.pitch + turn.y, -kPi / 2.0, kPi / 2.0);
  g.target = eye - g.distance * backward(g.yaw, g.pitch);
  setGoal(g);
}

bool CameraController::update(double seconds, const HeightAt& height) {
  const double dt = seconds > 0.0 ? seconds : 0.0;
  const double clearance = settings_.groundClearance;
  const OrbitPose before = shown_;

  // The goal first, so that the shown camera approaches a goal that is already above ground.
  const double goalGround = groundNear(height, eyeOf(goal_), clearance);
  lift(goal_, goalGround + clearance, eyeAnchored());
  goalNear_ = nearFor(goal_, goalGround);
  goalAboveGround_ = std::isfinite(goalGround) ? eyeOf(goal_).z - goalGround : goal_.distance;

  if (animation_) {
    animation_->elapsed += dt;
    if (animation_->elapsed >= animation_->seconds) {
      shown_ = goal_;
      animation_.reset();
    } else {
      const double s = animation_->elapsed / animation_->seconds;
      shown_ = interpolate(animation_->from, goal_, s * s * (3.0 - 2.0 * s), animation_->eyeAnchored);
    }
  } else {
    // 1 − exp(−k·dt) is frame-rate independent: two half steps move as far as one whole one.
    const double alpha = settings_.smoothing > 0.0 ? 1.0 - std::exp(-settings_.smoothing * dt) : 1.0;
    shown_ = interpolate(shown_, goal_, alpha, eyeAnchored());
    if (closeEnough(shown_, goal_)) shown_ = goal_;
  }

  // The way between two views may dip into a hill even when both ends are above it.
  const double shownGround = groundNear(height, eyeOf(shown_), clearance);
  lift(shown_, shownGround + clearance, eyeAnchored());
  shownNear_ = nearFor(shown_, shownGround);
  return !(shown_ == before) || !(shown_ == goal_) || animation_.has_value();
}

Camera CameraController::camera() const { return cameraOf(shown_, shownNear_); }

Camera CameraController::goal() const { return cameraOf(goal_, goalNear_); }

std::pair<glm::dvec3, glm::dvec3> CameraController::rayThrough(const glm::dvec2& pixel,
                                                               const glm::ivec2& viewport) const {
  return rayOf(shown_, pixel, viewport);
}

}  // namespace gis::scene
