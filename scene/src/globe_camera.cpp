#include "scene/globe_camera.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

namespace gis::scene {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDegree = kPi / 180.0;
// Distances the camera may hold at all, metres (the limits proper come from the settings).
constexpr double kMinDistance = 1e-3;
constexpr double kMaxDistance = 1e9;
// Away from the poles a gesture keeps the heading relative to north; within this latitude of them
// north turns too fast under a moving target, and the heading is carried along with the globe instead.
constexpr double kNorthKeepingLat = 89.0;
// Newton runs until the point is this close to its place (NDC) or stops improving: the point must stay
// within a fraction of a pixel from 2·10^7 m down to 1 m, so metres of slack at the top would be pixels
// at the bottom. A solve farther off than kNdcAcceptable (5·10^-4 pixel on 1000) is refused.
constexpr double kNdcTolerance = 1e-15;
constexpr double kNdcAcceptable = 1e-6;

bool finite(const glm::dvec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const GlobePose& p) {
  return std::isfinite(p.target.lon) && std::isfinite(p.target.lat) && std::isfinite(p.target.h) &&
         std::isfinite(p.distance) && std::isfinite(p.heading) && std::isfinite(p.pitch);
}

double wrapAngle(double a) {
  const double w = std::remainder(a, 2.0 * kPi);
  return w <= -kPi ? w + 2.0 * kPi : w;
}

double wrapLon(double lon) {
  const double w = std::remainder(lon, 360.0);
  return w <= -180.0 ? w + 360.0 : w;
}

double maxAbs(const glm::dvec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

/// The camera of a pose in ECEF: eye, target, and the view's forward, up and right unit vectors.
struct Frame {
  glm::dvec3 eye{0.0};
  glm::dvec3 target{0.0};
  glm::dvec3 forward{0.0};
  glm::dvec3 up{0.0};
  glm::dvec3 right{0.0};
};

Frame frameOf(const GlobePose& p) {
  const glm::dmat3 enu = globe::enuBasis(p.target.lon, p.target.lat);
  const glm::dvec3 level = std::sin(p.heading) * enu[0] + std::cos(p.heading) * enu[1];  // horizontal forward
  const double cp = std::cos(p.pitch), sp = std::sin(p.pitch);
  Frame f;
  f.target = globe::toEcef(p.target);
  f.forward = cp * level - sp * enu[2];
  f.eye = f.target - p.distance * f.forward;
  // The target's up projected on the screen; looking straight down it is the heading's direction.
  f.up = sp * level + cp * enu[2];
  f.right = glm::cross(f.forward, f.up);
  return f;
}

double tanHalfFov(double fovYDeg) { return std::tan(0.5 * fovYDeg * kDegree); }

/// A point's normalised device coordinates in the frame's view; empty behind the eye.
std::optional<glm::dvec2> ndcOf(const Frame& f, const glm::dvec3& point, double tanHalf, double aspect) {
  const glm::dvec3 v = point - f.eye;
  const double depth = glm::dot(v, f.forward);
  if (!(depth > 0.0)) return std::nullopt;
  return glm::dvec2(glm::dot(v, f.right) / (depth * tanHalf * aspect), glm::dot(v, f.up) / (depth * tanHalf));
}

glm::dvec3 rayDirection(const Frame& f, const glm::dvec2& ndc, double tanHalf, double aspect) {
  return glm::normalize(f.forward + f.right * (ndc.x * tanHalf * aspect) + f.up * (ndc.y * tanHalf));
}

/// First hit of a ray with the ellipsoid raised by `h` (semi-axes a + h, b + h); if the origin is
/// inside it, the way out. Empty if the ray misses it.
std::optional<double> rayEllipsoid(const glm::dvec3& origin, const glm::dvec3& direction, double h) {
  const glm::dvec3 radii(globe::kSemiMajor + h, globe::kSemiMajor + h, globe::kSemiMinor + h);
  const glm::dvec3 o = origin / radii, d = direction / radii;
  const double a = glm::dot(d, d), b = glm::dot(o, d), c = glm::dot(o, o) - 1.0;
  const double disc = b * b - a * c;
  if (!(disc >= 0.0) || !(a > 0.0)) return std::nullopt;
  const double root = std::sqrt(disc);
  const double near = (-b - root) / a, far = (-b + root) / a;
  if (near > 0.0) return near;
  if (far > 0.0) return far;
  return std::nullopt;
}

double eyeHeightOf(const GlobePose& p) { return globe::toGeodetic(frameOf(p).eye).h; }

GlobeCameraSettings sanitized(GlobeCameraSettings s) {
  const GlobeCameraSettings d;
  s.fovYDeg = std::isfinite(s.fovYDeg) ? std::clamp(s.fovYDeg, 1.0, 170.0) : d.fovYDeg;
  s.minHeight = std::isfinite(s.minHeight) && s.minHeight > 0.0 ? s.minHeight : d.minHeight;
  s.maxHeight = std::isfinite(s.maxHeight) && s.maxHeight > 2.0 * s.minHeight
                    ? std::min(s.maxHeight, 1e8)
                    : std::max(d.maxHeight, 4.0 * s.minHeight);
  s.zoomPerStep =
      std::isfinite(s.zoomPerStep) && s.zoomPerStep > 0.0 && s.zoomPerStep < 1.0 ? s.zoomPerStep : d.zoomPerStep;
  s.minPitch = std::isfinite(s.minPitch) ? std::clamp(s.minPitch, 1e-3, kPi / 2.0) : d.minPitch;
  return s;
}

}  // namespace

GlobeCameraController::GlobeCameraController(const globe::GeoGrid* ground, GlobeCameraSettings settings)
    : ground_(ground), settings_(sanitized(settings)) {
  pose_.target = {0.0, 0.0, groundHeight(0.0, 0.0)};
  home(-180.0, -90.0, 180.0, 90.0, glm::ivec2(1, 1));
}

double GlobeCameraController::groundHeight(double lonDeg, double latDeg) const {
  if (ground_ == nullptr || !std::isfinite(lonDeg) || !std::isfinite(latDeg)) return 0.0;
  const double h = ground_->heightAt(wrapLon(lonDeg), std::clamp(latDeg, -90.0, 90.0));
  return std::isfinite(h) ? h : 0.0;
}

void GlobeCameraController::setGround(const globe::GeoGrid* ground) {
  ground_ = ground;
  GlobePose p = pose_;
  p.target.h = groundHeight(p.target.lon, p.target.lat);
  accept(limited(p));
}

void GlobeCameraController::setPose(const GlobePose& pose) {
  if (!finite(pose)) return;
  GlobePose p = pose;
  p.target.lon = wrapLon(p.target.lon);
  p.target.lat = std::clamp(p.target.lat, -90.0, 90.0);
  p.target.h = groundHeight(p.target.lon, p.target.lat);
  p.distance = std::clamp(p.distance, kMinDistance, kMaxDistance);
  p.heading = wrapAngle(p.heading);
  p.pitch = std::clamp(p.pitch, settings_.minPitch, kPi / 2.0);
  accept(limited(p));
}

void GlobeCameraController::accept(const GlobePose& p) {
  if (finite(p) && finite(frameOf(p).eye)) pose_ = p;
}

glm::dvec3 GlobeCameraController::eye() const { return frameOf(pose_).eye; }

double GlobeCameraController::heightAboveGround() const {
  const globe::Geodetic g = globe::toGeodetic(eye());
  return g.h - groundHeight(g.lon, g.lat);
}

globe::GlobeView GlobeCameraController::view(int width, int height) const {
  const Frame f = frameOf(pose_);
  const globe::Geodetic g = globe::toGeodetic(f.eye);
  globe::GlobeView v = globe::GlobeView::looking(f.eye, f.target, settings_.fovYDeg, std::max(width, 1),
                                                 std::max(height, 1), groundHeight(g.lon, g.lat));
  v.up = f.up;
  return v;
}

namespace {

double aspectOf(const glm::ivec2& viewport) {
  return static_cast<double>(std::max(viewport.x, 1)) / static_cast<double>(std::max(viewport.y, 1));
}

glm::dvec2 ndcOfPixel(const glm::dvec2& pixel, const glm::ivec2& viewport) {
  const double w = static_cast<double>(std::max(viewport.x, 1)), h = static_cast<double>(std::max(viewport.y, 1));
  return {2.0 * (pixel.x + 0.5) / w - 1.0, 1.0 - 2.0 * (pixel.y + 0.5) / h};
}

}  // namespace

std::optional<glm::dvec3> GlobeCameraController::groundPointAt(const glm::dvec2& pixel,
                                                               const glm::ivec2& viewport) const {
  if (!finite(pixel)) return std::nullopt;
  return groundPointAtNdc(pose_, ndcOfPixel(pixel, viewport), aspectOf(viewport));
}

std::optional<glm::dvec3> GlobeCameraController::groundPointAtNdc(const GlobePose& p, const glm::dvec2& ndc,
                                                                  double aspect) const {
  const Frame f = frameOf(p);
  const glm::dvec3 direction = rayDirection(f, ndc, tanHalfFov(settings_.fovYDeg), aspect);
  if (!finite(direction)) return std::nullopt;
  // Raise the ellipsoid until the hit lies on the ground there (a secant iteration on the
  // inflation: the raised ellipsoid is not quite the surface at that geodetic height).
  double inflation = p.target.h;
  std::optional<glm::dvec3> hit;
  for (int i = 0; i < 12; ++i) {
    const std::optional<double> t = rayEllipsoid(f.eye, direction, inflation);
    if (!t) break;
    hit = f.eye + *t * direction;
    const globe::Geodetic g = globe::toGeodetic(*hit);
    const double miss = groundHeight(g.lon, g.lat) - g.h;
    if (std::abs(miss) < 1e-7) break;
    inflation += miss;
  }
  return hit;
}

GlobePose GlobeCameraController::moved(const GlobePose& base, double x, double y, double distance, bool carry) const {
  GlobePose q = base;
  q.distance = distance;
  if (x != 0.0 || y != 0.0) {
    const glm::dmat3 enu = globe::enuBasis(base.target.lon, base.target.lat);
    const glm::dvec3 onPlane = globe::toEcef(base.target.lon, base.target.lat, 0.0) + x * enu[0] + y * enu[1];
    const globe::Geodetic g = globe::toGeodetic(onPlane);
    q.target.lon = wrapLon(g.lon);
    q.target.lat = g.lat;
    if (carry) {
      // The horizontal forward turned with the globe: the least rotation taking the old up to the new.
      const glm::dvec3 level = std::sin(base.heading) * enu[0] + std::cos(base.heading) * enu[1];
      const glm::dmat3 enuNew = globe::enuBasis(q.target.lon, q.target.lat);
      const glm::dvec3 k = glm::cross(enu[2], enuNew[2]);
      const double c = glm::dot(enu[2], enuNew[2]);
      if (c > -0.5) {
        const glm::dvec3 turned = level + glm::cross(k, level) + glm::cross(k, glm::cross(k, level)) / (1.0 + c);
        q.heading = std::atan2(glm::dot(turned, enuNew[0]), glm::dot(turned, enuNew[1]));
      }
    }
  }
  q.target.h = groundHeight(q.target.lon, q.target.lat);
  return q;
}

void GlobeCameraController::fly(const glm::dvec3& move, double seconds) {
  if (!finite(move) || !(seconds > 0.0) || !std::isfinite(seconds)) return;
  const double speed =
      std::max(settings_.minFlySpeed, settings_.flySpeedPerSecond * std::max(heightAboveGround(), 0.0));
  const double step = speed * seconds;
  // Over the ground: along the heading (forward) and across it (right), in the target's tangent plane.
  const double forward = std::clamp(move.y, -1.0, 1.0) * step, right = std::clamp(move.x, -1.0, 1.0) * step;
  const double east = forward * std::sin(pose_.heading) + right * std::cos(pose_.heading);
  const double north = forward * std::cos(pose_.heading) - right * std::sin(pose_.heading);
  GlobePose p = moved(pose_, east, north, pose_.distance, true);
  if (move.z != 0.0) {
    const double height = globe::toGeodetic(frameOf(p).eye).h;
    p = withEyeHeight(p, height + std::clamp(move.z, -1.0, 1.0) * step);
  }
  accept(limited(p));
}

void GlobeCameraController::look(double dHeading, double dPitch) {
  if (!std::isfinite(dHeading) || !std::isfinite(dPitch)) return;
  const glm::dvec3 eye = frameOf(pose_).eye;
  GlobePose p = pose_;
  p.heading = std::remainder(p.heading + dHeading, 2.0 * std::numbers::pi);
  p.pitch = std::clamp(p.pitch + dPitch, settings_.minPitch, std::numbers::pi / 2.0);
  // The target that puts the eye back where it was: along the new direction, taken in the frame
  // of the target found so far (a few rounds: the frame turns little over the distance); then the
  // ground point that direction meets, when it meets the ground, at its distance.
  for (int round = 0; round < 6; ++round) {
    const Frame f = frameOf(p);
    const globe::Geodetic t = globe::toGeodetic(eye + p.distance * f.forward);
    p.target = {wrapLon(t.lon), t.lat, t.h};
    if (round < 3) continue;
    const std::optional<glm::dvec3> hit = groundPointAtNdc(p, glm::dvec2(0.0), 1.0);
    if (!hit) break;
    const globe::Geodetic g = globe::toGeodetic(*hit);
    p.target = {wrapLon(g.lon), g.lat, groundHeight(g.lon, g.lat)};
    p.distance = glm::length(*hit - eye);
  }
  p.target.h = groundHeight(p.target.lon, p.target.lat);
  accept(limited(p));
}

std::optional<GlobePose> GlobeCameraController::place(const GlobePose& base, const glm::dvec3& point,
                                                      const glm::dvec2& ndc, double aspect, const Hold& hold,
                                                      bool carry) const {
  const double tanHalf = tanHalfFov(settings_.fovYDeg);
  // Unknowns: the target's move (x, y) in metres on the tangent plane at base's target, and the log of
  // the distance. Residuals: where the point is on screen less where it should be (NDC), and the hold.
  const auto residual = [&](const glm::dvec3& z) -> std::optional<glm::dvec3> {
    const GlobePose q = moved(base, z.x, z.y, std::exp(z.z), carry);
    const Frame f = frameOf(q);
    const std::optional<glm::dvec2> at = ndcOf(f, point, tanHalf, aspect);
    if (!at) return std::nullopt;
    const double third =
        hold.eyeHeight ? (globe::toGeodetic(f.eye).h - hold.value) / hold.scale : z.z - std::log(hold.value);
    const glm::dvec3 r(at->x - ndc.x, at->y - ndc.y, third);
    if (!finite(r)) return std::nullopt;
    return r;
  };
  glm::dvec3 z(0.0, 0.0, std::log(base.distance));
  std::optional<glm::dvec3> r = residual(z);
  if (!r) return std::nullopt;
  const double reach = base.distance + glm::length(point - frameOf(base).eye);
  const double stepXY = std::max(1e-6 * reach, 1e-5), stepS = 1e-6;
  for (int iteration = 0; iteration < 60 && maxAbs(*r) > kNdcTolerance; ++iteration) {
    glm::dmat3 jacobian(0.0);
    for (int k = 0; k < 3; ++k) {
      glm::dvec3 dz(0.0);
      dz[k] = k < 2 ? stepXY : stepS;
      const std::optional<glm::dvec3> plus = residual(z + dz), minus = residual(z - dz);
      if (!plus || !minus) return std::nullopt;
      jacobian[k] = (*plus - *minus) / (2.0 * dz[k]);
    }
    const double det = glm::determinant(jacobian);
    if (!std::isfinite(det) || det == 0.0) return std::nullopt;
    glm::dvec3 step = -(glm::inverse(jacobian) * *r);
    if (!finite(step)) return std::nullopt;
    // Keep a step on the near side of the globe and within a factor e of the distance.
    const double planar = std::hypot(step.x, step.y), maxPlanar = 0.25 * globe::kSemiMajor;
    if (planar > maxPlanar) step *= maxPlanar / planar;
    if (std::abs(step.z) > 1.0) step *= 1.0 / std::abs(step.z);
    // Damped: halve the step until the residual shrinks.
    bool improved = false;
    for (int halving = 0; halving < 20 && !improved; ++halving, step *= 0.5) {
      const std::optional<glm::dvec3> next = residual(z + step);
      if (next && maxAbs(*next) < maxAbs(*r)) {
        z += step;
        r = next;
        improved = true;
      }
    }
    if (!improved) break;
  }
  if (!(maxAbs(*r) <= kNdcAcceptable)) return std::nullopt;
  GlobePose q = moved(base, z.x, z.y, std::exp(z.z), carry);
  q.heading = wrapAngle(q.heading);
  if (!finite(q) || q.distance < kMinDistance || q.distance > kMaxDistance) return std::nullopt;
  return q;
}

std::optional<GlobePose> GlobeCameraController::placeEither(const GlobePose& base, const glm::dvec3& point,
                                                            const glm::dvec2& ndc, double aspect,
                                                            const Hold& hold) const {
  if (std::abs(base.target.lat) < kNorthKeepingLat) {
    const std::optional<GlobePose> q = place(base, point, ndc, aspect, hold, false);
    if (q && std::abs(q->target.lat) < kNorthKeepingLat) return q;
  }
  return place(base, point, ndc, aspect, hold, true);
}

GlobePose GlobeCameraController::withEyeHeight(const GlobePose& p, double eyeHeight) const {
  // The eye's height grows with the distance (the eye leaves the target at least minPitch above its
  // horizon): bisection in log distance, ending on the low side.
  double lo = std::log(kMinDistance), hi = std::log(kMaxDistance);
  GlobePose q = p;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    q.distance = std::exp(mid);
    (eyeHeightOf(q) > eyeHeight ? hi : lo) = mid;
  }
  q.distance = std::exp(lo);
  return q;
}

