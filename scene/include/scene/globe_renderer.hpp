#pragma once
// One frame of a globe scene (docs/globe.md): the terrain's tiles for the view, then the layers'
// stencil polyhedra over them, into the bound framebuffer, with GPU times per part.
#include <cstdint>
#include <memory>
#include <vector>

#include "gfx/state_cache.hpp"
#include "globe/globe_terrain.hpp"
#include "vector_overlay/globe_overlay.hpp"

namespace gis::globe {

struct GlobeFrameStats {
  TerrainStats terrain;
  GlobeOverlayStats overlay;
  std::size_t selectedTiles = 0;
  double selectMilliseconds = 0.0;
  double terrainGpuMilliseconds = 0.0;  ///< GL_TIME_ELAPSED; 0 unless timed
  double overlayGpuMilliseconds = 0.0;
  /// The layers' passes as the pipeline counts them (deterministic, unlike times); 0 unless timed.
  std::uint64_t overlayFragments = 0;
  std::uint64_t overlayPrimitives = 0;  ///< entering the clipper
  std::uint64_t terrainFragments = 0;
};

struct GlobeFrameTarget {
  GLuint framebuffer = 0;
  int width = 0, height = 0;
  bool hasMask = false;  ///< a second draw buffer for the layers' bits (gfx::RenderTarget's mask)
  glm::vec4 clearColor{0.02F, 0.03F, 0.08F, 1.0F};
};

class GlobeRenderer {
 public:
  GlobeRenderer(std::shared_ptr<const GeoGrid> heights, TerrainOptions terrain = {});

  /// Clears the target and draws the terrain and (unless empty) the layers; with `timed`, waits
  /// for GPU timer queries around each part.
  GlobeFrameStats render(gfx::StateCache& cache, const GlobeFrameTarget& target, const GlobeView& view,
                         const std::vector<const GlobeLayer*>& layers, bool timed = false,
                         const GlobeOverlaySettings& settings = {});

  /// Imagery draped over the terrain's tiles (GlobeTerrain::setImagery); null: the height tint.
  void setImagery(std::shared_ptr<const GlobeImagery> imagery) { terrain_.setImagery(std::move(imagery)); }

  [[nodiscard]] GlobeTerrain& terrain() { return terrain_; }
  [[nodiscard]] const GlobeTerrain& terrain() const { return terrain_; }
  /// The layers' renderer, for analyses over the last frame (GlobeOverlayRenderer::markOverlap).
  [[nodiscard]] GlobeOverlayRenderer& overlay() { return overlay_; }
  [[nodiscard]] const GlobeOverlayRenderer& overlay() const { return overlay_; }
  /// The tiles the last frame drew.
  [[nodiscard]] const std::vector<DrawnTile>& tiles() const { return tiles_; }
  [[nodiscard]] const GeoGrid& heights() const { return *heights_; }

 private:
  std::shared_ptr<const GeoGrid> heights_;
  GlobeTerrain terrain_;
  GlobeOverlayRenderer overlay_;
  std::vector<DrawnTile> tiles_;
};

}  // namespace gis::globe
