// The globe overlay on the CPU (docs/globe.md): the ellipsoid's arithmetic, polygons prepared
// across the antimeridian and around the poles, and the pieces: closed, and holding exactly the
// ground the reference says is inside, point by point, in ECEF.
#include <cmath>
#include <limits>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <glm/matrix.hpp>

#include "globe/ellipsoid.hpp"
#include "globe/globe_terrain.hpp"
#include "globe_scene.hpp"
#include "vector_overlay/globe_overlay.hpp"

namespace gis::globe {
namespace {

TEST(Ellipsoid, RoundTripsAndNormals) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> lon(-180.0, 180.0), lat(-90.0, 90.0), h(-1e4, 2e7);
  for (int i = 0; i < 1000; ++i) {
    const double lo = lon(rng), la = lat(rng), he = h(rng);
    const glm::dvec3 p = toEcef(lo, la, he);
    const Geodetic g = toGeodetic(p);
    EXPECT_NEAR(g.h, he, 1e-6);
    EXPECT_NEAR(glm::length(toEcef(g) - p), 0.0, 1e-6);
    // The normal is the direction of growing height.
    const glm::dvec3 up = (toEcef(lo, la, he + 1.0) - p);
    EXPECT_NEAR(glm::length(up - surfaceNormal(lo, la)), 0.0, 1e-6);
  }
}

TEST(Ellipsoid, SplitPositionsAreExactOnTheGpuAnywhere) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> c(-3e7, 3e7);
  for (int i = 0; i < 1000; ++i) {
    const glm::dvec3 p(c(rng), c(rng), c(rng));
    const SplitPosition s = splitPosition(p);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(std::fmod(static_cast<double>(s.high[k]), 16.0), 0.0);
      EXPECT_LE(std::abs(s.low[k]), 8.0F);
      EXPECT_NEAR(static_cast<double>(s.high[k]) + static_cast<double>(s.low[k]), p[k], 1e-6);
    }
  }
}

TEST(Ellipsoid, HorizonHidesThePointsBehindTheEarthOnly) {
  const glm::dvec3 eye = toEcef(0.0, 0.0, 1e6);
  EXPECT_FALSE(hiddenByEllipsoid(eye, toEcef(0.0, 0.0, 0.0)));
  EXPECT_FALSE(hiddenByEllipsoid(eye, toEcef(5.0, 0.0, 0.0)));
  EXPECT_TRUE(hiddenByEllipsoid(eye, toEcef(180.0, 0.0, 0.0)));
  EXPECT_TRUE(hiddenByEllipsoid(eye, toEcef(40.0, 0.0, 0.0)));   // beyond the horizon (~29.2° away)
  EXPECT_FALSE(hiddenByEllipsoid(eye, toEcef(40.0, 0.0, 1e6)));  // a point as high as the eye
}

std::vector<geo::Feature> one(geo::Polygon p) {
  geo::Feature f;
  f.fid = 7;
  f.polygons.push_back(std::move(p));
  return {f};
}

bool inside(const GlobeLayer& layer, double lon, double lat) { return layer.contains(toEcef(lon, lat, 0.0), lon, lat); }

TEST(GlobePolygons, AcrossTheAntimeridian) {
  const auto features = test::globe_scene::features();
  Result<GlobeLayer> layer = GlobeLayer::build("t", {features[1]}, glm::vec4(1.0F));
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->polygons().size(), 1u);
  const LonLatRect box = layer->polygons()[0].box;
  EXPECT_LT(box.east - box.west, 40.0) << "one ring across ±180, not one around the earth";
  EXPECT_TRUE(inside(*layer, 179.9, -12.0));
  EXPECT_TRUE(inside(*layer, -179.9, -12.0));
  EXPECT_TRUE(inside(*layer, 180.0, -12.0));
  EXPECT_FALSE(inside(*layer, 160.0, -12.0));
  EXPECT_FALSE(inside(*layer, -160.0, -12.0));
  EXPECT_FALSE(inside(*layer, 0.0, -12.0));
}

