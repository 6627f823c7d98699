// Drawing the globe's layers (globe_overlay.hpp): each drawn tile's pieces become a chunk of
// world pieces that the overlay renderer of both frames draws, marks and counts.
#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <list>
#include <optional>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "core/log.hpp"
#include "globe/globe_overlay.hpp"
#include "globe/globe_selection.hpp"
#include "globe_detail.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/tiled_layer.hpp"

namespace gis::globe {

namespace {

/// A layer's pieces over a tile, for a width class (lines in pixels: lineWidthClass).
struct Key {
  std::uint64_t layer = 0;  ///< GlobeLayer::serial
  std::uint64_t tile = 0;
  int widthClass = 0;
  bool operator==(const Key&) const = default;
};

struct KeyHash {
  std::size_t operator()(const Key& k) const {
    return std::hash<std::uint64_t>()(k.layer) ^
           static_cast<std::size_t>((k.tile + static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.widthClass)) *
                                                  std::uint64_t{0x100000001B3}) *
                                    0x9E3779B97F4A7C15ULL);
  }
};

/// A tile's pieces as world pieces of the overlay pipeline: each vertex coloured with its piece's
/// group colour.
overlay::LayerGeometry worldPiecesOf(const GlobeLayer& layer, TilePieces pieces) {
  using Vertex = overlay::LayerGeometry::Vertex;
  std::vector<Vertex> vertices(pieces.vertices.size());
  std::vector<glm::vec4> normals(pieces.vertices.size());
  for (std::size_t i = 0; i < pieces.vertices.size(); ++i) {
    const glm::vec4& p = pieces.vertices[i].position;
    vertices[i] = Vertex{p.x, p.y, p.z, p.w, {0, 0, 0, 255}};
    normals[i] = pieces.vertices[i].normal;
  }
  const std::vector<glm::vec4>& colours = layer.colors();
  std::vector<overlay::LayerGeometry::WorldPiece> world;
  world.reserve(pieces.pieces.size());
  bool uniform = true;
  for (const TilePieces::Piece& p : pieces.pieces) {
    const glm::vec4 c = p.group < colours.size() ? colours[p.group] : layer.color();
    uniform = uniform && c == (colours.empty() ? layer.color() : colours.front());
    const std::array<std::uint8_t, 4> rgba = overlay::rgba8(c);
    for (std::uint32_t k = p.firstIndex; k < p.firstIndex + p.indexCount; ++k)
      std::copy(rgba.begin(), rgba.end(), vertices[pieces.indices[k]].rgba);
    world.push_back({p.firstIndex, p.bottomCount, p.indexCount, p.boxLo, p.boxHi});
  }
  const std::optional<glm::vec4> uniformColour =
      uniform ? std::optional<glm::vec4>(colours.empty() ? layer.color() : colours.front()) : std::nullopt;
  overlay::LayerGeometry::WorldLines lines;
  if (!pieces.scaling.empty()) {
    lines.scaling = std::move(pieces.scaling);
    lines.widthPixels = layer.lineWidthPixels();
    lines.maxWidth = 2.0 * pieces.maxHalfWidth;
  }
  return overlay::LayerGeometry::ofWorldPieces(layer.name(), overlay::LayerKind::Polygon, pieces.origin,
                                               std::move(vertices), std::move(normals), std::move(pieces.indices),
                                               world, uniformColour, std::move(lines));
}

}  // namespace

overlay::OverlaySettings overlaySettingsOf(const GlobeOverlaySettings& settings) {
  overlay::OverlaySettings s;
  s.padBase = settings.padBase;
  s.padPerMetre = settings.padPerMetre;
  return s;
}

struct GlobeOverlayRenderer::Gpu {
  std::optional<overlay::OverlayRenderer> renderer;
  bool failed = false;  ///< the renderer's shaders do not build
  struct Tile {
    std::optional<overlay::OverlayLayer> layer;  ///< none: no pieces over the tile
    std::list<Key>::iterator lru;
    std::size_t bytes = 0;
    std::uint64_t frame = 0;  ///< the draw that last took it
  };
  std::unordered_map<Key, Tile, KeyHash> tiles;
  std::list<Key> lru;  ///< most recently drawn first
  std::size_t built = 0;
  std::size_t bytes = 0;                            ///< of every resident tile
  const GeoGrid* gridDigestOf = nullptr;            ///< the grid gridDigest is of
  std::unordered_set<std::uint64_t> openedFolders;  ///< cache folders (keys) used by this renderer
  std::optional<std::uint64_t> gridDigest;
  std::uint64_t frame = 0;  ///< draws so far
};

