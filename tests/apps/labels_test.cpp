// Feature labels: anchors inside polygons (checked by this file's own point-in-polygon and
// distance, against brute-force sampling), at half a line's length, and a screen placement with
// no overlap, inside the screen and outside blocked rectangles, greedy by priority and stable
// from frame to frame.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "app/labels.hpp"

namespace gis::test {
namespace {

using app::LabelCandidate;
using app::LabelLayout;
using app::LabelPosition;
using app::PlacedLabel;
using app::ScreenRect;
using geo::Polygon;
using geo::Ring;
using glm::dvec2;

constexpr double kPi = std::numbers::pi;

// ---- This file's own geometry: winding numbers and distances, apart from the library's ----

int windingNumber(const Ring& ring, const dvec2& p) {
  int w = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const dvec2& a = ring[i];
    const dvec2& b = ring[(i + 1) % ring.size()];
    const double side = (b.x - a.x) * (p.y - a.y) - (p.x - a.x) * (b.y - a.y);
    if (a.y <= p.y && b.y > p.y && side > 0) ++w;
    if (a.y > p.y && b.y <= p.y && side < 0) --w;
  }
  return w;
}

bool insideRing(const Ring& ring, const dvec2& p) { return windingNumber(ring, p) != 0; }

bool insidePolygon(const Polygon& polygon, const dvec2& p) {
  if (!insideRing(polygon.outer, p)) return false;
  return std::none_of(polygon.holes.begin(), polygon.holes.end(), [&](const Ring& h) { return insideRing(h, p); });
}

double distanceToRing(const Ring& ring, const dvec2& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const dvec2& a = ring[i];
    const dvec2& b = ring[(i + 1) % ring.size()];
    const double t = std::clamp(glm::dot(p - a, b - a) / glm::dot(b - a, b - a), 0.0, 1.0);
    best = std::min(best, glm::distance(p, a + t * (b - a)));
  }
  return best;
}

double distanceToBoundary(const Polygon& polygon, const dvec2& p) {
  double d = distanceToRing(polygon.outer, p);
  for (const Ring& h : polygon.holes) d = std::min(d, distanceToRing(h, p));
  return d;
}

double shoelace(const Ring& r) {
  double a = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) a += r[i].x * r[(i + 1) % r.size()].y - r[(i + 1) % r.size()].x * r[i].y;
  return 0.5 * std::abs(a);
}

double area(const Polygon& p) {
  double a = shoelace(p.outer);
  for (const Ring& h : p.holes) a -= shoelace(h);
  return a;
}

// The largest clearance among the inside points of an n x n grid over the box; 0 if none is inside.
double bruteForceClearance(const Polygon& polygon, int n) {
  dvec2 lo = polygon.outer[0];
  dvec2 hi = lo;
  for (const dvec2& p : polygon.outer) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  double best = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const dvec2 p = lo + (hi - lo) * dvec2((i + 0.5) / n, (j + 0.5) / n);
      if (insidePolygon(polygon, p)) best = std::max(best, distanceToBoundary(polygon, p));
    }
  }
  return best;
}

// ---- Random polygons ----

// Star-shaped about `centre` (so simple), concave where the radii vary.
Ring star(std::mt19937& rng, const dvec2& centre, double rMin, double rMax, int n, bool clockwise = false) {
  std::uniform_real_distribution<double> radius(rMin, rMax);
  std::uniform_real_distribution<double> jitter(-0.35, 0.35);
  Ring ring;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * kPi * (i + jitter(rng)) / n;
    ring.push_back(centre + radius(rng) * dvec2(std::cos(a), std::sin(a)));
  }
  if (clockwise) std::reverse(ring.begin(), ring.end());
  return ring;
}

Ring transformed(const Ring& r, double angle, const dvec2& shift) {
  Ring out;
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  for (const dvec2& p : r) out.push_back(dvec2(c * p.x - s * p.y, s * p.x + c * p.y) + shift);
  return out;
}

