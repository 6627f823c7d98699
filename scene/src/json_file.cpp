#include "scene/json_file.hpp"

#include <filesystem>
#include <fstream>

namespace gis::scene {

std::optional<nlohmann::json> readJsonFile(const std::string& path, Diagnostics& d) {
  // A folder opens as a stream on Linux, and reading it throws: say what it is instead.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    d.add({Severity::Error, path, "", "", "is a folder, not a file"});
    return std::nullopt;
  }
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
  } catch (const std::exception& e) {
    d.add({Severity::Error, path, "", "", std::string("cannot read: ") + e.what()});
  }
  return std::nullopt;
}

}  // namespace gis::scene
