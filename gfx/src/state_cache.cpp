#include "gfx/state_cache.hpp"

#include <cassert>

#include "gfx/program.hpp"
#include "gl_enums.hpp"

namespace gis::gfx {
namespace {

/// The first of this thread's live caches, linked through StateCache::nextLive_. A plain pointer:
/// nothing to destroy at thread exit, whatever outlives it.
thread_local StateCache* firstLiveCache = nullptr;

void setEnabled(GLenum cap, bool on) { on ? glEnable(cap) : glDisable(cap); }

bool isEnabled(GLenum cap) { return glIsEnabled(cap) == GL_TRUE; }

GLint getInt(GLenum pname) {
  GLint v = 0;
  glGetIntegerv(pname, &v);
  return v;
}

GLenum getEnum(GLenum pname) { return static_cast<GLenum>(getInt(pname)); }

std::uint8_t getByte(GLenum pname) { return static_cast<std::uint8_t>(getInt(pname) & 0xFF); }

}  // namespace

void detail::forgetBindings(BindableKind kind, GLuint id) {
  for (StateCache* cache = firstLiveCache; cache != nullptr; cache = cache->nextLive_) cache->forget(kind, id);
}

StateCache::StateCache() : nextLive_(firstLiveCache) {
  if (nextLive_ != nullptr) nextLive_->previousLive_ = this;
  firstLiveCache = this;
}

StateCache::~StateCache() {
  (previousLive_ != nullptr ? previousLive_->nextLive_ : firstLiveCache) = nextLive_;
  if (nextLive_ != nullptr) nextLive_->previousLive_ = previousLive_;
}

void StateCache::invalidate() {
  valid_ = false;
  drawFramebuffer_.reset();
  viewport_.reset();
  program_.reset();
  vertexArray_.reset();
  textures_.fill(std::nullopt);
  uniformBuffers_.fill(std::nullopt);
  storageBuffers_.fill(std::nullopt);
  indirectBuffer_.reset();
}

void StateCache::forget(BindableKind kind, GLuint id) {
  const auto drop = [id](std::optional<GLuint>& slot) {
    if (slot == id) slot.reset();
  };
  switch (kind) {
    case BindableKind::Framebuffer:
      drop(drawFramebuffer_);  // GL falls back to the default framebuffer; unknown is as good
      break;
    case BindableKind::Program:
      drop(program_);  // GL keeps a deleted current program until another is used
      break;
    case BindableKind::VertexArray:
      drop(vertexArray_);
      break;
    case BindableKind::Texture:
      for (std::optional<GLuint>& slot : textures_) drop(slot);
      break;
    case BindableKind::Buffer:
      for (std::optional<GLuint>& slot : uniformBuffers_) drop(slot);
      for (std::optional<GLuint>& slot : storageBuffers_) drop(slot);
      drop(indirectBuffer_);
      break;
  }
}

void StateCache::bindDrawTarget(const DrawTarget& target) {
  if (drawFramebuffer_ != target.framebuffer) {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, target.framebuffer);
    drawFramebuffer_ = target.framebuffer;
    ++calls_;
  }
  if (viewport_ != target.viewport) {
    const Viewport& v = target.viewport;
    glViewport(v.x, v.y, v.width, v.height);
    viewport_ = v;
    ++calls_;
  }
}

DrawTarget StateCache::drawTarget() {
  if (!drawFramebuffer_) drawFramebuffer_ = static_cast<GLuint>(getInt(GL_DRAW_FRAMEBUFFER_BINDING));
  if (!viewport_) {
    GLint v[4] = {0, 0, 0, 0};
    glGetIntegerv(GL_VIEWPORT, v);
    viewport_ = Viewport{v[0], v[1], v[2], v[3]};
  }
  return {*drawFramebuffer_, *viewport_};
}

void StateCache::useProgram(GLuint program) {
  if (program_ == program) return;
  glUseProgram(program);
  program_ = program;
  ++calls_;
}

void StateCache::useProgram(const Program& program) { useProgram(program.id()); }

void StateCache::bindVertexArray(GLuint vertexArray) {
  if (vertexArray_ == vertexArray) return;
  glBindVertexArray(vertexArray);
  vertexArray_ = vertexArray;
  ++calls_;
}

void StateCache::bindTexture(GLuint unit, GLuint texture) {
  assert(unit < kTextureUnits && "raise StateCache::kTextureUnits");
  std::optional<GLuint>& slot = textures_[unit];
  if (slot == texture) return;
  glBindTextureUnit(unit, texture);
  slot = texture;
  ++calls_;
}

void StateCache::bindBuffer(GLenum target, std::array<std::optional<GLuint>, kBufferBindings>& slots, GLuint index,
                            GLuint buffer) {
  assert(index < kBufferBindings && "raise StateCache::kBufferBindings");
  std::optional<GLuint>& slot = slots[index];
  if (slot == buffer) return;
  glBindBufferBase(target, index, buffer);
  slot = buffer;
  ++calls_;
}

