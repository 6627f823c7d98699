// Lasso volumes and their CPU twin (vector_overlay/lasso.hpp): the volume is closed and wound
// outward for concave and self-intersecting lassos; its winding number around a point is 1
// exactly where the twin says "inside"; the operators follow the seed report's Table 1, for pairs
// and long chains; bad lassos are reported and select nothing.
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "gfx/camera.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::test {
namespace {

using overlay::Lasso;
using overlay::SelectionOp;
using overlay::SelectionStep;

Lasso lassoOf(std::vector<glm::dvec2> points, double distance = std::numeric_limits<double>::infinity()) {
  Lasso l;
  l.points = std::move(points);
  l.viewProj = gfx::reversedInfinitePerspective(glm::radians(60.0), 4.0 / 3.0, 1.0) *
               gfx::lookAt(glm::dvec3(10, -400, 300), glm::dvec3(0, 0, 0), glm::dvec3(0, 0, 1));
  l.width = 400;
  l.height = 300;
  l.distance = distance;
  return l;
}

/// Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom and Strackee).
double solidAngle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const double numerator = glm::dot(a, glm::cross(b, c));
  const double denominator = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
  return 2.0 * std::atan2(numerator, denominator);
}

double windingNumber(const overlay::LassoVolume& v, const glm::dvec3& p) {
  double sum = 0.0;
  for (const auto& t : v.triangles) {
    sum += solidAngle(glm::dvec3(t[0]) / t[0].w - p, glm::dvec3(t[1]) / t[1].w - p, glm::dvec3(t[2]) / t[2].w - p);
  }
  return sum / (4.0 * std::numbers::pi);
}

TEST(Lasso, OperatorNamesRoundTrip) {
  for (SelectionOp op : {SelectionOp::Single, SelectionOp::Or, SelectionOp::And, SelectionOp::Xor,
                         SelectionOp::Subtract, SelectionOp::Invert}) {
    EXPECT_EQ(overlay::parseSelectionOp(overlay::selectionOpName(op)), op);
  }
  EXPECT_EQ(overlay::parseSelectionOp("XOR"), SelectionOp::Xor);
  EXPECT_EQ(overlay::parseSelectionOp("union"), std::nullopt);
}

TEST(Lasso, VolumesAreClosedOutwardAndHoldExactlyTheTwinsPoints) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<glm::dvec2> pts;
    const int n = 4 + trial % 9;
    for (int k = 0; k < n; ++k) {
      if (trial % 3 == 0) {  // scribble: self-intersecting
        pts.emplace_back(50.0 + 300.0 * unit(rng), 40.0 + 220.0 * unit(rng));
      } else {  // star: concave
        const double a = 6.283 * k / n, r = (30.0 + 90.0 * unit(rng)) * (k % 2 == 0 ? 1.0 : 0.4);
        pts.push_back(glm::dvec2(200, 150) + r * glm::dvec2(std::cos(a), std::sin(a)));
      }
    }
    const Lasso lasso = lassoOf(pts, 300.0 + 400.0 * unit(rng));  // finite: every vertex a point
    Diagnostics d;
    const overlay::LassoVolume v = overlay::buildLassoVolume(lasso, "lasso", d);
    ASSERT_FALSE(v.empty()) << trial;
    // Closed: every directed edge has its reverse, as often.
    std::map<std::tuple<double, double, double, double, double, double>, int> edges;
    double volume6 = 0.0;
    for (const auto& t : v.triangles) {
      for (std::size_t k = 0; k < 3; ++k) {
        const glm::dvec3 a = glm::dvec3(t[k]) / t[k].w, b = glm::dvec3(t[(k + 1) % 3]) / t[(k + 1) % 3].w;
        ++edges[{a.x, a.y, a.z, b.x, b.y, b.z}];
        --edges[{b.x, b.y, b.z, a.x, a.y, a.z}];
      }
      volume6 += glm::dot(glm::dvec3(t[0]) / t[0].w, glm::cross(glm::dvec3(t[1]) / t[1].w, glm::dvec3(t[2]) / t[2].w));
    }
    for (const auto& [edge, count] : edges) ASSERT_EQ(count, 0) << "open edge, trial " << trial;
    EXPECT_GT(volume6, 0.0) << "wound inward, trial " << trial;
    // Winding number 1 exactly where the twin says inside (random points in the camera's view).
    const glm::dmat4 inverse = glm::inverse(lasso.viewProj);
    for (int k = 0; k < 200; ++k) {
      const glm::dvec4 h = inverse * glm::dvec4(2.0 * unit(rng) - 1.0, 2.0 * unit(rng) - 1.0, 0.001 + unit(rng), 1.0);
      const glm::dvec3 p = glm::dvec3(h) / h.w;
      const double w = windingNumber(v, p);
      ASSERT_NEAR(w, std::round(w), 1e-6);
      EXPECT_EQ(std::lround(w) == 1, overlay::insideLasso(lasso, p)) << "trial " << trial << " point " << k;
      EXPECT_TRUE(std::lround(w) == 0 || std::lround(w) == 1);
    }
  }
}

