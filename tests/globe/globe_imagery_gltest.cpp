// Imagery in a projected CRS on the globe's terrain (docs/globe.md, "Imagery"): a GeoTIFF in UTM
// 25S whose every 1 km square of the UTM grid has one of four colours, draped on flat ground near
// Recife and drawn top-down and obliquely at 256². Every ground pixel is taken back to the ground
// (its depth, unprojected), to longitude/latitude and to UTM by PROJ; away from the squares' edges
// (a margin for the imagery's resampling, the tile textures' texels and the pixel's footprint) the
// colour drawn is the square's, within 3/255 a channel (imagery is drawn unshaded, as in the
// projected frame). Ground beyond the imagery keeps the height tint: none of those colours.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "globe/ellipsoid.hpp"
#include "globe/globe_imagery.hpp"
#include "globe/globe_terrain.hpp"
#include "test_paths.hpp"
#include "vector_overlay/globe_overlay.hpp"

namespace gis::globe {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr int kSize = 256;
constexpr double kCell = 30.0;      ///< imagery cell, metres
constexpr int kImageryCells = 400;  ///< 12 km a side
const std::array<std::array<std::uint8_t, 3>, 4> kColors{{{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 0}}};

struct Transform {
  Transform(const char* from, const char* to) {
    a.SetFromUserInput(from);
    b.SetFromUserInput(to);
    a.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    b.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    t = OGRCreateCoordinateTransformation(&a, &b);
  }
  ~Transform() { OGRCoordinateTransformation::DestroyCT(t); }
  Transform(const Transform&) = delete;
  Transform& operator=(const Transform&) = delete;
  glm::dvec2 operator()(double x, double y) const {
    t->Transform(1, &x, &y);
    return {x, y};
  }
  OGRSpatialReference a, b;
  OGRCoordinateTransformation* t = nullptr;
};

/// The colour of the UTM 1 km square holding (e, n).
int squareColor(double e, double n) {
  const auto i = static_cast<long>(std::floor(e / 1000.0)), j = static_cast<long>(std::floor(n / 1000.0));
  return static_cast<int>(((i + 2 * j) % 4 + 4) % 4);
}

class GlobeImageryGl : public test::GlTest {
 protected:
  static void SetUpTestSuite() {
    test::GlTest::SetUpTestSuite();
    GDALAllRegister();
    const Transform toUtm("EPSG:4326", "EPSG:32725");
    const glm::dvec2 centre = toUtm(-35.0, -8.0);
    west_ = std::floor(centre.x / 1000.0) * 1000.0 - 6000.0;
    north_ = std::floor(centre.y / 1000.0) * 1000.0 + 6000.0;
    const fs::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
    fs::create_directories(dir);
    // One file a process: ctest runs this suite's tests in parallel, each writing the image.
    path_ = (dir / ("utm_squares_" + std::to_string(::getpid()) + ".tif")).string();
    GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(path_.c_str(), kImageryCells,
                                                                               kImageryCells, 3, GDT_Byte, nullptr);
    double gt[6] = {west_, kCell, 0.0, north_, 0.0, -kCell};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.SetFromUserInput("EPSG:32725");
    ds->SetSpatialRef(&srs);
    for (int b = 0; b < 3; ++b) {
      std::vector<std::uint8_t> band(static_cast<std::size_t>(kImageryCells * kImageryCells));
      for (int r = 0; r < kImageryCells; ++r)
        for (int c = 0; c < kImageryCells; ++c)
          band[static_cast<std::size_t>(r * kImageryCells + c)] =
              kColors[static_cast<std::size_t>(squareColor(west_ + (c + 0.5) * kCell, north_ - (r + 0.5) * kCell))]
                     [static_cast<std::size_t>(b)];
      ASSERT_EQ(ds->GetRasterBand(b + 1)->RasterIO(GF_Write, 0, 0, kImageryCells, kImageryCells, band.data(),
                                                   kImageryCells, kImageryCells, GDT_Byte, 0, 0, nullptr),
                CE_None);
    }
    GDALClose(GDALDataset::ToHandle(ds));
  }