void StateCache::bindUniformBuffer(GLuint index, GLuint buffer) {
  bindBuffer(GL_UNIFORM_BUFFER, uniformBuffers_, index, buffer);
}

void StateCache::bindStorageBuffer(GLuint index, GLuint buffer) {
  bindBuffer(GL_SHADER_STORAGE_BUFFER, storageBuffers_, index, buffer);
}

void StateCache::bindIndirectBuffer(GLuint buffer) {
  if (indirectBuffer_ == buffer) return;
  glBindBuffer(GL_DRAW_INDIRECT_BUFFER, buffer);
  indirectBuffer_ = buffer;
  ++calls_;
}

void StateCache::apply(const PipelineState& state) {
  const bool force = !valid_;
  applyDepth(state.depth, force);
  applyStencil(state.stencil, force);
  applyBlend(state.blend, force);
  applyRaster(state.raster, force);
  current_ = state;
  valid_ = true;
}

void StateCache::applyDepth(const DepthState& s, bool force) {
  const DepthState& c = current_.depth;
  if (force || s.test != c.test) {
    setEnabled(GL_DEPTH_TEST, s.test);
    ++calls_;
  }
  if (force || s.write != c.write) {
    glDepthMask(s.write ? GL_TRUE : GL_FALSE);
    ++calls_;
  }
  if (force || s.func != c.func) {
    glDepthFunc(detail::toGl(s.func));
    ++calls_;
  }
  if (force || s.clamp != c.clamp) {
    setEnabled(GL_DEPTH_CLAMP, s.clamp);
    ++calls_;
  }
}

void StateCache::applyStencil(const StencilState& s, bool force) {
  const StencilState& c = current_.stencil;
  if (force || s.test != c.test) {
    setEnabled(GL_STENCIL_TEST, s.test);
    ++calls_;
  }
  auto face = [&](GLenum glFace, const StencilFace& n, const StencilFace& o) {
    if (force || n.func != o.func || n.ref != o.ref || n.readMask != o.readMask) {
      glStencilFuncSeparate(glFace, detail::toGl(n.func), n.ref, n.readMask);
      ++calls_;
    }
    if (force || n.writeMask != o.writeMask) {
      glStencilMaskSeparate(glFace, n.writeMask);
      ++calls_;
    }
    if (force || n.stencilFail != o.stencilFail || n.depthFail != o.depthFail || n.depthPass != o.depthPass) {
      glStencilOpSeparate(glFace, detail::toGl(n.stencilFail), detail::toGl(n.depthFail), detail::toGl(n.depthPass));
      ++calls_;
    }
  };
  face(GL_FRONT, s.front, c.front);
  face(GL_BACK, s.back, c.back);
}

void StateCache::applyBlend(const BlendState& s, bool force) {
  const BlendState& c = current_.blend;
  if (force || s.enabled != c.enabled) {
    setEnabled(GL_BLEND, s.enabled);
    ++calls_;
  }
  if (force || s.srcColor != c.srcColor || s.dstColor != c.dstColor || s.srcAlpha != c.srcAlpha ||
      s.dstAlpha != c.dstAlpha) {
    glBlendFuncSeparate(detail::toGl(s.srcColor), detail::toGl(s.dstColor), detail::toGl(s.srcAlpha),
                        detail::toGl(s.dstAlpha));
    ++calls_;
  }
  if (force || s.colorEquation != c.colorEquation || s.alphaEquation != c.alphaEquation) {
    glBlendEquationSeparate(detail::toGl(s.colorEquation), detail::toGl(s.alphaEquation));
    ++calls_;
  }
}

void StateCache::applyRaster(const RasterState& s, bool force) {
  const RasterState& c = current_.raster;
  if (force || s.cull != c.cull) {
    setEnabled(GL_CULL_FACE, s.cull != CullMode::None);
    if (s.cull != CullMode::None) glCullFace(s.cull == CullMode::Front ? GL_FRONT : GL_BACK);
    ++calls_;
  }
  if (force || s.frontFaceCCW != c.frontFaceCCW) {
    glFrontFace(s.frontFaceCCW ? GL_CCW : GL_CW);
    ++calls_;
  }
  if (force || s.colorMask != c.colorMask) {
    glColorMask(s.colorMask.r, s.colorMask.g, s.colorMask.b, s.colorMask.a);
    ++calls_;
  }
  if (force || s.polygonMode != c.polygonMode) {
    glPolygonMode(GL_FRONT_AND_BACK, s.polygonMode == PolygonMode::Line ? GL_LINE : GL_FILL);
    ++calls_;
  }
  if (force || s.polygonOffsetFactor != c.polygonOffsetFactor || s.polygonOffsetUnits != c.polygonOffsetUnits) {
    const bool on = s.polygonOffsetFactor != 0.0F || s.polygonOffsetUnits != 0.0F;
    setEnabled(GL_POLYGON_OFFSET_FILL, on);
    glPolygonOffset(s.polygonOffsetFactor, s.polygonOffsetUnits);
    ++calls_;
  }
  if (force || s.multisample != c.multisample) {
    setEnabled(GL_MULTISAMPLE, s.multisample);
    ++calls_;
  }
}

