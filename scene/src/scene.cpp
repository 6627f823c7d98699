#include "scene/scene.hpp"

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/json_file.hpp"

namespace gis::scene {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

class SceneParser {
 public:
  SceneParser(std::string path, Diagnostics& diagnostics)
      : path_(std::move(path)), base_(fs::absolute(fs::path(path_)).parent_path()), diag_(diagnostics) {}

  void error(const std::string& key, const std::string& message) {
    diag_.add({Severity::Error, path_, "", "", "'" + key + "': " + message});
  }

  std::string resolve(const std::string& relative) const {
    const fs::path p(relative);
    return (p.is_absolute() ? p : (base_ / p)).lexically_normal().string();
  }

  /// A layer's source: a path relative to the scene file, or as it is when GDAL names a
  /// source that is not a file that way (a "PG:" connection string for PostGIS, a GDAL virtual
  /// file system path such as /vsizip/..., a URL).
  [[nodiscard]] std::string resolveSource(const std::string& source) const {
    const bool connection =
        source.rfind("PG:", 0) == 0 || source.rfind("/vsi", 0) == 0 || source.find("://") != std::string::npos;
    return connection ? source : resolve(source);
  }

  /// Every object of the file is checked against the keys its reader understands, at every level.
  void warnUnknownKeys(const json& object, std::initializer_list<std::string_view> known, const std::string& where) {
    scene::warnUnknownKeys(object, known, path_, where, diag_);
  }

  template <typename T>
  bool read(const json& object, const std::string& key, const std::string& where, T& out) {
    if (!object.contains(key)) return false;
    const json& v = object.at(key);
    // Numbers are range-checked (a JSON 1e10 is no int), element by element in lists.
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      const std::optional<T> x = numberAs<T>(v);
      if (!x) error(where + key, "expected a number that fits (finite, in range), got " + v.dump());
      if (x) out = *x;
      return x.has_value();
    } else if constexpr (std::is_same_v<T, std::vector<int>>) {
      std::vector<int> list;
      for (const json& e : v.is_array() ? v : json::array({nullptr})) {
        const std::optional<int> x = numberAs<int>(e);
        if (!x) {
          error(where + key, "expected a list of whole numbers, got " + v.dump());
          return false;
        }
        list.push_back(*x);
      }
      out = std::move(list);
      return true;
    } else {
      try {
        out = v.get<T>();
        return true;
      } catch (const json::exception& e) {
        error(where + key, std::string("wrong type: ") + e.what());
        return false;
      }
    }
  }

  void color(const json& object, const std::string& key, const std::string& where, glm::vec4& out) {
    std::string text;
    if (read(object, key, where, text) && !overlay::parseHexColor(text, out)) {
      error(where + key, "expected a colour like \"#ff8800\" or \"#ff8800cc\", got \"" + text + "\"");
    }
  }

  LayerDescription layer(const json& j, std::size_t index) {
    const std::string where = "layers[" + std::to_string(index) + "].";
    LayerDescription layer;
    if (!j.is_object()) {
      error(where.substr(0, where.size() - 1), "expected an object (a layer), got " + j.dump());
      return layer;
    }
    warnUnknownKeys(j, {"name", "kind", "source", "layer", "style", "visible"}, where);
    read(j, "name", where, layer.name);
    if (layer.name.empty()) layer.name = "layer " + std::to_string(index);
    std::string kind;
    if (!read(j, "kind", where, kind))
      error(where + "kind", "missing (\"polygon\" or \"line\")");
    else if (kind == "polygon")
      layer.kind = overlay::LayerKind::Polygon;
    else if (kind == "line")
      layer.kind = overlay::LayerKind::Line;
    else
      error(where + "kind", "expected \"polygon\" or \"line\", got \"" + kind + "\"");
    std::string source;
    if (!read(j, "source", where, source) || source.empty())
      error(where + "source", "missing vector file");
    else
      layer.source = resolveSource(source);
    read(j, "layer", where, layer.sourceLayer);
    read(j, "visible", where, layer.visible);
    if (j.contains("style")) style(j.at("style"), where + "style.", layer.style);
    return layer;
  }

