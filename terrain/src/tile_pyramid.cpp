#include "terrain/tile_pyramid.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <span>
#include <type_traits>

#include <glm/common.hpp>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include "core/hash.hpp"
#include "geo/raster.hpp"
#include "terrain/geometric_error.hpp"

namespace gis::terrain {
namespace {

constexpr char kMagic[8] = {'S', 'G', 'I', 'S', 'P', 'Y', 'R', '\0'};
// 2: implausiblePosts; 3: DEMs in any CRS, mosaics; 4: checksums (header, node table and cell
// ranges, each tile)
constexpr std::uint32_t kVersion = 4;
constexpr std::size_t kHeaderBytes = 4096;

struct FileHeader {
  char magic[8];
  std::uint32_t version;
  std::int32_t chunkCells, rootLevel, pinnedLevel, pinnedTilesPerSide;
  std::int32_t width, height;
  std::int32_t band;
  double origin[2], step[2];
  std::uint64_t sourceBytes;
  std::int64_t sourceModifiedNs;
  std::uint64_t nodeCount, nodeTableOffset, cellRangeOffset, fileBytes, nodataPosts;
  std::int32_t cellRangeWidth, cellRangeHeight;
  std::uint32_t pathLength;
  char path[2048];
  std::uint64_t implausiblePosts;  ///< samples made nodata by implausibleHeightsToNodata
  std::uint64_t tableDigest;       ///< XXH3-64 of the node table, then the cell ranges (lo, hi)
  std::uint64_t headerDigest;      ///< XXH3-64 of this header with this field 0
};
static_assert(std::is_trivially_copyable_v<FileHeader> && sizeof(FileHeader) <= kHeaderBytes);

struct NodeRecord {
  float minHeight, maxHeight, geometricError;
  std::uint32_t hasData;
  std::uint64_t tileOffset;
  std::uint64_t tileDigest;  ///< XXH3-64 of the tile's heights, verified at every read
};
static_assert(sizeof(NodeRecord) == 32);

std::uint64_t headerDigestOf(FileHeader h) {
  h.headerDigest = 0;
  return XXH3_64bits(&h, sizeof(h));
}

std::uint64_t tableDigestOf(const std::vector<NodeRecord>& records, const std::vector<float>& lo,
                            const std::vector<float>& hi) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  XXH3_64bits_update(state, records.data(), records.size() * sizeof(NodeRecord));
  XXH3_64bits_update(state, lo.data(), lo.size() * sizeof(float));
  XXH3_64bits_update(state, hi.data(), hi.size() * sizeof(float));
  const std::uint64_t d = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return d;
}

std::string systemError(const std::string& what) { return what + ": " + std::strerror(errno); }

/// Repeats a positional read or write (pread/pwrite) until all bytes moved; false on error or
/// end of file.
template <typename Byte, typename Io>
bool transferAll(Io io, int fd, Byte* p, std::size_t bytes, std::uint64_t offset) {
  while (bytes > 0) {
    const ssize_t n = io(fd, p, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    bytes -= static_cast<std::size_t>(n);
    offset += static_cast<std::uint64_t>(n);
  }
  return true;
}

bool writeAll(int fd, const void* data, std::size_t bytes, std::uint64_t offset) {
  return transferAll(::pwrite, fd, static_cast<const char*>(data), bytes, offset);
}

bool readAll(int fd, void* data, std::size_t bytes, std::uint64_t offset) {
  return transferAll(::pread, fd, static_cast<char*>(data), bytes, offset);
}

/// Sequential writer with a large buffer.
class FileWriter {
 public:
  explicit FileWriter(int fd, std::uint64_t offset) : fd_(fd), offset_(offset) { buffer_.reserve(8u << 20); }
  [[nodiscard]] std::uint64_t offset() const { return offset_ + buffer_.size(); }
  bool write(const void* data, std::size_t bytes) {
    const char* p = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), p, p + bytes);
    return buffer_.size() < (8u << 20) || flush();
  }
  bool flush() {
    if (!writeAll(fd_, buffer_.data(), buffer_.size(), offset_)) return false;
    offset_ += buffer_.size();
    buffer_.clear();
    return true;
  }

