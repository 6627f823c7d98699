// DEMs a GIS user may hand the scene loader by mistake: an undeclared nodata value (−3.4e38) or
// infinite samples become holes with a Warning naming the file and the count, in memory and
// paged (said again when the cached pyramid is reused); a DEM with no height at all, a
// geotransform with NaN and one spanning 1e16 m fail the scene with an Error naming the file.
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include "dem_files.hpp"
#include "scene/globe_scene.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "terrain/terrain_grid.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

constexpr int kSize = 33;

std::string outputDir() {
  const std::string dir = std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  return dir;
}

/// A kSize² Float32 GeoTIFF in UTM 25S near Olinda: 10 m posts, heights from `height(c, r)`.
template <typename Height>
std::string writeDem(const std::string& name, Height height, std::optional<double> nodata = std::nullopt,
                     std::array<double, 6> gt = {290000.0, 10.0, 0.0, 9120000.0, 0.0, -10.0}) {
  GDALAllRegister();
  const std::string path = outputDir() + "/" + name;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  EXPECT_NE(driver, nullptr);
  GDALDataset* ds = driver->Create(path.c_str(), kSize, kSize, 1, GDT_Float32, nullptr);
  EXPECT_NE(ds, nullptr);
  if (ds == nullptr) return path;
  ds->SetGeoTransform(gt.data());
  OGRSpatialReference srs;
  srs.importFromEPSG(32725);
  ds->SetSpatialRef(&srs);
  std::vector<float> heights(static_cast<std::size_t>(kSize * kSize));
  for (int r = 0; r < kSize; ++r) {
    for (int c = 0; c < kSize; ++c) heights[static_cast<std::size_t>(r * kSize + c)] = height(c, r);
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  if (nodata) band->SetNoDataValue(*nodata);
  EXPECT_EQ(band->RasterIO(GF_Write, 0, 0, kSize, kSize, heights.data(), kSize, kSize, GDT_Float32, 0, 0, nullptr),
            CE_None);
  GDALClose(GDALDataset::ToHandle(ds));
  return path;
}

scene::SceneDescription sceneOf(const std::string& dem) {
  scene::SceneDescription d;
  d.path = outputDir() + "/scene.json";
  d.dem = dem;
  d.chunkCells = 16;
  d.cacheDir = outputDir() + "/cache";
  return d;
}

const Diagnostic* find(const Diagnostics& d, Severity severity, const std::string& text) {
  for (const Diagnostic& item : d.items()) {
    if (item.severity == severity && item.message.find(text) != std::string::npos) return &item;
  }
  return nullptr;
}

/// Loading the scene of `dem`, in memory and paged, fails with an Error naming the file and
/// saying `message`.
void expectFailureNamingTheFile(const std::string& dem, const std::string& message) {
  for (const scene::TerrainPaging paging : {scene::TerrainPaging::Never, scene::TerrainPaging::Always}) {
    SCOPED_TRACE(paging == scene::TerrainPaging::Never ? "in memory" : "paged");
    scene::LoadOptions options;
    options.paging = paging;
    options.progress = [](double) {};
    Result<scene::LoadedScene> scene = scene::loadScene(sceneOf(dem), options);
    EXPECT_FALSE(scene.ok());
    const Diagnostic* error = find(scene.diagnostics, Severity::Error, message);
    ASSERT_NE(error, nullptr) << (scene.diagnostics.empty() ? "" : scene.diagnostics.items().front().toString());
    EXPECT_EQ(error->file, dem);
  }
}

TEST(SceneLoader, UndeclaredNodataAndInfiniteHeightsBecomeHolesWithAWarning) {
  // Posts on the diagonal hold −3.4e38 (a float DEM's usual nodata, here undeclared); post
  // (5, 0) is +inf; post (6, 0) is 1e8 m; post (7, 0) is exactly 1e7 m, which is kept.
  const std::string dem = writeDem("undeclared_nodata.tif", [](int c, int r) {
    if (c == r) return -std::numeric_limits<float>::max();
    if (r == 0 && c == 5) return std::numeric_limits<float>::infinity();
    if (r == 0 && c == 6) return 1e8F;
    if (r == 0 && c == 7) return terrain::kMaxPostHeight;
    return 10.0F + 0.5F * static_cast<float>(c);
  });
  const std::uint64_t expected = kSize + 2;
  scene::SceneDescription description = sceneOf(dem);
  std::filesystem::remove_all(description.cacheDir);
  for (const scene::TerrainPaging paging :
       {scene::TerrainPaging::Never, scene::TerrainPaging::Always, scene::TerrainPaging::Always}) {
    scene::LoadOptions options;
    options.paging = paging;
    options.progress = [](double) {};
    Result<scene::LoadedScene> scene = scene::loadScene(description, options);
    ASSERT_TRUE(scene.ok());
    SCOPED_TRACE(scene->paged() ? (scene->pyramidBuild ? "paged, building" : "paged, reusing") : "in memory");
    const Diagnostic* warning = find(scene.diagnostics, Severity::Warning, "beyond ±10,000 km");
    ASSERT_NE(warning, nullptr);
    EXPECT_EQ(warning->file, dem);
    EXPECT_EQ(warning->message.rfind(std::to_string(expected) + " posts have", 0), 0u) << warning->message;
    EXPECT_EQ(scene->nodataPosts, expected);
    EXPECT_FALSE(scene.diagnostics.hasErrors());
    // The plausible posts stay: the highest is the one at exactly 1e7 m.
    glm::dvec3 lo, hi;
    scene::terrainBox(*scene, 1.0, lo, hi);
    EXPECT_EQ(hi.z, static_cast<double>(terrain::kMaxPostHeight));
    EXPECT_GE(lo.z, 10.0);
  }
}

TEST(SceneLoader, ADemWithoutAnyHeightFailsNamingTheFile) {
  const std::string dem = writeDem(
      "all_nodata.tif", [](int, int) { return -9999.0F; }, -9999.0);
  expectFailureNamingTheFile(dem, "posts is nodata: there is no terrain to draw");
}

TEST(SceneLoader, ABrokenGeotransformFailsNamingTheFile) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    const char* file;
    std::array<double, 6> gt;
    const char* message;
  };
  const Case cases[] = {
      {"nan_origin.tif", {nan, 10.0, 0.0, 9120000.0, 0.0, -10.0}, "geotransform has a NaN or infinite value"},
      {"huge_posts.tif", {0.0, 1e14, 0.0, 1e16, 0.0, -1e14}, "more than 1e8 (100,000 km)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string dem = writeDem(
        c.file, [](int, int) { return 5.0F; }, std::nullopt, c.gt);
    expectFailureNamingTheFile(dem, c.message);
  }
}

