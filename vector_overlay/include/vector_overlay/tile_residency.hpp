#pragma once
// The view-dependent tiles of a frame's layers on the GPU, for both frames (docs/frames.md):
// per layer the tiles its TileSource selects for the view, built on worker threads (or read from
// the disk cache), kept on the GPU under a byte budget (the least recently drawn leave first),
// a tile's nearest resident ancestor drawn while it builds (a flight), all of them waited for when
// a still image asks (TechniqueFrame::waitForTiles) or when nothing would stand in, and a coarser
// detail chosen where the view's tiles would not fit the budget. The projected frame's
// `stencil-tiles` technique draws its LayerTilings through it, the globe its tiles over the
// drawn terrain tiles (globe::GlobeOverlayRenderer).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/technique.hpp"
#include "vector_overlay/tiled_layer.hpp"

namespace gis::overlay {

class TileWorkers;

class TileResidency {
 public:
  /// A tile on the GPU.
  struct Resident {
    TileKey key;
    std::optional<OverlayLayer> layer;        ///< none: the tile has nothing to draw
    std::vector<std::uint32_t> featureIndex;  ///< per feature of layer, its index in the source layer
    double error = 0.0;                       ///< the tile's ground error (LayerTile::groundError)
    std::uint64_t lastUsed = 0;
    std::pair<glm::dvec3, glm::dvec3> box;  ///< of its pieces (LayerGeometry::box3)
  };

  /// A tile to build (tile_residency.cpp).
  struct Job;

  /// `renderer` (which says where pieces may be drawn z-fail) must outlive the residency.
  TileResidency(const OverlayRenderer& renderer, const TilingOptions& tiling);
  ~TileResidency();
  TileResidency(const TileResidency&) = delete;
  TileResidency& operator=(const TileResidency&) = delete;

  /// The chunks to draw per layer for this frame (frame.view, frame.target.height,
  /// frame.settings, waitForTiles and tileProgress are read; frame.layers is not): layer i's
  /// tiles from sources[i] (null: hidden, its tiles kept). A source other than the one layer i
  /// had before drops its tiles. Sources must stay alive until replaced and cancel()ed. Fills
  /// the tile counts of `stats` (its other fields are reset). The chunks stay valid until the
  /// next frame() or a change of the tiles (clear, erase).
  std::vector<std::vector<const OverlayLayer*>> frame(const TechniqueFrame& frame,
                                                      std::span<const TileSource* const> sources,
                                                      TechniqueFrameStats& stats);
  /// Stops the builds in flight (their results are dropped); the resident tiles stay.
  void cancel();
  /// Cancels, and drops every resident tile (the sources stay).
  void clear();
  /// Before a source is destroyed: cancels, and the layers that had it lose it and their tiles.
  void forget(const TileSource* source);
  /// The GPU bytes the resident tiles may hold from the next frame on (TilingOptions::gpuBudgetBytes).
  /// A larger budget starts again from the finest detail (a smaller one coarsens as frames need).
  void setGpuBudget(std::size_t bytes) {
    if (bytes > tiling_.gpuBudgetBytes) errorScale_ = 1.0;
    tiling_.gpuBudgetBytes = bytes;
  }
  /// Layer i's resident tiles by TileKey::packed() (null: no such layer yet), to edit or drop
  /// some of them (after cancel()).
  [[nodiscard]] std::unordered_map<std::uint64_t, Resident>* tiles(std::size_t layer);
  /// Layer i's source (null: none yet), and how many layers there are.
  [[nodiscard]] const TileSource* source(std::size_t layer) const {
    return layer < layers_.size() ? layers_[layer].source : nullptr;
  }
  [[nodiscard]] std::size_t layerCount() const { return layers_.size(); }
  /// GPU bytes of every resident tile.
  [[nodiscard]] std::size_t gpuBytes() const;
  /// Logs each problem once (a feature's problem is said once, not once per tile); the tiles' own
  /// are kept for said().
  void reportOnce(const Diagnostics& diagnostics);
  /// What reportOnce kept: the tiles' problems (a damaged tile file, a tile that cannot be read).
  [[nodiscard]] const Diagnostics& said() const { return said_; }

 private:
  struct LayerState {
    const TileSource* source = nullptr;
    std::unordered_map<std::uint64_t, Resident> tiles;
  };
  /// The largest factor on errorPixels the budget may force (the root tiles are drawn long before).
  static constexpr double kMaxErrorScale = 4096.0;

  bool waitForBuilds(const TechniqueFrame& frame, TechniqueFrameStats& stats, bool mayGiveUp);
  [[nodiscard]] std::size_t wantedBytes() const;
  [[nodiscard]] std::size_t expectedBytes() const;
  [[nodiscard]] std::size_t knownBytes(const std::vector<Job>& jobs) const;
  [[nodiscard]] bool canCoarsen() const { return errorScale_ < kMaxErrorScale && wantedFinestLevel_ > 0; }
  [[nodiscard]] bool farFrom(const TileSource& source, const TileKey& key, const TechniqueFrame& frame) const;
  [[nodiscard]] bool drawable(const Resident& r, const TechniqueFrame& frame) const;
  std::size_t collect(const TechniqueFrame& frame);
  bool gather(const TechniqueFrame& frame, std::vector<std::vector<const OverlayLayer*>>& chunks,
              std::vector<Job>& jobs, TechniqueFrameStats& stats);
  std::size_t evict(std::size_t budget);
  void request(const std::vector<Job>& jobs);

  const OverlayRenderer* renderer_;
  TilingOptions tiling_;
  std::vector<LayerState> layers_;
  std::vector<const TileSource*> shown_;  ///< this frame's sources (null: hidden)
  std::uint64_t frameNumber_ = 0;
  std::size_t fromDisk_ = 0;  ///< of the tiles the last collect() took, those read from disk
  Diagnostics said_;
  double errorScale_ = 1.0;                                     ///< on errorPixels, where the budget needs it
  std::set<std::pair<std::size_t, std::uint64_t>> frameTiles_;  ///< (layer, place) drawn in this frame
  std::set<std::pair<std::size_t, std::uint64_t>> wanted_;      ///< (layer, place) the last gather() wanted
  int wantedFinestLevel_ = 0;                                   ///< the finest level it wanted
  std::set<std::string> reported_;
  std::unique_ptr<TileWorkers> workers_;  // last: stopped first
};

}  // namespace gis::overlay
