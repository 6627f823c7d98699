#include "vector_overlay/generalise.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>
#include <unordered_set>

#include <glm/geometric.hpp>

namespace gis::overlay {
namespace {

double distanceToSegment(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

/// Marks the points of [first, last] that Douglas–Peucker keeps in the plane (first and last
/// are kept by the caller). A NaN distance keeps the point: the footprint builder reports the
/// feature.
void markKept(std::span<const glm::dvec2> points, std::size_t first, std::size_t last, double epsilon,
              std::vector<char>& keep, const SegmentDistance& distance) {
  if (distance) {
    markDouglasPeucker(first, last, epsilon, keep, [points, &distance](std::size_t k, std::size_t a, std::size_t b) {
      return distance(points[k], points[a], points[b]);
    });
    return;
  }
  markDouglasPeucker(first, last, epsilon, keep, [points](std::size_t k, std::size_t a, std::size_t b) {
    return distanceToSegment(points[k], points[a], points[b]);
  });
}

/// The ring's point farthest from its first (the first of them; 1 for a ring of fewer than 2).
std::size_t farthestFromFirst(const geo::Ring& ring) {
  std::size_t far = 1;
  double farthest = -1.0;
  for (std::size_t k = 1; k < ring.size(); ++k) {
    const double d = glm::length(ring[k] - ring[0]);
    if (d > farthest) {
      farthest = d;
      far = k;
    }
  }
  return far;
}

double twiceArea(const geo::Ring& ring) {
  double a = 0.0;
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const glm::dvec2& p = ring[k];
    const glm::dvec2& q = ring[(k + 1) % ring.size()];
    a += p.x * q.y - q.x * p.y;
  }
  return a;
}

}  // namespace

std::vector<glm::dvec2> simplifyPolyline(std::span<const glm::dvec2> points, double epsilon,
                                         const SegmentDistance& distance) {
  if (points.size() < 3 || !(epsilon > 0.0)) return {points.begin(), points.end()};
  std::vector<char> keep(points.size(), 0);
  keep.front() = keep.back() = 1;
  markKept(points, 0, points.size() - 1, epsilon, keep, distance);
  std::vector<glm::dvec2> out;
  for (std::size_t k = 0; k < points.size(); ++k)
    if (keep[k] != 0) out.push_back(points[k]);
  return out;
}

geo::Ring simplifyRing(const geo::Ring& ring, double epsilon, const SegmentDistance& distance) {
  if (ring.size() <= 3 || !(epsilon > 0.0)) return ring;
  // Cut at point 0 and the point farthest from it; each half is a polyline with fixed ends.
  const std::size_t far = farthestFromFirst(ring);
  std::vector<glm::dvec2> closed(ring.begin(), ring.end());
  closed.push_back(ring.front());
  std::vector<char> keep(closed.size(), 0);
  keep[0] = keep[far] = keep.back() = 1;
  markKept(closed, 0, far, epsilon, keep, distance);
  markKept(closed, far, closed.size() - 1, epsilon, keep, distance);
  if (std::count(keep.begin(), keep.end() - 1, 1) < 3) {
    // A third point: the one farthest from the chord (0, far); then the chains between the
    // three simplified again, so that every point stays within epsilon of the triangle's edges.
    std::size_t best = 0;
    double d = -1.0;
    for (std::size_t k = 1; k < ring.size(); ++k) {
      if (k == far) continue;
      const double e =
          distance ? distance(ring[k], ring[0], ring[far]) : distanceToSegment(ring[k], ring[0], ring[far]);
      if (e > d) {
        d = e;
        best = k;
      }
    }
    if (best != 0) {
      keep[best] = 1;
      std::size_t previous = 0;
      for (std::size_t k = 1; k < closed.size(); ++k) {
        if (keep[k] == 0) continue;
        markKept(closed, previous, k, epsilon, keep, distance);
        previous = k;
      }
    }
  }
  geo::Ring out;
  for (std::size_t k = 0; k + 1 < closed.size(); ++k)
    if (keep[k] != 0) out.push_back(closed[k]);
  // Still a ring with area: use it; otherwise the original (whose problems the builder reports).
  return std::abs(twiceArea(out)) > 0.0 && std::isfinite(twiceArea(out)) ? out : ring;
}

double lineShapeSlack(LineJoin join, LineCap cap, double miterLimit, double width) {
  double reach = 0.0;
  if (join == LineJoin::Miter) reach = std::max(reach, std::max(1.0, miterLimit) * 0.5 * width);
  if (join == LineJoin::Bevel) reach = std::max(reach, 0.5 * width);
  if (cap == LineCap::Square) reach = std::max(reach, std::numbers::sqrt2 * 0.5 * width);
  if (cap == LineCap::Flat) reach = std::max(reach, 0.5 * width);
  return reach;
}

geo::Feature generaliseGeometry(const geo::Feature& feature, double epsilon) {
  geo::Feature out;
  out.fid = feature.fid;
  out.polygons.reserve(feature.polygons.size());
  for (const geo::Polygon& p : feature.polygons) {
    geo::Polygon q;
    q.outer = simplifyRing(p.outer, epsilon);
    q.holes.reserve(p.holes.size());
    for (const geo::Ring& h : p.holes) q.holes.push_back(simplifyRing(h, epsilon));
    out.polygons.push_back(std::move(q));
  }
  out.lines.reserve(feature.lines.size());
  for (const geo::LineString& l : feature.lines) out.lines.push_back(simplifyPolyline(l, epsilon));
  return out;
}

namespace {

/// Points matched exactly (−0 as +0).
struct PointHash {
  std::size_t operator()(const glm::dvec2& p) const noexcept {
    const std::uint64_t x = std::bit_cast<std::uint64_t>(p.x + 0.0), y = std::bit_cast<std::uint64_t>(p.y + 0.0);
    return static_cast<std::size_t>((x * 0x9E3779B97F4A7C15ULL) ^ (y + 0x7F4A7C159E3779B9ULL + (x << 6U) + (x >> 2U)));
  }
};

bool lexLess(const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

/// An undirected edge, its ends in lexicographic order.
struct Edge {
  glm::dvec2 a, b;
  bool operator==(const Edge& o) const { return a == o.a && b == o.b; }
};
struct EdgeHash {
  std::size_t operator()(const Edge& e) const noexcept {
    const PointHash h;
    return h(e.a) * 31U + h(e.b);
  }
};
Edge edgeOf(const glm::dvec2& p, const glm::dvec2& q) { return lexLess(p, q) ? Edge{p, q} : Edge{q, p}; }

bool finiteRing(const geo::Ring& ring) {
  return std::all_of(ring.begin(), ring.end(),
                     [](const glm::dvec2& p) { return std::isfinite(p.x) && std::isfinite(p.y); });
}

/// The ring without repeated consecutive points (nor a last point repeating the first).
geo::Ring withoutRepeats(const geo::Ring& ring) {
  geo::Ring out;
  out.reserve(ring.size());
  for (const glm::dvec2& p : ring)
    if (out.empty() || p != out.back()) out.push_back(p);
  while (out.size() > 1 && out.back() == out.front()) out.pop_back();
  return out;
}

}  // namespace

/// What generaliseCoverage finds once for a set of features: the rings taking part, which rings
/// hold each edge, how many rings each point, and each ring's nodes (before any ring is kept
/// whole).
struct CoverageGeneraliser::Topology {
  std::span<const geo::Feature* const> features;
  SegmentDistance distance;
  struct Place {
    std::uint32_t feature = 0, polygon = 0, ring = 0;  ///< ring 0: the outer one, h + 1: hole h
  };
  std::vector<Place> places;     ///< per ring
  std::vector<geo::Ring> rings;  ///< finite, at least 3 points, no repeated points
  std::unordered_map<Edge, std::vector<std::uint32_t>, EdgeHash> edgeRings;
  struct PointUse {
    std::uint32_t rings = 0, last = 0;
  };
  std::unordered_map<glm::dvec2, PointUse, PointHash> pointRings;
  std::vector<std::vector<std::size_t>> nodes;  ///< per ring
  std::vector<char> shared;                     ///< per ring: some edge held by another ring too

