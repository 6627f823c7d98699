// Drawing the globe's layers (globe_overlay.hpp): each layer's tiles over the drawn terrain tiles
// (GlobeTiling), held on the GPU by the tile residency of both frames (tile_residency.hpp: worker
// builds, the GPU budget, coarser detail where it would not fit), each tile's pieces a chunk of
// world pieces that the overlay renderer of both frames draws, marks and counts.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "core/log.hpp"
#include "globe_detail.hpp"
#include "vector_overlay/globe_drape.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/globe_selection.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/plan_chooser.hpp"
#include "vector_overlay/technique.hpp"
#include "vector_overlay/tile_residency.hpp"
#include "vector_overlay/tiled_layer.hpp"

namespace gis::globe {

namespace {

/// A layer's lookup: its serial and the reach class its lines in pixels are binned at
/// (GlobeOverlayRenderer::lookupReach; ReachClasses::kNatural: their own widths).
using LookupKey = std::pair<std::uint64_t, int>;
/// The lookup's reach classes on the globe (deferred_lookup.hpp): to 131 km, as views from space
/// see thousands of kilometres.
constexpr overlay::ReachClasses kReach{overlay::ReachClasses::kBaseReach, 14};

/// A globe layer's tiles as the residency asks for them: the drawn terrain tiles of the frame
/// (setFrame), each at the width class its lines in pixels need from the view, or their
/// ancestors where the GPU budget asks for coarser detail; built by buildTilePieces, or read
/// from (and written to) the disk cache.
class GlobeTiling final : public overlay::TileSource {
 public:
  GlobeTiling(const GlobeLayer& layer, const GeoGrid& heights, const std::string& cacheDir,
              std::optional<std::uint64_t> cacheKey)
      : layer_(&layer),
        heights_(&heights),
        cacheDir_(cacheDir),
        cacheKey_(cacheKey),
        cache_(cacheKey ? folderOf(cacheDir, *cacheKey) : std::string(), cacheKey.value_or(0)) {}
  /// Whether it was made for this layer object, grid and cache.
  [[nodiscard]] bool madeFor(const GlobeLayer& layer, const GeoGrid& heights, const std::string& cacheDir,
                             std::optional<std::uint64_t> cacheKey) const {
    return layer_ == &layer && heights_ == &heights && cacheDir_ == cacheDir && cacheKey_ == cacheKey;
  }
  /// The folder of a layer's tiles (by its cache key) in the scene's cache.
  static std::string folderOf(const std::string& cacheDir, std::uint64_t cacheKey) {
    char folder[17];
    std::snprintf(folder, sizeof(folder), "%016llx", static_cast<unsigned long long>(cacheKey));
    return (std::filesystem::path(cacheDir) / "globe-tiles" / folder).string();
  }

  /// The frame's drawn terrain tiles, and the view their lines in pixels are seen from.
  void setFrame(const GlobeView& view, const std::vector<DrawnTile>& tiles) {
    scale_ = layer_->lineWidthPixels() > 0.0 ? pixelScaleOf(view) : overlay::PixelScale{};
    keys_.clear();
    for (const DrawnTile& tile : tiles) keys_.push_back(keyOf(tile.key));
  }

  [[nodiscard]] const std::string& name() const override { return layer_->name(); }
  [[nodiscard]] std::vector<overlay::TileKey> select(const overlay::OverlayView& view, int viewportHeight,
                                                     std::size_t* culled, double errorScale) const override {
    (void)view;
    (void)viewportHeight;
    (void)culled;  // the terrain culled its tiles
    // Coarser detail for the budget: a level up for each doubling of the error.
    const int up = errorScale > 1.0 ? static_cast<int>(std::floor(std::log2(errorScale))) : 0;
    if (up == 0) return keys_;
    std::vector<overlay::TileKey> out;
    std::unordered_set<std::uint64_t> seen;
    for (const overlay::TileKey& k : keys_) {
      TileKey t{k.level, k.x, k.y};
      for (int u = 0; u < up && t.level > 0; ++u) t = t.parent();
      if (seen.insert(t.id()).second) out.push_back(keyOf(t));
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const overlay::TileKey& a, const overlay::TileKey& b) { return a.level < b.level; });
    return out;
  }
  /// The layers' generalisation (simplifyTolerance: areas within an eighth of a pixel, lines
  /// within half of one) follows the terrain's posts.
  [[nodiscard]] double errorPixels() const override { return 0.5; }
  [[nodiscard]] int finestLevel() const override { return kMaxLevel; }
  /// Tile `key` from the disk cache of both frames (overlay::WorldTileCache), else built; `lean`
  /// (far from the eye): its arrays left in the file.
  [[nodiscard]] Result<overlay::LayerTile> build(const overlay::TileKey& key, const std::atomic<bool>* cancel,
                                                 bool lean) const override {
    (void)cancel;
    const TileKey tile{key.level, key.x, key.y};
    const std::vector<glm::vec4> fallback{layer_->color()};
    return cache_.fetch(
        key, layer_->name(), layer_->colors().empty() ? fallback : layer_->colors(),
        [&] { return buildTilePieces(*layer_, tile, *heights_, key.width); }, lean);
  }
  [[nodiscard]] std::optional<std::size_t> cachedBytes(const overlay::TileKey& key) const override {
    return cache_.cachedBytes(key);
  }
  [[nodiscard]] const std::string& cacheFolder() const override { return cache_.folder(); }
  /// The tile's box of longitude and latitude grown by a hundredth (its cells' margins), between
  /// the bounds of the ground its pieces stand on, their caps' sag included. Lines in pixels may
  /// reach further: a tile read lean that a piece of which is then drawn z-fail is read again
  /// with its arrays (TileResidency::gather).
  [[nodiscard]] std::optional<std::pair<glm::dvec3, glm::dvec3>> leanBox(const overlay::TileKey& key) const override {
    const TileKey tile{key.level, key.x, key.y};
    const LonLatRect rect = tile.rect().expanded(0.01 * tile.size(), 0.01 * tile.size());
    const auto [lo, hi] = groundBounds(*heights_, rect, key.level);
    const double diagonal = tile.size() * 1.6e5;  // metres: more than the tile's (and a cap edge's)
    return ecefBoxOf(rect, lo - 1.0, hi + triangleSag(diagonal) + 1.0);
  }
  [[nodiscard]] bool worldPieces() const override { return true; }
  [[nodiscard]] double leanDistance() const override { return 0.125; }