// The areas' coarse levels are the layer generalised as one coverage (overlay::CoverageGeneraliser,
// as a projected tile's polygons): a border two features share, run the other way in each and
// densified along its geodesic, is simplified once, so both keep the very same points.
TEST(GlobePolygons, NeighboursShareTheirBorderAtEveryLevel) {
  // A wiggly border from (0, 0) to (0, 10) between a western and an eastern square.
  std::vector<glm::dvec2> border;
  for (int k = 0; k <= 40; ++k) border.emplace_back(0.01 * ((k % 3) - 1), 0.25 * k);
  geo::Polygon west, east;
  west.outer = {{-10.0, 10.0}, {-10.0, 0.0}};
  west.outer.insert(west.outer.end(), border.begin(), border.end());  // south to north
  east.outer = {{10.0, 0.0}, {10.0, 10.0}};
  east.outer.insert(east.outer.end(), border.rbegin(), border.rend());  // north to south
  std::vector<geo::Feature> features(2);
  features[0].fid = 1;
  features[0].polygons.push_back(west);
  features[1].fid = 2;
  features[1].polygons.push_back(east);
  Result<GlobeLayer> layer = GlobeLayer::build("neighbours", overlay::SharedFeatures(features), glm::vec4(1.0F));
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->polygons().size(), 2u);
  const auto onBorder = [](const std::vector<std::vector<glm::dvec2>>& rings) {
    std::vector<glm::dvec2> out;
    for (const glm::dvec2& p : rings.front())
      if (std::abs(p.x) < 0.02 && p.y > 0.0 && p.y < 10.0) out.push_back(p);
    std::sort(out.begin(), out.end(), [](const glm::dvec2& a, const glm::dvec2& b) { return a.y < b.y; });
    return out;
  };
  const std::vector<glm::dvec2> full = onBorder(layer->polygons()[0].rings);
  EXPECT_EQ(full, onBorder(layer->polygons()[1].rings)) << "densified from the same end in both rings";
  EXPECT_GT(full.size(), 1000u);
  // What a tile draws: the areas meeting it generalised together, over the whole world and over
  // a small box on the border alike.
  const LonLatRect world{-180.0, -90.0, 180.0, 90.0}, onTheBorder{-0.5, 4.0, 0.5, 5.0};
  int simplifiedLevels = 0;
  for (int level = 0; level < 8; ++level) {
    for (const LonLatRect& rect : {world, onTheBorder}) {
      const std::vector<GlobePolygon> areas = layer->areasIn(rect, level);
      ASSERT_EQ(areas.size(), 2u) << "level " << level;
      const std::vector<glm::dvec2> a = onBorder(areas[0].rings);
      EXPECT_EQ(a, onBorder(areas[1].rings)) << "level " << level;
      simplifiedLevels += a.size() < full.size() && rect.west == world.west ? 1 : 0;
    }
  }
  EXPECT_GT(simplifiedLevels, 3) << "the shared border is simplified at the coarse levels, not kept whole";
  EXPECT_TRUE(layer->areasIn(LonLatRect{20.0, 4.0, 21.0, 5.0}, 0).empty()) << "a box neither area meets";
  // A small box's areas are cut near it (what a tile reads follows the tile, not the areas' size).
  for (const GlobePolygon& a : layer->areasIn(onTheBorder, 10)) {
    EXPECT_GE(a.box.west, onTheBorder.west - 0.1);
    EXPECT_LE(a.box.east, onTheBorder.east + 0.1);
    EXPECT_GE(a.box.south, onTheBorder.south - 0.1);
    EXPECT_LE(a.box.north, onTheBorder.north + 0.1);
  }
  // Within the level's tolerance: every kept border point is one of the full border's.
  for (const glm::dvec2& p : onBorder(layer->areasIn(world, 0).front().rings))
    EXPECT_NE(std::find(full.begin(), full.end(), p), full.end());
}

TEST(GlobePolygons, AroundThePoles) {
  const auto features = test::globe_scene::features();
  Result<GlobeLayer> arctic = GlobeLayer::build("arctic", {features[2]}, glm::vec4(1.0F));
  Result<GlobeLayer> antarctica = GlobeLayer::build("antarctica", {features[3]}, glm::vec4(1.0F));
  ASSERT_TRUE(arctic.ok() && antarctica.ok());
  for (double lon = -180.0; lon <= 180.0; lon += 7.3) {
    EXPECT_TRUE(inside(*arctic, lon, 85.0)) << lon;
    EXPECT_TRUE(inside(*arctic, lon, 89.999)) << lon;
    EXPECT_FALSE(inside(*arctic, lon, 70.0)) << lon;
    EXPECT_FALSE(inside(*arctic, lon, -85.0)) << lon;
    EXPECT_TRUE(inside(*antarctica, lon, -80.0)) << lon;
    EXPECT_TRUE(inside(*antarctica, lon, -89.999)) << lon;
    EXPECT_FALSE(inside(*antarctica, lon, -60.0)) << lon;
    EXPECT_FALSE(inside(*antarctica, lon, 80.0)) << lon;
  }
}

TEST(GlobePolygons, HolesAndBrokenRings) {
  const auto features = test::globe_scene::features();
  Result<GlobeLayer> layer = GlobeLayer::build("holes", {features[4]}, glm::vec4(1.0F));
  ASSERT_TRUE(layer.ok());
  EXPECT_TRUE(inside(*layer, 5.0, 50.0));
  EXPECT_FALSE(inside(*layer, 15.0, 48.0));
  EXPECT_TRUE(inside(*layer, 25.0, 48.0));

  geo::Polygon bad = test::globe_scene::box(0.0, 0.0, 1.0, 1.0);
  bad.outer[2].y = 91.0;
  std::vector<geo::Feature> mixed = one(bad);
  mixed.push_back(features[0]);
  Result<GlobeLayer> partly = GlobeLayer::build("mixed", mixed, glm::vec4(1.0F));
  ASSERT_TRUE(partly.ok());
  EXPECT_EQ(partly->polygons().size(), 1u) << "the good feature is kept";
  ASSERT_FALSE(partly.diagnostics.empty());
  const std::string message = partly.diagnostics.items().front().toString();
  EXPECT_NE(message.find("layer 'mixed': feature 7"), std::string::npos) << message;
  EXPECT_NE(message.find("beyond"), std::string::npos) << message;
}