// A U: two arms of thickness t on a base of thickness b, w wide and h high.
Ring uShape(double w, double h, double t, double b) {
  return {{0, 0}, {w, 0}, {w, h}, {w - t, h}, {w - t, b}, {t, b}, {t, h}, {0, h}};
}

struct Case {
  std::vector<Polygon> parts;
  double knownClearance = 0.0;  ///< the exact optimum where known (slivers), else 0
};

Case randomCase(std::mt19937& rng, int kind) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double scale = std::pow(10.0, 4.0 * u(rng) - 1.0);  // 0.1 m to 1 km
  const dvec2 shift = dvec2(u(rng) - 0.5, u(rng) - 0.5) * 40000.0;
  const double angle = 2.0 * kPi * u(rng);
  const int n = 5 + static_cast<int>(u(rng) * 40);
  const int m = std::max(n, 20);  // outer rings with holes: fine enough that chords stay clear of them
  Case c;
  Polygon p;
  switch (kind) {
    case 0:  // concave star
      p.outer = star(rng, shift, 0.15 * scale, scale, n);
      break;
    case 1: {  // a hole at the centre (the centroid's place), small ones around it, either orientation
      p.outer = star(rng, shift, 0.6 * scale, scale, m);
      p.holes.push_back(star(rng, shift, 0.1 * scale, 0.3 * scale, 5 + n / 2, u(rng) < 0.5));
      const int more = static_cast<int>(u(rng) * 5);
      for (int k = 0; k < more; ++k) {
        const double a = 2.0 * kPi * (k + 0.3 * u(rng)) / 4.0;
        p.holes.push_back(star(rng, shift + 0.45 * scale * dvec2(std::cos(a), std::sin(a)), 0.03 * scale, 0.09 * scale,
                               5 + n / 4, u(rng) < 0.5));
      }
      break;
    }
    case 2: {  // a thin annulus: the centroid deep in the hole
      const double inner = 0.7 + 0.25 * u(rng);
      p.outer = star(rng, shift, 0.99 * scale, scale, 64);
      p.holes.push_back(star(rng, shift, inner * 0.98 * scale, inner * scale, 64, true));
      break;
    }
    case 3: {  // U with long arms: the centroid in the notch
      const double w = scale;
      const double h = scale * (0.5 + 2.0 * u(rng));
      p.outer = transformed(uShape(w, h, w * (0.02 + 0.2 * u(rng)), h * (0.02 + 0.2 * u(rng))), angle, shift);
      break;
    }
    case 4: {  // sliver: a rectangle up to 10^4 times longer than wide, any angle
      const double length = scale;
      const double width = length / std::pow(10.0, 1.0 + 3.0 * u(rng));
      p.outer = transformed({{0, 0}, {length, 0}, {length, width}, {0, width}}, angle, shift);
      c.knownClearance = 0.5 * width;
      break;
    }
    default: {  // multipolygon: parts far apart, of different sizes, some with holes
      const int parts = 2 + static_cast<int>(u(rng) * 3);
      for (int k = 0; k < parts; ++k) {
        Polygon part;
        const double s = scale * (0.3 + u(rng));
        const dvec2 at = shift + dvec2(3.0 * scale * k, 0.0);
        part.outer = star(rng, at, 0.5 * s, s, m);
        if (u(rng) < 0.5) part.holes.push_back(star(rng, at, 0.1 * s, 0.4 * s, 8, true));
        c.parts.push_back(part);
      }
      return c;
    }
  }
  c.parts.push_back(p);
  return c;
}

