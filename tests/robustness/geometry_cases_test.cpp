// The geometry rows of the robustness case matrix (docs/robustness.md), without GL: every messy
// or extreme polygon and road becomes pieces that are closed, outward and bounded
// (validation.hpp), hold the terrain between their bounds, and cover exactly what the CPU
// reference covers — or is left out with an Error naming the layer and the feature, or gives
// nothing to draw with a Warning saying so. On a stiff terrain from −430 m to 8,850 m with
// cliffs, a spike, a flat lake and nodata holes, at exaggerations 0.1×, 1× and 20×, and on one
// whose whole outside is nodata; split at cells, adaptively welded, and as the seed paper's
// construction; plus flat ground (lo == hi) and a polygon of 10^6 vertices (2·10^5
// under the sanitizers: sanitizer.hpp).
#include <chrono>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "extreme_cases.hpp"
#include "sanitizer.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/quadtree.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/validation.hpp"

namespace gis::test {
namespace {

using overlay::LayerKind;

constexpr int kPosts = 129;
constexpr double kSpacing = 20.0;
constexpr int kChunkCells = 16;

/// Flat ground at one height: every piece has lo == hi.
class FlatBounds final : public overlay::HeightBoundsProvider {
 public:
  [[nodiscard]] overlay::HeightBounds boundsOver(std::span<const glm::dvec2>) const override { return {42.0, 42.0}; }
  [[nodiscard]] overlay::HeightBounds globalBounds() const override { return {42.0, 42.0}; }
};

struct Terrain {
  std::shared_ptr<const terrain::TerrainQuadtree> tree;
  glm::dvec2 lo, hi;
  overlay::CellGrid cells;
};

/// The stiff terrain from −430 m to 8,850 m, or (`nodataBorder`) one whose outside is nodata.
Terrain extremeTerrain(bool nodataBorder = false) {
  Terrain t;
  auto grid =
      nodataBorder
          ? makeStiffTerrain({.width = kPosts, .height = kPosts, .spacing = kSpacing, .seed = 9, .nodataBorder = true})
          : makeStiffTerrain({.width = kPosts,
                              .height = kPosts,
                              .spacing = kSpacing,
                              .seed = 5,
                              .lowest = -430.0,
                              .highest = 8850.0});
  t.lo = grid->postPosition(0, grid->height - 1);
  t.hi = grid->postPosition(grid->width - 1, 0);
  t.tree = std::make_shared<terrain::TerrainQuadtree>(grid, kChunkCells);
  t.cells.origin = t.lo;
  t.cells.cellSize = kChunkCells * kSpacing;
  t.cells.columns = t.cells.rows = (kPosts - 1) / kChunkCells;
  return t;
}

struct Variant {
  const char* name;
  bool paper;
  bool adaptive;
};
constexpr Variant kVariants[] = {{"split at cells", false, false}, {"adaptive", false, true}, {"paper", true, false}};

bool inPieces(const std::vector<overlay::Polyhedron>& pieces, const glm::dvec2& q) {
  for (const overlay::Polyhedron& p : pieces) {
    if (q.x < p.boxMin.x || q.y < p.boxMin.y || q.x > p.boxMax.x || q.y > p.boxMax.y) continue;
    const overlay::Footprint& f = p.footprint;
    for (const auto& t : f.triangles) {
      const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], c = f.vertices[t[2]];
      auto side = [&](const glm::dvec2& u, const glm::dvec2& v) {
        return (v.x - u.x) * (q.y - u.y) - (v.y - u.y) * (q.x - u.x);
      };
      if (side(a, b) >= 0.0 && side(b, c) >= 0.0 && side(c, a) >= 0.0) return true;
    }
  }
  return false;
}

/// Counts problems of one case built one way; adds test failures naming the case.
struct CaseReport {
  std::size_t pieces = 0, triangles = 0, samples = 0, heightSamples = 0;
  double worstHeightExcess = 0.0;  ///< metres the surface lies beyond a piece's bounds (≤ 0 is fine)
};

CaseReport checkCase(const GeometryCase& c, const overlay::HeightBoundsProvider& bounds,
                     const terrain::QuadtreeHeightBounds* surface, const Terrain& terrain, const Variant& variant,
                     const std::string& label) {
  CaseReport report;
  overlay::LayerStyle style;
  style.widthAttribute = "width_m";
  const std::vector<geo::Feature> one{c.feature};
  Diagnostics diagnostics;
  const overlay::FeatureStyle fs = overlay::resolveFeatureStyles(style, c.kind, one, &diagnostics, "cases").front();
  overlay::LayerBuildOptions options;
  options.footprints.cells = terrain.cells;
  options.paperVariant = variant.paper;
  options.adaptiveSplit = variant.adaptive;
  const std::vector<overlay::Polyhedron> pieces =
      overlay::buildPolyhedra(c.feature, 0, c.kind, fs, "cases", bounds, options, diagnostics);
  report.pieces = pieces.size();

  // The outcome, and every message naming the layer and the feature.
  const std::size_t errors = diagnostics.count(Severity::Error), warnings = diagnostics.count(Severity::Warning);
  for (const Diagnostic& d : diagnostics.items()) {
    EXPECT_EQ(d.layer, "cases") << label;
    EXPECT_EQ(d.feature, std::to_string(c.feature.fid)) << label << ": " << d.toString();
  }
  Outcome outcome = c.outcome;
  if (variant.paper && outcome == Outcome::NothingThere && (!c.feature.polygons.empty() || !c.feature.lines.empty())) {
    outcome = Outcome::Drawn;  // the paper's construction is not clipped to the terrain
  }
  switch (outcome) {
    case Outcome::Drawn:
      EXPECT_GT(pieces.size(), 0u) << label;
      EXPECT_EQ(errors + warnings, 0u) << label << ": "
                                       << (diagnostics.empty() ? "" : diagnostics.items()[0].toString());
      break;
    case Outcome::DrawnWithWarning:
      EXPECT_GT(pieces.size(), 0u) << label;
      EXPECT_EQ(errors, 0u) << label;
      EXPECT_GT(warnings, 0u) << label;
      break;
    case Outcome::Skipped:
      EXPECT_EQ(pieces.size(), 0u) << label;
      EXPECT_GT(errors, 0u) << label;
      break;
    case Outcome::PartlyDrawn:
      EXPECT_GT(pieces.size(), 0u) << label;
      EXPECT_GT(errors, 0u) << label;
      break;
    case Outcome::NothingThere:
      EXPECT_EQ(pieces.size(), 0u) << label;
      EXPECT_EQ(errors, 0u) << label;
      EXPECT_EQ(warnings, 1u) << label;
      break;
  }

  // Closed, outward, bounded, in the grid.
  overlay::ValidationOptions vo;
  if (!variant.paper) vo.grid = terrain.cells;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const overlay::Polyhedron& p = pieces[k];
    report.triangles += p.footprint.triangles.size();
    for (const std::string& problem : overlay::polyhedronProblems(p, vo)) {
      ADD_FAILURE() << label << ": piece " << k << ": " << problem;
    }
    // The full-resolution surface lies between the bounds (coarser levels are the bounds'
    // business, tested in terrain/height_bounds_test).
    if (surface == nullptr) continue;
    const overlay::Footprint& f = p.footprint;
    for (const auto& t : f.triangles) {
      for (int s = 0; s < 3; ++s) {
        double u = unit(rng), v = unit(rng);
        if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
        const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], cc = f.vertices[t[2]];
        const double h = surface->fullResolutionHeightAt(a + u * (b - a) + v * (cc - a));
        if (std::isnan(h)) continue;
        ++report.heightSamples;
        report.worstHeightExcess = std::max({report.worstHeightExcess, h - p.hi, p.lo - h});
      }
    }
  }
  EXPECT_LE(report.worstHeightExcess, 1e-3) << label << ": the surface leaves a piece's bounds";

  // Coverage: where the reference is sure (the same answer within δ all around), the pieces
  // cover exactly what it covers (inside the grid, where pieces are clipped; everywhere for the
  // paper's unclipped pieces).
  overlay::ReferenceLayer ref{"cases", c.kind, &one, {fs.shape}, {}};
  const glm::dvec2 size = terrain.hi - terrain.lo;
  std::uniform_real_distribution<double> ux(terrain.lo.x - 0.2 * size.x, terrain.hi.x + 0.2 * size.x);
  std::uniform_real_distribution<double> uy(terrain.lo.y - 0.2 * size.y, terrain.hi.y + 0.2 * size.y);
  const double delta = 0.05;  // > the 0.02 m chord tolerance of arcs
  std::size_t disagreements = 0;
  for (int i = 0; i < 3000; ++i) {
    glm::dvec2 q(ux(rng), uy(rng));
    if (i % 3 == 0 && !pieces.empty()) {
      // a third of the samples near the pieces
      const overlay::Polyhedron& p = pieces[static_cast<std::size_t>(i) % pieces.size()];
      q = p.boxMin + glm::dvec2(unit(rng), unit(rng)) * (p.boxMax - p.boxMin);
    }
    const bool inGrid = q.x > terrain.lo.x + delta && q.y > terrain.lo.y + delta && q.x < terrain.hi.x - delta &&
                        q.y < terrain.hi.y - delta;
    if (!variant.paper && !inGrid) continue;
    const bool covered = overlay::featureCovers(ref, 0, q);
    bool sure = true;
    for (int k = 0; k < 8 && sure; ++k) {
      const double a = 0.785398 * k;
      sure = overlay::featureCovers(ref, 0, q + delta * glm::dvec2(std::cos(a), std::sin(a))) == covered;
    }
    if (!sure) continue;
    ++report.samples;
    if (inPieces(pieces, q) != covered && disagreements++ < 3) {
      ADD_FAILURE() << label << ": at (" << q.x << ", " << q.y << ") the reference says " << covered;
    }
  }
  return report;
}

