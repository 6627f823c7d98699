#pragma once
// Private to the CPU reference (cpu_reference.cpp): the coverage rules of footprints.hpp as
// point predicates, written independently of the footprint construction.
// - Polygons: the even-odd rule over the raw rings of one polygon (crossings of the ray from the
//   point towards +x), union over the feature's polygons.
// - Lines: a line of a given shape is the union of primitives, each a closed point set:
//   bands (a segment's rectangle, a square cap, the square of a one-point line), discs (round
//   joins and caps, exact circles) and convex polygons (bevel triangles, miter quadrilaterals).
// The grid index in cpu_reference.cpp only selects candidates; both it and the unindexed path
// call exactly these predicates, so they agree bit for bit.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "cgal.hpp"

#include "geo/feature.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/style.hpp"

namespace gis::overlay::reference {

inline double cross(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }
inline double dot(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.x + a.y * b.y; }
inline bool finite(const glm::dvec2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }
/// Coordinates and widths beyond this (metres) cannot be used, as in footprints.hpp.
constexpr double kMaxCoordinate = 1e15;
inline bool usable(const glm::dvec2& p) {
  return finite(p) && std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate;
}

/// Exact sign of the turn a → b → c on the double coordinates (CGAL's filtered predicate):
/// +1 left (counter-clockwise), −1 right, 0 exactly collinear.
inline int orientation(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;
  const CGAL::Orientation o = CGAL::orientation(Point(a.x, a.y), Point(b.x, b.y), Point(c.x, c.y));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

/// An axis-aligned box; empty when lo > hi.
struct Box {
  glm::dvec2 lo{std::numeric_limits<double>::infinity()};
  glm::dvec2 hi{-std::numeric_limits<double>::infinity()};

  void add(const glm::dvec2& p) {
    lo = glm::dvec2(std::min(lo.x, p.x), std::min(lo.y, p.y));
    hi = glm::dvec2(std::max(hi.x, p.x), std::max(hi.y, p.y));
  }
  void add(const Box& b) {
    if (b.empty()) return;
    add(b.lo);
    add(b.hi);
  }
  [[nodiscard]] bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y); }
  [[nodiscard]] bool contains(const glm::dvec2& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y;
  }
  [[nodiscard]] bool intersects(const Box& b) const {
    return !empty() && !b.empty() && lo.x <= b.hi.x && b.lo.x <= hi.x && lo.y <= b.hi.y && b.lo.y <= hi.y;
  }
  [[nodiscard]] Box intersection(const Box& b) const {
    Box r;
    r.lo = glm::dvec2(std::max(lo.x, b.lo.x), std::max(lo.y, b.lo.y));
    r.hi = glm::dvec2(std::min(hi.x, b.hi.x), std::min(hi.y, b.hi.y));
    return r;
  }
  /// Grown by a margin that absorbs the rounding of the predicates (the box is only a filter:
  /// it must contain every point a predicate accepts).
  void padForRounding() {
    if (empty()) return;
    const double scale =
        std::max({std::abs(lo.x), std::abs(lo.y), std::abs(hi.x), std::abs(hi.y), hi.x - lo.x, hi.y - lo.y, 1.0});
    const double pad = 1e-9 * scale;
    lo -= glm::dvec2(pad);
    hi += glm::dvec2(pad);
  }
};

/// A convex quadrilateral (a pixel's footprint on the ground), vertices in order, either
/// orientation, possibly degenerate.
using Quad = std::array<glm::dvec2, 4>;

inline Box boundsOf(const Quad& q) {
  Box b;
  for (const glm::dvec2& p : q) b.add(p);
  return b;
}

/// Whether two convex polygons (vertices in order, either orientation) share a point, by the
/// separating axis theorem. Degenerate polygons (segments, points) are handled conservatively:
/// they may be reported as meeting when they only lie on one line.
inline bool convexMeet(const glm::dvec2* a, std::size_t na, const glm::dvec2* b, std::size_t nb) {
  auto separatedByEdgeOf = [&](const glm::dvec2* p, std::size_t np) {
    for (std::size_t i = 0; i < np; ++i) {
      const glm::dvec2 e = p[i + 1 == np ? 0 : i + 1] - p[i];
      const glm::dvec2 axis(-e.y, e.x);
      if (axis.x == 0.0 && axis.y == 0.0) continue;
      double aMin = std::numeric_limits<double>::infinity();
      double aMax = -aMin;
      double bMin = aMin;
      double bMax = -aMin;
      for (std::size_t k = 0; k < na; ++k) {
        const double t = dot(a[k], axis);
        aMin = std::min(aMin, t);
        aMax = std::max(aMax, t);
      }
      for (std::size_t k = 0; k < nb; ++k) {
        const double t = dot(b[k], axis);
        bMin = std::min(bMin, t);
        bMax = std::max(bMax, t);
      }
      if (aMax < bMin || bMax < aMin) return true;
    }
    return false;
  };
  return !separatedByEdgeOf(a, na) && !separatedByEdgeOf(b, nb);
}

