// Drawing the globe's layers (globe_overlay.hpp): the stencil core's mark and cover passes
// (vector_overlay/stencil_states.hpp) over the pieces of the drawn tiles.
#include <algorithm>
#include <cmath>
#include <list>
#include <unordered_map>

#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "globe/globe_overlay.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::globe {

namespace {

struct TileGpu {
  gfx::BufferHandle vertices, indices;
  gfx::VertexArrayHandle vao;
  std::vector<TilePieces::Piece> pieces;
  std::size_t indexCount = 0;
  std::list<std::pair<const GlobeLayer*, std::uint64_t>>::iterator lru;
};

struct PairHash {
  std::size_t operator()(const std::pair<const GlobeLayer*, std::uint64_t>& k) const {
    return std::hash<const void*>()(k.first) ^ static_cast<std::size_t>(k.second * 0x9E3779B97F4A7C15ULL);
  }
};

}  // namespace

struct GlobeOverlayRenderer::Gpu {
  gfx::Program program;
  std::unordered_map<std::pair<const GlobeLayer*, std::uint64_t>, TileGpu, PairHash> tiles;
  std::list<std::pair<const GlobeLayer*, std::uint64_t>> lru;  ///< most recently drawn first
};

GlobeOverlayRenderer::GlobeOverlayRenderer() : gpu_(std::make_unique<Gpu>()) {}
GlobeOverlayRenderer::~GlobeOverlayRenderer() = default;

