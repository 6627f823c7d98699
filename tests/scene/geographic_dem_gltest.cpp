// A scene on a geographic DEM (issue 20): terrain_synth's stiff relief in EPSG:4326 at 3" posts
// and vector layers in longitude/latitude, loaded in memory and paged. From top-down, oblique,
// grazing and eye-inside cameras:
// - every terrain pixel, unprojected through its camera and carried back to longitude/latitude,
//   lies on the source DEM: between the lowest and highest source posts around it (the frame
//   grid is a bilinear resampling of them), and on average within the resampling error the CPU
//   measures on the same grids;
// - the overlay covers exactly the pixels the CPU reference covers (0 wrong away from edges).
// And a 2x2 SRTM mosaic (.hgt, voids) drawn at full detail has no crack: every pixel inside the
// mosaic's footprint, off its voids, is terrain.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <nlohmann/json.hpp>

#include "dem_files.hpp"
#include "geo/raster.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "random_features.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "synth/synthetic_dem.hpp"
#include "test_paths.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
constexpr int kSize = 256;
constexpr double kStep = 1.0 / 1200.0;  // 3"

std::string outputDir() {
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("geographic-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir.string();
}

/// Features (frame coordinates) as a GeoJSON file in longitude/latitude.
void writeLonLatGeoJson(const std::string& path, const std::vector<geo::Feature>& features,
                        const geo::SceneFrame& frame) {
  auto lonLat = [&](const glm::dvec2& p) {
    const glm::dvec3 ll = *frame.toLonLat(glm::dvec3(p, 0.0));
    return nlohmann::json::array({ll.x, ll.y});
  };
  nlohmann::json collection = {{"type", "FeatureCollection"}, {"features", nlohmann::json::array()}};
  for (const geo::Feature& f : features) {
    nlohmann::json geometry;
    if (!f.polygons.empty()) {
      nlohmann::json rings = nlohmann::json::array();
      for (const geo::Ring* ring : [&] {
             std::vector<const geo::Ring*> all{&f.polygons[0].outer};
             for (const geo::Ring& h : f.polygons[0].holes) all.push_back(&h);
             return all;
           }()) {
        nlohmann::json coords = nlohmann::json::array();
        for (const glm::dvec2& p : *ring) coords.push_back(lonLat(p));
        coords.push_back(lonLat(ring->front()));
        rings.push_back(coords);
      }
      geometry = {{"type", "Polygon"}, {"coordinates", rings}};
    } else {
      nlohmann::json coords = nlohmann::json::array();
      for (const glm::dvec2& p : f.lines[0]) coords.push_back(lonLat(p));
      geometry = {{"type", "LineString"}, {"coordinates", coords}};
    }
    nlohmann::json properties = nlohmann::json::object();
    if (auto it = f.attributes.find("width_m"); it != f.attributes.end()) {
      properties["width_m"] = std::get<std::int64_t>(it->second);
    }
    collection["features"].push_back({{"type", "Feature"}, {"properties", properties}, {"geometry", geometry}});
  }
  std::ofstream(path) << collection.dump();
}

class GeographicDemGlTest : public GlTest {
 protected:
  static void SetUpTestSuite() {
    GlTest::SetUpTestSuite();
    dir() = outputDir();
    demPath() = dir() + "/synth_lonlat.tif";
    ASSERT_TRUE(synth::writeSyntheticDem(demPath(), synth::geographicDemOptions(161, 11)).ok());
    scene::SceneDescription scene = scene::sceneForDem(demPath());
    scene.chunkCells = 16;
    scene.cacheDir = dir() + "/cache";
    // Features placed in the frame the DEM gets, written in longitude/latitude.
    Result<geo::DemSource> dem = geo::DemSource::open(scene.demSpec());
    ASSERT_TRUE(dem.ok());
    Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->extent());
    ASSERT_TRUE(frame.ok());
    const glm::dvec3 a = *frame->fromLonLat(6.0 + 10 * kStep, 50.0 - 150 * kStep, 0.0);
    const glm::dvec3 b = *frame->fromLonLat(6.0 + 150 * kStep, 50.0 - 10 * kStep, 0.0);
    std::mt19937 rng(20);
    std::vector<geo::Feature> polygons = randomPolygons(rng, glm::dvec2(a), glm::dvec2(b), 10);
    std::vector<geo::Feature> lines = randomLines(rng, glm::dvec2(a), glm::dvec2(b), 12);
    writeLonLatGeoJson(dir() + "/areas.geojson", polygons, *frame);
    writeLonLatGeoJson(dir() + "/roads.geojson", lines, *frame);
    insideArea() = polygons[1].polygons[0].outer;
    road() = lines[4].lines[0];  // 28 m wide
    scene::LayerDescription areas;
    areas.name = "areas";
    areas.kind = overlay::LayerKind::Polygon;
    areas.source = dir() + "/areas.geojson";
    areas.style.outlineWidthMetres = 8.0F;
    scene::LayerDescription roads;
    roads.name = "roads";
    roads.kind = overlay::LayerKind::Line;
    roads.source = dir() + "/roads.geojson";
    roads.style.widthAttribute = "width_m";
    roads.fileIndex = 1;
    scene.layers = {areas, roads};
    description() = scene;
  }
  static void TearDownTestSuite() { fs::remove_all(dir()); }

  static std::string& dir() {
    static std::string d;
    return d;
  }
  static std::string& demPath() {
    static std::string p;
    return p;
  }
  static std::optional<scene::SceneDescription>& description() {
    static std::optional<scene::SceneDescription> d;
    return d;
  }
  static geo::Ring& insideArea() {
    static geo::Ring r;
    return r;
  }
  static geo::LineString& road() {
    static geo::LineString l;
    return l;
  }
};

