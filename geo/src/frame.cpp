#include "geo/frame.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <vector>

#include <GeographicLib/UTMUPS.hpp>

#include "geo/gdal_support.hpp"
#include "geo/raster.hpp"

namespace gis::geo {

namespace {

struct CtDeleter {
  void operator()(OGRCoordinateTransformation* ct) const {
    if (ct != nullptr) OCTDestroyCoordinateTransformation(OGRCoordinateTransformation::ToHandle(ct));
  }
};
using CtPtr = std::unique_ptr<OGRCoordinateTransformation, CtDeleter>;

/// Creates source → target; both SRSs must already have traditional axis order.
CtPtr makeTransform(const OGRSpatialReference& source, const OGRSpatialReference& target, std::string& error) {
  detail::QuietGdal quiet;
  CtPtr ct(OGRCreateCoordinateTransformation(&source, &target));
  if (!ct) error = detail::QuietGdal::lastMessage("no coordinate operation between the CRSs");
  return ct;
}

/// EPSG code of the CRS itself (for a bound CRS: of its source CRS), never of a base CRS.
std::optional<int> epsgOf(const OGRSpatialReference& srs) {
  const char* name = srs.GetAuthorityName(nullptr);
  const char* code = srs.GetAuthorityCode(nullptr);
  if (name == nullptr || code == nullptr || std::string(name) != "EPSG") return std::nullopt;
  char* end = nullptr;
  const long value = std::strtol(code, &end, 10);
  if (end == code || *end != '\0' || value <= 0 || value > std::numeric_limits<int>::max()) return std::nullopt;
  return static_cast<int>(value);
}

bool finite2(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// CrsTransform

struct CrsTransform::Impl {
  CtPtr ct;
  bool sourceGeographic = false;
  double semiMajor = 0.0;
  double flattening = 0.0;
  // One OGRCoordinateTransformation must not be used from two threads at once.
  mutable std::mutex mutex;
};

CrsTransform::CrsTransform(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CrsTransform::CrsTransform(CrsTransform&&) noexcept = default;
CrsTransform& CrsTransform::operator=(CrsTransform&&) noexcept = default;
CrsTransform::~CrsTransform() = default;

bool CrsTransform::transform(glm::dvec2* points, std::size_t count) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!impl_ || !impl_->ct) {
    std::fill(points, points + count, glm::dvec2(nan));
    return count == 0;
  }
  // OGR takes an int count; transform in chunks, in separate x/y arrays.
  constexpr std::size_t kChunk = 1u << 16;
  std::vector<double> xs;
  std::vector<double> ys;
  std::vector<int> ok;
  bool allOk = true;
  detail::QuietGdal quiet;
  const std::lock_guard lock(impl_->mutex);
  for (std::size_t begin = 0; begin < count; begin += kChunk) {
    const std::size_t n = std::min(kChunk, count - begin);
    xs.resize(n);
    ys.resize(n);
    ok.assign(n, 0);
    // Non-finite input never reaches PROJ: some operations pass NaN through as "success".
    std::vector<std::size_t> finiteIndex;
    finiteIndex.reserve(n);
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const glm::dvec2& p = points[begin + i];
      if (finite2(p.x, p.y)) {
        xs[m] = p.x;
        ys[m] = p.y;
        finiteIndex.push_back(i);
        ++m;
      }
    }
    if (m > 0) impl_->ct->Transform(static_cast<int>(m), xs.data(), ys.data(), nullptr, ok.data());
    for (std::size_t i = 0; i < n; ++i) points[begin + i] = glm::dvec2(nan);
    if (m < n) allOk = false;
    for (std::size_t k = 0; k < m; ++k) {
      if (ok[k] != 0 && finite2(xs[k], ys[k])) {
        points[begin + finiteIndex[k]] = glm::dvec2(xs[k], ys[k]);
      } else {
        allOk = false;
      }
    }
  }
  return allOk;
}

std::optional<glm::dvec2> CrsTransform::transform(const glm::dvec2& p) const {
  glm::dvec2 q = p;
  if (!transform(&q, 1)) return std::nullopt;
  return q;
}

bool CrsTransform::sourceIsGeographic() const { return impl_ && impl_->sourceGeographic; }
double CrsTransform::sourceSemiMajor() const { return impl_ ? impl_->semiMajor : 0.0; }
double CrsTransform::sourceFlattening() const { return impl_ ? impl_->flattening : 0.0; }

// ---------------------------------------------------------------------------------------------
// SceneFrame

struct SceneFrame::Impl {
  detail::SrsPtr projected;   // the frame CRS (traditional axis order)
  detail::SrsPtr geographic;  // its own geographic CRS (lon, lat)
  std::string wkt;
  std::optional<int> epsg;
  CtPtr toProjected;   // geographic → projected
  CtPtr toGeographic;  // projected → geographic
  mutable std::mutex mutex;

