#include "synth/synthetic_vectors.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <numbers>
#include <random>
#include <vector>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "gdal_util.hpp"

namespace gis::synth {
namespace {

using detail::parseCrs;
using detail::QuietGdal;

constexpr int kAreaPoints = kPaperAreaPoints / kPaperAreas;  // 151 per area
/// Roads: 80 of every 144 have 131 points, the others 130 (18,800 in all).
constexpr int kLongRoads = kPaperRoadPoints - kPaperRoads * (kPaperRoadPoints / kPaperRoads);
static_assert(kAreaPoints * kPaperAreas == kPaperAreaPoints);

/// Uniform doubles from a standard engine (its sequence is fixed by the standard, unlike the
/// library's distributions), so a seed gives the same features everywhere.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

 private:
  std::mt19937_64 engine_;
};

struct Rect {
  double minX, minY, maxX, maxY;
  [[nodiscard]] double width() const { return maxX - minX; }
  [[nodiscard]] double height() const { return maxY - minY; }
  [[nodiscard]] double extent() const { return std::min(width(), height()); }
};

/// A star-shaped ring of kAreaPoints points around a random centre: the radius varies smoothly
/// with the angle but stays within [0.6, 1.4] of its mean, so the ring is simple.
std::vector<std::array<double, 2>> areaRing(Random& rng, const Rect& r) {
  const double cx = r.minX + rng.uniform(0.1, 0.9) * r.width();
  const double cy = r.minY + rng.uniform(0.1, 0.9) * r.height();
  const double radius = rng.uniform(0.003, 0.012) * r.extent();
  std::array<double, 4> phase{}, amplitude{};
  for (std::size_t k = 0; k < phase.size(); ++k) {
    phase[k] = rng.uniform(0.0, 2.0 * std::numbers::pi);
    amplitude[k] = rng.uniform(0.0, 0.3) / static_cast<double>(k + 2);
  }
  std::vector<std::array<double, 2>> ring;
  ring.reserve(kAreaPoints);
  for (int j = 0; j < kAreaPoints; ++j) {
    const double a = 2.0 * std::numbers::pi * j / kAreaPoints;
    double f = 1.0;
    for (std::size_t k = 0; k < phase.size(); ++k)
      f += amplitude[k] * std::sin(static_cast<double>(k + 2) * a + phase[k]);
    ring.push_back({cx + radius * f * std::cos(a), cy + radius * f * std::sin(a)});
  }
  return ring;
}

/// A smooth random walk of `points` points, steps of 0.08 % of the extent (about 260 m over
/// 330 km), turning back towards the centre near the rectangle's edge.
std::vector<std::array<double, 2>> roadLine(Random& rng, const Rect& r, int points) {
  double x = r.minX + rng.uniform(0.05, 0.95) * r.width();
  double y = r.minY + rng.uniform(0.05, 0.95) * r.height();
  double heading = rng.uniform(0.0, 2.0 * std::numbers::pi), turn = 0.0;
  const double step = 0.0008 * r.extent(), margin = 0.02 * r.extent();
  std::vector<std::array<double, 2>> line;
  line.reserve(static_cast<std::size_t>(points));
  line.push_back({x, y});
  for (int j = 1; j < points; ++j) {
    turn = 0.8 * turn + rng.uniform(-0.08, 0.08);
    heading += turn;
    const double nx = x + step * std::cos(heading), ny = y + step * std::sin(heading);
    if (nx < r.minX + margin || nx > r.maxX - margin || ny < r.minY + margin || ny > r.maxY - margin) {
      // Head for the centre, with a little noise, and go on from there.
      heading = std::atan2(0.5 * (r.minY + r.maxY) - y, 0.5 * (r.minX + r.maxX) - x) + rng.uniform(-0.5, 0.5);
      turn = 0.0;
    }
    x += step * std::cos(heading);
    y += step * std::sin(heading);
    line.push_back({x, y});
  }
  return line;
}

/// One GeoPackage with one layer, written in a single transaction.
class LayerWriter {
 public:
  LayerWriter(const std::string& path, const char* layerName, OGRwkbGeometryType type, OGRSpatialReference* srs,
              std::string& error)
      : path_(path) {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
    if (driver == nullptr) {
      error = "GDAL has no GPKG driver";
      return;
    }
    std::error_code ec;
    std::filesystem::remove(path, ec);
    ds_.reset(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!ds_) {
      error = "cannot create the GeoPackage: " + QuietGdal::lastMessage("GDAL could not create it");
      return;
    }
    layer_ = ds_->CreateLayer(layerName, srs, type, nullptr);
    if (layer_ == nullptr) {
      error = "cannot create layer '" + std::string(layerName) + "': " + QuietGdal::lastMessage("unknown GDAL error");
      return;
    }
    OGRFieldDefn name("name", OFTString);
    OGRFieldDefn width("width_m", OFTReal);
    if (layer_->CreateField(&name) != OGRERR_NONE ||
        (type == wkbLineString && layer_->CreateField(&width) != OGRERR_NONE)) {
      error = "cannot create the attribute fields: " + QuietGdal::lastMessage("unknown GDAL error");
      layer_ = nullptr;
      return;
    }
    if (ds_->StartTransaction() != OGRERR_NONE) {
      error = "cannot start a transaction: " + QuietGdal::lastMessage("unknown GDAL error");
      layer_ = nullptr;
    }
  }

  [[nodiscard]] bool ok() const { return layer_ != nullptr; }

