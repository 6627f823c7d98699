#pragma once
// Reading the programs' JSON files (scripts, lasso files, camera files) with errors that name
// the file.
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "core/diagnostics.hpp"

namespace gis::scene {

/// JSON text for an output file. Strings that are not UTF-8 (a path in a Latin-1 folder name, say)
/// get U+FFFD for their bad bytes instead of an exception (nlohmann's dump throws on them).
inline std::string jsonText(const nlohmann::json& j, int indent = 2) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

/// Writes `j` (jsonText, a line end after it) to `path` whole or not at all: into a sibling file
/// that is then renamed over `path`, so a program polling for the file never reads half of it.
/// False when it cannot be written (the partial sibling is removed).
bool writeJsonFile(const std::string& path, const nlohmann::json& j);

/// The file's JSON; nothing, with an error naming the file, if it cannot be opened or is not JSON.
std::optional<nlohmann::json> readJsonFile(const std::string& path, Diagnostics& d);

/// The key of `known` a misspelt `key` most likely meant: the nearest by edits (a letter added,
/// dropped or changed, two neighbours swapped), if at most 2 edits and fewer than half of `key`'s
/// letters away ("widht_m" → "width_m", "colour" → "color"; "meshes" → none of a scene's keys).
std::optional<std::string> closestKey(std::string_view key, std::initializer_list<std::string_view> known);

/// A warning for each key of `object` not in `known`, naming the file and the key's JSON path
/// (`where` ends with "." or is empty): `unknown key "layers[2].style.widht_m" (ignored); did you
/// mean "width_m"?`. Nothing when `object` is not an object (its reader says what it expected).
void warnUnknownKeys(const nlohmann::json& object, std::initializer_list<std::string_view> known,
                     const std::string& file, const std::string& where, Diagnostics& d);

/// `v` as an arithmetic T when it is a JSON number that T can hold: finite, within T's range and,
/// for integral T, whole; else nothing. (nlohmann's get<int>() of 1e10 or get<float>() of 1e300
/// would be undefined behaviour.)
template <typename T>
std::optional<T> numberAs(const nlohmann::json& v) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
  if (!v.is_number()) return std::nullopt;
  if constexpr (std::is_integral_v<T>) {
    if (v.is_number_integer()) {
      // Compare in the widest types: no conversion of an out-of-range value.
      if (v.is_number_unsigned()) {
        const auto u = v.get<unsigned long long>();
        if (u > static_cast<unsigned long long>(std::numeric_limits<T>::max())) return std::nullopt;
        return static_cast<T>(u);
      }
      const auto i = v.get<long long>();
      if (i < static_cast<long long>(std::numeric_limits<T>::lowest()) ||
          (i > 0 &&
           static_cast<unsigned long long>(i) > static_cast<unsigned long long>(std::numeric_limits<T>::max())))
        return std::nullopt;
      return static_cast<T>(i);
    }
    const double x = v.get<double>();
    if (!std::isfinite(x) || x != std::floor(x) || x < static_cast<double>(std::numeric_limits<T>::lowest()) ||
        x > static_cast<double>(std::numeric_limits<T>::max()))
      return std::nullopt;
    return static_cast<T>(x);
  } else {
    const double x = v.get<double>();
    if (!std::isfinite(x) || std::abs(x) > static_cast<double>(std::numeric_limits<T>::max())) return std::nullopt;
    return static_cast<T>(x);
  }
}

}  // namespace gis::scene
