// Globe camera controller: gestures checked through the views they produce, projected with
// GlobeView::viewProj (not the controller's own maths): zoom to the cursor keeps the ground point
// under the cursor from 20,000 km down to 1 m and clamps there, home frames boxes (across ±180° too),
// orbit keeps the target, north-up points north up, grab moves the grabbed point under the cursor,
// and nothing becomes non-finite at the poles, at ±180° or along a long random sequence.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include "globe/ellipsoid.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_view.hpp"
#include "scene/globe_camera.hpp"

namespace gis::test {
namespace {

using scene::GlobeCameraController;
using scene::GlobePose;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
const glm::ivec2 kViewport(1024, 768);

/// A pixel (x right, y down, centres at +0.5) of the view, or empty behind the eye.
std::optional<glm::dvec2> pixelOf(const globe::GlobeView& view, const glm::dvec3& point) {
  const glm::dvec4 clip = view.viewProj() * glm::dvec4(point, 1.0);
  if (!(clip.w > 0.0)) return std::nullopt;
  const double x = clip.x / clip.w, y = clip.y / clip.w;
  return glm::dvec2((x + 1.0) * 0.5 * view.width - 0.5, (1.0 - y) * 0.5 * view.height - 0.5);
}

globe::GlobeView viewOf(const GlobeCameraController& c) { return c.view(kViewport.x, kViewport.y); }

bool finiteMatrix(const glm::dmat4& m) {
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      if (!std::isfinite(m[i][j])) return false;
    }
  }
  return true;
}

/// Everything a client reads is finite, and the eye is within the limits.
void expectSane(const GlobeCameraController& c, const char* where) {
  const glm::dvec3 eye = c.eye();
  ASSERT_TRUE(std::isfinite(eye.x) && std::isfinite(eye.y) && std::isfinite(eye.z)) << where;
  ASSERT_TRUE(std::isfinite(c.heading()) && std::isfinite(c.pitch()) && std::isfinite(c.distance())) << where;
  ASSERT_TRUE(std::isfinite(c.target().lon) && std::isfinite(c.target().lat) && std::isfinite(c.target().h)) << where;
  const globe::GlobeView v = viewOf(c);
  ASSERT_TRUE(finiteMatrix(v.viewProj()) && finiteMatrix(v.eyeViewProj())) << where;
  EXPECT_GE(c.heightAboveGround(), c.settings().minHeight - 1e-6) << where;
  EXPECT_LE(globe::toGeodetic(eye).h, c.settings().maxHeight * (1.0 + 1e-9)) << where;
  EXPECT_GE(c.pitch(), c.settings().minPitch - 1e-12) << where;
  EXPECT_LE(c.pitch(), kPi / 2.0 + 1e-12) << where;
}

/// A global 1° grid of hills and basins from −1000 m to 4000 m (wraps in longitude).
const globe::GeoGrid& hills() {
  static const globe::GeoGrid grid = [] {
    const int width = 361, height = 181;
    std::vector<float> heights(static_cast<std::size_t>(width) * height);
    for (int r = 0; r < height; ++r) {
      for (int c = 0; c < width; ++c) {
        const double lon = -180.0 + c, lat = 90.0 - r;
        // Flat at the poles, as a real DEM is (one point, one height).
        const double h =
            1500.0 + 2500.0 * std::sin(3.0 * lon * kDeg) * std::cos(lat * kDeg) * std::cos(2.0 * lat * kDeg);
        heights[static_cast<std::size_t>(r) * width + static_cast<std::size_t>(c)] = static_cast<float>(h);
      }
    }
    return globe::GeoGrid(width, height, -180.0, 90.0, 1.0, std::move(heights));
  }();
  return grid;
}

GlobePose poseAt(double lon, double lat, double distance, double heading, double pitch) {
  GlobePose p;
  p.target = {lon, lat, 0.0};
  p.distance = distance;
  p.heading = heading;
  p.pitch = pitch;
  return p;
}