  /// Tiles written to the disk cache, and found damaged there, so far.
  [[nodiscard]] std::size_t written() const { return cache_.written(); }
  [[nodiscard]] std::size_t repaired() const { return cache_.damaged(); }

 private:
  [[nodiscard]] overlay::TileKey keyOf(const TileKey& t) const {
    return {t.level, t.x, t.y, lineWidthClass(*layer_, t, *heights_, scale_)};
  }
  const GlobeLayer* layer_;
  const GeoGrid* heights_;
  std::string cacheDir_;
  std::optional<std::uint64_t> cacheKey_;
  overlay::WorldTileCache cache_;
  overlay::PixelScale scale_;
  std::vector<overlay::TileKey> keys_;
};

/// A GL object made on first use (T::create); null, and not tried again, if it cannot be made (its
/// shaders do not build: the GL tests report it).
template <typename T>
T* madeOnFirstUse(std::optional<T>& held, bool& failed) {
  if (!held && !failed) {
    Result<T> made = T::create();
    if (made) {
      held = std::move(*made);
    } else {
      failed = true;
    }
  }
  return held ? &*held : nullptr;
}

}  // namespace

overlay::OverlaySettings overlaySettingsOf(const GlobeOverlaySettings& settings) {
  overlay::OverlaySettings s = settings.passes;
  s.measure = settings.measure;  // per layer, its mark and cover apart (as in a projected frame)
  s.padBase = settings.padBase;
  s.padPerMetre = settings.padPerMetre;
  return s;
}

struct GlobeOverlayRenderer::Gpu {
  std::optional<overlay::OverlayRenderer> renderer;
  bool failed = false;  ///< the renderer's shaders do not build
  std::unique_ptr<overlay::TileResidency> residency;
  /// Per layer (its serial): its tiling, for the layer object and grid it was made for.
  std::unordered_map<std::uint64_t, std::unique_ptr<GlobeTiling>> tilings;
  const GeoGrid* gridDigestOf = nullptr;  ///< the grid gridDigest is of
  std::optional<std::uint64_t> gridDigest;
  std::unordered_set<std::uint64_t> openedFolders;  ///< cache folders (keys) used by this renderer
  // The last frame: its layers (in order), their chunks, and what it was drawn for.
  std::vector<const GlobeLayer*> layers;
  std::vector<std::vector<const overlay::OverlayLayer*>> chunks;
  std::vector<std::uint64_t> tileIds;
  glm::dmat4 viewProj{0.0};
  const GeoGrid* heights = nullptr;
  GlobeOverlaySettings settings;
  // The deferred lookup: its pass (made on first use), per layer (its serial) and reach class its
  // indices, those being built, and builds for layers since edited (left to finish: a future from
  // std::async waits for its thread when destroyed); `auto`'s chooser and the plan it last took.
  std::optional<overlay::DeferredPass> pass;
  bool passFailed = false;
  std::map<LookupKey, overlay::DeferredLayer> deferred;
  std::map<LookupKey, std::future<overlay::DeferredLayer>> building;
  /// Indices that came out larger than a quarter of the GPU budget (their layers keep their
  /// pieces at that class: the estimate of lookupFits was short).
  std::set<LookupKey> tooLarge;
  std::vector<std::future<overlay::DeferredLayer>> retired;
  overlay::PlanChooser chooser;
  int plan = -1;  ///< -1: the last draw was not `auto`'s
  /// Per line layer (its serial): its primitives in space, counted once (lookupFits).
  std::unordered_map<std::uint64_t, std::size_t> linePrimitives;
  /// Per line layer in pixels (its serial): its lines' widths and the largest of their shape
  /// reaches, found once (lookupReach).
  std::unordered_map<std::uint64_t, std::pair<overlay::PixelLineWidths, double>> pixelWidths;
  // Texture draping: the registry's technique, made for its name, texture size and extent; what
  // it rasterises, for the layers (their serials) it was made for.
  std::unique_ptr<overlay::OverlayTechnique> drape;
  std::string drapeName;
  int drapeSize = 0;
  overlay::DrapeExtent drapeExtent;
  bool drapeFailed = false;  ///< the technique could not be made for them (said once)
  std::unique_ptr<GlobeDrapeSource> drapeSource;
  std::vector<std::uint64_t> drapeSerials;
  /// `stencil`: per layer (its serial) its pieces built once for the grid, per tile (the tiles
  /// without pieces left out), or refused (too large: its tiles draw it).
  struct WholeLoad {
    const GeoGrid* heights = nullptr;
    bool refused = false;
    std::vector<WholeLoadTile> tiles;  ///< their geometry moved into chunks
    std::vector<overlay::OverlayLayer> chunks;
    /// Per chunk: the coarser drawn levels its caps' reach was last set for (none yet: ~0).
    std::vector<std::uint32_t> reachLevels;
  };
  std::map<std::pair<std::uint64_t, bool>, WholeLoad> wholeLoads;  ///< by serial and paper
};

