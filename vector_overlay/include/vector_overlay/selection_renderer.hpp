#pragma once
// Lasso selection on the GPU (docs/design.md §6): the volumes of a list of steps (lasso.hpp) marked into
// the stencil z-fail with depth clamp, combined by operator (selection_states.hpp), then
// highlighted. Works on any framebuffer whose depth buffer holds the scene (reversed-Z, clip
// control on) and whose stencil is 0 — after the overlays, which leave it 0.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::overlay {

enum class SelectionScheme : std::uint8_t {
  Runs,    ///< ours: runs of one operator share a combine pass (selected = 0x80)
  Report,  ///< the seed report's reduction after every volume (selected = 1)
};

struct SelectionSettings {
  SelectionScheme scheme = SelectionScheme::Runs;
  bool measure = false;  ///< GPU time and fragment counts (waits for the GPU)
};

struct SelectionStyle {
  glm::vec4 color{1.0F, 0.2F, 0.1F, 1.0F};  ///< straight alpha
  float opacity = 0.45F;
};

struct SelectionFrameStats {
  std::size_t volumes = 0;       ///< lassos drawn
  std::size_t triangles = 0;     ///< after clipping at the eye
  std::size_t markDraws = 0;     ///< one per volume
  std::size_t screenPasses = 0;  ///< combine, reduce and invert passes
  double gpuMilliseconds = 0.0;  ///< when measured
  std::uint64_t fragments = 0;   ///< fragment shader invocations, when measured
};

class SelectionRenderer {
 public:
  /// Needs a current GL 4.5 context.
  static Result<SelectionRenderer> create();

  /// The selection to draw from now on; the volumes are built here (once per change). Bad
  /// lassos are reported (named "lasso N") and select nothing; the chain still applies them.
  Diagnostics setSteps(std::vector<SelectionStep> steps);
  [[nodiscard]] const std::vector<SelectionStep>& steps() const { return steps_; }

  /// Marks the selection of the current steps seen from `view` into the stencil (which must be
  /// 0). Afterwards selected pixels hold kSelectedBit (Runs) or 1 (Report, where geometry was
  /// drawn: elsewhere any value); Runs leaves every other pixel 0.
  SelectionFrameStats select(gfx::StateCache& cache, const OverlayView& view, const SelectionSettings& settings = {});
  /// Colours the selected pixels (premultiplied blend) and zeroes the stencil.
  void highlight(gfx::StateCache& cache, const SelectionStyle& style, const SelectionSettings& settings = {});
  /// Zeroes the stencil without colour.
  void clear(gfx::StateCache& cache);
  /// "Show volumes": the volumes' visible faces, translucent (no stencil).
  void drawVolumes(gfx::StateCache& cache, const OverlayView& view, const glm::vec4& colour);

 private:
  SelectionRenderer() = default;
  /// Clips every volume at half the near distance of `view` (homogeneous, relative to the eye),
  /// drops faces seen exactly edge on, uploads them; per step its vertex range and the screen
  /// rectangle (NDC) of what remains.
  void upload(const OverlayView& view);
  /// A screen rectangle with rectProgram_, or a step's volumes with volumeProgram_, in the
  /// current pipeline state (each binds its program and vertex array).
  void drawRect(gfx::StateCache& cache, const glm::vec4& rect);
  void drawStep(gfx::StateCache& cache, std::size_t step);

  gfx::Program volumeProgram_;
  gfx::Program rectProgram_;
  gfx::VertexArrayHandle vao_;
  gfx::VertexArrayHandle emptyVao_;
  gfx::BufferHandle vertices_;
  std::size_t capacity_ = 0;
  std::vector<SelectionStep> steps_;
  std::vector<LassoVolume> volumes_;
  struct Range {
    GLint first = 0;
    GLsizei count = 0;
    glm::vec4 rect{1.0F, 1.0F, -1.0F, -1.0F};  ///< empty
  };
  std::vector<Range> ranges_;
  std::optional<gfx::GpuTimer> timer_;
  std::optional<gfx::PipelineStatistics> stats_;
};

}  // namespace gis::overlay
