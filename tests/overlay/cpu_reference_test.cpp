// The CPU reference (vector_overlay/cpu_reference.hpp), without GL: depth images are computed
// analytically (ray casts against planes and a step) for cameras built with gfx::lookAt and
// gfx::reversedInfinitePerspective, then checked against the analytic ground points and against
// shapes whose coverage is known by hand.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "gfx/camera.hpp"
#include "test_paths.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace {

namespace ov = gis::overlay;
using gis::geo::Feature;
using gis::geo::LineString;
using gis::geo::Polygon;
using gis::geo::Ring;
using glm::dvec2;
using glm::dvec3;
using ov::LayerKind;
using ov::LineCap;
using ov::LineJoin;
using ov::LineShape;
using ov::ReferenceLayer;

constexpr double kPi = std::numbers::pi;
double radians(double degrees) { return degrees * kPi / 180.0; }

// ---------------------------------------------------------------------------------------------
// Analytic scenes and cameras

struct Hit {
  double t = 0.0;  ///< along the ray direction (whose forward component is 1: t = view depth)
  int surface = 0;
};
using Scene = std::function<std::optional<Hit>(const dvec3& origin, const dvec3& direction)>;

/// The plane n·p = offset; with a radius, only its points within that distance (in x, y) of
/// `centre` exist (the rest of the image is background).
Scene planeScene(const dvec3& normal, double offset, std::optional<double> radius = std::nullopt,
                 dvec2 centre = dvec2(0.0)) {
  return [=](const dvec3& o, const dvec3& d) -> std::optional<Hit> {
    const double denominator = glm::dot(normal, d);
    if (denominator == 0.0) return std::nullopt;
    const double t = (offset - glm::dot(normal, o)) / denominator;
    if (!(t > 0.0)) return std::nullopt;
    const dvec3 p = o + d * t;
    if (radius && glm::length(dvec2(p) - centre) > *radius) return std::nullopt;
    return Hit{t, 0};
  };
}

/// Ground z = 0 for x < 0 (surface 0), a plateau z = height for x > 0 (surface 2), joined by the
/// wall x = 0 (surface 1).
Scene stepScene(double height) {
  return [=](const dvec3& o, const dvec3& d) -> std::optional<Hit> {
    std::optional<Hit> best;
    auto consider = [&best](double t, int surface) {
      if (t > 0.0 && (!best || t < best->t)) best = Hit{t, surface};
    };
    if (d.z != 0.0) {
      const double tLow = -o.z / d.z;
      if (o.x + d.x * tLow <= 0.0) consider(tLow, 0);
      const double tHigh = (height - o.z) / d.z;
      if (o.x + d.x * tHigh > 0.0) consider(tHigh, 2);
    }
    if (d.x != 0.0) {
      const double tWall = -o.x / d.x;
      const double z = o.z + d.z * tWall;
      if (z >= 0.0 && z <= height) consider(tWall, 1);
    }
    return best;
  };
}

struct Camera {
  dvec3 eye{0.0};
  dvec3 right{1.0, 0.0, 0.0};
  dvec3 up{0.0, 1.0, 0.0};
  dvec3 forward{0.0, 0.0, -1.0};
  double tanHalf = 1.0;
  double aspect = 1.0;
  double near = 0.5;
  int width = 1;
  int height = 1;
  glm::dmat4 viewProj{1.0};

  /// The ray through window point (px, py) (pixels, y down), scaled so its forward part is 1.
  [[nodiscard]] dvec3 ray(double px, double py) const {
    const double nx = 2.0 * px / width - 1.0;
    const double ny = 1.0 - 2.0 * py / height;
    return forward + right * (nx * tanHalf * aspect) + up * (ny * tanHalf);
  }
};

Camera makeCamera(const dvec3& eye, const dvec3& target, double fovYRadians, int width, int height) {
  Camera c;
  c.eye = eye;
  c.width = width;
  c.height = height;
  c.aspect = static_cast<double>(width) / height;
  c.tanHalf = std::tan(fovYRadians / 2.0);
  const glm::dmat4 view = gis::gfx::lookAt(eye, target, dvec3(0.0, 0.0, 1.0));
  // lookAt's rotation rows are right, up and −forward.
  c.right = dvec3(view[0][0], view[1][0], view[2][0]);
  c.up = dvec3(view[0][1], view[1][1], view[2][1]);
  c.forward = -dvec3(view[0][2], view[1][2], view[2][2]);
  c.viewProj = gis::gfx::reversedInfinitePerspective(fovYRadians, c.aspect, c.near) * view;
  return c;
}

/// A camera looking at a random point of the plane n·p = offset near `centre`, from above.
Camera randomCamera(std::mt19937& rng, int width, int height, double minElevationDeg, const dvec3& normal = {0, 0, 1},
                    double offset = 0.0, const dvec2& centre = dvec2(0.0)) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const dvec2 xy = centre + dvec2(-40.0 + 80.0 * u(rng), -40.0 + 80.0 * u(rng));
  const dvec3 target(xy, (offset - normal.x * xy.x - normal.y * xy.y) / normal.z);
  const double distance = 80.0 + 220.0 * u(rng);
  const double elevation = radians(minElevationDeg + (90.0 - minElevationDeg) * u(rng));
  const double azimuth = 2.0 * kPi * u(rng);
  const dvec3 eye = target + distance * dvec3(std::cos(elevation) * std::cos(azimuth),
                                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
  return makeCamera(eye, target, radians(30.0 + 35.0 * u(rng)), width, height);
}

/// A depth image rendered analytically, with the true terrain point and surface of each pixel.
struct Rendered {
  Camera camera;
  std::vector<float> depth;
  std::vector<std::optional<dvec3>> truth;
  std::vector<int> surface;  ///< −1 for background

  [[nodiscard]] ov::DepthImage image() const {
    return ov::DepthImage{camera.width, camera.height, depth, camera.viewProj};
  }
  [[nodiscard]] std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x);
  }
};

Rendered render(const Camera& camera, const Scene& scene) {
  Rendered r{camera, {}, {}, {}};
  const std::size_t n = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  r.depth.assign(n, 0.0F);
  r.truth.assign(n, std::nullopt);
  r.surface.assign(n, -1);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const dvec3 d = camera.ray(x + 0.5, y + 0.5);
      const std::optional<Hit> hit = scene(camera.eye, d);
      if (!hit || hit->t < camera.near) continue;
      const std::size_t i = r.index(x, y);
      r.depth[i] = static_cast<float>(camera.near / hit->t);  // reversed-Z: near / view depth
      r.truth[i] = camera.eye + d * hit->t;
      r.surface[i] = hit->surface;
    }
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Features and layers

Ring rect(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }

Feature polygonFeature(std::vector<Polygon> polygons) {
  Feature f;
  f.polygons = std::move(polygons);
  return f;
}

Feature lineFeature(std::vector<LineString> lines) {
  Feature f;
  f.lines = std::move(lines);
  return f;
}

ReferenceLayer polygonLayer(const std::vector<Feature>& features, std::string name = "polygons") {
  ReferenceLayer layer;
  layer.name = std::move(name);
  layer.kind = LayerKind::Polygon;
  layer.features = &features;
  return layer;
}

ReferenceLayer lineLayer(const std::vector<Feature>& features, std::vector<LineShape> shapes,
                         std::string name = "lines") {
  ReferenceLayer layer;
  layer.name = std::move(name);
  layer.kind = LayerKind::Line;
  layer.features = &features;
  layer.shapes = std::move(shapes);
  return layer;
}

LineShape shapeOf(double width, LineJoin join, LineCap cap, double miterLimit = 4.0) {
  LineShape shape;
  shape.width = width;
  shape.join = join;
  shape.cap = cap;
  shape.miterLimit = miterLimit;
  return shape;
}

bool covers(const ReferenceLayer& layer, const dvec2& p) { return ov::coveringFeature(layer, p).has_value(); }

/// Coverage of one line by itself.
bool lineCovers(const LineString& line, const LineShape& shape, const dvec2& p) {
  const std::vector<Feature> features{lineFeature({line})};
  return covers(lineLayer(features, {shape}), p);
}

double segmentDistance(const dvec2& p, const dvec2& a, const dvec2& b) {
  const dvec2 ab = b - a;
  const double t = std::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.0, 1.0);
  return glm::length(p - (a + ab * t));
}

// ---------------------------------------------------------------------------------------------
// unprojectPixel

