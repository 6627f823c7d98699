// Measuring lengths and areas: geodesic values from GeographicLib, surface values from terrain
// samples along segments and on a grid inside rings (see measure.hpp for the method).
#include "scene/measure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <GeographicLib/AzimuthalEquidistant.hpp>
#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/PolygonArea.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace gis::scene {

namespace {

constexpr int kScanlinesPerCell = 4;  // inside fraction of a cell: exact along x, 4 samples along y
constexpr double kCoarsening = 1.25;  // step growth per try when the sample budget is exceeded
constexpr int kMaxCoarsenings = 400;  // 1.25^400 exceeds any extent: the loop always ends

bool isFinite(const glm::dvec2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }

Result<Measurement> failure(std::string feature, std::string message) {
  return Result<Measurement>::failure({Severity::Error, "", "", std::move(feature), std::move(message)});
}

/// Segments of the line (or ring) as index pairs into the points.
std::vector<std::pair<std::size_t, std::size_t>> segmentsOf(std::size_t count, bool closed) {
  std::vector<std::pair<std::size_t, std::size_t>> s;
  if (count < 2) return s;
  for (std::size_t i = 0; i + 1 < count; ++i) s.emplace_back(i, i + 1);
  if (closed) s.emplace_back(count - 1, 0);
  return s;
}

/// Equal steps of a segment of planar length `planar`: at least one, none longer than `step`.
std::size_t stepsOf(double planar, double step) {
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(planar / step)));
}

/// The sampling grid over a ring's bounding box: cells of `step` from `min`.
struct Grid {
  glm::dvec2 min{0.0};
  double step = 1.0;
  std::size_t nx = 1;
  std::size_t ny = 1;
};

Grid gridOver(std::span<const glm::dvec2> ring, double step) {
  glm::dvec2 lo = ring.front();
  glm::dvec2 hi = ring.front();
  for (const glm::dvec2& p : ring) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  Grid g;
  g.min = lo;
  g.step = step;
  g.nx = stepsOf(hi.x - lo.x, step);
  g.ny = stepsOf(hi.y - lo.y, step);
  return g;
}

/// Heights the step would query at most: every segment's samples and every grid corner.
double estimatedSamples(std::span<const double> planarLengths, std::span<const glm::dvec2> ring, double step) {
  double n = 0.0;
  for (const double p : planarLengths) n += std::ceil(p / step) + 1.0;
  if (!ring.empty()) {
    const Grid g = gridOver(ring, step);
    n += (static_cast<double>(g.nx) + 1.0) * (static_cast<double>(g.ny) + 1.0);
  }
  return n;
}

/// Height at `p`, or NaN for no terrain and non-finite answers.
double heightAt(const TerrainHeight& height, const glm::dvec2& p, std::size_t& samples) {
  ++samples;
  const double h = height(p);
  return std::isfinite(h) ? h : std::numeric_limits<double>::quiet_NaN();
}

/// `seg.surfaceMetres` over n equal steps of length d, `heightOf(i)` the height at the end of
/// step i (0: the start): each step counts sqrt(d² + Δh²), or d alone where an end has no height
/// (then `seg.surfaceComplete` is false).
template <typename HeightOf>
void sumSteps(std::size_t n, double d, SegmentMeasure& seg, HeightOf heightOf) {
  double surface = 0.0;
  double previous = heightOf(std::size_t{0});
  for (std::size_t i = 1; i <= n; ++i) {
    const double h = heightOf(i);
    if (std::isfinite(h) && std::isfinite(previous)) {
      const double dh = h - previous;
      surface += std::sqrt(d * d + dh * dh);
    } else {
      surface += d;
      seg.surfaceComplete = false;
    }
    previous = h;
  }
  seg.surfaceMetres = surface;
}

/// Fills `seg.surfaceMetres` (and `surfaceComplete`) of segment a→b from its planar and geodesic lengths.
void sampleSegment(const glm::dvec2& a, const glm::dvec2& b, double step, const TerrainHeight& height,
                   SegmentMeasure& seg, std::size_t& samples) {
  seg.surfaceMetres = seg.geodesicMetres;
  if (seg.planarMetres == 0.0) return;
  if (!height) {
    seg.surfaceComplete = false;
    return;
  }
  const std::size_t n = stepsOf(seg.planarMetres, step);
  sumSteps(n, seg.geodesicMetres / static_cast<double>(n), seg, [&](std::size_t i) {
    const glm::dvec2 p = i == 0 ? a : (i == n ? b : a + (b - a) * (static_cast<double>(i) / static_cast<double>(n)));
    return heightAt(height, p, samples);
  });
}

