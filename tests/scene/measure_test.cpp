// Measure tool: lengths and areas checked against references computed here from textbook formulas
// (not from the code under test): the meridian arc by Simpson's rule, the ellipsoidal graticule cell
// by its closed form, and terrain planes whose surface lengths and areas follow from their slope.
// Each check states its tolerance and why.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "scene/measure.hpp"

namespace gis::test {
namespace {

using scene::Ellipsoid;
using scene::Measurement;
using scene::MeasureOptions;
using scene::TerrainHeight;

constexpr double kPi = std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDeg = kPi / 180.0;

/// WGS 84, written out here so the references do not depend on the code under test.
constexpr double kA = 6378137.0;
constexpr double kF = 1.0 / 298.257223563;

geo::SceneFrame frameOf(const char* crs, const glm::dvec3& origin) {
  Result<geo::SceneFrame> f = geo::SceneFrame::fromCrs(crs, origin);
  EXPECT_TRUE(f.ok()) << crs;
  return std::move(f.value.value());  // throws (a test failure) if the CRS is unknown
}

/// Olinda's frame (UTM 25S, WGS 84), origin near the town.
geo::SceneFrame olinda() { return frameOf("EPSG:32725", glm::dvec3(292000.0, 9116000.0, 0.0)); }
/// UTM 31N (central meridian 3°E), origin just north of the equator.
geo::SceneFrame equator() { return frameOf("EPSG:32631", glm::dvec3(500000.0, 55000.0, 0.0)); }

glm::dvec2 at(const geo::SceneFrame& frame, double lonDeg, double latDeg) {
  const std::optional<glm::dvec3> p = frame.fromLonLat(lonDeg, latDeg, 0.0);
  EXPECT_TRUE(p.has_value());
  return p ? glm::dvec2(*p) : glm::dvec2(0.0);
}

Measurement measured(const geo::SceneFrame& frame, const std::vector<glm::dvec2>& points, bool closed,
                     const TerrainHeight& height, MeasureOptions options = {}) {
  Result<Measurement> r = scene::measure(frame, points, closed, height, options);
  EXPECT_TRUE(r.ok());
  return r.ok() ? *r.value : Measurement{};
}

double relative(double actual, double expected) { return std::abs(actual - expected) / std::abs(expected); }

/// Meridian arc from latitude 0 to `latDeg` on WGS 84: ∫ a(1−e²)/(1−e² sin²φ)^(3/2) dφ by Simpson's
/// rule (1000 intervals: error far below a micrometre over a degree).
double meridianArc(double latDeg) {
  const double e2 = kF * (2.0 - kF);
  const auto radius = [&](double phi) {
    const double s = std::sin(phi);
    return kA * (1.0 - e2) / std::pow(1.0 - e2 * s * s, 1.5);
  };
  const int n = 1000;
  const double h = latDeg * kDeg / n;
  double sum = radius(0.0) + radius(latDeg * kDeg);
  for (int i = 1; i < n; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * radius(i * h);
  return sum * h / 3.0;
}

/// Area on WGS 84 between two parallels and two meridians `dLonDeg` apart (the closed form of the
/// authalic integral, Snyder, Map Projections — A Working Manual, eq. 3-12).
double graticuleArea(double lat0Deg, double lat1Deg, double dLonDeg) {
  const double e2 = kF * (2.0 - kF);
  const double e = std::sqrt(e2);
  const double b = kA * (1.0 - kF);
  const auto q = [&](double latDeg) {
    const double s = std::sin(latDeg * kDeg);
    return s / (1.0 - e2 * s * s) + std::log((1.0 + e * s) / (1.0 - e * s)) / (2.0 * e);
  };
  return 0.5 * b * b * dLonDeg * kDeg * (q(lat1Deg) - q(lat0Deg));
}

/// A plane rising at `slopeRad` towards direction `dipAzimuth` (radians from +x, anticlockwise).
TerrainHeight plane(double slopeRad, double dipAzimuth, double h0 = 0.0) {
  const glm::dvec2 dir(std::cos(dipAzimuth), std::sin(dipAzimuth));
  const double grade = std::tan(slopeRad);
  return [=](const glm::dvec2& p) { return h0 + grade * glm::dot(p, dir); };
}

TEST(Measure, FlatGroundSurfaceEqualsGeodesic) {
  const geo::SceneFrame frame = olinda();
  const std::vector<glm::dvec2> points{{-1500.0, -700.0}, {400.0, 900.0}, {2100.0, -300.0}, {-200.0, -2200.0}};
  const auto flat = [](const glm::dvec2&) { return 12.0; };
  for (const bool closed : {false, true}) {
    const Measurement m = measured(frame, points, closed, flat);
    ASSERT_EQ(m.segments.size(), closed ? 4U : 3U);
    for (const scene::SegmentMeasure& s : m.segments) {
      // Flat steps are the geodesic length split into equal parts: equal up to rounding.
      EXPECT_LT(relative(s.surfaceMetres, s.geodesicMetres), 1e-12);
      // UTM grid vs ellipsoid: scale factor 0.9996..1.001 this close to the zone's centre.
      EXPECT_LT(relative(s.planarMetres, s.geodesicMetres), 2e-3);
      EXPECT_TRUE(s.surfaceComplete);
    }
    EXPECT_LT(relative(m.surfaceMetres, m.geodesicMetres), 1e-12);
    EXPECT_TRUE(m.surfaceComplete);
    EXPECT_GT(m.samples, 0U);
    EXPECT_EQ(m.sampleStepMetres, MeasureOptions{}.sampleStepMetres);
    EXPECT_EQ(m.planarAreaM2.has_value(), closed);
    if (closed) {
      EXPECT_LT(relative(*m.surfaceAreaM2, *m.geodesicAreaM2), 1e-12);
      EXPECT_LT(relative(*m.planarAreaM2, *m.geodesicAreaM2), 4e-3);
    }
  }
}

TEST(Measure, TiltedPlaneScalesBySecantOfSlope) {
  const geo::SceneFrame frame = olinda();
  std::mt19937 rng(25);
  std::uniform_real_distribution<double> coord(-4000.0, 4000.0);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  std::uniform_real_distribution<double> slope(0.0, 60.0 * kDeg);
  std::uniform_real_distribution<double> radius(300.0, 3000.0);
  MeasureOptions options;
  options.sampleStepMetres = 25.0;
  for (int trial = 0; trial < 20; ++trial) {
    const double theta = slope(rng);
    const double dip = angle(rng);
    const glm::dvec2 dir(std::cos(dip), std::sin(dip));
    const TerrainHeight h = plane(theta, dip, 30.0);

    // Along the dip, along the strike, and a random line.
    const glm::dvec2 start(coord(rng), coord(rng));
    const glm::dvec2 strike(-dir.y, dir.x);
    const std::vector<glm::dvec2> line{start, start + 2500.0 * dir, start + 2500.0 * dir + 1800.0 * strike,
                                       glm::dvec2(coord(rng), coord(rng))};
    const Measurement m = measured(frame, line, false, h, options);
    ASSERT_EQ(m.segments.size(), 3U);
    for (std::size_t i = 0; i < 3; ++i) {
      // A straight line on a plane rises uniformly: each equal step adds the same Δh, so the
      // sampled length is exactly hypot(geodesic, total rise) up to rounding.
      const double rise = h(line[i + 1]) - h(line[i]);
      const double expected = std::hypot(m.segments[i].geodesicMetres, rise);
      EXPECT_LT(relative(m.segments[i].surfaceMetres, expected), 1e-9) << "trial " << trial << " segment " << i;
    }
    // Along the dip: horizontal / cos(slope), up to the UTM scale factor that separates the grid
    // distance (which sets the rise) from the geodesic one (≤ 1e-3 here).
    EXPECT_LT(relative(m.segments[0].surfaceMetres, m.segments[0].geodesicMetres / std::cos(theta)), 1e-3);
    // Along the strike the height does not change.
    EXPECT_LT(relative(m.segments[1].surfaceMetres, m.segments[1].geodesicMetres), 1e-12);

    // A random star-shaped (so simple) ring: every cell has the plane's slope factor 1/cos θ.
    std::vector<glm::dvec2> ring;
    const glm::dvec2 centre(coord(rng), coord(rng));
    const int corners = 3 + trial % 6;
    for (int k = 0; k < corners; ++k) {
      const double a = 2.0 * kPi * (k + 0.5 * std::uniform_real_distribution<double>(0.0, 1.0)(rng)) / corners;
      ring.push_back(centre + radius(rng) * glm::dvec2(std::cos(a), std::sin(a)));
    }
    const Measurement area = measured(frame, ring, true, h, options);
    ASSERT_TRUE(area.surfaceAreaM2.has_value());
    EXPECT_LT(relative(*area.surfaceAreaM2, *area.geodesicAreaM2 / std::cos(theta)), 1e-9) << "trial " << trial;
    EXPECT_TRUE(area.surfaceComplete);
  }
}

TEST(Measure, MixedSlopesAreWeightedByTheirAreaInsideTheRing) {
  // Ground folded along x = 0: flat to the west, rising at 50° to the east. The surface area is the
  // geodesic area times the area-weighted mean slope factor of the two parts, whose planar areas
  // follow from where the fold cuts each ring.
  const geo::SceneFrame frame = olinda();
  const double theta = 50.0 * kDeg;
  const auto fold = [&](const glm::dvec2& p) { return std::max(0.0, p.x) * std::tan(theta); };
  const std::vector<glm::dvec2> diamond{{2000.0, 0.0}, {0.0, 2000.0}, {-2000.0, 0.0}, {0.0, -2000.0}};
  // Cut where its long edge crosses x = 0 at y = 1250: the eastern part is a trapezoid 1000 m wide
  // with sides 2250 m and 3000 m.
  const std::vector<glm::dvec2> triangle{{-3000.0, -1000.0}, {1000.0, -1000.0}, {1000.0, 2000.0}};
  struct Case {
    const std::vector<glm::dvec2>& ring;
    double westArea;  // planar, m²
    double eastArea;
    double step;
    double tolerance;
  };
  const std::vector<Case> cases{
      // A coarse step with the fold on a grid line: many cells are cut by the ring's edges, so this
      // checks that they count by their inside part (weighting them as whole cells is off by 4e-3
      // for the triangle). Tolerance 1e-4: the UTM scale varies by ~1e-5 across the rings.
      {diamond, 4.0e6, 4.0e6, 100.0, 1e-4},
      {triangle, 6.0e6 - 2.625e6, 2.625e6, 100.0, 1e-4},
      // A fine step with the fold inside a column of cells (0.4% of the area), whose slope factor
      // lies between the two: tolerance 1e-3.
      {triangle, 6.0e6 - 2.625e6, 2.625e6, 7.0, 1e-3},
  };
  for (const Case& c : cases) {
    MeasureOptions options;
    options.sampleStepMetres = c.step;
    const Measurement m = measured(frame, c.ring, true, fold, options);
    ASSERT_TRUE(m.surfaceAreaM2.has_value());
    const double total = c.westArea + c.eastArea;
    const double meanFactor = (c.westArea + c.eastArea / std::cos(theta)) / total;
    EXPECT_LT(relative(*m.surfaceAreaM2, *m.geodesicAreaM2 * meanFactor), c.tolerance) << "step " << c.step;
    EXPECT_LT(relative(*m.planarAreaM2, total), 1e-12);  // the shoelace is exact in the frame
  }
}

TEST(Measure, MeridianDegreeAtTheEquator) {
  // From 0° to 1° N along 3° E (UTM 31N's central meridian). Reference: Simpson on the meridian
  // radius of curvature, 110,574.389 m; tolerance 1 mm (GeographicLib's inverse is good to nm,
  // the frame's round trip through PROJ to well below a millimetre).
  const geo::SceneFrame frame = equator();
  const std::vector<glm::dvec2> line{at(frame, 3.0, 0.0), at(frame, 3.0, 1.0)};
  const Measurement m = measured(frame, line, false, {});
  EXPECT_NEAR(m.geodesicMetres, meridianArc(1.0), 1e-3);
  EXPECT_NEAR(m.geodesicMetres, 110574.389, 1e-3);
  EXPECT_FALSE(m.geodesicAreaM2.has_value());
  EXPECT_FALSE(m.planarAreaM2.has_value());
  EXPECT_FALSE(m.surfaceAreaM2.has_value());
  // On the central meridian UTM's scale factor is 0.9996: the grid distance is that much shorter.
  EXPECT_NEAR(m.planarMetres / m.geodesicMetres, 0.9996, 1e-6);
}

TEST(Measure, DegreeCellAreaAtTheEquator) {
  // 2.5°–3.5° E × 0°–1° N. The meridian edges are geodesics; the parallel at 1° N is not (a single
  // geodesic there bows ~4 m poleward, +0.3 km²), so both parallels are clicked every 0.01°, which
  // brings the difference to ~30 m². Reference: the closed-form graticule area, 12,308.46 km²;
  // tolerance 1e-6 relative (1.2 ha).
  const geo::SceneFrame frame = equator();
  std::vector<glm::dvec2> ring;
  for (int i = 0; i <= 100; ++i) ring.push_back(at(frame, 2.5 + 0.01 * i, 0.0));
  for (int i = 0; i <= 100; ++i) ring.push_back(at(frame, 3.5 - 0.01 * i, 1.0));
  const auto flat = [](const glm::dvec2&) { return 0.0; };
  const Measurement m = measured(frame, ring, true, flat);
  ASSERT_TRUE(m.geodesicAreaM2.has_value());
  const double expected = graticuleArea(0.0, 1.0, 1.0);
  EXPECT_NEAR(expected / 1e6, 12308.46, 0.01);
  EXPECT_LT(relative(*m.geodesicAreaM2, expected), 1e-6);
  // Perimeter: two meridian degrees, the equator's degree a·Δλ and the 1° parallel's N·cos φ·Δλ
  // (its 0.01° geodesic chords are shorter by micrometres). Tolerance 1 mm.
  const double e2 = kF * (2.0 - kF);
  const double n1 = kA / std::sqrt(1.0 - e2 * std::sin(kDeg) * std::sin(kDeg));
  EXPECT_NEAR(m.geodesicMetres, 2.0 * meridianArc(1.0) + kA * kDeg + n1 * std::cos(kDeg) * kDeg, 1e-3);
  // Grid area: the UTM scale factor squared is 0.9992 on the central meridian, 0.99923 at ±0.5°.
  EXPECT_NEAR(*m.planarAreaM2 / *m.geodesicAreaM2, 0.9992, 1e-4);
  // 111 km across at a 5 m step would be 5e8 samples: the step coarsens to fit the budget.
  EXPECT_GT(m.sampleStepMetres, MeasureOptions{}.sampleStepMetres);
  EXPECT_LE(m.samples, MeasureOptions{}.maxSamples);
  EXPECT_GT(m.samples, MeasureOptions{}.maxSamples / 4);
  EXPECT_LT(relative(*m.surfaceAreaM2, *m.geodesicAreaM2), 1e-12);
}

TEST(Measure, SampleBudgetCoarsensTheStep) {
  const geo::SceneFrame frame = olinda();
  const std::vector<glm::dvec2> line{{-3000.0, 0.0}, {3000.0, 0.0}, {3000.0, 4000.0}};
  MeasureOptions options;
  options.sampleStepMetres = 1.0;
  options.maxSamples = 500;
  const Measurement m = measured(frame, line, false, plane(0.3, 0.0), options);
  EXPECT_LE(m.samples, 500U);
  EXPECT_GE(m.sampleStepMetres, 10000.0 / 500.0);
  // A plane still gives the exact answer at any step.
  EXPECT_LT(relative(m.segments[0].surfaceMetres, std::hypot(m.segments[0].geodesicMetres, 6000.0 * std::tan(0.3))),
            1e-9);
}

TEST(Measure, MissingHeightsMakeTheSurfaceIncomplete) {
  const geo::SceneFrame frame = olinda();
  // No terrain east of x = 0; flat elsewhere, so the gaps counted as flat give the geodesic values.
  const auto westOnly = [](const glm::dvec2& p) { return p.x > 0.0 ? kNaN : 5.0; };
  const std::vector<glm::dvec2> line{{-2000.0, 0.0}, {-1000.0, 100.0}, {1000.0, 300.0}};
  const Measurement m = measured(frame, line, false, westOnly);
  ASSERT_EQ(m.segments.size(), 2U);
  EXPECT_TRUE(m.segments[0].surfaceComplete);
  EXPECT_FALSE(m.segments[1].surfaceComplete);
  EXPECT_FALSE(m.surfaceComplete);
  EXPECT_LT(relative(m.surfaceMetres, m.geodesicMetres), 1e-12);

  const std::vector<glm::dvec2> ring{{-1000.0, -1000.0}, {1000.0, -1000.0}, {1000.0, 1000.0}, {-1000.0, 1000.0}};
  const Measurement area = measured(frame, ring, true, westOnly);
  EXPECT_FALSE(area.surfaceComplete);
  ASSERT_TRUE(area.surfaceAreaM2.has_value());
  EXPECT_LT(relative(*area.surfaceAreaM2, *area.geodesicAreaM2), 1e-12);

  // Infinite heights count as missing too.
  const auto infinite = [](const glm::dvec2&) { return kInf; };
  const Measurement inf = measured(frame, ring, true, infinite);
  EXPECT_FALSE(inf.surfaceComplete);
  EXPECT_TRUE(std::isfinite(inf.surfaceMetres));
  EXPECT_TRUE(std::isfinite(*inf.surfaceAreaM2));

  // No height function at all: no samples, surface = geodesic, flagged.
  const Measurement none = measured(frame, ring, true, {});
  EXPECT_FALSE(none.surfaceComplete);
  EXPECT_EQ(none.samples, 0U);
  EXPECT_EQ(none.surfaceMetres, none.geodesicMetres);
  EXPECT_EQ(*none.surfaceAreaM2, *none.geodesicAreaM2);
}

TEST(Measure, DegenerateInputsGiveZeros) {
  const geo::SceneFrame frame = olinda();
  const TerrainHeight h = plane(0.5, 1.0);
  const glm::dvec2 p(120.0, -340.0);
  const std::vector<std::vector<glm::dvec2>> cases{{}, {p}, {p, p}, {p, p, p}, {p, p, p, p}};
  for (const auto& points : cases) {
    for (const bool closed : {false, true}) {
      const Measurement m = measured(frame, points, closed, h);
      EXPECT_EQ(m.planarMetres, 0.0);
      EXPECT_EQ(m.geodesicMetres, 0.0);
      EXPECT_EQ(m.surfaceMetres, 0.0);
      EXPECT_EQ(m.geodesicAreaM2.has_value(), closed);
      if (closed) {
        EXPECT_EQ(*m.planarAreaM2, 0.0);
        EXPECT_EQ(*m.geodesicAreaM2, 0.0);
        EXPECT_EQ(*m.surfaceAreaM2, 0.0);
      }
      for (const scene::SegmentMeasure& s : m.segments) EXPECT_EQ(s.surfaceMetres, 0.0);
    }
  }
  // A repeated click inside a line adds a zero segment and changes nothing else.
  const std::vector<glm::dvec2> once{{0.0, 0.0}, {500.0, 200.0}, {900.0, -100.0}};
  const std::vector<glm::dvec2> twice{{0.0, 0.0}, {500.0, 200.0}, {500.0, 200.0}, {900.0, -100.0}};
  const Measurement a = measured(frame, once, true, h);
  const Measurement b = measured(frame, twice, true, h);
  ASSERT_EQ(b.segments.size(), 4U);
  EXPECT_EQ(b.segments[1].geodesicMetres, 0.0);
  EXPECT_NEAR(a.geodesicMetres, b.geodesicMetres, 1e-9);
  EXPECT_NEAR(a.surfaceMetres, b.surfaceMetres, 1e-9);
  EXPECT_NEAR(*a.geodesicAreaM2, *b.geodesicAreaM2, 1e-6);
  EXPECT_NEAR(*a.surfaceAreaM2, *b.surfaceAreaM2, 1e-6);
}

TEST(Measure, NonFiniteInputsAreRejected) {
  const geo::SceneFrame frame = olinda();
  const TerrainHeight h = plane(0.2, 0.0);
  std::size_t calls = 0;
  const TerrainHeight counted = [&](const glm::dvec2& p) {
    ++calls;
    return h(p);
  };
  for (const glm::dvec2 bad : {glm::dvec2(kNaN, 0.0), glm::dvec2(0.0, kInf), glm::dvec2(-kInf, kNaN)}) {
    const std::vector<glm::dvec2> points{{0.0, 0.0}, {100.0, 0.0}, bad, {0.0, 100.0}};
    const Result<Measurement> r = scene::measure(frame, points, true, counted);
    EXPECT_FALSE(r.ok());
    ASSERT_TRUE(r.diagnostics.hasErrors());
    EXPECT_EQ(r.diagnostics.items().front().feature, "point 2");
  }
  EXPECT_EQ(calls, 0U);  // rejected before any sampling

  const std::vector<glm::dvec2> line{{0.0, 0.0}, {100.0, 0.0}};
  for (const double step : {0.0, -1.0, kNaN, kInf}) {
    MeasureOptions options;
    options.sampleStepMetres = step;
    EXPECT_FALSE(scene::measure(frame, line, false, h, options).ok()) << step;
  }
  MeasureOptions badEllipsoid;
  badEllipsoid.ellipsoid = Ellipsoid{-1.0, 0.0};
  EXPECT_FALSE(scene::measure(frame, line, false, h, badEllipsoid).ok());
}

TEST(Measure, EllipsoidFollowsTheFrameDatum) {
  // SIRGAS 2000 / UTM 25S is on GRS 80, WGS 84 / UTM 25S on WGS 84: same a, flattenings differ
  // in the tenth significant digit.
  const glm::dvec3 origin(292000.0, 9116000.0, 0.0);
  const Ellipsoid grs80 = scene::ellipsoidOf(frameOf("EPSG:31985", origin));
  const Ellipsoid wgs84 = scene::ellipsoidOf(frameOf("EPSG:32725", origin));
  EXPECT_EQ(grs80.semiMajorMetres, 6378137.0);
  EXPECT_NEAR(1.0 / grs80.flattening, 298.257222101, 1e-8);
  EXPECT_EQ(wgs84.semiMajorMetres, kA);
  EXPECT_NEAR(1.0 / wgs84.flattening, 298.257223563, 1e-8);

  // The difference is negligible: a 10 km line changes by less than a micrometre.
  const geo::SceneFrame frame = olinda();
  const std::vector<glm::dvec2> line{{-5000.0, -3000.0}, {3000.0, 3000.0}};
  MeasureOptions options;
  options.ellipsoid = grs80;
  const Measurement onGrs80 = measured(frame, line, false, {}, options);
  options.ellipsoid = wgs84;
  const Measurement onWgs84 = measured(frame, line, false, {}, options);
  EXPECT_NEAR(onGrs80.geodesicMetres, onWgs84.geodesicMetres, 1e-6);
  EXPECT_EQ(onGrs80.ellipsoid.flattening, grs80.flattening);
}

// --- On the globe: points in lon/lat, segments geodesics, no CRS. ---

Measurement onGlobe(const std::vector<glm::dvec2>& lonLat, bool closed, const scene::GeodeticHeight& height,
                    MeasureOptions options = {}) {
  Result<Measurement> r = scene::measureOnGlobe(lonLat, closed, height, options);
  EXPECT_TRUE(r.ok());
  return r.ok() ? *r.value : Measurement{};
}

TEST(MeasureOnGlobe, AcrossTheAntimeridianTheShortWay) {
  // 179.5° E to 179.5° W on the equator: one degree of the equator, a·π/180 = 111,319.491 m, not
  // the 359° the other way. Tolerance 1 mm. The chord is 2a·sin(0.5°).
  const Measurement m = onGlobe({{179.5, 0.0}, {-179.5, 0.0}}, false, {});
  EXPECT_NEAR(m.geodesicMetres, kA * kDeg, 1e-3);
  EXPECT_NEAR(m.planarMetres, 2.0 * kA * std::sin(0.5 * kDeg), 1e-3);
  EXPECT_FALSE(m.surfaceComplete) << "no heights";
  // Along a meridian, over 10°: Simpson on the meridian radius of curvature.
  const Measurement meridian = onGlobe({{-180.0, 0.0}, {-180.0, 10.0}}, false, {});
  EXPECT_NEAR(meridian.geodesicMetres, meridianArc(10.0), 1e-3);
  // What the tool draws: the short way too, in 1 km pieces (112 of them), every point within
  // 0.5° of the antimeridian and on the equator.
  const std::vector<glm::dvec2> path =
      scene::geodesicPath(std::vector<glm::dvec2>{{179.5, 0.0}, {-179.5, 0.0}}, false, 1000.0);
  ASSERT_EQ(path.size(), 113u);
  for (const glm::dvec2& p : path) {
    EXPECT_GE(std::abs(p.x), 179.5 - 1e-9);
    EXPECT_NEAR(p.y, 0.0, 1e-9);
  }
  EXPECT_EQ(path.back(), glm::dvec2(-179.5, 0.0));
}

TEST(MeasureOnGlobe, ARingRoundThePoleEnclosesThePole) {
  // 3,600 points along 80° N (0.1° apart; each geodesic chord bows ~0.4 m poleward, ~2 km² over
  // the ring, 5e-7 of it): the polar cap above 80° N (closed form, 3.9 M km²), tolerance 1e-5
  // relative; the cap, not the rest of the earth.
  std::vector<glm::dvec2> ring;
  for (int i = 0; i < 3600; ++i) ring.emplace_back(-180.0 + 0.1 * i, 80.0);
  const auto flat = [](double, double) { return 25.0; };
  const Measurement m = onGlobe(ring, true, flat);
  ASSERT_TRUE(m.geodesicAreaM2.has_value());
  const double cap = graticuleArea(80.0, 90.0, 360.0);
  EXPECT_NEAR(2.0 * graticuleArea(0.0, 90.0, 360.0) / 1e6, 510065621.7, 0.2) << "the earth's area";
  EXPECT_LT(relative(*m.geodesicAreaM2, cap), 1e-5) << *m.geodesicAreaM2 << " vs " << cap;
  // The parallel's length, N(80°)·cos 80°·2π, within the chords' shortening (1e-6).
  const double e2 = kF * (2.0 - kF);
  const double s80 = std::sin(80.0 * kDeg);
  const double parallel = kA / std::sqrt(1.0 - e2 * s80 * s80) * std::cos(80.0 * kDeg) * 2.0 * kPi;
  EXPECT_LT(relative(m.geodesicMetres, parallel), 1e-6);
  // Constant height: the surface is the geodesic, length and area exactly.
  EXPECT_TRUE(m.surfaceComplete);
  EXPECT_DOUBLE_EQ(m.surfaceMetres, m.geodesicMetres);
  ASSERT_TRUE(m.surfaceAreaM2.has_value());
  EXPECT_LT(relative(*m.surfaceAreaM2, *m.geodesicAreaM2), 1e-12);
  // The same ring the other way round: the same area.
  std::reverse(ring.begin(), ring.end());
  const Measurement reversed = onGlobe(ring, true, flat);
  EXPECT_LT(relative(*reversed.geodesicAreaM2, cap), 1e-5);
}

TEST(MeasureOnGlobe, ASlopeNorthwardsScalesTheSurface) {
  // Terrain rising northwards at a grade g per metre of meridian arc, on 0.1° about (10° E, 0°):
  // the meridian's surface length is sqrt(1 + g²) times its geodesic, a parallel's is its
  // geodesic (no rise east-west), and the ring's surface area is sqrt(1 + g²) times its area.
  // The grade is per metre of arc exactly only along the meridian; across the ring it varies by the
  // meridian radius's change over 0.1° (1e-7) and the azimuthal map's scale (1e-6): tolerance 1e-5.
  const double grade = 0.3;
  const auto slope = [grade](double, double lat) { return 100.0 + grade * meridianArc(lat); };
  MeasureOptions options;
  options.sampleStepMetres = 50.0;
  const Measurement north = onGlobe({{10.0, 0.0}, {10.0, 0.1}}, false, slope, options);
  EXPECT_LT(relative(north.surfaceMetres, north.geodesicMetres * std::sqrt(1.0 + grade * grade)), 1e-7);
  EXPECT_GT(north.samples, 200u) << "sampled every 50 m along 11 km";
  const Measurement east = onGlobe({{9.95, 0.05}, {10.05, 0.05}}, false, slope, options);
  EXPECT_LT(relative(east.surfaceMetres, east.geodesicMetres), 1e-7);
  const Measurement ring = onGlobe({{9.95, 0.0}, {10.05, 0.0}, {10.05, 0.1}, {9.95, 0.1}}, true, slope, options);
  ASSERT_TRUE(ring.surfaceAreaM2.has_value());
  EXPECT_LT(relative(*ring.surfaceAreaM2, *ring.geodesicAreaM2 * std::sqrt(1.0 + grade * grade)), 1e-5);
  // The plane: the azimuthal equidistant map about the centre keeps areas to 1e-6 at 6 km.
  EXPECT_LT(relative(*ring.planarAreaM2, *ring.geodesicAreaM2), 1e-5);
}

TEST(MeasureOnGlobe, BadPointsAreNamed) {
  Result<Measurement> r = scene::measureOnGlobe(std::vector<glm::dvec2>{{0.0, 0.0}, {10.0, 95.0}}, false, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.diagnostics.items().front().feature, "point 1");
  r = scene::measureOnGlobe(std::vector<glm::dvec2>{{kNaN, 0.0}, {10.0, 5.0}}, false, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.diagnostics.items().front().feature, "point 0");
  MeasureOptions zero;
  zero.sampleStepMetres = 0.0;
  EXPECT_FALSE(scene::measureOnGlobe(std::vector<glm::dvec2>{{0.0, 0.0}, {1.0, 0.0}}, false, {}, zero).ok());
}

}  // namespace
}  // namespace gis::test
