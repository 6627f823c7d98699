#include "gfx/render_target.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "core/log.hpp"
#include "gfx/program.hpp"

namespace gis::gfx {
namespace {

// GL reads bottom row first; images (PNG, TIFF, our files) are stored top row first.
template <typename T>
void flipRows(std::vector<T>& pixels, int width, int height, int channels) {
  const std::size_t row = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  for (int y = 0; y < height / 2; ++y) {
    auto a = pixels.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y) * row);
    auto b = pixels.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(height - 1 - y) * row);
    std::swap_ranges(a, a + static_cast<std::ptrdiff_t>(row), b);
  }
}

TextureHandle makeAttachment(GLenum format, int width, int height, int samples) {
  if (samples > 1) {
    TextureHandle t = createTexture(GL_TEXTURE_2D_MULTISAMPLE);
    glTextureStorage2DMultisample(t.id(), samples, format, width, height, GL_TRUE);
    return t;
  }
  TextureHandle t = createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(t.id(), 1, format, width, height);
  glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

template <typename T>
std::vector<T> readPixels(const RenderTarget& target, GLenum readBuffer, GLenum format, GLenum type, int channels) {
  assert(!target.multisampled() && "resolve a multisampled target before reading it back");
  std::vector<T> pixels(static_cast<std::size_t>(target.width()) * static_cast<std::size_t>(target.height()) *
                        static_cast<std::size_t>(channels));
  readFramebuffer(target.framebuffer(), readBuffer, 0, 0, target.width(), target.height(), format, type, pixels.data());
  flipRows(pixels, target.width(), target.height(), channels);
  return pixels;
}

/// copySampleInto's pass: every fragment written, depth included, nothing tested or blended.
constexpr PipelineState kCopyPass = [] {
  PipelineState s;
  s.depth = DepthState{true, true, CompareFunc::Always, false};
  s.stencil.test = false;
  s.blend.enabled = false;
  s.raster.cull = CullMode::None;
  return s;
}();

}  // namespace

RenderTarget::RenderTarget(int width, int height, int samples, bool mask, DepthFormat depth)
    : width_(width), height_(height), samples_(samples > 1 ? samples : 0), depthFormat_(depth) {
  color_ = makeAttachment(GL_RGBA8, width, height, samples_);
  depthStencil_ = makeAttachment(depth == DepthFormat::Fixed24 ? GL_DEPTH24_STENCIL8 : GL_DEPTH32F_STENCIL8, width,
                                 height, samples_);
  fbo_ = createFramebuffer();
  glNamedFramebufferTexture(fbo_.id(), GL_COLOR_ATTACHMENT0, color_.id(), 0);
  glNamedFramebufferTexture(fbo_.id(), GL_DEPTH_STENCIL_ATTACHMENT, depthStencil_.id(), 0);
  if (mask) {
    mask_ = makeAttachment(GL_R32F, width, height, samples_);
    glNamedFramebufferTexture(fbo_.id(), GL_COLOR_ATTACHMENT1, mask_.id(), 0);
    const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(fbo_.id(), 2, buffers);
  } else {
    glNamedFramebufferDrawBuffer(fbo_.id(), GL_COLOR_ATTACHMENT0);
  }
  if (!complete()) logError("render target " + std::to_string(width) + "x" + std::to_string(height) + " incomplete");
}

