#pragma once
// What the viewer remembers between runs: window size, view and panel settings. Stored as JSON in
// $XDG_CONFIG_HOME/stencil-gis/viewer.json (or ~/.config/…); a missing or broken file gives the
// defaults (reported, never fatal). Scripted runs neither read nor write it, so tests see the
// defaults whatever the machine's user did.
#include <filesystem>
#include <optional>
#include <string>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"

namespace gis::app {

struct ViewerSettings {
  glm::ivec2 windowSize{1280, 800};
  double lodTolerancePixels = 1.5;
  double fovYDeg = 45.0;
  bool showHud = true;
  bool showPanel = true;
  bool imagery = true;  ///< off: hillshade
  std::string exportPath = "selected_features.json";
};

/// The settings file's path, or nullopt when neither XDG_CONFIG_HOME nor HOME is set.
std::optional<std::filesystem::path> settingsPath();

/// Reads the file; unknown or malformed values keep their defaults, with a warning.
Result<ViewerSettings> loadViewerSettings(const std::filesystem::path& path);
Diagnostics saveViewerSettings(const ViewerSettings& settings, const std::filesystem::path& path);

}  // namespace gis::app