 private:
  int fd_;
  std::uint64_t offset_;
  std::vector<char> buffer_;
};

struct NodeIndexer {
  std::vector<std::size_t> levelOffset;
  int rootLevel = 0;
  NodeIndexer(int root) : rootLevel(root) {
    std::size_t offset = 0;
    for (int level = 0; level <= root; ++level) {
      levelOffset.push_back(offset);
      const auto side = static_cast<std::size_t>(1) << (root - level);
      offset += side * side;
    }
    levelOffset.push_back(offset);
  }
  [[nodiscard]] std::size_t count() const { return levelOffset.back(); }
  [[nodiscard]] std::size_t operator()(const NodeId& n) const {
    const auto side = static_cast<std::size_t>(1) << (rootLevel - n.level);
    return levelOffset[static_cast<std::size_t>(n.level)] + static_cast<std::size_t>(n.y) * side +
           static_cast<std::size_t>(n.x);
  }
};

/// Streams rows of level-0 posts through every level of the pyramid. Level k keeps a band of
/// 2N + 1 of its rows (two tile rows); when the band is full it emits the level's tiles and node
/// records, computes the geometric errors of the level-(k+1) nodes over the band (the same
/// computation as TerrainQuadtree::computeLevel, on the same floats) and passes every second
/// row, every second post, to level k + 1.
class PyramidBuilder {
 public:
  PyramidBuilder(const TerrainGrid& geometry, int chunkCells, int rootLevel, int pinnedLevel, FileWriter& writer)
      : grid_(geometry), n_(chunkCells), root_(rootLevel), writer_(writer), index_(rootLevel) {
    nodes_.resize(index_.count());
    offsets_.assign(index_.count(), 0);
    digests_.assign(index_.count(), 0);
    for (int k = 0; k <= root_; ++k) {
      Level level;
      level.tiles = 1 << (root_ - k);
      level.posts = n_ * level.tiles + 1;
      level.bandRows = k == root_ ? n_ + 1 : 2 * n_ + 1;
      level.band.reserve(static_cast<std::size_t>(level.bandRows) * static_cast<std::size_t>(level.posts));
      level.pendingError.resize(static_cast<std::size_t>(level.tiles));
      levels_.push_back(std::move(level));
    }
    cellSize_ = 1 << pinnedLevel;
    cellWidth_ = std::max(1, (grid_.width - 1 + cellSize_ - 1) / cellSize_);
    cellHeight_ = std::max(1, (grid_.height - 1 + cellSize_ - 1) / cellSize_);
    const auto cells = static_cast<std::size_t>(cellWidth_) * static_cast<std::size_t>(cellHeight_);
    cellLo_.assign(cells, std::numeric_limits<float>::infinity());
    cellHi_.assign(cells, -std::numeric_limits<float>::infinity());
    window_.resize(static_cast<std::size_t>((2 * n_ + 1) * (2 * n_ + 1)));
    tile_.resize(static_cast<std::size_t>((n_ + 1) * (n_ + 1)));
  }

  [[nodiscard]] int paddedPosts() const { return levels_[0].posts; }

  /// Level-0 row `row` (paddedPosts() values, NaN beyond the DEM). False on a write error.
  bool pushLevel0Row(int row, std::span<const float> values) {
    if (row < grid_.height) {
      addToCellRanges(row, values);
      for (int c = 0; c < grid_.width; ++c) nodata_ += std::isnan(values[static_cast<std::size_t>(c)]) ? 1u : 0u;
    }
    return pushRow(0, values);
  }