GlobePose GlobeCameraController::limited(GlobePose p) const {
  if (!finite(p)) return p;
  p.distance = std::clamp(p.distance, kMinDistance, kMaxDistance);
  if (eyeHeightOf(p) > settings_.maxHeight) p = withEyeHeight(p, settings_.maxHeight);
  const auto clear = [&](double distance) {
    GlobePose q = p;
    q.distance = distance;
    const globe::Geodetic g = globe::toGeodetic(frameOf(q).eye);
    return g.h - groundHeight(g.lon, g.lat) >= settings_.minHeight;
  };
  if (clear(p.distance)) return p;
  // Back away from the target until clear of the ground (terrain may rise behind the eye, so this
  // is not monotonic: find a clear distance, then the boundary between it and the last low one).
  double low = p.distance, high = p.distance;
  bool found = false;
  for (int i = 0; i < 80 && !found; ++i) {
    low = high;
    high = std::min(high * 1.5 + settings_.minHeight, kMaxDistance);
    found = clear(high);
    if (high >= kMaxDistance) break;
  }
  if (!found) return p;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (low + high);
    (clear(mid) ? high : low) = mid;
  }
  p.distance = high;
  return p;
}

void GlobeCameraController::orbit(double dHeading, double dPitch) {
  if (!std::isfinite(dHeading) || !std::isfinite(dPitch)) return;
  GlobePose p = pose_;
  p.heading = wrapAngle(p.heading + dHeading);
  p.pitch = std::clamp(p.pitch + dPitch, settings_.minPitch, kPi / 2.0);
  accept(limited(p));
}

