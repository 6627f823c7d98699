// Camera controller: gestures checked through the cameras they produce, with GLM's own view and
// projection matrices as the reference (not the controller's maths): zoom and pan keep what is under
// the cursor, orbit keeps target and distance, smoothing settles, keyframes land exactly, terrain
// following keeps the eye above synthetic hills and cliffs, and no input gives a non-finite camera.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <utility>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "scene/camera.hpp"
#include "scene/camera_controller.hpp"

namespace gis::test {
namespace {

using scene::Camera;
using scene::CameraController;
using scene::ControllerSettings;
using scene::HeightAt;
using scene::OrbitPose;

constexpr double kPi = std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kFrame = 1.0 / 60.0;
const glm::ivec2 kViewport(800, 600);

Camera makeCamera(const glm::dvec3& eye, const glm::dvec3& target, double fovYDeg = 45.0) {
  Camera c;
  c.eye = eye;
  c.target = target;
  c.fovYDeg = fovYDeg;
  return c;
}

/// 1000 m from the origin, looking north and about 37° down.
Camera oblique() { return makeCamera(glm::dvec3(0.0, -800.0, 600.0), glm::dvec3(0.0)); }

ControllerSettings unsmoothed() {
  ControllerSettings s;
  s.smoothing = 0.0;
  return s;
}

glm::dvec3 direction(const Camera& c) { return glm::normalize(c.target - c.eye); }

glm::dmat4 viewOf(const Camera& c) { return glm::lookAtRH(c.eye, c.target, c.up); }

glm::dmat4 projectionOf(const Camera& c, const glm::ivec2& viewport) {
  const double aspect = static_cast<double>(viewport.x) / static_cast<double>(viewport.y);
  return glm::perspectiveRH_NO(glm::radians(c.fovYDeg), aspect, 1.0, 1e5);
}

glm::dvec4 rectOf(const glm::ivec2& viewport) {
  return glm::dvec4(0.0, 0.0, static_cast<double>(viewport.x), static_cast<double>(viewport.y));
}

/// Pixel (x right, y down, centres at +0.5) where a point appears, by GLM's matrices.
glm::dvec2 project(const Camera& c, const glm::dvec3& p, const glm::ivec2& viewport = kViewport) {
  const glm::dvec3 win = glm::projectNO(p, viewOf(c), projectionOf(c, viewport), rectOf(viewport));
  return glm::dvec2(win.x - 0.5, static_cast<double>(viewport.y) - win.y - 0.5);
}

/// The ray through a pixel, by GLM's matrices.
std::pair<glm::dvec3, glm::dvec3> unprojectRay(const Camera& c, const glm::dvec2& pixel,
                                               const glm::ivec2& viewport = kViewport) {
  const glm::dvec3 win(pixel.x + 0.5, static_cast<double>(viewport.y) - (pixel.y + 0.5), 0.0);
  const glm::dmat4 view = viewOf(c), proj = projectionOf(c, viewport);
  const glm::dvec3 nearPoint = glm::unProjectNO(win, view, proj, rectOf(viewport));
  const glm::dvec3 farPoint = glm::unProjectNO(glm::dvec3(win.x, win.y, 1.0), view, proj, rectOf(viewport));
  return {c.eye, glm::normalize(farPoint - nearPoint)};
}

glm::dvec3 hitPlane(const std::pair<glm::dvec3, glm::dvec3>& ray, double z) {
  const double t = (z - ray.first.z) / ray.second.z;
  glm::dvec3 p = ray.first + t * ray.second;
  p.z = z;
  return p;
}

/// First crossing of a ray with a height field (marching, then bisection).
glm::dvec3 hitSurface(const std::pair<glm::dvec3, glm::dvec3>& ray, const HeightAt& height) {
  auto above = [&](double t) {
    const glm::dvec3 p = ray.first + t * ray.second;
    return p.z - height(glm::dvec2(p.x, p.y));
  };
  double lo = 0.0, hi = 0.0;
  for (double t = 1.0; t < 1e5; t += 1.0) {
    if (above(t) < 0.0) {
      lo = t - 1.0;
      hi = t;
      break;
    }
  }
  EXPECT_GT(hi, 0.0) << "ray does not reach the surface";
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (above(mid) < 0.0 ? hi : lo) = mid;
  }
  return ray.first + lo * ray.second;
}

bool finiteVec(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Finite, eye ≠ target, unit up orthogonal to the view, positive near plane and field of view.
void expectUsable(const Camera& c) {
  ASSERT_TRUE(finiteVec(c.eye) && finiteVec(c.target) && finiteVec(c.up))
      << c.eye.x << " " << c.eye.y << " " << c.eye.z << " / " << c.target.x << " " << c.target.y << " " << c.target.z;
  EXPECT_GE(glm::length(c.target - c.eye), 1.0 - 1e-9);
  EXPECT_NEAR(glm::length(c.up), 1.0, 1e-9);
  EXPECT_NEAR(glm::dot(c.up, direction(c)), 0.0, 1e-9);
  EXPECT_TRUE(std::isfinite(c.nearPlane) && c.nearPlane > 0.0) << c.nearPlane;
  EXPECT_TRUE(c.fovYDeg > 0.0 && c.fovYDeg < 180.0) << c.fovYDeg;
}

void expectNear(const glm::dvec3& actual, const glm::dvec3& expected, double tolerance, const char* what = "") {
  EXPECT_LE(glm::length(actual - expected), tolerance)
      << what << ": (" << actual.x << ", " << actual.y << ", " << actual.z << ") vs (" << expected.x << ", "
      << expected.y << ", " << expected.z << ")";
}

void expectSameView(const Camera& a, const Camera& b, double tolerance) {
  expectNear(a.eye, b.eye, tolerance, "eye");
  expectNear(direction(a), direction(b), tolerance, "direction");
}

/// Runs 60 Hz frames until the controller reports rest; returns the number of frames.
int settle(CameraController& controller, const HeightAt& height = {}) {
  int frames = 0;
  while (controller.update(kFrame, height) && frames < 100000) ++frames;
  return frames;
}

HeightAt flat(double z) {
  return [z](const glm::dvec2&) { return z; };
}

HeightAt sineHills() {
  return [](const glm::dvec2& p) { return 150.0 + 100.0 * std::sin(p.x / 170.0) * std::cos(p.y / 230.0); };
}

/// A 300 m wall along x = 0 (high to the east), and no terrain beyond |y| > 5 km.
HeightAt cliff() {
  return [](const glm::dvec2& p) { return std::abs(p.y) > 5000.0 ? kNaN : (p.x < 0.0 ? 0.0 : 300.0); };
}

void expectAboveGround(const Camera& c, const HeightAt& height, double clearance, const char* what) {
  const double ground = height(glm::dvec2(c.eye.x, c.eye.y));
  EXPECT_GE(c.eye.z, ground + clearance - 1e-9) << what << " at (" << c.eye.x << ", " << c.eye.y << ")";
}

TEST(CameraController, StartsAtHomeAndRests) {
  CameraController controller(oblique());
  expectSameView(controller.camera(), oblique(), 1e-9);
  expectNear(controller.camera().target, oblique().target, 1e-9, "target");
  expectUsable(controller.camera());
  EXPECT_EQ(controller.mode(), CameraController::Mode::Orbit);
  EXPECT_FALSE(controller.update(kFrame, flat(-100.0)));
  EXPECT_FALSE(controller.animating());
}

TEST(CameraController, RayThroughAgreesWithGlmViewAndProjection) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Camera cameras[] = {oblique(), makeCamera(glm::dvec3(10.0, 20.0, 3000.0), glm::dvec3(10.0, 20.0, 0.0)),
                            makeCamera(glm::dvec3(-500.0, 300.0, 20.0), glm::dvec3(400.0, -100.0, 15.0), 70.0)};
  const glm::ivec2 viewports[] = {kViewport, glm::ivec2(1920, 1080), glm::ivec2(300, 700)};
  for (const Camera& start : cameras) {
    CameraController controller(start);
    for (const glm::ivec2& viewport : viewports) {
      for (int i = 0; i < 50; ++i) {
        const glm::dvec2 pixel(unit(random) * viewport.x, unit(random) * viewport.y);
        const auto [origin, dir] = controller.rayThrough(pixel, viewport);
        expectNear(origin, controller.camera().eye, 1e-9, "ray origin");
        EXPECT_NEAR(glm::length(dir), 1.0, 1e-12);
        const glm::dvec2 back = project(controller.camera(), origin + 700.0 * dir, viewport);
        EXPECT_NEAR(back.x, pixel.x, 1e-6);
        EXPECT_NEAR(back.y, pixel.y, 1e-6);
      }
    }
    // The centre of an odd-sized viewport looks along the view direction.
    const auto centre = controller.rayThrough(glm::dvec2(400.0, 300.0), glm::ivec2(801, 601));
    expectNear(centre.second, direction(controller.camera()), 1e-12, "centre ray");
  }
}

TEST(CameraControllerOrbit, KeepsTargetAndDistance) {
  CameraController controller(oblique(), unsmoothed());
  std::mt19937 random(3);
  std::uniform_real_distribution<double> delta(-300.0, 300.0);
  const ControllerSettings settings;
  for (int i = 0; i < 200; ++i) {
    const Camera before = controller.goal();
    controller.orbit(glm::dvec2(delta(random), delta(random)));
    const Camera after = controller.goal();
    expectNear(after.target, glm::dvec3(0.0), 1e-9, "target");
    EXPECT_NEAR(glm::length(after.eye - after.target), 1000.0, 1e-9);
    EXPECT_GE(controller.goalPose().pitch, settings.minPitch - 1e-12);
    EXPECT_LE(controller.goalPose().pitch, settings.maxPitch + 1e-12);
    EXPECT_GT(glm::length(after.eye - before.eye), 0.0);
    expectUsable(after);
  }
  // A horizontal drag turns about +z: the height of the eye does not change.
  const double height = controller.goal().eye.z;
  controller.orbit(glm::dvec2(57.0, 0.0));
  EXPECT_NEAR(controller.goal().eye.z, height, 1e-9);
}

// The compass's north-up: the view turns to the heading asked, about the target in orbit mode and
// about the eye in fly mode, keeping pitch and distance; a non-finite heading changes nothing.
TEST(CameraControllerHeading, TurnsAboutTheTargetOrTheEye) {
  CameraController controller(oblique(), unsmoothed());
  controller.orbit(glm::dvec2(123.0, 0.0));
  const OrbitPose turned = controller.goalPose();
  controller.setHeading(0.0);
  const Camera north = controller.goal();
  expectNear(north.target, turned.target, 1e-9, "target");
  EXPECT_NEAR(controller.goalPose().pitch, turned.pitch, 1e-12);
  EXPECT_NEAR(controller.goalPose().distance, turned.distance, 1e-9);
  // Yaw 0 looks north (+y), with no sideways component.
  EXPECT_NEAR(direction(north).x, 0.0, 1e-12);
  EXPECT_GT(direction(north).y, 0.0);

  controller.setMode(CameraController::Mode::Fly);
  const glm::dvec3 eye = controller.goal().eye;
  controller.setHeading(kPi / 2.0);  // looks west
  const Camera west = controller.goal();
  expectNear(west.eye, eye, 1e-9, "eye");
  EXPECT_NEAR(direction(west).y, 0.0, 1e-12);
  EXPECT_LT(direction(west).x, 0.0);

  const OrbitPose before = controller.goalPose();
  controller.setHeading(kNaN);
  EXPECT_EQ(controller.goalPose(), before);
}

TEST(CameraControllerOrbit, APivotOnTheViewAxisKeepsTheViewAndBecomesTheCentre) {
  CameraController controller(oblique(), unsmoothed());
  const Camera before = controller.camera();
  controller.pivotAt(400.0);  // the terrain, say, 400 m along the view axis
  const Camera after = controller.camera();
  expectNear(after.eye, before.eye, 1e-9, "eye");
  expectNear(direction(after), direction(before), 1e-12, "direction");
  expectNear(after.target, before.eye + 400.0 * direction(before), 1e-9, "target");
  EXPECT_NEAR(controller.goalPose().distance, 400.0, 1e-12);
  // The next orbit turns about the pivot.
  controller.orbit(glm::dvec2(80.0, 30.0));
  expectNear(controller.goal().target, after.target, 1e-9, "orbit centre");
  EXPECT_NEAR(glm::length(controller.goal().eye - after.target), 400.0, 1e-9);
  // Distances outside [1, 1e7] or not finite are ignored.
  const OrbitPose kept = controller.goalPose();
  for (const double d : {0.5, 2e7, kNaN, kInf, -10.0}) {
    controller.pivotAt(d);
    EXPECT_TRUE(controller.goalPose() == kept) << d;
  }
}

TEST(CameraControllerOrbit, NoPivotWhileTheViewIsStillMoving) {
  CameraController controller(oblique());  // smoothed
  controller.orbit(glm::dvec2(100.0, 0.0));
  controller.update(kFrame, {});
  const scene::OrbitPose shown = controller.shownPose(), goal = controller.goalPose();
  ASSERT_FALSE(shown == goal);
  controller.pivotAt(300.0);
  EXPECT_TRUE(controller.shownPose() == shown);
  EXPECT_TRUE(controller.goalPose() == goal);
}

TEST(CameraControllerOrbit, PitchStopsJustAboveTheHorizonAndStraightDown) {
  CameraController controller(oblique(), unsmoothed());
  controller.orbit(glm::dvec2(0.0, 1e6));
  Camera c = controller.goal();
  expectUsable(c);
  expectNear(c.eye, glm::dvec3(0.0, 0.0, 1000.0), 1e-9, "straight down");
  expectNear(c.up, glm::dvec3(0.0, 1.0, 0.0), 1e-9, "up keeps the heading");
  controller.orbit(glm::dvec2(0.0, -1e6));
  c = controller.goal();
  expectUsable(c);
  EXPECT_NEAR(c.eye.z, 1000.0 * std::sin(ControllerSettings().minPitch), 1e-9);
  EXPECT_TRUE(controller.update(kFrame, {}));
  expectUsable(controller.camera());
}

TEST(CameraControllerPan, GrabbedPlanePointStaysUnderTheCursor) {
  for (const Camera& start : {oblique(), makeCamera(glm::dvec3(0.0, 0.0, 2000.0), glm::dvec3(0.0, 0.0, 50.0))}) {
    CameraController controller(start, unsmoothed());
    std::mt19937 random(11);
    std::uniform_real_distribution<double> x(0.0, 800.0), y(0.0, 600.0);
    for (int i = 0; i < 100; ++i) {
      const Camera before = controller.goal();
      const glm::dvec2 from(x(random), y(random)), to(x(random), y(random));
      const glm::dvec3 grabbed = hitPlane(unprojectRay(before, from), before.target.z);
      controller.pan(from, to, kViewport);
      const Camera after = controller.goal();
      const glm::dvec2 seen = project(after, grabbed);
      EXPECT_NEAR(seen.x, to.x, 0.01);
      EXPECT_NEAR(seen.y, to.y, 0.01);
      EXPECT_NEAR(after.target.z, before.target.z, 1e-9);
      expectNear(direction(after), direction(before), 1e-12, "pan does not turn the view");
    }
  }
}

TEST(CameraControllerPan, RaysOverTheHorizonMoveTheViewABoundedWay) {
  const Camera grazing = makeCamera(glm::dvec3(0.0, -1000.0, 10.0), glm::dvec3(0.0));
  CameraController controller(grazing, unsmoothed());
  controller.pan(glm::dvec2(400.0, 0.0), glm::dvec2(400.0, 40.0), kViewport);     // from the sky
  controller.pan(glm::dvec2(400.0, 305.0), glm::dvec2(400.0, 302.0), kViewport);  // near the horizon
  const Camera c = controller.goal();
  expectUsable(c);
  EXPECT_LT(glm::length(c.target), 2.0 * 50.0 * 1000.0);
}

TEST(CameraControllerZoom, GivenPointStaysUnderTheCursorAndComesCloserByTheFactor) {
  CameraController controller(oblique(), unsmoothed());
  std::mt19937 random(5);
  std::uniform_real_distribution<double> x(0.0, 800.0), y(0.0, 600.0), depth(100.0, 3000.0), off(-5.0, 5.0);
  const double stepsList[] = {1.0, 2.0, -1.0, 0.5, 3.0, -2.5};
  for (int i = 0; i < 60; ++i) {
    const Camera before = controller.goal();
    const glm::dvec2 cursor(x(random), y(random));
    const auto ray = unprojectRay(before, cursor);
    // Every third point lies off the cursor ray, as a depth read from a frame still moving would.
    glm::dvec3 point = ray.first + depth(random) * ray.second;
    if (i % 3 == 2) point += glm::dvec3(off(random), off(random), off(random));
    const double steps = stepsList[static_cast<std::size_t>(i) % std::size(stepsList)];
    const double factor = std::pow(ControllerSettings().zoomPerWheelStep, steps);
    const double orbitDistance = controller.goalPose().distance;
    if (orbitDistance * factor < 1.0 || orbitDistance * factor > 1e7) continue;
    controller.zoomAt(steps, cursor, kViewport, point);
    const Camera after = controller.goal();
    const glm::dvec2 seen = project(after, point);
    EXPECT_NEAR(seen.x, cursor.x, 0.5);
    EXPECT_NEAR(seen.y, cursor.y, 0.5);
    EXPECT_NEAR(glm::length(after.eye - point), factor * glm::length(before.eye - point),
                1e-9 * glm::length(before.eye - point));
    EXPECT_NEAR(controller.goalPose().distance, factor * orbitDistance, 1e-9 * orbitDistance);
    expectNear(direction(after), direction(before), 1e-12, "zoom does not turn the view");
  }
}

TEST(CameraControllerZoom, WithoutAPointZoomsTowardsTheTargetPlane) {
  CameraController controller(oblique(), unsmoothed());
  const glm::dvec2 cursor(612.0, 455.0);
  const Camera before = controller.goal();
  const glm::dvec3 point = hitPlane(unprojectRay(before, cursor), 0.0);
  controller.zoomAt(2.0, cursor, kViewport, std::nullopt);
  const Camera after = controller.goal();
  const glm::dvec2 seen = project(after, point);
  EXPECT_NEAR(seen.x, cursor.x, 0.5);
  EXPECT_NEAR(seen.y, cursor.y, 0.5);
  EXPECT_NEAR(glm::length(after.eye - point), 0.85 * 0.85 * glm::length(before.eye - point), 1e-6);
  EXPECT_NEAR(after.target.z, 0.0, 1e-9);  // the target stays on its plane
  // A cursor in the sky zooms towards the target's depth, a finite step.
  controller.zoomAt(1.0, glm::dvec2(400.0, 0.0), kViewport, std::nullopt);
  expectUsable(controller.goal());
}

TEST(CameraControllerZoom, DistanceStaysWithinOneMetreAndTenThousandKilometres) {
  CameraController controller(oblique(), unsmoothed());
  for (int i = 0; i < 1000; ++i) controller.zoomAt(1.0, glm::dvec2(400.0, 300.0), kViewport, std::nullopt);
  EXPECT_NEAR(controller.goalPose().distance, 1.0, 1e-12);
  expectUsable(controller.goal());
  controller.zoomAt(1e300, glm::dvec2(400.0, 300.0), kViewport, glm::dvec3(0.0));
  EXPECT_NEAR(controller.goalPose().distance, 1.0, 1e-12);
  controller.zoomAt(-1e6, glm::dvec2(10.0, 10.0), kViewport, std::nullopt);
  EXPECT_NEAR(controller.goalPose().distance, 1e7, 1e-3);
  expectUsable(controller.goal());
  controller.update(kFrame, {});
  expectUsable(controller.camera());
}

TEST(CameraControllerSmoothing, ConvergesToTheGoalAndSettles) {
  CameraController controller(oblique());
  controller.orbit(glm::dvec2(120.0, -40.0));
  controller.zoomAt(3.0, glm::dvec2(500.0, 400.0), kViewport, std::nullopt);
  const Camera goal = controller.goal();
  EXPECT_GT(glm::length(controller.camera().eye - goal.eye), 100.0);  // gestures move the goal only
  double gap = glm::length(controller.camera().eye - goal.eye);
  int frames = 0;
  while (controller.update(kFrame, flat(-1000.0))) {
    const double now = glm::length(controller.camera().eye - goal.eye);
    EXPECT_LE(now, gap + 1e-9);
    gap = now;
    ASSERT_LT(++frames, 600) << "does not settle within 10 s";
  }
  EXPECT_GT(frames, 10);  // it does ease
  EXPECT_EQ(controller.camera().eye, goal.eye);
  EXPECT_EQ(controller.camera().target, goal.target);
  EXPECT_FALSE(controller.update(kFrame, flat(-1000.0)));
}

TEST(CameraControllerSmoothing, IsIndependentOfTheFrameRate) {
  CameraController coarse(oblique()), fine(oblique());
  for (CameraController* c : {&coarse, &fine}) {
    c->orbit(glm::dvec2(-200.0, 30.0));
    c->pan(glm::dvec2(100.0, 500.0), glm::dvec2(300.0, 200.0), kViewport);
    c->zoomAt(-2.0, glm::dvec2(700.0, 100.0), kViewport, std::nullopt);
  }
  coarse.update(0.1, {});
  fine.update(0.05, {});
  fine.update(0.05, {});
  expectSameView(coarse.camera(), fine.camera(), 1e-9);
}

TEST(CameraControllerSmoothing, NoneMeansTheGoalAtOnceAndHugeStepsSnap) {
  CameraController immediate(oblique(), unsmoothed());
  immediate.orbit(glm::dvec2(50.0, 50.0));
  EXPECT_TRUE(immediate.update(kFrame, {}));
  expectSameView(immediate.camera(), immediate.goal(), 0.0);
  EXPECT_FALSE(immediate.update(kFrame, {}));

  CameraController smooth(oblique());
  smooth.orbit(glm::dvec2(50.0, 50.0));
  EXPECT_TRUE(smooth.update(0.0, {}));  // no time, no motion, but not there yet
  EXPECT_NE(smooth.camera().eye, smooth.goal().eye);
  EXPECT_TRUE(smooth.update(1e6, {}));
  expectSameView(smooth.camera(), smooth.goal(), 0.0);
  EXPECT_FALSE(smooth.update(1e6, {}));
}

TEST(CameraControllerSmoothing, YawTakesTheShortWayRound) {
  // Start with the eye just west of north of the target (yaw ≈ π − 0.1), then orbit 0.2 rad across ±π.
  const double yaw = kPi - 0.1;
  CameraController controller(
      makeCamera(glm::dvec3(1000.0 * std::sin(yaw), -1000.0 * std::cos(yaw), 300.0), glm::dvec3(0.0)));
  controller.orbit(glm::dvec2(-0.2 / ControllerSettings().orbitRadiansPerPixel, 0.0));
  EXPECT_NEAR(std::remainder(controller.goalPose().yaw - (-kPi + 0.1), 2.0 * kPi), 0.0, 1e-9);
  while (controller.update(kFrame, {})) {
    EXPECT_LE(std::abs(std::remainder(controller.shownPose().yaw - kPi, 2.0 * kPi)), 0.1 + 1e-9);
  }
}

TEST(CameraControllerAnimation, ReachesTheKeyframeExactlyAtItsTime) {
  CameraController controller(oblique());
  const Camera key = makeCamera(glm::dvec3(2000.0, 1500.0, 900.0), glm::dvec3(1500.0, 2500.0, 40.0), 60.0);
  controller.animateTo(key, 2.0);
  EXPECT_TRUE(controller.animating());
  EXPECT_TRUE(controller.update(0.5, {}));
  // smoothstep(0.25) = 0.15625 of the way, the target on a straight line.
  expectNear(controller.camera().target, 0.15625 * key.target, 1e-9, "quarter time");
  EXPECT_TRUE(controller.update(0.5, {}));
  expectNear(controller.camera().target, 0.5 * key.target, 1e-9, "half time");
  EXPECT_NEAR(controller.shownPose().distance, std::sqrt(1000.0 * glm::length(key.eye - key.target)), 1e-9);
  EXPECT_NEAR(controller.camera().fovYDeg, 52.5, 1e-12);
  EXPECT_TRUE(controller.update(1.0, {}));
  expectNear(controller.camera().eye, key.eye, 1e-9, "keyframe eye");
  expectNear(controller.camera().target, key.target, 1e-9, "keyframe target");
  EXPECT_DOUBLE_EQ(controller.camera().fovYDeg, 60.0);
  EXPECT_FALSE(controller.animating());
  EXPECT_FALSE(controller.update(kFrame, {}));
}

TEST(CameraControllerAnimation, AGestureEndsIt) {
  CameraController controller(oblique());
  controller.animateTo(makeCamera(glm::dvec3(5000.0, 0.0, 3000.0), glm::dvec3(4000.0, 0.0, 0.0)), 5.0);
  controller.update(1.0, {});
  controller.fly(glm::dvec3(0.0), kFrame);  // idle input every frame
  controller.orbit(glm::dvec2(0.0));
  controller.pan(glm::dvec2(5.0), glm::dvec2(5.0), kViewport);
  EXPECT_TRUE(controller.animating());
  controller.orbit(glm::dvec2(10.0, 0.0));
  EXPECT_FALSE(controller.animating());
  EXPECT_LT(settle(controller), 600);
  expectSameView(controller.camera(), controller.goal(), 0.0);
}

TEST(CameraController, GoHomeReturnsHome) {
  CameraController controller(oblique());
  controller.orbit(glm::dvec2(300.0, 100.0));
  controller.pan(glm::dvec2(100.0, 100.0), glm::dvec2(600.0, 500.0), kViewport);
  controller.zoomAt(4.0, glm::dvec2(200.0, 500.0), kViewport, std::nullopt);
  controller.setMode(CameraController::Mode::Fly);
  controller.fly(glm::dvec3(0.3, 1.0, 0.0), 0.5);
  settle(controller);
  controller.setMode(CameraController::Mode::Orbit);
  controller.goHome();
  EXPECT_LT(settle(controller), 600);
  expectSameView(controller.camera(), oblique(), 1e-9);
  expectNear(controller.camera().target, oblique().target, 1e-9, "home target");

  const Camera other = makeCamera(glm::dvec3(100.0, 100.0, 5000.0), glm::dvec3(100.0, 900.0, 0.0));
  controller.setHome(other);
  controller.goHome();
  settle(controller);
  expectSameView(controller.camera(), other, 1e-9);
}

TEST(CameraControllerTerrain, ZoomingIntoHillsKeepsTheEyeAboveGround) {
  const HeightAt hills = sineHills();
  const double clearance = ControllerSettings().groundClearance;
  CameraController controller(makeCamera(glm::dvec3(0.0, -1500.0, 1200.0), glm::dvec3(0.0, 0.0, 150.0)));
  const glm::dvec2 cursors[] = {glm::dvec2(400.0, 450.0), glm::dvec2(200.0, 500.0), glm::dvec2(650.0, 320.0)};
  for (int i = 0; i < 120; ++i) {
    const glm::dvec2 cursor = cursors[static_cast<std::size_t>(i / 40)];
    const glm::dvec3 point = hitSurface(controller.rayThrough(cursor, kViewport), hills);
    controller.zoomAt(1.0, cursor, kViewport, point);
    if (i % 10 == 0) controller.orbit(glm::dvec2(40.0, -60.0));  // towards the horizon
    for (int frame = 0; frame < 5; ++frame) {
      controller.update(kFrame, hills);
      expectAboveGround(controller.camera(), hills, clearance, "shown");
      expectAboveGround(controller.goal(), hills, clearance, "goal");
      expectUsable(controller.camera());
    }
  }
  EXPECT_LT(settle(controller, hills), 600);
  expectAboveGround(controller.camera(), hills, clearance, "settled");
}

TEST(CameraControllerTerrain, OrbitIntoACliffLiftsTheEyeAndKeepsTheTarget) {
  const HeightAt wall = cliff();
  // The target lies below the wall on the west, the eye inside the rock to the east.
  CameraController controller(makeCamera(glm::dvec3(200.0, 0.0, 100.0), glm::dvec3(-200.0, 0.0, 0.0)), unsmoothed());
  controller.update(kFrame, wall);
  for (const Camera& c : {controller.camera(), controller.goal()}) {
    EXPECT_NEAR(c.eye.z, 302.0, 1e-9);
    EXPECT_NEAR(c.eye.x, 200.0, 1e-9);
    EXPECT_NEAR(c.eye.y, 0.0, 1e-9);
    expectNear(c.target, glm::dvec3(-200.0, 0.0, 0.0), 1e-9, "target stays");
    expectUsable(c);
  }
  // Off the terrain nothing is lifted.
  controller.jumpTo(makeCamera(glm::dvec3(0.0, 8000.0, -50.0), glm::dvec3(0.0, 9000.0, -100.0)));
  controller.update(kFrame, wall);
  EXPECT_NEAR(controller.camera().eye.z, -50.0, 1e-9);
}

TEST(CameraControllerTerrain, FlyingIntoHillsAndCliffsClimbsOverThem) {
  ControllerSettings settings;
  settings.minFlySpeed = 50.0;  // hugging the ground after a lift, keep going
  const double clearance = settings.groundClearance;
  for (const HeightAt& terrain : {sineHills(), cliff()}) {
    // Level at 200 m, heading east: hill tops reach 250 m, the wall 300 m.
    CameraController controller(makeCamera(glm::dvec3(-1500.0, 10.0, 200.0), glm::dvec3(-500.0, 10.0, 200.0)),
                                settings);
    controller.update(kFrame, terrain);
    controller.setMode(CameraController::Mode::Fly);
    double lowest = 1e9;
    for (int frame = 0; frame < 1200; ++frame) {
      controller.fly(glm::dvec3(0.0, 1.0, 0.0), kFrame);
      controller.update(kFrame, terrain);
      expectAboveGround(controller.camera(), terrain, clearance, "shown");
      expectAboveGround(controller.goal(), terrain, clearance, "goal");
      const Camera c = controller.camera();
      lowest = std::min(lowest, c.eye.z - terrain(glm::dvec2(c.eye.x, c.eye.y)));
    }
    EXPECT_LT(lowest, clearance + 1.0);           // it did run into the terrain
    EXPECT_GT(controller.camera().eye.x, 100.0);  // and got over it
    // Diving straight down ends at the clearance.
    controller.look(glm::dvec2(0.0, 1e6));
    for (int frame = 0; frame < 600; ++frame) {
      controller.fly(glm::dvec3(0.0, 1.0, 0.0), kFrame);
      controller.update(kFrame, terrain);
      expectAboveGround(controller.camera(), terrain, clearance, "diving");
    }
    const Camera c = controller.camera();
    // The highest ground within the clearance counts: on a slope that is a little higher.
    EXPECT_NEAR(c.eye.z, terrain(glm::dvec2(c.eye.x, c.eye.y)) + clearance, clearance);
    EXPECT_FALSE(controller.update(kFrame, terrain));  // resting on the ground is rest
    expectUsable(c);
  }
}

TEST(CameraControllerModes, SwitchingKeepsEyeAndDirection) {
  CameraController controller(oblique());
  controller.orbit(glm::dvec2(80.0, 20.0));
  controller.update(kFrame, {});  // mid-way: shown and goal differ
  const Camera shown = controller.camera(), goal = controller.goal();
  controller.setMode(CameraController::Mode::Fly);
  EXPECT_EQ(controller.mode(), CameraController::Mode::Fly);
  expectSameView(controller.camera(), shown, 1e-9);
  expectSameView(controller.goal(), goal, 1e-9);
  controller.update(kFrame, {});

  controller.look(glm::dvec2(-150.0, -300.0));  // up, above the horizon
  controller.fly(glm::dvec3(0.5, 1.0, -0.2), 0.3);
  settle(controller);
  const Camera flown = controller.camera();
  const double distance = controller.goalPose().distance;
  EXPECT_NEAR(distance, 1000.0, 1e-9);  // flying and looking keep the orbit distance
  controller.setMode(CameraController::Mode::Orbit);
  expectSameView(controller.camera(), flown, 1e-9);
  expectSameView(controller.goal(), flown, 1e-9);
  expectNear(controller.goal().target, flown.eye + distance * direction(flown), 1e-9, "target on the view");
  EXPECT_FALSE(controller.update(kFrame, {}));
  // Orbiting from a pitch above the horizon may only come back towards the allowed range.
  const double pitch = controller.goalPose().pitch;
  ASSERT_LT(pitch, 0.0);
  controller.orbit(glm::dvec2(0.0, -100.0));
  EXPECT_DOUBLE_EQ(controller.goalPose().pitch, pitch);
  controller.orbit(glm::dvec2(0.0, 100.0));
  EXPECT_GT(controller.goalPose().pitch, pitch);
}

TEST(CameraControllerModes, SwitchingDuringAnAnimationDoesNotJump) {
  for (const CameraController::Mode mode : {CameraController::Mode::Orbit, CameraController::Mode::Fly}) {
    CameraController controller(oblique());
    controller.setMode(mode);
    const Camera key = makeCamera(glm::dvec3(3000.0, 0.0, 500.0), glm::dvec3(3000.0, 4000.0, 0.0));
    controller.animateTo(key, 2.0);
    controller.update(0.7, {});
    const Camera before = controller.camera();
    controller.setMode(mode == CameraController::Mode::Orbit ? CameraController::Mode::Fly
                                                             : CameraController::Mode::Orbit);
    controller.update(0.0, {});
    expectSameView(controller.camera(), before, 1e-9);
    controller.update(1.3, {});
    expectNear(controller.camera().eye, key.eye, 1e-9, "keyframe reached");
  }
}

TEST(CameraControllerFly, SpeedScalesWithHeightAboveGround) {
  auto travelled = [](double height) {
    CameraController controller(makeCamera(glm::dvec3(0.0, 0.0, height), glm::dvec3(0.0, 5000.0, height)),
                                unsmoothed());
    controller.setMode(CameraController::Mode::Fly);
    controller.update(0.0, flat(0.0));  // learns the height above ground
    const glm::dvec3 start = controller.goal().eye;
    controller.fly(glm::dvec3(0.0, 1.0, 0.0), 0.5);
    return glm::length(controller.goal().eye - start);
  };
  EXPECT_NEAR(travelled(100.0), 50.0, 1e-9);
  EXPECT_NEAR(travelled(1000.0), 500.0, 1e-9);
  EXPECT_NEAR(travelled(3.0), 0.5 * ControllerSettings().minFlySpeed, 1e-9);  // near the ground
}

TEST(CameraControllerFly, MovesAlongViewRightAndUp) {
  CameraController controller(makeCamera(glm::dvec3(0.0, 0.0, 100.0), glm::dvec3(0.0, 1000.0, 100.0)), unsmoothed());
  controller.setMode(CameraController::Mode::Fly);
  controller.update(0.0, flat(0.0));
  controller.fly(glm::dvec3(1.0, 0.0, 0.0), 0.1);
  expectNear(controller.goal().eye, glm::dvec3(10.0, 0.0, 100.0), 1e-9, "right is east when heading north");
  controller.fly(glm::dvec3(0.0, 0.0, -1.0), 0.1);
  expectNear(controller.goal().eye, glm::dvec3(10.0, 0.0, 90.0), 1e-9, "down");
  controller.fly(glm::dvec3(0.0, 5.0, 0.0), 10.0);  // clamped: full speed for one second
  EXPECT_NEAR(controller.goal().eye.y, 100.0, 1e-9);
}

TEST(CameraControllerFly, LookTurnsAroundTheEye) {
  CameraController controller(oblique(), unsmoothed());
  controller.setMode(CameraController::Mode::Fly);
  const Camera before = controller.goal();
  controller.look(glm::dvec2(100.0, 0.0));
  const Camera after = controller.goal();
  expectNear(after.eye, before.eye, 1e-9, "eye stays");
  EXPECT_LT(glm::cross(direction(before), direction(after)).z, 0.0);  // moving right turns clockwise (right)
  controller.look(glm::dvec2(0.0, 1e6));
  expectNear(direction(controller.goal()), glm::dvec3(0.0, 0.0, -1.0), 1e-12, "straight down");
  expectUsable(controller.goal());
  controller.look(glm::dvec2(0.0, -1e6));
  expectNear(direction(controller.goal()), glm::dvec3(0.0, 0.0, 1.0), 1e-12, "straight up");
  expectUsable(controller.goal());
  expectNear(controller.goal().eye, before.eye, 1e-9, "eye still there");
}

TEST(CameraController, NearPlaneFollowsTheHeightAboveGround) {
  auto nearAt = [](double height, const HeightAt& ground) {
    CameraController controller(makeCamera(glm::dvec3(0.0, 0.0, height), glm::dvec3(0.0, 20000.0, 0.0)));
    controller.update(kFrame, ground);
    settle(controller, ground);
    EXPECT_NEAR(controller.goal().nearPlane, controller.camera().nearPlane, 1e-9);
    return controller.camera().nearPlane;
  };
  EXPECT_NEAR(nearAt(100.0, flat(0.0)), 50.0, 1e-9);
  EXPECT_NEAR(nearAt(2.5, flat(0.0)), 1.25, 1e-9);
  EXPECT_NEAR(nearAt(100.0, flat(99.99)), 1.0, 1e-9);  // lifted to the 2 m clearance
  EXPECT_NEAR(nearAt(1e5, flat(0.0)), 1000.0, 1e-9);
  EXPECT_NEAR(nearAt(100.0, flat(kNaN)), 1000.0, 1e-9);  // off the terrain: half the target distance, capped
}

TEST(CameraController, DegenerateInputsGiveFiniteCameras) {
  const Camera straightDown = makeCamera(glm::dvec3(5.0, 5.0, 1000.0), glm::dvec3(5.0, 5.0, 0.0));
  Camera eastUp = straightDown;
  eastUp.up = glm::dvec3(1.0, 0.0, 0.0);
  const Camera cases[] = {straightDown,
                          eastUp,
                          makeCamera(glm::dvec3(0.0, 0.0, -300.0), glm::dvec3(0.0)),         // straight up
                          makeCamera(glm::dvec3(0.0, -1000.0, 1e-3), glm::dvec3(0.0)),       // grazing
                          makeCamera(glm::dvec3(1.0, 2.0, 3.0), glm::dvec3(1.0, 2.0, 3.0)),  // eye = target
                          makeCamera(glm::dvec3(0.0, 0.0, 1e9), glm::dvec3(0.0)),            // too far
                          makeCamera(glm::dvec3(0.0, -0.1, 0.1), glm::dvec3(0.0), kNaN)};    // too close, bad fov
  for (const Camera& start : cases) {
    for (const CameraController::Mode mode : {CameraController::Mode::Orbit, CameraController::Mode::Fly}) {
      CameraController controller(oblique());
      controller.setMode(mode);
      controller.jumpTo(start);
      expectUsable(controller.camera());
      EXPECT_LE(controller.goalPose().distance, 1e7);
      EXPECT_GE(controller.goalPose().distance, 1.0);
      for (const double dt : {0.0, 1e6, -1.0, kNaN, kInf, kFrame}) {
        controller.update(dt, flat(kNaN));
        expectUsable(controller.camera());
      }
      controller.orbit(glm::dvec2(kNaN, 3.0));
      controller.look(glm::dvec2(kInf, 0.0));
      controller.fly(glm::dvec3(kNaN, 1.0, 0.0), 1.0);
      controller.fly(glm::dvec3(0.0, 1.0, 0.0), kInf);
      controller.pan(glm::dvec2(0.0), glm::dvec2(kNaN), kViewport);
      controller.pan(glm::dvec2(10.0), glm::dvec2(20.0), glm::ivec2(0, 0));
      controller.zoomAt(1.0, glm::dvec2(400.0, 300.0), glm::ivec2(0, -5), glm::dvec3(kNaN));
      controller.zoomAt(kNaN, glm::dvec2(400.0, 300.0), kViewport, std::nullopt);
      controller.zoomAt(1.0, glm::dvec2(1e300, -1e300), kViewport, controller.camera().eye);
      controller.orbit(glm::dvec2(1e300, -1e300));
      controller.zoomAt(2.0, glm::dvec2(400.0, 300.0), kViewport, glm::dvec3(1e300, 0.0, -1e300));
      controller.fly(glm::dvec3(0.0, 1.0, 1.0), 1e300);
      controller.animateTo(start, kNaN);
      controller.animateTo(makeCamera(glm::dvec3(kNaN), glm::dvec3(0.0)), 1.0);
      controller.jumpTo(makeCamera(glm::dvec3(kInf), glm::dvec3(0.0)));
      controller.update(1e6, HeightAt());
      controller.update(kFrame, [](const glm::dvec2&) { return kInf; });
      expectUsable(controller.camera());
      expectUsable(controller.goal());
      const auto ray = controller.rayThrough(glm::dvec2(kNaN, 1e300), glm::ivec2(0, 0));
      EXPECT_TRUE(finiteVec(ray.first) && finiteVec(ray.second));
    }
  }
  // A vertical view takes its heading from the camera's up vector.
  CameraController controller(eastUp);
  expectNear(controller.camera().up, glm::dvec3(1.0, 0.0, 0.0), 1e-12, "up kept looking down");
  expectNear(controller.camera().eye, eastUp.eye, 1e-9, "eye kept looking down");
}

TEST(CameraController, BadSettingsAreReplaced) {
  ControllerSettings bad;
  bad.smoothing = kNaN;
  bad.zoomPerWheelStep = -1.0;
  bad.groundClearance = -5.0;
  bad.minPitch = 2.0;
  bad.maxPitch = kNaN;
  bad.flySpeedPerSecond = kInf;
  bad.orbitRadiansPerPixel = 1e300;
  CameraController controller(oblique(), bad);
  controller.zoomAt(1.0, glm::dvec2(400.0, 300.0), kViewport, std::nullopt);
  controller.orbit(glm::dvec2(30.0, 30.0));
  controller.orbit(glm::dvec2(1e10, 0.0));  // overflows to infinity: ignored
  controller.setMode(CameraController::Mode::Fly);
  controller.fly(glm::dvec3(0.0, 1.0, 0.0), 0.1);
  controller.update(kFrame, flat(0.0));
  expectUsable(controller.camera());
  expectUsable(controller.goal());
}

}  // namespace
}  // namespace gis::test

