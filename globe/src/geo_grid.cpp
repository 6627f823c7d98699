#include "globe/geo_grid.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <unordered_map>

#include <fcntl.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include "core/hash.hpp"
#include "core/log.hpp"
#include "geo/checked_file.hpp"
#include "geo/gdal_support.hpp"
#include "geo/raster.hpp"

namespace gis::globe {

namespace {

/// Bytes a post of a GeoGrid takes while it is read and kept: the heights (4), the min/max
/// pyramid (8 · 4/3) and the warped grid they are read from (4), rounded up.
constexpr double kBytesPerPost = 20.0;

/// A min/max pyramid: level 0 as given (w × h cells, row-major), each next level's cell the
/// union of 2 × 2 of the level below, up to one cell.
void buildMinMaxPyramid(std::vector<std::pair<float, float>> level0, int w, int h,
                        std::vector<std::vector<std::pair<float, float>>>& pyramid,
                        std::vector<std::pair<int, int>>& sizes) {
  pyramid.push_back(std::move(level0));
  sizes.emplace_back(w, h);
  while (w > 1 || h > 1) {
    const int nw = (w + 1) / 2, nh = (h + 1) / 2;
    const auto& prev = pyramid.back();
    std::vector<std::pair<float, float>> next(static_cast<std::size_t>(nw) * static_cast<std::size_t>(nh),
                                              {std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()});
    for (int r = 0; r < h; ++r) {
      for (int c = 0; c < w; ++c) {
        const auto& v = prev[static_cast<std::size_t>(r) * static_cast<std::size_t>(w) + static_cast<std::size_t>(c)];
        auto& o =
            next[static_cast<std::size_t>(r / 2) * static_cast<std::size_t>(nw) + static_cast<std::size_t>(c / 2)];
        o.first = std::min(o.first, v.first);
        o.second = std::max(o.second, v.second);
      }
    }
    pyramid.push_back(std::move(next));
    sizes.emplace_back(nw, nh);
    w = nw;
    h = nh;
  }
}

struct TransformCloser {
  void operator()(OGRCoordinateTransformation* t) const { OGRCoordinateTransformation::DestroyCT(t); }
};
using TransformPtr = std::unique_ptr<OGRCoordinateTransformation, TransformCloser>;

using geo::detail::DatasetPtr;
using geo::detail::QuietGdal;
using geo::detail::TranslateOptions;
using geo::detail::WarpOptions;

OGRSpatialReference traditional(const char* userInput) {
  OGRSpatialReference srs;
  srs.SetFromUserInput(userInput);
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

std::string format(double v, int precision = 6) {
  std::ostringstream out;
  out.precision(precision);
  out << v;
  return out.str();
}

/// The vertical CRS of a compound CRS (its VERT_CS), if it has one.
std::optional<OGRSpatialReference> verticalPart(const OGRSpatialReference& srs) {
  if (srs.IsCompound() == 0) return std::nullopt;
  const OGR_SRSNode* node = srs.GetAttrNode("VERT_CS");
  if (node == nullptr) return std::nullopt;
  char* wkt = nullptr;
  if (node->exportToWkt(&wkt) != OGRERR_NONE || wkt == nullptr) return std::nullopt;
  OGRSpatialReference vertical;
  const OGRErr err = vertical.importFromWkt(wkt);
  CPLFree(wkt);
  if (err != OGRERR_NONE) return std::nullopt;
  return vertical;
}

/// From (lon, lat, height above `vertical`) on WGS 84 to (lon, lat, height above the ellipsoid),
/// by PROJ with no ballpark operation: a missing geoid grid is an error, not a silent h = H.
Result<TransformPtr> geoidTransform(const OGRSpatialReference& vertical, const std::string& what,
                                    const std::string& grid) {
  Result<TransformPtr> out;
  QuietGdal quiet;
  const OGRSpatialReference wgs84 = traditional("EPSG:4326");
  OGRSpatialReference source;
  source.SetCompoundCS(("WGS 84 + " + what).c_str(), &wgs84, &vertical);
  source.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const OGRSpatialReference target = traditional("EPSG:4979");
  OGRCoordinateTransformationOptions options;
  options.SetBallparkAllowed(false);
  TransformPtr t(OGRCreateCoordinateTransformation(&source, &target, options));
  // A probe where every geoid model is far from the ellipsoid (EGM96: N = 17.2 m at 0°, 0°).
  double x = 0.0, y = 0.0, z = 0.0;
  int ok = 0;
  if (t) ok = t->Transform(1, &x, &y, &z, nullptr, &ok) ? ok : 0;
  if (!t || ok == 0 || !std::isfinite(z) || z == 0.0) {
    out.diagnostics.add({Severity::Error,
                         {},
                         {},
                         {},
                         "cannot convert " + what +
                             " heights to heights above the ellipsoid: PROJ has no usable "
                             "transformation (" +
                             QuietGdal::lastMessage("no message") + ")" +
                             (grid.empty() ? std::string()
                                           : "; it needs the geoid grid " + grid +
                                                 ", which is not installed (Debian's proj-data ships EGM96's "
                                                 "egm96_15.gtx only)")});
    return out;
  }
  out.value = std::move(t);
  return out;
}

/// The conversion of a tile's raw samples to metres: (raw · scale + offset) · metresPerUnit.
struct HeightConversion {
  double scale = 1.0, offset = 0.0, metresPerUnit = 1.0;
  [[nodiscard]] bool identity() const { return scale == 1.0 && offset == 0.0 && metresPerUnit == 1.0; }
};

HeightConversion heightConversion(GDALRasterBand& band, const OGRSpatialReference* srs, double unitOverride) {
  HeightConversion c;
  int has = 0;
  const double scale = band.GetScale(&has);
  if (has != 0 && std::isfinite(scale) && scale != 0.0) c.scale = scale;
  has = 0;
  const double offset = band.GetOffset(&has);
  if (has != 0 && std::isfinite(offset)) c.offset = offset;
  if (unitOverride > 0.0) {
    c.metresPerUnit = unitOverride;
  } else {
    const char* unitType = band.GetUnitType();
    const std::string unit = unitType != nullptr ? unitType : "";
    if (!unit.empty()) {
      const double m = geo::metresPerHeightUnit(unit);
      if (m > 0.0) c.metresPerUnit = m;
    } else if (srs != nullptr && srs->IsCompound() != 0) {
      const double toMetre = srs->GetTargetLinearUnits("VERT_CS");
      if (toMetre > 0.0 && std::isfinite(toMetre)) c.metresPerUnit = toMetre;
    }
  }
  return c;
}

/// Windows of the grid read from the DEM: warped (bilinear, exact transformation, nodata kept out
/// of the heights), holes at height 0 of the DEM's datum, converted to the ellipsoid. Each post
/// depends on its own position, so windows give the posts the whole grid gives; except beside
/// nodata, where GDAL's bilinear kernel at a source cell's centre may or may not reach the nodata
/// neighbour by the rounding of the window's offset, and keeps or drops the post with it. The
/// same window always gives the same posts, so a paged grid's damaged block is read again from
/// here (GeoGrid::Paged::repair) and is the block that was written.
struct GridWindows {
  std::vector<DatasetPtr> files, bands;
  std::vector<GDALDatasetH> handles;
  GDALDriver* mem = nullptr;
  OGRSpatialReference wgs84;
  TransformPtr toEllipsoid;  ///< null: heights above the ellipsoid already
  double west = 0.0, north = 0.0, step = 1.0;
  std::size_t holes = 0, failed = 0;  ///< posts left at 0 (nodata) and posts not converted

  /// Posts [x0, x0 + w) × [y0, y0 + h), row-major, into `posts`; "" or what went wrong.
  std::string read(int x0, int y0, int w, int h, std::vector<float>& posts) {
    DatasetPtr grid(mem->Create("", w, h, 1, GDT_Float32, nullptr));
    if (!grid) return "cannot allocate the DEM grid: " + QuietGdal::lastMessage("no message");
    double gt[6] = {west + x0 * step, step, 0.0, north - y0 * step, 0.0, -step};
    grid->SetGeoTransform(gt);
    grid->SetSpatialRef(&wgs84);
    grid->GetRasterBand(1)->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());
    grid->GetRasterBand(1)->Fill(std::numeric_limits<double>::quiet_NaN());
    // The grid starts as nodata (above); no INIT_DEST, which would wipe one tile's posts with the
    // next's pass.
    WarpOptions warp({"-r", "bilinear", "-et", "0", "-dstnodata", "nan"});
    int usageError = 0;
    if (GDALWarp(nullptr, GDALDataset::ToHandle(grid.get()), static_cast<int>(handles.size()), handles.data(),
                 warp.options, &usageError) == nullptr) {
      return "cannot resample the DEM into longitude/latitude: " + QuietGdal::lastMessage("GDALWarp failed");
    }
    posts.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0F);
    if (grid->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, posts.data(), w, h, GDT_Float32, 0, 0, nullptr) !=
        CE_None) {
      return "cannot read the resampled DEM: " + QuietGdal::lastMessage("RasterIO failed");
    }
    for (float& v : posts) {
      if (!std::isfinite(v) || std::abs(v) > 1e5F) {
        v = 0.0F;
        ++holes;
      }
    }
    if (toEllipsoid) {
      std::vector<double> x(static_cast<std::size_t>(w)), y(x.size()), z(x.size());
      std::vector<int> ok(x.size());
      for (int r = 0; r < h; ++r) {
        const double lat = north - (y0 + r + 0.5) * step;
        float* row = posts.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(w);
        for (int c = 0; c < w; ++c) {
          const auto k = static_cast<std::size_t>(c);
          x[k] = west + (x0 + c + 0.5) * step;
          y[k] = lat;
          z[k] = row[c];
        }
        toEllipsoid->Transform(w, x.data(), y.data(), z.data(), nullptr, ok.data());
        for (int c = 0; c < w; ++c) {
          const auto k = static_cast<std::size_t>(c);
          if (ok[k] != 0 && std::isfinite(z[k])) {
            row[c] = static_cast<float>(z[k]);
          } else {
            ++failed;
          }
        }
      }
    }
    return {};
  }
};

}  // namespace