TEST(LabelAnchorTest, PolygonAnchorsLieInsideTheLargestPartAndFarFromItsBoundary) {
  std::mt19937 rng(20250925);
  int checked = 0;
  double worstRatio = 1e9;
  for (int i = 0; i < 3000; ++i) {
    const int kind = i % 6;
    const Case c = randomCase(rng, kind);
    geo::Feature f;
    f.fid = i;
    f.polygons = c.parts;
    const std::optional<app::LabelAnchor> a = app::featureLabelAnchor(f);
    ASSERT_TRUE(a.has_value());
    std::size_t largest = 0;
    for (std::size_t k = 1; k < c.parts.size(); ++k) {
      if (area(c.parts[k]) > area(c.parts[largest])) largest = k;
    }
    const Polygon& part = c.parts[largest];
    SCOPED_TRACE(testing::Message() << "case " << i << " kind " << kind);
    ASSERT_TRUE(insidePolygon(part, a->point)) << "anchor outside or in a hole";
    const double clearance = distanceToBoundary(part, a->point);
    EXPECT_NEAR(a->clearance, clearance, 1e-9 * (1.0 + clearance) + 1e-6 * clearance);
    EXPECT_NEAR(a->partSize, area(part), 1e-9 * area(part));
    for (const Polygon& p : c.parts) {
      for (const dvec2& v : p.outer) {
        EXPECT_TRUE(v.x >= a->boundsMin.x && v.y >= a->boundsMin.y && v.x <= a->boundsMax.x && v.y <= a->boundsMax.y);
      }
    }
    const double brute = c.knownClearance > 0.0 ? c.knownClearance : bruteForceClearance(part, 48);
    if (brute > 0.0) {
      EXPECT_GE(clearance, 0.5 * brute);
      worstRatio = std::min(worstRatio, clearance / brute);
      ++checked;
    }
  }
  std::printf("polygon anchors: %d compared with brute force or the exact optimum, worst clearance ratio %.3f\n",
              checked, worstRatio);
  EXPECT_GT(checked, 2900);
}

TEST(LabelAnchorTest, ClassicTrickyShapes) {
  // The U's centroid and bounding-box centre are both in its notch.
  const Polygon u{uShape(10, 10, 1, 1), {}};
  const app::InteriorPoint pu = app::polygonLabelPoint(u);
  EXPECT_TRUE(insidePolygon(u, pu.point));
  EXPECT_GE(pu.clearance, 0.49);
  // A square annulus 2 wide: the centre is in the hole; the best points are in the corners, on
  // the diagonal at x where the outer edge and the hole's corner are equally far:
  // 10 - x = sqrt(2) (x - 8).
  const Polygon ring{{{-10, -10}, {10, -10}, {10, 10}, {-10, 10}}, {{{-8, -8}, {-8, 8}, {8, 8}, {8, -8}}}};
  const app::InteriorPoint pr = app::polygonLabelPoint(ring);
  EXPECT_TRUE(insidePolygon(ring, pr.point));
  const double corner = (10.0 + 8.0 * std::sqrt(2.0)) / (1.0 + std::sqrt(2.0));
  EXPECT_NEAR(pr.clearance, 10.0 - corner, 0.03 * (10.0 - corner));
  EXPECT_NEAR(std::abs(pr.point.x), corner, 0.05);
  EXPECT_NEAR(std::abs(pr.point.y), corner, 0.05);
  // A square: its centre, within the tolerance.
  const Polygon square{{{0, 0}, {4, 0}, {4, 4}, {0, 4}}, {}};
  const app::InteriorPoint ps = app::polygonLabelPoint(square, {.relativeTolerance = 0.0, .toleranceMetres = 1e-6});
  EXPECT_NEAR(ps.point.x, 2.0, 1e-5);
  EXPECT_NEAR(ps.point.y, 2.0, 1e-5);
  EXPECT_NEAR(ps.clearance, 2.0, 1e-6);
  // Degenerate rings give a point and no clearance, never a crash.
  EXPECT_EQ(app::polygonLabelPoint(Polygon{{{1, 1}, {1, 1}, {1, 1}}, {}}).clearance, 0.0);
  EXPECT_EQ(app::polygonLabelPoint(Polygon{{{0, 0}, {1, 1}, {2, 2}}, {}}).clearance, 0.0);
  EXPECT_EQ(app::polygonLabelPoint(Polygon{}).clearance, 0.0);
}

// ---- Lines ----