TEST(SceneLoader, AFolderOfGeographicTilesLoadsTheSameInMemoryAndPagedAndIsRebuiltWhenATileIsAdded) {
  const std::string dir = outputDir() + "/lonlat-tiles";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const double step = 1.0 / 1200.0;
  auto tile = [&](const std::string& name, double lon0) {
    DemFileOptions o;
    o.width = o.height = 81;
    o.geoTransform = {lon0 - 0.5 * step, step, 0.0, -7.9 + 0.5 * step, 0.0, -step};
    o.crs = "EPSG:4326";
    writeDemFile(dir + "/" + name, o, [&](int c, int r) { return 20.0 + 3.0 * c + std::sin(0.3 * r) * 10.0; });
  };
  tile("a.tif", -35.0);
  tile("b.tif", -35.0 + 80 * step);
  scene::SceneDescription description = sceneOf(dir);
  description.demPaths = {dir};
  std::filesystem::remove_all(description.cacheDir);
  scene::LoadOptions memory, paged;
  memory.paging = scene::TerrainPaging::Never;
  paged.paging = scene::TerrainPaging::Always;
  paged.progress = [](double) {};
  Result<scene::LoadedScene> m = scene::loadScene(description, memory);
  Result<scene::LoadedScene> p = scene::loadScene(description, paged);
  ASSERT_TRUE(m.ok() && p.ok());
  EXPECT_EQ(m->frame.epsg(), 32725);
  EXPECT_NE(find(m.diagnostics, Severity::Info, "resampled"), nullptr);
  ASSERT_TRUE(p->paged());
  EXPECT_TRUE(p->pyramidBuild.has_value());
  const terrain::TerrainGrid& g = m->quadtree->grid();
  const terrain::TerrainGrid& pg = p->quadtree->grid();
  ASSERT_EQ(g.width, pg.width);
  ASSERT_EQ(g.height, pg.height);
  EXPECT_EQ(g.origin, pg.origin);
  EXPECT_EQ(p->nodataPosts, m->nodataPosts);
  // Paged heights at full resolution equal the in-memory ones.
  std::size_t compared = 0;
  for (int r = 1; r < g.height; r += 7) {
    for (int c = 1; c < g.width; c += 5) {
      const glm::dvec2 xy = g.postPosition(c, r);
      const double a = m->bounds->fullResolutionHeightAt(xy), b = p->bounds->fullResolutionHeightAt(xy);
      if (std::isnan(a)) {
        EXPECT_TRUE(std::isnan(b));
        continue;
      }
      EXPECT_DOUBLE_EQ(a, b);
      ++compared;
    }
  }
  EXPECT_GT(compared, 100u);
  Result<scene::LoadedScene> again = scene::loadScene(description, paged);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->pyramidBuild.has_value()) << "reused";
  tile("c.tif", -35.0 + 160 * step);
  Result<scene::LoadedScene> grown = scene::loadScene(description, paged);
  ASSERT_TRUE(grown.ok());
  EXPECT_TRUE(grown->pyramidBuild.has_value()) << "a tile added: rebuilt";
  EXPECT_GT(grown->quadtree->grid().width, g.width);
}

