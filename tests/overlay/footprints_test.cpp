// Footprints (vector_overlay/footprints.hpp): every output of many regular, adversarial and
// random inputs is checked against the footprint invariants, and coverage is compared with the
// header's rules implemented here independently (even-odd point in polygon on the raw rings;
// distances to segments with exact circles for lines).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <glm/common.hpp>

#include "vector_overlay/footprints.hpp"

namespace gis::overlay {
namespace {

using Vec = glm::dvec2;
constexpr double kPi = std::numbers::pi;

double cross(const Vec& a, const Vec& b) { return a.x * b.y - a.y * b.x; }
double dot(const Vec& a, const Vec& b) { return a.x * b.x + a.y * b.y; }
double area2(const Vec& a, const Vec& b, const Vec& c) { return cross(b - a, c - a); }
double length(const Vec& a) { return std::hypot(a.x, a.y); }

double distanceToSegment(const Vec& p, const Vec& a, const Vec& b) {
  const Vec d = b - a;
  const double l2 = dot(d, d);
  const double t = l2 > 0.0 ? std::clamp(dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
  return length(p - (a + t * d));
}

// ---------------------------------------------------------------------------------------------
// Invariants

double triangleArea(const Footprint& fp, const std::array<std::uint32_t, 3>& t) {
  return 0.5 * area2(fp.vertices[t[0]], fp.vertices[t[1]], fp.vertices[t[2]]);
}

double footprintArea(const Footprint& fp) {
  double a = 0.0;
  for (const auto& t : fp.triangles) a += triangleArea(fp, t);
  return a;
}

double totalArea(const std::vector<Footprint>& fps) {
  double a = 0.0;
  for (const auto& fp : fps) a += footprintArea(fp);
  return a;
}

double totalArea(const std::vector<Footprint>& fps, PieceKind kind) {
  double a = 0.0;
  for (const auto& fp : fps) {
    if (fp.kind == kind) a += footprintArea(fp);
  }
  return a;
}

std::size_t countKind(const std::vector<Footprint>& fps, PieceKind kind) {
  return static_cast<std::size_t>(
      std::count_if(fps.begin(), fps.end(), [&](const Footprint& f) { return f.kind == kind; }));
}

/// All invariants of footprints.hpp for one footprint.
::testing::AssertionResult validFootprint(const Footprint& fp, std::uint32_t feature, const FootprintOptions& options) {
  if (fp.feature != feature) return ::testing::AssertionFailure() << "feature index " << fp.feature;
  if (fp.triangles.empty()) return ::testing::AssertionFailure() << "no triangles";
  const std::size_t nv = fp.vertices.size();
  Vec lo(std::numeric_limits<double>::infinity());
  Vec hi(-std::numeric_limits<double>::infinity());
  std::set<std::pair<double, double>> distinct;
  for (const auto& v : fp.vertices) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y)) return ::testing::AssertionFailure() << "non-finite vertex";
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
    if (!distinct.emplace(v.x + 0.0, v.y + 0.0).second) {
      return ::testing::AssertionFailure() << "vertices with equal coordinates not merged";
    }
  }
  std::vector<bool> used(nv, false);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  double sum = 0.0;
  double sumAbs = 0.0;
  for (const auto& t : fp.triangles) {
    for (const auto i : t) {
      if (i >= nv) return ::testing::AssertionFailure() << "index out of range";
      used[i] = true;
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return ::testing::AssertionFailure() << "repeated index";
    const double a = triangleArea(fp, t);
    if (!(a > 0.0)) return ::testing::AssertionFailure() << "triangle with area " << a;
    sum += a;
    sumAbs += std::abs(a);
    for (std::size_t k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
  }
  if (std::find(used.begin(), used.end(), false) != used.end()) return ::testing::AssertionFailure() << "unused vertex";
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> expected;
  for (const auto& [e, c] : edges) {
    if (c > 1) return ::testing::AssertionFailure() << "directed edge used by " << c << " triangles (overlap)";
    const auto rev = edges.find({e.second, e.first});
    if (rev == edges.end()) expected[e] = c;
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> boundary;
  std::vector<int> degree(nv, 0);
  for (const auto& b : fp.boundary) {
    if (b[0] >= nv || b[1] >= nv) return ::testing::AssertionFailure() << "boundary index out of range";
    ++boundary[{b[0], b[1]}];
    ++degree[b[0]];
    --degree[b[1]];
  }
  if (boundary != expected) {
    return ::testing::AssertionFailure() << "boundary is not the set of unshared triangle edges (" << fp.boundary.size()
                                         << " edges)";
  }
  if (std::any_of(degree.begin(), degree.end(), [](int d) { return d != 0; })) {
    return ::testing::AssertionFailure() << "boundary loops not closed";
  }
  // Shoelace over the boundary, relative to the first vertex.
  const Vec o = fp.vertices[0];
  double shoelace = 0.0;
  for (const auto& b : fp.boundary) shoelace += 0.5 * cross(fp.vertices[b[0]] - o, fp.vertices[b[1]] - o);
  const double extent = length(hi - lo);
  if (std::abs(shoelace - sum) > 1e-9 * sumAbs + 1e-14 * extent * extent) {
    return ::testing::AssertionFailure() << "triangle area " << sum << " but boundary encloses " << shoelace;
  }
  if (!options.cells) {
    if (fp.cell != -1) return ::testing::AssertionFailure() << "cell " << fp.cell << " without a grid";
  } else {
    const CellGrid& g = *options.cells;
    if (fp.cell < 0 || fp.cell >= g.columns * g.rows) return ::testing::AssertionFailure() << "cell " << fp.cell;
    const int column = fp.cell % g.columns;
    const int row = fp.cell / g.columns;
    const Vec cmin = g.origin + g.cellSize * Vec(column, row);
    const Vec cmax = g.origin + g.cellSize * Vec(column + 1, row + 1);
    const double tol =
        1e-9 * std::max({g.cellSize, std::abs(cmin.x), std::abs(cmin.y), std::abs(cmax.x), std::abs(cmax.y)});
    for (const auto& v : fp.vertices) {
      if (v.x < cmin.x - tol || v.x > cmax.x + tol || v.y < cmin.y - tol || v.y > cmax.y + tol) {
        return ::testing::AssertionFailure() << "vertex (" << v.x << ", " << v.y << ") outside cell " << fp.cell;
      }
    }
  }
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult allValid(const std::vector<Footprint>& fps, std::uint32_t feature,
                                    const FootprintOptions& options) {
  for (std::size_t i = 0; i < fps.size(); ++i) {
    auto r = validFootprint(fps[i], feature, options);
    if (!r) return ::testing::AssertionFailure() << "footprint " << i << ": " << r.message();
  }
  return ::testing::AssertionSuccess();
}

/// Triangles of the footprint containing p: inclusive (p on an edge counts) and strict.
struct Hits {
  int inclusive = 0;
  int strict = 0;
};

Hits hits(const Footprint& fp, const Vec& p) {
  Hits h;
  for (const auto& t : fp.triangles) {
    const Vec& a = fp.vertices[t[0]];
    const Vec& b = fp.vertices[t[1]];
    const Vec& c = fp.vertices[t[2]];
    const double s0 = area2(a, b, p);
    const double s1 = area2(b, c, p);
    const double s2 = area2(c, a, p);
    if (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) ++h.inclusive;
    if (s0 > 0.0 && s1 > 0.0 && s2 > 0.0) ++h.strict;
  }
  return h;
}

/// Bounding boxes speed up the Monte-Carlo tests.
struct Indexed {
  const Footprint* fp;
  Vec lo;
  Vec hi;
};

std::vector<Indexed> index(const std::vector<Footprint>& fps) {
  std::vector<Indexed> out;
  for (const auto& fp : fps) {
    Indexed ix{&fp, fp.vertices[0], fp.vertices[0]};
    for (const auto& v : fp.vertices) {
      ix.lo = glm::min(ix.lo, v);
      ix.hi = glm::max(ix.hi, v);
    }
    out.push_back(ix);
  }
  return out;
}

/// Whether p is in some footprint; fails the test if a footprint's triangles overlap at p.
bool covered(const std::vector<Indexed>& fps, const Vec& p, int* strictTotal = nullptr) {
  bool in = false;
  int strict = 0;
  for (const auto& ix : fps) {
    if (p.x < ix.lo.x || p.y < ix.lo.y || p.x > ix.hi.x || p.y > ix.hi.y) continue;
    const Hits h = hits(*ix.fp, p);
    EXPECT_LE(h.strict, 1) << "overlapping triangles at (" << p.x << ", " << p.y << ")";
    strict += h.strict;
    in = in || h.inclusive > 0;
  }
  if (strictTotal != nullptr) *strictTotal = strict;
  return in;
}

// ---------------------------------------------------------------------------------------------
// Polygon reference: even-odd on the raw rings

geo::Feature polygonFeature(std::vector<geo::Polygon> polygons, std::int64_t fid = 7) {
  geo::Feature f;
  f.fid = fid;
  f.polygons = std::move(polygons);
  return f;
}

geo::Ring rect(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }

/// A ring from x0, y0, x1, y1, …
geo::Ring ringOf(std::initializer_list<double> xy) {
  geo::Ring r;
  for (auto it = xy.begin(); it != xy.end() && it + 1 != xy.end(); it += 2) r.push_back({*it, *(it + 1)});
  return r;
}

std::vector<const geo::Ring*> allRings(const geo::Feature& f) {
  std::vector<const geo::Ring*> rings;
  for (const auto& p : f.polygons) {
    rings.push_back(&p.outer);
    for (const auto& h : p.holes) rings.push_back(&h);
  }
  return rings;
}

bool evenOdd(const std::vector<const geo::Ring*>& rings, const Vec& p) {
  bool in = false;
  for (const auto* ring : rings) {
    const std::size_t n = ring->size();
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
      const Vec& a = (*ring)[i];
      const Vec& b = (*ring)[j];
      if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
    }
  }
  return in;
}

/// The coverage rule of footprints.hpp: even-odd within each polygon, union over the
/// feature's polygons. `count` gives how many polygons cover p (their pieces may overlap).
int polygonsCovering(const geo::Feature& f, const Vec& p) {
  int count = 0;
  for (const auto& polygon : f.polygons) {
    std::vector<const geo::Ring*> rings{&polygon.outer};
    for (const auto& h : polygon.holes) rings.push_back(&h);
    count += evenOdd(rings, p) ? 1 : 0;
  }
  return count;
}
bool featureCovers(const geo::Feature& f, const Vec& p) { return polygonsCovering(f, p) > 0; }

/// Whether p is within `eps` of an edge of the rings.
bool nearRings(const std::vector<const geo::Ring*>& rings, const Vec& p, double eps) {
  for (const auto* ring : rings) {
    const std::size_t n = ring->size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec& a = (*ring)[i];
      const Vec& b = (*ring)[(i + 1) % n];
      if (p.x < std::min(a.x, b.x) - eps || p.x > std::max(a.x, b.x) + eps || p.y < std::min(a.y, b.y) - eps ||
          p.y > std::max(a.y, b.y) + eps) {
        continue;
      }
      if (distanceToSegment(p, a, b) <= eps) return true;
    }
  }
  return false;
}

/// Every boundary edge of a polygon piece lies on an input ring or on a grid line: pieces of one
/// cell share their clipped vertices exactly, so no wall is left inside a footprint.
::testing::AssertionResult boundaryOnRingsOrGrid(const std::vector<Footprint>& fps,
                                                 const std::vector<const geo::Ring*>& rings,
                                                 const FootprintOptions& options, double scale) {
  for (const auto& fp : fps) {
    for (const auto& b : fp.boundary) {
      const Vec p = fp.vertices[b[0]];
      const Vec q = fp.vertices[b[1]];
      const Vec mid = 0.5 * (p + q);
      if (options.cells) {
        const CellGrid& g = *options.cells;
        const auto onLine = [&](double u, double w, double origin) {
          const double k = std::round((u - origin) / g.cellSize);
          const double line = origin + k * g.cellSize;
          return std::abs(u - line) <= 1e-9 * scale && std::abs(w - line) <= 1e-9 * scale;
        };
        if (onLine(p.x, q.x, g.origin.x) || onLine(p.y, q.y, g.origin.y)) continue;
      }
      if (nearRings(rings, mid, 1e-9 * scale)) continue;
      return ::testing::AssertionFailure() << "boundary edge (" << p.x << ", " << p.y << ") → (" << q.x << ", " << q.y
                                           << ") of cell " << fp.cell << " is neither on a ring nor on a grid line";
    }
  }
  return ::testing::AssertionSuccess();
}

std::vector<Footprint> polygons(const geo::Feature& f, const FootprintOptions& options, Diagnostics& diagnostics) {
  return polygonFootprints(f, 3, "parcels", options, diagnostics);
}

std::vector<Footprint> polygons(const geo::Feature& f, const FootprintOptions& options = {}) {
  Diagnostics d;
  auto out = polygons(f, options, d);
  EXPECT_TRUE(d.empty()) << (d.empty() ? "" : d.items()[0].toString());
  EXPECT_TRUE(allValid(out, 3, options));
  return out;
}

FootprintOptions gridOptions(Vec origin, double cellSize, int columns, int rows) {
  FootprintOptions o;
  o.cells = CellGrid{origin, cellSize, columns, rows};
  return o;
}

// ---------------------------------------------------------------------------------------------
// Polygon tests

TEST(PolygonFootprints, SquareIsOnePieceWithFourBoundaryEdges) {
  const auto out = polygons(polygonFeature({{rect(0, 0, 10, 10), {}}}));
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].kind, PieceKind::PolygonPart);
  EXPECT_EQ(out[0].cell, -1);
  EXPECT_EQ(out[0].triangles.size(), 2U);
  EXPECT_EQ(out[0].boundary.size(), 4U);
  EXPECT_DOUBLE_EQ(footprintArea(out[0]), 100.0);
}

