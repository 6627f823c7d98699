// Preparing polygons for the globe (globe_overlay.hpp): densified along geodesics, unwrapped,
// closed along a pole; the edges' planes and the reference's point-in-polygon test.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include "geo/checked_file.hpp"
#include "globe/tile.hpp"
#include "globe_detail.hpp"
#include "vector_overlay/generalise.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/pieces_fingerprint.hpp"

namespace gis::globe {

namespace detail {

double wrap180(double d) {
  d = std::remainder(d, 360.0);  // [−180, 180]
  return d <= -180.0 ? d + 360.0 : d;
}

EdgePlane edgePlane(const glm::dvec2& p, const glm::dvec2& q) {
  EdgePlane e;
  e.a = toEcef(p.x, p.y, 0.0);
  const glm::dvec3 b = toEcef(q.x, q.y, 0.0);
  e.n = glm::normalize(surfaceNormal(p.x, p.y) + surfaceNormal(q.x, q.y));
  e.m = glm::cross(e.n, b - e.a);
  return e;
}

}  // namespace detail

double edgeSide(const glm::dvec2& p, const glm::dvec2& q, const glm::dvec3& point) {
  const detail::EdgePlane e = detail::edgePlane(p, q);
  return glm::dot(point - e.a, e.m);
}

namespace {

using detail::isPole;
using detail::wrap180;

/// How many runs of consecutive features `count` features are prepared in (forRuns).
std::size_t runCount(std::size_t count) {
  const std::size_t cores = std::max(1U, std::thread::hardware_concurrency());
  return std::max<std::size_t>(1, std::min(count, 8 * cores));
}

/// Calls work(run, f) for the features [0, count) in `runs` runs of consecutive ones, the runs on
/// every core: what the runs make, joined in their order, is in the features' order and the same
/// on any number of cores.
template <typename Work>
void forRuns(std::size_t count, std::size_t runs, const Work& work) {
  std::atomic<std::size_t> next{0};
  const auto worker = [&] {
    for (std::size_t r = next++; r < runs; r = next++) {
      for (std::size_t f = r * count / runs; f < (r + 1) * count / runs; ++f) work(r, f);
    }
  };
  const std::size_t cores = std::max(1U, std::thread::hardware_concurrency());
  std::vector<std::thread> helpers;
  for (std::size_t h = 1; h < std::min(cores, runs); ++h) helpers.emplace_back(worker);
  worker();
  for (std::thread& t : helpers) t.join();
}

/// The grid of the items' boxes (GlobeLayer's areas or lines).
template <typename Item>
std::shared_ptr<const detail::BoxGrid> gridOfBoxes(const std::vector<Item>& items) {
  std::vector<LonLatRect> boxes;
  boxes.reserve(items.size());
  for (const Item& item : items) boxes.push_back(item.box);
  return std::make_shared<const detail::BoxGrid>(detail::BoxGrid::of(boxes));
}

/// A digest of a feature's areas as prepared: their colour group and rings.
std::uint64_t areasDigest(std::span<const GlobePolygon> polygons) {
  std::vector<std::uint64_t> parts;
  for (const GlobePolygon& p : polygons) {
    parts.push_back(geo::io::digest(&p.group, sizeof(p.group)));
    for (const auto& ring : p.rings) parts.push_back(geo::io::digest(ring.data(), ring.size() * sizeof(glm::dvec2)));
  }
  return parts.empty() ? 0 : geo::io::digest(parts.data(), parts.size() * sizeof(std::uint64_t));
}

/// False, with `problem` set, for a point that is not a longitude and latitude.
bool usablePoint(const glm::dvec2& p, std::string& problem) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
    problem = "a coordinate is not a finite number";
    return false;
  }
  if (std::abs(p.y) > 90.0) {
    problem = "latitude " + std::to_string(p.y) + " is beyond ±90°";
    return false;
  }
  return true;
}

/// The ring's points with geodesic points added, unwrapped, closed along a pole if it winds
/// around one; empty with `problem` set when it cannot be used.
std::vector<glm::dvec2> prepareRing(const std::vector<glm::dvec2>& input, double maxSegment, std::string& problem,
                                    bool densify = true) {
  std::vector<glm::dvec2> ring;
  for (const glm::dvec2& p : input) {
    if (!usablePoint(p, problem)) return {};
    if (!ring.empty() && ring.back() == p) continue;
    ring.push_back(p);
  }
  while (ring.size() > 1 && ring.back() == ring.front()) ring.pop_back();
  // Start at a point that is not a pole (its longitude means something).
  const auto firstPlain = std::find_if(ring.begin(), ring.end(), [](const glm::dvec2& p) { return !isPole(p.y); });
  if (firstPlain == ring.end()) {
    problem = "every point is at a pole";
    return {};
  }
  std::rotate(ring.begin(), firstPlain, ring.end());
  if (ring.size() < 3) {
    problem = "fewer than 3 distinct points";
    return {};
  }

  // Geodesic points: no piece longer than maxSegment.
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  std::vector<glm::dvec2> dense;
  const std::size_t n = ring.size();
  if (!densify) dense = ring;
  for (std::size_t i = 0; i < n && densify; ++i) {
    const glm::dvec2 p = ring[i], q = ring[(i + 1) % n];
    dense.push_back(p);
    if (isPole(p.y) && isPole(q.y) && (p.y > 0) == (q.y > 0)) continue;  // along a pole: no length
    // From the lesser end (longitude, then latitude): a border two rings share, run one way in
    // each, gets the same points in both, so the coverage's generalisation sees it shared.
    const bool forward = p.x < q.x || (p.x == q.x && p.y < q.y);
    const glm::dvec2 from = forward ? p : q, to = forward ? q : p;
    const GeographicLib::GeodesicLine line = geod.InverseLine(from.y, from.x, to.y, to.x);
    const double s12 = line.Distance();
    const auto pieces = static_cast<std::size_t>(std::ceil(s12 / maxSegment));
    for (std::size_t k = 1; k < pieces; ++k) {
      double lat = 0.0, lon = 0.0;
      const std::size_t at = forward ? k : pieces - k;
      line.Position(s12 * static_cast<double>(at) / static_cast<double>(pieces), lat, lon);
      dense.emplace_back(lon, lat);
    }
  }

  // Unwrap. A run of pole points becomes two: the pole on the meridian it is reached by and on
  // the one it is left by; the turn between them is the run's own (a run of two or more points
  // says how far it goes round), else the shorter way.
  std::vector<glm::dvec2> out;
  out.reserve(dense.size() + 4);
  out.push_back(dense[0]);
  double lastRaw = dense[0].x;
  std::size_t i = 1;
  const std::size_t m = dense.size();
  while (i <= m) {
    const bool closing = i == m;
    const glm::dvec2 q = dense[i % m];
    if (!closing && isPole(q.y)) {
      std::size_t j = i;
      while (j < m && isPole(dense[j].y) && (dense[j].y > 0) == (q.y > 0)) ++j;
      const glm::dvec2 next = dense[j % m];  // not a pole: the ring starts with a plain point
      double turn = 0.0;
      if (j - i >= 2) {
        turn = wrap180(dense[i].x - lastRaw) + (dense[j - 1].x - dense[i].x) + wrap180(next.x - dense[j - 1].x);
      } else {
        turn = wrap180(next.x - lastRaw);
      }
      const double pole = q.y > 0 ? 90.0 : -90.0;
      out.emplace_back(out.back().x, pole);
      if (j == m) {
        // The run ends the ring: it turns back to the first point's meridian, whichever way
        // closes the ring (it encloses the pole then, like Antarctica's coast and its pole edge).
        out.emplace_back(out.front().x, pole);
        break;
      }
      out.emplace_back(out.back().x + turn, pole);
      out.emplace_back(out.back().x, next.y);
      lastRaw = next.x;
      i = j + 1;
      continue;
    }
    if (closing) {
      const double total = out.back().x + wrap180(dense[0].x - lastRaw) - out.front().x;
      if (std::abs(total) > 1e-9) {
        if (std::abs(std::abs(total) - 360.0) > 1e-6) {
          problem = "the ring winds around a pole more than once";
          return {};
        }
        // Winds once around a pole: close it along the nearer one.
        double meanLat = 0.0;
        for (const glm::dvec2& p : out) meanLat += p.y;
        const double pole = meanLat < 0.0 ? -90.0 : 90.0;
        const double end = out.back().x + wrap180(dense[0].x - lastRaw);
        out.emplace_back(end, out.back().y);  // the first point again, 360° on
        out.emplace_back(end, pole);
        out.emplace_back(out.front().x, pole);
      }
      break;
    }
    out.emplace_back(out.back().x + wrap180(q.x - lastRaw), q.y);
    lastRaw = q.x;
    ++i;
  }
  // Remove repeated points the unwrapping may leave.
  std::vector<glm::dvec2> clean;
  for (const glm::dvec2& p : out) {
    if (clean.empty() || clean.back() != p) clean.push_back(p);
  }
  while (clean.size() > 1 && clean.back() == clean.front()) clean.pop_back();
  if (clean.size() < 3) {
    problem = "fewer than 3 distinct points";
    return {};
  }
  return clean;
}

/// How far a point lies from the chord a–b of a ring, as the globe's generalisation measures it
/// (overlay::SegmentDistance): in degrees of arc, longitude scaled by the cosine of the point's
/// latitude, divided by that cosine again: a tolerance in arc at the equator that shrinks with
/// the cosine of the latitude, as the posts of the geographic grid do. Points at a pole are
/// always kept (the ring runs along it there).
double ringDistance(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  if (isPole(p.y)) return std::numeric_limits<double>::infinity();
  // The cosine from a table every 1/64° (linear between: within 1e-8 of it, far below any
  // tolerance's meaning): generalisation asks it at every point of every span it looks at.
  constexpr int kPerDegree = 64;
  static const std::vector<double> table = [] {
    constexpr double kDegree = 3.14159265358979323846 / 180.0;
    std::vector<double> t(90 * kPerDegree + 2);
    for (std::size_t k = 0; k < t.size(); ++k) t[k] = std::cos(static_cast<double>(k) / kPerDegree * kDegree);
    return t;
  }();
  const double at = std::abs(p.y) * kPerDegree;
  const auto k = static_cast<std::size_t>(at);
  const double c = table[k] + (table[k + 1] - table[k]) * (at - static_cast<double>(k));
  const glm::dvec2 u((a.x - p.x) * c, a.y - p.y), v((b.x - p.x) * c, b.y - p.y);
  const glm::dvec2 d = v - u;
  const double len2 = glm::dot(d, d);
  const double t = len2 > 0.0 ? std::clamp(-glm::dot(u, d) / len2, 0.0, 1.0) : 0.0;
  return glm::length(u + d * t) / std::max(c, 1e-12);
}

}  // namespace

