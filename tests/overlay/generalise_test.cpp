// Generalisation (vector_overlay/generalise.hpp): Douglas–Peucker on lines and rings with its
// error bound, the shapes' extra slack, whole features, and the runs of a line that can reach a
// tile. Each property is checked on many random inputs (fixed seeds) and on hand-made edge
// cases; the runs are checked against the CPU reference's coverage rules (cpu_reference.hpp),
// which are independent of generalise.cpp.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/vec2.hpp>

#include "geo/feature.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/generalise.hpp"
#include "vector_overlay/style.hpp"

namespace gis::test {
namespace {

using geo::Feature;
using geo::LineString;
using geo::Polygon;
using geo::Ring;
using glm::dvec2;
using overlay::LayerKind;
using overlay::LineCap;
using overlay::LineJoin;
using overlay::LineShape;
using overlay::ReferenceLayer;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// Relative slack on epsilon for the error bounds (the distances are computed in double).
constexpr double kSlack = 1e-9;

// ---------------------------------------------------------------------------------------------
// Geometry helpers, written here independently of generalise.cpp

double cross(const dvec2& a, const dvec2& b) { return a.x * b.y - a.y * b.x; }
double dot(const dvec2& a, const dvec2& b) { return a.x * b.x + a.y * b.y; }

double distanceToSegment(const dvec2& p, const dvec2& a, const dvec2& b) {
  const dvec2 d = b - a;
  const double l2 = dot(d, d);
  const double t = l2 > 0.0 ? std::clamp(dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
  const dvec2 q = a + t * d;
  return std::hypot(p.x - q.x, p.y - q.y);
}

/// Distance from p to an open polyline (to its only point when it has one).
double distanceToPolyline(const dvec2& p, const std::vector<dvec2>& line) {
  if (line.size() == 1) return std::hypot(p.x - line[0].x, p.y - line[0].y);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k + 1 < line.size(); ++k) best = std::min(best, distanceToSegment(p, line[k], line[k + 1]));
  return best;
}

/// Distance from p to the boundary of a closed ring (the edge back to the first point included).
double distanceToRing(const dvec2& p, const Ring& ring) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < ring.size(); ++k) {
    best = std::min(best, distanceToSegment(p, ring[k], ring[(k + 1) % ring.size()]));
  }
  return best;
}

/// Even-odd rule: crossings of the ray from p towards +x.
bool insideEvenOdd(const dvec2& p, const Ring& ring) {
  bool inside = false;
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const dvec2& a = ring[k];
    const dvec2& b = ring[(k + 1) % ring.size()];
    if ((a.y > p.y) != (b.y > p.y)) {
      const double x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (x > p.x) inside = !inside;
    }
  }
  return inside;
}

double twiceArea(const Ring& ring) {
  double a = 0.0;
  for (std::size_t k = 0; k < ring.size(); ++k) a += cross(ring[k], ring[(k + 1) % ring.size()]);
  return a;
}

bool samePoint(const dvec2& a, const dvec2& b) {
  const auto same = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
  return same(a.x, b.x) && same(a.y, b.y);
}

/// The indices in `in` of the points of `out` when `out` is a subsequence of `in` (greedy match,
/// exact for inputs without repeated points), or nullopt.
std::optional<std::vector<std::size_t>> subsequenceIndices(const std::vector<dvec2>& out,
                                                           const std::vector<dvec2>& in) {
  std::vector<std::size_t> indices;
  std::size_t k = 0;
  for (const dvec2& p : out) {
    while (k < in.size() && !samePoint(in[k], p)) ++k;
    if (k == in.size()) return std::nullopt;
    indices.push_back(k++);
  }
  return indices;
}

std::string describe(const std::vector<dvec2>& pts) {
  std::ostringstream s;
  s.precision(17);
  for (const dvec2& p : pts) s << '(' << p.x << ", " << p.y << ") ";
  return s.str();
}

double uniform(std::mt19937& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
std::size_t uniformIndex(std::mt19937& rng, std::size_t lo, std::size_t hi) {
  return std::uniform_int_distribution<std::size_t>(lo, hi)(rng);
}

/// A random walk of n points: steps of [stepMin, stepMax], heading turning by up to ±turn.
std::vector<dvec2> randomWalk(std::mt19937& rng, std::size_t n, const dvec2& start, double stepMin, double stepMax,
                              double turn) {
  std::vector<dvec2> pts{start};
  double heading = uniform(rng, -std::numbers::pi, std::numbers::pi);
  while (pts.size() < n) {
    heading += uniform(rng, -turn, turn);
    const double step = uniform(rng, stepMin, stepMax);
    pts.push_back(pts.back() + step * dvec2(std::cos(heading), std::sin(heading)));
  }
  return pts;
}

// ---------------------------------------------------------------------------------------------
// simplifyPolyline

/// The Douglas–Peucker contract on one input: both ends kept, a subsequence, every dropped point
/// within epsilon of the kept segment that replaces its run (hence of the simplified polyline,
/// measured to segments, not lines).
::testing::AssertionResult simplifiedWithinEpsilon(const std::vector<dvec2>& in, const std::vector<dvec2>& out,
                                                   double epsilon) {
  if (out.size() < 2) return ::testing::AssertionFailure() << "fewer than 2 points: " << out.size();
  if (!samePoint(out.front(), in.front()) || !samePoint(out.back(), in.back())) {
    return ::testing::AssertionFailure() << "an end was dropped";
  }
  const auto indices = subsequenceIndices(out, in);
  if (!indices) return ::testing::AssertionFailure() << "not a subsequence of the input";
  if (indices->back() != in.size() - 1) return ::testing::AssertionFailure() << "last point matched early";
  const double bound = epsilon * (1.0 + kSlack);
  for (std::size_t r = 0; r + 1 < indices->size(); ++r) {
    const std::size_t a = (*indices)[r], b = (*indices)[r + 1];
    for (std::size_t k = a + 1; k < b; ++k) {
      const double d = distanceToSegment(in[k], in[a], in[b]);
      if (!(d <= bound)) {
        return ::testing::AssertionFailure()
               << "point " << k << " is " << d << " from its segment (" << a << ", " << b << "), epsilon " << epsilon;
      }
    }
  }
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double d = distanceToPolyline(in[k], out);
    if (!(d <= bound)) {
      return ::testing::AssertionFailure()
             << "point " << k << " is " << d << " from the simplified line, epsilon " << epsilon;
    }
  }
  return ::testing::AssertionSuccess();
}

TEST(SimplifyPolyline, RandomLinesStayWithinEpsilon) {
  // 600 random walks (3 to 400 points, smooth to zig-zag, steps 0.05 to 40 m) at epsilons from
  // 1 mm to 100 m: the contract above holds for each, and most of them do drop points (the
  // function is not the identity).
  std::mt19937 rng(101);
  const double epsilons[] = {0.001, 0.05, 0.5, 2.0, 10.0, 100.0};
  int simplified = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const std::size_t n = uniformIndex(rng, 3, 400);
    const double step = uniform(rng, 0.05, 40.0);
    const double turn = uniform(rng, 0.01, 3.0);
    const std::vector<dvec2> in =
        randomWalk(rng, n, dvec2(uniform(rng, -1e4, 1e4), uniform(rng, -1e4, 1e4)), 0.2 * step, step, turn);
    const double epsilon = epsilons[static_cast<std::size_t>(trial) % std::size(epsilons)] * uniform(rng, 0.5, 2.0);
    const std::vector<dvec2> out = overlay::simplifyPolyline(in, epsilon);
    ASSERT_TRUE(simplifiedWithinEpsilon(in, out, epsilon)) << "trial " << trial << ", " << n << " points";
    if (out.size() < in.size()) ++simplified;
  }
  EXPECT_GT(simplified, 300);
}

