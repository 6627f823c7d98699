#pragma once
// Draws a TerrainMesh with its orthophoto (or hillshade when there is no imagery).
#include <optional>

#include <glm/mat4x4.hpp>

#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/state_cache.hpp"
#include "terrain/orthophoto.hpp"
#include "terrain/terrain_mesh.hpp"

namespace gis::terrain {

class TerrainRenderer {
 public:
  /// Uploads the mesh and the orthophoto (may be null). Needs a current GL 4.5 context.
  static Result<TerrainRenderer> create(const TerrainMesh& mesh, const Orthophoto* orthophoto);

  /// Draws with depth test and write (reversed-Z). `viewProj` maps frame coordinates to clip.
  void draw(gfx::StateCache& cache, const glm::dmat4& viewProj) const;

  [[nodiscard]] std::size_t triangleCount() const { return indexCount_ / 3; }

 private:
  TerrainRenderer() = default;
  mutable gfx::Program program_;
  gfx::VertexArrayHandle vao_;
  gfx::BufferHandle vertices_;
  gfx::BufferHandle indices_;
  gfx::TextureHandle imagery_;
  bool hasImagery_ = false;
  glm::dvec3 centre_{0.0};
  std::size_t indexCount_ = 0;
};

}  // namespace gis::terrain
