#include "terrain/terrain_renderer.hpp"

#include <cmath>
#include <cstddef>

#include "gfx/camera.hpp"

namespace gis::terrain {

Result<TerrainRenderer> TerrainRenderer::create(const TerrainMesh& mesh, const Orthophoto* orthophoto) {
  Result<gfx::Program> program = gfx::Program::build({{"terrain.vert", {}}, {"terrain.frag", {}}});
  if (!program) {
    Result<TerrainRenderer> r;
    r.diagnostics = program.diagnostics;
    return r;
  }
  TerrainRenderer t;
  t.program_ = std::move(*program);
  t.centre_ = mesh.centre;
  t.indexCount_ = mesh.indices.size();
  t.vertices_ = gfx::createBufferWithData(mesh.vertices.data(), mesh.vertices.size() * sizeof(TerrainVertex));
  t.indices_ = gfx::createBufferWithData(mesh.indices.data(), mesh.indices.size() * sizeof(std::uint32_t));

  t.vao_ = gfx::createVertexArray();
  const GLuint vao = t.vao_.id();
  glVertexArrayVertexBuffer(vao, 0, t.vertices_.id(), 0, sizeof(TerrainVertex));
  glVertexArrayElementBuffer(vao, t.indices_.id());
  auto attribute = [vao](GLuint index, GLint size, std::size_t offset) {
    glEnableVertexArrayAttrib(vao, index);
    glVertexArrayAttribFormat(vao, index, size, GL_FLOAT, GL_FALSE, static_cast<GLuint>(offset));
    glVertexArrayAttribBinding(vao, index, 0);
  };
  attribute(0, 3, offsetof(TerrainVertex, position));
  attribute(1, 3, offsetof(TerrainVertex, normal));
  attribute(2, 2, offsetof(TerrainVertex, imageryUv));

  if (orthophoto != nullptr && orthophoto->width > 0 && orthophoto->height > 0) {
    const int levels = 1 + static_cast<int>(std::floor(std::log2(std::max(orthophoto->width, orthophoto->height))));
    t.imagery_ = gfx::createTexture(GL_TEXTURE_2D);
    const GLuint tex = t.imagery_.id();
    glTextureStorage2D(tex, levels, GL_RGBA8, orthophoto->width, orthophoto->height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(tex, 0, 0, 0, orthophoto->width, orthophoto->height, GL_RGBA, GL_UNSIGNED_BYTE,
                        orthophoto->rgba.data());
    glGenerateTextureMipmap(tex);
    glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    t.hasImagery_ = true;
  }
  t.program_.set("u_imagery", 0);
  t.program_.set("u_hasImagery", t.hasImagery_ ? 1 : 0);
  t.program_.set("u_lightDirection", glm::vec3(-0.5F, 0.6F, 0.8F));

  Result<TerrainRenderer> result;
  result.value = std::move(t);
  return result;
}

void TerrainRenderer::draw(gfx::StateCache& cache, const glm::dmat4& viewProj) const {
  cache.apply(gfx::kOpaque);
  program_.use();
  program_.set("u_modelViewProj", gfx::relativeToCentre(viewProj, centre_));
  if (hasImagery_) glBindTextureUnit(0, imagery_.id());
  glBindVertexArray(vao_.id());
  glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(indexCount_), GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

}  // namespace gis::terrain
