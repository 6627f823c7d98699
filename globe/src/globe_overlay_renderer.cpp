// Drawing the globe's layers (globe_overlay.hpp): the stencil core's mark and cover passes
// (vector_overlay/stencil_states.hpp) over the pieces of the drawn tiles.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <list>
#include <unordered_map>

#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "globe/globe_overlay.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::globe {

namespace detail {

struct TileGpu {
  gfx::BufferHandle vertices, indices;
  gfx::VertexArrayHandle vao;
  glm::dvec3 origin{0.0};  ///< ECEF: its vertices are relative to it (TilePieces::origin)
  GLuint originSlot = 0;   ///< in this frame's origins (relative to the eye): the draws' base instance
  std::vector<TilePieces::Piece> pieces;
  std::size_t indexCount = 0;
  std::list<std::pair<const GlobeLayer*, std::uint64_t>>::iterator lru;
};

}  // namespace detail

namespace {

using detail::TileGpu;

struct PairHash {
  std::size_t operator()(const std::pair<const GlobeLayer*, std::uint64_t>& k) const {
    return std::hash<const void*>()(k.first) ^ static_cast<std::size_t>(k.second * 0x9E3779B97F4A7C15ULL);
  }
};

}  // namespace

struct GlobeOverlayRenderer::Gpu {
  gfx::Program program;  ///< the volume shader of both frames (overlay_volume.vert)
  gfx::Program rect;     ///< the screen pass of the overlap's cover (overlay_cover.vert)
  gfx::VertexArrayHandle emptyVao;
  /// The drawn tiles' origins relative to the eye, this frame (the shader's a_origin, one per
  /// instance), and the buffer holding them.
  std::vector<glm::vec3> frameOrigins;
  gfx::BufferHandle origins;
  std::size_t originsCapacity = 0;
  std::unordered_map<std::pair<const GlobeLayer*, std::uint64_t>, TileGpu, PairHash> tiles;
  std::list<std::pair<const GlobeLayer*, std::uint64_t>> lru;  ///< most recently drawn first
};

GlobeOverlayRenderer::GlobeOverlayRenderer() : gpu_(std::make_unique<Gpu>()) {}
GlobeOverlayRenderer::~GlobeOverlayRenderer() = default;

/// A tile's pieces in this frame: z-pass or z-fail each.
struct detail::DrawnPieces {
  TileGpu* tile = nullptr;
  std::vector<char> zFail;
  bool allZPass = true;
};

namespace {

using detail::DrawnPieces;

/// Draws the chosen pieces of `drawn` (z-fail ones or z-pass ones; of one colour group, or all
/// for kAllGroups) in the current state, pieces [first, last) counted over all tiles in order.
constexpr std::uint32_t kAllGroups = UINT32_MAX;
void drawPieces(gfx::StateCache& cache, const std::vector<DrawnPieces>& drawn, bool wantZFail, std::size_t first = 0,
                std::size_t last = SIZE_MAX, std::uint32_t group = kAllGroups) {
  std::size_t counted = 0;
  for (const DrawnPieces& d : drawn) {
    const auto& pieces = d.tile->pieces;
    const std::size_t begin = counted, end = counted + pieces.size();
    counted = end;
    if (end <= first || begin >= last) continue;
    // The group's pieces: a run of them, their indices a run too (buildTilePieces).
    std::size_t from = 0, to = pieces.size();
    if (group != kAllGroups) {
      const auto below = [](const TilePieces::Piece& p, std::uint32_t g) { return p.group < g; };
      from = static_cast<std::size_t>(std::lower_bound(pieces.begin(), pieces.end(), group, below) - pieces.begin());
      to = from;
      while (to < pieces.size() && pieces[to].group == group) ++to;
      if (from == to) continue;
    }
    cache.bindVertexArray(d.tile->vao.id());
    const GLuint origin = d.tile->originSlot;
    const auto drawIndices = [origin](std::uint32_t firstIndex, std::uint32_t count) {
      glDrawElementsInstancedBaseInstance(
          GL_TRIANGLES, static_cast<GLsizei>(count), GL_UNSIGNED_INT,
          reinterpret_cast<const void*>(static_cast<std::uintptr_t>(firstIndex) * sizeof(std::uint32_t)), 1, origin);
    };
    const bool whole = first <= begin && end <= last;
    const bool allZPass =
        d.allZPass || std::none_of(d.zFail.begin() + static_cast<std::ptrdiff_t>(from),
                                   d.zFail.begin() + static_cast<std::ptrdiff_t>(to), [](char z) { return z != 0; });
    if (whole && !wantZFail && allZPass) {  // the tile's (group's) pieces in one draw
      const std::uint32_t firstIndex = pieces[from].firstIndex;
      drawIndices(firstIndex, pieces[to - 1].firstIndex + pieces[to - 1].indexCount - firstIndex);
      continue;
    }
    for (std::size_t k = from; k < to; ++k) {
      if (begin + k < first || begin + k >= last || (d.zFail[k] != 0) != wantZFail) continue;
      drawIndices(pieces[k].firstIndex, pieces[k].indexCount);
    }
  }
}

}  // namespace

