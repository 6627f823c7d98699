// Runs the real overlay_render program on the Olinda sample and checks its outputs: files exist
// with the asked size; terrain pixels are not background and carry imagery colour; depth is
// finite and 0 only on background; and every terrain pixel unprojected through camera.json
// lands on the DEM surface as drawn (same triangulation), within a stated tolerance.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "gfx/image_io.hpp"
#include "program_output.hpp"
#include "test_paths.hpp"
#include "vector_files.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kSamples = STENCIL_GIS_SAMPLES_DIR;
constexpr int kWidth = 256;
constexpr int kHeight = 192;
// Float depth at ~15 km and float vertices relative to the mesh centre: a few centimetres.
constexpr double kSurfaceTolerance = 0.25;  // metres, vertical

int runOverlayRender(const std::string& args, const fs::path& log) {
  const std::string command = std::string(OVERLAY_RENDER_EXE) + " " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// The Olinda sample's scene file with its files' paths made absolute (to write elsewhere).
json olindaScene() {
  json description = json::parse(readText(kSamples + "/olinda/scene.json"));
  const std::string olinda = kSamples + "/olinda/";
  description["terrain"]["dem"] = olinda + description["terrain"]["dem"].get<std::string>();
  description["imagery"]["path"] = olinda + description["imagery"]["path"].get<std::string>();
  for (json& layer : description["layers"]) layer["source"] = olinda + layer["source"].get<std::string>();
  return description;
}

/// Height of the full-resolution DEM surface at frame (x, y): triangles a-d-e and a-e-b per cell
/// (what is drawn at --lod-tolerance 0).
std::optional<double> drawnHeight(const geo::Raster& dem, const geo::SceneFrame& frame, double x, double y) {
  const auto& gt = dem.info.geoTransform.c;
  const glm::dvec3 p = frame.frameToProjected({x, y, 0});
  const double col = (p.x - gt[0]) / gt[1] - 0.5;
  const double row = (p.y - gt[3]) / gt[5] - 0.5;
  const int c = static_cast<int>(std::floor(col));
  const int r = static_cast<int>(std::floor(row));
  if (c < 0 || r < 0 || c + 1 >= dem.info.width || r + 1 >= dem.info.height) return std::nullopt;
  const double fx = col - c, fy = row - r;
  const double a = dem.at(c, r), b = dem.at(c + 1, r), d = dem.at(c, r + 1), e = dem.at(c + 1, r + 1);
  if (fy >= fx) return a + fy * (d - a) + fx * (e - d);
  return a + fx * (b - a) + fy * (e - b);
}

class OverlayRenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // ctest runs each test case in its own process, possibly in parallel: one folder per process.
    out_ = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("olinda_" + std::to_string(getpid()));
    fs::remove_all(out_);
    fs::create_directories(out_);
    status_ = runOverlayRender("--scene " + kSamples + "/olinda/scene.json --width " + std::to_string(kWidth) +
                                   " --height " + std::to_string(kHeight) + " --lod-tolerance 0 --out " + out_.string(),
                               out_ / "log.txt");
  }
  static fs::path out_;
  static int status_;
};
fs::path OverlayRenderTest::out_;
int OverlayRenderTest::status_ = -1;

TEST_F(OverlayRenderTest, WritesEveryOutput) {
  ASSERT_EQ(status_, 0) << readText(out_ / "log.txt");
  for (const char* name : {"color.png", "depth.tiff", "mask.png", "camera.json", "stats.json"}) {
    EXPECT_TRUE(fs::exists(out_ / name)) << name;
  }
  EXPECT_NE(readText(out_ / "log.txt").find("color.png"), std::string::npos) << "prints where the PNG is";
  const json stats = json::parse(readText(out_ / "stats.json"));
  EXPECT_EQ(stats["frame"], "projected");
  EXPECT_EQ(stats["gl_errors"].get<int>(), 0);
  // The shipped sample loads clean (its broken lines are test data: tests/data).
  EXPECT_EQ(stats["errors"].get<int>(), 0) << stats["diagnostics"].dump(2);
  // Tolerance 0: only nodes whose surface equals the DEM exactly stay coarse (flat sea).
  EXPECT_LE(stats["terrain"]["triangles"].get<int>(), 110 * 110 * 2);  // 111 × 111 posts, no nodata
  EXPECT_GT(stats["terrain"]["triangles"].get<int>(), 0);
  EXPECT_TRUE(stats["terrain"]["imagery"].get<bool>());
  EXPECT_GT(stats["passes"]["terrain"]["pipeline"]["fragment_shader_invocations"].get<double>(), 0.0);
  ASSERT_EQ(stats["layers"].size(), 2u);
  EXPECT_EQ(stats["layers"][0]["features"].get<int>(), 470);
  EXPECT_EQ(stats["layers"][1]["features"].get<int>(), 1413);
  EXPECT_EQ(stats["layers"][1]["skipped_features"].get<int>(), 0);
  EXPECT_EQ(stats["layers"][1]["skipped_when_read"].get<int>(), 0);
  EXPECT_EQ(stats["layers"][1]["drawn_features"].get<int>(), 1413);
  EXPECT_EQ(stats["layers"][1]["features_with_nothing_to_draw"].get<int>(), 0);
  const gfx::Image8 mask = *gfx::readImage8((out_ / "mask.png").string());
  EXPECT_EQ(mask.width, kWidth);
  EXPECT_EQ(mask.channels, 1);
}

TEST_F(OverlayRenderTest, TerrainPixelsAreImageryAndLieOnTheDrawnSurface) {
  ASSERT_EQ(status_, 0);
  Result<gfx::Image8> color = gfx::readImage8((out_ / "color.png").string());
  Result<gfx::ImageFloat> depth = gfx::readImageFloat((out_ / "depth.tiff").string());
  ASSERT_TRUE(color.ok() && depth.ok());
  ASSERT_EQ(color->width, kWidth);
  ASSERT_EQ(color->height, kHeight);
  ASSERT_EQ(depth->width, kWidth);
  const json camera = json::parse(readText(out_ / "camera.json"));
  EXPECT_EQ(camera["width"].get<int>(), kWidth);
  EXPECT_EQ(camera["depth"]["convention"].get<std::string>(), "reversed-z");
  const glm::dmat4 inverse = glm::inverse(viewProjOf(camera));

  Result<geo::Raster> dem = geo::readRaster(kSamples + "/olinda/olinda_dem_utm25s.tif");
  ASSERT_TRUE(dem.ok());
  Result<geo::SceneFrame> frame = geo::SceneFrame::fromCrs(
      camera["crs_wkt"].get<std::string>(),
      {camera["origin"][0].get<double>(), camera["origin"][1].get<double>(), camera["origin"][2].get<double>()});
  ASSERT_TRUE(frame.ok());

  const std::uint8_t background[3] = {15, 18, 23};  // kBackground in 8 bits
  std::size_t terrain = 0, checked = 0, offSurface = 0, backgroundColoured = 0, nonFinite = 0;
  double worst = 0.0;
  double sum[3] = {0, 0, 0};
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y * kWidth + x);
      const float d = depth->pixels[i];
      const std::uint8_t* c = &color->pixels[i * 3];
      if (!std::isfinite(d) || d < 0.0F || d > 1.0F) {
        ++nonFinite;
        continue;
      }
      if (d == 0.0F) continue;
      ++terrain;
      for (int k = 0; k < 3; ++k) sum[k] += c[k];
      if (std::abs(c[0] - background[0]) <= 1 && std::abs(c[1] - background[1]) <= 1 &&
          std::abs(c[2] - background[2]) <= 1) {
        ++backgroundColoured;
      }
      const glm::dvec4 ndc((x + 0.5) / kWidth * 2.0 - 1.0, 1.0 - (y + 0.5) / kHeight * 2.0, d, 1.0);
      const glm::dvec4 h = inverse * ndc;
      const glm::dvec3 p = glm::dvec3(h) / h.w;
      const std::optional<double> surface = drawnHeight(*dem, *frame, p.x, p.y);
      if (!surface) continue;  // within half a post of the DEM border
      ++checked;
      const double err = std::abs(p.z - *surface);
      worst = std::max(worst, err);
      offSurface += err > kSurfaceTolerance;
    }
  }
  EXPECT_EQ(nonFinite, 0u);
  EXPECT_GT(terrain, static_cast<std::size_t>(kWidth * kHeight / 4)) << "terrain should fill much of the view";
  EXPECT_LT(terrain, static_cast<std::size_t>(kWidth * kHeight)) << "the overview shows some sky";
  EXPECT_EQ(backgroundColoured, 0u);
  EXPECT_GT(checked, terrain * 9 / 10);
  EXPECT_EQ(offSurface, 0u) << "worst vertical error " << worst << " m";
  // Landsat true colour of Olinda (town, vegetation, sea): not the grey hillshade, not flat.
  const double mean[3] = {sum[0] / double(terrain), sum[1] / double(terrain), sum[2] / double(terrain)};
  EXPECT_GT(std::abs(mean[0] - mean[1]) + std::abs(mean[1] - mean[2]), 3.0)
      << "mean colour " << mean[0] << " " << mean[1] << " " << mean[2];
}