TEST(GlobePolygons, EdgesFollowGeodesics) {
  // A long edge along a geodesic: the points added along it lie on the geodesic, and points a
  // little to either side of its middle are classified by the side they are on.
  Result<GlobeLayer> layer =
      GlobeLayer::build("g", one({{{-60.0, 50.0}, {60.0, 50.0}, {60.0, 20.0}, {-60.0, 20.0}}, {}}), glm::vec4(1.0F));
  ASSERT_TRUE(layer.ok());
  // The geodesic from (−60, 50) to (60, 50) runs far north of the parallel: at lon 0 it is at
  // about 67.2° (on a sphere, tan φ = tan 50° / cos 60°). That is where the north edge is.
  EXPECT_TRUE(inside(*layer, 0.0, 66.5));
  EXPECT_FALSE(inside(*layer, 0.0, 68.0));
  EXPECT_FALSE(inside(*layer, -60.5, 51.0));
}

/// Whether a point lies inside any of the pieces (closed triangle meshes): parity of the
/// crossings of a ray with each.
bool insideMesh(const overlay::LayerGeometry& t, const glm::dvec3& point, const glm::dvec3& dir) {
  const auto at = [&](std::uint32_t i) {
    const overlay::LayerGeometry::Vertex& v = t.vertices()[i];
    return t.worldOrigins().at(0) + glm::dvec3(glm::vec3(v.x, v.y, v.height));
  };
  for (const overlay::LayerGeometry::PieceSlot& p : t.slots()) {
    int crossings = 0;
    for (std::uint32_t k = p.firstIndex; k + 2 < p.firstIndex + p.indexCount; k += 3) {
      const glm::dvec3 a = at(p.baseVertex + t.indices()[k]), b = at(p.baseVertex + t.indices()[k + 1]),
                       c = at(p.baseVertex + t.indices()[k + 2]);
      // Möller–Trumbore.
      const glm::dvec3 e1 = b - a, e2 = c - a, pv = glm::cross(dir, e2);
      const double det = glm::dot(e1, pv);
      if (std::abs(det) < 1e-18) continue;
      const glm::dvec3 tv = point - a;
      const double u = glm::dot(tv, pv) / det;
      if (u < 0.0 || u > 1.0) continue;
      const glm::dvec3 qv = glm::cross(tv, e1);
      const double v = glm::dot(dir, qv) / det;
      if (v < 0.0 || u + v > 1.0) continue;
      if (glm::dot(e2, qv) / det > 0.0) ++crossings;
    }
    if ((crossings & 1) != 0) return true;
  }
  return false;
}

/// Every directed edge of a piece is used as often as its reverse: each piece is a closed
/// surface, so every ray crosses it in and out alike (what the stencil count needs). A united
/// line's piece may touch itself at a vertex (two shapes meeting at a corner), where its
/// boundary passes twice: such an edge along the vertex's column is used twice each way.
void expectClosed(const overlay::LayerGeometry& t, const std::string& label) {
  ASSERT_TRUE(t.alongNormals()) << label << ": world pieces";
  ASSERT_EQ(t.normals().size(), t.vertices().size()) << label;
  for (const overlay::LayerGeometry::PieceSlot& p : t.slots()) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    for (std::uint32_t k = p.firstIndex; k < p.firstIndex + p.indexCount; k += 3) {
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t a = t.indices()[k + static_cast<std::uint32_t>(e)];
        const std::uint32_t b = t.indices()[k + static_cast<std::uint32_t>((e + 1) % 3)];
        ++edges[{a, b}];
      }
    }
    for (const auto& [e, n] : edges) {
      const auto reverse = edges.find({e.second, e.first});
      ASSERT_TRUE(reverse != edges.end()) << label << ": open edge";
      ASSERT_EQ(reverse->second, n) << label << ": an edge used " << n << " times one way, " << reverse->second
                                    << " the other";
    }
  }
}

/// For tiles of several levels at each place: every piece closed, and random ground points in
/// the tile inside a piece exactly when the layer (the reference) holds them, but for points
/// within `slack` metres (plus the level's generalisation) of an edge.
void expectPiecesHoldTheGround(const GlobeLayer& layer, const GeoGrid& grid,
                               const std::vector<std::pair<double, double>>& places, const std::vector<int>& levels,
                               double slack, std::size_t& checked, std::size_t& insideCount) {
  std::mt19937 rng(11);
  for (const auto& [lon, lat] : places) {
    for (const int level : levels) {
      const double size = 180.0 / (1 << level);
      TileKey key{level, static_cast<int>(std::floor((lon + 180.0) / size)),
                  static_cast<int>(std::floor((lat + 90.0) / size))};
      const overlay::LayerGeometry pieces = buildTilePieces(layer, key, grid);
      const std::string label =
          layer.name() + " tile " + std::to_string(level) + "/" + std::to_string(key.x) + "/" + std::to_string(key.y);
      expectClosed(pieces, label);
      const LonLatRect r = key.rect();
      std::uniform_real_distribution<double> ulon(r.west, r.east), ulat(r.south, r.north), unit(-1.0, 1.0);
      for (int i = 0; i < 200; ++i) {
        const double plon = ulon(rng), plat = ulat(rng);
        const glm::dvec3 x = toEcef(plon, plat, grid.heightAt(plon, plat));
        const bool expected = layer.contains(x, plon, plat);
        // Points near an edge may go either way: tell them by nudging the point, at steps along
        // each direction (a nudge longer than a thin line is wide would jump over it).
        bool nearEdge = false;
        const glm::dmat3 enu = enuBasis(plon, plat);
        const double generalised = layer.lines().empty() ? 1.0 : kLineGeneralisation;
        const double nudge = slack + 1.2 * generalised * simplifyTolerance(level) * kMetresPerDegreeMax;
        const glm::dvec3 ne = (enu[0] + enu[1]) * 0.7071, nw = (enu[1] - enu[0]) * 0.7071;
        for (const glm::dvec3& d : {enu[0], -enu[0], enu[1], -enu[1], ne, -ne, nw, -nw}) {
          for (int step = 1; step <= 8 && !nearEdge; ++step) {
            const glm::dvec3 y = x + d * (nudge * step / 8.0);
            const Geodetic g = toGeodetic(y);
            if (layer.contains(y, g.lon, g.lat) != expected) nearEdge = true;
          }
        }
        if (nearEdge) continue;
        const glm::dvec3 dir = glm::normalize(glm::dvec3(unit(rng), unit(rng), unit(rng)));
        const bool got = insideMesh(pieces, x, dir);
        ++checked;
        insideCount += expected ? 1U : 0U;
        EXPECT_EQ(got, expected) << label << " at (" << plon << ", " << plat << ")";
      }
    }
  }
}

