#pragma once
// Off-screen render targets: RGBA8 colour + GL_DEPTH32F_STENCIL8, optionally multisampled,
// and render passes that say what they clear (filament's RenderPassParams).
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/vec4.hpp>

#include "gfx/handles.hpp"
#include "gfx/state_cache.hpp"

namespace gis::gfx {

class RenderTarget {
 public:
  /// `samples` 0 or 1 = single-sampled (textures); >1 = multisampled textures, resolve with
  /// resolveInto() before reading back.
  RenderTarget(int width, int height, int samples = 0);

  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }
  [[nodiscard]] int samples() const { return samples_; }
  [[nodiscard]] bool multisampled() const { return samples_ > 1; }
  [[nodiscard]] GLuint framebuffer() const { return fbo_.id(); }
  [[nodiscard]] GLuint colorTexture() const { return color_.id(); }
  [[nodiscard]] GLuint depthStencilTexture() const { return depthStencil_.id(); }
  /// False (with the status logged) if GL did not accept the attachments.
  [[nodiscard]] bool complete() const;

  /// Copies colour, depth and stencil into a single-sampled target of the same size (colour
  /// averaged over samples; depth and stencil of one sample per pixel, as GL defines).
  void resolveInto(const RenderTarget& single) const;

 private:
  int width_;
  int height_;
  int samples_;
  TextureHandle color_;
  TextureHandle depthStencil_;
  FramebufferHandle fbo_;
};

/// What a pass clears, and to which values. Reversed-Z clears depth to 0 (= infinitely far).
struct RenderPassParams {
  std::optional<glm::vec4> clearColor;
  std::optional<float> clearDepth;
  std::optional<int> clearStencil;
};

inline constexpr float kReversedZFar = 0.0F;

/// Binds the target (0 = the default framebuffer with the given size), sets the viewport and
/// clears what `params` names, through the state cache.
void beginRenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params);
inline void beginRenderPass(StateCache& cache, const RenderTarget& target, const RenderPassParams& params) {
  beginRenderPass(cache, target.framebuffer(), target.width(), target.height(), params);
}

/// Readback of a single-sampled target, top row first (image order).
std::vector<std::uint8_t> readColorRgba8(const RenderTarget& target);
/// Depth as stored (float; reversed-Z: 1 at the near plane, 0 at infinity), top row first.
std::vector<float> readDepth(const RenderTarget& target);
/// Stencil values, top row first.
std::vector<std::uint8_t> readStencil(const RenderTarget& target);

}  // namespace gis::gfx
