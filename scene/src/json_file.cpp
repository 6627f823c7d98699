#include "scene/json_file.hpp"

#include <fstream>

namespace gis::scene {

std::optional<nlohmann::json> readJsonFile(const std::string& path, Diagnostics& d) {
  std::ifstream in(path);
  if (!in) {
    d.add({Severity::Error, path, "", "", "cannot open"});
    return std::nullopt;
  }
  try {
    nlohmann::json j;
    in >> j;
    return j;
  } catch (const nlohmann::json::exception& e) {
    d.add({Severity::Error, path, "", "", std::string("not JSON: ") + e.what()});
    return std::nullopt;
  }
}

}  // namespace gis::scene