  /// Builds everything from a projected CRS; null with `error` set on failure.
  static std::unique_ptr<Impl> make(const OGRSpatialReference& crs, std::string& error) {
    detail::QuietGdal quiet;
    auto impl = std::make_unique<Impl>();
    impl->projected = detail::cloneTraditional(crs);
    if (!impl->projected) {
      error = "cannot copy the CRS";
      return nullptr;
    }
    impl->geographic.reset(impl->projected->CloneGeogCS());
    if (!impl->geographic) {
      error = "the CRS has no geographic base CRS";
      return nullptr;
    }
    impl->geographic->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    impl->wkt = detail::toWkt(*impl->projected);
    impl->epsg = epsgOf(*impl->projected);
    impl->toProjected = makeTransform(*impl->geographic, *impl->projected, error);
    if (!impl->toProjected) return nullptr;
    impl->toGeographic = makeTransform(*impl->projected, *impl->geographic, error);
    if (!impl->toGeographic) return nullptr;
    return impl;
  }
};

SceneFrame::SceneFrame(std::unique_ptr<Impl> impl, const glm::dvec3& origin)
    : impl_(std::move(impl)), origin_(origin) {}

SceneFrame::SceneFrame(const SceneFrame& other) : origin_(other.origin_) {
  if (other.impl_) {
    std::string error;
    impl_ = Impl::make(*other.impl_->projected, error);  // cannot fail: it worked once
  }
}

SceneFrame& SceneFrame::operator=(const SceneFrame& other) {
  if (this != &other) {
    SceneFrame copy(other);
    *this = std::move(copy);
  }
  return *this;
}

SceneFrame::SceneFrame(SceneFrame&&) noexcept = default;
SceneFrame& SceneFrame::operator=(SceneFrame&&) noexcept = default;
SceneFrame::~SceneFrame() = default;

Result<SceneFrame> SceneFrame::fromCrs(const std::string& crs, const glm::dvec3& origin) {
  std::string error;
  const detail::SrsPtr srs = detail::parseSrs(crs, error);
  if (!srs) return Result<SceneFrame>::failure({Severity::Error, "", "", "", "scene frame: " + error});
  if (srs->IsProjected() == 0) {
    const char* name = srs->GetName();
    return Result<SceneFrame>::failure({Severity::Error, "", "", "",
                                        "scene frame: CRS '" + std::string(name != nullptr ? name : crs) +
                                            "' is not projected; the scene frame needs a projected CRS in metres"});
  }
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z)) {
    return Result<SceneFrame>::failure({Severity::Error, "", "", "", "scene frame: origin is not finite"});
  }
  auto impl = Impl::make(*srs, error);
  if (!impl) return Result<SceneFrame>::failure({Severity::Error, "", "", "", "scene frame: " + error});
  Result<SceneFrame> r;
  r.value.emplace(SceneFrame(std::move(impl), origin));
  return r;
}