/// A scene of `dem` with one polygon layer read from `source`, its cache in a fresh folder.
scene::SceneDescription sceneWithCachedLayer(const std::string& dem, const std::string& source, const std::string& name,
                                             const std::string& cacheFolder) {
  scene::SceneDescription description = sceneOf(dem);
  description.cacheDir = outputDir() + "/" + cacheFolder;
  std::filesystem::remove_all(description.cacheDir);
  scene::LayerDescription layer;
  layer.name = name;
  layer.kind = overlay::LayerKind::Polygon;
  layer.source = source;
  description.layers.push_back(layer);
  return description;
}

TEST(SceneLoader, ALayerIsReadFromTheCacheUntilItsFileChanges) {
  // A lon/lat GeoJSON (reprojected and densified when read) with a polygon, a line, attributes
  // of every kind and a broken feature (a Warning or Error to repeat from the cache).
  const std::string dem = writeDem("cached_layer_dem.tif", [](int c, int r) { return static_cast<float>(c + r); });
  const std::string source = outputDir() + "/cached_layer.geojson";
  const auto write = [&](double shift) {
    std::ofstream(source) << R"({"type": "FeatureCollection", "features": [
      {"type": "Feature", "properties": {"name": "a", "n": 3, "x": 2.5, "none": null},
       "geometry": {"type": "Polygon", "coordinates": [[[-34.862, -8.050], [-34.858, -8.050], [-34.858, -8.046],
                                                        [-34.862, -8.046], [-34.862, -8.050]]]}},
      {"type": "Feature", "properties": {"name": "b"},
       "geometry": {"type": "LineString", "coordinates": [[-34.861, -8.049], [)"
                          << -34.859 + shift << R"(, -8.047]]}},
      {"type": "Feature", "properties": {"name": "broken"},
       "geometry": {"type": "Polygon", "coordinates": [[[-34.86, -8.05], [-34.86, -8.05]]]}}]})";
  };
  write(0.0);
  scene::SceneDescription description = sceneWithCachedLayer(dem, source, "things", "cached_layer_cache");
  scene::LoadOptions options;
  options.progress = [](double) {};
  const auto load = [&] {
    Result<scene::LoadedScene> s = scene::loadScene(description, options);
    EXPECT_TRUE(s.ok());
    return s;
  };
  const Result<scene::LoadedScene> first = load();
  ASSERT_TRUE(first.ok() && first->layers.size() == 1u);
  EXPECT_EQ(first->layersFromCache, 0u);
  EXPECT_EQ(first->layers[0].features.size(), 2u);
  ASSERT_NE(find(first.diagnostics, Severity::Error, ""), nullptr) << "the broken feature is named";

  // Again: from the cache, the same features (geometry and attributes) and the same messages.
  const Result<scene::LoadedScene> second = load();
  ASSERT_TRUE(second.ok() && second->layers.size() == 1u);
  EXPECT_EQ(second->layersFromCache, 1u);
  EXPECT_EQ(second->layers[0].data.name, first->layers[0].data.name);
  EXPECT_EQ(second->layers[0].data.sourceCrsWkt, first->layers[0].data.sourceCrsWkt);
  EXPECT_EQ(second->layers[0].data.kind, first->layers[0].data.kind);
  const std::vector<geo::Feature>& a = first->layers[0].features.all();
  const std::vector<geo::Feature>& b = second->layers[0].features.all();
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b[i].fid, a[i].fid);
    EXPECT_EQ(b[i].attributes, a[i].attributes);
    ASSERT_EQ(b[i].polygons.size(), a[i].polygons.size());
    for (std::size_t k = 0; k < a[i].polygons.size(); ++k) {
      EXPECT_EQ(b[i].polygons[k].outer, a[i].polygons[k].outer);
      EXPECT_EQ(b[i].polygons[k].holes, a[i].polygons[k].holes);
    }
    EXPECT_EQ(b[i].lines, a[i].lines);
  }
  ASSERT_EQ(second.diagnostics.items().size(), first.diagnostics.items().size());
  for (std::size_t i = 0; i < first.diagnostics.items().size(); ++i)
    EXPECT_EQ(second.diagnostics.items()[i].toString(), first.diagnostics.items()[i].toString());

  // The file changes (its size and time): read again, and the change shows.
  write(0.001);
  std::filesystem::last_write_time(source, std::filesystem::last_write_time(source) + std::chrono::seconds(2));
  const Result<scene::LoadedScene> changed = load();
  ASSERT_TRUE(changed.ok() && changed->layers.size() == 1u);
  EXPECT_EQ(changed->layersFromCache, 0u);
  EXPECT_NE(changed->layers[0].features.all().at(1).lines, a[1].lines);

  // A damaged cache file is not used: read again from the source (and written again).
  std::size_t damaged = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(description.cacheDir)) {
    if (entry.path().extension() != ".layer") continue;
    std::filesystem::resize_file(entry.path(), std::filesystem::file_size(entry.path()) / 2);
    ++damaged;
  }
  ASSERT_GT(damaged, 0u);
  const Result<scene::LoadedScene> repaired = load();
  ASSERT_TRUE(repaired.ok());
  EXPECT_EQ(repaired->layersFromCache, 0u);
  // Said once per damaged file, naming it and the source it is rebuilt from; a warning, not an error.
  std::size_t said = 0;
  for (const Diagnostic& d : repaired.diagnostics.items()) {
    if (d.message.find("cache file damaged") == std::string::npos) continue;
    ++said;
    EXPECT_EQ(d.severity, Severity::Warning);
    EXPECT_EQ(std::filesystem::path(d.file).extension(), ".layer");
    EXPECT_NE(d.message.find("rebuilt from " + source), std::string::npos) << d.toString();
  }
  EXPECT_EQ(said, 1u) << "the layer's file (the other is the source's older version, never read)";
  EXPECT_EQ(repaired->layers[0].features.all().at(1).lines, changed->layers[0].features.all().at(1).lines);
  EXPECT_EQ(load()->layersFromCache, 1u);
  // Without the cache (LoadOptions::layerCache), always from the source.
  options.layerCache = false;
  EXPECT_EQ(load()->layersFromCache, 0u);
}