/// Float depth carries a relative rounding error of at most 2^-24; the view depth (near / depth)
/// and so the distance from the eye along the pixel's ray inherit it. The double unprojection
/// adds far less. So the recovered point is within 2^-23 (a 2× margin) of the eye distance.
double unprojectTolerance(const dvec3& eye, const dvec3& p) { return std::ldexp(glm::length(p - eye), -23) + 1e-9; }

/// Checks every pixel; returns the largest error in units of 2^-24 of the eye distance.
double expectUnprojects(const Rendered& r) {
  const ov::DepthImage image = r.image();
  int hits = 0;
  double worst = 0.0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::optional<dvec3> got = ov::unprojectPixel(image, x, y);
      const std::optional<dvec3>& want = r.truth[r.index(x, y)];
      EXPECT_EQ(got.has_value(), want.has_value()) << x << "," << y;
      if (!want || !got) continue;
      ++hits;
      const double error = glm::length(*got - *want);
      EXPECT_LE(error, unprojectTolerance(r.camera.eye, *want))
          << "pixel " << x << "," << y << " distance " << glm::length(*want - r.camera.eye);
      worst = std::max(worst, std::ldexp(error / glm::length(*want - r.camera.eye), 24));
    }
  }
  EXPECT_GT(hits, 0);
  return worst;
}

TEST(UnprojectPixel, PixelCentresFromTheTopLeft) {
  // Straight down onto z = 0 (lookAt's fallback up is +y, so the image's up is +y): a 4 × 2
  // image; pixel (0, 0) is the top-left one, its centre at NDC (−0.75, +0.5).
  const double fov = radians(60.0);
  const Camera camera = makeCamera({10.0, 20.0, 100.0}, {10.0, 20.0, 0.0}, fov, 4, 2);
  const Rendered r = render(camera, planeScene({0, 0, 1}, 0.0));
  const ov::DepthImage image = r.image();
  const double halfHeight = 100.0 * std::tan(fov / 2.0);  // metres on the ground
  const double halfWidth = halfHeight * 2.0;
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 4; ++x) {
      const dvec3 want(10.0 + halfWidth * (2.0 * (x + 0.5) / 4.0 - 1.0),
                       20.0 + halfHeight * (1.0 - 2.0 * (y + 0.5) / 2.0), 0.0);
      const std::optional<dvec3> got = ov::unprojectPixel(image, x, y);
      ASSERT_TRUE(got.has_value());
      EXPECT_LE(glm::length(*got - want), unprojectTolerance(camera.eye, want)) << x << "," << y;
    }
  }
  EXPECT_FALSE(ov::unprojectPixel(image, -1, 0).has_value());
  EXPECT_FALSE(ov::unprojectPixel(image, 4, 0).has_value());
  EXPECT_FALSE(ov::unprojectPixel(image, 0, 2).has_value());
}

TEST(UnprojectPixel, RecoversGroundPointsFromRandomCameras) {
  std::mt19937 rng(7);
  const dvec3 tilted = glm::normalize(dvec3(0.3, -0.2, 1.0));
  double worst = 0.0;
  for (int i = 0; i < 8; ++i) {
    SCOPED_TRACE(i);
    // Flat ground, with the horizon in view for low elevations (background above it).
    worst = std::max(worst, expectUnprojects(render(randomCamera(rng, 64, 48, 5.0), planeScene({0, 0, 1}, 0.0))));
    worst = std::max(worst,
                     expectUnprojects(render(randomCamera(rng, 48, 64, 20.0, tilted, 5.0), planeScene(tilted, 5.0))));
  }
  std::cout << "[ unproject ] largest error: " << worst << " × 2^-24 of the eye distance (tolerance 2)\n";
}

TEST(UnprojectPixel, FarFromTheFrameOrigin) {
  // 60 km from the origin, as at the edge of a large DEM.
  std::mt19937 rng(8);
  const dvec2 centre(60000.0, -45000.0);
  double worst = 0.0;
  for (int i = 0; i < 3; ++i) {
    worst = std::max(worst, expectUnprojects(render(randomCamera(rng, 40, 30, 20.0, {0, 0, 1}, 0.0, centre),
                                                    planeScene({0, 0, 1}, 0.0))));
  }
  std::cout << "[ unproject ] 60 km out, largest error: " << worst << " × 2^-24 of the eye distance\n";
}

TEST(UnprojectPixel, BackgroundIsNullopt) {
  const Camera camera = makeCamera({0, 0, 50}, {0, 0, 0}, radians(60.0), 8, 8);
  std::vector<float> depth(64, 0.0F);
  depth[9] = 0.5F;
  const ov::DepthImage image{8, 8, depth, camera.viewProj};
  EXPECT_FALSE(ov::unprojectPixel(image, 0, 0).has_value());
  EXPECT_TRUE(ov::unprojectPixel(image, 1, 1).has_value());
  EXPECT_TRUE(ov::pick(image, {}, 0, 0).empty());
}

// ---------------------------------------------------------------------------------------------
// Coverage of polygons

TEST(PolygonCoverage, Square) {
  const std::vector<Feature> features{polygonFeature({Polygon{rect(0, 0, 10, 10), {}}})};
  const ReferenceLayer layer = polygonLayer(features);
  for (const dvec2 p : {dvec2(5, 5), dvec2(0.01, 0.01), dvec2(9.99, 5), dvec2(5, 9.99)}) EXPECT_TRUE(covers(layer, p));
  for (const dvec2 p : {dvec2(-0.01, 5), dvec2(10.01, 5), dvec2(5, -0.01), dvec2(5, 10.01), dvec2(20, 20)})
    EXPECT_FALSE(covers(layer, p));
  EXPECT_EQ(ov::coveringFeature(layer, {5, 5}), std::optional<std::size_t>(0));
}

TEST(PolygonCoverage, RawRingsNeedNoRepair) {
  // Clockwise, with a repeated point, collinear points and the closing point repeated.
  Ring ring{{0, 0}, {0, 10}, {0, 10}, {10, 10}, {10, 5}, {10, 0}, {5, 0}, {0, 0}};
  const std::vector<Feature> features{polygonFeature({Polygon{ring, {}}})};
  const ReferenceLayer layer = polygonLayer(features);
  EXPECT_TRUE(covers(layer, {5, 5}));
  EXPECT_TRUE(covers(layer, {9.99, 0.01}));
  EXPECT_FALSE(covers(layer, {10.01, 5}));
  EXPECT_FALSE(covers(layer, {5, -0.01}));
}

TEST(PolygonCoverage, HoleInEitherOrientation) {
  Ring hole = rect(3, 3, 7, 7);
  Ring reversedHole(hole.rbegin(), hole.rend());
  for (const Ring& h : {hole, reversedHole}) {
    const std::vector<Feature> features{polygonFeature({Polygon{rect(0, 0, 10, 10), {h}}})};
    const ReferenceLayer layer = polygonLayer(features);
    for (const dvec2 p : {dvec2(1, 1), dvec2(2.99, 5), dvec2(7.01, 5), dvec2(5, 9)}) EXPECT_TRUE(covers(layer, p));
    for (const dvec2 p : {dvec2(5, 5), dvec2(3.01, 5), dvec2(6.99, 6.99), dvec2(11, 5)}) EXPECT_FALSE(covers(layer, p));
  }
}

TEST(PolygonCoverage, BowTieByEvenOdd) {
  // (0,0) → (10,10) → (10,0) → (0,10): two triangles meeting at (5,5); signed area zero.
  const std::vector<Feature> features{polygonFeature({Polygon{{{0, 0}, {10, 10}, {10, 0}, {0, 10}}, {}}})};
  const ReferenceLayer layer = polygonLayer(features);
  for (const dvec2 p : {dvec2(1, 5), dvec2(9, 5), dvec2(4.9, 5), dvec2(0.5, 9)}) EXPECT_TRUE(covers(layer, p));
  for (const dvec2 p : {dvec2(5, 9), dvec2(5, 1), dvec2(5, 5.1), dvec2(-0.1, 5)}) EXPECT_FALSE(covers(layer, p));
}

TEST(PolygonCoverage, SelfOverlappingRingByEvenOdd) {
  // A ring that winds twice round the square [4,6]² inside [0,10]²: the doubly wound part is even.
  const Ring ring{{0, 0}, {10, 0}, {10, 10}, {0, 10}, {0, 0}, {4, 4}, {6, 4}, {6, 6}, {4, 6}, {4, 4}};
  const std::vector<Feature> features{polygonFeature({Polygon{ring, {}}})};
  const ReferenceLayer layer = polygonLayer(features);
  EXPECT_TRUE(covers(layer, {2, 7}));
  EXPECT_FALSE(covers(layer, {5, 5}));
}

