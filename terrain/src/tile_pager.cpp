#include "terrain/tile_pager.hpp"

#include <limits>

#include "core/log.hpp"

namespace gis::terrain {

namespace {

/// The log, at each message's severity.
void say(const Diagnostics& diagnostics) {
  for (const Diagnostic& d : diagnostics.items()) {
    if (d.severity == Severity::Error) {
      logError(d.toString());
    } else {
      logWarning(d.toString());
    }
  }
}

}  // namespace

TilePager::TilePager(std::shared_ptr<const TilePyramidFile> file, std::size_t budgetBytes)
    : file_(std::move(file)), budget_(budgetBytes) {
  const TilePyramidFile& f = *file_;
  for (int level = f.pinnedLevel(); level <= f.rootLevel(); ++level) {
    const int side = 1 << (f.rootLevel() - level);
    for (int y = 0; y < side; ++y) {
      for (int x = 0; x < side; ++x) {
        const NodeId id{level, x, y};
        if (!f.hasTile(id)) continue;
        std::vector<float> data(f.tilePosts());
        Diagnostics diagnostics;
        const bool read = f.readTile(id, data, diagnostics);
        say(diagnostics);
        if (!read) {
          ++readErrors_;
          std::fill(data.begin(), data.end(), std::numeric_limits<float>::quiet_NaN());
        }
        pinnedBytes_ += data.size() * sizeof(float);
        pinned_.emplace(id.key(), std::move(data));
      }
    }
  }
  worker_ = std::thread([this] { run(); });
}

TilePager::~TilePager() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  worker_.join();
}

const float* TilePager::pinnedTile(const NodeId& n) const {
  const auto it = pinned_.find(n.key());
  return it == pinned_.end() ? nullptr : it->second.data();
}

bool TilePager::resident(const NodeId& n) {
  if (!file_->hasTile(n) || n.level >= file_->pinnedLevel()) return true;
  std::lock_guard lock(mutex_);
  const auto it = cache_.find(n.key());
  if (it == cache_.end()) return false;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return true;
}

TileData TilePager::find(const NodeId& n) {
  if (n.level >= file_->pinnedLevel()) {
    const auto it = pinned_.find(n.key());
    if (it == pinned_.end()) return nullptr;
    // Pinned tiles live as long as the pager; hand out a non-owning pointer to them.
    return TileData(TileData{}, &it->second);
  }
  std::lock_guard lock(mutex_);
  const auto it = cache_.find(n.key());
  if (it == cache_.end()) return nullptr;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return it->second.data;
}

TileData TilePager::load(const NodeId& n) {
  if (!file_->hasTile(n)) return nullptr;
  if (TileData found = find(n)) return found;
  TileData data = read(n);
  std::lock_guard lock(mutex_);
  const auto it = cache_.find(n.key());  // another thread may have loaded it meanwhile
  if (it != cache_.end()) return it->second.data;
  insertLocked(n, data);
  return data;
}

TileData TilePager::read(const NodeId& n) {
  auto data = std::make_shared<std::vector<float>>(file_->tilePosts());
  Diagnostics diagnostics;
  const bool read = file_->readTile(n, *data, diagnostics);
  say(diagnostics);  // a damaged tile rebuilt (a warning), or one that cannot be read
  if (!read) {
    // Drawn as a hole rather than retried every frame; the log names the file and the tile.
    std::fill(data->begin(), data->end(), std::numeric_limits<float>::quiet_NaN());
    std::lock_guard lock(mutex_);
    ++readErrors_;
  }
  return data;
}

void TilePager::insertLocked(const NodeId& n, TileData data) {
  lru_.push_front(n.key());
  cacheBytes_ += data->size() * sizeof(float);
  cache_.emplace(n.key(), Entry{std::move(data), lru_.begin()});
  ++loads_;
}

void TilePager::request(std::span<const NodeId> wanted) {
  {
    std::lock_guard lock(mutex_);
    queue_.clear();
    for (const NodeId& n : wanted) {
      if (n.level >= file_->pinnedLevel() || !file_->hasTile(n)) continue;
      if (cache_.count(n.key()) != 0 || inFlight_.count(n.key()) != 0) continue;
      queue_.push_back(n);
    }
  }
  wake_.notify_one();
}

void TilePager::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const NodeId n = queue_.front();
    queue_.pop_front();
    inFlight_.emplace(n.key(), true);
    busy_ = true;
    lock.unlock();
    TileData data = read(n);
    lock.lock();
    loaded_.emplace_back(n, std::move(data));
    busy_ = false;
    idle_.notify_all();
  }
}

std::size_t TilePager::update() {
  std::lock_guard lock(mutex_);
  std::size_t added = 0;
  for (auto& [n, data] : loaded_) {
    inFlight_.erase(n.key());
    if (cache_.count(n.key()) != 0) continue;
    insertLocked(n, std::move(data));
    ++added;
  }
  loaded_.clear();
  while (cacheBytes_ > budget_ && !lru_.empty()) {
    const auto it = cache_.find(lru_.back());
    cacheBytes_ -= it->second.data->size() * sizeof(float);
    cache_.erase(it);
    lru_.pop_back();
    ++evictions_;
  }
  return added;
}

void TilePager::waitIdle() {
  {
    std::unique_lock lock(mutex_);
    idle_.wait(lock, [&] { return queue_.empty() && !busy_; });
  }
  update();
}

TilePagerStats TilePager::stats() const {
  std::lock_guard lock(mutex_);
  TilePagerStats s;
  s.residentTiles = cache_.size();
  s.residentBytes = cacheBytes_;
  s.pinnedTiles = pinned_.size();
  s.pinnedBytes = pinnedBytes_;
  s.pending = queue_.size() + inFlight_.size();
  s.loads = loads_;
  s.evictions = evictions_;
  s.readErrors = readErrors_;
  return s;
}

}  // namespace gis::terrain