struct ZoomRun {
  double maxError = 0.0;     ///< pixels, over the run
  double finalHeight = 0.0;  ///< above the ground
  int stepsToBottom = -1;    ///< first step at the lowest height
};

/// Zooms `calls` times by `steps` at `cursor`, checking the point first under it after every call.
ZoomRun zoomRun(GlobeCameraController& c, const glm::dvec2& cursor, double steps, int calls) {
  ZoomRun run;
  const std::optional<glm::dvec3> point = c.groundPointAt(cursor, kViewport);
  EXPECT_TRUE(point.has_value());
  if (!point) return run;
  for (int i = 0; i < calls; ++i) {
    c.zoomToCursor(steps, cursor, kViewport);
    const std::optional<glm::dvec2> at = pixelOf(viewOf(c), *point);
    EXPECT_TRUE(at.has_value()) << "call " << i;
    if (!at) return run;
    run.maxError = std::max(run.maxError, glm::length(*at - cursor));
    if (run.stepsToBottom < 0 && c.heightAboveGround() < c.settings().minHeight * (1.0 + 1e-6)) run.stepsToBottom = i;
    EXPECT_GE(c.heightAboveGround(), c.settings().minHeight - 1e-6) << "call " << i;
  }
  run.finalHeight = c.heightAboveGround();
  return run;
}

TEST(GlobeCamera, ZoomToCursorKeepsTheGroundPointDownToOneMetre) {
  struct Case {
    const char* name;
    bool terrain;
    GlobePose start;
    glm::dvec2 cursor;
  };
  const Case cases[] = {
      {"straight down, ellipsoid", false, poseAt(10.0, 45.0, 2e7, 0.0, kPi / 2.0), {600.0, 300.0}},
      {"oblique, ellipsoid", false, poseAt(-60.0, -20.0, 2e7, 0.5, 60.0 * kDeg), {560.0, 430.0}},
      {"straight down, hills", true, poseAt(30.0, 10.0, 2e7, 0.0, kPi / 2.0), {400.0, 460.0}},
      {"oblique, hills, near ±180", true, poseAt(179.0, 60.0, 2e7, -2.0, 50.0 * kDeg), {520.0, 360.0}},
      {"near the north pole", false, poseAt(45.0, 88.0, 2e7, 1.0, 70.0 * kDeg), {530.0, 400.0}},
  };
  for (const Case& k : cases) {
    GlobeCameraController c(k.terrain ? &hills() : nullptr);
    c.setPose(k.start);
    const double startHeight = c.heightAboveGround();
    // 30 calls of 2.6 steps (factor 0.8^2.6 = 0.56 each) take 2·10^7 m to below 1 m: the last clamp.
    const ZoomRun in = zoomRun(c, k.cursor, 2.6, 30);
    EXPECT_LT(in.maxError, 0.5) << k.name;
    EXPECT_NEAR(in.finalHeight, 1.0, 1e-6) << k.name;
    EXPECT_GE(in.stepsToBottom, 25) << k.name;
    // Clamped: more zooming stays at 1 m, the point still under the cursor.
    const ZoomRun more = zoomRun(c, k.cursor, 3.0, 5);
    EXPECT_LT(more.maxError, 0.5) << k.name;
    EXPECT_NEAR(more.finalHeight, 1.0, 1e-6) << k.name;
    std::printf("zoom in %-28s from %.4g m: max cursor error %.2e px, at 1 m after call %d, then %.9f m\n", k.name,
                startHeight, std::max(in.maxError, more.maxError), in.stepsToBottom, more.finalHeight);
    expectSane(c, k.name);

    // Out again: heights grow until the eye is at the maximum above the ellipsoid, never beyond.
    double highest = 0.0;
    for (int i = 0; i < 200; ++i) {
      c.zoomToCursor(-3.0, k.cursor, kViewport);
      const double h = globe::toGeodetic(c.eye()).h;
      highest = std::max(highest, h);
      ASSERT_LE(h, 5e7 * (1.0 + 1e-9)) << k.name;
    }
    EXPECT_GT(highest, 5e7 * 0.999) << k.name;
    expectSane(c, k.name);
    std::printf("zoom out %-27s highest eye %.6g m\n", k.name, highest);
  }
}

