// Scene and camera files: the sample parses into what it names; bad files give errors that
// name the file and the key, and a broken layer entry does not take the scene down.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scene/camera.hpp"
#include "scene/globe_selection.hpp"
#include "scene/json_file.hpp"
#include "scene/scene.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

const std::string kSamples = STENCIL_GIS_SAMPLES_DIR;

bool mentions(const Diagnostics& d, const std::string& text) {
  for (const Diagnostic& item : d.items()) {
    if (item.toString().find(text) != std::string::npos) return true;
  }
  return false;
}

TEST(SceneFile, OlindaSampleNamesItsData) {
  Result<scene::SceneDescription> scene = scene::loadSceneFile(kSamples + "/olinda/scene.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene.diagnostics.count(Severity::Error), 0u);
  EXPECT_EQ(scene.diagnostics.count(Severity::Warning), 0u);
  EXPECT_TRUE(std::filesystem::exists(scene->dem)) << scene->dem;
  ASSERT_TRUE(scene->imagery.has_value());
  EXPECT_TRUE(std::filesystem::exists(*scene->imagery));
  EXPECT_EQ(scene->imageryBands, (std::vector<int>{3, 2, 1}));
  ASSERT_EQ(scene->layers.size(), 2u);
  EXPECT_EQ(scene->layers[0].kind, overlay::LayerKind::Polygon);
  EXPECT_EQ(scene->layers[1].kind, overlay::LayerKind::Line);
  EXPECT_EQ(scene->layers[1].style.widthAttribute, "width_m");
  for (const auto& layer : scene->layers) EXPECT_TRUE(std::filesystem::exists(layer.source)) << layer.source;
}

TEST(SceneFile, PathsAreRelativeToTheSceneFile) {
  Result<scene::SceneDescription> scene =
      scene::parseScene(R"({"terrain": {"dem": "../x/dem.tif"}})", "/data/scenes/a.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene->dem, "/data/x/dem.tif");
}

TEST(SceneFile, ALayerSourceMayBeAConnectionString) {
  Result<scene::SceneDescription> scene = scene::parseScene(
      R"({"terrain": {"dem": "dem.tif"}, "layers": [
          {"name": "roads", "kind": "line", "source": "PG:host=/tmp/pg port=5432 dbname=gis", "layer": "roads"},
          {"name": "tiles", "kind": "polygon", "source": "tiles/roads.mbtiles", "layer": "roads"}]})",
      "/data/scenes/a.json");
  ASSERT_TRUE(scene.ok());
  ASSERT_EQ(scene->layers.size(), 2u);
  EXPECT_EQ(scene->layers[0].source, "PG:host=/tmp/pg port=5432 dbname=gis");
  EXPECT_EQ(scene->layers[1].source, "/data/scenes/tiles/roads.mbtiles");
}

TEST(SceneFile, DemMayBeAListOfFilesAndFoldersWithItsCrsUnitAndSpacing) {
  Result<scene::SceneDescription> scene = scene::parseScene(
      R"({"terrain": {"dem": ["srtm", "extra/N49E008.hgt"], "crs": "EPSG:4326", "height_unit": "ft",
                      "resolution_m": 30}})",
      "/data/scenes/a.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene.diagnostics.count(Severity::Warning), 0u);
  EXPECT_EQ(scene->dem, "/data/scenes/srtm");
  const geo::DemSpec spec = scene->demSpec();
  EXPECT_EQ(spec.paths, (std::vector<std::string>{"/data/scenes/srtm", "/data/scenes/extra/N49E008.hgt"}));
  EXPECT_EQ(spec.crs, "EPSG:4326");
  EXPECT_EQ(spec.heightUnit, "ft");
  EXPECT_EQ(spec.resolutionMetres, 30.0);
  // One file is a list of one.
  Result<scene::SceneDescription> one = scene::parseScene(R"({"terrain": {"dem": "dem.tif"}})", "/s/a.json");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->demSpec().paths, (std::vector<std::string>{"/s/dem.tif"}));
  // Bad values name the key.
  for (const char* text : {R"({"terrain": {"dem": []}})", R"({"terrain": {"dem": ["a.tif", 3]}})"}) {
    Result<scene::SceneDescription> bad = scene::parseScene(text, "b.json");
    EXPECT_FALSE(bad.ok()) << text;
    EXPECT_TRUE(mentions(bad.diagnostics, "terrain.dem")) << text;
  }
  Result<scene::SceneDescription> unit =
      scene::parseScene(R"({"terrain": {"dem": "d.tif", "height_unit": "cubit", "resolution_m": -1}})", "u.json");
  EXPECT_TRUE(mentions(unit.diagnostics, "terrain.height_unit"));
  EXPECT_TRUE(mentions(unit.diagnostics, "terrain.resolution_m"));
}