TEST(OverlayRenderCli, AGeographicDemLiesOnItsSourceThroughCameraJson) {
  // Olinda's SRTM heights back in longitude/latitude at SRTM's 3" (nearest post: the heights
  // unchanged), with the tracts and the Landsat scene: the scene gets UTM 25S again, resampled.
  // Every terrain pixel of the image, unprojected through camera.json and carried back to
  // longitude/latitude, lies between the lowest and highest source posts around it, and on
  // average within the resampling error of docs/terrain.md (2.3 m RMS at the source posts; 1.1 m
  // over the pixels).
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("lonlat_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string dem = (dir / "olinda_lonlat.tif").string();
  const std::string warp = "gdalwarp -q -t_srs EPSG:4326 -tr 0.000833333333333 0.000833333333333 -r near " + kSamples +
                           "/olinda/olinda_dem_utm25s.tif " + dem;
  ASSERT_EQ(std::system(warp.c_str()), 0);
  const json scene = {{"terrain", {{"dem", dem}}},
                      {"imagery", {{"path", kSamples + "/olinda/L7_ETMs.tif"}, {"bands", {3, 2, 1}}}},
                      {"layers",
                       {{{"name", "tracts"},
                         {"kind", "polygon"},
                         {"source", kSamples + "/olinda/olinda1.shp"},
                         {"style", {{"color", "#ffcc00"}, {"opacity", 0.5}}}}}}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const fs::path out = dir / "out";
  ASSERT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                                 " --height " + std::to_string(kHeight) + " --lod-tolerance 0 --out " + out.string(),
                             dir / "log.txt"),
            0)
      << readText(dir / "log.txt");
  const json camera = json::parse(readText(out / "camera.json"));
  const glm::dmat4 inverse = glm::inverse(viewProjOf(camera));
  Result<geo::SceneFrame> frame = geo::SceneFrame::fromCrs(
      camera["crs_wkt"].get<std::string>(),
      {camera["origin"][0].get<double>(), camera["origin"][1].get<double>(), camera["origin"][2].get<double>()});
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(frame->epsg(), 32725);
  const json stats = json::parse(readText(out / "stats.json"));
  Result<geo::Raster> source = geo::readRaster(dem);
  ASSERT_TRUE(source.ok());
  const geo::RasterInfo& si = source->info;
  Result<geo::CrsTransform> toSource = frame->transformTo(si.crsWkt);
  ASSERT_TRUE(toSource.ok());
  Result<gfx::ImageFloat> depth = gfx::readImageFloat((out / "depth.tiff").string());
  ASSERT_TRUE(depth.ok());
  std::size_t terrain = 0, outside = 0, compared = 0;
  double sum = 0.0, worst = 0.0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const float d = depth->pixels[static_cast<std::size_t>(y * kWidth + x)];
      if (!(d > 0.0F)) continue;
      ++terrain;
      const glm::dvec4 h =
          inverse * glm::dvec4((x + 0.5) / kWidth * 2.0 - 1.0, 1.0 - (y + 0.5) / kHeight * 2.0, d, 1.0);
      const glm::dvec3 p = glm::dvec3(h) / h.w;
      const glm::dvec2 ll = *toSource->transform(glm::dvec2(frame->frameToProjected(p)));
      const glm::dvec2 uv = *si.geoTransform.crsToPixel(ll) - glm::dvec2(0.5);
      const int c0 = static_cast<int>(std::floor(uv.x)), r0 = static_cast<int>(std::floor(uv.y));
      double lo = 1e30, hi = -1e30;
      for (int r = r0 - 2; r <= r0 + 3; ++r) {
        for (int c = c0 - 2; c <= c0 + 3; ++c) {
          if (c < 0 || r < 0 || c >= si.width || r >= si.height || std::isnan(source->at(c, r))) continue;
          lo = std::min(lo, static_cast<double>(source->at(c, r)));
          hi = std::max(hi, static_cast<double>(source->at(c, r)));
        }
      }
      if (p.z < lo - kSurfaceTolerance || p.z > hi + kSurfaceTolerance) {
        if (outside++ < 5)
          ADD_FAILURE() << "pixel " << x << ", " << y << " at " << p.z << " m, posts " << lo << " .. " << hi;
      }
      if (c0 < 0 || r0 < 0 || c0 + 1 >= si.width || r0 + 1 >= si.height) continue;
      const double fx = uv.x - c0, fy = uv.y - r0;
      const double s = (source->at(c0, r0) * (1 - fx) + source->at(c0 + 1, r0) * fx) * (1 - fy) +
                       (source->at(c0, r0 + 1) * (1 - fx) + source->at(c0 + 1, r0 + 1) * fx) * fy;
      if (std::isnan(s)) continue;
      sum += (p.z - s) * (p.z - s);
      worst = std::max(worst, std::abs(p.z - s));
      ++compared;
    }
  }
  const double rms = std::sqrt(sum / static_cast<double>(std::max<std::size_t>(compared, 1)));
  std::printf(
      "Olinda in lon/lat through overlay_render: %zu terrain pixels, %zu compared, RMS %.2f m, worst %.2f m "
      "from the source surface\n",
      terrain, compared, rms, worst);
  EXPECT_GT(terrain, static_cast<std::size_t>(kWidth * kHeight / 4));
  EXPECT_GT(compared, terrain * 9 / 10);
  EXPECT_EQ(outside, 0u);
  EXPECT_LT(rms, 3.0);
  EXPECT_GT(stats["layers"][0]["drawn_features"].get<int>(), 400) << stats.dump(1);
}

TEST(OverlayRenderCli, Latin1TextReachesTheOutputsReadable) {
  // A scene in a folder whose name is Latin-1 ("São" with the byte 0xE3), and a Shapefile layer
  // without .cpg whose attribute is Latin-1: the program finishes (it aborted in nlohmann's dump),
  // every JSON output is valid, and the attribute arrives in UTF-8 in the exported features.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("latin1_" + std::to_string(getpid()) + "_S\xe3o");
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(kSamples + "/olinda/olinda_dem_utm25s.tif", dir / "dem.tif");
  writeUndeclaredEncodingShapefile((dir / "bairros.shp").string(), 32725,
                                   {{{290000, 9112000}, {297500, 9112000}, {297500, 9119500}, {290000, 9119500}}},
                                   "S\xe3o Paulo");
  const json scene = {{"terrain", {{"dem", "dem.tif"}}},
                      {"layers", {{{"name", "bairros"}, {"kind", "polygon"}, {"source", "bairros.shp"}}}}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const json lasso = {
      {"lassos", {{{"op", "single"}, {"points", {{0, 0}, {kWidth, 0}, {kWidth, kHeight}, {0, kHeight}}}}}}};
  std::ofstream(dir / "lasso.json") << lasso.dump(1);
  const fs::path out = dir / "out";
  const int status = runOverlayRender("--scene '" + (dir / "scene.json").string() + "' --lasso '" +
                                          (dir / "lasso.json").string() + "' --width " + std::to_string(kWidth) +
                                          " --height " + std::to_string(kHeight) + " --out '" + out.string() + "'",
                                      dir / "log.txt");
  ASSERT_EQ(status, 0) << readText(dir / "log.txt");
  const json stats = json::parse(readText(out / "stats.json"));  // throws (fails) if not valid
  EXPECT_EQ(stats["layers"][0]["drawn_features"].get<int>(), 1);
  EXPECT_TRUE(json::accept(readText(out / "camera.json")));
  const std::string selected = readText(out / "selected_features.json");
  EXPECT_NE(selected.find("S\xc3\xa3o Paulo"), std::string::npos) << selected;
  // And in the layer's own export (the source's CRS and attribute types).
  EXPECT_NE(readText(out / "selected_bairros.geojson").find("S\xc3\xa3o Paulo"), std::string::npos);
  EXPECT_NE(readText(dir / "log.txt").find("read as Latin-1"), std::string::npos);
}

TEST(OverlayRenderCli, MaskBitsStayWithTheSceneFilesLayersWhenOneFailsToLoad) {
  // Layer 0's file does not exist; layer 1 (the tracts) keeps bit 1 in mask.png and stats.json.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("bits_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json scene = {{"terrain", {{"dem", kSamples + "/olinda/olinda_dem_utm25s.tif"}}},
                      {"layers",
                       {{{"name", "missing"}, {"kind", "polygon"}, {"source", "missing.geojson"}},
                        {{"name", "tracts"}, {"kind", "polygon"}, {"source", kSamples + "/olinda/olinda1.shp"}}}}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  ASSERT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                                 " --height " + std::to_string(kHeight) + " --out " + (dir / "out").string(),
                             dir / "log.txt"),
            0)
      << readText(dir / "log.txt");
  EXPECT_NE(readText(dir / "log.txt").find("missing.geojson"), std::string::npos);
  const json stats = json::parse(readText(dir / "out" / "stats.json"));
  ASSERT_EQ(stats["layers"].size(), 1u);
  EXPECT_EQ(stats["layers"][0]["name"], "tracts");
  EXPECT_EQ(stats["layers"][0]["mask_bit"], 1);
  Result<gfx::Image8> mask = gfx::readImage8((dir / "out" / "mask.png").string());
  ASSERT_TRUE(mask.ok());
  std::size_t bit0 = 0, bit1 = 0;
  for (const std::uint8_t m : mask->pixels) {
    bit0 += (m & 1u) != 0 ? 1u : 0u;
    bit1 += (m & 2u) != 0 ? 1u : 0u;
  }
  EXPECT_EQ(bit0, 0u);
  EXPECT_GT(bit1, 1000u);
  EXPECT_EQ(stats["layers"][0]["covered_pixels"].get<std::size_t>(), bit1);
}