/// Adds the part of [u0, u1] (in cell widths from the grid's left edge) each cell holds.
void addCoverage(double u0, double u1, std::vector<double>& cover) {
  const double nx = static_cast<double>(cover.size());
  u0 = std::clamp(u0, 0.0, nx);
  u1 = std::clamp(u1, 0.0, nx);
  if (u1 <= u0) return;
  const auto first = std::min(cover.size() - 1, static_cast<std::size_t>(u0));
  const auto last = std::min(cover.size() - 1, static_cast<std::size_t>(u1));
  if (first == last) {
    cover[first] += u1 - u0;
    return;
  }
  cover[first] += static_cast<double>(first + 1) - u0;
  for (std::size_t i = first + 1; i < last; ++i) cover[i] += 1.0;
  cover[last] += u1 - static_cast<double>(last);
}

/// One row of grid corner heights, each queried when a cell first needs it.
class CornerRow {
 public:
  explicit CornerRow(std::size_t corners) : heights_(corners), known_(corners, false) {}

  void reset(double y) {
    y_ = y;
    std::fill(known_.begin(), known_.end(), false);
  }
  double at(std::size_t i, const Grid& g, const TerrainHeight& height, std::size_t& samples) {
    if (!known_[i]) {
      heights_[i] = heightAt(height, glm::dvec2(g.min.x + static_cast<double>(i) * g.step, y_), samples);
      known_[i] = true;
    }
    return heights_[i];
  }

 private:
  std::vector<double> heights_;
  std::vector<bool> known_;
  double y_ = 0.0;
};

/// 3-D area of the two terrain triangles on a cell's corners over its planar area; nullopt if a
/// corner has no height.
std::optional<double> slopeFactor(double h00, double h10, double h01, double h11, double step) {
  if (!std::isfinite(h00) || !std::isfinite(h10) || !std::isfinite(h01) || !std::isfinite(h11)) return std::nullopt;
  const glm::dvec3 c00(0.0, 0.0, h00);
  const glm::dvec3 c10(step, 0.0, h10);
  const glm::dvec3 c01(0.0, step, h01);
  const glm::dvec3 c11(step, step, h11);
  const double twiceArea =
      glm::length(glm::cross(c10 - c00, c11 - c00)) + glm::length(glm::cross(c11 - c00, c01 - c00));
  return 0.5 * twiceArea / (step * step);
}

/// Mean slope factor over the ring's interior, each cell weighted by its part inside (even-odd);
/// 1 when no cell is inside (a ring thinner than the scanlines).
double meanSlopeFactor(std::span<const glm::dvec2> ring, double step, const TerrainHeight& height, std::size_t& samples,
                       bool& complete) {
  const Grid g = gridOver(ring, step);
  std::vector<double> cover(g.nx);
  std::vector<double> crossings;
  CornerRow bottom(g.nx + 1);
  CornerRow top(g.nx + 1);
  double weight = 0.0;
  double weighted = 0.0;
  for (std::size_t j = 0; j < g.ny; ++j) {
    std::fill(cover.begin(), cover.end(), 0.0);
    for (int k = 0; k < kScanlinesPerCell; ++k) {
      const double y = g.min.y + (static_cast<double>(j) + (k + 0.5) / kScanlinesPerCell) * step;
      crossings.clear();
      for (std::size_t i = 0; i < ring.size(); ++i) {
        const glm::dvec2& a = ring[i];
        const glm::dvec2& b = ring[(i + 1) % ring.size()];
        if ((a.y > y) != (b.y > y)) crossings.push_back(a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y));
      }
      std::sort(crossings.begin(), crossings.end());
      for (std::size_t c = 0; c + 1 < crossings.size(); c += 2) {
        addCoverage((crossings[c] - g.min.x) / step, (crossings[c + 1] - g.min.x) / step, cover);
      }
    }
    if (j == 0) bottom.reset(g.min.y);
    top.reset(g.min.y + static_cast<double>(j + 1) * step);
    for (std::size_t i = 0; i < g.nx; ++i) {
      if (cover[i] <= 0.0) continue;
      const std::optional<double> f =
          slopeFactor(bottom.at(i, g, height, samples), bottom.at(i + 1, g, height, samples),
                      top.at(i, g, height, samples), top.at(i + 1, g, height, samples), step);
      if (!f) complete = false;
      weight += cover[i];
      weighted += cover[i] * f.value_or(1.0);
    }
    std::swap(bottom, top);
  }
  return weight > 0.0 ? weighted / weight : 1.0;
}