TEST(GlobeCamera, HomeFramesTheBox) {
  struct Box {
    double west, south, east, north;
  };
  const Box boxes[] = {
      {-10.0, 35.0, 30.0, 60.0},      // Europe
      {-80.0, -56.0, -34.0, 13.0},    // South America
      {170.0, -25.0, -170.0, -10.0},  // Fiji, across ±180 (east < west)
      {160.0, 50.0, 200.0, 72.0},     // Chukotka, east beyond 180
      {-180.0, 60.0, 180.0, 90.0},    // the Arctic
      {5.0, 45.0, 5.2, 45.1},         // a small one
  };
  for (const bool terrain : {false, true}) {
    GlobeCameraController c(terrain ? &hills() : nullptr);
    for (const Box& b : boxes) {
      c.home(b.west, b.south, b.east, b.north, kViewport);
      expectSane(c, "home");
      EXPECT_DOUBLE_EQ(c.heading(), 0.0);
      EXPECT_DOUBLE_EQ(c.pitch(), kPi / 2.0);
      const globe::GlobeView v = viewOf(c);
      double east = b.east;
      while (east < b.west) east += 360.0;
      double fill = 0.0;
      for (int i = 0; i <= 2; ++i) {
        for (int j = 0; j <= 2; ++j) {
          const double lon = b.west + 0.5 * i * (east - b.west), lat = b.south + 0.5 * j * (b.north - b.south);
          const glm::dvec3 p = globe::toEcef(lon, lat, c.groundHeight(lon, lat));
          const std::optional<glm::dvec2> at = pixelOf(v, p);
          ASSERT_TRUE(at.has_value());
          EXPECT_GE(at->x, 0.0) << lon << " " << lat;
          EXPECT_LE(at->x, kViewport.x) << lon << " " << lat;
          EXPECT_GE(at->y, 0.0) << lon << " " << lat;
          EXPECT_LE(at->y, kViewport.y) << lon << " " << lat;
          EXPECT_FALSE(globe::hiddenByEllipsoid(c.eye(), p, -1000.0)) << lon << " " << lat;
          fill = std::max({fill, std::abs(2.0 * at->x / kViewport.x - 1.0), std::abs(2.0 * at->y / kViewport.y - 1.0)});
        }
      }
      // Just far enough: the box reaches near the (90 %) margin somewhere.
      EXPECT_GT(fill, 0.6) << b.west << " " << b.south;
      if (!terrain) {
        std::printf("home (%g, %g, %g, %g): target (%.3f, %.3f), eye %.4g m up, box fills %.0f %% of the view\n",
                    b.west, b.south, b.east, b.north, c.target().lon, c.target().lat, c.heightAboveGround(),
                    100.0 * fill);
      }
    }
  }
  // Wider than a hemisphere: the whole globe, so rays through the edges of the viewport miss it.
  GlobeCameraController c;
  c.home(-170.0, -80.0, 170.0, 80.0, kViewport);
  expectSane(c, "world");
  for (const glm::dvec2 edge :
       {glm::dvec2(0.0, 384.0), glm::dvec2(1023.0, 384.0), glm::dvec2(512.0, 0.0), glm::dvec2(512.0, 767.0)}) {
    EXPECT_FALSE(c.groundPointAt(edge, kViewport).has_value()) << edge.x << " " << edge.y;
  }
  EXPECT_TRUE(c.groundPointAt(glm::dvec2(512.0, 384.0), kViewport).has_value());
  std::printf("home (whole globe): eye %.4g m up\n", c.heightAboveGround());
}