TEST(PolygonFootprints, HolesAreCutOut) {
  geo::Polygon p{rect(0, 0, 10, 10), {rect(2, 2, 4, 4), rect(6, 5, 8, 9)}};
  const auto out = polygons(polygonFeature({p}));
  ASSERT_EQ(out.size(), 1U);
  EXPECT_NEAR(footprintArea(out[0]), 100.0 - 4.0 - 8.0, 1e-12);
  EXPECT_EQ(out[0].boundary.size(), 12U);
  EXPECT_FALSE(hits(out[0], {3, 3}).inclusive > 0);
  EXPECT_TRUE(hits(out[0], {5, 3}).strict == 1);
}

TEST(PolygonFootprints, MultiPolygonPartsAreUnited) {
  // One footprint per polygon of the feature; the feature covers their union.
  const auto disjoint = polygons(polygonFeature({{rect(0, 0, 10, 10), {}}, {rect(20, 0, 25, 4), {}}}));
  ASSERT_EQ(disjoint.size(), 2U);
  EXPECT_NEAR(totalArea(disjoint), 120.0, 1e-12);
  // Overlapping parts (invalid, but common): the overlap stays covered, as GIS viewers paint it.
  const auto overlapping = polygons(polygonFeature({{rect(0, 0, 10, 10), {}}, {rect(5, 5, 15, 15), {}}}));
  ASSERT_EQ(overlapping.size(), 2U);
  EXPECT_TRUE(covered(index(overlapping), {7.5, 7.5}));
  EXPECT_FALSE(covered(index(overlapping), {12.5, 2.5}));
}

TEST(PolygonFootprints, PartsSharingAnEdgeCoverBothSides) {
  for (const auto& second : {rect(10, 0, 20, 10), rect(10, 5, 20, 15), rect(10, 2, 12, 4)}) {
    const geo::Feature f = polygonFeature({{rect(0, 0, 10, 10), {}}, {second, {}}});
    const auto out = polygons(f);
    ASSERT_EQ(out.size(), 2U);
    const double expected = 100.0 + std::abs(area2(second[0], second[1], second[2]));
    EXPECT_NEAR(totalArea(out), expected, 1e-12);
    const Vec onEdge(10, second[0].y + 1.0);
    EXPECT_EQ(hits(out[0], onEdge).inclusive + hits(out[1], onEdge).inclusive, 2) << "both sides of the shared edge";
  }
}

TEST(PolygonFootprints, BowTieCoversItsTwoTriangles) {
  const auto out = polygons(polygonFeature({{{{0, 0}, {2, 2}, {2, 0}, {0, 2}}, {}}}));
  ASSERT_EQ(out.size(), 1U);
  EXPECT_NEAR(footprintArea(out[0]), 2.0, 1e-12);
  EXPECT_EQ(hits(out[0], {1.5, 1.0}).strict, 1);
  EXPECT_EQ(hits(out[0], {0.5, 1.0}).strict, 1);
  EXPECT_EQ(hits(out[0], {1.0, 0.5}).inclusive, 0);
  EXPECT_EQ(hits(out[0], {1.0, 1.5}).inclusive, 0);
}

