#pragma once
// Draws the quadtree's chunks chosen by the LOD selection: one vertex buffer per chunk, made on
// first use and kept in an LRU cache under a GPU memory budget; one shared index buffer for
// chunks without nodata; odd edge vertices take the coarser neighbour's heights in the vertex
// shader where the chunk's stitch mask says so; vertical exaggeration is a uniform.
#include <array>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "geo/raster.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/state_cache.hpp"
#include "terrain/elevation_ramp.hpp"
#include "terrain/lod.hpp"
#include "terrain/orthophoto.hpp"
#include "terrain/quadtree.hpp"

namespace gis::terrain {

/// Orthophoto resampled into the scene frame: texels on a north-up grid whose geotransform is in
/// frame coordinates.
struct FrameOrthophoto {
  Orthophoto image;
  geo::GeoTransform frameTransform;  ///< pixel corner → frame coordinates
};

/// Towards the hillshade's light, frame coordinates (from the north-west, high).
inline constexpr glm::dvec3 kLightDirection{-0.5, 0.6, 0.8};

/// The hillshade's brightness for a surface normal (frame coordinates, drawn heights): what the
/// terrain shader multiplies the grey or the elevation tint by, from the normal of the drawn
/// triangle.
inline double hillshadeFactor(const glm::dvec3& normal) {
  glm::dvec3 n = glm::normalize(normal);
  if (n.z < 0.0) n = -n;
  const double shade = glm::clamp(glm::dot(n, glm::normalize(kLightDirection)), 0.0, 1.0);
  return 0.35 + 0.65 * shade;
}

struct TerrainDrawStats {
  std::size_t chunks = 0;
  std::size_t triangles = 0;
  std::size_t chunksBuilt = 0;    ///< vertex buffers made this frame
  std::size_t chunksMissing = 0;  ///< selected but neither on the GPU nor resident (not drawn)
};

class TerrainEngine {
 public:
  static constexpr std::size_t kDefaultGpuBudgetBytes = 512u << 20;

  /// Needs a current GL 4.5 context. `photo` may be null (hillshade).
  static Result<TerrainEngine> create(std::shared_ptr<const TerrainQuadtree> tree, const FrameOrthophoto* photo,
                                      std::size_t gpuBudgetBytes = kDefaultGpuBudgetBytes);

  /// Draws the chunks of `selection` (depth test and write, reversed-Z). `eye` (frame
  /// coordinates) picks the frame-wide centre that vertices are made relative to.
  TerrainDrawStats draw(gfx::StateCache& cache, const glm::dmat4& viewProj, const glm::dvec3& eye,
                        const LodSelection& selection, double exaggeration);

  [[nodiscard]] const TerrainQuadtree& tree() const { return *tree_; }
  [[nodiscard]] std::size_t gpuBytes() const { return gpuBytes_; }
  [[nodiscard]] std::size_t cachedChunks() const { return chunks_.size(); }
  /// True if the chunk's buffers are on the GPU (drawable without its posts in memory).
  [[nodiscard]] bool hasChunk(const NodeId& id) const;
  void setWireframe(bool on) { wireframe_ = on; }
  /// A texture drape (the draping baseline: overlay::TextureDrape) sampled by the terrain shader,
  /// its colour blended over the terrain and its layer bits written to the mask attachment; none
  /// by default. The textures must outlive its use.
  struct Drape {
    GLuint color = 0;        ///< premultiplied RGBA, mip-mapped
    GLuint mask = 0;         ///< R32F layer bits
    glm::dvec2 origin{0.0};  ///< the extent's minimum corner, frame coordinates
    glm::dvec2 size{1.0};    ///< metres
    /// Draping per tile (overlay::TiledDrape): texture arrays, and for each chunk its layer and
    /// extent (origin, size); a chunk without one is drawn undraped. Then color, mask, origin
    /// and size are not used.
    GLuint colorArray = 0;
    GLuint maskArray = 0;
    std::function<std::optional<std::tuple<int, glm::dvec2, glm::dvec2>>(const NodeId&)> tileOf;
  };
  void setDrape(std::optional<Drape> drape) { drape_ = drape; }
  [[nodiscard]] bool hasDrape() const { return drape_.has_value(); }
  /// Off: hillshade even where there is imagery (the viewer's "imagery" switch).
  void setImagery(bool on) { imageryOn_ = on; }
  [[nodiscard]] bool hasImagery() const { return imageryTransform_.has_value(); }
  /// A hypsometric tint where the terrain is hill-shaded (no imagery, imagery off, or outside
  /// it): the ramp's colour at the true height (exaggeration undone) normalised over `range`
  /// (low, high; ElevationRamp::normalised), times the hillshade. nullopt: grey (the default).
  void setElevationRamp(std::optional<std::pair<double, double>> range,
                        const ElevationRamp& ramp = ElevationRamp::hypsometric()) {
    rampRange_ = range;
    ramp_ = ramp;
  }

 private:
  struct GpuChunk {
    gfx::BufferHandle vertices;
    gfx::VertexArrayHandle vao;
    bool hasNodata = false;
    std::vector<bool> valid;  ///< per vertex, for chunks with nodata
    /// Index buffers per stitch mask of chunks with nodata (others share the engine's).
    std::array<std::pair<gfx::BufferHandle, GLsizei>, 16> ownIndices;
    std::size_t bytes = 0;
    std::list<std::uint64_t>::iterator lru;
  };
  TerrainEngine() = default;
  GpuChunk* chunk(const NodeId& id, TerrainDrawStats& stats);
  std::pair<GLuint, GLsizei> indicesFor(GpuChunk& c, std::uint8_t mask);
  void evictTo(std::size_t budget);

  std::shared_ptr<const TerrainQuadtree> tree_;
  gfx::Program program_;
  std::array<gfx::BufferHandle, 16> sharedIndices_;  ///< per stitch mask
  std::array<GLsizei, 16> sharedIndexCount_{};
  gfx::TextureHandle imagery_;
  std::optional<geo::GeoTransform> imageryTransform_;
  glm::dvec2 imagerySize_{1.0};
  std::unordered_map<std::uint64_t, GpuChunk> chunks_;
  std::list<std::uint64_t> lru_;  ///< most recently used first
  std::size_t gpuBytes_ = 0;
  std::size_t gpuBudget_ = kDefaultGpuBudgetBytes;
  bool wireframe_ = false;
  bool imageryOn_ = true;
  std::optional<std::pair<double, double>> rampRange_;
  ElevationRamp ramp_ = ElevationRamp::hypsometric();
  std::optional<Drape> drape_;
};

}  // namespace gis::terrain
