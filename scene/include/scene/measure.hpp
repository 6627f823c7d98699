#pragma once
// Distance and area for the viewer's measure tool (issue 25): the points a person clicked, measured
// three ways — straight in the projected CRS (planar), on the ellipsoid (geodesic, GeographicLib) and
// along the terrain surface (sampled heights). Pure CPU maths: no GL, testable without a display.
#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"

namespace gis::scene {

/// True (not exaggerated) terrain height in metres at frame (x, y); NaN where there is no terrain.
using TerrainHeight = std::function<double(const glm::dvec2& frameXY)>;

/// The ellipsoid geodesic lengths and areas are computed on.
struct Ellipsoid {
  double semiMajorMetres = 6378137.0;       ///< a
  double flattening = 1.0 / 298.257223563;  ///< f = (a − b) / a; 0 for a sphere

  /// WGS 84. GRS 80 (SIRGAS 2000, NAD83, ETRS89) has the same a and a semi-minor axis 0.1 mm
  /// shorter: lengths and areas on the two differ by parts in 1e11, far below any DEM's accuracy.
  static Ellipsoid wgs84() { return {}; }
};

/// The ellipsoid of the frame CRS's datum (the one `SceneFrame::toLonLat` answers on), so lon/lat
/// and geodesics agree; WGS 84 if the CRS does not say. Builds a PROJ transform: call once per frame.
Ellipsoid ellipsoidOf(const geo::SceneFrame& frame);

/// How finely the terrain is sampled and on which ellipsoid.
struct MeasureOptions {
  /// Horizontal spacing of terrain samples in frame metres, along each segment and as the grid
  /// step inside a ring. A fraction of the DEM post spacing (e.g. half) follows every post.
  double sampleStepMetres = 5.0;
  /// Bound on terrain height queries. When the step would need more, it grows by 1.25× until the
  /// estimate fits; `Measurement::sampleStepMetres` reports the step used. Whatever the bound,
  /// each segment gets at least its two ends and a ring at least one grid cell.
  std::size_t maxSamples = 2'000'000;
  /// Ellipsoid for geodesic values; unset: `ellipsoidOf(frame)` (a PROJ look-up on every call).
  std::optional<Ellipsoid> ellipsoid;
};

/// One segment between consecutive points (or the closing one of a ring).
struct SegmentMeasure {
  double planarMetres = 0.0;    ///< straight-line length in the projected CRS (grid distance)
  double geodesicMetres = 0.0;  ///< shortest path on the ellipsoid between the two ends
  double surfaceMetres = 0.0;   ///< along the terrain above the straight frame line (see `measure`)
  bool surfaceComplete = true;  ///< false if some sample on it had no height
};

/// Everything the measure tool shows. Lengths in metres, areas in square metres.
struct Measurement {
  bool closed = false;  ///< measured as a ring: lengths include the closing segment, areas are set
  /// One entry per pair of consecutive points, then the closing segment for a ring (last → first,
  /// zero when the person clicked the first point again). Repeated points give zero segments.
  std::vector<SegmentMeasure> segments;

  double planarMetres = 0.0;    ///< sum of segment planar lengths
  double geodesicMetres = 0.0;  ///< sum of segment geodesic lengths (perimeter for a ring)
  double surfaceMetres = 0.0;   ///< sum of segment surface lengths

  /// Rings only (nullopt for an open line; 0 for fewer than three distinct points). Areas are of
  /// the ring as given: self-intersecting rings give signed-area sums, where opposite loops cancel.
  std::optional<double> planarAreaM2;    ///< shoelace area in the projected CRS
  std::optional<double> geodesicAreaM2;  ///< area on the ellipsoid, edges being geodesics
  std::optional<double> surfaceAreaM2;   ///< terrain area above the ring's interior (see `measure`)

