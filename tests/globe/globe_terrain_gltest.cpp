// The globe terrain drawn on llvmpipe from space, obliquely, grazing the horizon, over both poles,
// across the antimeridian and 1 m above the ground, against a CPU reference of the same views:
// every pixel whose ray meets the ground (an ellipsoid enclosed by every drawn mesh) has terrain
// depth (no cracks, no tile culled wrongly), and every depth unprojects to a point within the
// drawn tiles' height bounds. The images go to STENCIL_GIS_TEST_OUTPUT_DIR for inspection.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "globe/globe_terrain.hpp"
#include "test_paths.hpp"

namespace gis::globe {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kSize = 256;

/// A global grid of 0.5° posts, all at or above the ellipsoid: flat seas at 0, hills and peaks
/// to 6,000 m.
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
      if ((c * 7 + r * 13) % 97 == 0) v += 3000.0;
      heights[static_cast<std::size_t>(r * w + c)] = static_cast<float>(std::clamp(v, 0.0, 6000.0));
    }
  }
  return std::make_shared<const GeoGrid>(w, h, -180.0, 90.0, 0.5, std::move(heights));
}

/// A view from `altitude` above the ground at (lon, lat), looking at `elevation` degrees above
/// the horizontal towards `azimuth` (degrees from north).
GlobeView viewFrom(const GeoGrid& grid, double lon, double lat, double altitude, double azimuth, double elevation,
                   double fov = 45.0) {
  const double ground = grid.heightAt(lon, lat);
  const glm::dvec3 eye = toEcef(lon, lat, ground + altitude);
  const double az = azimuth * kPi / 180.0, el = elevation * kPi / 180.0;
  const glm::dvec3 dir =
      enuBasis(lon, lat) * glm::dvec3(std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el));
  return GlobeView::looking(eye, eye + 1000.0 * dir, fov, kSize, kSize, ground);
}

class GlobeTerrainGl : public test::GlTest {
 protected:
  void check(const std::string& name, const GlobeView& view) {
    const std::vector<DrawnTile> tiles = terrain_.select(view);
    gfx::RenderTarget target(kSize, kSize);
    ASSERT_TRUE(target.complete());
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F), gfx::kReversedZFar, 0});
    terrain_.draw(cache_, view, tiles);
    const std::vector<float> depth = gfx::readDepth(target);
    const TerrainStats& stats = terrain_.stats();
    EXPECT_EQ(stats.tiles, tiles.size());

    // The lowest any drawn mesh reaches, by the bounds contract; the ground rays are cast at an
    // ellipsoid inside that surface (the offset surface departs from the scaled ellipsoid by
    // less than e² |h|).
    double low = 0.0, high = 0.0;
    for (const DrawnTile& t : tiles) {
      const auto [lo, hi] = terrainBounds(terrain_.heights(), t.key);
      low = std::min(low, lo);
      high = std::max(high, hi);
    }
    const double r = low - 0.01 * std::abs(low) - 1.0;
    const glm::dvec3 radii(kSemiMajor + r, kSemiMajor + r, kSemiMinor + r);
    const glm::dvec3 zeroRadii(kSemiMajor, kSemiMajor, kSemiMinor);
    const glm::dmat4 eyeViewProj = view.eyeViewProj();
    const glm::dmat4 inv = glm::inverse(eyeViewProj);
    const auto unproject = [&](double x, double y, double z) {
      const glm::dvec4 q = inv * glm::dvec4(x, y, z, 1.0);
      return glm::dvec3(q) / q.w;  // eye-relative
    };
    // The first hit of the ray with an ellipsoid of these radii beyond the near plane, if any.
    const auto hits = [&](const glm::dvec3& dir, const glm::dvec3& radii3) {
      const glm::dvec3 o = view.eye / radii3, d = dir / radii3;
      const double a = glm::dot(d, d), b = glm::dot(o, d), c = glm::dot(o, o) - 1.0;
      const double disc = b * b - a * c;
      if (disc < 0.0) return false;
      const double t = (-b - std::sqrt(disc)) / a;
      if (t <= 0.0) return false;
      const glm::dvec4 clip = eyeViewProj * glm::dvec4(t * dir, 1.0);
      return clip.z <= clip.w;
    };
    std::size_t ground = 0, covered = 0, missing = 0, limbOnly = 0, drawnPixels = 0, outOfBounds = 0;
    double seenLow = 1e300, seenHigh = -1e300;
    for (int py = 0; py < kSize; ++py) {
      for (int px = 0; px < kSize; ++px) {
        const double x = 2.0 * (px + 0.5) / kSize - 1.0, y = 1.0 - 2.0 * (py + 0.5) / kSize;
        const float d = depth[static_cast<std::size_t>(py * kSize + px)];
        const glm::dvec3 dir = glm::normalize(unproject(x, y, 0.5));
        if (hits(dir, radii)) {
          ++ground;
          if (d > 0.0F) {
            ++covered;
          } else if (++missing <= 5) {
            ADD_FAILURE() << name << ": pixel " << px << ", " << py << " sees the ground but has no terrain";
          }
        } else if (d <= 0.0F && hits(dir, zeroRadii)) {
          ++limbOnly;  // meets the bare ellipsoid where the coarse meshes' chords may pass under it
        }
        if (d > 0.0F) {
          ++drawnPixels;
          const glm::dvec3 p = unproject(x, y, d);
          const double distance = glm::length(p);
          const double h = toGeodetic(view.eye + p).h;
          const double tolerance = 1e-5 * distance + 0.5;  // float depth and vertex rounding
          const double beyond = std::max(low - h, h - high);
          seenLow = std::min(seenLow, h);
          seenHigh = std::max(seenHigh, h);
          if (beyond > tolerance && ++outOfBounds <= 5) {
            ADD_FAILURE() << name << ": pixel " << px << ", " << py << " at height " << h << " outside [" << low << ", "
                          << high << "]";
          }
        }
      }
    }
    std::printf(
        "%-12s %4zu tiles (%zu uploads, %zu resident), %7zu triangles; %5zu ground pixels, %5zu covered, "
        "%zu missing; %zu at the bare limb only; %5zu drawn, %zu out of bounds (heights [%.0f, %.0f] "
        "within [%.0f, %.0f] m)\n",
        name.c_str(), tiles.size(), stats.uploads, stats.resident, stats.triangles, ground, covered, missing, limbOnly,
        drawnPixels, outOfBounds, seenLow, seenHigh, low, high);
    EXPECT_EQ(missing, 0u) << name;
    EXPECT_EQ(outOfBounds, 0u) << name;
    EXPECT_GT(ground, 0u) << name;

    const std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
    std::filesystem::create_directories(dir);
    (void)gfx::writeImage8((dir / ("globe_terrain_" + name + ".png")).string(), kSize, kSize, 4,
                           gfx::readColorRgba8(target));
  }

  std::shared_ptr<const GeoGrid> grid_ = reliefGrid();
  GlobeTerrain terrain_{grid_};
};

