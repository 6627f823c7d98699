#include "gfx/render_target.hpp"

#include <algorithm>
#include <cassert>
#include <string>

#include "core/log.hpp"

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
  glBindFramebuffer(GL_READ_FRAMEBUFFER, target.framebuffer());
  glNamedFramebufferReadBuffer(target.framebuffer(), readBuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, target.width(), target.height(), format, type, pixels.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  flipRows(pixels, target.width(), target.height(), channels);
  return pixels;
}

}  // namespace

RenderTarget::RenderTarget(int width, int height, int samples)
    : width_(width), height_(height), samples_(samples > 1 ? samples : 0) {
  color_ = makeAttachment(GL_RGBA8, width, height, samples_);
  depthStencil_ = makeAttachment(GL_DEPTH32F_STENCIL8, width, height, samples_);
  fbo_ = createFramebuffer();
  glNamedFramebufferTexture(fbo_.id(), GL_COLOR_ATTACHMENT0, color_.id(), 0);
  glNamedFramebufferTexture(fbo_.id(), GL_DEPTH_STENCIL_ATTACHMENT, depthStencil_.id(), 0);
  glNamedFramebufferDrawBuffer(fbo_.id(), GL_COLOR_ATTACHMENT0);
  if (!complete()) logError("render target " + std::to_string(width) + "x" + std::to_string(height) + " incomplete");
}

bool RenderTarget::complete() const {
  return glCheckNamedFramebufferStatus(fbo_.id(), GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

void RenderTarget::resolveInto(const RenderTarget& single) const {
  assert(single.width_ == width_ && single.height_ == height_ && !single.multisampled());
  glBlitNamedFramebuffer(fbo_.id(), single.fbo_.id(), 0, 0, width_, height_, 0, 0, width_, height_,
                         GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT, GL_NEAREST);
}

void beginRenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params) {
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glViewport(0, 0, width, height);
  if (!params.clearColor && !params.clearDepth && !params.clearStencil) return;
  cache.prepareForClear();
  if (params.clearColor) {
    const glm::vec4& c = *params.clearColor;
    const GLfloat value[4] = {c.x, c.y, c.z, c.w};
    glClearNamedFramebufferfv(framebuffer, GL_COLOR, 0, value);
  }
  if (params.clearDepth && params.clearStencil) {
    glClearNamedFramebufferfi(framebuffer, GL_DEPTH_STENCIL, 0, *params.clearDepth, *params.clearStencil);
  } else if (params.clearDepth) {
    glClearNamedFramebufferfv(framebuffer, GL_DEPTH, 0, &*params.clearDepth);
  } else if (params.clearStencil) {
    glClearNamedFramebufferiv(framebuffer, GL_STENCIL, 0, &*params.clearStencil);
  }
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

}  // namespace gis::gfx
