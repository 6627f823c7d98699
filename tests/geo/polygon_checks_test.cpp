// The reader's validity checks of polygons (geo/src/vector.cpp, checkPolygons): what each tricky
// polygon becomes and every word said about it, and a feature shaped like a real land border —
// a shell of many vertices with many holes (many_holes.hpp) — whose checks must stay
// near-linear (polygon_checks_bench times it at 10^5 vertices and 10^4 holes; no time is
// asserted here).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <glm/geometric.hpp>

#include "geo/frame.hpp"
#include "geo/vector.hpp"
#include "many_holes.hpp"
#include "test_paths.hpp"

namespace {

using gis::geo::SceneFrame;
using gis::geo::VectorLayer;

std::string outputFile(const std::string& name) {
  const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

SceneFrame utm25s() {
  gis::Result<SceneFrame> frame = SceneFrame::fromCrs("EPSG:32725", glm::dvec3(300000.0, 9110000.0, 0.0));
  EXPECT_TRUE(frame.ok());
  return *frame;
}

using Points = std::vector<std::pair<double, double>>;

/// A ring in units of 0.001° from (-34.86°, -8.01°), closed, as GeoJSON coordinates.
std::string ring(const Points& points) {
  std::ostringstream s;
  s.precision(12);
  s << '[';
  for (std::size_t i = 0; i <= points.size(); ++i) {
    const auto& [x, y] = points[i % points.size()];
    s << (i == 0 ? "" : ",") << '[' << -34.86 + x * 1e-3 << ',' << -8.01 + y * 1e-3 << ']';
  }
  s << ']';
  return s.str();
}
Points box(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }
std::string polygon(const std::vector<Points>& rings) {
  std::string s = "[";
  for (std::size_t i = 0; i < rings.size(); ++i) s += (i == 0 ? "" : ",") + ring(rings[i]);
  return s + "]";
}
std::string polygonGeometry(const std::vector<Points>& rings) {
  return R"({"type": "Polygon", "coordinates": )" + polygon(rings) + "}";
}
std::string multiGeometry(const std::vector<std::vector<Points>>& parts) {
  std::string s = R"({"type": "MultiPolygon", "coordinates": [)";
  for (std::size_t i = 0; i < parts.size(); ++i) s += (i == 0 ? "" : ",") + polygon(parts[i]);
  return s + "]}";
}

/// What the reader made of each feature: "drawn: holes a b …" per polygon, or nothing, then its
/// messages ("W: …", "E: …") in order.
std::map<std::int64_t, std::vector<std::string>> outcomes(const std::string& path, const SceneFrame& frame) {
  gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, frame);
  EXPECT_TRUE(layer.ok());
  std::map<std::int64_t, std::vector<std::string>> out;
  if (!layer) return out;
  for (const gis::geo::Feature& f : layer->features) {
    std::string drawn = "drawn:";
    for (const gis::geo::Polygon& p : f.polygons) drawn += " [" + std::to_string(p.holes.size()) + " holes]";
    out[f.fid].push_back(drawn);
  }
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    if (d.feature.empty()) continue;
    out[std::stoll(d.feature)].push_back((d.severity == gis::Severity::Error ? "E: " : "W: ") + d.message);
  }
  return out;
}

// ---- tricky polygons: the outcome of the checks as they were (GEOS relate per hole) ----------

struct Case {
  std::int64_t id;
  const char* what;
  std::string geometry;
  std::vector<std::string> expected;
};