/// A paged grid (GeoGrid::fromDem): its file, the blocks read from it (least recently used first
/// out beyond the budget), the min/max pyramid over its blocks and its poles.
///
/// The file (format 2, docs/cache.md) checks itself:
/// - a header (kHeaderBytes: magic, sizes, the holes and failed conversions counted when it was
///   written, the poles' heights, the table's digest and its own);
/// - the table: each block's (min, max), then each block's digest (of its rows' digests);
/// - each block's rows' digests (block of them, XXH3-64 of a row of block floats);
/// - the blocks, each block × block floats row-major (posts beyond the grid's east and south
///   edges are 0).
/// The header and the table are verified at open (a file that fails is written again, with a
/// warning); a block's rows are verified before any of its posts is used, a post read alone with
/// its row. A damaged block is read again from the DEM (the same window gives the same posts),
/// written back into the file where it can be, and said once.
struct GeoGrid::Paged {
  struct Block {
    int w = 0, h = 0;  ///< its posts inside the grid
    std::vector<float> heights;
    /// Level k = 1 … log2(block): cells of 2^k × 2^k posts, (min, max) over its posts in the grid.
    std::vector<std::vector<std::pair<float, float>>> levels;
  };
  static constexpr char kMagic[8] = {'S', 'G', 'G', 'L', 'O', 'B', 'E', '2'};
  static constexpr std::size_t kHeaderBytes = 128;

  std::string path, sourceLabel;
  int fd = -1;
  int width = 0, height = 0, block = 256, levels = 8, blocksX = 0, blocksY = 0;
  std::size_t budget = 0;
  std::array<double, 2> poles{0.0, 0.0};
  bool made = false;
  /// Level j: cells of 2^j × 2^j blocks, (min, max) each, row-major.
  std::vector<std::vector<std::pair<float, float>>> pyramid;
  std::vector<std::pair<int, int>> pyramidSize;
  /// Per block: the digest of its rows' digests (verified with the table at open).
  std::vector<std::uint64_t> blockDigests;
  /// The DEM's windows, to read a damaged block again.
  std::shared_ptr<GridWindows> windows;

  mutable std::mutex mutex;
  mutable std::list<std::size_t> lru;  ///< block indices, most recently used first
  mutable std::unordered_map<std::size_t, std::pair<std::shared_ptr<const Block>, std::list<std::size_t>::iterator>>
      cache;
  mutable std::size_t cachedBytes = 0, reads = 0, repaired = 0;
  /// Posts read one by one, and per block how many times a post of it was asked for while it
  /// was not cached: a block is read whole only from its kDenseTouches-th (a far view's tiles ask
  /// a few posts of each block, a near view's many of a few).
  mutable std::size_t postReads = 0;
  mutable std::unordered_map<std::size_t, std::uint32_t> touches;
  static constexpr std::uint32_t kDenseTouches = 64;

  Paged() = default;
  Paged(const Paged&) = delete;
  Paged& operator=(const Paged&) = delete;
  ~Paged() {
    if (fd >= 0) ::close(fd);
  }

