// Linked into every executable of a sanitizer build (STENCIL_GIS_SANITIZE=ON).
// The sanitizer runtimes call these weak hooks at start-up.

extern "C" {

// Leaks inside Mesa's own libraries (llvmpipe's LLVM JIT, the DRI/gallium driver, EGL/GLX
// dispatch) are Mesa's, not ours: they keep per-process caches alive until exit. Suppress only
// frames from those shared objects; leaks with our frames on top still fail.
const char* __lsan_default_suppressions() {
  return "leak:libLLVM\n"
         "leak:libgallium\n"
         "leak:swrast_dri\n"
         "leak:libEGL_mesa\n"
         "leak:libGLX_mesa\n"
         "leak:libglapi\n"
         "leak:libdrm\n"
         "leak:libX11\n";
}

const char* __ubsan_default_options() { return "print_stacktrace=1:halt_on_error=1"; }

}  // extern "C"