  double sampleStepMetres = 0.0;  ///< step actually used: the asked one or coarser (budget)
  std::size_t samples = 0;        ///< terrain heights queried
  /// False when a sample had no height (NaN) or there was no height function: the surface values
  /// then count those parts as flat ground (surface = geodesic there).
  bool surfaceComplete = true;
  Ellipsoid ellipsoid;  ///< the ellipsoid the geodesic values are on
};

/// Measures the polyline (or, with `closed`, the ring) through `frameXY`, points in frame
/// coordinates of `frame`.
///
/// Geodesic values: each point goes to lon/lat through the frame; segment lengths are geodesic
/// inverse problems and the ring's area is that of the geodesic polygon (GeographicLib).
///
/// Surface length: each segment's straight frame line is sampled at `sampleStepMetres` or finer
/// (equal steps). Each step counts sqrt(d² + Δh²), where d is its horizontal length scaled by the
/// segment's geodesic/planar ratio, so flat ground gives exactly the geodesic length and the UTM
/// scale factor does not leak in. A step with an end without height counts d alone.
///
/// Surface area: a grid at the step over the ring's bounding box; each cell's slope factor is the
/// 3-D area of the two terrain triangles on its four corner heights over its planar area. The
/// surface area is the geodesic area times the mean slope factor over the ring, each cell weighted
/// by the part of it inside the ring (exact along x, four scanlines along y). So flat ground gives
/// exactly the geodesic area, a plane of slope θ exactly geodesic/cos θ; boundary cells count their
/// whole cell's slope for their inside part. A cell with a corner without height counts as flat.
///
/// Fails, with a message naming the point, if a point is not finite or cannot be converted to
/// lon/lat, or if `sampleStepMetres` is not positive and finite. An empty `height` measures with
/// no terrain (surface = geodesic, `surfaceComplete` false, no samples).
Result<Measurement> measure(const geo::SceneFrame& frame, std::span<const glm::dvec2> frameXY, bool closed,
                            const TerrainHeight& height, const MeasureOptions& options = {});

/// True terrain height in metres above the ellipsoid at (lon, lat), degrees; NaN where there is
/// no terrain.
using GeodeticHeight = std::function<double(double lonDeg, double latDeg)>;

/// Measures the polyline (or, with `closed`, the ring) through `lonLat` (degrees, x = longitude)
/// on the ellipsoid of `options` (WGS 84 unset): the globe's measure tool. Segments are geodesics
/// (GeographicLib), so a segment across ±180° is the short way over it and a ring round a pole
/// encloses the pole (PolygonArea).
///
/// Surface length: each geodesic is sampled at equal steps of at most `sampleStepMetres` along
/// it (GeodesicLine), each step counting sqrt(d² + Δh²), d the step's geodesic length: flat
/// ground gives exactly the geodesic length.
///
/// Surface area: the ring mapped to the azimuthal equidistant plane about its centre (the
/// normalised mean of its points' unit vectors), where the same grid of slope factors as in
/// `measure` runs, heights read back through the inverse map; the surface area is the geodesic
/// area times that mean slope factor.
///
/// Planar values have no CRS on the globe: `planarMetres` is the sum of the straight chords
/// between the points on the ellipsoid (height 0), `planarAreaM2` the ring's area in that
/// azimuthal equidistant plane.
///
/// Fails, with a message naming the point, if a longitude or latitude is not finite or a
/// latitude is outside [−90°, 90°], or if `sampleStepMetres` is not positive and finite.
Result<Measurement> measureOnGlobe(std::span<const glm::dvec2> lonLat, bool closed, const GeodeticHeight& height,
                                   const MeasureOptions& options = {});

/// Points along the geodesics through `lonLat` (degrees, x = longitude; closed: back to the
/// first), each segment cut into equal pieces of at most `stepMetres` (at most `maxPiecesPerSegment`
/// of them): what the measure tool draws on the globe. Longitudes stay in [−180°, 180°].
std::vector<glm::dvec2> geodesicPath(std::span<const glm::dvec2> lonLat, bool closed, double stepMetres,
                                     std::size_t maxPiecesPerSegment = 4096);

}  // namespace gis::scene