TEST(GlobeCamera, HomeFramesTheBoxInTheRegionAPanelLeavesFree) {
  // A panel over the left 400 pixels and a status bar at the bottom: home frames each box in the
  // rest, its middle in the region's middle (the box's extent on screen centred there within a
  // pixel), just far enough (it reaches near the margin), heading 0 and straight down as before;
  // a box wider than a hemisphere shows the whole globe.
  const glm::dvec4 region(400.0, 0.0, 1024.0, 740.0);
  const glm::dvec2 middle(0.5 * (region.x + region.z), 0.5 * (region.y + region.w));
  struct Box {
    double west, south, east, north;
  };
  const Box boxes[] = {{-10.0, 35.0, 30.0, 60.0},
                       {-80.0, -56.0, -34.0, 13.0},
                       {170.0, -25.0, -170.0, -10.0},
                       {5.0, 45.0, 5.2, 45.1},
                       {-60.0, 70.0, 60.0, 85.0}};
  for (const bool terrain : {false, true}) {
    GlobeCameraController c(terrain ? &hills() : nullptr);
    for (const Box& b : boxes) {
      c.home(b.west, b.south, b.east, b.north, kViewport, region);
      expectSane(c, "home in a region");
      EXPECT_DOUBLE_EQ(c.heading(), 0.0);
      EXPECT_DOUBLE_EQ(c.pitch(), kPi / 2.0);
      const globe::GlobeView v = viewOf(c);
      double east = b.east;
      while (east < b.west) east += 360.0;
      glm::dvec2 lo(1e9), hi(-1e9);
      for (int i = 0; i <= 16; ++i) {
        for (int j = 0; j <= 16; ++j) {
          if (i != 0 && i != 16 && j != 0 && j != 16) continue;  // the outline
          const double lon = b.west + i / 16.0 * (east - b.west), lat = b.south + j / 16.0 * (b.north - b.south);
          const std::optional<glm::dvec2> at = pixelOf(v, globe::toEcef(lon, lat, c.groundHeight(lon, lat)));
          ASSERT_TRUE(at.has_value()) << lon << " " << lat;
          lo = glm::min(lo, *at);
          hi = glm::max(hi, *at);
        }
      }
      EXPECT_GE(lo.x, region.x) << b.west << " " << b.south;
      EXPECT_LE(hi.x, region.z) << b.west << " " << b.south;
      EXPECT_GE(lo.y, region.y) << b.west << " " << b.south;
      EXPECT_LE(hi.y, region.w) << b.west << " " << b.south;
      EXPECT_LT(glm::length(0.5 * (lo + hi) - middle), 1.0) << b.west << " " << b.south;
      const double fill = std::max((hi.x - lo.x) / (region.z - region.x), (hi.y - lo.y) / (region.w - region.y));
      EXPECT_GT(fill, 0.8) << b.west << " " << b.south;
    }
  }
  // Wider than a hemisphere: the whole globe, as without a region (looking straight down, the
  // globe is in the middle of the view).
  GlobeCameraController c;
  c.home(-170.0, -80.0, 170.0, 80.0, kViewport, region);
  expectSane(c, "world in a region");
  EXPECT_TRUE(c.groundPointAt(glm::dvec2(512.0, 384.0), kViewport).has_value());
  EXPECT_FALSE(c.groundPointAt(glm::dvec2(0.0, 384.0), kViewport).has_value());
}