TEST(GeometryCases, EveryCaseIsClosedOutwardBoundedAndCoversWhatTheReferenceCovers) {
  const Terrain terrain = extremeTerrain();
  const std::vector<GeometryCase> cases = geometryCases(terrain.lo, terrain.hi);
  std::printf("%-52s %-15s %6s %8s %8s %10s\n", "case", "build", "pieces", "tris", "samples", "excess m");
  // On the nodata-bordered terrain too (no table).
  const Terrain bordered = extremeTerrain(true);
  const terrain::QuadtreeHeightBounds borderedBounds(bordered.tree, 1.0);
  for (const GeometryCase& c : cases) {
    for (const Variant& v : kVariants) {
      checkCase(c, borderedBounds, &borderedBounds, bordered, v, c.name + " / nodata border / " + v.name);
    }
  }
  for (double exaggeration : {0.1, 1.0, 20.0}) {
    const terrain::QuadtreeHeightBounds bounds(terrain.tree, exaggeration);
    for (const GeometryCase& c : cases) {
      for (const Variant& v : kVariants) {
        const std::string label = c.name + " / " + v.name + " / " + std::to_string(exaggeration) + "x";
        const CaseReport r = checkCase(c, bounds, &bounds, terrain, v, label);
        if (exaggeration == 1.0) {
          std::printf("%-52s %-15s %6zu %8zu %8zu %10.4f\n", c.name.c_str(), v.name, r.pieces, r.triangles, r.samples,
                      r.worstHeightExcess);
        }
      }
    }
  }
}

