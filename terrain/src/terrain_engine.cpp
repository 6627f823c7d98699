#include "terrain/terrain_engine.hpp"

#include <cmath>

#include "gfx/camera.hpp"

namespace gis::terrain {
namespace {

struct ChunkVertex {
  float x, y;           ///< relative to the chunk centre, metres
  float height;         ///< unexaggerated
  float stitchHeight;   ///< height when the vertex's edge is stitched
  std::uint32_t edges;  ///< ChunkEdge bits of the edge this odd vertex lies on (0 for others)
};
static_assert(sizeof(ChunkVertex) == 20);

std::uint32_t oddEdgeBits(int i, int j, int n) {
  std::uint32_t bits = 0;
  if ((i & 1) == 1 && j == 0) bits |= kEdgeNorth;
  if ((i & 1) == 1 && j == n) bits |= kEdgeSouth;
  if ((j & 1) == 1 && i == 0) bits |= kEdgeWest;
  if ((j & 1) == 1 && i == n) bits |= kEdgeEast;
  return bits;
}

/// Cell (i, j) of an n × n chunk as two triangles a-d-e, a-e-b (counter-clockwise seen from
/// above for a north-up grid, where j grows southwards).
void pushCell(std::vector<std::uint32_t>& out, int i, int j, int n) {
  const auto v = [n](int ii, int jj) { return static_cast<std::uint32_t>(jj * (n + 1) + ii); };
  out.insert(out.end(), {v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i + 1, j)});
}

}  // namespace

Result<TerrainEngine> TerrainEngine::create(std::shared_ptr<const TerrainQuadtree> tree, const FrameOrthophoto* photo,
                                            std::size_t gpuBudgetBytes) {
  Result<gfx::Program> program = gfx::Program::build({{"terrain_chunk.vert", {}}, {"terrain_chunk.frag", {}}});
  if (!program) {
    Result<TerrainEngine> r;
    r.diagnostics = program.diagnostics;
    return r;
  }
  TerrainEngine e;
  e.tree_ = std::move(tree);
  e.program_ = std::move(*program);
  e.gpuBudget_ = gpuBudgetBytes;
  const int n = e.tree_->chunkCells();
  std::vector<std::uint32_t> indices;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) pushCell(indices, i, j, n);
  }
  e.sharedIndices_ = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint32_t));
  e.sharedIndexCount_ = static_cast<GLsizei>(indices.size());

  if (photo != nullptr && photo->image.width > 0) {
    const Orthophoto& img = photo->image;
    const int levels = 1 + static_cast<int>(std::floor(std::log2(std::max(img.width, img.height))));
    e.imagery_ = gfx::createTexture(GL_TEXTURE_2D);
    const GLuint tex = e.imagery_.id();
    glTextureStorage2D(tex, levels, GL_RGBA8, img.width, img.height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(tex, 0, 0, 0, img.width, img.height, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
    glGenerateTextureMipmap(tex);
    glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    e.imageryTransform_ = photo->frameTransform;
    e.imagerySize_ = glm::dvec2(img.width, img.height);
  }
  e.program_.set("u_imagery", 0);
  e.program_.set("u_hasImagery", e.imageryTransform_ ? 1 : 0);
  e.program_.set("u_lightDirection", glm::vec3(-0.5F, 0.6F, 0.8F));
  Result<TerrainEngine> r;
  r.value = std::move(e);
  return r;
}

TerrainEngine::GpuChunk& TerrainEngine::chunk(const NodeId& id, TerrainDrawStats& stats) {
  const auto found = chunks_.find(id.key());
  if (found != chunks_.end()) {
    lru_.splice(lru_.begin(), lru_, found->second.lru);
    return found->second;
  }
  const TerrainQuadtree& tree = *tree_;
  const int n = tree.chunkCells();
  const auto extent = tree.frameExtent(id);
  GpuChunk c;
  c.centre = (extent[0] + extent[1]) * 0.5;
  std::vector<ChunkVertex> vertices;
  vertices.reserve(static_cast<std::size_t>((n + 1) * (n + 1)));
  bool hasNodata = false;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const glm::ivec2 p = tree.vertexPost(id, i, j);
      const float h = tree.post(p.x, p.y);
      const std::uint32_t edges = oddEdgeBits(i, j, n);
      float stitched = h;
      if (edges != 0) {
        const std::uint8_t mask = static_cast<std::uint8_t>(edges);
        stitched = tree.drawnVertexHeight(id, mask, i, j);
        if (std::isnan(stitched)) stitched = h;  // a neighbour with nodata: that coarse cell is not drawn
      }
      hasNodata = hasNodata || std::isnan(h);
      const glm::dvec2 xy = tree.grid().postPosition(p.x, p.y) - c.centre;
      vertices.push_back({static_cast<float>(xy.x), static_cast<float>(xy.y), std::isnan(h) ? 0.0F : h,
                          std::isnan(stitched) ? 0.0F : stitched, edges});
    }
  }
  c.vertices = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(ChunkVertex));
  c.bytes = vertices.size() * sizeof(ChunkVertex);
  GLuint indexBuffer = sharedIndices_.id();
  c.indexCount = sharedIndexCount_;
  if (hasNodata) {
    // Cells with a nodata corner are holes, not spikes: leave them out.
    std::vector<std::uint32_t> indices;
    auto valid = [&](int i, int j) {
      const glm::ivec2 p = tree.vertexPost(id, i, j);
      return !std::isnan(tree.post(p.x, p.y));
    };
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (valid(i, j) && valid(i + 1, j) && valid(i, j + 1) && valid(i + 1, j + 1)) pushCell(indices, i, j, n);
      }
    }
    c.indices = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint32_t));
    c.indexCount = static_cast<GLsizei>(indices.size());
    c.bytes += indices.size() * sizeof(std::uint32_t);
    indexBuffer = c.indices.id();
  }
  c.vao = gfx::createVertexArray();
  const GLuint vao = c.vao.id();
  glVertexArrayVertexBuffer(vao, 0, c.vertices.id(), 0, sizeof(ChunkVertex));
  glVertexArrayElementBuffer(vao, indexBuffer);
  auto floatAttribute = [vao](GLuint index, GLint size, std::size_t offset) {
    glEnableVertexArrayAttrib(vao, index);
    glVertexArrayAttribFormat(vao, index, size, GL_FLOAT, GL_FALSE, static_cast<GLuint>(offset));
    glVertexArrayAttribBinding(vao, index, 0);
  };
  floatAttribute(0, 2, offsetof(ChunkVertex, x));
  floatAttribute(1, 1, offsetof(ChunkVertex, height));
  floatAttribute(2, 1, offsetof(ChunkVertex, stitchHeight));
  glEnableVertexArrayAttrib(vao, 3);
  glVertexArrayAttribIFormat(vao, 3, 1, GL_UNSIGNED_INT, static_cast<GLuint>(offsetof(ChunkVertex, edges)));
  glVertexArrayAttribBinding(vao, 3, 0);

  ++stats.chunksBuilt;
  gpuBytes_ += c.bytes;
  lru_.push_front(id.key());
  c.lru = lru_.begin();
  return chunks_.emplace(id.key(), std::move(c)).first->second;
}