GlobeOverlayRenderer::GlobeOverlayRenderer() : gpu_(std::make_unique<Gpu>()) {}
GlobeOverlayRenderer::~GlobeOverlayRenderer() = default;

overlay::OverlayRenderer* GlobeOverlayRenderer::renderer() {
  if (!gpu_->renderer && !gpu_->failed) {
    Result<overlay::OverlayRenderer> made = overlay::OverlayRenderer::create();
    if (made) {
      gpu_->renderer = std::move(*made);
    } else {
      gpu_->failed = true;  // a broken build of the shaders: the GL tests report it
    }
  }
  return gpu_->renderer ? &*gpu_->renderer : nullptr;
}

std::size_t GlobeOverlayRenderer::featureChanged(const GlobeLayer& layer, const std::vector<LonLatRect>& boxes) {
  // A tile's pieces reach a little beyond it (the cells' margins): grown by a hundredth of it.
  const auto reaches = [&](const TileKey& key) {
    const LonLatRect r = key.rect().expanded(0.01 * key.size(), 0.01 * key.size());
    for (const LonLatRect& b : boxes) {
      for (int turn = -1; turn <= 1; ++turn) {
        const double shift = 360.0 * turn;
        if (b.west + shift <= r.east && r.west <= b.east + shift && b.south <= r.north && r.south <= b.north)
          return true;
      }
    }
    return false;
  };
  std::size_t dropped = 0;
  for (auto it = gpu_->tiles.begin(); it != gpu_->tiles.end();) {
    const Key& key = it->first;
    if (key.layer != layer.serial() || !reaches(TileKey::fromId(key.tile))) {
      ++it;
      continue;
    }
    gpu_->bytes -= it->second.bytes;
    gpu_->lru.erase(it->second.lru);
    it = gpu_->tiles.erase(it);
    ++dropped;
  }
  return dropped;
}

std::vector<const overlay::OverlayLayer*> GlobeOverlayRenderer::chunks(const GlobeView& view,
                                                                       const std::vector<DrawnTile>& tiles,
                                                                       const GeoGrid& heights,
                                                                       const GlobeLayer& layer) {
  // Lines in pixels: each tile's width class from this view (0 for every other layer).
  overlay::PixelScale scale;
  if (layer.lineWidthPixels() > 0.0) scale = pixelScaleOf(view);
  std::vector<Key> keys;
  keys.reserve(tiles.size());
  for (const DrawnTile& tile : tiles)
    keys.push_back({layer.serial(), tile.key.id(), lineWidthClass(layer, tile.key, heights, scale)});
  // The missing tiles' pieces are built on every core at once (pure: the layer, the grid and the
  // pieces' builder may be read from any thread), then uploaded here, in the tiles' order.
  std::vector<std::size_t> missing;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    if (gpu_->tiles.find(keys[t]) == gpu_->tiles.end()) missing.push_back(t);
  }
  std::vector<std::optional<overlay::LayerGeometry>> built(missing.size());
  // The cache on disk, for a grid whose digest is known (made once per grid).
  std::optional<std::uint64_t> cacheKey;
  if (!cacheDir_.empty() && !missing.empty()) {
    if (gpu_->gridDigestOf != &heights) {
      gpu_->gridDigestOf = &heights;
      gpu_->gridDigest = heights.contentDigest();
    }
    if (gpu_->gridDigest) cacheKey = layer.fingerprint() ^ (*gpu_->gridDigest * 0x9E3779B97F4A7C15ULL);
    // The first use of a layer's folder: marked as opened, and the folders no layer opened lately
    // removed beyond the budget (other builds, grids and code: never read again).
    if (cacheKey && gpu_->openedFolders.insert(*cacheKey).second) {
      const std::filesystem::path folder = detail::tileCachePath(cacheDir_, *cacheKey, TileKey{}, 0).parent_path();
      stats_.prunedFolders += overlay::pruneTileFolders(folder.parent_path(), folder, cacheBudget_);
    }
  }
  std::atomic<std::size_t> read{0}, written{0}, repaired{0};
  {
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
      for (std::size_t k = next++; k < missing.size(); k = next++) {
        const TileKey& tile = tiles[missing[k]].key;
        const int widthClass = keys[missing[k]].widthClass;
        std::optional<TilePieces> pieces;
        std::filesystem::path file;
        if (cacheKey) {
          file = detail::tileCachePath(cacheDir_, *cacheKey, tile, widthClass);
          bool damaged = false;
          pieces = detail::readTilePieces(file, damaged);
          if (pieces) ++read;
          if (damaged) {
            ++repaired;
            logWarning(file.string() + ": layer '" + layer.name() +
                       "': cache file damaged (not whole, or not a tile); built again");
          }
        }
        if (!pieces) {
          pieces = buildTilePieces(layer, tile, heights, widthClass);
          if (cacheKey && detail::writeTilePieces(file, *pieces)) ++written;
        }
        if (!pieces->pieces.empty()) built[k] = worldPiecesOf(layer, std::move(*pieces));
      }
    };
    const std::size_t helpers =
        std::min<std::size_t>(missing.size(), std::max(1U, std::thread::hardware_concurrency())) -
        (missing.empty() ? 0 : 1);
    std::vector<std::thread> threads;
    for (std::size_t h = 0; h < helpers; ++h) threads.emplace_back(work);
    work();
    for (std::thread& t : threads) t.join();
  }
  stats_.readTiles += read;
  stats_.writtenTiles += written;
  stats_.repairedTiles += repaired;
  for (std::size_t k = 0; k < missing.size(); ++k) {
    Gpu::Tile entry;
    if (built[k]) {
      entry.layer = overlay::OverlayLayer::upload(std::move(*built[k]));
      entry.layer->releaseCpuArrays();  // drawn from the GPU's copy only (never edited; z-fail drawn whole)
      entry.bytes = entry.layer->stats().gpuBytes;
      gpu_->bytes += entry.bytes;
    }
    const Key& key = keys[missing[k]];
    gpu_->lru.push_front(key);
    entry.lru = gpu_->lru.begin();
    gpu_->tiles.emplace(key, std::move(entry));
    ++gpu_->built;
  }
  gpu_->built -= read;  // counted with the rest above: those read from disk were not built
  std::vector<const overlay::OverlayLayer*> out;
  for (const Key& key : keys) {
    const auto found = gpu_->tiles.find(key);
    gpu_->lru.splice(gpu_->lru.begin(), gpu_->lru, found->second.lru);
    found->second.frame = gpu_->frame;
    if (found->second.layer) out.push_back(&*found->second.layer);
  }
  return out;
}