  void style(const json& j, const std::string& where, overlay::LayerStyle& s) {
    if (!j.is_object()) {
      error(where, "expected an object");
      return;
    }
    warnUnknownKeys(j,
                    {"color", "opacity", "outline_width_m", "outline_width_px", "outline_color", "width_m", "width_px",
                     "min_width_px", "max_width_m", "width_attribute", "join", "cap", "miter_limit", "color_attribute",
                     "categories", "order"},
                    where);
    color(j, "color", where, s.color);
    color(j, "outline_color", where, s.outlineColor);
    if (read(j, "opacity", where, s.opacity) && (s.opacity < 0.0F || s.opacity > 1.0F)) {
      error(where + "opacity", "must be in [0, 1]");
    }
    if (read(j, "outline_width_m", where, s.outlineWidthMetres) && s.outlineWidthMetres < 0.0F) {
      error(where + "outline_width_m", "must not be negative");
    }
    if (read(j, "outline_width_px", where, s.outlineWidthPixels) && s.outlineWidthPixels < 0.0F) {
      error(where + "outline_width_px", "must not be negative");
    }
    if (read(j, "width_m", where, s.widthMetres) && !(s.widthMetres > 0.0)) {
      error(where + "width_m", "must be positive");
    }
    if (read(j, "width_px", where, s.widthPixels) && !(s.widthPixels > 0.0)) {
      error(where + "width_px", "must be positive");
    }
    if (read(j, "min_width_px", where, s.minWidthPixels) && !(s.minWidthPixels >= 0.0 && s.minWidthPixels <= 1e3)) {
      error(where + "min_width_px", "must be in [0, 1000] (0: lines exactly as wide as in metres)");
    }
    if (read(j, "max_width_m", where, s.maxWidthMetres) && !(s.maxWidthMetres > 0.0)) {
      error(where + "max_width_m", "must be positive");
    }
    if (j.contains("width_m") && j.contains("width_px")) {
      error(where + "width_px", "give the width in metres (width_m) or in pixels (width_px), not both");
    }
    if (j.contains("outline_width_m") && j.contains("outline_width_px")) {
      error(where + "outline_width_px",
            "give the outline width in metres (outline_width_m) or in pixels (outline_width_px), not both");
    }
    read(j, "width_attribute", where, s.widthAttribute);
    read(j, "color_attribute", where, s.colorAttribute);
    read(j, "order", where, s.drawOrder);
    if (j.contains("categories")) {
      if (!j["categories"].is_object()) {
        error(where + "categories", "expected an object mapping attribute values to colours");
      } else {
        for (const auto& [value, colour] : j["categories"].items()) {
          glm::vec4 c;
          if (!colour.is_string() || !overlay::parseHexColor(colour.get<std::string>(), c)) {
            error(where + "categories." + value, "expected a colour like \"#ff8800\"");
          } else {
            s.categories[value] = c;
          }
        }
      }
    }
    read(j, "miter_limit", where, s.miterLimit);
    std::string text;
    bool ok = true;
    if (read(j, "join", where, text)) {
      s.join = overlay::parseLineJoin(text, ok);
      if (!ok) error(where + "join", "expected round, miter or bevel");
    }
    if (read(j, "cap", where, text)) {
      s.cap = overlay::parseLineCap(text, ok);
      if (!ok) error(where + "cap", "expected round, flat or square");
    }
  }

 private:
  std::string path_;
  fs::path base_;
  Diagnostics& diag_;
};

}  // namespace