// A frame that cuts its own cells (the globe) hands the builder a cell's part as loose edges or
// as a line's overlapping shapes, with points to add inside (docs/frames.md).
TEST(RegionFootprints, LooseEdgesByEvenOddWithRunsLaidOverEachOtherCancelling) {
  // A 10 × 10 square with a 2 × 2 hole, as loose edges in no order, and a run along x = 10 given
  // twice over part of it (as clipping at a cell border lays runs over each other): cancelled.
  std::vector<std::array<Vec, 2>> edges = {
      {Vec(10, 0), Vec(10, 10)}, {Vec(0, 0), Vec(10, 0)}, {Vec(10, 10), Vec(0, 10)}, {Vec(0, 10), Vec(0, 0)},
      {Vec(4, 4), Vec(6, 4)},    {Vec(6, 4), Vec(6, 6)},  {Vec(6, 6), Vec(4, 6)},    {Vec(4, 6), Vec(4, 4)},
      {Vec(10, 2), Vec(10, 5)},  {Vec(10, 5), Vec(10, 2)}};
  const std::vector<Vec> points = {{2, 2}, {8, 8}, {5, 5}, {12, 5}};  // inside, inside, in the hole, outside
  const Footprint f = evenOddFootprint(edges, points);
  EXPECT_TRUE(validFootprint(f, 0, FootprintOptions{}));
  EXPECT_NEAR(footprintArea(f), 96.0, 1e-12);
  EXPECT_EQ(f.boundary.size(), 10U) << "4 for the hole, 6 for the square (its east side cut where the run ends)";
  const auto hasVertex = [&](const Vec& p) {
    return std::find(f.vertices.begin(), f.vertices.end(), p) != f.vertices.end();
  };
  EXPECT_TRUE(hasVertex({2, 2}) && hasVertex({8, 8})) << "points inside become vertices";
  EXPECT_FALSE(hasVertex({5, 5}) || hasVertex({12, 5})) << "points outside are left out";
  EXPECT_EQ(hits(f, {5, 5}).inclusive, 0);
  EXPECT_EQ(hits(f, {9.5, 3}).strict, 1);
  // Nothing with area: no triangles.
  EXPECT_TRUE(evenOddFootprint({{Vec(0, 0), Vec(1, 0)}, {Vec(1, 0), Vec(0, 0)}}, {{0.5, 0.5}}).triangles.empty());
}

TEST(RegionFootprints, UnionOfOverlappingPartsOfEitherOrientationHasNoWallsInside) {
  // Two overlapping squares, one clockwise, and a point in the overlap added as a vertex.
  const std::vector<std::vector<Vec>> parts = {rect(0, 0, 10, 10), {{5, 5}, {5, 15}, {15, 15}, {15, 5}}};
  const Footprint f = unionFootprint(parts, {{7, 7}, {20, 20}});
  EXPECT_TRUE(validFootprint(f, 0, FootprintOptions{}));
  EXPECT_NEAR(footprintArea(f), 175.0, 1e-9);
  EXPECT_EQ(f.boundary.size(), 8U) << "only the union's outline has walls";
  EXPECT_NE(std::find(f.vertices.begin(), f.vertices.end(), Vec(7, 7)), f.vertices.end());
  EXPECT_EQ(hits(f, {7.5, 2.5}).strict, 1);
  EXPECT_EQ(hits(f, {12.5, 2.5}).inclusive, 0);
}

TEST(PolygonFootprints, DuplicateCollinearAndClosingPointsAreRepaired) {
  const geo::Ring ring = {{0, 0}, {0, 0}, {5, 0}, {10, 0}, {10, 0}, {10, 5}, {10, 10}, {5, 10}, {0, 10}, {0, 0}};
  const auto out = polygons(polygonFeature({{ring, {}}}));
  ASSERT_EQ(out.size(), 1U);
  EXPECT_NEAR(footprintArea(out[0]), 100.0, 1e-12);
}

TEST(PolygonFootprints, ClockwiseRingsGiveTheSameRegion) {
  geo::Ring outer = rect(0, 0, 10, 10);
  geo::Ring hole = rect(2, 2, 4, 4);
  std::reverse(outer.begin(), outer.end());
  const auto out = polygons(polygonFeature({{outer, {hole}}}));
  ASSERT_EQ(out.size(), 1U);
  EXPECT_NEAR(footprintArea(out[0]), 96.0, 1e-12);
}

TEST(PolygonFootprints, HolesTouchingTheShell) {
  // at a vertex
  {
    const auto out = polygons(polygonFeature({{rect(0, 0, 10, 10), {{{0, 5}, {3, 3}, {3, 7}}}}}));
    ASSERT_EQ(out.size(), 1U);
    EXPECT_NEAR(footprintArea(out[0]), 100.0 - 6.0, 1e-12);
  }
  // along part of an edge: the shared piece is in two rings and cancels
  {
    const auto out = polygons(polygonFeature({{rect(0, 0, 10, 10), {rect(0, 2, 3, 4)}}}));
    ASSERT_EQ(out.size(), 1U);
    EXPECT_NEAR(footprintArea(out[0]), 100.0 - 6.0, 1e-12);
    EXPECT_EQ(hits(out[0], {1, 3}).inclusive, 0);
  }
  // a hole filling a corner
  {
    const auto out = polygons(polygonFeature({{rect(0, 0, 10, 10), {rect(0, 0, 5, 5)}}}));
    ASSERT_EQ(out.size(), 1U);
    EXPECT_NEAR(footprintArea(out[0]), 75.0, 1e-12);
  }
}

TEST(PolygonFootprints, ZeroAreaRingIsSkippedWithADiagnostic) {
  geo::Feature f = polygonFeature({{{{0, 0}, {1, 1}, {2, 2}, {3, 3}}, {}}, {rect(10, 10, 11, 11), {}}}, 42);
  Diagnostics d;
  const auto out = polygonFootprints(f, 0, "parcels", {}, d);
  ASSERT_EQ(d.items().size(), 1U);
  EXPECT_EQ(d.items()[0].severity, Severity::Error);
  EXPECT_EQ(d.items()[0].feature, "42");
  EXPECT_EQ(d.items()[0].layer, "parcels");
  EXPECT_EQ(d.items()[0].file, "");
  EXPECT_NE(d.items()[0].message.find("zero area"), std::string::npos) << d.items()[0].message;
  ASSERT_EQ(out.size(), 1U) << "the feature's other polygon still counts";
  EXPECT_NEAR(footprintArea(out[0]), 1.0, 1e-12);

  Diagnostics d2;
  f.polygons = {{{{0, 0}, {1, 0}, {1, 0}, {0, 0}}, {}}};
  EXPECT_TRUE(polygonFootprints(f, 0, "parcels", {}, d2).empty());
  ASSERT_EQ(d2.items().size(), 1U);
  EXPECT_NE(d2.items()[0].message.find("fewer than 3"), std::string::npos) << d2.items()[0].message;
}

TEST(PolygonFootprints, NonFiniteCoordinatesAreSkippedWithADiagnostic) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Vec bad : {Vec(nan, 1), Vec(1, inf), Vec(-inf, nan)}) {
    geo::Feature f = polygonFeature({{{{0, 0}, {4, 0}, bad, {0, 4}}, {}}}, 9);
    Diagnostics d;
    EXPECT_TRUE(polygonFootprints(f, 0, "parcels", {}, d).empty());
    ASSERT_EQ(d.items().size(), 1U);
    EXPECT_EQ(d.items()[0].feature, "9");
    // in a hole: the whole polygon is unusable
    f.polygons = {{rect(0, 0, 10, 10), {{{1, 1}, {2, 1}, bad}}}};
    Diagnostics d2;
    EXPECT_TRUE(polygonFootprints(f, 0, "parcels", {}, d2).empty());
    EXPECT_EQ(d2.items().size(), 1U);
  }
}

TEST(PolygonFootprints, DegenerateHoleIsDroppedWithAWarning) {
  geo::Feature f = polygonFeature({{rect(0, 0, 10, 10), {{{1, 1}, {2, 2}, {3, 3}}}}}, 5);
  Diagnostics d;
  const auto out = polygonFootprints(f, 0, "parcels", {}, d);
  ASSERT_EQ(d.items().size(), 1U);
  EXPECT_EQ(d.items()[0].severity, Severity::Warning);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_NEAR(footprintArea(out[0]), 100.0, 1e-12);
}