namespace {

/// What a single drape covers: the layers' box, within the world (every longitude where it
/// crosses ±180°).
overlay::DrapeExtent drapeExtentOf(const std::vector<const GlobeLayer*>& layers) {
  LonLatRect box{180.0, 90.0, -180.0, -90.0};
  for (const GlobeLayer* layer : layers) {
    const LonLatRect e = layer->extent();
    if (e.empty()) continue;
    box = {std::min(box.west, e.west), std::min(box.south, e.south), std::max(box.east, e.east),
           std::max(box.north, e.north)};
  }
  if (box.empty()) return {glm::dvec2(-180.0, -90.0), glm::dvec2(360.0, 180.0)};
  if (box.west < -180.0 || box.east > 180.0) box.west = -180.0, box.east = 180.0;
  box.south = std::max(box.south, -90.0);
  box.north = std::min(box.north, 90.0);
  return {glm::dvec2(box.west, box.south), glm::dvec2(box.east - box.west, box.north - box.south)};
}

}  // namespace

std::optional<overlay::SurfaceDrape> GlobeOverlayRenderer::prepareDrape(gfx::StateCache& cache, const GlobeView& view,
                                                                        const std::vector<DrawnTile>& tiles,
                                                                        const std::vector<const GlobeLayer*>& layers,
                                                                        const GlobeOverlaySettings& settings) {
  stats_ = {};
  if (!drapes(settings.technique) || layers.empty()) return std::nullopt;
  Gpu& g = *gpu_;
  const std::string name = settings.technique == GlobeTechnique::Drape ? "drape" : "drape-tiles";
  const overlay::TechniqueInfo* info = overlay::findTechnique(name);
  if (info == nullptr) return std::nullopt;
  const int size = settings.textureSize > 0 ? settings.textureSize : info->defaultTextureSize;
  const overlay::DrapeExtent extent = drapeExtentOf(layers);
  const bool sameExtent = settings.technique != GlobeTechnique::Drape ||
                          (g.drapeExtent.origin == extent.origin && g.drapeExtent.size == extent.size);
  if (!g.drape || g.drapeName != name || g.drapeSize != size || !sameExtent) {
    const bool sameAsFailed = g.drapeFailed && g.drapeName == name && g.drapeSize == size && sameExtent;
    g.drape.reset();
    g.drapeName = name;
    g.drapeSize = size;
    g.drapeExtent = extent;
    if (sameAsFailed) return std::nullopt;
    overlay::TechniqueOptions options;
    options.textureSize = size;
    options.extent = extent;
    Result<std::unique_ptr<overlay::OverlayTechnique>> made = info->create(options);
    g.drapeFailed = !made.ok();
    for (const Diagnostic& d : made.diagnostics.items()) logError(d.toString());
    if (!made) return std::nullopt;
    g.drape = std::move(*made);
    g.drapeSerials.clear();
  }
  // Other layers (another set shown, another style: a new serial): every texture again.
  std::vector<std::uint64_t> serials;
  for (const GlobeLayer* layer : layers) serials.push_back(layer->serial());
  if (serials != g.drapeSerials || !g.drapeSource) {
    g.drapeSerials = serials;
    g.drapeSource = std::make_unique<GlobeDrapeSource>(layers);
    g.drape->invalidate();
  }
  std::vector<overlay::DrawnTile> drawn;
  drawn.reserve(tiles.size());
  for (const DrawnTile& t : tiles) {
    const LonLatRect r = t.key.rect();
    drawn.push_back({t.key.id(), glm::dvec2(r.west, r.south), glm::dvec2(r.east, r.north)});
  }
  overlay::TechniqueFrame frame;
  frame.target = {settings.targetFramebuffer, view.width, view.height};
  frame.view = overlayViewOf(view);
  frame.tiles = drawn;
  frame.drapeSource = g.drapeSource.get();
  frame.settings = overlaySettingsOf(settings);
  frame.waitForTiles = settings.waitForTiles;
  overlay::TechniqueFrameStats techniqueStats;
  std::optional<overlay::SurfaceDrape> surface = g.drape->prepare(cache, frame, techniqueStats);
  stats_.draped = surface.has_value();
  stats_.texturesBuilt = techniqueStats.texturesBuilt;
  stats_.textureSeconds = techniqueStats.textureSeconds;
  stats_.drapeGpuBytes = g.drape->gpuBytes();
  return surface;
}

const overlay::TextureDrape* GlobeOverlayRenderer::textureDrape() const {
  return gpu_->drape ? gpu_->drape->textureDrape() : nullptr;
}