TEST_F(GeographicDemGlTest, TerrainLiesOnTheSourceAndOverlaysAreExactPagedAndInMemory) {
  Result<geo::Raster> source = geo::readRaster(demPath());
  ASSERT_TRUE(source.ok());
  const geo::RasterInfo& si = source->info;
  for (const scene::TerrainPaging paging : {scene::TerrainPaging::Never, scene::TerrainPaging::Always}) {
    const char* mode = paging == scene::TerrainPaging::Never ? "in memory" : "paged";
    scene::LoadOptions options;
    options.paging = paging;
    options.progress = [](double) {};
    Result<scene::LoadedScene> scene = scene::loadScene(*description(), options);
    ASSERT_TRUE(scene.ok());
    ASSERT_EQ(scene->paged(), paging == scene::TerrainPaging::Always);
    EXPECT_EQ(scene->frame.epsg(), 32632);
    ASSERT_EQ(scene->layers.size(), 2u);
    Result<geo::CrsTransform> toSource = scene->frame.transformTo(si.crsWkt);
    ASSERT_TRUE(toSource.ok());
    Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*scene);
    ASSERT_TRUE(renderer.ok());
    std::vector<overlay::ReferenceLayer> ref;
    for (const overlay::OverlayLayer& l : renderer->overlayLayers()) ref.push_back(overlay::referenceLayerOf(l));

    // The resampling error of these grids on the CPU: the frame grid's bilinear surface against
    // the source's at random points, the bound of the mean below.
    const terrain::TerrainGrid& grid = scene->quadtree->grid();
    auto groundAt = [&](const glm::dvec2& frameXy) { return scene->bounds->fullResolutionHeightAt(frameXy); };
    auto sourceAt = [&](const glm::dvec2& frameXy) {
      const glm::dvec2 p = *toSource->transform(glm::dvec2(scene->frame.frameToProjected(glm::dvec3(frameXy, 0.0))));
      const glm::dvec2 uv = *si.geoTransform.crsToPixel(p) - glm::dvec2(0.5);
      return bilinearAt(source->samples, si.width, si.height, uv.x, uv.y);
    };
    glm::dvec3 lo, hi;
    scene::terrainBox(*scene, 1.0, lo, hi);
    const glm::dvec3 centre = 0.5 * (lo + hi);

    std::vector<scene::Camera> cameras;
    scene::Camera top = scene::overviewCamera(lo, hi);
    top.eye = centre + glm::dvec3(0.0, -10.0, 14000.0);
    top.target = centre;
    cameras.push_back(top);
    scene::Camera oblique = top;
    oblique.eye = centre + glm::dvec3(2000.0, -9000.0, 5000.0);
    cameras.push_back(oblique);
    const glm::dvec2 low(centre.x, lo.y + 800.0);
    const double lowGround = groundAt(low);
    if (std::isnan(lowGround)) FAIL() << "no ground under the grazing camera";
    scene::Camera grazing = top;
    grazing.eye = glm::dvec3(low, lowGround + 40.0);
    grazing.target = glm::dvec3(centre.x + 500.0, hi.y, lowGround + 10.0);
    grazing.nearPlane = 1.0;
    cameras.push_back(grazing);
    // The eye in an area's volume (just above the ground at a vertex's inner side) and in a road's.
    const glm::dvec2 areaCentre = 0.5 * (insideArea()[0] + insideArea()[insideArea().size() / 2]);
    const glm::dvec2 inArea = glm::mix(insideArea()[0], areaCentre, 0.3);
    scene::Camera inside = top;
    inside.eye = glm::dvec3(inArea, groundAt(inArea) + 2.0);
    inside.target = glm::dvec3(areaCentre, groundAt(areaCentre));
    inside.nearPlane = 0.3;
    cameras.push_back(inside);
    // The first road segment with ground under its middle.
    std::size_t seg = 0;
    while (seg + 2 < road().size() && std::isnan(groundAt(glm::mix(road()[seg], road()[seg + 1], 0.5)))) ++seg;
    const glm::dvec2 onRoad = glm::mix(road()[seg], road()[seg + 1], 0.5);
    scene::Camera inRoad = top;
    inRoad.eye = glm::dvec3(onRoad, groundAt(onRoad) + 1.0);
    // Along the road, 10° down.
    const glm::dvec2 along = glm::normalize(road()[seg + 1] - road()[seg]);
    inRoad.target = inRoad.eye + glm::dvec3(along * 100.0, -17.6);
    inRoad.nearPlane = 0.3;
    cameras.push_back(inRoad);
    const char* names[] = {"top-down", "oblique", "grazing", "eye in an area", "eye in a road"};

    gfx::RenderTarget target(kSize, kSize, 0, true);
    scene::RenderSettings settings;
    settings.lodTolerancePixels = 0.0;  // every post: the surface is the frame grid's
    settings.waitForTiles = true;
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      const scene::Camera& camera = cameras[k];
      ASSERT_FALSE(std::isnan(camera.eye.z)) << names[k];
      renderer->render(cache_, target.framebuffer(), kSize, kSize, camera, settings);
      const std::vector<float> depth = gfx::readDepth(target);
      const std::vector<std::uint32_t> mask = gfx::readMask(target);
      const overlay::DepthImage image{kSize, kSize, depth, camera.projection(1.0) * camera.view()};
      const std::vector<std::uint32_t> reference = overlay::referenceMask(image, ref);
      const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
      std::size_t terrain = 0, covered = 0, wrong = 0, edgeWrong = 0, outsideHull = 0;
      double sum = 0.0, worst = 0.0, cpuSum = 0.0;
      for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * kSize + static_cast<std::size_t>(x);
          covered += reference[i] != 0 ? 1u : 0u;
          if (mask[i] != reference[i]) {
            if (edges[i] != 0) {
              ++edgeWrong;
            } else if (wrong++ < 5) {
              ADD_FAILURE() << mode << ", " << names[k] << ": pixel " << x << ", " << y << " mask " << mask[i]
                            << ", reference " << reference[i];
            }
          }
          const std::optional<glm::dvec3> p = overlay::unprojectPixel(image, x, y);
          if (!p) continue;
          ++terrain;
          // The source posts around the point: the frame post it comes from is their bilinear
          // blend, the rendered triangle blends three frame posts: all lie in their range.
          const glm::dvec2 ll =
              *toSource->transform(glm::dvec2(scene->frame.frameToProjected(glm::dvec3(p->x, p->y, 0.0))));
          const glm::dvec2 uv = *si.geoTransform.crsToPixel(ll) - glm::dvec2(0.5);
          double hmin = 1e30, hmax = -1e30;
          for (int r = static_cast<int>(std::floor(uv.y)) - 2; r <= static_cast<int>(std::floor(uv.y)) + 3; ++r) {
            for (int c = static_cast<int>(std::floor(uv.x)) - 2; c <= static_cast<int>(std::floor(uv.x)) + 3; ++c) {
              if (c < 0 || r < 0 || c >= si.width || r >= si.height) continue;
              const double h = source->at(c, r);
              if (std::isnan(h)) continue;
              hmin = std::min(hmin, h);
              hmax = std::max(hmax, h);
            }
          }
          // Float depth: 2^-22 of the distance from the eye (a few ulps of the unprojection).
          const double slack = 0.01 + glm::length(*p - camera.eye) * 2.4e-7;
          if (p->z < hmin - slack || p->z > hmax + slack) {
            if (outsideHull++ < 5) {
              ADD_FAILURE() << mode << ", " << names[k] << ": pixel " << x << ", " << y << " at height " << p->z
                            << ", source posts around it " << hmin << " .. " << hmax;
            }
          }
          const double s = sourceAt(glm::dvec2(*p));
          if (!std::isnan(s)) {
            sum += (p->z - s) * (p->z - s);
            worst = std::max(worst, std::abs(p->z - s));
            const double g = groundAt(glm::dvec2(*p));
            if (!std::isnan(g)) cpuSum += (g - s) * (g - s);
          }
        }
      }
      const double rms = std::sqrt(sum / static_cast<double>(std::max<std::size_t>(terrain, 1)));
      const double cpuRms = std::sqrt(cpuSum / static_cast<double>(std::max<std::size_t>(terrain, 1)));
      std::printf(
          "%s, %s: %zu terrain pixels, %zu covered, %zu wrong away from edges (%zu on edges); height "
          "against the source: RMS %.2f m (the grid's own: %.2f m), worst %.2f m\n",
          mode, names[k], terrain, covered, wrong, edgeWrong, rms, cpuRms, worst);
      EXPECT_GT(terrain, static_cast<std::size_t>(kSize * kSize / 10)) << names[k];
      EXPECT_EQ(wrong, 0u) << mode << ", " << names[k];
      EXPECT_EQ(outsideHull, 0u) << mode << ", " << names[k];
      // The rendered surface is the grid's triangulation of the same posts: within a metre of
      // the grid's bilinear surface on average.
      EXPECT_LT(rms, cpuRms + 1.0) << mode << ", " << names[k];
    }
    EXPECT_GT(grid.width, 0);
  }
}