TEST(PolygonFootprints, CoveringTheWholeGridGivesEveryCellItsSquare) {
  const FootprintOptions o = gridOptions({-50, -30}, 25.0, 4, 3);
  const auto out = polygons(polygonFeature({{rect(-1000, -2000, 3000, 1000), {}}}), o);
  ASSERT_EQ(out.size(), 12U);
  std::set<int> cells;
  for (const auto& fp : out) {
    cells.insert(fp.cell);
    EXPECT_NEAR(footprintArea(fp), 625.0, 1e-9);
    EXPECT_EQ(fp.boundary.size(), 4U);
  }
  EXPECT_EQ(cells.size(), 12U);
  // The same with the grid inside a hole-free polygon with a rotated, irregular outline.
  const auto rotated = polygons(polygonFeature({{{{-400, 10}, {20, -500}, {900, 30}, {10, 700}}, {}}}), o);
  EXPECT_EQ(rotated.size(), 12U);
  EXPECT_NEAR(totalArea(rotated), 100.0 * 75.0, 1e-9);
}

TEST(PolygonFootprints, OutsideTheGridGivesNoPieces) {
  const FootprintOptions o = gridOptions({0, 0}, 10.0, 4, 4);
  EXPECT_TRUE(polygons(polygonFeature({{rect(50, 50, 60, 60), {}}}), o).empty());
  EXPECT_TRUE(polygons(polygonFeature({{rect(-20, 0, -1, 40), {}}}), o).empty());
  // touching the extent from outside along an edge: no area inside
  EXPECT_TRUE(polygons(polygonFeature({{rect(40, 0, 50, 40), {}}}), o).empty());
}

TEST(PolygonFootprints, InvalidGridIsReported) {
  Diagnostics d;
  FootprintOptions o = gridOptions({0, 0}, 0.0, 4, 4);
  EXPECT_TRUE(polygonFootprints(polygonFeature({{rect(0, 0, 1, 1), {}}}), 0, "parcels", o, d).empty());
  EXPECT_EQ(d.count(Severity::Error), 1U);
}

/// Pieces of a 4×4 grid: one per cell met, each within its cell, total area conserved.
void expectClippedLikeUnclipped(const geo::Feature& f, const FootprintOptions& grid) {
  const auto whole = polygons(f);
  const auto pieces = polygons(f, grid);
  ASSERT_EQ(whole.size(), 1U);
  const double a = footprintArea(whole[0]);
  EXPECT_NEAR(totalArea(pieces), a, 1e-9 * a);
  std::set<int> cells;
  for (const auto& fp : pieces) EXPECT_TRUE(cells.insert(fp.cell).second) << "two pieces for cell " << fp.cell;
  EXPECT_TRUE(boundaryOnRingsOrGrid(whole, allRings(f), {}, 100.0));
  EXPECT_TRUE(boundaryOnRingsOrGrid(pieces, allRings(f), grid, 100.0));
}

TEST(PolygonFootprints, ClippingToAGridConservesArea) {
  const FootprintOptions grid = gridOptions({0, 0}, 25.0, 4, 4);
  // star with a hole, entirely inside the grid
  geo::Ring star;
  geo::Ring hole;
  for (int i = 0; i < 14; ++i) {
    const double angle = 2.0 * kPi * i / 14.0 + 0.1;
    const double r = i % 2 == 0 ? 45.0 : 18.0;
    star.push_back(Vec(50.3, 49.1) + r * Vec(std::cos(angle), std::sin(angle)));
    hole.push_back(Vec(50.3, 49.1) + 9.0 * Vec(std::cos(-angle), std::sin(-angle)));
  }
  expectClippedLikeUnclipped(polygonFeature({{star, {hole}}}), grid);
  // vertices and edges exactly on grid lines
  expectClippedLikeUnclipped(
      polygonFeature({{{{0, 0}, {50, 0}, {75, 25}, {75, 75}, {25, 100}, {25, 50}}, {rect(50, 50, 75, 75)}}}), grid);
  const auto onLines = polygons(polygonFeature({{rect(25, 25, 75, 75), {}}}), grid);
  EXPECT_EQ(onLines.size(), 4U);
  for (const auto& fp : onLines) EXPECT_NEAR(footprintArea(fp), 625.0, 1e-9);
  // a bow-tie crossing cell corners
  expectClippedLikeUnclipped(polygonFeature({{{{1, 1}, {99, 99}, {99, 1}, {1, 99}}, {}}}), grid);
}

TEST(PolygonFootprints, AdversarialShapes) {
  const FootprintOptions grid = gridOptions({-3, -3}, 7.0, 5, 5);
  std::vector<geo::Feature> cases;
  // spike going out and back (zero-width), comb, sliver, tiny polygon far from the origin
  cases.push_back(polygonFeature({{{{0, 0}, {10, 0}, {10, 5}, {20, 5}, {10, 5}, {10, 10}, {0, 10}}, {}}}));
  geo::Ring comb = {{0, 0}};
  for (int i = 0; i < 10; ++i) {
    comb.push_back({i * 3.0 + 1, 0});
    comb.push_back({i * 3.0 + 1, 20});
    comb.push_back({i * 3.0 + 2, 20});
    comb.push_back({i * 3.0 + 2, 0});
  }
  comb.push_back({31, -5});
  cases.push_back(polygonFeature({{comb, {}}}));
  cases.push_back(polygonFeature({{{{0, 0}, {30, 1e-9}, {0, 2e-9}}, {}}}));
  cases.push_back(polygonFeature({{{{1e5, 1e5}, {1e5 + 1e-6, 1e5}, {1e5, 1e5 + 1e-6}}, {}}}));
  // a ring through the same vertex several times (figure eight, rosette)
  cases.push_back(polygonFeature({{{{0, 0}, {5, 5}, {10, 0}, {10, 10}, {5, 5}, {0, 10}}, {}}}));
  cases.push_back(polygonFeature({{{{5, 5}, {10, 5}, {10, 6}, {5, 5}, {5, 10}, {4, 10}, {5, 5}, {0, 5}, {0, 4}}, {}}}));
  // the same ring twice (two polygons: united) and a ring with many collinear overlapping edges
  cases.push_back(polygonFeature({{rect(0, 0, 5, 5), {}}, {rect(0, 0, 5, 5), {}}}));
  cases.push_back(polygonFeature({{{{0, 0}, {10, 0}, {5, 0}, {15, 0}, {15, 3}, {0, 3}}, {}}}));
  for (std::size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE("case " + std::to_string(i));
    const auto rings = allRings(cases[i]);
    for (const auto& options : {FootprintOptions{}, grid}) {
      Diagnostics d;
      const auto out = polygons(cases[i], options, d);
      EXPECT_TRUE(allValid(out, 3, options));
      EXPECT_TRUE(boundaryOnRingsOrGrid(out, rings, options, 100.0));
      // coverage at a lattice of probe points
      const auto ix = index(out);
      for (int x = -3; x <= 33; ++x) {
        for (int y = -3; y <= 22; ++y) {
          const Vec p(x + 0.37, y + 0.61);
          if (nearRings(rings, p, 1e-6)) continue;
          const bool inGrid = !options.cells || (p.x > -3 && p.x < 32 && p.y > -3 && p.y < 32);
          EXPECT_EQ(covered(ix, p), featureCovers(cases[i], p) && inGrid) << p.x << ", " << p.y;
        }
      }
    }
  }
  // expected areas of some of them
  EXPECT_NEAR(totalArea(polygons(cases[0])), 100.0, 1e-12);
  EXPECT_NEAR(totalArea(polygons(cases[4])), 50.0, 1e-12);
  // the same square twice as two polygons: united, each polygon its own piece
  EXPECT_NEAR(totalArea(polygons(cases[6])), 50.0, 1e-12);
  EXPECT_NEAR(totalArea(polygons(cases[7])), 45.0, 1e-12);
}