bool GlobeOverlayRenderer::lookupFits(const GlobeLayer& layer, int reachClass, std::size_t gpuBudgetBytes) {
  if (!layer.hasLines()) return true;  // areas: their indices are as large as their edges
  auto counted = gpu_->linePrimitives.find(layer.serial());
  if (counted == gpu_->linePrimitives.end()) {
    std::size_t primitives = 0;
    for (const GlobeLine& line : layer.lines()) primitives += 2 * line.points.size();
    counted = gpu_->linePrimitives.emplace(layer.serial(), primitives).first;
  }
  // An index that would pass a quarter of the GPU budget (the rivers of GSHHG 800 m wide: 4.3 GB)
  // is not built, and the layer keeps its pieces.
  return kReach.lineIndexBytes(counted->second, reachClass) <= static_cast<double>(gpuBudgetBytes / 4);
}

GlobeOverlayRenderer::GlobeOverlayRenderer() : gpu_(std::make_unique<Gpu>()) {}
GlobeOverlayRenderer::~GlobeOverlayRenderer() {
  if (gpu_->residency) gpu_->residency->cancel();
}

overlay::OverlayRenderer* GlobeOverlayRenderer::renderer() { return madeOnFirstUse(gpu_->renderer, gpu_->failed); }

std::size_t GlobeOverlayRenderer::featureChanged(const GlobeLayer& layer, const std::vector<LonLatRect>& boxes) {
  // A drape rasterises the textures over the boxes again (the areas are read and triangulated per texture).
  if (gpu_->drape &&
      std::find(gpu_->drapeSerials.begin(), gpu_->drapeSerials.end(), layer.serial()) != gpu_->drapeSerials.end()) {
    for (const LonLatRect& b : boxes) {
      for (int turn = -1; turn <= 1; ++turn) {
        const double shift = 360.0 * turn;
        gpu_->drape->invalidate(glm::dvec2(b.west + shift, b.south), glm::dvec2(b.east + shift, b.north));
      }
    }
  }
  if (!gpu_->residency) return 0;
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
  // `stencil` builds the edited layer whole again when next drawn.
  if (gpu_->wholeLoads.erase({layer.serial(), false}) + gpu_->wholeLoads.erase({layer.serial(), true}) > 0)
    gpu_->chunks.clear();  // the last frame's chunks may be gone
  // The lookup's indices (every reach class) are made again from the edited layer when next drawn.
  std::erase_if(gpu_->deferred, [&layer](const auto& entry) { return entry.first.first == layer.serial(); });
  std::erase_if(gpu_->tooLarge, [&layer](const LookupKey& key) { return key.first == layer.serial(); });
  gpu_->linePrimitives.erase(layer.serial());
  gpu_->pixelWidths.erase(layer.serial());
  for (auto building = gpu_->building.begin(); building != gpu_->building.end();) {
    if (building->first.first != layer.serial()) {
      ++building;
      continue;
    }
    gpu_->retired.push_back(std::move(building->second));
    building = gpu_->building.erase(building);
  }
  const auto made = gpu_->tilings.find(layer.serial());
  if (made == gpu_->tilings.end()) return 0;
  gpu_->residency->cancel();
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < gpu_->residency->layerCount(); ++i) {
    if (gpu_->residency->source(i) != made->second.get()) continue;
    auto* tiles = gpu_->residency->tiles(i);
    for (auto it = tiles->begin(); it != tiles->end();) {
      const bool meets = reaches(TileKey{it->second.key.level, it->second.key.x, it->second.key.y});
      dropped += meets ? 1U : 0U;
      it = meets ? tiles->erase(it) : std::next(it);
    }
  }
  gpu_->chunks.clear();  // the last frame's chunks may be gone
  return dropped;
}