TEST(SceneLoader, OnTheGlobeLayersAreReadByTheSameLoaderAndCache) {
  // One loader for both frames (issue 41): a globe scene reads its layers through loadLayers,
  // in longitude and latitude, through the layer cache; the second load keeps the features on
  // disk and builds the same globe layers (fill and outline), attributes and all.
  const std::string dem = writeDem("globe_cached_dem.tif", [](int c, int r) { return static_cast<float>(c + r); });
  const std::string source = outputDir() + "/globe_cached.geojson";
  std::ofstream(source) << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"name": "a", "n": 3},
     "geometry": {"type": "Polygon", "coordinates": [[[-34.862, -8.050], [-34.858, -8.050], [-34.858, -8.046],
                                                      [-34.862, -8.046], [-34.862, -8.050]]]}},
    {"type": "Feature", "properties": {"name": "b"},
     "geometry": {"type": "Polygon", "coordinates": [[[-34.857, -8.050], [-34.855, -8.050], [-34.855, -8.048],
                                                      [-34.857, -8.050]]]}}]})";
  scene::SceneDescription description = sceneWithCachedLayer(dem, source, "things", "globe_cached_cache");
  description.frame = scene::FrameKind::Globe;
  description.layers[0].style.outlineWidthMetres = 3.0F;
  const Result<scene::LoadedGlobeScene> first = scene::loadGlobeScene(description);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->layersFromCache, 0u);
  ASSERT_EQ(first->sourceLayers.size(), 1u);
  ASSERT_EQ(first->layers.size(), 2u) << "the fill and its outline";
  const std::vector<geo::Feature>& read = first->sourceLayers[0].features.all();
  ASSERT_EQ(read.size(), 2u);
  // In longitude and latitude, as given (the globe densifies along geodesics itself).
  ASSERT_EQ(read[0].polygons.size(), 1u);
  EXPECT_NEAR(read[0].polygons[0].outer.front().x, -34.862, 1e-12);
  EXPECT_NEAR(read[0].polygons[0].outer.front().y, -8.050, 1e-12);

  const Result<scene::LoadedGlobeScene> second = scene::loadGlobeScene(description);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second->layersFromCache, 1u);
  EXPECT_TRUE(second->sourceLayers[0].features.onDisk()) << "read one at a time, never all at once";
  ASSERT_EQ(second->layers.size(), first->layers.size());
  // A tile is built from the features that reach it, read for it: the fill's areas are not all
  // prepared (only their boxes are kept), nor the outline's lines, and the features stay on disk.
  const globe::GlobeLayer& fill = second->layers[0];
  ASSERT_EQ(fill.areaCount(), 2u);
  constexpr int kLevel = 12;
  const double size = globe::TileKey{kLevel, 0, 0}.size();
  const globe::TileKey key{kLevel, static_cast<int>(std::floor((-34.86 + 180.0) / size)),
                           static_cast<int>(std::floor((-8.05 + 90.0) / size))};
  const overlay::LayerGeometry pieces = globe::buildTilePieces(fill, key, *second->heights, 0);
  EXPECT_GT(pieces.indexCount(), 0u);
  EXPECT_FALSE(fill.allAreasPrepared()) << "a tile prepares the areas that reach it, not the layer's";
  // The same for the outline's lines.
  const globe::GlobeLayer& outline = second->layers[1];
  ASSERT_EQ(outline.lineCount(), 2u);
  EXPECT_GT(globe::buildTilePieces(outline, key, *second->heights, 0).indexCount(), 0u);
  EXPECT_FALSE(outline.allLinesPrepared()) << "a tile prepares the lines that reach it, not the layer's";
  EXPECT_TRUE(second->sourceLayers[0].features.onDisk());
  for (std::size_t l = 0; l < first->layers.size(); ++l) {
    EXPECT_EQ(second->layers[l].fingerprint(), first->layers[l].fingerprint()) << l;
    EXPECT_EQ(second->layers[l].polygons().size(), first->layers[l].polygons().size()) << l;
    EXPECT_EQ(second->layers[l].lines().size(), first->layers[l].lines().size()) << l;
    ASSERT_EQ(second->layerFeatures[l].size(), 2u);
    EXPECT_EQ(second->layerFeatures[l].get(1)->attributes, read[1].attributes) << "identify's attributes";
  }
  EXPECT_TRUE(second->sourceLayers[0].features.onDisk()) << "the globe layers were built reading one feature at a time";
}