TEST(PolygonFootprints, ManyConcurrentCrossingsKeepTheRingsStraight) {
  // Lattice rings where CGAL's inexact crossing points made constraints snap to far vertices
  // (the fast triangulation is then redone with exact constructions).
  const std::vector<geo::Ring> rings = {
      ringOf({100, 100, 100, 100, 60, 20, 60, 20, 60, 0, 0, 80, 60, 0, 20, 0, 20, 20, 80, 40, 40, 80, 20, 60}),
      ringOf({0, 60, 0, 100, 80, 60, 80, 60, 20, 100, 40, 40, 0, 40, 60, 40, 20, 0, 100, 40, 80, 40, 40, 80}),
      ringOf({60, 100, 0, 80, 100, 40, 60, 80, 60, 80, 100, 20, 60, 20, 60, 100, 60, 100, 40, 100})};
  const geo::Feature f = polygonFeature({{rings[0], {}}, {rings[1], {}}, {rings[2], {}}});
  const auto raw = allRings(f);
  for (const auto& options :
       {FootprintOptions{}, gridOptions({-7.93667006203634, 9.7631083419364764}, 21.254075848575663, 5, 4),
        gridOptions({-20, 0}, 20.0, 6, 5)}) {
    const auto out = polygons(f, options);
    EXPECT_TRUE(boundaryOnRingsOrGrid(out, raw, options, 100.0));
    const auto ix = index(out);
    for (int x = 0; x <= 100; ++x) {
      for (int y = 0; y <= 100; ++y) {
        const Vec p(x + 0.31, y + 0.47);
        if (nearRings(raw, p, 1e-7)) continue;
        bool inGrid = true;
        if (options.cells) {
          const CellGrid& g = *options.cells;
          inGrid = p.x > g.origin.x && p.y > g.origin.y && p.x < g.origin.x + g.columns * g.cellSize &&
                   p.y < g.origin.y + g.rows * g.cellSize;
        }
        ASSERT_EQ(covered(ix, p), featureCovers(f, p) && inGrid) << p.x << ", " << p.y;
      }
    }
  }
}

/// Random features: star-shaped rings with star holes, random self-intersecting rings,
/// several overlapping rings, and rings on a small integer lattice (exact collinear overlaps,
/// vertices on edges, shared edges).
geo::Feature randomPolygonFeature(std::mt19937_64& rng, int kind) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto integer = [&](int n) { return static_cast<int>(rng() % static_cast<std::uint64_t>(n)); };
  geo::Feature f;
  f.fid = 1;
  const auto star = [&](Vec centre, double rmin, double rmax, int n, bool clockwise) {
    std::vector<double> angles;
    for (int i = 0; i < n; ++i) angles.push_back(2.0 * kPi * u(rng));
    std::sort(angles.begin(), angles.end());
    if (clockwise) std::reverse(angles.begin(), angles.end());
    geo::Ring ring;
    for (double a : angles) ring.push_back(centre + (rmin + (rmax - rmin) * u(rng)) * Vec(std::cos(a), std::sin(a)));
    return ring;
  };
  switch (kind) {
    case 0: {  // star with optional star holes
      geo::Polygon p;
      const Vec c(20 + 60 * u(rng), 20 + 60 * u(rng));
      p.outer = star(c, 10, 40, 3 + integer(40), integer(2) == 0);
      for (int h = integer(3); h > 0; --h) p.holes.push_back(star(c, 1, 9, 3 + integer(12), integer(2) == 0));
      f.polygons.push_back(p);
      break;
    }
    case 1: {  // random self-intersecting ring
      geo::Ring ring;
      for (int n = 3 + integer(25); n > 0; --n) ring.push_back({100 * u(rng), 100 * u(rng)});
      f.polygons.push_back({ring, {}});
      break;
    }
    case 2: {  // several random rings over each other
      for (int k = 1 + integer(3); k > 0; --k) {
        geo::Ring ring;
        for (int n = 3 + integer(8); n > 0; --n) ring.push_back({100 * u(rng), 100 * u(rng)});
        f.polygons.push_back({ring, {}});
      }
      break;
    }
    default: {  // lattice rings with repeated points
      for (int k = 1 + integer(3); k > 0; --k) {
        geo::Ring ring;
        for (int n = 3 + integer(10); n > 0; --n) {
          ring.push_back(Vec(integer(6), integer(6)) * 20.0);
          if (integer(5) == 0) ring.push_back(ring.back());
        }
        f.polygons.push_back({ring, {}});
      }
      break;
    }
  }
  return f;
}

TEST(PolygonFootprints, RandomPolygonsMatchEvenOddByMonteCarlo) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checkedPoints = 0;
  for (int iteration = 0; iteration < 320; ++iteration) {
    SCOPED_TRACE("iteration " + std::to_string(iteration));
    const geo::Feature f = randomPolygonFeature(rng, iteration % 4);
    const auto rings = allRings(f);
    FootprintOptions options;
    if (iteration % 4 == 3) {
      // grid lines through the lattice points: vertices and edges exactly on cell borders
      options = gridOptions({-20, 0}, 20.0 * static_cast<double>(1 + rng() % 2), 2 + static_cast<int>(rng() % 6),
                            2 + static_cast<int>(rng() % 6));
    } else if (iteration % 2 == 1) {
      options = gridOptions({-10 + 30 * u(rng), -10 + 30 * u(rng)}, 5 + 30 * u(rng), 1 + static_cast<int>(rng() % 6),
                            1 + static_cast<int>(rng() % 6));
    }
    Diagnostics d;
    const auto out = polygons(f, options, d);  // lattice rings may be degenerate: diagnostics allowed
    ASSERT_TRUE(allValid(out, 3, options));
    ASSERT_TRUE(boundaryOnRingsOrGrid(out, rings, options, 100.0));
    const auto ix = index(out);
    const auto inGrid = [&](const Vec& p) {
      if (!options.cells) return true;
      const CellGrid& g = *options.cells;
      return p.x >= g.origin.x && p.y >= g.origin.y && p.x <= g.origin.x + g.columns * g.cellSize &&
             p.y <= g.origin.y + g.rows * g.cellSize;
    };
    const auto nearGridLine = [&](const Vec& p) {
      if (!options.cells) return false;
      const CellGrid& g = *options.cells;
      const Vec q = (p - g.origin) / g.cellSize;
      return std::abs(q.x - std::round(q.x)) < 1e-9 || std::abs(q.y - std::round(q.y)) < 1e-9;
    };
    // Monte-Carlo over the box [-5, 105]²
    const int samples = 400;
    int inside = 0;
    for (int s = 0; s < samples; ++s) {
      const Vec p(-5 + 110 * u(rng), -5 + 110 * u(rng));
      const bool reference = featureCovers(f, p) && inGrid(p);
      // the pieces of overlapping polygons overlap: count each polygon covering p
      if (inGrid(p)) inside += polygonsCovering(f, p);
      if (nearRings(rings, p, 1e-7) || nearGridLine(p)) continue;
      int strict = 0;
      const bool got = covered(ix, p, &strict);
      ++checkedPoints;
      ASSERT_EQ(got, reference) << "at (" << p.x << ", " << p.y << ")";
      EXPECT_LE(strict, polygonsCovering(f, p)) << "pieces of one polygon overlap";
    }
    // binomial spread of the hit count if the footprints' area is right
    const double boxArea = 110.0 * 110.0;
    const double p0 = std::clamp(totalArea(out) / boxArea, 0.0, 1.0);
    const double fraction = static_cast<double>(inside) / samples;
    const double sigma = boxArea * std::sqrt(p0 * (1 - p0) / samples) + boxArea / samples;
    EXPECT_NEAR(totalArea(out), boxArea * fraction, 5.0 * sigma);
  }
  EXPECT_GT(checkedPoints, 100000);
}

TEST(PolygonFootprints, LargePolygonOnAFineGrid) {
  geo::Ring circle;
  for (int i = 0; i < 4000; ++i) {
    const double a = 2.0 * kPi * i / 4000.0;
    circle.push_back(Vec(500, 500) + 480.0 * Vec(std::cos(a), std::sin(a)) + 3.0 * Vec(std::sin(37 * a), 0));
  }
  const geo::Feature f = polygonFeature({{circle, {rect(300, 300, 700, 700)}}});
  const auto whole = polygons(f);
  const auto pieces = polygons(f, gridOptions({0, 0}, 1000.0 / 16.0, 16, 16));
  ASSERT_EQ(whole.size(), 1U);
  EXPECT_NEAR(totalArea(pieces), footprintArea(whole[0]), 1e-9 * footprintArea(whole[0]));
  EXPECT_GT(pieces.size(), 150U);
  EXPECT_TRUE(boundaryOnRingsOrGrid(pieces, allRings(f), gridOptions({0, 0}, 1000.0 / 16.0, 16, 16), 1000.0));
}

// ---------------------------------------------------------------------------------------------
// Line reference: the coverage rules of footprints.hpp, arcs exact

geo::Feature lineFeature(std::vector<geo::LineString> lines, std::int64_t fid = 11) {
  geo::Feature f;
  f.fid = fid;
  f.lines = std::move(lines);
  return f;
}