/// How many features a vector file holds as its author wrote it: the entries of a GeoJSON's
/// "features" array (objects or not), else OGR's count of the first layer.
std::size_t featuresInSource(const std::string& path) {
  if (path.size() > 8 && path.substr(path.size() - 8) == ".geojson") {
    // The messy files hold NaN and Infinity, which GDAL reads and JSON does not: counted as 0.
    std::string text = readText(path);
    for (const std::string token : {"NaN", "Infinity", "1e999"}) {
      for (std::size_t at = text.find(token); at != std::string::npos; at = text.find(token, at)) {
        text.replace(at, token.size(), "0");
      }
    }
    return json::parse(text)["features"].size();
  }
  GDALAllRegister();
  GDALDataset* ds = GDALDataset::FromHandle(GDALOpenEx(path.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr));
  if (ds == nullptr) return 0;
  const auto n = static_cast<std::size_t>(ds->GetLayer(0)->GetFeatureCount(TRUE));
  GDALClose(GDALDataset::ToHandle(ds));
  return n;
}

TEST(OverlayRenderCli, EveryFeatureOfEveryMessyFileIsAccountedFor) {
  // Every messy test file as a layer (polygon and line layers both, so each geometry meets a
  // layer that does not draw it): in stats.json, for every layer, the features read from the
  // source = drawn + skipped + nothing to draw, and "features" is what the file holds.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("identity_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string data = STENCIL_GIS_TEST_DATA_DIR;
  writeUndeclaredEncodingShapefile((dir / "latin1.shp").string(), 32725,
                                   {{{292000, 9114000}, {295500, 9114000}, {295500, 9117500}},
                                    {{292000, 9114000}, {292000, 9114000}, {292000, 9114000}}},
                                   "S\xe3o Paulo");
  std::vector<std::string> files;
  for (const char* name :
       {"messy_layer.geojson", "messy_roads.geojson", "broken_features.geojson", "holes_and_multipolygons.geojson",
        "long_edge_crs84.geojson", "empty_layer.geojson", "non_objects_and_invalid_polygons.geojson"}) {
    files.push_back(data + "/" + name);
  }
  files.push_back((dir / "latin1.shp").string());
  json layers = json::array();
  for (const std::string& f : files) {
    for (const char* kind : {"polygon", "line"}) {
      layers.push_back({{"name", fs::path(f).stem().string() + " " + kind}, {"kind", kind}, {"source", f}});
    }
  }
  const json scene = {{"terrain", {{"dem", kSamples + "/olinda/olinda_dem_utm25s.tif"}}}, {"layers", layers}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  ASSERT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                                 " --height " + std::to_string(kHeight) + " --out " + (dir / "out").string(),
                             dir / "log.txt"),
            0)
      << readText(dir / "log.txt");
  const json stats = json::parse(readText(dir / "out" / "stats.json"));
  ASSERT_EQ(stats["layers"].size(), 2 * files.size());
  for (std::size_t i = 0; i < stats["layers"].size(); ++i) {
    const json& l = stats["layers"][i];
    const std::size_t read = featuresInSource(files[i / 2]);
    SCOPED_TRACE(l["name"].get<std::string>());
    EXPECT_EQ(l["features"].get<std::size_t>(), read) << l.dump(1);
    EXPECT_EQ(l["drawn_features"].get<std::size_t>() + l["skipped_features"].get<std::size_t>() +
                  l["features_with_nothing_to_draw"].get<std::size_t>(),
              read)
        << l.dump(1);
  }
}

TEST(OverlayRenderCli, BadArgumentsAndFilesGiveClearErrors) {
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / "cli";
  fs::create_directories(dir);
  EXPECT_EQ(runOverlayRender("--width", dir / "a.txt"), 2);
  EXPECT_NE(readText(dir / "a.txt").find("usage"), std::string::npos);
  EXPECT_EQ(runOverlayRender("--scene x.json --out " + dir.string() + " --msaa lots", dir / "b.txt"), 2);
  EXPECT_EQ(runOverlayRender("--scene /nonexistent/scene.json --out " + dir.string(), dir / "c.txt"), 1);
  EXPECT_NE(readText(dir / "c.txt").find("/nonexistent/scene.json"), std::string::npos);
  EXPECT_EQ(runOverlayRender("--help", dir / "d.txt"), 0);
}

TEST(OverlayRenderCli, MessyLayersAreCountedNamedAndTheRestDraws) {
  // A polygon layer and a road layer full of problems over the Olinda DEM: what can be drawn is
  // drawn; every feature left out is named with its file, layer and problem; the counts are in
  // the log and in stats.json.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("messy_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string data = STENCIL_GIS_TEST_DATA_DIR;
  const json scene = {{"name", "messy"},
                      {"terrain", {{"dem", kSamples + "/olinda/olinda_dem_utm25s.tif"}}},
                      {"camera",
                       {{"eye", {{"lon", -34.856}, {"lat", -8.024}, {"h", 1500.0}}},
                        {"target", {{"lon", -34.856}, {"lat", -8.006}, {"h", 0.0}}},
                        {"fov_y_deg", 40.0}}},
                      {"layers",
                       {{{"name", "messy areas"}, {"kind", "polygon"}, {"source", data + "/messy_layer.geojson"}},
                        {{"name", "messy roads"},
                         {"kind", "line"},
                         {"source", data + "/messy_roads.geojson"},
                         {"style", {{"width_m", 6.0}, {"width_attribute", "width_m"}}}}}}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const int status =
      runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                           " --height " + std::to_string(kHeight) + " --out " + dir.string(),
                       dir / "log.txt");
  const std::string log = readText(dir / "log.txt");
  ASSERT_EQ(status, 0) << log;
  const json stats = json::parse(readText(dir / "stats.json"));
  ASSERT_EQ(stats["layers"].size(), 2u);
  const json& areas = stats["layers"][0];
  const json& roads = stats["layers"][1];
  // Areas: NaN vertex and the ring collinear in lon/lat (no area: it would be a sliver once
  // projected) left out when read, outside the DEM (nothing to draw); the square, the bow-tie
  // (even-odd, with a warning) and the hole touching its shell are drawn.
  EXPECT_EQ(areas["features"].get<int>(), 6) << areas.dump(1);
  EXPECT_EQ(areas["skipped_when_read"].get<int>(), 2);
  EXPECT_EQ(areas["skipped_when_built"].get<int>(), 0);
  EXPECT_EQ(areas["features_with_nothing_to_draw"].get<int>(), 1);
  EXPECT_EQ(areas["drawn_features"].get<int>(), 3);
  EXPECT_GT(areas["covered_pixels"].get<int>(), 100);
  // Roads: an infinite coordinate (read), a 1e20 m width (built), outside the DEM (nothing to
  // draw); the hairpin, the road of unusable width (drawn at the layer's 6 m, with a warning) and
  // the 1 cm road with a zero-length segment are drawn.
  EXPECT_EQ(roads["features"].get<int>(), 6) << roads.dump(1);
  EXPECT_EQ(roads["skipped_when_read"].get<int>(), 1);
  EXPECT_EQ(roads["skipped_when_built"].get<int>(), 1);
  EXPECT_EQ(roads["features_with_nothing_to_draw"].get<int>(), 1);
  EXPECT_EQ(roads["drawn_features"].get<int>(), 3);
  EXPECT_GT(roads["covered_pixels"].get<int>(), 10);
  // Each problem names the file, the layer and the feature.
  std::size_t named = 0;
  for (const json& d : stats["diagnostics"]) {
    const std::string text = d.get<std::string>();
    if (text.find("features skipped for errors") != std::string::npos) continue;  // the per-layer counts
    EXPECT_NE(text.find("/tests/data/messy_"), std::string::npos) << text;
    EXPECT_NE(text.find("layer 'messy "), std::string::npos) << text;
    EXPECT_NE(text.find("feature "), std::string::npos) << text;
    ++named;
  }
  // 2 + 2 skipped, 2 nothing to draw, 1 width, 1 bow-tie drawn by the even-odd rule
  EXPECT_EQ(named, 8u) << stats["diagnostics"].dump(1);
  EXPECT_EQ(stats["errors"].get<int>(), 4);
  for (const char* summary : {"layer 'messy areas': 2 of 6 features skipped for errors (2 when read, 0 when built), 1 "
                              "with nothing to draw",
                              "layer 'messy roads': 2 of 6 features skipped for errors (1 when read, 1 when built), 1 "
                              "with nothing to draw"}) {
    EXPECT_NE(log.find(summary), std::string::npos) << summary << "\n" << log;
  }
}

/// A diagnostic line of the log ("[error] error: …"), with how many messages it stands for: the
/// count of a grouped line ("…: 500 features: …", "…: 7 messages about 3 features: …", "… (2
/// times)"), else 1.
struct LoggedKind {
  std::string line;
  std::size_t count = 1;
};

