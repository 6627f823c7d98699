// The classified search of the logical selection (vector_overlay/logical_selection.hpp): it
// selects the same features with the same fully-inside flags as testing every sample, over
// random cameras, lassos and operator chains (Invert, Xor and Subtract included) on a small
// synthetic scene; and at a low camera over large features it tests few samples.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <glm/matrix.hpp>
#include <glm/trigonometric.hpp>

#include "gfx/camera.hpp"
#include "vector_overlay/logical_selection.hpp"

namespace gis::test {
namespace {

using overlay::FeatureSelection;
using overlay::Lasso;
using overlay::SelectionOp;
using overlay::SelectionStep;

constexpr int kWidth = 320, kHeight = 240;

glm::dmat4 cameraLookingAt(const glm::dvec3& eye, const glm::dvec3& target) {
  return gfx::reversedInfinitePerspective(glm::radians(50.0), double(kWidth) / kHeight, 1.0) *
         gfx::lookAt(eye, target, glm::dvec3(0, 0, 1));
}

Lasso lassoWith(const glm::dmat4& viewProj, std::vector<glm::dvec2> points,
                double distance = std::numeric_limits<double>::infinity()) {
  Lasso l;
  l.points = std::move(points);
  l.viewProj = viewProj;
  l.width = kWidth;
  l.height = kHeight;
  l.distance = distance;
  return l;
}

/// Rolling hills with a corner of nodata (x > 800 and y > 600).
double hills(const glm::dvec2& p) {
  if (p.x > 800.0 && p.y > 600.0) return std::numeric_limits<double>::quiet_NaN();
  return 30.0 + 25.0 * std::sin(p.x / 170.0) * std::cos(p.y / 230.0) + 10.0 * std::sin((p.x + p.y) / 90.0);
}

/// Bounds of `hills` over a box from its slope (|∇h| < 0.35); none in the nodata corner.
HeightBounds hillBounds(const glm::dvec2& lo, const glm::dvec2& hi) {
  if (lo.x > 800.0 && lo.y > 600.0) return {1.0, 0.0};
  const glm::dvec2 c = 0.5 * (lo + hi);
  const double z = 30.0 + 25.0 * std::sin(c.x / 170.0) * std::cos(c.y / 230.0) + 10.0 * std::sin((c.x + c.y) / 90.0);
  const double reach = 0.35 * 0.5 * glm::length(hi - lo) + 1e-6;
  return {z - reach, z + reach};
}

/// Polygons (some with a hole, some of two parts) and lines (metres and pixels, every join and
/// cap) over [-1000, 1000]².
struct RandomLayers {
  std::vector<geo::Feature> polygons, lines;
  std::vector<overlay::LineShape> shapes;
};

RandomLayers randomLayers(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  RandomLayers out;
  const auto star = [&](const glm::dvec2& c, double r, int n) {
    geo::Ring ring;
    for (int k = 0; k < n; ++k) {
      const double a = 6.283 * k / n, rr = r * (0.5 + 0.5 * unit(rng));
      ring.push_back(c + rr * glm::dvec2(std::cos(a), std::sin(a)));
    }
    return ring;
  };
  for (int i = 0; i < 30; ++i) {
    const glm::dvec2 c(-1000 + 2000 * unit(rng), -1000 + 2000 * unit(rng));
    const double r = i % 10 == 0 ? 600.0 : 5.0 + 300.0 * unit(rng) * unit(rng);
    geo::Feature f;
    f.polygons.push_back({star(c, r, 4 + i % 9), {}});
    if (i % 4 == 0) f.polygons[0].holes.push_back(star(c, 0.2 * r, 4));
    if (i % 5 == 0) f.polygons.push_back({star(c + glm::dvec2(2.5 * r, 0), 0.5 * r, 5), {}});
    out.polygons.push_back(std::move(f));
  }
  for (int i = 0; i < 30; ++i) {
    geo::Feature f;
    geo::LineString line{glm::dvec2(-1000 + 2000 * unit(rng), -1000 + 2000 * unit(rng))};
    double heading = 6.283 * unit(rng);
    for (int k = 0; k < 1 + i % 6; ++k) {
      heading += 2.0 * (unit(rng) - 0.5);
      line.push_back(line.back() + (10.0 + 300.0 * unit(rng)) * glm::dvec2(std::cos(heading), std::sin(heading)));
    }
    f.lines.push_back(std::move(line));
    out.lines.push_back(std::move(f));
    overlay::LineShape shape;
    shape.width = 2.0 + 20.0 * unit(rng);
    shape.join = static_cast<overlay::LineJoin>(i % 3);
    shape.cap = static_cast<overlay::LineCap>((i / 3) % 3);
    if (i % 4 == 0) {  // in pixels, at most 30 m wide
      shape.widthPixels = 3.0;
      shape.width = 30.0;
      shape.minWidth = 0.5;
    }
    out.shapes.push_back(shape);
  }
  return out;
}

/// A random star of 5–40 vertices in pixels (concave; self-crossing when scrambled).
std::vector<glm::dvec2> randomLassoPolygon(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const glm::dvec2 c(kWidth * unit(rng), kHeight * unit(rng));
  const double r = 20.0 + 200.0 * unit(rng);
  const int n = 5 + static_cast<int>(35 * unit(rng));
  std::vector<glm::dvec2> points;
  for (int k = 0; k < n; ++k) {
    const double a = 6.283 * k / n, rr = r * (0.3 + 0.7 * unit(rng));
    points.push_back(c + rr * glm::dvec2(std::cos(a), std::sin(a)));
  }
  if (unit(rng) < 0.2) std::swap(points[0], points[static_cast<std::size_t>(n / 2)]);
  return points;
}

std::vector<SelectionStep> randomChain(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const SelectionOp ops[] = {SelectionOp::Or, SelectionOp::And, SelectionOp::Xor, SelectionOp::Subtract,
                             SelectionOp::Invert};
  std::vector<SelectionStep> steps;
  const int length = 1 + static_cast<int>(5 * unit(rng));
  for (int k = 0; k < length; ++k) {
    const SelectionOp op = k == 0 ? SelectionOp::Single : ops[static_cast<std::size_t>(unit(rng) * 5)];
    if (op == SelectionOp::Invert) {
      steps.push_back({op, {}});
      continue;
    }
    // Eyes from 15 m to 1500 m over the ground, looking at a ground point, often obliquely.
    const glm::dvec2 target(-900 + 1800 * unit(rng), -900 + 1800 * unit(rng));
    const double heading = 6.283 * unit(rng);
    const glm::dvec2 away = (100.0 + 1500.0 * unit(rng)) * glm::dvec2(std::cos(heading), std::sin(heading));
    const double ground = std::isfinite(hills(target)) ? hills(target) : 30.0;
    const glm::dvec3 eye(target + away, ground + 15.0 + 1500.0 * unit(rng) * unit(rng));
    const double distance = unit(rng) < 0.25 ? 300.0 + 2000.0 * unit(rng) : std::numeric_limits<double>::infinity();
    steps.push_back(
        {op, lassoWith(cameraLookingAt(eye, glm::dvec3(target, ground)), randomLassoPolygon(rng), distance)});
  }
  return steps;
}

void expectSameAnswers(const std::vector<FeatureSelection>& searched, const std::vector<FeatureSelection>& all,
                       const std::string& what) {
  ASSERT_EQ(searched.size(), all.size()) << what;
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(searched[i].feature, all[i].feature) << what;
    EXPECT_EQ(searched[i].fullyInside, all[i].fullyInside) << what << " feature " << all[i].feature;
    EXPECT_LE(searched[i].samples, all[i].samples) << what;
    EXPECT_EQ(searched[i].spacing, all[i].spacing) << what;
  }
}

/// The ground point at height z seen through pixel `pixel` of a camera.
glm::dvec3 groundThrough(const glm::dmat4& viewProj, const glm::dvec2& pixel, double z) {
  const glm::dmat4 inverse = glm::inverse(viewProj);
  const glm::dvec2 ndc(2.0 * pixel.x / kWidth - 1.0, 1.0 - 2.0 * pixel.y / kHeight);
  const glm::dvec4 a = inverse * glm::dvec4(ndc, 1.0, 1.0), b = inverse * glm::dvec4(ndc, 0.5, 1.0);
  const glm::dvec3 p = glm::dvec3(a) / a.w, q = glm::dvec3(b) / b.w;
  return p + (q - p) * ((z - p.z) / (q.z - p.z));
}

TEST(BoundedSelection, ClassifiedBoxesAgreeWithSelectedAt) {
  // Boxes from a millimetre to 300 m, most of them on a lasso's wall, where a classification
  // that is not conservative would show.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t known = 0, boxes = 0, onWall = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const std::vector<SelectionStep> steps = randomChain(rng);
    const overlay::SelectionEvaluator evaluator(steps);
    for (int b = 0; b < 300; ++b) {
      const SelectionStep& step = steps[static_cast<std::size_t>(unit(rng) * static_cast<double>(steps.size()))];
      if (step.op == SelectionOp::Invert) continue;
      const std::vector<glm::dvec2>& ring = step.lasso.points;
      const std::size_t e = static_cast<std::size_t>(unit(rng) * static_cast<double>(ring.size()));
      const glm::dvec2 pixel = ring[e] + unit(rng) * (ring[(e + 1) % ring.size()] - ring[e]);
      const glm::dvec3 centre = groundThrough(step.lasso.viewProj, pixel, 60.0 * unit(rng));
      if (!std::isfinite(centre.x) || glm::length(centre) > 5000.0) continue;
      const glm::dvec3 half =
          std::pow(10.0, -3.0 + 5.5 * unit(rng) * unit(rng)) * glm::dvec3(unit(rng), unit(rng), unit(rng) * unit(rng));
      const glm::dvec3 lo = centre - half, hi = centre + half;
      std::vector<overlay::SelectionEvaluator::Side> sides;
      const std::optional<bool> answer = evaluator.classify(lo, hi, sides);
      ++boxes;
      known += answer ? 1u : 0u;
      for (int i = 0; i < 64; ++i) {
        const glm::dvec3 t =
            i < 8 ? glm::dvec3(i & 1, (i >> 1) & 1, (i >> 2) & 1) : glm::dvec3(unit(rng), unit(rng), unit(rng));
        const glm::dvec3 p = lo + (hi - lo) * t;
        const bool selected = overlay::selectedAt(steps, p);
        ASSERT_EQ(evaluator.selectedWith(p, sides), selected) << "trial " << trial << " box " << b;
        if (answer) {
          ASSERT_EQ(*answer, selected) << "trial " << trial << " box " << b;
        }
        for (std::size_t k = 0; k < steps.size(); ++k) {
          if (sides[k] == overlay::SelectionEvaluator::Side::Unknown || steps[k].op == SelectionOp::Invert) continue;
          ASSERT_EQ(sides[k] == overlay::SelectionEvaluator::Side::Inside, overlay::insideLasso(steps[k].lasso, p))
              << "trial " << trial << " box " << b << " step " << k;
        }
      }
      onWall += answer ? 0u : 1u;
    }
  }
  EXPECT_GT(boxes, 5000u);
  EXPECT_GT(known, boxes / 4);   // small boxes off the edge are answered
  EXPECT_GT(onWall, boxes / 4);  // large ones across it are not
}

