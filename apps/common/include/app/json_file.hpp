#pragma once
// Reading the programs' JSON files (scripts, lasso files, camera files) with errors that name
// the file.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/diagnostics.hpp"

namespace gis::app {

/// The file's JSON; nothing, with an error naming the file, if it cannot be opened or is not JSON.
std::optional<nlohmann::json> readJsonFile(const std::string& path, Diagnostics& d);

}  // namespace gis::app
