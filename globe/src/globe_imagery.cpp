#include "globe/globe_imagery.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <gdal_utils.h>

#include "geo/gdal_support.hpp"

namespace gis::globe {

namespace {

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

}  // namespace

struct GlobeImagery::State {
  std::string path;
  ImageryOptions options;
  int channels = 3;
  DatasetPtr source, bands, warped;  ///< the file, its chosen bands (VRT), those in lon/lat (warped VRT)
  std::array<double, 6> gt{};        ///< the warped grid's geotransform
  int width = 0, height = 0;
  LonLatRect box{};
  std::vector<std::pair<float, float>> stretch;  ///< per channel: (low, high)
  mutable std::mutex mutex;                      ///< GDAL datasets are read by one thread at a time
};

GlobeImagery::GlobeImagery(std::unique_ptr<State> state) : state_(std::move(state)) {}
GlobeImagery::~GlobeImagery() = default;

const std::string& GlobeImagery::path() const { return state_->path; }
const LonLatRect& GlobeImagery::box() const { return state_->box; }
double GlobeImagery::step() const { return std::min(state_->gt[1], -state_->gt[5]); }

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

  // The chosen bands, then those warped into WGS 84 lon/lat with an alpha band (coverage).
  std::vector<std::string> translateArgs{"-of", "VRT"};
  for (const int b : bands) translateArgs.insert(translateArgs.end(), {"-b", std::to_string(b)});
  const TranslateOptions translate(translateArgs);
  int usageError = 0;
  state->bands.reset(
      GDALDataset::FromHandle(GDALTranslate("", GDALDataset::ToHandle(&src), translate.options, &usageError)));
  if (!state->bands)
    return fail("cannot select the imagery's bands: " + QuietGdal::lastMessage("GDALTranslate failed"));
  // The transformation is approximated within 0.05 of a cell (GDAL's default is 0.125).
  const WarpOptions warp(
      {"-of", "VRT", "-t_srs", "EPSG:4326", "-r", "bilinear", "-dstalpha", "-et", "0.05", "-ot", "Float32"});
  GDALDatasetH bandsHandle = GDALDataset::ToHandle(state->bands.get());
  state->warped.reset(GDALDataset::FromHandle(GDALWarp("", nullptr, 1, &bandsHandle, warp.options, &usageError)));
  if (!state->warped)
    return fail("cannot warp the imagery into longitude/latitude: " + QuietGdal::lastMessage("GDALWarp failed"));
  GDALDataset& w = *state->warped;
  if (w.GetRasterCount() != state->channels + 1 || w.GetGeoTransform(state->gt.data()) != CE_None ||
      state->gt[2] != 0.0 || state->gt[4] != 0.0 || !(state->gt[1] > 0.0) || !(state->gt[5] < 0.0))
    return fail("the imagery warped into longitude/latitude is not a north-up grid");
  state->width = w.GetRasterXSize();
  state->height = w.GetRasterYSize();
  const auto& gt = state->gt;
  state->box = {gt[0], gt[3] + state->height * gt[5], gt[0] + state->width * gt[1], gt[3]};

  // The stretch, from the source bands read at most 1024 samples a side.
  const int sw = src.GetRasterXSize(), sh = src.GetRasterYSize();
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

std::optional<TileImage> GlobeImagery::tileImage(const TileKey& key) const {
  if (!covers(key)) return std::nullopt;
  const State& s = *state_;
  const int size = textureSize(key);
  const LonLatRect r = key.rect();
  const double d = key.size() / size;  // degrees a texel
  const auto& gt = s.gt;
  const double x0 = gt[0], y0 = gt[3], x1 = gt[0] + s.width * gt[1], y1 = gt[3] + s.height * gt[5];
  // Texels whose centres lie on the warped grid: columns from the west, rows from the north.
  const int c0 = std::max(0, static_cast<int>(std::ceil((x0 - r.west) / d - 0.5)));
  const int c1 = std::min(size - 1, static_cast<int>(std::floor((x1 - r.west) / d - 0.5)));
  const int r0 = std::max(0, static_cast<int>(std::ceil((r.north - y0) / d - 0.5)));
  const int r1 = std::min(size - 1, static_cast<int>(std::floor((r.north - y1) / d - 0.5)));
  if (c0 > c1 || r0 > r1) return std::nullopt;
  const int bw = c1 - c0 + 1, bh = r1 - r0 + 1;
  // The texels' window in the warped grid's cells, clamped to the grid.
  const double fx0 = std::clamp((r.west + c0 * d - x0) / gt[1], 0.0, static_cast<double>(s.width));
  const double fx1 = std::clamp((r.west + (c1 + 1) * d - x0) / gt[1], 0.0, static_cast<double>(s.width));
  const double fy0 = std::clamp((r.north - r0 * d - y0) / gt[5], 0.0, static_cast<double>(s.height));
  const double fy1 = std::clamp((r.north - (r1 + 1) * d - y0) / gt[5], 0.0, static_cast<double>(s.height));
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
  const int ix1 = std::min(s.width, static_cast<int>(std::ceil(fx1)));
  const int iy1 = std::min(s.height, static_cast<int>(std::ceil(fy1)));
  const int bands = s.channels + 1;
  std::vector<float> buffer(static_cast<std::size_t>(bw) * static_cast<std::size_t>(bh) *
                            static_cast<std::size_t>(bands));
  std::vector<int> bandMap;
  for (int b = 1; b <= bands; ++b) bandMap.push_back(b);
  {
    const std::lock_guard lock(s.mutex);
    QuietGdal quiet;
    const auto pixelSpace = static_cast<GSpacing>(sizeof(float)) * bands;
    if (s.warped->RasterIO(GF_Read, ix0, iy0, std::max(1, ix1 - ix0), std::max(1, iy1 - iy0), buffer.data(), bw, bh,
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