TEST(BoundedSelection, SameAnswersAsEverySampleOnRandomChains) {
  std::mt19937 rng(25);
  std::size_t selected = 0, fullyInside = 0, searchedSamples = 0, allSamples = 0, invertedFullyInside = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const RandomLayers layers = randomLayers(rng);
    const std::vector<SelectionStep> steps = randomChain(rng);
    overlay::FeatureSelectionOptions options;
    options.sampleSpacing = 5.0;
    options.minHeight = -6.0;  // 30 ± 35
    options.maxHeight = 66.0;
    if (steps.front().op != SelectionOp::Invert)
      options.scale = overlay::pixelScaleOf(steps.front().lasso.viewProj, kHeight);
    overlay::ReferenceLayer polygons{"areas", overlay::LayerKind::Polygon, &layers.polygons, {}, {}};
    overlay::ReferenceLayer lines{"roads", overlay::LayerKind::Line, &layers.lines, layers.shapes, {}};
    polygons.visible.assign(layers.polygons.size(), true);
    polygons.visible[3] = false;  // hidden: never selected
    for (const overlay::ReferenceLayer* layer : {&polygons, &lines}) {
      const std::string what = "trial " + std::to_string(trial) + " " + layer->name;
      overlay::FeatureSelectionOptions every = options;
      every.exhaustive = true;
      const std::vector<FeatureSelection> all = overlay::selectFeatures(*layer, steps, hills, every);
      // With the terrain's bounds over each block, and with its global range only.
      overlay::FeatureSelectionOptions bounded = options;
      bounded.heightBounds = hillBounds;
      const std::vector<FeatureSelection> searched = overlay::selectFeatures(*layer, steps, hills, bounded);
      expectSameAnswers(searched, all, what + " (block bounds)");
      expectSameAnswers(overlay::selectFeatures(*layer, steps, hills, options), all, what + " (global range)");
      for (const FeatureSelection& f : all) {
        selected += 1;
        fullyInside += f.fullyInside ? 1u : 0u;
        allSamples += f.samples;
        const bool inverted = std::any_of(steps.begin(), steps.end(), [](const SelectionStep& s) {
          return s.op == SelectionOp::Invert || s.op == SelectionOp::Subtract || s.op == SelectionOp::Xor;
        });
        invertedFullyInside += inverted && f.fullyInside ? 1u : 0u;
      }
      for (const FeatureSelection& f : searched) searchedSamples += f.samples;
    }
  }
  // The chains select, fully and partly, also through Invert / Subtract / Xor.
  EXPECT_GT(selected, 300u);
  EXPECT_GT(fullyInside, 60u);
  EXPECT_LT(fullyInside, selected - 60);
  EXPECT_GT(invertedFullyInside, 20u);
  EXPECT_LT(searchedSamples, allSamples / 10);
}