TEST(GeometryCases, FlatGroundGivesValidPiecesWithEqualBounds) {
  const Terrain terrain = extremeTerrain();
  const FlatBounds flat;
  for (const GeometryCase& c : geometryCases(terrain.lo, terrain.hi)) {
    for (const Variant& v : kVariants) checkCase(c, flat, nullptr, terrain, v, c.name + " / flat / " + v.name);
  }
}

TEST(GeometryCases, AMillionVertexPolygon) {
  const Terrain terrain = extremeTerrain();
  const terrain::QuadtreeHeightBounds bounds(terrain.tree, 1.0);
  const glm::dvec2 centre = 0.5 * (terrain.lo + terrain.hi);
  const geo::Feature star = starPolygon(centre, 0.45 * (terrain.hi.x - terrain.lo.x), kStressPolygonVertices);
  double area = 0.0;  // shoelace, relative to the centre
  const geo::Ring& r = star.polygons[0].outer;
  for (std::size_t k = 0; k < r.size(); ++k) {
    const glm::dvec2 a = r[k] - centre, b = r[(k + 1) % r.size()] - centre;
    area += 0.5 * (a.x * b.y - a.y * b.x);
  }
  overlay::LayerBuildOptions options;
  options.footprints.cells = terrain.cells;
  Diagnostics diagnostics;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<overlay::Polyhedron> pieces =
      overlay::buildPolyhedra(star, 0, LayerKind::Polygon, {}, "big", bounds, options, diagnostics);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(diagnostics.empty());
  overlay::ValidationOptions vo;
  vo.grid = terrain.cells;
  double piecesArea = 0.0;
  std::size_t triangles = 0;
  for (const overlay::Polyhedron& p : pieces) {
    for (const std::string& problem : overlay::polyhedronProblems(p, vo)) ADD_FAILURE() << problem;
    triangles += p.footprint.triangles.size();
    for (const auto& t : p.footprint.triangles) {
      const glm::dvec2 a = p.footprint.vertices[t[0]] - centre, b = p.footprint.vertices[t[1]] - centre,
                       c = p.footprint.vertices[t[2]] - centre;
      piecesArea += 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    }
  }
  std::printf("%d-vertex polygon: %zu pieces, %zu triangles, built in %.2f s\n", kStressPolygonVertices, pieces.size(),
              triangles, seconds);
  EXPECT_NEAR(piecesArea, area, 1e-9 * area);
  EXPECT_GT(pieces.size(), 1u);
}

