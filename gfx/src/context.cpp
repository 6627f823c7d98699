#include "gfx/context.hpp"

#include <cstring>

#include "gfx/gl.hpp"

namespace gis::gfx {

void Context::initialiseAfterMakeCurrent(bool debugOutput) {
  auto str = [](GLenum name) {
    const auto* s = reinterpret_cast<const char*>(glGetString(name));
    return std::string(s ? s : "");
  };
  info_.vendor = str(GL_VENDOR);
  info_.renderer = str(GL_RENDERER);
  info_.version = str(GL_VERSION);
  glGetIntegerv(GL_MAJOR_VERSION, &info_.major);
  glGetIntegerv(GL_MINOR_VERSION, &info_.minor);
  const int version = epoxy_gl_version();
  info_.clipControl = version >= 45 || epoxy_has_gl_extension("GL_ARB_clip_control");
  info_.pipelineStatistics = version >= 46 || epoxy_has_gl_extension("GL_ARB_pipeline_statistics_query");
  info_.timerQuery = version >= 33 || epoxy_has_gl_extension("GL_ARB_timer_query");
  glGetIntegerv(GL_MAX_SAMPLES, &info_.maxSamples);
  if (debugOutput) debug_ = std::make_unique<DebugOutput>();
}

}  // namespace gis::gfx