// Arc length from the line's start to the point p on it (the first piece within tol).
std::optional<double> arcLengthTo(const geo::LineString& line, const dvec2& p, double tol) {
  double along = 0.0;
  for (std::size_t i = 1; i < line.size(); ++i) {
    const dvec2 a = line[i - 1];
    const dvec2 b = line[i];
    const double len = glm::distance(a, b);
    const double t = len > 0 ? std::clamp(glm::dot(p - a, b - a) / (len * len), 0.0, 1.0) : 0.0;
    if (glm::distance(p, a + t * (b - a)) <= tol) return along + t * len;
    along += len;
  }
  return std::nullopt;
}

double length(const geo::LineString& l) {
  double s = 0.0;
  for (std::size_t i = 1; i < l.size(); ++i) s += glm::distance(l[i - 1], l[i]);
  return s;
}

TEST(LabelAnchorTest, LineAnchorsLieOnTheLongestPartAtHalfItsLength) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    geo::Feature f;
    const int parts = 1 + i % 3;
    for (int k = 0; k < parts; ++k) {
      geo::LineString line;
      dvec2 p = dvec2(u(rng), u(rng)) * 30000.0;
      const int n = 2 + static_cast<int>((u(rng) + 1.0) * 10);
      for (int j = 0; j < n; ++j) {
        line.push_back(p);
        if (u(rng) > 0.8) line.push_back(p);  // repeated points: pieces of no length
        p += dvec2(u(rng), u(rng)) * 100.0;
      }
      f.lines.push_back(line);
    }
    const std::optional<app::LabelAnchor> a = app::featureLabelAnchor(f);
    ASSERT_TRUE(a.has_value());
    const auto longest = std::max_element(f.lines.begin(), f.lines.end(),
                                          [](const auto& x, const auto& y) { return length(x) < length(y); });
    const double total = length(*longest);
    const std::optional<double> along = arcLengthTo(*longest, a->point, 1e-6);
    ASSERT_TRUE(along.has_value()) << "line " << i << ": anchor not on the longest part";
    EXPECT_NEAR(*along, 0.5 * total, 1e-6);
    EXPECT_NEAR(a->partSize, total, 1e-9 * total);
    EXPECT_EQ(a->clearance, 0.0);
  }
  EXPECT_EQ(app::lineMidpoint({{3, 4}}), dvec2(3, 4));
  EXPECT_EQ(app::lineMidpoint({{3, 4}, {3, 4}}), dvec2(3, 4));
  EXPECT_EQ(app::lineMidpoint({{0, 0}, {2, 0}, {2, 2}}), dvec2(2, 0));
}

TEST(LabelAnchorTest, PolygonsWinOverLinesAndEmptyFeaturesHaveNoAnchor) {
  geo::Feature f;
  EXPECT_FALSE(app::featureLabelAnchor(f).has_value());
  f.lines.push_back({{100, 100}, {200, 100}});
  f.polygons.push_back(Polygon{{{0, 0}, {2, 0}, {2, 2}, {0, 2}}, {}});
  const std::optional<app::LabelAnchor> a = app::featureLabelAnchor(f);
  ASSERT_TRUE(a.has_value());
  EXPECT_TRUE(insidePolygon(f.polygons[0], a->point));
  EXPECT_EQ(a->boundsMin, dvec2(0, 0));  // the extent covers the lines too
  EXPECT_EQ(a->boundsMax, dvec2(200, 100));
}

TEST(LabelTextTest, AttributesBecomeTextAndMissingOrEmptyOnesNone) {
  geo::Feature f;
  f.attributes = {{"name", std::string("Olinda")}, {"pop", std::int64_t{-3}}, {"ratio", 0.1}, {"whole", 3.0},
                  {"null", std::monostate{}},      {"empty", std::string()}};
  EXPECT_EQ(app::labelText(f, "name"), "Olinda");
  EXPECT_EQ(app::labelText(f, "pop"), "-3");
  EXPECT_EQ(app::labelText(f, "ratio"), "0.1");
  EXPECT_EQ(app::labelText(f, "whole"), "3");
  EXPECT_FALSE(app::labelText(f, "null").has_value());
  EXPECT_FALSE(app::labelText(f, "empty").has_value());
  EXPECT_FALSE(app::labelText(f, "missing").has_value());
}

