#include "geo/vector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include <ogr_api.h>
#include <ogrsf_frmts.h>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "geo/gdal_support.hpp"
#include "geojson_entries.hpp"
#include "vector_tiles.hpp"

namespace gis::geo {

std::size_t VectorLayer::vertexCount() const {
  std::size_t n = 0;
  for (const Feature& f : features) n += f.vertexCount();
  return n;
}

namespace {

/// The point at distance s along the geodesic (longitudes continued from its start: no jump at
/// the antimeridian).
glm::dvec2 positionAt(const GeographicLib::GeodesicLine& line, double s) {
  double lat = 0.0;
  double lon = 0.0;
  double unused = 0.0;
  line.GenPosition(false, s,
                   GeographicLib::GeodesicLine::LATITUDE | GeographicLib::GeodesicLine::LONGITUDE |
                       GeographicLib::GeodesicLine::LONG_UNROLL,
                   lat, lon, unused, unused, unused, unused, unused, unused);
  return {lon, lat};
}

/// Distance from p to the segment a–b.
double distanceToSegment(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

/// Refines the geodesic between distances s0 and s1 (mapped to p0 and p1) until the mapped chord
/// stays within `tolerance` of the mapped geodesic, judged at a quarter, half and three quarters
/// of each span (a short span of a smooth curve bulges most near its middle); appends the
/// points strictly between, in order.
void refine(const GeographicLib::GeodesicLine& line, const GeodesicProjection& project, double tolerance, double s0,
            double s1, const glm::dvec2& p0, const glm::dvec2& p1, int depth, std::vector<glm::dvec2>& out) {
  // 2^16 spans per edge at most (1 mm along a 15,000 km geodesic near the frame's zone takes
  // about 2^16): beyond, the caller gets the chord. No runaway on absurd input: an edge round
  // most of the earth, far from the zone, never came within 1 mm and took 2^24 points (the
  // fuzzer's regressions/vector_reader/long_geodesic_far_from_the_zone.geojson, out of memory).
  constexpr int kMaxDepth = 16;
  if (depth >= kMaxDepth) return;
  const double sm = 0.5 * (s0 + s1);
  const glm::dvec2 mid = positionAt(line, sm);
  const std::optional<glm::dvec2> pm = project(mid);
  if (!pm) return;  // a point that cannot be projected: the reader reports the vertices that fail
  double departure = distanceToSegment(*pm, p0, p1);
  for (const double q : {0.25, 0.75}) {
    if (departure > tolerance) break;
    const std::optional<glm::dvec2> pq = project(positionAt(line, s0 + q * (s1 - s0)));
    if (!pq) return;
    departure = std::max(departure, distanceToSegment(*pq, p0, p1));
  }
  if (!(departure > tolerance)) return;
  refine(line, project, tolerance, s0, sm, p0, *pm, depth + 1, out);
  out.push_back(mid);
  refine(line, project, tolerance, sm, s1, *pm, p1, depth + 1, out);
}

/// Appends a and the points strictly between a and b along the geodesic: equally spaced in
/// distance so that no piece is longer than maxSegmentMetres, then, with `project`, more
/// wherever the projected geodesic departs from the projected chord by more than
/// toleranceMetres.
void appendGeodesic(const GeographicLib::Geodesic& geodesic, const glm::dvec2& a, const glm::dvec2& b,
                    double maxSegmentMetres, double toleranceMetres, const GeodesicProjection* project,
                    std::vector<glm::dvec2>& out) {
  out.push_back(a);
  if (!std::isfinite(a.x) || !std::isfinite(a.y) || !std::isfinite(b.x) || !std::isfinite(b.y) || a == b) return;
  const bool byLength = maxSegmentMetres > 0.0 && std::isfinite(maxSegmentMetres);
  const bool byTolerance = project != nullptr && toleranceMetres > 0.0 && std::isfinite(toleranceMetres);
  if (!byLength && !byTolerance) return;
  const GeographicLib::GeodesicLine line = geodesic.InverseLine(a.y, a.x, b.y, b.x);
  const double length = line.Distance();
  if (!std::isfinite(length) || !(length > 0.0)) return;
  const double pieces = byLength ? std::ceil(length / maxSegmentMetres) : 1.0;
  // A guard against absurd requests (e.g. 1 mm steps around the globe): beyond this many
  // pieces the caller gets longer pieces rather than an out-of-memory crash.
  constexpr double kMaxPieces = 1 << 22;
  const int n = std::isfinite(pieces) ? static_cast<int>(std::clamp(pieces, 1.0, kMaxPieces)) : 1;
  const double step = length / n;
  std::optional<glm::dvec2> previous;
  if (byTolerance) previous = (*project)(a);
  for (int i = 1; i <= n; ++i) {
    const glm::dvec2 next = i < n ? positionAt(line, step * i) : b;
    if (byTolerance) {
      const std::optional<glm::dvec2> projected = (*project)(next);
      if (previous && projected)
        refine(line, *project, toleranceMetres, step * (i - 1), step * i, *previous, *projected, 0, out);
      previous = projected;
    }
    if (i < n) out.push_back(next);
  }
}

}  // namespace

std::vector<glm::dvec2> densifyGeodesic(const glm::dvec2& a, const glm::dvec2& b, double maxSegmentMetres,
                                        double semiMajor, double flattening) {
  std::vector<glm::dvec2> out;
  try {
    const GeographicLib::Geodesic geodesic(semiMajor, flattening);
    appendGeodesic(geodesic, a, b, maxSegmentMetres, 0.0, nullptr, out);
  } catch (const std::exception&) {
    // Invalid ellipsoid: no densification possible; the edge stays straight.
    out.assign(1, a);
  }
  return out;
}

std::vector<glm::dvec2> densifyGeodesicWithin(const glm::dvec2& a, const glm::dvec2& b, double toleranceMetres,
                                              double semiMajor, double flattening, const GeodesicProjection& project) {
  std::vector<glm::dvec2> out;
  try {
    const GeographicLib::Geodesic geodesic(semiMajor, flattening);
    appendGeodesic(geodesic, a, b, std::numeric_limits<double>::infinity(), toleranceMetres, &project, out);
  } catch (const std::exception&) {
    // Invalid ellipsoid: no densification possible; the edge stays straight.
    out.assign(1, a);
  }
  return out;
}

namespace {

struct DatasetDeleter {
  void operator()(GDALDataset* ds) const {
    if (ds != nullptr) GDALClose(GDALDataset::ToHandle(ds));
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetDeleter>;

/// Opens a vector data source; null with `error` set (with every message GDAL gave when `gdal`
/// collects them). Call inside a QuietGdal or a GdalMessages.
DatasetPtr openVector(const std::string& path, std::string& error, const detail::GdalMessages* gdal = nullptr,
                      const char* const* openOptions = nullptr) {
  detail::ensureGdalRegistered();
  DatasetPtr ds(GDALDataset::FromHandle(GDALOpenEx(
      path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, openOptions, nullptr)));
  if (!ds) {
    const std::string fallback = detail::QuietGdal::lastMessage("not a vector format OGR can read");
    error = "cannot open as vector data: " + (gdal != nullptr ? gdal->joined(fallback) : fallback);
  } else if (ds->GetLayerCount() == 0) {
    error = "the data source has no vector layers";
    ds.reset();
  }
  return ds;
}

std::string formatPoint(const glm::dvec2& p) {
  std::ostringstream s;
  s.precision(10);
  s << '(' << p.x << ", " << p.y << ')';
  return s.str();
}

/// Turns OGR geometries of one layer into frame coordinates. Each method returns an empty
/// string on success, else what was wrong (the caller names file, layer and feature).
class GeometryConverter {
 public:
  GeometryConverter(const SceneFrame& frame, const CrsTransform& toFrame,
                    std::optional<GeographicLib::Geodesic> geodesic, double maxSegment, double tolerance)
      : frame_(frame),
        toFrame_(toFrame),
        geodesic_(std::move(geodesic)),
        maxSegment_(maxSegment),
        tolerance_(tolerance) {}

  /// A multi-part geometry keeps its good parts: each bad one goes into `leftOut` ("part 2 of 3:
  /// …"), and its index (from 0) into `leftOutParts` when given; only when no part is good is the
  /// feature broken (the returned message).
  std::string convert(const OGRGeometry& geometry, Feature& out, std::vector<std::string>& leftOut,
                      std::vector<int>* leftOutParts = nullptr) const {
    switch (wkbFlatten(geometry.getGeometryType())) {
      case wkbPolygon:
        return addPolygon(*geometry.toPolygon(), out);
      case wkbMultiPolygon:
        return convertParts(*geometry.toMultiPolygon(), out, leftOut, leftOutParts,
                            [this](const OGRPolygon& p, Feature& f) { return addPolygon(p, f); });
      case wkbLineString:
        return addLine(*geometry.toLineString(), out);
      case wkbMultiLineString:
        return convertParts(*geometry.toMultiLineString(), out, leftOut, leftOutParts,
                            [this](const OGRLineString& l, Feature& f) { return addLine(l, f); });
      default:
        return std::string("unsupported geometry type ") + OGRGeometryTypeToName(geometry.getGeometryType());
    }
  }

 private:
  template <typename Collection, typename Add>
  static std::string convertParts(const Collection& parts, Feature& out, std::vector<std::string>& leftOut,
                                  std::vector<int>* leftOutParts, Add add) {
    const int n = parts.getNumGeometries();
    std::vector<std::string> problems;
    int good = 0;
    for (int i = 0; i < n; ++i) {
      if (std::string e = add(*parts.getGeometryRef(i), out); !e.empty()) {
        problems.push_back("part " + std::to_string(i + 1) + " of " + std::to_string(n) + ": " + e);
        if (leftOutParts != nullptr) leftOutParts->push_back(i);
      } else {
        ++good;
      }
    }
    if (good == 0) {
      std::string all;
      for (const std::string& p : problems) all += (all.empty() ? "" : "; ") + p;
      return all.empty() ? std::string("no parts") : all;
    }
    leftOut.insert(leftOut.end(), problems.begin(), problems.end());
    return {};
  }

  std::string addPolygon(const OGRPolygon& polygon, Feature& out) const {
    const OGRLinearRing* exterior = polygon.getExteriorRing();
    if (exterior == nullptr || exterior->IsEmpty()) return "polygon without exterior ring";
    Polygon p;
    if (std::string e = convertPart(*exterior, true, p.outer); !e.empty()) return "exterior ring: " + e;
    for (int i = 0; i < polygon.getNumInteriorRings(); ++i) {
      Ring hole;
      if (std::string e = convertPart(*polygon.getInteriorRing(i), true, hole); !e.empty())
        return "hole " + std::to_string(i + 1) + ": " + e;
      p.holes.push_back(std::move(hole));
    }
    out.polygons.push_back(std::move(p));
    return {};
  }

  std::string addLine(const OGRLineString& line, Feature& out) const {
    LineString l;
    if (std::string e = convertPart(line, false, l); !e.empty()) return "line: " + e;
    out.lines.push_back(std::move(l));
    return {};
  }

  /// One ring (closed = true; the closing duplicate is dropped) or one line string.
  std::string convertPart(const OGRSimpleCurve& curve, bool closed, std::vector<glm::dvec2>& out) const {
    const int n = curve.getNumPoints();
    std::vector<glm::dvec2> pts;
    pts.reserve(static_cast<std::size_t>(std::max(n, 0)));
    for (int i = 0; i < n; ++i) {
      const glm::dvec2 p(curve.getX(i), curve.getY(i));
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) return "non-finite coordinate at vertex " + std::to_string(i);
      if (geodesic_ && (std::abs(p.y) > 90.0 || std::abs(p.x) > 360.0))
        return "vertex " + std::to_string(i) + " " + formatPoint(p) + " is outside the range of longitude/latitude";
      // Repeated vertices carry no shape and make zero-length edges; keep one.
      if (pts.empty() || pts.back() != p) pts.push_back(p);
    }
    if (closed) {
      while (pts.size() > 1 && pts.back() == pts.front()) pts.pop_back();
    }
    std::vector<glm::dvec2> distinct = pts;
    std::sort(distinct.begin(), distinct.end(),
              [](const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
    if (closed && distinct.size() < 3)
      return "ring has " + std::to_string(distinct.size()) + " distinct point(s); at least 3 needed";
    if (!closed && distinct.size() < 2)
      return "line has " + std::to_string(distinct.size()) + " distinct point(s); at least 2 needed";

    if (geodesic_ && (std::isfinite(maxSegment_) || std::isfinite(tolerance_))) pts = densify(pts, closed);

    std::vector<glm::dvec2> projected = pts;
    if (!toFrame_.transform(projected.data(), projected.size())) {
      for (std::size_t i = 0; i < projected.size(); ++i) {
        if (!std::isfinite(projected[i].x))
          return "point " + formatPoint(pts[i]) + " cannot be projected into the frame CRS";
      }
      return "points cannot be projected into the frame CRS";
    }
    const glm::dvec2 origin(frame_.origin());
    for (glm::dvec2& p : projected) p -= origin;
    out = std::move(projected);
    return {};
  }

  /// Inserts geodesic points on every edge (for a ring including the closing edge) where the
  /// projected geodesic departs from the projected chord by more than tolerance_, and so that
  /// no piece is longer than maxSegment_.
  std::vector<glm::dvec2> densify(const std::vector<glm::dvec2>& pts, bool closed) const {
    std::vector<glm::dvec2> out;
    out.reserve(pts.size());
    const std::size_t edges = closed ? pts.size() : pts.size() - 1;
    const GeodesicProjection project = [this](const glm::dvec2& p) { return toFrame_.transform(p); };
    for (std::size_t i = 0; i < edges; ++i) {
      appendGeodesic(*geodesic_, pts[i], pts[(i + 1) % pts.size()], maxSegment_, tolerance_, &project, out);
    }
    if (!closed) out.push_back(pts.back());
    return out;
  }

  const SceneFrame& frame_;
  const CrsTransform& toFrame_;
  std::optional<GeographicLib::Geodesic> geodesic_;  // set when the source is geographic
  double maxSegment_;
  double tolerance_;
};

/// The attributes of a feature, text as UTF-8 (`recoded` set when some was not: detail::toUtf8).
void readAttributes(const OGRFeature& feature, const OGRFeatureDefn& defn, Feature& out, bool& recoded) {
  for (int i = 0; i < defn.GetFieldCount(); ++i) {
    const OGRFieldDefn* field = defn.GetFieldDefn(i);
    AttributeValue value;
    if (feature.IsFieldSetAndNotNull(i)) {
      switch (field->GetType()) {
        case OFTInteger:
        case OFTInteger64:
          value = static_cast<std::int64_t>(feature.GetFieldAsInteger64(i));
          break;
        case OFTReal:
          value = feature.GetFieldAsDouble(i);
          break;
        default:
          value = detail::toUtf8(feature.GetFieldAsString(i), recoded);
          break;
      }
    }
    out.attributes[detail::toUtf8(field->GetNameRef(), recoded)] = std::move(value);
  }
}

struct FeatureDeleter {
  void operator()(OGRFeature* f) const { OGRFeature::DestroyFeature(f); }
};

}  // namespace

Result<std::vector<std::string>> listVectorLayers(const std::string& path) {
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openVector(path, error);
  if (!ds) return Result<std::vector<std::string>>::failure({Severity::Error, path, "", "", error});
  Result<std::vector<std::string>> r;
  r.value.emplace();
  for (int i = 0; i < ds->GetLayerCount(); ++i) r.value->emplace_back(ds->GetLayer(i)->GetName());
  return r;
}

Result<std::array<double, 4>> vectorExtentLonLat(const std::string& path) {
  using R = Result<std::array<double, 4>>;
  detail::QuietGdal quiet;
  std::string error;
  DatasetPtr ds = openVector(path, error);
  if (!ds) return R::failure({Severity::Error, path, "", "", error});
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (int i = 0; i < ds->GetLayerCount(); ++i) {
    OGRLayer* layer = ds->GetLayer(i);
    OGREnvelope e;
    if (layer == nullptr || layer->GetExtent(&e, TRUE) != OGRERR_NONE) continue;
    const OGRSpatialReference* srs = layer->GetSpatialRef();
    if (srs == nullptr || srs->IsEmpty()) {
      return R::failure({Severity::Error, path, layer->GetName(), "", "the layer has no CRS"});
    }
    const detail::SrsPtr source = detail::cloneTraditional(*srs);
    std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(source.get(), &wgs84));
    if (!ct) return R::failure({Severity::Error, path, layer->GetName(), "", "cannot transform the layer to WGS 84"});
    // The envelope's boundary, densified: a projected box is curved in longitude/latitude.
    for (int k = 0; k <= 16; ++k) {
      const double t = k / 16.0;
      const double x = e.MinX + t * (e.MaxX - e.MinX), y = e.MinY + t * (e.MaxY - e.MinY);
      for (const glm::dvec2 p :
           {glm::dvec2(x, e.MinY), glm::dvec2(x, e.MaxY), glm::dvec2(e.MinX, y), glm::dvec2(e.MaxX, y)}) {
        double px = p.x, py = p.y;
        int ok = 0;
        if (ct->Transform(1, &px, &py, nullptr, &ok) != 0 && ok != 0 && std::isfinite(px) && std::isfinite(py)) {
          lo = glm::min(lo, glm::dvec2(px, py));
          hi = glm::max(hi, glm::dvec2(px, py));
        }
      }
    }
  }
  if (!(lo.x <= hi.x && lo.y <= hi.y)) {
    return R::failure({Severity::Error, path, "", "", "the file holds no features with coordinates"});
  }
  R r;
  r.value = std::array<double, 4>{lo.x, lo.y, hi.x, hi.y};
  return r;
}

namespace {

/// GDAL's words about a CRS it could not read ("PROJ: proj_create: crs not found" for a GeoJSON
/// `crs` member naming EPSG:999999): the driver then reads the layer as WGS 84 without a word.
bool aboutTheCrs(const detail::GdalMessages::Message& m) {
  if (m.level != CE_Failure && m.level != CE_Fatal) return false;
  for (const char* key : {"proj_create", "crs", "CRS", "SRS", "spatial reference", "coordinate system"}) {
    if (m.text.find(key) != std::string::npos) return true;
  }
  return false;
}

/// GDAL's other messages as Warnings naming the file and layer.
void addGdalMessages(std::vector<detail::GdalMessages::Message> messages, const std::string& path,
                     const std::string& layer, Diagnostics& d) {
  for (const auto& m : messages) d.add({Severity::Warning, path, layer, "", "GDAL: " + m.text});
}

/// GEOS's reason for the last IsValid() that failed ("Self-intersection at or near point …"),
/// taken from GDAL's messages (nothing else is left among them).
std::string validityReason(detail::GdalMessages& gdal) {
  std::string reason;
  for (const auto& m : gdal.take()) reason = m.text;
  const std::string prefix = "GEOS warning: ";
  if (reason.rfind(prefix, 0) == 0) reason = reason.substr(prefix.size());
  return reason.empty() ? std::string("GEOS gives no reason") : reason;
}

/// Whether a ring's points lie on one line (within 1e-9 of its extent): it has no area, whatever
/// its vertex order (a bow-tie's signed area can be 0 too, but it has two triangles).
bool onOneLine(const OGRLinearRing& ring) {
  const int n = ring.getNumPoints();
  if (n < 3) return true;
  const glm::dvec2 p0(ring.getX(0), ring.getY(0));
  glm::dvec2 far = p0;
  for (int i = 1; i < n; ++i) {
    const glm::dvec2 p(ring.getX(i), ring.getY(i));
    if (glm::length(p - p0) > glm::length(far - p0)) far = p;
  }
  const glm::dvec2 axis = far - p0;
  const double length = glm::length(axis);
  if (!(length > 0.0)) return true;
  for (int i = 1; i < n; ++i) {
    const glm::dvec2 d = glm::dvec2(ring.getX(i), ring.getY(i)) - p0;
    if (std::abs(axis.x * d.y - axis.y * d.x) / length > 1e-9 * length) return false;
  }
  return true;
}

/// A polygon of `exterior` and `holes` (copies).
OGRPolygon polygonOf(const OGRLinearRing& exterior, const std::vector<const OGRLinearRing*>& holes = {}) {
  OGRPolygon p;
  p.addRingDirectly(exterior.clone());
  for (const OGRLinearRing* h : holes) p.addRingDirectly(h->clone());
  return p;
}

/// A GEOS prepared geometry of an OGR geometry (its edges and its area indexed), or none where
/// GDAL has no GEOS.
class Prepared {
 public:
  explicit Prepared(const OGRGeometry& g)
      : handle_(OGRHasPreparedGeometrySupport() != 0
                    ? OGRCreatePreparedGeometry(OGRGeometry::ToHandle(const_cast<OGRGeometry*>(&g)))
                    : nullptr) {}
  Prepared(const Prepared&) = delete;
  Prepared& operator=(const Prepared&) = delete;
  ~Prepared() {
    if (handle_ != nullptr) OGRDestroyPreparedGeometry(handle_);
  }
  [[nodiscard]] bool ok() const { return handle_ != nullptr; }
  [[nodiscard]] bool intersects(const OGRGeometry& g) const {
    return OGRPreparedGeometryIntersects(handle_, OGRGeometry::ToHandle(const_cast<OGRGeometry*>(&g))) != 0;
  }
  /// For a point: whether it lies in the interior of the area (GEOS's indexed point-in-area
  /// locator, the same crossings as its point-in-ring test).
  [[nodiscard]] bool contains(const OGRGeometry& g) const {
    return OGRPreparedGeometryContains(handle_, OGRGeometry::ToHandle(const_cast<OGRGeometry*>(&g))) != 0;
  }

