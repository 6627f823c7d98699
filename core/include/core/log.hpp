#pragma once
// One logger for the whole product, injected by the application. Libraries never print.
#include <functional>
#include <string_view>

namespace gis {

enum class LogLevel { Debug, Info, Warning, Error };

/// Receives every message of the libraries. The default sink writes to stderr.
using LogSink = std::function<void(LogLevel, std::string_view)>;

/// Replaces the sink (e.g. a test that collects messages, a viewer console); returns the old one.
LogSink setLogSink(LogSink sink);
/// Messages below this level are dropped (default: Info).
void setLogLevel(LogLevel level);

void log(LogLevel level, std::string_view message);
inline void logDebug(std::string_view m) { log(LogLevel::Debug, m); }
inline void logInfo(std::string_view m) { log(LogLevel::Info, m); }
inline void logWarning(std::string_view m) { log(LogLevel::Warning, m); }
inline void logError(std::string_view m) { log(LogLevel::Error, m); }

}  // namespace gis