TEST(GlobePieces, ClosedAndHoldingExactlyTheGroundInside) {
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  const auto features = test::globe_scene::features();
  GlobeLayerOptions options;
  options.maxSegmentMetres = 20000.0;
  Result<GlobeLayer> layer = GlobeLayer::build("all", features, glm::vec4(1.0F), options);
  ASSERT_TRUE(layer.ok());
  // Tiles on the features' edges and inside them: the continent, across ±180, at both poles,
  // the hole, the small field; coarse and fine. Points within a metre of an edge go either way
  // (the walls are the edges' planes through the normals at their ends, to millimetres).
  const std::vector<std::pair<double, double>> places{{-60.0, -20.0}, {-40.0, -5.0}, {179.0, -20.0}, {-179.0, -6.0},
                                                      {10.0, 79.0},   {100.0, 89.5}, {-30.0, -71.0}, {60.0, -89.7},
                                                      {10.0, 45.0},   {20.0, 52.0},  {8.5, 47.3}};
  std::size_t checked = 0, insideCount = 0;
  expectPiecesHoldTheGround(*layer, *grid, places, {0, 1, 2, 5, 9, 13}, 1.0, checked, insideCount);
  std::printf("%zu ground points checked against the pieces, %zu inside\n", checked, insideCount);
  EXPECT_GT(insideCount, checked / 5);
}

using test::globe_scene::lineFeature;

TEST(GlobePieces, LinesAndOutlinesHoldTheGroundWithinTheirWidth) {
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  // 30 km lines: with a join, across ±180°, near the north pole; a 10 m road.
  GlobeLayerOptions wide;
  wide.lineWidthMetres = 30000.0;
  Result<GlobeLayer> lines = GlobeLayer::build("lines", test::globe_scene::wideLines(), glm::vec4(1.0F), wide);
  GlobeLayerOptions narrow;
  narrow.lineWidthMetres = 10.0;
  Result<GlobeLayer> road = GlobeLayer::build("road", {lineFeature({{8.498, 47.304}, {8.51, 47.3041}, {8.515, 47.31}})},
                                              glm::vec4(1.0F), narrow);
  GlobeLayerOptions outline;
  outline.outlines = true;
  outline.lineWidthMetres = 5000.0;
  Result<GlobeLayer> outlines =
      GlobeLayer::build("outlines", {test::globe_scene::features()[4]}, glm::vec4(1.0F), outline);
  ASSERT_TRUE(lines.ok() && road.ok() && outlines.ok());
  EXPECT_EQ(lines->lines().size(), 3u);
  EXPECT_EQ(outlines->lines().size(), 2u) << "the outer ring and the hole";
  std::size_t checked = 0, insideCount = 0;
  // The discs of the joins are within 1.2 m of their circles (256 sides at 15 km).
  expectPiecesHoldTheGround(*lines, *grid, {{-55.0, -25.0}, {-65.0, -15.0}, {179.9, -31.0}, {60.0, 88.5}}, {3, 6, 9},
                            2.0, checked, insideCount);
  expectPiecesHoldTheGround(*road, *grid, {{8.5, 47.304}, {8.51, 47.3041}}, {13, 16, 19}, 0.05, checked, insideCount);
  expectPiecesHoldTheGround(*outlines, *grid, {{0.0, 50.0}, {10.0, 45.0}, {30.0, 60.0}}, {5, 8}, 1.0, checked,
                            insideCount);
  std::printf("%zu ground points checked against the lines' pieces, %zu inside\n", checked, insideCount);
  EXPECT_GT(insideCount, checked / 20);
}

