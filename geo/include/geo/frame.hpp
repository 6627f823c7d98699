#pragma once
// The scene frame (docs/design.md §3): a projected CRS in metres with z up and an origin near the scene
// centre. All georeferenced arithmetic is double; GPU code narrows only relative coordinates.
#include <memory>
#include <optional>
#include <string>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "core/diagnostics.hpp"

class OGRSpatialReference;

namespace gis::geo {

struct RasterInfo;
class CrsTransform;

/// A projected CRS plus an origin. Frame coordinates = projected coordinates − origin.
/// Geographic coordinates (lon, lat in degrees) are on the frame CRS's own geodetic datum,
/// which is what `gdalinfo` prints for a projected raster.
class SceneFrame {
 public:
  /// `crs` is anything OGR's SetFromUserInput accepts: "EPSG:32725", WKT, PROJ string.
  /// Fails (with a message) if the CRS is unknown or not projected.
  static Result<SceneFrame> fromCrs(const std::string& crs, const glm::dvec3& origin);

  /// WGS 84 longitude/latitude in degrees (x = lon, y = lat), origin 0: not a frame to draw in,
  /// but what the globe (docs/globe.md) reads vector data into (readVectorLayer with it gives
  /// features in lon/lat on WGS 84, from any source CRS).
  static SceneFrame wgs84LonLat();
  /// True for wgs84LonLat(): coordinates are degrees, not metres.
  [[nodiscard]] bool geographic() const;

  /// The frame for a DEM: its own CRS if projected in metres, otherwise (geographic, or
  /// projected in feet) the UTM zone (WGS 84) of its centre; origin at the centre of its extent,
  /// z = 0.
  static Result<SceneFrame> forRaster(const RasterInfo& dem);

  SceneFrame(const SceneFrame&);
  SceneFrame& operator=(const SceneFrame&);
  SceneFrame(SceneFrame&&) noexcept;
  SceneFrame& operator=(SceneFrame&&) noexcept;
  ~SceneFrame();

  [[nodiscard]] const std::string& crsWkt() const;
  /// EPSG code of the CRS when it has one.
  [[nodiscard]] std::optional<int> epsg() const;
  [[nodiscard]] const glm::dvec3& origin() const { return origin_; }
  /// Direction along which volumes are extruded (+z in a projected frame). A property of the
  /// frame so a geocentric frame can use the ellipsoid normal later.
  [[nodiscard]] glm::dvec3 up(const glm::dvec3& /*framePoint*/) const { return {0.0, 0.0, 1.0}; }

  [[nodiscard]] glm::dvec3 projectedToFrame(const glm::dvec3& p) const { return p - origin_; }
  [[nodiscard]] glm::dvec3 frameToProjected(const glm::dvec3& f) const { return f + origin_; }

  /// lon/lat in degrees, h in metres (passed through) → frame. nullopt if the point cannot be
  /// projected (e.g. NaN).
  [[nodiscard]] std::optional<glm::dvec3> fromLonLat(double lonDeg, double latDeg, double h) const;
  /// frame → (lon, lat, h).
  [[nodiscard]] std::optional<glm::dvec3> toLonLat(const glm::dvec3& frame) const;

  /// A transform from another CRS (user input or WKT) into this frame's projected CRS (not yet
  /// minus origin). Fails with a message for unknown CRSs.
  [[nodiscard]] Result<CrsTransform> transformFrom(const std::string& sourceCrs) const;
  /// The reverse: from this frame's projected CRS (not minus origin) into another CRS.
  [[nodiscard]] Result<CrsTransform> transformTo(const std::string& targetCrs) const;

 private:
  struct Impl;
  SceneFrame(std::unique_ptr<Impl> impl, const glm::dvec3& origin);
  /// A CrsTransform between two parsed CRSs; `what` names the direction in messages.
  static Result<CrsTransform> transformBetween(const OGRSpatialReference& src, const OGRSpatialReference& dst,
                                               const std::string& what);
  std::unique_ptr<Impl> impl_;
  glm::dvec3 origin_{0.0};
};

/// A coordinate transform between two CRSs, with traditional GIS axis order (x = easting or
/// longitude, y = northing or latitude) on both sides.
class CrsTransform {
 public:
  CrsTransform(CrsTransform&&) noexcept;
  CrsTransform& operator=(CrsTransform&&) noexcept;
  ~CrsTransform();

  /// Transforms points in place; returns false for the points that failed (set to NaN).
  bool transform(glm::dvec2* points, std::size_t count) const;
  [[nodiscard]] std::optional<glm::dvec2> transform(const glm::dvec2& p) const;
  /// True when the source CRS is geographic (lon/lat): its edges need geodesic densification.
  [[nodiscard]] bool sourceIsGeographic() const;
  /// Ellipsoid of the source CRS (semi-major axis in metres, flattening).
  [[nodiscard]] double sourceSemiMajor() const;
  [[nodiscard]] double sourceFlattening() const;

 private:
  friend class SceneFrame;
  struct Impl;
  explicit CrsTransform(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// UTM zone (1..60) and hemisphere of a lon/lat point, via GeographicLib's standard zone rule.
struct UtmZone {
  int zone = 0;
  bool north = true;
  [[nodiscard]] int epsgWgs84() const { return (north ? 32600 : 32700) + zone; }
};
UtmZone utmZoneOf(double lonDeg, double latDeg);

}  // namespace gis::geo