TEST(PolygonCoverage, MultiPolygonIsAUnion) {
  // Two overlapping parts: the overlap stays covered (union, not even-odd across polygons);
  // a hole of one part is covered by the other part.
  const Polygon a{rect(0, 0, 10, 10), {rect(6, 6, 8, 8)}};
  const Polygon b{rect(5, 5, 15, 15), {}};
  const std::vector<Feature> features{polygonFeature({a, b})};
  const ReferenceLayer layer = polygonLayer(features);
  for (const dvec2 p : {dvec2(2, 2), dvec2(7, 7), dvec2(9, 9), dvec2(12, 12)}) EXPECT_TRUE(covers(layer, p));
  for (const dvec2 p : {dvec2(2, 12), dvec2(12, 2), dvec2(16, 16)}) EXPECT_FALSE(covers(layer, p));
}

TEST(PolygonCoverage, UnusablePolygonsAreSkipped) {
  // An outer ring without area (collinear points, or fewer than 3 distinct points) makes the
  // polygon unusable: its hole must not become covered; the feature's good polygon still counts.
  const Polygon flat{{{0, 0}, {5, 0}, {10, 0}}, {rect(2, 2, 4, 4)}};
  const Polygon twoPoints{{{0, 0}, {10, 10}, {0, 0}}, {rect(5, -5, 7, -3)}};
  const Polygon good{rect(20, 0, 30, 10), {}};
  const std::vector<Feature> features{polygonFeature({flat, twoPoints, good})};
  const ReferenceLayer layer = polygonLayer(features);
  EXPECT_FALSE(covers(layer, {3, 3}));
  EXPECT_FALSE(covers(layer, {6, -4}));
  EXPECT_TRUE(covers(layer, {25, 5}));
}

TEST(PolygonCoverage, FirstVisibleFeature) {
  std::vector<Feature> features{polygonFeature({Polygon{rect(0, 0, 10, 10), {}}}),
                                polygonFeature({Polygon{rect(5, 0, 15, 10), {}}}),
                                polygonFeature({Polygon{rect(0, 0, 20, 10), {}}})};
  ReferenceLayer layer = polygonLayer(features);
  EXPECT_EQ(ov::coveringFeature(layer, {7, 5}), std::optional<std::size_t>(0));
  EXPECT_EQ(ov::coveringFeature(layer, {12, 5}), std::optional<std::size_t>(1));
  EXPECT_EQ(ov::coveringFeature(layer, {17, 5}), std::optional<std::size_t>(2));
  layer.visible = {false, true, false};
  EXPECT_EQ(ov::coveringFeature(layer, {7, 5}), std::optional<std::size_t>(1));
  EXPECT_EQ(ov::coveringFeature(layer, {2, 5}), std::nullopt);
  EXPECT_EQ(ov::coveringFeature(layer, {17, 5}), std::nullopt);
  const ReferenceLayer empty;  // no features at all
  EXPECT_EQ(ov::coveringFeature(empty, {7, 5}), std::nullopt);
}

// ---------------------------------------------------------------------------------------------
// Coverage of lines (width 2: half width 1 unless stated)

const LineString kElbow{{0, 0}, {10, 0}, {10, 10}};  // a left turn of 90° at (10, 0)

TEST(LineCoverage, SegmentsAndRoundJoinsAndCaps) {
  const LineShape round = shapeOf(2.0, LineJoin::Round, LineCap::Round);
  // Rectangles.
  EXPECT_TRUE(lineCovers(kElbow, round, {5, 0.99}));
  EXPECT_TRUE(lineCovers(kElbow, round, {5, -0.99}));
  EXPECT_FALSE(lineCovers(kElbow, round, {5, 1.01}));
  EXPECT_TRUE(lineCovers(kElbow, round, {9.01, 5}));
  EXPECT_FALSE(lineCovers(kElbow, round, {8.99, 5}));
  // Round join: the disc of radius 1 round (10, 0), outside both rectangles.
  EXPECT_TRUE(lineCovers(kElbow, round, {10.7, -0.7}));     // 0.99 from the vertex
  EXPECT_FALSE(lineCovers(kElbow, round, {10.75, -0.75}));  // 1.06
  // Round caps.
  EXPECT_TRUE(lineCovers(kElbow, round, {-0.99, 0}));
  EXPECT_TRUE(lineCovers(kElbow, round, {-0.7, -0.7}));
  EXPECT_FALSE(lineCovers(kElbow, round, {-1.01, 0}));
  EXPECT_FALSE(lineCovers(kElbow, round, {-0.75, 0.75}));
  EXPECT_TRUE(lineCovers(kElbow, round, {10, 10.99}));
  EXPECT_FALSE(lineCovers(kElbow, round, {10.8, 10.8}));
}

TEST(LineCoverage, BevelJoin) {
  // Outer corners (10, −1) and (11, 0): the bevel is the triangle under the line x − y = 11.
  const LineShape bevel = shapeOf(2.0, LineJoin::Bevel, LineCap::Flat);
  EXPECT_TRUE(lineCovers(kElbow, bevel, {10.4, -0.4}));
  EXPECT_TRUE(lineCovers(kElbow, bevel, {10.05, -0.9}));
  EXPECT_FALSE(lineCovers(kElbow, bevel, {10.6, -0.6}));  // inside the round join, beyond the bevel
  EXPECT_FALSE(lineCovers(kElbow, bevel, {10.9, -0.9}));
}

TEST(LineCoverage, MiterJoin) {
  // A right angle: miter length √2 · 1 ≤ 4 · 1: the square corner up to (11, −1).
  const LineShape miter = shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 4.0);
  EXPECT_TRUE(lineCovers(kElbow, miter, {10.9, -0.9}));
  EXPECT_TRUE(lineCovers(kElbow, miter, {10.99, -0.5}));
  EXPECT_FALSE(lineCovers(kElbow, miter, {11.01, -0.5}));
  EXPECT_FALSE(lineCovers(kElbow, miter, {10.5, -1.01}));
  // The limit is on miter length / half width = √2: just above → miter, just below → bevel.
  EXPECT_TRUE(lineCovers(kElbow, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 1.4143), {10.9, -0.9}));
  EXPECT_FALSE(lineCovers(kElbow, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 1.4141), {10.9, -0.9}));
  EXPECT_TRUE(lineCovers(kElbow, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 1.4141), {10.4, -0.4}));
}

TEST(LineCoverage, SharpMiterAndItsLimit) {
  // Interior angle θ = 30° at (10, 0): the outgoing segment heads back at 150° of turn. Miter
  // length = 1 / sin 15° = 3.8637; the tip is at (10 + cot 15°, −1) = (13.7321, −1).
  const LineString line{{0, 0}, {10, 0}, {10 - 10 * std::cos(radians(30)), 10 * std::sin(radians(30))}};
  const dvec2 nearTip(13.6, -0.95);
  const dvec2 beyondTip(13.8, -0.95);
  EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 4.0), nearTip));
  EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 4.0), beyondTip));
  EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 3.8), nearTip));  // → bevel
  EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Bevel, LineCap::Flat), nearTip));
  // The bevel reaches from (10, −1) to (10.5, 0.866).
  // (its edge crosses y = −0.5 at x = 10 + 0.5 · 0.5 / 1.866 = 10.134).
  EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 3.8), {10.1, -0.5}));
  EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 3.8), {10.2, -0.5}));
}

TEST(LineCoverage, SquareAndFlatCaps) {
  const LineString line{{0, 0}, {10, 0}};
  const LineShape square = shapeOf(2.0, LineJoin::Round, LineCap::Square);
  EXPECT_TRUE(lineCovers(line, square, {-0.99, 0.99}));
  EXPECT_TRUE(lineCovers(line, square, {10.99, -0.99}));
  EXPECT_FALSE(lineCovers(line, square, {-1.01, 0}));
  EXPECT_FALSE(lineCovers(line, square, {11.01, 0}));
  EXPECT_FALSE(lineCovers(line, square, {10.5, 1.01}));
  const LineShape flat = shapeOf(2.0, LineJoin::Round, LineCap::Flat);
  EXPECT_TRUE(lineCovers(line, flat, {0.01, 0.99}));
  EXPECT_TRUE(lineCovers(line, flat, {9.99, -0.99}));
  EXPECT_FALSE(lineCovers(line, flat, {-0.01, 0}));
  EXPECT_FALSE(lineCovers(line, flat, {10.01, 0}));
  // A slanted square cap follows the segment's direction.
  const LineString slanted{{0, 0}, {3, 4}};  // direction (0.6, 0.8)
  EXPECT_TRUE(lineCovers(slanted, square, dvec2(3, 4) + dvec2(0.6, 0.8) * 0.99 + dvec2(-0.8, 0.6) * 0.99));
  EXPECT_FALSE(lineCovers(slanted, square, dvec2(3, 4) + dvec2(0.6, 0.8) * 1.01));
}

