#pragma once
// What is drawn over a frame the scene renderer has drawn, and read back from it: the lasso
// selection, the layer analyses (overlap of two layers, open volumes), and the frame's colour,
// depth and per-scene-layer mask. Headless programs and tests read frames through these; a
// windowed client may use them on any render target it owns.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "scene/camera.hpp"
#include "scene/lasso_file.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace gis::scene {

/// The selection's pixels as the GPU marked them.
struct SelectionPixels {
  std::vector<std::uint8_t> pixels;  ///< 255 = selected, top row first
  overlay::SelectionFrameStats stats;
};

/// Marks the selection into the stencil of the frame in `target` (single-sampled, drawn from
/// `camera`), reads it, then highlights it (and draws the volumes when the request asks) into the
/// colour. The overlay mask stays as the layers left it.
Result<SelectionPixels> drawSelection(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                      const SelectionRequest& request, const Camera& camera);
/// The same for a frame drawn in any frame of reference (the globe's: globe::overlayViewOf).
Result<SelectionPixels> drawSelection(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                      const SelectionRequest& request, const overlay::OverlayView& view);

/// The overlay layer that draws the fill (not the outline) of the scene layer with this name.
std::optional<std::size_t> fillLayerNamed(const LoadedScene& scene, const SceneRenderer& renderer,
                                          std::string_view name);

inline constexpr glm::vec4 kOverlapColour{1.0F, 0.0F, 1.0F, 0.6F};
inline constexpr glm::vec4 kOpenVolumeColour{0.0F, 1.0F, 0.0F, 1.0F};

/// Where overlay layers a and b cover the frame, as marked between the mark and the cover.
struct OverlapPixels {
  std::size_t a = 0, b = 0;         ///< overlay layers
  std::vector<std::uint8_t> flags;  ///< the stencil after marking (overlay::kOverlapFlagA/B), top row first
  overlay::AnalysisMarks marks;
};

/// Marks overlay layers a and b over the frame in `target`, reads the marks, and colours where
/// `op` holds.
OverlapPixels drawOverlap(gfx::StateCache& cache, const gfx::RenderTarget& target, SceneRenderer& renderer,
                          std::size_t a, std::size_t b, overlay::OverlapOp op, const overlay::OverlayView& view);
/// The same in either frame: two layers given as the chunks the overlay renderer draws (a whole
/// layer, a projected layer's tiles, the globe's tile chunks: globe::GlobeOverlayRenderer::chunks).
/// `a` and `b` of the result are 0 and 1.
OverlapPixels drawOverlap(gfx::StateCache& cache, const gfx::RenderTarget& target, overlay::OverlayRenderer& renderer,
                          std::span<const overlay::OverlayLayer* const> a,
                          std::span<const overlay::OverlayLayer* const> b, overlay::OverlapOp op,
                          const overlay::OverlayView& view);

struct OpenVolumeLayer {
  std::string name;  ///< the overlay layer's
  std::size_t openPixels = 0;
  overlay::AnalysisMarks marks;
};

/// Where some overlay layer's volumes are not closed (a defect: docs/overlay.md).
struct OpenVolumePixels {
  std::vector<std::uint8_t> pixels;  ///< 255 where some layer's volumes are open, top row first
  std::vector<OpenVolumeLayer> layers;
  std::size_t openPixels = 0;
};

/// Counts each overlay layer's open faces over the frame in `target` and colours them.
OpenVolumePixels drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target, SceneRenderer& renderer,
                                 const overlay::OverlayView& view);

/// A layer as the overlay renderer draws it, in either frame: its name and its chunks.
struct ChunkedLayer {
  std::string name;
  std::vector<const overlay::OverlayLayer*> chunks;
};
/// The same for layers given as chunks.
OpenVolumePixels drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                 overlay::OverlayRenderer& renderer, std::span<const ChunkedLayer> layers,
                                 const overlay::OverlayView& view);

/// The frame as files hold it.
struct FrameImages {
  int samples = 1;                 ///< per pixel, as the target has them
  std::vector<std::uint8_t> rgb;   ///< top row first
  std::vector<float> depth;        ///< as stored (reversed-Z)
  std::vector<std::uint8_t> mask;  ///< bit i: the scene file's layer i (fileIndex) covers the pixel
  /// Per bit of the GPU mask (each drawn layer, fills and outlines apart): the pixels it covers
  /// (with MSAA, at least half of whose samples it covers).
  std::vector<std::size_t> coveredPixels;
};

/// Reads the frame in `target` back (resolving it first with MSAA), in either frame. The GPU
/// mask has a bit per drawn layer (fills and outlines); bit j is the scene file's layer
/// `fileIndexOfBit[j]` (its place there; a layer that failed to load keeps its bit, unset), and
/// the returned mask has a bit per layer of the scene file. With MSAA a pixel has a layer's bit
/// when at least half its samples do.
FrameImages readFrame(gfx::StateCache& cache, const gfx::RenderTarget& target,
                      std::span<const std::size_t> fileIndexOfBit);
/// The same for a projected scene drawn by its renderer (its overlay layers' scene layers).
FrameImages readFrame(gfx::StateCache& cache, const LoadedScene& scene, const SceneRenderer& renderer,
                      const gfx::RenderTarget& target);

}  // namespace gis::scene
