#include "core/log.hpp"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <utility>

namespace gis {
namespace {

const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::Debug:
      return "debug";
    case LogLevel::Info:
      return "info";
    case LogLevel::Warning:
      return "warning";
    case LogLevel::Error:
      return "error";
  }
  return "?";
}

void stderrSink(LogLevel level, std::string_view message) {
  std::fprintf(stderr, "[%s] %.*s\n", levelName(level), static_cast<int>(message.size()), message.data());
}

std::mutex& sinkMutex() {
  static std::mutex m;
  return m;
}
LogSink& currentSink() {
  static LogSink sink = stderrSink;
  return sink;
}
std::atomic<LogLevel> gMinLevel{LogLevel::Info};

}  // namespace

LogSink setLogSink(LogSink sink) {
  std::lock_guard lock(sinkMutex());
  LogSink old = std::move(currentSink());
  currentSink() = sink ? std::move(sink) : LogSink(stderrSink);
  return old;
}

void setLogLevel(LogLevel level) { gMinLevel = level; }

void log(LogLevel level, std::string_view message) {
  if (level < gMinLevel.load()) return;
  std::lock_guard lock(sinkMutex());
  currentSink()(level, message);
}

}  // namespace gis