std::size_t countIn(const std::string& text) {
  std::string digits;
  for (const char c : text) {
    if (c != ',') digits += c;
  }
  return static_cast<std::size_t>(std::stoull(digits));
}

/// Whether `line` starts as the log writes a diagnostic: "[level] level: ".
bool isDiagnosticLine(const std::string& line) {
  for (const char* level : {"info", "warning", "error"}) {
    for (const char* said : {"info", "warning", "error"}) {
      if (line.rfind(std::string("[") + level + "] " + said + ": ", 0) == 0) return true;
    }
  }
  return false;
}

/// The digits and commas of `text` from `at` on (empty when there are none).
std::string numberAt(const std::string& text, std::size_t at) {
  std::size_t end = at;
  while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) != 0 || text[end] == ',')) ++end;
  return text.substr(at, end - at);
}

/// The count of a grouped line: ": N features: ", ": N messages about M feature(s): " or a
/// closing "(N times)"; none for a line that stands for one message. (Scanned by hand: GCC 12's
/// <regex> does not build warning-free under the sanitizers.)
std::optional<std::size_t> groupCount(const std::string& line) {
  for (std::size_t at = line.find(": "); at != std::string::npos; at = line.find(": ", at + 1)) {
    const std::string n = numberAt(line, at + 2);
    if (n.empty() || std::isdigit(static_cast<unsigned char>(n.front())) == 0) continue;
    const std::string rest = line.substr(at + 2 + n.size());
    if (rest.rfind(" features: ", 0) == 0) return countIn(n);
    if (rest.rfind(" messages about ", 0) == 0) {
      const std::string m = numberAt(rest, 16);
      const std::string after = rest.substr(16 + m.size());
      if (!m.empty() && (after.rfind(" features: ", 0) == 0 || after.rfind(" feature: ", 0) == 0)) return countIn(n);
    }
  }
  const std::string times = " times)";
  if (line.size() > times.size() && line.compare(line.size() - times.size(), times.size(), times) == 0) {
    const std::size_t open = line.rfind('(');
    if (open != std::string::npos) {
      const std::string n = numberAt(line, open + 1);
      if (!n.empty() && open + 1 + n.size() == line.size() - times.size()) return countIn(n);
    }
  }
  return std::nullopt;
}

std::vector<LoggedKind> loggedKinds(const std::string& log) {
  std::vector<LoggedKind> kinds;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) {
    if (!isDiagnosticLine(line)) continue;
    kinds.push_back({line, groupCount(line).value_or(1)});
  }
  return kinds;
}

TEST(OverlayRenderCli, RepeatedMessagesAreOneLineEachWithTheCountsOfStatsJson) {
  // 500 one-point lines, 7 lines with an infinite coordinate (at vertex 0, 1 or 2), 3 features
  // without geometry and 4 lines beyond the DEM among 20 good lines: the log says each kind once
  // with its count and first features, the counts are stats.json's, and stats.json keeps every
  // message.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("grouped_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ostringstream features;
  auto feature = [&, first = true](int id, const std::string& geometry) mutable {
    features << (first ? "" : ",\n") << R"({"type": "Feature", "id": )" << id << R"(, "properties": {}, "geometry": )"
             << geometry << "}";
    first = false;
  };
  auto line = [](const std::vector<std::string>& points) {
    std::string g = R"({"type": "LineString", "coordinates": [)";
    for (std::size_t i = 0; i < points.size(); ++i) g += (i > 0 ? ", " : "") + points[i];
    return g + "]}";
  };
  auto point = [](double lon, double lat) {
    char text[64];
    std::snprintf(text, sizeof text, "[%.6f, %.6f]", lon, lat);
    return std::string(text);
  };
  for (int k = 0; k < 20; ++k) {
    feature(1 + k, line({point(-34.860, -8.030 + 0.002 * k), point(-34.850, -8.030 + 0.002 * k)}));
  }
  for (int k = 0; k < 500; ++k) {
    const std::string p = point(-34.870 + 0.00005 * k, -8.010);
    feature(1000 + k, line({p, p}));
  }
  for (int k = 0; k < 7; ++k) {
    std::vector<std::string> points{point(-34.860, -8.000), point(-34.855, -8.001), point(-34.850, -8.000)};
    points[static_cast<std::size_t>(k % 3)] = "[-34.855, 1e999]";
    feature(2000 + k, line(points));
  }
  for (int k = 0; k < 3; ++k) feature(3000 + k, "null");
  for (int k = 0; k < 4; ++k) feature(4000 + k, line({point(-30.0, -8.0 - 0.01 * k), point(-30.01, -8.0 - 0.01 * k)}));
  std::ofstream(dir / "rivers.geojson")
      << R"({"type": "FeatureCollection", "name": "rivers", "crs": {"type": "name", "properties": {"name": )"
      << R"("urn:ogc:def:crs:OGC:1.3:CRS84"}}, "features": [)"
      << "\n"
      << features.str() << "\n]}\n";
  const json scene = {{"terrain", {{"dem", kSamples + "/olinda/olinda_dem_utm25s.tif"}}},
                      {"layers",
                       {{{"name", "rivers"},
                         {"kind", "line"},
                         {"source", (dir / "rivers.geojson").string()},
                         {"style", {{"width_m", 8.0}}}}}}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const int status =
      runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                           " --height " + std::to_string(kHeight) + " --out " + (dir / "out").string(),
                       dir / "log.txt");
  const std::string log = readText(dir / "log.txt");
  ASSERT_EQ(status, 0) << log;
  const json stats = json::parse(readText(dir / "out" / "stats.json"));
  ASSERT_EQ(stats["layers"].size(), 1u);
  EXPECT_EQ(stats["layers"][0]["features"].get<int>(), 534);
  EXPECT_EQ(stats["layers"][0]["drawn_features"].get<int>(), 20);

  const std::vector<LoggedKind> kinds = loggedKinds(log);
  std::size_t logged = 0;
  for (const LoggedKind& k : kinds) logged += k.count;
  EXPECT_EQ(logged, stats["diagnostics"].size()) << "every message of stats.json is counted in the log once\n" << log;
  EXPECT_LT(kinds.size(), 12u) << log;
  // Per kind: one line of the log, whose count is how many of stats.json's messages are of it.
  const struct {
    const char* text;
    std::size_t expected;
    const char* firstFeatures;
  } expected[] = {{"line has 1 distinct point(s)", 500, "(features 1000, 1001, 1002, 1003, 1004, …)"},
                  {"non-finite coordinate at vertex", 7, "(features 2000, 2001, 2002, 2003, 2004, …)"},
                  {"has no geometry", 3, "(features 3000, 3001, 3002)"},
                  {"lies outside the terrain", 4, "(features 4000, 4001, 4002, 4003)"}};
  for (const auto& e : expected) {
    SCOPED_TRACE(e.text);
    std::size_t inStats = 0;
    for (const json& d : stats["diagnostics"])
      inStats += d.get<std::string>().find(e.text) != std::string::npos ? 1u : 0u;
    EXPECT_EQ(inStats, e.expected) << stats["diagnostics"].dump(1);
    std::vector<const LoggedKind*> lines;
    for (const LoggedKind& k : kinds) {
      if (k.line.find(e.text) != std::string::npos) lines.push_back(&k);
    }
    ASSERT_EQ(lines.size(), 1u) << log;
    EXPECT_EQ(lines[0]->count, inStats) << lines[0]->line;
    EXPECT_NE(lines[0]->line.find("rivers.geojson: layer 'rivers': " + countText(inStats) + " features: "),
              std::string::npos)
        << lines[0]->line;
    EXPECT_NE(lines[0]->line.find(e.firstFeatures), std::string::npos) << lines[0]->line;
  }
  // The vertex differs from line to line: said as N.
  EXPECT_NE(log.find("line: non-finite coordinate at vertex N (features"), std::string::npos) << log;
}

TEST(OverlayRenderCli, MsaaAndCameraFileRoundTrip) {
  // The camera.json of one run is a valid --camera for the next: same view, same image size.
  const fs::path first = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / "msaa_first";
  const fs::path second = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / "msaa_second";
  const std::string scene = "--scene " + kSamples + "/olinda/scene.json --width 96 --height 64";
  ASSERT_EQ(runOverlayRender(scene + " --out " + first.string(), first.string() + ".log"), 0);
  ASSERT_EQ(
      runOverlayRender(scene + " --msaa 4 --camera " + (first / "camera.json").string() + " --out " + second.string(),
                       second.string() + ".log"),
      0)
      << readText(second.string() + ".log");
  const json a = json::parse(readText(first / "camera.json"));
  const json b = json::parse(readText(second / "camera.json"));
  for (std::size_t i = 0; i < 16; ++i) EXPECT_NEAR(a["view"][i].get<double>(), b["view"][i].get<double>(), 1e-6);
  EXPECT_EQ(json::parse(readText(second / "stats.json"))["msaa"].get<int>(), 4);
}