void GlobeCameraController::setHeading(double heading) {
  if (!std::isfinite(heading)) return;
  GlobePose p = pose_;
  p.heading = wrapAngle(heading);
  accept(limited(p));
}

void GlobeCameraController::zoomToCursor(double steps, const glm::dvec2& pixel, const glm::ivec2& viewport) {
  if (!finite(pixel)) return;
  zoomToCursorNdc(steps, ndcOfPixel(pixel, viewport), viewport);
}

void GlobeCameraController::zoomToCursorNdc(double steps, const glm::dvec2& ndc, const glm::ivec2& viewport) {
  if (!std::isfinite(steps) || steps == 0.0 || !finite(ndc)) return;
  const double aspect = aspectOf(viewport);
  const GlobePose base = pose_;
  const globe::Geodetic eyeNow = globe::toGeodetic(frameOf(base).eye);
  const double ground = groundHeight(eyeNow.lon, eyeNow.lat);
  const double above = std::max(eyeNow.h - ground, settings_.minHeight);
  const double aboveWanted = above * std::pow(settings_.zoomPerStep, steps);
  const double wanted = std::clamp(ground + aboveWanted, ground + settings_.minHeight, settings_.maxHeight);

  std::optional<GlobePose> result;
  if (const std::optional<glm::dvec3> point = groundPointAtNdc(base, ndc, aspect)) {
    // Heights in between for a large step (continuation: each solve starts near its answer).
    const double ratio = (wanted - ground) / (eyeNow.h - ground);
    for (int parts = 1; parts <= 16 && !result && ratio > 0.0 && std::isfinite(ratio); parts *= 4) {
      std::optional<GlobePose> q = base;
      for (int i = 1; i <= parts && q; ++i) {
        const double height = ground + (eyeNow.h - ground) * std::pow(ratio, static_cast<double>(i) / parts);
        q = placeEither(*q, *point, ndc, aspect, Hold{true, height, std::max(height - ground, settings_.minHeight)});
      }
      result = q;
    }
    // The ground under the new eye is not the ground under the old one: hold the limits there.
    for (int round = 0; round < 4 && result; ++round) {
      const globe::Geodetic e = globe::toGeodetic(frameOf(*result).eye);
      const double g = groundHeight(e.lon, e.lat);
      if (e.h - g >= settings_.minHeight && e.h <= settings_.maxHeight) break;
      const double height = std::clamp(e.h, g + settings_.minHeight * (1.0 + 1e-9), settings_.maxHeight);
      result = placeEither(*result, *point, ndc, aspect, Hold{true, height, settings_.minHeight});
    }
  }
  if (!result) result = withEyeHeight(base, wanted);
  accept(limited(*result));
}