TEST(LabelTextTest, LayerLabelsKeepFeaturesWithTextAndGeometry) {
  std::vector<geo::Feature> layer(3);
  layer[0].fid = 10;
  layer[0].attributes["name"] = std::string("a");
  layer[0].lines.push_back({{0, 0}, {4, 0}});
  layer[1].fid = 11;  // no text
  layer[1].lines.push_back({{0, 0}, {4, 0}});
  layer[2].fid = 12;
  layer[2].attributes["name"] = std::string("c");  // no geometry
  const std::vector<app::FeatureLabel> labels = app::layerLabels(layer, "name");
  ASSERT_EQ(labels.size(), 1u);
  EXPECT_EQ(labels[0].feature, 0u);
  EXPECT_EQ(labels[0].fid, 10);
  EXPECT_EQ(labels[0].text, "a");
  EXPECT_EQ(labels[0].anchor.point, dvec2(2, 0));
}

// ---- Placement ----

bool overlap(const ScreenRect& a, const ScreenRect& b, float gap) {
  return a.min.x < b.max.x + gap && b.min.x < a.max.x + gap && a.min.y < b.max.y + gap && b.min.y < a.max.y + gap;
}

bool insideRect(const ScreenRect& r, const ScreenRect& outer, float margin) {
  return r.min.x >= outer.min.x + margin && r.min.y >= outer.min.y + margin && r.max.x <= outer.max.x - margin &&
         r.max.y <= outer.max.y - margin;
}

std::vector<LabelCandidate> randomCandidates(std::mt19937& rng, std::size_t n, const ScreenRect& screen,
                                             int priorityLevels) {
  std::uniform_real_distribution<float> x(screen.min.x - 50.0F, screen.max.x + 50.0F);
  std::uniform_real_distribution<float> y(screen.min.y - 50.0F, screen.max.y + 50.0F);
  std::uniform_real_distribution<float> w(20.0F, 120.0F);
  std::uniform_real_distribution<float> h(12.0F, 18.0F);
  std::uniform_int_distribution<int> priority(0, priorityLevels - 1);
  std::vector<LabelCandidate> out;
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(
        {{x(rng), y(rng)}, {w(rng), h(rng)}, static_cast<double>(priority(rng)), static_cast<std::int64_t>(i * 7 + 3)});
  }
  return out;
}

// Everything placeLabels promises, checked against the candidates.
// `previous`: the ids placed in the previous frame, which had layout.stabilityBonus.
void checkPlacement(const std::vector<LabelCandidate>& candidates, const LabelLayout& layout,
                    const std::vector<PlacedLabel>& placed, const std::set<std::int64_t>& previous = {}) {
  constexpr float kEps = 1e-3F;
  std::vector<bool> accepted(candidates.size(), false);
  for (const PlacedLabel& p : placed) {
    ASSERT_LT(p.candidate, candidates.size());
    const LabelCandidate& c = candidates[p.candidate];
    EXPECT_EQ(p.id, c.id);
    EXPECT_FALSE(accepted[p.candidate]) << "placed twice";
    accepted[p.candidate] = true;
    EXPECT_NE(std::find(layout.positions.begin(), layout.positions.end(), p.position), layout.positions.end());
    const ScreenRect r = app::labelRect(c, p.position, layout.offset);
    EXPECT_EQ(r.min, p.rect.min);
    EXPECT_EQ(r.max, p.rect.max);
    EXPECT_TRUE(insideRect(p.rect, layout.screen, layout.margin - kEps));
    for (const ScreenRect& b : layout.blocked) EXPECT_FALSE(overlap(p.rect, b, layout.margin - kEps));
  }
  for (std::size_t i = 0; i < placed.size(); ++i) {
    for (std::size_t j = i + 1; j < placed.size(); ++j) {
      ASSERT_FALSE(overlap(placed[i].rect, placed[j].rect, layout.padding - kEps))
          << "labels " << placed[i].id << " and " << placed[j].id << " overlap";
    }
  }
  // Greedy: a candidate is left out only if each position leaves the usable screen, meets a
  // blocked rectangle or meets a label placed before it (higher priority, or equal and lower id).
  auto key = [&](const LabelCandidate& c) {
    return previous.count(c.id) != 0 ? c.priority + layout.stabilityBonus : c.priority;
  };
  auto before = [&](const PlacedLabel& p, const LabelCandidate& c) {
    const LabelCandidate& q = candidates[p.candidate];
    return key(q) > key(c) || (key(q) == key(c) && q.id < c.id);
  };
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (accepted[i]) continue;
    const LabelCandidate& c = candidates[i];
    for (const LabelPosition position : layout.positions) {
      const ScreenRect r = app::labelRect(c, position, layout.offset);
      const bool off = !insideRect(r, layout.screen, layout.margin + kEps);
      const bool blocked = std::any_of(layout.blocked.begin(), layout.blocked.end(),
                                       [&](const ScreenRect& b) { return overlap(r, b, layout.margin + kEps); });
      const bool taken = std::any_of(placed.begin(), placed.end(), [&](const PlacedLabel& p) {
        return before(p, c) && overlap(r, p.rect, layout.padding + kEps);
      });
      ASSERT_TRUE(off || blocked || taken) << "candidate " << c.id << " rejected though a position was free";
    }
  }
}