struct LineRule {
  LineShape shape;
  std::vector<std::vector<Vec>> lines;  ///< repeated points dropped

  /// Discs of the rule (round joins and caps): points near their circles are not compared.
  [[nodiscard]] std::vector<Vec> discCentres() const {
    std::vector<Vec> c;
    for (const auto& l : lines) {
      if (shape.cap == LineCap::Round) {
        c.push_back(l.front());
        c.push_back(l.back());
      }
      if (shape.join == LineJoin::Round) {
        for (std::size_t i = 1; i + 1 < l.size(); ++i) c.push_back(l[i]);
      }
    }
    return c;
  }

  [[nodiscard]] bool covers(const Vec& p) const {
    const double h = shape.width / 2;
    for (const auto& l : lines) {
      if (l.size() == 1) {
        if (shape.cap == LineCap::Round && length(p - l[0]) <= h) return true;
        if (shape.cap == LineCap::Square && std::abs(p.x - l[0].x) <= h && std::abs(p.y - l[0].y) <= h) return true;
        continue;
      }
      for (std::size_t i = 0; i + 1 < l.size(); ++i) {
        const Vec d = l[i + 1] - l[i];
        const double t = dot(p - l[i], d) / dot(d, d);
        if (t >= 0 && t <= 1 && std::abs(cross(d, p - l[i])) / length(d) <= h) return true;
      }
      for (std::size_t i = 1; i + 1 < l.size(); ++i) {
        if (joinCovers(l[i - 1], l[i], l[i + 1], p, h)) return true;
      }
      if (capCovers(l[0], l[1], p, h) || capCovers(l[l.size() - 1], l[l.size() - 2], p, h)) return true;
    }
    return false;
  }

  /// Cap at `end`, whose segment comes from `inner`.
  [[nodiscard]] bool capCovers(const Vec& end, const Vec& inner, const Vec& p, double h) const {
    if (shape.cap == LineCap::Round) return length(p - end) <= h;
    if (shape.cap == LineCap::Flat) return false;
    const Vec out = (end - inner) / length(end - inner);
    const double along = dot(p - end, out);
    return along >= 0 && along <= h && std::abs(cross(out, p - end)) <= h;
  }

  [[nodiscard]] bool joinCovers(const Vec& a, const Vec& v, const Vec& b, const Vec& p, double h) const {
    const Vec in = (v - a) / length(v - a);
    const Vec out = (b - v) / length(b - v);
    if (cross(v - a, b - v) == 0 && dot(v - a, b - v) > 0) return false;  // straight
    if (shape.join == LineJoin::Round) return length(p - v) <= h;
    // The outer side is where the turn is not: the corners there, at distance h from v.
    const double side = cross(in, out) > 0 ? -1.0 : 1.0;  // +1: outer side is on the left
    const Vec c0 = v + side * h * Vec(-in.y, in.x);
    const Vec c1 = v + side * h * Vec(-out.y, out.x);
    // θ between the segments at v, measured with atan2 (independent of the implementation)
    const Vec toA = a - v;
    const Vec toB = b - v;
    const double theta = std::atan2(std::abs(cross(toA, toB)), dot(toA, toB));
    const double miterLength = h / std::sin(theta / 2);
    std::vector<Vec> poly;
    if (shape.join == LineJoin::Miter && miterLength <= shape.miterLimit * h) {
      const Vec bisector = (c0 - v) + (c1 - v);
      poly = {v, c0, v + miterLength * bisector / length(bisector), c1};
    } else {
      poly = {v, c0, c1};
    }
    return inConvex(poly, p);
  }

  /// Point in a convex polygon of either orientation (degenerate ones contain nothing).
  static bool inConvex(const std::vector<Vec>& poly, const Vec& p) {
    double area = 0;
    for (std::size_t i = 0; i < poly.size(); ++i) area += cross(poly[i], poly[(i + 1) % poly.size()]);
    if (area == 0) return false;
    const double s = area > 0 ? 1.0 : -1.0;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      if (s * area2(poly[i], poly[(i + 1) % poly.size()], p) < 0) return false;
    }
    return true;
  }
};

LineRule ruleFor(const geo::Feature& f, const LineShape& shape) {
  LineRule r{shape, {}};
  for (auto l : f.lines) {
    l.erase(std::unique(l.begin(), l.end()), l.end());
    if (!l.empty()) r.lines.push_back(l);
  }
  return r;
}

std::vector<Footprint> lines(const geo::Feature& f, const LineShape& shape, const FootprintOptions& options = {}) {
  Diagnostics d;
  auto out = lineFootprints(f, 4, "roads", shape, options, d);
  EXPECT_TRUE(d.empty()) << (d.empty() ? "" : d.items()[0].toString());
  EXPECT_TRUE(allValid(out, 4, options));
  return out;
}

/// A piece per segment, join and cap shape (not united), to check each shape.
std::vector<Footprint> shapes(const geo::Feature& f, const LineShape& shape, FootprintOptions options = {}) {
  options.uniteLines = false;
  return lines(f, shape, options);
}

LineShape shapeOf(double width, LineJoin join, LineCap cap, double miterLimit = 4.0) {
  LineShape shape;
  shape.width = width;
  shape.join = join;
  shape.cap = cap;
  shape.miterLimit = miterLimit;
  return shape;
}

/// Area of the part of footprint `fp` on the side of the line through `o` where dot(p − o, n) ≥ 0.
double areaBeyond(const Footprint& fp, const Vec& o, const Vec& n) {
  double total = 0;
  for (const auto& t : fp.triangles) {
    std::vector<Vec> poly = {fp.vertices[t[0]], fp.vertices[t[1]], fp.vertices[t[2]]};
    std::vector<Vec> clipped;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Vec& p = poly[i];
      const Vec& q = poly[(i + 1) % poly.size()];
      const double sp = dot(p - o, n);
      const double sq = dot(q - o, n);
      if (sp >= 0) clipped.push_back(p);
      if ((sp >= 0) != (sq >= 0)) clipped.push_back(p + (sp / (sp - sq)) * (q - p));
    }
    for (std::size_t i = 0; i + 2 < clipped.size(); ++i) {
      total += 0.5 * area2(clipped[0], clipped[i + 1], clipped[i + 2]);
    }
  }
  return total;
}

/// Circle area lost by an inscribed polygon with sagitta ≤ tol: at most circumference · tol.
double arcBound(double r, double tol) { return 2 * kPi * r * tol; }

// ---------------------------------------------------------------------------------------------
// Line tests

TEST(LineFootprints, StraightTwoSegmentRoundLineIsACapsule) {
  for (const double width : {0.01, 1.0, 7.5, 5000.0}) {
    SCOPED_TRACE("width " + std::to_string(width));
    const geo::Feature f = lineFeature({{{0, 0}, {30, 40}, {75, 100}}});
    FootprintOptions o;
    o.chordTolerance = 0.02;
    const auto out = shapes(f, shapeOf(width, LineJoin::Round, LineCap::Round), o);
    EXPECT_EQ(countKind(out, PieceKind::Segment), 2U);
    EXPECT_EQ(countKind(out, PieceKind::Join), 0U) << "nothing on a straight continuation";
    ASSERT_EQ(countKind(out, PieceKind::Cap), 2U);
    const double r = width / 2;
    const double exact = 125.0 * width + kPi * r * r;
    // union: the two rectangles tile the body; the caps add what lies beyond the ends
    const Vec d(0.6, 0.8);
    double area = totalArea(out, PieceKind::Segment);
    EXPECT_NEAR(area, 125.0 * width, 1e-9 * area);
    for (const auto& fp : out) {
      if (fp.kind != PieceKind::Cap) continue;
      Vec centre(0.0);
      for (const auto& v : fp.vertices) centre += v / static_cast<double>(fp.vertices.size());
      const bool start = length(centre) < length(centre - Vec(75, 100));
      area += start ? areaBeyond(fp, {0, 0}, -d) : areaBeyond(fp, {75, 100}, d);
      // the outer half disc when the end segment (50 m, 75 m) holds the other half, else the
      // full disc: area within the chord bound
      const double disc = (r <= 50.0 ? 0.5 : 1.0) * kPi * r * r;
      EXPECT_LE(footprintArea(fp), disc * (1 + 1e-12));
      EXPECT_GE(footprintArea(fp), disc - arcBound(r, o.chordTolerance));
      for (const auto& v : fp.vertices)
        EXPECT_NEAR(length(v - (start ? Vec(0, 0) : Vec(75, 100))), r, 1e-12 * (125 + r));
    }
    EXPECT_LE(area, exact * (1 + 1e-12));
    EXPECT_GE(area, exact - arcBound(r, o.chordTolerance));
  }
}

