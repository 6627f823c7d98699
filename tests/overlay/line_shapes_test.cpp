// The shapes of a line from its stations (vector_overlay/line_shapes.hpp), the seam both frames'
// lines are made through: each station in a plane of its own.
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "vector_overlay/line_shapes.hpp"

namespace gis::overlay {
namespace {

using Shapes = std::vector<std::pair<PieceKind, std::vector<ShapeCorner>>>;

Shapes shapesOf(const std::vector<LineStation>& stations, const LineShapeRules& rules) {
  Shapes out;
  lineShapes(stations, rules,
             [&out](PieceKind kind, std::vector<ShapeCorner> c) { out.emplace_back(kind, std::move(c)); });
  return out;
}

/// The stations of a polyline in one plane (the projected frame's).
std::vector<LineStation> planeStations(const std::vector<glm::dvec2>& line) {
  std::vector<LineStation> s(line.size());
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const glm::dvec2 d = glm::normalize(line[i + 1] - line[i]);
    const double length = glm::length(line[i + 1] - line[i]);
    s[i].out = d;
    s[i].outLength = length;
    s[i + 1].in = d;
    s[i + 1].inLength = length;
  }
  for (LineStation& st : s) {
    const double cross = st.in.x * st.out.y - st.in.y * st.out.x;
    st.turn = cross > 0.0 ? 1 : (cross < 0.0 ? -1 : 0);
  }
  return s;
}

glm::dvec2 rotate(const glm::dvec2& v, double a) {
  return {std::cos(a) * v.x - std::sin(a) * v.y, std::sin(a) * v.x + std::cos(a) * v.y};
}

std::size_t count(const Shapes& shapes, PieceKind kind) {
  std::size_t n = 0;
  for (const auto& s : shapes) n += s.first == kind ? 1 : 0;
  return n;
}

TEST(LineShapes, AnLGetsItsRectanglesItsJoinAndItsCapsInOrder) {
  // East 10, then north 10 (a left turn), half width 1.
  const std::vector<LineStation> st = planeStations({{0, 0}, {10, 0}, {10, 10}});
  LineShapeRules rules;
  rules.join = LineJoin::Miter;
  rules.cap = LineCap::Square;
  rules.miterLimit = 2.0;  // a right angle's miter is √2 half widths long: kept
  const Shapes shapes = shapesOf(st, rules);
  ASSERT_EQ(shapes.size(), 5U);
  EXPECT_EQ(shapes[0].first, PieceKind::Cap);
  EXPECT_EQ(shapes[1].first, PieceKind::Segment);
  EXPECT_EQ(shapes[2].first, PieceKind::Join);
  EXPECT_EQ(shapes[3].first, PieceKind::Segment);
  EXPECT_EQ(shapes[4].first, PieceKind::Cap);
  // The first rectangle: right side (−y) then left (+y), counter-clockwise.
  const std::vector<ShapeCorner>& r = shapes[1].second;
  ASSERT_EQ(r.size(), 4U);
  EXPECT_EQ(r[0].station, 0U);
  EXPECT_EQ(r[1].station, 1U);
  EXPECT_EQ(r[0].direction, glm::dvec2(0.0, -1.0));
  EXPECT_EQ(r[2].direction, glm::dvec2(0.0, 1.0));
  // The miter on the outside of the left turn (south-east): the point, the corners out, the tip.
  const std::vector<ShapeCorner>& j = shapes[2].second;
  ASSERT_EQ(j.size(), 4U);
  EXPECT_EQ(j[0].direction, glm::dvec2(0.0));
  EXPECT_NEAR(j[2].direction.x, 1.0, 1e-12);
  EXPECT_NEAR(j[2].direction.y, -1.0, 1e-12);
  // A tighter limit makes it a bevel.
  rules.miterLimit = 1.2;
  EXPECT_EQ(shapesOf(st, rules)[2].second.size(), 3U);
  // Flat caps add nothing; segments only, neither joins nor caps.
  rules.cap = LineCap::Flat;
  EXPECT_EQ(count(shapesOf(st, rules), PieceKind::Cap), 0U);
  rules.ends = false;
  const Shapes bare = shapesOf(st, rules);
  EXPECT_EQ(bare.size(), 2U);
  EXPECT_EQ(count(bare, PieceKind::Segment), 2U);
}

TEST(LineShapes, StationsInPlanesOfTheirOwnGiveTheSameShapesTurnedWithThem) {
  // The seam: a frame may give each station a plane turned any way (the globe's tangent planes);
  // every corner is then the same corner in that station's plane.
  const std::vector<glm::dvec2> line{{0, 0}, {5, 1}, {7, 6}, {3, 9}, {-2, 8}};
  const std::vector<LineStation> flat = planeStations(line);
  std::vector<LineStation> turned = flat;
  std::vector<double> angle(line.size());
  for (std::size_t s = 0; s < line.size(); ++s) {
    angle[s] = 0.7 * static_cast<double>(s) + 0.3;
    turned[s].in = rotate(flat[s].in, angle[s]);
    turned[s].out = rotate(flat[s].out, angle[s]);
  }
  for (const LineJoin join : {LineJoin::Round, LineJoin::Miter, LineJoin::Bevel}) {
    for (const LineCap cap : {LineCap::Round, LineCap::Square, LineCap::Flat}) {
      LineShapeRules rules;
      rules.join = join;
      rules.cap = cap;
      rules.wedgeLength = 0.5;
      const Shapes a = shapesOf(flat, rules), b = shapesOf(turned, rules);
      ASSERT_EQ(a.size(), b.size());
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].first, b[i].first);
        ASSERT_EQ(a[i].second.size(), b[i].second.size());
        for (std::size_t k = 0; k < a[i].second.size(); ++k) {
          const ShapeCorner& ca = a[i].second[k];
          const ShapeCorner& cb = b[i].second[k];
          ASSERT_EQ(ca.station, cb.station);
          const glm::dvec2 expected = rotate(ca.direction, angle[ca.station]);
          EXPECT_NEAR(cb.direction.x, expected.x, 1e-9) << "shape " << i << " corner " << k;
          EXPECT_NEAR(cb.direction.y, expected.y, 1e-9) << "shape " << i << " corner " << k;
        }
      }
    }
  }
}