TEST(GlobeCamera, AnAuthoredCameraIsCentredInTheRegionAPanelLeavesFree) {
  // A camera as a scene's author placed it (straight down from 9,000 km, or oblique, at any
  // heading, near a pole or across ±180°): slid over the ground so that its target is seen in the
  // middle of the region a panel leaves free, within a pixel; distance, heading and pitch kept.
  const glm::dvec4 region(400.0, 0.0, 1024.0, 740.0);
  const glm::dvec2 middle(0.5 * (region.x + region.z), 0.5 * (region.y + region.w));
  struct Case {
    double lon, lat, distance, heading, pitch;
  };
  const Case cases[] = {{-62.0, -28.0, 9e6, 0.0, kPi / 2.0},
                        {10.0, 45.0, 2e5, 30.0 * kDeg, 40.0 * kDeg},
                        {179.9, -16.0, 5e4, -120.0 * kDeg, 60.0 * kDeg},
                        {0.0, 84.0, 1e6, 200.0 * kDeg, 70.0 * kDeg}};
  for (const bool terrain : {false, true}) {
    for (const Case& k : cases) {
      GlobeCameraController c(terrain ? &hills() : nullptr);
      GlobePose pose;
      pose.target = {k.lon, k.lat, 0.0};
      pose.distance = k.distance;
      pose.heading = k.heading;
      pose.pitch = k.pitch;
      c.setPose(pose);
      const GlobePose before{c.target(), c.distance(), c.heading(), c.pitch()};
      const glm::dvec3 target = globe::toEcef(before.target.lon, before.target.lat, before.target.h);
      c.centreIn(kViewport, region);
      expectSane(c, "centred in a region");
      const std::optional<glm::dvec2> at = pixelOf(viewOf(c), target);
      ASSERT_TRUE(at.has_value()) << k.lon << " " << k.lat;
      EXPECT_LT(glm::length(*at + 0.5 - middle), 1.0) << k.lon << " " << k.lat << " at " << at->x << " " << at->y;
      EXPECT_NEAR(c.distance(), before.distance, 1e-6 * before.distance);
      EXPECT_NEAR(std::remainder(c.heading() - before.heading, 2.0 * kPi), 0.0, 0.02) << k.lon << " " << k.lat;
      EXPECT_DOUBLE_EQ(c.pitch(), before.pitch);
      // The whole viewport as the region: nothing moves.
      const GlobePose placed{c.target(), c.distance(), c.heading(), c.pitch()};
      c.centreIn(kViewport, glm::dvec4(0.0, 0.0, kViewport.x, kViewport.y));
      EXPECT_DOUBLE_EQ(c.target().lon, placed.target.lon);
      EXPECT_DOUBLE_EQ(c.target().lat, placed.target.lat);
    }
  }
}

TEST(GlobeCamera, OrbitKeepsTheTarget) {
  GlobeCameraController c(&hills());
  c.setPose(poseAt(20.0, 40.0, 5000.0, 0.3, 0.8));
  const glm::dvec3 target = globe::toEcef(c.target());
  const glm::dvec2 centre(0.5 * kViewport.x - 0.5, 0.5 * kViewport.y - 0.5);
  double maxError = 0.0;
  const double turns[][2] = {{0.5, 0.1}, {-2.0, -0.3}, {3.0, 0.5}, {0.1, -2.0}, {-0.7, 4.0}, {1.0, -0.2}};
  for (const auto& t : turns) {
    c.orbit(t[0], t[1]);
    expectSane(c, "orbit");
    const std::optional<glm::dvec2> at = pixelOf(viewOf(c), target);
    ASSERT_TRUE(at.has_value());
    maxError = std::max(maxError, glm::length(*at - centre));
    EXPECT_NEAR(globe::toEcef(c.target()).x, target.x, 1e-6);
  }
  EXPECT_LT(maxError, 1e-3);
  // Pitch limits.
  c.orbit(0.0, -10.0);
  EXPECT_NEAR(c.pitch(), c.settings().minPitch, 1e-12);
  c.orbit(0.0, 10.0);
  EXPECT_NEAR(c.pitch(), kPi / 2.0, 1e-12);
  // Orbiting low over the hills keeps the eye above them (the distance grows if it must).
  c.setPose(poseAt(20.0, 40.0, 30.0, 0.0, kPi / 2.0));
  for (int i = 0; i < 72; ++i) {
    c.orbit(0.1, -0.05);
    expectSane(c, "low orbit");
  }
  std::printf("orbit: target off the centre by at most %.2e px\n", maxError);
}

