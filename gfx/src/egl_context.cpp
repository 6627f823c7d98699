// Headless OpenGL 4.5 core through EGL. Mesa's surfaceless platform needs no display server
// and no GPU (llvmpipe); the context renders only into framebuffer objects.
#include <epoxy/egl.h>

#include <string>

#include "core/log.hpp"
#include "gfx/context.hpp"

#ifndef EGL_PLATFORM_SURFACELESS_MESA
#define EGL_PLATFORM_SURFACELESS_MESA 0x31DD
#endif

namespace gis::gfx {
namespace {

Diagnostic eglError(const std::string& what) {
  char code[32];
  std::snprintf(code, sizeof code, " (EGL error 0x%04x)", static_cast<unsigned>(eglGetError()));
  return Diagnostic{Severity::Error, "", "", "", "headless OpenGL: " + what + code};
}

class EglContext final : public Context {
 public:
  EglContext(EGLDisplay display, EGLContext context) : display_(display), context_(context) {}
  ~EglContext() override {
    releaseBeforeDestroy();
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    // No eglTerminate: the display is one per process and shared by every context on it, so
    // terminating it here would break other live contexts. (It also keeps Mesa's driver loaded
    // until exit, so LeakSanitizer can name Mesa's own frames in its reports.)
  }
  void makeCurrent() override { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_); }
  void swapBuffers() override {}
  [[nodiscard]] glm::ivec2 framebufferSize() const override { return {0, 0}; }
  [[nodiscard]] bool headless() const override { return true; }
  void initialise(bool debugOutput) { initialiseAfterMakeCurrent(debugOutput); }

 private:
  EGLDisplay display_;
  EGLContext context_;
};

EGLDisplay openDisplay() {
  // Prefer Mesa's surfaceless platform: works with no X server, no GBM device, no GPU.
  if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY) return d;
  }
  return eglGetDisplay(EGL_DEFAULT_DISPLAY);
}

}  // namespace

Result<std::unique_ptr<Context>> createHeadlessContext(const ContextOptions& options) {
  using R = Result<std::unique_ptr<Context>>;
  EGLDisplay display = openDisplay();
  if (display == EGL_NO_DISPLAY) return R::failure(eglError("no EGL display"));
  EGLint major = 0, minor = 0;
  if (eglInitialize(display, &major, &minor) != EGL_TRUE) return R::failure(eglError("eglInitialize failed"));
  if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) {
    eglTerminate(display);
    return R::failure(eglError("desktop OpenGL API not available"));
  }
  const EGLint configAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configCount = 0;
  EGLBoolean chosen = eglChooseConfig(display, configAttribs, &config, 1, &configCount);
  if (chosen != EGL_TRUE || configCount == 0) {
    // Surfaceless rendering does not need a pbuffer-capable config.
    const EGLint anyAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
    chosen = eglChooseConfig(display, anyAttribs, &config, 1, &configCount);
  }
  if (chosen != EGL_TRUE || configCount == 0) {
    eglTerminate(display);
    return R::failure(eglError("no EGL config for desktop OpenGL"));
  }
  const EGLint contextAttribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                   4,
                                   EGL_CONTEXT_MINOR_VERSION,
                                   5,
                                   EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                   EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                   EGL_CONTEXT_OPENGL_DEBUG,
                                   options.debug ? EGL_TRUE : EGL_FALSE,
                                   EGL_NONE};
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, contextAttribs);
  if (context == EGL_NO_CONTEXT) {
    eglTerminate(display);
    return R::failure(eglError("cannot create an OpenGL 4.5 core context"));
  }
  if (eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context) != EGL_TRUE) {
    eglDestroyContext(display, context);
    eglTerminate(display);
    return R::failure(eglError("eglMakeCurrent (surfaceless) failed"));
  }
  auto ctx = std::make_unique<EglContext>(display, context);
  ctx->initialise(options.debug);
  logDebug("headless context: " + ctx->info().renderer + ", " + ctx->info().version);
  R result;
  result.value = std::move(ctx);
  return result;
}

}  // namespace gis::gfx