TEST(LineCoverage, Hairpin) {
  // Out to (10, 0) and straight back to (2, 0): a full reversal.
  const LineString line{{0, 0}, {10, 0}, {2, 0}};
  EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Flat), {10.99, 0}));
  EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Flat), {10.5, 0.8}));
  for (const LineJoin join : {LineJoin::Bevel, LineJoin::Miter}) {
    EXPECT_FALSE(lineCovers(line, shapeOf(2.0, join, LineCap::Flat, 1e9), {10.01, 0}));
    EXPECT_TRUE(lineCovers(line, shapeOf(2.0, join, LineCap::Flat), {9.99, 0.99}));
  }
  // A near reversal: the miter is far beyond any limit, so the bevel is used.
  const LineString nearly{{0, 0}, {10, 0}, {0, 0.1}};
  EXPECT_FALSE(lineCovers(nearly, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 50.0), {10.5, -0.5}));
  // The thin bevel (10, 0), (10, −1), (10.01, 1.0) crosses y = −0.5 at x = 10.0025.
  EXPECT_TRUE(lineCovers(nearly, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 50.0), {10.001, -0.5}));
  EXPECT_FALSE(lineCovers(nearly, shapeOf(2.0, LineJoin::Miter, LineCap::Flat, 50.0), {10.004, -0.5}));
}

TEST(LineCoverage, OnePointLines) {
  const LineString point{{5, 5}};
  const LineString repeated{{5, 5}, {5, 5}, {5, 5}};
  for (const LineString& line : {point, repeated}) {
    EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Round), {5.7, 5.7}));
    EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Round), {5.75, 5.75}));
    EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Square), {5.99, 4.01}));
    EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Square), {6.01, 5}));
    EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Flat), {5, 5}));
  }
}

TEST(LineCoverage, StraightContinuationHasNoJoin) {
  // A vertex 0.2 from the start of a straight line: no round disc there (it would reach −0.8).
  const LineString line{{0, 0}, {0.2, 0}, {10, 0}};
  EXPECT_FALSE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Flat), {-0.5, 0}));
  EXPECT_TRUE(lineCovers(line, shapeOf(2.0, LineJoin::Round, LineCap::Flat), {0.1, 0.99}));
  // Exactly collinear in double coordinates, although the cross product of the normalised
  // directions rounds to 5.6e-17: still no join. The point is 0.9 behind the vertex (1.25, 2.75)
  // along the line, 0.11 behind its start (1, 2).
  const LineString slanted{{1, 2}, {1.25, 2.75}, {5, 14}};
  const dvec2 behind = dvec2(1.25, 2.75) - glm::normalize(dvec2(1, 3)) * 0.9;
  EXPECT_FALSE(lineCovers(slanted, shapeOf(2.0, LineJoin::Round, LineCap::Flat), behind));
  EXPECT_TRUE(lineCovers(slanted, shapeOf(2.0, LineJoin::Round, LineCap::Round), behind));  // the start cap
}

TEST(LineCoverage, PerFeatureShapesVisibilityAndWidth) {
  const std::vector<Feature> features{lineFeature({{{0, 0}, {10, 0}}}), lineFeature({{{0, 10}, {10, 10}}}),
                                      lineFeature({{{0, 20}, {10, 20}}}), lineFeature({{{0, 0}, {10, 20}}})};
  ReferenceLayer layer = lineLayer(
      features, {shapeOf(2.0, LineJoin::Round, LineCap::Round), shapeOf(6.0, LineJoin::Round, LineCap::Flat),
                 shapeOf(0.0, LineJoin::Round, LineCap::Round), shapeOf(2.0, LineJoin::Round, LineCap::Round)});
  EXPECT_TRUE(covers(layer, {5, 0.9}));
  EXPECT_FALSE(covers(layer, {5, 1.5}));
  EXPECT_TRUE(covers(layer, {5, 12.9}));    // width 6
  EXPECT_FALSE(covers(layer, {-0.5, 10}));  // flat cap
  EXPECT_FALSE(covers(layer, {5, 20}));     // width 0 draws nothing
  layer.shapes[2].width = std::nan("");
  EXPECT_FALSE(covers(layer, {5, 20}));
  EXPECT_EQ(ov::coveringFeature(layer, {0.2, 0.2}), std::optional<std::size_t>(0));  // 0 and 3 overlap
  layer.visible = {false, true, true, true};
  EXPECT_EQ(ov::coveringFeature(layer, {0.2, 0.2}), std::optional<std::size_t>(3));
  EXPECT_FALSE(covers(layer, {8, 0}));
}

TEST(LineCoverage, WidthsInPixelsFollowTheCamera) {
  // The pixel scale of a camera: its eye and the size of a pixel at 1 m.
  const dvec3 eye(30.0, -20.0, 100.0);
  const double fov = 0.8;
  const int height = 300;
  const glm::dmat4 viewProj = gis::gfx::reversedInfinitePerspective(fov, 1.5, 0.5) *
                              gis::gfx::lookAt(eye, dvec3(40.0, 0.0, 0.0), dvec3(0.0, 0.0, 1.0));
  const ov::PixelScale scale = ov::pixelScaleOf(viewProj, height);
  EXPECT_NEAR(glm::length(scale.eye - eye), 0.0, 1e-9);
  const double mpp = 2.0 * std::tan(fov / 2.0) / height;
  EXPECT_NEAR(scale.metresPerPixel, mpp, 1e-12);

  // A 4-pixel line from (0, 0) to (100, 0), anchored at heights 0 and 50: half widths
  // 2 · mpp · distance at the ends, linear in between (a trapezoid).
  LineShape shape = shapeOf(1000.0, LineJoin::Round, LineCap::Round);
  shape.widthPixels = 4.0;
  shape.anchorHeights = {{0.0, 50.0}};
  const std::vector<Feature> features{lineFeature({{{0.0, 0.0}, {100.0, 0.0}}})};
  const ReferenceLayer layer = lineLayer(features, {shape});
  const double h0 = 2.0 * mpp * glm::length(dvec3(0.0, 0.0, 0.0) - eye);
  const double h1 = 2.0 * mpp * glm::length(dvec3(100.0, 0.0, 50.0) - eye);
  ASSERT_GT(std::abs(h1 - h0), 0.01);
  for (const double t : {0.0, 0.25, 0.5, 0.9}) {
    const double h = h0 + t * (h1 - h0);
    EXPECT_TRUE(ov::coveringFeature(layer, {100.0 * t, 0.999 * h}, scale)) << t;
    EXPECT_TRUE(ov::coveringFeature(layer, {100.0 * t, -0.999 * h}, scale)) << t;
    EXPECT_FALSE(ov::coveringFeature(layer, {100.0 * t, 1.001 * h}, scale)) << t;
  }
  // Round caps of each end's half width.
  EXPECT_TRUE(ov::coveringFeature(layer, {-0.999 * h0, 0.0}, scale));
  EXPECT_FALSE(ov::coveringFeature(layer, {-1.001 * h0, 0.0}, scale));
  EXPECT_TRUE(ov::coveringFeature(layer, {100.0 + 0.999 * h1, 0.0}, scale));
  EXPECT_FALSE(ov::coveringFeature(layer, {100.0 + 1.001 * h1, 0.0}, scale));
  // Far away the width in metres stops at its largest: 1000 m here, 3 m below.
  shape.width = 3.0;
  const ReferenceLayer capped = lineLayer(features, {shape});
  ov::PixelScale far = scale;
  far.eye = dvec3(0.0, 0.0, 1e7);
  EXPECT_TRUE(ov::coveringFeature(capped, {50.0, 1.49}, far));
  EXPECT_FALSE(ov::coveringFeature(capped, {50.0, 1.51}, far));
  // Without a scale, lines in pixels have no width.
  EXPECT_FALSE(ov::coveringFeature(layer, {50.0, 1e-6}));
}