TEST(LineFootprints, ArcsMeetTheChordTolerance) {
  for (const double tol : {0.001, 0.02, 0.5, 10.0}) {
    for (const double width : {0.01, 2.0, 40.0, 5000.0}) {
      FootprintOptions o;
      o.chordTolerance = tol;
      const auto out = lines(lineFeature({{{3, 4}}}), shapeOf(width, LineJoin::Round, LineCap::Round), o);
      ASSERT_EQ(out.size(), 1U);
      const auto& fp = out[0];
      const double r = width / 2;
      // sagitta of every boundary chord
      for (const auto& b : fp.boundary) {
        const Vec mid = 0.5 * (fp.vertices[b[0]] + fp.vertices[b[1]]);
        EXPECT_LE(r - length(mid - Vec(3, 4)), tol + 1e-9);
      }
      EXPECT_GE(fp.boundary.size(), 8U);
    }
  }
}

TEST(LineFootprints, JoinAndCapShapesHaveTheirClosedFormAreas) {
  const double width = 4.0;
  const double h = width / 2;
  for (const double turnDegrees : {10.0, 45.0, 90.0, 120.0, 150.0, 170.0}) {
    for (const double side : {1.0, -1.0}) {  // left and right turns
      const double turn = side * turnDegrees * kPi / 180.0;
      const Vec v(10, 0);
      const Vec next = v + 10.0 * Vec(std::cos(turn), std::sin(turn));
      const geo::Feature f = lineFeature({{{0, 0}, v, next}});
      const double phi = turnDegrees * kPi / 180.0;
      SCOPED_TRACE("turn " + std::to_string(turn));
      // bevel: triangle with legs h at angle φ
      {
        const auto out = shapes(f, shapeOf(width, LineJoin::Bevel, LineCap::Flat));
        EXPECT_EQ(countKind(out, PieceKind::Cap), 0U);
        ASSERT_EQ(countKind(out, PieceKind::Join), 1U);
        EXPECT_NEAR(totalArea(out, PieceKind::Join), 0.5 * h * h * std::sin(phi), 1e-12);
        EXPECT_NEAR(totalArea(out, PieceKind::Segment), 2 * 10.0 * width, 1e-12);
      }
      // miter within the limit: kite h² tan(φ/2); beyond it: the bevel
      for (const double limit : {1.5, 4.0, 10.0}) {
        const auto out = shapes(f, shapeOf(width, LineJoin::Miter, LineCap::Square, limit));
        const bool miter = 1.0 / std::cos(phi / 2) <= limit;
        const double expected = miter ? h * h * std::tan(phi / 2) : 0.5 * h * h * std::sin(phi);
        EXPECT_NEAR(totalArea(out, PieceKind::Join), expected, 1e-12 * std::max(1.0, expected)) << "limit " << limit;
        EXPECT_EQ(countKind(out, PieceKind::Cap), 2U);
        EXPECT_NEAR(totalArea(out, PieceKind::Cap), 2 * width * h, 1e-12);
      }
      // round join: the outer wedge of angle φ (the rectangles, 10 m ≥ h long, hold the rest of
      // the disc); with segments shorter than h, the full disc
      {
        const auto out = shapes(f, shapeOf(width, LineJoin::Round, LineCap::Round));
        EXPECT_EQ(countKind(out, PieceKind::Join), 1U);
        EXPECT_NEAR(totalArea(out, PieceKind::Join), 0.5 * h * h * phi, arcBound(h, 0.02));
        const auto wide = shapes(f, shapeOf(25.0, LineJoin::Round, LineCap::Round));
        EXPECT_NEAR(totalArea(wide, PieceKind::Join), kPi * 12.5 * 12.5, arcBound(12.5, 0.02));
      }
    }
  }
}

TEST(LineFootprints, SinglePointLines) {
  const geo::Feature f = lineFeature({{{5, 5}, {5, 5}, {5, 5}}});
  const auto round = shapes(f, shapeOf(2.0, LineJoin::Round, LineCap::Round));
  ASSERT_EQ(round.size(), 1U);
  EXPECT_NEAR(footprintArea(round[0]), kPi, arcBound(1.0, 0.02));
  const auto square = shapes(f, shapeOf(2.0, LineJoin::Round, LineCap::Square));
  ASSERT_EQ(square.size(), 1U);
  EXPECT_NEAR(footprintArea(square[0]), 4.0, 1e-12);
  EXPECT_TRUE(lines(f, shapeOf(2.0, LineJoin::Round, LineCap::Flat)).empty());
}

TEST(LineFootprints, HairpinsAndZeroLengthSegments) {
  const geo::Feature f = lineFeature({{{0, 0}, {10, 0}, {10, 0}, {0, 0}, {0, 0}, {0, 10}}});
  for (const auto join : {LineJoin::Round, LineJoin::Bevel, LineJoin::Miter}) {
    for (const auto cap : {LineCap::Round, LineCap::Square, LineCap::Flat}) {
      const auto out = shapes(f, shapeOf(3.0, join, cap, 1000.0));
      EXPECT_EQ(countKind(out, PieceKind::Segment), 3U);
      // 180° at (10, 0): a disc for round, nothing for bevel and miter; 90° at (0, 0): a join
      EXPECT_EQ(countKind(out, PieceKind::Join), 2U - (join == LineJoin::Round ? 0U : 1U));
    }
  }
  // nearly a hairpin with a huge miter limit: a long but valid miter
  const geo::Feature g = lineFeature({{{0, 0}, {10, 0}, {0, 1e-7}}});
  const auto out = shapes(g, shapeOf(3.0, LineJoin::Miter, LineCap::Flat, 1e12));
  ASSERT_EQ(countKind(out, PieceKind::Join), 1U);
  EXPECT_GT(totalArea(out, PieceKind::Join), 1e5);
}

TEST(LineFootprints, ExtremeWidths) {
  const geo::Feature f = lineFeature({{{1000.5, -300.25}, {1003.5, -296.25}, {1003.6, -296.0}, {990, -310}}});
  for (const double width : {0.01, 5000.0}) {
    for (const auto join : {LineJoin::Round, LineJoin::Bevel, LineJoin::Miter}) {
      for (const auto cap : {LineCap::Round, LineCap::Square, LineCap::Flat}) {
        const auto out = shapes(f, shapeOf(width, join, cap));
        EXPECT_NEAR(totalArea(out, PieceKind::Segment), width * (5.0 + std::hypot(0.1, 0.25) + std::hypot(13.6, 14.0)),
                    1e-9 * width * 25);
        if (cap == LineCap::Square) {
          EXPECT_NEAR(totalArea(out, PieceKind::Cap), width * width, 1e-9 * width * width);
        }
        // United: one valid piece, no larger than the shapes together, no smaller than the
        // longest segment's rectangle.
        FootprintOptions unite;
        unite.uniteLines = true;
        const auto united = lines(f, shapeOf(width, join, cap), unite);
        ASSERT_EQ(united.size(), 1U);
        EXPECT_LE(totalArea(united), totalArea(out) * (1.0 + 1e-9));
        EXPECT_GE(totalArea(united), width * std::hypot(13.6, 14.0) * (1.0 - 1e-9));
      }
    }
  }
  // widths far larger than the segments, on a grid
  const auto out =
      lines(f, shapeOf(5000.0, LineJoin::Round, LineCap::Round), gridOptions({-2000, -3000}, 1000.0, 5, 6));
  EXPECT_GT(out.size(), 20U);
}