 private:
  OGRPreparedGeometryH handle_;
};

/// Whether the area of a ring meets a polygon's shell (OGC Intersects, as
/// OGRGeometry::Intersects answers it: boundaries that touch count), asked of many rings: the
/// shell is prepared once when there are several to ask. An envelope that misses the shell's
/// answers at once, as OGR's does.
class ShellTest {
 public:
  ShellTest(const OGRLinearRing& exterior, int rings) : shell_(polygonOf(exterior)) {
    shell_.getEnvelope(&envelope_);
    if (rings > 1) prepared_.emplace(shell_);
  }

  [[nodiscard]] bool intersects(const OGRLinearRing& ring) const {
    OGREnvelope e;
    ring.getEnvelope(&e);
    if (!envelope_.Intersects(e)) return false;
    const OGRPolygon area = polygonOf(ring);
    if (!prepared_ || !prepared_->ok()) return shell_.Intersects(&area);
    return prepared_->intersects(area);
  }

 private:
  OGRPolygon shell_;
  OGREnvelope envelope_;
  std::optional<Prepared> prepared_;
};

std::vector<const OGRPolygon*> partsOf(const OGRGeometry& geometry) {
  std::vector<const OGRPolygon*> parts;
  if (wkbFlatten(geometry.getGeometryType()) == wkbPolygon) {
    parts.push_back(geometry.toPolygon());
  } else {
    for (const OGRPolygon* p : *geometry.toMultiPolygon()) parts.push_back(p);
  }
  return parts;
}

/// GEOS's Envelope::covers.
bool covers(const OGREnvelope& outer, const OGREnvelope& inner) {
  return inner.MinX >= outer.MinX && inner.MaxX <= outer.MaxX && inner.MinY >= outer.MinY && inner.MaxY <= outer.MaxY;
}

/// Whether every ring passes GEOS's first checks, or fails them (the caller then asks GEOS,
/// which stops there): not empty, finite, closed, of at least 4 points not repeated in a row.
bool ringsWellFormed(const std::vector<const OGRPolygon*>& parts) {
  auto wellFormed = [](const OGRLinearRing* ring) {
    if (ring == nullptr || ring->IsEmpty()) return false;
    const int n = ring->getNumPoints();
    int distinct = 0;
    for (int i = 0; i < n; ++i) {
      const double x = ring->getX(i), y = ring->getY(i);
      if (!std::isfinite(x) || !std::isfinite(y)) return false;
      if (i == 0 || x != ring->getX(i - 1) || y != ring->getY(i - 1)) ++distinct;
    }
    return distinct >= 4 && ring->getX(0) == ring->getX(n - 1) && ring->getY(0) == ring->getY(n - 1);
  };
  for (const OGRPolygon* p : parts) {
    if (!wellFormed(p->getExteriorRing())) return false;
    for (int i = 0; i < p->getNumInteriorRings(); ++i)
      if (!wellFormed(p->getInteriorRing(i))) return false;
  }
  return true;
}

/// Whether some part's shell lies inside another part (its first point inside that polygon, holes
/// excepted): GEOS's "Nested shells", for parts whose rings share no point. Candidates are found
/// through a grid of the parts' envelopes: a part can hold another only if its envelope covers the
/// other's.
bool anyPartNested(const std::vector<const OGRPolygon*>& parts) {
  const std::size_t n = parts.size();
  std::vector<OGREnvelope> envelopes(n);
  OGREnvelope all;
  for (std::size_t i = 0; i < n; ++i) {
    parts[i]->getEnvelope(&envelopes[i]);
    all.Merge(envelopes[i]);
  }
  const int side = std::clamp(static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n)))), 1, 256);
  const double w = std::max(all.MaxX - all.MinX, 1e-300), h = std::max(all.MaxY - all.MinY, 1e-300);
  auto cell = [&](double v, double lo, double extent) {
    return std::clamp(static_cast<int>((v - lo) / extent * side), 0, side - 1);
  };
  std::vector<std::vector<std::uint32_t>> grid(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  for (std::size_t j = 0; j < n; ++j) {
    const OGREnvelope& e = envelopes[j];
    for (int y = cell(e.MinY, all.MinY, h); y <= cell(e.MaxY, all.MinY, h); ++y)
      for (int x = cell(e.MinX, all.MinX, w); x <= cell(e.MaxX, all.MinX, w); ++x)
        grid[static_cast<std::size_t>(y * side + x)].push_back(static_cast<std::uint32_t>(j));
  }
  std::vector<std::unique_ptr<Prepared>> prepared(n);
  for (std::size_t i = 0; i < n; ++i) {
    const OGREnvelope& e = envelopes[i];
    const OGRLinearRing* shell = parts[i]->getExteriorRing();
    const OGRPoint first(shell->getX(0), shell->getY(0));
    for (const std::uint32_t j :
         grid[static_cast<std::size_t>(cell(e.MinY, all.MinY, h) * side + cell(e.MinX, all.MinX, w))]) {
      if (j == i || !covers(envelopes[j], e)) continue;
      if (!prepared[j]) prepared[j] = std::make_unique<Prepared>(*parts[j]);
      if (!prepared[j]->ok() || prepared[j]->contains(first)) return true;
    }
  }
  return false;
}

/// OGRGeometry::IsValid() of a polygon or multi-polygon — the same answer, and when it is not
/// valid the same GEOS reason among GDAL's messages — in about the time of noding its rings.
/// GEOS 3.11's IsValid tests each hole against its shell with a point-in-ring test over the
/// whole shell: 10^4 lakes in a border of 10^5 vertices cost it seconds, once per call.
///
/// GEOS checks, in order: the rings' points, the rings crossing or touching, each hole inside
/// its shell, no hole inside another, no part inside another, the interior connected. When no
/// two rings share a point and none crosses itself (IsSimple of the rings as lines: its noding
/// is GEOS's, the same exact predicates) and the rings are well formed, the first two pass and
/// so does the last (only touches disconnect an interior); the others are asked here as GEOS
/// asks them, the shell's point-in-ring test prepared once (its crossings counted as GEOS
/// counts them). Where one fails, GEOS itself is asked of a small polygon failing the same way
/// first (the shell and that hole; a rectangle and the part's holes), for its reason. Anything
/// else — rings that touch or cross, malformed rings, nested parts, no holes to test — is
/// GEOS's IsValid on the geometry itself (fast where it fails early, or has no holes).
bool isValid(const OGRGeometry& geometry) {
  const std::vector<const OGRPolygon*> parts = partsOf(geometry);
  std::size_t holes = 0;
  for (const OGRPolygon* p : parts) holes += static_cast<std::size_t>(std::max(0, p->getNumInteriorRings()));
  if (holes == 0 || OGRHasPreparedGeometrySupport() == 0 || !ringsWellFormed(parts)) return geometry.IsValid();
  {
    OGRMultiLineString rings;
    for (const OGRPolygon* p : parts) {
      rings.addGeometryDirectly(new OGRLineString(*p->getExteriorRing()));
      for (int i = 0; i < p->getNumInteriorRings(); ++i)
        rings.addGeometryDirectly(new OGRLineString(*p->getInteriorRing(i)));
    }
    if (!rings.IsSimple()) return geometry.IsValid();
  }
  // Each hole inside its shell: every part's holes, in order (GEOS's order: the first that is not
  // gives the reason, at its first point).
  for (const OGRPolygon* p : parts) {
    if (p->getNumInteriorRings() == 0) continue;
    const OGRLinearRing& shell = *p->getExteriorRing();
    OGREnvelope shellEnvelope;
    shell.getEnvelope(&shellEnvelope);
    const OGRPolygon shellArea = polygonOf(shell);
    const Prepared area(shellArea);
    if (!area.ok()) return geometry.IsValid();
    for (int i = 0; i < p->getNumInteriorRings(); ++i) {
      const OGRLinearRing* hole = p->getInteriorRing(i);
      OGREnvelope holeEnvelope;
      hole->getEnvelope(&holeEnvelope);
      if (covers(shellEnvelope, holeEnvelope) && area.contains(OGRPoint(hole->getX(0), hole->getY(0)))) continue;
      if (!polygonOf(shell, {hole}).IsValid()) return false;  // "Hole lies outside shell" at that point
      return geometry.IsValid();                              // not expected
    }
  }
  // No hole inside another: GEOS tests the holes alone (an index of their envelopes), so a
  // rectangle around them as the shell gives its answer and reason, at the cost of the holes.
  for (const OGRPolygon* p : parts) {
    if (p->getNumInteriorRings() < 2) continue;
    OGREnvelope e;
    p->getExteriorRing()->getEnvelope(&e);
    const double margin = std::max({e.MaxX - e.MinX, e.MaxY - e.MinY, 1.0});
    OGRLinearRing rectangle;
    rectangle.addPoint(e.MinX - margin, e.MinY - margin);
    rectangle.addPoint(e.MaxX + margin, e.MinY - margin);
    rectangle.addPoint(e.MaxX + margin, e.MaxY + margin);
    rectangle.addPoint(e.MinX - margin, e.MaxY + margin);
    rectangle.closeRings();
    std::vector<const OGRLinearRing*> partHoles;
    for (int i = 0; i < p->getNumInteriorRings(); ++i) partHoles.push_back(p->getInteriorRing(i));
    if (!polygonOf(rectangle, partHoles).IsValid()) return false;  // "Holes are nested"
  }
  if (parts.size() > 1 && anyPartNested(parts)) return geometry.IsValid();
  return true;
}

/// What checkPolygons keeps of a feature's polygons: per part of the source geometry, null when
/// it is left out (by the converter or the checks), else the indices of its holes that stay.
using KeptPolygons = std::vector<std::optional<std::vector<int>>>;

/// OGC validity (GEOS, through OGR) of a polygon or multi-polygon in its source coordinates, with
/// the repairs whose intent is clear, each said in `notes`:
/// - a polygon whose exterior ring has no area (its points on one line: in longitude/latitude it
///   would become a centimetre sliver after densification) is left out;
/// - a hole lying wholly outside its shell excludes nothing and is left out;
/// - anything else invalid (a ring that crosses itself, a bow-tie) is drawn by the even-odd
///   rule, and parts that overlap as their union, as every polygon is (docs/overlay.md).
/// Parts the converter left out (`leftOutParts`, by index: a NaN, a ring of two points) were
/// named there and are neither checked nor named again. Fills `kept` (`changed` when a hole or
/// a polygon was left out here); false, with `refused` saying why, when no polygon is left.
///
/// Each step costs about the size of what it checks (issue 40: a border of 10^5 vertices with
/// 10^4 lakes took 20 minutes here): validity (isValid, GEOS's answer without its cost per hole)
/// on the whole, then, when it is not valid, on each part and on the parts kept, and each hole
/// against its shell prepared once (ShellTest).
bool checkPolygons(const OGRGeometry& geometry, const std::vector<int>& leftOutParts, detail::GdalMessages& gdal,
                   std::vector<std::string>& notes, std::string& refused, bool& changed, KeptPolygons& kept) {
  changed = false;
  const std::vector<const OGRPolygon*> parts = partsOf(geometry);
  std::vector<bool> checked(parts.size(), true);
  for (const int k : leftOutParts) {
    if (k >= 0 && static_cast<std::size_t>(k) < parts.size()) checked[static_cast<std::size_t>(k)] = false;
  }
  kept.assign(parts.size(), std::nullopt);
  auto allHoles = [](const OGRPolygon& p) {
    std::vector<int> all(static_cast<std::size_t>(std::max(0, p.getNumInteriorRings())));
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    return all;
  };
  // The geometry as the converter kept it: without the parts it left out.
  std::unique_ptr<OGRMultiPolygon> convertible;
  if (std::find(checked.begin(), checked.end(), false) != checked.end()) {
    convertible = std::make_unique<OGRMultiPolygon>();
    for (std::size_t k = 0; k < parts.size(); ++k)
      if (checked[k]) convertible->addGeometry(parts[k]);
  }
  const OGRGeometry& whole = convertible ? *convertible : geometry;
  // Valid, and no sliver: a ring whose points are on one line up to rounding is valid by OGC
  // rules (it has an area of 1e-17) but has no area to draw.
  bool sliver = false;
  for (std::size_t k = 0; k < parts.size() && !sliver; ++k) {
    const OGRLinearRing* exterior = parts[k]->getExteriorRing();
    sliver = checked[k] && exterior != nullptr && !exterior->IsEmpty() && onOneLine(*exterior);
  }
  if (!sliver && isValid(whole)) {
    gdal.take();
    for (std::size_t k = 0; k < parts.size(); ++k)
      if (checked[k]) kept[k] = allHoles(*parts[k]);
    return true;
  }
  const std::string wholeReason = validityReason(gdal);
  const bool multi = parts.size() > 1 || wkbFlatten(geometry.getGeometryType()) == wkbMultiPolygon;
  OGRMultiPolygon out;
  std::vector<std::string> dropped;
  bool partsInvalid = false;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    if (!checked[k]) continue;
    const std::string label =
        multi ? "polygon " + std::to_string(k + 1) + " of " + std::to_string(parts.size()) : std::string("the polygon");
    const OGRLinearRing* exterior = parts[k]->getExteriorRing();
    if (exterior == nullptr || exterior->IsEmpty()) continue;  // the converter names it
    if (onOneLine(*exterior)) {
      changed = true;
      dropped.push_back(label + ": its exterior ring has no area (its points lie on one line)");
      continue;
    }
    std::vector<const OGRLinearRing*> holes;
    std::vector<int> holeIndices;
    // Whether a hole meets its shell (OGC Intersects: touching counts): the shell prepared once
    // (GEOS indexes its edges and its area), so that each hole costs about its own size, not the
    // shell's. Asked one by one against the shell unprepared, a border's 10^4 lakes in a shell of
    // 10^5 vertices took minutes (issue 40).
    const ShellTest shell(*exterior, parts[k]->getNumInteriorRings());
    for (int i = 0; i < parts[k]->getNumInteriorRings(); ++i) {
      const OGRLinearRing* hole = parts[k]->getInteriorRing(i);
      if (hole != nullptr && !hole->IsEmpty() && !shell.intersects(*hole)) {
        changed = true;
        notes.push_back(label + ": hole " + std::to_string(i + 1) +
                        " lies wholly outside its shell and excludes nothing: left out");
        continue;
      }
      holes.push_back(hole);
      holeIndices.push_back(i);
    }
    OGRPolygon part = polygonOf(*exterior, holes);
    if (!isValid(part)) {
      partsInvalid = true;
      notes.push_back(label + " is not valid by OGC rules (GEOS: " + validityReason(gdal) +
                      "): drawn by the even-odd rule");
    }
    gdal.take();
    kept[k] = std::move(holeIndices);
    out.addGeometry(&part);
  }
  if (out.IsEmpty()) {
    for (const std::string& d : dropped) refused += (refused.empty() ? "" : "; ") + d;
    if (refused.empty()) refused = "no polygon with an area (GEOS: " + wholeReason + ")";
    return false;
  }
  for (const std::string& d : dropped) notes.push_back(d + ": left out");
  if (!partsInvalid && out.getNumGeometries() > 1 && !isValid(out)) {
    notes.push_back("its polygons overlap or touch along a line (GEOS: " + validityReason(gdal) +
                    "): drawn as their union");
  }
  gdal.take();
  return true;
}

/// Keeps of a converted feature's polygons (one per part the converter kept, in order) what
/// checkPolygons kept: the same as converting the kept geometry again, without converting it.
void keepPolygons(const KeptPolygons& kept, const std::vector<int>& leftOutParts, Feature& f) {
  std::vector<Polygon> polygons;
  std::size_t converted = 0;
  for (std::size_t k = 0; k < kept.size() && converted < f.polygons.size(); ++k) {
    if (std::find(leftOutParts.begin(), leftOutParts.end(), static_cast<int>(k)) != leftOutParts.end()) continue;
    Polygon& p = f.polygons[converted++];
    if (!kept[k]) continue;
    if (kept[k]->size() != p.holes.size()) {
      std::vector<Ring> holes;
      for (const int i : *kept[k]) holes.push_back(std::move(p.holes[static_cast<std::size_t>(i)]));
      p.holes = std::move(holes);
    }
    polygons.push_back(std::move(p));
  }
  f.polygons = std::move(polygons);
}

std::string layerNames(GDALDataset& ds) {
  std::string names;
  for (int i = 0; i < ds.GetLayerCount(); ++i) names += (i > 0 ? ", " : "") + std::string(ds.GetLayer(i)->GetName());
  return names;
}

}  // namespace