TEST(LineCoverage, MultiLineFeature) {
  const std::vector<Feature> features{lineFeature({{{0, 0}, {10, 0}}, {{0, 10}, {10, 10}, {10, 20}}})};
  const ReferenceLayer layer = lineLayer(features, {shapeOf(2.0, LineJoin::Miter, LineCap::Flat)});
  EXPECT_TRUE(covers(layer, {5, 0.5}));
  EXPECT_TRUE(covers(layer, {10.9, 9.1}));  // miter of the second line
  EXPECT_FALSE(covers(layer, {5, 5}));
}

// ---------------------------------------------------------------------------------------------
// referenceMask

TEST(ReferenceMask, BitsPerLayerAndNoneOnBackground) {
  // Straight down from 120 m onto a round patch of ground (radius 45 m) with background round
  // it; three layers, one of them covering everything.
  const Camera camera = makeCamera({0, 0, 120}, {0, 0, 0}, radians(60.0), 128, 128);
  const Rendered r = render(camera, planeScene({0, 0, 1}, 0.0, 45.0));
  const std::vector<Feature> squares{polygonFeature({Polygon{rect(-30, -30, 0, 0), {}}}),
                                     polygonFeature({Polygon{rect(10, -30, 30, -10), {rect(15, -25, 25, -15)}}})};
  const std::vector<Feature> roads{lineFeature({{{-40, 20}, {40, 20}}})};
  const std::vector<Feature> everything{polygonFeature({Polygon{rect(-60, -60, 60, 60), {}}})};
  const std::vector<ReferenceLayer> layers{polygonLayer(squares),
                                           lineLayer(roads, {shapeOf(6.0, LineJoin::Round, LineCap::Round)}),
                                           polygonLayer(everything)};
  const std::vector<std::uint32_t> mask = ov::referenceMask(r.image(), layers);
  ASSERT_EQ(mask.size(), r.depth.size());
  const double margin = 2.0;  // metres; a pixel is about 1.1 m here
  std::uint32_t counts[3] = {0, 0, 0};
  int background = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (!r.truth[i]) {
      EXPECT_EQ(mask[i], 0U);
      ++background;
      continue;
    }
    const dvec2 p(*r.truth[i]);
    EXPECT_NE(mask[i] & 4U, 0U);
    // Layer 0: the square [−30, 0]² or the frame [10, 30] × [−30, −10] minus [15, 25] × [−25, −15].
    auto inBox = [&p](double x0, double y0, double x1, double y1, double m) {
      return p.x > x0 + m && p.x < x1 - m && p.y > y0 + m && p.y < y1 - m;
    };
    const bool in0 =
        inBox(-30, -30, 0, 0, margin) || (inBox(10, -30, 30, -10, margin) && !inBox(15, -25, 25, -15, -margin));
    const bool out0 =
        !inBox(-30, -30, 0, 0, -margin) && (!inBox(10, -30, 30, -10, -margin) || inBox(15, -25, 25, -15, margin));
    if (in0 != out0) {  // else within the margin of a boundary
      EXPECT_EQ((mask[i] & 1U) != 0, in0) << p.x << "," << p.y;
    }
    // Layer 1: the capsule of radius 3 round the segment.
    const double d = segmentDistance(p, {-40, 20}, {40, 20});
    if (std::abs(d - 3.0) > margin) {
      EXPECT_EQ((mask[i] & 2U) != 0, d < 3.0) << p.x << "," << p.y;
    }
    for (std::uint32_t b = 0; b < 3; ++b) counts[b] += (mask[i] >> b) & 1U;
  }
  EXPECT_GT(background, 1000);
  EXPECT_GT(counts[0], 500);
  EXPECT_GT(counts[1], 200);
}

/// Random test shapes: star polygons (some scrambled into self-intersecting rings, some with
/// holes, some multi-part) and random walks drawn with random shapes.
struct RandomLayers {
  std::vector<Feature> polygons;
  std::vector<Feature> lines;
  std::vector<LineShape> shapes;
  std::vector<bool> lineVisible;
  std::vector<ReferenceLayer> layers;

  explicit RandomLayers(std::mt19937& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto star = [&](const dvec2& c, double r0, double r1, int n) {
      Ring ring;
      for (int k = 0; k < n; ++k) {
        const double a = 2.0 * kPi * (k + 0.8 * u(rng)) / n;
        ring.push_back(c + (r0 + (r1 - r0) * u(rng)) * dvec2(std::cos(a), std::sin(a)));
      }
      return ring;
    };
    for (int f = 0; f < 12; ++f) {
      Feature feature;
      const int parts = u(rng) < 0.3 ? 2 : 1;
      for (int part = 0; part < parts; ++part) {
        const dvec2 c(-60.0 + 120.0 * u(rng), -60.0 + 120.0 * u(rng));
        Polygon polygon{star(c, 8.0, 30.0, 3 + static_cast<int>(12 * u(rng))), {}};
        if (u(rng) < 0.3) std::shuffle(polygon.outer.begin(), polygon.outer.end(), rng);
        if (u(rng) < 0.4) polygon.holes.push_back(star(c, 2.0, 7.0, 5));
        feature.polygons.push_back(std::move(polygon));
      }
      polygons.push_back(std::move(feature));
    }
    for (int f = 0; f < 25; ++f) {
      LineString line{dvec2(-70.0 + 140.0 * u(rng), -70.0 + 140.0 * u(rng))};
      const int n = static_cast<int>(6 * u(rng));
      double heading = 2.0 * kPi * u(rng);
      for (int k = 0; k < n; ++k) {
        const double choice = u(rng);
        if (choice < 0.1) {
          line.push_back(line.back());  // repeated point
          continue;
        }
        heading += choice < 0.2 ? kPi : (u(rng) - 0.5) * 2.5;  // sometimes a full reversal
        line.push_back(line.back() + (3.0 + 25.0 * u(rng)) * dvec2(std::cos(heading), std::sin(heading)));
      }
      lines.push_back(lineFeature({line}));
      const auto join = static_cast<LineJoin>(static_cast<int>(3 * u(rng)));
      const auto cap = static_cast<LineCap>(static_cast<int>(3 * u(rng)));
      shapes.push_back(shapeOf(1.0 + 11.0 * u(rng), join, cap, 1.0 + 5.0 * u(rng)));
      lineVisible.push_back(u(rng) > 0.15);
    }
    layers.push_back(polygonLayer(polygons, "random polygons"));
    ReferenceLayer l = lineLayer(lines, shapes, "random lines");
    l.visible = lineVisible;
    layers.push_back(std::move(l));
    // The same lines again, all visible, all round: a third bit.
    layers.push_back(
        lineLayer(lines, std::vector<LineShape>(lines.size(), shapeOf(4.0, LineJoin::Round, LineCap::Round))));
  }
};

TEST(ReferenceMask, IndexAgreesWithUnindexedCoverage) {
  std::mt19937 rng(11);
  const RandomLayers random(rng);
  // Every feature alone (through a layer where only it is visible), for pick.
  std::vector<std::vector<ReferenceLayer>> singles(random.layers.size());
  for (std::size_t l = 0; l < random.layers.size(); ++l) {
    const ReferenceLayer& layer = random.layers[l];
    for (std::size_t f = 0; f < layer.features->size(); ++f) {
      ReferenceLayer single = layer;
      single.visible.assign(layer.features->size(), false);
      single.visible[f] = f >= layer.visible.size() || layer.visible[f];
      singles[l].push_back(std::move(single));
    }
  }
  int covered = 0;
  int picks = 0;
  for (int c = 0; c < 4; ++c) {
    const Rendered r = render(randomCamera(rng, 72, 54, c == 0 ? 5.0 : 25.0), planeScene({0, 0, 1}, 0.0));
    const ov::DepthImage image = r.image();
    const std::vector<std::uint32_t> mask = ov::referenceMask(image, random.layers);
    ASSERT_EQ(mask.size(), r.depth.size());
    for (int y = 0; y < image.height; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const std::optional<dvec3> p = ov::unprojectPixel(image, x, y);
        std::uint32_t want = 0;
        for (std::size_t l = 0; p && l < random.layers.size(); ++l)
          if (covers(random.layers[l], dvec2(*p))) want |= 1U << l;
        ASSERT_EQ(mask[r.index(x, y)], want) << "pixel " << x << "," << y << " camera " << c;
        covered += want != 0 ? 1 : 0;
        if ((x + 2 * y) % 5 != 0) continue;
        std::vector<ov::PickedFeature> wantPicked;
        for (std::size_t l = 0; p && l < singles.size(); ++l)
          for (std::size_t f = 0; f < singles[l].size(); ++f)
            if (covers(singles[l][f], dvec2(*p))) wantPicked.push_back({l, f});
        const std::vector<ov::PickedFeature> picked = ov::pick(image, random.layers, x, y);
        ASSERT_EQ(picked.size(), wantPicked.size()) << "pixel " << x << "," << y << " camera " << c;
        for (std::size_t k = 0; k < picked.size(); ++k) {
          EXPECT_EQ(picked[k].layer, wantPicked[k].layer);
          EXPECT_EQ(picked[k].feature, wantPicked[k].feature);
        }
        picks += picked.size() > 1 ? 1 : 0;
      }
    }
  }
  EXPECT_GT(covered, 1000);
  EXPECT_GT(picks, 50);  // overlaps were picked
}

