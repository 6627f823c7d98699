// The view-dependent tiles on the GPU (tile_residency.hpp): the workers that build them and the
// choice, per frame, of what is drawn, waited for, built and evicted.
#include "vector_overlay/tile_residency.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <tuple>
#include <unordered_set>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "core/log.hpp"

namespace gis::overlay {

struct TileResidency::Job {
  std::size_t layer = 0;
  const TileSource* source = nullptr;
  TileKey key;
  bool lean = false;  ///< may come lean from the disk cache (TileSource::build)
};

/// Worker threads building tiles. request() replaces the jobs not yet started; take() hands
/// over what is done.
class TileWorkers {
 public:
  using Job = TileResidency::Job;
  struct Done {
    std::size_t layer = 0;
    TileKey key;
    Result<LayerTile> tile;
    std::size_t hostBytes = 0;  ///< held against the host limit until release()
  };

  /// `hostLimit`: the host bytes that tiles read from the disk cache may hold at once, from their
  /// read until their upload (release()); one tile is read whatever its size. Tiles built anew
  /// are not counted (their size is not known before).
  TileWorkers(unsigned count, std::size_t hostLimit) : hostLimit_(hostLimit) {
    for (unsigned k = 0; k < std::max(1U, count); ++k) threads_.emplace_back([this] { run(); });
  }
  ~TileWorkers() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
      queue_.clear();
    }
    wake_.notify_all();
    room_.notify_all();
    threads_.clear();  // joins
  }
  TileWorkers(const TileWorkers&) = delete;
  TileWorkers& operator=(const TileWorkers&) = delete;

  /// The jobs wanted now, most urgent first; those running or done are not repeated.
  void request(const std::vector<Job>& jobs) {
    {
      std::lock_guard lock(mutex_);
      queue_.clear();
      for (const Job& j : jobs) {
        if (busy_.count({j.layer, j.key.packed()}) == 0) queue_.push_back(j);
      }
    }
    wake_.notify_all();
  }
  /// Whether a tile is queued, being built, or built and not yet taken.
  [[nodiscard]] bool pending(std::size_t layer, const TileKey& key) {
    std::lock_guard lock(mutex_);
    if (busy_.count({layer, key.packed()}) != 0) return true;
    return std::any_of(queue_.begin(), queue_.end(), [&](const Job& j) { return j.layer == layer && j.key == key; });
  }
  std::vector<Done> take() {
    std::lock_guard lock(mutex_);
    std::vector<Done> out = std::move(done_);
    done_.clear();
    for (const Done& d : out) busy_.erase({d.layer, d.key.packed()});
    return out;
  }
  /// Until nothing is queued or running, or a tile is done and not taken, or `timeout` passed:
  /// whether nothing is queued or running.
  bool waitIdleOrDoneFor(std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    idle_.wait_for(lock, timeout, [&] { return (queue_.empty() && running_ == 0) || !done_.empty(); });
    return queue_.empty() && running_ == 0;
  }
  /// Jobs queued or running.
  [[nodiscard]] std::size_t remaining() {
    std::lock_guard lock(mutex_);
    return queue_.size() + static_cast<std::size_t>(running_);
  }
  /// The most host bytes tiles read from disk held at once, and the largest of them, so far.
  [[nodiscard]] std::pair<std::size_t, std::size_t> hostPeak() {
    std::lock_guard lock(mutex_);
    return {peakInFlight_, largestRead_};
  }
  /// A taken tile's host bytes are no longer held (uploaded, or dropped).
  void release(std::size_t bytes) {
    {
      std::lock_guard lock(mutex_);
      inFlight_ -= std::min(inFlight_, bytes);
    }
    room_.notify_all();
  }
  /// Drops the queue and stops the running jobs (their results are dropped too).
  void cancel() {
    std::unique_lock lock(mutex_);
    queue_.clear();
    cancelled_ = true;
    room_.notify_all();
    idle_.wait(lock, [&] { return running_ == 0; });
    cancelled_ = false;
    for (const Done& d : done_) inFlight_ -= std::min(inFlight_, d.hostBytes);
    done_.clear();
    busy_.clear();
    room_.notify_all();
  }

 private:
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      const Job job = queue_.front();
      queue_.pop_front();
      busy_.insert({job.layer, job.key.packed()});
      ++running_;
      lock.unlock();
      // A tile on disk is read once the host holds room for it (its file says how much).
      const std::size_t bytes = job.source->cachedBytes(job.key).value_or(0);
      lock.lock();
      room_.wait(lock, [&] { return stop_ || cancelled_ || inFlight_ == 0 || inFlight_ + bytes <= hostLimit_; });
      const bool skip = stop_ || cancelled_;
      inFlight_ += bytes;
      peakInFlight_ = std::max(peakInFlight_, inFlight_);
      largestRead_ = std::max(largestRead_, bytes);
      lock.unlock();
      Result<LayerTile> tile;
      try {
        if (!skip) tile = job.source->build(job.key, &cancelled_, job.lean);
      } catch (const std::exception& e) {  // on a worker thread it would end the program
        tile.diagnostics.add(
            {Severity::Error, "", job.source->name(), "", std::string("a tile cannot be built (") + e.what() + ")"});
      }
      lock.lock();
      --running_;
      done_.push_back({job.layer, job.key, std::move(tile), bytes});
      idle_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, idle_, room_;
  std::size_t hostLimit_ = 0;
  std::size_t inFlight_ = 0;  ///< host bytes of tiles read and not yet released
  std::size_t peakInFlight_ = 0, largestRead_ = 0;
  std::deque<Job> queue_;
  std::set<std::pair<std::size_t, std::uint64_t>> busy_;  ///< running, or done and not taken
  std::vector<Done> done_;
  std::atomic<bool> cancelled_{false};  ///< set while cancel() waits: running builds stop early
  int running_ = 0;
  bool stop_ = false;
  std::vector<std::jthread> threads_;  // last: joined first
};