SceneFrame SceneFrame::wgs84LonLat() {
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  std::string error;
  auto impl = Impl::make(wgs84, error);  // a well-known CRS: cannot fail
  return SceneFrame(std::move(impl), glm::dvec3(0.0));
}

bool SceneFrame::geographic() const { return impl_ && impl_->projected->IsGeographic() != 0; }

Result<SceneFrame> SceneFrame::forRaster(const RasterInfo& dem) {
  auto fail = [&dem](const std::string& message) {
    return Result<SceneFrame>::failure({Severity::Error, dem.path, "", "", message});
  };
  if (dem.crsWkt.empty()) return fail("raster has no CRS; cannot place it in a scene frame");
  if (dem.width <= 0 || dem.height <= 0) return fail("raster has no pixels");
  if (!dem.geoTransform.finite()) return fail("the raster's geotransform has a NaN or infinite value");
  const glm::dvec2 centre = dem.geoTransform.pixelToCrs(0.5 * dem.width, 0.5 * dem.height);

  // A projected CRS in metres is the frame; one in feet (a US State Plane DEM, say) is not: the
  // frame is in metres, so such a DEM gets the UTM zone of its centre as a geographic one does.
  bool metres = false;
  if (dem.crsIsProjected) {
    std::string error;
    const detail::SrsPtr srs = detail::parseSrs(dem.crsWkt, error);
    metres = srs && std::abs(srs->GetLinearUnits() - 1.0) < 1e-9;
  }
  if (dem.crsIsProjected && metres) {
    Result<SceneFrame> r = fromCrs(dem.crsWkt, glm::dvec3(centre, 0.0));
    if (!r) {
      const auto& items = r.diagnostics.items();
      return fail(items.empty() ? "cannot create a scene frame from the raster CRS" : items.front().message);
    }
    return r;
  }
  if (!dem.crsIsGeographic && !dem.crsIsProjected) return fail("raster CRS is neither projected nor geographic");

  // Geographic DEM (or projected in feet): lon/lat of the centre on WGS 84 picks the UTM zone.
  std::string error;
  const detail::SrsPtr src = detail::parseSrs(dem.crsWkt, error);
  if (!src) return fail(error);
  glm::dvec2 lonLat(0.0);
  {
    detail::QuietGdal quiet;
    OGRSpatialReference wgs84;
    wgs84.SetWellKnownGeogCS("WGS84");
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    CtPtr ct = makeTransform(*src, wgs84, error);
    if (!ct) return fail("cannot transform the raster CRS to WGS 84: " + error);
    double x = centre.x;
    double y = centre.y;
    int ok = 0;
    if (!finite2(x, y) || ct->Transform(1, &x, &y, nullptr, &ok) == 0 || ok == 0 || !finite2(x, y))
      return fail("the raster centre cannot be transformed to WGS 84");
    lonLat = {x, y};
  }
  const UtmZone zone = utmZoneOf(lonLat.x, lonLat.y);
  if (zone.zone < 1) return fail("no UTM zone for the raster centre");
  Result<SceneFrame> utm = fromCrs("EPSG:" + std::to_string(zone.epsgWgs84()), glm::dvec3(0.0));
  if (!utm) return fail("cannot create the UTM frame EPSG:" + std::to_string(zone.epsgWgs84()));
  Result<CrsTransform> toUtm = utm->transformFrom(dem.crsWkt);
  if (!toUtm) return fail("cannot transform the raster CRS to UTM");
  const std::optional<glm::dvec2> origin = toUtm->transform(centre);
  if (!origin) return fail("the raster centre cannot be projected to UTM");
  utm->origin_ = glm::dvec3(*origin, 0.0);
  return utm;
}

const std::string& SceneFrame::crsWkt() const {
  static const std::string empty;
  return impl_ ? impl_->wkt : empty;
}

std::optional<int> SceneFrame::epsg() const { return impl_ ? impl_->epsg : std::nullopt; }