TEST(GlobeCamera, FlyMovesTheEyeAlongTheHeadingAndLookTurnsAboutIt) {
  // Over the ellipsoid (no ground), about 1,000 m up at 45° N, heading 60°.
  GlobeCameraController c(nullptr);
  c.setPose(poseAt(10.0, 45.0, 2000.0, 60.0 * kDeg, 30.0 * kDeg));
  const double height = c.heightAboveGround();
  ASSERT_NEAR(height, 1000.0, 1.0);  // the ellipsoid curves away under the eye 1.7 km off the target
  // Forward for a second: the eye goes about its height (flySpeedPerSecond 1) along the heading,
  // level; heading, pitch and distance stay.
  const glm::dvec3 eye0 = c.eye();
  const glm::dmat3 enu = globe::enuBasis(c.target().lon, c.target().lat);
  c.fly({0.0, 1.0, 0.0}, 1.0);
  expectSane(c, "fly");
  const glm::dvec3 step = c.eye() - eye0;
  const glm::dvec3 along = std::sin(60.0 * kDeg) * enu[0] + std::cos(60.0 * kDeg) * enu[1];
  EXPECT_NEAR(glm::length(step), height, 0.01 * height);
  EXPECT_GT(glm::dot(step, along), 0.999 * glm::length(step));
  EXPECT_NEAR(c.heightAboveGround(), height, 0.5);
  EXPECT_NEAR(c.pitch(), 30.0 * kDeg, 1e-9);
  EXPECT_NEAR(c.distance(), 2000.0, 1e-6);
  // Right: across the heading; up: higher by the speed (the height's) times the seconds.
  const glm::dvec3 eye1 = c.eye();
  c.fly({1.0, 0.0, 0.0}, 0.5);
  const glm::dvec3 across = std::cos(60.0 * kDeg) * enu[0] - std::sin(60.0 * kDeg) * enu[1];
  EXPECT_GT(glm::dot(glm::normalize(c.eye() - eye1), across), 0.999);
  const double before = c.heightAboveGround();
  c.fly({0.0, 0.0, 1.0}, 0.25);
  EXPECT_NEAR(c.heightAboveGround(), 1.25 * before, 1e-3 * before);
  // Down as far as it goes: the eye stops at minHeight.
  for (int i = 0; i < 200; ++i) c.fly({0.0, 0.0, -1.0}, 1.0);
  EXPECT_NEAR(c.heightAboveGround(), c.settings().minHeight, 1e-6);
  // Look: the view turns about the eye, which stays; the target is on the ground ahead.
  c.setPose(poseAt(-170.0, -30.0, 3000.0, 0.0, 40.0 * kDeg));
  const glm::dvec3 eye2 = c.eye();
  c.look(0.5, -0.2);
  expectSane(c, "look");
  EXPECT_LT(glm::length(c.eye() - eye2), 1e-3);
  EXPECT_NEAR(c.heading(), 0.5, 1e-9);
  EXPECT_NEAR(c.pitch(), 40.0 * kDeg - 0.2, 1e-9);
  EXPECT_NEAR(globe::toGeodetic(globe::toEcef(c.target())).h, 0.0, 1e-6);
  // Turning all the way round comes back to the same view.
  for (int i = 0; i < 8; ++i) c.look(kPi / 4.0, 0.0);
  EXPECT_LT(glm::length(c.eye() - eye2), 1e-3);
  EXPECT_NEAR(std::remainder(c.heading() - 0.5, 2.0 * kPi), 0.0, 1e-9);
}

TEST(GlobeCamera, NorthUpPointsNorthUp) {
  for (const double pitch : {kPi / 2.0, 0.9, 0.2}) {
    GlobeCameraController c(&hills());
    c.setPose(poseAt(-75.0, 45.0, 20000.0, 2.0, pitch));
    c.northUp();
    EXPECT_EQ(c.heading(), 0.0);
    const globe::GlobeView v = viewOf(c);
    const globe::Geodetic t = c.target();
    const std::optional<glm::dvec2> here = pixelOf(v, globe::toEcef(t));
    const std::optional<glm::dvec2> north = pixelOf(v, globe::toEcef(t.lon, t.lat + 0.01, t.h));
    const std::optional<glm::dvec2> east = pixelOf(v, globe::toEcef(t.lon + 0.01, t.lat, t.h));
    ASSERT_TRUE(here && north && east);
    EXPECT_LT(north->y, here->y - 1.0) << pitch;                                       // north is up on screen
    EXPECT_NEAR(north->x, here->x, 0.5) << pitch;                                      // straight up
    EXPECT_GT(east->x, here->x + 1.0) << pitch;                                        // and east to the right
    EXPECT_NEAR(east->y, here->y, 0.5 + 0.01 * std::abs(east->x - here->x)) << pitch;  // the horizon is level
  }
  // At a pole north is not defined: heading 0 in the frame of the target's longitude, finite.
  for (const double lat : {90.0, -90.0}) {
    GlobeCameraController c;
    c.setPose(poseAt(33.0, lat, 1e5, 1.2, 0.6));
    c.northUp();
    EXPECT_EQ(c.heading(), 0.0);
    expectSane(c, "pole north-up");
  }
}