void GlobeCameraController::grab(const glm::dvec2& fromPixel, const glm::dvec2& toPixel, const glm::ivec2& viewport) {
  if (!finite(fromPixel) || !finite(toPixel) || fromPixel == toPixel) return;
  const double aspect = aspectOf(viewport);
  const glm::dvec2 from = ndcOfPixel(fromPixel, viewport), to = ndcOfPixel(toPixel, viewport);
  const std::optional<glm::dvec3> point = groundPointAtNdc(pose_, from, aspect);
  if (!point) return;
  const Hold hold{false, pose_.distance, 1.0};
  if (const std::optional<GlobePose> q = placeEither(pose_, *point, to, aspect, hold)) {
    accept(limited(*q));
    return;
  }
  // The whole way cannot be done (the cursor beyond the limb, say): go as far along it as can be.
  GlobePose p = pose_;
  for (int i = 1; i <= 16; ++i) {
    const glm::dvec2 ndc = from + (to - from) * (static_cast<double>(i) / 16.0);
    const std::optional<GlobePose> q = placeEither(p, *point, ndc, aspect, hold);
    if (!q) break;
    p = *q;
  }
  accept(limited(p));
}

void GlobeCameraController::centreIn(const glm::ivec2& viewport, const glm::dvec4& region) {
  if (!(region.z > region.x && region.w > region.y) || viewport.x <= 0 || viewport.y <= 0) return;
  const glm::dvec2 regionMiddle(0.5 * (region.x + region.z), 0.5 * (region.y + region.w));
  const glm::dvec3 point = globe::toEcef(pose_.target.lon, pose_.target.lat, pose_.target.h);
  const double aspect = aspectOf(viewport), tanHalf = tanHalfFov(settings_.fovYDeg);
  const double metresPerPixel = 2.0 * pose_.distance * tanHalf / viewport.y;
  const auto offset = [&](const GlobePose& q) -> std::optional<glm::dvec2> {
    const std::optional<glm::dvec2> at = ndcOf(frameOf(q), point, tanHalf, aspect);
    if (!at || globe::hiddenByEllipsoid(frameOf(q).eye, point, pose_.target.h - 1.0)) return std::nullopt;
    return glm::dvec2((0.5 * at->x + 0.5) * viewport.x, (0.5 - 0.5 * at->y) * viewport.y) - regionMiddle;
  };
  // Newton steps: the target moves over the ground (east and north, metres), and how the point
  // moves on screen for a small move each way (the view's Jacobian there) says how far.
  const auto moved = [&](GlobePose q, double east, double north) {
    const double lat = q.target.lat * kDegree;
    q.target.lon = wrapLon(q.target.lon + east / (globe::kSemiMajor * std::max(std::cos(lat), 1e-6)) / kDegree);
    q.target.lat = std::clamp(q.target.lat + north / globe::kSemiMajor / kDegree, -89.9, 89.9);
    q.target.h = groundHeight(q.target.lon, q.target.lat);
    return q;
  };
  GlobePose q = pose_, good = pose_;
  for (int step = 0; step < 20; ++step) {
    const std::optional<glm::dvec2> off = offset(q);
    if (!off) break;
    good = q;
    if (glm::length(*off) < 0.25) break;
    const double h = metresPerPixel;  // a pixel's move each way
    const std::optional<glm::dvec2> e = offset(moved(q, h, 0.0)), n = offset(moved(q, 0.0, h));
    if (!e || !n) break;
    const glm::dvec2 de = (*e - *off) / h, dn = (*n - *off) / h;  // pixels per metre
    const double det = de.x * dn.y - de.y * dn.x;
    if (!(std::abs(det) > 1e-30)) break;
    // Solve [de dn] (east, north) = −off.
    const double east = (-off->x * dn.y + off->y * dn.x) / det, north = (-de.x * off->y + de.y * off->x) / det;
    // A step that would lose the point (behind the eye, past the horizon) or bring it no nearer
    // is halved.
    double scale = 1.0;
    for (; scale > 1e-3; scale *= 0.5) {
      const std::optional<glm::dvec2> next = offset(moved(q, scale * east, scale * north));
      if (next && glm::length(*next) < glm::length(*off)) break;
    }
    if (scale <= 1e-3) break;
    q = moved(q, scale * east, scale * north);
  }
  accept(limited(good));
}