TEST(GlobePieces, JoinsAndCapsOfEveryKindHoldTheGroundWithinTheirWidth) {
  // A 20 m line (half width 10 m) that turns by 5°, 90° left and right, 170° and 179° (nearly
  // back on itself), with segments shorter than 1.5 half widths (whole discs there) and a
  // repeated point; and a line of one segment (two caps). Tiles of levels 16 to 19 around each
  // point given, so the ground checked lies near the joins.
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  const double m = 1.0 / 111000.0;  // about a metre of latitude, in degrees
  const double lon0 = 8.6, lat0 = 47.35, k = 1.0 / std::cos(lat0 * 3.14159265358979323846 / 180.0);
  std::vector<glm::dvec2> zigzag;
  std::vector<std::pair<double, double>> places;
  for (const auto& [x, y] : std::vector<std::pair<double, double>>{{0, 0},
                                                                   {100, 0},
                                                                   {199, 9},
                                                                   {199, 109},
                                                                   {299, 109},
                                                                   {299, 9},
                                                                   {200, 7},
                                                                   {200.1, 7.9},
                                                                   {209, 8},
                                                                   {215, 8},
                                                                   {215, 8},
                                                                   {300, -60}}) {
    zigzag.emplace_back(lon0 + x * m * k, lat0 + y * m);
    places.emplace_back(zigzag.back().x, zigzag.back().y);
  }
  GlobeLayerOptions options;
  options.lineWidthMetres = 20.0;
  Result<GlobeLayer> lines = GlobeLayer::build(
      "zigzag", {lineFeature(zigzag), lineFeature({{lon0, lat0 - 50 * m}, {lon0 + 60 * m * k, lat0 - 40 * m}})},
      glm::vec4(1.0F), options);
  ASSERT_TRUE(lines.ok());
  places.emplace_back(lon0, lat0 - 50 * m);
  places.emplace_back(lon0 + 60 * m * k, lat0 - 40 * m);
  std::size_t checked = 0, insideCount = 0;
  expectPiecesHoldTheGround(*lines, *grid, places, {16, 17, 18, 19}, 0.05, checked, insideCount);
  std::printf("%zu ground points near joins and caps checked, %zu inside\n", checked, insideCount);
  EXPECT_GT(insideCount, checked / 5);
}

TEST(GlobePieces, ADenseNetworkIsUnitedPerCellAndHoldsItsGround) {
  // 80 random 7 m streets of 12 points over 2 km × 2 km at 8° S (an Olinda), crossing each other
  // everywhere, in two colours: per tile, a colour's shapes in a cell are one piece (their union;
  // the overlaps leave no wall and no cap inside it), and the pieces hold the ground exactly
  // where the streets are, at levels where the shapes are generalised and where they are whole.
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  std::mt19937 rng(5);
  const double lon0 = -34.86, lat0 = -8.01, size = 0.018;
  std::uniform_real_distribution<double> start(0.0, size), turn(-0.8, 0.8);
  std::vector<geo::Feature> features;
  std::vector<glm::vec4> colours;
  std::vector<std::pair<double, double>> places;
  for (int f = 0; f < 80; ++f) {
    std::vector<glm::dvec2> street{{lon0 + start(rng), lat0 + start(rng)}};
    double heading = start(rng) / size * 6.283;
    for (int i = 0; i < 11; ++i) {
      heading += turn(rng);
      street.push_back(street.back() + 0.0012 * glm::dvec2(std::cos(heading), std::sin(heading)));
    }
    places.emplace_back(street[3].x, street[3].y);
    features.push_back(lineFeature(street));
    colours.push_back(f % 2 == 0 ? glm::vec4(1.0F, 0.0F, 0.0F, 1.0F) : glm::vec4(0.0F, 0.0F, 1.0F, 1.0F));
  }
  GlobeLayerOptions options;
  options.lineWidthMetres = 7.0;
  options.featureColors = colours;
  Result<GlobeLayer> layer = GlobeLayer::build("network", features, glm::vec4(1.0F), options);
  ASSERT_TRUE(layer.ok());
  const std::size_t shapes = layer->lines().size();
  for (const int level : {9, 12, 15, 18}) {
    const double tile = 180.0 / (1 << level);
    const TileKey key{level, static_cast<int>(std::floor((places[0].first + 180.0) / tile)),
                      static_cast<int>(std::floor((places[0].second + 90.0) / tile))};
    const overlay::LayerGeometry pieces = buildTilePieces(*layer, key, *grid);
    std::printf("level %d: %zu pieces for %zu lines, %zu triangles\n", level, pieces.slots().size(), shapes,
                pieces.indices().size() / 3);
    EXPECT_GT(pieces.slots().size(), 0u);
    EXPECT_LE(pieces.slots().size(), 2u * 4u) << "a piece per colour and cell";
  }
  places.resize(24);
  std::size_t checked = 0, insideCount = 0;
  expectPiecesHoldTheGround(*layer, *grid, places, {11, 14, 17, 19}, 0.05, checked, insideCount);
  std::printf("%zu ground points checked against a united network, %zu inside\n", checked, insideCount);
  EXPECT_GT(insideCount, checked / 20);
}

/// The tile of `level` that holds (lon, lat).
TileKey tileAt(double lon, double lat, int level) {
  const double size = 180.0 / static_cast<double>(1 << level);
  return {level, static_cast<int>(std::floor((lon + 180.0) / size)), static_cast<int>(std::floor((lat + 90.0) / size))};
}

