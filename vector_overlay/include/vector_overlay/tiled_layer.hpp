#pragma once
// View-dependent detail for one vector layer (docs/design.md §5, "cost follows the view"): the layer cut
// into the tiles of a quadtree over the terrain, each tile's pieces built on demand from the
// features that reach it, generalised so that the ground error of level L is known:
//
//   ε_L = tile size_L / tileResolution (+ lineShapeSlack for miter, bevel, flat or square
//   lines, generalise.hpp) on every level but the finest, 0 (the source geometry) there:
//   lines and rings simplified within 3/4 ε_L, arcs drawn with chords within 1/4 ε_L (or the
//   layer's chord tolerance, if larger), and a line layer whose shapes reach at most 1/4 ε_L
//   from the line drawn as its segments' rectangles only (FootprintOptions::segmentsOnly: the
//   joins and caps left out lie within w/2 of a vertex).
//
// A tile is drawn when ε_L, seen from the eye at the distance of the tile's nearest point, is at
// most `errorPixels` on screen (0.5: the drawn outline stays within half a pixel of the true
// one), else its four children are (screen-space error, as the terrain chooses its chunks);
// tiles outside the view are left out, and so are tiles no feature reaches.
//
// Pieces are clipped to their tile (CellGrid clipping), so the tiles of one level cover each
// feature exactly once; tiles of different levels drawn side by side (or a parent drawn over
// children that are still building) overlap only in ground that both cover within their ε:
// one layer's tiles are marked together and covered once (OverlayRenderer::draw with chunks),
// so an overlap never colours a pixel twice.
//
// Lines at least `min_width_px` wide (LayerStyle::minWidthPixels, round joins and caps): the
// half width at a vertex is max(min(px / 2 · pixel size there, cap / 2), w / 2) (LineShape), a
// shape that changes every frame, drawn from pieces built at the largest width they may take.
// Each tile is built for a width class (TileKey::width): the narrowest power-of-two width that
// holds minWidthPixels at the tile's farthest point (its box grown by that half width, heights
// from the global bounds), 0 where that is no wider than the lines in metres (then they are
// built in metres, split at cells, as without the option). In a class above 0 the wider lines
// are cut to the tile grown by the class's half width (appendClipped) and not split at cells;
// culling and the test for features near the tile grow the tile by it as well. A resident tile
// of a wider class than the view needs is still exact (its pieces shrink in the shader), so a
// class changes only when the view moves by a factor of two.
//
// LayerTiling is the CPU side (no GL, const methods safe from any thread): selection and tile
// building. The tiled technique (techniques/tiled_stencil_technique.cpp) keeps the built tiles
// on the GPU under a budget and builds them on worker threads.
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"
#include "core/height_bounds.hpp"
#include "vector_overlay/layer_geometry.hpp"
#include "vector_overlay/near_clip.hpp"