TEST(ReferenceMask, AnImageRelativeToAnOriginIsTheSameImage) {
  // The globe's depth images are eye-relative (DepthImage::origin): the same camera made relative
  // to a far origin (1,000 km away) unprojects every pixel to the same point within 1 µm of the
  // distance, gives the same mask through a frame's own FrameLayers as through ReferenceLayer, and
  // maskEdges marks exactly where the mask or ground changes within a pixel's neighbours.
  const Camera camera = makeCamera({30, -40, 60}, {0, 0, 0}, radians(60.0), 48, 32);
  const Rendered r = render(camera, planeScene({0.1, 0.05, 1}, 2.0));
  const ov::DepthImage plain = r.image();
  ov::DepthImage far = plain;
  far.origin = dvec3(1.0e6, -2.0e6, 300.0);
  glm::dmat4 translate(1.0);
  translate[3] = glm::dvec4(far.origin, 1.0);
  far.viewProj = plain.viewProj * translate;
  std::size_t ground = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const std::optional<dvec3> a = ov::unprojectPixel(plain, x, y), b = ov::unprojectPixel(far, x, y);
      ASSERT_EQ(a.has_value(), b.has_value());
      if (!a) continue;
      ++ground;
      EXPECT_LT(glm::length(*a - *b), 1e-6 * glm::length(*a - dvec3(30, -40, 60)) + 1e-6);
      const std::optional<dvec3> c = ov::unprojectDepth(far, x, y, r.depth[r.index(x, y)]);
      ASSERT_TRUE(c);
      EXPECT_EQ(*c, *b);
    }
  }
  EXPECT_GT(ground, 1000U);
  EXPECT_FALSE(ov::unprojectDepth(far, 0, 0, 0.0F).has_value()) << "background";

  const std::vector<Feature> features{polygonFeature({Polygon{rect(-20, -15, 10, 25), {}}})};
  const std::vector<ReferenceLayer> layers{polygonLayer(features)};
  // A frame's layers of one's own, asked point by point (no index): the reference's per-pixel
  // core calls them with the far image's world points.
  struct ThroughTheLayer final : ov::FrameLayers {
    const ReferenceLayer* layer = nullptr;
    [[nodiscard]] std::uint32_t bits(const dvec3& world) const override {
      return ov::coveringFeature(*layer, glm::dvec2(world)).has_value() ? 1U : 0U;
    }
    [[nodiscard]] bool straddles(const std::array<dvec3, 4>& /*footprint*/,
                                 std::uint32_t /*centreBits*/) const override {
      return true;
    }
  };
  const ov::FrameLayersMaker throughTheLayer = [&layers](const dvec3&, const dvec3&) {
    auto made = std::make_unique<ThroughTheLayer>();
    made->layer = &layers[0];
    return std::unique_ptr<ov::FrameLayers>(std::move(made));
  };
  const std::vector<std::uint32_t> byLayer = ov::referenceMask(plain, layers);
  const std::vector<std::uint32_t> byCoverage = ov::referenceMask(far, throughTheLayer);
  std::size_t differing = 0, covered = 0;
  for (std::size_t i = 0; i < byLayer.size(); ++i) {
    differing += byLayer[i] != byCoverage[i] ? 1U : 0U;
    covered += byLayer[i] != 0 ? 1U : 0U;
  }
  EXPECT_GT(covered, 100U);
  EXPECT_LE(differing, 2U) << "only where a point lies within rounding of the border";

  const std::vector<std::uint8_t> edges = ov::maskEdges(byLayer, plain);
  ASSERT_EQ(edges.size(), byLayer.size());
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      bool changes = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= camera.width || yy >= camera.height) continue;
          changes = changes || byLayer[r.index(xx, yy)] != byLayer[r.index(x, y)] ||
                    (r.depth[r.index(xx, yy)] > 0.0F) != (r.depth[r.index(x, y)] > 0.0F);
        }
      EXPECT_EQ(edges[r.index(x, y)] != 0, changes) << x << ", " << y;
    }
  }
  EXPECT_TRUE(ov::maskEdges(std::vector<std::uint32_t>(3, 0U), plain).empty()) << "a mask of another size";
}

TEST(ReferenceMask, EmptyAndDegenerateInputs) {
  const Camera camera = makeCamera({0, 0, 50}, {0, 0, 0}, radians(60.0), 16, 16);
  const Rendered r = render(camera, planeScene({0, 0, 1}, 0.0));
  const std::vector<std::uint32_t> none = ov::referenceMask(r.image(), std::span<const ReferenceLayer>{});
  EXPECT_EQ(none, std::vector<std::uint32_t>(256, 0U));
  const std::vector<float> background(256, 0.0F);
  const std::vector<Feature> features{polygonFeature({Polygon{rect(-60, -60, 60, 60), {}}})};
  const std::vector<ReferenceLayer> layers{polygonLayer(features)};
  EXPECT_EQ(ov::referenceMask(ov::DepthImage{16, 16, background, camera.viewProj}, layers),
            std::vector<std::uint32_t>(256, 0U));
  EXPECT_EQ(ov::edgePixels(ov::DepthImage{16, 16, background, camera.viewProj}, layers),
            std::vector<std::uint8_t>(256, 0U));
  EXPECT_EQ(ov::referenceMask(r.image(), layers), std::vector<std::uint32_t>(256, 1U));
  EXPECT_EQ(ov::edgePixels(r.image(), layers), std::vector<std::uint8_t>(256, 0U));
  EXPECT_TRUE(ov::referenceMask(ov::DepthImage{}, layers).empty());
}

// ---------------------------------------------------------------------------------------------
// edgePixels

/// The analytic pixel square of (x, y) on the plane: its 8 probe points' distances from the
/// centre point (in x, y, where coverage is decided): the largest, and the distance to the
/// nearest side of the corner quadrilateral. nullopt if a probe ray misses the plane.
struct Footprint {
  double outer = 0.0;
  double inner = 0.0;
};
std::optional<Footprint> pixelFootprint(const Camera& camera, const Scene& scene, int x, int y, const dvec2& centre) {
  const std::array<dvec2, 4> cornersPx{dvec2(0, 0), dvec2(1, 0), dvec2(1, 1), dvec2(0, 1)};
  std::array<dvec2, 4> corners{};
  Footprint f{0.0, std::numeric_limits<double>::infinity()};
  for (int k = 0; k < 8; ++k) {
    const dvec2 offset =
        k < 4 ? cornersPx[static_cast<std::size_t>(k)]
              : (cornersPx[static_cast<std::size_t>(k - 4)] + cornersPx[static_cast<std::size_t>(k - 3) % 4]) / 2.0;
    const dvec3 d = camera.ray(x + offset.x, y + offset.y);
    const std::optional<Hit> hit = scene(camera.eye, d);
    if (!hit) return std::nullopt;
    const dvec2 p(camera.eye + d * hit->t);
    if (k < 4) corners[static_cast<std::size_t>(k)] = p;
    f.outer = std::max(f.outer, glm::length(p - centre));
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const dvec2 a = corners[k];
    const dvec2 b = corners[(k + 1) % 4];
    const dvec2 n = glm::normalize(dvec2(a.y - b.y, b.x - a.x));
    f.inner = std::min(f.inner, std::abs(glm::dot(centre - a, n)));
  }
  return f;
}

