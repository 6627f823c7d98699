#pragma once
// Draws overlay layers onto a framebuffer whose depth buffer holds the terrain (ours or a GIS
// client's), pass by pass (docs/design.md §4): per layer, mark (z-pass pieces, then z-fail pieces — those
// that may hold the eye or reach it through the near plane) and cover (their front, resp. back,
// faces with stencil NOTEQUAL 0, zeroing the count: one blend per pixel per layer, no stencil
// clear before the next layer). The stencil must be 0 when called and is 0 afterwards.
//
// Draw buffer 0 receives the blended colour. If the framebuffer has a second draw buffer (a
// float format such as R32F), layer i adds 2^i there: a per-pixel layer mask (written with the
// same premultiplied blend: the mask output has alpha 0, so it adds).
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/near_clip.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::overlay {

struct OverlaySettings {
  /// Caps are moved out by padBase + padPerMetre · distance from the eye, beyond the depth
  /// buffer's resolution (float reversed-Z: about 1e-7 relative) and the vertices' float error.
  double padBase = 0.05;
  double padPerMetre = 2e-6;
  /// A quadratic term, padPerMetreSquared · distance², for fixed-point depth buffers, whose steps
  /// grow with the distance squared (under reversed-Z a step of a B-bit buffer is d² / (near ·
  /// 2^B)). The renderer finds the bound framebuffer's depth format at every draw and, for a
  /// fixed-point buffer, uses at least 2 / (near · 2^B) (docs/depth-precision.md); this is a
  /// floor on top of that.
  double padPerMetreSquared = 0.0;
  /// Off: no quadratic term for fixed-point depth buffers beyond padPerMetreSquared (to measure
  /// what a linear padding does with them).
  bool padForDepthFormat = true;
  bool measure = false;      ///< GPU time and fragment counts per layer (waits for the GPU)
  bool forceZFail = false;   ///< every piece z-fail (for tests and cost comparisons)
  bool forceGroups = false;  ///< the grouped scheme for deep overlaps on every layer (tests)
  /// Cover a layer whose features share one colour with one screen rectangle; off: with its
  /// pieces, as layers of several colours are covered (for tests and cost comparisons).
  bool rectangleCover = true;
  /// With rectangleCover: cover only the screen tiles the visible pieces' boxes touch (off: one
  /// rectangle around all of them). Sparse layers (roads from afar) cover a fraction of the screen.
  bool tiledCover = true;
  /// Savings that the benchmark switches off one at a time (docs/design.md §9; overlay_bench --mode
  /// ablation). Off, the image is the same and the work larger.
  bool cullPieces = true;          ///< off: every piece is drawn, in view or not
  bool bottomCapsInZPass = false;  ///< on: z-pass pieces over drawn terrain keep their hidden bottom caps
};

struct LayerFrameStats {
  std::size_t zPassPieces = 0;
  std::size_t zFailPieces = 0;
  std::size_t culledPieces = 0;
  std::size_t drawCommands = 0;
  bool rectangleCover = false;  ///< covered with one screen rectangle (one colour for the layer)
  bool grouped = false;         ///< drawn in groups (the layer may overlap more than 255 deep)
  std::size_t groups = 0;
  double gpuMilliseconds = 0.0;  ///< mark + cover, when measured (GPU timer queries)
  double markMilliseconds = 0.0;
  double coverMilliseconds = 0.0;
  std::uint64_t markFragments = 0;  ///< fragment shader invocations, when measured
  std::uint64_t coverFragments = 0;
  std::uint64_t markTriangles = 0;  ///< primitives submitted, when measured
  std::uint64_t coverTriangles = 0;
};

/// Layer overlap analysis: which pixels' terrain is covered by layer A, by layer B, or both.
enum class OverlapOp {
  And,       ///< covered by both
  Or,        ///< by either
  Xor,       ///< by exactly one
  Subtract,  ///< by A and not by B
};

/// The operator's truth table: whether a pixel covered by A (`a`) and by B (`b`) is shown.
constexpr bool overlapHolds(OverlapOp op, bool a, bool b) {
  switch (op) {
    case OverlapOp::And:
      return a && b;
    case OverlapOp::Or:
      return a || b;
    case OverlapOp::Xor:
      return a != b;
    case OverlapOp::Subtract:
      return a && !b;
  }
  return false;
}

/// The operator's name as the command line takes it: "and", "or", "xor", "subtract".
constexpr const char* overlapOpName(OverlapOp op) {
  switch (op) {
    case OverlapOp::And:
      return "and";
    case OverlapOp::Or:
      return "or";
    case OverlapOp::Xor:
      return "xor";
    case OverlapOp::Subtract:
      return "subtract";
  }
  return "?";
}

/// What markOverlap / countOpenFaces leave in the stencil, for the cover that follows.
struct AnalysisMarks {
  glm::vec4 rect{0.0F};          ///< normalised-device rectangle holding every marked pixel (empty: none)
  LayerFrameStats a, b;          ///< the layers' pieces as drawn (b unused by countOpenFaces)
  double gpuMilliseconds = 0.0;  ///< marking, when measured
  std::uint64_t fragments = 0;
  /// countOpenFaces: pieces near the eye that have nothing left to clip and cap from (lean
  /// tiles: LayerGeometry::footprintsReleased), left out of the count; the rest of
  /// a.zFailPieces were clipped and capped.
  std::size_t uncountedPieces = 0;
};

class OverlayRenderer {
 public:
  /// Needs a current GL 4.5 context.
  static Result<OverlayRenderer> create();

  /// Draws the layers in order (layer i → mask bit i). The depth buffer must hold the terrain
  /// drawn with view.viewProj; reversed-Z clip control must be on.
  std::vector<LayerFrameStats> draw(gfx::StateCache& cache, const OverlayView& view,
                                    std::span<const OverlayLayer* const> layers, const OverlaySettings& settings = {});

  /// Whether a piece inside the box [lo, hi] (frame metres, heights exaggerated) could be drawn
  /// z-fail in this view: the eye within the box grown by the padding of its farthest piece and
  /// the near plane's reach (as the draw decides it per piece). A layer whose footprints were
  /// released (LayerGeometry::releaseFootprints) may be drawn only where this is false.
  [[nodiscard]] bool mayDrawZFail(const OverlayView& view, const OverlaySettings& settings, const glm::dvec3& lo,
                                  const glm::dvec3& hi) const;

  /// The same for layers drawn in chunks (tiled layers: layer i is the union of layers[i]'s
  /// chunks, which may overlap: marked together and covered once, layer i → mask bit i). An
  /// empty entry draws nothing (its bit stays).
  std::vector<LayerFrameStats> draw(gfx::StateCache& cache, const OverlayView& view,
                                    std::span<const std::vector<const OverlayLayer*>> layers,
                                    const OverlaySettings& settings = {});

  /// Debug view: the layer's pieces in view, translucent over the terrain (depth tested, front
  /// faces), z-pass pieces in `zPassColour` and z-fail pieces in `zFailColour` (straight alpha).
  /// Uses no stencil. Returns the pieces as classified.
  LayerFrameStats drawPieces(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer,
                             const glm::vec4& zPassColour, const glm::vec4& zFailColour,
                             const OverlaySettings& settings = {});
  /// The same for a layer drawn in chunks (its tiles).
  LayerFrameStats drawPieces(gfx::StateCache& cache, const OverlayView& view,
                             std::span<const OverlayLayer* const> chunks, const glm::vec4& zPassColour,
                             const glm::vec4& zFailColour, const OverlaySettings& settings = {});

  // Analysis with the same stencil core (after the stencil-volume-intersections article). Each
  // is two calls: mark into the stencil (read it in between if you like), then cover, which
  // colours and returns the stencil to 0. The stencil must be 0 before marking; the depth
  // buffer must hold the terrain. Covers write `colour` (straight alpha, blended over) and add
  // `maskValue` to a second draw buffer if there is one.

  /// Where layer A, and where layer B, covers the terrain: bit kOverlapFlagA / kOverlapFlagB of
  /// the stencil (stencil_states.hpp). A layer that may overlap deeper than 63 pieces
  /// (OverlayLayer::maxOverlap) is counted in groups of 63, so any depth of overlap is exact.
  AnalysisMarks markOverlap(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& a,
                            const OverlayLayer& b, const OverlaySettings& settings = {});
  /// The same for layers drawn in chunks (their tiles, which may overlap: each is collected into
  /// its layer's flag).
  AnalysisMarks markOverlap(gfx::StateCache& cache, const OverlayView& view, std::span<const OverlayLayer* const> a,
                            std::span<const OverlayLayer* const> b, const OverlaySettings& settings = {});
  /// Colours the pixels where `op` of the two marks holds, and zeroes the marks.
  void coverOverlap(gfx::StateCache& cache, const AnalysisMarks& marks, OverlapOp op, const glm::vec4& colour,
                    float maskValue = 0.0F);

  /// Where the layer's volumes are not closed: every face of every piece in view counted with
  /// no depth test, front faces +1 and back faces −1 (mod 256). Closed volumes sum to 0 on every
  /// pixel when the eye is outside them; pieces that may hold the eye or meet the near plane are
  /// clipped on the CPU and capped on the clip plane with the section their cut edges bound,
  /// so they sum to 0 too. A non-zero stencil marks a ray through a hole.
  AnalysisMarks countOpenFaces(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer,
                               const OverlaySettings& settings = {});
  /// The same for a layer drawn in chunks: each chunk's volumes are closed on their own.
  AnalysisMarks countOpenFaces(gfx::StateCache& cache, const OverlayView& view,
                               std::span<const OverlayLayer* const> chunks, const OverlaySettings& settings = {});
  /// Colours the pixels with a non-zero count and zeroes the counts.
  void coverOpenFaces(gfx::StateCache& cache, const AnalysisMarks& marks, const glm::vec4& colour,
                      float maskValue = 0.0F);

 private:
  OverlayRenderer() = default;
  struct Command {
    GLuint count, instanceCount, firstIndex;
    GLint baseVertex;
    GLuint baseInstance;
  };
  /// A layer's pieces in view for one frame, classified z-pass / z-fail.
  struct Pieces {
    std::vector<Command> zPass;                   ///< bottom caps left out where the terrain hides them (unless whole)
    std::vector<Command> zFail;                   ///< whole, for the paper's variant (ours are clipped on the CPU)
    std::vector<Command> coverZPass, coverZFail;  ///< the paper's bounding boxes
    std::vector<std::size_t> zFailSlots;
    std::vector<std::pair<bool, std::size_t>> order;  ///< (z-fail, index into zPass / zFailSlots)
    std::vector<std::array<glm::dvec3, 2>> boxes;     ///< per entry of order, padded
  };
  Pieces classify(const OverlayView& view, const OverlayLayer& layer, const OverlaySettings& settings, bool wholePieces,
                  LayerFrameStats& stats) const;
  /// The normalised-device rectangle holding the boxes of pieces.order[first, last).
  static glm::vec4 rectOf(const OverlayView& view, const Pieces& pieces, std::size_t first, std::size_t last);
  /// Sets the per-frame uniforms (matrix, padding) and the pixel scale of lines in pixels; finds
  /// the depth format of the bound draw framebuffer (the cache's) for the padding.
  PixelScale beginFrame(gfx::StateCache& cache, const OverlayView& view, const OverlaySettings& settings,
                        std::span<const OverlayLayer* const> layers);
  /// The caps' padding at `distance` metres from the eye this frame (settings and depth format).
  [[nodiscard]] double padAt(const OverlaySettings& settings, double distance) const {
    return settings.padBase + settings.padPerMetre * distance + padPerMetreSquared_ * distance * distance;
  }
  /// Uploads the layer's origins relative to the eye and binds its buffers; returns whether its
  /// lines are drawn in pixels (attribute 3 enabled, to be disabled with endLayer).
  bool bindLayer(const OverlayView& view, const OverlayLayer& layer, const PixelScale& scale);
  void endLayer(bool inPixels);
  /// Draws `vertices` clipped triangles (uploadClippedPieces) of the bound layer.
  void drawClipped(gfx::StateCache& cache, const OverlayLayer& layer, GLsizei vertices, bool inPixels);
  /// Marks the bound layer's pieces (our states) group by group and collects each group into a
  /// stencil flag (stencil_states.hpp).
  void markIntoFlag(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer, const Pieces& pieces,
                    const OverlaySettings& settings, const PixelScale& scale, bool inPixels,
                    const FlagMarkStates& states, LayerFrameStats& stats);
  /// Draws one layer given as chunks (one OverlayLayer, or a tiled layer's tiles).
  void drawLayer(gfx::StateCache& cache, const OverlayView& view, std::span<const OverlayLayer* const> chunks,
                 std::size_t index, const OverlaySettings& settings, const PixelScale& scale, LayerFrameStats& stats);
  void multiDraw(gfx::StateCache& cache, const std::vector<Command>& commands);
  /// The z-fail pieces as triangles relative to the eye, clipped on the CPU at half the near
  /// distance (shared edges cut bit-identically): GL never clips them at the eye plane, where
  /// independent clipping of neighbouring faces leaves one-pixel cracks. With `capped`, each
  /// piece is closed again on the clip plane by a fan over its cut edges. Returns the vertex
  /// count in clipped_.
  GLsizei uploadClippedPieces(const OverlayView& view, const OverlayLayer& layer, const std::vector<std::size_t>& slots,
                              const OverlaySettings& settings, const PixelScale& scale, bool capped = false);
  /// Draws the bound layer's z-fail pieces `entries` (indices into pieces.zFail and
  /// pieces.zFailSlots) in `state`: clipped at the near plane (uploadClippedPieces), or whole for
  /// a layer with nothing left to clip from (LayerGeometry::footprintsReleased).
  void drawZFail(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer, const Pieces& pieces,
                 std::span<const std::size_t> entries, const gfx::PipelineState& state, const OverlaySettings& settings,
                 const PixelScale& scale, bool inPixels);
  void beginMeasure(const OverlaySettings& settings);
  void endMeasure(const OverlaySettings& settings, double& milliseconds, std::uint64_t& fragments);
  /// Ends the mark pass's queries and starts the cover's (when measuring).
  void switchToCover(const OverlaySettings& settings);

  /// Draws a screen rectangle with the cover program (colour and mask bit) in the current state.
  void drawRect(gfx::StateCache& cache, const glm::vec4& rect, const glm::vec4& colour, float maskBit);
  /// Draws disjoint screen rectangles in one instanced draw, as drawRect.
  void drawRects(gfx::StateCache& cache, const std::vector<glm::vec4>& rects, const glm::vec4& colour, float maskBit);
  static constexpr int kCoverTiles = 48;
  /// The cover of the chunks' pieces: the tiles of a kCoverTiles² grid over the viewport that
  /// some piece's screen box touches, merged into disjoint rectangles (rows of tiles, and equal
  /// rows one above the other).
  static std::vector<glm::vec4> tileRectsOf(const OverlayView& view, std::span<const Pieces> chunks);

  gfx::Program program_;
  gfx::Program coverProgram_;       ///< screen-rectangle covers
  gfx::Program coverRectsProgram_;  ///< tiled covers (instanced rectangles)
  gfx::VertexArrayHandle vao_;
  gfx::VertexArrayHandle emptyVao_;
  gfx::BufferHandle origins_;
  std::size_t originsCapacity_ = 0;
  gfx::BufferHandle clipped_;
  bool boundAlongNormals_ = false;   ///< the bound layer's caps are padded along its normals (bindLayer)
  double padPerMetreSquared_ = 0.0;  ///< this frame's quadratic padding (OverlaySettings::padPerMetreSquared)
  int fixedDepthBitsLogged_ = 0;     ///< a fixed-point depth buffer of this many bits was reported
  std::size_t clippedCapacity_ = 0;
  gfx::BufferHandle commands_;
  std::size_t commandsCapacity_ = 0;
  gfx::BufferHandle rects_;  ///< cover rectangles (shader storage)
  std::size_t rectsCapacity_ = 0;
  std::optional<gfx::GpuTimer> timer_, coverTimer_;  ///< the mark (and analysis) passes, the cover
  std::optional<gfx::PipelineStatistics> markStats_, coverStats_;
};

}  // namespace gis::overlay
