#include "vector_overlay/texture_drape.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include <glm/vec4.hpp>

#include "gfx/gl.hpp"
#include "gfx/pipeline_state.hpp"
#include "gfx/render_target.hpp"

namespace gis::overlay {
namespace {

struct DrapeVertex {
  float x, y;
  float r, g, b, a;
};

/// One blend per texel and layer: where the stencil is still 0 the fragment blends and sets it
/// to 1 (the first feature drawn wins where features of a layer overlap).
constexpr gfx::PipelineState kDrapeLayer = [] {
  gfx::StencilFace face;
  face.func = gfx::CompareFunc::NotEqual;
  face.ref = 1;
  face.depthPass = gfx::StencilOp::Replace;
  gfx::PipelineState s;
  s.depth = gfx::DepthState{false, false, gfx::CompareFunc::Always, false};
  s.stencil = gfx::StencilState{true, face, face};
  s.blend = gfx::kBlendPremultipliedOver;
  s.raster.cull = gfx::CullMode::None;
  return s;
}();

int mipLevels(int size) {
  int levels = 1;
  while ((size >> levels) > 0) ++levels;
  return levels;
}

/// The vertex array of DrapeVertex (binding 0).
gfx::VertexArrayHandle drapeVertexArray() {
  gfx::VertexArrayHandle vao = gfx::createVertexArray();
  glEnableVertexArrayAttrib(vao.id(), 0);
  glVertexArrayAttribFormat(vao.id(), 0, 2, GL_FLOAT, GL_FALSE, offsetof(DrapeVertex, x));
  glVertexArrayAttribBinding(vao.id(), 0, 0);
  glEnableVertexArrayAttrib(vao.id(), 1);
  glVertexArrayAttribFormat(vao.id(), 1, 4, GL_FLOAT, GL_FALSE, offsetof(DrapeVertex, r));
  glVertexArrayAttribBinding(vao.id(), 1, 0);
  return vao;
}

/// Clears the `size`² framebuffer `fbo` (colour, mask) and draws into it the triangles of
/// `source` that may meet `extent`: one layer after the other, the stencil cleared before each, so
/// a texel blends each layer once. A pass of its own: the target bound before (the frame's) is
/// bound again after it. Returns the triangles.
std::size_t drawLayers(gfx::StateCache& cache, gfx::Program& program, GLuint vao, GLuint fbo, int size,
                       const DrapeSource& source, const DrapeExtent& extent) {
  const gfx::RenderPass pass(cache, fbo, size, size);
  cache.apply(kDrapeLayer);
  const float zero[4] = {0.0F, 0.0F, 0.0F, 0.0F};
  glClearNamedFramebufferfv(fbo, GL_COLOR, 0, zero);
  glClearNamedFramebufferfv(fbo, GL_COLOR, 1, zero);
  cache.useProgram(program);
  program.set("u_scale", glm::vec2(2.0 / extent.size.x, 2.0 / extent.size.y));
  cache.bindVertexArray(vao);
  std::size_t triangles = 0;
  const glm::dvec2 lo = extent.origin, hi = extent.origin + extent.size;
  const glm::dvec2 texel = extent.size / static_cast<double>(size);
  std::vector<DrapeVertex> vertices;
  const DrapeSource::TriangleSink emit = [&](const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c,
                                             const glm::vec4& colour) {
    for (const glm::dvec2& p : {a, b, c}) {
      const glm::dvec2 q = p - extent.origin;
      vertices.push_back({static_cast<float>(q.x), static_cast<float>(q.y), colour.x, colour.y, colour.z, colour.w});
    }
  };
  for (std::size_t i = 0; i < source.layerCount(); ++i) {
    vertices.clear();
    source.triangles(i, lo, hi, texel, emit);
    if (vertices.empty()) continue;
    triangles += vertices.size() / 3;
    const gfx::BufferHandle buffer = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(DrapeVertex));
    glVertexArrayVertexBuffer(vao, 0, buffer.id(), 0, sizeof(DrapeVertex));
    program.set("u_maskBit", static_cast<float>(std::uint32_t{1} << std::min<std::size_t>(i, 23)));
    const GLint zeroStencil = 0;
    glClearNamedFramebufferiv(fbo, GL_STENCIL, 0, &zeroStencil);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(vertices.size()));
  }
  return triangles;
}

}  // namespace

void FootprintDrapeSource::triangles(std::size_t layer, const glm::dvec2& lo, const glm::dvec2& hi,
                                     const glm::dvec2& texel, const TriangleSink& emit) const {
  (void)texel;
  const OverlayLayer* drawn = layers_[layer];
  if (drawn == nullptr) return;
  const std::vector<FeatureStyle>& styles = drawn->featureStyles();
  for (std::size_t p = 0; p < drawn->polyhedra().size(); ++p) {
    if (!drawn->slots()[p].live) continue;
    const Polyhedron& piece = drawn->polyhedra()[p];
    if (piece.boxMax.x < lo.x || piece.boxMin.x > hi.x || piece.boxMax.y < lo.y || piece.boxMin.y > hi.y) continue;
    const Footprint& f = piece.footprint;
    if (f.feature >= styles.size() || !styles[f.feature].visible) continue;
    const glm::vec4 c = styles[f.feature].color;
    for (const auto& t : f.triangles) emit(f.vertices[t[0]], f.vertices[t[1]], f.vertices[t[2]], c);
  }
}