/// Shoelace area of the ring (absolute), relative to its first point for precision.
double planarArea(std::span<const glm::dvec2> ring) {
  double twice = 0.0;
  for (std::size_t i = 1; i + 1 < ring.size(); ++i) {
    const glm::dvec2 a = ring[i] - ring[0];
    const glm::dvec2 b = ring[i + 1] - ring[0];
    twice += a.x * b.y - a.y * b.x;
  }
  return 0.5 * std::abs(twice);
}

/// The totals of the segments (lengths, and whether every sample had a height).
void sumSegments(Measurement& m) {
  for (const SegmentMeasure& seg : m.segments) {
    m.planarMetres += seg.planarMetres;
    m.geodesicMetres += seg.geodesicMetres;
    m.surfaceMetres += seg.surfaceMetres;
    m.surfaceComplete = m.surfaceComplete && seg.surfaceComplete;
  }
}

/// A ring's areas (zero for fewer than three points): on the ellipsoid, edges being geodesics
/// (lonLat); planar, of `ring` (its points in a plane); and on the surface, the geodesic area
/// times the mean slope factor over `ring`, with `height` read in that plane.
void measureArea(Measurement& m, const GeographicLib::Geodesic& geodesic, std::span<const glm::dvec2> lonLat,
                 std::span<const glm::dvec2> ring, double step, const TerrainHeight& height) {
  if (!m.closed) return;
  m.planarAreaM2 = 0.0;
  m.geodesicAreaM2 = 0.0;
  m.surfaceAreaM2 = 0.0;
  if (lonLat.size() < 3 || ring.size() < 3) return;
  GeographicLib::PolygonArea polygon(geodesic, false);
  for (const glm::dvec2& ll : lonLat) polygon.AddPoint(ll.y, ll.x);
  double perimeter = 0.0;
  double area = 0.0;
  polygon.Compute(false, true, perimeter, area);
  m.planarAreaM2 = planarArea(ring);
  m.geodesicAreaM2 = std::abs(area);
  double factor = 1.0;
  if (height && *m.planarAreaM2 > 0.0) {
    bool complete = true;
    factor = meanSlopeFactor(ring, step, height, m.samples, complete);
    m.surfaceComplete = m.surfaceComplete && complete;
  }
  m.surfaceAreaM2 = *m.geodesicAreaM2 * factor;
}

constexpr const char* kBadEllipsoid = "the ellipsoid needs a positive semi-major axis and a flattening below 1";

bool validEllipsoid(const Ellipsoid& e) {
  return std::isfinite(e.semiMajorMetres) && e.semiMajorMetres > 0.0 && std::isfinite(e.flattening) &&
         e.flattening < 1.0;
}

/// Step budget shared by both frames: the asked step, coarsened until the samples fit.
double budgetedStep(const MeasureOptions& options, bool withHeights, std::span<const double> lengths,
                    std::span<const glm::dvec2> ring) {
  double step = options.sampleStepMetres;
  if (withHeights) {
    const auto budget = static_cast<double>(options.maxSamples);
    for (int n = 0; n < kMaxCoarsenings && estimatedSamples(lengths, ring, step) > budget; ++n) step *= kCoarsening;
  }
  return step;
}

/// Surface length of the geodesic a→b (lon/lat) of length seg.geodesicMetres, sampled along it.
void sampleGeodesic(const GeographicLib::Geodesic& geodesic, const glm::dvec2& a, const glm::dvec2& b, double step,
                    const GeodeticHeight& height, SegmentMeasure& seg, std::size_t& samples) {
  seg.surfaceMetres = seg.geodesicMetres;
  if (seg.geodesicMetres == 0.0) return;
  if (!height) {
    seg.surfaceComplete = false;
    return;
  }
  const GeographicLib::GeodesicLine line = geodesic.InverseLine(a.y, a.x, b.y, b.x);
  const std::size_t n = stepsOf(seg.geodesicMetres, step);
  const double d = seg.geodesicMetres / static_cast<double>(n);
  sumSteps(n, d, seg, [&](std::size_t i) {
    glm::dvec2 p = i == 0 ? a : b;
    if (i > 0 && i < n) line.Position(d * static_cast<double>(i), p.y, p.x);
    ++samples;
    const double h = height(p.x, p.y);
    return std::isfinite(h) ? h : std::numeric_limits<double>::quiet_NaN();
  });
}

}  // namespace