bool GlobeOverlayRenderer::begin(const GlobeView& view, const GlobeOverlaySettings& settings) {
  if (!gpu_->program.id()) {
    Result<gfx::Program> built = gfx::Program::build({{"overlay_volume.vert", {}}, {"overlay_volume.frag", {}}});
    if (!built.ok()) return false;  // a broken build of the shaders: the GL tests report it
    gpu_->program = std::move(*built);
  }
  gfx::Program& program = gpu_->program;
  // Positions relative to the tile's origin, the origin relative to the eye: the matrix is the
  // eye-relative one, and caps move along the normals.
  program.set("u_modelViewProj", glm::mat4(view.eyeViewProj()));
  program.set("u_alongNormals", 1);
  program.set("u_padBase", static_cast<float>(settings.padBase));
  program.set("u_padPerMetre", static_cast<float>(settings.padPerMetre));
  program.set("u_padPerMetreSquared", 0.0F);
  program.set("u_halfWidthPerMetre", 0.0F);
  program.set("u_maxHalfWidth", 0.0F);
  program.set("u_debugColor", glm::vec4(0.0F));
  gpu_->frameOrigins.clear();
  return true;
}

void GlobeOverlayRenderer::uploadOrigins(const std::vector<detail::DrawnPieces>& drawn) {
  const std::size_t bytes = gpu_->frameOrigins.size() * sizeof(glm::vec3);
  if (bytes == 0) return;
  if (!gpu_->origins || gpu_->originsCapacity < bytes) {
    gpu_->originsCapacity = std::max(bytes, 2 * gpu_->originsCapacity);
    gpu_->origins = gfx::createBuffer();
    glNamedBufferData(gpu_->origins.id(), static_cast<GLsizeiptr>(gpu_->originsCapacity), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(gpu_->origins.id(), 0, static_cast<GLsizeiptr>(bytes), gpu_->frameOrigins.data());
  for (const detail::DrawnPieces& d : drawn)
    glVertexArrayVertexBuffer(d.tile->vao.id(), 1, gpu_->origins.id(), 0, sizeof(glm::vec3));
}

void GlobeOverlayRenderer::setColour(const glm::vec4& colour) {
  // The volume shader's a_color, left disabled: its current value is the colour of every vertex.
  glVertexAttrib4f(1, colour.x, colour.y, colour.z, colour.w);
}

std::vector<detail::DrawnPieces> GlobeOverlayRenderer::prepare(const GlobeView& view,
                                                               const std::vector<DrawnTile>& tiles,
                                                               const GeoGrid& heights, const GlobeLayer& layer,
                                                               const GlobeOverlaySettings& settings,
                                                               GlobeOverlayStats& stats) {
  // The near plane's corners are this far from the eye at most: a piece whose padded box comes
  // closer may be cut by the near plane and is marked z-fail.
  const double tanY = std::tan(0.5 * view.fovYDeg * 3.14159265358979323846 / 180.0);
  const double nearReach = view.near * std::sqrt(1.0 + tanY * tanY * (1.0 + view.aspect() * view.aspect())) * 1.01;
  std::vector<DrawnPieces> drawn;
  for (const DrawnTile& tile : tiles) {
    const auto key = std::make_pair(&layer, tile.key.id());
    auto found = gpu_->tiles.find(key);
    if (found == gpu_->tiles.end()) {
      TilePieces pieces = buildTilePieces(layer, tile.key, heights);
      ++stats.builtTiles;
      TileGpu gpu;
      gpu.pieces = std::move(pieces.pieces);
      gpu.indexCount = pieces.indices.size();
      if (!pieces.indices.empty()) {
        gpu.vertices = gfx::createBufferWithData(pieces.vertices.data(), pieces.vertices.size() * sizeof(PieceVertex));
        gpu.indices = gfx::createBufferWithData(pieces.indices.data(), pieces.indices.size() * sizeof(std::uint32_t));
        gpu.vao = gfx::createVertexArray();
        const GLuint vao = gpu.vao.id();
        glVertexArrayVertexBuffer(vao, 0, gpu.vertices.id(), 0, sizeof(PieceVertex));
        glVertexArrayElementBuffer(vao, gpu.indices.id());
        // a_position (x, y, z, side) and a_up (the normal) per vertex; a_origin per instance
        // (binding 1: this frame's origins, uploadOrigins); a_color and a_scaling disabled.
        const std::array<std::pair<GLuint, std::pair<GLint, GLuint>>, 2> attributes{
            {{0, {4, 0}}, {4, {3, static_cast<GLuint>(offsetof(PieceVertex, normal))}}}};
        for (const auto& [a, format] : attributes) {
          glEnableVertexArrayAttrib(vao, a);
          glVertexArrayAttribFormat(vao, a, format.first, GL_FLOAT, GL_FALSE, format.second);
          glVertexArrayAttribBinding(vao, a, 0);
        }
        glEnableVertexArrayAttrib(vao, 2);
        glVertexArrayAttribFormat(vao, 2, 3, GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribBinding(vao, 2, 1);
        glVertexArrayBindingDivisor(vao, 1, 1);
      }
      gpu.origin = pieces.origin;
      gpu_->lru.push_front(key);
      gpu.lru = gpu_->lru.begin();
      found = gpu_->tiles.emplace(key, std::move(gpu)).first;
    } else {
      gpu_->lru.splice(gpu_->lru.begin(), gpu_->lru, found->second.lru);
    }
    if (found->second.indexCount == 0) continue;
    // Its origin relative to the eye, in double and then rounded once.
    found->second.originSlot = static_cast<GLuint>(gpu_->frameOrigins.size());
    gpu_->frameOrigins.push_back(glm::vec3(found->second.origin - view.eye));
    // z-pass or z-fail, per piece.
    DrawnPieces d;
    d.tile = &found->second;
    for (const TilePieces::Piece& p : d.tile->pieces) {
      const double far = glm::length(glm::max(glm::abs(p.boxLo - view.eye), glm::abs(p.boxHi - view.eye)));
      const double reach = nearReach + settings.padBase + settings.padPerMetre * far;
      const glm::dvec3 lo = p.boxLo - reach, hi = p.boxHi + reach;
      const bool cut = glm::all(glm::greaterThanEqual(view.eye, lo)) && glm::all(glm::lessThanEqual(view.eye, hi));
      d.zFail.push_back(cut ? 1 : 0);
      d.allZPass = d.allZPass && !cut;
      ++stats.pieces;
      stats.zFailPieces += cut ? 1U : 0U;
      stats.triangles += p.indexCount / 3;
    }
    drawn.push_back(std::move(d));
  }
  return drawn;
}

void GlobeOverlayRenderer::trim(std::size_t layers, const GlobeOverlaySettings& settings) {
  // Least recently drawn tiles go beyond the budget.
  const std::size_t budget = settings.cacheTiles * std::max<std::size_t>(layers, 1);
  while (gpu_->tiles.size() > budget) {
    gpu_->tiles.erase(gpu_->lru.back());
    gpu_->lru.pop_back();
  }
}

void GlobeOverlayRenderer::draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                                const GeoGrid& heights, const std::vector<const GlobeLayer*>& layers,
                                const GlobeOverlaySettings& settings) {
  stats_ = {};
  if (!begin(view, settings)) return;
  gfx::Program& program = gpu_->program;
  for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
    const GlobeLayer* layer = layers[l];
    const std::vector<DrawnPieces> drawn = prepare(view, tiles, heights, *layer, settings, stats_);
    uploadOrigins(drawn);
    cache.useProgram(program);
    program.set("u_maskBit", static_cast<float>(1U << l));
    // One mark and cover a colour (one for a layer of one colour).
    const std::size_t groups = std::max<std::size_t>(layer->colors().size(), 1);
    for (std::size_t g = 0; g < groups; ++g) {
      const auto group = groups == 1 ? kAllGroups : static_cast<std::uint32_t>(g);
      setColour(layer->colors().empty() ? layer->color() : layer->colors()[g]);
      // z-pass keeps the bottom caps: a ray that misses the ground (the sky past the limb) must
      // leave every polyhedron it entered.
      cache.apply(overlay::kMarkZPass);
      drawPieces(cache, drawn, false, 0, SIZE_MAX, group);
      cache.apply(overlay::kMarkZFail);
      drawPieces(cache, drawn, true, 0, SIZE_MAX, group);
      // The cover's bottom caps face away from an eye above them (culled), and any face of the
      // layer may cover: it colours only where the stencil holds the layer's count. So each
      // tile's pieces that are all z-pass are one draw.
      cache.apply(overlay::kCoverZPass);
      drawPieces(cache, drawn, false, 0, SIZE_MAX, group);
      cache.apply(overlay::kCoverZFail);
      drawPieces(cache, drawn, true, 0, SIZE_MAX, group);
    }
  }
  setColour(glm::vec4(0.0F, 0.0F, 0.0F, 1.0F));  // the attribute's default again
  trim(layers.size(), settings);
}

GlobeAnalysisStats GlobeOverlayRenderer::markOverlap(gfx::StateCache& cache, const GlobeView& view,
                                                     const std::vector<DrawnTile>& tiles, const GeoGrid& heights,
                                                     const GlobeLayer& a, const GlobeLayer& b,
                                                     const GlobeOverlaySettings& settings) {
  GlobeAnalysisStats out;
  if (!begin(view, settings)) return out;
  gfx::Program& program = gpu_->program;
  cache.useProgram(program);
  program.set("u_maskBit", 0.0F);
  const std::array<std::pair<const GlobeLayer*, const overlay::FlagMarkStates*>, 2> marked{
      {{&a, &overlay::kOverlapMarkA}, {&b, &overlay::kOverlapMarkB}}};
  for (std::size_t m = 0; m < marked.size(); ++m) {
    GlobeOverlayStats& stats = m == 0 ? out.a : out.b;
    const std::vector<DrawnPieces> drawn = prepare(view, tiles, heights, *marked[m].first, settings, stats);
    uploadOrigins(drawn);
    const overlay::FlagMarkStates& states = *marked[m].second;
    // Groups of at most countMask pieces: each counts in the low bits (every piece holds a pixel
    // once at most, so the count of a group never wraps to 0 where a piece holds it), and its
    // pieces' own faces, drawn without the depth test, reach every pixel they marked to collect it.
    for (std::size_t first = 0; first < stats.pieces; first += states.groupSize) {
      const std::size_t last = std::min<std::size_t>(first + states.groupSize, stats.pieces);
      cache.apply(states.markZPass);
      drawPieces(cache, drawn, false, first, last);
      cache.apply(states.markZFail);
      drawPieces(cache, drawn, true, first, last);
      cache.apply(states.collect);
      drawPieces(cache, drawn, false, first, last);
      drawPieces(cache, drawn, true, first, last);
      ++out.groups;
    }
  }
  trim(2, settings);
  return out;
}

void GlobeOverlayRenderer::drawScreen(gfx::StateCache& cache, const glm::vec4& colour, float maskValue) {
  if (!gpu_->rect.id()) {
    Result<gfx::Program> built = gfx::Program::build({{"overlay_cover.vert", {}}, {"overlay_volume.frag", {}}});
    if (!built.ok()) return;
    gpu_->rect = std::move(*built);
    gpu_->emptyVao = gfx::createVertexArray();
  }
  cache.useProgram(gpu_->rect);
  gpu_->rect.set("u_rect", glm::vec4(-1.0F, -1.0F, 1.0F, 1.0F));
  gpu_->rect.set("u_color", colour);
  gpu_->rect.set("u_maskBit", maskValue);
  cache.bindVertexArray(gpu_->emptyVao.id());
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
}

void GlobeOverlayRenderer::coverOverlap(gfx::StateCache& cache, overlay::OverlapOp op, const glm::vec4& colour,
                                        float maskValue) {
  switch (op) {
    case overlay::OverlapOp::And:
      cache.apply(overlay::kOverlapAnd);
      break;
    case overlay::OverlapOp::Or:
      cache.apply(overlay::kOverlapOr);
      break;
    case overlay::OverlapOp::Subtract:
      cache.apply(overlay::kOverlapSubtract);
      break;
    case overlay::OverlapOp::Xor:
      cache.apply(overlay::kOverlapXorFirst);
      drawScreen(cache, colour, maskValue);
      cache.apply(overlay::kOverlapXorLast);
      break;
  }
  drawScreen(cache, colour, maskValue);
}

GlobeOverlayStats GlobeOverlayRenderer::countOpenFaces(gfx::StateCache& cache, const GlobeView& view,
                                                       const std::vector<DrawnTile>& tiles, const GeoGrid& heights,
                                                       const GlobeLayer& layer, const GlobeOverlaySettings& settings) {
  GlobeOverlayStats stats;
  if (!begin(view, settings)) return stats;
  const std::vector<DrawnPieces> drawn = prepare(view, tiles, heights, layer, settings, stats);
  uploadOrigins(drawn);
  cache.useProgram(gpu_->program);
  gpu_->program.set("u_maskBit", 0.0F);
  cache.apply(overlay::kCountFaces);
  drawPieces(cache, drawn, false);
  trim(1, settings);
  return stats;
}

void GlobeOverlayRenderer::coverOpenFaces(gfx::StateCache& cache, const glm::vec4& colour, float maskValue) {
  cache.apply(overlay::kCoverRect);
  drawScreen(cache, colour, maskValue);
}

}  // namespace gis::globe