bool RenderTarget::complete() const {
  return glCheckNamedFramebufferStatus(fbo_.id(), GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

void RenderTarget::resolveInto(const RenderTarget& single) const {
  assert(single.width_ == width_ && single.height_ == height_ && !single.multisampled());
  assert(single.depthFormat_ == depthFormat_ && "GL blits depth only between equal formats");
  glBlitNamedFramebuffer(fbo_.id(), single.fbo_.id(), 0, 0, width_, height_, 0, 0, width_, height_,
                         GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT, GL_NEAREST);
}

void RenderTarget::copySampleInto(StateCache& cache, const RenderTarget& single, int sample) const {
  assert(multisampled() && !single.multisampled() && single.width_ == width_ && single.height_ == height_);
  Result<Program> program = Program::build({{"sample_copy.vert", {}}, {"sample_copy.frag", {}}});
  if (!program) {
    for (const Diagnostic& d : program.diagnostics.items()) logError(d.toString());
    return;
  }
  const RenderPass pass(cache, single.fbo_.id(), width_, height_);
  cache.apply(kCopyPass);
  const VertexArrayHandle vao = createVertexArray();
  cache.bindVertexArray(vao.id());
  cache.useProgram(*program);
  program->set("u_color", 0);
  program->set("u_mask", 1);
  program->set("u_depth", 2);
  program->set("u_sample", sample);
  program->set("u_hasMask", hasMask() ? 1 : 0);
  cache.bindTexture(0, color_.id());
  cache.bindTexture(1, hasMask() ? mask_.id() : color_.id());
  cache.bindTexture(2, depthStencil_.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
}

void enableMaskWrites(GLuint framebuffer, bool enabled) {
  if (framebuffer == 0) return;
  GLint attached = GL_NONE;
  glGetNamedFramebufferAttachmentParameteriv(framebuffer, GL_COLOR_ATTACHMENT1, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                             &attached);
  if (attached == GL_NONE) return;
  const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, enabled ? GLenum{GL_COLOR_ATTACHMENT1} : GLenum{GL_NONE}};
  glNamedFramebufferDrawBuffers(framebuffer, 2, buffers);
}

void beginRenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params) {
  cache.bindDrawTarget(framebuffer, width, height);
  if (!params.clearColor && !params.clearDepth && !params.clearStencil) return;
  cache.prepareForClear();
  if (params.clearColor) {
    const glm::vec4& c = *params.clearColor;
    const GLfloat value[4] = {c.x, c.y, c.z, c.w};
    glClearNamedFramebufferfv(framebuffer, GL_COLOR, 0, value);
    GLint attached = GL_NONE;
    if (framebuffer != 0) {
      glGetNamedFramebufferAttachmentParameteriv(framebuffer, GL_COLOR_ATTACHMENT1,
                                                 GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE, &attached);
    }
    if (attached != GL_NONE) {  // the mask: cleared to 0 through its own draw buffer slot
      enableMaskWrites(framebuffer, true);
      const GLfloat zero[4] = {0.0F, 0.0F, 0.0F, 0.0F};
      glClearNamedFramebufferfv(framebuffer, GL_COLOR, 1, zero);
    }
  }
  if (params.clearDepth && params.clearStencil) {
    glClearNamedFramebufferfi(framebuffer, GL_DEPTH_STENCIL, 0, *params.clearDepth, *params.clearStencil);
  } else if (params.clearDepth) {
    glClearNamedFramebufferfv(framebuffer, GL_DEPTH, 0, &*params.clearDepth);
  } else if (params.clearStencil) {
    glClearNamedFramebufferiv(framebuffer, GL_STENCIL, 0, &*params.clearStencil);
  }
}

RenderPass::RenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params)
    : cache_(cache), previous_(cache.drawTarget()) {
  beginRenderPass(cache, framebuffer, width, height, params);
}

void readFramebuffer(GLuint framebuffer, GLenum readBuffer, int x, int y, int width, int height, GLenum format,
                     GLenum type, void* pixels) {
  // The read binding is not the state cache's: bound here for this call only.
  glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
  glNamedFramebufferReadBuffer(framebuffer, readBuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(x, y, width, height, format, type, pixels);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
}

std::vector<std::uint8_t> readColorRgba8(const RenderTarget& target) {
  return readPixels<std::uint8_t>(target, GL_COLOR_ATTACHMENT0, GL_RGBA, GL_UNSIGNED_BYTE, 4);
}

std::vector<float> readDepth(const RenderTarget& target) {
  return readPixels<float>(target, GL_COLOR_ATTACHMENT0, GL_DEPTH_COMPONENT, GL_FLOAT, 1);
}

std::vector<std::uint8_t> readStencil(const RenderTarget& target) {
  return readPixels<std::uint8_t>(target, GL_COLOR_ATTACHMENT0, GL_STENCIL_INDEX, GL_UNSIGNED_BYTE, 1);
}

std::vector<std::uint32_t> readMask(const RenderTarget& target) {
  assert(target.hasMask());
  const std::vector<float> values = readPixels<float>(target, GL_COLOR_ATTACHMENT1, GL_RED, GL_FLOAT, 1);
  std::vector<std::uint32_t> bits(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) bits[i] = static_cast<std::uint32_t>(std::lround(values[i]));
  return bits;
}

}  // namespace gis::gfx