TEST_F(GlobeTerrainGl, FromSpace) { check("space", viewFrom(*grid_, 20.0, 30.0, 1e7, 0.0, -90.0)); }

TEST_F(GlobeTerrainGl, Oblique500Km) { check("oblique", viewFrom(*grid_, -60.0, 10.0, 5e5, 40.0, -35.0)); }

TEST_F(GlobeTerrainGl, GrazingTheHorizon) { check("grazing", viewFrom(*grid_, 31.0, 2.0, 2000.0, 250.0, -2.0)); }

TEST_F(GlobeTerrainGl, OverTheNorthPole) { check("north_pole", viewFrom(*grid_, 30.0, 89.5, 3e5, 30.0, -60.0)); }

TEST_F(GlobeTerrainGl, OverTheSouthPole) { check("south_pole", viewFrom(*grid_, -120.0, -89.9, 8e5, 0.0, -89.0)); }

TEST_F(GlobeTerrainGl, AcrossTheAntimeridian) {
  check("antimeridian", viewFrom(*grid_, 179.8, 5.0, 2e5, 270.0, -25.0));
}

TEST_F(GlobeTerrainGl, OneMetreAboveGround) { check("one_metre", viewFrom(*grid_, 30.3, 5.2, 1.0, 120.0, -10.0)); }

TEST_F(GlobeTerrainGl, MeshesAreCachedAndEvicted) {
  TerrainOptions options;
  options.cacheTiles = 8;
  GlobeTerrain small(grid_, options);
  const GlobeView view = viewFrom(*grid_, -60.0, 10.0, 5e5, 40.0, -35.0);
  const std::vector<DrawnTile> tiles = small.select(view);
  ASSERT_GT(tiles.size(), 8u);
  gfx::RenderTarget target(64, 64);
  gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F), gfx::kReversedZFar, 0});
  small.draw(cache_, view, tiles);
  EXPECT_EQ(small.stats().uploads, tiles.size());
  EXPECT_EQ(small.stats().resident, 8u);
  // The second frame finds the last 8 tiles of the first one resident.
  small.draw(cache_, view, tiles);
  EXPECT_EQ(small.stats().uploads, tiles.size() - 8);
  // A frame of 4 tiles drawn twice uploads them once.
  const std::vector<DrawnTile> few(tiles.begin(), tiles.begin() + 4);
  small.draw(cache_, view, few);
  small.draw(cache_, view, few);
  EXPECT_EQ(small.stats().uploads, 0u);
  EXPECT_EQ(small.stats().tiles, 4u);
}

}  // namespace
}  // namespace gis::globe