TEST(SceneFile, NotJsonIsAnErrorNamingTheFile) {
  Result<scene::SceneDescription> scene = scene::parseScene("{ nope", "broken.json");
  EXPECT_FALSE(scene.ok());
  EXPECT_TRUE(mentions(scene.diagnostics, "broken.json"));
}

TEST(SceneFile, MissingDemFailsTheScene) {
  Result<scene::SceneDescription> scene = scene::parseScene(R"({"name": "x"})", "s.json");
  EXPECT_FALSE(scene.ok());
  EXPECT_TRUE(mentions(scene.diagnostics, "terrain"));
}

TEST(SceneFile, BrokenLayerIsLeftOutWithAMessageAndTheRestLoads) {
  const char* text = R"({
    "terrain": {"dem": "dem.tif"},
    "layers": [
      {"name": "good", "kind": "line", "source": "a.geojson", "style": {"color": "#112233"}},
      {"name": "bad", "kind": "volcano", "source": "b.geojson"},
      {"name": "bad colour", "kind": "polygon", "source": "c.shp", "style": {"color": "red"}}
    ]})";
  Result<scene::SceneDescription> scene = scene::parseScene(text, "s.json");
  ASSERT_TRUE(scene.ok());
  ASSERT_EQ(scene->layers.size(), 1u);
  EXPECT_EQ(scene->layers[0].name, "good");
  EXPECT_EQ(scene.diagnostics.count(Severity::Error), 2u);
  EXPECT_TRUE(mentions(scene.diagnostics, "layers[1].kind"));
  EXPECT_TRUE(mentions(scene.diagnostics, "layers[2].style.color"));
}

TEST(SceneFile, UnknownKeysAreWarnings) {
  Result<scene::SceneDescription> scene = scene::parseScene(R"({"terrain": {"dem": "d.tif", "colour": 1}})", "s.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene.diagnostics.count(Severity::Warning), 1u);
  EXPECT_TRUE(mentions(scene.diagnostics, "terrain.colour"));
}

/// The warnings of `d` as the log says them.
std::vector<std::string> warningsOf(const Diagnostics& d) {
  std::vector<std::string> out;
  for (const Diagnostic& item : d.items()) {
    if (item.severity == Severity::Warning) out.push_back(item.toString());
  }
  return out;
}

TEST(SceneFile, MisspeltKeysAtEveryLevelAreNamedWithTheirPath) {
  // Top, terrain, imagery, a layer, its style, the camera and its eye; a close key suggested.
  // "meshes" is no key of a scene file yet. The categories' keys are attribute values: any goes.
  Result<scene::SceneDescription> scene = scene::parseScene(R"({
    "name": "keys",
    "meshes": [{"source": "m.glb"}],
    "terrain": {"dem": "d.tif", "vertical_exageration": 2},
    "imagery": {"path": "i.tif", "band": [1]},
    "layers": [
      {"name": "a", "kind": "polygon", "source": "a.shp",
       "style": {"colour": "#ff0000", "categories": {"widht_m": "#00ff00", "x": "#0000ff"}}},
      {"name": "b", "kind": "line", "source": "b.shp", "visable": false},
      {"name": "c", "kind": "line", "source": "c.shp", "style": {"widht_m": 4, "width_px": 2}}
    ],
    "camera": {"eye": {"lon": 1, "lat": 2, "height": 3}, "target": {"lon": 1, "lat": 2.1}, "fov": 40}
  })",
                                                            "keys.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene.diagnostics.count(Severity::Error), 0u) << scene.diagnostics.items().front().toString();
  EXPECT_EQ(
      warningsOf(scene.diagnostics),
      (std::vector<std::string>{
          R"(warning: keys.json: unknown key "meshes" (ignored))",
          R"(warning: keys.json: unknown key "terrain.vertical_exageration" (ignored); did you mean "vertical_exaggeration"?)",
          R"(warning: keys.json: unknown key "imagery.band" (ignored); did you mean "bands"?)",
          R"(warning: keys.json: unknown key "layers[0].style.colour" (ignored); did you mean "color"?)",
          R"(warning: keys.json: unknown key "layers[1].visable" (ignored); did you mean "visible"?)",
          R"(warning: keys.json: unknown key "layers[2].style.widht_m" (ignored); did you mean "width_m"?)",
          R"(warning: keys.json: unknown key "camera.fov" (ignored))",
          R"(warning: keys.json: unknown key "camera.eye.height" (ignored))",
      }));
  // What was understood is read as usual.
  ASSERT_EQ(scene->layers.size(), 3u);
  EXPECT_TRUE(scene->layers[1].visible);
  EXPECT_DOUBLE_EQ(scene->layers[2].style.widthPixels, 2.0);
  ASSERT_TRUE(scene->camera.has_value());
  EXPECT_DOUBLE_EQ(scene->camera->eyeLonLatH->z, 0.0);
}

