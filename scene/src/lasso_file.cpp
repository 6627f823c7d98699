#include "scene/lasso_file.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "scene/globe_scene.hpp"
#include "scene/json_file.hpp"
#include "vector_overlay/globe_selection.hpp"
#include "vector_overlay/style.hpp"

namespace gis::scene {
namespace {

using nlohmann::json;

/// "#rrggbb" and an opacity in [0, 1] from an object {"color", "opacity"}.
bool readColour(const json& j, const char* key, const std::string& file, glm::vec4& colour, float& opacity,
                Diagnostics& d) {
  if (!j.contains(key)) return false;
  const json& o = j[key];
  if (!o.is_object()) {
    d.add({Severity::Error, file, "", "", std::string("'") + key + "': expected {\"color\", \"opacity\"}"});
    return false;
  }
  bool ok = true;
  if (o.contains("color")) {
    glm::vec4 c(1.0F);
    if (!o["color"].is_string() || !overlay::parseHexColor(o["color"].get<std::string>(), c)) {
      d.add({Severity::Error, file, "", "", std::string("'") + key + ".color': expected \"#rrggbb\""});
      ok = false;
    } else {
      colour = c;
    }
  }
  if (o.contains("opacity")) {
    if (!o["opacity"].is_number() || !(o["opacity"].get<double>() >= 0.0 && o["opacity"].get<double>() <= 1.0)) {
      d.add({Severity::Error, file, "", "", std::string("'") + key + ".opacity': expected a number in [0, 1]"});
      ok = false;
    } else {
      opacity = o["opacity"].get<float>();
    }
  }
  return ok;
}

LassoCamera lassoCameraOf(const Camera& camera) {
  return {[camera](int w, int h) { return camera.projection(static_cast<double>(w) / h) * camera.view(); },
          camera.nearPlane};
}

/// A projected scene's cameras (scene/camera.hpp) placed in its frame.
LassoCameraPlacer projectedPlacer(const geo::SceneFrame& frame) {
  return [&frame](const json& spec, const std::string& where, Diagnostics& d) -> std::optional<LassoCamera> {
    Result<CameraSpec> parsed = parseCameraSpec(spec, where);
    d.append(parsed.diagnostics);
    if (!parsed) return std::nullopt;
    Result<Camera> placed = placeCamera(*parsed, frame, where);
    d.append(placed.diagnostics);
    if (!placed) return std::nullopt;
    return lassoCameraOf(*placed);
  };
}

LassoCamera lassoCameraOf(const globe::GlobeView& view, const globe::GeoGrid& ground) {
  return {[view](int w, int h) {
            globe::GlobeView sized = view;
            sized.width = w;
            sized.height = h;
            return sized.viewProj();
          },
          view.near, globe::horizonReach(view.eye, ground.bounds({-180.0, -90.0, 180.0, 90.0}).second)};
}

}  // namespace

Result<SelectionRequest> parseLassoFile(const json& j, const std::string& file, const std::string& baseDir,
                                        const geo::SceneFrame& frame, const Camera& current, int width, int height) {
  return parseLassoFile(j, file, baseDir, lassoCameraOf(current), projectedPlacer(frame), width, height);
}

Result<SelectionRequest> parseLassoFile(const json& j, const std::string& file, const std::string& baseDir,
                                        const LassoCamera& current, const LassoCameraPlacer& place, int width,
                                        int height) {
  Result<SelectionRequest> result;
  Diagnostics& d = result.diagnostics;
  if (!j.is_object() || !j.contains("lassos") || !j["lassos"].is_array()) {
    return Result<SelectionRequest>::failure(
        {Severity::Error, file, "", "", "expected an object with an array 'lassos'"});
  }
  SelectionRequest request;
  warnUnknownKeys(j, {"lassos", "highlight", "show_volumes", "scheme", "sample_spacing_m"}, file, "", d);
  for (const char* colour : {"highlight", "show_volumes"}) {
    if (j.contains(colour)) warnUnknownKeys(j[colour], {"color", "opacity"}, file, std::string(colour) + ".", d);
  }
  readColour(j, "highlight", file, request.highlight.color, request.highlight.opacity, d);
  if (j.contains("show_volumes") && !(j["show_volumes"].is_boolean() && !j["show_volumes"].get<bool>())) {
    glm::vec4 colour(0.2F, 0.6F, 1.0F, 1.0F);
    float opacity = 0.25F;
    if (j["show_volumes"].is_boolean() || readColour(j, "show_volumes", file, colour, opacity, d)) {
      request.showVolumes = glm::vec4(colour.x, colour.y, colour.z, opacity);
    }
  }
  if (j.contains("scheme")) {
    const json& s = j["scheme"];
    if (s == "runs") {
      request.scheme = overlay::SelectionScheme::Runs;
    } else if (s == "report") {
      request.scheme = overlay::SelectionScheme::Report;
    } else {
      d.add({Severity::Error, file, "", "", "'scheme': expected \"runs\" or \"report\""});
    }
  }
  if (j.contains("sample_spacing_m")) {
    const json& s = j["sample_spacing_m"];
    if (!s.is_number() || !(s.get<double>() > 0.0)) {
      d.add({Severity::Error, file, "", "", "'sample_spacing_m': expected a positive number (metres)"});
    } else {
      request.sampleSpacing = s.get<double>();
    }
  }
  std::size_t index = 0;
  for (const json& entry : j["lassos"]) {
    const std::string name = "lasso " + std::to_string(++index);
    const auto bad = [&](const std::string& problem) {
      d.add({Severity::Error, file, "", name, problem + "; left out of the selection"});
    };
    if (!entry.is_object()) {
      bad("expected an object");
      continue;
    }
    warnUnknownKeys(entry, {"op", "camera", "width", "height", "distance", "points"}, file,
                    "lassos[" + std::to_string(index - 1) + "].", d);
    const std::optional<overlay::SelectionOp> op =
        entry.contains("op") && entry["op"].is_string()
            ? overlay::parseSelectionOp(entry["op"].get<std::string>())
            : (entry.contains("op") ? std::nullopt : std::optional<overlay::SelectionOp>(overlay::SelectionOp::Or));
    if (!op) {
      bad("'op': expected one of single, or, and, xor, subtract, invert");
      continue;
    }
    overlay::SelectionStep step;
    step.op = index == 1 && !entry.contains("op") ? overlay::SelectionOp::Single : *op;
    step.lasso.file = file;
    step.lasso.label = name;
    if (step.op == overlay::SelectionOp::Invert) {
      request.steps.push_back(step);
      continue;
    }
    // The camera and viewport it was drawn with.
    LassoCamera camera = current;
    int w = width, h = height;
    if (entry.contains("camera")) {
      const json& c = entry["camera"];
      std::optional<json> spec;
      std::string where = file;
      if (c.is_string()) {
        std::filesystem::path p(c.get<std::string>());
        if (p.is_relative()) p = std::filesystem::path(baseDir) / p;
        where = p.string();
        spec = readJsonFile(where, d);
        if (spec && spec->is_object()) {
          w = numberAs<int>((*spec)["width"]).value_or(w);
          h = numberAs<int>((*spec)["height"]).value_or(h);
        }
      } else {
        spec = c;
      }
      if (!spec) {
        bad("camera file cannot be read");
        continue;
      }
      std::optional<LassoCamera> placed = place(*spec, where, d);
      if (!placed) {
        bad("camera cannot be placed");
        continue;
      }
      camera = std::move(*placed);
    }
    for (const char* key : {"width", "height"}) {
      if (!entry.contains(key)) continue;
      const std::optional<int> size = numberAs<int>(entry[key]);
      if (!entry[key].is_number_integer() || !size || *size < 1 || *size > 65536) {
        bad(std::string("'") + key + "': expected a positive integer (pixels)");
        w = 0;
      } else {
        (std::string(key) == "width" ? w : h) = *size;
      }
    }
    if (w < 1 || h < 1) continue;
    step.lasso.width = w;
    step.lasso.height = h;
    step.lasso.viewProj = camera.viewProj(w, h);
    step.lasso.distance = camera.distance;
    if (entry.contains("distance")) {
      const json& dist = entry["distance"];
      if (dist.is_null()) {
        step.lasso.distance = std::numeric_limits<double>::infinity();
      } else if (!dist.is_number() || !(dist.get<double>() > camera.nearPlane)) {
        bad("'distance': expected a number of metres beyond the near plane, or null (infinity)");
        continue;
      } else {
        step.lasso.distance = dist.get<double>();
      }
    }
    const json& points = entry.contains("points") ? entry["points"] : json();
    bool ok = points.is_array();
    for (const json& p : points.is_array() ? points : json::array()) {
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
          !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>())) {
        ok = false;
        break;
      }
      step.lasso.points.emplace_back(p[0].get<double>(), p[1].get<double>());
    }
    if (!ok || step.lasso.points.size() < 3) {
      bad("'points': expected at least 3 pixel positions [x, y] (finite numbers)");
      continue;
    }
    request.steps.push_back(std::move(step));
  }
  if (request.steps.empty()) d.add({Severity::Warning, file, "", "", "no usable lasso: nothing is selected"});
  result.value = std::move(request);
  return result;
}

