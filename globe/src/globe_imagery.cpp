#include "globe/globe_imagery.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <optional>
#include <sstream>
#include <system_error>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <unistd.h>

#include "core/hash.hpp"
#include "geo/checked_file.hpp"
#include "geo/gdal_support.hpp"

namespace gis::globe {

namespace {

namespace fs = std::filesystem;
namespace io = geo::io;
using geo::detail::DatasetPtr;
using geo::detail::QuietGdal;
using geo::detail::TranslateOptions;
using geo::detail::WarpOptions;

/// Value at a percentile of `values` (nearest rank), as terrain::makeOrthophoto's.
float percentile(std::vector<float> values, double pct) {
  if (values.empty()) return 0.0F;
  const double rank = std::clamp(pct / 100.0, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto k = static_cast<std::ptrdiff_t>(std::llround(rank));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

/// The least power of two ≥ v.
int powerOfTwoAtLeast(double v) {
  int n = 1;
  while (n < v && n < (1 << 20)) n *= 2;
  return n;
}

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

/// A band of a LevelDataset: one chosen band of the imagery at one level (the full resolution or
/// an overview). Reads go to that band and the cells they take are counted; no overviews of its
/// own, so a warp over it reads this level and no other. Nodata, colour and a per-dataset mask
/// are the full-resolution band's, as the band VRT the warp read before overviews had them.
class CountedBand final : public GDALRasterBand {
 public:
  CountedBand(GDALDataset* owner, int number, GDALRasterBand& level, GDALRasterBand& full,
              std::atomic<std::uint64_t>& cells)
      : level_(level), full_(full), cells_(cells) {
    poDS = owner;
    nBand = number;
    nRasterXSize = level.GetXSize();
    nRasterYSize = level.GetYSize();
    eDataType = level.GetRasterDataType();
    level.GetBlockSize(&nBlockXSize, &nBlockYSize);
  }

  double GetNoDataValue(int* has) override { return full_.GetNoDataValue(has); }
  GDALColorInterp GetColorInterpretation() override { return full_.GetColorInterpretation(); }
  int GetMaskFlags() override { return perDatasetMask() ? GMF_PER_DATASET : GDALRasterBand::GetMaskFlags(); }
  GDALRasterBand* GetMaskBand() override {
    return perDatasetMask() ? level_.GetMaskBand() : GDALRasterBand::GetMaskBand();
  }
  int GetOverviewCount() override { return 0; }
  GDALRasterBand* GetOverview(int) override { return nullptr; }

 protected:
  CPLErr IReadBlock(int blockX, int blockY, void* data) override {
    const int x = blockX * nBlockXSize, y = blockY * nBlockYSize;
    const int w = std::min(nBlockXSize, nRasterXSize - x), h = std::min(nBlockYSize, nRasterYSize - y);
    const int bytes = GDALGetDataTypeSizeBytes(eDataType);
    cells_ += static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h);
    return level_.RasterIO(GF_Read, x, y, w, h, data, w, h, eDataType, bytes,
                           static_cast<GSpacing>(bytes) * nBlockXSize, nullptr);
  }
  CPLErr IRasterIO(GDALRWFlag flag, int x, int y, int w, int h, void* data, int bufferW, int bufferH, GDALDataType type,
                   GSpacing pixelSpace, GSpacing lineSpace, GDALRasterIOExtraArg* extra) override {
    if (flag != GF_Read) return CE_Failure;
    cells_ += static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h);
    return level_.RasterIO(GF_Read, x, y, w, h, data, bufferW, bufferH, type, pixelSpace, lineSpace, extra);
  }

 private:
  bool perDatasetMask() { return full_.GetMaskFlags() == GMF_PER_DATASET; }
  GDALRasterBand& level_;
  GDALRasterBand& full_;
  std::atomic<std::uint64_t>& cells_;
};

/// The chosen bands of the imagery at one level, placed (the full resolution's geotransform
/// scaled to the level's size) in the imagery's CRS: what one warped VRT warps.
class LevelDataset final : public GDALDataset {
 public:
  LevelDataset(GDALDataset& full, const std::vector<GDALRasterBand*>& levelBands,
               const std::vector<GDALRasterBand*>& fullBands, const std::array<double, 6>& fullGt,
               std::atomic<std::uint64_t>& cells)
      : srs_(full.GetSpatialRef()) {
    SetDescription(full.GetDescription());
    nRasterXSize = levelBands.front()->GetXSize();
    nRasterYSize = levelBands.front()->GetYSize();
    const double sx = static_cast<double>(full.GetRasterXSize()) / nRasterXSize;
    const double sy = static_cast<double>(full.GetRasterYSize()) / nRasterYSize;
    gt_ = {fullGt[0], fullGt[1] * sx, fullGt[2] * sy, fullGt[3], fullGt[4] * sx, fullGt[5] * sy};
    for (std::size_t i = 0; i < levelBands.size(); ++i) {
      const int n = static_cast<int>(i) + 1;
      SetBand(n, new CountedBand(this, n, *levelBands[i], *fullBands[i], cells));
    }
  }

