// Reading Olinda into the terrain: the DEM grid and the orthophoto resampled into the frame are
// georeferenced to a small fraction of a post.
#include <cmath>

#include <gtest/gtest.h>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/terrain_grid.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

const std::string kOlinda = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";

TEST(OlindaGeoreference, DemGridPostsSitAtPixelCentres) {
  Result<geo::Raster> dem = geo::readRaster(kOlinda + "olinda_dem_utm25s.tif");
  ASSERT_TRUE(dem.ok());
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->info);
  ASSERT_TRUE(frame.ok());
  Result<terrain::TerrainGrid> grid = terrain::gridFromRaster(*dem, *frame);
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->width, 111);
  EXPECT_NEAR(grid->step.x, 89.994067349451157, 1e-9);
  EXPECT_NEAR(grid->step.y, -89.994067349451157, 1e-9);
  for (int r = 0; r < 111; r += 10) {
    for (int c = 0; c < 111; c += 10) {
      const glm::dvec2 expected = dem->info.pixelCentre(c, r);
      const glm::dvec3 projected = frame->frameToProjected(glm::dvec3(grid->postPosition(c, r), 0.0));
      EXPECT_NEAR(projected.x, expected.x, 1e-6);  // metres: exact up to rounding
      EXPECT_NEAR(projected.y, expected.y, 1e-6);
      EXPECT_EQ(grid->at(c, r), dem->at(c, r));
    }
  }
  // Full-resolution heights at post positions are the samples.
  auto tree = std::make_shared<const terrain::TerrainQuadtree>(std::make_shared<terrain::TerrainGrid>(*grid));
  terrain::QuadtreeHeightBounds bounds(tree);
  EXPECT_NEAR(bounds.fullResolutionHeightAt(grid->postPosition(37, 58)), dem->at(37, 58), 1e-4);
}

TEST(OlindaGeoreference, ImageryResampledIntoTheFrameMatchesTheSourceAtTheSameGroundPoint) {
  Result<geo::Raster> dem = geo::readRaster(kOlinda + "olinda_dem_utm25s.tif");
  ASSERT_TRUE(dem.ok());
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->info);
  ASSERT_TRUE(frame.ok());
  Result<geo::Raster> source = geo::readRaster(kOlinda + "L7_ETMs.tif", {3, 2, 1});
  Result<geo::Raster> warped = geo::readRasterInCrs(kOlinda + "L7_ETMs.tif", {3, 2, 1}, frame->crsWkt());
  ASSERT_TRUE(source.ok() && warped.ok());
  Result<geo::CrsTransform> toSource = frame->transformTo(source->info.crsWkt);
  ASSERT_TRUE(toSource.ok());
  // Bilinear sample of the source at continuous pixel coordinates (pixel centres at +0.5).
  auto sample = [&](const glm::dvec2& px, int channel) {
    const double x = px.x - 0.5, y = px.y - 0.5;
    const int c = static_cast<int>(std::floor(x)), r = static_cast<int>(std::floor(y));
    const double fx = x - c, fy = y - r;
    auto at = [&](int cc, int rr) { return static_cast<double>(source->at(cc, rr, channel)); };
    return (1 - fy) * ((1 - fx) * at(c, r) + fx * at(c + 1, r)) +
           fy * ((1 - fx) * at(c, r + 1) + fx * at(c + 1, r + 1));
  };
  // Each resampled pixel holds the source's colour at that pixel's ground point (independent
  // chain: frame CRS → source CRS → source pixel). A georeference off by a tenth of a pixel
  // would change values by several digital numbers where the image has detail.
  double worst = 0.0;
  int checked = 0;
  for (int r = 20; r < warped->info.height - 20; r += 7) {
    for (int c = 20; c < warped->info.width - 20; c += 7) {
      const glm::dvec2 ground = warped->info.pixelCentre(c, r);
      const glm::dvec2 px = *source->info.geoTransform.crsToPixel(*toSource->transform(ground));
      for (int ch = 0; ch < 3; ++ch) worst = std::max(worst, std::abs(warped->at(c, r, ch) - sample(px, ch)));
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LE(worst, 1.0) << "digital numbers (8-bit rounding of the bilinear resampling)";
}

}  // namespace
}  // namespace gis::test