TEST(LineFootprints, LinesInPixelsScaleAroundTheirCentres) {
  // Repeated point, sharp turn, hairpin; anchors differ per vertex (the repeated point's is
  // dropped with it).
  const geo::Feature f = lineFeature({{{0, 0}, {40, 0}, {40, 0}, {70, 30}, {20, 32}, {60, 32}}});
  LineShape base;
  base.width = 12.0;  // the largest width
  base.widthPixels = 3.0;
  base.anchorHeights = {{5.0, 7.0, 7.0, 9.0, 11.0, 13.0}};
  const FootprintOptions grid = gridOptions({-100, -100}, 16.0, 20, 20);  // not used for pixels
  std::mt19937_64 rng(5);
  for (const auto join : {LineJoin::Round, LineJoin::Bevel, LineJoin::Miter}) {
    for (const auto cap : {LineCap::Round, LineCap::Square, LineCap::Flat}) {
      LineShape shape = base;
      shape.join = join;
      shape.cap = cap;
      Diagnostics d;
      const std::vector<Footprint> out = lineFootprints(f, 4, "roads", shape, grid, d);
      EXPECT_TRUE(d.empty());
      ASSERT_FALSE(out.empty());
      EXPECT_TRUE(allValid(out, 4, FootprintOptions{}));  // unsplit: no cells
      // Per-centre half widths up to the largest: every triangle keeps its orientation.
      std::map<std::pair<double, double>, double> half;
      std::uniform_real_distribution<double> fraction(0.0, 1.0);
      for (const Footprint& fp : out) {
        ASSERT_TRUE(fp.scalable());
        ASSERT_EQ(fp.centres.size(), fp.vertices.size());
        ASSERT_EQ(fp.directions.size(), fp.vertices.size());
        for (std::size_t k = 0; k < fp.vertices.size(); ++k) {
          const Vec c(fp.centres[k]);
          EXPECT_EQ(fp.vertices[k], c + 6.0 * fp.directions[k]);
          const auto& raw = f.lines[0];
          const auto at = std::find(raw.begin(), raw.end(), c);
          ASSERT_NE(at, raw.end()) << "centre off the line";
          EXPECT_EQ(fp.centres[k].z, base.anchorHeights[0][static_cast<std::size_t>(at - raw.begin())]);
          half.try_emplace({c.x, c.y}, 6.0 * fraction(rng));
        }
        std::vector<Vec> scaled;
        for (std::size_t k = 0; k < fp.vertices.size(); ++k) {
          const Vec c(fp.centres[k]);
          scaled.push_back(c + half.at({c.x, c.y}) * fp.directions[k]);
        }
        for (const auto& t : fp.triangles) {
          EXPECT_GE(area2(scaled[t[0]], scaled[t[1]], scaled[t[2]]), -1e-12);
        }
      }
      // Round joins and caps are whole discs (a segment's trapezoid need not hold their inner half).
      if (join == LineJoin::Round && cap == LineCap::Round) {
        for (const Footprint& fp : out) {
          if (fp.kind == PieceKind::Join || fp.kind == PieceKind::Cap) {
            EXPECT_TRUE(
                std::none_of(fp.directions.begin(), fp.directions.end(), [](const Vec& v) { return v == Vec(0.0); }));
          }
        }
      }
    }
  }
}

TEST(LineFootprints, BadWidthsAreSkippedWithADiagnostic) {
  const geo::Feature f = lineFeature({{{0, 0}, {10, 0}}}, 77);
  for (const double width :
       {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    Diagnostics d;
    EXPECT_TRUE(lineFootprints(f, 0, "roads", shapeOf(width, LineJoin::Round, LineCap::Round), {}, d).empty());
    ASSERT_EQ(d.items().size(), 1U);
    EXPECT_EQ(d.items()[0].feature, "77");
    EXPECT_EQ(d.items()[0].layer, "roads");
  }
  // a line with a NaN: skipped, the feature's other lines still count
  const geo::Feature g = lineFeature({{{0, 0}, {std::numeric_limits<double>::quiet_NaN(), 0}}, {{0, 0}, {10, 0}}}, 78);
  Diagnostics d;
  const auto out = lineFootprints(g, 0, "roads", shapeOf(2.0, LineJoin::Round, LineCap::Flat), {}, d);
  EXPECT_EQ(d.items().size(), 1U);
  EXPECT_EQ(out.size(), 1U);
}

TEST(LineFootprints, SplittingAtCellsConservesEveryPiece) {
  const FootprintOptions grid = gridOptions({-30, -30}, 10.0, 10, 10);
  const geo::Feature f = lineFeature({{{-5, -3}, {37, 12}, {41, 44}, {3, 50}, {3, 50}, {10, 10}}, {{20, 20}}});
  for (const auto join : {LineJoin::Round, LineJoin::Bevel, LineJoin::Miter}) {
    for (const auto cap : {LineCap::Round, LineCap::Square, LineCap::Flat}) {
      const LineShape shape = shapeOf(6.0, join, cap);
      const auto whole = lines(f, shape);
      const auto split = lines(f, shape, grid);
      EXPECT_GT(split.size(), whole.size());
      for (const auto kind : {PieceKind::Segment, PieceKind::Join, PieceKind::Cap, PieceKind::Line}) {
        const double a = totalArea(whole, kind);
        EXPECT_NEAR(totalArea(split, kind), a, 1e-9 * std::max(a, 1.0));
      }
      // the union too: the same points are covered
      const auto wi = index(whole);
      const auto si = index(split);
      std::mt19937_64 rng(5);
      std::uniform_real_distribution<double> u(-15, 55);
      for (int s = 0; s < 300; ++s) {
        const Vec p(u(rng), u(rng));
        EXPECT_EQ(covered(wi, p), covered(si, p));
      }
    }
  }
  // partly outside the grid: nothing outside
  const auto out = lines(lineFeature({{{-100, 5}, {100, 5}}}), shapeOf(2.0, LineJoin::Round, LineCap::Round), grid);
  EXPECT_NEAR(totalArea(out), 100.0 * 2.0, 1e-9);
}

TEST(LineFootprints, RandomLinesMatchTheCoverageRulesByMonteCarlo) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto integer = [&](int n) { return static_cast<int>(rng() % static_cast<std::uint64_t>(n)); };
  int checked = 0;
  for (int iteration = 0; iteration < 240; ++iteration) {
    SCOPED_TRACE("iteration " + std::to_string(iteration));
    // integer points make exact straight continuations, hairpins and repeats likely
    geo::Feature f;
    f.fid = iteration;
    for (int k = 1 + integer(2); k > 0; --k) {
      geo::LineString l;
      const bool lattice = integer(2) == 0;
      for (int n = 1 + integer(7); n > 0; --n) {
        const int r = integer(10);
        if (l.size() >= 2 && r == 0) {
          l.push_back(l[l.size() - 2]);  // hairpin
        } else if (l.size() >= 2 && r == 1) {
          l.push_back(2.0 * l.back() - l[l.size() - 2]);  // straight on
        } else if (!l.empty() && r == 2) {
          l.push_back(l.back());  // repeat
        } else {
          l.push_back(lattice ? Vec(integer(10) * 10, integer(10) * 10) : Vec(100 * u(rng), 100 * u(rng)));
        }
      }
      f.lines.push_back(l);
    }
    const LineShape shape = shapeOf(0.2 + 30 * u(rng) * u(rng), static_cast<LineJoin>(integer(3)),
                                    static_cast<LineCap>(integer(3)), 1.0 + 7 * u(rng));
    FootprintOptions options;
    options.chordTolerance = 0.005 + 0.3 * u(rng);
    options.uniteLines = iteration % 2 == 0;  // one union piece per cell, or a piece per shape
    if (iteration % 6 == 2) {
      options.cells = CellGrid{{-30 + 40 * u(rng), -30 + 40 * u(rng)}, 5 + 40 * u(rng), 1 + integer(8), 1 + integer(8)};
    } else if (iteration % 6 == 5) {
      options.cells =
          CellGrid{{-20, -20}, 10.0 * (1 + integer(3)), 2 + integer(12), 2 + integer(12)};  // on the lattice
    }
    const auto out = lines(f, shape, options);
    const LineRule rule = ruleFor(f, shape);
    const auto centres = rule.discCentres();
    const auto ix = index(out);
    const double h = shape.width / 2;
    for (int s = 0; s < 300; ++s) {
      const Vec p(-h - 5 + (110 + 2 * h) * u(rng), -h - 5 + (110 + 2 * h) * u(rng));
      bool nearArc = false;
      for (const auto& c : centres) nearArc = nearArc || std::abs(length(p - c) - h) <= options.chordTolerance + 1e-9;
      if (nearArc) continue;
      bool inGrid = true;
      if (options.cells) {
        const CellGrid& g = *options.cells;
        const Vec q = (p - g.origin) / g.cellSize;
        if (std::abs(q.x - std::round(q.x)) < 1e-9 || std::abs(q.y - std::round(q.y)) < 1e-9) continue;
        inGrid = q.x > 0 && q.y > 0 && q.x < g.columns && q.y < g.rows;
      }
      ++checked;
      ASSERT_EQ(covered(ix, p), rule.covers(p) && inGrid) << "at (" << p.x << ", " << p.y << ")";
    }
  }
  EXPECT_GT(checked, 40000);
}

}  // namespace
}  // namespace gis::overlay