TEST(SimplifyPolyline, TrivialInputsAreReturnedUnchanged) {
  // epsilon <= 0 (and NaN) keeps every point, however close to a line; fewer than 3 points are
  // never touched.
  std::mt19937 rng(102);
  for (int trial = 0; trial < 50; ++trial) {
    const std::vector<dvec2> in = randomWalk(rng, uniformIndex(rng, 3, 100), dvec2(0.0), 0.01, 1.0, 0.1);
    for (const double epsilon : {0.0, -1.0, -1e-300, kNaN}) {
      EXPECT_EQ(overlay::simplifyPolyline(in, epsilon), in) << "trial " << trial << " epsilon " << epsilon;
    }
  }
  const std::vector<dvec2> none;
  const std::vector<dvec2> one{{3.0, 4.0}};
  const std::vector<dvec2> two{{3.0, 4.0}, {3.0, 4.0}};
  for (const std::vector<dvec2>& in : {none, one, two}) EXPECT_EQ(overlay::simplifyPolyline(in, 1e6), in);
}

TEST(SimplifyPolyline, StraightLineBecomesItsEnds) {
  // 1,000 collinear points (uneven spacing, slanted): only the two ends remain.
  std::mt19937 rng(103);
  std::vector<dvec2> in;
  double t = 0.0;
  for (int k = 0; k < 1000; ++k) {
    in.push_back(dvec2(100.0, -50.0) + t * dvec2(3.0, 4.0));
    t += uniform(rng, 0.1, 2.0);
  }
  const std::vector<dvec2> out = overlay::simplifyPolyline(in, 1e-6);
  ASSERT_EQ(out.size(), 2U);
  EXPECT_EQ(out.front(), in.front());
  EXPECT_EQ(out.back(), in.back());
}

TEST(SimplifyPolyline, DistanceIsToSegmentsNotLines) {
  // On one straight line, going out to x = 10 and back to x = 5: the turning point is on the
  // line through the ends but 5 m beyond the segment between them, so epsilon 1 keeps it.
  const std::vector<dvec2> in{{0, 0}, {2, 0}, {10, 0}, {7, 0}, {5, 0}};
  const std::vector<dvec2> out = overlay::simplifyPolyline(in, 1.0);
  EXPECT_EQ(out, (std::vector<dvec2>{{0, 0}, {10, 0}, {5, 0}}));
  // A loop back to the start: every point is far from the (degenerate) segment between the ends.
  const std::vector<dvec2> loop{{0, 0}, {10, 0}, {10, 10}, {0, 10}, {0, 0}};
  EXPECT_TRUE(simplifiedWithinEpsilon(loop, overlay::simplifyPolyline(loop, 1.0), 1.0));
  EXPECT_GE(overlay::simplifyPolyline(loop, 1.0).size(), 4U);
}

TEST(SimplifyPolyline, WigglyLinesKeepFarFewerPoints) {
  // 20 random wiggly lines of 2,000 points (steps of about 0.5 m, jitter ±0.3 m across, slow
  // bends) at epsilon 1 m: within epsilon, and at most a fifth of the points kept.
  std::mt19937 rng(104);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<dvec2> in;
    dvec2 centre(uniform(rng, -1e3, 1e3), uniform(rng, -1e3, 1e3));
    double heading = uniform(rng, 0.0, 2.0 * std::numbers::pi);
    for (int k = 0; k < 2000; ++k) {
      heading += uniform(rng, -0.05, 0.05);
      centre += 0.5 * dvec2(std::cos(heading), std::sin(heading));
      in.push_back(centre + dvec2(-std::sin(heading), std::cos(heading)) * uniform(rng, -0.3, 0.3));
    }
    const std::vector<dvec2> out = overlay::simplifyPolyline(in, 1.0);
    ASSERT_TRUE(simplifiedWithinEpsilon(in, out, 1.0)) << "trial " << trial;
    EXPECT_LT(out.size(), in.size() / 5) << "trial " << trial;
  }
}

TEST(SimplifyPolyline, NaNPointIsKept) {
  // The header (generalise.cpp: "NaN keeps the point (the footprint builder reports it)"): a
  // point with a NaN coordinate must survive, so that the simplified line is still recognised
  // as broken (the CPU reference draws nothing for a line with a non-finite point, and neither
  // must its generalisation draw something). And nothing crashes.
  // (An interior NaN point was once dropped: its distance is NaN and `d > worst` is false.)
  const std::vector<std::vector<dvec2>> inputs{
      {{0, 0}, {kNaN, kNaN}, {10, 0}},
      {{0, 0}, {5, 0.1}, {kNaN, 3.0}, {7, -0.2}, {10, 0}},
      {{0, 0}, {5, 20}, {kNaN, kNaN}, {8, -20}, {10, 0}},
  };
  for (const std::vector<dvec2>& in : inputs) {
    const std::vector<dvec2> out = overlay::simplifyPolyline(in, 1.0);
    const bool keepsNaN =
        std::any_of(out.begin(), out.end(), [](const dvec2& p) { return std::isnan(p.x) || std::isnan(p.y); });
    EXPECT_TRUE(keepsNaN) << "input " << describe(in) << "→ output " << describe(out);
  }
  // NaN at an end: the ends are always kept.
  const std::vector<dvec2> end{{0, 0}, {5, 0.1}, {kNaN, kNaN}};
  EXPECT_TRUE(std::isnan(overlay::simplifyPolyline(end, 1.0).back().x));
}

// ---------------------------------------------------------------------------------------------
// simplifyRing

enum class RingKind { Star, Scribble, Sliver };

/// Random rings: star-shaped simple polygons, self-intersecting scribbles, and thin slivers
/// (out along one side of a segment, back along the other) that epsilon can flatten.
Ring randomRing(std::mt19937& rng, RingKind kind, double size) {
  const dvec2 centre(uniform(rng, -1e4, 1e4), uniform(rng, -1e4, 1e4));
  Ring ring;
  switch (kind) {
    case RingKind::Star: {
      const std::size_t n = uniformIndex(rng, 4, 200);
      std::vector<double> angles;
      for (std::size_t k = 0; k < n; ++k) angles.push_back(uniform(rng, 0.0, 2.0 * std::numbers::pi));
      std::sort(angles.begin(), angles.end());
      const double noise = uniform(rng, 0.0, 0.6);
      for (const double a : angles)
        ring.push_back(centre + size * (1.0 + uniform(rng, -noise, noise)) * dvec2(std::cos(a), std::sin(a)));
      break;
    }
    case RingKind::Scribble: {
      const std::size_t n = uniformIndex(rng, 4, 40);
      for (std::size_t k = 0; k < n; ++k)
        ring.push_back(centre + size * dvec2(uniform(rng, -1, 1), uniform(rng, -1, 1)));
      break;
    }
    case RingKind::Sliver: {
      const std::size_t n = uniformIndex(rng, 2, 15);
      const double thickness = size * uniform(rng, 0.001, 0.05);
      const double a = uniform(rng, 0.0, 2.0 * std::numbers::pi);
      const dvec2 u(std::cos(a), std::sin(a)), v(-u.y, u.x);
      ring.push_back(centre);
      for (std::size_t k = 1; k < n; ++k)
        ring.push_back(centre + u * (size * static_cast<double>(k) / static_cast<double>(n)) +
                       v * uniform(rng, 0.0, thickness));
      ring.push_back(centre + u * size);
      for (std::size_t k = n - 1; k >= 1; --k)
        ring.push_back(centre + u * (size * static_cast<double>(k) / static_cast<double>(n)) -
                       v * uniform(rng, 0.0, thickness));
      break;
    }
  }
  return ring;
}

