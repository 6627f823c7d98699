#include "globe/geo_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "geo/raster.hpp"

namespace gis::globe {

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

Result<GeoGrid> GeoGrid::fromRaster(const std::string& path) {
  Result<geo::Raster> raster = geo::readRasterInCrs(path, {1}, "EPSG:4326");
  Result<GeoGrid> out;
  out.diagnostics = raster.diagnostics;
  if (!raster.ok()) return out;
  const geo::RasterInfo& info = raster->info;
  const auto& c = info.geoTransform.c;
  if (c[2] != 0.0 || c[4] != 0.0 || c[1] <= 0.0 || c[5] >= 0.0 || std::abs(c[1] + c[5]) > 1e-9 * c[1]) {
    out.diagnostics.add(
        {Severity::Error, path, {}, {}, "the DEM is not a north-up grid of square cells in longitude and latitude"});
    return out;
  }
  std::vector<float> heights(raster->samples);
  std::size_t holes = 0;
  for (float& h : heights) {
    if (!std::isfinite(h) || std::abs(h) > 1e5F) {
      h = 0.0F;
      ++holes;
    }
  }
  if (holes > 0)
    out.diagnostics.add(
        {Severity::Warning,
         path,
         {},
         {},
         std::to_string(holes) + " posts without a height (nodata) are drawn at the ellipsoid (height 0)"});
  // Posts at the centres of the raster's cells.
  out.value.emplace(info.width, info.height, c[0] + 0.5 * c[1], c[3] + 0.5 * c[5], c[1], std::move(heights));
  return out;
}

double GeoGrid::post(int c, int r) const {
  if (r < 0 || r >= height_) return 0.0;
  if (wraps_) {
    c %= width_;
    if (c < 0) c += width_;
  } else if (c < 0 || c >= width_) {
    return 0.0;
  }
  return heights_[static_cast<std::size_t>(r) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(c)];
}

double GeoGrid::heightAt(double lonDeg, double latDeg) const {
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
  int w = width_, h = height_;
  pyramid_.push_back(std::move(level));
  pyramidSize_.emplace_back(w, h);
  while (w > 1 || h > 1) {
    const int nw = (w + 1) / 2, nh = (h + 1) / 2;
    const auto& prev = pyramid_.back();
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
    pyramid_.push_back(std::move(next));
    pyramidSize_.emplace_back(nw, nh);
    w = nw;
    h = nh;
  }
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
  std::size_t k = 0;
  while (k + 1 < pyramid_.size() && ((c1 - c0) >> k) > 16 && ((r1 - r0) >> k) > 16) ++k;
  while (k + 1 < pyramid_.size() && (((c1 - c0) >> k) > 64 || ((r1 - r0) >> k) > 64)) ++k;
  const auto& level = pyramid_[k];
  const long w = pyramidSize_[k].first;
  for (long r = r0 >> k; r <= (r1 >> k); ++r) {
    for (long c = c0 >> k; c <= (c1 >> k); ++c) {
      const auto& v = level[static_cast<std::size_t>(r * w + c)];
      include(v.first, v.second);
    }
  }
  return {lo, hi};
}

std::pair<double, double> GeoGrid::bounds(const LonLatRect& box) const {
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
