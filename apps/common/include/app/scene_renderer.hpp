#pragma once
// Draws a loaded scene into any framebuffer, headless or windowed, pass by pass (DESIGN §4).
// For now the terrain pass; the overlay and selection passes join in later issues.
#include <cstdint>
#include <optional>

#include <glm/vec4.hpp>

#include "app/camera.hpp"
#include "app/scene_loader.hpp"
#include "gfx/queries.hpp"
#include "gfx/state_cache.hpp"
#include "terrain/terrain_engine.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::app {

struct RenderSettings {
  double lodTolerancePixels = 1.5;
  double verticalExaggeration = 1.0;
  bool wireframe = false;
  bool measure = false;  ///< wrap passes in GPU timer and pipeline-statistics queries (waits)
  /// Paged terrain: wait until every tile the view wants is loaded (still images), instead of
  /// drawing coarser parents while they load (flights).
  bool waitForTiles = false;
};

struct PassStats {
  double gpuMilliseconds = 0.0;
  gfx::PipelineCounts counts;
};

struct FrameStats {
  PassStats terrain;
  terrain::TerrainDrawStats terrainDraw;
  std::size_t terrainCulled = 0;
  int finestLevel = 0;
  int coarsestLevel = 0;
  double selectMilliseconds = 0.0;  ///< CPU time of the LOD selection
  std::size_t tilesMissing = 0;     ///< paged terrain: tiles wanted but not loaded (parents drawn)
  std::size_t tilesArrived = 0;     ///< paged terrain: tiles that became resident this frame
  terrain::TilePagerStats pager;
};

inline constexpr glm::vec4 kBackground{0.06F, 0.07F, 0.09F, 1.0F};

class SceneRenderer {
 public:
  /// Uploads the scene to the current context.
  static Result<SceneRenderer> create(const LoadedScene& scene);

  /// Clears colour, depth (reversed-Z: 0) and stencil, selects the terrain chunks for this view
  /// and draws all passes.
  FrameStats render(gfx::StateCache& cache, GLuint framebuffer, int width, int height, const Camera& camera,
                    const RenderSettings& settings);

  [[nodiscard]] const terrain::TerrainEngine& terrainEngine() const { return *terrain_; }
  [[nodiscard]] const terrain::LodSelection& lastSelection() const { return selection_; }

 private:
  SceneRenderer() = default;
  std::optional<terrain::TerrainEngine> terrain_;
  terrain::LodSelection selection_;
  std::optional<gfx::GpuTimer> timer_;
  std::optional<gfx::PipelineStatistics> statistics_;
};

}  // namespace gis::app