TEST(SceneFile, EntriesOfTheWrongTypeAreErrorsNamingThem) {
  Result<scene::SceneDescription> scene =
      scene::parseScene(R"({"terrain": {"dem": "d.tif"}, "imagery": "i.tif", "layers": [7]})", "s.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_TRUE(warningsOf(scene.diagnostics).empty());
  EXPECT_TRUE(mentions(scene.diagnostics, "error: s.json: 'imagery': expected an object"));
  EXPECT_TRUE(mentions(scene.diagnostics, "error: s.json: 'layers[0]': expected an object (a layer), got 7"));
  EXPECT_TRUE(scene->layers.empty());
}

TEST(SceneFile, EverySceneFileOfTheSamplesAndTestDataHasNoUnknownKey) {
  // Every JSON file under samples/ and tests/data that is a scene file (it has a "terrain").
  std::size_t scenes = 0;
  for (const std::string& root : {kSamples, std::string(STENCIL_GIS_TEST_DATA_DIR)}) {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(root)) {
      if (entry.path().extension() != ".json") continue;
      std::ifstream in(entry.path());
      const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
      if (!j.is_object() || !j.contains("terrain")) continue;
      ++scenes;
      Result<scene::SceneDescription> scene = scene::loadSceneFile(entry.path().string());
      SCOPED_TRACE(entry.path().string());
      EXPECT_TRUE(scene.ok());
      EXPECT_FALSE(scene.diagnostics.hasErrors());
      EXPECT_TRUE(warningsOf(scene.diagnostics).empty()) << warningsOf(scene.diagnostics).front();
    }
  }
  EXPECT_GE(scenes, 1u) << "samples/olinda/scene.json at least";
  // The scene terrain_synth writes, with its layers (samples/synth/terrain_synth.cpp).
  Result<scene::SceneDescription> synth = scene::parseScene(R"({
    "name": "synthetic terrain",
    "terrain": {"dem": "dem.tif", "band": 1, "vertical_exaggeration": 1.0},
    "layers": [
      {"name": "habitation", "kind": "polygon", "source": "areas.gpkg", "layer": "areas",
       "style": {"color": "#ffd400", "opacity": 0.5}},
      {"name": "roads", "kind": "line", "source": "roads.gpkg", "layer": "roads",
       "style": {"color": "#d62728", "opacity": 0.9, "width_m": 10, "width_attribute": "width_m", "join": "round",
                 "cap": "round"}}]})",
                                                            "synth.json");
  EXPECT_TRUE(synth.diagnostics.empty()) << synth.diagnostics.items().front().toString();
  // Every key docs/command-line.md lists, at once.
  Result<scene::SceneDescription> every = scene::parseScene(R"({
    "name": "n", "frame": "auto",
    "terrain": {"dem": "d.tif", "band": 1, "crs": "EPSG:32725", "height_unit": "m", "vertical_datum": "auto",
                "resolution_m": 30, "vertical_exaggeration": 1, "chunk_cells": 64, "paging": "auto",
                "memory_budget_mb": 1024, "gpu_budget_mb": 512, "cache_dir": "cache"},
    "imagery": {"path": "i.tif", "bands": [3, 2, 1]},
    "layers": [{"name": "l", "kind": "line", "source": "l.shp", "layer": "l", "visible": true,
                "style": {"color": "#ffffff", "opacity": 1, "outline_width_m": 1, "outline_color": "#000000",
                          "width_m": 5, "min_width_px": 1, "max_width_m": 50, "width_attribute": "w",
                          "join": "round", "cap": "round", "miter_limit": 4, "color_attribute": "c",
                          "categories": {"a": "#ff0000"}, "order": 1}}],
    "camera": {"eye": {"lon": 1, "lat": 2, "h": 3}, "target_xyz": [0, 0, 0], "fov_y_deg": 45, "near": 1}})",
                                                            "every.json");
  EXPECT_TRUE(every.diagnostics.empty()) << every.diagnostics.items().front().toString();
}

