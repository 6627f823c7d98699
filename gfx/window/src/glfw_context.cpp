// A window context through GLFW (GLX on X11, also under Xvfb).
#include <string>

#include "core/log.hpp"
#include "gfx/context.hpp"
#include "gfx/gl.hpp"
#include "gfx/window_context.hpp"

#include <GLFW/glfw3.h>

namespace gis::gfx {
namespace {

std::string lastGlfwError() {
  const char* description = nullptr;
  glfwGetError(&description);
  return description ? description : "unknown GLFW error";
}

class GlfwContext final : public Context {
 public:
  explicit GlfwContext(GLFWwindow* window) : window_(window) {}
  ~GlfwContext() override {
    releaseBeforeDestroy();
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  void makeCurrent() override { glfwMakeContextCurrent(window_); }
  void swapBuffers() override { glfwSwapBuffers(window_); }
  [[nodiscard]] glm::ivec2 framebufferSize() const override {
    glm::ivec2 size(0);
    glfwGetFramebufferSize(window_, &size.x, &size.y);
    return size;
  }
  [[nodiscard]] bool headless() const override { return false; }
  [[nodiscard]] GLFWwindow* window() const override { return window_; }
  void initialise(bool debugOutput) { initialiseAfterMakeCurrent(debugOutput); }

 private:
  GLFWwindow* window_;
};

}  // namespace

bool windowSystemAvailable() {
  // GLFW stays initialised on success (createWindowContext's glfwInit is then a no-op; the
  // context's destructor terminates it): connecting twice in a row can hit an X server that
  // resets when its last client leaves (Xvfb without -noreset).
  glfwSetErrorCallback(nullptr);
  return glfwInit() == GLFW_TRUE;
}

Result<std::unique_ptr<Context>> createWindowContext(const ContextOptions& options) {
  using R = Result<std::unique_ptr<Context>>;
  if (glfwInit() != GLFW_TRUE) {
    return R::failure(Diagnostic{Severity::Error, "", "", "", "no window system: " + lastGlfwError()});
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, options.debug ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_DEPTH_BITS, 24);
  glfwWindowHint(GLFW_STENCIL_BITS, 8);
  glfwWindowHint(GLFW_SAMPLES, options.samples);
  glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_TRUE);
  GLFWwindow* window = glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window) {
    const std::string error = lastGlfwError();
    glfwTerminate();
    return R::failure(Diagnostic{Severity::Error, "", "", "", "cannot open an OpenGL 4.5 core window: " + error});
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(options.vsync ? 1 : 0);
  auto ctx = std::make_unique<GlfwContext>(window);
  ctx->initialise(options.debug);
  logDebug("window context: " + ctx->info().renderer + ", " + ctx->info().version);
  R result;
  result.value = std::move(ctx);
  return result;
}

}  // namespace gis::gfx