TEST(LabelPlacementTest, RandomCandidatesAreGreedyWithoutOverlapOnTheFreeScreen) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0F, 1.0F);
  for (int trial = 0; trial < 40; ++trial) {
    LabelLayout layout;
    layout.screen = {{u(rng) * 100.0F, u(rng) * 100.0F}, {800.0F + 1200.0F * u(rng), 500.0F + 600.0F * u(rng)}};
    layout.margin = 8.0F * u(rng);
    layout.padding = 6.0F * u(rng);
    layout.offset = 5.0F * u(rng);
    if (trial % 3 == 0) layout.positions = {LabelPosition::Centred};
    if (trial % 3 == 1) layout.positions = {LabelPosition::Left, LabelPosition::Below};
    // A panel on the left edge and a HUD box at the top right, partly off the screen.
    layout.blocked = {{layout.screen.min - glm::vec2(10.0F), {layout.screen.min.x + 250.0F, layout.screen.max.y}},
                      {{layout.screen.max.x - 200.0F, layout.screen.min.y - 5.0F},
                       {layout.screen.max.x + 5.0F, layout.screen.min.y + 90.0F}}};
    const std::vector<LabelCandidate> candidates =
        randomCandidates(rng, 300 + static_cast<std::size_t>(trial) * 40, layout.screen, trial % 2 == 0 ? 3 : 1000);
    const std::vector<PlacedLabel> placed = app::placeLabels(candidates, layout);
    SCOPED_TRACE(testing::Message() << "trial " << trial);
    EXPECT_FALSE(placed.empty());
    checkPlacement(candidates, layout, placed);

    // The same result whatever the candidates' order (ties broken by id).
    std::vector<LabelCandidate> shuffled = candidates;
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    const std::vector<PlacedLabel> again = app::placeLabels(shuffled, layout);
    ASSERT_EQ(again.size(), placed.size());
    for (std::size_t i = 0; i < placed.size(); ++i) {
      EXPECT_EQ(again[i].id, placed[i].id);
      EXPECT_EQ(again[i].position, placed[i].position);
    }

    // The next frame, the camera having moved, with a placer that remembers this one: the same
    // promises with the bonus counted in the priorities.
    layout.stabilityBonus = 1.5;
    app::LabelPlacer placer;
    std::set<std::int64_t> previous;
    for (const PlacedLabel& p : placer.place(candidates, layout)) previous.insert(p.id);
    std::vector<LabelCandidate> moved = candidates;
    for (LabelCandidate& c : moved) c.anchor += glm::vec2(3.0F * u(rng), -2.0F * u(rng));
    checkPlacement(moved, layout, placer.place(moved, layout), previous);
  }
}