  const std::vector<NodeInfo>& nodes() const { return nodes_; }
  const std::vector<std::uint64_t>& offsets() const { return offsets_; }
  const std::vector<std::uint64_t>& digests() const { return digests_; }
  [[nodiscard]] std::size_t tiles() const { return tileCount_; }
  [[nodiscard]] std::uint64_t nodataPosts() const { return nodata_; }
  [[nodiscard]] int cellWidth() const { return cellWidth_; }
  [[nodiscard]] int cellHeight() const { return cellHeight_; }
  const std::vector<float>& cellLo() const { return cellLo_; }
  const std::vector<float>& cellHi() const { return cellHi_; }

 private:
  struct Level {
    int tiles = 1, posts = 0, bandRows = 0;
    int baseRow = 0;  ///< level row of the band's first row
    std::vector<float> band;
    std::vector<std::vector<float>> pendingError;  ///< per tile row: errors computed one level down
  };

  void addToCellRanges(int row, std::span<const float> values) {
    const int s = cellSize_;
    const int cy0 = std::min(row / s, cellHeight_ - 1);
    const int cy1 = row % s == 0 && row > 0 ? row / s - 1 : cy0;
    for (int c = 0; c < grid_.width; ++c) {
      const float v = values[static_cast<std::size_t>(c)];
      if (std::isnan(v)) continue;
      const int cx0 = std::min(c / s, cellWidth_ - 1);
      const int cx1 = c % s == 0 && c > 0 ? c / s - 1 : cx0;
      for (int cy : {cy0, cy1}) {
        for (int cx : {cx0, cx1}) {
          const auto i =
              static_cast<std::size_t>(cy) * static_cast<std::size_t>(cellWidth_) + static_cast<std::size_t>(cx);
          cellLo_[i] = std::min(cellLo_[i], v);
          cellHi_[i] = std::max(cellHi_[i], v);
        }
      }
    }
  }

  bool pushRow(int k, std::span<const float> values) {
    Level& level = levels_[static_cast<std::size_t>(k)];
    level.band.insert(level.band.end(), values.begin(), values.end());
    if (level.band.size() < static_cast<std::size_t>(level.bandRows) * static_cast<std::size_t>(level.posts)) {
      return true;
    }
    return process(k);
  }

  [[nodiscard]] float bandAt(const Level& level, int row, int col) const {
    return level
        .band[static_cast<std::size_t>(row) * static_cast<std::size_t>(level.posts) + static_cast<std::size_t>(col)];
  }