TEST(GlobeLines, GeneralisedFromAfarAndWholeUpClose) {
  // A 7 m street of 2,000 points zigzagging a metre either side of its way (8 km at 8° S, like
  // Olinda's): from afar its centreline needs two points, up close every one.
  std::vector<glm::dvec2> street;
  for (int i = 0; i < 2000; ++i) street.emplace_back(-34.9 + i * 4e-5, -8.0 + ((i % 2) != 0 ? 1e-5 : -1e-5));
  GlobeLayerOptions options;
  options.lineWidthMetres = 7.0;
  Result<GlobeLayer> layer = GlobeLayer::build("street", {lineFeature(street)}, glm::vec4(1.0F), options);
  ASSERT_TRUE(layer.ok());
  // The points of the shapes the tiles of a level along the street draw (lineShapesIn: each
  // tile the runs near it).
  const auto pointsAt = [&](int level) {
    const TileKey first = tileAt(-34.9, -8.0, level), last = tileAt(-34.9 + 2000 * 4e-5, -8.0, level);
    std::size_t n = 0, tiles = 0;
    for (int x = first.x; x <= last.x; ++x) {
      for (const GlobePolygon& p : layer->lineShapesIn({level, x, first.y})) {
        for (const auto& ring : p.rings) n += ring.size();
      }
      ++tiles;
    }
    std::printf("level %d: %zu tiles along the street draw %zu points\n", level, tiles, n);
    return n;
  };
  const std::size_t close = pointsAt(17), middle = pointsAt(12), far = pointsAt(8);
  EXPECT_LT(far * 50, close);
  EXPECT_LT(middle * 2, close);
  // A tile away from the street draws nothing of it.
  EXPECT_TRUE(layer->lineShapesIn(tileAt(-34.8, -8.2, 12)).empty());
  // What the coarse tiles draw still holds the ground within the width, but for the level's
  // tolerance (expectPiecesHoldTheGround nudges by it).
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  std::size_t checked = 0, insideCount = 0;
  expectPiecesHoldTheGround(*layer, *grid, {{-34.9, -8.0}, {-34.86, -8.0}}, {8, 12, 15, 22}, 0.05, checked,
                            insideCount);
  EXPECT_GT(insideCount, 0u);
}

TEST(GlobeLines, TilesAroundAPoleDrawOnlyTheLinesNearThem) {
  // Rivers of Siberia (60° N, 100° E) and of Alaska (64° N, 150° W), 10 km wide, and one across
  // the pole's cap (89.95° N). The eight level-2 tiles around the north pole (45° × 45°, up to
  // 90° N) each drew every line of their latitudes: the window was widened by the tile's highest
  // latitude, the pole's. Now a tile draws a line only where it passes within reach; the line
  // across the cap is near every one of them.
  GlobeLayerOptions options;
  options.lineWidthMetres = 10000.0;
  Result<GlobeLayer> layer =
      GlobeLayer::build("rivers",
                        {lineFeature({{100.0, 60.0}, {100.5, 60.3}, {101.0, 60.5}}),
                         lineFeature({{-150.0, 64.0}, {-149.5, 64.2}}), lineFeature({{-20.0, 89.95}, {160.0, 89.95}})},
                        glm::vec4(1.0F), options);
  ASSERT_TRUE(layer.ok());
  ASSERT_EQ(layer->lines().size(), 3u);
  std::array<int, 3> tiles{};
  for (int x = 0; x < 8; ++x) {
    const TileKey key{2, x, 3};
    for (std::size_t j = 0; j < 3; ++j) {
      if (!GlobeLayer::lineRunsIn(layer->lineAt(j, key.level), key, 5000.0).empty()) ++tiles[j];
    }
    // Siberia lies in the tile of 90°–135° E only, Alaska in that of 180°–135° W.
    const LonLatRect r = key.rect();
    EXPECT_EQ(!GlobeLayer::lineRunsIn(layer->lineAt(0, key.level), key, 5000.0).empty(),
              r.west <= 100.0 && 101.0 <= r.east)
        << x;
    EXPECT_EQ(!GlobeLayer::lineRunsIn(layer->lineAt(1, key.level), key, 5000.0).empty(),
              r.west <= -150.0 && -149.5 <= r.east)
        << x;
  }
  EXPECT_EQ(tiles[0], 1);
  EXPECT_EQ(tiles[1], 1);
  EXPECT_EQ(tiles[2], 8) << "a line across the pole's cap is within reach of every tile around it";
}

/// The depth buffer of the bare ellipsoid for a view, as the GPU would leave it (reversed-Z).
std::vector<float> ellipsoidDepth(const GlobeView& view) {
  const glm::dmat4 toClip = view.eyeViewProj(), inverse = glm::inverse(toClip);
  std::vector<float> depth(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height), 0.0F);
  const glm::dvec3 scale(1.0 / kSemiMajor, 1.0 / kSemiMajor, 1.0 / kSemiMinor);
  for (int row = 0; row < view.height; ++row) {
    for (int col = 0; col < view.width; ++col) {
      const double x = (col + 0.5) / view.width * 2.0 - 1.0, y = 1.0 - (row + 0.5) / view.height * 2.0;
      const glm::dvec4 a = inverse * glm::dvec4(x, y, 1.0, 1.0), b = inverse * glm::dvec4(x, y, 0.5, 1.0);
      const glm::dvec3 dir = glm::normalize(glm::dvec3(b) / b.w - glm::dvec3(a) / a.w);
      const glm::dvec3 o = view.eye * scale, d = dir * scale;  // the unit sphere's frame
      const double qa = glm::dot(d, d), qb = 2.0 * glm::dot(o, d), qc = glm::dot(o, o) - 1.0;
      const double disc = qb * qb - 4.0 * qa * qc;
      if (disc < 0.0) continue;
      const double t = (-qb - std::sqrt(disc)) / (2.0 * qa);
      if (t <= 0.0) continue;
      const glm::dvec4 clip = toClip * glm::dvec4(dir * t, 1.0);
      depth[static_cast<std::size_t>(row) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(col)] =
          static_cast<float>(clip.z / clip.w);
    }
  }
  return depth;
}