void TerrainEngine::evictTo(std::size_t budget) {
  while (gpuBytes_ > budget && !lru_.empty()) {
    const auto it = chunks_.find(lru_.back());
    gpuBytes_ -= it->second.bytes;
    chunks_.erase(it);
    lru_.pop_back();
  }
}

TerrainDrawStats TerrainEngine::draw(gfx::StateCache& cache, const glm::dmat4& viewProj, const LodSelection& selection,
                                     double exaggeration) {
  TerrainDrawStats stats;
  gfx::PipelineState state = gfx::kOpaque;
  if (wireframe_) state.raster.polygonMode = gfx::PolygonMode::Line;
  cache.apply(state);
  program_.use();
  program_.set("u_exaggeration", static_cast<float>(exaggeration));
  if (imageryTransform_) glBindTextureUnit(0, imagery_.id());
  const GLint stitchLocation = program_.location("u_stitchMask");
  for (const SelectedChunk& s : selection.chunks) {
    GpuChunk& c = chunk(s.id, stats);
    program_.set("u_modelViewProj", gfx::relativeToCentre(viewProj, glm::dvec3(c.centre, 0.0)));
    glProgramUniform1ui(program_.id(), stitchLocation, s.stitchMask);
    if (imageryTransform_) {
      // uv = (frame − imagery corner) / imagery size, split into a double base and a float slope.
      const glm::dvec2 pixel = *imageryTransform_->crsToPixel(c.centre);
      const auto& g = imageryTransform_->c;
      program_.set("u_uvBase", glm::vec2(pixel / imagerySize_));
      program_.set("u_uvScale", glm::vec2(1.0 / (g[1] * imagerySize_.x), 1.0 / (g[5] * imagerySize_.y)));
    }
    glBindVertexArray(c.vao.id());
    glDrawElements(GL_TRIANGLES, c.indexCount, GL_UNSIGNED_INT, nullptr);
    ++stats.chunks;
    stats.triangles += static_cast<std::size_t>(c.indexCount) / 3;
  }
  glBindVertexArray(0);
  // Keep this frame's chunks; drop the least recently used beyond the budget.
  evictTo(std::max(gpuBudget_, std::size_t{0}));
  return stats;
}

}  // namespace gis::terrain
