#include "gfx/pipeline_state.hpp"

#include <array>
#include <cstdio>
#include <utility>

#include "gl_enums.hpp"

namespace gis::gfx {
namespace detail {
namespace {

// One table per enum: the position in the table is the enumerator's value.
constexpr std::array<GLenum, 8> kCompare{GL_NEVER,    GL_LESS,   GL_LEQUAL,  GL_EQUAL,
                                         GL_NOTEQUAL, GL_GEQUAL, GL_GREATER, GL_ALWAYS};
constexpr std::array<GLenum, 8> kStencilOp{GL_KEEP,      GL_ZERO, GL_REPLACE,   GL_INCR,
                                           GL_INCR_WRAP, GL_DECR, GL_DECR_WRAP, GL_INVERT};
constexpr std::array<GLenum, 12> kBlendFactor{GL_ZERO,           GL_ONE,
                                              GL_SRC_COLOR,      GL_ONE_MINUS_SRC_COLOR,
                                              GL_DST_COLOR,      GL_ONE_MINUS_DST_COLOR,
                                              GL_SRC_ALPHA,      GL_ONE_MINUS_SRC_ALPHA,
                                              GL_DST_ALPHA,      GL_ONE_MINUS_DST_ALPHA,
                                              GL_CONSTANT_COLOR, GL_CONSTANT_ALPHA};
constexpr std::array<GLenum, 5> kBlendEquation{GL_FUNC_ADD, GL_FUNC_SUBTRACT, GL_FUNC_REVERSE_SUBTRACT, GL_MIN, GL_MAX};

template <typename E, std::size_t N>
E fromGl(const std::array<GLenum, N>& table, GLenum value) {
  for (std::size_t i = 0; i < N; ++i) {
    if (table[i] == value) return static_cast<E>(i);
  }
  return static_cast<E>(0);
}

}  // namespace

GLenum toGl(CompareFunc f) { return kCompare[static_cast<std::size_t>(f)]; }
GLenum toGl(StencilOp op) { return kStencilOp[static_cast<std::size_t>(op)]; }
GLenum toGl(BlendFactor f) { return kBlendFactor[static_cast<std::size_t>(f)]; }
GLenum toGl(BlendEquation e) { return kBlendEquation[static_cast<std::size_t>(e)]; }
CompareFunc compareFuncFromGl(GLenum e) { return fromGl<CompareFunc>(kCompare, e); }
StencilOp stencilOpFromGl(GLenum e) { return fromGl<StencilOp>(kStencilOp, e); }
BlendFactor blendFactorFromGl(GLenum e) { return fromGl<BlendFactor>(kBlendFactor, e); }
BlendEquation blendEquationFromGl(GLenum e) { return fromGl<BlendEquation>(kBlendEquation, e); }

}  // namespace detail

std::string toString(CompareFunc f) {
  constexpr std::array<const char*, 8> names{"NEVER",    "LESS",   "LEQUAL",  "EQUAL",
                                             "NOTEQUAL", "GEQUAL", "GREATER", "ALWAYS"};
  return names[static_cast<std::size_t>(f)];
}

std::string toString(StencilOp op) {
  constexpr std::array<const char*, 8> names{"KEEP",      "ZERO", "REPLACE",   "INCR",
                                             "INCR_WRAP", "DECR", "DECR_WRAP", "INVERT"};
  return names[static_cast<std::size_t>(op)];
}

namespace {
std::string faceString(const char* name, const StencilFace& f) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "  %s: func %s ref %u read 0x%02x write 0x%02x sfail %s dpfail %s dppass %s\n", name,
                toString(f.func).c_str(), f.ref, f.readMask, f.writeMask, toString(f.stencilFail).c_str(),
                toString(f.depthFail).c_str(), toString(f.depthPass).c_str());
  return buf;
}
}  // namespace

std::string toString(const PipelineState& s) {
  std::string out;
  char buf[200];
  std::snprintf(buf, sizeof buf, "depth: test %d write %d func %s clamp %d\n", s.depth.test, s.depth.write,
                toString(s.depth.func).c_str(), s.depth.clamp);
  out += buf;
  std::snprintf(buf, sizeof buf, "stencil: test %d\n", s.stencil.test);
  out += buf;
  out += faceString("front", s.stencil.front);
  out += faceString("back", s.stencil.back);
  std::snprintf(buf, sizeof buf, "blend: %d src %d/%d dst %d/%d eq %d/%d\n", s.blend.enabled,
                static_cast<int>(s.blend.srcColor), static_cast<int>(s.blend.srcAlpha),
                static_cast<int>(s.blend.dstColor), static_cast<int>(s.blend.dstAlpha),
                static_cast<int>(s.blend.colorEquation), static_cast<int>(s.blend.alphaEquation));
  out += buf;
  const RasterState& r = s.raster;
  std::snprintf(buf, sizeof buf, "raster: cull %d ccw %d mask %d%d%d%d mode %d offset %g/%g ms %d\n",
                static_cast<int>(r.cull), r.frontFaceCCW, r.colorMask.r, r.colorMask.g, r.colorMask.b, r.colorMask.a,
                static_cast<int>(r.polygonMode), static_cast<double>(r.polygonOffsetFactor),
                static_cast<double>(r.polygonOffsetUnits), r.multisample);
  out += buf;
  return out;
}

}  // namespace gis::gfx