std::vector<std::vector<const overlay::OverlayLayer*>> GlobeOverlayRenderer::tilesFor(
    const GlobeView& view, const std::vector<DrawnTile>& tiles, const GeoGrid& heights,
    const std::vector<const GlobeLayer*>& layers, const GlobeOverlaySettings& settings) {
  overlay::OverlayRenderer* overlays = renderer();
  if (overlays == nullptr) return std::vector<std::vector<const overlay::OverlayLayer*>>(layers.size());
  overlay::TilingOptions tiling;
  tiling.gpuBudgetBytes = settings.gpuBudgetBytes;
  if (!gpu_->residency) gpu_->residency = std::make_unique<overlay::TileResidency>(*overlays, tiling);
  overlay::TileResidency& residency = *gpu_->residency;
  residency.setGpuBudget(settings.gpuBudgetBytes);
  // The cache on disk, for a grid whose digest is known (made once per grid).
  if (!settings.cacheDir.empty() && gpu_->gridDigestOf != &heights) {
    gpu_->gridDigestOf = &heights;
    gpu_->gridDigest = heights.contentDigest();
  }
  // Each layer's tiling, made again for another layer object, grid or cache.
  std::vector<const overlay::TileSource*> sources;
  for (const GlobeLayer* layer : layers) {
    std::optional<std::uint64_t> cacheKey;
    if (!settings.cacheDir.empty() && gpu_->gridDigest)
      cacheKey = layer->fingerprint() ^ (*gpu_->gridDigest * 0x9E3779B97F4A7C15ULL) ^
                 (overlay::coloursFingerprint(layer->colors()) * 0xC2B2AE3D27D4EB4FULL);
    std::unique_ptr<GlobeTiling>& made = gpu_->tilings[layer->serial()];
    if (made && !made->madeFor(*layer, heights, settings.cacheDir, cacheKey)) {
      residency.forget(made.get());
      made.reset();
    }
    if (!made) {
      made = std::make_unique<GlobeTiling>(*layer, heights, settings.cacheDir, cacheKey);
      // The first use of a layer's folder: marked as opened, and the folders no layer opened
      // lately removed beyond the budget (other builds, grids and code: never read again).
      if (cacheKey && gpu_->openedFolders.insert(*cacheKey).second) {
        const std::filesystem::path folder(made->cacheFolder());
        stats_.prunedFolders += overlay::pruneTileFolders(folder.parent_path(), folder, settings.cacheBudgetBytes);
      }
    }
    made->setFrame(view, tiles);
    sources.push_back(made.get());
  }
  std::vector<std::pair<std::size_t, std::size_t>> counts;  // written, repaired before
  for (const overlay::TileSource* s : sources)
    counts.emplace_back(static_cast<const GlobeTiling*>(s)->written(), static_cast<const GlobeTiling*>(s)->repaired());
  overlay::TechniqueFrame frame;
  frame.target = {0, view.width, view.height};
  frame.view = overlayViewOf(view);
  frame.settings = overlaySettingsOf(settings);
  frame.waitForTiles = settings.waitForTiles;
  overlay::TechniqueFrameStats tileStats;
  std::vector<std::vector<const overlay::OverlayLayer*>> chunks = residency.frame(frame, sources, tileStats);
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const auto* g = static_cast<const GlobeTiling*>(sources[i]);
    stats_.writtenTiles += g->written() - counts[i].first;
    stats_.repairedTiles += g->repaired() - counts[i].second;
  }
  stats_.builtTiles += tileStats.tilesBuilt - std::min(tileStats.tilesBuilt, tileStats.tilesFromDisk);
  stats_.readTiles += tileStats.tilesFromDisk;
  stats_.evictedTiles += tileStats.tilesEvicted;
  stats_.residentTiles = tileStats.tilesResident;
  stats_.residentBytes = residency.gpuBytes();
  stats_.missingTiles = tileStats.tilesMissing;
  stats_.tiles = tileStats;
  // The last frame, for analyses on it (chunks()).
  gpu_->layers = layers;
  gpu_->chunks = chunks;
  gpu_->tileIds.clear();
  for (const DrawnTile& t : tiles) gpu_->tileIds.push_back(t.key.id());
  gpu_->viewProj = view.viewProj();
  gpu_->heights = &heights;
  gpu_->settings = settings;
  return chunks;
}

std::vector<const overlay::OverlayLayer*> GlobeOverlayRenderer::chunks(const GlobeView& view,
                                                                       const std::vector<DrawnTile>& tiles,
                                                                       const GeoGrid& heights,
                                                                       const GlobeLayer& layer) {
  const GlobeTechnique last = gpu_->settings.technique;
  if ((last == GlobeTechnique::Stencil || last == GlobeTechnique::Paper) && renderer() != nullptr) {
    if (const std::vector<overlay::OverlayLayer>* whole =
            wholeLoadOf(layer, heights, tiles, last == GlobeTechnique::Paper)) {
      std::vector<const overlay::OverlayLayer*> out;
      for (const overlay::OverlayLayer& chunk : *whole) out.push_back(&chunk);
      return out;
    }
  }
  bool same = gpu_->heights == &heights && gpu_->viewProj == view.viewProj() && gpu_->tileIds.size() == tiles.size();
  for (std::size_t t = 0; same && t < tiles.size(); ++t) same = gpu_->tileIds[t] == tiles[t].key.id();
  std::vector<const GlobeLayer*> layers = same ? gpu_->layers : std::vector<const GlobeLayer*>{};
  auto at = std::find(layers.begin(), layers.end(), &layer);
  if (at != layers.end() && static_cast<std::size_t>(at - layers.begin()) < gpu_->chunks.size())
    return gpu_->chunks[static_cast<std::size_t>(at - layers.begin())];
  // Not drawn in this frame: its tiles join the frame's (the others stay as they are).
  if (at == layers.end()) layers.push_back(&layer);
  const GlobeOverlaySettings settings = gpu_->settings;
  std::vector<std::vector<const overlay::OverlayLayer*>> all = tilesFor(view, tiles, heights, layers, settings);
  at = std::find(layers.begin(), layers.end(), &layer);
  return all[static_cast<std::size_t>(at - layers.begin())];
}

