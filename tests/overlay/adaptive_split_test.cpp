// The split at cells kept only where it pays (LayerBuildOptions::adaptiveSplit): on flat ground
// a shape cut at the cells is welded back into one closed piece; on a steep slope the parts keep
// their own, tighter bounds. Either way the pieces cover exactly the shape's region and hold the
// terrain between their bounds.
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "vector_overlay/overlay_layer.hpp"

namespace {

using namespace gis;
using namespace gis::overlay;

/// Bounds of the plane z = a·x + b·y plus a tower of `tower` metres on the cell (0, 100)², over
/// a footprint's hull: at its vertices, and the tower where the hull's box overlaps it.
class PlaneBounds final : public HeightBoundsProvider {
 public:
  PlaneBounds(double a, double b, double tower = 0.0) : a_(a), b_(b), tower_(tower) {}
  [[nodiscard]] double at(const glm::dvec2& p) const {
    const bool onTower = p.x > 0.0 && p.x < 100.0 && p.y > 0.0 && p.y < 100.0;
    return a_ * p.x + b_ * p.y + (onTower ? tower_ : 0.0);
  }
  [[nodiscard]] HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override {
    HeightBounds r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec2& p : footprint) {
      r.lo = std::min(r.lo, a_ * p.x + b_ * p.y);
      r.hi = std::max(r.hi, a_ * p.x + b_ * p.y);
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    if (hi.x > 0.0 && lo.x < 100.0 && hi.y > 0.0 && lo.y < 100.0) r.hi += tower_;
    return r;
  }
  [[nodiscard]] HeightBounds globalBounds() const override { return {-1e6, 1e6}; }

 private:
  double a_, b_, tower_;
};

LayerBuildOptions optionsOnGrid(bool adaptive) {
  LayerBuildOptions o;
  CellGrid g;
  g.origin = glm::dvec2(-5000.0);
  g.cellSize = 100.0;
  g.columns = g.rows = 100;
  o.footprints.cells = g;
  o.adaptiveSplit = adaptive;
  return o;
}

geo::Feature square(double x0, double y0, double size) {
  geo::Feature f;
  f.fid = 1;
  f.polygons.push_back({{{x0, y0}, {x0 + size, y0}, {x0 + size, y0 + size}, {x0, y0 + size}}, {}});
  return f;
}

geo::Feature road() {
  geo::Feature f;
  f.fid = 2;
  f.lines.push_back({{-730.0, -410.0}, {-120.0, -150.0}, {260.0, 310.0}, {1090.0, 420.0}});
  return f;
}

double area(const Footprint& f) {
  double sum = 0.0;
  for (const auto& t : f.triangles) {
    const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], c = f.vertices[t[2]];
    sum += 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
  }
  return sum;
}

double totalArea(const std::vector<Polyhedron>& pieces) {
  double sum = 0.0;
  for (const Polyhedron& p : pieces) sum += area(p.footprint);
  return sum;
}

/// Every boundary edge of a footprint is a triangle edge without its reverse (the walls close
/// the volume), and the terrain under every vertex and triangle centre lies within the bounds.
void expectClosedAndBounded(const std::vector<Polyhedron>& pieces, const PlaneBounds& plane) {
  for (const Polyhedron& p : pieces) {
    const Footprint& f = p.footprint;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (const auto& t : f.triangles) {
      for (std::size_t i = 0; i < 3; ++i) ++directed[{t[i], t[(i + 1) % 3]}];
    }
    std::size_t open = 0;
    for (const auto& [edge, count] : directed) {
      if (directed.find({edge.second, edge.first}) == directed.end()) open += static_cast<std::size_t>(count);
    }
    EXPECT_EQ(open, f.boundary.size());
    for (const auto& t : f.triangles) {
      const glm::dvec2 c = (f.vertices[t[0]] + f.vertices[t[1]] + f.vertices[t[2]]) / 3.0;
      EXPECT_GE(plane.at(c), p.lo - 1e-9);
      EXPECT_LE(plane.at(c), p.hi + 1e-9);
    }
    for (const glm::dvec2& v : f.vertices) {
      EXPECT_GE(plane.at(v), p.lo - 1e-9);
      EXPECT_LE(plane.at(v), p.hi + 1e-9);
    }
  }
}

std::vector<Polyhedron> build(const geo::Feature& f, LayerKind kind, const PlaneBounds& plane, bool adaptive,
                              bool uniteLines = false) {
  FeatureStyle style;
  style.shape.width = 12.0;
  Diagnostics d;
  LayerBuildOptions options = optionsOnGrid(adaptive);
  options.footprints.uniteLines = uniteLines;
  std::vector<Polyhedron> out = buildPolyhedra(f, 0, kind, style, "test", plane, options, d);
  EXPECT_TRUE(d.items().empty());
  return out;
}

TEST(AdaptiveSplit, FlatGroundWeldsAPolygonBackIntoOnePiece) {
  const PlaneBounds flat(0.0, 0.0);
  const geo::Feature f = square(-430.0, -270.0, 1000.0);  // over 11 x 11 cells
  const std::vector<Polyhedron> split = build(f, LayerKind::Polygon, flat, false);
  const std::vector<Polyhedron> adaptive = build(f, LayerKind::Polygon, flat, true);
  EXPECT_EQ(split.size(), 121u);
  ASSERT_EQ(adaptive.size(), 1u);
  EXPECT_NEAR(totalArea(adaptive), 1e6, 1e-6);
  EXPECT_NEAR(totalArea(split), 1e6, 1e-6);
  // The cut edges cancel: the welded piece's walls are the square's four sides.
  double perimeter = 0.0;
  const Footprint& fp = adaptive[0].footprint;
  for (const auto& e : fp.boundary) perimeter += glm::length(fp.vertices[e[1]] - fp.vertices[e[0]]);
  EXPECT_NEAR(perimeter, 4000.0, 1e-6);
  // Inside the grid it is the square itself, not its 121 parts welded: 2 triangles, 4 walls.
  EXPECT_EQ(fp.triangles.size(), 2u);
  EXPECT_EQ(fp.boundary.size(), 4u);
  expectClosedAndBounded(adaptive, flat);
}