void StateCache::prepareForClear() {
  PipelineState s = valid_ ? current_ : kGlDefault;
  s.depth.write = true;
  s.stencil.front.writeMask = 0xFF;
  s.stencil.back.writeMask = 0xFF;
  s.raster.colorMask = ColorMask{};
  apply(s);
}

PipelineState StateCache::queryGl() {
  PipelineState s;
  s.depth.test = isEnabled(GL_DEPTH_TEST);
  GLboolean depthWrite = GL_FALSE;
  glGetBooleanv(GL_DEPTH_WRITEMASK, &depthWrite);
  s.depth.write = depthWrite == GL_TRUE;
  s.depth.func = detail::compareFuncFromGl(getEnum(GL_DEPTH_FUNC));
  s.depth.clamp = isEnabled(GL_DEPTH_CLAMP);

  s.stencil.test = isEnabled(GL_STENCIL_TEST);
  auto face = [](StencilFace& f, GLenum func, GLenum ref, GLenum readMask, GLenum writeMask, GLenum sfail,
                 GLenum dpfail, GLenum dppass) {
    f.func = detail::compareFuncFromGl(getEnum(func));
    f.ref = getByte(ref);
    f.readMask = getByte(readMask);
    f.writeMask = getByte(writeMask);
    f.stencilFail = detail::stencilOpFromGl(getEnum(sfail));
    f.depthFail = detail::stencilOpFromGl(getEnum(dpfail));
    f.depthPass = detail::stencilOpFromGl(getEnum(dppass));
  };
  face(s.stencil.front, GL_STENCIL_FUNC, GL_STENCIL_REF, GL_STENCIL_VALUE_MASK, GL_STENCIL_WRITEMASK, GL_STENCIL_FAIL,
       GL_STENCIL_PASS_DEPTH_FAIL, GL_STENCIL_PASS_DEPTH_PASS);
  face(s.stencil.back, GL_STENCIL_BACK_FUNC, GL_STENCIL_BACK_REF, GL_STENCIL_BACK_VALUE_MASK, GL_STENCIL_BACK_WRITEMASK,
       GL_STENCIL_BACK_FAIL, GL_STENCIL_BACK_PASS_DEPTH_FAIL, GL_STENCIL_BACK_PASS_DEPTH_PASS);

  s.blend.enabled = isEnabled(GL_BLEND);
  s.blend.srcColor = detail::blendFactorFromGl(getEnum(GL_BLEND_SRC_RGB));
  s.blend.dstColor = detail::blendFactorFromGl(getEnum(GL_BLEND_DST_RGB));
  s.blend.srcAlpha = detail::blendFactorFromGl(getEnum(GL_BLEND_SRC_ALPHA));
  s.blend.dstAlpha = detail::blendFactorFromGl(getEnum(GL_BLEND_DST_ALPHA));
  s.blend.colorEquation = detail::blendEquationFromGl(getEnum(GL_BLEND_EQUATION_RGB));
  s.blend.alphaEquation = detail::blendEquationFromGl(getEnum(GL_BLEND_EQUATION_ALPHA));

  RasterState& r = s.raster;
  r.cull = !isEnabled(GL_CULL_FACE)                 ? CullMode::None
           : getEnum(GL_CULL_FACE_MODE) == GL_FRONT ? CullMode::Front
                                                    : CullMode::Back;
  r.frontFaceCCW = getEnum(GL_FRONT_FACE) == GL_CCW;
  GLboolean mask[4] = {GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE};
  glGetBooleanv(GL_COLOR_WRITEMASK, mask);
  r.colorMask = ColorMask{mask[0] == GL_TRUE, mask[1] == GL_TRUE, mask[2] == GL_TRUE, mask[3] == GL_TRUE};
  GLint modes[2] = {0, 0};
  glGetIntegerv(GL_POLYGON_MODE, modes);
  r.polygonMode = static_cast<GLenum>(modes[0]) == GL_LINE ? PolygonMode::Line : PolygonMode::Fill;
  if (isEnabled(GL_POLYGON_OFFSET_FILL)) {
    glGetFloatv(GL_POLYGON_OFFSET_FACTOR, &r.polygonOffsetFactor);
    glGetFloatv(GL_POLYGON_OFFSET_UNITS, &r.polygonOffsetUnits);
  } else {
    r.polygonOffsetFactor = 0.0F;
    r.polygonOffsetUnits = 0.0F;
  }
  r.multisample = isEnabled(GL_MULTISAMPLE);
  return s;
}

}  // namespace gis::gfx
