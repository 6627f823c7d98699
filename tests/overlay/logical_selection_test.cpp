// The logical selection (vector_overlay/logical_selection.hpp): the batched evaluator answers
// exactly as selectedAt on every point, with its box test skipping lassos far away; DEM posts
// and features are selected by the rules of the header — any part, fully inside, holes,
// lines, Invert, no terrain, hidden features.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <glm/trigonometric.hpp>

#include "gfx/camera.hpp"
#include "vector_overlay/logical_selection.hpp"

namespace gis::test {
namespace {

using overlay::Lasso;
using overlay::SelectionOp;
using overlay::SelectionStep;

constexpr int kWidth = 400, kHeight = 300;

glm::dmat4 cameraLookingAt(const glm::dvec3& eye, const glm::dvec3& target) {
  const glm::dvec3 up =
      std::abs(eye.x - target.x) + std::abs(eye.y - target.y) < 1e-9 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
  return gfx::reversedInfinitePerspective(glm::radians(60.0), double(kWidth) / kHeight, 1.0) *
         gfx::lookAt(eye, target, up);
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

/// The lasso of a straight-down camera 1000 m over the origin: pixel (200, 150) is the origin
/// and, at height 0, one pixel is 2·1000·tan(30°)/300 ≈ 3.85 m, x east and y south.
const glm::dmat4& topDown() {
  static const glm::dmat4 m = cameraLookingAt(glm::dvec3(0, 0, 1000), glm::dvec3(0, 0, 0));
  return m;
}
double metresPerPixel() { return 2.0 * 1000.0 * std::tan(glm::radians(30.0)) / kHeight; }
glm::dvec2 pixelOf(const glm::dvec2& ground) {
  return glm::dvec2(200.0, 150.0) + glm::dvec2(ground.x, -ground.y) / metresPerPixel();
}
/// A lasso square covering the ground square [lo, hi] at height 0.
Lasso groundSquare(const glm::dvec2& lo, const glm::dvec2& hi) {
  return lassoWith(topDown(), {pixelOf(lo), pixelOf({hi.x, lo.y}), pixelOf(hi), pixelOf({lo.x, hi.y})});
}

geo::Feature squareFeature(const glm::dvec2& lo, const glm::dvec2& hi) {
  geo::Feature f;
  f.polygons.push_back({{lo, {hi.x, lo.y}, hi, {lo.x, hi.y}}, {}});
  return f;
}

const overlay::TerrainHeightFunction kFlat = [](const glm::dvec2&) { return 0.0; };

TEST(LogicalSelection, EvaluatorAgreesWithSelectedAtAndSkipsFarLassos) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const SelectionOp ops[] = {SelectionOp::Or, SelectionOp::And, SelectionOp::Xor, SelectionOp::Subtract,
                             SelectionOp::Invert};
  std::size_t points = 0, selected = 0, skippedTests = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<SelectionStep> steps;
    const int length = 1 + trial % 12;
    for (int k = 0; k < length; ++k) {
      const glm::dvec3 eye(-2000 + 4000 * unit(rng), -2000 + 4000 * unit(rng), 50 + 2000 * unit(rng));
      std::vector<glm::dvec2> poly;
      const glm::dvec2 c(kWidth * unit(rng), kHeight * unit(rng));
      for (int v = 0; v < 7; ++v) poly.push_back(c + glm::dvec2(120 * (unit(rng) - 0.5), 120 * (unit(rng) - 0.5)));
      steps.push_back({k == 0 ? SelectionOp::Single : ops[static_cast<std::size_t>(unit(rng) * 5)],
                       lassoWith(cameraLookingAt(eye, glm::dvec3(0, 0, 0)), poly,
                                 unit(rng) < 0.3 ? 500 + 3000 * unit(rng) : std::numeric_limits<double>::infinity())});
    }
    const overlay::SelectionEvaluator evaluator(steps);
    // Batches: small clusters anywhere (many lassos miss them), and one spread batch.
    for (int batch = 0; batch < 20; ++batch) {
      const glm::dvec3 centre(-3000 + 6000 * unit(rng), -3000 + 6000 * unit(rng), -200 + 1500 * unit(rng));
      const double radius = batch == 0 ? 3000.0 : 5.0 + 200.0 * unit(rng);
      std::vector<glm::dvec3> pts;
      for (int i = 0; i < 200; ++i)
        pts.push_back(centre + radius * glm::dvec3(unit(rng) - 0.5, unit(rng) - 0.5, 0.3 * (unit(rng) - 0.5)));
      std::vector<std::uint8_t> out;
      evaluator.evaluate(pts, out);
      ASSERT_EQ(out.size(), pts.size());
      for (std::size_t i = 0; i < pts.size(); ++i) {
        ASSERT_EQ(out[i] != 0, overlay::selectedAt(steps, pts[i])) << "trial " << trial << " point " << i;
        selected += out[i];
      }
      points += pts.size();
      // The box test: a constant answer must be the answer at every point.
      glm::dvec3 lo(1e300), hi(-1e300);
      for (const glm::dvec3& p : pts) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
      if (const std::optional<bool> constant = evaluator.constantOver(lo, hi)) {
        ++skippedTests;
        for (const glm::dvec3& p : pts) ASSERT_EQ(overlay::selectedAt(steps, p), *constant);
      }
    }
  }
  EXPECT_GT(selected, points / 50);
  EXPECT_LT(selected, points - points / 50);
  EXPECT_GT(skippedTests, 100u);  // the box test does skip
}

TEST(LogicalSelection, PostsAreTheSelectedPointsOfTheGrid) {
  overlay::PostGrid grid;
  grid.width = 97;
  grid.height = 71;
  grid.origin = glm::dvec2(-480, 350);
  grid.step = glm::dvec2(10, -10);
  grid.heightAt = [](int c, int r) {
    if (c > 40 && c < 50 && r > 10 && r < 20) return std::numeric_limits<double>::quiet_NaN();  // nodata
    return 30.0 * std::sin(c * 0.2) * std::cos(r * 0.15);
  };
  const std::vector<SelectionStep> steps = {
      {SelectionOp::Single, groundSquare({-300, -200}, {200, 250})},
      {SelectionOp::Subtract, groundSquare({-100, -50}, {50, 60})},
      {SelectionOp::Or, lassoWith(cameraLookingAt(glm::dvec3(900, -900, 400), glm::dvec3(0, 0, 0)),
                                  {{100, 100}, {300, 120}, {200, 260}})},
  };
  const overlay::PostSelection s = overlay::selectPosts(grid, steps);
  ASSERT_EQ(s.mask.size(), std::size_t{97 * 71});
  std::size_t expected = 0, withHeight = 0;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const double z = grid.heightAt(c, r);
      const bool want =
          std::isfinite(z) && overlay::selectedAt(steps, glm::dvec3(grid.origin + glm::dvec2(c, r) * grid.step, z));
      EXPECT_EQ(s.mask[static_cast<std::size_t>(r * grid.width + c)] != 0, want) << c << ", " << r;
      expected += want ? 1u : 0u;
      withHeight += std::isfinite(z) ? 1u : 0u;
    }
  }
  EXPECT_EQ(s.selected, expected);
  EXPECT_EQ(s.posts, withHeight);
  EXPECT_GT(expected, 500u);
  EXPECT_LT(expected, withHeight - 500);
}