void GlobeCameraController::home(double west, double south, double east, double north, const glm::ivec2& viewport,
                                 const std::optional<glm::dvec4>& region) {
  if (!std::isfinite(west) || !std::isfinite(south) || !std::isfinite(east) || !std::isfinite(north)) return;
  south = std::clamp(south, -90.0, 90.0);
  north = std::clamp(north, -90.0, 90.0);
  if (south > north) std::swap(south, north);
  while (east < west) east += 360.0;
  const double width = std::min(east - west, 360.0);

  GlobePose p;
  p.target.lon = wrapLon(west + 0.5 * width);
  p.target.lat = 0.5 * (south + north);
  p.target.h = groundHeight(p.target.lon, p.target.lat);
  p.heading = 0.0;
  p.pitch = kPi / 2.0;
  const globe::Geodetic middle = p.target;

  // The box's outline (its parallels bulge: sampled) and middle, on the ground.
  constexpr int kSamples = 16;
  std::vector<glm::dvec3> points;
  double lowest = 0.0;
  const auto add = [&](double lon, double lat) {
    const double h = groundHeight(lon, lat);
    lowest = std::min(lowest, h);
    points.push_back(globe::toEcef(wrapLon(lon), lat, h));
  };
  for (int i = 0; i <= kSamples; ++i) {
    const double s = static_cast<double>(i) / kSamples;
    add(west + s * width, south);
    add(west + s * width, north);
    add(west, south + s * (north - south));
    add(west + width, south + s * (north - south));
  }
  add(p.target.lon, p.target.lat);

  const double aspect = aspectOf(viewport), tanHalf = tanHalfFov(settings_.fovYDeg);
  // The region (pixels) and the part of it the box may fill.
  const glm::dvec4 r =
      region && region->z > region->x && region->w > region->y ? *region : glm::dvec4(0.0, 0.0, viewport.x, viewport.y);
  constexpr double kMargin = 0.05;  // of the region, on each side
  const glm::dvec2 regionMiddle(0.5 * (r.x + r.z), 0.5 * (r.y + r.w));
  const glm::dvec2 room = (1.0 - 2.0 * kMargin) * glm::dvec2(r.z - r.x, r.w - r.y);
  const auto pixelOf = [&](const glm::dvec2& ndc) {
    return glm::dvec2((0.5 * ndc.x + 0.5) * viewport.x, (0.5 - 0.5 * ndc.y) * viewport.y);
  };
  // The box's extent in pixels from pose q, if all of it is in view.
  const auto extentFrom = [&](const GlobePose& q) -> std::optional<std::pair<glm::dvec2, glm::dvec2>> {
    const Frame f = frameOf(q);
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& x : points) {
      if (globe::hiddenByEllipsoid(f.eye, x, lowest - 1.0)) return std::nullopt;
      const std::optional<glm::dvec2> at = ndcOf(f, x, tanHalf, aspect);
      if (!at) return std::nullopt;
      lo = glm::min(lo, pixelOf(*at));
      hi = glm::max(hi, pixelOf(*at));
    }
    return std::make_pair(lo, hi);
  };
  // At `distance`: the target slid (east and north: the view looks straight down, north up) so that
  // the box's middle is in the region's middle; the pose, and whether the box then fits the room.
  const auto placed = [&](double distance) {
    GlobePose q = p;
    q.target = middle;
    q.distance = distance;
    const double metresPerPixel = 2.0 * distance * tanHalf / std::max(viewport.y, 1);
    // Secant steps per axis: a move of the target shifts the box on screen less than the ground
    // scale at the target says where the globe curves away; the gain learns by how much.
    glm::dvec2 gain(1.0), lastOff(0.0), lastStep(0.0);
    GlobePose good = q;
    for (int step = 0; step < 40; ++step) {
      const std::optional<std::pair<glm::dvec2, glm::dvec2>> e = extentFrom(q);
      if (!e) {
        q = good;  // a step too far: the box left the view
        break;
      }
      good = q;
      const glm::dvec2 off = 0.5 * (e->first + e->second) - regionMiddle;  // pixels, y down
      if (glm::length(off) < 0.1) break;
      if (step > 0) {
        for (int a = 0; a < 2; ++a) {
          const double moved = lastOff[a] - off[a];
          if (std::abs(lastStep[a]) > 1.0 && std::abs(moved) > 0.5 && moved * lastStep[a] > 0.0)
            gain[a] = std::clamp(gain[a] * lastStep[a] / moved, 0.5, 4.0);
        }
      }
      const glm::dvec2 stepPx = off * gain;
      const double lat = q.target.lat * kPi / 180.0;
      q.target.lon = wrapLon(q.target.lon + stepPx.x * metresPerPixel /
                                                (globe::kSemiMajor * std::max(std::cos(lat), 1e-6)) * 180.0 / kPi);
      q.target.lat =
          std::clamp(q.target.lat - stepPx.y * metresPerPixel / globe::kSemiMajor * 180.0 / kPi, -89.9, 89.9);
      q.target.h = groundHeight(q.target.lon, q.target.lat);
      lastOff = off;
      lastStep = stepPx;
    }
    const std::optional<std::pair<glm::dvec2, glm::dvec2>> e = extentFrom(q);
    const bool fits = e && e->second.x - e->first.x <= room.x && e->second.y - e->first.y <= room.y;
    return std::make_pair(q, fits);
  };
  // The whole globe fits the viewport when its outline (seen under asin(a / r) from r) is within
  // the narrower half field of view. A box that does not fit there shows the whole globe, centred
  // in the viewport (looking straight down, the globe is always in the middle of the view).
  const double halfFov = std::atan(tanHalf * std::min(aspect, 1.0));
  const double globeDistance = globe::kSemiMajor / std::sin(0.9 * halfFov) - glm::length(globe::toEcef(p.target));
  if (!placed(globeDistance).second) {
    p.distance = globeDistance;
  } else {
    double lo = std::log(settings_.minHeight), hi = std::log(globeDistance);
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (placed(std::exp(mid)).second ? hi : lo) = mid;
    }
    p = placed(std::exp(hi)).first;
  }
  accept(limited(p));
}

}  // namespace gis::scene
