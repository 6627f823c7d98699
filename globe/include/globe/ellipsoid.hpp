#pragma once
// The WGS 84 ellipsoid and earth-centred, earth-fixed (ECEF) coordinates (docs/globe.md): the
// globe frame's arithmetic, all in double. Longitudes and latitudes are degrees, heights metres
// above the ellipsoid along its normal.
#include <array>
#include <cmath>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace gis::globe {

inline constexpr double kSemiMajor = 6378137.0;
inline constexpr double kFlattening = 1.0 / 298.257223563;
inline constexpr double kSemiMinor = kSemiMajor * (1.0 - kFlattening);
inline constexpr double kEccentricitySquared = kFlattening * (2.0 - kFlattening);
/// The least radius of curvature anywhere on the ellipsoid (the meridian's at the equator,
/// a (1 − e²)): chords sag below the surface by at most chord² / (8 · this).
inline constexpr double kMinCurvatureRadius = kSemiMajor * (1.0 - kEccentricitySquared);

struct Geodetic {
  double lon = 0.0;  ///< degrees, (−180, 180]
  double lat = 0.0;  ///< degrees, [−90, 90]
  double h = 0.0;    ///< metres above the ellipsoid
};

/// (lon, lat, h) → ECEF metres (GeographicLib::Geocentric, WGS 84).
glm::dvec3 toEcef(double lonDeg, double latDeg, double h);
inline glm::dvec3 toEcef(const Geodetic& g) { return toEcef(g.lon, g.lat, g.h); }
/// ECEF → (lon, lat, h); exact to GeographicLib's precision (nanometres) at any height.
Geodetic toGeodetic(const glm::dvec3& ecef);

/// The outward unit normal of the ellipsoid at (lon, lat): the direction heights are measured in.
glm::dvec3 surfaceNormal(double lonDeg, double latDeg);
/// The same at a point on the ellipsoid given in ECEF (no trigonometry: the gradient there).
inline glm::dvec3 surfaceNormalAt(const glm::dvec3& onEllipsoid) {
  const glm::dvec3 g(onEllipsoid.x / (kSemiMajor * kSemiMajor), onEllipsoid.y / (kSemiMajor * kSemiMajor),
                     onEllipsoid.z / (kSemiMinor * kSemiMinor));
  return g / std::sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
}
/// Columns: east, north, up (the surface normal) at (lon, lat).
glm::dmat3 enuBasis(double lonDeg, double latDeg);

/// How far below the lower of its ends a straight chord of this length between two points of the
/// surface (at any heights above it) can pass, metres: chord² / (8 R_min), with a margin.
double chordSag(double chordMetres);
/// How far below the lowest of its corners a flat triangle whose longest edge is this long can
/// pass, metres: r² / (2 R_min) for r the radius of the least circle around it, r ≤ edge / √3,
/// so edge² / (6 R_min), with a margin. (Its middle sags more than its edges: chordSag is not
/// enough for a triangle.)
double triangleSag(double longestEdgeMetres);

/// An upper bound of the ground length of a degree of latitude or longitude anywhere, metres
/// (a degree of latitude at a pole is 111,694 m, of longitude at the equator 111,319 m).
inline constexpr double kMetresPerDegreeMax = 111700.0;

/// True if the ellipsoid (shrunk so that it lies at `occluderHeight` metres, ≤ 0 for safety under
/// seas and depressions) hides the point from the eye: the segment from the eye to the point meets
/// it before the point. Both in ECEF.
bool hiddenByEllipsoid(const glm::dvec3& eye, const glm::dvec3& point, double occluderHeight = 0.0);

/// A position split for the GPU (relative to the eye in float, docs/globe.md): high = the
/// coordinate rounded to a multiple of 16 m (exact in float up to 2.6·10^8 m), low = the rest
/// (|low| ≤ 8 m, float keeps it to 10^-6 m). On the GPU (high − eyeHigh) is exact and
/// (low − eyeLow) keeps micrometres, so every vertex shared by two meshes lands on the same
/// float value in both.
struct SplitPosition {
  glm::vec3 high{0.0F};
  glm::vec3 low{0.0F};
};
SplitPosition splitPosition(const glm::dvec3& p);

}  // namespace gis::globe