namespace gis::overlay {

struct TilingOptions {
  /// Generalised levels: ε_L = tile size / tileResolution.
  int tileResolution = 1024;
  /// The drawn outline stays within this many pixels of the true one.
  double errorPixels = 0.5;
  /// The finest tiles hold this many cells of the layer's grid (the source geometry, exact), or
  /// fewer on a grid less than 8 × that across, so that it has 8 finest tiles a side (of at
  /// least one cell).
  int finestTileCells = 32;
  /// Coarser tiles cut their pieces at cells of tile size / cellsPerTile (never finer than the
  /// layer's grid): fewer, taller pieces where they are seen from afar.
  int cellsPerTile = 64;
  /// GPU bytes the resident tiles may hold (least recently drawn tiles leave first; the tiles
  /// of the frame being drawn always stay).
  std::size_t gpuBudgetBytes = std::size_t{512} << 20U;
  /// Host bytes that tiles read from the disk cache may hold at once, from their read to their
  /// upload (one tile is read whatever its size): two workers reading two large tiles side by
  /// side would hold both on the host beside the GPU's copy.
  std::size_t hostBytesInFlight = std::size_t{128} << 20U;
  /// Worker threads that build tiles (0: one per core).
  unsigned workers = 0;
  /// Where built tiles are kept on disk for the next run (empty: nowhere). Each layer gets a
  /// folder named after the fingerprint of what its pieces depend on: its features and styles,
  /// the build and tiling options, and `cacheKey`.
  std::string cacheDirectory;
  /// The folders of cacheDirectory that no layer opened lately (tiles of other features, other
  /// terrain, other code: never read again) are removed, least recently opened first, while the
  /// folder holds more than this; a folder unused for 30 days goes in any case. A folder opened
  /// in the last 10 minutes stays (another layer of this scene, another process).
  std::uintmax_t cacheBudgetBytes = std::uintmax_t{4} << 30U;
  /// What the pieces depend on that the layer cannot see: the terrain (DEM files and their
  /// dates, band, chunk size, vertical exaggeration), as the scene states it.
  std::string cacheKey;
  /// The bounds' revision() when cacheKey was stated: the cache is used only while the bounds
  /// are still at it (another exaggeration is not in the key).
  std::uint64_t cacheRevision = 0;
};

/// The disk cache's housekeeping, for both frames' tiles: marks `folder` (a layer's, in
/// `directory`) as opened now, then removes the other folders of `directory` that no layer opened
/// in the last 10 minutes, least recently opened first, while the folders hold more than `budget`
/// bytes, and any unused for 30 days (TilingOptions::cacheBudgetBytes). Returns how many it
/// removed.
std::size_t pruneTileFolders(const std::filesystem::path& directory, const std::filesystem::path& folder,
                             std::uintmax_t budget);

struct TileKey {
  int level = 0;
  int x = 0;
  int y = 0;
  /// Lines with a least width in pixels (LineShape::minWidth): the widths the tile is built
  /// for. 0: every such line at its width in metres; c > 0: up to widthClassCap(c) metres, drawn
  /// at least LayerStyle::minWidthPixels on screen (LayerTiling::select picks the class whose
  /// width holds the tile's farthest pixel). Not in packed(): one tile per place.
  int width = 0;
  /// The place: level, x and y.
  [[nodiscard]] std::uint64_t packed() const {
    return (static_cast<std::uint64_t>(level) << 58U) | (static_cast<std::uint64_t>(x) << 29U) |
           static_cast<std::uint64_t>(y);
  }
  [[nodiscard]] TileKey parent() const { return {level - 1, x / 2, y / 2, 0}; }
  friend bool operator==(const TileKey&, const TileKey&) = default;
};

/// The widest line (metres) a tile of width class c > 0 is built for: 2^(c − 8).
inline double widthClassCap(int c) { return std::ldexp(1.0, c - 8); }

/// A tile's pieces: a LayerGeometry of the features that reach the tile (generalised, lines cut
/// to the runs near it), and which feature of the layer each of its features is.
struct LayerTile {
  TileKey key;
  LayerGeometry geometry;
  std::vector<std::uint32_t> featureIndex;  ///< per feature of geometry, its index in the layer
  double groundError = 0.0;                 ///< metres: the footprint is within this of the source's
  bool fromDisk = false;                    ///< read from the disk cache, not built
};

/// A layer's tiles as the tiled technique's residency asks for them (tile_residency.hpp), in
/// either frame: the projected frame's LayerTiling below, the globe's tiles over its terrain's
/// (globe_overlay.hpp). The const methods but select may run on any thread while tiles build.
class TileSource {
 public:
  virtual ~TileSource() = default;
  TileSource() = default;
  TileSource(const TileSource&) = delete;
  TileSource& operator=(const TileSource&) = delete;
  /// The layer's name, for messages.
  [[nodiscard]] virtual const std::string& name() const = 0;
  /// The tiles to draw for this view, coarse to fine: at a screen-space error of at most
  /// errorPixels() · errorScale (a larger scale where the GPU budget needs coarser detail).
  /// `culled` counts the tiles left out for lying outside the view.
  [[nodiscard]] virtual std::vector<TileKey> select(const OverlayView& view, int viewportHeight, std::size_t* culled,
                                                    double errorScale) const = 0;
  [[nodiscard]] virtual double errorPixels() const = 0;
  /// The level whose tiles hold the source geometry (coarser ones may go lean, below).
  [[nodiscard]] virtual int finestLevel() const = 0;
  /// Builds one tile (any thread), or reads it from the disk cache; problems in the result's
  /// diagnostics. Once `cancel` is set the build may stop early and fail. `lean`: it may come
  /// without footprints (LayerGeometry::releaseFootprints).
  [[nodiscard]] virtual Result<LayerTile> build(const TileKey& key, const std::atomic<bool>* cancel,
                                                bool lean) const = 0;
  /// The GPU bytes of tile `key` as the disk cache holds it, or none (not cached, or not known).
  [[nodiscard]] virtual std::optional<std::size_t> cachedBytes(const TileKey& key) const = 0;
  /// The folder of the layer's tiles on disk (empty: none), for messages.
  [[nodiscard]] virtual const std::string& cacheFolder() const = 0;
  /// A box (the view's world coordinates) holding every piece tile `key` can have, where the tile
  /// may come lean when the eye is far from it; none where it may not.
  [[nodiscard]] virtual std::optional<std::pair<glm::dvec3, glm::dvec3>> leanBox(const TileKey& key) const = 0;
  /// How far from a tile's box, in its sizes, the eye must be for the tile to go lean (read lean,
  /// or its footprints released once uploaded): a margin so that a tile is not read again each
  /// time the eye moves a little. A projected frame's tiles: their size. The globe's tiles are
  /// drawn from about their size and their boxes bulge with the earth's curvature, so that
  /// margin would keep most of a view from space whole: an eighth.
  [[nodiscard]] virtual double leanDistance() const { return 1.0; }
  /// Tiles of world pieces (LayerGeometry::ofWorldPieces: never edited): their host arrays are
  /// what their pieces near the eye are clipped from, kept where a piece may be drawn z-fail and
  /// let go elsewhere once uploaded (the coarse tiles' rule at every level).
  [[nodiscard]] virtual bool worldPieces() const { return false; }
};

/// The disk cache for a frame whose tiles are world pieces built by a builder of its own (the
/// globe's, LayerGeometry::ofWorldPieces): the same files, checks and lean reads as a
/// LayerTiling's (one checked file per tile in the layer's folder, named by a fingerprint of what
/// its pieces depend on; a damaged file is said and written again).
class WorldTileCache {
 public:
  /// `folder`: the layer's (empty: no cache); `fingerprint`: of everything its pieces depend on.
  WorldTileCache(std::string folder, std::uint64_t fingerprint)
      : folder_(std::move(folder)), fingerprint_(fingerprint) {}
  /// Tile `key` from the cache, else built by `build` and written there. `lean` (a tile far from
  /// the eye, TileSource::build): a tile read comes with its GPU arrays left in its file (the
  /// upload copies them from there a slice at a time), and so does one built and written, read
  /// back (its built arrays freed before the upload); else with its arrays, for clipping its
  /// pieces at the near plane. Its colour groups are drawn in `groupColours` (the fingerprint
  /// holds them where they differ: coloursFingerprint).
  [[nodiscard]] Result<LayerTile> fetch(const TileKey& key, const std::string& layerName,
                                        std::span<const glm::vec4> groupColours,
                                        const std::function<LayerGeometry()>& build, bool lean = true) const;
  /// The GPU bytes of tile `key` as the cache holds it (LayerTiling::cachedBytes), or none.
  [[nodiscard]] std::optional<std::size_t> cachedBytes(const TileKey& key) const;
  [[nodiscard]] const std::string& folder() const { return folder_; }
  /// Tiles read, written and found damaged so far.
  [[nodiscard]] std::size_t read() const { return read_; }
  [[nodiscard]] std::size_t written() const { return written_; }
  [[nodiscard]] std::size_t damaged() const { return damaged_; }

