#pragma once
// A test terrain twice: written as a GeoTIFF (UTM 25S, nodata −9999), then loaded in memory the
// way the scene loader does and pre-built into a tile pyramid that a pager pages. Tests compare
// the two. Needs GDAL (link GDAL::GDAL).
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <unistd.h>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "terrain/quadtree.hpp"
#include "terrain/tile_pager.hpp"
#include "terrain/tile_pyramid.hpp"

namespace gis::test {

/// Writes the grid's heights as a GeoTIFF in UTM 25S with its lower-left corner near
/// (290 km, 9120 km) (Olinda's neighbourhood); NaN posts become the nodata value −9999.
inline void writeGridGeoTiff(const terrain::TerrainGrid& grid, const std::string& path) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), grid.width, grid.height, 1, GDT_Float32, nullptr);
  ASSERT_NE(ds, nullptr);
  const double corner[2] = {290000.0, 9120000.0};
  double gt[6] = {corner[0] - 0.5 * grid.step.x, grid.step.x, 0.0, corner[1] - 0.5 * grid.step.y, 0.0, grid.step.y};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.importFromEPSG(32725);
  ds->SetSpatialRef(&srs);
  std::vector<float> heights = grid.heights;
  for (float& h : heights) h = std::isnan(h) ? -9999.0F : h;
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(-9999.0);
  ASSERT_EQ(band->RasterIO(GF_Write, 0, 0, grid.width, grid.height, heights.data(), grid.width, grid.height,
                           GDT_Float32, 0, 0, nullptr),
            CE_None);
  GDALClose(GDALDataset::ToHandle(ds));
}

/// Removes a directory when the last owner goes.
struct ScratchDirectory {
  std::string path;
  ~ScratchDirectory() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

struct PagedTerrain {
  std::shared_ptr<ScratchDirectory> scratch;  ///< declared first: removed after the file closes
  std::string demPath;
  std::string pyramidPath;
  terrain::PyramidSource source;
  std::optional<geo::SceneFrame> frame;  ///< the pyramid was built in
  std::shared_ptr<const terrain::TilePyramidFile> file;
  std::shared_ptr<terrain::TerrainQuadtree> memory;  ///< the DEM in memory
  std::shared_ptr<terrain::TerrainQuadtree> paged;   ///< the same DEM paged from the pyramid
};

/// Writes `grid` into a subdirectory of `parent` of this process's own (CTest runs the cases of
/// one test program in parallel processes), builds its pyramid and opens both trees. A
/// non-fatal test failure leaves the trees null.
inline PagedTerrain makePagedTerrain(const terrain::TerrainGrid& grid, const std::string& parent, int chunkCells,
                                     int pinnedTilesPerSide, std::size_t budgetBytes) {
  PagedTerrain t;
  const std::string dir = parent + "/" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  t.scratch = std::make_shared<ScratchDirectory>();
  t.scratch->path = dir;
  t.demPath = dir + "/dem.tif";
  t.pyramidPath = dir + "/dem.sgpyr";
  std::filesystem::remove(t.pyramidPath);
  writeGridGeoTiff(grid, t.demPath);
  Result<geo::Raster> dem = geo::readRaster(t.demPath);
  EXPECT_TRUE(dem.ok());
  if (!dem) return t;
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->info);
  EXPECT_TRUE(frame.ok());
  if (!frame) return t;
  Result<terrain::TerrainGrid> loaded = terrain::gridFromRaster(std::move(*dem), *frame);
  EXPECT_TRUE(loaded.ok());
  if (!loaded) return t;
  t.memory = std::make_shared<terrain::TerrainQuadtree>(
      std::make_shared<const terrain::TerrainGrid>(std::move(*loaded)), chunkCells);
  Result<terrain::PyramidSource> source = terrain::PyramidSource::of(t.demPath, 1, chunkCells);
  EXPECT_TRUE(source.ok());
  if (!source) return t;
  source->pinnedTilesPerSide = pinnedTilesPerSide;
  t.source = *source;
  t.frame = *frame;
  Result<terrain::PyramidBuildStats> built = terrain::buildTilePyramid(t.source, *frame, t.pyramidPath);
  EXPECT_TRUE(built.ok()) << (built.diagnostics.empty() ? "" : built.diagnostics.items()[0].toString());
  if (!built) return t;
  Result<std::shared_ptr<const terrain::TilePyramidFile>> file =
      terrain::TilePyramidFile::open(t.pyramidPath, t.source);
  EXPECT_TRUE(file.ok()) << (file.diagnostics.empty() ? "" : file.diagnostics.items()[0].toString());
  if (!file) return t;
  t.file = *file;
  t.paged = std::make_shared<terrain::TerrainQuadtree>(std::make_shared<terrain::TilePager>(t.file, budgetBytes));
  return t;
}

}  // namespace gis::test