TEST_F(GeographicDemGlTest, ImageryInLongitudeLatitudeLandsWhereItBelongs) {
  // A 3-band image in EPSG:4326 over the DEM: red west of 6.06°E, blue east of it, and a green
  // band north of 49.95°N. Resampled into the frame with the DEM, each colour stays on its side.
  GDALAllRegister();
  const std::string path = dir() + "/imagery_lonlat.tif";
  constexpr int kPixels = 400;
  const double step = 0.14 / kPixels;
  {
    GDALDataset* ds =
        GetGDALDriverManager()->GetDriverByName("GTiff")->Create(path.c_str(), kPixels, kPixels, 3, GDT_Byte, nullptr);
    ASSERT_NE(ds, nullptr);
    std::array<double, 6> gt{5.995, step, 0.0, 50.005, 0.0, -step};
    ds->SetGeoTransform(gt.data());
    OGRSpatialReference srs;
    srs.importFromEPSG(4326);
    ds->SetSpatialRef(&srs);
    std::vector<std::uint8_t> rgb(static_cast<std::size_t>(3 * kPixels * kPixels));
    for (int r = 0; r < kPixels; ++r) {
      for (int c = 0; c < kPixels; ++c) {
        const double lon = 5.995 + (c + 0.5) * step, lat = 50.005 - (r + 0.5) * step;
        const bool west = lon<6.06, north = lat> 49.95;
        const std::size_t i = static_cast<std::size_t>(r * kPixels + c);
        rgb[i] = west ? 255 : 0;
        rgb[static_cast<std::size_t>(kPixels * kPixels) + i] = north ? 255 : 0;
        rgb[static_cast<std::size_t>(2 * kPixels * kPixels) + i] = west ? 0 : 255;
      }
    }
    ASSERT_EQ(ds->RasterIO(GF_Write, 0, 0, kPixels, kPixels, rgb.data(), kPixels, kPixels, GDT_Byte, 3, nullptr, 0, 0,
                           0, nullptr),
              CE_None);
    GDALClose(GDALDataset::ToHandle(ds));
  }
  scene::SceneDescription description = *this->description();
  description.layers.clear();
  description.imagery = path;
  Result<scene::LoadedScene> scene = scene::loadScene(description);
  ASSERT_TRUE(scene.ok());
  ASSERT_TRUE(scene->orthophoto.has_value());
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*scene);
  ASSERT_TRUE(renderer.ok());
  glm::dvec3 lo, hi;
  scene::terrainBox(*scene, 1.0, lo, hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  scene::Camera camera = scene::overviewCamera(lo, hi);
  camera.eye = centre + glm::dvec3(1500.0, -7000.0, 9000.0);
  camera.target = centre;
  gfx::RenderTarget target(kSize, kSize, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  settings.overlays = false;
  renderer->render(cache_, target.framebuffer(), kSize, kSize, camera, settings);
  const std::vector<float> depth = gfx::readDepth(target);
  const std::vector<std::uint8_t> color = gfx::readColorRgba8(target);
  const overlay::DepthImage image{kSize, kSize, depth, camera.projection(1.0) * camera.view()};
  Result<geo::CrsTransform> toLonLat = scene->frame.transformTo("EPSG:4326");
  ASSERT_TRUE(toLonLat.ok());
  std::size_t judged = 0, wrong = 0;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      const std::optional<glm::dvec3> p = overlay::unprojectPixel(image, x, y);
      if (!p) continue;
      const glm::dvec2 ll = *toLonLat->transform(glm::dvec2(scene->frame.frameToProjected(*p)));
      // Two image pixels (0.0007°) from a colour edge the mip-mapped texture may blend.
      if (std::abs(ll.x - 6.06) < 0.002 || std::abs(ll.y - 49.95) < 0.002) continue;
      const std::size_t i = (static_cast<std::size_t>(y) * kSize + static_cast<std::size_t>(x)) * 4;
      const bool red = color[i] > 128, green = color[i + 1] > 128, blue = color[i + 2] > 128;
      ++judged;
      wrong += red != (ll.x < 6.06) || blue != (ll.x >= 6.06) || green != (ll.y > 49.95) ? 1u : 0u;
    }
  }
  std::printf("imagery in lon/lat over the geographic DEM: %zu of %zu pixels off their colour\n", wrong, judged);
  EXPECT_GT(judged, static_cast<std::size_t>(kSize * kSize / 5));
  EXPECT_EQ(wrong, 0u);
}