TEST(SceneFile, WidthsInPixels) {
  Result<scene::SceneDescription> scene = scene::parseScene(R"({
    "terrain": {"dem": "dem.tif"},
    "layers": [
      {"name": "roads", "kind": "line", "source": "a.geojson", "style": {"width_px": 3, "max_width_m": 20}},
      {"name": "tracts", "kind": "polygon", "source": "b.shp", "style": {"outline_width_px": 1.5}},
      {"name": "both", "kind": "line", "source": "c.geojson", "style": {"width_px": 3, "width_m": 4}},
      {"name": "negative", "kind": "polygon", "source": "d.shp", "style": {"outline_width_px": -1}}
    ]})",
                                                            "s.json");
  ASSERT_TRUE(scene.ok());
  ASSERT_EQ(scene->layers.size(), 2u);  // a layer with a style error is left out
  EXPECT_EQ(scene->layers[0].style.widthPixels, 3.0);
  EXPECT_EQ(scene->layers[0].style.maxWidthMetres, 20.0);
  EXPECT_EQ(scene->layers[1].style.outlineWidthPixels, 1.5F);
  EXPECT_EQ(scene.diagnostics.count(Severity::Error), 2u);
  EXPECT_TRUE(mentions(scene.diagnostics, "layers[2].style.width_px"));
  EXPECT_TRUE(mentions(scene.diagnostics, "layers[3].style.outline_width_px"));
}

TEST(SceneFile, NumbersThatDoNotFitAreErrorsNamingTheKey) {
  // Found by the fuzzer: converting 1e10 to an int (or 1e300 to a float) was undefined behaviour.
  const std::pair<const char*, const char*> cases[] = {
      {R"({"terrain": {"dem": "x", "band": 1e10}})", "terrain.band"},
      {R"({"terrain": {"dem": "x", "band": 2.5}})", "terrain.band"},
      {R"({"terrain": {"dem": "x", "chunk_cells": -1e300}})", "terrain.chunk_cells"},
      {R"({"terrain": {"dem": "x"}, "imagery": {"path": "i.tif", "bands": [1, 2, 1e12]}})", "imagery.bands"},
      {R"({"terrain": {"dem": "x"}, "layers": [{"kind": "line", "source": "a",
           "style": {"outline_width_m": 1e300}}]})",
       "layers[0].style.outline_width_m"},
      {R"({"terrain": {"dem": "x"}, "layers": [{"kind": "line", "source": "a", "style": {"order": 3e9}}]})",
       "layers[0].style.order"},
  };
  for (const auto& [text, key] : cases) {
    Result<scene::SceneDescription> scene = scene::parseScene(text, "s.json");
    ASSERT_TRUE(scene.diagnostics.hasErrors()) << text;
    bool named = false;
    for (const Diagnostic& d : scene.diagnostics.items()) {
      named =
          named || (d.severity == Severity::Error && d.message.find(std::string("'") + key + "'") != std::string::npos);
    }
    EXPECT_TRUE(named) << key << ": " << scene.diagnostics.items().front().toString();
  }
}

TEST(SceneFile, TerrainPagingKeys) {
  Result<scene::SceneDescription> scene = scene::parseScene(
      R"({"terrain": {"dem": "d.tif", "paging": "always", "chunk_cells": 32, "memory_budget_mb": 300,
                      "gpu_budget_mb": 200, "cache_dir": "cache"}})",
      "/data/s.json");
  ASSERT_TRUE(scene.ok());
  EXPECT_TRUE(scene.diagnostics.empty());
  EXPECT_EQ(scene->paging, scene::TerrainPaging::Always);
  EXPECT_EQ(scene->chunkCells, 32);
  EXPECT_EQ(scene->memoryBudgetMb, 300.0);
  EXPECT_EQ(scene->gpuBudgetMb, 200.0);
  EXPECT_EQ(scene->cacheDir, "/data/cache");

  Result<scene::SceneDescription> bad = scene::parseScene(
      R"({"terrain": {"dem": "d.tif", "paging": "sometimes", "chunk_cells": 48, "memory_budget_mb": 1}})", "s.json");
  ASSERT_TRUE(bad.ok());  // the terrain still loads, with the defaults
  EXPECT_EQ(bad.diagnostics.count(Severity::Error), 3u);
  EXPECT_TRUE(mentions(bad.diagnostics, "terrain.paging"));
  EXPECT_TRUE(mentions(bad.diagnostics, "terrain.chunk_cells"));
  EXPECT_TRUE(mentions(bad.diagnostics, "terrain.memory_budget_mb"));
  EXPECT_EQ(bad->paging, scene::TerrainPaging::Auto);
  EXPECT_EQ(bad->chunkCells, 64);
}