double simplifyTolerance(int level) { return TileKey{level, 0, 0}.postStep() / 64.0; }

namespace {

/// What prepareLine finds wrong with a line before densifying it (empty: nothing).
std::string lineProblem(const std::vector<glm::dvec2>& input) {
  std::string problem;
  std::size_t distinct = 0;
  const glm::dvec2* last = nullptr;
  for (const glm::dvec2& p : input) {
    if (!usablePoint(p, problem)) return problem;
    if (last == nullptr || *last != p) ++distinct;
    last = &p;
  }
  return distinct < 2 ? "fewer than 2 distinct points" : "";
}

/// A line's points densified along geodesics and unwrapped (empty with `problem` set when it
/// cannot be used: lineProblem), and each of them on the ellipsoid (ECEF) in `surface`.
std::vector<glm::dvec2> prepareLine(const std::vector<glm::dvec2>& input, double maxSegment, std::string& problem,
                                    std::vector<char>& given, std::vector<glm::dvec3>& surface) {
  problem = lineProblem(input);
  if (!problem.empty()) return {};
  std::vector<glm::dvec2> line;
  for (const glm::dvec2& p : input) {
    if (line.empty() || line.back() != p) line.push_back(p);
  }
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  std::vector<glm::dvec2> out{line[0]};
  given.assign(1, 1);
  glm::dvec3 from = toEcef(line[0].x, line[0].y, 0.0);
  surface.assign(1, from);
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const glm::dvec2 p = line[i], q = line[i + 1];
    const glm::dvec3 to = toEcef(q.x, q.y, 0.0);
    // Most segments of real data are far shorter than maxSegment: their chord says so without a
    // geodesic (the geodesic is longer than the chord by less than c³ / (24 R²), R ≥ 6,335 km the
    // least radius of curvature; bounded with room to spare below 100 km). The point is the same.
    const double chord = glm::length(to - from);
    from = to;
    if (chord < 1e5 && chord + chord * chord * chord / (20.0 * 6.3e6 * 6.3e6) < maxSegment) {
      out.emplace_back(out.back().x + wrap180(q.x - out.back().x), q.y);
      given.push_back(1);
      surface.push_back(to);
      continue;
    }
    const GeographicLib::GeodesicLine g = geod.InverseLine(p.y, p.x, q.y, q.x);
    const auto pieces = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(g.Distance() / maxSegment)));
    for (std::size_t k = 1; k <= pieces; ++k) {
      double lat = q.y, lon = q.x;
      if (k < pieces) g.Position(g.Distance() * static_cast<double>(k) / static_cast<double>(pieces), lat, lon);
      out.emplace_back(out.back().x + wrap180(lon - out.back().x), lat);
      given.push_back(k == pieces ? 1 : 0);
      surface.push_back(k == pieces ? to : toEcef(out.back().x, out.back().y, 0.0));
    }
  }
  return out;
}

/// The rings a run of a line in metres is drawn with (buildTilePieces unites them per cell): the
/// shared shapes (overlay::lineShapes) in the tangent planes of its stations (globeStations), each
/// corner put on the ellipsoid (the foot of centre + half width · direction) in unwrapped lon/lat
/// near its point. As fewer rings unite faster, and the generaliser keeps borders that rings share
/// but may open a crack where they only nearly meet: the segments through stations the source did
/// not give make one band, and a join from its point (a wedge, bevel or miter) or a half-disc cap
/// is glued to the band ending there (on the band's end edge: the ring stays simple). A join that
/// turns so little that it lies within the chord tolerance of the bands is left out (its corners
/// would nearly repeat the bands' and leave slivers for the caps' triangulation). No join or cap
/// at a pole.
std::vector<std::vector<glm::dvec2>> runRings(const GlobeLine& line, double h, const std::vector<glm::dvec2>& points,
                                              std::size_t first, std::size_t last, const std::vector<char>& given,
                                              double chordTolerance) {
  const detail::GlobeStations st = detail::globeStations(points, first, last, given);
  const double tol = std::min(chordTolerance, 0.5 * h);
  const int chords = static_cast<int>(std::ceil(3.14159265358979323846 / std::acos(1.0 - tol / h)));
  const overlay::LineShapeRules rules = detail::globeShapeRules(line, h, std::clamp(chords, 8, 256), false);
  using Corners = std::vector<overlay::ShapeCorner>;
  std::vector<Corners> rings;
  struct Band {
    Corners right, left;  ///< left from the band's start
    Corners startCap;     ///< a cap glued to its start: its corners between the band's start corners
    std::uint32_t last = 0;
    bool open = false;
  } band;
  Corners startCap;  ///< the line's first cap, until the band it rests on opens
  const auto same = [](const overlay::ShapeCorner& a, const overlay::ShapeCorner& b) {
    return a.station == b.station && glm::length(a.direction - b.direction) <= 1e-9;
  };
  const auto flush = [&] {
    if (!band.open) return;
    Corners ring = std::move(band.right);
    ring.insert(ring.end(), band.left.rbegin(), band.left.rend());
    ring.insert(ring.end(), band.startCap.begin(), band.startCap.end());
    rings.push_back(std::move(ring));
    band = Band{};
  };
  const auto fromCentre = [](const Corners& c) { return c.size() >= 3 && c[0].direction == glm::dvec2(0.0); };
  overlay::lineShapes(st.stations, rules, [&](overlay::PieceKind kind, Corners corners) {
    if (corners.empty()) return;
    if (kind == overlay::PieceKind::Segment) {
      const std::uint32_t a = corners[0].station, b = corners[1].station;
      if (band.open && band.last == a && !st.stations[a].given) {
        band.right.push_back(corners[1]);
        band.left.push_back(corners[2]);
        band.last = b;
        return;
      }
      flush();
      band.right = {corners[0], corners[1]};
      band.left = {corners[3], corners[2]};
      band.last = b;
      band.open = true;
      if (!startCap.empty()) {
        if (same(startCap.front(), band.left.front()) && same(startCap.back(), band.right.front())) {
          band.startCap.assign(startCap.begin() + 1, startCap.end() - 1);
        } else {
          rings.push_back(std::move(startCap));
        }
        startCap.clear();
      }
      return;
    }
    const std::uint32_t s = corners[0].station;
    if (st.pole[s] != 0) return;
    if (kind == overlay::PieceKind::Join && fromCentre(corners)) {
      const overlay::LineStation& at = st.stations[s];
      const double turn = std::abs(at.in.x * at.out.y - at.in.y * at.out.x);
      if (at.in.x * at.out.x + at.in.y * at.out.y > 0.0 && h * std::asin(std::min(turn, 1.0)) <= 2.0 * tol) return;
    }
    const bool atBandEnd = band.open && band.last == s;
    if (kind == overlay::PieceKind::Join && atBandEnd && fromCentre(corners)) {
      if (same(corners[1], band.right.back())) {
        // Outside on the right: on from the band's right end corner, back to the point.
        band.right.insert(band.right.end(), corners.begin() + 2, corners.end());
        band.right.push_back(corners[0]);
        flush();
        return;
      }
      if (same(corners.back(), band.left.back())) {
        // Outside on the left: from the point out to the band's left end corner.
        band.right.insert(band.right.end(), corners.begin(), corners.end() - 1);
        flush();
        return;
      }
    }
    if (kind == overlay::PieceKind::Cap && !band.open && rings.empty() && startCap.empty() && s == 0) {
      startCap = std::move(corners);  // glued once its band opens
      return;
    }
    if (kind == overlay::PieceKind::Cap && atBandEnd && corners.size() >= 3 &&
        same(corners.front(), band.right.back()) && same(corners.back(), band.left.back())) {
      band.right.insert(band.right.end(), corners.begin() + 1, corners.end() - 1);
      flush();
      return;
    }
    rings.push_back(std::move(corners));
  });
  flush();
  if (!startCap.empty()) rings.push_back(std::move(startCap));
  std::vector<std::vector<glm::dvec2>> out;
  out.reserve(rings.size());
  for (const auto& ring : rings) {
    std::vector<glm::dvec2> lonLat;
    lonLat.reserve(ring.size());
    for (const overlay::ShapeCorner& c : ring) {
      const glm::dvec2& p = points[first + st.point[c.station]];
      const Geodetic g = toGeodetic(st.centre[c.station] + h * st.direction(c));
      lonLat.emplace_back(p.x + wrap180(g.lon - p.x), g.lat);
    }
    out.push_back(std::move(lonLat));
  }
  return out;
}