TEST(OverlayRenderLasso, SelectionImageFeaturesAndExportsAgreeWithTheTwin) {
  // Lassos on the Olinda sample drawn with the run's own camera (Single, Or, Subtract, one
  // broken entry): selection.png against the CPU twin on depth.tiff and camera.json, the
  // logical selection in stats.json against the exported GeoJSON files.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("lasso_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json lassos = {
      {"highlight", {{"color", "#ff2010"}, {"opacity", 0.5}}},
      {"lassos", json::array({{{"op", "single"}, {"points", {{60, 60}, {150, 50}, {170, 120}, {95, 140}, {120, 95}}}},
                              {{"op", "or"}, {"points", {{170, 120}, {220, 125}, {205, 170}}}},
                              {{"op", "subtract"}, {"points", {{110, 80}, {135, 80}, {135, 105}, {110, 105}}}},
                              {{"op", "or"}, {"points", {{10, 10}, {20, 10}}}},
                              "not a lasso",
                              {{"op", "or"}, {"points", {{10, 10}, {20, 20}, {30, 30}}}}})}};
  { std::ofstream(dir / "lasso.json") << lassos.dump(1); }
  const std::string args = "--scene " + kSamples + "/olinda/scene.json --width " + std::to_string(kWidth) +
                           " --height " + std::to_string(kHeight) + " --lasso " + (dir / "lasso.json").string();
  ASSERT_EQ(runOverlayRender(args + " --out " + (dir / "out").string(), dir / "log.txt"), 0)
      << readText(dir / "log.txt");
  EXPECT_NE(readText(dir / "log.txt").find("lasso 4"), std::string::npos) << "the broken lasso is named";
  // Numbered as the file's entries, counting the ones left out, and with the file's name.
  EXPECT_NE(readText(dir / "log.txt").find((dir / "lasso.json").string() + ": feature lasso 6: polygon has no area"),
            std::string::npos)
      << readText(dir / "log.txt");
  const fs::path out = dir / "out";
  const gfx::Image8 selection = *gfx::readImage8((out / "selection.png").string());
  ASSERT_EQ(selection.width, kWidth);
  ASSERT_EQ(selection.channels, 1);
  const gfx::ImageFloat depth = *gfx::readImageFloat((out / "depth.tiff").string());
  const json camera = json::parse(readText(out / "camera.json"));
  const glm::dmat4 viewProj = viewProjOf(camera);
  std::vector<overlay::SelectionStep> steps;
  for (std::size_t k = 0; k < 3; ++k) {
    overlay::SelectionStep s;
    s.op = *overlay::parseSelectionOp(lassos["lassos"][k]["op"].get<std::string>());
    for (const json& p : lassos["lassos"][k]["points"])
      s.lasso.points.emplace_back(p[0].get<double>(), p[1].get<double>());
    s.lasso.viewProj = viewProj;
    s.lasso.width = kWidth;
    s.lasso.height = kHeight;
    steps.push_back(std::move(s));
  }
  const overlay::DepthImage image{kWidth, kHeight, depth.pixels, viewProj};
  const std::vector<std::uint8_t> twin = overlay::selectionMask(image, steps);
  std::size_t selected = 0, wrong = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y * kWidth + x);
      EXPECT_TRUE(selection.pixels[i] == 0 || selection.pixels[i] == 255);
      selected += twin[i];
      if ((selection.pixels[i] != 0) == (twin[i] != 0)) continue;
      // Only where the twin itself changes within a pixel (a lasso edge through the pixel).
      bool edge = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = std::clamp(x + dx, 0, kWidth - 1), v = std::clamp(y + dy, 0, kHeight - 1);
          edge = edge || twin[static_cast<std::size_t>(v * kWidth + u)] != twin[i];
        }
      EXPECT_TRUE(edge) << "pixel (" << x << ", " << y << ") differs from the twin away from a lasso edge";
      ++wrong;
    }
  }
  EXPECT_GT(selected, 3000u);
  EXPECT_LE(wrong, selected / 200);
  const json stats = json::parse(readText(out / "stats.json"));
  const json& s = stats["selection"];
  EXPECT_EQ(stats["gl_errors"].get<int>(), 0);
  EXPECT_EQ(s["steps"].get<int>(), 4);  // the collinear lasso is a step that selects nothing
  EXPECT_EQ(s["pixels_differing_from_cpu_twin"].get<std::size_t>(), wrong);
  EXPECT_EQ(s["differing_away_from_edges"].get<std::size_t>(), 0u) << s.dump(1);
  EXPECT_GT(s["dem_posts"]["selected"].get<int>(), 0);
  // Every feature the stats list is exported, in its layer's file (original CRS) and in the
  // combined RFC 7946 file, with its attributes.
  const json combined = json::parse(readText(out / "selected_features.json"));
  std::size_t total = 0;
  for (const json& layer : s["layers"]) {
    const std::size_t n = layer["selected"].get<std::size_t>();
    EXPECT_GT(n, 0u) << layer["name"];
    EXPECT_LT(layer["fully_inside"].get<std::size_t>(), n);
    EXPECT_GT(layer["fully_inside"].get<std::size_t>(), 0u);
    total += n;
    const json own = json::parse(readText(out / layer["file"].get<std::string>()));
    ASSERT_EQ(own["features"].size(), n) << layer["file"];
    for (std::size_t k = 0; k < n; ++k) {
      EXPECT_EQ(own["features"][k]["id"].get<std::int64_t>(), layer["features"][k]["fid"].get<std::int64_t>());
      EXPECT_EQ(own["features"][k]["properties"]["selection_fully_inside"].get<int>() == 1,
                layer["features"][k]["fully_inside"].get<bool>());
    }
  }
  ASSERT_EQ(combined["features"].size(), total);
  EXPECT_EQ(combined["features"][0]["properties"]["selection_layer"], "census tracts");
  EXPECT_TRUE(combined["features"][0]["properties"].contains("CD_GEOCODI"));
  EXPECT_TRUE(json::parse(readText(out / "selected_census_tracts.geojson")).contains("crs"))
      << "the tracts' own CRS (GRS 1980 geographic) is kept";

  // With MSAA the selection is refused (drawn single-sampled only); a file that is not JSON fails.
  EXPECT_EQ(runOverlayRender(args + " --msaa 4 --out " + (dir / "msaa").string(), dir / "msaa.txt"), 2);
  { std::ofstream(dir / "bad.json") << "{ lassos: "; }
  EXPECT_EQ(runOverlayRender("--scene " + kSamples + "/olinda/scene.json --width 64 --height 48 --lasso " +
                                 (dir / "bad.json").string() + " --out " + (dir / "bad").string(),
                             dir / "bad.txt"),
            1);
  EXPECT_NE(readText(dir / "bad.txt").find("bad.json"), std::string::npos);
}

TEST(OverlayRenderAnalysis, OverlapMatchesTheLayerMaskAndVolumesAreClosed) {
  // --overlap "census tracts,streets" (And) and --open-volumes on the sample without the tracts'
  // outline: overlap.png is exactly where both layers' bits are set in mask.png (the ordinary
  // layer passes on the same depth), agrees with the CPU reference away from edges (stats), and
  // no layer's volumes are open.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("analysis_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  json description = olindaScene();
  for (json& layer : description["layers"]) layer["style"].erase("outline_width_m");
  { std::ofstream(dir / "scene.json") << description.dump(1); }
  const std::string scene = "--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                            " --height " + std::to_string(kHeight);
  ASSERT_EQ(
      runOverlayRender(scene + " --overlap \"census tracts,streets\" --open-volumes --out " + (dir / "out").string(),
                       dir / "log.txt"),
      0)
      << readText(dir / "log.txt");
  const fs::path out = dir / "out";
  const gfx::Image8 overlap = *gfx::readImage8((out / "overlap.png").string());
  const gfx::Image8 mask = *gfx::readImage8((out / "mask.png").string());
  const gfx::Image8 open = *gfx::readImage8((out / "open_volumes.png").string());
  ASSERT_EQ(overlap.width, kWidth);
  ASSERT_EQ(mask.pixels.size(), overlap.pixels.size());
  std::size_t both = 0, shown = 0, differing = 0;
  for (std::size_t i = 0; i < overlap.pixels.size(); ++i) {
    const bool inBoth = (mask.pixels[i] & 3) == 3;
    both += inBoth ? 1u : 0u;
    shown += overlap.pixels[i] != 0 ? 1u : 0u;
    differing += inBoth != (overlap.pixels[i] != 0) ? 1u : 0u;
    EXPECT_EQ(open.pixels[i], 0);
  }
  EXPECT_GT(both, 50u);
  EXPECT_EQ(differing, 0u) << both << " pixels in both layers' masks, " << shown << " in overlap.png";
  const json stats = json::parse(readText(out / "stats.json"));
  const json& s = stats["overlap"];
  EXPECT_EQ(s["op"], "and");
  EXPECT_EQ(s["pixels"].get<std::size_t>(), shown);
  EXPECT_EQ(s["both_pixels"].get<std::size_t>(), shown);
  EXPECT_EQ(s["differing_away_from_edges"].get<std::size_t>(), 0u);
  // On edges only (the count above away from them is 0): generalised tiles draw outlines within
  // half a pixel of the source's, which moves edge pixels (about 1.3 % of them here).
  EXPECT_LE(s["pixels_differing_from_cpu_reference"].get<std::size_t>(),
            2 + (s["a_pixels"].get<std::size_t>() + s["b_pixels"].get<std::size_t>()) / 40);
  EXPECT_EQ(stats["open_volumes"]["open_pixels"].get<std::size_t>(), 0u);
  EXPECT_EQ(stats["open_volumes"]["layers"].size(), 2u);
  EXPECT_EQ(stats["gl_errors"].get<std::size_t>(), 0u);

  // A layer that is not in the scene, and an unknown operator: usage errors naming the choices.
  EXPECT_EQ(runOverlayRender(scene + " --overlap tracts,streets --out " + (dir / "bad").string(), dir / "bad.txt"), 2);
  EXPECT_NE(readText(dir / "bad.txt").find("'tracts'"), std::string::npos);
  EXPECT_NE(readText(dir / "bad.txt").find("census tracts, streets"), std::string::npos);
  EXPECT_EQ(
      runOverlayRender(scene + " --overlap a,b --overlap-op nand --out " + (dir / "bad").string(), dir / "op.txt"), 2);
  EXPECT_NE(readText(dir / "op.txt").find("and, or, xor, subtract"), std::string::npos);
  // The deferred lookup draws no polyhedra to analyse: refused, saying why, not an empty answer.
  EXPECT_EQ(runOverlayRender(scene + " --method deferred --open-volumes --out " + (dir / "bad").string(),
                             dir / "deferred.txt"),
            2);
  EXPECT_NE(readText(dir / "deferred.txt").find("looks the layers up"), std::string::npos)
      << readText(dir / "deferred.txt");
}