TEST(GlobeEdgeBand, HoldsLinesNarrowerThanAPixelAndNothingFarFromEdges) {
  // Straight down from 2 km over a 2 m road and a 300 m field: pixels of about 26 m.
  const glm::dvec2 at(8.5, 47.3);
  const double m = 1.0 / 111000.0, k = 1.0 / std::cos(at.y * 3.14159265358979323846 / 180.0);
  GlobeLayerOptions options;
  options.lineWidthMetres = 2.0;
  const std::vector<glm::dvec2> ends{{at.x - 400 * m * k, at.y - 300 * m}, {at.x + 350 * m * k, at.y + 250 * m}};
  Result<GlobeLayer> road = GlobeLayer::build("road", {lineFeature(ends)}, glm::vec4(1.0F), options);
  geo::Polygon field;
  field.outer = {{at.x - 150 * m * k, at.y + 100 * m},
                 {at.x + 150 * m * k, at.y + 100 * m},
                 {at.x + 150 * m * k, at.y + 400 * m},
                 {at.x - 150 * m * k, at.y + 400 * m}};
  Result<GlobeLayer> fields = GlobeLayer::build("field", one(field), glm::vec4(1.0F));
  ASSERT_TRUE(road.ok() && fields.ok());
  const GlobeView view = GlobeView::looking(toEcef(at.x, at.y, 2000.0), toEcef(at.x, at.y + 1e-6, 0.0), 45.0, 64, 64);
  const std::vector<float> depth = ellipsoidDepth(view);
  const double pixel = view.pixelSizeAt(2000.0);
  for (const GlobeLayer* layer : {&*road, &*fields}) {
    const std::vector<std::uint32_t> mask =
        overlay::referenceMask(depthImageOf(view, depth), referenceLayersOf({layer}, depthImageOf(view, depth)));
    const std::vector<std::uint8_t> byMask = overlay::maskEdges(mask, depthImageOf(view, depth));
    const std::vector<std::uint8_t> band =
        overlay::edgePixels(depthImageOf(view, depth), referenceLayersOf({layer}, depthImageOf(view, depth)));
    std::size_t near = 0, far = 0, bandCount = 0, maskCount = 0;
    for (int row = 1; row + 1 < view.height; ++row) {
      for (int col = 1; col + 1 < view.width; ++col) {
        const std::size_t i =
            static_cast<std::size_t>(row) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(col);
        ASSERT_GT(depth[i], 0.0F);
        glm::dvec3 p;
        const std::optional<glm::dvec3> seen = overlay::unprojectDepth(depthImageOf(view, {}), col, row, depth[i]);
        ASSERT_TRUE(seen);
        p = *seen;
        // The distance to the layer's border, by sampling a disc around the point.
        const glm::dmat3 enu = enuBasis(at.x, at.y);
        const auto inside = [&](const glm::dvec3& q) {
          const Geodetic g = toGeodetic(q);
          return layer->contains(q, g.lon, g.lat);
        };
        const bool here = inside(p);
        // (Steps of 0.4 m cannot step over the 2 m road.)
        double border = std::numeric_limits<double>::infinity();
        for (int s = 0; s < 32; ++s) {
          const double a = s * 2.0 * 3.14159265358979323846 / 32;
          for (double r = 0.4; r <= std::min(2.5 * pixel, border); r += 0.4) {
            if (inside(p + (enu[0] * std::cos(a) + enu[1] * std::sin(a)) * r) != here) {
              border = std::min(border, r);
              break;
            }
          }
        }
        bandCount += band[i];
        maskCount += byMask[i];
        if (border < 0.5 * pixel) {
          ++near;
          EXPECT_EQ(band[i], 1) << layer->name() << " pixel " << col << ", " << row << ": " << border
                                << " m from the border";
        }
        // (The band reaches as far as the pixel's footprint, 0.7 px from its middle straight down.)
        // (The rays sampled may pass beside the road's round ends, narrower than their spacing.)
        bool nearEnd = false;
        for (const glm::dvec2& end : ends)
          nearEnd = nearEnd || glm::length(p - toEcef(end.x, end.y, 0.0)) < 3.0 * pixel;
        if (border == std::numeric_limits<double>::infinity() && byMask[i] == 0 && !nearEnd) {
          ++far;
          EXPECT_EQ(band[i], 0) << layer->name() << " pixel " << col << ", " << row << ": 2.5 px from any border";
        }
      }
    }
    std::printf("%s: %zu pixels within half a pixel of its border, %zu beyond 2.5; band %zu pixels (%zu by the mask)\n",
                layer->name().c_str(), near, far, bandCount, maskCount);
    EXPECT_GT(near, 20u);
    EXPECT_GT(far, 1500u);
    if (layer == &*road) {
      EXPECT_GT(bandCount, 2 * maskCount) << "the road is narrower than a pixel";
    }
  }
}