TEST(EdgePixels, ExactlyNearShapeBoundaries) {
  // Separate shapes with known boundaries: a square, a square with a square hole, and a capsule
  // (a round-capped segment of half width 20 m). Bits change only across their boundaries.
  const std::vector<Feature> polygons{
      polygonFeature({Polygon{rect(-50, -50, -10, -10), {}}}),
      polygonFeature({Polygon{rect(10, -60, 60, -10), {rect(25, -45, 45, -25)}}}),
  };
  const dvec2 a(-40, 35);
  const dvec2 b(40, 30);
  const std::vector<Feature> roads{lineFeature({{a, b}})};
  const std::vector<ReferenceLayer> layers{polygonLayer(polygons),
                                           lineLayer(roads, {shapeOf(40.0, LineJoin::Round, LineCap::Round)})};
  std::vector<std::array<dvec2, 2>> edges;  // straight boundary pieces
  for (const Feature& f : polygons) {
    for (const Polygon& p : f.polygons) {
      std::vector<Ring> rings{p.outer};
      rings.insert(rings.end(), p.holes.begin(), p.holes.end());
      for (const Ring& ring : rings) {
        for (std::size_t k = 0; k < ring.size(); ++k) {
          edges.push_back({ring[k], ring[(k + 1) % ring.size()]});
        }
      }
    }
  }
  auto boundaryDistance = [&](const dvec2& p) {
    double d = std::abs(segmentDistance(p, a, b) - 20.0);
    for (const auto& e : edges) d = std::min(d, segmentDistance(p, e[0], e[1]));
    return d;
  };
  std::mt19937 rng(5);
  const dvec3 tilted = glm::normalize(dvec3(-0.15, 0.1, 1.0));
  int edgeCount = 0;
  int nearCount = 0;
  int horizon = 0;
  for (int c = 0; c < 4; ++c) {
    SCOPED_TRACE(c);
    const bool flat = c % 2 == 0;
    const dvec3 normal = flat ? dvec3(0, 0, 1) : tilted;
    const Scene scene = planeScene(normal, flat ? 0.0 : 3.0);
    const Rendered r = render(randomCamera(rng, 144, 108, 45.0, normal, flat ? 0.0 : 3.0), scene);
    const std::vector<std::uint8_t> edge = ov::edgePixels(r.image(), layers);
    ASSERT_EQ(edge.size(), r.depth.size());
    for (int y = 0; y < r.camera.height; ++y) {
      for (int x = 0; x < r.camera.width; ++x) {
        const std::size_t i = r.index(x, y);
        if (!r.truth[i]) {  // sky (rare with these cameras): left to the silhouette test
          ++horizon;
          continue;
        }
        const dvec2 centre(*r.truth[i]);
        const std::optional<Footprint> f = pixelFootprint(r.camera, scene, x, y, centre);
        if (!f) {
          // The pixel square reaches above the horizon: its footprint is unbounded.
          EXPECT_EQ(edge[i], 1) << x << "," << y;
          ++horizon;
          continue;
        }
        const double d = boundaryDistance(centre);
        if (edge[i] != 0) {
          // Some probe lies across a boundary from the centre.
          EXPECT_LE(d, f->outer * (1.0 + 1e-6)) << x << "," << y;
          ++edgeCount;
        } else if (d < 0.5 * f->inner) {
          ADD_FAILURE() << "pixel " << x << "," << y << " is " << d << " m from a boundary (pixel inner radius "
                        << f->inner << " m) but not an edge pixel";
        }
        nearCount += d < 0.5 * f->inner ? 1 : 0;
      }
    }
  }
  EXPECT_GT(edgeCount, 500);
  EXPECT_GT(nearCount, 200);
  std::cout << "[ edges   ] " << edgeCount << " edge pixels, " << nearCount << " pixels near a boundary, " << horizon
            << " at the horizon\n";
}

TEST(EdgePixels, SilhouettesAndBackground) {
  // Looking from above the plateau (x > 0) towards the low ground: the plateau's rim hides the
  // wall and the ground just behind it, a jump in depth. No layers: only silhouettes are edges.
  const Scene scene = stepScene(40.0);
  const Camera camera = makeCamera({150, 20, 200}, {-60, 0, 0}, radians(50.0), 120, 90);
  const Rendered r = render(camera, scene);
  const std::vector<ReferenceLayer> layers;
  const std::vector<std::uint8_t> edge = ov::edgePixels(r.image(), layers);
  ASSERT_EQ(edge.size(), r.depth.size());
  auto surfaceAt = [&r](int x, int y) {
    if (x < 0 || y < 0 || x >= r.camera.width || y >= r.camera.height) return -2;
    return r.surface[r.index(x, y)];
  };
  int jumps = 0;
  int plain = 0;
  for (int y = 0; y < r.camera.height; ++y) {
    for (int x = 0; x < r.camera.width; ++x) {
      const int s = surfaceAt(x, y);
      ASSERT_NE(s, 1) << "the wall is hidden from this side";
      bool nextToOther = false;
      bool uniform = true;
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
          const int t = surfaceAt(x + dx, y + dy);
          if (t != -2 && t != s) {
            uniform = false;
            if (std::abs(dx) <= 1 && std::abs(dy) <= 1) nextToOther = true;
          }
        }
      }
      const std::uint8_t e = edge[r.index(x, y)];
      if (nextToOther) {
        EXPECT_EQ(e, 1) << x << "," << y;
        ++jumps;
      }
      if (uniform) {
        EXPECT_EQ(e, 0) << x << "," << y;
        ++plain;
      }
    }
  }
  EXPECT_GT(jumps, 100);
  EXPECT_GT(plain, 5000);

  // A round patch of ground: the pixels on both sides of its outline are edges, the background
  // elsewhere is not.
  const Camera top = makeCamera({0, 0, 100}, {0, 0, 0}, radians(60.0), 64, 64);
  const Rendered patch = render(top, planeScene({0, 0, 1}, 0.0, 30.0));
  const std::vector<std::uint8_t> patchEdges = ov::edgePixels(patch.image(), layers);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      bool mixed = false;
      const bool here = patch.truth[patch.index(x, y)].has_value();
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (x + dx >= 0 && y + dy >= 0 && x + dx < 64 && y + dy < 64)
            mixed = mixed || patch.truth[patch.index(x + dx, y + dy)].has_value() != here;
      EXPECT_EQ(patchEdges[patch.index(x, y)], mixed ? 1 : 0) << x << "," << y;
    }
  }
}

/// Distance from a point to the box [lo, hi] (0 inside).
double boxDistance(const dvec2& p, const dvec2& lo, const dvec2& hi) {
  return glm::length(dvec2(std::max({lo.x - p.x, 0.0, p.x - hi.x}), std::max({lo.y - p.y, 0.0, p.y - hi.y})));
}

/// Distance from the segment ab to the box [lo, hi] (0 when they meet).
double segmentBoxDistance(const dvec2& a, const dvec2& b, const dvec2& lo, const dvec2& hi) {
  // Clip the segment to the box (Liang–Barsky): any part left means they meet.
  double t0 = 0.0;
  double t1 = 1.0;
  const dvec2 d = b - a;
  bool meets = true;
  for (int axis = 0; axis < 2 && meets; ++axis) {
    const double p = d[axis];
    const double q0 = lo[axis] - a[axis];
    const double q1 = hi[axis] - a[axis];
    if (p == 0.0) {
      meets = q0 <= 0.0 && q1 >= 0.0;
    } else {
      const double ta = std::min(q0 / p, q1 / p);
      const double tb = std::max(q0 / p, q1 / p);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      meets = t0 <= t1;
    }
  }
  if (meets) return 0.0;
  double best = std::min(boxDistance(a, lo, hi), boxDistance(b, lo, hi));
  for (const dvec2& c : {lo, hi, dvec2(lo.x, hi.y), dvec2(hi.x, lo.y)}) best = std::min(best, segmentDistance(c, a, b));
  return best;
}

