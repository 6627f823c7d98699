#pragma once
// Conversions between the value types of pipeline_state.hpp and GL enums (private to gfx).
#include "gfx/gl.hpp"
#include "gfx/pipeline_state.hpp"

namespace gis::gfx::detail {

GLenum toGl(CompareFunc f);
GLenum toGl(StencilOp op);
GLenum toGl(BlendFactor f);
GLenum toGl(BlendEquation e);

CompareFunc compareFuncFromGl(GLenum e);
StencilOp stencilOpFromGl(GLenum e);
BlendFactor blendFactorFromGl(GLenum e);
BlendEquation blendEquationFromGl(GLenum e);

}  // namespace gis::gfx::detail