Result<SceneDescription> parseScene(const std::string& text, const std::string& path) {
  Result<SceneDescription> result;
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    return Result<SceneDescription>::failure({Severity::Error, path, "", "", std::string("not JSON: ") + e.what()});
  }
  if (!root.is_object()) {
    return Result<SceneDescription>::failure({Severity::Error, path, "", "", "a scene file is a JSON object"});
  }
  SceneParser p(path, result.diagnostics);
  SceneDescription scene;
  scene.path = path;
  p.warnUnknownKeys(root, {"name", "frame", "terrain", "imagery", "layers", "camera"}, "");
  p.read(root, "name", "", scene.name);
  if (std::string frame; p.read(root, "frame", "", frame)) {
    if (frame == "auto") {
      scene.frame = FrameKind::Auto;
    } else if (frame == "projected") {
      scene.frame = FrameKind::Projected;
    } else if (frame == "globe") {
      scene.frame = FrameKind::Globe;
    } else {
      p.error("frame", "expected \"auto\", \"projected\" or \"globe\", got \"" + frame + "\"");
    }
  }

  if (!root.contains("terrain") || !root["terrain"].is_object()) {
    p.error("terrain", "missing (an object with \"dem\")");
  } else {
    const json& t = root["terrain"];
    p.warnUnknownKeys(t,
                      {"dem", "band", "crs", "height_unit", "vertical_datum", "resolution_m", "vertical_exaggeration",
                       "paging", "chunk_cells", "memory_budget_mb", "gpu_budget_mb", "cache_dir"},
                      "terrain.");
    // One file, a folder of tiles, a VRT, or a list of those.
    std::vector<std::string> dems;
    if (t.contains("dem") && t["dem"].is_array()) {
      for (const json& e : t["dem"]) {
        if (e.is_string() && !e.get<std::string>().empty()) {
          dems.push_back(p.resolve(e.get<std::string>()));
        } else {
          p.error("terrain.dem", "expected a list of file or folder names, got " + e.dump());
          dems.clear();
          break;
        }
      }
      if (dems.empty() && t["dem"].empty()) p.error("terrain.dem", "the list of DEM files is empty");
    } else if (std::string dem; p.read(t, "dem", "terrain.", dem) && !dem.empty()) {
      dems.push_back(p.resolve(dem));
    } else if (!t.contains("dem") || (t["dem"].is_string() && t["dem"].get<std::string>().empty())) {
      p.error("terrain.dem", "missing DEM file");
    }
    if (!dems.empty()) {
      scene.dem = dems.front();
      scene.demPaths = std::move(dems);
    }
    p.read(t, "crs", "terrain.", scene.demCrs);
    if (p.read(t, "height_unit", "terrain.", scene.demHeightUnit) &&
        !(geo::metresPerHeightUnit(scene.demHeightUnit) > 0.0)) {
      p.error("terrain.height_unit", "expected \"m\", \"ft\" or \"us-ft\", got \"" + scene.demHeightUnit + "\"");
      scene.demHeightUnit.clear();
    }
    if (std::string datum; p.read(t, "vertical_datum", "terrain.", datum)) {
      if (datum == "auto" || datum == "ellipsoid" || datum == "egm96" || datum == "egm2008") {
        scene.demVerticalDatum = datum;
      } else {
        p.error("terrain.vertical_datum",
                "expected \"auto\", \"ellipsoid\", \"egm96\" or \"egm2008\", got \"" + datum + "\"");
      }
    }
    if (p.read(t, "resolution_m", "terrain.", scene.demResolution) && !(scene.demResolution > 0.0)) {
      p.error("terrain.resolution_m", "must be a positive number of metres");
      scene.demResolution = 0.0;
    }
    if (p.read(t, "band", "terrain.", scene.demBand) && scene.demBand < 1) p.error("terrain.band", "bands start at 1");
    if (p.read(t, "vertical_exaggeration", "terrain.", scene.verticalExaggeration) &&
        !(scene.verticalExaggeration > 0.0)) {
      p.error("terrain.vertical_exaggeration", "must be positive");
    }
    std::string paging;
    if (p.read(t, "paging", "terrain.", paging)) {
      if (paging == "auto") {
        scene.paging = TerrainPaging::Auto;
      } else if (paging == "always") {
        scene.paging = TerrainPaging::Always;
      } else if (paging == "never") {
        scene.paging = TerrainPaging::Never;
      } else {
        p.error("terrain.paging", "expected \"auto\", \"always\" or \"never\", got \"" + paging + "\"");
      }
    }
    if (p.read(t, "memory_budget_mb", "terrain.", scene.memoryBudgetMb) && !(scene.memoryBudgetMb >= 16.0)) {
      p.error("terrain.memory_budget_mb", "must be at least 16");
      scene.memoryBudgetMb = 1024.0;
    }
    if (p.read(t, "gpu_budget_mb", "terrain.", scene.gpuBudgetMb) && !(scene.gpuBudgetMb >= 16.0)) {
      p.error("terrain.gpu_budget_mb", "must be at least 16");
      scene.gpuBudgetMb = 512.0;
    }
    if (p.read(t, "chunk_cells", "terrain.", scene.chunkCells) &&
        (scene.chunkCells < 8 || scene.chunkCells > 256 || (scene.chunkCells & (scene.chunkCells - 1)) != 0)) {
      p.error("terrain.chunk_cells", "must be a power of two from 8 to 256");
      scene.chunkCells = 64;
    }
    std::string cacheDir;
    if (p.read(t, "cache_dir", "terrain.", cacheDir) && !cacheDir.empty()) scene.cacheDir = p.resolve(cacheDir);
  }
  if (root.contains("imagery") && !root["imagery"].is_object()) {
    p.error("imagery", "expected an object with \"path\" (and \"bands\")");
  } else if (root.contains("imagery")) {
    const json& im = root["imagery"];
    p.warnUnknownKeys(im, {"path", "bands"}, "imagery.");
    std::string imagery;
    if (p.read(im, "path", "imagery.", imagery) && !imagery.empty()) scene.imagery = p.resolve(imagery);
    if (p.read(im, "bands", "imagery.", scene.imageryBands) && scene.imageryBands.size() != 1 &&
        scene.imageryBands.size() != 3) {
      p.error("imagery.bands", "give 1 (grey) or 3 (red, green, blue) band numbers");
    }
  }
  if (root.contains("layers")) {
    if (!root["layers"].is_array()) {
      p.error("layers", "expected an array");
    } else {
      // A broken layer entry is reported and left out; the other layers and the terrain load.
      for (std::size_t i = 0; i < root["layers"].size(); ++i) {
        const std::size_t errorsBefore = result.diagnostics.count(Severity::Error);
        LayerDescription layer = p.layer(root["layers"][i], i);
        layer.fileIndex = i;
        if (result.diagnostics.count(Severity::Error) == errorsBefore) scene.layers.push_back(std::move(layer));
      }
    }
  }
  if (root.contains("camera")) {
    Result<CameraSpec> camera = parseCameraSpec(root["camera"], path, "camera.");
    result.diagnostics.append(camera.diagnostics);
    if (camera) scene.camera = *camera;
  }
  // Without a DEM there is nothing to draw; everything else degrades with a message.
  if (!scene.dem.empty()) result.value = std::move(scene);
  return result;
}

geo::DemSpec SceneDescription::demSpec() const {
  geo::DemSpec spec;
  spec.paths = demPaths.empty() ? std::vector<std::string>{dem} : demPaths;
  spec.band = demBand;
  spec.crs = demCrs;
  spec.heightUnit = demHeightUnit;
  spec.resolutionMetres = demResolution;
  return spec;
}

Result<SceneDescription> loadSceneFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Result<SceneDescription>::failure({Severity::Error, path, "", "", "cannot open scene file"});
  std::ostringstream text;
  text << in.rdbuf();
  return parseScene(text.str(), path);
}

}  // namespace gis::scene