TEST(OverlayRenderLasso, TheDeferredLookupLeavesTheSelectionAsItIs) {
  // The lasso selects with volumes and footprints of its own: with --method deferred and auto the
  // selection image and the selected features are those of --method stencil-tiles (lines at least
  // min_width_px wide in all three).
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("lasso_methods_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const json lassos = {
      {"lassos", json::array({{{"op", "single"}, {"points", {{40, 40}, {180, 30}, {200, 140}, {70, 150}}}}})}};
  { std::ofstream(dir / "lasso.json") << lassos.dump(1); }
  const std::string args = "--scene " + kSamples + "/olinda/scene.json --width " + std::to_string(kWidth) +
                           " --height " + std::to_string(kHeight) + " --lasso " + (dir / "lasso.json").string();
  for (const char* method : {"stencil", "deferred", "stencil-tiles", "auto"}) {
    ASSERT_EQ(runOverlayRender(args + " --method " + method + " --out " + (dir / method).string(), dir / "log.txt"), 0)
        << method << ": " << readText(dir / "log.txt");
    // The lookup's block says what it drew and holds (both frames write it: the globe's test
    // below); the others have none.
    const json stats = json::parse(readText(dir / method / "stats.json"));
    if (std::string(method) == "deferred") {
      EXPECT_EQ(stats["deferred"]["layers"].get<std::size_t>(), 3U) << stats.dump(1);
      EXPECT_GT(stats["deferred"]["gpu_bytes"].get<std::size_t>(), 1'000'000U) << stats.dump(1);
    } else if (std::string(method) != "auto") {
      EXPECT_FALSE(stats.contains("deferred")) << method;
    }
  }
  for (const auto& [a, b] : {std::pair{"stencil-tiles", "deferred"}, std::pair{"stencil-tiles", "auto"}}) {
    SCOPED_TRACE(std::string(a) + " against " + b);
    const json fa = json::parse(readText(dir / a / "selected_features.json"));
    const json fb = json::parse(readText(dir / b / "selected_features.json"));
    EXPECT_GT(fa["features"].size(), 10u);
    EXPECT_EQ(fa, fb);
    const gfx::Image8 ia = *gfx::readImage8((dir / a / "selection.png").string());
    const gfx::Image8 ib = *gfx::readImage8((dir / b / "selection.png").string());
    EXPECT_EQ(ia.pixels, ib.pixels);
  }
}

/// Every position (lon, lat) of a GeoJSON geometry's coordinates, at any depth of nesting.
void positionsOf(const json& coordinates, std::vector<glm::dvec2>& out) {
  if (coordinates.is_array() && coordinates.size() >= 2 && coordinates[0].is_number()) {
    out.emplace_back(coordinates[0].get<double>(), coordinates[1].get<double>());
    return;
  }
  for (const json& c : coordinates) positionsOf(c, out);
}

/// The exports of a lasso on the globe (overlay_render --lasso on Olinda's scene `scene`) in
/// `out`, against its stats.json's "selection" block: selected_<layer>.geojson per layer holds
/// exactly the listed features (read through GDAL, ids the listed fids, each the source's feature
/// of that FID with its attributes) and selected_features.json all of them in WGS 84 lon/lat,
/// within Olinda's box.
void expectGlobeExport(const fs::path& out, const json& selection, const json& scene) {
  const json combined = json::parse(readText(out / "selected_features.json"));
  EXPECT_EQ(combined["type"], "FeatureCollection");
  EXPECT_FALSE(combined.contains("crs")) << "RFC 7946: WGS 84 lon/lat, no crs member";
  std::size_t total = 0;
  std::map<std::string, std::set<std::int64_t>> listed;  // per layer name: the fids stats.json lists
  GDALAllRegister();
  for (std::size_t l = 0; l < selection["layers"].size(); ++l) {
    const json& layer = selection["layers"][l];
    const std::string name = layer["name"].get<std::string>();
    SCOPED_TRACE(name);
    EXPECT_EQ(name, scene["layers"][l]["name"].get<std::string>()) << "the scene file's names, in its order";
    const std::size_t n = layer["selected"].get<std::size_t>();
    total += n;
    ASSERT_TRUE(layer.contains("file"));
    const fs::path file = out / layer["file"].get<std::string>();
    const json own = json::parse(readText(file));
    ASSERT_EQ(own["features"].size(), n) << file;
    for (std::size_t k = 0; k < n; ++k) {
      const std::int64_t fid = layer["features"][k]["fid"].get<std::int64_t>();
      listed[name].insert(fid);
      EXPECT_EQ(own["features"][k]["id"].get<std::int64_t>(), fid);
      EXPECT_EQ(own["features"][k]["properties"]["selection_fully_inside"].get<int>() == 1,
                layer["features"][k]["fully_inside"].get<bool>());
    }
    // GDAL reads the layer's file back, and each feature is the source's of the same FID.
    GDALDatasetUniquePtr exported(GDALDataset::Open(file.string().c_str(), GDAL_OF_VECTOR));
    ASSERT_NE(exported, nullptr) << file;
    OGRLayer* read = exported->GetLayer(0);
    ASSERT_NE(read, nullptr);
    EXPECT_EQ(read->GetFeatureCount(), static_cast<GIntBig>(n));
    const std::string sourcePath = scene["layers"][l]["source"].get<std::string>();
    GDALDatasetUniquePtr source(GDALDataset::Open(sourcePath.c_str(), GDAL_OF_VECTOR));
    ASSERT_NE(source, nullptr) << sourcePath;
    OGRLayer* sourceLayer = source->GetLayer(0);
    ASSERT_NE(sourceLayer, nullptr);
    std::size_t checkedFields = 0;
    read->ResetReading();
    while (OGRFeature* f = read->GetNextFeature()) {
      const OGRFeatureUniquePtr feature(f);
      EXPECT_EQ(listed[name].count(feature->GetFID()), 1u) << "fid " << feature->GetFID();
      const OGRFeatureUniquePtr original(sourceLayer->GetFeature(feature->GetFID()));
      ASSERT_NE(original, nullptr) << "fid " << feature->GetFID() << " is not in " << sourcePath;
      EXPECT_NE(feature->GetGeometryRef(), nullptr);
      for (int i = 0; i < original->GetFieldCount(); ++i) {
        const char* field = original->GetFieldDefnRef(i)->GetNameRef();
        const int at = feature->GetFieldIndex(field);
        ASSERT_GE(at, 0) << field;
        switch (original->GetFieldDefnRef(i)->GetType()) {
          case OFTInteger:
          case OFTInteger64:
            EXPECT_EQ(feature->GetFieldAsInteger64(at), original->GetFieldAsInteger64(i)) << field;
            break;
          case OFTReal:
            EXPECT_DOUBLE_EQ(feature->GetFieldAsDouble(at), original->GetFieldAsDouble(i)) << field;
            break;
          default:
            EXPECT_STREQ(feature->GetFieldAsString(at), original->GetFieldAsString(i)) << field;
        }
        ++checkedFields;
      }
    }
    EXPECT_GT(checkedFields, 0u);
  }
  // The combined file: every listed feature once, with its layer, fid and attributes, in lon/lat
  // within Olinda's box (35.0–34.75° W, 8.15–7.85° S): not metres, not latitude first.
  ASSERT_EQ(combined["features"].size(), total);
  std::map<std::string, std::set<std::int64_t>> found;
  std::size_t positions = 0;
  for (const json& f : combined["features"]) {
    const json& p = f["properties"];
    const std::string layer = p["selection_layer"].get<std::string>();
    EXPECT_TRUE(found[layer].insert(p["selection_fid"].get<std::int64_t>()).second) << "twice: " << p.dump();
    EXPECT_TRUE(p.contains("selection_fully_inside"));
    if (layer == "census tracts") {
      EXPECT_TRUE(p.contains("CD_GEOCODI")) << p.dump();
    }
    std::vector<glm::dvec2> lonLat;
    positionsOf(f["geometry"]["coordinates"], lonLat);
    EXPECT_FALSE(lonLat.empty());
    for (const glm::dvec2& q : lonLat) {
      EXPECT_TRUE(q.x > -35.0 && q.x < -34.75 && q.y > -8.15 && q.y < -7.85) << layer << ": " << q.x << ", " << q.y;
      ++positions;
    }
  }
  EXPECT_EQ(found, listed);
  EXPECT_GT(positions, 100u);
}