TEST(Lasso, InfiniteDarkCapIsAtInfinityBehindTheLightCap) {
  Diagnostics d;
  const Lasso lasso = lassoOf({{100, 100}, {300, 100}, {300, 200}, {100, 200}});
  const overlay::LassoVolume v = overlay::buildLassoVolume(lasso, "lasso", d);
  ASSERT_FALSE(v.empty());
  const glm::dvec3 eye(10, -400, 300);
  for (std::size_t i = v.lightCapTriangles; i < v.lightCapTriangles + v.darkCapTriangles; ++i) {
    for (const glm::dvec4& h : v.triangles[i]) {
      EXPECT_EQ(h.w, 0.0);
      EXPECT_GT(glm::dot(glm::dvec3(h), glm::dvec3(0, 0, 0) - eye), 0.0);  // away from the eye, forward
    }
  }
  // Points far along the view are inside; behind the eye and before the near plane are not.
  EXPECT_TRUE(overlay::insideLasso(lasso, eye + 1e7 * glm::normalize(-eye)));
  EXPECT_FALSE(overlay::insideLasso(lasso, eye - 100.0 * glm::normalize(-eye)));
  EXPECT_FALSE(overlay::insideLasso(lasso, eye + 0.5 * glm::normalize(-eye)));
}

TEST(Lasso, OperatorsFollowTheTruthTable) {
  // A = left square, B = right square, overlapping in the middle (pixels).
  const Lasso a = lassoOf({{100, 100}, {220, 100}, {220, 200}, {100, 200}});
  const Lasso b = lassoOf({{180, 100}, {300, 100}, {300, 200}, {180, 200}});
  const glm::dmat4 inverse = glm::inverse(a.viewProj);
  const auto at = [&](double px) {  // a point seen at pixel (px, 150), 50 m beyond the near plane
    const glm::dvec4 h = inverse * glm::dvec4(2.0 * px / 400.0 - 1.0, 0.0, 0.02, 1.0);
    return glm::dvec3(h) / h.w;
  };
  const glm::dvec3 none = at(50), onlyA = at(150), both = at(200), onlyB = at(260);
  // Table 1 of the report: (A, B) → And, Or, Xor, Subtract.
  struct Row {
    glm::dvec3 p;
    bool andV, orV, xorV, subV;
  };
  for (const Row& r : {Row{none, false, false, false, false}, Row{onlyB, false, true, true, false},
                       Row{onlyA, false, true, true, true}, Row{both, true, true, false, false}}) {
    const auto eval = [&](SelectionOp op) {
      const std::vector<SelectionStep> steps{{SelectionOp::Single, a}, {op, b}};
      return overlay::selectedAt(steps, r.p);
    };
    EXPECT_EQ(eval(SelectionOp::And), r.andV);
    EXPECT_EQ(eval(SelectionOp::Or), r.orV);
    EXPECT_EQ(eval(SelectionOp::Xor), r.xorV);
    EXPECT_EQ(eval(SelectionOp::Subtract), r.subV);
    // Invert flips; background is never selected.
    const std::vector<SelectionStep> inverted{{SelectionOp::Single, a}, {SelectionOp::Invert, {}}};
    EXPECT_EQ(overlay::selectedAt(inverted, r.p), !overlay::insideLasso(a, r.p));
    EXPECT_FALSE(overlay::selectedAt(inverted, r.p, false));
  }
  // A long chain: 51 Xors of A flip 51 times; Single restarts.
  std::vector<SelectionStep> chain{{SelectionOp::Single, b}};
  for (int k = 0; k < 51; ++k) chain.push_back({SelectionOp::Xor, a});
  EXPECT_FALSE(overlay::selectedAt(chain, both));
  EXPECT_TRUE(overlay::selectedAt(chain, onlyA));
  EXPECT_TRUE(overlay::selectedAt(chain, onlyB));
  chain.push_back({SelectionOp::Single, a});
  EXPECT_TRUE(overlay::selectedAt(chain, both));
  EXPECT_FALSE(overlay::selectedAt(chain, onlyB));
}

TEST(Lasso, BadLassosAreReportedAndSelectNothing) {
  for (const std::vector<glm::dvec2>& pts :
       {std::vector<glm::dvec2>{{1, 1}, {2, 2}}, std::vector<glm::dvec2>{{1, 1}, {2, 2}, {3, 3}, {4, 4}},
        std::vector<glm::dvec2>{{1, 1}, {std::nan(""), 2}, {3, 1}}}) {
    Diagnostics d;
    EXPECT_TRUE(overlay::buildLassoVolume(lassoOf(pts), "lasso 3", d).empty());
    ASSERT_EQ(d.count(Severity::Error), 1u);
    EXPECT_NE(d.items()[0].toString().find("lasso 3"), std::string::npos);
  }
  Lasso singular = lassoOf({{100, 100}, {300, 100}, {300, 200}});
  singular.viewProj = glm::dmat4(0.0);
  Diagnostics d;
  EXPECT_TRUE(overlay::buildLassoVolume(singular, "lasso", d).empty());
  EXPECT_EQ(d.count(Severity::Error), 1u);
}

}  // namespace
}  // namespace gis::test
