#pragma once
// Small helpers shared by the command-line programs.
#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>

#include "core/diagnostics.hpp"
#include "core/log.hpp"

namespace gis::app {

inline std::optional<int> parseInt(std::string_view text) {
  int value = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

inline std::optional<double> parseDouble(std::string_view text) {
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

/// Sends every diagnostic to the logger at its severity.
inline void report(const Diagnostics& diagnostics) {
  for (const Diagnostic& d : diagnostics.items()) {
    log(d.severity == Severity::Error     ? LogLevel::Error
        : d.severity == Severity::Warning ? LogLevel::Warning
                                          : LogLevel::Info,
        d.toString());
  }
}

}  // namespace gis::app