Ellipsoid ellipsoidOf(const geo::SceneFrame& frame) {
  const Result<geo::CrsTransform> t = frame.transformTo("EPSG:4326");
  if (!t) return Ellipsoid::wgs84();
  const double a = t->sourceSemiMajor();
  const double f = t->sourceFlattening();
  if (!(std::isfinite(a) && a > 0.0 && std::isfinite(f) && f >= 0.0 && f < 1.0)) return Ellipsoid::wgs84();
  return {a, f};
}

Result<Measurement> measure(const geo::SceneFrame& frame, std::span<const glm::dvec2> frameXY, bool closed,
                            const TerrainHeight& height, const MeasureOptions& options) {
  if (!(std::isfinite(options.sampleStepMetres) && options.sampleStepMetres > 0.0)) {
    return failure("", "sampleStepMetres must be positive and finite");
  }
  const Ellipsoid ellipsoid = options.ellipsoid ? *options.ellipsoid : ellipsoidOf(frame);
  if (!validEllipsoid(ellipsoid)) return failure("", kBadEllipsoid);

  // lon/lat of every point first: a bad point fails the whole measurement before any sampling.
  std::vector<glm::dvec2> lonLat;
  lonLat.reserve(frameXY.size());
  for (std::size_t i = 0; i < frameXY.size(); ++i) {
    const std::string feature = "point " + std::to_string(i);
    if (!isFinite(frameXY[i])) return failure(feature, "coordinates are not finite");
    const std::optional<glm::dvec3> ll = frame.toLonLat(glm::dvec3(frameXY[i], 0.0));
    if (!ll) return failure(feature, "cannot be converted to lon/lat in the frame CRS");
    lonLat.emplace_back(ll->x, ll->y);
  }

  Measurement m;
  m.closed = closed;
  m.ellipsoid = ellipsoid;
  const GeographicLib::Geodesic geodesic(ellipsoid.semiMajorMetres, ellipsoid.flattening);
  const auto pairs = segmentsOf(frameXY.size(), closed);
  std::vector<double> planarLengths;
  for (const auto& [i, j] : pairs) {
    SegmentMeasure seg;
    seg.planarMetres = glm::length(frameXY[j] - frameXY[i]);
    geodesic.Inverse(lonLat[i].y, lonLat[i].x, lonLat[j].y, lonLat[j].x, seg.geodesicMetres);
    planarLengths.push_back(seg.planarMetres);
    m.segments.push_back(seg);
  }

  const bool hasArea = closed && frameXY.size() >= 3;
  const std::span<const glm::dvec2> ring = hasArea ? frameXY : std::span<const glm::dvec2>();
  const double step = budgetedStep(options, static_cast<bool>(height), planarLengths, ring);
  m.sampleStepMetres = step;
  m.surfaceComplete = static_cast<bool>(height);

  for (std::size_t s = 0; s < pairs.size(); ++s) {
    sampleSegment(frameXY[pairs[s].first], frameXY[pairs[s].second], step, height, m.segments[s], m.samples);
  }
  sumSegments(m);
  measureArea(m, geodesic, lonLat, ring, step, height);

  Result<Measurement> r;
  r.value = std::move(m);
  return r;
}