 private:
  std::string folder_;
  std::uint64_t fingerprint_ = 0;
  mutable std::atomic<std::size_t> read_{0}, written_{0}, damaged_{0};
};

class LayerTiling final : public TileSource {
 public:
  /// `source`: the layer's features and styles (its pieces are not used; a layer built with
  /// LayerBuildOptions::deferPieces has none). `cells`: the layer's grid (the terrain's cells).
  /// Both `source` and `bounds` must outlive the tiling and not change while tiles build.
  LayerTiling(const LayerGeometry& source, const HeightBoundsProvider& bounds, const LayerBuildOptions& options,
              const TilingOptions& tiling);

  [[nodiscard]] const std::string& name() const override { return source_->name(); }
  [[nodiscard]] int finestLevel() const override { return finestLevel_; }
  [[nodiscard]] double tileSize(int level) const { return rootSize_ / static_cast<double>(1 << level); }
  [[nodiscard]] std::pair<glm::dvec2, glm::dvec2> extent(const TileKey& key) const;
  /// Metres between a level's drawn footprints and the source's, at most.
  [[nodiscard]] double groundError(int level) const;
  /// The tiles to draw for this view (screen-space error at most errorPixels · errorScale, and
  /// frustum), coarse to fine. `culled` counts the tiles left out for lying outside the view.
  [[nodiscard]] std::vector<TileKey> select(const OverlayView& view, int viewportHeight, std::size_t* culled = nullptr,
                                            double errorScale = 1.0) const override;
  [[nodiscard]] double errorPixels() const override { return tiling_.errorPixels; }
  /// Builds one tile (any thread). Errors of features are reported in the result's diagnostics.
  /// Once `cancel` is set the build stops early and fails (nothing is written to disk). `lean`:
  /// a tile read from the disk cache may come lean (LayerGeometry::releaseFootprints), for a
  /// view far from it; a built one too once written there (read back lean, so that the built
  /// copy is freed before the upload); otherwise a built one is whole.
  [[nodiscard]] Result<LayerTile> build(const TileKey& key, const std::atomic<bool>* cancel = nullptr,
                                        bool lean = false) const override;
  /// The GPU bytes of tile `key` as the disk cache holds it (its lean section: the arrays and
  /// the pieces' boxes, a little more than the GPU takes), or none when the cache has no usable
  /// file for it. Reads the file's header only.
  [[nodiscard]] std::optional<std::size_t> cachedBytes(const TileKey& key) const override;
  /// Coarser than the finest level: the tile grown by the layer's reach and its class's width,
  /// between the terrain's global bounds widened by the level's error.
  [[nodiscard]] std::optional<std::pair<glm::dvec3, glm::dvec3>> leanBox(const TileKey& key) const override;
  /// Feature i of the layer as tile `key` draws it (generalised for the level, a line cut to the
  /// runs that reach the tile), or none when it does not reach the tile.
  [[nodiscard]] std::optional<geo::Feature> featureFor(const TileKey& key, std::uint32_t i) const;
  /// Features `indices` as tile `key` draws them, those that reach it, in order: a polygon layer's
  /// generalised together (generaliseCoverage: shared borders stay shared), so one feature's
  /// pieces in a tile are the same whether built with the tile or alone (featureFor). Empty once
  /// `cancel` is set.
  [[nodiscard]] std::vector<std::pair<std::uint32_t, geo::Feature>> featuresFor(
      const TileKey& key, const std::vector<std::uint32_t>& indices, const std::atomic<bool>* cancel) const;
  /// How far tile `key`'s features may be simplified (metres; 0 at the finest level).
  [[nodiscard]] double generalisation(const TileKey& key) const;
  /// After feature i of the source changed (geometry or style): index it again. Not while tiles
  /// build.
  void update(std::uint32_t i);
  /// The largest reach of the layer's features (how far their shapes reach from their lines;
  /// for lines with a least width in pixels, at that least width).
  [[nodiscard]] double widestReach() const;
  /// Feature i's style in tile `key`: lines with a least width in pixels at the tile's width
  /// class (in metres where the class is no wider than them), others as in the source.
  [[nodiscard]] FeatureStyle tileStyle(const TileKey& key, std::uint32_t i) const;
  /// The features that reach the tile (their boxes widened by the lines' reach meet it).
  [[nodiscard]] std::vector<std::uint32_t> featuresNear(const TileKey& key) const;
  [[nodiscard]] const LayerGeometry& source() const { return *source_; }
  /// The folder of this layer's tiles on disk (empty without a cache), and how many tiles were
  /// read from it and written to it so far.
  [[nodiscard]] const std::string& cacheFolder() const override { return cacheFolder_; }
  [[nodiscard]] std::size_t tilesRead() const { return tilesRead_; }
  [[nodiscard]] std::size_t tilesWritten() const { return tilesWritten_; }
  /// Tiles whose cache file was damaged (rebuilt, and said in the build's diagnostics).
  [[nodiscard]] std::size_t tilesDamaged() const { return tilesDamaged_; }