TEST(LineShapes, APointTheFrameAddedJoinsItsPiecesOnTheBisectorWithoutAJoin) {
  // A point added along a geodesic turns by a rounding: no join there, and both pieces end on
  // the same corners, on the bisector of their sides, 1 / cos(θ/2) half widths out.
  std::vector<LineStation> st = planeStations({{0, 0}, {10, 0}, {20, 0.02}});
  st[1].given = false;
  LineShapeRules rules;
  rules.join = LineJoin::Bevel;
  const Shapes shapes = shapesOf(st, rules);
  EXPECT_EQ(count(shapes, PieceKind::Join), 0U);
  ASSERT_EQ(count(shapes, PieceKind::Segment), 2U);
  const std::vector<ShapeCorner>* first = nullptr;
  const std::vector<ShapeCorner>* second = nullptr;
  for (const auto& [kind, corners] : shapes) {
    if (kind != PieceKind::Segment) continue;
    (first == nullptr ? first : second) = &corners;
  }
  EXPECT_EQ((*first)[1].direction, (*second)[0].direction);  // right side, at the added point
  EXPECT_EQ((*first)[2].direction, (*second)[3].direction);  // left side
  const double theta = std::atan2(0.02, 10.0);
  EXPECT_NEAR(glm::length((*first)[2].direction), 1.0 / std::cos(0.5 * theta), 1e-12);
  EXPECT_NEAR(std::atan2(-(*first)[2].direction.x, (*first)[2].direction.y), 0.5 * theta, 1e-12);
}

TEST(LineShapes, ARunCutOutOfALineGetsJoinsAtItsEndsAndALoneStationItsCap) {
  // A run whose first station has a piece arriving (the globe cuts lines into runs per tile):
  // its join there, not a cap.
  std::vector<LineStation> st = planeStations({{0, 0}, {10, 0}});
  st[0].in = glm::normalize(glm::dvec2(1.0, -1.0));
  st[0].inLength = 5.0;
  st[0].turn = 1;
  LineShapeRules rules;
  rules.wedgeLength = 1.0;
  const Shapes shapes = shapesOf(st, rules);
  ASSERT_FALSE(shapes.empty());
  EXPECT_EQ(shapes.front().first, PieceKind::Join);
  EXPECT_EQ(shapes.back().first, PieceKind::Cap);
  // One station: a round cap's whole disc, a square cap's square, a flat cap nothing.
  const std::vector<LineStation> lone(1);
  rules.chords = 16;
  const Shapes disc = shapesOf(lone, rules);
  ASSERT_EQ(disc.size(), 1U);
  EXPECT_EQ(disc[0].second.size(), 16U);
  rules.cap = LineCap::Square;
  EXPECT_EQ(shapesOf(lone, rules)[0].second.size(), 4U);
  rules.cap = LineCap::Flat;
  EXPECT_TRUE(shapesOf(lone, rules).empty());
}

}  // namespace
}  // namespace gis::overlay