TEST(GlobeCamera, GrabMovesThePointUnderTheCursor) {
  struct Case {
    double height;
    glm::dvec2 from, to;
  };
  const Case cases[] = {
      {1e7, {400.0, 300.0}, {620.0, 480.0}}, {1e7, {700.0, 500.0}, {300.0, 250.0}},
      {1e7, {512.0, 150.0}, {512.0, 600.0}}, {1e3, {400.0, 300.0}, {620.0, 480.0}},
      {1e3, {700.0, 600.0}, {100.0, 650.0}}, {1e3, {512.0, 500.0}, {520.0, 200.0}},
  };
  for (const bool terrain : {false, true}) {
    for (const Case& k : cases) {
      GlobeCameraController c(terrain ? &hills() : nullptr);
      c.setPose(poseAt(12.0, 47.0, k.height, 0.4, 1.2));
      if (&k == &cases[2]) c.setPose(poseAt(12.0, 75.0, k.height, 0.0, kPi / 2.0));  // drags the pole across
      const std::optional<glm::dvec3> point = c.groundPointAt(k.from, kViewport);
      ASSERT_TRUE(point.has_value());
      const globe::Geodetic before = c.target();
      c.grab(k.from, k.to, kViewport);
      expectSane(c, "grab");
      const std::optional<glm::dvec2> at = pixelOf(viewOf(c), *point);
      ASSERT_TRUE(at.has_value());
      const double error = glm::length(*at - k.to);
      EXPECT_LT(error, 1.0) << k.height << " " << k.from.x << " " << k.to.x;
      std::printf(
          "grab at %.0e m%s: (%g, %g) → (%g, %g), the point lands %.2e px off; target moved %.4g° lon, %.4g° lat, "
          "heading %.3f\n",
          k.height, terrain ? " (hills)" : "", k.from.x, k.from.y, k.to.x, k.to.y, error, c.target().lon - before.lon,
          c.target().lat - before.lat, c.heading());
    }
  }
}

TEST(GlobeCamera, FiniteAtThePolesAndAcrossTheAntimeridian) {
  const double lats[] = {90.0, -90.0, 89.999999, -89.9999, 89.5, 0.0};
  const double lons[] = {180.0, -180.0, 179.99999, 0.0};
  const glm::dvec2 pixels[] = {{512.0, 384.0}, {100.0, 100.0}, {900.0, 700.0}, {512.0, 10.0}};
  double worstZoom = 0.0;
  for (const bool terrain : {false, true}) {
    for (const double lat : lats) {
      for (const double lon : lons) {
        for (const double height : {5e6, 2e3, 10.0}) {
          GlobeCameraController c(terrain ? &hills() : nullptr);
          c.setPose(poseAt(lon, lat, height, 0.7, 1.0));
          expectSane(c, "pose");
          c.orbit(1.0, 0.3);
          c.northUp();
          expectSane(c, "north-up");
          for (const glm::dvec2& from : pixels) {
            for (const glm::dvec2& to : pixels) {
              c.grab(from, to, kViewport);
              expectSane(c, "grab");
            }
          }
          // Zooming near a pole still keeps the point under the cursor.
          const glm::dvec2 cursor(560.0, 420.0);
          if (const std::optional<glm::dvec3> point = c.groundPointAt(cursor, kViewport)) {
            for (int i = 0; i < 10; ++i) {
              c.zoomToCursor(2.0, cursor, kViewport);
              expectSane(c, "zoom");
              const std::optional<glm::dvec2> at = pixelOf(viewOf(c), *point);
              ASSERT_TRUE(at.has_value());
              worstZoom = std::max(worstZoom, glm::length(*at - cursor));
            }
          }
          c.zoomToCursor(-20.0, cursor, kViewport);
          expectSane(c, "zoom out");
          c.setHeading(-2.5);
          c.home(lon - 1.0, std::max(lat - 1.0, -90.0), lon + 1.0, std::min(lat + 1.0, 90.0), kViewport);
          expectSane(c, "home");
        }
      }
    }
  }
  EXPECT_LT(worstZoom, 0.5);
  std::printf("poles and ±180°: all finite; zoom near them keeps the point within %.2e px\n", worstZoom);
}