Result<Measurement> measureOnGlobe(std::span<const glm::dvec2> lonLat, bool closed, const GeodeticHeight& height,
                                   const MeasureOptions& options) {
  if (!(std::isfinite(options.sampleStepMetres) && options.sampleStepMetres > 0.0)) {
    return failure("", "sampleStepMetres must be positive and finite");
  }
  const Ellipsoid ellipsoid = options.ellipsoid.value_or(Ellipsoid::wgs84());
  if (!validEllipsoid(ellipsoid)) return failure("", kBadEllipsoid);
  for (std::size_t i = 0; i < lonLat.size(); ++i) {
    if (!isFinite(lonLat[i])) return failure("point " + std::to_string(i), "longitude or latitude is not finite");
    if (std::abs(lonLat[i].y) > 90.0) return failure("point " + std::to_string(i), "latitude outside [-90, 90]");
  }

  Measurement m;
  m.closed = closed;
  m.ellipsoid = ellipsoid;
  const GeographicLib::Geodesic geodesic(ellipsoid.semiMajorMetres, ellipsoid.flattening);
  const GeographicLib::Geocentric geocentric(ellipsoid.semiMajorMetres, ellipsoid.flattening);
  const auto ecef = [&geocentric](const glm::dvec2& ll) {
    glm::dvec3 p(0.0);
    geocentric.Forward(ll.y, ll.x, 0.0, p.x, p.y, p.z);
    return p;
  };
  const auto pairs = segmentsOf(lonLat.size(), closed);
  std::vector<double> lengths;
  for (const auto& [i, j] : pairs) {
    SegmentMeasure seg;
    seg.planarMetres = glm::length(ecef(lonLat[j]) - ecef(lonLat[i]));
    geodesic.Inverse(lonLat[i].y, lonLat[i].x, lonLat[j].y, lonLat[j].x, seg.geodesicMetres);
    lengths.push_back(seg.geodesicMetres);
    m.segments.push_back(seg);
  }

  // The ring in the azimuthal equidistant plane about its centre, for the slope factors' grid.
  const bool hasArea = closed && lonLat.size() >= 3;
  std::vector<glm::dvec2> plane;
  std::optional<GeographicLib::AzimuthalEquidistant> projection;
  glm::dvec2 centre(0.0);
  if (hasArea) {
    glm::dvec3 sum(0.0);
    for (const glm::dvec2& ll : lonLat) sum += glm::normalize(ecef(ll));
    // On the ellipsoid's scale: near the earth's centre geodetic latitude means nothing.
    sum = glm::length(sum) > 0.0 ? glm::normalize(sum) * ellipsoid.semiMajorMetres : glm::dvec3(ecef(lonLat[0]));
    double h = 0.0;
    geocentric.Reverse(sum.x, sum.y, sum.z, centre.y, centre.x, h);
    projection.emplace(geodesic);
    for (const glm::dvec2& ll : lonLat) {
      glm::dvec2 xy(0.0);
      projection->Forward(centre.y, centre.x, ll.y, ll.x, xy.x, xy.y);
      plane.push_back(xy);
    }
  }
  const double step = budgetedStep(options, static_cast<bool>(height), lengths, plane);
  m.sampleStepMetres = step;
  m.surfaceComplete = static_cast<bool>(height);

  for (std::size_t s = 0; s < pairs.size(); ++s) {
    sampleGeodesic(geodesic, lonLat[pairs[s].first], lonLat[pairs[s].second], step, height, m.segments[s], m.samples);
  }
  sumSegments(m);
  TerrainHeight inPlane;
  if (height && projection) {
    inPlane = [&](const glm::dvec2& xy) {
      double lat = 0.0, lon = 0.0;
      projection->Reverse(centre.y, centre.x, xy.x, xy.y, lat, lon);
      return height(lon, lat);
    };
  }
  measureArea(m, geodesic, lonLat, plane, step, inPlane);

  Result<Measurement> r;
  r.value = std::move(m);
  return r;
}

std::vector<glm::dvec2> geodesicPath(std::span<const glm::dvec2> lonLat, bool closed, double stepMetres,
                                     std::size_t maxPiecesPerSegment) {
  std::vector<glm::dvec2> path;
  const GeographicLib::Geodesic& geodesic = GeographicLib::Geodesic::WGS84();
  const auto pairs = segmentsOf(lonLat.size(), closed);
  for (const auto& [i, j] : pairs) {
    const glm::dvec2 a = lonLat[i], b = lonLat[j];
    const GeographicLib::GeodesicLine line = geodesic.InverseLine(a.y, a.x, b.y, b.x);
    const double length = line.Distance();
    const std::size_t n = std::min(std::max<std::size_t>(maxPiecesPerSegment, 1),
                                   stepMetres > 0.0 && std::isfinite(length) ? stepsOf(length, stepMetres) : 1);
    path.push_back(a);
    for (std::size_t k = 1; k < n; ++k) {
      glm::dvec2 p(0.0);
      line.Position(length * static_cast<double>(k) / static_cast<double>(n), p.y, p.x);
      path.push_back(p);
    }
  }
  if (!pairs.empty()) path.push_back(closed ? lonLat.front() : lonLat.back());
  return path;
}

}  // namespace gis::scene