TEST(EdgePixels, FeaturesThinnerThanAPixel) {
  // Straight down: every pixel's footprint is a 1.8 m square. A 0.3 m wide line, a 0.5 m square
  // and a 0.4 m dot mostly fall between a pixel's probe points; the pixels whose footprint they
  // touch must still be edge pixels, and no others.
  const Camera camera = makeCamera({0.3, -0.2, 100}, {0.3, -0.2, 0}, radians(60.0), 64, 64);
  const Scene ground = planeScene({0, 0, 1}, 0.0);
  const Rendered r = render(camera, ground);
  const dvec2 a(-40.3, -20.7);
  const dvec2 b(35.1, 28.9);
  const dvec2 squareLo(10.37, -15.61);
  const dvec2 squareHi = squareLo + dvec2(0.5);
  const dvec2 dot(-12.23, 17.89);
  const std::vector<Feature> line{lineFeature({{a, b}})};
  const std::vector<Feature> square{
      polygonFeature({Polygon{rect(squareLo.x, squareLo.y, squareHi.x, squareHi.y), {}}})};
  const std::vector<Feature> dots{lineFeature({{dot}})};
  const std::vector<ReferenceLayer> layers{lineLayer(line, {shapeOf(0.3, LineJoin::Round, LineCap::Round)}),
                                           polygonLayer(square),
                                           lineLayer(dots, {shapeOf(0.4, LineJoin::Round, LineCap::Round)})};
  const std::vector<std::uint8_t> edge = ov::edgePixels(r.image(), layers);
  const std::vector<std::uint32_t> mask = ov::referenceMask(r.image(), layers);
  int touched = 0;
  int coveredCentres = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      // The footprint: the ground under the pixel's corners (an axis-aligned square here).
      const dvec3 c0 = camera.eye + camera.ray(x, y) * ground(camera.eye, camera.ray(x, y))->t;
      const dvec3 c1 = camera.eye + camera.ray(x + 1, y + 1) * ground(camera.eye, camera.ray(x + 1, y + 1))->t;
      const dvec2 lo(std::min(c0.x, c1.x), std::min(c0.y, c1.y));
      const dvec2 hi(std::max(c0.x, c1.x), std::max(c0.y, c1.y));
      ASSERT_NEAR(hi.x - lo.x, 1.8042, 1e-3);
      const double gaps[3] = {segmentBoxDistance(a, b, lo, hi) - 0.15,
                              std::max({squareLo.x - hi.x, lo.x - squareHi.x, squareLo.y - hi.y, lo.y - squareHi.y}),
                              boxDistance(dot, lo, hi) - 0.2};
      bool touches = false;
      bool ambiguous = false;
      for (const double g : gaps) {
        touches = touches || g <= 0.0;
        ambiguous = ambiguous || std::abs(g) < 1e-6;
      }
      if (ambiguous) continue;
      EXPECT_EQ(edge[r.index(x, y)], touches ? 1 : 0) << x << "," << y;
      touched += touches ? 1 : 0;
      coveredCentres += mask[r.index(x, y)] != 0 ? 1 : 0;
    }
  }
  EXPECT_GT(touched, 60);
  EXPECT_GT(coveredCentres, 3);  // a few centres fall on the thin line
}

// ---------------------------------------------------------------------------------------------
// pick

TEST(Pick, FeaturesInLayerThenFeatureOrder) {
  const Camera camera = makeCamera({0, 0, 100}, {0, 0, 0}, radians(60.0), 65, 65);  // centre pixel on (0, 0)
  const Rendered r = render(camera, planeScene({0, 0, 1}, 0.0));
  const std::vector<Feature> polygons{polygonFeature({Polygon{rect(-10, -10, 10, 10), {}}}),
                                      polygonFeature({Polygon{rect(20, 20, 30, 30), {}}}),
                                      polygonFeature({Polygon{rect(-5, -5, 5, 5), {}}})};
  const std::vector<Feature> roads{lineFeature({{{-20, 0}, {20, 0}}}), lineFeature({{{0, -20}, {0, 20}}}),
                                   lineFeature({{{-20, 5}, {20, 5}}})};
  const LineShape road = shapeOf(4.0, LineJoin::Round, LineCap::Round);
  std::vector<ReferenceLayer> layers{lineLayer(roads, {road, road, road}), polygonLayer(polygons)};
  const std::vector<ov::PickedFeature> picked = ov::pick(r.image(), layers, 32, 32);
  ASSERT_EQ(picked.size(), 4U);
  const std::size_t want[4][2] = {{0, 0}, {0, 1}, {1, 0}, {1, 2}};
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(picked[k].layer, want[k][0]);
    EXPECT_EQ(picked[k].feature, want[k][1]);
  }
  layers[0].visible = {true, false, true};
  EXPECT_EQ(ov::pick(r.image(), layers, 32, 32).size(), 3U);
  EXPECT_TRUE(ov::pick(r.image(), layers, 0, 0).empty());  // (−x, +y) corner: nothing there
  EXPECT_TRUE(ov::pick(r.image(), layers, -1, 0).empty());
}

// ---------------------------------------------------------------------------------------------
// The Olinda sample

TEST(Olinda, ReferenceMaskOfTheRealLayers) {
  const std::string dir = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";
  const gis::Result<gis::geo::RasterInfo> dem = gis::geo::inspectRaster(dir + "olinda_dem_utm25s.tif");
  ASSERT_TRUE(dem.ok());
  const gis::Result<gis::geo::SceneFrame> frame = gis::geo::SceneFrame::forRaster(*dem);
  ASSERT_TRUE(frame.ok());
  const gis::Result<gis::geo::VectorLayer> tracts = gis::geo::readVectorLayer(dir + "olinda1.shp", *frame);
  const gis::Result<gis::geo::VectorLayer> streets =
      gis::geo::readVectorLayer(dir + "olinda_tract_boundaries.geojson", *frame);
  ASSERT_TRUE(tracts.ok());
  ASSERT_TRUE(streets.ok());
  ASSERT_EQ(tracts->features.size(), 470U);
  ASSERT_EQ(streets->features.size(), 1413U);

  std::vector<LineShape> shapes;
  for (const Feature& f : streets->features) {
    LineShape s = shapeOf(7.0, LineJoin::Round, LineCap::Round);
    const auto w = f.attributes.find("width_m");
    if (w != f.attributes.end() && std::holds_alternative<double>(w->second)) s.width = std::get<double>(w->second);
    shapes.push_back(s);
  }
  const std::vector<ReferenceLayer> layers{polygonLayer(tracts->features, "census tracts"),
                                           lineLayer(streets->features, shapes, "streets")};

  // Straight down over the middle of the data, the whole extent in view.
  double lo[2] = {1e300, 1e300};
  double hi[2] = {-1e300, -1e300};
  for (const Feature& f : streets->features) {
    for (const LineString& l : f.lines) {
      for (const dvec2& p : l) {
        lo[0] = std::min(lo[0], p.x);
        lo[1] = std::min(lo[1], p.y);
        hi[0] = std::max(hi[0], p.x);
        hi[1] = std::max(hi[1], p.y);
      }
    }
  }
  const dvec2 centre((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
  const double half = std::max(hi[0] - lo[0], hi[1] - lo[1]) / 2.0;
  const double fov = radians(60.0);
  const double height = half / std::tan(fov / 2.0);
  const Camera camera = makeCamera(dvec3(centre, height), dvec3(centre, 0.0), fov, 256, 256);
  const Rendered r = render(camera, planeScene({0, 0, 1}, 0.0));
  const ov::DepthImage image = r.image();

  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<std::uint32_t> mask = ov::referenceMask(image, layers);
  const auto t1 = std::chrono::steady_clock::now();
  const std::vector<std::uint8_t> edge = ov::edgePixels(image, layers);
  const auto t2 = std::chrono::steady_clock::now();
  const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::cout << "[ olinda  ] referenceMask 256x256 (470 polygons, 1413 lines): " << ms(t1 - t0)
            << " ms; edgePixels: " << ms(t2 - t1) << " ms\n";

  std::size_t bits[2] = {0, 0};
  std::size_t edges = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    bits[0] += mask[i] & 1U;
    bits[1] += (mask[i] >> 1) & 1U;
    edges += edge[i];
  }
  std::cout << "[ olinda  ] pixels covered: tracts " << bits[0] << ", streets " << bits[1] << "; edge pixels " << edges
            << "\n";
  EXPECT_GT(bits[0], mask.size() / 4);
  EXPECT_GT(bits[1], mask.size() / 50);
  EXPECT_LT(edges, mask.size());
  // A sample of pixels against the unindexed coverage.
  for (std::size_t i = 0; i < mask.size(); i += 331) {
    const int x = static_cast<int>(i % 256);
    const int y = static_cast<int>(i / 256);
    const std::optional<dvec3> p = ov::unprojectPixel(image, x, y);
    ASSERT_TRUE(p.has_value());
    const std::uint32_t want = (covers(layers[0], dvec2(*p)) ? 1U : 0U) | (covers(layers[1], dvec2(*p)) ? 2U : 0U);
    EXPECT_EQ(mask[i], want) << x << "," << y;
  }
}

}  // namespace
