// The globe terrain's tile selection and meshes, without GL: over many random views (1 m to
// 20,000 km up, over the poles, across the antimeridian) the selected tiles never overlap, are
// balanced (across ±180° too), stitch exactly the edges beside coarser tiles and cover every
// ground point the view sees; the meshes tile their squares, wind outwards and stay within
// terrainBounds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <unordered_map>
#include <unordered_set>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "globe/globe_terrain.hpp"

namespace gis::globe {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A global grid of 0.5° posts with seas (down to −4,000 m), hills and sharp peaks to 6,000 m.
std::shared_ptr<const GeoGrid> reliefGrid() {
  const int w = 720, h = 361;
  std::vector<float> heights(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (int r = 0; r < h; ++r) {
    const double lat = (90.0 - 0.5 * r) * kPi / 180.0;
    for (int c = 0; c < w; ++c) {
      const double lon = (-180.0 + 0.5 * c) * kPi / 180.0;
      double v = 2500.0 * std::sin(3.0 * lon) * std::cos(2.0 * lat) +
                 1200.0 * std::sin(7.0 * lon + 1.0) * std::sin(5.0 * lat) +
                 400.0 * std::cos(23.0 * lon) * std::sin(17.0 * lat + 0.3);
      if ((c * 7 + r * 13) % 97 == 0) v += 3000.0;  // isolated peaks: detail between coarse posts
      heights[static_cast<std::size_t>(r * w + c)] = static_cast<float>(std::clamp(v, -4000.0, 6000.0));
    }
  }
  return std::make_shared<const GeoGrid>(w, h, -180.0, 90.0, 0.5, std::move(heights));
}

enum Side { kWest = 0, kEast = 1, kSouth = 2, kNorth = 3 };

std::optional<TileKey> neighbourOf(const TileKey& k, int side) {
  const int cols = k.columns();
  switch (side) {
    case kWest:
      return TileKey{k.level, k.x == 0 ? cols - 1 : k.x - 1, k.y};
    case kEast:
      return TileKey{k.level, k.x == cols - 1 ? 0 : k.x + 1, k.y};
    case kSouth:
      return k.y == 0 ? std::nullopt : std::optional<TileKey>(TileKey{k.level, k.x, k.y - 1});
    default:
      return k.y == k.rows() - 1 ? std::nullopt : std::optional<TileKey>(TileKey{k.level, k.x, k.y + 1});
  }
}

/// The tile of `level` holding (lon, lat).
TileKey tileAt(int level, double lon, double lat) {
  const TileKey probe{level, 0, 0};
  const int x = std::clamp(static_cast<int>(std::floor((lon + 180.0) / probe.size())), 0, probe.columns() - 1);
  const int y = std::clamp(static_cast<int>(std::floor((lat + 90.0) / probe.size())), 0, probe.rows() - 1);
  return {level, x, y};
}

struct Checked {
  std::size_t neighbourPairs = 0, acrossAntimeridian = 0, stitchedEdges = 0, stitchUnseen = 0, rays = 0;
};

/// The invariants of a selection; failures name the view.
void checkSelection(const std::vector<DrawnTile>& tiles, const std::string& what, Checked& checked) {
  std::unordered_map<TileKey, std::uint8_t, TileKeyHash> drawn;
  for (const DrawnTile& t : tiles) {
    ASSERT_TRUE(drawn.emplace(t.key, t.stitch).second) << what << ": tile drawn twice";
  }
  const auto find = [&](const TileKey& k) { return drawn.find(k) != drawn.end(); };
  for (const DrawnTile& t : tiles) {
    for (TileKey a = t.key; a.level > 0;) {
      a = a.parent();
      ASSERT_FALSE(find(a)) << what << ": tile " << t.key.level << "/" << t.key.x << "/" << t.key.y
                            << " overlaps its ancestor at level " << a.level;
    }
    for (int side = 0; side < 4; ++side) {
      const bool stitched = ((t.stitch >> side) & 1) != 0;
      const std::optional<TileKey> n = neighbourOf(t.key, side);
      if (!n) {
        EXPECT_FALSE(stitched) << what << ": stitched across a pole";
        continue;
      }
      // A drawn coarser tile over the neighbour's region: at most one level coarser, and stitched.
      std::optional<TileKey> coarser;
      for (TileKey a = *n; a.level > 0 && !coarser;) {
        a = a.parent();
        if (find(a)) coarser = a;
      }
      const bool wraps = (side == kWest && t.key.x == 0) || (side == kEast && t.key.x == t.key.columns() - 1);
      checked.stitchedEdges += stitched ? 1 : 0;
      if (coarser) {
        ++checked.neighbourPairs;
        checked.acrossAntimeridian += wraps ? 1 : 0;
        EXPECT_EQ(coarser->level, t.key.level - 1)
            << what << ": unbalanced: tile " << t.key.level << "/" << t.key.x << "/" << t.key.y << " beside level "
            << coarser->level << " (side " << side << ")";
        EXPECT_TRUE(stitched) << what << ": edge beside a coarser tile not stitched";
        continue;
      }
      // Otherwise a drawn neighbour of the same level or finer (if any is drawn) forbids stitching.
      bool equalOrFiner = find(*n);
      const auto c = n->children();
      const std::array<TileKey, 2> facing = side == kWest    ? std::array<TileKey, 2>{c[1], c[3]}
                                            : side == kEast  ? std::array<TileKey, 2>{c[0], c[2]}
                                            : side == kSouth ? std::array<TileKey, 2>{c[2], c[3]}
                                                             : std::array<TileKey, 2>{c[0], c[1]};
      for (const TileKey& f : facing) equalOrFiner = equalOrFiner || find(f);
      if (equalOrFiner) {
        ++checked.neighbourPairs;
        checked.acrossAntimeridian += wraps ? 1 : 0;
        EXPECT_FALSE(stitched) << what << ": edge stitched beside an equal or finer tile";
      } else if (stitched) {
        ++checked.stitchUnseen;  // the coarser neighbour is culled: nothing drawn contradicts it
      }
    }
  }
}

/// Every ground point a pixel ray meets (on an ellipsoid enclosed by every drawn mesh, so that
/// the tile holding it must be drawn) lies in a selected tile.
void checkCoverage(const GlobeView& view, const std::vector<DrawnTile>& tiles, const GeoGrid& grid,
                   const std::string& what, Checked& checked) {
  std::unordered_set<TileKey, TileKeyHash> drawn;
  double low = 0.0;
  int finest = 0;
  for (const DrawnTile& t : tiles) {
    drawn.insert(t.key);
    low = std::min(low, terrainBounds(grid, t.key).first);
    finest = std::max(finest, t.key.level);
  }
  // An ellipsoid inside the surface at height `low` (the offset surface departs from the scaled
  // ellipsoid by less than e² |h|).
  const double r = low - 0.01 * std::abs(low) - 1.0;
  const glm::dvec3 radii(kSemiMajor + r, kSemiMajor + r, kSemiMinor + r);
  const glm::dmat4 inv = glm::inverse(view.eyeViewProj());
  const int n = 24;
  for (int py = 0; py < n; ++py) {
    for (int px = 0; px < n; ++px) {
      const glm::dvec4 clip(2.0 * (px + 0.5) / n - 1.0, 2.0 * (py + 0.5) / n - 1.0, 0.5, 1.0);
      const glm::dvec4 q = inv * clip;
      const glm::dvec3 dir = glm::normalize(glm::dvec3(q) / q.w);
      const glm::dvec3 o = view.eye / radii, d = dir / radii;
      const double a = glm::dot(d, d), b = glm::dot(o, d), c = glm::dot(o, o) - 1.0;
      const double disc = b * b - a * c;
      if (disc < 0.0) continue;
      const double t = (-b - std::sqrt(disc)) / a;
      if (t <= 0.0) continue;
      const glm::dvec4 hitClip = view.eyeViewProj() * glm::dvec4(t * dir, 1.0);
      if (hitClip.z > hitClip.w) continue;  // before the near plane
      ++checked.rays;
      const Geodetic g = toGeodetic(view.eye + t * dir);
      bool covered = false;
      for (int level = 0; level <= finest && !covered; ++level) covered = drawn.count(tileAt(level, g.lon, g.lat)) != 0;
      EXPECT_TRUE(covered) << what << ": ground at " << g.lon << ", " << g.lat << " seen but no tile drawn there";
    }
  }
}

GlobeView randomView(std::mt19937& rng, const GeoGrid& grid, int index) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double lon = -180.0 + 360.0 * uniform(rng);
  double lat = std::asin(2.0 * uniform(rng) - 1.0) * 180.0 / kPi;
  if (index % 5 == 1) lat = (uniform(rng) < 0.5 ? -1.0 : 1.0) * (88.0 + 2.0 * uniform(rng));   // over a pole
  if (index % 5 == 2) lon = 180.0 - 1.0 * uniform(rng) + (uniform(rng) < 0.5 ? 0.0 : -359.0);  // by ±180°
  const double altitude = std::exp(std::log(1.0) + (std::log(2e7) - std::log(1.0)) * uniform(rng));
  const double ground = grid.heightAt(lon, lat);
  const glm::dvec3 eye = toEcef(lon, lat, std::max(ground, 0.0) + altitude);
  // Down, oblique or along the horizon (the top of the view at most a little above it).
  const double fov = 30.0 + 30.0 * uniform(rng);
  const double dip = std::acos(kSemiMajor / (kSemiMajor + altitude));
  const double highest = -dip + 0.4 * fov * kPi / 180.0;
  const double elevation = -kPi / 2.0 + (highest + kPi / 2.0) * std::sqrt(uniform(rng));
  const double azimuth = 2.0 * kPi * uniform(rng);
  const glm::dmat3 enu = enuBasis(lon, lat);
  const glm::dvec3 dir = enu * glm::dvec3(std::cos(elevation) * std::sin(azimuth),
                                          std::cos(elevation) * std::cos(azimuth), std::sin(elevation));
  return GlobeView::looking(eye, eye + 1000.0 * dir, fov, 256, 256, std::max(ground, 0.0));
}

TEST(GlobeTerrainSelect, InvariantsOverRandomViews) {
  const auto grid = reliefGrid();
  GlobeTerrain terrain(grid);
  std::mt19937 rng(20240611);
  Checked checked;
  std::size_t total = 0, most = 0;
  const int views = 60;
  for (int v = 0; v < views; ++v) {
    const GlobeView view = randomView(rng, *grid, v);
    const std::vector<DrawnTile> tiles = terrain.select(view);
    const Geodetic g = toGeodetic(view.eye);
    const std::string what = "view " + std::to_string(v) + " (lon " + std::to_string(g.lon) + ", lat " +
                             std::to_string(g.lat) + ", h " + std::to_string(g.h) + ")";
    ASSERT_FALSE(tiles.empty()) << what;
    checkSelection(tiles, what, checked);
    checkCoverage(view, tiles, *grid, what, checked);
    if (HasFailure()) return;
    total += tiles.size();
    most = std::max(most, tiles.size());
  }
  std::printf(
      "%d views: %zu tiles (mean %.0f, most %zu); %zu neighbour pairs checked (%zu across ±180°), %zu "
      "stitched edges (%zu beside culled tiles), %zu ground rays covered\n",
      views, total, static_cast<double>(total) / views, most, checked.neighbourPairs, checked.acrossAntimeridian,
      checked.stitchedEdges, checked.stitchUnseen, checked.rays);
  EXPECT_GT(checked.acrossAntimeridian, 0u);
  EXPECT_GT(checked.stitchedEdges, 0u);
  EXPECT_GT(checked.rays, 10000u);
}

TEST(GlobeTerrainSelect, HemisphereFromSpace) {
  const auto grid = reliefGrid();
  GlobeTerrain terrain(grid);
  for (const double altitude : {2e7, 1e7, 3e6}) {
    const GlobeView view = GlobeView::looking(toEcef(10.0, 20.0, altitude), glm::dvec3(0.0), 45.0, 256, 256);
    const std::vector<DrawnTile> tiles = terrain.select(view);
    int finest = 0;
    for (const DrawnTile& t : tiles) finest = std::max(finest, t.key.level);
    std::printf("from %.0f km: %zu tiles, finest level %d\n", altitude / 1000.0, tiles.size(), finest);
    EXPECT_GE(tiles.size(), 2u);
    EXPECT_LE(tiles.size(), 400u);
    Checked checked;
    checkSelection(tiles, "space", checked);
    checkCoverage(view, tiles, *grid, "space", checked);
  }
}

TEST(GlobeTerrainSelect, RefinesNearTheEyeAndCullsTheFarSide) {
  const auto grid = reliefGrid();
  GlobeTerrain terrain(grid);
  const double ground = grid->heightAt(7.0, 45.0);
  const glm::dvec3 eye = toEcef(7.0, 45.0, ground + 100.0);
  const GlobeView view = GlobeView::looking(eye, toEcef(7.0, 45.0, ground), 45.0, 256, 256, ground);
  const std::vector<DrawnTile> tiles = terrain.select(view);
  int finest = 0;
  for (const DrawnTile& t : tiles) {
    finest = std::max(finest, t.key.level);
    // Nothing from the far side of the globe.
    EXPECT_GT(glm::dot(glm::normalize(toEcef(t.key.rect().west, t.key.rect().south, 0.0)), glm::normalize(eye)), -0.5);
  }
  std::printf("100 m above ground, looking down: %zu tiles, finest level %d\n", tiles.size(), finest);
  EXPECT_GE(finest, 12);
}

// --- Meshes ----------------------------------------------------------------------------------

TEST(GlobeTerrainMesh, TrianglesTileTheSquareAndStitchedEdgesMatchTheCoarserTile) {
  for (std::uint8_t mask = 0; mask < 16; ++mask) {
    const std::vector<std::uint16_t> tris = tileTriangles(mask);
    ASSERT_EQ(tris.size() % 3, 0u);
    // Counter-clockwise in (i east, j north), areas summing to the square.
    long twiceArea = 0;
    std::map<std::pair<int, int>, int> edges;  // directed edge counts
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      std::array<glm::ivec2, 3> p;
      for (std::size_t k = 0; k < 3; ++k) p[k] = {tris[t + k] % kTilePosts, tris[t + k] / kTilePosts};
      const int area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
      ASSERT_GT(area, 0) << "mask " << int(mask) << " triangle " << t / 3;
      twiceArea += area;
      for (std::size_t k = 0; k < 3; ++k) ++edges[{tris[t + k], tris[t + (k + 1) % 3]}];
    }
    EXPECT_EQ(twiceArea, 2L * kTileSegments * kTileSegments);
    // Boundary edges (no twin): exactly the sides, in steps of 2 posts where stitched.
    std::map<std::pair<int, int>, int> boundary;
    for (const auto& [e, count] : edges) {
      EXPECT_EQ(count, 1) << "edge used twice in one direction";
      if (edges.count({e.second, e.first}) == 0) boundary[e] = 1;
    }
    std::size_t expected = 0;
    for (int side = 0; side < 4; ++side) {
      const int stride = ((mask >> side) & 1) != 0 ? 2 : 1;
      for (int t = 0; t < kTileSegments; t += stride) {
        const auto at = [&](int s) {
          switch (side) {
            case kWest:
              return s * kTilePosts;
            case kEast:
              return s * kTilePosts + kTileSegments;
            case kSouth:
              return s;
            default:
              return kTileSegments * kTilePosts + s;
          }
        };
        // Counter-clockwise around the square: south eastwards, east northwards, north
        // westwards, west southwards.
        const bool forward = side == kSouth || side == kEast;
        const std::pair<int, int> e = forward ? std::pair{at(t), at(t + stride)} : std::pair{at(t + stride), at(t)};
        EXPECT_EQ(boundary.count(e), 1u) << "mask " << int(mask) << " side " << side << " segment " << t;
        ++expected;
      }
    }
    EXPECT_EQ(boundary.size(), expected) << "mask " << int(mask);
  }
}