void GlobeOverlayRenderer::draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                                const GeoGrid& heights, const std::vector<const GlobeLayer*>& layers,
                                const GlobeOverlaySettings& settings) {
  stats_ = {};
  overlay::OverlayRenderer* overlays = renderer();
  if (overlays == nullptr) return;
  std::vector<const GlobeLayer*> drawn(
      layers.begin(), layers.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(layers.size(), 32)));
  const std::size_t n = drawn.size();
  // The deferred lookup may draw the last layers it can (deferredDraws: areas only, or lines in
  // metres with round joins and caps), from `lookedUp` on: those
  // whose indices are built (on a thread of their own; a still waits for them with `deferred`)
  // and, with `auto`, fit a quarter of the GPU budget when the chooser takes the lookup.
  std::vector<const overlay::DeferredLayer*> indexed(n, nullptr);
  std::size_t lookedUp = n;
  gpu_->plan = -1;  // not `auto`: its chooser takes no measurement of this frame
  const bool lookup = settings.technique == GlobeTechnique::Deferred || settings.technique == GlobeTechnique::Auto;
  if (lookup && deferredPass() != nullptr) {
    std::erase_if(gpu_->retired, [](std::future<overlay::DeferredLayer>& f) {
      return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
    });
    // Per layer the reach class its lines in pixels need in this view (kBeyond: beyond every
    // class, its pieces draw it).
    std::vector<int> reach(n, overlay::ReachClasses::kNatural);
    for (std::size_t i = 0; i < n; ++i) reach[i] = lookupReach(*drawn[i], view, tiles, heights);
    std::size_t areas = n;
    while (areas > 0 && deferredDraws(*drawn[areas - 1]) && reach[areas - 1] != overlay::ReachClasses::kBeyond &&
           lookupFits(*drawn[areas - 1], reach[areas - 1], settings.gpuBudgetBytes) &&
           !gpu_->tooLarge.contains(LookupKey{drawn[areas - 1]->serial(), reach[areas - 1]}))
      --areas;
    const bool wait = settings.technique == GlobeTechnique::Deferred && settings.waitForTiles;
    for (std::size_t i = areas; i < n; ++i)
      indexed[i] = deferredOf(*drawn[i], heights, reach[i], wait, settings.gpuBudgetBytes / 4);
    // Indices this frame does not draw (a layer built again for another style has a new serial:
    // the old one's are never drawn again; a reach class another view needed) leave once all of
    // them pass a quarter of the GPU budget; those of a layer merely hidden stay below it.
    std::size_t held = 0;
    for (const auto& [key, index] : gpu_->deferred) held += index.bytes();
    if (held > settings.gpuBudgetBytes / 4) {
      std::erase_if(gpu_->deferred, [&](const auto& entry) {
        for (std::size_t i = areas; i < n; ++i)
          if (LookupKey{drawn[i]->serial(), reach[i]} == entry.first) return false;
        return true;
      });
    }
    std::size_t bytes = 0;
    while (lookedUp > areas && indexed[lookedUp - 1] != nullptr) bytes += indexed[--lookedUp]->bytes();
    for (std::size_t i = areas; i < n; ++i) {
      const bool pending = indexed[i] == nullptr && !gpu_->tooLarge.contains(LookupKey{drawn[i]->serial(), reach[i]});
      stats_.deferredPending += pending ? 1U : 0U;
    }
    if (settings.technique == GlobeTechnique::Auto) {
      const bool fits = bytes <= settings.gpuBudgetBytes / 4;
      const int plan = gpu_->chooser.choose(lookedUp < n && fits);
      if (plan == 0) lookedUp = n;
      gpu_->plan = plan;
      if (!settings.measure) gpu_->chooser.begin(plan);
    }
  }
  std::vector<const GlobeLayer*> pieced(drawn.begin(), drawn.begin() + static_cast<std::ptrdiff_t>(lookedUp));
  // `stencil`: the layers' pieces built once; those too large for it drawn by their tiles.
  std::vector<const std::vector<overlay::OverlayLayer>*> whole(pieced.size(), nullptr);
  const bool wholeLoad = settings.technique == GlobeTechnique::Stencil || settings.technique == GlobeTechnique::Paper;
  if (wholeLoad) {
    std::vector<const GlobeLayer*> tiled;
    for (std::size_t i = 0; i < pieced.size(); ++i) {
      whole[i] = wholeLoadOf(*pieced[i], heights, tiles, settings.technique == GlobeTechnique::Paper);
      if (whole[i] == nullptr) tiled.push_back(pieced[i]);
    }
    pieced = std::move(tiled);
  }
  std::vector<std::vector<const overlay::OverlayLayer*>> chunked = tilesFor(view, tiles, heights, pieced, settings);
  if (wholeLoad) {
    std::vector<std::vector<const overlay::OverlayLayer*>> all(whole.size());
    std::size_t next = 0;
    for (std::size_t i = 0; i < whole.size(); ++i) {
      if (whole[i] == nullptr) {
        all[i] = std::move(chunked[next++]);
        continue;
      }
      for (const overlay::OverlayLayer& chunk : *whole[i]) all[i].push_back(&chunk);
    }
    chunked = std::move(all);
    gpu_->chunks = chunked;
    gpu_->layers.assign(drawn.begin(), drawn.begin() + static_cast<std::ptrdiff_t>(lookedUp));
  }
  for (const auto& layer : chunked) {
    for (const overlay::OverlayLayer* chunk : layer) {
      stats_.triangles += chunk->stats().triangles;
      stats_.drawnBytes += chunk->stats().gpuBytes;
    }
    stats_.drawnTiles += layer.size();
  }
  chunked.resize(n);  // the looked-up layers have no pieces (their bits stay theirs)
  std::vector<overlay::LayerFrameStats> drawnStats =
      overlays->draw(cache, overlayViewOf(view), chunked, overlaySettingsOf(settings));
  for (const overlay::LayerFrameStats& s : drawnStats) {
    stats_.pieces += s.zPassPieces + s.zFailPieces;
    stats_.zFailPieces += s.zFailPieces;
    stats_.culledPieces += s.culledPieces;
  }
  for (const auto& [key, index] : gpu_->deferred) stats_.deferredHeldBytes += index.bytes();
  if (lookedUp < n) {
    for (std::size_t i = 0; i < lookedUp; ++i) indexed[i] = nullptr;
    for (std::size_t i = lookedUp; i < n; ++i) stats_.deferredBytes += indexed[i]->bytes();
    stats_.deferredLayers = n - lookedUp;
    deferredPass()->draw(cache, {settings.targetFramebuffer, view.width, view.height}, overlayViewOf(view), indexed,
                         settings.measure, drawnStats);
  }
  stats_.layers = std::move(drawnStats);
  if (settings.technique == GlobeTechnique::Auto && !settings.measure && deferredPass() != nullptr) gpu_->chooser.end();
}