  [[nodiscard]] std::size_t blockCount() const {
    return static_cast<std::size_t>(blocksX) * static_cast<std::size_t>(blocksY);
  }
  [[nodiscard]] std::size_t rowBytes() const { return static_cast<std::size_t>(block) * sizeof(float); }
  [[nodiscard]] std::uint64_t rowDigestsOffset(std::size_t index) const {
    return kHeaderBytes + blockCount() * 16U +
           static_cast<std::uint64_t>(index) * static_cast<std::uint64_t>(block) * 8U;
  }
  [[nodiscard]] std::uint64_t blockOffset(std::size_t index) const {
    return rowDigestsOffset(blockCount()) + static_cast<std::uint64_t>(index) * static_cast<std::uint64_t>(block) *
                                                static_cast<std::uint64_t>(block) * 4U;
  }
  [[nodiscard]] std::size_t blockBytes() const {
    return static_cast<std::size_t>(block) * static_cast<std::size_t>(block) * (4U + 8U * 4U / 3U);
  }

  /// Digests of a padded block's rows.
  [[nodiscard]] std::vector<std::uint64_t> rowDigestsOf(const std::vector<float>& heights) const {
    std::vector<std::uint64_t> rows(static_cast<std::size_t>(block));
    for (std::size_t r = 0; r < rows.size(); ++r)
      rows[r] = geo::io::digest(heights.data() + r * static_cast<std::size_t>(block), rowBytes());
    return rows;
  }

  /// Block `index`'s rows' digests from the file, if they match its digest in the table.
  [[nodiscard]] std::optional<std::vector<std::uint64_t>> readRowDigests(std::size_t index) const {
    std::vector<std::uint64_t> rows(static_cast<std::size_t>(block));
    const std::size_t bytes = rows.size() * sizeof(std::uint64_t);
    if (::pread(fd, rows.data(), bytes, static_cast<off_t>(rowDigestsOffset(index))) != static_cast<ssize_t>(bytes) ||
        geo::io::digest(rows.data(), bytes) != blockDigests[index])
      return std::nullopt;
    return rows;
  }

  /// Block `index`'s padded posts from the file, verified row by row; false if any row is not
  /// whole.
  bool readBlock(std::size_t index, std::vector<float>& heights) const {
    const std::optional<std::vector<std::uint64_t>> rows = readRowDigests(index);
    if (!rows) return false;
    const std::size_t bytes = heights.size() * sizeof(float);
    if (::pread(fd, heights.data(), bytes, static_cast<off_t>(blockOffset(index))) != static_cast<ssize_t>(bytes))
      return false;
    return rowDigestsOf(heights) == *rows;
  }

  /// Block `index` read again from the DEM (its padded posts), written back into the file where
  /// the file can be written; said once per grid. Called with the mutex held.
  void repair(std::size_t index, std::vector<float>& heights) const {
    const int bx = static_cast<int>(index % static_cast<std::size_t>(blocksX));
    const int by = static_cast<int>(index / static_cast<std::size_t>(blocksX));
    const int x0 = bx * block, y0 = by * block;
    const int w = std::min(block, width - x0), h = std::min(block, height - y0);
    std::fill(heights.begin(), heights.end(), 0.0F);
    std::vector<float> posts;
    QuietGdal quiet;
    const std::string problem = windows ? windows->read(x0, y0, w, h, posts) : std::string("no DEM to read it from");
    const std::string where = path + ": block " + std::to_string(bx) + "," + std::to_string(by);
    if (!problem.empty()) {
      logError(where + " is damaged and cannot be read again from " + sourceLabel + " (" + problem +
               "): its heights are 0");
      return;
    }
    for (int r = 0; r < h; ++r)
      std::copy_n(posts.begin() + static_cast<std::ptrdiff_t>(r) * w, w,
                  heights.begin() + static_cast<std::ptrdiff_t>(r) * block);
    const std::vector<std::uint64_t> rows = rowDigestsOf(heights);
    const std::uint64_t blockDigest = geo::io::digest(rows.data(), rows.size() * sizeof(std::uint64_t));
    if (++repaired == 1) {
      logWarning(path + ": cache file damaged (block " + std::to_string(bx) + "," + std::to_string(by) +
                 " does not match its checksum); its damaged blocks are read again from " + sourceLabel);
    }
    if (blockDigest != blockDigests[index]) {
      // The DEM no longer gives what was written (its fingerprint matched): the heights read now
      // are used, the file is left alone.
      logWarning(where + ": the DEM gives other heights than the cache holds; the DEM's are used");
      return;
    }
    // Written back at its own offsets: the same bytes a whole file has, so a reader of this file
    // meanwhile reads either the damaged bytes (and finds them so) or these.
    const int out = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (out < 0) return;
    const std::size_t rowDigestBytes = rows.size() * sizeof(std::uint64_t);
    const std::size_t bytes = heights.size() * sizeof(float);
    const bool written =
        ::pwrite(out, rows.data(), rowDigestBytes, static_cast<off_t>(rowDigestsOffset(index))) ==
            static_cast<ssize_t>(rowDigestBytes) &&
        ::pwrite(out, heights.data(), bytes, static_cast<off_t>(blockOffset(index))) == static_cast<ssize_t>(bytes);
    ::close(out);
    if (!written) logWarning(where + ": the repaired block could not be written back (kept in memory)");
  }

  /// Block (bx, by), read if it is not cached.
  std::shared_ptr<const Block> load(int bx, int by) const {
    const std::size_t index =
        static_cast<std::size_t>(by) * static_cast<std::size_t>(blocksX) + static_cast<std::size_t>(bx);
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto found = cache.find(index); found != cache.end()) {
      lru.splice(lru.begin(), lru, found->second.second);
      return found->second.first;
    }
    auto b = std::make_shared<Block>();
    b->w = std::min(block, width - bx * block);
    b->h = std::min(block, height - by * block);
    b->heights.assign(static_cast<std::size_t>(block) * static_cast<std::size_t>(block), 0.0F);
    if (!readBlock(index, b->heights)) repair(index, b->heights);
    ++reads;
    // Its own min/max levels, over its posts inside the grid.
    for (int k = 1, n = block / 2; n >= 1; ++k, n /= 2) {
      std::vector<std::pair<float, float>> level(
          static_cast<std::size_t>(n) * static_cast<std::size_t>(n),
          {std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()});
      for (int r = 0; r < b->h; ++r) {
        for (int c = 0; c < b->w; ++c) {
          const float v =
              b->heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(block) + static_cast<std::size_t>(c)];
          auto& o =
              level[static_cast<std::size_t>(r >> k) * static_cast<std::size_t>(n) + static_cast<std::size_t>(c >> k)];
          o.first = std::min(o.first, v);
          o.second = std::max(o.second, v);
        }
      }
      b->levels.push_back(std::move(level));
    }
    lru.push_front(index);
    cache.emplace(index, std::make_pair(std::shared_ptr<const Block>(b), lru.begin()));
    cachedBytes += blockBytes();
    while (cachedBytes > budget && lru.size() > 1) {
      cache.erase(lru.back());
      lru.pop_back();
      cachedBytes -= blockBytes();
    }
    return b;
  }

  [[nodiscard]] float post(int c, int r) const {
    const std::size_t inRow = static_cast<std::size_t>(c % block);
    const std::size_t row = static_cast<std::size_t>(r % block);
    {
      const std::size_t index =
          static_cast<std::size_t>(r / block) * static_cast<std::size_t>(blocksX) + static_cast<std::size_t>(c / block);
      const std::lock_guard<std::mutex> lock(mutex);
      if (cache.count(index) == 0 && ++touches[index] < kDenseTouches) {
        // The one post, from its row verified against the block's rows' digests (a damaged row
        // falls through to the block, which is repaired).
        const std::optional<std::vector<std::uint64_t>> rows = readRowDigests(index);
        std::vector<float> posts(static_cast<std::size_t>(block));
        if (rows &&
            ::pread(fd, posts.data(), rowBytes(), static_cast<off_t>(blockOffset(index) + row * rowBytes())) ==
                static_cast<ssize_t>(rowBytes()) &&
            geo::io::digest(posts.data(), rowBytes()) == (*rows)[row]) {
          ++postReads;
          return posts[inRow];
        }
      }
    }
    return load(c / block, r / block)->heights[row * static_cast<std::size_t>(block) + inRow];
  }
};