/// A polygon's rings prepared (prepareRing), the outer one's west end in [−180, 180) and the
/// holes moved by whole turns to lie nearest its middle, and its box. False, with `problem`
/// naming the ring, when a ring cannot be used.
bool preparePolygon(const geo::Polygon& polygon, double maxSegment, GlobePolygon& prepared, std::string& problem,
                    bool densify = true) {
  std::vector<const geo::Ring*> rings{&polygon.outer};
  for (const geo::Ring& hole : polygon.holes) rings.push_back(&hole);
  prepared.rings.clear();
  for (std::size_t r = 0; r < rings.size(); ++r) {
    std::vector<glm::dvec2> ring = prepareRing(*rings[r], maxSegment, problem, densify);
    if (ring.empty()) {
      problem = (r == 0 ? "outer ring: " : "hole " + std::to_string(r) + ": ") + problem;
      return false;
    }
    prepared.rings.push_back(std::move(ring));
  }
  const auto lonRange = [](const std::vector<glm::dvec2>& ring) {
    double lo = std::numeric_limits<double>::max(), hi = -lo;
    for (const glm::dvec2& p : ring) {
      lo = std::min(lo, p.x);
      hi = std::max(hi, p.x);
    }
    return std::pair{lo, hi};
  };
  const auto shift = [](std::vector<glm::dvec2>& ring, double by) {
    for (glm::dvec2& p : ring) p.x += by;
  };
  auto [west, east] = lonRange(prepared.rings[0]);
  const double outerShift = -360.0 * std::floor((west + 180.0) / 360.0);
  shift(prepared.rings[0], outerShift);
  const double middle = 0.5 * (west + east) + outerShift;
  for (std::size_t r = 1; r < prepared.rings.size(); ++r) {
    const auto [hw, he] = lonRange(prepared.rings[r]);
    shift(prepared.rings[r], 360.0 * std::round((middle - 0.5 * (hw + he)) / 360.0));
  }
  LonLatRect box{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
  for (const auto& ring : prepared.rings) {
    for (const glm::dvec2& p : ring) {
      box.west = std::min(box.west, p.x);
      box.east = std::max(box.east, p.x);
      box.south = std::min(box.south, p.y);
      box.north = std::max(box.north, p.y);
    }
  }
  prepared.box = box;
  return true;
}

/// How far (degrees of latitude) the geodesic from p to q (longitudes unwrapped) may stray
/// poleward of its ends: twice the bound (L/2)² tan φ / 2R. None where the bound is not small: a
/// piece longer than 5° or a point beyond 80°.
std::optional<double> geodesicBulge(const glm::dvec2& p, const glm::dvec2& q) {
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  const double poleward = std::max(std::abs(p.y), std::abs(q.y));
  if (poleward > 80.0 || std::abs(q.x - p.x) > 5.0 || std::abs(q.y - p.y) > 5.0) return std::nullopt;
  // The piece's length bounded from above without trigonometry per point: its longitude span
  // along the parallel nearer the equator (cos ≤ 1 - x²/2 + x⁴/24), its latitude span, on a
  // sphere larger than any radius of curvature of WGS 84 (6,399,594 m at the poles).
  constexpr double kRadius = 6.4e6;
  const double x = std::min(std::abs(p.y), std::abs(q.y)) * kDegree, x2 = x * x;
  const double along = std::abs(q.x - p.x) * kDegree * (1.0 - x2 / 2.0 + x2 * x2 / 24.0) * kRadius;
  const double across = std::abs(q.y - p.y) * kDegree * kRadius;
  const double length2 = along * along + across * across;
  return length2 / (4.0 * kMinCurvatureRadius) * std::tan(poleward * kDegree) / (kMinCurvatureRadius * kDegree);
}

/// What preparePolygon says of a polygon, without the geodesic points (GlobeLayer::build checks
/// every area but keeps only its box): the rings as given, unwrapped as preparePolygon unwraps
/// them, and a box that holds the prepared rings (each edge's geodesic bulges poleward of its
/// ends by at most (L/2)² tan φ / 2R; twice that is added). Where that bound is not small (long
/// edges, points near a pole) or the rings as given would not do, the polygon is prepared.
bool checkPolygon(const geo::Polygon& polygon, double maxSegment, GlobePolygon& checked, std::string& problem) {
  if (!preparePolygon(polygon, maxSegment, checked, problem, false))
    return preparePolygon(polygon, maxSegment, checked, problem);
  double bulge = 0.0;  // degrees of latitude
  for (const auto& ring : checked.rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const std::optional<double> b = geodesicBulge(ring[i], ring[(i + 1) % ring.size()]);
      if (!b) return preparePolygon(polygon, maxSegment, checked, problem);
      bulge = std::max(bulge, *b);
    }
  }
  const double grow = 2.0 * bulge + 1e-9;
  checked.box = {checked.box.west - 1e-9, std::max(-90.0, checked.box.south - grow), checked.box.east + 1e-9,
                 std::min(90.0, checked.box.north + grow)};
  return true;
}

}  // namespace

namespace {

/// The lines a feature is drawn with: its line strings, and with `outlines` its polygons' rings,
/// each closed.
std::vector<std::vector<glm::dvec2>> featureLines(const geo::Feature& feature, bool outlines) {
  std::vector<std::vector<glm::dvec2>> lines;
  for (const geo::LineString& l : feature.lines) lines.push_back(l);
  if (outlines) {
    for (const geo::Polygon& polygon : feature.polygons) {
      std::vector<const geo::Ring*> rings{&polygon.outer};
      for (const geo::Ring& hole : polygon.holes) rings.push_back(&hole);
      for (const geo::Ring* ring : rings) {
        std::vector<glm::dvec2> closed = *ring;
        if (!closed.empty()) closed.push_back(closed.front());
        lines.push_back(std::move(closed));
      }
    }
  }
  return lines;
}

}  // namespace

double GlobeLayer::featureHalfWidth(std::uint32_t f) const {
  double halfWidth = 0.5 * options_.lineWidthMetres;
  if (f < options_.featureWidthMetres.size() && options_.featureWidthMetres[f] > 0.0 &&
      std::isfinite(options_.featureWidthMetres[f]))
    halfWidth = 0.5 * options_.featureWidthMetres[f];
  return halfWidth;
}

std::uint64_t GlobeLayer::checkLines(std::uint32_t f, const geo::Feature& feature, std::uint32_t group,
                                     FeatureParts& part, LonLatRect& box, bool& any,
                                     std::vector<LineEntry>& entries) const {
  const std::vector<std::vector<glm::dvec2>> lines = featureLines(feature, options_.outlines);
  const double halfWidth = featureHalfWidth(f);
  const bool inPixels = widthPixels_ > 0.0;
  const double maxHalfWidth = inPixels ? std::max(0.5 * options_.lineMaxWidthMetres, halfWidth) : 0.0;
  std::vector<std::uint64_t> parts;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    const std::string problem = lineProblem(lines[k]);
    if (!problem.empty()) {
      part.diagnostics.add({Severity::Error,
                            {},
                            name_,
                            std::to_string(feature.fid),
                            "line " + std::to_string(k) + ": " + problem + "; the line is left out"});
      continue;
    }
    any = true;
    parts.push_back(geo::io::digest(lines[k].data(), lines[k].size() * sizeof(glm::dvec2)));
    // The given points' box, unwrapped as prepareFeature unwraps them, widened by the reach.
    LonLatRect b{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
    double x = lines[k].front().x;
    const double shift = -360.0 * std::floor((x + 180.0) / 360.0);
    for (const glm::dvec2& p : lines[k]) {
      x += wrap180(p.x - x);
      b.west = std::min(b.west, x + shift);
      b.east = std::max(b.east, x + shift);
      b.south = std::min(b.south, p.y);
      b.north = std::max(b.north, p.y);
    }
    // Room for the geodesics' bulge poleward of their ends (as checkPolygon); a line with a piece
    // longer than 5° or a point beyond 80° is prepared to be boxed.
    double bulge = 0.0;
    bool exact = false;
    for (std::size_t i = 0; i + 1 < lines[k].size() && !exact; ++i) {
      const glm::dvec2 p = lines[k][i], q = lines[k][i + 1];
      const std::optional<double> by = geodesicBulge(p, {p.x + wrap180(q.x - p.x), q.y});
      exact = !by;
      bulge = std::max(bulge, by.value_or(0.0));
    }
    if (exact) {
      std::string unused;
      std::vector<char> given;
      std::vector<glm::dvec3> surface;
      std::vector<glm::dvec2> prepared = prepareLine(lines[k], options_.maxSegmentMetres, unused, given, surface);
      const double by = prepared.empty() ? 0.0 : -360.0 * std::floor((prepared.front().x + 180.0) / 360.0);
      for (const glm::dvec2& p : prepared) {
        b.west = std::min(b.west, p.x + by);
        b.east = std::max(b.east, p.x + by);
        b.south = std::min(b.south, p.y);
        b.north = std::max(b.north, p.y);
      }
    } else {
      b.south = std::max(-90.0, b.south - 2.0 * bulge - 1e-9);
      b.north = std::min(90.0, b.north + 2.0 * bulge + 1e-9);
    }
    GlobeLine shape;
    shape.join = options_.join;
    shape.cap = options_.cap;
    shape.miterLimit = options_.miterLimit;
    const double dLat = halfWidth * shape.shapeReach() / 110000.0;
    const double high = std::min(89.9, std::max(std::abs(b.south), std::abs(b.north)) + dLat);
    b = b.expanded(b.north + dLat >= 90.0 || b.south - dLat <= -90.0
                       ? 360.0
                       : dLat / std::cos(high * 3.14159265358979323846 / 180.0),
                   dLat);
    box = {std::min(box.west, b.west), std::min(box.south, b.south), std::max(box.east, b.east),
           std::max(box.north, b.north)};
    entries.push_back({f, group, static_cast<std::uint32_t>(k), b});
  }
  if (parts.empty()) return 0;
  const std::array<double, 7> shape{halfWidth,
                                    widthPixels_,
                                    maxHalfWidth,
                                    options_.miterLimit,
                                    static_cast<double>(options_.join),
                                    static_cast<double>(options_.cap),
                                    static_cast<double>(group)};
  parts.push_back(geo::io::digest(shape.data(), sizeof(shape)));
  return geo::io::digest(parts.data(), parts.size() * sizeof(std::uint64_t));
}