TEST(OverlayRenderGlobe, LassoAndOverlapOnTheGlobeAgreeWithTheirTwins) {
  // The Olinda sample drawn on the globe ("frame": "globe"), with a lasso chain (one lasso in the
  // view drawn, a second from a camera file in lon/lat, subtracted) and the overlap of tracts and
  // streets (xor): selection.png and overlap.png agree with the CPU twins on the same depth away
  // from edges, and they select what they must.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("globe_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  json description = olindaScene();
  description["frame"] = "globe";
  for (json& layer : description["layers"]) {
    layer["style"].erase("outline_width_m");  // mask.png's bit 0 is then the tracts' areas alone
  }
  { std::ofstream(dir / "scene.json") << description.dump(1); }
  const json camera = {{"eye", {{"lon", -34.855}, {"lat", -8.03}, {"h", 3000.0}}},
                       {"target", {{"lon", -34.855}, {"lat", -8.01}, {"h", 0.0}}},
                       {"width", kWidth},
                       {"height", kHeight}};
  { std::ofstream(dir / "lasso_camera.json") << camera.dump(1); }
  const json lassos = {{"lassos",
                        {{{"op", "single"}, {"points", {{20, 20}, {230, 30}, {200, 170}, {40, 160}}}},
                         {{"op", "subtract"},
                          {"camera", "lasso_camera.json"},
                          {"points", {{60, 60}, {190, 60}, {190, 150}, {60, 150}}}}}}};
  { std::ofstream(dir / "lassos.json") << lassos.dump(1); }
  const fs::path out = dir / "out";
  ASSERT_EQ(
      runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                           " --height " + std::to_string(kHeight) + " --lasso " + (dir / "lassos.json").string() +
                           " --overlap \"census tracts,streets\" --overlap-op xor --open-volumes --out " + out.string(),
                       dir / "log.txt"),
      0)
      << readText(dir / "log.txt");
  const json stats = json::parse(readText(out / "stats.json"));
  ASSERT_EQ(stats["frame"], "globe") << stats.dump(1);
  EXPECT_EQ(stats["method"], "stencil-tiles");
  // One program for both frames: the blocks every frame reports, with the globe's own.
  EXPECT_EQ(stats["gl_errors"].get<int>(), 0);
  EXPECT_EQ(stats["errors"].get<int>(), 0) << stats["diagnostics"].dump(1);
  EXPECT_FALSE(stats["gl"]["renderer"].get<std::string>().empty());
  EXPECT_FALSE(stats["globe_reason"].get<std::string>().empty());
  // The layers' tiles under the scene's GPU budget (terrain.gpu_budget_mb, 512 MiB by default).
  const json& tiles = stats["tiles"];
  EXPECT_GT(tiles["drawn"].get<std::size_t>(), 0u) << tiles.dump(1);
  EXPECT_GT(tiles["gpu_bytes"].get<std::size_t>(), 0u) << tiles.dump(1);
  EXPECT_EQ(tiles["gpu_budget_bytes"].get<std::size_t>(), std::size_t{512} << 20U) << tiles.dump(1);
  EXPECT_LE(tiles["gpu_bytes"].get<std::size_t>(), tiles["gpu_budget_bytes"].get<std::size_t>()) << tiles.dump(1);
  // The projected frame's block (overlay::TileResidency): at the terrain's detail, nothing missing.
  EXPECT_EQ(tiles["error_px"].get<double>(), 0.5) << tiles.dump(1);
  EXPECT_GE(tiles["finest_level"].get<int>(), 0) << tiles.dump(1);
  EXPECT_EQ(tiles["missing"].get<std::size_t>(), 0u) << tiles.dump(1);
  EXPECT_GE(tiles["wanted"].get<std::size_t>(), tiles["drawn"].get<std::size_t>()) << tiles.dump(1);
  const json& selection = stats["selection"];
  EXPECT_EQ(selection["steps"].get<int>(), 2);
  EXPECT_EQ(selection["differing_away_from_edges"].get<std::size_t>(), 0u) << selection.dump(1);
  EXPECT_GT(selection["selected_pixels"].get<std::size_t>(), 5000u) << selection.dump(1);
  const gfx::Image8 selected = *gfx::readImage8((out / "selection.png").string());
  std::size_t shown = 0;
  for (const std::uint8_t p : selected.pixels) shown += p != 0 ? 1u : 0u;
  EXPECT_EQ(shown, selection["selected_pixels"].get<std::size_t>());
  // The features: tracts and streets under the selected ground, some of them whole; fids as read.
  ASSERT_EQ(selection["layers"].size(), 2u) << selection.dump(1);
  EXPECT_TRUE(selection["dem_posts"].is_null());
  for (const json& layer : selection["layers"]) {
    EXPECT_GT(layer["selected"].get<std::size_t>(), 3u) << layer["name"];
    EXPECT_LE(layer["fully_inside"].get<std::size_t>(), layer["selected"].get<std::size_t>());
    ASSERT_EQ(layer["features"].size(), layer["selected"].get<std::size_t>()) << layer["name"];
    for (const json& f : layer["features"]) {
      EXPECT_GE(f["fid"].get<std::int64_t>(), 0);
      EXPECT_GT(f["selected_samples"].get<std::size_t>(), 0u);
    }
  }
  EXPECT_GT(selection["layers"][0]["fully_inside"].get<std::size_t>(), 0u);
  expectGlobeExport(out, selection, description);
  EXPECT_EQ(stats["open_volumes"]["open_pixels"].get<std::size_t>(), 0u) << stats["open_volumes"].dump(1);
  EXPECT_EQ(stats["open_volumes"]["layers"].size(), 2u);
  const json& overlap = stats["overlap"];
  EXPECT_EQ(overlap["op"], "xor");
  EXPECT_EQ(overlap["differing_away_from_edges"].get<std::size_t>(), 0u) << overlap.dump(1);
  EXPECT_GT(overlap["both_pixels"].get<std::size_t>(), 100u) << overlap.dump(1);
  EXPECT_GT(overlap["pixels"].get<std::size_t>(), 1000u) << overlap.dump(1);
  // The layers' mask is the layers' own, not the analyses': both bits where the flags say both.
  const gfx::Image8 mask = *gfx::readImage8((out / "mask.png").string());
  std::size_t both = 0;
  for (const std::uint8_t m : mask.pixels) both += (m & 3) == 3 ? 1u : 0u;
  EXPECT_NEAR(static_cast<double>(both), overlap["both_pixels"].get<double>(),
              2.0 + overlap["both_pixels"].get<double>() / 20.0);
}

TEST(OverlayRenderGlobe, AFailedExportIsInStatsAndTheExitStatus) {
  // The export cannot write its combined file (a folder of that name is in the way): the run
  // fails, but the frame's files and stats.json are written, and stats.json's diagnostics name
  // the file, as in a projected frame.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("globe_export_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "out" / "selected_features.json");
  json description = olindaScene();
  description["frame"] = "globe";
  { std::ofstream(dir / "scene.json") << description.dump(1); }
  const json lassos = {{"lassos", {{{"op", "single"}, {"points", {{10, 10}, {110, 15}, {100, 80}, {20, 85}}}}}}};
  { std::ofstream(dir / "lassos.json") << lassos.dump(1); }
  const fs::path out = dir / "out";
  EXPECT_NE(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width 128 --height 96 --lasso " +
                                 (dir / "lassos.json").string() + " --out " + out.string(),
                             dir / "log.txt"),
            0)
      << readText(dir / "log.txt");
  ASSERT_TRUE(fs::exists(out / "stats.json")) << readText(dir / "log.txt");
  ASSERT_TRUE(fs::exists(out / "color.png"));
  const json stats = json::parse(readText(out / "stats.json"));
  EXPECT_GT(stats["selection"]["selected_pixels"].get<std::size_t>(), 1000u);
  std::size_t named = 0;
  for (const json& d : stats["diagnostics"]) {
    named += d.get<std::string>().find("selected_features.json") != std::string::npos ? 1u : 0u;
  }
  EXPECT_GE(named, 1u) << stats["diagnostics"].dump(1);
}