namespace {

/// GPU bytes of the chunks to draw.
std::size_t chunkBytes(const std::vector<std::vector<const OverlayLayer*>>& chunks) {
  std::size_t bytes = 0;
  for (const auto& layer : chunks)
    for (const OverlayLayer* c : layer) bytes += c->stats().gpuBytes;
  return bytes;
}

/// Returns the heap's free pages to the system: a tile's many small arrays, freed, would
/// otherwise stay in the process (glibc keeps them for reuse), and the host would hold the
/// most any detail ever took instead of what is resident.
void giveBackFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace

TileResidency::TileResidency(const OverlayRenderer& renderer, const TilingOptions& tiling)
    : renderer_(&renderer),
      tiling_(tiling),
      workers_(std::make_unique<TileWorkers>(
          tiling.workers > 0 ? tiling.workers : std::max(1U, std::thread::hardware_concurrency()),
          tiling.hostBytesInFlight)) {}

TileResidency::~TileResidency() { workers_->cancel(); }

void TileResidency::cancel() { workers_->cancel(); }

void TileResidency::clear() {
  workers_->cancel();
  for (LayerState& l : layers_) l.tiles.clear();
}

void TileResidency::forget(const TileSource* source) {
  workers_->cancel();
  for (LayerState& l : layers_) {
    if (l.source != source) continue;
    l.source = nullptr;
    l.tiles.clear();
  }
  for (const TileSource*& s : shown_)
    if (s == source) s = nullptr;
}

std::unordered_map<std::uint64_t, TileResidency::Resident>* TileResidency::tiles(std::size_t layer) {
  return layer < layers_.size() ? &layers_[layer].tiles : nullptr;
}

std::size_t TileResidency::gpuBytes() const {
  std::size_t bytes = 0;
  for (const LayerState& l : layers_)
    for (const auto& [key, t] : l.tiles) bytes += t.layer ? t.layer->stats().gpuBytes : 0;
  return bytes;
}

void TileResidency::reportOnce(const Diagnostics& diagnostics) {
  for (const Diagnostic& m : diagnostics.items()) {
    if (reported_.insert(m.toString()).second) {
      logWarning(m.toString());
      // A feature's problems were said by the load's checks already (checkFeature); the
      // tiles' own (a damaged tile file, a tile that cannot be read) are kept.
      if (m.feature.empty()) said_.add(m);
    }
  }
}

void TileResidency::request(const std::vector<Job>& jobs) { workers_->request(jobs); }

std::vector<std::vector<const OverlayLayer*>> TileResidency::frame(const TechniqueFrame& frame,
                                                                   std::span<const TileSource* const> sources,
                                                                   TechniqueFrameStats& stats) {
  ++frameNumber_;
  if (layers_.size() != sources.size()) {
    workers_->cancel();  // a job of a layer that leaves would read its source
    layers_.resize(sources.size());
  }
  for (std::size_t i = 0; i < sources.size(); ++i) {
    if (sources[i] == nullptr || layers_[i].source == sources[i]) continue;
    // Another layer in this place: its tiles are stale.
    workers_->cancel();
    layers_[i].tiles.clear();
    layers_[i].source = sources[i];
  }
  shown_.assign(sources.begin(), sources.end());  // a hidden layer's tiles stay, not drawn
  stats.tilesBuilt += collect(frame);
  stats.tilesFromDisk += fromDisk_;
  stats.tilePeakBytes = gpuBytes();
  // A still starts from the finest detail the budget allowed lately.
  if (frame.waitForTiles) errorScale_ = std::max(1.0, 0.5 * errorScale_);
  std::vector<std::vector<const OverlayLayer*>> chunks;
  std::vector<Job> jobs;
  bool overBudget = false;  // the wanted tiles passed the budget while they built
  bool squeezed = false;    // a detail was given up for the budget in this frame
  const auto choose = [&] {
    for (;;) {
      const std::size_t built = stats.tilesBuilt, read = stats.tilesFromDisk, evicted = stats.tilesEvicted,
                        peak = stats.tilePeakBytes;
      stats = TechniqueFrameStats{};
      stats.tilesBuilt = built;
      stats.tilesFromDisk = read;
      stats.tilesEvicted = evicted;
      stats.tilePeakBytes = peak;
      chunks.clear();
      jobs.clear();
      const bool standIn = gather(frame, chunks, jobs, stats);
      // A still whose tiles the disk cache says will not fit: coarser at once, nothing read.
      if (frame.waitForTiles && canCoarsen() && knownBytes(jobs) > tiling_.gpuBudgetBytes) {
        overBudget = true;
        return;
      }
      if (!jobs.empty()) request(jobs);
      if (stats.tilesMissing == 0 || !(frame.waitForTiles || !standIn)) return;
      // A still image, or a tile with no ancestor to stand in: wait for them (then every
      // wanted tile is there), the budget made room for first (a finer detail that did not
      // fit leaves before the coarser one builds). Where the wanted tiles pass the budget
      // before all are there, the rest are not built: a coarser detail is chosen.
      // Once a detail was given up for the budget, nothing but this frame's tiles stays: the
      // given-up tiles would otherwise sit beside the coarser ones being built.
      stats.tilesEvicted += evict(squeezed ? 0 : tiling_.gpuBudgetBytes);
      if (!waitForBuilds(frame, stats, canCoarsen())) {
        overBudget = true;
        return;
      }
    }
  };
  choose();
  // The budget is kept: where the frame's tiles do not fit it, coarser detail (a flight draws
  // what is resident of it meanwhile); finer again from the next frame once they take under an
  // eighth of it (a level finer takes about four times as much).
  // (Not beyond the root tiles: then the budget cannot be kept, and the frame says so in
  // tileBytes.)
  while ((overBudget || chunkBytes(chunks) > tiling_.gpuBudgetBytes) && canCoarsen()) {
    overBudget = false;
    squeezed = true;
    errorScale_ *= 2.0;
    choose();
  }
  if (!frame.waitForTiles && chunkBytes(chunks) < tiling_.gpuBudgetBytes / 8 && errorScale_ > 1.0)
    errorScale_ = std::max(1.0, 0.5 * errorScale_);
  stats.tileBytes = chunkBytes(chunks);
  // Over the budget: the tiles drawn longest ago leave (never this frame's).
  stats.tilesEvicted += evict(tiling_.gpuBudgetBytes);
  for (const LayerState& l : layers_) {
    stats.tilesResident += l.tiles.size();
    for (const auto& [key, t] : l.tiles)
      stats.tilesLean += t.layer && t.layer->geometry().footprintsReleased() ? 1U : 0U;
  }
  std::tie(stats.tileHostPeakBytes, stats.tileLargestReadBytes) = workers_->hostPeak();
  return chunks;
}

/// Until the workers are idle, uploading each tile as it comes (its host arrays go once it is
/// on the GPU, so that the host holds at most the tiles being built) and telling
/// frame.tileProgress after the first second. With `mayGiveUp`, once the wanted tiles that
/// are there take more than the budget, or are expected to take more than twice the budget
/// (expectedBytes: an estimate from the tiles there, hence the margin; at once it misjudges
/// a budget that fits one frame), the rest are dropped and the running builds stopped, and false is
/// returned: the caller coarsens instead of building a detail that cannot be kept.
bool TileResidency::waitForBuilds(const TechniqueFrame& frame, TechniqueFrameStats& stats, bool mayGiveUp) {
  const auto start = std::chrono::steady_clock::now();
  const double total = static_cast<double>(std::max<std::size_t>(workers_->remaining(), 1));
  bool told = false;
  for (;;) {
    const bool idle = workers_->waitIdleOrDoneFor(std::chrono::milliseconds(250));
    stats.tilesBuilt += collect(frame);
    stats.tilesFromDisk += fromDisk_;
    stats.tilePeakBytes = std::max(stats.tilePeakBytes, gpuBytes());
    if (mayGiveUp && (wantedBytes() > tiling_.gpuBudgetBytes || expectedBytes() > 2 * tiling_.gpuBudgetBytes)) {
      workers_->cancel();
      if (told) frame.tileProgress(1.0);
      return false;
    }
    if (idle) break;
    if (!frame.tileProgress || std::chrono::steady_clock::now() - start < std::chrono::seconds(1)) continue;
    frame.tileProgress(std::clamp(1.0 - static_cast<double>(workers_->remaining()) / total, 0.0, 1.0));
    told = true;
  }
  if (told) frame.tileProgress(1.0);
  return true;
}

/// GPU bytes of the resident tiles the last gather() wanted.
std::size_t TileResidency::wantedBytes() const {
  std::size_t bytes = 0;
  for (const auto& [layer, key] : wanted_) {
    const auto it = layers_[layer].tiles.find(key);
    if (it != layers_[layer].tiles.end() && it->second.layer) bytes += it->second.layer->stats().gpuBytes;
  }
  return bytes;
}

/// GPU bytes the tiles the last gather() wanted are expected to take: per layer, those there,
/// and each missing one as much as those there on average.
std::size_t TileResidency::expectedBytes() const {
  std::vector<std::size_t> bytes(layers_.size(), 0), there(layers_.size(), 0), missing(layers_.size(), 0);
  for (const auto& [layer, key] : wanted_) {
    const auto it = layers_[layer].tiles.find(key);
    if (it == layers_[layer].tiles.end()) {
      ++missing[layer];
      continue;
    }
    ++there[layer];
    if (it->second.layer) bytes[layer] += it->second.layer->stats().gpuBytes;
  }
  std::size_t total = 0;
  for (std::size_t i = 0; i < layers_.size(); ++i)
    total += bytes[i] + (there[i] > 0 ? bytes[i] / there[i] * missing[i] : 0);
  return total;
}

/// GPU bytes of the wanted tiles that are resident and of those the jobs would read from the
/// disk cache (as its files say; tiles to be built count nothing).
std::size_t TileResidency::knownBytes(const std::vector<Job>& jobs) const {
  std::size_t bytes = wantedBytes();
  for (const Job& j : jobs) {
    if (layers_[j.layer].tiles.count(j.key.packed()) != 0) continue;  // counted, or a wider class
    bytes += j.source->cachedBytes(j.key).value_or(0);
  }
  return bytes;
}

/// Whether the eye is farther than its size (times TileSource::leanDistance) from any piece of tile `key` that could be
/// drawn z-fail (as collect() decides to release a tile's footprints), by a box that holds every piece the tile can
/// have: then it may come lean from the disk cache.
bool TileResidency::farFrom(const TileSource& source, const TileKey& key, const TechniqueFrame& frame) const {
  const std::optional<std::pair<glm::dvec3, glm::dvec3>> box = source.leanBox(key);
  if (!box) return false;
  const glm::dvec3 grow = (box->second - box->first) * source.leanDistance();
  return !renderer_->mayDrawZFail(frame.view, frame.settings, box->first - grow, box->second + grow);
}

/// Whether a resident tile can be drawn in this frame: one whose footprints (world pieces: their
/// arrays) were released only where none of its pieces could be drawn z-fail.
bool TileResidency::drawable(const Resident& r, const TechniqueFrame& frame) const {
  return !r.layer || !r.layer->geometry().footprintsReleased() ||
         !renderer_->mayDrawZFail(frame.view, frame.settings, r.box.first, r.box.second);
}

/// Uploads the tiles the workers finished; returns how many.
std::size_t TileResidency::collect(const TechniqueFrame& frame) {
  std::size_t count = 0;
  bool released = false;
  fromDisk_ = 0;
  for (TileWorkers::Done& d : workers_->take()) {
    // Its host arrays are uploaded (and freed) below, or dropped.
    struct Release {
      TileWorkers& workers;
      std::size_t bytes;
      ~Release() { workers.release(bytes); }
    } const release{*workers_, d.hostBytes};
    if (d.layer >= layers_.size() || layers_[d.layer].source == nullptr) continue;
    const TileSource& source = *layers_[d.layer].source;
    reportOnce(d.tile.diagnostics);
    Resident r;
    r.key = d.key;
    r.lastUsed = frameNumber_;
    if (d.tile && d.tile.value->fromDisk) ++fromDisk_;
    if (d.tile && d.tile.value->geometry.stats().pieces > 0) {
      r.featureIndex = std::move(d.tile.value->featureIndex);
      r.error = d.tile.value->groundError;
      r.layer = OverlayLayer::upload(std::move(d.tile.value->geometry));
      if (r.layer->broken()) {
        Diagnostics lost;
        lost.add({Severity::Error, source.cacheFolder(), source.name(), "",
                  "tile " + std::to_string(d.key.level) + "-" + std::to_string(d.key.x) + "-" +
                      std::to_string(d.key.y) + " could not be read from the disk cache; it is left out"});
        reportOnce(lost);
        r.layer.reset();
        layers_[d.layer].tiles[d.key.packed()] = std::move(r);
        ++count;
        continue;
      }
      r.box = r.layer->geometry().box3();
      if (d.key.level < source.finestLevel() || source.worldPieces()) {
        // Coarse tiles are built again after an edit (rarely drawn while editing close up), and
        // world pieces never edited: the GPU holds their arrays, the CPU need not. Their
        // footprints go too while the eye is farther than their size (times leanDistance) from
        // any piece that could be drawn z-fail (a tile drawn where one could is built again with
        // them, drawable).
        // World pieces are clipped from their arrays: those are their footprints.
        const glm::dvec3 grow = (r.box.second - r.box.first) * source.leanDistance();
        if (!renderer_->mayDrawZFail(frame.view, frame.settings, r.box.first - grow, r.box.second + grow)) {
          r.layer->releaseFootprints();
          released = true;
        } else if (!source.worldPieces()) {
          r.layer->releaseCpuArrays();
        }
      }
    }
    layers_[d.layer].tiles[d.key.packed()] = std::move(r);
    ++count;
  }
  if (released) giveBackFreedMemory();
  return count;
}

/// The chunks to draw per layer: each wanted tile if resident (at its width class or a wider
/// one), else the tile at a narrower class or its nearest resident ancestor (once), and the
/// jobs for the missing ones (and for tiles resident at a class more than 4× too wide). False
/// when a missing tile has nothing to stand in for it.
bool TileResidency::gather(const TechniqueFrame& frame, std::vector<std::vector<const OverlayLayer*>>& chunks,
                           std::vector<Job>& jobs, TechniqueFrameStats& stats) {
  bool standIn = true;
  chunks.assign(layers_.size(), {});
  frameTiles_.clear();
  wanted_.clear();
  wantedFinestLevel_ = 0;
  for (std::size_t i = 0; i < layers_.size(); ++i) {
    LayerState& l = layers_[i];
    if (i >= shown_.size() || shown_[i] == nullptr) continue;
    const TileSource& source = *l.source;
    const std::vector<TileKey> wanted = source.select(frame.view, frame.target.height, &stats.tilesCulled, errorScale_);
    stats.tileErrorPixels = source.errorPixels() * errorScale_;
    stats.tilesWanted += wanted.size();
    std::unordered_set<std::uint64_t> used;
    const auto use = [&](Resident& r) {
      r.lastUsed = frameNumber_;
      if (!used.insert(r.key.packed()).second) return;
      frameTiles_.insert({i, r.key.packed()});
      ++stats.tilesDrawn;
      stats.finestTileLevel = std::max(stats.finestTileLevel, r.key.level);
      if (r.layer) chunks[i].push_back(&*r.layer);
    };
    for (const TileKey& key : wanted) {
      wanted_.insert({i, key.packed()});
      wantedFinestLevel_ = std::max(wantedFinestLevel_, key.level);
      auto here = l.tiles.find(key.packed());
      bool near = false;  // its footprints are wanted whatever leanBox says (it may not hold all)
      if (here != l.tiles.end() && !drawable(here->second, frame)) {
        l.tiles.erase(here);  // built again with its footprints (near the eye now)
        here = l.tiles.end();
        near = true;
      }
      if (here != l.tiles.end() && here->second.key.width >= key.width) {
        // A wider class is exact too (its pieces shrink in the shader), only looser.
        if (here->second.key.width > key.width + 2) jobs.push_back({i, &source, key, farFrom(source, key, frame)});
        use(here->second);
        continue;
      }
      ++stats.tilesMissing;
      jobs.push_back({i, &source, key, !near && farFrom(source, key, frame)});
      bool found = here != l.tiles.end();  // too narrow for a still, fine in a flight
      if (found) use(here->second);
      for (TileKey a = key; a.level > 0 && !found;) {
        a = a.parent();
        if (auto it = l.tiles.find(a.packed()); it != l.tiles.end() && drawable(it->second, frame)) {
          use(it->second);
          found = true;
        }
      }
      standIn = standIn && found;
    }
  }
  return standIn;
}

/// Drops the least recently drawn tiles while over `budget` bytes (never those chosen for
/// this frame; those chosen and dropped for a coarser detail in it may go).
std::size_t TileResidency::evict(std::size_t budget) {
  std::size_t bytes = gpuBytes();
  if (bytes <= budget) return 0;
  std::vector<std::tuple<std::uint64_t, std::size_t, std::uint64_t>> order;  // (last used, layer, key)
  for (std::size_t i = 0; i < layers_.size(); ++i)
    for (const auto& [key, t] : layers_[i].tiles)
      if (frameTiles_.count({i, key}) == 0) order.emplace_back(t.lastUsed, i, key);
  std::sort(order.begin(), order.end());
  std::size_t evicted = 0;
  for (const auto& [used, layer, key] : order) {
    if (bytes <= budget) break;
    auto it = layers_[layer].tiles.find(key);
    bytes -= it->second.layer ? it->second.layer->stats().gpuBytes : 0;
    layers_[layer].tiles.erase(it);
    ++evicted;
  }
  if (evicted > 0) giveBackFreedMemory();
  return evicted;
}

}  // namespace gis::overlay
