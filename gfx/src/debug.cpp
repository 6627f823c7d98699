#include "gfx/debug.hpp"

#include <string>

#include "core/log.hpp"
#include "gfx/gl.hpp"

namespace gis::gfx {
namespace {

void GLAPIENTRY onDebugMessage(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei /*length*/,
                               const GLchar* message, const void* user) {
  auto* self = static_cast<DebugOutput*>(const_cast<void*>(user));
  self->receive(source, type, id, severity, message);
}

const char* typeName(GLenum type) {
  switch (type) {
    case GL_DEBUG_TYPE_ERROR:
      return "error";
    case GL_DEBUG_TYPE_DEPRECATED_BEHAVIOR:
      return "deprecated";
    case GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR:
      return "undefined behaviour";
    case GL_DEBUG_TYPE_PORTABILITY:
      return "portability";
    case GL_DEBUG_TYPE_PERFORMANCE:
      return "performance";
    default:
      return "other";
  }
}

}  // namespace

DebugOutput::DebugOutput() {
  glEnable(GL_DEBUG_OUTPUT);
  glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
  glDebugMessageCallback(onDebugMessage, this);
  glDebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, nullptr, GL_TRUE);
}

DebugOutput::~DebugOutput() { glDebugMessageCallback(nullptr, nullptr); }

void DebugOutput::receive(unsigned /*source*/, unsigned type, unsigned id, unsigned severity, const char* message) {
  const std::string text = std::string("GL ") + typeName(type) + " #" + std::to_string(id) + ": " + message;
  if (type == GL_DEBUG_TYPE_ERROR) {
    ++errors_;
    std::lock_guard lock(mutex_);
    errorTexts_.push_back(text);
    logError(text);
  } else if (type == GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR || severity == GL_DEBUG_SEVERITY_HIGH) {
    logWarning(text);
  } else {
    logDebug(text);
  }
}

std::vector<std::string> DebugOutput::errorMessages() const {
  std::lock_guard lock(mutex_);
  return errorTexts_;
}

void DebugOutput::reset() {
  errors_ = 0;
  std::lock_guard lock(mutex_);
  errorTexts_.clear();
}

}  // namespace gis::gfx
