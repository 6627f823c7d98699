// The deferred technique's index (vector_overlay/src/deferred_index.hpp) against the CPU
// reference, without a GPU: its test in float (the shader's, transcribed) must give the
// reference's first covering feature at every point whose neighbourhood the reference covers
// uniformly. Random polygons with holes and random lines with every join and cap, lines in
// metres and in pixels, the robustness case matrix, near the frame origin and 9,900 km from it.
#include <array>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "deferred_index.hpp"
#include "extreme_cases.hpp"
#include "random_features.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/deferred_lookup.hpp"

namespace gis::test {
namespace {

using overlay::LayerKind;
using overlay::ReferenceLayer;

/// The reference's first covering feature of the layer at p, or -1.
std::int64_t referenceFeature(const ReferenceLayer& layer, const glm::dvec2& p, const overlay::PixelScale& scale) {
  const std::optional<std::size_t> f = overlay::coveringFeature(layer, p, scale);
  return f ? static_cast<std::int64_t>(*f) : -1;
}

struct Tally {
  std::size_t checked = 0, covered = 0, wrong = 0, nearEdges = 0;
};

/// Random points over [lo, hi]; those whose 8 neighbours at `radius` get the same answer from the
/// reference must get it from the index too. The eye is above the point's region at `eyeHeight`.
Tally compareAtRandomPoints(const ReferenceLayer& layer, const glm::dvec2& lo, const glm::dvec2& hi, int count,
                            double radius, std::uint32_t seed, const overlay::PixelScale& scale = {},
                            double eyeHeight = 500.0, const overlay::deferred::BuildOptions& options = {},
                            std::size_t* nodes = nullptr) {
  std::vector<glm::vec4> colors(layer.features->size(), glm::vec4(1.0F));
  const overlay::deferred::Index index = overlay::deferred::build(layer, colors, options);
  if (nodes != nullptr) *nodes = index.nodes.size();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y);
  Tally t;
  const glm::dvec3 eye(0.5 * (lo + hi) + glm::dvec2(37.0, -81.0), eyeHeight);
  overlay::PixelScale pixels = scale;
  pixels.eye = eye;
  const overlay::deferred::EyeCells cells = overlay::deferred::eyeCells(index, eye);
  for (int k = 0; k < count; ++k) {
    const glm::dvec2 p(ux(rng), uy(rng));
    const std::int64_t expected = referenceFeature(layer, p, pixels);
    bool uniform = true;
    for (int a = 0; a < 8 && uniform; ++a) {
      const double angle = 0.785398 * a;
      uniform = referenceFeature(layer, p + radius * glm::dvec2(std::cos(angle), std::sin(angle)), pixels) == expected;
    }
    if (!uniform) {
      ++t.nearEdges;
      continue;
    }
    ++t.checked;
    t.covered += expected >= 0 ? 1 : 0;
    const glm::vec3 relative(glm::dvec3(p, 0.0) - eye);
    const std::int64_t got = overlay::deferred::coveringFeature(index, cells, relative, eye, pixels);
    if (got != expected) {
      if (t.wrong++ < 5)
        ADD_FAILURE() << layer.name << ": at (" << p.x << ", " << p.y << ") the index gives " << got
                      << ", the reference " << expected;
    }
  }
  return t;
}

ReferenceLayer layerOf(std::string name, LayerKind kind, const std::vector<geo::Feature>& features,
                       const overlay::LineShape& shape = {}) {
  ReferenceLayer layer;
  layer.name = std::move(name);
  layer.kind = kind;
  layer.features = &features;
  if (kind == LayerKind::Line) layer.shapes.assign(features.size(), shape);
  return layer;
}

TEST(DeferredIndexTest, RandomPolygonsAndLinesNearAndFarFromTheOrigin) {
  for (const glm::dvec2 offset : {glm::dvec2(0.0), glm::dvec2(500000.0, 9900000.0)}) {
    SCOPED_TRACE(offset.y > 0.0 ? "far" : "near");
    const glm::dvec2 lo = offset + glm::dvec2(-1200.0), hi = offset + glm::dvec2(1300.0);
    std::mt19937 rng(7);
    const std::vector<geo::Feature> polygons = randomPolygons(rng, lo, hi, 40);
    const std::vector<geo::Feature> lines = randomLines(rng, lo, hi, 40);
    Tally all;
    auto add = [&all](const Tally& t) {
      all.checked += t.checked;
      all.covered += t.covered;
      all.wrong += t.wrong;
      all.nearEdges += t.nearEdges;
    };
    add(compareAtRandomPoints(layerOf("polygons", LayerKind::Polygon, polygons), lo, hi, 6000, 0.002, 1));
    const std::pair<overlay::LineJoin, overlay::LineCap> styles[] = {
        {overlay::LineJoin::Round, overlay::LineCap::Round},
        {overlay::LineJoin::Miter, overlay::LineCap::Square},
        {overlay::LineJoin::Bevel, overlay::LineCap::Flat}};
    for (const auto& [join, cap] : styles) {
      overlay::LineShape shape;
      shape.width = 24.0;
      shape.join = join;
      shape.cap = cap;
      add(compareAtRandomPoints(layerOf("lines", LayerKind::Line, lines, shape), lo, hi, 6000, 0.002, 2));
      // In pixels: 4 px at 1 m per 1,000 m from the eye, at most 40 m, at least 2 m.
      shape.widthPixels = 4.0;
      shape.width = 40.0;
      shape.minWidth = 2.0;
      add(compareAtRandomPoints(layerOf("lines in pixels", LayerKind::Line, lines, shape), lo, hi, 6000, 0.002, 3,
                                {glm::dvec3(0.0), 1e-3}));
    }
    std::printf("%s: %zu points checked (%zu covered), %zu wrong, %zu near edges\n", offset.y > 0.0 ? "far" : "near",
                all.checked, all.covered, all.wrong, all.nearEdges);
    EXPECT_EQ(all.wrong, 0u);
    EXPECT_GT(all.covered, 5000u);
  }
}

void robustnessCases(const glm::dvec2& offset);

TEST(DeferredIndexTest, TheRobustnessCasesMatchTheReference) {
  for (const glm::dvec2 offset : {glm::dvec2(0.0), glm::dvec2(500000.0, 9900000.0)}) {
    SCOPED_TRACE(offset.y > 0.0 ? "far" : "near");
    robustnessCases(offset);
  }
}

void robustnessCases(const glm::dvec2& offset) {
  const glm::dvec2 lo = offset + glm::dvec2(-1280.0), hi = offset + glm::dvec2(1280.0);
  const std::vector<GeometryCase> cases = geometryCases(lo, hi);
  std::vector<geo::Feature> areas, roads;
  for (const GeometryCase& c : cases) (c.kind == LayerKind::Polygon ? areas : roads).push_back(c.feature);
  const Tally a = compareAtRandomPoints(layerOf("areas", LayerKind::Polygon, areas), lo, hi, 40000, 0.01, 4);
  ReferenceLayer lines = layerOf("roads", LayerKind::Line, roads);
  for (std::size_t i = 0; i < roads.size(); ++i) {
    const auto w = roads[i].attributes.find("width_m");
    if (w == roads[i].attributes.end()) continue;
    if (const double* width = std::get_if<double>(&w->second);
        width != nullptr && std::isfinite(*width) && *width > 0.0)
      lines.shapes[i].width = *width;
  }
  Tally l;
  for (const overlay::LineJoin join : {overlay::LineJoin::Round, overlay::LineJoin::Miter, overlay::LineJoin::Bevel}) {
    for (overlay::LineShape& shape : lines.shapes) {
      shape.join = join;
      shape.cap = join == overlay::LineJoin::Round   ? overlay::LineCap::Round
                  : join == overlay::LineJoin::Miter ? overlay::LineCap::Square
                                                     : overlay::LineCap::Flat;
    }
    const Tally t = compareAtRandomPoints(lines, lo, hi, 20000, 0.01, 5);
    l.checked += t.checked;
    l.covered += t.covered;
    l.wrong += t.wrong;
  }
  std::printf("cases: areas %zu checked (%zu covered), roads %zu checked (%zu covered), wrong %zu\n", a.checked,
              a.covered, l.checked, l.covered, a.wrong + l.wrong);
  EXPECT_EQ(a.wrong + l.wrong, 0u);
  EXPECT_GT(a.covered, 1000u);
  EXPECT_GT(l.covered, 100u);
}

// ---- what one feature may cost (issue 40, 7) --------------------------------------------------

/// A line of two points 1e15 m wide (the widest footprints.hpp accepts) from the middle of
/// [lo, hi], after `before` ordinary roads.
std::vector<geo::Feature> roadsAndAWideLine(const glm::dvec2& lo, const glm::dvec2& hi, int before) {
  std::mt19937 rng(17);
  std::vector<geo::Feature> features = randomLines(rng, lo, hi, before);
  geo::Feature wide;
  wide.fid = 1000;
  const glm::dvec2 middle = 0.5 * (lo + hi);
  wide.lines.push_back({middle, middle + glm::dvec2(700.0, 250.0)});
  features.push_back(std::move(wide));
  return features;
}

TEST(DeferredIndexTest, ALineAsWideAsTheWidestAcceptedCostsAFewLeavesAndStaysExact) {
  // Before, every node it met split down to 1 km leaves: 23 GB and std::bad_alloc. Within the
  // terrain's extent (the region, as the technique gives it) it costs what a line covering the
  // terrain does and matches the reference; with no region (a client without a cell grid) the
  // index stays bounded.
  const glm::dvec2 lo(-1280.0), hi(1280.0);
  const std::vector<geo::Feature> features = roadsAndAWideLine(lo, hi, 12);
  for (const overlay::LineCap cap : {overlay::LineCap::Flat, overlay::LineCap::Round, overlay::LineCap::Square}) {
    const char* capName = cap == overlay::LineCap::Flat ? "flat" : cap == overlay::LineCap::Round ? "round" : "square";
    SCOPED_TRACE(capName);
    ReferenceLayer layer = layerOf("roads", LayerKind::Line, features);
    for (overlay::LineShape& shape : layer.shapes) {
      shape.width = 12.0;
      shape.cap = cap;
      shape.join = overlay::LineJoin::Miter;
    }
    layer.shapes.back().width = 1e15;
    overlay::deferred::BuildOptions options;
    options.region = std::array<glm::dvec2, 2>{lo, hi};
    std::size_t nodes = 0;
    const Tally t = compareAtRandomPoints(layer, lo, hi, 20000, 0.01, 9, {}, 500.0, options, &nodes);
    std::printf("%s caps, region: %zu nodes, %zu points checked (%zu covered), %zu wrong\n", capName, nodes, t.checked,
                t.covered, t.wrong);
    EXPECT_EQ(t.wrong, 0u);
    EXPECT_LT(nodes, 5000u);  // the 12 roads alone take about 2,000
    if (cap == overlay::LineCap::Flat) {
      // The flat end crosses the region: a real edge there, on either side of it.
      EXPECT_GT(t.covered, t.checked / 4);
      EXPECT_LT(t.covered, t.checked * 3 / 4);
    } else {
      EXPECT_EQ(t.covered, t.checked);
    }

    std::vector<glm::vec4> colors(features.size(), glm::vec4(1.0F));
    const overlay::deferred::Index unbounded = overlay::deferred::build(layer, colors);
    std::printf("%s caps, no region: %zu nodes, %zu items, %.1f MB\n", capName, unbounded.nodes.size(),
                unbounded.items.size(), static_cast<double>(unbounded.bytes()) / 1e6);
    // At most maxSizeSplitsPerFeature (and 4 per primitive) splits of 4 nodes for the wide line,
    // and the roads' own.
    EXPECT_LT(unbounded.nodes.size(), 4u * (1U << 16) + 20000u);
    EXPECT_LT(unbounded.bytes(), std::size_t{200} << 20);
  }
}

TEST(DeferredIndexTest, TheEstimateOfALineIndexHoldsItsSizeAtEveryReach) {
  // Both frames' lookups decide with ReachClasses::lineIndexBytes whether to build a line layer's
  // index within their budget (an index built and then refused costs its build, and memory for
  // a while). Roads 10 m wide in metres, and at least a pixel wide binned at reach classes 3
  // (64 m) and 7 (1 km): the estimate within a factor of two of what is built.
  const glm::dvec2 lo(0.0), hi(40000.0);
  std::mt19937 rng(41);
  const std::vector<geo::Feature> features = randomLines(rng, lo, hi, 400);
  std::size_t vertices = 0;
  for (const geo::Feature& f : features)
    for (const geo::LineString& l : f.lines) vertices += l.size();
  const overlay::ReachClasses classes;
  for (const int c : {overlay::ReachClasses::kNatural, 3, 7}) {
    ReferenceLayer layer = layerOf("roads", LayerKind::Line, features);
    overlay::deferred::BuildOptions options;
    for (overlay::LineShape& shape : layer.shapes) {
      shape.width = 10.0;
      if (c == overlay::ReachClasses::kNatural) continue;
      shape.widthPixels = 1.0;  // at least a pixel: binned at the class's reach
      shape.minWidth = 10.0;
      shape.width = 1e7;
      options.maxReach = classes.reach(c);
    }
    std::vector<glm::vec4> colors(features.size(), glm::vec4(1.0F));
    const overlay::deferred::Index index = overlay::deferred::build(layer, colors, options);
    const double estimate = classes.lineIndexBytes(2 * vertices, c);
    std::printf("class %d: %zu items for %zu vertices, %.1f MB, estimated %.1f MB\n", c, index.items.size(), vertices,
                static_cast<double>(index.bytes()) / 1e6, estimate / 1e6);
    EXPECT_LE(static_cast<double>(index.bytes()), 2.0 * estimate) << "class " << c;
    EXPECT_GE(2.0 * static_cast<double>(index.bytes()), estimate) << "class " << c;
  }
}

TEST(DeferredIndexTest, APolygonReachingFarBeyondTheTerrainCostsABoundedIndex) {
  // A square 2e15 m across with the terrain in a hole, and ordinary polygons: within the region
  // exact and small; with no region its edges stop forcing splits after maxSizeSplitsPerFeature.
  const glm::dvec2 lo(-1280.0), hi(1280.0);
  std::mt19937 rng(3);
  std::vector<geo::Feature> features = randomPolygons(rng, lo, hi, 10);
  geo::Feature huge;
  huge.fid = 99;
  huge.polygons.push_back(
      {{glm::dvec2(-1e15, -1e15), glm::dvec2(1e15, -1e15), glm::dvec2(1e15, 1e15), glm::dvec2(-1e15, 1e15)},
       {{glm::dvec2(-300.0, -200.0), glm::dvec2(400.0, -250.0), glm::dvec2(100.0, 500.0)}}});
  features.push_back(std::move(huge));
  const ReferenceLayer layer = layerOf("areas", LayerKind::Polygon, features);
  overlay::deferred::BuildOptions options;
  options.region = std::array<glm::dvec2, 2>{lo, hi};
  std::size_t nodes = 0;
  const Tally t = compareAtRandomPoints(layer, lo, hi, 20000, 0.01, 10, {}, 500.0, options, &nodes);
  std::printf("region: %zu nodes, %zu points checked (%zu covered), %zu wrong\n", nodes, t.checked, t.covered, t.wrong);
  EXPECT_EQ(t.wrong, 0u);
  EXPECT_GT(t.covered, t.checked / 2);
  EXPECT_LT(nodes, 5000u);
  std::vector<glm::vec4> colors(features.size(), glm::vec4(1.0F));
  const overlay::deferred::Index unbounded = overlay::deferred::build(layer, colors);
  std::printf("no region: %zu nodes, %zu edges, %.1f MB\n", unbounded.nodes.size(), unbounded.edges.size(),
              static_cast<double>(unbounded.bytes()) / 1e6);
  EXPECT_LT(unbounded.nodes.size(), 4u * (1U << 16) + 20000u);
  EXPECT_LT(unbounded.bytes(), std::size_t{200} << 20);
}

}  // namespace
}  // namespace gis::test