namespace {

/// Gives the layer the spatial filter of a frame box (VectorReadOptions::filter): the box's
/// outline, 32 points a side, mapped into the source CRS; their bounds, widened by 1 % a side
/// for the bulge of the mapped sides between the points. An error message, or empty.
std::string setSpatialFilter(OGRLayer& layer, const SceneFrame& frame, const std::string& sourceCrsWkt,
                             const std::array<glm::dvec2, 2>& box) {
  for (const glm::dvec2& corner : box) {
    if (!std::isfinite(corner.x) || !std::isfinite(corner.y)) return "the spatial filter's box is not finite";
  }
  const glm::dvec2 lo = glm::min(box[0], box[1]), hi = glm::max(box[0], box[1]);
  Result<CrsTransform> toSource = frame.transformTo(sourceCrsWkt);
  if (!toSource) return "cannot map the spatial filter's box into the layer's CRS";
  constexpr int kPerSide = 32;
  const glm::dvec2 origin(frame.origin());
  std::vector<glm::dvec2> outline;
  for (int i = 0; i < kPerSide; ++i) {
    const double t = static_cast<double>(i) / kPerSide;
    outline.push_back(origin + glm::dvec2(lo.x + t * (hi.x - lo.x), lo.y));
    outline.push_back(origin + glm::dvec2(hi.x, lo.y + t * (hi.y - lo.y)));
    outline.push_back(origin + glm::dvec2(hi.x - t * (hi.x - lo.x), hi.y));
    outline.push_back(origin + glm::dvec2(lo.x, hi.y - t * (hi.y - lo.y)));
  }
  glm::dvec2 a(std::numeric_limits<double>::infinity()), b(-std::numeric_limits<double>::infinity());
  for (const glm::dvec2& p : outline) {
    const std::optional<glm::dvec2> q = toSource->transform(p);
    if (!q || !std::isfinite(q->x) || !std::isfinite(q->y))
      return "the spatial filter's box does not map into the layer's CRS everywhere";
    a = glm::min(a, *q);
    b = glm::max(b, *q);
  }
  const glm::dvec2 margin = 0.01 * (b - a);
  layer.SetSpatialFilterRect(a.x - margin.x, a.y - margin.y, b.x + margin.x, b.y + margin.y);
  return {};
}

}  // namespace

