// Linked into every executable of a sanitizer build (STENCIL_GIS_SANITIZE=ON).
// The sanitizer runtimes call these weak hooks at start-up.
#include <dlfcn.h>

#include <cstdlib>
#include <initializer_list>

namespace {

// Mesa unloads its DRI driver when the last display closes (glfwTerminate, eglTerminate), and
// LeakSanitizer can then no longer name the frames of what the driver leaked ("<unknown
// module>"), so the suppressions below cannot match them. Pinning the driver with RTLD_NODELETE
// keeps its frames nameable; leaks in our own code are reported as before.
//
// llvmpipe also runs rasteriser threads; under load, LeakSanitizer's stop-the-world at exit
// occasionally crashed ("Tracer caught signal 11") while stopping them. Sanitizer builds run
// llvmpipe single-threaded (LP_NUM_THREADS=0, unless the caller set it): same pixels, no race.
struct PinMesaDriver {
  PinMesaDriver() {
    setenv("LP_NUM_THREADS", "0", 0);
    for (const char* path : {"/usr/lib/x86_64-linux-gnu/dri/swrast_dri.so", "/usr/lib/dri/swrast_dri.so"}) {
      if (dlopen(path, RTLD_LAZY | RTLD_LOCAL | RTLD_NODELETE) != nullptr) break;
    }
  }
} pinMesaDriver;

}  // namespace

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

// GCC 12's sanitizer runtime on Debian 12's glibc (2.36) can record a bogus dynamic TLS block
// for a module loaded at run time (seen: "DTLS 40 at 0x845b-0x18000955d"); LeakSanitizer's
// stop-the-world at exit then crashes reading it ("Tracer caught signal 11"), deterministically
// for overlay_render reading a longitude/latitude Shapefile when a test started it. Without
// intercepting __tls_get_addr that block is not recorded; the whole sanitizer suite then runs
// with no leak reported (dynamic TLS held nothing that only it could reach).
//
// Freed memory waits in a quarantine of 64 MB before it is used again, not 256: a use after
// free is still caught while the freed block is among the last 64 MB freed, and a short process
// stops faulting in a fresh page for nearly every block it allocates (overlay_render on Olinda,
// warm: 3.4 → 3.0 s of CPU, 124 k → 113 k page faults, 695 → 585 MB peak).
const char* __asan_default_options() { return "intercept_tls_get_addr=0:quarantine_size_mb=64"; }

}  // extern "C"
