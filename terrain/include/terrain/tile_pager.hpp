#pragma once
// Pages the tiles of a pyramid on disk into memory: the pinned (coarsest) levels stay loaded;
// finer tiles are read asynchronously by a worker thread on request and kept in an LRU cache
// under a CPU memory budget. Loaded tiles become visible, and the cache is trimmed, only in
// update() — called by the render loop once per frame — so a frame's LOD selection and drawing
// see one consistent set of resident tiles.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>

#include "terrain/tile_pyramid.hpp"

namespace gis::terrain {

struct TilePagerStats {
  std::size_t residentTiles = 0;  ///< paged tiles in memory (not counting pinned ones)
  std::size_t residentBytes = 0;
  std::size_t pinnedTiles = 0;
  std::size_t pinnedBytes = 0;
  std::size_t pending = 0;  ///< requested, not yet loaded
  std::size_t loads = 0;    ///< total tiles read
  std::size_t evictions = 0;
  std::size_t readErrors = 0;
};

class TilePager {
 public:
  static constexpr std::size_t kDefaultBudgetBytes = 384u << 20;

  /// Loads the pinned levels (synchronously) and starts the worker.
  explicit TilePager(std::shared_ptr<const TilePyramidFile> file, std::size_t budgetBytes = kDefaultBudgetBytes);
  ~TilePager();
  TilePager(const TilePager&) = delete;
  TilePager& operator=(const TilePager&) = delete;

  [[nodiscard]] const TilePyramidFile& file() const { return *file_; }
  [[nodiscard]] std::size_t budgetBytes() const { return budget_; }

  /// True if the node's tile is in memory or the node has no data (nothing to page).
  [[nodiscard]] bool resident(const NodeId& n);
  /// The node's tile if resident (marks it used), else null.
  [[nodiscard]] TileData find(const NodeId& n);
  /// The node's tile, read now if it is not resident (for exact height queries).
  TileData load(const NodeId& n);
  /// A pinned tile (levels ≥ pinnedLevel()): always resident, no locking.
  [[nodiscard]] const float* pinnedTile(const NodeId& n) const;

  /// Replaces the queue of wanted tiles (most wanted first); earlier wishes not repeated are
  /// dropped, so the worker never reads tiles the view has flown past.
  void request(std::span<const NodeId> wanted);
  /// Makes tiles loaded since the last call resident and trims the cache to the budget (least
  /// recently used first). Returns the number of tiles that became resident.
  std::size_t update();
  /// For tests and still images: waits until every requested tile is loaded, then update().
  void waitIdle();

  [[nodiscard]] TilePagerStats stats() const;

 private:
  struct Entry {
    TileData data;
    std::list<std::uint64_t>::iterator lru;
  };
  void run();
  TileData read(const NodeId& n);
  void insertLocked(const NodeId& n, TileData data);

  std::shared_ptr<const TilePyramidFile> file_;
  std::size_t budget_;
  std::unordered_map<std::uint64_t, std::vector<float>> pinned_;
  std::size_t pinnedBytes_ = 0;

  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::unordered_map<std::uint64_t, Entry> cache_;
  std::list<std::uint64_t> lru_;  ///< most recently used first
  std::size_t cacheBytes_ = 0;
  std::deque<NodeId> queue_;
  std::vector<std::pair<NodeId, TileData>> loaded_;  ///< by the worker, not yet resident
  std::unordered_map<std::uint64_t, bool> inFlight_;
  bool busy_ = false;
  bool stop_ = false;
  std::size_t loads_ = 0, evictions_ = 0, readErrors_ = 0;
  std::thread worker_;
};

}  // namespace gis::terrain