Result<VectorLayer> readVectorLayer(const std::string& path, const SceneFrame& frame,
                                    const VectorReadOptions& options) {
  detail::GdalMessages gdal;
  auto fail = [&path](const std::string& layer, const std::string& message) {
    return Result<VectorLayer>::failure({Severity::Error, path, layer, "", message});
  };
  if (std::isnan(options.maxGeodesicSegmentMetres) || options.maxGeodesicSegmentMetres <= 0.0)
    return fail(options.layer, "maxGeodesicSegmentMetres must be > 0");
  if (std::isnan(options.geodesicToleranceMetres) || options.geodesicToleranceMetres <= 0.0)
    return fail(options.layer, "geodesicToleranceMetres must be > 0");

  std::string error;
  const std::string opened = detail::vectorTilePath(path);  // a folder of tiles: its deepest zoom
  DatasetPtr ds = openVector(opened, error, &gdal);
  if (!ds) return fail("", error);
  const std::optional<int> tileZoom = detail::vectorTileZoom(*ds, opened);
  if (tileZoom) {
    // Vector tiles unclipped: a feature's pieces then overlap by the tiles' buffer instead of
    // meeting on the tile edges, so that their union has no sliver along an edge.
    static constexpr const char* kUnclipped[] = {"CLIP=NO", nullptr};
    ds = openVector(opened, error, &gdal, kUnclipped);
    if (!ds) return fail("", error);
  }

  OGRLayer* layer = nullptr;
  if (options.layer.empty()) {
    // Several layers and none named: taking the first would drop the others without a word.
    if (ds->GetLayerCount() > 1) {
      return fail("", "the data source has " + std::to_string(ds->GetLayerCount()) + " layers (" + layerNames(*ds) +
                          "): name the one to draw (a scene layer's \"layer\" key), one scene layer each");
    }
    layer = ds->GetLayer(0);
  } else {
    layer = ds->GetLayerByName(options.layer.c_str());
    if (layer == nullptr) return fail(options.layer, "no such layer (the data source has: " + layerNames(*ds) + ")");
  }
  if (layer == nullptr) return fail("", "cannot read the first layer");

  VectorLayer result;
  result.path = path;
  result.name = layer->GetName();
  // What GDAL said while opening: a CRS it could not read fails the layer (it would be drawn in
  // a CRS it does not have); anything else is a Warning.
  static_cast<void>(layer->GetSpatialRef());
  Diagnostics openWarnings;
  {
    std::vector<detail::GdalMessages::Message> said = gdal.take();
    for (const auto& m : said) {
      if (aboutTheCrs(m)) {
        return fail(result.name, "the CRS the file declares cannot be read (GDAL: " + m.text +
                                     "); it would be drawn in another CRS: correct the file's CRS");
      }
    }
    addGdalMessages(std::move(said), path, result.name, openWarnings);
  }

  // Source CRS: the layer's, else the assumed one.
  if (const OGRSpatialReference* srs = layer->GetSpatialRef(); srs != nullptr && !srs->IsEmpty()) {
    result.sourceCrsWkt = detail::toWkt(*srs);
    if (result.sourceCrsWkt.empty()) return fail(result.name, "cannot export the layer CRS as WKT");
  } else if (!options.assumedCrs.empty()) {
    const detail::SrsPtr assumed = detail::parseSrs(options.assumedCrs, error);
    if (!assumed) return fail(result.name, "the layer has no CRS and the assumed CRS is bad: " + error);
    result.sourceCrsWkt = detail::toWkt(*assumed);
  } else {
    return fail(result.name, "the layer has no CRS and no CRS to assume was given");
  }
  Result<CrsTransform> toFrame = frame.transformFrom(result.sourceCrsWkt);
  if (!toFrame) {
    const auto& items = toFrame.diagnostics.items();
    return fail(result.name, items.empty() ? "cannot transform into the frame" : items.front().message);
  }

  if (options.filter) {
    if (const std::string e = setSpatialFilter(*layer, frame, result.sourceCrsWkt, *options.filter); !e.empty())
      return fail(result.name, e);
  }

  std::optional<GeographicLib::Geodesic> geodesic;
  if (toFrame->sourceIsGeographic()) {
    try {
      geodesic.emplace(toFrame->sourceSemiMajor(), toFrame->sourceFlattening());
    } catch (const std::exception& e) {
      return fail(result.name, std::string("invalid ellipsoid of the source CRS: ") + e.what());
    }
  }
  const GeometryConverter converter(frame, *toFrame, std::move(geodesic), options.maxGeodesicSegmentMetres,
                                    options.geodesicToleranceMetres);

  Result<VectorLayer> r;
  r.diagnostics = std::move(openWarnings);
  const OGRFeatureDefn* defn = layer->GetLayerDefn();
  layer->ResetReading();
  // Vector tiles: each source feature once (its tiles' pieces stitched), and the quantisation
  // said with its bound.
  std::optional<std::vector<detail::FeaturePtr>> stitched;
  std::size_t nextStitched = 0;
  if (const std::optional<int> zoom = tileZoom) {
    std::size_t failures = 0;
    stitched = detail::stitchedTileFeatures(*layer, *zoom, failures);
    result.quantisationMetres = detail::vectorTileQuantisation(*zoom);
    std::ostringstream said;
    said.precision(3);
    said << "vector tiles of zoom " << *zoom << ": positions are quantised (4096 units a tile side), so the drawn "
         << "features lie within " << result.quantisationMetres << " m of the source's";
    r.diagnostics.add({Severity::Warning, path, result.name, "", said.str()});
    if (failures > 0) {
      r.diagnostics.add(
          {Severity::Warning, path, result.name, "",
           std::to_string(failures) + " features' tile pieces could not be united (GEOS); they draw as their parts"});
    }
  }
  auto nextFeature = [&]() -> detail::FeaturePtr {
    if (!stitched) return detail::FeaturePtr(layer->GetNextFeature());
    return nextStitched < stitched->size() ? std::move((*stitched)[nextStitched++]) : nullptr;
  };
  const GIntBig total = options.progress && !stitched ? layer->GetFeatureCount(FALSE) : -1;
  const std::int64_t progressStep = total > 0 ? std::max<std::int64_t>(1, total / 100) : 0;
  std::int64_t index = 0;
  bool recoded = false;
  bool anyPolygon = false, anyLine = false;
  std::size_t kept = 0;
  for (;; ++index) {
    if (progressStep > 0 && index % progressStep == 0)
      options.progress(std::min(1.0, static_cast<double>(index) / static_cast<double>(total)));
    CPLErrorReset();
    detail::FeaturePtr feature = nextFeature();
    if (!feature) {
      if (CPLGetLastErrorType() == CE_Failure || CPLGetLastErrorType() == CE_Fatal) {
        r.diagnostics.add({Severity::Error, path, result.name, "",
                           "reading stopped after " + std::to_string(index) +
                               " features: " + gdal.joined(detail::QuietGdal::lastMessage("read error"))});
        gdal.take();
      }
      break;
    }
    Feature f;
    f.fid = feature->GetFID();
    const std::string fid = f.fid != OGRNullFID ? std::to_string(f.fid) : "#" + std::to_string(index);
    auto reject = [&](const std::string& message) {
      r.diagnostics.add({Severity::Error, path, result.name, fid, message});
    };

    const OGRGeometry* geometry = feature->GetGeometryRef();
    if (geometry == nullptr) {
      reject("feature has no geometry");
      continue;
    }
    if (geometry->IsEmpty()) {
      reject("empty geometry");
      continue;
    }
    std::unique_ptr<OGRGeometry> linear;
    if (geometry->hasCurveGeometry()) {
      linear.reset(geometry->getLinearGeometry());
      if (!linear) {
        reject("cannot approximate the curve geometry by line segments");
        continue;
      }
      geometry = linear.get();
    }
    std::vector<std::string> leftOut;
    std::vector<int> leftOutParts;
    if (const std::string e = converter.convert(*geometry, f, leftOut, &leftOutParts); !e.empty()) {
      reject(e);
      continue;
    }
    // Polygons that convert (finite, in range, rings of 3 points) are checked by OGC rules and
    // repaired where the intent is clear, each repair said; what a repair leaves out is taken out
    // of the converted polygons.
    if (const auto type = wkbFlatten(geometry->getGeometryType());
        !f.polygons.empty() && (type == wkbPolygon || type == wkbMultiPolygon)) {
      std::string refused;
      bool changed = false;
      KeptPolygons keptPolygons;
      if (!checkPolygons(*geometry, leftOutParts, gdal, leftOut, refused, changed, keptPolygons)) {
        reject(refused);
        continue;
      }
      if (changed) keepPolygons(keptPolygons, leftOutParts, f);
    }
    // The feature draws its good parts; each bad one is named.
    for (const std::string& note : leftOut) {
      const bool part = note.rfind("part ", 0) == 0;
      r.diagnostics.add({Severity::Warning, path, result.name, fid, part ? note + "; that part is left out" : note});
    }
    readAttributes(*feature, *defn, f, recoded);
    anyPolygon = anyPolygon || !f.polygons.empty();
    anyLine = anyLine || !f.lines.empty();
    ++kept;
    if (options.sink) {
      options.sink(std::move(f));
    } else {
      result.features.push_back(std::move(f));
    }
  }

  if (progressStep > 0) options.progress(1.0);
  addGdalMessages(gdal.take(), path, result.name, r.diagnostics);
  // Entries of a GeoJSON "features" array that GDAL skipped without a word.
  if (const char* driver = ds->GetDriverName(); driver != nullptr && std::string(driver) == "GeoJSON") {
    for (const detail::NonObjectEntry& e : detail::nonObjectFeatureEntries(path)) {
      r.diagnostics.add({Severity::Error, path, result.name, "features[" + std::to_string(e.index) + "]",
                         e.kind + ", not a feature object: left out"});
    }
  }
  if (recoded) {
    r.diagnostics.add({Severity::Warning, path, result.name, "",
                       "attribute text is not UTF-8 and the file declares no encoding: read as Latin-1 "
                       "(ISO-8859-1); if that is wrong, declare the encoding (a .cpg file beside a Shapefile)"});
  }
  result.kind = anyPolygon && anyLine ? GeometryKind::Mixed
                : anyPolygon          ? GeometryKind::Polygon
                : anyLine             ? GeometryKind::Line
                                      : GeometryKind::Empty;
  if (kept == 0) {
    r.diagnostics.add({Severity::Warning, path, result.name, "",
                       r.diagnostics.hasErrors() ? "no usable feature: nothing to draw"
                                                 : "the layer holds no features: nothing to draw"});
  }
  r.value = std::move(result);
  return r;
}

}  // namespace gis::geo