Result<SelectionRequest> loadLassoFile(const std::string& path, const geo::SceneFrame& frame, const Camera& current,
                                       int width, int height) {
  return loadLassoFile(path, lassoCameraOf(current), projectedPlacer(frame), width, height);
}

Result<SelectionRequest> loadGlobeLassoFile(const std::string& path, const globe::GlobeView& current,
                                            const globe::GeoGrid& ground) {
  const LassoCameraPlacer place = [&ground](const json& spec, const std::string& where,
                                            Diagnostics& d) -> std::optional<LassoCamera> {
    Result<CameraSpec> parsed = parseCameraSpec(spec, where);
    d.append(parsed.diagnostics);
    if (!parsed) return std::nullopt;
    Result<globe::GlobeView> view = globeViewOf(*parsed, ground, 1, 1, where);
    d.append(view.diagnostics);
    if (!view) return std::nullopt;
    return lassoCameraOf(*view, ground);
  };
  return loadLassoFile(path, lassoCameraOf(current, ground), place, current.width, current.height);
}

Result<SelectionRequest> loadLassoFile(const std::string& path, const LassoCamera& current,
                                       const LassoCameraPlacer& place, int width, int height) {
  Diagnostics d;
  const std::optional<json> j = readJsonFile(path, d);
  if (!j) {
    Result<SelectionRequest> failed;
    failed.diagnostics = d;
    return failed;
  }
  return parseLassoFile(*j, path, std::filesystem::path(path).parent_path().string(), current, place, width, height);
}

}  // namespace gis::scene