TEST(LogicalSelection, FeaturesAnyPartAndFullyInside) {
  std::vector<geo::Feature> features = {
      squareFeature({-50, -50}, {50, 50}),    // 0: fully inside the lasso
      squareFeature({80, -20}, {160, 20}),    // 1: straddles the lasso's east edge at x = 100
      squareFeature({300, 300}, {350, 350}),  // 2: outside
      squareFeature({-90, 60}, {-60, 90}),    // 3: inside but hidden
  };
  // 4: a polygon with a hole that holds the whole lasso: only its hole meets the volume.
  geo::Feature ring = squareFeature({-400, -400}, {400, 400});
  ring.polygons[0].holes.push_back({{-150, -150}, {150, -150}, {150, 150}, {-150, 150}});
  features.push_back(ring);
  // 5: a tiny polygon, much smaller than the sample spacing, inside the lasso.
  features.push_back(squareFeature({10.0, 70.0}, {10.5, 70.4}));
  overlay::ReferenceLayer layer{"areas", overlay::LayerKind::Polygon, &features, {}, {}};
  layer.visible = {true, true, true, false, true, true};
  const std::vector<SelectionStep> steps = {{SelectionOp::Single, groundSquare({-100, -100}, {100, 100})}};
  overlay::FeatureSelectionOptions options;
  options.sampleSpacing = 4.0;
  const std::vector<overlay::FeatureSelection> s = overlay::selectFeatures(layer, steps, kFlat, options);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].feature, 0u);
  EXPECT_TRUE(s[0].fullyInside);
  EXPECT_EQ(s[0].samples, s[0].selectedSamples);
  EXPECT_EQ(s[1].feature, 1u);
  EXPECT_FALSE(s[1].fullyInside);
  EXPECT_GT(s[1].selectedSamples, 0u);
  EXPECT_LT(s[1].selectedSamples, s[1].samples);
  EXPECT_EQ(s[2].feature, 5u);  // found through its vertices
  EXPECT_TRUE(s[2].fullyInside);

  // Invert: the complement; the straddling square stays partly selected, the inside one goes.
  std::vector<SelectionStep> inverted = steps;
  inverted.push_back({SelectionOp::Invert, {}});
  const std::vector<overlay::FeatureSelection> t = overlay::selectFeatures(layer, inverted, kFlat, options);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].feature, 1u);
  EXPECT_FALSE(t[0].fullyInside);
  EXPECT_EQ(t[1].feature, 2u);
  EXPECT_TRUE(t[1].fullyInside);
  EXPECT_EQ(t[2].feature, 4u);
  EXPECT_TRUE(t[2].fullyInside);  // every sample of the ring lies outside the small lasso

  // No terrain under a feature: nothing of it is on the terrain, so nothing is selected.
  const overlay::TerrainHeightFunction westOnly = [](const glm::dvec2& p) {
    return p.x < 70.0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  };
  const std::vector<overlay::FeatureSelection> u = overlay::selectFeatures(layer, steps, westOnly, options);
  ASSERT_EQ(u.size(), 2u);
  EXPECT_EQ(u[0].feature, 0u);
  EXPECT_EQ(u[1].feature, 5u);

  // The height range lets far features be skipped and blocks answered whole; the answer is the
  // same, found with fewer samples tested.
  options.minHeight = -10.0;
  options.maxHeight = 10.0;
  const std::vector<overlay::FeatureSelection> v = overlay::selectFeatures(layer, steps, kFlat, options);
  ASSERT_EQ(v.size(), s.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    EXPECT_EQ(v[i].feature, s[i].feature);
    EXPECT_EQ(v[i].fullyInside, s[i].fullyInside);
    EXPECT_LE(v[i].samples, s[i].samples);
  }
  EXPECT_LT(v[0].samples, s[0].samples / 10);  // the square inside: its blocks answered whole
  // Every sample tested: the same answer again, from every sample.
  options.exhaustive = true;
  const std::vector<overlay::FeatureSelection> w = overlay::selectFeatures(layer, steps, kFlat, options);
  ASSERT_EQ(w.size(), s.size());
  for (std::size_t i = 0; i < w.size(); ++i) {
    EXPECT_EQ(w[i].feature, s[i].feature);
    EXPECT_EQ(w[i].fullyInside, s[i].fullyInside);
    EXPECT_GE(w[i].samples, s[i].samples);
  }
  EXPECT_EQ(w[0].samples, w[0].selectedSamples);
}

