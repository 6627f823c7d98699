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
#include "terrain/terrain_renderer.hpp"

namespace gis::app {

struct PassStats {
  double gpuMilliseconds = 0.0;
  gfx::PipelineCounts counts;
};

struct FrameStats {
  PassStats terrain;
};

inline constexpr glm::vec4 kBackground{0.06F, 0.07F, 0.09F, 1.0F};

class SceneRenderer {
 public:
  /// Uploads the scene to the current context.
  static Result<SceneRenderer> create(const LoadedScene& scene);

  /// Clears colour, depth (reversed-Z: 0) and stencil and draws all passes. With `measure`,
  /// every pass is wrapped in a GPU timer and pipeline-statistics queries (waits for them).
  FrameStats render(gfx::StateCache& cache, GLuint framebuffer, int width, int height, const Camera& camera,
                    bool measure);

  [[nodiscard]] std::size_t terrainTriangles() const { return terrain_->triangleCount(); }

 private:
  SceneRenderer() = default;
  std::optional<terrain::TerrainRenderer> terrain_;
  std::optional<gfx::GpuTimer> timer_;
  std::optional<gfx::PipelineStatistics> statistics_;
};

}  // namespace gis::app
