#pragma once
// The one include for OpenGL in this project: libepoxy resolves entry points for EGL and GLX
// contexts alike.
#include <epoxy/gl.h>