void GlobeOverlayRenderer::measured(double milliseconds) {
  if (gpu_->plan >= 0) gpu_->chooser.record(gpu_->plan, milliseconds);
}

overlay::DeferredPass* GlobeOverlayRenderer::deferredPass() { return madeOnFirstUse(gpu_->pass, gpu_->passFailed); }

const std::vector<overlay::OverlayLayer>* GlobeOverlayRenderer::wholeLoadOf(const GlobeLayer& layer,
                                                                            const GeoGrid& heights,
                                                                            const std::vector<DrawnTile>& tiles,
                                                                            bool paper) {
  Gpu::WholeLoad& w = gpu_->wholeLoads[{layer.serial(), paper}];
  if (w.heights != &heights) {
    w = Gpu::WholeLoad{};
    w.heights = &heights;
    // The tiles of kWholeLoadLevel the layer's features meet: each feature's box grown by what
    // its shapes reach and by a tile (the pieces' margins), so that a layer of a few features far
    // apart builds the tiles around them only.
    const TileKey probe{kWholeLoadLevel, 0, 0};
    const double size = probe.size();
    const long long columns = probe.columns();
    std::unordered_set<std::uint64_t> ids;
    std::vector<TileKey> keys;
    std::size_t count = 0;
    const auto addBox = [&](const LonLatRect& box, double reach) {
      if (box.empty() || count > kWholeLoadMaxTiles) return;
      const glm::dvec2 grow = detail::degreesAround(box, reach, size);
      const double dLon = grow.x, dLat = grow.y;
      const auto x0 = static_cast<long long>(std::floor((box.west - dLon + 180.0) / size));
      const long long x1 =
          std::min(static_cast<long long>(std::floor((box.east + dLon + 180.0) / size)), x0 + columns - 1);
      const auto y0 = std::max(0LL, static_cast<long long>(std::floor((box.south - dLat + 90.0) / size)));
      const auto y1 =
          std::min<long long>(probe.rows() - 1, static_cast<long long>(std::floor((box.north + dLat + 90.0) / size)));
      if (static_cast<double>(x1 - x0 + 1) * static_cast<double>(y1 - y0 + 1) >
          static_cast<double>(kWholeLoadMaxTiles)) {
        count = kWholeLoadMaxTiles + 1;
        return;
      }
      for (long long y = y0; y <= y1; ++y) {
        for (long long x = x0; x <= x1; ++x) {
          const TileKey key{kWholeLoadLevel, static_cast<int>(((x % columns) + columns) % columns),
                            static_cast<int>(y)};
          if (ids.insert(key.id()).second) keys.push_back(key);
        }
      }
      count = keys.size();
    };
    for (std::size_t k = 0; k < layer.areaCount(); ++k) addBox(layer.area(k).box, 0.0);
    if (layer.hasLines()) {
      for (const GlobeLine& line : layer.lines()) addBox(line.box, line.halfWidth * line.shapeReach());
    }
    if (count > kWholeLoadMaxTiles) {
      w.refused = true;
      logError("layer '" + layer.name() + "': " + (paper ? "paper" : "stencil") +
               " builds a layer whole over tiles of about 5 km, and its features need more than " +
               std::to_string(kWholeLoadMaxTiles) +
               " of them: it is drawn by its view's tiles (stencil-tiles) instead");
      return nullptr;
    }
    // Built on every core, uploaded here.
    std::vector<WholeLoadTile> built(keys.size());
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
      for (std::size_t k = next++; k < keys.size(); k = next++)
        built[k] = buildWholeLoadPieces(layer, keys[k], heights, paper);
    };
    std::vector<std::thread> workers;
    const unsigned cores = std::max(1U, std::thread::hardware_concurrency());
    for (unsigned t = 1; t < cores && t < keys.size(); ++t) workers.emplace_back(work);
    work();
    for (std::thread& t : workers) t.join();
    for (WholeLoadTile& tile : built) {
      if (tile.empty) continue;
      w.chunks.push_back(overlay::OverlayLayer::upload(std::move(*tile.geometry)));
      tile.geometry.reset();
      w.tiles.push_back(std::move(tile));
      ++stats_.builtTiles;
    }
  }
  if (w.refused) return nullptr;
  // A chunk's reach changes only with the coarser levels drawn over it: found by key, and the
  // ground's bounds read again only where those changed (a view from afar draws a few levels).
  const CoarseDrawnTiles coarse(tiles);
  w.reachLevels.resize(w.chunks.size(), ~0U);
  for (std::size_t k = 0; k < w.chunks.size(); ++k) {
    const std::uint32_t levels = coarserLevelsOver(w.tiles[k], coarse);
    if (levels == w.reachLevels[k]) continue;
    w.reachLevels[k] = levels;
    const glm::dvec2 reach = wholeLoadCapReach(w.tiles[k], levels, heights);
    // The paper's boxes move out with the top caps' reach: both caps reach as far.
    const double both = std::max(reach.x, reach.y);
    w.chunks[k].setCapReach(paper ? both : reach.x, paper ? both : reach.y);
  }
  return &w.chunks;
}

