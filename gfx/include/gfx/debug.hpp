#pragma once
// KHR_debug output routed to the logger. Errors are counted so a GL test can fail on any.
#include <atomic>
#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace gis::gfx {

class DebugOutput {
 public:
  /// Installs the callback on the current context (synchronous output).
  DebugOutput();
  ~DebugOutput();
  DebugOutput(const DebugOutput&) = delete;
  DebugOutput& operator=(const DebugOutput&) = delete;

  /// Number of messages of type GL_DEBUG_TYPE_ERROR since construction or the last reset.
  [[nodiscard]] std::size_t errorCount() const { return errors_.load(); }
  /// The text of the error messages (for test failure output).
  [[nodiscard]] std::vector<std::string> errorMessages() const;
  void reset();

  /// Called from the GL callback.
  void receive(unsigned source, unsigned type, unsigned id, unsigned severity, const char* message);

 private:
  std::atomic<std::size_t> errors_{0};
  mutable std::mutex mutex_;
  std::vector<std::string> errorTexts_;
};

}  // namespace gis::gfx