Result<TextureDrape> TextureDrape::build(gfx::StateCache& cache, const DrapeSource& source, const DrapeExtent& extent,
                                         int size) {
  GLint maxSize = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &maxSize);
  if (size < 1 || size > maxSize) {
    return Result<TextureDrape>::failure(
        {Severity::Error, "", "", "",
         "texture drape: size " + std::to_string(size) + " outside [1, " + std::to_string(maxSize) + "]"});
  }
  if (!(extent.size.x > 0.0 && extent.size.y > 0.0 && std::isfinite(extent.size.x) && std::isfinite(extent.size.y))) {
    return Result<TextureDrape>::failure({Severity::Error, "", "", "", "texture drape: empty extent"});
  }
  Result<gfx::Program> program = gfx::Program::build({{"drape.vert", {}}, {"overlay_volume.frag", {}}});
  if (!program) {
    Result<TextureDrape> failed;
    failed.diagnostics = std::move(program.diagnostics);
    return failed;
  }
  const auto start = std::chrono::steady_clock::now();
  TextureDrape drape;
  drape.extent_ = extent;
  drape.stats_.size = size;
  const int levels = mipLevels(size);
  drape.color_ = gfx::createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(drape.color_.id(), levels, GL_RGBA8, size, size);
  glTextureParameteri(drape.color_.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(drape.color_.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(drape.color_.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(drape.color_.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  drape.mask_ = gfx::createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(drape.mask_.id(), 1, GL_R32F, size, size);
  glTextureParameteri(drape.mask_.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(drape.mask_.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  const gfx::RenderbufferHandle stencil = gfx::createRenderbuffer();
  glNamedRenderbufferStorage(stencil.id(), GL_STENCIL_INDEX8, size, size);
  const gfx::FramebufferHandle fbo = gfx::createFramebuffer();
  glNamedFramebufferTexture(fbo.id(), GL_COLOR_ATTACHMENT0, drape.color_.id(), 0);
  glNamedFramebufferTexture(fbo.id(), GL_COLOR_ATTACHMENT1, drape.mask_.id(), 0);
  glNamedFramebufferRenderbuffer(fbo.id(), GL_STENCIL_ATTACHMENT, GL_RENDERBUFFER, stencil.id());
  const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glNamedFramebufferDrawBuffers(fbo.id(), 2, buffers);
  if (glCheckNamedFramebufferStatus(fbo.id(), GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    return Result<TextureDrape>::failure({Severity::Error, "", "", "", "texture drape: framebuffer incomplete"});
  }

  const gfx::VertexArrayHandle vao = drapeVertexArray();
  drape.stats_.triangles = drawLayers(cache, *program, vao.id(), fbo.id(), size, source, extent);
  glGenerateTextureMipmap(drape.color_.id());
  glFinish();
  drape.stats_.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto texels = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
  drape.stats_.gpuBytes = texels * 4 * 4 / 3 + texels * 4;  // RGBA8 with its mip chain, R32F
  Result<TextureDrape> built;
  built.value = std::move(drape);
  return built;
}

std::vector<std::uint32_t> TextureDrape::readMask() const {
  const auto texels = static_cast<std::size_t>(stats_.size) * static_cast<std::size_t>(stats_.size);
  std::vector<float> values(texels);
  glGetTextureImage(mask_.id(), 0, GL_RED, GL_FLOAT, static_cast<GLsizei>(texels * sizeof(float)), values.data());
  std::vector<std::uint32_t> bits(texels);
  for (std::size_t i = 0; i < texels; ++i) bits[i] = static_cast<std::uint32_t>(std::lround(values[i]));
  return bits;
}

std::uint32_t TextureDrape::maskAt(const std::vector<std::uint32_t>& mask, const glm::dvec2& point) const {
  const glm::dvec2 uv = (point - extent_.origin) / extent_.size;
  if (!(uv.x >= 0.0 && uv.x < 1.0 && uv.y >= 0.0 && uv.y < 1.0)) return 0;
  const auto x = static_cast<std::size_t>(uv.x * stats_.size), y = static_cast<std::size_t>(uv.y * stats_.size);
  return mask[y * static_cast<std::size_t>(stats_.size) + x];
}

Result<TiledDrape> TiledDrape::create(int tileSize) {
  if (tileSize < 16 || tileSize > 4096) {
    return Result<TiledDrape>::failure(
        {Severity::Error, "", "", "", "tiled drape: tile size " + std::to_string(tileSize) + " outside [16, 4096]"});
  }
  Result<gfx::Program> program = gfx::Program::build({{"drape.vert", {}}, {"overlay_volume.frag", {}}});
  if (!program) {
    Result<TiledDrape> failed;
    failed.diagnostics = std::move(program.diagnostics);
    return failed;
  }
  TiledDrape d;
  d.tileSize_ = tileSize;
  d.program_ = std::move(*program);
  d.vao_ = drapeVertexArray();
  d.stencil_ = gfx::createRenderbuffer();
  glNamedRenderbufferStorage(d.stencil_.id(), GL_STENCIL_INDEX8, tileSize, tileSize);
  d.fbo_ = gfx::createFramebuffer();
  d.allocate(16);
  Result<TiledDrape> r;
  r.value = std::move(d);
  return r;
}

void TiledDrape::allocate(int capacity) {
  capacity_ = capacity;
  tiles_.clear();
  lru_.clear();
  freeLayers_.clear();
  for (int i = capacity - 1; i >= 0; --i) freeLayers_.push_back(i);
  // No mip levels: a tile's texels are already about a pixel where its chunk is drawn.
  color_ = gfx::createTexture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(color_.id(), 1, GL_RGBA8, tileSize_, tileSize_, capacity);
  glTextureParameteri(color_.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(color_.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(color_.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(color_.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  mask_ = gfx::createTexture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(mask_.id(), 1, GL_R32F, tileSize_, tileSize_, capacity);
  glTextureParameteri(mask_.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(mask_.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

std::size_t TiledDrape::gpuBytes() const {
  const auto texels = static_cast<std::size_t>(tileSize_) * static_cast<std::size_t>(tileSize_);
  return static_cast<std::size_t>(capacity_) * texels * 8 + texels;  // RGBA8 + R32F per layer, stencil
}

void TiledDrape::beginFrame(std::size_t tiles) {
  ++frame_;
  if (tiles > static_cast<std::size_t>(capacity_)) {
    int capacity = capacity_;
    while (static_cast<std::size_t>(capacity) < tiles) capacity *= 2;
    allocate(capacity);
  }
}

void TiledDrape::invalidate() {
  for (const auto& [key, entry] : tiles_) freeLayers_.push_back(entry.layer);
  tiles_.clear();
  lru_.clear();
}

void TiledDrape::invalidate(const glm::dvec2& lo, const glm::dvec2& hi) {
  for (auto it = tiles_.begin(); it != tiles_.end();) {
    const glm::dvec2 a = it->second.extent.origin, b = a + it->second.extent.size;
    if (b.x < lo.x || a.x > hi.x || b.y < lo.y || a.y > hi.y) {
      ++it;
      continue;
    }
    freeLayers_.push_back(it->second.layer);
    lru_.erase(it->second.lru);
    it = tiles_.erase(it);
  }
}

TiledDrape::Tile TiledDrape::tile(gfx::StateCache& cache, const DrapeSource& source, std::uint64_t key,
                                  const DrapeExtent& extent, FrameStats& stats) {
  if (const auto found = tiles_.find(key); found != tiles_.end()) {
    Entry& e = found->second;
    e.frame = frame_;
    lru_.splice(lru_.begin(), lru_, e.lru);
    stats.tilesResident = tiles_.size();
    return {e.layer, e.extent};
  }
  if (freeLayers_.empty()) {
    // The least recently used tile; beginFrame made room for every tile of this frame.
    const std::uint64_t oldest = lru_.back();
    freeLayers_.push_back(tiles_.at(oldest).layer);
    tiles_.erase(oldest);
    lru_.pop_back();
  }
  const int layer = freeLayers_.back();
  freeLayers_.pop_back();
  const auto start = std::chrono::steady_clock::now();
  rasterise(cache, source, layer, extent);
  glFinish();
  stats.buildSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++stats.tilesBuilt;
  lru_.push_front(key);
  tiles_[key] = Entry{layer, extent, frame_, lru_.begin()};
  stats.tilesResident = tiles_.size();
  return {layer, extent};
}

void TiledDrape::rasterise(gfx::StateCache& cache, const DrapeSource& source, int layer, const DrapeExtent& extent) {
  glNamedFramebufferTextureLayer(fbo_.id(), GL_COLOR_ATTACHMENT0, color_.id(), 0, layer);
  glNamedFramebufferTextureLayer(fbo_.id(), GL_COLOR_ATTACHMENT1, mask_.id(), 0, layer);
  glNamedFramebufferRenderbuffer(fbo_.id(), GL_STENCIL_ATTACHMENT, GL_RENDERBUFFER, stencil_.id());
  const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glNamedFramebufferDrawBuffers(fbo_.id(), 2, buffers);
  drawLayers(cache, program_, vao_.id(), fbo_.id(), tileSize_, source, extent);
}

}  // namespace gis::overlay
