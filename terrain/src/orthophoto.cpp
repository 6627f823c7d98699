#include "terrain/orthophoto.hpp"

#include <algorithm>
#include <cmath>

namespace gis::terrain {
namespace {

/// Value at a percentile of the finite samples of one channel (nearest rank).
float percentile(std::vector<float> values, double pct) {
  if (values.empty()) return 0.0F;
  const double rank = std::clamp(pct / 100.0, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto k = static_cast<std::ptrdiff_t>(std::llround(rank));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

}  // namespace

Result<Orthophoto> makeOrthophoto(const geo::Raster& imagery, const StretchOptions& options) {
  const int channels = imagery.channels();
  if (channels != 1 && channels != 3) {
    return Result<Orthophoto>::failure(
        {Severity::Error, imagery.info.path, "", "", "imagery needs 1 or 3 bands, got " + std::to_string(channels)});
  }
  const std::size_t pixelCount =
      static_cast<std::size_t>(imagery.info.width) * static_cast<std::size_t>(imagery.info.height);
  Orthophoto photo;
  photo.width = imagery.info.width;
  photo.height = imagery.info.height;
  photo.rgba.assign(pixelCount * 4, 0);

  const auto nc = static_cast<std::size_t>(channels);
  for (std::size_t ch = 0; ch < nc; ++ch) {
    std::vector<float> valid;
    valid.reserve(pixelCount);
    for (std::size_t i = 0; i < pixelCount; ++i) {
      const float v = imagery.samples[i * nc + ch];
      if (std::isfinite(v)) valid.push_back(v);
    }
    const float lo = percentile(valid, options.lowPercentile);
    float hi = percentile(std::move(valid), options.highPercentile);
    if (hi <= lo) hi = lo + 1.0F;
    for (std::size_t i = 0; i < pixelCount; ++i) {
      const float v = imagery.samples[i * nc + ch];
      const float t = std::isfinite(v) ? std::clamp((v - lo) / (hi - lo), 0.0F, 1.0F) : 0.0F;
      const auto byte = static_cast<std::uint8_t>(std::lround(t * 255.0F));
      if (channels == 1) {
        photo.rgba[i * 4 + 0] = photo.rgba[i * 4 + 1] = photo.rgba[i * 4 + 2] = byte;
      } else {
        photo.rgba[i * 4 + ch] = byte;
      }
    }
  }
  for (std::size_t i = 0; i < pixelCount; ++i) {
    bool ok = true;
    for (std::size_t ch = 0; ch < nc; ++ch) ok = ok && std::isfinite(imagery.samples[i * nc + ch]);
    photo.rgba[i * 4 + 3] = ok ? 255 : 0;
  }
  Result<Orthophoto> result;
  result.value = std::move(photo);
  return result;
}

}  // namespace gis::terrain