namespace {

/// The header of a paged grid's file (no padding: every byte is a field).
struct PagedHeader {
  char magic[8];
  std::int32_t width, height, block, blocksX, blocksY, reserved;
  std::uint64_t holes, failed;
  double poles[2];
  std::uint64_t tableDigest, headerDigest;
};
static_assert(sizeof(PagedHeader) == 80 && sizeof(PagedHeader) <= GeoGrid::Paged::kHeaderBytes);

std::uint64_t headerDigestOf(PagedHeader h) {
  h.headerDigest = 0;
  return geo::io::digest(&h, sizeof h);
}

/// The paged grid of `file`: opened if it is there and whole, else written block by block from
/// `windows` (which counts the holes and failed conversions it leaves: kept in the file). A file
/// that is there but not whole is written again, with a warning.
Result<std::shared_ptr<const GeoGrid::Paged>> openPaged(const std::string& file, const std::string& sourceLabel,
                                                        int width, int height, int block, std::size_t budget,
                                                        double postNorth, double step,
                                                        const std::shared_ptr<GridWindows>& windows) {
  using Paged = GeoGrid::Paged;
  Result<std::shared_ptr<const Paged>> out;
  auto p = std::make_shared<Paged>();
  p->path = file;
  p->sourceLabel = sourceLabel;
  p->windows = windows;
  p->width = width;
  p->height = height;
  p->block = block;
  p->levels = static_cast<int>(std::lround(std::log2(block)));
  p->blocksX = (width + block - 1) / block;
  p->blocksY = (height + block - 1) / block;
  p->budget = budget;
  const std::size_t blocks = p->blockCount();
  const std::uint64_t size = p->blockOffset(blocks);
  // The table: each block's (min, max), then each block's digest.
  std::vector<std::pair<float, float>> ranges(blocks);
  p->blockDigests.assign(blocks, 0);
  const auto tableDigest = [&] {
    const std::uint64_t parts[2] = {geo::io::digest(ranges.data(), blocks * 8U),
                                    geo::io::digest(p->blockDigests.data(), blocks * 8U)};
    return geo::io::digest(parts, sizeof parts);
  };
  // The rows heightAt takes each pole's height from (the GeoGrid constructor's rowMean).
  std::array<int, 2> poleRow{-1, -1};
  for (std::size_t k = 0; k < 2; ++k) {
    const double fr = (postNorth - (k == 0 ? 90.0 : -90.0)) / step;
    if (fr >= -0.5 && fr <= height - 0.5) poleRow[k] = std::clamp(static_cast<int>(std::lround(fr)), 0, height - 1);
  }
  std::error_code ec;
  const std::uintmax_t found = std::filesystem::file_size(file, ec);
  if (!ec) {
    // There: used if it is whole.
    std::string damage;
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    PagedHeader h{};
    if (fd < 0) {
      damage = "it cannot be read";
    } else if (found != size) {
      damage = "it is " + std::to_string(found) + " bytes, not " + std::to_string(size);
    } else if (::pread(fd, &h, sizeof h, 0) != static_cast<ssize_t>(sizeof h) ||
               !std::equal(std::begin(h.magic), std::end(h.magic), std::begin(Paged::kMagic)) ||
               h.headerDigest != headerDigestOf(h)) {
      damage = "its header does not match its checksum";
    } else if (h.width != width || h.height != height || h.block != block || h.blocksX != p->blocksX ||
               h.blocksY != p->blocksY) {
      damage = "its header is of another grid";
    } else if (::pread(fd, ranges.data(), blocks * 8U, static_cast<off_t>(Paged::kHeaderBytes)) !=
                   static_cast<ssize_t>(blocks * 8U) ||
               ::pread(fd, p->blockDigests.data(), blocks * 8U,
                       static_cast<off_t>(Paged::kHeaderBytes + blocks * 8U)) != static_cast<ssize_t>(blocks * 8U) ||
               tableDigest() != h.tableDigest) {
      damage = "its table does not match its checksum";
    }
    if (damage.empty()) {
      p->fd = fd;
      windows->holes = h.holes;
      windows->failed = h.failed;
      p->poles = {h.poles[0], h.poles[1]};
    } else {
      if (fd >= 0) ::close(fd);
      out.diagnostics.add(
          {Severity::Warning, file, {}, {}, "cache file damaged (" + damage + "); rebuilt from " + sourceLabel});
    }
  }
  if (p->fd < 0) {
    // Written to a temporary file, renamed when whole: a file found in the cache is always whole.
    std::filesystem::create_directories(std::filesystem::path(file).parent_path(), ec);
    const std::string temporary = file + ".part" + std::to_string(::getpid());
    const int fd = ::open(temporary.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
      out.diagnostics.add({Severity::Error, {}, {}, {}, "cannot write the paged DEM " + temporary});
      return out;
    }
    const auto abandon = [&](const std::string& problem) {
      ::close(fd);
      std::filesystem::remove(temporary, ec);
      out.diagnostics.add({Severity::Error, {}, {}, {}, problem});
      return std::move(out);
    };
    std::array<double, 2> poleSum{0.0, 0.0};
    std::vector<float> posts, padded(static_cast<std::size_t>(block) * static_cast<std::size_t>(block));
    for (int by = 0; by < p->blocksY; ++by) {
      for (int bx = 0; bx < p->blocksX; ++bx) {
        const int x0 = bx * block, y0 = by * block;
        const int w = std::min(block, width - x0), h = std::min(block, height - y0);
        if (const std::string problem = windows->read(x0, y0, w, h, posts); !problem.empty()) return abandon(problem);
        std::fill(padded.begin(), padded.end(), 0.0F);
        const std::size_t index =
            static_cast<std::size_t>(by) * static_cast<std::size_t>(p->blocksX) + static_cast<std::size_t>(bx);
        auto& range = ranges[index];
        range = {std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
        for (int r = 0; r < h; ++r) {
          for (int c = 0; c < w; ++c) {
            const float v =
                posts[static_cast<std::size_t>(r) * static_cast<std::size_t>(w) + static_cast<std::size_t>(c)];
            padded[static_cast<std::size_t>(r) * static_cast<std::size_t>(block) + static_cast<std::size_t>(c)] = v;
            range.first = std::min(range.first, v);
            range.second = std::max(range.second, v);
          }
          for (std::size_t k = 0; k < 2; ++k) {
            if (y0 + r != poleRow[k]) continue;
            for (int c = 0; c < w; ++c)
              poleSum[k] +=
                  posts[static_cast<std::size_t>(r) * static_cast<std::size_t>(w) + static_cast<std::size_t>(c)];
          }
        }
        const std::vector<std::uint64_t> rows = p->rowDigestsOf(padded);
        const std::size_t rowDigestBytes = rows.size() * sizeof(std::uint64_t);
        p->blockDigests[index] = geo::io::digest(rows.data(), rowDigestBytes);
        const std::size_t bytes = padded.size() * sizeof(float);
        if (::pwrite(fd, rows.data(), rowDigestBytes, static_cast<off_t>(p->rowDigestsOffset(index))) !=
                static_cast<ssize_t>(rowDigestBytes) ||
            ::pwrite(fd, padded.data(), bytes, static_cast<off_t>(p->blockOffset(index))) !=
                static_cast<ssize_t>(bytes))
          return abandon("cannot write the paged DEM " + temporary + ": " + std::strerror(errno));
      }
    }
    for (std::size_t k = 0; k < 2; ++k) p->poles[k] = poleRow[k] >= 0 && width > 0 ? poleSum[k] / width : 0.0;
    PagedHeader h;
    std::memset(&h, 0, sizeof h);
    std::copy(std::begin(Paged::kMagic), std::end(Paged::kMagic), std::begin(h.magic));
    h.width = width;
    h.height = height;
    h.block = block;
    h.blocksX = p->blocksX;
    h.blocksY = p->blocksY;
    h.holes = windows->holes;
    h.failed = windows->failed;
    h.poles[0] = p->poles[0];
    h.poles[1] = p->poles[1];
    h.tableDigest = tableDigest();
    h.headerDigest = headerDigestOf(h);
    std::vector<char> header(Paged::kHeaderBytes, 0);
    std::memcpy(header.data(), &h, sizeof h);
    if (::pwrite(fd, header.data(), header.size(), 0) != static_cast<ssize_t>(header.size()) ||
        ::pwrite(fd, ranges.data(), blocks * 8U, static_cast<off_t>(Paged::kHeaderBytes)) !=
            static_cast<ssize_t>(blocks * 8U) ||
        ::pwrite(fd, p->blockDigests.data(), blocks * 8U, static_cast<off_t>(Paged::kHeaderBytes + blocks * 8U)) !=
            static_cast<ssize_t>(blocks * 8U) ||
        ::fsync(fd) != 0)
      return abandon("cannot write the paged DEM " + temporary + ": " + std::strerror(errno));
    std::filesystem::rename(temporary, file, ec);
    if (ec) return abandon("cannot place the paged DEM at " + file + ": " + ec.message());
    p->fd = fd;
    p->made = true;
  }
  // The pyramid over the blocks.
  buildMinMaxPyramid(std::move(ranges), p->blocksX, p->blocksY, p->pyramid, p->pyramidSize);
  out.value = std::shared_ptr<const Paged>(std::move(p));
  return out;
}

}  // namespace

std::optional<VerticalDatum> parseVerticalDatum(const std::string& text) {
  if (text == "auto") return VerticalDatum::Auto;
  if (text == "ellipsoid") return VerticalDatum::Ellipsoid;
  if (text == "egm96") return VerticalDatum::Egm96;
  if (text == "egm2008") return VerticalDatum::Egm2008;
  return std::nullopt;
}

Result<GeoGrid> GeoGrid::fromDem(const geo::DemSpec& spec, const GeoGridReadOptions& options) {
  geo::detail::ensureGdalRegistered();
  Result<GeoGrid> out;
  Result<geo::DemSource> source = geo::DemSource::open(spec);
  out.diagnostics.append(source.diagnostics);
  if (!source.ok()) return out;
  const std::string& label = source->label();
  const auto fail = [&](const std::string& message) {
    out.diagnostics.add({Severity::Error, label, {}, {}, message});
    return std::move(out);
  };
  QuietGdal quiet;
  const double unitOverride = spec.heightUnit.empty() ? 0.0 : geo::metresPerHeightUnit(spec.heightUnit);
  const OGRSpatialReference wgs84 = traditional("EPSG:4326");
  char* wgs84WktRaw = nullptr;
  wgs84.exportToWkt(&wgs84WktRaw);
  const std::string wgs84Wkt = wgs84WktRaw != nullptr ? wgs84WktRaw : "";
  CPLFree(wgs84WktRaw);

  // Each tile as a VRT of its band (the CRS override and the height conversion applied), and
  // where it lands in longitude/latitude at its own resolution.
  std::vector<DatasetPtr> files, bands;
  std::optional<OGRSpatialReference> vertical;  // the first tile's vertical CRS
  bool threeD = false;
  double west = std::numeric_limits<double>::max(), east = -west, south = west, north = -west;
  double step = std::numeric_limits<double>::max();
  for (const std::string& file : source->files()) {
    DatasetPtr ds(GDALDataset::Open(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
    if (!ds || spec.band > ds->GetRasterCount()) continue;  // DemSource named it and left it out
    OGRSpatialReference srs;
    if (!spec.crs.empty()) {
      srs.SetFromUserInput(spec.crs.c_str());
    } else if (const OGRSpatialReference* own = ds->GetSpatialRef(); own != nullptr) {
      srs = *own;
    }
    if (srs.IsEmpty()) continue;
    if (!vertical) {
      vertical = verticalPart(srs);
      threeD = srs.IsGeographic() != 0 && srs.GetAxesCount() == 3;
    }
    const HeightConversion conv = heightConversion(*ds->GetRasterBand(spec.band), &srs, unitOverride);
    std::vector<std::string> args{"-of", "VRT", "-b", std::to_string(spec.band), "-ot", "Float32"};
    if (!spec.crs.empty()) args.insert(args.end(), {"-a_srs", spec.crs});
    if (!conv.identity()) {
      // raw → (raw · scale + offset) · metresPerUnit, as a linear map of [0, 1].
      args.insert(args.end(), {"-scale", "0", "1", format(conv.offset * conv.metresPerUnit, 17),
                               format((conv.scale + conv.offset) * conv.metresPerUnit, 17)});
    }
    TranslateOptions translate(args);
    int usageError = 0;
    DatasetPtr vrt(
        GDALDataset::FromHandle(GDALTranslate("", GDALDataset::ToHandle(ds.get()), translate.options, &usageError)));
    if (!vrt) return fail("cannot read " + file + ": " + QuietGdal::lastMessage("GDALTranslate failed"));
    // Where the tile lands in lon/lat, and the resolution that keeps its posts: its own grid when
    // it is in WGS 84 lon/lat already (GDALSuggestedWarpOutput widens a raster that touches a pole
    // to all 360° of longitude), else GDAL's suggestion.
    double gt[6];
    int pixels = 0, lines = 0;
    bool placed = false;
    double own[6];
    if (srs.IsGeographic() != 0 && srs.IsSameGeogCS(&wgs84) != 0 && vrt->GetGeoTransform(own) == CE_None &&
        own[2] == 0.0 && own[4] == 0.0 && own[1] > 0.0 && own[5] < 0.0 && own[0] >= -540.0 && own[0] <= 540.0) {
      std::copy(std::begin(own), std::end(own), std::begin(gt));
      pixels = vrt->GetRasterXSize();
      lines = vrt->GetRasterYSize();
      placed = true;
    } else {
      const std::string dst = "DST_SRS=" + wgs84Wkt;
      const char* const transformerOptions[] = {dst.c_str(), nullptr};
      void* transformer = GDALCreateGenImgProjTransformer2(GDALDataset::ToHandle(vrt.get()), nullptr,
                                                           const_cast<char**>(transformerOptions));
      placed =
          transformer != nullptr && GDALSuggestedWarpOutput(GDALDataset::ToHandle(vrt.get()), GDALGenImgProjTransform,
                                                            transformer, gt, &pixels, &lines) == CE_None;
      if (transformer != nullptr) GDALDestroyGenImgProjTransformer(transformer);
    }
    if (!placed)
      return fail("cannot place " + file + " in longitude/latitude: " + QuietGdal::lastMessage("no message"));
    step = std::min({step, gt[1], -gt[5]});
    west = std::min(west, gt[0]);
    east = std::max(east, gt[0] + pixels * gt[1]);
    north = std::max(north, gt[3]);
    south = std::min(south, gt[3] + lines * gt[5]);
    files.push_back(std::move(ds));
    bands.push_back(std::move(vrt));
  }
  if (bands.empty()) return fail("no DEM tile could be read");
  north = std::min(north, 90.0);
  south = std::max(south, -90.0);
  if (!(step > 0.0) || !(east > west) || !(north > south)) return fail("the DEM has no extent in longitude/latitude");
  // Cells of `step` from the north-west corner, covering the extent.
  const double cols = std::ceil((east - west) / step - 1e-6), rows = std::ceil((north - south) / step - 1e-6);
  const double megabytes = cols * rows * kBytesPerPost / (1024.0 * 1024.0);
  const bool overBudget = options.memoryBudgetMb > 0.0 && megabytes > options.memoryBudgetMb;
  if (overBudget && options.paging == GridPaging::Never) {
    return fail((options.sceneFile.empty() ? std::string() : options.sceneFile + ": ") + "the DEM " + label +
                " would take " + format(megabytes, 4) + " MB in memory on the globe (" + format(cols, 10) + " x " +
                format(rows, 10) + " posts of " + format(step * 3600.0, 4) +
                "\"), more than terrain.memory_budget_mb (" + format(options.memoryBudgetMb, 6) +
                ") and terrain.paging is \"never\": page it, cut the DEM or raise the budget");
  }
  const bool page = options.paging == GridPaging::Always || overBudget;
  const int width = static_cast<int>(cols), height = static_cast<int>(rows);

  // The vertical datum, decided before any post is read.
  VerticalDatum datum = options.vertical;
  std::optional<OGRSpatialReference> geoid;
  std::string what, gridName;
  if (datum == VerticalDatum::Auto) {
    if (vertical) {
      geoid = *vertical;
      what = vertical->GetName() != nullptr ? vertical->GetName() : "the DEM's vertical CRS";
      out.diagnostics.add({Severity::Info,
                           label,
                           {},
                           {},
                           "heights above " + what + " (the DEM's vertical CRS), converted to the ellipsoid"});
    } else if (threeD) {
      datum = VerticalDatum::Ellipsoid;
      out.diagnostics.add(
          {Severity::Info, label, {}, {}, "heights above the ellipsoid (the DEM's CRS is 3D geographic)"});
    } else {
      datum = VerticalDatum::Egm96;
      out.diagnostics.add({Severity::Info,
                           label,
                           {},
                           {},
                           "the DEM has no vertical CRS: its heights are taken as EGM96 geoid heights (as SRTM's "
                           "and Copernicus') and converted to the ellipsoid; say terrain.vertical_datum otherwise"});
    }
  }
  if (datum == VerticalDatum::Egm96 || datum == VerticalDatum::Egm2008) {
    const bool egm96 = datum == VerticalDatum::Egm96;
    geoid = traditional(egm96 ? "EPSG:5773" : "EPSG:3855");
    what = egm96 ? "EGM96 height (EPSG:5773)" : "EGM2008 height (EPSG:3855)";
    gridName = egm96 ? "us_nga_egm96_15.tif (egm96_15.gtx)" : "us_nga_egm08_25.tif";
  }
  TransformPtr toEllipsoid;
  std::string verticalSource = "ellipsoid";
  if (geoid) {
    Result<TransformPtr> t = geoidTransform(*geoid, what, gridName);
    for (Diagnostic d : t.diagnostics.items()) {
      d.file = label;
      out.diagnostics.add(std::move(d));
    }
    if (!t.ok()) return out;
    toEllipsoid = std::move(*t);
    verticalSource = what;
  }

  // Windows of the grid (GridWindows), kept by a paged grid to repair a damaged block.
  auto windows = std::make_shared<GridWindows>();
  windows->mem = GetGDALDriverManager()->GetDriverByName("MEM");
  if (windows->mem == nullptr) return fail("GDAL has no MEM driver");
  for (const DatasetPtr& b : bands) windows->handles.push_back(GDALDataset::ToHandle(b.get()));
  windows->files = std::move(files);
  windows->bands = std::move(bands);
  windows->wgs84 = wgs84;
  windows->toEllipsoid = std::move(toEllipsoid);
  windows->west = west;
  windows->north = north;
  windows->step = step;
  const std::size_t& holes = windows->holes;
  const std::size_t& failed = windows->failed;
  const auto readWindow = [&windows](int x0, int y0, int w, int h, std::vector<float>& posts) {
    return windows->read(x0, y0, w, h, posts);
  };
  const auto report = [&] {
    if (holes > 0)
      out.diagnostics.add({Severity::Warning,
                           label,
                           {},
                           {},
                           std::to_string(holes) +
                               " posts without a height (nodata) are drawn at height 0 of the DEM's vertical datum"});
    if (failed > 0)
      out.diagnostics.add({Severity::Warning,
                           label,
                           {},
                           {},
                           std::to_string(failed) + " posts could not be converted from " + what +
                               " to the ellipsoid (kept as they are)"});
  };

  if (!page) {
    std::vector<float> heights;
    if (const std::string problem = readWindow(0, 0, width, height, heights); !problem.empty()) return fail(problem);
    report();
    // Posts at the centres of the grid's cells.
    out.value.emplace(width, height, west + 0.5 * step, north - 0.5 * step, step, std::move(heights));
    out.value->verticalSource_ = verticalSource;
    return out;
  }

  // Paged: the grid written block by block into the cache (once for this DEM and these options).
  const int block = std::clamp(options.blockPosts, 16, 4096);
  if ((block & (block - 1)) != 0) return fail("the page block size must be a power of two");
  std::ostringstream key;
  key << "globe-dem v2|" << source->fingerprint() << "|band " << spec.band << "|crs " << spec.crs << "|unit "
      << spec.heightUnit << "|" << verticalSource << "|" << format(west, 17) << " " << format(north, 17) << " "
      << format(step, 17) << " " << width << "x" << height << "|block " << block;
  const std::string dir = options.cacheDir ? options.cacheDir() : std::string(".");
  const std::string file = dir + "/globe-dem-" + stableHashHex(key.str()) + ".grid";
  const double budgetMb =
      options.pageBudgetMb > 0.0 ? options.pageBudgetMb : std::max(16.0, options.memoryBudgetMb / 3.0);
  Result<std::shared_ptr<const Paged>> paged =
      openPaged(file, label, width, height, block, static_cast<std::size_t>(budgetMb * 1024.0 * 1024.0),
                north - 0.5 * step, step, windows);
  for (Diagnostic d : paged.diagnostics.items()) {
    if (d.file.empty()) d.file = label;
    out.diagnostics.add(std::move(d));
  }
  if (!paged.ok()) return out;
  report();
  if ((*paged)->made) {
    out.diagnostics.add({Severity::Info,
                         label,
                         {},
                         {},
                         "the DEM (" + format(megabytes, 4) + " MB in memory) is paged on the globe from " + file +
                             ", written once; blocks of " + std::to_string(block) + " posts are kept within " +
                             format(budgetMb, 4) + " MB"});
  }
  out.value.emplace(GeoGrid(width, height, west + 0.5 * step, north - 0.5 * step, step, std::move(*paged)));
  out.value->verticalSource_ = verticalSource;
  return out;
}

GeoGrid::GeoGrid(int width, int height, double west, double north, double step, std::vector<float> heights)
    : width_(width), height_(height), west_(west), north_(north), step_(step), heights_(std::move(heights)) {
  wraps_ = width_ * step_ >= 360.0 - 1e-9;
  const auto rowMean = [&](double lat) {
    const double fr = (north_ - lat) / step_;
    if (!(fr >= -0.5 && fr <= height_ - 0.5) || width_ == 0) return 0.0;
    const int r = std::clamp(static_cast<int>(std::lround(fr)), 0, height_ - 1);
    double sum = 0.0;
    for (int c = 0; c < width_; ++c) sum += post(c, r);
    return sum / width_;
  };
  poleHeight_ = {rowMean(90.0), rowMean(-90.0)};
  buildPyramid();
}

std::shared_ptr<const GeoGrid> GeoGrid::exaggerated(std::shared_ptr<const GeoGrid> grid, double factor) {
  if (!grid) return grid;
  std::shared_ptr<const GeoGrid> base = grid->base_ ? grid->base_ : grid;
  if (!(factor > 0.0) || !std::isfinite(factor) || factor == 1.0) return base;
  return std::shared_ptr<const GeoGrid>(new GeoGrid(std::move(base), factor));
}

GeoGrid::GeoGrid(std::shared_ptr<const GeoGrid> base, double factor)
    : width_(base->width_),
      height_(base->height_),
      west_(base->west_),
      north_(base->north_),
      step_(base->step_),
      wraps_(base->wraps_),
      poleHeight_{factor * base->poleHeight_[0], factor * base->poleHeight_[1]},
      base_(std::move(base)),
      exaggeration_(factor) {}

std::optional<std::uint64_t> GeoGrid::contentDigest() const {
  if (base_) {
    const std::optional<std::uint64_t> inner = base_->contentDigest();
    if (!inner) return std::nullopt;
    const std::array<std::uint64_t, 2> parts{*inner, geo::io::digest(&exaggeration_, sizeof(exaggeration_))};
    return geo::io::digest(parts.data(), sizeof(parts));
  }
  if (paged_) return std::nullopt;
  const std::array<double, 5> place{static_cast<double>(width_), static_cast<double>(height_), west_, north_, step_};
  const std::array<std::uint64_t, 2> parts{geo::io::digest(place.data(), sizeof(place)),
                                           geo::io::digest(heights_.data(), heights_.size() * sizeof(float))};
  return geo::io::digest(parts.data(), sizeof(parts));
}

GeoGrid::GeoGrid(int width, int height, double west, double north, double step, std::shared_ptr<const Paged> paged)
    : width_(width), height_(height), west_(west), north_(north), step_(step), paged_(std::move(paged)) {
  wraps_ = width_ * step_ >= 360.0 - 1e-9;
  poleHeight_ = paged_->poles;
}

std::size_t GeoGrid::residentBytes() const {
  if (base_) return base_->residentBytes();
  if (!paged_) {
    std::size_t bytes = heights_.size() * sizeof(float);
    for (const auto& level : pyramid_) bytes += level.size() * sizeof(level[0]);
    return bytes;
  }
  const std::lock_guard<std::mutex> lock(paged_->mutex);
  std::size_t bytes = paged_->cachedBytes;
  for (const auto& level : paged_->pyramid) bytes += level.size() * sizeof(level[0]);
  return bytes;
}

std::size_t GeoGrid::blocksRead() const {
  if (base_) return base_->blocksRead();
  if (!paged_) return 0;
  const std::lock_guard<std::mutex> lock(paged_->mutex);
  return paged_->reads;
}

std::size_t GeoGrid::postsRead() const {
  if (base_) return base_->postsRead();
  if (!paged_) return 0;
  const std::lock_guard<std::mutex> lock(paged_->mutex);
  return paged_->postReads;
}

std::size_t GeoGrid::blocksRepaired() const {
  if (base_) return base_->blocksRepaired();
  if (!paged_) return 0;
  const std::lock_guard<std::mutex> lock(paged_->mutex);
  return paged_->repaired;
}

bool GeoGrid::pageFileMade() const { return base_ ? base_->pageFileMade() : paged_ && paged_->made; }

double GeoGrid::post(int c, int r) const {
  if (r < 0 || r >= height_) return 0.0;
  if (wraps_) {
    c %= width_;
    if (c < 0) c += width_;
  } else if (c < 0 || c >= width_) {
    return 0.0;
  }
  if (paged_) return paged_->post(c, r);
  return heights_[static_cast<std::size_t>(r) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(c)];
}

double GeoGrid::heightAt(double lonDeg, double latDeg) const {
  if (base_) return exaggeration_ * base_->heightAt(lonDeg, latDeg);
  // Every post at a pole is the same point: one height there (the nearest row's mean).
  if (latDeg >= 90.0) return poleHeight_[0];
  if (latDeg <= -90.0) return poleHeight_[1];
  const double fc = (lonDeg - west_) / step_;
  const double fr = (north_ - latDeg) / step_;
  const double c0 = std::floor(fc), r0 = std::floor(fr);
  const double tx = fc - c0, ty = fr - r0;
  const int c = static_cast<int>(c0), r = static_cast<int>(r0);
  // Rows beyond the grid's first and last are clamped (the poles of a global grid).
  const auto row = [&](int rr) { return std::clamp(rr, 0, height_ - 1); };
  const bool inRows = fr >= -0.5 && fr <= height_ - 0.5;
  if (!inRows) return 0.0;
  const double h00 = post(c, row(r)), h10 = post(c + 1, row(r));
  const double h01 = post(c, row(r + 1)), h11 = post(c + 1, row(r + 1));
  return (h00 * (1.0 - tx) + h10 * tx) * (1.0 - ty) + (h01 * (1.0 - tx) + h11 * tx) * ty;
}

void GeoGrid::buildPyramid() {
  pyramid_.clear();
  pyramidSize_.clear();
  std::vector<std::pair<float, float>> level(heights_.size());
  for (std::size_t i = 0; i < heights_.size(); ++i) level[i] = {heights_[i], heights_[i]};
  buildMinMaxPyramid(std::move(level), width_, height_, pyramid_, pyramidSize_);
}

std::pair<double, double> GeoGrid::postRange(long c0, long c1, long r0, long r1) const {
  double lo = std::numeric_limits<double>::max(), hi = -std::numeric_limits<double>::max();
  const auto include = [&](double a, double b) {
    lo = std::min(lo, a);
    hi = std::max(hi, b);
  };
  if (r0 < 0 || r1 >= height_) include(0.0, 0.0);  // rows beyond the grid read 0 only past ±0.5 post
  r0 = std::clamp<long>(r0, 0, height_ - 1);
  r1 = std::clamp<long>(r1, 0, height_ - 1);
  if (wraps_) {
    if (c1 - c0 + 1 >= width_) {
      c0 = 0;
      c1 = width_ - 1;
    } else {
      const long shift = ((c0 % width_) + width_) % width_ - c0;
      c0 += shift;
      c1 += shift;
      if (c1 >= width_) {  // two runs: [c0, width) and [0, c1 − width]
        const auto [a, b] = postRange(0, c1 - width_, r0, r1);
        include(a, b);
        c1 = width_ - 1;
      }
    }
  } else {
    if (c0 < 0 || c1 >= width_) include(0.0, 0.0);
    c0 = std::clamp<long>(c0, 0, width_ - 1);
    c1 = std::clamp<long>(c1, 0, width_ - 1);
  }
  // A pyramid level with at most ~16 blocks across the box.
  const std::size_t levels =
      paged_ ? static_cast<std::size_t>(paged_->levels) + paged_->pyramid.size() : pyramid_.size();
  std::size_t k = 0;
  while (k + 1 < levels && ((c1 - c0) >> k) > 16 && ((r1 - r0) >> k) > 16) ++k;
  while (k + 1 < levels && (((c1 - c0) >> k) > 64 || ((r1 - r0) >> k) > 64)) ++k;
  const auto cells = [&](const std::vector<std::pair<float, float>>& level, long w, long shift, long cBegin, long cEnd,
                         long rBegin, long rEnd) {
    for (long r = rBegin >> shift; r <= (rEnd >> shift); ++r) {
      for (long c = cBegin >> shift; c <= (cEnd >> shift); ++c) {
        const auto& v = level[static_cast<std::size_t>(r * w + c)];
        include(v.first, v.second);
      }
    }
  };
  if (!paged_) {
    cells(pyramid_[k], pyramidSize_[k].first, static_cast<long>(k), c0, c1, r0, r1);
    return {lo, hi};
  }
  // Paged: levels of whole blocks and up stay in memory; finer ones are the blocks' own.
  const auto kb = static_cast<std::size_t>(paged_->levels);
  if (k >= kb) {
    cells(paged_->pyramid[k - kb], paged_->pyramidSize[k - kb].first, static_cast<long>(k), c0, c1, r0, r1);
    return {lo, hi};
  }
  const long b = paged_->block;
  for (long by = r0 / b; by <= r1 / b; ++by) {
    for (long bx = c0 / b; bx <= c1 / b; ++bx) {
      const std::shared_ptr<const Paged::Block> block = paged_->load(static_cast<int>(bx), static_cast<int>(by));
      const long bc0 = std::max(c0, bx * b) - bx * b, bc1 = std::min(c1, bx * b + b - 1) - bx * b;
      const long br0 = std::max(r0, by * b) - by * b, br1 = std::min(r1, by * b + b - 1) - by * b;
      if (k == 0) {
        for (long r = br0; r <= br1; ++r) {
          for (long c = bc0; c <= bc1; ++c) {
            const float v = block->heights[static_cast<std::size_t>(r * b + c)];
            include(v, v);
          }
        }
      } else {
        cells(block->levels[k - 1], b >> k, static_cast<long>(k), bc0, bc1, br0, br1);
      }
    }
  }
  return {lo, hi};
}

std::pair<double, double> GeoGrid::bounds(const LonLatRect& box) const {
  if (base_) {
    const auto [lo, hi] = base_->bounds(box);
    return {exaggeration_ * lo, exaggeration_ * hi};  // a factor > 0 keeps the order
  }
  // Posts heightAt may read for points in the box: one beyond each side.
  const long c0 = static_cast<long>(std::floor((box.west - west_) / step_)) - 1;
  const long c1 = static_cast<long>(std::floor((box.east - west_) / step_)) + 2;
  const long r0 = static_cast<long>(std::floor((north_ - box.north) / step_)) - 1;
  const long r1 = static_cast<long>(std::floor((north_ - box.south) / step_)) + 2;
  auto [lo, hi] = postRange(c0, c1, r0, r1);
  // heightAt gives one height at a pole (the nearest row's mean), which need not be a post's.
  for (std::size_t k = 0; k < 2; ++k) {
    const double pole = k == 0 ? 90.0 : -90.0;
    if (box.south <= pole && pole <= box.north) {
      lo = std::min(lo, poleHeight_[k]);
      hi = std::max(hi, poleHeight_[k]);
    }
  }
  return {lo, hi};
}

}  // namespace gis::globe