 private:
  const LayerGeometry* source_;
  const HeightBoundsProvider* bounds_;
  LayerBuildOptions options_;
  TilingOptions tiling_;
  CellGrid grid_;
  glm::dvec2 origin_{0.0};
  double rootSize_ = 1.0;
  int finestLevel_ = 0;
  double slack_ = 0.0;          ///< lineShapeSlack of the widest line
  double minPixels_ = 0.0;      ///< the layer's least width in pixels (0: no line has one)
  double leastMinWidth_ = 0.0;  ///< the narrowest such line's width in metres
  double widestCap_ = 0.0;      ///< the widest such line's largest width
  std::vector<double> reach_;   ///< per feature: how far its footprint reaches from its geometry
  std::vector<std::pair<glm::dvec2, glm::dvec2>> boxes_;  ///< per feature, widened by its reach (empty: hidden)
  // A bucket grid over the extent: each bucket lists the features whose widened box meets it.
  int buckets_ = 1;
  std::vector<std::vector<std::uint32_t>> bucket_;
  std::string cacheFolder_;          ///< empty: no disk cache
  std::uint64_t fingerprint_ = 0;    ///< of what the pieces depend on
  std::uint64_t cacheRevision_ = 0;  ///< the bounds' revision the fingerprint holds
  bool cacheUsable_ = false;         ///< off after an edit (the fingerprint no longer holds)
  mutable std::atomic<std::size_t> tilesRead_{0}, tilesWritten_{0}, tilesDamaged_{0};
  [[nodiscard]] std::uint64_t fingerprint() const;
  [[nodiscard]] std::filesystem::path tileFile(const TileKey& key) const;
  /// How tile `key` is built: its cells, chords, bounds slack and line shapes for its level.
  [[nodiscard]] LayerBuildOptions tileOptions(const TileKey& key) const;
  [[nodiscard]] Result<LayerTile> buildNew(const TileKey& key, const std::atomic<bool>* cancel) const;
  /// The width class a drawn tile needs (TileKey::width) for this eye and pixel size.
  [[nodiscard]] int widthClass(const TileKey& key, const glm::dvec3& eye, double metresPerPixel, double zLo,
                               double zHi) const;
  /// Whether feature i is drawn in pixels in a tile of width class c.
  [[nodiscard]] bool scalableIn(std::uint32_t i, int c) const;
  void measure(std::uint32_t i);  ///< feature i's reach and widened box
  void fill(std::uint32_t i);     ///< adds feature i to the buckets its box meets
  /// The buckets [x0, x1] × [y0, y1] a box meets; false when it misses the root tile.
  bool bucketRange(const std::pair<glm::dvec2, glm::dvec2>& box, int& x0, int& y0, int& x1, int& y1) const;
};

}  // namespace gis::overlay