/// simplifyRing's contract on one input, except parity: at least 3 points, starting at the
/// ring's first point and a subsequence of the ring, every ring vertex within epsilon of the
/// simplified ring's (closed) edges, and an area whenever the input has one.
::testing::AssertionResult ringWithinEpsilon(const Ring& in, const Ring& out, double epsilon) {
  if (out.size() < 3) return ::testing::AssertionFailure() << "fewer than 3 points: " << out.size();
  if (!samePoint(out.front(), in.front())) return ::testing::AssertionFailure() << "does not start at point 0";
  if (!subsequenceIndices(out, in)) return ::testing::AssertionFailure() << "not a subsequence of the ring";
  for (std::size_t k = 0; k < in.size(); ++k) {
    const double d = distanceToRing(in[k], out);
    if (!(d <= epsilon * (1.0 + kSlack))) {
      return ::testing::AssertionFailure()
             << "vertex " << k << " is " << d << " from the simplified ring, epsilon " << epsilon;
    }
  }
  if (twiceArea(in) != 0.0 && !(std::abs(twiceArea(out)) > 0.0)) {
    return ::testing::AssertionFailure() << "the simplified ring has no area";
  }
  return ::testing::AssertionSuccess();
}

/// The number of random points farther than epsilon from the ring's boundary (`samples` tried,
/// in the ring's box widened by a tenth) whose even-odd status differs between the two rings;
/// `compared` counts the points farther than epsilon, `first` describes the first mismatch.
std::size_t parityMismatches(std::mt19937& rng, const Ring& in, const Ring& out, double epsilon, int samples,
                             std::size_t& compared, std::string& first) {
  dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const dvec2& p : in) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const dvec2 pad = 0.1 * (hi - lo) + dvec2(epsilon);
  std::size_t mismatches = 0;
  for (int k = 0; k < samples; ++k) {
    const dvec2 p(uniform(rng, lo.x - pad.x, hi.x + pad.x), uniform(rng, lo.y - pad.y, hi.y + pad.y));
    if (!(distanceToRing(p, in) > epsilon * (1.0 + 1e-6))) continue;
    ++compared;
    if (insideEvenOdd(p, in) != insideEvenOdd(p, out)) {
      if (mismatches++ == 0) {
        std::ostringstream s;
        s.precision(17);
        s << "point (" << p.x << ", " << p.y << ") " << distanceToRing(p, in) << " from the ring, inside original "
          << insideEvenOdd(p, in) << ", inside simplified " << insideEvenOdd(p, out);
        first = s.str();
      }
    }
  }
  return mismatches;
}

TEST(SimplifyRing, RandomRingsStayWithinEpsilonAndKeepParityAwayFromTheBoundary) {
  // 900 random rings (stars, scribbles; sizes 1 m to 1 km; epsilons from 1/1000 to twice the
  // size): the contract above, and the even-odd status of 300 random points per ring that lie
  // farther than epsilon from the ORIGINAL boundary is the same for both rings (the homotopy
  // argument of generalise.hpp). Slivers have their own test below.
  std::mt19937 rng(201);
  const double relative[] = {0.001, 0.01, 0.05, 0.2, 0.5, 2.0};
  int simplified = 0;
  std::size_t compared = 0;
  for (int trial = 0; trial < 900; ++trial) {
    const RingKind kind = trial % 2 == 0 ? RingKind::Star : RingKind::Scribble;
    const double size = std::pow(10.0, uniform(rng, 0.0, 3.0));
    const Ring in = randomRing(rng, kind, size);
    const double epsilon = size * relative[static_cast<std::size_t>(trial / 2) % std::size(relative)];
    const Ring out = overlay::simplifyRing(in, epsilon);
    ASSERT_TRUE(ringWithinEpsilon(in, out, epsilon)) << "trial " << trial << ": " << describe(in);
    std::string first;
    EXPECT_EQ(parityMismatches(rng, in, out, epsilon, 300, compared, first), 0U)
        << "trial " << trial << ", epsilon " << epsilon << ": " << first << "\nring " << describe(in) << "\nsimplified "
        << describe(out);
    if (out.size() < in.size()) ++simplified;
  }
  EXPECT_GT(simplified, 450);
  EXPECT_GT(compared, 900U * 100U);  // the parity was compared at many points
}

TEST(SimplifyRing, RandomSliversKeepAnAreaAndParity) {
  // 400 thin slivers at epsilons from below to far above their thickness: at least 3 points,
  // an area, every vertex within epsilon; and the even-odd status away from the boundary.
  std::mt19937 rng(202);
  std::size_t parityFailures = 0;
  std::string firstFailure;
  for (int trial = 0; trial < 400; ++trial) {
    const double size = std::pow(10.0, uniform(rng, 0.0, 3.0));
    const Ring in = randomRing(rng, RingKind::Sliver, size);
    const double epsilon = size * std::pow(10.0, uniform(rng, -4.0, 0.0));
    const Ring out = overlay::simplifyRing(in, epsilon);
    ASSERT_TRUE(ringWithinEpsilon(in, out, epsilon)) << "trial " << trial << ": " << describe(in);
    std::string first;
    std::size_t compared = 0;
    if (parityMismatches(rng, in, out, epsilon, 300, compared, first) != 0 && parityFailures++ == 0) {
      firstFailure = "trial " + std::to_string(trial) + ": " + first + "\nring " + describe(in) + "\nsimplified " +
                     describe(out) + "\nepsilon " + std::to_string(epsilon);
    }
  }
  EXPECT_EQ(parityFailures, 0U) << firstFailure;
}

TEST(SimplifyRing, FallbackTriangleKeepsParityAwayFromTheBoundary) {
  // When Douglas–Peucker keeps only point 0 and the farthest point, simplifyRing adds the point
  // farthest from that chord to make a triangle. The header's promise (parity unchanged farther
  // than epsilon from the original ring) must hold for that triangle too.
  // The case that once failed: the points dropped between point 0 and the added third point
  // were only checked against the chord, not against the new edges. Here a thin band along
  // y ≈ −0.95 with one spike to (50, 1), epsilon 1: every vertex is within 1 of the chord
  // (0,0)–(100,0), and the triangle (0,0), (50,1), (100,0) would cover (25, 0.45), 1.39 from
  // the original ring and outside it.
  const Ring in{{0, 0},      {1, -0.95}, {49.9, -0.95}, {50, 1},   {50.1, -0.95},
                {99, -0.95}, {100, 0},   {99, -0.94},   {1, -0.94}};
  const Ring out = overlay::simplifyRing(in, 1.0);
  EXPECT_TRUE(ringWithinEpsilon(in, out, 1.0)) << describe(out);
  const dvec2 p(25.0, 0.45);
  ASSERT_GT(distanceToRing(p, in), 1.0);
  EXPECT_FALSE(insideEvenOdd(p, in));
  EXPECT_EQ(insideEvenOdd(p, out), insideEvenOdd(p, in)) << "ring " << describe(in) << "\nsimplified " << describe(out);
}

TEST(SimplifyRing, TrivialAndDegenerateRingsAreReturnedUnchanged) {
  // 3 points or fewer, and epsilon <= 0 or NaN: unchanged.
  const Ring triangle{{0, 0}, {10, 0}, {5, 0.001}};
  EXPECT_EQ(overlay::simplifyRing(triangle, 100.0), triangle);
  const Ring square{{0, 0}, {5, 0.01}, {10, 0}, {10, 10}, {0, 10}};
  for (const double epsilon : {0.0, -2.0, kNaN}) EXPECT_EQ(overlay::simplifyRing(square, epsilon), square);
  // A ring with no area (all points on one line): the simplified triangle would have none
  // either, so the ring comes back unchanged.
  const Ring flat{{0, 0}, {4, 0}, {10, 0}, {7, 0}, {2, 0}};
  EXPECT_EQ(overlay::simplifyRing(flat, 1.0), flat);
}