  /// Draws until every tile's texture is built, then checks each ground pixel.
  void check(const std::string& name, double lon, double lat, double altitude, double azimuth, double elevation,
             std::size_t minChecked) {
    const double ground = grid_->heightAt(lon, lat);
    const glm::dvec3 eye = toEcef(lon, lat, ground + altitude);
    const double az = azimuth * kPi / 180.0, el = elevation * kPi / 180.0;
    const glm::dvec3 dir =
        enuBasis(lon, lat) * glm::dvec3(std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el));
    const GlobeView view = GlobeView::looking(eye, eye + 1000.0 * dir, 45.0, kSize, kSize, ground);
    gfx::RenderTarget target(kSize, kSize);
    ASSERT_TRUE(target.complete());
    int frames = 0;
    std::size_t built = 0;
    do {
      const std::vector<DrawnTile> tiles = terrain_->select(view);
      gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F), gfx::kReversedZFar, 0});
      terrain_->draw(cache_, view, tiles);
      built += terrain_->stats().imageryBuilt;
      ++frames;
    } while (terrain_->stats().imageryPending > 0 && frames < 200);
    const TerrainStats& stats = terrain_->stats();
    EXPECT_EQ(stats.imageryPending, 0u);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint8_t> color = gfx::readColorRgba8(target);

    const Transform toUtm("EPSG:4326", "EPSG:32725");
    const auto groundAt = [&](int col, int row, glm::dvec3& p) {
      if (col >= kSize || row >= kSize) return false;
      const float d = depth[static_cast<std::size_t>(row * kSize + col)];
      const std::optional<glm::dvec3> seen = overlay::unprojectDepth(depthImageOf(view, {}), col, row, d);
      if (seen) p = *seen;
      return seen.has_value();
    };
    std::size_t checked = 0, wrong = 0, outside = 0, outsideWrong = 0;
    int worst = 0;
    for (int row = 0; row < kSize; ++row) {
      for (int col = 0; col < kSize; ++col) {
        glm::dvec3 p, px, py;
        if (!groundAt(col, row, p)) continue;
        // The pixel's footprint on the ground.
        double footprint = 0.0;
        if (groundAt(col + 1, row, px)) footprint = std::max(footprint, glm::length(px - p));
        if (groundAt(col, row + 1, py)) footprint = std::max(footprint, glm::length(py - p));
        if (footprint == 0.0) continue;
        const Geodetic g = toGeodetic(p);
        const glm::dvec2 utm = toUtm(g.lon, g.lat);
        // Imagery resampled twice (to lon/lat, then to the tile's texels: a cell each), a tile
        // texel (≤ 26 m here), the pixel's footprint twice: beyond that from an edge, one colour.
        const double margin = 2.0 * kCell + 30.0 + 2.0 * footprint;
        const std::uint8_t* c = color.data() + static_cast<std::size_t>(row * kSize + col) * 4;
        const double ex = std::min(utm.x - west_, west_ + kImageryCells * kCell - utm.x);
        const double ny = std::min(north_ - utm.y, utm.y - (north_ - kImageryCells * kCell));
        if (ex < -margin || ny < -margin) {  // beyond the imagery: the height tint, no square's colour
          ++outside;
          for (const auto& k : kColors) {
            int diff = 0;
            for (int ch = 0; ch < 3; ++ch)
              diff = std::max(diff, std::abs(int{c[ch]} - int{k[static_cast<std::size_t>(ch)]}));
            if (diff <= 3) ++outsideWrong;
          }
          continue;
        }
        if (ex < margin || ny < margin) continue;
        const double fe = utm.x / 1000.0 - std::floor(utm.x / 1000.0), fn = utm.y / 1000.0 - std::floor(utm.y / 1000.0);
        if (std::min({fe, 1.0 - fe, fn, 1.0 - fn}) * 1000.0 < margin) continue;
        const auto& want = kColors[static_cast<std::size_t>(squareColor(utm.x, utm.y))];
        int diff = 0;
        for (int ch = 0; ch < 3; ++ch)
          diff = std::max(diff, std::abs(int{c[ch]} - int{want[static_cast<std::size_t>(ch)]}));
        worst = std::max(worst, diff);
        ++checked;
        if (diff > 3) ++wrong;
      }
    }
    std::printf(
        "%-8s %3zu tiles (%zu with imagery), %zu textures built in %d frames, %.1f MB: %zu pixels checked, "
        "%zu wrong (worst channel difference %d); %zu beyond the imagery, %zu of them in a square's colour\n",
        name.c_str(), stats.tiles, stats.imageryTiles, built, frames,
        static_cast<double>(stats.imageryBytes) / (1024.0 * 1024.0), checked, wrong, worst, outside, outsideWrong);
    EXPECT_GE(checked, minChecked) << name;
    EXPECT_EQ(wrong, 0u) << name;
    EXPECT_EQ(outsideWrong, 0u) << name;
    const fs::path out(STENCIL_GIS_TEST_OUTPUT_DIR);
    (void)gfx::writeImage8((out / ("globe_imagery_" + name + ".png")).string(), kSize, kSize, 4, color);
  }

  static std::shared_ptr<GlobeImagery> openImagery() {
    ImageryOptions options;
    options.lowPercentile = 0.0;  // the squares' colours as they are
    options.highPercentile = 100.0;
    Result<std::shared_ptr<GlobeImagery>> imagery = GlobeImagery::open(path_, {1, 2, 3}, options);
    EXPECT_TRUE(imagery.ok());
    return imagery.ok() ? *imagery : nullptr;
  }

  static inline double west_ = 0.0, north_ = 0.0;
  static inline std::string path_;
  std::shared_ptr<const GeoGrid> grid_ =
      std::make_shared<const GeoGrid>(2, 2, -36.0, -7.0, 2.0, std::vector<float>(4, 0.0F));
  std::unique_ptr<GlobeTerrain> terrain_ = std::make_unique<GlobeTerrain>(grid_);
};

TEST_F(GlobeImageryGl, TopDown) {
  terrain_->setImagery(openImagery());
  check("topdown", -35.0, -8.0, 12000.0, 0.0, -90.0, 20000);
}

TEST_F(GlobeImageryGl, Oblique) {
  terrain_->setImagery(openImagery());
  check("oblique", -35.03, -8.06, 3000.0, 30.0, -20.0, 5000);
}

TEST_F(GlobeImageryGl, SmallTextureBudgetStillDrawsTheFrame) {
  TerrainOptions options;
  options.imageryGpuBudgetMb = 0.5;  // less than one frame's textures: nothing of this frame is dropped
  options.imageryTilesPerFrame = 2;
  terrain_ = std::make_unique<GlobeTerrain>(grid_, options);
  terrain_->setImagery(openImagery());
  check("budget", -35.0, -8.0, 12000.0, 0.0, -90.0, 20000);
}

}  // namespace
}  // namespace gis::globe