  bool process(int k) {
    Level& level = levels_[static_cast<std::size_t>(k)];
    const int b = level.baseRow / (2 * n_);
    const int tileRows = k == root_ ? 1 : 2;
    for (int tr = 0; tr < tileRows; ++tr) {
      const int t = 2 * b + tr;
      for (int x = 0; x < level.tiles; ++x) {
        const NodeId id{k, x, t};
        NodeInfo info;
        float lo = std::numeric_limits<float>::infinity(), hi = -lo;
        for (int j = 0; j <= n_; ++j) {
          for (int i = 0; i <= n_; ++i) {
            const float v = bandAt(level, tr * n_ + j, x * n_ + i);
            tile_[static_cast<std::size_t>(j * (n_ + 1) + i)] = v;
            if (k == 0 && !std::isnan(v)) {
              lo = std::min(lo, v);
              hi = std::max(hi, v);
            }
          }
        }
        if (k > 0) {
          for (const NodeId& c : id.children()) {
            const NodeInfo& child = nodes_[index_(c)];
            if (!child.hasData) continue;
            lo = std::min(lo, child.minHeight);
            hi = std::max(hi, child.maxHeight);
          }
        }
        info.hasData = lo <= hi;
        if (info.hasData) {
          info.minHeight = lo;
          info.maxHeight = hi;
          if (k > 0) info.geometricError = level.pendingError[static_cast<std::size_t>(t)][static_cast<std::size_t>(x)];
          offsets_[index_(id)] = writer_.offset();
          digests_[index_(id)] = XXH3_64bits(tile_.data(), tile_.size() * sizeof(float));
          if (!writer_.write(tile_.data(), tile_.size() * sizeof(float))) return false;
          ++tileCount_;
        }
        nodes_[index_(id)] = info;
      }
      level.pendingError[static_cast<std::size_t>(t)] = {};
    }
    if (k == root_) return true;

    // Geometric errors of the level-(k+1) nodes of tile row b.
    Level& up = levels_[static_cast<std::size_t>(k + 1)];
    std::vector<float>& errors = up.pendingError[static_cast<std::size_t>(b)];
    errors.assign(static_cast<std::size_t>(up.tiles), 0.0F);
    const glm::dvec2 spacing = glm::abs(grid_.step) * static_cast<double>(1 << k);
    for (int x = 0; x < up.tiles; ++x) {
      const NodeId id{k + 1, x, b};
      float childError = 0.0F;
      bool hasData = false;
      for (const NodeId& c : id.children()) {
        const NodeInfo& child = nodes_[index_(c)];
        if (!child.hasData) continue;
        hasData = true;
        childError = std::max(childError, child.geometricError);
      }
      if (!hasData) continue;
      for (int j = 0; j <= 2 * n_; ++j) {
        for (int i = 0; i <= 2 * n_; ++i) {
          window_[static_cast<std::size_t>(j * (2 * n_ + 1) + i)] = bandAt(level, j, 2 * n_ * x + i);
        }
      }
      const double total = simplificationError(window_, n_, spacing) + static_cast<double>(childError);
      errors[static_cast<std::size_t>(x)] =
          total > 0.0 ? std::nextafter(static_cast<float>(total), std::numeric_limits<float>::infinity()) : 0.0F;
    }

    // Every second row and post to the next level (the band's first row went up already,
    // as the previous band's last).
    std::vector<float> row(static_cast<std::size_t>(up.posts));
    for (int r = b == 0 ? 0 : 2; r <= 2 * n_; r += 2) {
      for (int c = 0; c < up.posts; ++c) row[static_cast<std::size_t>(c)] = bandAt(level, r, 2 * c);
      if (!pushRow(k + 1, row)) return false;
    }
    // Keep the last row: it is the first of the next band.
    std::copy(level.band.end() - level.posts, level.band.end(), level.band.begin());
    level.band.resize(static_cast<std::size_t>(level.posts));
    level.baseRow += 2 * n_;
    return true;
  }

  const TerrainGrid& grid_;
  int n_, root_;
  FileWriter& writer_;
  NodeIndexer index_;
  std::vector<Level> levels_;
  std::vector<NodeInfo> nodes_;
  std::vector<std::uint64_t> offsets_;
  std::vector<std::uint64_t> digests_;
  std::size_t tileCount_ = 0;
  std::uint64_t nodata_ = 0;
  int cellSize_ = 1, cellWidth_ = 1, cellHeight_ = 1;
  std::vector<float> cellLo_, cellHi_;
  std::vector<float> window_, tile_;
};

std::string sourceMismatch(const FileHeader& h, const PyramidSource& s) {
  const std::string stored(h.path, std::min<std::size_t>(h.pathLength, sizeof(h.path)));
  if (stored != s.demPath) return "built from " + stored;
  if (h.band != s.band) return "built from band " + std::to_string(h.band);
  if (h.sourceBytes != s.bytes || h.sourceModifiedNs != s.modifiedNs) return "the DEM changed since it was built";
  if (h.chunkCells != s.chunkCells) return "built with chunks of " + std::to_string(h.chunkCells) + " cells";
  if (h.pinnedTilesPerSide != s.pinnedTilesPerSide) return "built with another pinned level";
  return {};
}

}  // namespace

int quadtreeRootLevel(int width, int height, int chunkCells) {
  const int cells = std::max(width, height) - 1;
  int root = 0;
  while ((chunkCells << root) < cells) ++root;
  return root;
}