TEST(LogicalSelection, LinesCountTheirWidthAndTheTerrainHeight) {
  // A road passing 3 m east of the lasso's east edge (x = 100): selected only when its half
  // width reaches over the edge.
  std::vector<geo::Feature> features(1);
  features[0].lines.push_back({{103, -300}, {103, 300}});
  overlay::ReferenceLayer layer{"roads", overlay::LayerKind::Line, &features, {}, {}};
  overlay::LineShape shape;
  shape.width = 4.0;  // half 2 m: stops 1 m short of the edge
  layer.shapes = {shape};
  const std::vector<SelectionStep> steps = {{SelectionOp::Single, groundSquare({-100, -100}, {100, 100})}};
  EXPECT_TRUE(overlay::selectFeatures(layer, steps, kFlat).empty());
  layer.shapes[0].width = 8.0;  // half 4 m: 1 m over the edge
  const std::vector<overlay::FeatureSelection> s = overlay::selectFeatures(layer, steps, kFlat);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_FALSE(s[0].fullyInside);
  // The same road on a plateau 500 m up, seen from 1000 m: the lasso's rays spread less by
  // then, and the road lies outside.
  const overlay::TerrainHeightFunction plateau = [](const glm::dvec2&) { return 500.0; };
  EXPECT_TRUE(overlay::selectFeatures(layer, steps, plateau).empty());
  // A road inside, fully.
  features[0].lines[0] = {{0, -50}, {20, 0}, {0, 50}};
  const std::vector<overlay::FeatureSelection> t = overlay::selectFeatures(layer, steps, kFlat);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_TRUE(t[0].fullyInside);
}

TEST(LogicalSelection, HugeFeaturesGetACoarserGrid) {
  std::vector<geo::Feature> features = {squareFeature({-50000, -50000}, {50000, 50000})};
  const overlay::ReferenceLayer layer{"big", overlay::LayerKind::Polygon, &features, {}, {}};
  // A lasso wider than the coarser grid's spacing (a narrower one could fall between samples).
  const std::vector<SelectionStep> steps = {{SelectionOp::Single, groundSquare({-2000, -2000}, {2000, 2000})}};
  overlay::FeatureSelectionOptions options;
  options.sampleSpacing = 1.0;
  options.maxGridSamplesPerFeature = 100000;
  const std::vector<overlay::FeatureSelection> s = overlay::selectFeatures(layer, steps, kFlat, options);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_GT(s[0].spacing, 300.0);
  EXPECT_LE(s[0].samples, 100000u + 4u * 100000u / 300u + 10u);
}

}  // namespace
}  // namespace gis::test