LabelLayout screen800x600() {
  LabelLayout layout;
  layout.screen = {{0.0F, 0.0F}, {800.0F, 600.0F}};
  return layout;
}

TEST(LabelPlacementTest, HigherPriorityWinsAConflictAndEqualOnesGoByLowerId) {
  LabelLayout layout = screen800x600();
  layout.positions = {LabelPosition::Centred};
  const std::vector<LabelCandidate> c = {{{400, 300}, {80, 16}, 1.0, 1}, {{410, 305}, {80, 16}, 2.0, 2}};
  std::vector<PlacedLabel> placed = app::placeLabels(c, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].id, 2);
  const std::vector<LabelCandidate> tie = {{{410, 305}, {80, 16}, 1.0, 9}, {{400, 300}, {80, 16}, 1.0, 4}};
  placed = app::placeLabels(tie, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].id, 4);
  // With every position the loser moves around its anchor instead of going.
  layout = screen800x600();
  const std::vector<LabelCandidate> near = {{{400, 290}, {80, 16}, 1.0, 1}, {{410, 305}, {80, 16}, 2.0, 2}};
  placed = app::placeLabels(near, layout);
  ASSERT_EQ(placed.size(), 2u);
  EXPECT_EQ(placed[0].id, 2);
  EXPECT_EQ(placed[0].position, LabelPosition::Centred);
  EXPECT_NE(placed[1].position, LabelPosition::Centred);
}

TEST(LabelPlacementTest, EdgesMarginsPaddingAndBlockedRectangles) {
  LabelLayout layout = screen800x600();
  layout.margin = 10.0F;
  layout.padding = 5.0F;
  layout.offset = 2.0F;
  // Near the left edge a centred label would stick out: it goes to the right of the anchor.
  std::vector<PlacedLabel> placed = app::placeLabels(std::vector<LabelCandidate>{{{15, 300}, {60, 14}, 0, 1}}, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].position, LabelPosition::Right);
  EXPECT_FLOAT_EQ(placed[0].rect.min.x, 17.0F);
  // Off the screen: left out.
  EXPECT_TRUE(app::placeLabels(std::vector<LabelCandidate>{{{-100, 300}, {60, 14}, 0, 1}}, layout).empty());
  EXPECT_TRUE(app::placeLabels(
                  std::vector<LabelCandidate>{{{std::numeric_limits<float>::quiet_NaN(), 300}, {60, 14}, 0, 1}}, layout)
                  .empty());
  // Under the panel: left out; beside it: kept clear of it by the margin.
  layout.blocked = {{{0, 0}, {200, 600}}};
  EXPECT_TRUE(app::placeLabels(std::vector<LabelCandidate>{{{100, 300}, {60, 14}, 0, 1}}, layout).empty());
  placed = app::placeLabels(std::vector<LabelCandidate>{{{215, 300}, {20, 14}, 0, 1}}, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_GE(placed[0].rect.min.x, 210.0F);
  // Two labels exactly `padding` apart both stay; closer, one goes.
  layout.blocked.clear();
  layout.positions = {LabelPosition::Centred};
  const std::vector<LabelCandidate> apart = {{{300, 300}, {100, 10}, 1, 1}, {{405, 300}, {100, 10}, 0, 2}};
  EXPECT_EQ(app::placeLabels(apart, layout).size(), 2u);
  const std::vector<LabelCandidate> close = {{{300, 300}, {100, 10}, 1, 1}, {{404, 300}, {100, 10}, 0, 2}};
  EXPECT_EQ(app::placeLabels(close, layout).size(), 1u);
  // Broken input places nothing or a point, never crashes: no screen, sizes NaN or negative.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  LabelLayout broken = layout;
  broken.screen.max.x = nan;
  EXPECT_TRUE(app::placeLabels(apart, broken).empty());
  const std::vector<LabelCandidate> odd = {{{300, 300}, {nan, 10}, 1, 1}, {{500, 300}, {-5, -5}, 0, 2}};
  placed = app::placeLabels(odd, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].rect.min, placed[0].rect.max);  // a negative size counts as none
}