int pinnedLevelFor(int rootLevel, int tilesPerSide) {
  int level = rootLevel;
  while (level > 0 && (1 << (rootLevel - level + 1)) <= tilesPerSide) --level;
  return level;
}

Result<PyramidSource> PyramidSource::of(const std::string& demPath, int band, int chunkCells) {
  struct stat st {};
  const std::string absolute = std::filesystem::absolute(demPath).lexically_normal().string();
  if (::stat(absolute.c_str(), &st) != 0) {
    return Result<PyramidSource>::failure({Severity::Error, demPath, "", "", systemError("cannot read the DEM")});
  }
  PyramidSource s;
  s.demPath = absolute;
  s.band = band;
  s.bytes = static_cast<std::uint64_t>(st.st_size);
  s.modifiedNs = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
  s.chunkCells = chunkCells;
  s.dem.paths = {absolute};
  s.dem.band = band;
  Result<PyramidSource> r;
  r.value = std::move(s);
  return r;
}

PyramidSource PyramidSource::of(const geo::DemSource& dem, int chunkCells) {
  PyramidSource s;
  s.dem = dem.spec();
  s.demPath = dem.label();
  s.band = dem.spec().band;
  for (const std::string& f : dem.files()) {
    struct stat st {};
    if (::stat(f.c_str(), &st) == 0) s.bytes += static_cast<std::uint64_t>(st.st_size);
  }
  // A hash of the fingerprint: any file added, removed, resized or touched changes it.
  s.modifiedNs = static_cast<std::int64_t>(stableHash(dem.fingerprint()) >> 1);
  s.chunkCells = chunkCells;
  return s;
}

Result<PyramidBuildStats> buildTilePyramid(const PyramidSource& source, const geo::SceneFrame& frame,
                                           const std::string& path, const PyramidProgress& progress) {
  Result<geo::DemSource> dem = geo::DemSource::open(source.dem);
  if (!dem) {
    Result<PyramidBuildStats> r;
    r.diagnostics = std::move(dem.diagnostics);
    return r;
  }
  Result<geo::FrameDem> inFrame = geo::FrameDem::open(*dem, frame);
  if (!inFrame) {
    Result<PyramidBuildStats> r;
    r.diagnostics = std::move(dem.diagnostics);
    r.diagnostics.append(inFrame.diagnostics);
    return r;
  }
  return buildTilePyramid(*inFrame, source, frame, path, progress);
}