void GlobeLayer::prepareFeature(std::uint32_t f, const geo::Feature& feature, std::uint32_t group, FeatureParts& part,
                                bool areas, bool checkOnly, std::size_t onlyLine) const {
  const GlobeLayerOptions& options = options_;
  const bool inPixels = widthPixels_ > 0.0;
  const double maxHalfWidth = 0.5 * options.lineMaxWidthMetres;
  const std::vector<std::vector<glm::dvec2>> lines =
      areas ? std::vector<std::vector<glm::dvec2>>{} : featureLines(feature, options.outlines);
  for (std::size_t k = 0; k < lines.size(); ++k) {
    if (onlyLine != kAllLines && k != onlyLine) continue;
    std::string problem;
    std::vector<char> given;
    std::vector<glm::dvec3> surface;
    std::vector<glm::dvec2> line = prepareLine(lines[k], options.maxSegmentMetres, problem, given, surface);
    if (line.empty()) {
      part.diagnostics.add({Severity::Error,
                            {},
                            name_,
                            std::to_string(feature.fid),
                            "line " + std::to_string(k) + ": " + problem + "; the line is left out"});
      continue;
    }
    GlobeLine g;
    g.feature = static_cast<std::uint32_t>(f);
    g.group = group;
    g.halfWidth = featureHalfWidth(f);
    g.join = options.join;
    g.cap = options.cap;
    g.miterLimit = options.miterLimit;
    if (inPixels) {
      g.widthPixels = options.lineWidthPixels;
      g.maxHalfWidth = std::max(maxHalfWidth, g.halfWidth);
    }
    const double shift = -360.0 * std::floor((line.front().x + 180.0) / 360.0);
    for (glm::dvec2& p : line) p.x += shift;
    g.box = {std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
    g.surface = std::move(surface);
    for (const glm::dvec2& p : line) {
      g.box.west = std::min(g.box.west, p.x);
      g.box.east = std::max(g.box.east, p.x);
      g.box.south = std::min(g.box.south, p.y);
      g.box.north = std::max(g.box.north, p.y);
    }
    if (inPixels && options.anchorGround) {
      g.anchors.reserve(line.size());
      for (const glm::dvec2& p : line)
        g.anchors.push_back(static_cast<float>(options.anchorGround->heightAt(p.x, p.y)));
    }
    if (!g.round()) {
      // Joins and caps, once: the reference tests them at every point it looks at.
      auto joins = std::make_shared<detail::LineJoins>();
      joins->at.reserve(line.size());
      for (std::size_t i = 0; i < line.size(); ++i) {
        joins->at.push_back(detail::pointShape(g, line, i, given[i] != 0));
        g.reach = std::max(g.reach, joins->at.back().reach);
      }
      g.joins = std::move(joins);
    }
    // Widened by the half width (in degrees of latitude; longitude at the box's highest latitude).
    const double dLat = g.halfWidth * g.reach / 110000.0;
    const double high = std::min(89.9, std::max(std::abs(g.box.south), std::abs(g.box.north)) + dLat);
    const double dLon = dLat / std::cos(high * 3.14159265358979323846 / 180.0);
    g.box = g.box.expanded(g.box.north + dLat >= 90.0 || g.box.south - dLat <= -90.0 ? 360.0 : dLon, dLat);
    {
      // Pieces in a grid of about a quarter as many cells as points, as square in degrees as
      // the box allows, for the reference.
      const detail::GridShape grid = detail::gridShape(std::clamp<std::size_t>(line.size() / 4, 1, 4096),
                                                       g.box.east - g.box.west, g.box.north - g.box.south);
      g.bucketColumns = grid.columns;
      g.bucketWidth = grid.cellWidth;
      g.bucketHeight = grid.cellHeight;
      g.buckets.assign(grid.columns * grid.rows, {});
      for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        // Widened by the farther reach of its two points' shapes.
        const double share = g.joins ? std::max({1.0, g.joins->at[i].reach, g.joins->at[i + 1].reach}) / g.reach : 1.0;
        const double dLatHere = dLat * share, dLonHere = dLon * share;
        const std::size_t c0 = g.bucketColumn(std::min(line[i].x, line[i + 1].x) - dLonHere),
                          c1 = g.bucketColumn(std::max(line[i].x, line[i + 1].x) + dLonHere);
        // A geodesic bulges poleward of its ends by up to (L/2)² tan φ / 2R (twice that here);
        // pieces near a pole are in every row.
        const double poleward = std::max(std::abs(line[i].y), std::abs(line[i + 1].y));
        const glm::dvec3 chord = g.surface[i + 1] - g.surface[i];
        const double bulge = poleward >= 89.0 ? 180.0
                                              : glm::dot(chord, chord) / (4.0 * kMinCurvatureRadius) *
                                                    std::tan(poleward * 3.14159265358979323846 / 180.0) / 110000.0;
        const std::size_t r0 = g.bucketRow(std::min(line[i].y, line[i + 1].y) - dLatHere - bulge),
                          r1 = g.bucketRow(std::max(line[i].y, line[i + 1].y) + dLatHere + bulge);
        for (std::size_t r = r0; r <= r1; ++r) {
          for (std::size_t c = c0; c <= c1; ++c)
            g.buckets[r * g.bucketColumns + c].push_back(static_cast<std::uint32_t>(i));
        }
      }
    }
    g.points = std::move(line);
    g.given = std::move(given);
    part.lines.push_back(std::move(g));
  }
  if (areas && !options.outlines) {
    for (std::size_t k = 0; k < feature.polygons.size(); ++k) {
      GlobePolygon prepared;
      prepared.feature = static_cast<std::uint32_t>(f);
      prepared.group = group;
      prepared.source = static_cast<std::uint32_t>(k);
      std::string problem;
      if (!(checkOnly ? checkPolygon(feature.polygons[k], options.maxSegmentMetres, prepared, problem)
                      : preparePolygon(feature.polygons[k], options.maxSegmentMetres, prepared, problem))) {
        part.diagnostics.add({Severity::Error,
                              {},
                              name_,
                              std::to_string(feature.fid),
                              "polygon " + std::to_string(k) + ", " + problem + "; the polygon is left out"});
        continue;
      }
      if (!checkOnly) prepared.index = detail::buildIndex(prepared);
      part.polygons.push_back(std::move(prepared));
    }
  }
}

