#include "globe/ellipsoid.hpp"

#include <cmath>

#include <GeographicLib/Geocentric.hpp>

namespace gis::globe {

namespace {
constexpr double kDegree = 3.14159265358979323846 / 180.0;
}

glm::dvec3 toEcef(double lonDeg, double latDeg, double h) {
  glm::dvec3 out;
  GeographicLib::Geocentric::WGS84().Forward(latDeg, lonDeg, h, out.x, out.y, out.z);
  return out;
}

Geodetic toGeodetic(const glm::dvec3& ecef) {
  Geodetic g;
  GeographicLib::Geocentric::WGS84().Reverse(ecef.x, ecef.y, ecef.z, g.lat, g.lon, g.h);
  return g;
}

glm::dvec3 surfaceNormal(double lonDeg, double latDeg) {
  const double lon = lonDeg * kDegree, lat = latDeg * kDegree;
  return {std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)};
}

glm::dmat3 enuBasis(double lonDeg, double latDeg) {
  const double lon = lonDeg * kDegree, lat = latDeg * kDegree;
  const glm::dvec3 east(-std::sin(lon), std::cos(lon), 0.0);
  const glm::dvec3 north(-std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat));
  const glm::dvec3 up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
  return {east, north, up};
}

double chordSag(double chordMetres) {
  // On a sphere of radius R a chord of length c between points at radius ≥ R dips to
  // sqrt(R² − c²/4) ≥ R − c²/(8R) · (1 + c²/(4R²))...; R_min bounds every normal section's
  // curvature. The 2 % and the millimetre cover the ellipsoid's departure from its osculating
  // spheres and rounding.
  return chordMetres * chordMetres / (8.0 * kMinCurvatureRadius) * 1.02 + 1e-3;
}

bool hiddenByEllipsoid(const glm::dvec3& eye, const glm::dvec3& point, double occluderHeight) {
  // Scaled space: the occluding ellipsoid becomes the unit sphere. The point is hidden when it is
  // beyond the plane of the eye's horizon circle and inside the cone the sphere casts from the
  // eye (the segment then meets the sphere first).
  const glm::dvec3 radii(kSemiMajor + occluderHeight, kSemiMajor + occluderHeight, kSemiMinor + occluderHeight);
  const glm::dvec3 v = eye / radii;
  const glm::dvec3 p = point / radii;
  const double vhSquared = glm::dot(v, v) - 1.0;
  if (vhSquared <= 0.0) return false;  // the eye is inside the occluder: it hides nothing
  const glm::dvec3 vt = p - v;
  const double vtDotVc = -glm::dot(vt, v);
  return vtDotVc > vhSquared && vtDotVc * vtDotVc / glm::dot(vt, vt) > vhSquared;
}

double triangleSag(double longestEdgeMetres) {
  return longestEdgeMetres * longestEdgeMetres / (6.0 * kMinCurvatureRadius) * 1.02 + 1e-3;
}

SplitPosition splitPosition(const glm::dvec3& p) {
  SplitPosition s;
  for (int i = 0; i < 3; ++i) {
    const double high = std::round(p[i] / 16.0) * 16.0;
    s.high[i] = static_cast<float>(high);
    s.low[i] = static_cast<float>(p[i] - high);
  }
  return s;
}

}  // namespace gis::globe