namespace gis::test {
namespace {

// A home view in the part of the window a panel leaves free: every corner of the box projects
// into the region (less its margin), the box fills it along one axis, and it is centred; the
// direction of view is kept. Over boxes of many shapes, regions and directions.
TEST(FrameBoxInRegion, FitsFillsAndCentresTheBox) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const glm::dvec3 lo(-5000.0 * unit(random), -5000.0 * unit(random), 100.0 * unit(random));
    const glm::dvec3 hi(lo.x + 100.0 + 20000.0 * unit(random), lo.y + 100.0 + 20000.0 * unit(random),
                        lo.z + 1.0 + 1500.0 * unit(random));
    const glm::ivec2 viewport(400 + static_cast<int>(1200 * unit(random)), 300 + static_cast<int>(900 * unit(random)));
    const double left = viewport.x * 0.45 * unit(random);
    const glm::dvec4 region(left, 0.0, viewport.x, viewport.y - 30.0);
    Camera start = scene::overviewCamera(lo, hi, 30.0 + 30.0 * unit(random));
    // Headings and pitches other than the overview's.
    const double yaw = 2.0 * kPi * unit(random), pitch = 0.3 + 1.0 * unit(random);
    const double distance = glm::length(start.eye - start.target);
    start.eye = start.target + distance * glm::dvec3(std::cos(pitch) * std::sin(yaw), -std::cos(pitch) * std::cos(yaw),
                                                     std::sin(pitch));
    const double margin = 0.05;
    const Camera c = scene::frameBoxInRegion(start, lo, hi, viewport, region, margin);
    expectNear(direction(c), direction(start), 1e-9, "direction");
    const glm::dmat4 viewProj = c.projection(static_cast<double>(viewport.x) / viewport.y) * c.view();
    glm::dvec2 pmin(1e300), pmax(-1e300);
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y, (k & 4) != 0 ? hi.z : lo.z);
      const glm::dvec4 clip = viewProj * glm::dvec4(corner, 1.0);
      ASSERT_GT(clip.w, 0.0);
      const glm::dvec2 pixel((clip.x / clip.w * 0.5 + 0.5) * viewport.x, (0.5 - clip.y / clip.w * 0.5) * viewport.y);
      pmin = glm::min(pmin, pixel);
      pmax = glm::max(pmax, pixel);
    }
    const glm::dvec2 size(region.z - region.x, region.w - region.y);
    const glm::dvec2 inner = size * (1.0 - 2.0 * margin);
    EXPECT_GE(pmin.x, region.x + margin * size.x - 0.5) << i;
    EXPECT_LE(pmax.x, region.z - margin * size.x + 0.5) << i;
    EXPECT_GE(pmin.y, region.y + margin * size.y - 0.5) << i;
    EXPECT_LE(pmax.y, region.w - margin * size.y + 0.5) << i;
    EXPECT_GT(std::max((pmax.x - pmin.x) / inner.x, (pmax.y - pmin.y) / inner.y), 0.995) << i;
    EXPECT_NEAR(0.5 * (pmin.x + pmax.x), 0.5 * (region.x + region.z), 0.5) << i;
    EXPECT_NEAR(0.5 * (pmin.y + pmax.y), 0.5 * (region.y + region.w), 0.5) << i;
  }
}

}  // namespace
}  // namespace gis::test