Result<PyramidBuildStats> buildTilePyramid(geo::FrameDem& reader, const PyramidSource& source,
                                           const geo::SceneFrame& frame, const std::string& path,
                                           const PyramidProgress& progress) {
  const auto start = std::chrono::steady_clock::now();
  auto fail = [&](const std::string& message) {
    return Result<PyramidBuildStats>::failure({Severity::Error, path, "", "", message});
  };
  const int n = source.chunkCells;
  if (n < 2 || (n & (n - 1)) != 0 || n > 1024) return fail("chunk size must be a power of two in 2 … 1024");
  Result<TerrainGrid> geometry = gridGeometry(reader.info(), frame);
  if (!geometry) {
    Result<PyramidBuildStats> r;
    r.diagnostics = std::move(geometry.diagnostics);
    return r;
  }
  const int root = quadtreeRootLevel(geometry->width, geometry->height, n);
  const int pinned = pinnedLevelFor(root, source.pinnedTilesPerSide);

  const std::string partial = path + ".partial-" + std::to_string(::getpid());
  const int fd = ::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail(systemError("cannot create " + partial));
  struct Closer {
    int fd;
    std::string partial;
    bool keep = false;
    ~Closer() {
      ::close(fd);
      if (!keep) ::unlink(partial.c_str());
    }
  } closer{fd, partial};

  FileWriter writer(fd, kHeaderBytes);
  PyramidBuilder builder(*geometry, n, root, pinned, writer);
  const int padded = builder.paddedPosts();
  const int strip = std::max(1, std::min(geometry->height, (4 << 20) / std::max(1, geometry->width)));
  std::vector<float> rows, row(static_cast<std::size_t>(padded), std::numeric_limits<float>::quiet_NaN());
  Diagnostics diagnostics;
  std::uint64_t implausible = 0;
  for (int r0 = 0; r0 < padded; r0 += strip) {
    const int count = std::min(strip, padded - r0);
    const int real = std::clamp(geometry->height - r0, 0, count);
    if (real > 0 && !reader.read(r0, real, rows, diagnostics)) {
      Result<PyramidBuildStats> r;
      r.diagnostics = std::move(diagnostics);
      return r;
    }
    if (real > 0) implausible += implausibleHeightsToNodata(std::span<float>(rows.data(), rows.size()));
    for (int i = 0; i < count; ++i) {
      if (i < real) {
        std::copy_n(rows.begin() + static_cast<std::ptrdiff_t>(i) * geometry->width, geometry->width, row.begin());
      } else {
        std::fill(row.begin(), row.begin() + geometry->width, std::numeric_limits<float>::quiet_NaN());
      }
      if (!builder.pushLevel0Row(r0 + i, row)) return fail(systemError("cannot write " + partial));
    }
    if (progress) progress(static_cast<double>(r0 + count) / padded);
  }

  // Node table and cell ranges after the tiles; the header last.
  std::vector<NodeRecord> records(builder.nodes().size());
  for (std::size_t i = 0; i < records.size(); ++i) {
    const NodeInfo& info = builder.nodes()[i];
    records[i] = {info.minHeight,         info.maxHeight,       info.geometricError,
                  info.hasData ? 1u : 0u, builder.offsets()[i], builder.digests()[i]};
  }
  FileHeader header{};
  std::memcpy(header.magic, kMagic, sizeof(kMagic));
  header.version = kVersion;
  header.chunkCells = n;
  header.rootLevel = root;
  header.pinnedLevel = pinned;
  header.pinnedTilesPerSide = source.pinnedTilesPerSide;
  header.width = geometry->width;
  header.height = geometry->height;
  header.band = source.band;
  header.origin[0] = geometry->origin.x;
  header.origin[1] = geometry->origin.y;
  header.step[0] = geometry->step.x;
  header.step[1] = geometry->step.y;
  header.sourceBytes = source.bytes;
  header.sourceModifiedNs = source.modifiedNs;
  header.nodeCount = records.size();
  header.nodataPosts = builder.nodataPosts();
  header.implausiblePosts = implausible;
  header.nodeTableOffset = writer.offset();
  if (!writer.write(records.data(), records.size() * sizeof(NodeRecord))) return fail(systemError("cannot write"));
  header.cellRangeOffset = writer.offset();
  header.cellRangeWidth = builder.cellWidth();
  header.cellRangeHeight = builder.cellHeight();
  if (!writer.write(builder.cellLo().data(), builder.cellLo().size() * sizeof(float)) ||
      !writer.write(builder.cellHi().data(), builder.cellHi().size() * sizeof(float)) || !writer.flush()) {
    return fail(systemError("cannot write " + partial));
  }
  header.fileBytes = writer.offset();
  header.tableDigest = tableDigestOf(records, builder.cellLo(), builder.cellHi());
  if (source.demPath.size() > sizeof(header.path)) return fail("DEM path too long for the pyramid header");
  header.pathLength = static_cast<std::uint32_t>(source.demPath.size());
  std::memcpy(header.path, source.demPath.data(), source.demPath.size());
  header.headerDigest = headerDigestOf(header);
  std::vector<char> headerBytes(kHeaderBytes, 0);
  std::memcpy(headerBytes.data(), &header, sizeof(header));
  if (!writeAll(fd, headerBytes.data(), headerBytes.size(), 0)) return fail(systemError("cannot write " + partial));
  if (::rename(partial.c_str(), path.c_str()) != 0) return fail(systemError("cannot rename " + partial));
  closer.keep = true;

  Result<PyramidBuildStats> r;
  r.value = PyramidBuildStats{std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                              header.fileBytes, builder.tiles()};
  r.diagnostics = std::move(diagnostics);
  return r;
}