TEST(BoundedSelection, FewSamplesAtALowCameraOverLargeFeatures) {
  // An eye 20 m over flat ground looking obliquely; a lasso over most of the view.
  const glm::dmat4 viewProj = cameraLookingAt(glm::dvec3(0, -300, 20), glm::dvec3(0, 0, 0));
  const std::vector<SelectionStep> steps = {
      {SelectionOp::Single, lassoWith(viewProj, {{10, 10}, {310, 10}, {310, 230}, {10, 230}})}};
  std::vector<geo::Feature> features(2);
  // A 6 km square under the whole view and beyond; a 40 m square around the target.
  features[0].polygons.push_back({{{-3000, -3000}, {3000, -3000}, {3000, 3000}, {-3000, 3000}}, {}});
  features[1].polygons.push_back({{{-20, -20}, {20, -20}, {20, 20}, {-20, 20}}, {}});
  for (const glm::dvec2& corner : features[1].polygons[0].outer) {
    const glm::dvec4 c = viewProj * glm::dvec4(corner, 0.0, 1.0);
    const glm::dvec2 pixel((c.x / c.w + 1.0) * 0.5 * kWidth, (1.0 - c.y / c.w) * 0.5 * kHeight);
    ASSERT_TRUE(pixel.x > 20 && pixel.x < 300 && pixel.y > 20 && pixel.y < 220) << pixel.x << ", " << pixel.y;
  }
  const overlay::ReferenceLayer layer{"areas", overlay::LayerKind::Polygon, &features, {}, {}};
  const overlay::TerrainHeightFunction flat = [](const glm::dvec2&) { return 0.0; };
  overlay::FeatureSelectionOptions options;
  options.sampleSpacing = 0.25;
  options.maxGridSamplesPerFeature = std::size_t{1} << 40;  // no coarser grid: 24000² samples
  options.minHeight = 0.0;
  options.maxHeight = 0.0;
  std::size_t tested = 0;
  options.testedSamples = &tested;
  const std::vector<FeatureSelection> s = overlay::selectFeatures(layer, steps, flat, options);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_FALSE(s[0].fullyInside);
  EXPECT_TRUE(s[1].fullyInside);  // its 25,600 grid samples answered by blocks
  EXPECT_EQ(s[0].spacing, 0.25);
  EXPECT_LE(s[0].samples, 100u);
  EXPECT_LE(s[1].samples, 100u);
  EXPECT_LE(tested, 200u);
  // Inverted: the large square is selected outside the lasso, the small one no longer.
  std::vector<SelectionStep> inverted = steps;
  inverted.push_back({SelectionOp::Invert, {}});
  const std::vector<FeatureSelection> t = overlay::selectFeatures(layer, inverted, flat, options);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].feature, 0u);
  EXPECT_FALSE(t[0].fullyInside);
  EXPECT_LE(t[0].samples, 100u);
  // A hole cut into the view by Subtract: the small square is then partly selected, found near
  // the hole's walls.
  std::vector<SelectionStep> cut = steps;
  cut.push_back({SelectionOp::Subtract, lassoWith(viewProj, {{150, 110}, {170, 110}, {170, 130}, {150, 130}})});
  const std::vector<FeatureSelection> u = overlay::selectFeatures(layer, cut, flat, options);
  ASSERT_EQ(u.size(), 2u);
  EXPECT_FALSE(u[1].fullyInside);
  EXPECT_LE(u[1].samples, 25600u / 4);
}

}  // namespace
}  // namespace gis::test
