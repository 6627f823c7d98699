#include "app/viewer_settings.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <system_error>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "scene/json_file.hpp"

namespace gis::app {

std::optional<std::filesystem::path> settingsPath() {
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg != nullptr && *xdg != '\0') {
    return std::filesystem::path(xdg) / "stencil-gis" / "viewer.json";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0') {
    return std::filesystem::path(home) / ".config" / "stencil-gis" / "viewer.json";
  }
  return std::nullopt;
}

Result<ViewerSettings> loadViewerSettings(const std::filesystem::path& path) {
  Result<ViewerSettings> r;
  r.value = ViewerSettings{};
  std::ifstream in(path);
  if (!in) return r;  // first run
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    r.diagnostics.add(
        {Severity::Warning, path.string(), "", "", "not a settings file (JSON object); using the defaults"});
    return r;
  }
  ViewerSettings& s = *r.value;
  // Each value on its own: one bad entry does not lose the others.
  auto number = [&](const char* key, auto& target, double lo, double hi) {
    if (!j.contains(key)) return;
    const nlohmann::json& v = j[key];
    if (!v.is_number() || v.get<double>() < lo || v.get<double>() > hi) {
      r.diagnostics.add({Severity::Warning, path.string(), "", "",
                         std::string("'") + key + "' must be a number in [" + std::to_string(lo) + ", " +
                             std::to_string(hi) + "]; using the default"});
      return;
    }
    target = v.get<std::remove_reference_t<decltype(target)>>();
  };
  auto flag = [&](const char* key, bool& target) {
    if (!j.contains(key)) return;
    if (!j[key].is_boolean()) {
      r.diagnostics.add({Severity::Warning, path.string(), "", "",
                         std::string("'") + key + "' must be true or false; using the default"});
      return;
    }
    target = j[key].get<bool>();
  };
  if (j.contains("window")) {
    const nlohmann::json& w = j["window"];
    const auto finite = [](const nlohmann::json& v) { return v.is_number() && std::isfinite(v.get<double>()); };
    if (w.is_array() && w.size() == 2 && finite(w[0]) && finite(w[1])) {
      // A window that no longer fits the screen, or was made tiny, still opens usable.
      s.windowSize = glm::ivec2(static_cast<int>(std::clamp(w[0].get<double>(), 320.0, 16384.0)),
                                static_cast<int>(std::clamp(w[1].get<double>(), 240.0, 16384.0)));
    } else {
      r.diagnostics.add(
          {Severity::Warning, path.string(), "", "", "'window' must be [width, height]; using the default"});
    }
  }
  number("lod_tolerance_px", s.lodTolerancePixels, 0.0, 64.0);
  number("fov_y_deg", s.fovYDeg, 5.0, 120.0);
  flag("show_hud", s.showHud);
  flag("show_panel", s.showPanel);
  flag("imagery", s.imagery);
  if (j.contains("export_path")) {
    if (j["export_path"].is_string() && !j["export_path"].get<std::string>().empty()) {
      s.exportPath = j["export_path"].get<std::string>();
    } else {
      r.diagnostics.add(
          {Severity::Warning, path.string(), "", "", "'export_path' must be a non-empty string; using the default"});
    }
  }
  return r;
}

Diagnostics saveViewerSettings(const ViewerSettings& s, const std::filesystem::path& path) {
  Diagnostics d;
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  const nlohmann::json j = {{"window", {s.windowSize.x, s.windowSize.y}},
                            {"lod_tolerance_px", s.lodTolerancePixels},
                            {"fov_y_deg", s.fovYDeg},
                            {"show_hud", s.showHud},
                            {"show_panel", s.showPanel},
                            {"imagery", s.imagery},
                            {"export_path", s.exportPath}};
  if (!scene::writeJsonFile(path.string(), j))
    d.add({Severity::Warning, path.string(), "", "", "cannot write the viewer settings"});
  return d;
}

}  // namespace gis::app