TEST(SimplifyRing, ThinSliverKeepsAnArea) {
  // A sliver 2 mm thick and 10 m long at epsilon 1 m: Douglas–Peucker alone would keep only
  // its two ends (a segment, no area); the result has at least 3 points and an area, and every
  // vertex is within epsilon.
  const Ring in{{0, 0}, {2.5, 0.001}, {5, 0.0012}, {7.5, 0.001}, {10, 0}, {7.5, -0.001}, {5, -0.0008}, {2.5, -0.001}};
  const Ring out = overlay::simplifyRing(in, 1.0);
  EXPECT_TRUE(ringWithinEpsilon(in, out, 1.0)) << describe(out);
  EXPECT_NE(twiceArea(out), 0.0);
  EXPECT_LT(out.size(), in.size());
}

TEST(SimplifyRing, NaNPointIsKept) {
  // As for lines: a ring with a NaN coordinate must stay broken (the reference skips a polygon
  // with a non-finite coordinate; its generalisation must not become a drawable polygon).
  // (It was once dropped, as in SimplifyPolyline.NaNPointIsKept, leaving a clean square.)
  const Ring in{{0, 0}, {10, 0}, {kNaN, kNaN}, {10, 10}, {0, 10}};
  const Ring out = overlay::simplifyRing(in, 1.0);
  const bool keepsNaN = std::any_of(out.begin(), out.end(), [](const dvec2& p) { return std::isnan(p.x); });
  EXPECT_TRUE(keepsNaN) << "simplified " << describe(out);
}

// ---------------------------------------------------------------------------------------------
// lineShapeSlack