void GlobeOverlayRenderer::draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                                const GeoGrid& heights, const std::vector<const GlobeLayer*>& layers,
                                const GlobeOverlaySettings& settings) {
  stats_ = {};
  if (!gpu_->program.id()) {
    Result<gfx::Program> built = gfx::Program::build({{"globe_volume.vert", {}}, {"overlay_volume.frag", {}}});
    if (!built.ok()) return;  // a broken build of the shaders: the GL tests report it
    gpu_->program = std::move(*built);
  }
  gfx::Program& program = gpu_->program;
  program.set("u_eyeViewProj", glm::mat4(view.eyeViewProj()));
  const SplitPosition eye = view.eyeSplit();
  program.set("u_eyeHigh", eye.high);
  program.set("u_eyeLow", eye.low);
  program.set("u_padBase", static_cast<float>(settings.padBase));
  program.set("u_padPerMetre", static_cast<float>(settings.padPerMetre));
  // The near plane's corners are this far from the eye at most: a piece whose padded box comes
  // closer may be cut by the near plane and is marked z-fail.
  const double tanY = std::tan(0.5 * view.fovYDeg * 3.14159265358979323846 / 180.0);
  const double nearReach = view.near * std::sqrt(1.0 + tanY * tanY * (1.0 + view.aspect() * view.aspect())) * 1.01;

  for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
    const GlobeLayer* layer = layers[l];
    // The tiles' pieces, built and uploaded where missing.
    std::vector<TileGpu*> drawn;
    for (const DrawnTile& tile : tiles) {
      const auto key = std::make_pair(layer, tile.key.id());
      auto found = gpu_->tiles.find(key);
      if (found == gpu_->tiles.end()) {
        TilePieces pieces = buildTilePieces(*layer, tile.key, heights);
        ++stats_.builtTiles;
        TileGpu gpu;
        gpu.pieces = std::move(pieces.pieces);
        gpu.indexCount = pieces.indices.size();
        if (!pieces.indices.empty()) {
          gpu.vertices =
              gfx::createBufferWithData(pieces.vertices.data(), pieces.vertices.size() * sizeof(PieceVertex));
          gpu.indices = gfx::createBufferWithData(pieces.indices.data(), pieces.indices.size() * sizeof(std::uint32_t));
          gpu.vao = gfx::createVertexArray();
          const GLuint vao = gpu.vao.id();
          glVertexArrayVertexBuffer(vao, 0, gpu.vertices.id(), 0, sizeof(PieceVertex));
          glVertexArrayElementBuffer(vao, gpu.indices.id());
          const GLuint offsets[4] = {0, 12, 24, 36};
          const GLint sizes[4] = {3, 3, 3, 1};
          for (GLuint a = 0; a < 4; ++a) {
            glEnableVertexArrayAttrib(vao, a);
            glVertexArrayAttribFormat(vao, a, sizes[a], GL_FLOAT, GL_FALSE, offsets[a]);
            glVertexArrayAttribBinding(vao, a, 0);
          }
        }
        gpu_->lru.push_front(key);
        gpu.lru = gpu_->lru.begin();
        found = gpu_->tiles.emplace(key, std::move(gpu)).first;
      } else {
        gpu_->lru.splice(gpu_->lru.begin(), gpu_->lru, found->second.lru);
      }
      if (found->second.indexCount > 0) drawn.push_back(&found->second);
    }
    // z-pass or z-fail, per piece.
    std::vector<std::vector<char>> zFail(drawn.size());
    for (std::size_t t = 0; t < drawn.size(); ++t) {
      for (const TilePieces::Piece& p : drawn[t]->pieces) {
        const double far = glm::length(glm::max(glm::abs(p.boxLo - view.eye), glm::abs(p.boxHi - view.eye)));
        const double reach = nearReach + settings.padBase + settings.padPerMetre * far;
        const glm::dvec3 lo = p.boxLo - reach, hi = p.boxHi + reach;
        const bool cut = glm::all(glm::greaterThanEqual(view.eye, lo)) && glm::all(glm::lessThanEqual(view.eye, hi));
        zFail[t].push_back(cut ? 1 : 0);
        ++stats_.pieces;
        stats_.zFailPieces += cut ? 1U : 0U;
        stats_.triangles += p.indexCount / 3;
      }
    }
    cache.useProgram(program);
    program.set("u_color", layer->color());
    program.set("u_maskBit", static_cast<float>(1U << l));
    const auto drawPieces = [&](bool wantZFail, bool skipBottom) {
      for (std::size_t t = 0; t < drawn.size(); ++t) {
        cache.bindVertexArray(drawn[t]->vao.id());
        const auto& pieces = drawn[t]->pieces;
        const bool allZPass = std::none_of(zFail[t].begin(), zFail[t].end(), [](char z) { return z != 0; });
        if (!wantZFail && allZPass && !skipBottom) {  // the whole tile in one draw
          glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(drawn[t]->indexCount), GL_UNSIGNED_INT, nullptr);
          continue;
        }
        for (std::size_t k = 0; k < pieces.size(); ++k) {
          if ((zFail[t][k] != 0) != wantZFail) continue;
          const std::uint32_t skip = skipBottom ? pieces[k].bottomCount : 0;
          glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(pieces[k].indexCount - skip), GL_UNSIGNED_INT,
                         reinterpret_cast<const void*>(static_cast<std::uintptr_t>(pieces[k].firstIndex + skip) *
                                                       sizeof(std::uint32_t)));
        }
      }
    };
    // z-pass keeps the bottom caps: a ray that misses the ground (the sky past the limb) must
    // leave every polyhedron it entered.
    cache.apply(overlay::kMarkZPass);
    drawPieces(false, false);
    cache.apply(overlay::kMarkZFail);
    drawPieces(true, false);
    cache.apply(overlay::kCoverZPass);
    drawPieces(false, true);
    cache.apply(overlay::kCoverZFail);
    drawPieces(true, false);
  }
  // Least recently drawn tiles go beyond the budget.
  const std::size_t budget = settings.cacheTiles * std::max<std::size_t>(layers.size(), 1);
  while (gpu_->tiles.size() > budget) {
    gpu_->tiles.erase(gpu_->lru.back());
    gpu_->lru.pop_back();
  }
}

}  // namespace gis::globe
