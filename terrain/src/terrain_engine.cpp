#include "terrain/terrain_engine.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "gfx/camera.hpp"

namespace gis::terrain {
namespace {

struct ChunkVertex {
  std::uint16_t i, j;  ///< vertex of the chunk's (N + 1)² grid; the shader derives the position
  float height;        ///< unexaggerated; nodata posts hold 0 and are never referenced
};
static_assert(sizeof(ChunkVertex) == 8);

/// Cell (i, j) of an n × n chunk as two triangles a-d-e, a-e-b (counter-clockwise seen from
/// above for a north-up grid, where j grows southwards), with odd vertices of stitched edges
/// collapsed onto their even predecessor; collapsed (zero-area) triangles are left out.
void pushCell(std::vector<std::uint32_t>& out, const TerrainQuadtree& tree, std::uint8_t mask, int i, int j) {
  const int n = tree.chunkCells();
  const auto v = [&](int ii, int jj) {
    const glm::ivec2 c = tree.stitchedVertex(mask, ii, jj);
    return static_cast<std::uint32_t>(c.y * (n + 1) + c.x);
  };
  const std::uint32_t a = v(i, j), b = v(i + 1, j), d = v(i, j + 1), e = v(i + 1, j + 1);
  if (a != d && d != e && a != e) out.insert(out.end(), {a, d, e});
  if (a != e && e != b && a != b) out.insert(out.end(), {a, e, b});
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
  for (std::uint8_t mask = 0; mask < 16; ++mask) {
    std::vector<std::uint32_t> indices;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) pushCell(indices, *e.tree_, mask, i, j);
    }
    e.sharedIndices_[mask] = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint32_t));
    e.sharedIndexCount_[mask] = static_cast<GLsizei>(indices.size());
  }

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
  e.program_.set("u_drape", 1);
  e.program_.set("u_drapeMask", 2);
  e.program_.set("u_drapeTiles", 3);
  e.program_.set("u_drapeTileMask", 4);
  e.program_.set("u_hasImagery", e.imageryTransform_ ? 1 : 0);
  e.program_.set("u_lightDirection", glm::vec3(kLightDirection));
  Result<TerrainEngine> r;
  r.value = std::move(e);
  return r;
}

bool TerrainEngine::hasChunk(const NodeId& id) const { return chunks_.count(id.key()) != 0; }

TerrainEngine::GpuChunk* TerrainEngine::chunk(const NodeId& id, TerrainDrawStats& stats) {
  const auto found = chunks_.find(id.key());
  if (found != chunks_.end()) {
    lru_.splice(lru_.begin(), lru_, found->second.lru);
    return &found->second;
  }
  const TileData posts = tree_->chunkPosts(id);
  if (!posts) {
    ++stats.chunksMissing;  // not resident: the LOD selection should not have chosen it
    return nullptr;
  }
  const int n = tree_->chunkCells();
  GpuChunk c;
  std::vector<ChunkVertex> vertices;
  vertices.reserve(posts->size());
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const float h = (*posts)[static_cast<std::size_t>(j * (n + 1) + i)];
      c.hasNodata = c.hasNodata || std::isnan(h);
      vertices.push_back({static_cast<std::uint16_t>(i), static_cast<std::uint16_t>(j), std::isnan(h) ? 0.0F : h});
    }
  }
  if (c.hasNodata) {
    c.valid.resize(posts->size());
    for (std::size_t k = 0; k < posts->size(); ++k) c.valid[k] = !std::isnan((*posts)[k]);
  }
  c.vertices = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(ChunkVertex));
  c.bytes = vertices.size() * sizeof(ChunkVertex);
  c.vao = gfx::createVertexArray();
  const GLuint vao = c.vao.id();
  glVertexArrayVertexBuffer(vao, 0, c.vertices.id(), 0, sizeof(ChunkVertex));
  glEnableVertexArrayAttrib(vao, 0);
  glVertexArrayAttribIFormat(vao, 0, 2, GL_UNSIGNED_SHORT, static_cast<GLuint>(offsetof(ChunkVertex, i)));
  glVertexArrayAttribBinding(vao, 0, 0);
  glEnableVertexArrayAttrib(vao, 1);
  glVertexArrayAttribFormat(vao, 1, 1, GL_FLOAT, GL_FALSE, static_cast<GLuint>(offsetof(ChunkVertex, height)));
  glVertexArrayAttribBinding(vao, 1, 0);

  ++stats.chunksBuilt;
  gpuBytes_ += c.bytes;
  lru_.push_front(id.key());
  c.lru = lru_.begin();
  return &chunks_.emplace(id.key(), std::move(c)).first->second;
}