// Found by the polyhedra fuzzer (fuzz/regressions/polyhedra): every point of a road within
// ±1e15 m, but its widened outline beyond it, unclipped (the paper's construction). The builder
// skips that line with an Error naming it and the reference draws none of it; a road as wide
// that stays within the limit is built and covered as usual.
TEST(GeometryCases, ARoadThatReachesBeyondTheLimitOnceWidenedIsSkippedNamingIt) {
  const FlatBounds flat;
  overlay::LayerBuildOptions options;
  options.paperVariant = true;
  overlay::FeatureStyle style;
  style.shape.width = 10.0;
  style.shape.cap = overlay::LineCap::Square;
  for (const double x : {1e15, 1e15 - 1000.0}) {
    geo::Feature road;
    road.fid = 12;
    road.lines = {{glm::dvec2(x, 0.0), glm::dvec2(x, -400.0)}, {glm::dvec2(0.0, 0.0), glm::dvec2(100.0, 0.0)}};
    Diagnostics diagnostics;
    const std::vector<overlay::Polyhedron> pieces =
        overlay::buildPolyhedra(road, 0, LayerKind::Line, style, "roads", flat, options, diagnostics);
    const std::vector<geo::Feature> one{road};
    const overlay::ReferenceLayer ref{"roads", LayerKind::Line, &one, {style.shape}, {}};
    const bool beyond = x == 1e15;
    SCOPED_TRACE(beyond ? "at the limit" : "within it");
    EXPECT_EQ(diagnostics.count(Severity::Error), beyond ? 1u : 0u);
    if (beyond) {
      const Diagnostic& d = diagnostics.items().front();
      EXPECT_EQ(d.layer, "roads");
      EXPECT_EQ(d.feature, "12");
      EXPECT_NE(d.message.find("line 0 reaches beyond"), std::string::npos) << d.toString();
    }
    for (const overlay::Polyhedron& p : pieces) {
      EXPECT_TRUE(overlay::polyhedronProblems(p, {}).empty());
      EXPECT_LE(p.boxMax.x, 1e15);
    }
    EXPECT_EQ(overlay::featureCovers(ref, 0, glm::dvec2(x, -200.0)), !beyond);
    EXPECT_TRUE(overlay::featureCovers(ref, 0, glm::dvec2(50.0, 0.0)));  // the other line still counts
    EXPECT_TRUE(inPieces(pieces, glm::dvec2(50.0, 0.0)));
    EXPECT_EQ(inPieces(pieces, glm::dvec2(x, -200.0)), !beyond);
  }
}

}  // namespace
}  // namespace gis::test