  bool add(const std::string& name, std::unique_ptr<OGRGeometry> geometry, double widthMetres, std::string& error) {
    OGRFeature feature(layer_->GetLayerDefn());
    feature.SetField("name", name.c_str());
    if (widthMetres > 0.0) feature.SetField("width_m", widthMetres);
    feature.SetGeometryDirectly(geometry.release());
    if (layer_->CreateFeature(&feature) != OGRERR_NONE) {
      error = "cannot write feature '" + name + "': " + QuietGdal::lastMessage("unknown GDAL error");
      return false;
    }
    return true;
  }

  bool finish(std::string& error) {
    if (ds_->CommitTransaction() != OGRERR_NONE) {
      error = "cannot commit: " + QuietGdal::lastMessage("unknown GDAL error");
      return false;
    }
    CPLErrorReset();
    ds_.reset();
    if (CPLGetLastErrorType() == CE_Failure) {
      error = "cannot finish the file: " + QuietGdal::lastMessage("unknown GDAL error");
      return false;
    }
    return true;
  }

  /// Closes and removes a partly written file.
  void abandon() {
    ds_.reset();
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }

 private:
  struct Close {
    void operator()(GDALDataset* d) const { GDALClose(GDALDataset::ToHandle(d)); }
  };
  std::string path_;
  std::unique_ptr<GDALDataset, Close> ds_;
  OGRLayer* layer_ = nullptr;
};

}  // namespace

std::string checkSyntheticVectorOptions(const SyntheticVectorOptions& o) {
  if (o.scale < 1 || o.scale > 10000) return "scale must be 1 .. 10000, not " + std::to_string(o.scale);
  if (!(o.maxX > o.minX) || !(o.maxY > o.minY) || !std::isfinite(o.maxX - o.minX) || !std::isfinite(o.maxY - o.minY))
    return "the rectangle is empty or not finite";
  if (!(o.roadWidthMetres > 0.0) || !std::isfinite(o.roadWidthMetres)) return "the road width must be positive";
  return {};
}

Result<SyntheticVectorSummary> writeSyntheticVectors(const std::string& areasPath, const std::string& roadsPath,
                                                     const SyntheticVectorOptions& options) {
  auto fail = [](const std::string& file, const std::string& message) {
    return Result<SyntheticVectorSummary>::failure({Severity::Error, file, "", "", message});
  };
  if (std::string error = checkSyntheticVectorOptions(options); !error.empty())
    return fail(areasPath, "invalid options: " + error);
  static std::once_flag registered;
  std::call_once(registered, [] { GDALAllRegister(); });
  QuietGdal quiet;
  OGRSpatialReference srs;
  if (std::string error; !options.crs.empty() && !parseCrs(options.crs, srs, error)) return fail(areasPath, error);
  OGRSpatialReference* crs = options.crs.empty() ? nullptr : &srs;
  const Rect rect{options.minX, options.minY, options.maxX, options.maxY};

  SyntheticVectorSummary summary;
  summary.areasPath = areasPath;
  summary.roadsPath = roadsPath;
  std::string error;
  {
    Random rng(options.seed * 0x9E3779B97F4A7C15ULL + 1);
    LayerWriter writer(areasPath, "areas", wkbPolygon, crs, error);
    if (!writer.ok()) return fail(areasPath, error);
    const int areas = kPaperAreas * options.scale;
    for (int i = 0; i < areas; ++i) {
      auto ring = std::make_unique<OGRLinearRing>();
      const auto points = areaRing(rng, rect);
      for (const auto& p : points) ring->addPoint(p[0], p[1]);
      ring->closeRings();
      auto polygon = std::make_unique<OGRPolygon>();
      polygon->addRingDirectly(ring.release());
      if (!writer.add("area " + std::to_string(i + 1), std::move(polygon), 0.0, error)) {
        writer.abandon();
        return fail(areasPath, error);
      }
      ++summary.areas;
      summary.areaPoints += points.size();
    }
    if (!writer.finish(error)) {
      writer.abandon();
      return fail(areasPath, error);
    }
  }
  {
    Random rng(options.seed * 0x9E3779B97F4A7C15ULL + 2);
    LayerWriter writer(roadsPath, "roads", wkbLineString, crs, error);
    if (!writer.ok()) return fail(roadsPath, error);
    const int roads = kPaperRoads * options.scale;
    for (int i = 0; i < roads; ++i) {
      const int points = kPaperRoadPoints / kPaperRoads + (i % kPaperRoads < kLongRoads ? 1 : 0);
      const auto line = roadLine(rng, rect, points);
      auto geometry = std::make_unique<OGRLineString>();
      geometry->setNumPoints(static_cast<int>(line.size()));
      for (std::size_t j = 0; j < line.size(); ++j) geometry->setPoint(static_cast<int>(j), line[j][0], line[j][1]);
      summary.roadKilometres += geometry->get_Length() / 1000.0;
      if (!writer.add("road " + std::to_string(i + 1), std::move(geometry), options.roadWidthMetres, error)) {
        writer.abandon();
        return fail(roadsPath, error);
      }
      ++summary.roads;
      summary.roadPoints += line.size();
    }
    if (!writer.finish(error)) {
      writer.abandon();
      return fail(roadsPath, error);
    }
  }
  Result<SyntheticVectorSummary> result;
  result.value = std::move(summary);
  return result;
}

}  // namespace gis::synth