TEST_F(GeographicDemGlTest, SrtmMosaicHasNoCrack) {
  // Four 3" tiles of a smooth field around 7°E 50°N with one void; drawn top-down at full detail,
  // every pixel whose ground point is inside the mosaic and away from the void is terrain.
  const std::string tiles = dir() + "/srtm";
  fs::create_directories(tiles);
  auto field = [](double lon, double lat) {
    if ((lon - 6.8) * (lon - 6.8) + (lat - 50.2) * (lat - 50.2) < 0.03 * 0.03) return std::nan("");
    return 300.0 + 150.0 * std::sin(11.0 * lon) * std::cos(13.0 * lat);
  };
  // Small tiles are not SRTM's 1201²: write the 2x2 as GeoTIFF tiles of 0.25°, 301² posts.
  std::vector<std::string> paths;
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      const double lon0 = 6.75 + 0.25 * i, lat0 = 50.25 - 0.25 * j;
      DemFileOptions o;
      o.width = o.height = 301;
      o.geoTransform = {lon0 - 0.5 * kStep, kStep, 0.0, lat0 + 0.5 * kStep, 0.0, -kStep};
      o.crs = "EPSG:4326";
      o.nodata = -32768.0;
      const std::string path = tiles + "/tile" + std::to_string(j) + std::to_string(i) + ".tif";
      writeDemFile(path, o, [&](int c, int r) {
        const double h = field(lon0 + c * kStep, lat0 - r * kStep);
        return std::isnan(h) ? -32768.0 : h;
      });
      paths.push_back(path);
    }
  }
  scene::SceneDescription description = scene::sceneForDem(tiles);
  description.chunkCells = 16;
  description.cacheDir = dir() + "/cache-srtm";
  for (const scene::TerrainPaging paging : {scene::TerrainPaging::Never, scene::TerrainPaging::Always}) {
    scene::LoadOptions options;
    options.paging = paging;
    options.progress = [](double) {};
    Result<scene::LoadedScene> scene = scene::loadScene(description, options);
    ASSERT_TRUE(scene.ok());
    Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(*scene);
    ASSERT_TRUE(renderer.ok());
    Result<geo::CrsTransform> toLonLat = scene->frame.transformTo("EPSG:4326");
    ASSERT_TRUE(toLonLat.ok());
    // Centred on the corner where the four tiles meet, the seams through the middle.
    const glm::dvec3 corner = *scene->frame.fromLonLat(7.0, 50.0, 0.0);
    gfx::RenderTarget target(kSize, kSize, 0, true);
    scene::RenderSettings settings;
    settings.lodTolerancePixels = 1.5;  // mixed levels of detail: their stitching is checked too
    settings.waitForTiles = true;
    scene::Camera camera;
    camera.eye = corner + glm::dvec3(0.0, -1.0, 30000.0);
    camera.target = corner;
    camera.fovYDeg = 60.0;
    renderer->render(cache_, target.framebuffer(), kSize, kSize, camera, settings);
    const std::vector<float> depth = gfx::readDepth(target);
    const glm::dmat4 viewProj = camera.projection(1.0) * camera.view();
    const glm::dmat4 inverse = glm::inverse(viewProj);
    std::size_t inside = 0, cracks = 0;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        // Where the pixel's ray meets height 300 m (the field's mean): inside the mosaic and
        // off the void, the ray hits terrain.
        const double nx = 2.0 * (x + 0.5) / kSize - 1.0, ny = 1.0 - 2.0 * (y + 0.5) / kSize;
        const glm::dvec4 a = inverse * glm::dvec4(nx, ny, 1.0, 1.0), b = inverse * glm::dvec4(nx, ny, 0.5, 1.0);
        const glm::dvec3 pa = glm::dvec3(a) / a.w, pb = glm::dvec3(b) / b.w;
        const double t = (300.0 - pa.z) / (pb.z - pa.z);
        const glm::dvec3 ground = pa + t * (pb - pa);
        const glm::dvec2 ll = *toLonLat->transform(glm::dvec2(scene->frame.frameToProjected(ground)));
        if (ll.x < 6.76 || ll.x > 7.24 || ll.y < 49.76 || ll.y > 50.24) continue;
        if ((ll.x - 6.8) * (ll.x - 6.8) + (ll.y - 50.2) * (ll.y - 50.2) < 0.04 * 0.04) continue;
        ++inside;
        if (!(depth[static_cast<std::size_t>(y) * kSize + static_cast<std::size_t>(x)] > 0.0F)) {
          if (cracks++ < 5)
            ADD_FAILURE() << "no terrain at pixel " << x << ", " << y << " (" << ll.x << ", " << ll.y << ")";
        }
      }
    }
    std::printf("mosaic (%s): %zu pixels inside, %zu without terrain\n",
                paging == scene::TerrainPaging::Never ? "in memory" : "paged", inside, cracks);
    EXPECT_GT(inside, static_cast<std::size_t>(kSize * kSize / 3));
    EXPECT_EQ(cracks, 0u);
  }
}

}  // namespace
}  // namespace gis::test