TEST(GlobeLines, ALongGeodesicFromAfarStaysClosedAndHoldsItsGround) {
  // 3,100 km along one geodesic, 5 km wide: from afar its generalised centreline turns by
  // hundredths of a degree at every point kept, where a sector would nearly repeat the bands'
  // corners (the first run of this test found pieces that were not closed there).
  GlobeLayerOptions options;
  options.lineWidthMetres = 5000.0;
  Result<GlobeLayer> road =
      GlobeLayer::build("road", {lineFeature({{-72.0, -33.0}, {-38.0, -34.0}})}, glm::vec4(1.0F), options);
  ASSERT_TRUE(road.ok());
  EXPECT_FALSE(road->lineShapesIn(tileAt(-55.0, -34.5, 2)).empty());
  const auto grid = test::globe_scene::syntheticGrid(1.0);
  std::size_t checked = 0, insideCount = 0;
  expectPiecesHoldTheGround(*road, *grid, {{-60.0, -34.5}, {-55.0, -34.7}, {-50.0, -34.75}}, {2, 3, 4, 5, 6, 7}, 100.0,
                            checked, insideCount);
  EXPECT_GT(insideCount, 0u);
}

TEST(WholeLoad, TheCoarserDrawnLevelsOverATileAreFoundByKeyAsByEveryRectangle) {
  // `stencil` sets its tiles' caps each frame from the levels of the coarser terrain tiles drawn
  // over them (coarserLevelsOver: a few lookups by key per tile, not a pass over every drawn
  // tile). Against that pass, the rectangles' closed test a turn east and west included: random
  // cuts of the quadtree (split at random, as views split it), every tile of kWholeLoadLevel
  // under a few of their tiles, and tiles along ±180° and the poles.
  std::mt19937 random(20261130);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto bruteForce = [](const LonLatRect& box, int level, const std::vector<DrawnTile>& drawn) {
    std::uint32_t found = 0;
    for (const DrawnTile& d : drawn) {
      if (d.key.level >= std::min(level, kWholeLoadLevel)) continue;
      const LonLatRect r = d.key.rect();
      for (int turn = -1; turn <= 1; ++turn) {
        const double shift = 360.0 * turn;
        if (box.west + shift <= r.east && r.west <= box.east + shift && box.south <= r.north && r.south <= box.north)
          found |= 1U << static_cast<unsigned>(d.key.level);
      }
    }
    return found;
  };
  std::size_t compared = 0, withLevels = 0;
  for (int cut = 0; cut < 12; ++cut) {
    // A cut: split each tile while a random draw says so, deeper near a random point.
    const double lon = -180.0 + 360.0 * unit(random), lat = -90.0 + 180.0 * unit(random);
    std::vector<DrawnTile> drawn;
    std::vector<TileKey> open{TileKey{0, 0, 0}, TileKey{0, 1, 0}};
    while (!open.empty()) {
      const TileKey k = open.back();
      open.pop_back();
      const LonLatRect r = k.rect();
      const bool near = r.west <= lon && lon <= r.east && r.south <= lat && lat <= r.north;
      if (k.level < 14 && (near || (k.level < 3 && unit(random) < 0.6))) {
        for (const TileKey& c : k.children()) open.push_back(c);
      } else {
        drawn.push_back({k, 0});
      }
    }
    const CoarseDrawnTiles coarse(drawn);
    std::vector<TileKey> probes;
    for (int k = 0; k < 200; ++k) {
      const TileKey any{kWholeLoadLevel, 0, 0};
      const double plon = k < 100 ? lon + (unit(random) - 0.5) * 40.0 : -180.0 + 360.0 * unit(random);
      const double plat =
          std::clamp(k < 100 ? lat + (unit(random) - 0.5) * 20.0 : -90.0 + 180.0 * unit(random), -89.999, 89.999);
      const int x = std::clamp(static_cast<int>(std::floor((std::remainder(plon, 360.0) + 180.0) / any.size())), 0,
                               any.columns() - 1);
      const int y = std::clamp(static_cast<int>(std::floor((plat + 90.0) / any.size())), 0, any.rows() - 1);
      probes.push_back({kWholeLoadLevel, x, y});
    }
    const TileKey last{kWholeLoadLevel, 0, 0};
    probes.push_back({kWholeLoadLevel, 0, 3000});                   // at −180°
    probes.push_back({kWholeLoadLevel, last.columns() - 1, 1000});  // at +180°
    probes.push_back({kWholeLoadLevel, 17, 0});                     // at the south pole
    probes.push_back({kWholeLoadLevel, 4000, last.rows() - 1});     // at the north pole
    for (const TileKey& key : probes) {
      WholeLoadTile tile;
      tile.key = key;
      tile.empty = false;
      const LonLatRect box = key.rect().expanded(0.01 * key.size(), 0.01 * key.size());
      const std::uint32_t expected = bruteForce(box, key.level, drawn);
      EXPECT_EQ(coarserLevelsOver(tile, coarse), expected) << "cut " << cut << ", tile " << key.x << ", " << key.y;
      ++compared;
      withLevels += expected != 0 ? 1U : 0U;
    }
  }
  EXPECT_EQ(compared, 12U * 204U);
  EXPECT_GT(withLevels, compared / 4);  // the cuts draw coarse tiles over many of them
}

}  // namespace
}  // namespace gis::globe