inline double segmentDistance(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 ab = b - a;
  const double l2 = dot(ab, ab);
  const double t = l2 > 0.0 ? std::clamp(dot(p - a, ab) / l2, 0.0, 1.0) : 0.0;
  const glm::dvec2 d = p - (a + ab * t);
  return std::sqrt(dot(d, d));
}

/// Whether the closed disc meets the convex quadrilateral.
inline bool discMeetsQuad(const glm::dvec2& centre, double radius, const Quad& q) {
  const glm::dvec2 box[4] = {centre - glm::dvec2(radius), glm::dvec2(centre.x + radius, centre.y - radius),
                             centre + glm::dvec2(radius), glm::dvec2(centre.x - radius, centre.y + radius)};
  if (!convexMeet(box, 4, q.data(), 4)) return false;    // quick rejection by the disc's square
  if (convexMeet(&centre, 1, q.data(), 4)) return true;  // the centre inside the quad
  for (std::size_t i = 0; i < 4; ++i)
    if (segmentDistance(centre, q[i], q[(i + 1) % 4]) <= radius) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// Polygons

/// Whether the edge a→b toggles the parity of p (the ray from p towards +x crosses it; half-open
/// in y so a vertex on the ray counts once).
inline bool crossesRay(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p) {
  if ((a.y > p.y) == (b.y > p.y)) return false;
  const double xi = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
  return p.x < xi;
}

/// Calls fn(a, b) for every edge of every ring (the closing edge included).
template <typename Fn>
void forEachRingEdge(const geo::Polygon& polygon, Fn&& fn) {
  auto ring = [&fn](const geo::Ring& r) {
    for (std::size_t i = 0; i < r.size(); ++i) fn(r[i], r[i + 1 == r.size() ? 0 : i + 1]);
  };
  ring(polygon.outer);
  for (const geo::Ring& h : polygon.holes) ring(h);
}

/// A polygon the footprints skip ("cannot be used"): a non-finite coordinate or one beyond
/// 1e15 m in any ring, or an outer ring of zero area (fewer than 3 distinct points, or all
/// points exactly on one line).
inline bool polygonUsable(const geo::Polygon& polygon) {
  bool allFinite = true;
  forEachRingEdge(polygon,
                  [&allFinite](const glm::dvec2& a, const glm::dvec2&) { allFinite = allFinite && usable(a); });
  if (!allFinite || polygon.outer.empty()) return false;
  const glm::dvec2 p0 = polygon.outer.front();
  const auto other =
      std::find_if(polygon.outer.begin(), polygon.outer.end(), [&p0](const glm::dvec2& p) { return p != p0; });
  if (other == polygon.outer.end()) return false;
  const glm::dvec2 p1 = *other;
  return std::any_of(polygon.outer.begin(), polygon.outer.end(),
                     [&](const glm::dvec2& p) { return orientation(p0, p1, p) != 0; });
}

inline Box polygonBounds(const geo::Polygon& polygon) {
  Box box;
  forEachRingEdge(polygon, [&box](const glm::dvec2& a, const glm::dvec2&) { box.add(a); });
  box.padForRounding();
  return box;
}

/// Even-odd rule over all rings of the polygon, by brute force.
inline bool insideEvenOdd(const geo::Polygon& polygon, const glm::dvec2& p) {
  bool inside = false;
  forEachRingEdge(polygon, [&inside, &p](const glm::dvec2& a, const glm::dvec2& b) {
    if (crossesRay(a, b, p)) inside = !inside;
  });
  return inside;
}

/// The same test with the edges bucketed into horizontal bands: only the edges whose y range
/// meets the point's band are tried, which always includes every edge that can cross the ray.
class BandedPolygon {
 public:
  BandedPolygon(const geo::Polygon& polygon, std::uint32_t feature) : feature_(feature), box_(polygonBounds(polygon)) {
    double sumDy = 0.0;
    forEachRingEdge(polygon, [this, &sumDy](const glm::dvec2& a, const glm::dvec2& b) {
      edges_.push_back({a, b});
      sumDy += std::abs(b.y - a.y);
    });
    y0_ = box_.lo.y;
    const double height = box_.hi.y - box_.lo.y;
    const double edgeCount = static_cast<double>(edges_.size());
    // About two edges per band, but at most ~8 entries per edge in total (long edges span bands).
    double bands = std::min(edgeCount / 2.0, sumDy > 0.0 ? 7.0 * edgeCount * height / sumDy : 1.0);
    bands = std::clamp(bands, 1.0, 65536.0);
    bandCount_ = static_cast<std::uint32_t>(bands);
    bandScale_ = height > 0.0 ? static_cast<double>(bandCount_) / height : 0.0;
    std::vector<std::uint32_t> counts(bandCount_ + 1, 0);
    for (const auto& e : edges_) {
      const auto [b0, b1] = bandRange(e[0].y, e[1].y);
      for (std::uint32_t b = b0; b <= b1; ++b) ++counts[b + 1];
    }
    for (std::uint32_t b = 0; b < bandCount_; ++b) counts[b + 1] += counts[b];
    bandStart_ = counts;
    bandEdges_.resize(counts[bandCount_]);
    for (std::uint32_t i = 0; i < edges_.size(); ++i) {
      const auto [b0, b1] = bandRange(edges_[i][0].y, edges_[i][1].y);
      for (std::uint32_t b = b0; b <= b1; ++b) bandEdges_[counts[b]++] = i;
    }
  }

  [[nodiscard]] std::uint32_t feature() const { return feature_; }
  [[nodiscard]] const Box& bounds() const { return box_; }

  [[nodiscard]] bool contains(const glm::dvec2& p) const {
    if (!box_.contains(p)) return false;
    const std::uint32_t band = bandOf(p.y);
    bool inside = false;
    for (std::uint32_t k = bandStart_[band]; k < bandStart_[band + 1]; ++k) {
      const auto& e = edges_[bandEdges_[k]];
      if (crossesRay(e[0], e[1], p)) inside = !inside;
    }
    return inside;
  }

  /// Whether some ring edge meets the quadrilateral.
  [[nodiscard]] bool edgeMeets(const Quad& q) const {
    const Box qb = boundsOf(q);
    if (!box_.intersects(qb)) return false;
    for (std::uint32_t band = bandOf(qb.lo.y), last = bandOf(qb.hi.y); band <= last; ++band) {
      for (std::uint32_t k = bandStart_[band]; k < bandStart_[band + 1]; ++k) {
        const auto& e = edges_[bandEdges_[k]];
        if (convexMeet(e.data(), 2, q.data(), 4)) return true;
      }
    }
    return false;
  }

 private:
  [[nodiscard]] std::uint32_t bandOf(double y) const {
    const double b = std::floor((y - y0_) * bandScale_);
    if (!(b > 0.0)) return 0;
    if (b >= static_cast<double>(bandCount_ - 1)) return bandCount_ - 1;
    return static_cast<std::uint32_t>(b);
  }
  [[nodiscard]] std::pair<std::uint32_t, std::uint32_t> bandRange(double ya, double yb) const {
    return {bandOf(std::min(ya, yb)), bandOf(std::max(ya, yb))};
  }

  std::uint32_t feature_;
  Box box_;
  std::vector<std::array<glm::dvec2, 2>> edges_;
  double y0_ = 0.0;
  double bandScale_ = 0.0;
  std::uint32_t bandCount_ = 1;
  std::vector<std::uint32_t> bandStart_;
  std::vector<std::uint32_t> bandEdges_;
};

// ---------------------------------------------------------------------------------------------
// Lines

/// One closed piece of a line's coverage.
struct LinePrimitive {
  enum class Kind : std::uint8_t { Band, Disc, Convex };
  Kind kind = Kind::Disc;
  std::uint8_t count = 0;  ///< Convex: number of vertices (3 or 4), counter-clockwise
  /// Band: v[0] origin, v[1] unit direction; Disc: v[0] centre; Convex: the vertices.
  std::array<glm::dvec2, 4> v{};
  double t0 = 0.0;  ///< Band: along-direction range [t0, t1] from the origin
  double t1 = 0.0;
  double half = 0.0;  ///< Band: half width; Disc: radius
  /// The line's vertices (indices as given, repeated points included) whose half width the
  /// primitive takes: a segment's two ends; a join's or cap's vertex twice. The deferred
  /// technique scales primitives built at unit half width by these vertices' widths.
  std::uint32_t anchor0 = 0;
  std::uint32_t anchor1 = 0;

  /// Band: points whose coordinate along the direction is in [t0, t1] and whose distance to the
  /// axis is at most `half`.
  static LinePrimitive band(const glm::dvec2& origin, const glm::dvec2& unit, double t0, double t1, double half) {
    LinePrimitive p;
    p.kind = Kind::Band;
    p.v[0] = origin;
    p.v[1] = unit;
    p.t0 = t0;
    p.t1 = t1;
    p.half = half;
    return p;
  }
  static LinePrimitive disc(const glm::dvec2& centre, double radius) {
    LinePrimitive p;
    p.kind = Kind::Disc;
    p.v[0] = centre;
    p.half = radius;
    return p;
  }
  /// A convex polygon given in either orientation; `count` = 0 (covers nothing) when it has no area.
  static LinePrimitive convex(std::initializer_list<glm::dvec2> vertices) {
    LinePrimitive p;
    p.kind = Kind::Convex;
    std::size_t count = 0;
    for (const glm::dvec2& q : vertices) p.v[count++] = q;
    double area2 = 0.0;
    for (std::size_t i = 0; i < count; ++i) area2 += cross(p.v[i], p.v[(i + 1) % count]);
    if (area2 < 0.0) std::reverse(p.v.begin(), p.v.begin() + static_cast<std::ptrdiff_t>(count));
    p.count = area2 == 0.0 ? 0 : static_cast<std::uint8_t>(count);
    return p;
  }

  [[nodiscard]] bool contains(const glm::dvec2& p) const {
    switch (kind) {
      case Kind::Band: {
        const glm::dvec2 d = p - v[0];
        const double t = dot(d, v[1]);
        return t >= t0 && t <= t1 && std::abs(cross(v[1], d)) <= half;
      }
      case Kind::Disc: {
        const glm::dvec2 d = p - v[0];
        return dot(d, d) <= half * half;
      }
      case Kind::Convex: {
        if (count < 3) return false;
        const std::size_t n = count;
        for (std::size_t i = 0; i < n; ++i) {
          const glm::dvec2& a = v[i];
          const glm::dvec2& b = v[(i + 1) % n];
          if (cross(b - a, p - a) < 0.0) return false;
        }
        return true;
      }
    }
    return false;
  }

  /// Whether the primitive meets the quadrilateral (a point in common).
  [[nodiscard]] bool meets(const Quad& q) const {
    switch (kind) {
      case Kind::Band: {
        const std::array<glm::dvec2, 4> c = bandCorners();
        return convexMeet(c.data(), 4, q.data(), 4);
      }
      case Kind::Disc:
        return discMeetsQuad(v[0], half, q);
      case Kind::Convex:
        return count >= 3 && convexMeet(v.data(), count, q.data(), 4);
    }
    return false;
  }

  /// Whether the primitive contains the whole quadrilateral (all primitives are convex).
  [[nodiscard]] bool containsAll(const Quad& q) const {
    return std::all_of(q.begin(), q.end(), [this](const glm::dvec2& p) { return contains(p); });
  }

  [[nodiscard]] std::array<glm::dvec2, 4> bandCorners() const {
    const glm::dvec2 n(-v[1].y, v[1].x);
    return {v[0] + v[1] * t0 - n * half, v[0] + v[1] * t1 - n * half, v[0] + v[1] * t1 + n * half,
            v[0] + v[1] * t0 + n * half};
  }

  [[nodiscard]] Box bounds() const {
    Box box;
    switch (kind) {
      case Kind::Band:
        for (const glm::dvec2& c : bandCorners()) box.add(c);
        break;
      case Kind::Disc:
        box.add(v[0] - glm::dvec2(half));
        box.add(v[0] + glm::dvec2(half));
        break;
      case Kind::Convex:
        for (std::size_t i = 0; i < count; ++i) box.add(v[i]);
        break;
    }
    box.padForRounding();
    return box;
  }
};

/// Whether a line shape draws anything at all (a positive, finite width of at most 1e15 m).
inline bool shapeUsable(const LineShape& shape) {
  return std::isfinite(shape.width) && shape.width > 0.0 && shape.width <= kMaxCoordinate;
}

/// The pieces of one line, without the range test of forEachLinePrimitive.
template <typename Emit>
bool emitLinePrimitives(const geo::LineString& line, std::size_t lineIndex, const LineShape& shape,
                        const PixelScale& scale, Emit&& emit);

/// Whether line `lineIndex`, widened at its largest width, stays within ±1e15 m (the builder
/// skips one that does not: footprints.hpp). Cheap unless the line comes within a few widths of
/// the limit.
inline bool lineWithinRange(const geo::LineString& line, std::size_t lineIndex, const LineShape& shape) {
  double far = 0.0;
  for (const glm::dvec2& p : line) far = std::max({far, std::abs(p.x), std::abs(p.y)});
  // Caps and round joins reach √2 half widths from a point, miters miterLimit half widths.
  const double miter = shape.join == LineJoin::Miter ? shape.miterLimit : 0.0;
  const double reach = 0.5 * shape.width * std::max(2.0, miter);
  if (far + reach <= kMaxCoordinate) return true;  // false for a NaN or infinite miter limit
  LineShape metres = shape;
  metres.widthPixels = 0.0;
  return !emitLinePrimitives(line, lineIndex, metres, PixelScale{}, [](const LinePrimitive& prim) {
    const Box box = prim.bounds();
    return !box.empty() && (std::max(std::abs(box.lo.x), std::abs(box.hi.x)) > kMaxCoordinate ||
                            std::max(std::abs(box.lo.y), std::abs(box.hi.y)) > kMaxCoordinate);
  });
}

/// Whether line `line` drawn with `shape` may reach `p`: false when `p` lies beyond the line's
/// bounding box widened by the farthest any piece reaches (a miter's tip, a square cap's corner),
/// so a test of a point against many lines need not make their pieces.
inline bool lineMayReach(const geo::LineString& line, const LineShape& shape, const glm::dvec2& p) {
  if (line.empty()) return false;
  glm::dvec2 lo = line.front(), hi = line.front();
  for (const glm::dvec2& q : line) {
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  const double miter = shape.join == LineJoin::Miter ? shape.miterLimit : 0.0;
  const double reach = 0.5 * std::max(shape.width, shape.minWidth) * std::max(2.0, miter) * (1.0 + 1e-9) + 1e-9;
  return !(p.x < lo.x - reach || p.x > hi.x + reach || p.y < lo.y - reach || p.y > hi.y + reach);
}

/// Calls emit(LinePrimitive) for every piece of line `lineIndex` of a feature drawn with
/// `shape` (whose width must be usable): after dropping consecutive repeated points, the
/// segments' rectangles, the joins at interior vertices and the caps at both ends
/// (footprints.hpp). Lines in pixels get each vertex's half width from `scale`, and trapezoids
/// for segments whose ends differ. A line with a non-finite point (or one beyond 1e15 m, or
/// one that reaches beyond once widened) draws nothing. emit returns true to stop early; the
/// function returns whether it was stopped.
template <typename Emit>
bool forEachLinePrimitive(const geo::LineString& line, std::size_t lineIndex, const LineShape& shape,
                          const PixelScale& scale, Emit&& emit) {
  if (!lineWithinRange(line, lineIndex, shape)) return false;
  return emitLinePrimitives(line, lineIndex, shape, scale, std::forward<Emit>(emit));
}

template <typename Emit>
bool emitLinePrimitives(const geo::LineString& line, std::size_t lineIndex, const LineShape& shape,
                        const PixelScale& scale, Emit&& emit) {
  std::vector<glm::dvec2> pts;
  std::vector<double> halves;
  std::vector<std::uint32_t> given;  // index of each kept point in `line`
  pts.reserve(line.size());
  for (std::size_t i = 0; i < line.size(); ++i) {
    const glm::dvec2& p = line[i];
    if (!usable(p)) return false;
    if (!pts.empty() && p == pts.back()) continue;
    pts.push_back(p);
    given.push_back(static_cast<std::uint32_t>(i));
    halves.push_back(halfWidthAt(shape, scale, glm::dvec3(p, shape.anchorHeight(lineIndex, i))));
  }
  if (pts.empty()) return false;
  auto anchored = [&given](LinePrimitive prim, std::size_t a, std::size_t b) {
    prim.anchor0 = given[a];
    prim.anchor1 = given[b];
    return prim;
  };
  if (pts.size() == 1) {
    const double h = halves[0];
    switch (shape.cap) {
      case LineCap::Round:
        return emit(anchored(LinePrimitive::disc(pts[0], h), 0, 0));
      case LineCap::Square:
        return emit(anchored(LinePrimitive::band(pts[0], glm::dvec2(1.0, 0.0), -h, h, h), 0, 0));
      case LineCap::Flat:
        return false;
    }
    return false;
  }
  const std::size_t n = pts.size();
  auto unit = [&pts](std::size_t i) {  // direction of segment i → i+1
    const glm::dvec2 d = pts[i + 1] - pts[i];
    return d / std::sqrt(dot(d, d));
  };
  // Segments: rectangles, or trapezoids between different half widths.
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const glm::dvec2 d = pts[i + 1] - pts[i];
    const double h0 = halves[i], h1 = halves[i + 1];
    if (h0 == h1) {
      if (emit(anchored(LinePrimitive::band(pts[i], unit(i), 0.0, std::sqrt(dot(d, d)), h0), i, i + 1))) return true;
    } else {
      const glm::dvec2 u = unit(i);
      const glm::dvec2 normal(-u.y, u.x);
      const glm::dvec2 a = pts[i], b = pts[i + 1];
      if (emit(anchored(LinePrimitive::convex({a - normal * h0, b - normal * h1, b + normal * h1, a + normal * h0}), i,
                        i + 1))) {
        return true;
      }
    }
  }
  // Joins.
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const glm::dvec2 u1 = unit(i - 1);
    const glm::dvec2 u2 = unit(i);
    const int turn = orientation(pts[i - 1], pts[i], pts[i + 1]);
    const double along = dot(u1, u2);
    if (turn == 0 && along > 0.0) continue;  // straight continuation (exactly collinear): no join
    const glm::dvec2& v = pts[i];
    const double h = halves[i];
    if (shape.join == LineJoin::Round) {
      if (emit(anchored(LinePrimitive::disc(v, h), i, i))) return true;
      continue;
    }
    if (turn == 0) continue;  // a full reversal: bevel and (infinite) miter have no area
    // Outer side: right of the path for a left turn, left of it for a right turn.
    auto outer = [turn](const glm::dvec2& u) { return turn > 0 ? glm::dvec2(u.y, -u.x) : glm::dvec2(-u.y, u.x); };
    const glm::dvec2 n1 = outer(u1);
    const glm::dvec2 n2 = outer(u2);
    const glm::dvec2 cornerIn = v + n1 * h;
    const glm::dvec2 cornerOut = v + n2 * h;
    // θ = π − turn angle; sin(θ/2) = cos(turn/2) = sqrt((1 + cos turn) / 2).
    const double sinHalfTheta = std::sqrt(std::max(0.0, (1.0 + along) / 2.0));
    const bool miter = shape.join == LineJoin::Miter && sinHalfTheta > 0.0 && h / sinHalfTheta <= shape.miterLimit * h;
    if (miter) {
      // The miter point lies on the bisector of the outer normals at distance h / sin(θ/2).
      const glm::dvec2 tip = v + (n1 + n2) * (h / (1.0 + along));
      if (emit(anchored(LinePrimitive::convex({v, cornerIn, tip, cornerOut}), i, i))) return true;
    } else {
      if (emit(anchored(LinePrimitive::convex({v, cornerIn, cornerOut}), i, i))) return true;
    }
  }
  // Caps.
  const double hFirst = halves[0], hLast = halves[n - 1];
  switch (shape.cap) {
    case LineCap::Round:
      return emit(anchored(LinePrimitive::disc(pts[0], hFirst), 0, 0)) ||
             emit(anchored(LinePrimitive::disc(pts[n - 1], hLast), n - 1, n - 1));
    case LineCap::Square:
      return emit(anchored(LinePrimitive::band(pts[0], unit(0), -hFirst, 0.0, hFirst), 0, 0)) ||
             emit(anchored(LinePrimitive::band(pts[n - 1], unit(n - 2), 0.0, hLast, hLast), n - 1, n - 1));
    case LineCap::Flat:
      return false;
  }
  return false;
}

}  // namespace gis::overlay::reference
