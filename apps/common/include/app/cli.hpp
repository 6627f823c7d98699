#pragma once
// Small helpers shared by the command-line programs.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "core/diagnostics.hpp"
#include "core/heap.hpp"
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

/// Sends the diagnostics to the logger at their severity, each kind once with its count and its
/// first features (groupDiagnostics): a layer of 16,906 one-point lines is one line of the log.
/// stats.json keeps every message.
inline void report(const Diagnostics& diagnostics) {
  for (const DiagnosticGroup& g : groupDiagnostics(diagnostics)) {
    log(g.severity == Severity::Error     ? LogLevel::Error
        : g.severity == Severity::Warning ? LogLevel::Warning
                                          : LogLevel::Info,
        g.toString());
  }
}

/// Runs `body`; an exception that escapes it is reported (`name: internal error: …`) and becomes
/// exit status 1, so no program ends in std::terminate.
inline int guardedMain(const char* name, const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", name, e.what());
  } catch (...) {
    std::fprintf(stderr, "%s: internal error (an unknown exception)\n", name);
  }
  return 1;
}

/// The common shape of our programs' main(): --help prints the usage; `parse` returns an error
/// message (printed with the usage, exit status 2) or an empty string; then `run` decides. Both
/// run inside guardedMain, with freed heap kept for the next frame (keepFreedHeapForFrames).
inline int programMain(int argc, char** argv, const char* name, const char* usage,
                       const std::function<std::string(int, char**)>& parse, const std::function<int()>& run) {
  keepFreedHeapForFrames();
  return guardedMain(name, [&] {
    if (argc == 2 && (std::string_view(argv[1]) == "--help" || std::string_view(argv[1]) == "-h")) {
      std::fputs(usage, stdout);
      return 0;
    }
    const std::string error = parse(argc, argv);
    if (!error.empty()) {
      std::fprintf(stderr, "%s: %s\n%s", name, error.c_str(), usage);
      return 2;
    }
    return run();
  });
}

}  // namespace gis::app
