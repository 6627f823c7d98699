#pragma once
// Reading what the programs write, for the tests that run them: text files and camera.json's
// column-major matrices.
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>

namespace gis::test {

/// The whole file, or "" if it cannot be read.
inline std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// A matrix written as 16 numbers, column by column (camera.json's "view" and "proj").
inline glm::dmat4 matrixOf(const nlohmann::json& a) {
  glm::dmat4 m(0.0);
  for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = a.at(static_cast<std::size_t>(i)).get<double>();
  return m;
}

/// proj × view of a camera.json.
inline glm::dmat4 viewProjOf(const nlohmann::json& camera) {
  return matrixOf(camera["proj"]) * matrixOf(camera["view"]);
}

}  // namespace gis::test