std::size_t GlobeOverlayRenderer::trim(const GlobeOverlaySettings& settings) {
  // Tiles with no pieces hold no GPU bytes; a bound on their number keeps the table small too.
  constexpr std::size_t kMostTiles = std::size_t{1} << 16U;
  std::size_t evicted = 0;
  while ((gpu_->bytes > settings.gpuBudgetBytes || gpu_->tiles.size() > kMostTiles) && !gpu_->lru.empty()) {
    const auto found = gpu_->tiles.find(gpu_->lru.back());
    if (found->second.frame == gpu_->frame) break;  // the least recent is this frame's: so are the rest
    gpu_->bytes -= found->second.bytes;
    gpu_->tiles.erase(found);
    gpu_->lru.pop_back();
    ++evicted;
  }
  return evicted;
}

void GlobeOverlayRenderer::draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                                const GeoGrid& heights, const std::vector<const GlobeLayer*>& layers,
                                const GlobeOverlaySettings& settings) {
  stats_ = {};
  cacheDir_ = settings.cacheDir;
  cacheBudget_ = settings.cacheBudgetBytes;
  overlay::OverlayRenderer* overlays = renderer();
  if (overlays == nullptr) return;
  gpu_->built = 0;
  ++gpu_->frame;
  std::vector<std::vector<const overlay::OverlayLayer*>> chunked;
  for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
    chunked.push_back(chunks(view, tiles, heights, *layers[l]));
    for (const overlay::OverlayLayer* chunk : chunked.back()) stats_.triangles += chunk->stats().triangles;
    stats_.drawnTiles += chunked.back().size();
    for (const overlay::OverlayLayer* chunk : chunked.back()) stats_.drawnBytes += chunk->stats().gpuBytes;
  }
  const std::vector<overlay::LayerFrameStats> drawn =
      overlays->draw(cache, overlayViewOf(view), chunked, overlaySettingsOf(settings));
  for (const overlay::LayerFrameStats& s : drawn) {
    stats_.pieces += s.zPassPieces + s.zFailPieces;
    stats_.zFailPieces += s.zFailPieces;
    stats_.culledPieces += s.culledPieces;
  }
  stats_.builtTiles = gpu_->built;
  // Over the budget: the tiles drawn longest ago leave (this frame's chunks stay until the next draw).
  stats_.evictedTiles = trim(settings);
  stats_.residentTiles = gpu_->tiles.size();
  stats_.residentBytes = gpu_->bytes;
}

}  // namespace gis::globe