std::vector<Case> trickyCases() {
  const Points shell = box(0, 0, 10, 10);
  const Points u = {{0, 0}, {10, 0}, {10, 10}, {7, 10}, {7, 3}, {3, 3}, {3, 10}, {0, 10}};  // a U
  const Points bowtie = {{0, 0}, {10, 10}, {10, 0}, {0, 10}};
  return {
      {1,
       "a hole wholly outside its shell",
       polygonGeometry({shell, box(12, 12, 14, 14)}),
       {"drawn: [0 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out"}},
      {2,
       "a hole touching the shell from outside at a vertex",
       polygonGeometry({shell, {{10, 10}, {12, 10}, {12, 12}}}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Hole lies outside shell at or near point -34.850000000000001 "
        "-8): drawn by the even-odd rule"}},
      {3,
       "a hole touching the shell from outside along an edge",
       polygonGeometry({shell, box(10, 2, 12, 4)}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0060000000000002): drawn by the even-odd rule"}},
      {4,
       "a hole touching the shell from outside at a point of an edge",
       polygonGeometry({shell, {{10, 4}, {12, 3}, {12, 5}}}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Hole lies outside shell at or near point -34.850000000000001 "
        "-8.0060000000000002): drawn by the even-odd rule"}},
      {5,
       "a hole touching the shell from inside at a vertex",
       polygonGeometry({shell, {{0, 0}, {3, 1}, {1, 3}}}),
       {"drawn: [1 holes]"}},
      {6,
       "a hole touching the shell from inside along an edge",
       polygonGeometry({shell, box(0, 2, 3, 4)}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.859999999999999 "
        "-8.0060000000000002): drawn by the even-odd rule"}},
      {7,
       "a hole crossing the shell",
       polygonGeometry({shell, box(8, 4, 12, 6)}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0060000000000002): drawn by the even-odd rule"}},
      {8,
       "a hole enclosing the shell",
       polygonGeometry({shell, box(-2, -2, 12, 12)}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Hole lies outside shell at or near point -34.862000000000002 "
        "-8.0120000000000005): drawn by the even-odd rule"}},
      {9,
       "a hole equal to the shell",
       polygonGeometry({shell, shell}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0099999999999998): drawn by the even-odd rule"}},
      {10,
       "nested holes",
       polygonGeometry({shell, box(2, 2, 8, 8), box(3, 3, 7, 7)}),
       {"drawn: [2 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Holes are nested at or near point -34.856999999999999 "
        "-8.0069999999999997): drawn by the even-odd rule"}},
      {11,
       "overlapping holes",
       polygonGeometry({shell, box(2, 2, 5, 5), box(4, 4, 7, 7)}),
       {"drawn: [2 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.0060000000000002): drawn by the even-odd rule"}},
      {12,
       "a bow-tie shell",
       polygonGeometry({bowtie}),
       {"drawn: [0 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.004999999999999): drawn by the even-odd rule"}},
      {13,
       "a bow-tie hole",
       polygonGeometry({shell, {{2, 2}, {8, 8}, {8, 2}, {2, 8}}}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.0050000000000008): drawn by the even-odd rule"}},
      {14,
       "a bow-tie shell and a hole outside it",
       polygonGeometry({bowtie, box(12, 12, 14, 14)}),
       {"drawn: [0 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.004999999999999): drawn by the even-odd rule"}},
      {15,
       "a bow-tie shell and a hole between its triangles",
       polygonGeometry({bowtie, {{4, 8}, {6, 8}, {5, 9}}}),
       {"drawn: [0 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.004999999999999): drawn by the even-odd rule"}},
      {16,
       "a U and a hole in its notch (outside, inside its bounding box)",
       polygonGeometry({u, box(4, 5, 6, 8)}),
       {"drawn: [0 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out"}},
      {17,
       "a U and a hole filling its notch, touching both arms",
       polygonGeometry({u, box(3, 5, 7, 8)}),
       {"drawn: [1 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.853000000000002 "
        "-8.0050000000000008): drawn by the even-odd rule"}},
      {18,
       "a hole whose points lie on one line",
       polygonGeometry({shell, {{2, 2}, {4, 4}, {6, 6}}}),
       {"drawn: [1 holes]"}},
      {19,
       "holes outside, inside and crossing, in that order",
       polygonGeometry({shell, box(12, 0, 14, 2), box(2, 2, 4, 4), box(9, 6, 11, 8), box(20, 20, 21, 21)}),
       {"drawn: [2 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out",
        "W: the polygon: hole 4 lies wholly outside its shell and excludes nothing: left out",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0039999999999996): drawn by the even-odd rule"}},
      {20,
       "a clockwise shell and a hole outside it",
       polygonGeometry({{{0, 0}, {0, 10}, {10, 10}, {10, 0}}, box(12, 12, 14, 14)}),
       {"drawn: [0 holes]", "W: the polygon: hole 1 lies wholly outside its shell and excludes nothing: left out"}},
      {21,
       "a valid polygon with holes",
       polygonGeometry({shell, box(1, 1, 2, 2), box(3, 3, 4, 4)}),
       {"drawn: [2 holes]"}},
      {22,
       "two overlapping squares",
       multiGeometry({{shell}, {box(5, 5, 15, 15)}}),
       {"drawn: [0 holes] [0 holes]",
        "W: its polygons overlap or touch along a line (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0050000000000008): drawn as their union"}},
      {23,
       "two squares sharing an edge",
       multiGeometry({{shell}, {box(10, 0, 20, 10)}}),
       {"drawn: [0 holes] [0 holes]",
        "W: its polygons overlap or touch along a line (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8): drawn as their union"}},
      {24,
       "two squares sharing a vertex",
       multiGeometry({{shell}, {box(10, 10, 20, 20)}}),
       {"drawn: [0 holes] [0 holes]"}},
      {25,
       "a part inside another",
       multiGeometry({{shell}, {box(2, 2, 4, 4)}}),
       {"drawn: [0 holes] [0 holes]",
        "W: its polygons overlap or touch along a line (GEOS: Nested shells at or near point -34.857999999999997 "
        "-8.0079999999999991): drawn as their union"}},
      {26,
       "a part inside another's hole",
       multiGeometry({{shell, box(2, 2, 8, 8)}, {box(3, 3, 7, 7)}}),
       {"drawn: [1 holes] [0 holes]"}},
      {27,
       "a good part, a part with a hole outside, a part whose points lie on one line",
       multiGeometry({{shell}, {box(20, 0, 30, 10), box(40, 0, 42, 2)}, {{{50, 0}, {52, 2}, {54, 4}}}}),
       {"drawn: [0 holes] [0 holes]",
        "W: polygon 2 of 3: hole 1 lies wholly outside its shell and excludes nothing: left out",
        "W: polygon 3 of 3: its exterior ring has no area (its points lie on one line): left out"}},
      {28,
       "every part's points on one line",
       multiGeometry({{{{0, 0}, {1, 1}, {2, 2}}}, {{{5, 0}, {6, 1}, {7, 2}}}}),
       {"E: polygon 1 of 2: its exterior ring has no area (its points lie on one line); polygon 2 of 2: its exterior "
        "ring has no area (its points lie on one line)"}},
      {29,
       "a bow-tie part and a part overlapping it",
       multiGeometry({{bowtie}, {box(8, 2, 14, 8)}}),
       {"drawn: [0 holes] [0 holes]",
        "W: polygon 1 of 2 is not valid by OGC rules (GEOS: Self-intersection at or near point -34.854999999999997 "
        "-8.004999999999999): drawn by the even-odd rule"}},
      {30,
       "a part with a hole outside overlapping another part",
       multiGeometry({{shell, box(30, 30, 32, 32)}, {box(5, 5, 15, 15)}}),
       {"drawn: [0 holes] [0 holes]",
        "W: polygon 1 of 2: hole 1 lies wholly outside its shell and excludes nothing: left out",
        "W: its polygons overlap or touch along a line (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0050000000000008): drawn as their union"}},
      {31,
       "a shell whose points lie on one line, with a hole",
       polygonGeometry({{{0, 0}, {5, 5}, {10, 10}}, box(1, 1, 2, 2)}),
       {"E: the polygon: its exterior ring has no area (its points lie on one line)"}},
      {32,
       "a hole outside its shell touching another hole that is inside",
       polygonGeometry({shell, box(6, 6, 10, 8), box(10, 8, 12, 9)}),
       {"drawn: [2 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Self-intersection at or near point -34.850000000000001 "
        "-8.0039999999999996): drawn by the even-odd rule"}},
      {33,
       "a part with a hole, and a part inside it (not in its hole)",
       multiGeometry({{shell, box(1, 1, 2, 2)}, {box(4, 4, 6, 6)}}),
       {"drawn: [1 holes] [0 holes]",
        "W: its polygons overlap or touch along a line (GEOS: Nested shells at or near point -34.856000000000002 "
        "-8.0060000000000002): drawn as their union"}},
      {34,
       "a valid part with a hole, and a part with a hole outside it",
       multiGeometry({{shell, box(1, 1, 2, 2)}, {box(20, 0, 30, 10), box(32, 2, 34, 4)}}),
       {"drawn: [1 holes] [0 holes]",
        "W: polygon 2 of 2: hole 1 lies wholly outside its shell and excludes nothing: left out"}},
      {35,
       "a hole inside the next hole, then a hole outside",
       polygonGeometry({shell, box(3, 3, 4, 4), box(2, 2, 8, 8), box(12, 2, 13, 3)}),
       {"drawn: [2 holes]", "W: the polygon: hole 3 lies wholly outside its shell and excludes nothing: left out",
        "W: the polygon is not valid by OGC rules (GEOS: Holes are nested at or near point -34.856999999999999 "
        "-8.0069999999999997): drawn by the even-odd rule"}},
      {36,
       "repeated points in the shell and the holes",
       polygonGeometry({{{0, 0}, {10, 0}, {10, 0}, {10, 10}, {0, 10}, {0, 10}},
                        {{1, 1}, {2, 1}, {2, 1}, {2, 2}, {1, 2}},
                        box(3, 3, 4, 4)}),
       {"drawn: [2 holes]"}},
      {37,
       "a U with holes in both arms",
       polygonGeometry({u, box(1, 4, 2, 8), box(8, 4, 9, 8), box(4, 1, 6, 2)}),
       {"drawn: [3 holes]"}},
      {38,
       "a U with holes in its arms and one in its notch",
       polygonGeometry({u, box(1, 4, 2, 8), box(4, 5, 6, 8), box(8, 4, 9, 8)}),
       {"drawn: [2 holes]", "W: the polygon: hole 2 lies wholly outside its shell and excludes nothing: left out"}},
      {39,
       "two disjoint parts with holes",
       multiGeometry({{shell, box(1, 1, 2, 2)}, {box(20, 0, 30, 10), box(21, 1, 22, 2)}}),
       {"drawn: [1 holes] [1 holes]"}},
      {40,
       "an island in a lake with an island in its own lake",
       multiGeometry(
           {{box(0, 0, 30, 30), box(5, 5, 25, 25)}, {box(7, 7, 23, 23), box(9, 9, 21, 21)}, {box(11, 11, 19, 19)}}),
       {"drawn: [1 holes] [1 holes] [0 holes]"}},
      {41,
       "holes touching each other at a point",
       polygonGeometry({shell, box(2, 2, 4, 4), box(4, 4, 6, 6)}),
       {"drawn: [2 holes]"}},
      {42,
       "holes touching each other at two points",
       polygonGeometry({shell, {{2, 2}, {6, 2}, {6, 6}, {2, 6}}, {{6, 2}, {8, 4}, {6, 6}, {7, 4}}}),
       {"drawn: [2 holes]",
        "W: the polygon is not valid by OGC rules (GEOS: Interior is disconnected at or near point -34.853999999999999 "
        "-8.0039999999999996): drawn by the even-odd rule"}},
      {43,
       "a hole whose first point is on the shell, inside",
       polygonGeometry({shell, {{0, 5}, {3, 4}, {3, 6}}, box(5, 5, 6, 6)}),
       {"drawn: [2 holes]"}},
      {44,
       "a part inside another part's hole, the other part with more holes",
       multiGeometry(
           {{box(0, 0, 30, 30), box(1, 1, 2, 2), box(3, 1, 4, 2), box(10, 10, 20, 20)}, {box(12, 12, 18, 18)}}),
       {"drawn: [3 holes] [0 holes]"}},
      {45,
       "a part whose hole holds a part that crosses it",
       multiGeometry({{box(0, 0, 30, 30), box(10, 10, 20, 20)}, {box(12, 12, 22, 18)}}),
       {"drawn: [1 holes] [0 holes]",
        "W: its polygons overlap or touch along a line (GEOS: Self-intersection at or near point -34.840000000000003 "
        "-7.9980000000000002): drawn as their union"}},
      {46,
       "two parts with holes, the second inside the first's shell envelope but outside it",
       multiGeometry({{u, box(1, 4, 2, 8)}, {box(4, 5, 6, 8), box(4.5, 6, 5.5, 7)}}),
       {"drawn: [1 holes] [1 holes]"}},
  };
}

void writeCases(const std::string& path, const std::vector<Case>& cases) {
  std::ofstream out(path);
  out << R"({"type": "FeatureCollection", "features": [)";
  for (std::size_t i = 0; i < cases.size(); ++i) {
    out << (i == 0 ? "" : ",\n") << R"({"type": "Feature", "id": )" << cases[i].id
        << R"(, "properties": {}, "geometry": )" << cases[i].geometry << '}';
  }
  out << "]}\n";
}

TEST(PolygonChecks, TrickyPolygonsGiveTheSameOutcomeAndMessagesAsBefore) {
  const std::vector<Case> cases = trickyCases();
  const std::string path = outputFile("tricky_polygons.geojson");
  writeCases(path, cases);
  const auto got = outcomes(path, utm25s());
  for (const Case& c : cases) {
    SCOPED_TRACE(std::to_string(c.id) + ": " + c.what);
    const auto found = got.find(c.id);
    const std::vector<std::string> actual = found != got.end() ? found->second : std::vector<std::string>{};
    std::string listing;
    for (const std::string& m : actual) listing += "\n    \"" + m + "\"";
    EXPECT_EQ(actual, c.expected) << "feature " << c.id << ":" << listing;
  }
}

TEST(PolygonChecks, WhatTheChecksLeaveOutIsTheSourceWithoutIt) {
  // The reader takes the holes and polygons the checks leave out of what it converted; the same
  // feature written without them reads to the very same vertices.
  const Points shell = box(0, 0, 10, 10);
  const std::vector<Case> repaired = {
      {1, "", polygonGeometry({shell, box(12, 0, 14, 2), box(2, 2, 4, 4), box(9, 6, 11, 8), box(20, 20, 21, 21)}), {}},
      {2,
       "",
       multiGeometry(
           {{shell}, {box(20, 0, 30, 10), box(40, 0, 42, 2), box(22, 2, 24, 4)}, {{{50, 0}, {52, 2}, {54, 4}}}}),
       {}}};
  const std::vector<Case> without = {{1, "", polygonGeometry({shell, box(2, 2, 4, 4), box(9, 6, 11, 8)}), {}},
                                     {2, "", multiGeometry({{shell}, {box(20, 0, 30, 10), box(22, 2, 24, 4)}}), {}}};
  const SceneFrame frame = utm25s();
  writeCases(outputFile("repaired.geojson"), repaired);
  writeCases(outputFile("without.geojson"), without);
  gis::Result<VectorLayer> a = gis::geo::readVectorLayer(outputFile("repaired.geojson"), frame);
  gis::Result<VectorLayer> b = gis::geo::readVectorLayer(outputFile("without.geojson"), frame);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->features.size(), 2u);
  ASSERT_EQ(b->features.size(), 2u);
  EXPECT_EQ(a.diagnostics.count(gis::Severity::Warning), 5u);
  for (std::size_t i = 0; i < 2; ++i) {
    ASSERT_EQ(a->features[i].polygons.size(), b->features[i].polygons.size());
    for (std::size_t k = 0; k < a->features[i].polygons.size(); ++k) {
      EXPECT_EQ(a->features[i].polygons[k].outer, b->features[i].polygons[k].outer);
      EXPECT_EQ(a->features[i].polygons[k].holes, b->features[i].polygons[k].holes);
    }
  }
}

// ---- a part the converter leaves out is named once (issue 40, 7) ----------------------------

TEST(PolygonChecks, APartLeftOutForItsCoordinatesIsNamedOnceNotAgainAsHavingNoArea) {
  // A multi-polygon's part with a NaN, one beyond the range of latitude, one with a NaN in a
  // hole, one of two distinct points: each is left out with the converter's one message, and the
  // validity checks neither see it nor name it again ("its points lie on one line"). The good
  // parts still draw, and are still checked (feature 5: its good parts overlap).
  const std::string good = ring(box(0, 0, 10, 10)), other = ring(box(20, 0, 30, 10)),
                    overlapping = ring(box(5, 5, 15, 15));
  const std::string path = outputFile("parts_left_out.geojson");
  std::ofstream(path) << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "id": 1, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [)" << good << R"(], [[[NaN, -8.0], [-34.85, -8.0], [-34.85, -7.99], [NaN, -8.0]]], [)"
                      << other << R"(]]}},
    {"type": "Feature", "id": 2, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [)" << good << R"(], [[[-34.86, 95.0], [-34.85, 95.0], [-34.85, 96.0], [-34.86, 95.0]]]]}},
    {"type": "Feature", "id": 3, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [)" << good << R"(], [)"
                      << other << R"(, [[-34.838, -8.008], [NaN, -8.008], [-34.836, -8.006], [-34.838, -8.008]]]]}},
    {"type": "Feature", "id": 4, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [[[-34.84, -8.0], [-34.83, -8.0], [-34.84, -8.0], [-34.84, -8.0]]], [)"
                      << good << R"(]]}},
    {"type": "Feature", "id": 5, "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [
      [)" << good << R"(], [[[-34.86, NaN], [-34.85, -8.0], [-34.85, -7.99], [-34.86, NaN]]], [)"
                      << overlapping << R"(]]}}]})";
  const auto got = outcomes(path, utm25s());
  using V = std::vector<std::string>;
  const std::map<std::int64_t, V> expected = {
      {1, V{"drawn: [0 holes] [0 holes]",
            "W: part 2 of 3: exterior ring: non-finite coordinate at vertex 0; that part is left out"}},
      {2, V{"drawn: [0 holes]",
            "W: part 2 of 2: exterior ring: vertex 0 (-34.86, 95) is outside the range of longitude/latitude; that "
            "part is left out"}},
      {3, V{"drawn: [0 holes]", "W: part 2 of 2: hole 1: non-finite coordinate at vertex 1; that part is left out"}},
      {4, V{"drawn: [0 holes]",
            "W: part 1 of 2: exterior ring: ring has 2 distinct point(s); at least 3 needed; that part is left out"}},
      {5, V{"drawn: [0 holes] [0 holes]",
            "W: part 2 of 3: exterior ring: non-finite coordinate at vertex 0; that part is left out",
            "W: its polygons overlap or touch along a line (GEOS: Self-intersection at or near point "
            "-34.850000000000001 -8.0050000000000008): drawn as their union"}},
  };
  EXPECT_EQ(got, expected);
  for (const auto& [id, messages] : got) {
    SCOPED_TRACE(id);
    for (const std::string& m : messages) EXPECT_EQ(m.find("lie on one line"), std::string::npos) << m;
  }
}

// ---- a border-sized feature: 2·10^4 shell vertices, 2·10^3 holes ----------------------------

/// The feature's messages, with GEOS's place ("at or near point …") cut off.
std::vector<std::string> messagesOf(const gis::Result<VectorLayer>& layer) {
  std::vector<std::string> out;
  for (const gis::Diagnostic& d : layer.diagnostics.items()) {
    std::string m = d.message;
    if (const std::size_t at = m.find(" at or near point "); at != std::string::npos) {
      m.erase(at, m.find(')', at) - at);
    }
    out.push_back((d.severity == gis::Severity::Error ? "E: " : "W: ") + d.feature + ": " + m);
  }
  return out;
}

TEST(PolygonChecks, AShellOfManyVerticesWithManyHolesIsCheckedAndRepaired) {
  // The shape of a real land border at a size the suite affords (polygon_checks_bench times
  // 10^5 vertices and 10^4 holes): the hole outside the shell is left out and said, the one
  // crossing it stays and the polygon is drawn by the even-odd rule, said with GEOS's reason.
  gis::test::ManyHolesShape shape;
  shape.shellVertices = 20000;
  shape.holes = 2000;
  shape.outsideHole = shape.crossingHole = true;
  const std::string path = outputFile("many_holes.geojson");
  gis::test::writeManyHoles(path, shape);
  const gis::Result<VectorLayer> layer = gis::geo::readVectorLayer(path, utm25s());
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->features.size(), 1u);
  ASSERT_EQ(layer->features[0].polygons.size(), 1u);
  const gis::geo::Polygon& p = layer->features[0].polygons[0];
  EXPECT_EQ(p.holes.size(), 1999u);
  EXPECT_EQ(p.outer.size(), 20000u);
  EXPECT_EQ(messagesOf(layer),
            (std::vector<std::string>{
                "W: 1: the polygon: hole 1001 lies wholly outside its shell and excludes nothing: left out",
                "W: 1: the polygon is not valid by OGC rules (GEOS: Self-intersection): drawn by the even-odd rule"}));
  // The hole crossing the shell (number 667) is kept, the one after the outside hole moved up.
  ASSERT_EQ(shape.crossingHoleNumber(), 667);
  double farthest = 0.0;
  for (const glm::dvec2& v : p.holes[666]) farthest = std::max(farthest, glm::length(v - p.outer[0]));
  EXPECT_LT(farthest, 1000.0);  // it lies about the shell's first vertex (angle 0), 16 km from the next lake

  // The same without the bad holes: valid, nothing said, every hole kept.
  shape.outsideHole = shape.crossingHole = false;
  gis::test::writeManyHoles(path, shape);
  const gis::Result<VectorLayer> valid = gis::geo::readVectorLayer(path, utm25s());
  ASSERT_TRUE(valid.ok());
  EXPECT_TRUE(valid.diagnostics.items().empty()) << valid.diagnostics.items().front().toString();
  ASSERT_EQ(valid->features.size(), 1u);
  EXPECT_EQ(valid->features[0].polygons.at(0).holes.size(), 2000u);

  // With 300 islands as further parts: the mainland is polygon 1 of 301, the islands all drawn.
  shape.outsideHole = true;
  shape.islands = 300;
  gis::test::writeManyHoles(path, shape);
  const gis::Result<VectorLayer> islands = gis::geo::readVectorLayer(path, utm25s());
  ASSERT_TRUE(islands.ok());
  ASSERT_EQ(islands->features.size(), 1u);
  EXPECT_EQ(islands->features[0].polygons.size(), 301u);
  EXPECT_EQ(islands->features[0].polygons[0].holes.size(), 1999u);
  EXPECT_EQ(messagesOf(islands),
            (std::vector<std::string>{
                "W: 1: polygon 1 of 301: hole 1001 lies wholly outside its shell and excludes nothing: left out"}));
}

// ---- random polygons: the checks as they were, transcribed, against the reader ---------------

/// GDAL's messages while alive (the last one is GEOS's reason for an IsValid that failed).
class CollectedMessages {
 public:
  CollectedMessages() { CPLPushErrorHandlerEx(&CollectedMessages::handler, this); }
  ~CollectedMessages() { CPLPopErrorHandler(); }
  CollectedMessages(const CollectedMessages&) = delete;
  CollectedMessages& operator=(const CollectedMessages&) = delete;
  /// The reason as the reader words it (the last message, without GDAL's "GEOS warning: ").
  std::string reason() {
    std::string r = messages_.empty() ? std::string() : messages_.back();
    messages_.clear();
    const std::string prefix = "GEOS warning: ";
    if (r.rfind(prefix, 0) == 0) r = r.substr(prefix.size());
    return r.empty() ? std::string("GEOS gives no reason") : r;
  }
  void clear() { messages_.clear(); }

 private:
  static void CPL_STDCALL handler(CPLErr, CPLErrorNum, const char* message) {
    static_cast<CollectedMessages*>(CPLGetErrorHandlerUserData())->messages_.emplace_back(message);
  }
  std::vector<std::string> messages_;
};

bool onOneLine(const OGRLinearRing& ring) {
  const int n = ring.getNumPoints();
  if (n < 3) return true;
  const glm::dvec2 p0(ring.getX(0), ring.getY(0));
  glm::dvec2 far = p0;
  for (int i = 1; i < n; ++i) {
    const glm::dvec2 p(ring.getX(i), ring.getY(i));
    if (glm::length(p - p0) > glm::length(far - p0)) far = p;
  }
  const glm::dvec2 axis = far - p0;
  const double length = glm::length(axis);
  if (!(length > 0.0)) return true;
  for (int i = 1; i < n; ++i) {
    const glm::dvec2 d = glm::dvec2(ring.getX(i), ring.getY(i)) - p0;
    if (std::abs(axis.x * d.y - axis.y * d.x) / length > 1e-9 * length) return false;
  }
  return true;
}

OGRPolygon polygonOf(const OGRLinearRing& exterior, const std::vector<const OGRLinearRing*>& holes = {}) {
  OGRPolygon p;
  p.addRingDirectly(exterior.clone());
  for (const OGRLinearRing* h : holes) p.addRingDirectly(h->clone());
  return p;
}

/// The reader's checks as they were before issue 40 (GEOS relate per hole, GEOS's IsValid on
/// the whole, per part and on the parts kept), transcribed: the same outcome as the reader's
/// lines "drawn: …" and "W: …"/"E: …" (no part of these is left out by the converter).
std::vector<std::string> checksAsTheyWere(const OGRGeometry& geometry) {
  CollectedMessages gdal;
  std::vector<const OGRPolygon*> parts;
  if (wkbFlatten(geometry.getGeometryType()) == wkbPolygon) {
    parts.push_back(geometry.toPolygon());
  } else {
    for (const OGRPolygon* p : *geometry.toMultiPolygon()) parts.push_back(p);
  }
  auto drawnAll = [&] {
    std::string drawn = "drawn:";
    for (const OGRPolygon* p : parts) drawn += " [" + std::to_string(p->getNumInteriorRings()) + " holes]";
    return std::vector<std::string>{drawn};
  };
  const bool sliver = std::any_of(parts.begin(), parts.end(), [](const OGRPolygon* p) {
    return p->getExteriorRing() != nullptr && !p->getExteriorRing()->IsEmpty() && onOneLine(*p->getExteriorRing());
  });
  if (!sliver && geometry.IsValid()) return drawnAll();
  const std::string wholeReason = gdal.reason();
  const bool multi = parts.size() > 1 || wkbFlatten(geometry.getGeometryType()) == wkbMultiPolygon;
  OGRMultiPolygon out;
  std::vector<std::string> notes, dropped;
  bool partsInvalid = false;
  std::string drawn = "drawn:";
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const std::string label =
        multi ? "polygon " + std::to_string(k + 1) + " of " + std::to_string(parts.size()) : std::string("the polygon");
    const OGRLinearRing* exterior = parts[k]->getExteriorRing();
    const OGRPolygon shell = polygonOf(*exterior);
    if (onOneLine(*exterior)) {
      dropped.push_back(label + ": its exterior ring has no area (its points lie on one line)");
      continue;
    }
    std::vector<const OGRLinearRing*> holes;
    for (int i = 0; i < parts[k]->getNumInteriorRings(); ++i) {
      const OGRLinearRing* hole = parts[k]->getInteriorRing(i);
      const OGRPolygon holeArea = polygonOf(*hole);
      if (!hole->IsEmpty() && !shell.Intersects(&holeArea)) {
        notes.push_back("W: " + label + ": hole " + std::to_string(i + 1) +
                        " lies wholly outside its shell and excludes nothing: left out");
        continue;
      }
      holes.push_back(hole);
    }
    OGRPolygon kept = polygonOf(*exterior, holes);
    if (!kept.IsValid()) {
      partsInvalid = true;
      notes.push_back("W: " + label + " is not valid by OGC rules (GEOS: " + gdal.reason() +
                      "): drawn by the even-odd rule");
    }
    gdal.clear();
    out.addGeometry(&kept);
    drawn += " [" + std::to_string(holes.size()) + " holes]";
  }
  if (out.IsEmpty()) {
    std::string refused;
    for (const std::string& d : dropped) refused += (refused.empty() ? "" : "; ") + d;
    if (refused.empty()) refused = "no polygon with an area (GEOS: " + wholeReason + ")";
    return {"E: " + refused};
  }
  for (const std::string& d : dropped) notes.push_back("W: " + d + ": left out");
  if (!partsInvalid && out.getNumGeometries() > 1 && !out.IsValid()) {
    notes.push_back("W: its polygons overlap or touch along a line (GEOS: " + gdal.reason() +
                    "): drawn as their union");
  }
  std::vector<std::string> result{drawn};
  result.insert(result.end(), notes.begin(), notes.end());
  return result;
}

TEST(PolygonChecks, RandomPolygonsGiveWhatTheChecksAsTheyWereGave) {
  // Parts and holes on a small integer grid, so that they touch, cross, nest and lie outside
  // each other in every way: 1,800 features, each read by the reader and put through the
  // transcribed checks of before.
  std::mt19937 rng(40);
  std::uniform_int_distribution<int> coordinate(0, 14), count(0, 6), partCount(1, 3), shape(0, 5);
  auto randomRing = [&](int lo, int hi) {
    // Rings of 3 distinct points at least: the converter leaves out no part (that is
    // APartLeftOutForItsCoordinatesIsNamedOnceNotAgainAsHavingNoArea).
    std::uniform_int_distribution<int> c(lo, hi);
    const int x0 = c(rng), y0 = c(rng);
    int x1 = c(rng), y1 = c(rng);
    while (x1 == x0 || y1 == y0) {
      x1 = c(rng);
      y1 = c(rng);
    }
    switch (shape(rng)) {
      case 0: {
        std::pair<double, double> third(c(rng), c(rng));
        while (third == std::pair<double, double>(x0, y0) || third == std::pair<double, double>(x1, y1))
          third = {c(rng), c(rng)};
        return Points{{x0, y0}, {x1, y1}, third};  // a triangle (or a sliver)
      }
      case 1:
        return Points{{x0, y0}, {x1, y1}, {x1, y0}, {x0, y1}};  // a bow-tie
      default:
        return box(std::min(x0, x1), std::min(y0, y1), std::max(x0, x1) + 1, std::max(y0, y1) + 1);
    }
  };
  std::vector<Case> cases;
  for (int id = 1; id <= 600; ++id) {
    std::vector<std::vector<Points>> parts;
    const int n = partCount(rng);
    for (int k = 0; k < n; ++k) {
      std::vector<Points> rings{n == 1 && shape(rng) < 4 ? box(0, 0, 14, 14) : randomRing(0, 14)};
      const int holes = count(rng);
      for (int h = 0; h < holes; ++h) rings.push_back(randomRing(-2, 14));
      parts.push_back(std::move(rings));
    }
    cases.push_back({id, "random", n == 1 && id % 2 == 0 ? polygonGeometry(parts[0]) : multiGeometry(parts), {}});
  }
  // Tidier ones: square parts side by side or one inside another, holes of 1 to 4 units about
  // them, mostly valid, some nested, outside, touching or crossing.
  std::uniform_int_distribution<int> place(0, 3), size(1, 4), spot(-1, 10);
  for (int id = 601; id <= 1200; ++id) {
    std::vector<std::vector<Points>> parts;
    const int n = partCount(rng);
    for (int k = 0; k < n; ++k) {
      const int at = place(rng) == 0 ? 2 : 14 * k;  // sometimes inside the first part
      std::vector<Points> rings{box(at, at, at + 10, at + 10)};
      const int holes = 2 * count(rng);
      for (int h = 0; h < holes; ++h) {
        const int x = at + spot(rng), y = at + spot(rng), d = size(rng);
        rings.push_back(box(x, y, x + d, y + d));
      }
      parts.push_back(std::move(rings));
    }
    cases.push_back({id, "tidy", n == 1 ? polygonGeometry(parts[0]) : multiGeometry(parts), {}});
  }
  // Rings that seldom share a point (holes off the integer grid): holes inside, outside,
  // nested in each other or crossing, parts beside each other or inside one another.
  std::uniform_int_distribution<int> corner(-2, 11), inner(0, 1);
  for (int id = 1201; id <= 1800; ++id) {
    std::vector<std::vector<Points>> parts;
    const int n = partCount(rng);
    for (int k = 0; k < n; ++k) {
      const double at = k == 0 ? 0.0 : (inner(rng) == 0 ? 3.1 : 14.0 * k), side = k > 0 && at < 4.0 ? 3.8 : 10.0;
      std::vector<Points> rings{box(at, at, at + side, at + side)};
      const int holes = count(rng);
      for (int h = 0; h < holes; ++h) {
        const double x = at + corner(rng), y = at + corner(rng), d = size(rng);
        rings.push_back(box(x + 0.15, y + 0.15, x + d - 0.15, y + d - 0.15));
      }
      parts.push_back(std::move(rings));
    }
    cases.push_back({id, "apart", n == 1 ? polygonGeometry(parts[0]) : multiGeometry(parts), {}});
  }
  const std::string path = outputFile("random_polygons.geojson");
  writeCases(path, cases);
  const auto got = outcomes(path, utm25s());
  GDALDataset* ds = GDALDataset::FromHandle(GDALOpenEx(path.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr));
  ASSERT_NE(ds, nullptr);
  std::size_t compared = 0, repaired = 0, differing = 0;
  for (auto& feature : *ds->GetLayer(0)) {
    const std::int64_t id = feature->GetFID();
    const std::vector<std::string> expected = checksAsTheyWere(*feature->GetGeometryRef());
    const auto found = got.find(id);
    const std::vector<std::string> actual = found != got.end() ? found->second : std::vector<std::string>{};
    ++compared;
    repaired += expected.size() > 1 || expected.front().rfind("E: ", 0) == 0 ? 1u : 0u;
    if (actual != expected && differing++ < 5) {
      std::string a, e;
      for (const std::string& m : actual) a += "\n    " + m;
      for (const std::string& m : expected) e += "\n    " + m;
      ADD_FAILURE() << "feature " << id << ": the reader says" << a << "\n  as before:" << e;
    }
  }
  GDALClose(GDALDataset::ToHandle(ds));
  std::printf("%zu random features compared, %zu repaired or refused, %zu differing\n", compared, repaired, differing);
  EXPECT_EQ(compared, 1800u);
  EXPECT_GT(repaired, 400u);
  EXPECT_EQ(differing, 0u);
}

}  // namespace