  CPLErr GetGeoTransform(double* gt) override {
    std::copy(gt_.begin(), gt_.end(), gt);
    return CE_None;
  }
  const OGRSpatialReference* GetSpatialRef() const override { return srs_; }

 protected:
  /// Band by band (never the block cache of a multi-band read): each band's cells counted once.
  CPLErr IRasterIO(GDALRWFlag flag, int x, int y, int w, int h, void* data, int bufferW, int bufferH, GDALDataType type,
                   int bandCount, int* bandMap, GSpacing pixelSpace, GSpacing lineSpace, GSpacing bandSpace,
                   GDALRasterIOExtraArg* extra) override {
    for (int i = 0; i < bandCount; ++i) {
      GDALRasterBand* band = GetRasterBand(bandMap[i]);
      if (band == nullptr || band->RasterIO(flag, x, y, w, h, static_cast<GByte*>(data) + i * bandSpace, bufferW,
                                            bufferH, type, pixelSpace, lineSpace, extra) != CE_None)
        return CE_Failure;
    }
    return CE_None;
  }

 private:
  const OGRSpatialReference* srs_;
  std::array<double, 6> gt_{};
};

/// Where the overviews of a file's chosen bands go in the cache: named after the file (absolute
/// path, size, time) and the bands, so that a changed file or other bands get their own. Empty
/// when the path is not a file on disk.
std::string overviewCacheFile(const std::string& path, const std::vector<int>& bands, const std::string& dir) {
  std::error_code ec;
  const fs::path file = fs::absolute(path, ec);
  if (ec || !fs::is_regular_file(file, ec)) return {};
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) return {};
  const auto time = fs::last_write_time(file, ec);
  if (ec) return {};
  std::ostringstream key;
  key << "globe-imagery-overviews v2|" << file.string() << "|" << size << "|" << time.time_since_epoch().count()
      << "|bands";
  for (const int b : bands) key << " " << b;
  return (fs::path(dir) / ("globe-imagery-" + stableHashHex(key.str()) + ".vrt")).string();
}

/// Overview factors 2, 4, 8, ... until the coarsest is at most 256 cells a side.
std::vector<int> overviewFactors(int width, int height) {
  std::vector<int> factors;
  for (int f = 2; std::max(width, height) / (f / 2) > 256 && f <= (1 << 20); f *= 2) factors.push_back(f);
  return factors;
}

/// Writes `file` (a VRT of the chosen bands of `path`) and `file`.ovr (its overviews, averaged),
/// each under a temporary name renamed when whole: a VRT found in the cache has its overviews.
/// The error, or empty.
std::string buildOverviewCache(const std::string& path, const std::vector<int>& bands, const std::string& file) {
  std::error_code ec;
  fs::create_directories(fs::path(file).parent_path(), ec);
  const std::string temporary = file + ".part" + std::to_string(::getpid());
  const auto abandon = [&](const std::string& problem) {
    fs::remove(temporary, ec);
    fs::remove(temporary + ".ovr", ec);
    return problem;
  };
  // The source by its absolute path, so that the VRT finds it from the cache.
  const DatasetPtr source(
      GDALDataset::Open(fs::absolute(path, ec).string().c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!source) return abandon("cannot open it again: " + QuietGdal::lastMessage("GDAL cannot read it"));
  std::vector<std::string> args{"-of", "VRT"};
  for (const int b : bands) args.insert(args.end(), {"-b", std::to_string(b)});
  const TranslateOptions translate(args);
  int usageError = 0;
  DatasetPtr vrt(GDALDataset::FromHandle(
      GDALTranslate(temporary.c_str(), GDALDataset::ToHandle(source.get()), translate.options, &usageError)));
  if (!vrt) return abandon("cannot write " + temporary + ": " + QuietGdal::lastMessage("GDALTranslate failed"));
  vrt.reset();  // written; opened again from the file, so that its overviews go beside it
  vrt.reset(GDALDataset::Open(temporary.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!vrt) return abandon("cannot read " + temporary + " back: " + QuietGdal::lastMessage("GDAL cannot read it"));
  std::vector<int> factors = overviewFactors(vrt->GetRasterXSize(), vrt->GetRasterYSize());
  {
    // Deflate with the horizontal predictor: imagery is smooth enough for it to pay.
    const CPLConfigOptionSetter compress("COMPRESS_OVERVIEW", "DEFLATE", true);
    const CPLConfigOptionSetter predictor("PREDICTOR_OVERVIEW", "2", true);
    const CPLConfigOptionSetter interleave("INTERLEAVE_OVERVIEW", "PIXEL", true);
    if (vrt->BuildOverviews("AVERAGE", static_cast<int>(factors.size()), factors.data(), 0, nullptr, nullptr, nullptr,
                            nullptr) != CE_None)
      return abandon("cannot build its overviews: " + QuietGdal::lastMessage("BuildOverviews failed"));
  }
  vrt.reset();  // both files whole on disk
  // Their digests, for the next open to check them by (checkOverviewCache).
  const std::optional<io::FileDigest> vrtDigest = io::digestOfFile(temporary);
  const std::optional<io::FileDigest> ovrDigest = io::digestOfFile(temporary + ".ovr");
  if (!vrtDigest || !ovrDigest) return abandon("cannot read " + temporary + " back");
  fs::remove(file + ".sum", ec);  // the old pair's digests go first: a pair is never checked by another's
  fs::rename(temporary + ".ovr", file + ".ovr", ec);
  if (ec) return abandon("cannot place " + file + ".ovr: " + ec.message());
  fs::rename(temporary, file, ec);
  if (ec) return abandon("cannot place " + file + ": " + ec.message());
  const io::WriteOutcome sums = io::writeCheckedFile(file + ".sum", [&](std::ostream& out, io::SectionMarks& marks) {
    marks.begin();
    for (const io::FileDigest& d : {*vrtDigest, *ovrDigest}) {
      out.write(reinterpret_cast<const char*>(&d.bytes), sizeof d.bytes);
      out.write(reinterpret_cast<const char*>(&d.digest), sizeof d.digest);
    }
  });
  if (!sums) return "cannot write " + file + ".sum: " + sums.error;
  return {};
}

/// Whether the overviews in the cache at `file` (its VRT, .ovr and .sum) are whole: "" when they
/// are, "missing" when any is not there, else the damage found.
std::string checkOverviewCache(const std::string& file) {
  std::error_code ec;
  if (!fs::exists(file, ec) || !fs::exists(file + ".ovr", ec)) return "missing";
  io::CheckedStatus status = io::CheckedStatus::Ok;
  std::string why;
  const std::shared_ptr<const io::CheckedFile> sums = io::CheckedFile::open(file + ".sum", status, why);
  if (status == io::CheckedStatus::Missing) return "missing";  // a build killed before its digests
  if (!sums) return file + ".sum: " + why;
  const std::optional<std::string> bytes = sums->sections() == 1 ? sums->read(0) : std::nullopt;
  if (!bytes || bytes->size() != 2 * sizeof(io::FileDigest)) return file + ".sum: its digests cannot be read";
  std::array<io::FileDigest, 2> expected{};
  std::memcpy(expected.data(), bytes->data(), bytes->size());
  if (io::digestOfFile(file) != expected[0]) return file + " does not match its checksum";
  if (io::digestOfFile(file + ".ovr") != expected[1]) return file + ".ovr does not match its checksum";
  return {};
}

/// The overview count every one of `bands` has with the same sizes as the first's (0 if any
/// has none).
int commonOverviews(const std::vector<GDALRasterBand*>& bands) {
  int count = bands.front()->GetOverviewCount();
  for (int k = 0; k < count; ++k) {
    GDALRasterBand* first = bands.front()->GetOverview(k);
    for (GDALRasterBand* b : bands) {
      GDALRasterBand* o = k < b->GetOverviewCount() ? b->GetOverview(k) : nullptr;
      if (o == nullptr || first == nullptr || o->GetXSize() != first->GetXSize() ||
          o->GetYSize() != first->GetYSize()) {
        count = k;
        break;
      }
    }
  }
  return count;
}

/// One level's grid in longitude/latitude: its warped VRT and where its cells lie.
struct Level {
  DatasetPtr bands;   ///< a LevelDataset: the chosen bands at this level, counted
  DatasetPtr warped;  ///< those warped into lon/lat, with an alpha band (coverage)
  std::array<double, 6> gt{};
  int width = 0, height = 0;
  [[nodiscard]] double step() const { return std::min(gt[1], -gt[5]); }
};

}  // namespace

struct GlobeImagery::State {
  std::string path;
  ImageryOptions options;
  int channels = 3;
  std::atomic<std::uint64_t> cells{0};  ///< source cells the levels' warps read, all bands
  DatasetPtr source;                    ///< the file
  DatasetPtr overviewSource;            ///< the cache's VRT of the chosen bands and its .ovr (Built, Cached)
  std::vector<Level> levels;            ///< [0] the full resolution, then each overview: in lon/lat
  ImageryOverviews overviews = ImageryOverviews::None;
  std::string overviewFile;
  LonLatRect box{};
  std::vector<std::pair<float, float>> stretch;  ///< per channel: (low, high)
  mutable std::mutex mutex;                      ///< GDAL datasets are read by one thread at a time
};

GlobeImagery::GlobeImagery(std::unique_ptr<State> state) : state_(std::move(state)) {}
GlobeImagery::~GlobeImagery() = default;

const std::string& GlobeImagery::path() const { return state_->path; }
const LonLatRect& GlobeImagery::box() const { return state_->box; }
double GlobeImagery::step() const { return state_->levels.front().step(); }
ImageryOverviews GlobeImagery::overviews() const { return state_->overviews; }
int GlobeImagery::overviewLevels() const { return static_cast<int>(state_->levels.size()) - 1; }
const std::string& GlobeImagery::overviewFile() const { return state_->overviewFile; }
std::uint64_t GlobeImagery::sourcePixelsRead() const {
  return state_->cells.load() / static_cast<std::uint64_t>(state_->channels);
}

Result<std::shared_ptr<GlobeImagery>> GlobeImagery::open(const std::string& path, const std::vector<int>& bands,
                                                         const ImageryOptions& options) {
  geo::detail::ensureGdalRegistered();
  Result<std::shared_ptr<GlobeImagery>> out;
  const auto fail = [&](const std::string& message) {
    out.diagnostics.add({Severity::Error, path, {}, {}, message});
    return std::move(out);
  };
  QuietGdal quiet;
  auto state = std::make_unique<State>();
  state->path = path;
  state->options = options;
  if (bands.size() != 1 && bands.size() != 3)
    return fail("imagery needs 1 (grey) or 3 (red, green, blue) bands, got " + std::to_string(bands.size()));
  state->channels = static_cast<int>(bands.size());
  state->source.reset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!state->source) return fail("cannot open the imagery: " + QuietGdal::lastMessage("GDAL cannot read it"));
  GDALDataset& src = *state->source;
  for (const int b : bands) {
    if (b < 1 || b > src.GetRasterCount())
      return fail("imagery band " + std::to_string(b) + " does not exist (the file has " +
                  std::to_string(src.GetRasterCount()) + ")");
  }
  if (src.GetSpatialRef() == nullptr || src.GetSpatialRef()->IsEmpty())
    return fail("the imagery has no CRS: it cannot be placed on the globe");
  std::array<double, 6> sourceGt{};
  if (src.GetGeoTransform(sourceGt.data()) != CE_None)
    return fail("the imagery has no geotransform: it cannot be placed on the globe");
  std::vector<GDALRasterBand*> fullBands;
  for (const int b : bands) fullBands.push_back(src.GetRasterBand(b));
  const int sw = src.GetRasterXSize(), sh = src.GetRasterYSize();

  // Overview levels: the source's own; else, for large imagery, built once into the cache.
  std::vector<GDALRasterBand*> overviewBands = fullBands;  // whose overviews the levels read
  if (options.overviews && commonOverviews(fullBands) > 0) {
    state->overviews = ImageryOverviews::Source;
  } else if (options.overviews && std::max(sw, sh) > options.buildOverviewsAbove) {
    const std::string size = std::to_string(sw) + " x " + std::to_string(sh);
    const std::string file = options.cacheDir ? overviewCacheFile(path, bands, options.cacheDir()) : std::string();
    const auto openCached = [&]() -> DatasetPtr {
      DatasetPtr vrt(GDALDataset::Open(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
      if (!vrt || vrt->GetRasterXSize() != sw || vrt->GetRasterYSize() != sh ||
          vrt->GetRasterCount() != state->channels)
        return nullptr;
      std::vector<GDALRasterBand*> vb;
      for (int b = 1; b <= state->channels; ++b) vb.push_back(vrt->GetRasterBand(b));
      return commonOverviews(vb) > 0 ? std::move(vrt) : nullptr;
    };
    if (file.empty()) {
      out.diagnostics.add({Severity::Info,
                           path,
                           {},
                           {},
                           "the imagery (" + size + ") has no overviews and none are built (" +
                               (options.cacheDir ? "not a file on disk" : "no cache directory") +
                               "): far views read it at full resolution"});
    } else if (const std::string damage = checkOverviewCache(file);
               damage.empty() && (state->overviewSource = openCached())) {
      state->overviews = ImageryOverviews::Cached;
    } else {
      if (damage != "missing")
        out.diagnostics.add({Severity::Warning,
                             file,
                             {},
                             {},
                             "cache file damaged (" + (damage.empty() ? std::string("it does not open") : damage) +
                                 "); rebuilt from " + path});
      const auto start = std::chrono::steady_clock::now();
      const std::string problem = buildOverviewCache(path, bands, file);
      state->overviewSource = problem.empty() ? openCached() : nullptr;
      if (state->overviewSource) {
        state->overviews = ImageryOverviews::Built;
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        char text[64];
        std::snprintf(text, sizeof text, "%.1f s", seconds);
        out.diagnostics.add(
            {Severity::Info,
             path,
             {},
             {},
             "overviews of the imagery (" + size + ") written once to " + file + " and its .ovr in " + text});
      } else {
        out.diagnostics.add({Severity::Warning,
                             path,
                             {},
                             {},
                             "cannot build the imagery's overviews in the cache (" +
                                 (problem.empty() ? std::string("the files written do not open") : problem) +
                                 "): far views read it at full resolution"});
      }
    }
    if (state->overviewSource) {
      state->overviewFile = file;
      overviewBands.clear();
      for (int b = 1; b <= state->channels; ++b) overviewBands.push_back(state->overviewSource->GetRasterBand(b));
    }
  }

  // Each level's bands warped into WGS 84 lon/lat with an alpha band (coverage); the full
  // resolution on the grid GDAL suggests, each overview on the same box with its cells as many
  // times larger as the overview's are. The transformation is approximated within 0.05 of a cell
  // (GDAL's default is 0.125).
  const int levelCount = state->overviews == ImageryOverviews::None ? 0 : commonOverviews(overviewBands);
  for (int k = 0; k <= levelCount; ++k) {
    std::vector<GDALRasterBand*> levelBands;
    for (GDALRasterBand* b : k == 0 ? fullBands : overviewBands)
      levelBands.push_back(k == 0 ? b : b->GetOverview(k - 1));
    Level level;
    level.bands.reset(new LevelDataset(src, levelBands, fullBands, sourceGt, state->cells));
    std::vector<std::string> args{"-of",       "VRT", "-t_srs", "EPSG:4326", "-r",     "bilinear",
                                  "-dstalpha", "-et", "0.05",   "-ot",       "Float32"};
    if (k > 0) {
      const Level& full = state->levels.front();
      const LonLatRect& b = state->box;
      const auto cellsAcross = [](int fullCells, int levelSource, int fullSource) {
        return std::max(1L, std::lround(static_cast<double>(fullCells) * levelSource / fullSource));
      };
      args.insert(args.end(), {"-te", number(b.west), number(b.south), number(b.east), number(b.north), "-ts",
                               std::to_string(cellsAcross(full.width, level.bands->GetRasterXSize(), sw)),
                               std::to_string(cellsAcross(full.height, level.bands->GetRasterYSize(), sh))});
    }
    const WarpOptions warp(args);
    int usageError = 0;
    GDALDatasetH bandsHandle = GDALDataset::ToHandle(level.bands.get());
    level.warped.reset(GDALDataset::FromHandle(GDALWarp("", nullptr, 1, &bandsHandle, warp.options, &usageError)));
    const bool grid = level.warped && level.warped->GetRasterCount() == state->channels + 1 &&
                      level.warped->GetGeoTransform(level.gt.data()) == CE_None && level.gt[2] == 0.0 &&
                      level.gt[4] == 0.0 && level.gt[1] > 0.0 && level.gt[5] < 0.0;
    if (k == 0 && !level.warped)
      return fail("cannot warp the imagery into longitude/latitude: " + QuietGdal::lastMessage("GDALWarp failed"));
    if (k == 0 && !grid) return fail("the imagery warped into longitude/latitude is not a north-up grid");
    // An overview level that does not warp, or is not coarser than the last: the levels end there.
    if (!grid || (k > 0 && !(level.step() > state->levels.back().step()))) break;
    level.width = level.warped->GetRasterXSize();
    level.height = level.warped->GetRasterYSize();
    if (k == 0) {
      const auto& gt = level.gt;
      state->box = {gt[0], gt[3] + level.height * gt[5], gt[0] + level.width * gt[1], gt[3]};
    }
    state->levels.push_back(std::move(level));
  }
  if (state->levels.size() == 1 && state->overviews != ImageryOverviews::None)
    state->overviews = ImageryOverviews::None;

  // The stretch, from the source bands read at most 1024 samples a side.
  const double shrink = std::max(1.0, std::max(sw, sh) / 1024.0);
  const int rw = std::max(1, static_cast<int>(sw / shrink)), rh = std::max(1, static_cast<int>(sh / shrink));
  for (const int b : bands) {
    GDALRasterBand* band = src.GetRasterBand(b);
    std::vector<float> samples(static_cast<std::size_t>(rw) * static_cast<std::size_t>(rh));
    if (band->RasterIO(GF_Read, 0, 0, sw, sh, samples.data(), rw, rh, GDT_Float32, 0, 0, nullptr) != CE_None)
      return fail("cannot read imagery band " + std::to_string(b) + ": " + QuietGdal::lastMessage("RasterIO failed"));
    int has = 0;
    const double nodata = band->GetNoDataValue(&has);
    std::vector<float> valid;
    valid.reserve(samples.size());
    for (const float v : samples) {
      if (std::isfinite(v) && (has == 0 || static_cast<double>(v) != nodata)) valid.push_back(v);
    }
    const float lo = percentile(valid, options.lowPercentile);
    float hi = percentile(std::move(valid), options.highPercentile);
    if (hi <= lo) hi = lo + 1.0F;
    state->stretch.emplace_back(lo, hi);
  }
  out.value = std::shared_ptr<GlobeImagery>(new GlobeImagery(std::move(state)));
  return out;
}

int GlobeImagery::textureSize(const TileKey& key) const {
  const double cells = key.size() / step();
  return std::clamp(powerOfTwoAtLeast(2.0 * cells), state_->options.minTexels, state_->options.maxTexels);
}

bool GlobeImagery::covers(const TileKey& key) const {
  const LonLatRect r = key.rect();
  const LonLatRect& b = state_->box;
  return r.west < b.east && b.west < r.east && r.south < b.north && b.south < r.north;
}

int GlobeImagery::levelFor(const TileKey& key) const {
  const double texel = key.size() / textureSize(key);
  const std::vector<Level>& levels = state_->levels;
  std::size_t k = 0;
  while (k + 1 < levels.size() && levels[k + 1].step() <= texel * (1.0 + 1e-9)) ++k;
  return static_cast<int>(k);
}

std::optional<TileImage> GlobeImagery::tileImage(const TileKey& key) const {
  if (!covers(key)) return std::nullopt;
  const State& s = *state_;
  const Level& level = s.levels[static_cast<std::size_t>(levelFor(key))];
  const int size = textureSize(key);
  const LonLatRect r = key.rect();
  const double d = key.size() / size;  // degrees a texel
  const auto& gt = level.gt;
  const double x0 = gt[0], y0 = gt[3], x1 = gt[0] + level.width * gt[1], y1 = gt[3] + level.height * gt[5];
  // Texels at or finer than the level's cells: those whose centres lie on its grid (the window
  // clamped to the grid, less than a texel off at the imagery's edges). Coarser ones: those
  // whose whole footprint does, so that the window maps onto them exactly (clamping would shift
  // the texels by up to a level's cell); a partly covered texel at the edge stays transparent.
  // Columns from the west, rows from the north.
  const double lead = d > level.step() * (1.0 + 1e-9) ? 0.0 : 0.5;
  const int c0 = std::max(0, static_cast<int>(std::ceil((x0 - r.west) / d - lead)));
  const int c1 = std::min(size - 1, static_cast<int>(std::floor((x1 - r.west) / d - 1.0 + lead)));
  const int r0 = std::max(0, static_cast<int>(std::ceil((r.north - y0) / d - lead)));
  const int r1 = std::min(size - 1, static_cast<int>(std::floor((r.north - y1) / d - 1.0 + lead)));
  if (c0 > c1 || r0 > r1) return std::nullopt;
  const int bw = c1 - c0 + 1, bh = r1 - r0 + 1;
  // The texels' window in the level's cells, clamped to its grid.
  const double fx0 = std::clamp((r.west + c0 * d - x0) / gt[1], 0.0, static_cast<double>(level.width));
  const double fx1 = std::clamp((r.west + (c1 + 1) * d - x0) / gt[1], 0.0, static_cast<double>(level.width));
  const double fy0 = std::clamp((r.north - r0 * d - y0) / gt[5], 0.0, static_cast<double>(level.height));
  const double fy1 = std::clamp((r.north - (r1 + 1) * d - y0) / gt[5], 0.0, static_cast<double>(level.height));
  if (!(fx1 > fx0) || !(fy1 > fy0)) return std::nullopt;
  GDALRasterIOExtraArg extra;
  INIT_RASTERIO_EXTRA_ARG(extra);
  extra.eResampleAlg = GRIORA_Bilinear;
  extra.bFloatingPointWindowValidity = TRUE;
  extra.dfXOff = fx0;
  extra.dfYOff = fy0;
  extra.dfXSize = fx1 - fx0;
  extra.dfYSize = fy1 - fy0;
  const int ix0 = static_cast<int>(std::floor(fx0)), iy0 = static_cast<int>(std::floor(fy0));
  const int ix1 = std::min(level.width, static_cast<int>(std::ceil(fx1)));
  const int iy1 = std::min(level.height, static_cast<int>(std::ceil(fy1)));
  const int bands = s.channels + 1;
  std::vector<float> buffer(static_cast<std::size_t>(bw) * static_cast<std::size_t>(bh) *
                            static_cast<std::size_t>(bands));
  std::vector<int> bandMap;
  for (int b = 1; b <= bands; ++b) bandMap.push_back(b);
  {
    const std::lock_guard lock(s.mutex);
    QuietGdal quiet;
    const auto pixelSpace = static_cast<GSpacing>(sizeof(float)) * bands;
    if (level.warped->RasterIO(GF_Read, ix0, iy0, std::max(1, ix1 - ix0), std::max(1, iy1 - iy0), buffer.data(), bw, bh,
                               GDT_Float32, bands, bandMap.data(), pixelSpace, pixelSpace * bw,
                               static_cast<GSpacing>(sizeof(float)), &extra) != CE_None)
      return std::nullopt;
  }
  TileImage image;
  image.size = size;
  image.rgba.assign(static_cast<std::size_t>(size) * static_cast<std::size_t>(size) * 4, 0);
  bool any = false;
  for (int row = 0; row < bh; ++row) {
    const int texRow = size - 1 - (r0 + row);  // row 0 of the texture is the south
    for (int col = 0; col < bw; ++col) {
      const float* v = buffer.data() +
                       (static_cast<std::size_t>(row) * static_cast<std::size_t>(bw) + static_cast<std::size_t>(col)) *
                           static_cast<std::size_t>(bands);
      std::uint8_t* t =
          image.rgba.data() +
          (static_cast<std::size_t>(texRow) * static_cast<std::size_t>(size) + static_cast<std::size_t>(c0 + col)) * 4;
      const float alpha = std::isfinite(v[s.channels]) ? std::clamp(v[s.channels], 0.0F, 255.0F) : 0.0F;
      if (alpha <= 0.0F) continue;
      for (int ch = 0; ch < 3; ++ch) {
        const int k = s.channels == 1 ? 0 : ch;
        const auto [lo, hi] = s.stretch[static_cast<std::size_t>(k)];
        const float x = std::isfinite(v[k]) ? std::clamp((v[k] - lo) / (hi - lo), 0.0F, 1.0F) : 0.0F;
        t[ch] = static_cast<std::uint8_t>(std::lround(x * 255.0F));
      }
      t[3] = static_cast<std::uint8_t>(std::lround(alpha));
      any = true;
    }
  }
  if (!any) return std::nullopt;
  return image;
}

}  // namespace gis::globe