  [[nodiscard]] const std::vector<std::uint32_t>& holdersOf(const geo::Ring& ring, std::size_t k) const {
    return edgeRings.find(edgeOf(ring[k], ring[(k + 1) % ring.size()]))->second;
  }
  /// Ring r's nodes: points where the rings holding its edges change, points of three rings or
  /// more, and points in `kept`.
  void findNodes(std::size_t r, const std::unordered_set<glm::dvec2, PointHash>& kept, std::vector<std::size_t>& out,
                 char& isShared) const {
    const geo::Ring& ring = rings[r];
    const std::size_t n = ring.size();
    out.clear();
    bool any = false;
    for (std::size_t k = 0; k < n; ++k) {
      const std::vector<std::uint32_t>& before = holdersOf(ring, (k + n - 1) % n);
      const std::vector<std::uint32_t>& after = holdersOf(ring, k);
      any = any || after.size() > 1;
      if (pointRings.find(ring[k])->second.rings >= 3 || before != after || kept.count(ring[k]) != 0) out.push_back(k);
    }
    isShared = any ? 1 : 0;
  }
};

CoverageGeneraliser::CoverageGeneraliser(std::span<const geo::Feature* const> features, SegmentDistance distance)
    : t_(std::make_unique<Topology>()) {
  Topology& t = *t_;
  t.features = features;
  t.distance = std::move(distance);
  // The rings taking part (finite, at least 3 distinct points), without repeated points.
  for (std::uint32_t f = 0; f < features.size(); ++f) {
    for (std::uint32_t p = 0; p < features[f]->polygons.size(); ++p) {
      const geo::Polygon& polygon = features[f]->polygons[p];
      for (std::uint32_t r = 0; r <= polygon.holes.size(); ++r) {
        geo::Ring clean = withoutRepeats(r == 0 ? polygon.outer : polygon.holes[r - 1]);
        if (clean.size() >= 3 && finiteRing(clean)) {
          t.places.push_back({f, p, r});
          t.rings.push_back(std::move(clean));
        }
      }
    }
  }
  // Which rings hold each edge, and how many rings each point.
  for (std::uint32_t r = 0; r < t.rings.size(); ++r) {
    const geo::Ring& ring = t.rings[r];
    for (std::size_t k = 0; k < ring.size(); ++k) {
      std::vector<std::uint32_t>& holders = t.edgeRings[edgeOf(ring[k], ring[(k + 1) % ring.size()])];
      if (holders.empty() || holders.back() != r) holders.push_back(r);
      Topology::PointUse& use = t.pointRings[ring[k]];
      if (use.rings == 0 || use.last != r) {
        ++use.rings;
        use.last = r;
      }
    }
  }
  t.nodes.resize(t.rings.size());
  t.shared.assign(t.rings.size(), 0);
  const std::unordered_set<glm::dvec2, PointHash> none;
  for (std::size_t r = 0; r < t.rings.size(); ++r) t.findNodes(r, none, t.nodes[r], t.shared[r]);
}

CoverageGeneraliser::~CoverageGeneraliser() = default;

namespace {

/// Whether every point of the ring lies within epsilon of the chord from its first point to the
/// point farthest from it (simplifyRing's first cut): all that two points would keep of it.
bool withinOneChord(const geo::Ring& ring, double epsilon, const SegmentDistance& distance) {
  const std::size_t far = farthestFromFirst(ring);
  for (std::size_t k = 1; k < ring.size(); ++k) {
    if (k == far) continue;
    const double d = distance ? distance(ring[k], ring[0], ring[far]) : distanceToSegment(ring[k], ring[0], ring[far]);
    if (!(d <= epsilon)) return false;
  }
  return true;
}

}  // namespace

std::vector<geo::Feature> CoverageGeneraliser::at(double epsilon, const std::vector<char>* wanted,
                                                  bool dropWithinEpsilon) const {
  const Topology& t = *t_;
  const auto isWanted = [&](std::size_t f) { return wanted == nullptr || (f < wanted->size() && (*wanted)[f] != 0); };
  std::vector<geo::Feature> out;
  out.reserve(t.features.size());
  for (std::size_t k = 0; k < t.features.size(); ++k) {
    const geo::Feature* f = t.features[k];
    geo::Feature g;
    g.fid = f->fid;
    if (isWanted(k)) {
      g.polygons = f->polygons;
      g.lines.reserve(f->lines.size());
      for (const geo::LineString& l : f->lines) g.lines.push_back(simplifyPolyline(l, epsilon, t.distance));
    }
    out.push_back(std::move(g));
  }
  if (!(epsilon > 0.0)) return out;

  // Each ring from its chains between nodes; rings that would lose their area make all their
  // points nodes (kept, in their neighbours too), and the rings are made again.
  std::unordered_set<glm::dvec2, PointHash> kept;
  std::vector<geo::Ring> result(t.rings.size());
  std::vector<std::size_t> found;
  for (int attempt = 0; attempt < 4; ++attempt) {
    bool again = false;
    for (std::size_t r = 0; r < t.rings.size(); ++r) {
      if (!isWanted(t.places[r].feature)) continue;
      const geo::Ring& ring = t.rings[r];
      const std::size_t n = ring.size();
      char shared = t.shared[r];
      if (!kept.empty()) t.findNodes(r, kept, found, shared);
      // The nodes found without kept points (made once), else those just found (not copied).
      const std::vector<std::size_t>* nodes = kept.empty() ? &t.nodes[r] : &found;
      if (nodes->empty() && shared == 0) {
        // A ring of its own: as generaliseGeometry, or nothing when it all lies within epsilon
        // of one chord and the caller lets such rings go.
        result[r] = dropWithinEpsilon && withinOneChord(ring, epsilon, t.distance)
                        ? geo::Ring{}
                        : simplifyRing(ring, epsilon, t.distance);
        continue;
      }
      if (nodes->empty()) {
        // Shared whole (an island in a hole): cut where its least point is, in both rings.
        std::size_t least = 0;
        for (std::size_t k = 1; k < n; ++k)
          if (lexLess(ring[k], ring[least])) least = k;
        found.clear();
        for (std::size_t k = 0; k < n; ++k)
          if (ring[k] == ring[least]) found.push_back(k);
        nodes = &found;
      }
      geo::Ring made;
      std::vector<glm::dvec2> chain;
      for (std::size_t j = 0; j < nodes->size(); ++j) {
        const std::size_t a = (*nodes)[j];
        const std::size_t b = (*nodes)[(j + 1) % nodes->size()];
        chain.clear();
        for (std::size_t k = a;; k = (k + 1) % n) {
          chain.push_back(ring[k]);
          if (chain.size() > 1 && k == b) break;
        }
        // A canonical direction: the same chain in a neighbour (usually reversed) gives the same
        // points.
        const bool reverse =
            lexLess(chain.back(), chain.front()) ||
            (chain.back() == chain.front() && chain.size() > 2 && lexLess(chain[chain.size() - 2], chain[1]));
        if (reverse) std::reverse(chain.begin(), chain.end());
        std::vector<glm::dvec2> simple = simplifyPolyline(chain, epsilon, t.distance);
        if (reverse) std::reverse(simple.begin(), simple.end());
        made.insert(made.end(), simple.begin(), simple.end() - 1);
      }
      const double area = twiceArea(made);
      if (made.size() >= 3 && area != 0.0 && std::isfinite(area)) {
        result[r] = std::move(made);
      } else if (attempt < 3) {
        for (const glm::dvec2& p : ring) again = kept.insert(p).second || again;
        result[r] = ring;
      } else {
        result[r] = ring;
      }
    }
    if (!again) break;
  }
  for (std::size_t r = 0; r < t.rings.size(); ++r) {
    const Topology::Place& at = t.places[r];
    if (!isWanted(at.feature)) continue;
    geo::Polygon& polygon = out[at.feature].polygons[at.polygon];
    (at.ring == 0 ? polygon.outer : polygon.holes[at.ring - 1]) = std::move(result[r]);
  }
  return out;
}

std::vector<geo::Feature> generaliseCoverage(std::span<const geo::Feature* const> features, double epsilon,
                                             const SegmentDistance& distance) {
  if (!(epsilon > 0.0)) {  // nothing to simplify: no need to find the shared borders
    std::vector<geo::Feature> out;
    out.reserve(features.size());
    for (const geo::Feature* f : features) {
      geo::Feature g;
      g.fid = f->fid;
      g.polygons = f->polygons;
      g.lines = f->lines;
      out.push_back(std::move(g));
    }
    return out;
  }
  return CoverageGeneraliser(features, distance).at(epsilon);
}

void appendRunsNear(std::span<const glm::dvec2> line, const glm::dvec2& lo, const glm::dvec2& hi, double reach,
                    std::vector<geo::LineString>& out) {
  const std::size_t n = line.size();
  if (n < 2) {
    // A single point: its disc or square (within reach) either reaches the box or not.
    if (n == 1 && line[0].x >= lo.x - reach && line[0].x <= hi.x + reach && line[0].y >= lo.y - reach &&
        line[0].y <= hi.y + reach)
      out.emplace_back(line.begin(), line.end());
    return;
  }
  const auto near = [&](std::size_t s) {  // segment s = (s, s + 1)
    const glm::dvec2 a = glm::min(line[s], line[s + 1]), b = glm::max(line[s], line[s + 1]);
    return !(b.x < lo.x - reach || b.y < lo.y - reach || a.x > hi.x + reach || a.y > hi.y + reach);
  };
  // Whole line when every segment is near (the common case for a small tile's features).
  std::size_t s = 0;
  while (s + 1 < n) {
    if (!near(s)) {
      ++s;
      continue;
    }
    std::size_t e = s;
    while (e + 1 < n - 1 && near(e + 1)) ++e;
    // Segments [s, e] are near: points [s, e + 1]. A cut end is also an end of a segment that is
    // not near, so it lies farther than reach from the box, and so does its cap.
    out.emplace_back(line.begin() + static_cast<std::ptrdiff_t>(s), line.begin() + static_cast<std::ptrdiff_t>(e) + 2);
    s = e + 1;
  }
}

}  // namespace gis::overlay

namespace gis::overlay {

void appendClipped(std::span<const glm::dvec2> line, const glm::dvec2& lo, const glm::dvec2& hi,
                   std::vector<geo::LineString>& out) {
  const auto inside = [&](const glm::dvec2& p) { return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y; };
  if (line.size() < 2) {
    if (line.size() == 1 && inside(line[0])) out.emplace_back(line.begin(), line.end());
    return;
  }
  geo::LineString run;
  const auto finish = [&] {
    if (run.size() >= 2) out.push_back(std::move(run));
    run.clear();
  };
  for (std::size_t s = 0; s + 1 < line.size(); ++s) {
    const glm::dvec2 a = line[s], d = line[s + 1] - a;
    // Liang–Barsky: the parameters [t0, t1] of the segment inside the box.
    double t0 = 0.0, t1 = 1.0;
    bool misses = false;
    const auto edge = [&](double p, double q) {  // p t <= q
      if (p == 0.0) {
        misses = misses || q < 0.0;
        return;
      }
      const double t = q / p;
      if (p < 0.0) {
        t0 = std::max(t0, t);
      } else {
        t1 = std::min(t1, t);
      }
    };
    edge(-d.x, a.x - lo.x);
    edge(d.x, hi.x - a.x);
    edge(-d.y, a.y - lo.y);
    edge(d.y, hi.y - a.y);
    if (misses || t0 > t1) {
      finish();
      continue;
    }
    const glm::dvec2 p0 = t0 > 0.0 ? a + t0 * d : a;
    const glm::dvec2 p1 = t1 < 1.0 ? a + t1 * d : line[s + 1];
    if (t0 > 0.0) finish();  // the segment enters the box: a new run
    if (run.empty() || run.back() != p0) run.push_back(p0);
    if (run.back() != p1) run.push_back(p1);
    if (t1 < 1.0) finish();  // it leaves the box
  }
  finish();
}

}  // namespace gis::overlay