std::pair<GLuint, GLsizei> TerrainEngine::indicesFor(GpuChunk& c, std::uint8_t mask) {
  if (!c.hasNodata) return {sharedIndices_[mask].id(), sharedIndexCount_[mask]};
  auto& own = c.ownIndices[mask];
  if (!own.first) {
    // Cells with a nodata corner are holes, not spikes: leave them out.
    const int n = tree_->chunkCells();
    auto valid = [&](int i, int j) { return c.valid[static_cast<std::size_t>(j * (n + 1) + i)]; };
    std::vector<std::uint32_t> indices;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (valid(i, j) && valid(i + 1, j) && valid(i, j + 1) && valid(i + 1, j + 1))
          pushCell(indices, *tree_, mask, i, j);
      }
    }
    own.first = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint32_t));
    own.second = static_cast<GLsizei>(indices.size());
    c.bytes += indices.size() * sizeof(std::uint32_t);
    gpuBytes_ += indices.size() * sizeof(std::uint32_t);
  }
  return {own.first.id(), own.second};
}

void TerrainEngine::evictTo(std::size_t budget) {
  while (gpuBytes_ > budget && !lru_.empty()) {
    const auto it = chunks_.find(lru_.back());
    gpuBytes_ -= it->second.bytes;
    chunks_.erase(it);
    lru_.pop_back();
  }
}

