#include "globe/geo_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include "geo/gdal_support.hpp"
#include "geo/raster.hpp"

namespace gis::globe {

namespace {

/// Bytes a post of a GeoGrid takes while it is read and kept: the heights (4), the min/max
/// pyramid (8 · 4/3) and the warped grid they are read from (4), rounded up.
constexpr double kBytesPerPost = 20.0;

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
    // Where the tile lands in lon/lat, and the resolution that keeps its posts.
    const std::string dst = "DST_SRS=" + wgs84Wkt;
    const char* const transformerOptions[] = {dst.c_str(), nullptr};
    void* transformer = GDALCreateGenImgProjTransformer2(GDALDataset::ToHandle(vrt.get()), nullptr,
                                                         const_cast<char**>(transformerOptions));
    double gt[6];
    int pixels = 0, lines = 0;
    const bool placed =
        transformer != nullptr && GDALSuggestedWarpOutput(GDALDataset::ToHandle(vrt.get()), GDALGenImgProjTransform,
                                                          transformer, gt, &pixels, &lines) == CE_None;
    if (transformer != nullptr) GDALDestroyGenImgProjTransformer(transformer);
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
  if (options.memoryBudgetMb > 0.0 && megabytes > options.memoryBudgetMb) {
    return fail((options.sceneFile.empty() ? std::string() : options.sceneFile + ": ") + "the DEM " + label +
                " would take " + format(megabytes, 4) + " MB in memory on the globe (" + format(cols, 10) + " x " +
                format(rows, 10) + " posts of " + format(step * 3600.0, 4) +
                "\"), more than terrain.memory_budget_mb (" + format(options.memoryBudgetMb, 6) +
                "): the globe reads its DEM whole (paging on the globe is not built); cut the DEM or raise the budget");
  }
  const int width = static_cast<int>(cols), height = static_cast<int>(rows);

  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  if (mem == nullptr) return fail("GDAL has no MEM driver");
  DatasetPtr grid(mem->Create("", width, height, 1, GDT_Float32, nullptr));
  if (!grid) return fail("cannot allocate the DEM grid: " + QuietGdal::lastMessage("no message"));
  double gt[6] = {west, step, 0.0, north, 0.0, -step};
  grid->SetGeoTransform(gt);
  grid->SetSpatialRef(&wgs84);
  grid->GetRasterBand(1)->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());
  grid->GetRasterBand(1)->Fill(std::numeric_limits<double>::quiet_NaN());
  // Bilinear, exact transformation (no approximation), nodata kept out of the heights. The grid
  // starts as nodata (above); no INIT_DEST, which would wipe one tile's posts with the next's pass.
  WarpOptions warp({"-r", "bilinear", "-et", "0", "-dstnodata", "nan"});
  std::vector<GDALDatasetH> handles;
  for (const DatasetPtr& b : bands) handles.push_back(GDALDataset::ToHandle(b.get()));
  int usageError = 0;
  if (GDALWarp(nullptr, GDALDataset::ToHandle(grid.get()), static_cast<int>(handles.size()), handles.data(),
               warp.options, &usageError) == nullptr) {
    return fail("cannot resample the DEM into longitude/latitude: " + QuietGdal::lastMessage("GDALWarp failed"));
  }
  std::vector<float> heights(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  if (grid->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, width, height, heights.data(), width, height, GDT_Float32, 0, 0,
                                       nullptr) != CE_None) {
    return fail("cannot read the resampled DEM: " + QuietGdal::lastMessage("RasterIO failed"));
  }
  grid.reset();
  bands.clear();
  files.clear();

  // Holes (nodata, or an undeclared nodata value) at height 0 of the DEM's datum.
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
         label,
         {},
         {},
         std::to_string(holes) + " posts without a height (nodata) are drawn at height 0 of the DEM's vertical datum"});

  // The vertical datum.
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
  std::string verticalSource = "ellipsoid";
  if (geoid) {
    Result<TransformPtr> t = geoidTransform(*geoid, what, gridName);
    for (Diagnostic d : t.diagnostics.items()) {
      d.file = label;
      out.diagnostics.add(std::move(d));
    }
    if (!t.ok()) return out;
    std::vector<double> x(static_cast<std::size_t>(width)), y(x.size()), z(x.size());
    std::vector<int> ok(x.size());
    std::size_t failed = 0;
    for (int r = 0; r < height; ++r) {
      const double lat = north - (r + 0.5) * step;
      float* row = heights.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(width);
      for (int c = 0; c < width; ++c) {
        const auto k = static_cast<std::size_t>(c);
        x[k] = west + (c + 0.5) * step;
        y[k] = lat;
        z[k] = row[c];
      }
      (*t)->Transform(width, x.data(), y.data(), z.data(), nullptr, ok.data());
      for (int c = 0; c < width; ++c) {
        const auto k = static_cast<std::size_t>(c);
        if (ok[k] != 0 && std::isfinite(z[k])) {
          row[c] = static_cast<float>(z[k]);
        } else {
          ++failed;
        }
      }
    }
    if (failed > 0)
      out.diagnostics.add({Severity::Warning,
                           label,
                           {},
                           {},
                           std::to_string(failed) + " posts could not be converted from " + what +
                               " to the ellipsoid (kept as they are)"});
    verticalSource = what;
  }
  // Posts at the centres of the grid's cells.
  out.value.emplace(width, height, west + 0.5 * step, north - 0.5 * step, step, std::move(heights));
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