TEST(LineShapeSlack, ZeroOnlyForRoundJoinsAndCaps) {
  // Round join and round cap: the footprint moves by epsilon only. Every other shape has a
  // positive slack: a miter reaches miterLimit · w/2 (limits of 1 and more), bevels and flat or
  // square caps at least w/2 (square: its corner, √2 · w/2). The slack scales with the width.
  for (const double width : {2.0, 7.5, 40.0}) {
    EXPECT_EQ(overlay::lineShapeSlack(LineJoin::Round, LineCap::Round, 4.0, width), 0.0);
    for (const double limit : {1.0, 1.5, 4.0, 10.0}) {
      EXPECT_DOUBLE_EQ(overlay::lineShapeSlack(LineJoin::Miter, LineCap::Round, limit, width), limit * width / 2.0);
    }
    EXPECT_GT(overlay::lineShapeSlack(LineJoin::Miter, LineCap::Round, 0.5, width), 0.0);
    EXPECT_GE(overlay::lineShapeSlack(LineJoin::Bevel, LineCap::Round, 4.0, width), width / 2.0);
    EXPECT_GE(overlay::lineShapeSlack(LineJoin::Round, LineCap::Flat, 4.0, width), width / 2.0);
    EXPECT_GE(overlay::lineShapeSlack(LineJoin::Round, LineCap::Square, 4.0, width), std::numbers::sqrt2 * width / 2.0);
    // Combinations: at least the largest part.
    EXPECT_GE(overlay::lineShapeSlack(LineJoin::Miter, LineCap::Square, 10.0, width), 10.0 * width / 2.0);
    EXPECT_GE(overlay::lineShapeSlack(LineJoin::Bevel, LineCap::Square, 1.0, width), std::numbers::sqrt2 * width / 2.0);
    for (const LineJoin join : {LineJoin::Round, LineJoin::Miter, LineJoin::Bevel}) {
      for (const LineCap cap : {LineCap::Round, LineCap::Flat, LineCap::Square}) {
        EXPECT_DOUBLE_EQ(overlay::lineShapeSlack(join, cap, 3.0, 2.0 * width),
                         2.0 * overlay::lineShapeSlack(join, cap, 3.0, width));
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// generaliseGeometry

TEST(GeneraliseGeometry, SimplifiesEveryRingAndLineAndDropsAttributes) {
  // A feature with two polygons (one with two holes), three lines and attributes: the fid is
  // kept, the attributes dropped, the counts of polygons, holes and lines unchanged, each ring
  // and line simplified as simplifyRing / simplifyPolyline would; epsilon <= 0 copies the
  // geometry exactly.
  std::mt19937 rng(401);
  Feature f;
  f.fid = 42;
  f.attributes["name"] = std::string("river");
  f.attributes["width_m"] = 12.5;
  Polygon p0;
  p0.outer = randomRing(rng, RingKind::Star, 100.0);
  p0.holes = {randomRing(rng, RingKind::Star, 10.0), randomRing(rng, RingKind::Star, 5.0)};
  Polygon p1;
  p1.outer = randomRing(rng, RingKind::Scribble, 50.0);
  f.polygons = {p0, p1};
  f.lines = {randomWalk(rng, 300, dvec2(0.0), 0.1, 2.0, 0.5), randomWalk(rng, 2, dvec2(5.0), 0.1, 2.0, 0.5),
             randomWalk(rng, 50, dvec2(-5.0), 1.0, 20.0, 2.0)};

  const double epsilon = 1.5;
  const Feature g = overlay::generaliseGeometry(f, epsilon);
  EXPECT_EQ(g.fid, 42);
  EXPECT_TRUE(g.attributes.empty());
  ASSERT_EQ(g.polygons.size(), 2U);
  ASSERT_EQ(g.lines.size(), 3U);
  std::size_t before = 0, after = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(g.polygons[i].outer, overlay::simplifyRing(f.polygons[i].outer, epsilon));
    ASSERT_EQ(g.polygons[i].holes.size(), f.polygons[i].holes.size());
    for (std::size_t h = 0; h < f.polygons[i].holes.size(); ++h) {
      EXPECT_EQ(g.polygons[i].holes[h], overlay::simplifyRing(f.polygons[i].holes[h], epsilon));
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(g.lines[i], overlay::simplifyPolyline(f.lines[i], epsilon));
    EXPECT_TRUE(simplifiedWithinEpsilon(f.lines[i], g.lines[i], epsilon)) << "line " << i;
  }
  before = f.vertexCount();
  after = g.vertexCount();
  EXPECT_LT(after, before);  // something was simplified

  for (const double none : {0.0, -1.0}) {
    const Feature c = overlay::generaliseGeometry(f, none);
    EXPECT_EQ(c.fid, 42);
    EXPECT_TRUE(c.attributes.empty());
    ASSERT_EQ(c.polygons.size(), f.polygons.size());
    for (std::size_t i = 0; i < f.polygons.size(); ++i) {
      EXPECT_EQ(c.polygons[i].outer, f.polygons[i].outer);
      EXPECT_EQ(c.polygons[i].holes, f.polygons[i].holes);
    }
    EXPECT_EQ(c.lines, f.lines);
  }
  // An empty feature stays empty.
  const Feature e = overlay::generaliseGeometry(Feature{}, epsilon);
  EXPECT_TRUE(e.polygons.empty());
  EXPECT_TRUE(e.lines.empty());
}

// ---------------------------------------------------------------------------------------------
// generaliseCoverage

/// Even-odd over all of the polygon's rings.
bool inPolygon(const Polygon& p, const dvec2& q) {
  bool in = false;
  const auto ring = [&](const Ring& r) {
    for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
      if ((r[i].y > q.y) != (r[j].y > q.y) && q.x < (r[j].x - r[i].x) * (q.y - r[i].y) / (r[j].y - r[i].y) + r[i].x)
        in = !in;
    }
  };
  ring(p.outer);
  for (const Ring& h : p.holes) ring(h);
  return in;
}

/// A coverage: a 4 × 3 grid of cells 100 m a side whose shared borders are wiggly lines (the same
/// points in both neighbours, the other way round), and in cell (1, 1) a hole holding an island
/// feature of its own (its ring the hole's, reversed).
std::vector<Feature> wigglyCoverage(std::mt19937& rng) {
  constexpr int kColumns = 4, kRows = 3;
  constexpr double kSize = 100.0;
  std::uniform_real_distribution<double> wiggle(-3.0, 3.0);
  // Border between corners (i, j) → (i + 1, j) (horizontal) and (i, j) → (i, j + 1) (vertical):
  // 40 points each, inner points wiggled across the border (grid edges straight).
  const auto corner = [&](int i, int j) { return dvec2(i * kSize, j * kSize); };
  std::vector<std::vector<dvec2>> horizontal((kColumns) * (kRows + 1)), vertical((kColumns + 1) * kRows);
  for (int j = 0; j <= kRows; ++j) {
    for (int i = 0; i < kColumns; ++i) {
      auto& b = horizontal[static_cast<std::size_t>(j * kColumns + i)];
      for (int k = 0; k <= 40; ++k)
        b.push_back(corner(i, j) +
                    dvec2(kSize * k / 40.0, (j > 0 && j < kRows && k > 0 && k < 40) ? wiggle(rng) : 0.0));
    }
  }
  for (int j = 0; j < kRows; ++j) {
    for (int i = 0; i <= kColumns; ++i) {
      auto& b = vertical[static_cast<std::size_t>(j * (kColumns + 1) + i)];
      for (int k = 0; k <= 40; ++k)
        b.push_back(corner(i, j) +
                    dvec2((i > 0 && i < kColumns && k > 0 && k < 40) ? wiggle(rng) : 0.0, kSize * k / 40.0));
    }
  }
  std::vector<Feature> out;
  for (int j = 0; j < kRows; ++j) {
    for (int i = 0; i < kColumns; ++i) {
      Ring r;
      const auto& south = horizontal[static_cast<std::size_t>(j * kColumns + i)];
      const auto& north = horizontal[static_cast<std::size_t>((j + 1) * kColumns + i)];
      const auto& west = vertical[static_cast<std::size_t>(j * (kColumns + 1) + i)];
      const auto& east = vertical[static_cast<std::size_t>(j * (kColumns + 1) + i + 1)];
      r.insert(r.end(), south.begin(), south.end() - 1);    // west → east
      r.insert(r.end(), east.begin(), east.end() - 1);      // south → north
      r.insert(r.end(), north.rbegin(), north.rend() - 1);  // east → west
      r.insert(r.end(), west.rbegin(), west.rend() - 1);    // north → south
      Feature f;
      f.fid = j * kColumns + i;
      f.polygons.push_back(Polygon{r, {}});
      out.push_back(std::move(f));
    }
  }
  // The island: a wiggly circle in cell (1, 1).
  Ring island;
  for (int k = 0; k < 60; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 60.0;
    island.push_back(dvec2(150.0, 150.0) + (25.0 + wiggle(rng)) * dvec2(std::cos(a), std::sin(a)));
  }
  out[static_cast<std::size_t>(1 * kColumns + 1)].polygons[0].holes.push_back(Ring(island.rbegin(), island.rend()));
  Feature i;
  i.fid = 100;
  i.polygons.push_back(Polygon{island, {}});
  out.push_back(std::move(i));
  return out;
}

/// Ground points of the coverage's extent farther than `margin` from its outside, covered by a
/// number of features other than one.
std::size_t crackedOrDoubled(const std::vector<Feature>& features, double margin, std::mt19937& rng) {
  std::uniform_real_distribution<double> x(margin, 400.0 - margin), y(margin, 300.0 - margin);
  std::size_t bad = 0;
  for (int k = 0; k < 200000; ++k) {
    const dvec2 q(x(rng), y(rng));
    int covered = 0;
    for (const Feature& f : features)
      for (const Polygon& p : f.polygons) covered += inPolygon(p, q) ? 1 : 0;
    bad += covered != 1 ? 1U : 0U;
  }
  return bad;
}

TEST(GeneraliseCoverage, NeighboursStillMeetExactly) {
  // The wiggly coverage generalised by 4 m (more than its wiggles): generalised one feature at a
  // time, cracks and overlaps open along the shared borders; generalised together, every point
  // of the extent (away from its outside by epsilon) is covered by exactly one feature. Each ring
  // stays within epsilon of its own and loses points.
  std::mt19937 rng(41);
  const std::vector<Feature> coverage = wigglyCoverage(rng);
  std::vector<const Feature*> pointers;
  for (const Feature& f : coverage) pointers.push_back(&f);
  const double epsilon = 4.0;
  ASSERT_EQ(crackedOrDoubled(coverage, epsilon, rng), 0U) << "the coverage itself";

  std::vector<Feature> alone;
  for (const Feature& f : coverage) alone.push_back(overlay::generaliseGeometry(f, epsilon));
  const std::size_t aloneBad = crackedOrDoubled(alone, epsilon, rng);
  std::printf("one feature at a time: %zu of 200,000 points cracked or doubled\n", aloneBad);
  EXPECT_GT(aloneBad, 100U) << "the test's coverage shows the cracks it is about";

  const std::vector<Feature> together = overlay::generaliseCoverage(pointers, epsilon);
  ASSERT_EQ(together.size(), coverage.size());
  EXPECT_EQ(crackedOrDoubled(together, epsilon, rng), 0U);
  std::size_t before = 0, after = 0;
  for (std::size_t i = 0; i < coverage.size(); ++i) {
    EXPECT_EQ(together[i].fid, coverage[i].fid);
    ASSERT_EQ(together[i].polygons.size(), coverage[i].polygons.size());
    const Polygon& p = coverage[i].polygons[0];
    const Polygon& q = together[i].polygons[0];
    ASSERT_EQ(q.holes.size(), p.holes.size());
    // Its points are the ring's, and every point of the ring lies within epsilon of it.
    Ring closedQ = q.outer;
    closedQ.push_back(q.outer.front());
    for (const dvec2& v : q.outer)
      EXPECT_NE(std::find(p.outer.begin(), p.outer.end(), v), p.outer.end()) << "feature " << i;
    double farthest = 0.0;
    for (const dvec2& v : p.outer) farthest = std::max(farthest, distanceToPolyline(v, closedQ));
    EXPECT_LE(farthest, epsilon * (1.0 + kSlack)) << "feature " << i;
    before += coverage[i].vertexCount();
    after += together[i].vertexCount();
  }
  std::printf("vertices: %zu -> %zu\n", before, after);
  EXPECT_LT(after, before / 3);

  // A lone ring is simplified as simplifyRing does; epsilon 0 copies.
  const Feature& lone = coverage.back();
  const std::vector<const Feature*> one{&lone};
  EXPECT_EQ(overlay::generaliseCoverage(one, epsilon)[0].polygons[0].outer,
            overlay::simplifyRing(lone.polygons[0].outer, epsilon));
  EXPECT_EQ(overlay::generaliseCoverage(pointers, 0.0)[3].polygons[0].outer, coverage[3].polygons[0].outer);
}

TEST(GeneraliseCoverage, OneGeneraliserServesEveryToleranceAndItsOptions) {
  // The globe's levels of detail: the shared borders found once, then one tolerance after the
  // other, each what generaliseCoverage gives; features not wanted cost nothing; islands within
  // epsilon of one chord may be let go; a frame's own distance is used throughout.
  std::mt19937 rng(43);
  std::vector<Feature> coverage = wigglyCoverage(rng);
  Feature island;
  island.fid = 99;
  island.polygons.push_back(Polygon{{dvec2(500.0, 500.0), dvec2(503.0, 500.0), dvec2(503.0, 501.0)}, {}});
  coverage.push_back(island);
  std::vector<const Feature*> pointers;
  for (const Feature& f : coverage) pointers.push_back(&f);
  const overlay::CoverageGeneraliser generaliser(pointers);
  for (const double epsilon : {0.5, 2.0, 4.0, 8.0}) {
    const std::vector<Feature> once = generaliser.at(epsilon);
    const std::vector<Feature> each = overlay::generaliseCoverage(pointers, epsilon);
    ASSERT_EQ(once.size(), each.size());
    for (std::size_t i = 0; i < once.size(); ++i) {
      ASSERT_EQ(once[i].polygons.size(), each[i].polygons.size());
      for (std::size_t k = 0; k < once[i].polygons.size(); ++k) {
        EXPECT_EQ(once[i].polygons[k].outer, each[i].polygons[k].outer) << epsilon << " " << i;
        EXPECT_EQ(once[i].polygons[k].holes, each[i].polygons[k].holes) << epsilon << " " << i;
      }
    }
  }
  std::vector<char> wanted(coverage.size(), 0);
  wanted[2] = 1;
  const std::vector<Feature> some = generaliser.at(4.0, &wanted);
  EXPECT_EQ(some[2].polygons[0].outer, overlay::generaliseCoverage(pointers, 4.0)[2].polygons[0].outer);
  EXPECT_TRUE(some[1].polygons.empty() && some[3].polygons.empty());
  EXPECT_EQ(some[1].fid, coverage[1].fid);
  // The island (1 m across) within 2 m of one chord: a triangle by default, nothing when let go;
  // within 0.5 m it stays either way.
  EXPECT_EQ(generaliser.at(2.0).back().polygons[0].outer.size(), 3U);
  EXPECT_TRUE(generaliser.at(2.0, nullptr, true).back().polygons[0].outer.empty());
  EXPECT_EQ(generaliser.at(0.5, nullptr, true).back().polygons[0].outer.size(), 3U);
  // A frame's distance: here twice another, so epsilon means half as much.
  const overlay::CoverageGeneraliser plain(
      pointers, [](const dvec2& p, const dvec2& a, const dvec2& b) { return distanceToSegment(p, a, b); });
  const overlay::CoverageGeneraliser doubled(
      pointers, [](const dvec2& p, const dvec2& a, const dvec2& b) { return 2.0 * distanceToSegment(p, a, b); });
  const std::vector<Feature> half = plain.at(2.0);
  const std::vector<Feature> viaDistance = doubled.at(4.0);
  EXPECT_LT(half[0].polygons[0].outer.size(), coverage[0].polygons[0].outer.size());
  for (std::size_t i = 0; i + 1 < coverage.size(); ++i)
    EXPECT_EQ(viaDistance[i].polygons[0].outer, half[i].polygons[0].outer) << i;
}

TEST(GeneraliseCoverage, RingsThatWouldLoseTheirAreaKeepTheirPointsAndTheirNeighboursToo) {
  // A thin lens (0.5 m wide, its two borders meeting at both ends) between wide neighbours,
  // generalised by 2 m: both borders would become the same segment and the lens lose its area, so
  // it keeps every point, and its neighbours keep theirs along it: still exactly one feature at
  // every point.
  Feature a, lens, b;
  Ring left, middle, right;
  std::vector<dvec2> border1, border2;
  for (int k = 0; k <= 20; ++k) {
    const double y = k * 5.0, wiggle = (k % 2 == 0 ? 0.3 : -0.3) * (k > 0 && k < 20 ? 1.0 : 0.0);
    border1.push_back(dvec2(50.0 + wiggle, y));
    border2.push_back(dvec2(k > 0 && k < 20 ? 50.5 + wiggle : 50.0, y));  // a lens: the same ends
  }
  left = {dvec2(0.0, 0.0)};
  left.insert(left.end(), border1.begin(), border1.end());
  left.push_back(dvec2(0.0, 100.0));
  std::reverse(left.begin(), left.end());  // counter-clockwise: (0,100) … border north → south … (0,0)
  middle.insert(middle.end(), border1.begin(), border1.end());
  middle.insert(middle.end(), border2.rbegin() + 1, border2.rend() - 1);  // the ends once
  right.insert(right.end(), border2.begin(), border2.end());
  right.push_back(dvec2(100.0, 100.0));
  right.push_back(dvec2(100.0, 0.0));
  a.polygons.push_back(Polygon{left, {}});
  lens.polygons.push_back(Polygon{middle, {}});
  b.polygons.push_back(Polygon{right, {}});
  const std::vector<const Feature*> all{&a, &lens, &b};
  const std::vector<Feature> g = overlay::generaliseCoverage(all, 2.0);
  EXPECT_EQ(g[1].polygons[0].outer, middle) << "the lens keeps its points";
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(0.5, 99.5), y(0.5, 99.5);
  std::size_t bad = 0;
  for (int k = 0; k < 100000; ++k) {
    const dvec2 q(x(rng), y(rng));
    int covered = 0;
    for (const Feature& f : g) covered += inPolygon(f.polygons[0], q) ? 1 : 0;
    bad += covered != 1 ? 1U : 0U;
  }
  EXPECT_EQ(bad, 0U);
}

// ---------------------------------------------------------------------------------------------
// appendRunsNear

LineShape shapeOf(double width, LineJoin join, LineCap cap, double miterLimit) {
  LineShape s;
  s.width = width;
  s.join = join;
  s.cap = cap;
  s.miterLimit = miterLimit;
  return s;
}

/// How far a line's footprint reaches from its centre line (what tiled_layer passes).
double reachOf(const LineShape& s) {
  double factor = 1.0;
  if (s.cap == LineCap::Square) factor = std::max(factor, std::numbers::sqrt2);
  if (s.join == LineJoin::Miter) factor = std::max(factor, s.miterLimit);
  return 0.5 * s.width * factor;
}

struct Box {
  dvec2 lo, hi;
};

/// Whether segment (a, b)'s box widened by reach meets the box: the segments appendRunsNear
/// must take.
bool segmentNear(const dvec2& a, const dvec2& b, const Box& box, double reach) {
  return std::max(a.x, b.x) >= box.lo.x - reach && std::min(a.x, b.x) <= box.hi.x + reach &&
         std::max(a.y, b.y) >= box.lo.y - reach && std::min(a.y, b.y) <= box.hi.y + reach;
}

/// The number of sample points in the box where the runs' coverage differs from the whole
/// line's (CPU reference, featureCovers): half uniform in the box (a few on its edges), half
/// near the line (a random point of a random segment, or a random vertex, moved by up to
/// 1.3 reach) when that lands in the box. `covered` counts the samples the whole line covers.
std::size_t coverageMismatches(std::mt19937& rng, const LineString& line, const std::vector<LineString>& runs,
                               const LineShape& shape, const Box& box, int samples, std::size_t& covered,
                               std::string& first) {
  const std::vector<Feature> whole{Feature{0, {}, {line}, {}}};
  const std::vector<Feature> parts{Feature{0, {}, runs, {}}};
  const ReferenceLayer wholeLayer{"whole", LayerKind::Line, &whole, {shape}, {}};
  const ReferenceLayer partsLayer{"runs", LayerKind::Line, &parts, {shape}, {}};
  const double reach = reachOf(shape);
  std::size_t mismatches = 0;
  for (int k = 0; k < samples; ++k) {
    dvec2 p(uniform(rng, box.lo.x, box.hi.x), uniform(rng, box.lo.y, box.hi.y));
    if (k % 2 == 1 && !line.empty()) {
      const std::size_t s = uniformIndex(rng, 0, line.size() - 1);
      const dvec2& a = line[s];
      const dvec2& b = line[std::min(s + 1, line.size() - 1)];
      const double angle = uniform(rng, 0.0, 2.0 * std::numbers::pi);
      const double along = k % 4 == 1 ? uniform(rng, 0.0, 1.0) : 0.0;  // near a segment or near a vertex
      const dvec2 q = a + along * (b - a) + uniform(rng, 0.0, 1.3 * reach) * dvec2(std::cos(angle), std::sin(angle));
      if (q.x >= box.lo.x && q.x <= box.hi.x && q.y >= box.lo.y && q.y <= box.hi.y) p = q;
    } else if (k % 50 == 0) {  // on the box's edges
      if (k % 100 == 0) {
        p.x = k % 200 == 0 ? box.lo.x : box.hi.x;
      } else {
        p.y = k % 150 == 0 ? box.lo.y : box.hi.y;
      }
    }
    const bool byWhole = overlay::featureCovers(wholeLayer, 0, p);
    const bool byRuns = overlay::featureCovers(partsLayer, 0, p);
    if (byWhole) ++covered;
    if (byWhole != byRuns && mismatches++ == 0) {
      std::ostringstream s;
      s.precision(17);
      s << "at (" << p.x << ", " << p.y << ") whole line " << byWhole << ", runs " << byRuns;
      first = s.str();
    }
  }
  return mismatches;
}

/// Random lines for the runs: walks around the box that leave and re-enter it, excursions that
/// alternate between points inside and points far outside, closed loops, lines on an integer
/// grid (repeated points, exactly straight continuations, hairpins) and one-point lines.
LineString randomRunLine(std::mt19937& rng, const Box& box, double reach, int variant) {
  const dvec2 centre = 0.5 * (box.lo + box.hi);
  const dvec2 size = box.hi - box.lo;
  const auto inBox = [&] { return dvec2(uniform(rng, box.lo.x, box.hi.x), uniform(rng, box.lo.y, box.hi.y)); };
  const auto outside = [&] {  // beyond the box by up to 3 reach + the box's size
    const double a = uniform(rng, 0.0, 2.0 * std::numbers::pi);
    const double r = 0.5 * std::max(size.x, size.y) + uniform(rng, 0.0, 3.0 * reach + std::max(size.x, size.y));
    return centre + r * std::numbers::sqrt2 * dvec2(std::cos(a), std::sin(a));
  };
  LineString line;
  switch (variant) {
    case 0:    // a walk around the box
    case 1: {  // the same, closed
      const double step = uniform(rng, 0.05, 0.5) * std::max(size.x, size.y);
      line = randomWalk(rng, uniformIndex(rng, 2, 60), outside(), 0.3 * step, step, uniform(rng, 0.2, 3.0));
      // Pull the walk towards the box so that it crosses it.
      for (std::size_t k = 0; k < line.size(); ++k) {
        const double t = std::sin(std::numbers::pi * static_cast<double>(k) / static_cast<double>(line.size()));
        line[k] = line[k] + t * (centre - line[k]) * 0.8;
      }
      if (variant == 1) line.push_back(line.front());
      break;
    }
    case 2: {  // excursions: in and out several times, a few points on each leg
      const std::size_t legs = uniformIndex(rng, 2, 8);
      dvec2 from = uniform(rng, 0.0, 1.0) < 0.5 ? inBox() : outside();
      line.push_back(from);
      for (std::size_t leg = 0; leg < legs; ++leg) {
        const dvec2 to = leg % 2 == 0 ? outside() : inBox();
        const std::size_t pieces = uniformIndex(rng, 1, 4);
        for (std::size_t k = 1; k <= pieces; ++k) {
          const double t = static_cast<double>(k) / static_cast<double>(pieces);
          line.push_back(from + t * (to - from) +
                         (k < pieces ? dvec2(uniform(rng, -reach, reach), uniform(rng, -reach, reach)) : dvec2(0.0)));
        }
        from = to;
      }
      if (uniform(rng, 0.0, 1.0) < 0.3) line.push_back(line.front());  // closed
      break;
    }
    case 3: {  // integer grid: repeats, straight continuations, hairpins
      const double cell = std::max(1.0, std::round(uniform(rng, 0.2, 1.0) * reach));
      dvec2 p(std::round(centre.x + uniform(rng, -2.0, 2.0) * size.x),
              std::round(centre.y + uniform(rng, -2.0, 2.0) * size.y));
      line.push_back(p);
      const std::size_t n = uniformIndex(rng, 2, 80);
      int dx = 1, dy = 0;
      while (line.size() < n) {
        if (uniform(rng, 0.0, 1.0) < 0.4) {
          dx = static_cast<int>(uniformIndex(rng, 0, 2)) - 1;
          dy = static_cast<int>(uniformIndex(rng, 0, 2)) - 1;
        }
        // Drift back towards the box so that the walk visits it.
        if (uniform(rng, 0.0, 1.0) < 0.2) {
          dx = centre.x > p.x ? 1 : -1;
          dy = centre.y > p.y ? 1 : -1;
        }
        p += cell * static_cast<double>(uniformIndex(rng, 1, 3)) * dvec2(dx, dy);
        line.push_back(p);
      }
      break;
    }
    default: {  // one point: inside, just within reach, or out of reach
      const double r = uniform(rng, 0.0, 1.0);
      line.push_back(r < 0.3
                         ? inBox()
                         : (r < 0.7 ? box.hi + dvec2(uniform(rng, -0.9, 0.9) * reach, uniform(rng, 0.0, 0.99) * reach)
                                    : outside()));
      break;
    }
  }
  return line;
}

TEST(AppendRunsNear, RunsCoverTheBoxExactlyAsTheWholeLine) {
  // The key property: inside the box [lo, hi], the runs' footprints (one feature whose lines
  // are the runs) cover exactly what the whole line's footprint covers, by the CPU reference's
  // rules, for every join (round, miter, bevel), every cap (round, flat, square), widths 2 to
  // 40 m and reach = w/2 · max(1, √2 for square caps, miterLimit for miters). 1,200 random lines
  // (walks crossing the box, excursions in and out of it, closed loops, grid lines with repeats
  // and hairpins, one-point lines), 500 samples each, half of them near the line.
  std::mt19937 rng(501);
  std::size_t samplesCovered = 0, samplesTotal = 0, linesWithRuns = 0, linesWithoutRuns = 0, split = 0;
  for (int trial = 0; trial < 1200; ++trial) {
    const dvec2 lo(uniform(rng, -200.0, 200.0), uniform(rng, -200.0, 200.0));
    const Box box{lo, lo + dvec2(uniform(rng, 5.0, 150.0), uniform(rng, 5.0, 150.0))};
    const LineJoin join = std::array{LineJoin::Round, LineJoin::Miter, LineJoin::Bevel}[uniformIndex(rng, 0, 2)];
    const LineCap cap = std::array{LineCap::Round, LineCap::Flat, LineCap::Square}[uniformIndex(rng, 0, 2)];
    const LineShape shape = shapeOf(uniform(rng, 2.0, 40.0), join, cap, uniform(rng, 0.5, 10.0));
    const double reach = reachOf(shape);
    const LineString line = randomRunLine(rng, box, reach, trial % 5);
    std::vector<LineString> runs;
    overlay::appendRunsNear(line, box.lo, box.hi, reach, runs);
    (runs.empty() ? linesWithoutRuns : linesWithRuns) += 1;
    if (runs.size() > 1) ++split;
    std::size_t covered = 0;
    std::string first;
    const std::size_t mismatches = coverageMismatches(rng, line, runs, shape, box, 500, covered, first);
    EXPECT_EQ(mismatches, 0U) << "trial " << trial << ", " << first << "\nbox (" << box.lo.x << ", " << box.lo.y
                              << ")–(" << box.hi.x << ", " << box.hi.y << "), width " << shape.width << ", join "
                              << static_cast<int>(join) << ", cap " << static_cast<int>(cap) << ", miter limit "
                              << shape.miterLimit << "\nline " << describe(line);
    samplesCovered += covered;
    samplesTotal += 500;
  }
  // The samples are meaningful: many covered and many not; lines with and without runs, and
  // lines cut into several runs.
  EXPECT_GT(samplesCovered, samplesTotal / 10);
  EXPECT_LT(samplesCovered, samplesTotal * 9 / 10);
  EXPECT_GT(linesWithRuns, 600U);
  EXPECT_GT(linesWithoutRuns, 10U);
  EXPECT_GT(split, 100U);
}

TEST(AppendRunsNear, CoverageCheckDetectsWrongRuns) {
  // A control for the test above (its comparison can fail): on 200 random cases (every join and
  // cap) it catches
  // - runs computed with no reach (a caller forgetting the line's width): segments within reach
  //   of the box but whose own box misses it are lost (unless an extra segment saves them);
  // - the right runs with their outermost segment at a line end dropped (that end's cap lost).
  // (Runs cut exactly at the near segments, without the extra one at each end, are NOT wrong:
  // a segment that is not near has both its ends beyond reach, so the cut point's cap or join
  // cannot reach the box either. The extra segments are a harmless margin.)
  std::mt19937 rng(502);
  std::size_t caughtNoReach = 0, caughtTrimmed = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const dvec2 lo(uniform(rng, -200.0, 200.0), uniform(rng, -200.0, 200.0));
    const Box box{lo, lo + dvec2(uniform(rng, 5.0, 150.0), uniform(rng, 5.0, 150.0))};
    const LineJoin join = std::array{LineJoin::Round, LineJoin::Miter, LineJoin::Bevel}[uniformIndex(rng, 0, 2)];
    const LineCap cap = std::array{LineCap::Round, LineCap::Flat, LineCap::Square}[uniformIndex(rng, 0, 2)];
    const LineShape shape = shapeOf(uniform(rng, 2.0, 40.0), join, cap, uniform(rng, 1.0, 10.0));
    const double reach = reachOf(shape);
    const LineString line = randomRunLine(rng, box, reach, trial % 2 == 0 ? 0 : 2);
    std::size_t covered = 0;
    std::string first;
    std::vector<LineString> noReach;
    overlay::appendRunsNear(line, box.lo, box.hi, 0.0, noReach);
    if (coverageMismatches(rng, line, noReach, shape, box, 500, covered, first) > 0) ++caughtNoReach;
    std::vector<LineString> trimmed;
    overlay::appendRunsNear(line, box.lo, box.hi, reach, trimmed);
    for (LineString& run : trimmed) {
      if (run.size() > 2 && run.front() == line.front()) run.erase(run.begin());
      if (run.size() > 2 && run.back() == line.back()) run.pop_back();
    }
    if (coverageMismatches(rng, line, trimmed, shape, box, 500, covered, first) > 0) ++caughtTrimmed;
  }
  EXPECT_GT(caughtNoReach, 15U);  // 29 with this seed
  EXPECT_GT(caughtTrimmed, 40U);  // 87 with this seed
}

TEST(AppendRunsNear, RunsAreTheMaximalRunsOfNearSegments) {
  // Structure, on 2,000 random lines with distinct points: each run is a contiguous slice of
  // the line, in order; every segment of a run is near (its box widened by reach meets the
  // box); every near segment lies in a run; the segments just before and after a run are not
  // near (runs are maximal); and `out` is appended to, not replaced.
  std::mt19937 rng(503);
  for (int trial = 0; trial < 2000; ++trial) {
    const dvec2 lo(uniform(rng, -200.0, 200.0), uniform(rng, -200.0, 200.0));
    const Box box{lo, lo + dvec2(uniform(rng, 5.0, 150.0), uniform(rng, 5.0, 150.0))};
    const double reach = uniform(rng, 1.0, 100.0);
    const LineString line = randomRunLine(rng, box, reach, trial % 3 == 2 ? 2 : 0);
    std::vector<LineString> out{LineString{{1e9, 1e9}}};
    overlay::appendRunsNear(line, box.lo, box.hi, reach, out);
    ASSERT_FALSE(out.empty());
    ASSERT_EQ(out.front(), (LineString{{1e9, 1e9}})) << "out was not appended to";
    std::vector<bool> inRun(line.size() > 0 ? line.size() - 1 : 0, false);
    std::size_t previousFirst = 0;
    for (std::size_t r = 1; r < out.size(); ++r) {
      const LineString& run = out[r];
      ASSERT_GE(run.size(), 2U) << "trial " << trial;
      // Its start in the line (points are distinct random doubles, so unique).
      const auto at = std::find(line.begin(), line.end(), run.front());
      ASSERT_NE(at, line.end()) << "trial " << trial << " run " << r;
      const auto f = static_cast<std::size_t>(at - line.begin());
      ASSERT_LE(f + run.size(), line.size()) << "trial " << trial;
      ASSERT_TRUE(std::equal(run.begin(), run.end(), at)) << "trial " << trial << " run " << r << " not a slice";
      ASSERT_GE(f, previousFirst) << "runs out of order, trial " << trial;
      previousFirst = f;
      const std::size_t l = f + run.size() - 1;  // last point index
      for (std::size_t s = f; s < l; ++s) {
        inRun[s] = true;
        EXPECT_TRUE(segmentNear(line[s], line[s + 1], box, reach))
            << "trial " << trial << " run " << r << ": segment " << s << " is not near";
      }
      if (f > 0) {
        EXPECT_FALSE(segmentNear(line[f - 1], line[f], box, reach))
            << "trial " << trial << " run " << r << ": not maximal at its start";
      }
      if (l + 1 < line.size()) {
        EXPECT_FALSE(segmentNear(line[l], line[l + 1], box, reach))
            << "trial " << trial << " run " << r << ": not maximal at its end";
      }
    }
    for (std::size_t s = 0; s + 1 < line.size(); ++s) {
      if (segmentNear(line[s], line[s + 1], box, reach)) {
        EXPECT_TRUE(inRun[s]) << "trial " << trial << ": near segment " << s << " in no run";
      }
    }
  }
}

TEST(AppendRunsNear, FarLinesGiveNoRunsAndInsideLinesOneRun) {
  // A line far from the box (more than reach beyond it on every side, even diagonally) gives
  // no run; a line entirely inside gives exactly one run, equal to the line; a one-point line
  // gives itself when within reach of the box (per axis) and nothing otherwise; empty lines
  // give nothing.
  std::mt19937 rng(504);
  const Box box{{0, 0}, {100, 50}};
  for (int trial = 0; trial < 200; ++trial) {
    const double reach = uniform(rng, 1.0, 30.0);
    // Far: entirely in a region beyond the box's right edge by more than reach.
    LineString far = randomWalk(rng, uniformIndex(rng, 1, 50), dvec2(100.0 + reach + 50.0, 25.0), 0.1, 5.0, 1.0);
    for (dvec2& p : far) p.x = std::max(p.x, 100.0 + reach * 1.001 + 1e-9);
    std::vector<LineString> out;
    overlay::appendRunsNear(far, box.lo, box.hi, reach, out);
    EXPECT_TRUE(out.empty()) << "trial " << trial << ": " << describe(far);
    // Inside: a walk clamped to the box.
    LineString inside = randomWalk(rng, uniformIndex(rng, 1, 50), dvec2(50.0, 25.0), 0.1, 20.0, 2.0);
    for (dvec2& p : inside) p = glm::clamp(p, box.lo, box.hi);
    out.clear();
    overlay::appendRunsNear(inside, box.lo, box.hi, reach, out);
    ASSERT_EQ(out.size(), 1U) << "trial " << trial;
    EXPECT_EQ(out[0], inside) << "trial " << trial;
  }
  std::vector<LineString> out;
  overlay::appendRunsNear(LineString{{105.0, 25.0}}, box.lo, box.hi, 5.0, out);  // exactly at reach
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], (LineString{{105.0, 25.0}}));
  out.clear();
  overlay::appendRunsNear(LineString{{105.01, 25.0}}, box.lo, box.hi, 5.0, out);
  EXPECT_TRUE(out.empty());
  overlay::appendRunsNear(LineString{}, box.lo, box.hi, 5.0, out);
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace gis::test