Result<std::shared_ptr<const TilePyramidFile>> TilePyramidFile::open(const std::string& path,
                                                                     const PyramidSource& expected) {
  using R = Result<std::shared_ptr<const TilePyramidFile>>;
  auto fail = [&](const std::string& message) { return R::failure({Severity::Error, path, "", "", message}); };
  std::shared_ptr<TilePyramidFile> file(new TilePyramidFile());
  file->path_ = path;
  file->fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (file->fd_ < 0) return fail(systemError("cannot open the tile pyramid"));
  struct stat st {};
  if (::fstat(file->fd_, &st) != 0) return fail(systemError("cannot stat the tile pyramid"));
  FileHeader h{};
  if (static_cast<std::size_t>(st.st_size) < kHeaderBytes || !readAll(file->fd_, &h, sizeof(h), 0)) {
    return fail("not a tile pyramid (too short)");
  }
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0) return fail("not a tile pyramid");
  if (h.version != kVersion) return fail("tile pyramid of format " + std::to_string(h.version));
  if (h.headerDigest != headerDigestOf(h)) return fail("tile pyramid damaged: its header does not match its checksum");
  if (h.fileBytes != static_cast<std::uint64_t>(st.st_size)) return fail("tile pyramid is truncated");
  if (const std::string why = sourceMismatch(h, expected); !why.empty()) return fail("tile pyramid is stale: " + why);
  if (h.chunkCells < 2 || h.rootLevel < 0 || h.rootLevel > 24 || h.width < 2 || h.height < 2 ||
      quadtreeRootLevel(h.width, h.height, h.chunkCells) != h.rootLevel || h.pinnedLevel < 0 ||
      h.pinnedLevel > h.rootLevel) {
    return fail("tile pyramid header is inconsistent");
  }
  file->fileBytes_ = h.fileBytes;
  file->nodataPosts_ = h.nodataPosts;
  file->implausiblePosts_ = h.implausiblePosts;
  file->chunkCells_ = h.chunkCells;
  file->rootLevel_ = h.rootLevel;
  file->pinnedLevel_ = h.pinnedLevel;
  file->geometry_.width = h.width;
  file->geometry_.height = h.height;
  file->geometry_.origin = glm::dvec2(h.origin[0], h.origin[1]);
  file->geometry_.step = glm::dvec2(h.step[0], h.step[1]);
  const NodeIndexer index(h.rootLevel);
  file->levelOffset_ = index.levelOffset;
  if (h.nodeCount != index.count()) return fail("tile pyramid node table has the wrong size");
  std::vector<NodeRecord> records(h.nodeCount);
  if (h.nodeTableOffset + records.size() * sizeof(NodeRecord) > h.fileBytes ||
      !readAll(file->fd_, records.data(), records.size() * sizeof(NodeRecord), h.nodeTableOffset)) {
    return fail("cannot read the tile pyramid's node table");
  }
  file->nodes_.resize(records.size());
  file->tileOffsets_.resize(records.size());
  file->tileDigests_.resize(records.size());
  const std::uint64_t tileBytes = file->tilePosts() * sizeof(float);
  for (std::size_t i = 0; i < records.size(); ++i) {
    const NodeRecord& rec = records[i];
    file->nodes_[i] = {rec.minHeight, rec.maxHeight, rec.geometricError, rec.hasData != 0};
    file->tileOffsets_[i] = rec.tileOffset;
    file->tileDigests_[i] = rec.tileDigest;
    if ((rec.hasData != 0) != (rec.tileOffset != 0) ||
        (rec.tileOffset != 0 && (rec.tileOffset < kHeaderBytes || rec.tileOffset + tileBytes > h.nodeTableOffset))) {
      return fail("tile pyramid node table is corrupt");
    }
  }
  file->cellRangeWidth_ = h.cellRangeWidth;
  file->cellRangeHeight_ = h.cellRangeHeight;
  const auto cells = static_cast<std::size_t>(std::max(0, h.cellRangeWidth)) *
                     static_cast<std::size_t>(std::max(0, h.cellRangeHeight));
  file->cellLo_.resize(cells);
  file->cellHi_.resize(cells);
  if (cells == 0 || h.cellRangeOffset + 2 * cells * sizeof(float) > h.fileBytes ||
      !readAll(file->fd_, file->cellLo_.data(), cells * sizeof(float), h.cellRangeOffset) ||
      !readAll(file->fd_, file->cellHi_.data(), cells * sizeof(float), h.cellRangeOffset + cells * sizeof(float))) {
    return fail("cannot read the tile pyramid's cell ranges");
  }
  if (h.tableDigest != tableDigestOf(records, file->cellLo_, file->cellHi_))
    return fail("tile pyramid damaged: its node table does not match its checksum");
  file->source_ = expected;
  R r;
  r.value = std::move(file);
  return r;
}