std::optional<glm::dvec3> SceneFrame::fromLonLat(double lonDeg, double latDeg, double h) const {
  if (!impl_ || !finite2(lonDeg, latDeg) || !std::isfinite(h)) return std::nullopt;
  double x = lonDeg;
  double y = latDeg;
  int ok = 0;
  {
    detail::QuietGdal quiet;
    const std::lock_guard lock(impl_->mutex);
    if (impl_->toProjected->Transform(1, &x, &y, nullptr, &ok) == 0 || ok == 0) return std::nullopt;
  }
  if (!finite2(x, y)) return std::nullopt;
  return projectedToFrame(glm::dvec3(x, y, h));
}

std::optional<glm::dvec3> SceneFrame::toLonLat(const glm::dvec3& frame) const {
  if (!impl_) return std::nullopt;
  const glm::dvec3 p = frameToProjected(frame);
  if (!finite2(p.x, p.y) || !std::isfinite(p.z)) return std::nullopt;
  double x = p.x;
  double y = p.y;
  int ok = 0;
  {
    detail::QuietGdal quiet;
    const std::lock_guard lock(impl_->mutex);
    if (impl_->toGeographic->Transform(1, &x, &y, nullptr, &ok) == 0 || ok == 0) return std::nullopt;
  }
  if (!finite2(x, y)) return std::nullopt;
  return glm::dvec3(x, y, p.z);
}

Result<CrsTransform> SceneFrame::transformFrom(const std::string& sourceCrs) const {
  if (!impl_) return Result<CrsTransform>::failure({Severity::Error, "", "", "", "scene frame is empty (moved from)"});
  std::string error;
  const detail::SrsPtr src = detail::parseSrs(sourceCrs, error);
  if (!src) return Result<CrsTransform>::failure({Severity::Error, "", "", "", error});
  return transformBetween(*src, *impl_->projected, "into the scene frame CRS");
}

Result<CrsTransform> SceneFrame::transformTo(const std::string& targetCrs) const {
  if (!impl_) return Result<CrsTransform>::failure({Severity::Error, "", "", "", "scene frame is empty (moved from)"});
  std::string error;
  const detail::SrsPtr dst = detail::parseSrs(targetCrs, error);
  if (!dst) return Result<CrsTransform>::failure({Severity::Error, "", "", "", error});
  return transformBetween(*impl_->projected, *dst, "from the scene frame CRS");
}

Result<CrsTransform> SceneFrame::transformBetween(const OGRSpatialReference& src, const OGRSpatialReference& dst,
                                                  const std::string& what) {
  std::string error;
  auto impl = std::make_unique<CrsTransform::Impl>();
  impl->ct = makeTransform(src, dst, error);
  if (!impl->ct) {
    return Result<CrsTransform>::failure({Severity::Error, "", "", "", "cannot transform " + what + ": " + error});
  }
  {
    detail::QuietGdal quiet;
    impl->sourceGeographic = src.IsGeographic() != 0;
    OGRErr err = OGRERR_NONE;
    impl->semiMajor = src.GetSemiMajor(&err);
    const double invFlattening = src.GetInvFlattening(&err);
    impl->flattening = invFlattening != 0.0 ? 1.0 / invFlattening : 0.0;
  }
  Result<CrsTransform> r;
  r.value.emplace(CrsTransform(std::move(impl)));
  return r;
}

UtmZone utmZoneOf(double lonDeg, double latDeg) {
  // UTMUPS::UTM forces a UTM zone near the poles too (where the standard rule says UPS), and
  // keeps the Norway and Svalbard exceptions. NaN gives zone 0 (invalid).
  UtmZone z;
  z.north = latDeg >= 0.0;
  if (!finite2(lonDeg, latDeg) || std::abs(latDeg) > 90.0) return z;
  const int zone = GeographicLib::UTMUPS::StandardZone(latDeg, lonDeg, GeographicLib::UTMUPS::UTM);
  z.zone = zone >= 1 && zone <= 60 ? zone : 0;
  return z;
}

}  // namespace gis::geo
