#pragma once
// GLSL sources from shaders/, embedded at build time (cmake/EmbedShaders.cmake).
#include <optional>
#include <string_view>
#include <vector>

namespace gis::shaders {

/// The text of an embedded shader file, by file name ("terrain.vert"); nullopt if unknown.
std::optional<std::string_view> source(std::string_view name);

/// All embedded file names, for diagnostics and tests.
std::vector<std::string_view> names();

}  // namespace gis::shaders