TEST(SceneLoader, CachedFeaturesStayOnDiskAndReadAsTheSourceGivesThem) {
  // Two lon/lat polygons (one with a hole) and a two-part line, read through OGR into memory
  // and through the layer cache, which keeps them on disk and reads one when asked.
  const std::string dem = writeDem("on_disk_dem.tif", [](int c, int r) { return static_cast<float>(c * r % 7); });
  const std::string source = outputDir() + "/on_disk.geojson";
  std::ofstream(source) << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"name": "holed", "n": 7},
     "geometry": {"type": "Polygon", "coordinates": [
       [[-34.862, -8.050], [-34.856, -8.050], [-34.856, -8.044], [-34.862, -8.044], [-34.862, -8.050]],
       [[-34.860, -8.048], [-34.860, -8.046], [-34.858, -8.046], [-34.858, -8.048], [-34.860, -8.048]]]}},
    {"type": "Feature", "properties": {"name": "two"},
     "geometry": {"type": "MultiPolygon", "coordinates": [
       [[[-34.861, -8.043], [-34.859, -8.043], [-34.859, -8.041], [-34.861, -8.043]]],
       [[[-34.857, -8.043], [-34.855, -8.043], [-34.855, -8.041], [-34.857, -8.043]]]]}}]})";
  scene::SceneDescription description = sceneWithCachedLayer(dem, source, "areas", "on_disk_cache");
  scene::LoadOptions options;
  options.progress = [](double) {};
  options.layerCache = false;
  const Result<scene::LoadedScene> memory = scene::loadScene(description, options);
  options.layerCache = true;
  const Result<scene::LoadedScene> cold = scene::loadScene(description, options);  // read, written, reopened
  const Result<scene::LoadedScene> warm = scene::loadScene(description, options);
  ASSERT_TRUE(memory.ok() && cold.ok() && warm.ok());
  EXPECT_EQ(warm->layersFromCache, 1u);
  const overlay::SharedFeatures& held = memory->layers.at(0).features;
  EXPECT_FALSE(held.onDisk());
  for (const scene::LoadedScene* s : {&*cold, &*warm}) {
    const overlay::SharedFeatures& kept = s->layers.at(0).features;
    EXPECT_TRUE(kept.onDisk());
    ASSERT_EQ(kept.size(), 2u);
    EXPECT_EQ(kept.vertexCount(), held.vertexCount());
    EXPECT_EQ(kept.fileContent(), warm->layers.at(0).features.fileContent());
    EXPECT_NE(kept.fileContent(), 0u);
    const overlay::SharedFeatures keptOutlines = kept.outlines(), heldOutlines = held.outlines();
    for (std::size_t i = 0; i < kept.size(); ++i) {
      const std::shared_ptr<const geo::Feature> a = held.get(i), b = kept.get(i);
      EXPECT_EQ(b->fid, a->fid);
      EXPECT_EQ(b->attributes, a->attributes);
      ASSERT_EQ(b->polygons.size(), a->polygons.size());
      for (std::size_t k = 0; k < a->polygons.size(); ++k) {
        EXPECT_EQ(b->polygons[k].outer, a->polygons[k].outer);
        EXPECT_EQ(b->polygons[k].holes, a->polygons[k].holes);
      }
      for (const bool lines : {false, true}) {
        EXPECT_EQ(kept.box(i, lines), held.box(i, lines)) << i << (lines ? " lines" : " rings");
        EXPECT_EQ(keptOutlines.box(i, lines), heldOutlines.box(i, lines)) << i << (lines ? " lines" : " rings");
      }
      EXPECT_EQ(keptOutlines.get(i)->lines, heldOutlines.get(i)->lines);
      EXPECT_FALSE(keptOutlines.get(i)->lines.empty());
    }
    EXPECT_TRUE(kept.onDisk()) << "get() reads one feature, not all";
  }
  EXPECT_TRUE(held.get(0)->polygons.at(0).holes.size() == 1u);

  // A file cut short under a reader: reading says which file and feature, nothing is made up.
  std::string file;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(description.cacheDir))
    if (entry.path().extension() == ".layer") file = entry.path().string();
  ASSERT_FALSE(file.empty());
  const auto size = std::filesystem::file_size(file);
  std::filesystem::resize_file(file, 40);
  try {
    (void)warm->layers.at(0).features.get(1);
    ADD_FAILURE() << "a feature read from a file cut short";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("feature 1"), std::string::npos) << e.what();
  }
  // A damaged index (its offset in the footer) is refused when opened: read from the source.
  std::filesystem::remove(file);
  ASSERT_TRUE(scene::loadScene(description, options).ok());
  ASSERT_EQ(std::filesystem::file_size(file), size);
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size - 12));  // where the index and messages start, before the magic
    const std::uint64_t beyond = size * 2;
    f.write(reinterpret_cast<const char*>(&beyond), sizeof(beyond));
  }
  const Result<scene::LoadedScene> reread = scene::loadScene(description, options);
  ASSERT_TRUE(reread.ok());
  EXPECT_EQ(reread->layersFromCache, 0u);
  EXPECT_EQ(reread->layers.at(0).features.get(0)->polygons.at(0).outer, held.get(0)->polygons.at(0).outer);
}

