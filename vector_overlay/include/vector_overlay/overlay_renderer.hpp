#pragma once
// Draws overlay layers onto a framebuffer whose depth buffer holds the terrain (ours or a GIS
// client's), pass by pass (DESIGN §4): per layer, mark (z-pass pieces, then z-fail pieces — those
// that may hold the eye or reach it through the near plane) and cover (their front, resp. back,
// faces with stencil NOTEQUAL 0, zeroing the count: one blend per pixel per layer, no stencil
// clear before the next layer). The stencil must be 0 when called and is 0 afterwards.
//
// Draw buffer 0 receives the blended colour. If the framebuffer has a second draw buffer (a
// float format such as R32F), layer i adds 2^i there: a per-pixel layer mask (written with the
// same premultiplied blend: the mask output has alpha 0, so it adds).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/overlay_layer.hpp"

namespace gis::overlay {

/// The camera of the frame, as the terrain was drawn with it.
struct OverlayView {
  glm::dmat4 viewProj{1.0};  ///< frame → clip (reversed-Z, infinite far plane, depth clamp)
  glm::dvec3 eye{0.0};       ///< frame coordinates
  double nearPlane = 1.0;    ///< metres
  double fovYRadians = 0.785;
  double aspect = 1.0;
};

struct OverlaySettings {
  /// Caps are moved out by padBase + padPerMetre · distance from the eye, beyond the depth
  /// buffer's resolution (float reversed-Z: about 1e-7 relative) and the vertices' float error.
  double padBase = 0.05;
  double padPerMetre = 2e-6;
  bool measure = false;      ///< GPU time and fragment counts per layer (waits for the GPU)
  bool forceZFail = false;   ///< every piece z-fail (for tests and cost comparisons)
  bool forceGroups = false;  ///< the grouped scheme for deep overlaps on every layer (tests)
  /// Cover a layer whose features share one colour with one screen rectangle; off: with its
  /// pieces, as layers of several colours are covered (for tests and cost comparisons).
  bool rectangleCover = true;
};

struct LayerFrameStats {
  std::size_t zPassPieces = 0;
  std::size_t zFailPieces = 0;
  std::size_t culledPieces = 0;
  std::size_t drawCommands = 0;
  bool rectangleCover = false;  ///< covered with one screen rectangle (one colour for the layer)
  bool grouped = false;         ///< drawn in groups (the layer may overlap more than 255 deep)
  std::size_t groups = 0;
  double gpuMilliseconds = 0.0;     ///< mark + cover, when measured
  std::uint64_t markFragments = 0;  ///< fragment shader invocations, when measured
  std::uint64_t coverFragments = 0;
};

class OverlayRenderer {
 public:
  /// Needs a current GL 4.5 context.
  static Result<OverlayRenderer> create();

  /// Draws the layers in order (layer i → mask bit i). The depth buffer must hold the terrain
  /// drawn with view.viewProj; reversed-Z clip control must be on.
  std::vector<LayerFrameStats> draw(gfx::StateCache& cache, const OverlayView& view,
                                    std::span<const OverlayLayer* const> layers, const OverlaySettings& settings = {});

 private:
  OverlayRenderer() = default;
  struct Command {
    GLuint count, instanceCount, firstIndex;
    GLint baseVertex;
    GLuint baseInstance;
  };
  void drawLayer(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer, std::size_t index,
                 const OverlaySettings& settings, const PixelScale& scale, LayerFrameStats& stats);
  void multiDraw(const std::vector<Command>& commands);
  /// The z-fail pieces as triangles relative to the eye, clipped on the CPU at half the near
  /// distance (shared edges cut bit-identically): GL never clips them at the eye plane, where
  /// independent clipping of neighbouring faces leaves one-pixel cracks. Returns the vertex
  /// count in clipped_.
  GLsizei uploadClippedPieces(const OverlayView& view, const OverlayLayer& layer, const std::vector<std::size_t>& slots,
                              const OverlaySettings& settings, const PixelScale& scale);

  /// Draws a screen rectangle with the cover program (colour and mask bit) in the current state.
  void drawRect(const glm::vec4& rect, const glm::vec4& colour, float maskBit);

  gfx::Program program_;
  gfx::Program coverProgram_;  ///< screen-rectangle covers
  gfx::VertexArrayHandle vao_;
  gfx::VertexArrayHandle emptyVao_;
  gfx::BufferHandle origins_;
  std::size_t originsCapacity_ = 0;
  gfx::BufferHandle clipped_;
  std::size_t clippedCapacity_ = 0;
  gfx::BufferHandle commands_;
  std::size_t commandsCapacity_ = 0;
  std::optional<gfx::GpuTimer> timer_;
  std::optional<gfx::PipelineStatistics> markStats_, coverStats_;
};

}  // namespace gis::overlay