/// A fresh folder `prefix`<pid> holding scene.json: Olinda's tracts alone, without their
/// outline, on the globe.
fs::path globeTractsScene(const std::string& prefix) {
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / (prefix + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  json description = olindaScene();
  description["frame"] = "globe";
  json tracts = description["layers"][0];
  tracts["style"].erase("outline_width_m");
  description["layers"] = json::array({tracts});
  { std::ofstream(dir / "scene.json") << description.dump(1); }
  return dir;
}

TEST(OverlayRenderGlobe, TheDrapesDrawOnTheGlobeAndStatsSaySo) {
  // --method drape and drape-tiles on Olinda's tracts on the globe: drawn by the terrain from
  // textures in longitude and latitude, stats.json names the method and its textures, and the
  // tracts cover about what the stencil pieces cover (a texture is not exact: within 3 %).
  const fs::path dir = globeTractsScene("globe_drape_");
  std::map<std::string, std::size_t> covered;
  for (const std::string method : {"stencil-tiles", "drape", "drape-tiles"}) {
    const fs::path out = dir / method;
    ASSERT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width 160 --height 120 --method " +
                                   method + (method == "drape" ? " --drape-size 1024" : "") + " --out " + out.string(),
                               dir / (method + ".txt")),
              0)
        << readText(dir / (method + ".txt"));
    const json stats = json::parse(readText(out / "stats.json"));
    EXPECT_EQ(stats["method"], method) << stats.dump(1);
    covered[method] = stats["layers"][0]["covered_pixels"].get<std::size_t>();
    if (method == "stencil-tiles") {
      EXPECT_FALSE(stats.contains("drape"));
      continue;
    }
    ASSERT_TRUE(stats.contains("drape")) << stats.dump(1);
    EXPECT_GT(stats["drape"]["tiles_built"].get<std::size_t>(), 0U) << stats.dump(1);
    EXPECT_GT(stats["drape"]["gpu_bytes"].get<std::size_t>(), 0U) << stats.dump(1);
    EXPECT_EQ(stats["overlay"]["pieces"].get<std::size_t>(), 0U) << stats.dump(1);
    if (method == "drape") {
      EXPECT_EQ(stats["drape"]["size"], 1024) << stats.dump(1);
    } else {
      EXPECT_EQ(stats["drape"]["tile_size"], 256) << stats.dump(1);
    }
  }
  ASSERT_GT(covered["stencil-tiles"], 1000U);
  for (const char* method : {"drape", "drape-tiles"}) {
    const double ratio = static_cast<double>(covered[method]) / static_cast<double>(covered["stencil-tiles"]);
    EXPECT_NEAR(ratio, 1.0, 0.03) << method;
  }
}

TEST(OverlayRenderGlobe, TheDeferredLookupDrawsTheGlobesAreasAsItsPiecesDo) {
  // --method deferred on Olinda's tracts on the globe (areas only): drawn by the lookup in the
  // cube's faces, stats.json says so, and its mask is the stencil pieces' but at edges. So are
  // --method stencil's and paper's (the pieces built once for every view; every method of the
  // registry draws on the globe, none is replaced by another).
  const fs::path dir = globeTractsScene("globe_deferred_");
  std::array<gfx::Image8, 4> masks;
  for (const std::string method : {"deferred", "stencil-tiles", "stencil", "paper"}) {
    const fs::path out = dir / method;
    ASSERT_EQ(
        runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                             " --height " + std::to_string(kHeight) + " --method " + method + " --out " + out.string(),
                         dir / (method + ".txt")),
        0)
        << readText(dir / (method + ".txt"));
    const json stats = json::parse(readText(out / "stats.json"));
    EXPECT_EQ(stats["method"], method) << stats.dump(1);
    const bool deferred = method == "deferred";
    EXPECT_EQ(stats["overlay"]["deferred_layers"].get<std::size_t>(), deferred ? 1U : 0U) << stats.dump(1);
    EXPECT_EQ(stats["overlay"]["deferred_index_bytes"].get<std::size_t>() > 0, deferred) << stats.dump(1);
    EXPECT_EQ(stats.contains("deferred"), deferred) << stats.dump(1);  // the block of both frames
    if (deferred) {
      EXPECT_EQ(stats["deferred"]["layers"], 1) << stats.dump(1);
      EXPECT_EQ(stats["deferred"]["gpu_bytes"], stats["overlay"]["deferred_index_bytes"]) << stats.dump(1);
    }
    EXPECT_EQ(stats["overlay"]["pieces"].get<std::size_t>() > 0, !deferred) << stats.dump(1);
    masks[deferred                    ? 0
          : method == "stencil-tiles" ? 1
          : method == "stencil"       ? 2
                                      : 3] = *gfx::readImage8((out / "mask.png").string());
  }
  for (const std::size_t other : {0U, 2U, 3U}) {
    ASSERT_EQ(masks[other].pixels.size(), masks[1].pixels.size());
    std::size_t covered = 0, differing = 0;
    for (std::size_t i = 0; i < masks[other].pixels.size(); ++i) {
      covered += masks[1].pixels[i] != 0 ? 1U : 0U;
      differing += masks[other].pixels[i] != masks[1].pixels[i] ? 1U : 0U;
    }
    EXPECT_GT(covered, 2000U);
    // Two exact ways of drawing differ at most on the tracts' borders (a pixel wide, either way).
    EXPECT_LT(differing, covered / 200) << differing << " of " << covered << " (mask " << other << ")";
  }
  std::size_t covered = 0;
  for (const std::uint8_t m : masks[1].pixels) covered += m != 0 ? 1U : 0U;
  // With 4× MSAA, as a projected scene: read back as the projected path reads it (a layer's bit
  // where half the samples have it), stats.json saying so; the same mask but at the borders.
  const fs::path msaa = dir / "msaa";
  ASSERT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --width " + std::to_string(kWidth) +
                                 " --height " + std::to_string(kHeight) + " --method deferred --msaa 4 --out " +
                                 msaa.string(),
                             dir / "msaa.txt"),
            0)
      << readText(dir / "msaa.txt");
  const json stats = json::parse(readText(msaa / "stats.json"));
  EXPECT_EQ(stats["msaa"].get<int>(), 4);
  const gfx::Image8 sampled = *gfx::readImage8((msaa / "mask.png").string());
  ASSERT_EQ(sampled.pixels.size(), masks[1].pixels.size());
  std::size_t coveredSampled = 0, differingSampled = 0;
  for (std::size_t i = 0; i < sampled.pixels.size(); ++i) {
    coveredSampled += sampled.pixels[i] != 0 ? 1U : 0U;
    differingSampled += sampled.pixels[i] != masks[1].pixels[i] ? 1U : 0U;
  }
  EXPECT_EQ(stats["layers"][0]["covered_pixels"].get<std::size_t>(), coveredSampled);
  EXPECT_LT(differingSampled, covered / 100) << differingSampled << " of " << covered;
  // The analyses are single-sampled, in both frames.
  EXPECT_EQ(runOverlayRender("--scene " + (dir / "scene.json").string() + " --msaa 4 --open-volumes --out " +
                                 (dir / "refused").string(),
                             dir / "refused.txt"),
            2);
}

TEST(OverlayRenderGlobe, APagedDemDrawsTheSameFrame) {
  // Olinda on the globe with its DEM read whole and paged from the cache (terrain.paging
  // "always"): the same depth and layers' mask on every pixel; the second run finds the paged
  // DEM in the cache.
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("globe_paged_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  json description = olindaScene();
  description["frame"] = "globe";
  { std::ofstream(dir / "whole.json") << description.dump(1); }
  description["terrain"]["paging"] = "always";
  description["terrain"]["cache_dir"] = (dir / "cache").string();
  { std::ofstream(dir / "paged.json") << description.dump(1); }
  const std::string size = " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
  for (const std::string run : {"whole", "paged", "paged_again"}) {
    const std::string scene = run == "whole" ? "whole.json" : "paged.json";
    ASSERT_EQ(runOverlayRender("--scene " + (dir / scene).string() + size + " --out " + (dir / run).string(),
                               dir / (run + ".txt")),
              0)
        << readText(dir / (run + ".txt"));
  }
  EXPECT_NE(readText(dir / "paged.txt").find("is paged on the globe"), std::string::npos)
      << readText(dir / "paged.txt");
  EXPECT_EQ(readText(dir / "paged_again.txt").find("is paged on the globe"), std::string::npos)
      << "the second run finds the paged DEM in the cache";
  const gfx::ImageFloat wholeDepth = *gfx::readImageFloat((dir / "whole" / "depth.tiff").string());
  const gfx::Image8 wholeMask = *gfx::readImage8((dir / "whole" / "mask.png").string());
  for (const std::string run : {"paged", "paged_again"}) {
    const gfx::ImageFloat depth = *gfx::readImageFloat((dir / run / "depth.tiff").string());
    const gfx::Image8 mask = *gfx::readImage8((dir / run / "mask.png").string());
    ASSERT_EQ(depth.pixels.size(), wholeDepth.pixels.size());
    std::size_t depthDiffering = 0, maskDiffering = 0, ground = 0;
    for (std::size_t i = 0; i < depth.pixels.size(); ++i) {
      ground += wholeDepth.pixels[i] > 0.0F ? 1u : 0u;
      depthDiffering += depth.pixels[i] != wholeDepth.pixels[i] ? 1u : 0u;
      maskDiffering += mask.pixels[i] != wholeMask.pixels[i] ? 1u : 0u;
    }
    EXPECT_GT(ground, depth.pixels.size() / 2);
    EXPECT_EQ(depthDiffering, 0u) << run;
    EXPECT_EQ(maskDiffering, 0u) << run;
  }
}

}  // namespace
}  // namespace gis::test