TEST(TerrainGrid, ImplausibleHeightsToNodataCountsWhatItChanges) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> h{0.0F, -430.0F, 8850.0F, 1e7F, -1e7F, 1.0001e7F, -3.4e38F, inf, -inf, nan};
  EXPECT_EQ(terrain::implausibleHeightsToNodata(h), 4u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_FALSE(std::isnan(h[i])) << i;
  for (std::size_t i = 5; i < h.size(); ++i) EXPECT_TRUE(std::isnan(h[i])) << i;
  EXPECT_EQ(terrain::implausibleHeightsToNodata(h), 0u);
}

}  // namespace
}  // namespace gis::test

namespace gis::test {
namespace {

TEST(SceneCache, AFolderThatCannotBeWrittenFallsBackToTheUserCacheThenToNone) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(outputDir()) / "cache_fallback";
  fs::remove_all(root);
  fs::create_directories(root);
  scene::SceneDescription d;
  d.path = (root / "scene.json").string();
  // A cache path that is a file: the user's cache folder, said once.
  std::ofstream(root / "a-file") << "x";
  d.cacheDir = (root / "a-file").string();
  const char* oldXdg = std::getenv("XDG_CACHE_HOME");
  const std::string keepXdg = oldXdg != nullptr ? oldXdg : "";
  ::setenv("XDG_CACHE_HOME", (root / "user").c_str(), 1);
  std::string warning;
  EXPECT_EQ(scene::cacheDirectoryFor(d, &warning), (root / "user" / "stencil-gis").string());
  EXPECT_NE(warning.find("cannot be written"), std::string::npos) << warning;
  EXPECT_NE(warning.find(d.cacheDir), std::string::npos) << warning;
  // Neither: no cache.
  ::setenv("XDG_CACHE_HOME", (root / "a-file").c_str(), 1);
  warning.clear();
  EXPECT_EQ(scene::cacheDirectoryFor(d, &warning), "");
  EXPECT_NE(warning.find("running without a cache"), std::string::npos) << warning;
  // A usable folder: no warning. Disabled: none.
  d.cacheDir = (root / "fine").string();
  warning.clear();
  EXPECT_EQ(scene::cacheDirectoryFor(d, &warning), d.cacheDir);
  EXPECT_TRUE(warning.empty()) << warning;
  d.cacheDisabled = true;
  EXPECT_EQ(scene::cacheDirectoryFor(d, &warning), "");
  if (oldXdg != nullptr) {
    ::setenv("XDG_CACHE_HOME", keepXdg.c_str(), 1);
  } else {
    ::unsetenv("XDG_CACHE_HOME");
  }
}

TEST(SceneCache, UsageCountsAndClearEmptiesTheFolder) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(outputDir()) / "cache_usage";
  fs::remove_all(root);
  fs::create_directories(root / "vector-tiles" / "0123");
  std::ofstream(root / "vector-tiles" / "0123" / "0-0-0.tile") << std::string(1000, 'a');
  std::ofstream(root / "x.layer") << std::string(234, 'b');
  const scene::CacheUsage usage = scene::cacheUsage(root.string());
  EXPECT_EQ(usage.files, 2u);
  EXPECT_EQ(usage.bytes, 1234u);
  const scene::CacheUsage removed = scene::clearCache(root.string());
  EXPECT_EQ(removed.files, 2u);
  EXPECT_EQ(removed.bytes, 1234u);
  EXPECT_TRUE(fs::is_directory(root));
  EXPECT_TRUE(fs::is_empty(root));
  EXPECT_EQ(scene::cacheUsage("").files, 0u);
}

}  // namespace
}  // namespace gis::test