TEST(CameraFile, LonLatAndFrameFormsParse) {
  nlohmann::json j = {
      {"eye", {{"lon", -34.9}, {"lat", -8.0}, {"h", 500.0}}}, {"target_xyz", {1.0, 2.0, 3.0}}, {"fov_y_deg", 30.0}};
  Result<scene::CameraSpec> spec = scene::parseCameraSpec(j, "c.json");
  ASSERT_TRUE(spec.ok());
  ASSERT_TRUE(spec->eyeLonLatH.has_value());
  EXPECT_DOUBLE_EQ(spec->eyeLonLatH->z, 500.0);
  ASSERT_TRUE(spec->targetXyz.has_value());
  EXPECT_DOUBLE_EQ(spec->fovYDeg, 30.0);
}

TEST(CameraFile, WhatCameraJsonHoldsIsReadWithoutAWordAndAMisspeltKeyIsNamed) {
  // camera.json as overlay_render writes it (projected and globe) is a camera file.
  const nlohmann::json written = {{"width", 256},
                                  {"height", 192},
                                  {"view", nlohmann::json::array()},
                                  {"proj", nlohmann::json::array()},
                                  {"depth", {{"convention", "reversed-z"}}},
                                  {"crs", "EPSG:32725"},
                                  {"crs_wkt", "…"},
                                  {"origin", {0, 0, 0}},
                                  {"eye_xyz", {0, 0, 100}},
                                  {"target_xyz", {0, 10, 0}},
                                  {"eye", {{"lon", -34.9}, {"lat", -8.0}, {"h", 100.0}}},
                                  {"target", {{"lon", -34.9}, {"lat", -7.99}, {"h", 0.0}}},
                                  {"fov_y_deg", 45.0},
                                  {"near", 1.0},
                                  {"frame", "globe"},
                                  {"view_proj_ecef", nlohmann::json::array()},
                                  {"eye_ecef", {1, 2, 3}}};
  Result<scene::CameraSpec> spec = scene::parseCameraSpec(written, "camera.json");
  ASSERT_TRUE(spec.ok());
  EXPECT_TRUE(spec.diagnostics.empty()) << spec.diagnostics.items().front().toString();
  nlohmann::json misspelt = written;
  misspelt["fov_y_dg"] = 30.0;
  misspelt["target"]["latt"] = 1.0;
  Result<scene::CameraSpec> warned = scene::parseCameraSpec(misspelt, "camera.json");
  ASSERT_TRUE(warned.ok());
  EXPECT_EQ(
      warningsOf(warned.diagnostics),
      (std::vector<std::string>{R"(warning: camera.json: unknown key "fov_y_dg" (ignored); did you mean "fov_y_deg"?)",
                                R"(warning: camera.json: unknown key "target.latt" (ignored); did you mean "lat"?)"}));
}

TEST(SceneKeys, AClosePairIsASlipAndAFarOneIsNot) {
  EXPECT_EQ(scene::closestKey("widht_m", {"width_m", "width_px"}), "width_m");
  EXPECT_EQ(scene::closestKey("colour", {"color", "opacity"}), "color");
  EXPECT_EQ(scene::closestKey("meshes", {"name", "frame", "terrain", "imagery", "layers", "camera"}), std::nullopt);
  EXPECT_EQ(scene::closestKey("h", {"lon", "lat"}), std::nullopt);  // one letter: no slip to guess
  EXPECT_EQ(scene::closestKey(std::string(1000, 'x'), {"x"}), std::nullopt);
}

TEST(CameraFile, AFolderOrAMissingFileIsAnErrorNamingIt) {
  // A folder opens as a stream on Linux and throws when read (the fuzzer found a lasso file
  // whose camera was "", its own folder): an Error, not an exception.
  const std::string folder = std::filesystem::temp_directory_path().string();
  Result<scene::CameraSpec> spec = scene::loadCameraFile(folder);
  EXPECT_FALSE(spec.ok());
  EXPECT_TRUE(mentions(spec.diagnostics, folder + ": is a folder, not a file"));
  Result<scene::CameraSpec> missing = scene::loadCameraFile(folder + "/no such camera.json");
  EXPECT_FALSE(missing.ok());
  EXPECT_TRUE(mentions(missing.diagnostics, "cannot open"));
}