TerrainDrawStats TerrainEngine::draw(gfx::StateCache& cache, const glm::dmat4& viewProj, const glm::dvec3& eye,
                                     const LodSelection& selection, double exaggeration) {
  TerrainDrawStats stats;
  gfx::PipelineState state = gfx::kOpaque;
  if (wireframe_) state.raster.polygonMode = gfx::PolygonMode::Line;
  cache.apply(state);
  cache.useProgram(program_);
  const TerrainGrid& grid = tree_->grid();
  // One frame-wide matrix, centred on the post nearest the eye: every chunk computes a shared
  // vertex from the same integers with the same float operations, so edges meet bit for bit.
  const glm::dvec2 eyeGrid = grid.gridCoordinates(glm::dvec2(eye));
  const glm::ivec2 eyePost(static_cast<int>(std::lround(std::clamp(eyeGrid.x, -1e6, 1e6))),
                           static_cast<int>(std::lround(std::clamp(eyeGrid.y, -1e6, 1e6))));
  const glm::dvec2 centre = grid.postPosition(eyePost.x, eyePost.y);
  program_.set("u_modelViewProj", gfx::relativeToCentre(viewProj, glm::dvec3(centre, 0.0)));
  glProgramUniform2i(program_.id(), program_.location("u_eyePost"), eyePost.x, eyePost.y);
  program_.set("u_step", glm::vec2(grid.step));
  program_.set("u_exaggeration", static_cast<float>(exaggeration));
  program_.set("u_hasImagery", imageryTransform_ && imageryOn_ ? 1 : 0);
  if (imageryTransform_ && imageryOn_) {
    // uv = (frame − imagery corner) / imagery size: a double base at the centre, a float slope.
    const glm::dvec2 pixel = *imageryTransform_->crsToPixel(centre);
    const auto& g = imageryTransform_->c;
    program_.set("u_uvBase", glm::vec2(pixel / imagerySize_));
    program_.set("u_uvScale", glm::vec2(1.0 / (g[1] * imagerySize_.x), 1.0 / (g[5] * imagerySize_.y)));
    cache.bindTexture(0, imagery_.id());
  }
  program_.set("u_hasRamp", rampRange_ ? 1 : 0);
  if (rampRange_) {
    // t = (height − low) · scale: ElevationRamp::normalised in float.
    const auto [low, high] = *rampRange_;
    program_.set("u_rampLow", static_cast<float>(low));
    program_.set("u_rampScale", high > low ? static_cast<float>(1.0 / (high - low)) : 0.0F);
    const std::span<const RampStop> stops = ramp_.stops();
    std::array<float, ElevationRamp::kMaxStops> t{};
    std::array<glm::vec3, ElevationRamp::kMaxStops> colors{};
    for (std::size_t k = 0; k < stops.size(); ++k) {
      t[k] = static_cast<float>(stops[k].t);
      colors[k] = stops[k].color;
    }
    const auto count = static_cast<GLsizei>(stops.size());
    program_.set("u_rampStops", static_cast<int>(count));
    glProgramUniform1fv(program_.id(), program_.location("u_rampT"), count, t.data());
    glProgramUniform3fv(program_.id(), program_.location("u_rampColors"), count, &colors[0].x);
  }
  const bool tiled = drape_ && drape_->tileOf;
  program_.set("u_hasDrape", drape_ ? 1 : 0);
  program_.set("u_drapeTiled", tiled ? 1 : 0);
  if (drape_ && !tiled) {
    program_.set("u_drapeUvBase", glm::vec2((centre - drape_->origin) / drape_->size));
    program_.set("u_drapeUvScale", glm::vec2(1.0 / drape_->size));
    cache.bindTexture(1, drape_->color);
    cache.bindTexture(2, drape_->mask);
  } else if (tiled) {
    cache.bindTexture(3, drape_->colorArray);
    cache.bindTexture(4, drape_->maskArray);
  }
  const GLint hasDrapeLocation = program_.location("u_hasDrape");
  const GLint drapeLayerLocation = program_.location("u_drapeLayer");
  const GLint baseLocation = program_.location("u_chunkBase");
  const GLint levelLocation = program_.location("u_level");
  for (const SelectedChunk& s : selection.chunks) {
    GpuChunk* c = chunk(s.id, stats);
    if (c == nullptr) continue;
    const auto [indexBuffer, indexCount] = indicesFor(*c, s.stitchMask);
    const glm::ivec2 base = tree_->vertexPost(s.id, 0, 0);
    glProgramUniform2i(program_.id(), baseLocation, base.x, base.y);
    glProgramUniform1i(program_.id(), levelLocation, s.id.level);
    if (tiled) {
      const auto tile = drape_->tileOf(s.id);
      glProgramUniform1i(program_.id(), hasDrapeLocation, tile ? 1 : 0);
      if (tile) {
        const auto& [layer, origin, size] = *tile;
        glProgramUniform1i(program_.id(), drapeLayerLocation, layer);
        program_.set("u_drapeUvBase", glm::vec2((centre - origin) / size));
        program_.set("u_drapeUvScale", glm::vec2(1.0 / size));
      }
    }
    glVertexArrayElementBuffer(c->vao.id(), indexBuffer);
    cache.bindVertexArray(c->vao.id());
    glDrawElements(GL_TRIANGLES, indexCount, GL_UNSIGNED_INT, nullptr);
    ++stats.chunks;
    stats.triangles += static_cast<std::size_t>(indexCount) / 3;
  }
  evictTo(gpuBudget_);  // this frame's chunks are the most recent; the oldest go first
  return stats;
}

}  // namespace gis::terrain