TEST(GlobeCamera, RandomGesturesStayFiniteAndWithinTheLimits) {
  std::mt19937 random(20240611);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  GlobeCameraController c(&hills());
  double lowest = 1e300, highest = 0.0, worstZoom = 0.0;
  int zooms = 0, kept = 0, atBottom = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 1000; ++i) {
    const glm::dvec2 a(unit(random) * kViewport.x, unit(random) * kViewport.y);
    const glm::dvec2 b(unit(random) * kViewport.x, unit(random) * kViewport.y);
    const int op = static_cast<int>(unit(random) * 16.0);
    if (op < 2) {
      c.orbit((unit(random) - 0.5) * 2.0, (unit(random) - 0.5) * 1.0);
    } else if (op < 8) {
      const std::optional<glm::dvec3> point = c.groundPointAt(a, kViewport);
      const double steps = (unit(random) - 0.3) * 12.0;
      const double before = c.heightAboveGround();
      c.zoomToCursor(steps, a, kViewport);
      // Away from the clamps and the limb the point stays under the cursor.
      if (point && c.heightAboveGround() > 1.01 && c.heightAboveGround() < 0.5 * before) {
        ++zooms;
        if (const std::optional<glm::dvec2> at = pixelOf(viewOf(c), *point)) {
          worstZoom = std::max(worstZoom, glm::length(*at - a));
          kept += glm::length(*at - a) < 0.5 ? 1 : 0;
        }
      }
    } else if (op < 12) {
      c.grab(a, glm::mix(a, b, unit(random)), kViewport);
    } else if (op == 12) {
      c.setHeading((unit(random) - 0.5) * 10.0);
    } else if (op == 13) {
      c.northUp();
    } else if (op == 14) {
      const double west = unit(random) * 400.0 - 200.0, south = unit(random) * 180.0 - 90.0;
      c.home(west, south, west + unit(random) * 60.0, std::min(south + unit(random) * 40.0, 90.0), kViewport);
    } else {
      // Somewhere awkward: at or near a pole or ±180°, low or high.
      const double lat = unit(random) < 0.5 ? (unit(random) < 0.5 ? 90.0 : -90.0) * (1.0 - 1e-7 * unit(random)) : 0.0;
      c.setPose(poseAt(unit(random) < 0.5 ? 180.0 : -180.0, lat, std::pow(10.0, unit(random) * 7.0), unit(random) * 7.0,
                       unit(random) * 1.6));
    }
    atBottom += c.heightAboveGround() < 1.0 + 1e-6 ? 1 : 0;
    expectSane(c, "random");
    if (HasFatalFailure()) return;
    lowest = std::min(lowest, c.heightAboveGround());
    highest = std::max(highest, globe::toGeodetic(c.eye()).h);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(kept, zooms);
  std::printf(
      "1000 random gestures in %.2f s: eye %.6f m above the ground at the lowest, %.4g m above the "
      "ellipsoid at the highest, %d gestures ended at 1 m; %d zooms in checked, worst cursor error %.2e px\n",
      seconds, lowest, highest, atBottom, zooms, worstZoom);
}

}  // namespace
}  // namespace gis::test