TilePyramidFile::~TilePyramidFile() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t TilePyramidFile::nodeIndex(const NodeId& n) const {
  const auto side = static_cast<std::size_t>(1) << (rootLevel_ - n.level);
  return levelOffset_[static_cast<std::size_t>(n.level)] + static_cast<std::size_t>(n.y) * side +
         static_cast<std::size_t>(n.x);
}

bool TilePyramidFile::readTile(const NodeId& n, std::span<float> out, Diagnostics& diagnostics) const {
  const std::size_t i = nodeIndex(n);
  const std::uint64_t offset = tileOffsets_[i];
  if (offset == 0 || out.size() != tilePosts()) {
    std::fill(out.begin(), out.end(), std::numeric_limits<float>::quiet_NaN());
    return offset == 0;
  }
  const std::string name = std::to_string(n.level) + "/" + std::to_string(n.x) + "/" + std::to_string(n.y);
  const auto read = [&] {
    return readAll(fd_, out.data(), out.size() * sizeof(float), offset) &&
           XXH3_64bits(out.data(), out.size() * sizeof(float)) == tileDigests_[i];
  };
  if (read()) return true;
  // A tile that cannot be read or does not match its checksum: the pyramid is built again from
  // the DEM (once, whoever finds it first) and the tile read from the new file, which the same
  // descriptor then holds (dup2): the builder is deterministic, so every offset and checksum is
  // the one this file's table has.
  {
    std::lock_guard lock(rebuildMutex_);
    if (rebuilds_ == 0 && rebuild_) {
      diagnostics.add({Severity::Warning, path_, "", "",
                       "tile pyramid damaged: tile " + name + " does not match its checksum; rebuilt from the DEM"});
      ++rebuilds_;
      if (rebuild_()) {
        Result<std::shared_ptr<const TilePyramidFile>> fresh = open(path_, source_);
        if (fresh && (*fresh)->tileOffsets_ == tileOffsets_ && (*fresh)->tileDigests_ == tileDigests_) {
          const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
          if (fd >= 0) {
            ::dup2(fd, fd_);
            ::close(fd);
          }
        }
      }
    }
  }
  if (read()) return true;
  diagnostics.add(
      {Severity::Error, path_, "", "",
       "tile " + name + " cannot be read (" +
           (readAll(fd_, out.data(), out.size() * sizeof(float), offset) ? std::string("damaged")
                                                                         : std::string(std::strerror(errno))) +
           ")"});
  return false;
}

void TilePyramidFile::setRebuild(std::function<bool()> rebuild) const {
  std::lock_guard lock(rebuildMutex_);
  rebuild_ = std::move(rebuild);
}

}  // namespace gis::terrain