TEST(GlobeTerrainMesh, WithinTerrainBoundsAndWoundOutwards) {
  const auto grid = reliefGrid();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<TileKey> keys = {{0, 0, 0},       {0, 1, 0},     {1, 3, 1},           {2, 0, 3},
                               {3, 15, 0},      {5, 63, 31},   {6, 0, 40},          {8, 300, 255},
                               {10, 1024, 700}, {14, 0, 9000}, {18, 524287, 200000}};
  for (int k = 0; k < 6; ++k) {
    const int level = 4 + 3 * k;
    const TileKey probe{level, 0, 0};
    keys.push_back(
        {level, static_cast<int>(uniform(rng) * probe.columns()), static_cast<int>(uniform(rng) * probe.rows())});
  }
  std::size_t samples = 0;
  for (const TileKey& key : keys) {
    const auto [lo, hi] = terrainBounds(*grid, key);
    const std::vector<glm::dvec3> posts = tilePostPositions(*grid, key);
    ASSERT_EQ(posts.size(), static_cast<std::size_t>(kTilePosts * kTilePosts));
    for (const std::uint8_t mask : {std::uint8_t{0}, std::uint8_t{5}, std::uint8_t{10}, std::uint8_t{15}}) {
      const std::vector<std::uint16_t> tris = tileTriangles(mask);
      for (std::size_t t = 0; t < tris.size(); t += 3) {
        const glm::dvec3 a = posts[tris[t]], b = posts[tris[t + 1]], c = posts[tris[t + 2]];
        const glm::dvec3 n = glm::cross(b - a, c - a);
        if (glm::length(n) > 1e-6 * glm::dot(b - a, b - a) + 1e-9) {
          EXPECT_GT(glm::dot(n, (a + b + c) / 3.0), 0.0)
              << "triangle facing inwards in tile " << key.level << "/" << key.x << "/" << key.y;
        }
        for (const glm::dvec3& w : {glm::dvec3(1.0 / 3), glm::dvec3(0.5, 0.5, 0.0), glm::dvec3(0.0, 0.5, 0.5),
                                    glm::dvec3(0.5, 0.0, 0.5), glm::dvec3(0.7, 0.2, 0.1)}) {
          const Geodetic g = toGeodetic(w.x * a + w.y * b + w.z * c);
          ++samples;
          EXPECT_GE(g.h, lo - 1e-6) << "tile " << key.level << "/" << key.x << "/" << key.y << " mask " << int(mask);
          EXPECT_LE(g.h, hi + 1e-6) << "tile " << key.level << "/" << key.x << "/" << key.y << " mask " << int(mask);
          if (HasFailure()) return;
        }
      }
    }
  }
  std::printf("%zu mesh points of %zu tiles within terrainBounds\n", samples, keys.size());
}

}  // namespace
}  // namespace gis::globe
