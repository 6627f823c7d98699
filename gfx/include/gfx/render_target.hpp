#pragma once
// Off-screen render targets: RGBA8 colour + depth/stencil (GL_DEPTH32F_STENCIL8 by default),
// optionally multisampled, and render passes that say what they clear (filament's
// RenderPassParams).
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/vec4.hpp>

#include "gfx/handles.hpp"
#include "gfx/state_cache.hpp"

namespace gis::gfx {

/// The depth/stencil attachment's format. Both hold reversed-Z depth = near / distance along the
/// view axis, but with different resolution (docs/depth-precision.md):
/// - Float32 (GL_DEPTH32F_STENCIL8): relative, about 2^-23 of the distance at any distance: what
///   the overlay's cap padding is made for. The product uses this.
/// - Fixed24 (GL_DEPTH24_STENCIL8): depth quantised in steps of 2^-24, i.e. distance steps of
///   about distance² / (near · 2^24), like a classic 24-bit buffer with the far plane at infinity.
///   For measuring what a client with a 24-bit buffer would get.
enum class DepthFormat { Float32, Fixed24 };

class RenderTarget {
 public:
  /// `samples` 0 or 1 = single-sampled (textures); >1 = multisampled textures, resolve with
  /// resolveInto() before reading back. `mask` adds a second draw buffer, R32F, for the overlay's
  /// per-pixel layer bits (cleared to 0 with the colour). `depth`: see DepthFormat.
  RenderTarget(int width, int height, int samples = 0, bool mask = false, DepthFormat depth = DepthFormat::Float32);

  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }
  [[nodiscard]] int samples() const { return samples_; }
  [[nodiscard]] bool multisampled() const { return samples_ > 1; }
  [[nodiscard]] DepthFormat depthFormat() const { return depthFormat_; }
  [[nodiscard]] GLuint framebuffer() const { return fbo_.id(); }
  [[nodiscard]] GLuint colorTexture() const { return color_.id(); }
  [[nodiscard]] GLuint depthStencilTexture() const { return depthStencil_.id(); }
  [[nodiscard]] bool hasMask() const { return static_cast<bool>(mask_); }
  [[nodiscard]] GLuint maskTexture() const { return mask_.id(); }
  /// False (with the status logged) if GL did not accept the attachments.
  [[nodiscard]] bool complete() const;

  /// Copies colour, depth and stencil into a single-sampled target of the same size and depth
  /// format (colour averaged over samples; depth and stencil of one sample per pixel, as GL
  /// defines). The mask is not resolved (bits do not average): read it per sample with
  /// copySampleInto().
  void resolveInto(const RenderTarget& single) const;
  /// Copies sample `sample` of colour, mask and depth into a single-sampled target (a shader
  /// pass with texelFetch): for per-sample comparisons. The bound target and viewport stay.
  void copySampleInto(StateCache& cache, const RenderTarget& single, int sample) const;

 private:
  int width_;
  int height_;
  int samples_;
  DepthFormat depthFormat_;
  TextureHandle color_;
  TextureHandle depthStencil_;
  TextureHandle mask_;
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
/// clears what `params` names, through the state cache. The target stays bound: a frame's pass.
/// (StateCache::bindDrawTarget binds without clearing.)
void beginRenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params);
inline void beginRenderPass(StateCache& cache, const RenderTarget& target, const RenderPassParams& params) {
  beginRenderPass(cache, target.framebuffer(), target.width(), target.height(), params);
}

/// A pass into a framebuffer of its own, nested in whatever pass has its target bound (a drape
/// texture rasterised while the frame is prepared): begins as beginRenderPass and, when it ends,
/// binds the target and viewport that were bound before it, so nothing it did leaks into the
/// enclosing pass.
class RenderPass {
 public:
  RenderPass(StateCache& cache, GLuint framebuffer, int width, int height, const RenderPassParams& params = {});
  ~RenderPass() { cache_.bindDrawTarget(previous_); }
  RenderPass(const RenderPass&) = delete;
  RenderPass& operator=(const RenderPass&) = delete;

 private:
  StateCache& cache_;
  DrawTarget previous_;
};

/// Turns writes to a framebuffer's second draw buffer (the overlay mask) off or on. Passes whose
/// shaders have no second output (the terrain) must run with it off: GL leaves unwritten
/// outputs undefined. No effect on the default framebuffer (0).
void enableMaskWrites(GLuint framebuffer, bool enabled);

/// glReadPixels of a rectangle of `framebuffer` (0 = the default framebuffer) through its read
/// buffer `readBuffer` (GL_COLOR_ATTACHMENT0, GL_BACK..., a valid one even for depth or stencil),
/// bottom row first as GL returns it, rows packed without padding. Binds the read framebuffer only for the call.
void readFramebuffer(GLuint framebuffer, GLenum readBuffer, int x, int y, int width, int height, GLenum format,
                     GLenum type, void* pixels);
/// Readback of a single-sampled target, top row first (image order).
std::vector<std::uint8_t> readColorRgba8(const RenderTarget& target);
/// Depth as stored (reversed-Z: 1 at the near plane, 0 at infinity), top row first, as float for
/// both formats (Fixed24 values are the stored steps k / (2^24 − 1), exactly as GL converts them).
std::vector<float> readDepth(const RenderTarget& target);
/// Stencil values, top row first.
std::vector<std::uint8_t> readStencil(const RenderTarget& target);
/// The overlay mask (bit i = layer i), top row first; the target must have a mask.
std::vector<std::uint32_t> readMask(const RenderTarget& target);

}  // namespace gis::gfx