TEST(CameraFile, MissingEyeOrBadFovIsAnError) {
  Result<scene::CameraSpec> spec = scene::parseCameraSpec({{"target_xyz", {0, 0, 0}}, {"fov_y_deg", 400}}, "c.json");
  EXPECT_FALSE(spec.ok());
  EXPECT_TRUE(mentions(spec.diagnostics, "eye"));
  EXPECT_TRUE(mentions(spec.diagnostics, "fov_y_deg"));
}

TEST(GlobeSelectionExport, EachFileLayerOnceWithItsFillAndOutlineUnited) {
  // A scene file's polygon layer drawn on the globe as a fill and an outline (globe layers 0 and
  // 1, one feature list), and a line layer (globe layer 2) whose entry comes after a broken one
  // (file place 2). The export's input: one entry per file layer, in the scene's order, with the
  // scene's names and sources, the features of fill and outline united by FID, fully inside only
  // when every globe layer selecting the feature says so.
  scene::LoadedGlobeScene scene;
  scene::LayerDescription tracts;
  tracts.name = "census tracts";
  tracts.source = "/data/tracts.shp";
  tracts.sourceLayer = "tracts";
  tracts.fileIndex = 0;
  scene::LayerDescription streets;
  streets.name = "streets";
  streets.kind = overlay::LayerKind::Line;
  streets.source = "/data/streets.geojson";
  streets.fileIndex = 2;
  scene.description.layers = {tracts, streets};
  scene.layerFileIndex = {0, 0, 2};
  const auto featuresWithFids = [](std::vector<std::int64_t> fids) {
    std::vector<geo::Feature> list;
    for (const std::int64_t fid : fids) {
      geo::Feature f;
      f.fid = fid;
      list.push_back(f);
    }
    return overlay::SharedFeatures(std::move(list));
  };
  const auto tractFeatures = featuresWithFids({10, 11, 12, 13});
  scene.layerFeatures = {tractFeatures, tractFeatures, featuresWithFids({100, 101})};
  const auto chosen = [](std::size_t feature, bool fullyInside) {
    overlay::FeatureSelection f;
    f.feature = feature;
    f.fullyInside = fullyInside;
    return f;
  };
  scene::GlobeSelection selection;
  selection.layers.push_back({0, {chosen(0, true), chosen(2, true)}, 2});
  selection.layers.push_back({1, {chosen(1, true), chosen(2, false)}, 1});
  selection.layers.push_back({2, {chosen(1, false)}, 0});
  ASSERT_NE(scene::sceneLayerOf(scene, 1), nullptr);
  EXPECT_EQ(scene::sceneLayerOf(scene, 1)->name, "census tracts");
  EXPECT_EQ(scene::sceneLayerOf(scene, 2)->name, "streets");
  EXPECT_EQ(scene::sceneLayerOf(scene, 3), nullptr);

  const std::vector<scene::SelectedLayerFeatures> out = scene::selectedSourceFeatures(scene, selection);
  ASSERT_EQ(out.size(), 2U);
  EXPECT_EQ(out[0].name, "census tracts");
  EXPECT_EQ(out[0].source, "/data/tracts.shp");
  EXPECT_EQ(out[0].sourceLayer, "tracts");
  ASSERT_EQ(out[0].features.size(), 3U);
  EXPECT_EQ(out[0].features[0].fid, 10);
  EXPECT_TRUE(out[0].features[0].fullyInside);
  EXPECT_EQ(out[0].features[1].fid, 11);
  EXPECT_TRUE(out[0].features[1].fullyInside);
  EXPECT_EQ(out[0].features[2].fid, 12);
  EXPECT_FALSE(out[0].features[2].fullyInside) << "its outline is not all inside";
  EXPECT_EQ(out[1].name, "streets");
  ASSERT_EQ(out[1].features.size(), 1U);
  EXPECT_EQ(out[1].features[0].fid, 101);
  EXPECT_FALSE(out[1].features[0].fullyInside);
  EXPECT_EQ(scene::selectedLayerFileName(out[0].name), "selected_census_tracts.geojson");
}

}  // namespace
}  // namespace gis::test
