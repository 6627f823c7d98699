#pragma once
// A current OpenGL 4.5 core context, headless (EGL, Mesa surfaceless) or in a window (GLFW,
// gfx/window_context.hpp in gis::window), behind one interface: everything above gfx works with
// either.
#include <memory>
#include <string>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "gfx/debug.hpp"

struct GLFWwindow;

namespace gis::gfx {

struct ContextOptions {
  int width = 1280;  ///< window size (ignored when headless: render into RenderTargets)
  int height = 800;
  std::string title = "stencil-gis";
  bool debug = true;  ///< KHR_debug context with synchronous debug output
  bool vsync = true;
  int samples = 0;  ///< window back buffer MSAA samples
};

/// Vendor, renderer and version strings plus the capabilities later passes rely on.
struct GlInfo {
  std::string vendor;
  std::string renderer;
  std::string version;
  int major = 0;
  int minor = 0;
  bool clipControl = false;
  bool pipelineStatistics = false;
  bool timerQuery = false;
  int maxSamples = 0;
};

class Context {
 public:
  virtual ~Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  virtual void makeCurrent() = 0;
  /// Presents the back buffer (no-op when headless).
  virtual void swapBuffers() = 0;
  /// Size of the default framebuffer in pixels (0×0 when headless).
  [[nodiscard]] virtual glm::ivec2 framebufferSize() const = 0;
  [[nodiscard]] virtual bool headless() const = 0;
  /// The GLFW window, or nullptr when headless.
  [[nodiscard]] virtual GLFWwindow* window() const { return nullptr; }

  [[nodiscard]] const GlInfo& info() const { return info_; }
  /// Debug output of this context (errors counted; messages go to the logger).
  [[nodiscard]] DebugOutput& debug() { return *debug_; }

 protected:
  Context() = default;
  /// Queries GlInfo and installs the debug callback; called by implementations once current.
  void initialiseAfterMakeCurrent(bool debugOutput);
  /// Detaches the debug callback; implementations call it while the context is still current.
  void releaseBeforeDestroy() { debug_.reset(); }

 private:
  GlInfo info_;
  std::unique_ptr<DebugOutput> debug_;
};

/// OpenGL 4.5 core through EGL on Mesa's surfaceless platform: no display, no window.
Result<std::unique_ptr<Context>> createHeadlessContext(const ContextOptions& options = {});

}  // namespace gis::gfx