TEST(AdaptiveSplit, AShapeReachingOutOfTheGridIsWeldedFromItsClippedParts) {
  // The grid ends at x = 5000: the part beyond is dropped, so the welded parts (not the whole
  // square) make the piece.
  const PlaneBounds flat(0.0, 0.0);
  const std::vector<Polyhedron> adaptive = build(square(4750.0, 0.0, 500.0), LayerKind::Polygon, flat, true);
  ASSERT_EQ(adaptive.size(), 1u);
  EXPECT_NEAR(totalArea(adaptive), 250.0 * 500.0, 1e-6);
  for (const glm::dvec2& v : adaptive[0].footprint.vertices) EXPECT_LE(v.x, 5000.0);
  expectClosedAndBounded(adaptive, flat);
}

TEST(AdaptiveSplit, ATowerInOneCellKeepsTheOtherCellsFlat) {
  // A 1 km tower on one cell inside the square: whole, all its walls would be 1 km high; cut,
  // only the tower cell's are.
  const PlaneBounds tower(0.0, 0.0, 1000.0);
  const geo::Feature f = square(-430.0, -270.0, 1000.0);
  const std::vector<Polyhedron> adaptive = build(f, LayerKind::Polygon, tower, true);
  EXPECT_EQ(adaptive.size(), 121u);
  EXPECT_NEAR(totalArea(adaptive), 1e6, 1e-6);
  std::size_t tall = 0;
  for (const Polyhedron& p : adaptive) tall += p.hi - p.lo > 0.0 ? 1u : 0u;
  EXPECT_EQ(tall, 1u);
  expectClosedAndBounded(adaptive, tower);
}

TEST(AdaptiveSplit, APlaneNeverPaysForTheCutWalls) {
  // On a plane the parts' walls add up to the whole's (each cell's range is its share), plus
  // the cut walls: splitting never pays, however steep.
  const PlaneBounds steep(2.0, 0.5);
  const std::vector<Polyhedron> adaptive = build(square(-430.0, -270.0, 1000.0), LayerKind::Polygon, steep, true);
  EXPECT_EQ(adaptive.size(), 1u);
  expectClosedAndBounded(adaptive, steep);
}

TEST(AdaptiveSplit, RoadOnFlatGroundKeepsOnePiecePerShape) {
  const PlaneBounds flat(0.0, 0.0);
  // A piece per shape (the default): 3 segments, 2 joins, 2 caps, each welded back.
  const std::vector<Polyhedron> split = build(road(), LayerKind::Line, flat, false);
  const std::vector<Polyhedron> adaptive = build(road(), LayerKind::Line, flat, true);
  EXPECT_EQ(adaptive.size(), 7u);
  EXPECT_GT(split.size(), adaptive.size());
  EXPECT_NEAR(totalArea(adaptive), totalArea(split), 1e-6 * totalArea(split));
  expectClosedAndBounded(adaptive, flat);
  // United (FootprintOptions::uniteLines): the road's shapes are one region, cut at the cells
  // and welded back into one piece.
  const std::vector<Polyhedron> unitedSplit = build(road(), LayerKind::Line, flat, false, true);
  const std::vector<Polyhedron> united = build(road(), LayerKind::Line, flat, true, true);
  EXPECT_EQ(united.size(), 1u);
  EXPECT_GT(unitedSplit.size(), united.size());
  EXPECT_NEAR(totalArea(united), totalArea(unitedSplit), 1e-6 * totalArea(unitedSplit));
  expectClosedAndBounded(united, flat);
  // The union is no larger than its shapes (they overlap at the joins) and no smaller than
  // its longest segment's rectangle.
  EXPECT_LT(totalArea(united), totalArea(adaptive));
  EXPECT_GT(totalArea(united), 12.0 * std::hypot(830.0, 110.0));
}

TEST(AdaptiveSplit, ALongNarrowPieceUpASlopeKeepsItsParts) {
  // A road segment 660 m long up a 1 % slope: whole, its long walls are 6.6 m high; cut at the
  // cells, about 1 m each, for a few short cut walls 12 m wide: the split pays.
  const PlaneBounds gentle(0.01, 0.0);
  const std::vector<Polyhedron> roadPieces = build(road(), LayerKind::Line, gentle, true);
  EXPECT_GT(roadPieces.size(), 7u);
  EXPECT_NEAR(totalArea(roadPieces), totalArea(build(road(), LayerKind::Line, gentle, false)), 1e-3);
  expectClosedAndBounded(roadPieces, gentle);
}

TEST(AdaptiveSplit, ThePapersVariantAndNoGridAreUntouched) {
  const PlaneBounds flat(0.0, 0.0);
  LayerBuildOptions o = optionsOnGrid(true);
  o.footprints.cells.reset();
  FeatureStyle style;
  Diagnostics d;
  EXPECT_EQ(buildPolyhedra(square(0.0, 0.0, 500.0), 0, LayerKind::Polygon, style, "t", flat, o, d).size(), 1u);
  o = optionsOnGrid(true);
  o.paperVariant = true;
  EXPECT_EQ(buildPolyhedra(square(0.0, 0.0, 500.0), 0, LayerKind::Polygon, style, "t", flat, o, d).size(), 1u);
}

}  // namespace
