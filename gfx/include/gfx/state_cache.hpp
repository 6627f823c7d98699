#pragma once
// The one place that changes GL pipeline state. It skips unchanged values and can be
// resynchronised after third-party GL code (ImGui) with invalidate().
#include "gfx/pipeline_state.hpp"

namespace gis::gfx {

class StateCache {
 public:
  /// Makes GL's state equal to `state`, issuing calls only for what differs from the cached
  /// state (all of it after invalidate()).
  void apply(const PipelineState& state);

  /// Forget what GL holds: the next apply() sets everything. Call after foreign GL code.
  void invalidate() { valid_ = false; }

  /// Enables every write mask (colour, depth, both stencil faces) so that a clear clears all,
  /// keeping the cache in step. Used by RenderPass before glClear*.
  void prepareForClear();

  /// The state GL actually holds, read with glGet* (for tests: no state leaks between passes).
  [[nodiscard]] static PipelineState queryGl();

  /// Number of GL state calls issued so far (to show that redundant calls are skipped).
  [[nodiscard]] std::size_t glCallCount() const { return calls_; }

  [[nodiscard]] const PipelineState& cached() const { return current_; }

 private:
  void applyDepth(const DepthState& s, bool force);
  void applyStencil(const StencilState& s, bool force);
  void applyBlend(const BlendState& s, bool force);
  void applyRaster(const RasterState& s, bool force);

  PipelineState current_{};
  bool valid_ = false;
  std::size_t calls_ = 0;
};

}  // namespace gis::gfx