int GlobeOverlayRenderer::lookupReach(const GlobeLayer& layer, const GlobeView& view,
                                      const std::vector<DrawnTile>& tiles, const GeoGrid& heights) {
  if (!layer.hasLines() || !(layer.lineWidthPixels() > 0.0)) return overlay::ReachClasses::kNatural;
  auto found = gpu_->pixelWidths.find(layer.serial());
  if (found == gpu_->pixelWidths.end()) {
    overlay::PixelLineWidths w;
    double shapeReach = 1.0;
    for (const GlobeLine& line : layer.lines()) {
      if (!(line.widthPixels > 0.0)) continue;
      w.pixelsHalf = std::max(w.pixelsHalf, 0.5 * line.widthPixels);
      w.leastHalf = std::max(w.leastHalf, line.halfWidth);
      w.largestHalf = std::max(w.largestHalf, line.maxHalfWidth);
      shapeReach = std::max(shapeReach, line.shapeReach());
    }
    found = gpu_->pixelWidths.emplace(layer.serial(), std::make_pair(w, shapeReach)).first;
  }
  // (Plain names: clang 14 cannot capture a structured binding in the lambda below.)
  const overlay::PixelLineWidths widths = found->second.first;
  const double shapeReach = found->second.second;
  // The farthest anchor that can colour a drawn pixel: no farther than the layer's extent's
  // farthest point (its anchors lie there), nor than the farthest point of a drawn tile the
  // extent grown by what the class's shapes reach meets (lineWidthClass's bound, per tile). The
  // first is tight for a small layer, the second for one over the world.
  const LonLatRect extent = layer.extent();
  const double within = detail::TileReach(extent, heights).farthest(view.eye, 0.0);
  // Each drawn tile's reach, found once for every class that meets it.
  std::vector<std::optional<detail::TileReach>> reached(tiles.size());
  return kReach.classFor(widths, pixelScaleOf(view).metresPerPixel, [&](double classReach) {
    const double reach = shapeReach * classReach;
    const glm::dvec2 grow = detail::degreesAround(extent, reach);
    double far = 0.0;
    for (std::size_t t = 0; t < tiles.size(); ++t) {
      const LonLatRect r = tiles[t].key.rect().expanded(grow.x, grow.y);
      bool meets = false;
      for (int turn = -1; turn <= 1 && !meets; ++turn) {
        const double shift = 360.0 * turn;
        meets = extent.west + shift <= r.east && r.west <= extent.east + shift && extent.south <= r.north &&
                r.south <= extent.north;
      }
      if (!meets) continue;
      if (!reached[t]) reached[t].emplace(tiles[t].key, heights);
      far = std::max(far, reached[t]->farthest(view.eye, reach));
    }
    return std::min(far, within);
  });
}

const overlay::DeferredLayer* GlobeOverlayRenderer::deferredOf(const GlobeLayer& layer, const GeoGrid& heights,
                                                               int reachClass, bool wait, std::size_t maxBytes) {
  const LookupKey key{layer.serial(), reachClass};
  const auto found = gpu_->deferred.find(key);
  if (found != gpu_->deferred.end()) return &found->second;
  auto building = gpu_->building.find(key);
  if (building == gpu_->building.end()) {
    // The parts are made here (a fraction of a second: the rings clipped and projected, the
    // layer read while it is certain to live); the indices on a thread of their own (the
    // countries: 12 s), which owns what it reads.
    // The cover boxes hold the drawn ground: the grid's heights, the lowest less the sag of the
    // coarsest tiles (the terrain's bounds contract at level 0).
    const double lowest = groundBounds(heights, LonLatRect{-180.0, -90.0, 180.0, 90.0}, 0).first;
    const double highest = heights.bounds(LonLatRect{-180.0, -90.0, 180.0, 90.0}).second;
    // Lines in space: what their leaves allow for is the ground of tiles of level 3 and finer
    // (docs/globe.md, "The deferred lookup"): the coarser tiles are drawn from so far that a pixel
    // is wider than what their deeper ground moves a line's edge.
    const double near = std::max(-groundBounds(heights, LonLatRect{-180.0, -90.0, 180.0, 90.0}, 3).first, highest);
    std::vector<glm::vec4> colors(layer.featureCount(), layer.color());
    const std::vector<glm::vec4>& groups = layer.colors();
    for (std::size_t k = 0; k < layer.areaCount(); ++k) {
      const GlobeLayer::Area& a = layer.area(k);
      if (a.feature < colors.size() && a.group < groups.size()) colors[a.feature] = groups[a.group];
    }
    if (layer.hasLines()) {
      for (const GlobeLine& l : layer.lines())
        if (l.feature < colors.size() && l.group < groups.size()) colors[l.feature] = groups[l.group];
    }
    std::vector<overlay::DeferredLayer::Part> parts =
        deferredParts(layer, lowest, highest, near, kReach.reach(reachClass));
    building = gpu_->building
                   .emplace(key, std::async(std::launch::async,
                                            [parts = std::move(parts), colors = std::move(colors)] {
                                              return overlay::DeferredLayer::build(parts, colors);
                                            }))
                   .first;
  }
  if (!wait && building->second.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return nullptr;
  overlay::DeferredLayer& made = gpu_->deferred.emplace(key, building->second.get()).first->second;
  gpu_->building.erase(building);
  if (made.bytes() > maxBytes) {  // the budget is a promise: its pieces draw it
    gpu_->tooLarge.insert(key);
    gpu_->deferred.erase(key);
    return nullptr;
  }
  return &made;
}

}  // namespace gis::globe