Result<GlobeLayer> GlobeLayer::build(std::string name, const overlay::SharedFeatures& features, glm::vec4 color,
                                     const GlobeLayerOptions& options) {
  Result<GlobeLayer> out;
  GlobeLayer layer;
  layer.name_ = std::move(name);
  layer.color_ = color;
  layer.chordTolerance_ = options.chordTolerance;
  layer.maxSegment_ = options.maxSegmentMetres;
  layer.options_ = options;
  layer.prepared_ = std::make_shared<detail::Prepared>();
  const bool inPixels = options.lineWidthPixels > 0.0 && std::isfinite(options.lineWidthPixels);
  if (inPixels) {
    layer.widthPixels_ = options.lineWidthPixels;
    layer.anchorGround_ = options.anchorGround;
  }
  // Each feature's colour group.
  layer.colors_.assign(1, color);
  std::vector<std::uint32_t> groupOf(features.size(), 0);
  for (std::size_t f = 0; f < features.size() && f < options.featureColors.size(); ++f) {
    const auto found = std::find(layer.colors_.begin(), layer.colors_.end(), options.featureColors[f]);
    groupOf[f] = static_cast<std::uint32_t>(found - layer.colors_.begin());
    if (found == layer.colors_.end()) layer.colors_.push_back(options.featureColors[f]);
  }
  // Lines (line strings, or the rings of an outline layer): their points, for the reference and
  // for the shapes each tile draws of them (lineShapesIn: made per tile, never for the whole layer).
  bool drawLines = options.outlines;
  for (std::size_t f = 0; f < features.size() && !drawLines; ++f) {
    const auto [lo, hi] = features.box(f, true);  // from the index on disk: nothing is read
    drawLines = lo.x <= hi.x;
  }
  const double halfWidth = 0.5 * options.lineWidthMetres;
  const double maxHalfWidth = 0.5 * options.lineMaxWidthMetres;
  if (drawLines && inPixels && !(maxHalfWidth > 0.0 && std::isfinite(maxHalfWidth))) {
    out.diagnostics.add(
        {Severity::Error,
         {},
         layer.name_,
         {},
         "largest line width " + std::to_string(options.lineMaxWidthMetres) + " m is not a positive width"});
    return out;
  }
  // A line in pixels needs no width in metres (0: none); one in metres a positive one.
  if (drawLines &&
      !(inPixels ? halfWidth >= 0.0 && std::isfinite(halfWidth) : halfWidth > 0.0 && std::isfinite(halfWidth))) {
    out.diagnostics.add({Severity::Error,
                         {},
                         layer.name_,
                         {},
                         "line width " + std::to_string(options.lineWidthMetres) + " m is not a positive width"});
    return out;
  }
  // The features in runs, on every core (features on disk are read one at a time, and only those
  // being checked are resident): the areas checked, for their boxes and digest (checkPolygon:
  // their rings are prepared as tiles ask, areasIn, or all at once, polygons()), the lines checked (prepared when first
  // asked for: lines()); the runs' areas, boxes and messages are joined in the features' order,
  // so the layer is the same on any number of cores.
  const std::size_t runs = runCount(features.size());
  struct Run {
    FeatureParts part;
    std::vector<Area> areas;
    std::vector<LineEntry> lines;
    LonLatRect box{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
    bool any = false;
  };
  std::vector<Run> parts(runs);
  layer.lineDigests_.assign(features.size(), 0);
  layer.areaDigests_.assign(features.size(), 0);
  forRuns(features.size(), runs, [&](std::size_t r, std::size_t f) {
    Run& run = parts[r];
    const std::shared_ptr<const geo::Feature> feature = features.get(f);
    const auto index = static_cast<std::uint32_t>(f);
    if (drawLines)
      layer.lineDigests_[f] = layer.checkLines(index, *feature, groupOf[f], run.part, run.box, run.any, run.lines);
    layer.prepareFeature(index, *feature, groupOf[f], run.part, true, true);
    layer.areaDigests_[f] = areasDigest(run.part.polygons);
    for (const GlobePolygon& p : run.part.polygons) run.areas.push_back({p.feature, p.group, p.source, p.box});
    run.part.polygons.clear();
  });
  LonLatRect extent{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
  const auto widen = [&extent](const LonLatRect& r) {
    extent = {std::min(extent.west, r.west), std::min(extent.south, r.south), std::max(extent.east, r.east),
              std::max(extent.north, r.north)};
  };
  for (Run& run : parts) {
    for (const Area& a : run.areas) {
      widen(a.box);
      layer.areas_.push_back(a);
    }
    if (run.any) {
      layer.hasLines_ = true;
      widen(run.box);
    }
    layer.lineEntries_.insert(layer.lineEntries_.end(), run.lines.begin(), run.lines.end());
    out.diagnostics.append(run.part.diagnostics);
  }
  layer.areaGrid_ = gridOfBoxes(layer.areas_);
  layer.lineBoxes_ = gridOfBoxes(layer.lineEntries_);
  if (extent.west <= extent.east) layer.extent_ = extent;
  // Of the lines in pixels, the least width in metres and the greatest largest one (what a frame's
  // width classes are chosen by), from the options: each line's widths are its feature's.
  if (inPixels && layer.hasLines_) {
    bool first = true;
    for (std::size_t f = 0; f < features.size(); ++f) {
      if (layer.lineDigests_[f] == 0) continue;
      const double h = layer.featureHalfWidth(static_cast<std::uint32_t>(f));
      layer.leastHalfWidth_ = first ? h : std::min(layer.leastHalfWidth_, h);
      layer.widestHalfWidth_ = std::max(layer.widestHalfWidth_, std::max(maxHalfWidth, h));
      first = false;
    }
    if (options.anchorGround) layer.anchorDigest_ = options.anchorGround->contentDigest().value_or(1);
  }
  layer.features_ = features;
  layer.featureGroups_ = std::move(groupOf);
  layer.fingerprint_ = layer.digestForCache();
  layer.serial_ = ++detail::layerBuilds;
  out.value = std::move(layer);
  return out;
}

const std::vector<GlobeLine>& GlobeLayer::lines() const {
  if (const std::vector<GlobeLine>* made = lines_->linesMade.load(std::memory_order_acquire)) return *made;
  const std::lock_guard<std::mutex> lock(lines_->mutex);
  if (!lines_->lines) lines_->lines = std::make_shared<const std::vector<GlobeLine>>(prepareLines());
  lines_->linesMade.store(lines_->lines.get(), std::memory_order_release);
  return *lines_->lines;
}

const detail::LineGrid& GlobeLayer::lineGrid() const {
  if (const detail::LineGrid* made = lines_->gridMade.load(std::memory_order_acquire)) return *made;
  const std::vector<GlobeLine>& all = lines();
  const std::lock_guard<std::mutex> lock(lines_->mutex);
  if (!lines_->grid) lines_->grid = std::make_shared<const detail::LineGrid>(detail::LineGrid::of(all));
  lines_->gridMade.store(lines_->grid.get(), std::memory_order_release);
  return *lines_->grid;
}

namespace detail {

LineGrid LineGrid::of(const std::vector<GlobeLine>& lines) {
  LineGrid grid;
  bool first = true;
  std::vector<LonLatRect> boxes(lines.size(), LonLatRect{0.0, 0.0, -1.0, -1.0});
  for (std::size_t j = 0; j < lines.size(); ++j) {
    const GlobeLine& line = lines[j];
    if (line.buckets.empty()) continue;
    boxes[j] = line.box;
    LineReach& w = grid.widths;
    w.widthPixels = std::max(w.widthPixels, line.widthPixels);
    w.maxHalfWidth = std::max(w.maxHalfWidth, line.maxHalfWidth);
    w.halfWidth = first ? line.halfWidth : std::min(w.halfWidth, line.halfWidth);
    w.reach = std::max(w.reach, line.reach);
    first = false;
  }
  static_cast<BoxGrid&>(grid) = BoxGrid::of(boxes);
  return grid;
}

BoxGrid BoxGrid::of(const std::vector<LonLatRect>& boxes) {
  BoxGrid grid;
  bool first = true;
  for (const LonLatRect& b : boxes) {
    if (b.west > b.east) continue;
    grid.box = first ? b
                     : LonLatRect{std::min(grid.box.west, b.west), std::min(grid.box.south, b.south),
                                  std::max(grid.box.east, b.east), std::max(grid.box.north, b.north)};
    first = false;
  }
  if (first) return grid;
  // About as many cells as boxes.
  const GridShape& s = grid.shape = gridShape(std::min<std::size_t>(boxes.size(), 1 << 16),
                                              grid.box.east - grid.box.west, grid.box.north - grid.box.south);
  grid.cells.assign(s.columns * s.rows, {});
  for (std::size_t j = 0; j < boxes.size(); ++j) {
    const LonLatRect& b = boxes[j];
    if (b.west > b.east) continue;
    const std::size_t c0 = cellIndex(b.west, grid.box.west, s.cellWidth, s.columns),
                      c1 = cellIndex(b.east, grid.box.west, s.cellWidth, s.columns);
    const std::size_t r0 = cellIndex(b.south, grid.box.south, s.cellHeight, s.rows),
                      r1 = cellIndex(b.north, grid.box.south, s.cellHeight, s.rows);
    if ((c1 - c0 + 1) * (r1 - r0 + 1) * 4 > grid.cells.size()) {
      grid.everywhere.push_back(static_cast<std::uint32_t>(j));
      continue;
    }
    for (std::size_t r = r0; r <= r1; ++r) {
      for (std::size_t c = c0; c <= c1; ++c) grid.cells[r * s.columns + c].push_back(static_cast<std::uint32_t>(j));
    }
  }
  return grid;
}

std::vector<std::uint32_t> BoxGrid::meeting(const LonLatRect& rect) const {
  std::vector<std::uint32_t> out = everywhere;
  if (!cells.empty() && rect.south <= box.north && rect.north >= box.south) {
    const std::size_t r0 = cellIndex(rect.south, box.south, shape.cellHeight, shape.rows),
                      r1 = cellIndex(rect.north, box.south, shape.cellHeight, shape.rows);
    for (int turn = -1; turn <= 1; ++turn) {
      const double west = rect.west + 360.0 * turn, east = rect.east + 360.0 * turn;
      if (east < box.west || west > box.east) continue;
      const std::size_t c0 = cellIndex(west, box.west, shape.cellWidth, shape.columns),
                        c1 = cellIndex(east, box.west, shape.cellWidth, shape.columns);
      for (std::size_t r = r0; r <= r1; ++r) {
        for (std::size_t c = c0; c <= c1; ++c) {
          const std::vector<std::uint32_t>& cell = cells[r * shape.columns + c];
          out.insert(out.end(), cell.begin(), cell.end());
        }
      }
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace detail

std::vector<GlobeLine> GlobeLayer::prepareLines() const {
  std::vector<GlobeLine> out;
  if (!hasLines_) return out;
  // As build runs its features (their messages were said at build).
  const std::size_t count = std::min(featureGroups_.size(), lineDigests_.size());
  std::vector<FeatureParts> parts(runCount(count));
  forRuns(count, parts.size(), [&](std::size_t r, std::size_t f) {
    if (lineDigests_[f] == 0) return;  // no usable line
    const auto index = static_cast<std::uint32_t>(f);
    prepareFeature(index, *featureAt(index), featureGroups_[f], parts[r], false);
  });
  for (FeatureParts& part : parts) {
    for (GlobeLine& g : part.lines) out.push_back(std::move(g));
  }
  return out;
}

std::vector<GlobePolygon> GlobeLayer::prepareAreas() const {
  std::vector<GlobePolygon> out;
  out.reserve(areas_.size());
  const std::size_t count = std::min(featureGroups_.size(), areaDigests_.size());
  std::vector<FeatureParts> parts(runCount(count));
  forRuns(count, parts.size(), [&](std::size_t r, std::size_t f) {
    if (areaDigests_[f] == 0) return;  // no usable area
    const auto index = static_cast<std::uint32_t>(f);
    prepareFeature(index, *featureAt(index), featureGroups_[f], parts[r], true);
  });
  for (FeatureParts& part : parts) {
    for (GlobePolygon& p : part.polygons) out.push_back(std::move(p));
  }
  return out;
}

const std::vector<GlobePolygon>& GlobeLayer::polygons() const {
  if (const std::vector<GlobePolygon>* made = allAreas_->made.load(std::memory_order_acquire)) return *made;
  const std::lock_guard<std::mutex> lock(allAreas_->mutex);
  if (!allAreas_->polygons) allAreas_->polygons = std::make_shared<const std::vector<GlobePolygon>>(prepareAreas());
  allAreas_->made.store(allAreas_->polygons.get(), std::memory_order_release);
  return *allAreas_->polygons;
}

bool GlobeLayer::allLinesPrepared() const { return lines_->linesMade.load(std::memory_order_acquire) != nullptr; }

bool GlobeLayer::allAreasPrepared() const { return allAreas_->made.load(std::memory_order_acquire) != nullptr; }

std::shared_ptr<const geo::Feature> GlobeLayer::featureAt(std::uint32_t f) const {
  if (edited_) {
    const auto found = edited_->find(f);
    if (found != edited_->end()) return found->second;
  }
  return features_.get(f);
}

namespace {

std::size_t bytesOf(const GlobePolygon& p) {
  std::size_t bytes = sizeof(GlobePolygon);
  for (const auto& ring : p.rings) bytes += ring.size() * sizeof(glm::dvec2) + sizeof(ring);
  return bytes;
}

/// Where edge p → q crosses the line coordinate[axis] = c, straight in longitude and latitude:
/// the same point whichever way the edge runs (a border two rings share runs both ways).
glm::dvec2 cutAt(const glm::dvec2& p, const glm::dvec2& q, int axis, double c) {
  const bool swap = q.x < p.x || (q.x == p.x && q.y < p.y);
  const glm::dvec2 a = swap ? q : p, b = swap ? p : q;
  glm::dvec2 at = a + (b - a) * ((c - a[axis]) / (b[axis] - a[axis]));
  at[axis] = c;
  return at;
}

/// A ring cut to a rectangle (Sutherland–Hodgman, side by side), repeated points left out.
std::vector<glm::dvec2> cutRing(const std::vector<glm::dvec2>& ring, const LonLatRect& r) {
  std::vector<glm::dvec2> out = ring;
  const std::array<std::tuple<int, double, bool>, 4> sides{
      {{0, r.west, true}, {0, r.east, false}, {1, r.south, true}, {1, r.north, false}}};
  for (const auto& side : sides) {
    if (out.empty()) break;
    // Named copies: clang 14 cannot capture structured bindings in a lambda (it came in clang 16).
    const int axis = std::get<0>(side);
    const double c = std::get<1>(side);
    const bool above = std::get<2>(side);
    const auto inside = [&](const glm::dvec2& p) { return above ? p[axis] >= c : p[axis] <= c; };
    std::vector<glm::dvec2> next;
    glm::dvec2 s = out.back();
    for (const glm::dvec2& e : out) {
      if (inside(e)) {
        if (!inside(s)) next.push_back(cutAt(s, e, axis, c));
        next.push_back(e);
      } else if (inside(s)) {
        next.push_back(cutAt(s, e, axis, c));
      }
      s = e;
    }
    out = std::move(next);
  }
  out.erase(std::unique(out.begin(), out.end()), out.end());
  while (out.size() > 1 && out.front() == out.back()) out.pop_back();
  if (out.size() < 3) out.clear();
  return out;
}

}  // namespace

std::shared_ptr<const GlobePolygon> GlobeLayer::preparedArea(std::size_t k) const {
  if (allAreasPrepared()) {
    const std::shared_ptr<const std::vector<GlobePolygon>>& all = allAreas_->polygons;
    return k < all->size() ? std::shared_ptr<const GlobePolygon>(all, &(*all)[k]) : nullptr;
  }
  if (const std::shared_ptr<const GlobePolygon> kept = prepared_->areas.find(k)) return kept;
  const Area& a = areas_[k];
  const std::shared_ptr<const geo::Feature> feature = featureAt(a.feature);
  if (a.source >= feature->polygons.size()) return nullptr;
  auto p = std::make_shared<GlobePolygon>();
  p->feature = a.feature;
  p->group = a.group;
  p->source = a.source;
  std::string problem;
  if (!preparePolygon(feature->polygons[a.source], maxSegment_, *p, problem)) return nullptr;
  const std::size_t bytes = bytesOf(*p);
  return prepared_->areas.keep(k, std::move(p), bytes);
}

std::vector<GlobePolygon> GlobeLayer::areasIn(const LonLatRect& rect, int level) const {
  std::vector<GlobePolygon> out;
  if (!areaGrid_) return out;
  const bool generalise = level >= 0 && level < kMaxLevel;
  // The cut's margin: what it adds (its edges along the cut) stays farther from `rect` than
  // the generalisation may move an edge, so that what is drawn in `rect` is the areas' own.
  const double dLat = generalise ? std::max(TileKey{level, 0, 0}.postStep(), 4.0 * simplifyTolerance(level))
                                 : 0.01 * std::max(rect.north - rect.south, rect.east - rect.west) + 1e-6;
  const double high = std::max(std::abs(rect.south), std::abs(rect.north)) + dLat;
  const double dLon = high >= 89.0 ? 360.0 : dLat / std::cos(high * 3.14159265358979323846 / 180.0);
  const LonLatRect cut{rect.west - dLon, rect.south - dLat, rect.east + dLon, rect.north + dLat};
  for (const std::uint32_t k : areaGrid_->meeting(rect)) {
    const LonLatRect& box = areas_[k].box;
    if (box.south > rect.north || box.north < rect.south) continue;
    std::shared_ptr<const GlobePolygon> area;
    for (int turn = -1; turn <= 1; ++turn) {
      const double shift = 360.0 * turn;
      if (box.west > rect.east + shift || box.east < rect.west + shift) continue;
      if (!area) area = preparedArea(k);
      if (!area) break;
      GlobePolygon p;
      p.feature = area->feature;
      p.group = area->group;
      p.source = area->source;
      if (dLon >= 180.0 && cut.south <= box.south && cut.north >= box.north) {
        p.rings = area->rings;  // nothing to cut
      } else {
        const LonLatRect shifted{dLon >= 180.0 ? -1e9 : cut.west + shift, cut.south,
                                 dLon >= 180.0 ? 1e9 : cut.east + shift, cut.north};
        for (const auto& ring : area->rings) {
          std::vector<glm::dvec2> r = cutRing(ring, shifted);
          if (!r.empty()) p.rings.push_back(std::move(r));
        }
      }
      if (p.rings.empty()) continue;
      p.box = {std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
      for (const auto& ring : p.rings) {
        for (const glm::dvec2& q : ring)
          p.box = {std::min(p.box.west, q.x), std::min(p.box.south, q.y), std::max(p.box.east, q.x),
                   std::max(p.box.north, q.y)};
      }
      out.push_back(std::move(p));
      if (dLon >= 180.0) break;  // uncut in longitude: one turn holds it
    }
  }
  if (out.empty() || !generalise) return out;
  // Generalised together: shared borders have the same points in both areas (prepareRing
  // densifies them from the same end), found once and simplified once.
  std::vector<geo::Feature> coverage(out.size());
  std::vector<const geo::Feature*> pointers;
  pointers.reserve(out.size());
  for (std::size_t a = 0; a < out.size(); ++a) {
    geo::Polygon polygon;
    for (std::size_t r = 0; r < out[a].rings.size(); ++r)
      (r == 0 ? polygon.outer : polygon.holes.emplace_back()) = out[a].rings[r];
    coverage[a].polygons.push_back(std::move(polygon));
    pointers.push_back(&coverage[a]);
  }
  // Islands within the tolerance of one chord are left out of the level.
  const std::vector<geo::Feature> generalised =
      overlay::CoverageGeneraliser(pointers, ringDistance).at(simplifyTolerance(level), nullptr, true);
  std::vector<GlobePolygon> kept;
  kept.reserve(out.size());
  for (std::size_t a = 0; a < out.size(); ++a) {
    const geo::Polygon& g = generalised[a].polygons.front();
    std::size_t points = 0, left = 0;
    for (const auto& ring : out[a].rings) points += ring.size();
    std::vector<std::vector<glm::dvec2>> rings;
    for (std::size_t r = 0; r <= g.holes.size(); ++r) {
      const geo::Ring& ring = r == 0 ? g.outer : g.holes[r - 1];
      left += ring.size();
      if (ring.size() >= 3) rings.push_back(ring);
    }
    // Nearly nothing left out: drawn from its own rings.
    if (left * 10 < points * 9) out[a].rings = std::move(rings);
    if (!out[a].rings.empty()) kept.push_back(std::move(out[a]));
  }
  return kept;
}

std::vector<LonLatRect> GlobeLayer::featureBoxes(std::uint32_t f) const {
  std::vector<LonLatRect> boxes;
  for (const Area& a : areas_) {
    if (a.feature == f) boxes.push_back(a.box);
  }
  const double maxHalfWidth = widthPixels_ > 0.0 ? 0.5 * options_.lineMaxWidthMetres : 0.0;
  for (const LineEntry& line : lineEntries_) {
    if (line.feature != f) continue;
    // The box holds the line's shapes at its least half width; its pieces in a width class reach
    // as far as the widest it is drawn, its joins and caps lineShapeReach() half widths.
    const double reach = std::max(featureHalfWidth(f), maxHalfWidth) * lineShapeReach() * 1.01 + 1.0;
    const double dLat = reach / 110000.0;
    const double high = std::min(89.9, std::max(std::abs(line.box.south), std::abs(line.box.north)) + dLat);
    const double dLon = dLat / std::cos(high * 3.14159265358979323846 / 180.0);
    boxes.push_back(
        line.box.north + dLat >= 90.0 || line.box.south - dLat <= -90.0
            ? LonLatRect{line.box.west - 360.0, line.box.south - dLat, line.box.east + 360.0, line.box.north + dLat}
            : line.box.expanded(dLon, dLat));
  }
  return boxes;
}

Result<std::vector<LonLatRect>> GlobeLayer::replaceFeature(std::size_t f, const geo::Feature& feature) {
  Result<std::vector<LonLatRect>> out;
  if (f > featureGroups_.size()) {
    out.diagnostics.add({Severity::Error,
                         {},
                         name_,
                         std::to_string(feature.fid),
                         "feature " + std::to_string(f) + " is not in the layer (it has " +
                             std::to_string(featureGroups_.size()) + "); nothing changed"});
    return out;
  }
  const auto index = static_cast<std::uint32_t>(f);
  if (f == featureGroups_.size()) featureGroups_.push_back(0);  // appended: the layer's colour
  std::vector<LonLatRect> boxes = featureBoxes(index);          // from the features as built
  // Its lines and areas checked as build checks them (their entries, digests and messages).
  FeatureParts part;
  std::vector<LineEntry> freshLines;
  {
    LonLatRect box{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
    bool any = false;
    if (f >= lineDigests_.size()) lineDigests_.resize(f + 1, 0);
    lineDigests_[f] = checkLines(index, feature, featureGroups_[f], part, box, any, freshLines);
    hasLines_ = hasLines_ || any;
  }
  prepareFeature(index, feature, featureGroups_[f], part, true, true);
  out.diagnostics.append(part.diagnostics);
  // The feature as edited, for what is prepared from now on (areasIn, polygons(), lines()).
  using Edited = std::map<std::uint32_t, std::shared_ptr<const geo::Feature>>;
  auto editedFeatures = edited_ ? std::make_shared<Edited>(*edited_) : std::make_shared<Edited>();
  (*editedFeatures)[index] = std::make_shared<const geo::Feature>(feature);
  edited_ = std::move(editedFeatures);
  // In the features' order, as build joins them: the layer is the one built from the edited features.
  const auto replace = [index](auto& items, auto& fresh) {
    items.erase(std::remove_if(items.begin(), items.end(), [&](const auto& item) { return item.feature == index; }),
                items.end());
    const auto at = std::find_if(items.begin(), items.end(), [&](const auto& item) { return item.feature > index; });
    items.insert(at, std::make_move_iterator(fresh.begin()), std::make_move_iterator(fresh.end()));
  };
  // Its areas' entries, in the features' order; the prepared areas edited if they were made.
  if (f >= areaDigests_.size()) areaDigests_.resize(f + 1, 0);
  areaDigests_[f] = areasDigest(part.polygons);
  std::vector<Area> fresh;
  for (const GlobePolygon& p : part.polygons) fresh.push_back({p.feature, p.group, p.source, p.box});
  replace(areas_, fresh);
  areaGrid_ = gridOfBoxes(areas_);
  prepared_ = std::make_shared<detail::Prepared>();
  if (allAreasPrepared()) {
    FeatureParts prepared;
    prepareFeature(index, feature, featureGroups_[f], prepared, true);
    std::vector<GlobePolygon> all = polygons();
    replace(all, prepared.polygons);
    allAreas_ = std::make_shared<LazyAreas>();
    allAreas_->polygons = std::make_shared<const std::vector<GlobePolygon>>(std::move(all));
    allAreas_->made.store(allAreas_->polygons.get(), std::memory_order_release);
  } else {
    allAreas_ = std::make_shared<LazyAreas>();
  }
  // Its lines' entries likewise; the prepared lines edited if they were made (a new list: copies
  // of the layer keep theirs).
  replace(lineEntries_, freshLines);
  lineBoxes_ = gridOfBoxes(lineEntries_);
  if (lines_->linesMade.load(std::memory_order_acquire) != nullptr) {
    FeatureParts prepared;
    prepareFeature(index, feature, featureGroups_[f], prepared, false);
    std::vector<GlobeLine> edited = lines();
    replace(edited, prepared.lines);
    lines_ = std::make_shared<LazyLines>();
    lines_->lines = std::make_shared<const std::vector<GlobeLine>>(std::move(edited));
    lines_->linesMade.store(lines_->lines.get(), std::memory_order_release);
  } else {
    lines_ = std::make_shared<LazyLines>();
  }
  if (widthPixels_ > 0.0) {
    // As build finds them: each line's widths are its feature's.
    const double maxHalfWidth = 0.5 * options_.lineMaxWidthMetres;
    bool first = true;
    leastHalfWidth_ = widestHalfWidth_ = 0.0;
    for (std::size_t g = 0; g < lineDigests_.size(); ++g) {
      if (lineDigests_[g] == 0) continue;
      const double h = featureHalfWidth(static_cast<std::uint32_t>(g));
      leastHalfWidth_ = first ? h : std::min(leastHalfWidth_, h);
      widestHalfWidth_ = std::max(widestHalfWidth_, std::max(maxHalfWidth, h));
      first = false;
    }
  }
  fingerprint_ = digestForCache();
  const std::vector<LonLatRect> reached = featureBoxes(index);
  boxes.insert(boxes.end(), reached.begin(), reached.end());
  out.value = std::move(boxes);
  return out;
}

namespace detail {

std::atomic<std::uint64_t> layerBuilds{0};

std::shared_ptr<const PolygonIndex> buildIndex(const GlobePolygon& polygon) {
  auto index = std::make_shared<PolygonIndex>();
  index->west = polygon.box.west;
  const double span = std::max(polygon.box.east - polygon.box.west, 1e-9);
  std::size_t edges = 0;
  for (const auto& ring : polygon.rings) edges += ring.size();
  index->buckets.resize(std::clamp<std::size_t>(edges / 4, 1, 8192));
  index->bucketWidth = span / static_cast<double>(index->buckets.size());
  for (const auto& ring : polygon.rings) {
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const glm::dvec2 p = ring[i], q = ring[(i + 1) % ring.size()];
      if (p.x == q.x) continue;  // along a meridian: never crosses one
      IndexedEdge e;
      e.lon0 = std::min(p.x, q.x);
      e.lon1 = std::max(p.x, q.x);
      e.eastward = q.x > p.x;
      if (isPole(p.y) && isPole(q.y) && (p.y > 0) == (q.y > 0)) {
        e.pole = p.y > 0 ? 1 : -1;
      } else {
        e.plane = edgePlane(p, q);
      }
      const auto b0 = index->bucketOf(e.lon0), b1 = index->bucketOf(e.lon1);
      const auto at = static_cast<std::uint32_t>(index->edges.size());
      index->edges.push_back(e);
      for (std::size_t b = b0; b <= b1; ++b) index->buckets[b].push_back(at);
    }
  }
  return index;
}

double reachBeyond(const LineReach& line, const overlay::PixelScale& scale, const glm::dvec3& point) {
  if (!(line.widthPixels > 0.0 && scale.metresPerPixel > 0.0)) return 0.0;
  // A point within r of an anchor at most 20 km above or below it: r ≤ c · (D + r + 20 km) with
  // c the half width per metre of distance and D the point's distance to the eye.
  const double c = 0.5 * line.widthPixels * scale.metresPerPixel;
  const double far = c < 0.5 ? c * (glm::length(point - scale.eye) + 2e4) / (1.0 - c) : line.maxHalfWidth;
  return line.reach * std::max(0.0, std::min(line.maxHalfWidth, far) - line.halfWidth);
}

bool nearLine(const GlobeLayer& layer, const GlobeLine& line, const glm::dvec3& point, double lonDeg, double latDeg,
              const overlay::PixelScale& scale) {
  if (line.buckets.empty()) return false;
  // The box and buckets hold the line's least half width; a line in pixels may reach further.
  const double extra = reachBeyond(line, scale, point);
  const double dLat = extra / 110000.0;
  if (latDeg < line.box.south - dLat || latDeg > line.box.north + dLat) return false;
  const double high = std::max(std::abs(line.box.south), std::abs(line.box.north)) + dLat;
  const double dLon = extra <= 0.0   ? 0.0
                      : high >= 89.9 ? 360.0
                                     : dLat / std::cos(high * 3.14159265358979323846 / 180.0);
  const bool fixed = !(line.widthPixels > 0.0 && scale.metresPerPixel > 0.0);
  const auto radius = [&](std::size_t k) { return fixed ? line.halfWidth : layer.halfWidthAt(line, k, scale); };
  // The walls are vertical (they hold the normals): a disc is a cylinder around the normal at its
  // point, a band the slab between two planes parallel to its piece's plane (a line in pixels:
  // its half width goes linearly from one end's to the other's, as in a projected frame).
  // Joins and caps other than round: their shapes in the tangent plane at the point.
  const auto nearPoint = [&](std::size_t k, double r) {
    const glm::dvec2& p = line.points[k];
    if (isPole(p.y)) return false;
    const glm::dvec3 n = surfaceNormalAt(line.surface[k]);
    const glm::dvec3 d = point - line.surface[k];
    if (!line.joins || k >= line.joins->at.size()) return glm::length(d - n * glm::dot(d, n)) <= r;
    if (glm::length(d - n * glm::dot(d, n)) > r * line.joins->at[k].reach) return false;
    return inPointShape(line.joins->at[k], line.surface[k], n, r, point);
  };
  // No shape of a piece reaches further than this across the normals (in 3D also the chord's sag
  // and the point's height, which is its distance to the ellipsoid along the normal).
  const double height = glm::length(point - toEcef(lonDeg, latDeg, 0.0)) * (1.0 + 1e-9) + 1.0;
  const auto farthest = [&](std::size_t k) {
    if (!line.joins) return (line.halfWidth + extra) + height;
    const std::vector<detail::PointShape>& at = line.joins->at;
    const double reach = std::max(std::max(1.0, k < at.size() ? at[k].reach : line.reach),
                                  k + 1 < at.size() ? at[k + 1].reach : line.reach);
    return (line.halfWidth + extra) * reach + height;
  };
  const auto nearPiece = [&](std::size_t k) {
    {
      // Most pieces a point is asked about are far from it: this test, in scalars (under the
      // sanitizers each vector temporary is a poisoned stack object; this was a fifth of a globe
      // accuracy test there).
      const glm::dvec3& a = line.surface[k];
      const glm::dvec3& b = line.surface[k + 1];
      const double abx = b.x - a.x, aby = b.y - a.y, abz = b.z - a.z;
      const double px = point.x - a.x, py = point.y - a.y, pz = point.z - a.z;
      const double l2 = abx * abx + aby * aby + abz * abz;
      const double t = l2 > 0.0 ? std::clamp((px * abx + py * aby + pz * abz) / l2, 0.0, 1.0) : 0.0;
      const double ox = px - abx * t, oy = py - aby * t, oz = pz - abz * t;
      const double slack = farthest(k) + l2 / (8.0 * kMinCurvatureRadius);
      if (ox * ox + oy * oy + oz * oz > slack * slack) return false;
    }
    const double ra = radius(k), rb = radius(k + 1);
    if (nearPoint(k, ra) || nearPoint(k + 1, rb)) return true;
    const glm::dvec3 a = line.surface[k], b = line.surface[k + 1];
    const glm::dvec3 along = b - a;
    const double length = glm::length(along);
    if (!(length > 0.0)) return false;
    const glm::dvec3 u = along / length;
    const glm::dvec3 na = surfaceNormalAt(a), nb = surfaceNormalAt(b);
    const glm::dvec3 m = glm::normalize(glm::cross(glm::normalize(na + nb), along));
    // Its ends: the vertical planes through its end points that hold its side there (the plane
    // a join's or cap's edge at the point lies in: pointShape), so that band and shape meet.
    if (glm::dot(point - a, bandEndNormal(u, m, na)) < 0.0 || glm::dot(point - b, bandEndNormal(u, m, nb)) > 0.0)
      return false;
    const double s = std::clamp(glm::dot(point - a, u), 0.0, length);
    return std::abs(glm::dot(point - a, m)) <= ra + (rb - ra) * (s / length);
  };
  const double west = line.box.west - dLon, east = line.box.east + dLon;
  const std::size_t r0 = line.bucketRow(latDeg - dLat), r1 = line.bucketRow(latDeg + dLat);
  for (double lon = lonDeg - 360.0 * std::ceil((lonDeg - west) / 360.0); lon <= east; lon += 360.0) {
    if (lon < west) continue;
    const std::size_t c0 = line.bucketColumn(lon - dLon), c1 = line.bucketColumn(lon + dLon);
    for (std::size_t r = r0; r <= r1; ++r) {
      for (std::size_t c = c0; c <= c1; ++c) {
        for (const std::uint32_t k :
             line.buckets[r * line.bucketColumns + c]) {  // a piece in several buckets is tried again
          if (nearPiece(k)) return true;
        }
      }
    }
  }
  return false;
}

}  // namespace detail

bool contains(const GlobePolygon& polygon, const glm::dvec3& point, double lonDeg, double latDeg) {
  if (latDeg < polygon.box.south || latDeg > polygon.box.north || !polygon.index) return false;
  const detail::PolygonIndex& index = *polygon.index;
  // The meridian through the point, in each turn of longitudes the polygon spans.
  int crossings = 0;
  double lon = lonDeg - 360.0 * std::ceil((lonDeg - polygon.box.west) / 360.0);  // ≤ west
  for (; lon <= polygon.box.east; lon += 360.0) {
    if (lon < polygon.box.west) continue;
    for (const std::uint32_t e : index.buckets[index.bucketOf(lon)]) {
      const detail::IndexedEdge& edge = index.edges[e];
      if (!(lon >= edge.lon0 && lon < edge.lon1)) continue;
      // Does the edge meet the meridian north of the point?
      if (edge.pole != 0) {
        crossings += edge.pole > 0 ? 1 : 0;
        continue;
      }
      const double side = glm::dot(point - edge.plane.a, edge.plane.m);
      if (edge.eastward ? side < 0.0 : side > 0.0) ++crossings;
    }
  }
  return (crossings & 1) != 0;
}

namespace {

/// The line's points Douglas–Peucker keeps for `tolerance` metres: each left-out point lies within
/// it of the chord between the kept ones around it, on the ellipsoid (ECEF: the chord's sag counts
/// too, so long chords are split where the ground curves away from them). The ends and any point
/// at a pole are kept.
std::vector<glm::dvec2> generalisedCentreline(const GlobeLine& line, double tolerance) {
  const std::size_t n = line.points.size();
  std::vector<char> keep(n, 0);
  keep[0] = keep[n - 1] = 1;
  for (std::size_t k = 0; k < n; ++k) keep[k] = static_cast<char>(keep[k] != 0 || isPole(line.points[k].y));
  // Each run between points kept already (ends, poles) on its own; the chord in ECEF.
  const auto distance = [&line](std::size_t k, std::size_t a, std::size_t b) {
    const glm::dvec3 pa = line.surface[a], along = line.surface[b] - pa;
    const double length2 = glm::dot(along, along);
    const glm::dvec3 d = line.surface[k] - pa;
    const double t = length2 > 0.0 ? std::clamp(glm::dot(d, along) / length2, 0.0, 1.0) : 0.0;
    return glm::length(d - along * t);
  };
  std::size_t from = 0;
  for (std::size_t k = 1; k < n; ++k) {
    if (keep[k] == 0) continue;
    overlay::markDouglasPeucker(from, k, tolerance, keep, distance);
    from = k;
  }
  std::vector<glm::dvec2> kept;
  for (std::size_t k = 0; k < n; ++k) {
    if (keep[k] != 0) kept.push_back(line.points[k]);
  }
  return kept;
}

}  // namespace

double GlobeLayer::lineTolerance(const GlobeLine& line, int level) {
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  const double high = std::min(89.0, std::max(std::abs(line.box.south), std::abs(line.box.north)));
  return kLineGeneralisation * simplifyTolerance(level) * kDegree * kSemiMajor * std::cos(high * kDegree);
}

std::vector<std::uint32_t> GlobeLayer::linesNear(const TileKey& key, double reach) const {
  std::vector<std::uint32_t> out;
  if (!lineBoxes_ || key.level < 0 || key.level > kMaxLevel) return out;
  // The tile grown as lineRunsIn grows it, in longitude at the highest latitude within reach.
  const LonLatRect rect = key.rect();
  const double dLat = (reach + 1.0) / 110000.0 + key.postStep();
  const double high = std::max(std::abs(rect.south), std::abs(rect.north)) + dLat;
  const double dLon = high >= 89.9 ? 360.0 : dLat / std::cos(high * 3.14159265358979323846 / 180.0);
  const LonLatRect near = rect.expanded(dLon, dLat);
  for (const std::uint32_t j : lineBoxes_->meeting(near)) {
    const LonLatRect& b = lineEntries_[j].box;
    if (b.south > near.north || b.north < near.south) continue;
    for (int turn = -1; turn <= 1; ++turn) {
      if (b.west <= near.east + 360.0 * turn && b.east >= near.west + 360.0 * turn) {
        out.push_back(j);
        break;
      }
    }
  }
  return out;
}

GlobeLayer::TileLine GlobeLayer::lineAt(std::size_t j, int level) const {
  TileLine t;
  if (j >= lineEntries_.size()) return t;
  if (const std::vector<GlobeLine>* all = lines_->linesMade.load(std::memory_order_acquire)) {
    if (j < all->size()) t.line = std::shared_ptr<const GlobeLine>(lines_->lines, &(*all)[j]);
  } else if (!(t.line = prepared_->lines.find(j))) {
    // Read and prepared now: this line of its feature only.
    const LineEntry& e = lineEntries_[j];
    FeatureParts part;
    prepareFeature(e.feature, *featureAt(e.feature), e.group, part, false, false, e.source);
    if (part.lines.size() != 1) return t;
    const GlobeLine& g = part.lines.front();
    std::size_t bytes = sizeof(GlobeLine) + g.points.size() * (sizeof(glm::dvec2) + sizeof(glm::dvec3) + 1) +
                        g.anchors.size() * sizeof(float);
    for (const auto& bucket : g.buckets) bytes += bucket.size() * sizeof(std::uint32_t) + sizeof(bucket);
    t.line = prepared_->lines.keep(j, std::make_shared<const GlobeLine>(std::move(part.lines.front())), bytes);
  }
  if (!t.line) return t;
  const int at = std::clamp(level, 0, kMaxLevel);
  const double tolerance = lineTolerance(*t.line, at);
  if (tolerance > 4.0 * chordTolerance_) {
    // Lines in metres: a quarter of the tolerance for the centreline (a quarter for the arcs,
    // half for the rings). Lines in pixels: three quarters (a quarter for the arcs; their rings,
    // where a tile draws them in metres, are not simplified again), as a projected tile's lines
    // (tiled_layer.hpp): within half a pixel in all.
    const std::uint64_t key = static_cast<std::uint64_t>(j) * (kMaxLevel + 1) + static_cast<std::uint64_t>(at);
    t.points = prepared_->centres.find(key);
    if (!t.points) {
      const double share = t.line->widthPixels > 0.0 ? 0.75 : 0.25;
      auto made = std::make_shared<const std::vector<glm::dvec2>>(generalisedCentreline(*t.line, share * tolerance));
      const std::size_t bytes = made->size() * sizeof(glm::dvec2) + sizeof(*made);
      t.points = prepared_->centres.keep(key, std::move(made), bytes);
    }
    t.generalised = true;
  } else {
    t.points = std::shared_ptr<const std::vector<glm::dvec2>>(t.line, &t.line->points);
  }
  return t;
}

std::vector<std::pair<std::size_t, std::size_t>> GlobeLayer::lineRunsIn(const TileLine& tileLine, const TileKey& key,
                                                                        double reach) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  if (!tileLine.line || !tileLine.points || key.level < 0 || key.level > kMaxLevel) return runs;
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  const GlobeLine& line = *tileLine.line;
  const LonLatRect rect = key.rect();
  // A box of points widened by the reach and a post, in longitude by the parallel's length at the
  // highest latitude a point within reach can have: the box's own, not the tile's. (Widened by the
  // tile's, every tile touching a pole reached every longitude: the eight tiles around a pole each
  // drew every line of their latitudes.)
  const double dLat = (reach + 1.0) / 110000.0 + key.postStep();
  const auto meets = [&](double west, double south, double east, double north) {
    const double high = std::max(std::abs(south), std::abs(north)) + dLat;
    const double dLon = high >= 89.9 ? 360.0 : dLat / std::cos(high * kDegree);
    for (int turn = -1; turn <= 1; ++turn) {
      if (west - dLon <= rect.east + 360.0 * turn && east + dLon >= rect.west + 360.0 * turn &&
          south - dLat <= rect.north && north + dLat >= rect.south)
        return true;
    }
    return false;
  };
  if (!meets(line.box.west, line.box.south - reach / 110000.0, line.box.east, line.box.north + reach / 110000.0))
    return runs;
  const std::vector<glm::dvec2>& points = *tileLine.points;
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const glm::dvec2 p = points[i], q = points[i + 1];
    if (!meets(std::min(p.x, q.x), std::min(p.y, q.y), std::max(p.x, q.x), std::max(p.y, q.y))) continue;
    if (!runs.empty() && runs.back().second == i) {
      runs.back().second = i + 1;
    } else {
      runs.emplace_back(i, i + 1);
    }
  }
  return runs;
}

bool GlobeLayer::scalesLine(const GlobeLine& line, int widthClass) {
  return widthClass > 0 && line.widthPixels > 0.0 && 0.5 * lineClassWidth(widthClass) > line.halfWidth;
}

std::vector<GlobePolygon> GlobeLayer::lineShapesIn(const TileKey& key, int widthClass, double pixelMetres,
                                                   int detailLevel) const {
  std::vector<GlobePolygon> out;
  if (!hasLines_ || key.level < 0 || key.level > kMaxLevel) return out;
  const int level = detailLevel < 0 ? key.level : std::min(detailLevel, kMaxLevel);
  // The lines near the tile (their boxes hold their shapes at their least widths; a drape's
  // lines in pixels may be wider), read and prepared as asked for.
  const double wider = widthPixels_ > 0.0 && pixelMetres > 0.0
                           ? std::min(0.5 * widthPixels_ * pixelMetres, widestHalfWidth_) * lineShapeReach()
                           : 0.0;
  for (const std::uint32_t j : linesNear(key, wider)) {
    const TileLine tileLine = lineAt(j, level);
    if (!tileLine.line) continue;
    const GlobeLine& line = *tileLine.line;
    // Lines the class scales are drawn by their own pieces (buildTilePieces); none is thinner.
    if (scalesLine(line, widthClass) || !(line.halfWidth > 0.0)) continue;
    // A drape's lines in pixels: widthPixels of its texels, within the line's least and largest.
    const double h = line.widthPixels > 0.0 && pixelMetres > 0.0
                         ? std::max(std::min(0.5 * line.widthPixels * pixelMetres, line.maxHalfWidth), line.halfWidth)
                         : line.halfWidth;
    const double tolerance = lineTolerance(line, level);
    const bool generalised = tileLine.generalised;
    const std::vector<glm::dvec2>& points = *tileLine.points;
    // The runs of pieces that meet the tile widened by the shapes' reach (the pieces' clip
    // margins are less): a run's ends outside it (or the line's own ends).
    for (const auto& [first, last] : lineRunsIn(tileLine, key, h * line.shapeReach())) {
      // Points the source gave get joins, and the line's ends caps; a run's ends where the window
      // cuts it get their joins (they lie beyond the tile's window by the line's reach).
      std::vector<GlobePolygon> made;
      const double arcTolerance = generalised ? std::max(chordTolerance_, 0.25 * tolerance) : chordTolerance_;
      std::vector<std::vector<glm::dvec2>> shapes =
          runRings(line, h, points, first, last, generalised ? std::vector<char>{} : line.given, arcTolerance);
      for (std::vector<glm::dvec2>& shape : shapes) {
        GlobePolygon p;
        p.feature = line.feature;
        p.group = line.group;
        std::string problem;
        if (preparePolygon({std::move(shape), {}}, maxSegment_, p, problem)) made.push_back(std::move(p));
      }
      if (generalised && !(line.widthPixels > 0.0)) {
        // The rings simplified within the other half as one coverage, so the borders the shapes
        // share (where bands and sectors meet) stay shared and no crack opens inside the line.
        std::vector<geo::Feature> coverage(made.size());
        std::vector<const geo::Feature*> pointers;
        for (std::size_t k = 0; k < made.size(); ++k) {
          coverage[k].polygons.push_back({made[k].rings.front(), {}});
          pointers.push_back(&coverage[k]);
        }
        const std::vector<geo::Feature> simplified =
            overlay::generaliseCoverage(pointers, 0.5 * kLineGeneralisation * simplifyTolerance(level), ringDistance);
        for (std::size_t k = 0; k < made.size(); ++k) {
          const geo::Ring& ring = simplified[k].polygons.front().outer;
          if (ring.size() >= 3) made[k].rings.front() = ring;
        }
      }
      for (GlobePolygon& p : made) out.push_back(std::move(p));
    }
  }
  return out;
}

std::size_t GlobeLine::bucketColumn(double lon) const {
  return detail::cellIndex(lon, box.west, bucketWidth, bucketColumns);
}

std::size_t GlobeLine::bucketRow(double lat) const {
  return detail::cellIndex(lat, box.south, bucketHeight, buckets.size() / bucketColumns);
}

bool GlobeLayer::contains(const glm::dvec3& point, double lonDeg, double latDeg,
                          const overlay::PixelScale& scale) const {
  if (!areas_.empty()) {
    for (const GlobePolygon& p : polygons()) {
      if (globe::contains(p, point, lonDeg, latDeg)) return true;
    }
  }
  if (!hasLines_) return false;
  const std::vector<GlobeLine>& all = lines();
  const detail::LineGrid& grid = lineGrid();
  // The farthest any line may reach beyond its box here (at the bounds over the layer's lines).
  const double extra = detail::reachBeyond(grid.widths, scale, point) * (1.0 + 1e-9) + 1.0;
  return grid.visit(lonDeg, latDeg, extra,
                    [&](std::uint32_t j) { return detail::nearLine(*this, all[j], point, lonDeg, latDeg, scale); });
}

std::uint64_t GlobeLayer::digestForCache() const {
  // The code that builds the pieces (the sources of vector_overlay and the globe's grid, as for a
  // projected layer's tiles: LayerTiling::fingerprint), not a version raised by hand.
  const std::string_view code(STENCIL_GIS_PIECES_FINGERPRINT);
  std::vector<std::uint64_t> parts{geo::io::digest(code.data(), code.size())};
  const auto add = [&parts](const void* data, std::size_t bytes) { parts.push_back(geo::io::digest(data, bytes)); };
  const std::array<double, 3> numbers{chordTolerance_, maxSegment_, widthPixels_};
  add(numbers.data(), sizeof(numbers));
  // The areas as prepared (areasDigest, per feature).
  parts.insert(parts.end(), areaDigests_.begin(), areaDigests_.end());
  // The lines as their features give them (checkLines: points, widths, joins, caps, colour
  // group; the densified points, anchors and buckets follow from these, the options and the anchor
  // ground), so the lines need not be prepared to know it.
  parts.insert(parts.end(), lineDigests_.begin(), lineDigests_.end());
  parts.push_back(anchorDigest_);
  const std::array<double, 2> outlines{options_.outlines ? 1.0 : 0.0, options_.maxSegmentMetres};
  add(outlines.data(), sizeof(outlines));
  return geo::io::digest(parts.data(), parts.size() * sizeof(std::uint64_t));
}

double GlobeLayer::halfWidthAt(const GlobeLine& line, std::size_t k, const overlay::PixelScale& scale) const {
  if (!(line.widthPixels > 0.0) || k >= line.points.size()) return line.halfWidth;
  const double height = k < line.anchors.size() ? static_cast<double>(line.anchors[k]) : 0.0;
  overlay::LineShape shape;
  shape.width = 2.0 * line.maxHalfWidth;
  shape.widthPixels = line.widthPixels;
  shape.minWidth = 2.0 * line.halfWidth;
  return overlay::halfWidthAt(shape, scale, line.surface[k] + surfaceNormalAt(line.surface[k]) * height);
}

}  // namespace gis::globe