TEST(LabelPlacementTest, TheStabilityBonusKeepsAPreviouslyPlacedLabel) {
  LabelLayout layout = screen800x600();
  layout.positions = {LabelPosition::Centred};
  // Frame 1: b is more important. Frame 2: the camera moved, a is slightly more important.
  const std::vector<LabelCandidate> frame1 = {{{400, 300}, {80, 16}, 10.0, 1}, {{405, 300}, {80, 16}, 11.0, 2}};
  const std::vector<LabelCandidate> frame2 = {{{398, 300}, {80, 16}, 11.0, 1}, {{403, 300}, {80, 16}, 10.5, 2}};
  std::vector<PlacedLabel> placed = app::placeLabels(frame1, layout);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].id, 2);
  EXPECT_EQ(app::placeLabels(frame2, layout)[0].id, 1);  // without the bonus it flickers over to a
  layout.stabilityBonus = 1.0;
  const std::vector<std::int64_t> previous = {placed[0].id};
  EXPECT_EQ(app::placeLabels(frame2, layout, previous)[0].id, 2);
  // A larger change in priority than the bonus does switch.
  const std::vector<LabelCandidate> frame3 = {{{398, 300}, {80, 16}, 13.0, 1}, {{403, 300}, {80, 16}, 10.5, 2}};
  EXPECT_EQ(app::placeLabels(frame3, layout, previous)[0].id, 1);

  // A placer kept between frames remembers by itself, and keeps each label where it was.
  layout = screen800x600();
  layout.stabilityBonus = 1.0;
  app::LabelPlacer placer;
  const std::vector<LabelCandidate> crowded = {{{400, 310}, {80, 16}, 5.0, 1}, {{400, 300}, {80, 16}, 1.0, 2}};
  const std::vector<PlacedLabel>& first = placer.place(crowded, layout);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_EQ(first[1].id, 2);
  EXPECT_EQ(first[1].position, LabelPosition::Above);
  const std::vector<LabelCandidate> alone = {crowded[1]};
  const std::vector<PlacedLabel>& second = placer.place(alone, layout);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(second[0].position, LabelPosition::Above);  // not back to the centre
  EXPECT_EQ(app::placeLabels(alone, layout)[0].position, LabelPosition::Centred);
  placer.forget();
  EXPECT_EQ(placer.place(alone, layout)[0].position, LabelPosition::Centred);
}

// Not a timed assertion: prints what placement costs, per frame, for a placer kept between frames
// while the camera pans (wall time, and this thread's CPU time, which a busy machine inflates less).
TEST(LabelPlacementTest, TimingOfTenThousandCandidates) {
  auto cpuNow = [] {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
  };
  for (const std::size_t count : {2000u, 10000u}) {
    std::mt19937 rng(5);
    LabelLayout layout;
    layout.screen = {{0.0F, 0.0F}, {1920.0F, 1080.0F}};
    layout.blocked = {{{0, 0}, {320, 1080}}, {{1600, 0}, {1920, 120}}};
    layout.stabilityBonus = 1.0;
    std::vector<LabelCandidate> candidates = randomCandidates(rng, count, layout.screen, 1 << 20);
    app::LabelPlacer placer;
    std::vector<double> wall;
    std::vector<double> cpu;
    std::size_t placed = 0;
    for (int frame = 0; frame < 30; ++frame) {
      for (LabelCandidate& c : candidates) c.anchor += glm::vec2(0.5F, 0.25F);  // the camera pans
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpuNow();
      placed = placer.place(candidates, layout).size();
      cpu.push_back(cpuNow() - c0);
      wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(wall.begin(), wall.end());
    std::sort(cpu.begin(), cpu.end());
    std::printf(
        "placement of %5zu candidates on 1920x1080 (5 positions, 2 blocked): %zu placed; per frame CPU "
        "median %.3f ms, max %.3f ms; wall median %.3f ms\n",
        count, placed, cpu[cpu.size() / 2], cpu.back(), wall[wall.size() / 2]);
    EXPECT_GT(placed, 100u);
  }
}

}  // namespace
}  // namespace gis::test
