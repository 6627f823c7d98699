#pragma once
// OpenGL 4.5 core in a GLFW window (gis::window): the one part of gfx that needs a window
// system, kept apart so that headless programs and GIS clients that bring their own window do
// not link GLFW.
#include <memory>

#include "core/diagnostics.hpp"
#include "gfx/context.hpp"

namespace gis::gfx {

/// True when a window can be opened (GLFW initialises and finds a display).
bool windowSystemAvailable();

/// OpenGL 4.5 core in a GLFW window.
Result<std::unique_ptr<Context>> createWindowContext(const ContextOptions& options = {});

}  // namespace gis::gfx
