#pragma once
// Private helpers shared by polygon_footprints.cpp and line_footprints.cpp: exact orientation,
// convex polygons clipped to grid cells with bit-reproducible intersection points, convex
// triangulation without zero-area triangles, and the builder that welds vertices and derives the
// boundary of a footprint.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "cgal.hpp"

#include "core/diagnostics.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay::detail {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

/// Exact sign of the orientation of (a, b, c) on the double coordinates: +1 counter-clockwise,
/// −1 clockwise, 0 collinear.
inline int orientation(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
  const auto o = CGAL::orientation(Kernel::Point_2(a.x, a.y), Kernel::Point_2(b.x, b.y), Kernel::Point_2(c.x, c.y));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

/// Twice the signed area of (a, b, c) in plain double arithmetic (the formula the tests use).
inline double doubleArea(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// A triangle is kept only when it is counter-clockwise both exactly and in double arithmetic.
inline bool usableTriangle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
  return doubleArea(a, b, c) > 0.0 && orientation(a, b, c) > 0;
}

inline bool finite(const glm::dvec2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }

inline Diagnostic featureError(Severity severity, const std::string& layer, std::int64_t fid, std::string message) {
  return Diagnostic{severity, "", layer, std::to_string(fid), std::move(message)};
}

// ---------------------------------------------------------------------------------------------
// Footprint builder

/// Collects triangles, merges vertices with exactly equal coordinates into one index and derives
/// the boundary (directed triangle edges without an opposite partner) when finished.
class FootprintBuilder {
 public:
  /// Adds triangle (a, b, c) if it is counter-clockwise with positive area (else drops it).
  void addTriangle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    if (!usableTriangle(a, b, c)) return;
    triangles_.push_back({vertex(a), vertex(b), vertex(c)});
  }

  [[nodiscard]] bool empty() const { return triangles_.empty(); }

  /// The footprint; the builder is left empty.
  Footprint finish(std::uint32_t feature, std::int32_t cell, PieceKind kind) {
    Footprint fp;
    fp.feature = feature;
    fp.cell = cell;
    fp.kind = kind;
    // Directed edges as sorted keys with their multiplicities (faster than a hash map).
    const auto key = [](std::uint32_t a, std::uint32_t b) { return (std::uint64_t{a} << 32U) | b; };
    std::vector<std::uint64_t> keys;
    keys.reserve(3 * triangles_.size());
    for (const auto& t : triangles_) {
      for (std::size_t i = 0; i < 3; ++i) keys.push_back(key(t[i], t[(i + 1) % 3]));
    }
    std::sort(keys.begin(), keys.end());
    std::vector<int> count;
    std::size_t unique = 0;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      if (i > 0 && keys[i] == keys[unique - 1]) {
        ++count.back();
      } else {
        keys[unique++] = keys[i];
        count.push_back(1);
      }
    }
    keys.resize(unique);
    const auto find = [&](std::uint64_t k) -> int* {
      const auto it = std::lower_bound(keys.begin(), keys.end(), k);
      return it != keys.end() && *it == k ? &count[static_cast<std::size_t>(it - keys.begin())] : nullptr;
    };
    for (const auto& t : triangles_) {
      for (std::size_t i = 0; i < 3; ++i) {
        const std::uint32_t a = t[i];
        const std::uint32_t b = t[(i + 1) % 3];
        int& forward = *find(key(a, b));
        const int* reverse = find(key(b, a));
        const int backward = reverse == nullptr ? 0 : *reverse;
        // Emits max(0, forward − backward) copies in total: an edge shared by two triangles in
        // opposite directions is interior, any other edge is boundary.
        if (forward > backward) {
          fp.boundary.push_back({a, b});
          --forward;
        }
      }
    }
    fp.vertices = std::move(vertices_);
    fp.triangles = std::move(triangles_);
    // Grown by doubling, the arrays hold up to twice what they need, and a layer keeps its
    // footprints (10^6–10^7 of them at scale): only what is used stays.
    fp.vertices.shrink_to_fit();
    fp.triangles.shrink_to_fit();
    fp.boundary.shrink_to_fit();
    vertices_.clear();
    triangles_.clear();
    index_.clear();
    return fp;
  }

 private:
  struct Key {
    std::uint64_t x;
    std::uint64_t y;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const noexcept {
      return static_cast<std::size_t>(k.x * 0x9E3779B97F4A7C15ULL ^ (k.y + 0x632BE59BD9B4E019ULL + (k.x << 6U)));
    }
  };

  std::uint32_t vertex(const glm::dvec2& p) {
    // + 0.0 turns −0.0 into +0.0 so that equal coordinates have equal bits.
    const Key k{std::bit_cast<std::uint64_t>(p.x + 0.0), std::bit_cast<std::uint64_t>(p.y + 0.0)};
    const auto [it, inserted] = index_.try_emplace(k, static_cast<std::uint32_t>(vertices_.size()));
    if (inserted) vertices_.push_back(p);
    return it->second;
  }

  std::vector<glm::dvec2> vertices_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::unordered_map<Key, std::uint32_t, KeyHash> index_;
};

// ---------------------------------------------------------------------------------------------
// Regions as triangles

using Triangle = std::array<glm::dvec2, 3>;

/// The triangles inside an odd number of the rings (closed implicitly), vertices in double,
/// when CGAL's fast triangulation keeps every constraint exactly on its ring edge (always so
/// without crossings); nothing otherwise (polygon_footprints.cpp). Throws what CGAL throws.
std::optional<std::vector<Triangle>> evenOddTrianglesIfExact(const std::vector<std::vector<glm::dvec2>>& rings,
                                                             const std::vector<glm::dvec2>& points = {});

/// The union of convex counter-clockwise polygons as triangles (line_union.cpp): its boundary's
/// vertices are the polygons' vertices and their edges' crossings, rounded to double, and those
/// of `points` that fall inside it (when the union's boundary triangulates cleanly).
std::vector<Triangle> unionTriangles(const std::vector<std::vector<glm::dvec2>>& parts,
                                     const std::vector<glm::dvec2>& points = {});

// ---------------------------------------------------------------------------------------------
// Convex triangulation

/// Removes consecutive (and first/last) points with exactly equal coordinates.
inline void dropRepeatedPoints(std::vector<glm::dvec2>& pts) {
  const auto last = std::unique(pts.begin(), pts.end());
  pts.erase(last, pts.end());
  while (pts.size() > 1 && pts.front() == pts.back()) pts.pop_back();
}

/// Triangulates a convex polygon (counter-clockwise, no repeated points; collinear runs allowed)
/// into `out`. The apex of the fan is a vertex that shares no supporting line with an edge not
/// incident to it, so no triangle is flat; when there is none (collinear points on every side)
/// the fan is made around the vertex average, which lies strictly inside. Any triangle that
/// still comes out flat or clockwise through rounding is dropped by the builder.
inline void triangulateConvex(const std::vector<glm::dvec2>& pts, FootprintBuilder& out) {
  const std::size_t n = pts.size();
  if (n < 3) return;
  if (n == 3) {
    out.addTriangle(pts[0], pts[1], pts[2]);
    return;
  }
  const auto at = [&](std::size_t i) -> const glm::dvec2& { return pts[i % n]; };
  for (std::size_t k = 0; k < n; ++k) {
    if (orientation(at(k), at(k + 1), at(k + 2)) == 0) continue;
    if (orientation(at(k + n - 2), at(k + n - 1), at(k)) == 0) continue;
    for (std::size_t j = 1; j + 1 < n; ++j) out.addTriangle(at(k), at(k + j), at(k + j + 1));
    return;
  }
  glm::dvec2 centre(0.0);
  for (const auto& p : pts) centre += p;
  centre /= static_cast<double>(n);
  for (std::size_t j = 0; j < n; ++j) out.addTriangle(centre, at(j), at(j + 1));
}

// ---------------------------------------------------------------------------------------------
// Clipping to grid cells
//
// A convex polygon carries, for every edge, the line it lies on: an input segment (the
// original edge of the triangle or piece, its endpoints in lexicographic order) or a grid line.
// Sutherland–Hodgman computes every intersection from that support, never from an already
// clipped (rounded) edge: the point where an input segment meets a grid line is therefore the
// same bits in every polygon sharing that segment, and where two grid lines meet it is the exact
// grid corner. Grid line coordinates are always origin + i · cellSize, computed the same way.

struct EdgeSupport {
  int axis = -1;  ///< −1: the segment (a, b); 0: the line x = value; 1: the line y = value
  double value = 0.0;
  glm::dvec2 a{0.0};
  glm::dvec2 b{0.0};
};

struct ClipPolygon {
  std::vector<glm::dvec2> points;
  std::vector<EdgeSupport> edges;  ///< edges[i] supports points[i] → points[i + 1]
};

inline EdgeSupport segmentSupport(const glm::dvec2& p, const glm::dvec2& q) {
  EdgeSupport s;
  const bool ordered = p.x < q.x || (p.x == q.x && p.y <= q.y);
  s.a = ordered ? p : q;
  s.b = ordered ? q : p;
  return s;
}

/// A convex polygon whose edges are its own segments.
inline ClipPolygon makeClipPolygon(const std::vector<glm::dvec2>& pts) {
  ClipPolygon poly;
  poly.points = pts;
  poly.edges.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) poly.edges.push_back(segmentSupport(pts[i], pts[(i + 1) % pts.size()]));
  return poly;
}

/// Where the support meets the grid line coordinate[axis] = value.
inline glm::dvec2 intersect(const EdgeSupport& s, int axis, double value) {
  const auto ax = static_cast<glm::dvec2::length_type>(axis);
  const auto other = static_cast<glm::dvec2::length_type>(1 - axis);
  glm::dvec2 r(0.0);
  r[ax] = value;
  if (s.axis >= 0 && s.axis != axis) {
    r[other] = s.value;  // exact grid corner
    return r;
  }
  const double denominator = s.b[ax] - s.a[ax];
  if (s.axis >= 0 || denominator == 0.0) {
    // Parallel to the clip line: cannot straddle it (the caller checks); keep something finite.
    r[other] = s.axis >= 0 ? s.a[other] : 0.5 * (s.a[other] + s.b[other]);
    return r;
  }
  const double lo = std::min(s.a[other], s.b[other]);
  const double hi = std::max(s.a[other], s.b[other]);
  // A support far larger than where it meets the line (a line 1e15 m wide crossing a 10 m cell)
  // loses the crossing to cancellation in double (an error of ulp(1e15) = 0.125 m, outside the
  // cell): such a crossing is computed in quadruple precision (113 bits) and rounded once.
  const double reach = std::max({std::abs(s.a.x), std::abs(s.a.y), std::abs(s.b.x), std::abs(s.b.y)});
  if (reach > 1e6 * (1.0 + std::abs(value))) {
    __extension__ using Quad = __float128;
    const Quad a0 = static_cast<Quad>(s.a[ax]), a1 = static_cast<Quad>(s.a[other]);
    const Quad t = (static_cast<Quad>(value) - a0) / (static_cast<Quad>(s.b[ax]) - a0);
    const Quad clamped = t < 0 ? Quad(0) : (t > 1 ? Quad(1) : t);
    r[other] = std::clamp(static_cast<double>(a1 + clamped * (static_cast<Quad>(s.b[other]) - a1)), lo, hi);
    return r;
  }
  const double t = std::clamp((value - s.a[ax]) / denominator, 0.0, 1.0);
  r[other] = std::clamp(s.a[other] + t * (s.b[other] - s.a[other]), lo, hi);
  return r;
}

/// Keeps the part of `poly` where coordinate[axis] ≥ value (keepAbove) or ≤ value. A vertex
/// exactly on the line is kept and no crossing point is computed next to it (that point would
/// be the same place, rounded differently): crossings are computed only between vertices
/// strictly on opposite sides.
inline ClipPolygon clipHalfPlane(const ClipPolygon& poly, int axis, double value, bool keepAbove) {
  const auto ax = static_cast<glm::dvec2::length_type>(axis);
  // +1 strictly inside, 0 on the line, −1 strictly outside
  const auto side = [&](const glm::dvec2& p) {
    const double d = keepAbove ? p[ax] - value : value - p[ax];
    return d > 0.0 ? 1 : (d < 0.0 ? -1 : 0);
  };
  ClipPolygon out;
  const std::size_t n = poly.points.size();
  out.points.reserve(n + 2);
  out.edges.reserve(n + 2);
  EdgeSupport line;
  line.axis = axis;
  line.value = value;
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2& p = poly.points[i];
    const glm::dvec2& q = poly.points[(i + 1) % n];
    const EdgeSupport& s = poly.edges[i];
    const int sp = side(p);
    const int sq = side(q);
    if (sp >= 0) {
      out.points.push_back(p);
      // leaving the half-plane: from here the boundary runs along the clip line
      out.edges.push_back(sq < 0 && sp == 0 ? line : s);
      if (sp > 0 && sq < 0) {
        out.points.push_back(intersect(s, axis, value));
        out.edges.push_back(line);
      }
    } else if (sq > 0) {
      out.points.push_back(intersect(s, axis, value));
      out.edges.push_back(s);
    }
  }
  return out;
}

/// Whether a grid can be used; fills `message` when not.
inline bool validGrid(const CellGrid& grid, std::string& message) {
  if (!(std::isfinite(grid.cellSize) && grid.cellSize > 0.0) || !finite(grid.origin)) {
    message = "the cell grid has a non-finite origin or a non-positive cell size";
    return false;
  }
  if (grid.columns < 1 || grid.rows < 1) {
    message = "the cell grid has no cells";
    return false;
  }
  return true;
}

inline double gridLine(const CellGrid& grid, int axis, int i) {
  return (axis == 0 ? grid.origin.x : grid.origin.y) + static_cast<double>(i) * grid.cellSize;
}

/// Range of cell indices along an axis that [lo, hi] may meet; false when it misses the grid.
inline bool cellRange(const CellGrid& grid, int axis, double lo, double hi, int& first, int& last) {
  const int count = axis == 0 ? grid.columns : grid.rows;
  const double origin = axis == 0 ? grid.origin.x : grid.origin.y;
  if (hi < origin || lo > gridLine(grid, axis, count)) return false;
  const double maxIndex = static_cast<double>(count - 1);
  first = static_cast<int>(std::clamp(std::floor((lo - origin) / grid.cellSize), 0.0, maxIndex));
  last = static_cast<int>(std::clamp(std::floor((hi - origin) / grid.cellSize), 0.0, maxIndex));
  return first <= last;
}

/// Splits a convex polygon (counter-clockwise) at the cells of `grid` and clips it to the grid's
/// extent; calls emit(cellIndex, points) for each non-empty part, repeated points removed.
template <typename Emit>
void splitIntoCells(const ClipPolygon& poly, const CellGrid& grid, Emit&& emit) {
  if (poly.points.size() < 3) return;
  double lo[2] = {poly.points[0].x, poly.points[0].y};
  double hi[2] = {lo[0], lo[1]};
  for (const auto& p : poly.points) {
    lo[0] = std::min(lo[0], p.x);
    hi[0] = std::max(hi[0], p.x);
    lo[1] = std::min(lo[1], p.y);
    hi[1] = std::max(hi[1], p.y);
  }
  int c0 = 0;
  int c1 = 0;
  if (!cellRange(grid, 0, lo[0], hi[0], c0, c1)) return;
  int r0 = 0;
  int r1 = 0;
  if (!cellRange(grid, 1, lo[1], hi[1], r0, r1)) return;
  for (int column = c0; column <= c1; ++column) {
    ClipPolygon strip = clipHalfPlane(poly, 0, gridLine(grid, 0, column), true);
    strip = clipHalfPlane(strip, 0, gridLine(grid, 0, column + 1), false);
    if (strip.points.size() < 3) continue;
    double ylo = strip.points[0].y;
    double yhi = ylo;
    for (const auto& p : strip.points) {
      ylo = std::min(ylo, p.y);
      yhi = std::max(yhi, p.y);
    }
    int s0 = 0;
    int s1 = 0;
    if (!cellRange(grid, 1, ylo, yhi, s0, s1)) continue;
    for (int row = std::max(s0, r0); row <= std::min(s1, r1); ++row) {
      ClipPolygon cell = clipHalfPlane(strip, 1, gridLine(grid, 1, row), true);
      cell = clipHalfPlane(cell, 1, gridLine(grid, 1, row + 1), false);
      dropRepeatedPoints(cell.points);
      if (cell.points.size() >= 3) emit(grid.cellIndex(column, row), cell.points);
    }
  }
}

/// The footprints of a region given as triangles: one per grid cell it meets (every triangle
/// clipped to the cells; neighbouring triangles compute the points where their shared edge
/// crosses a grid line from the same segment, so the parts in one cell share their vertices bit
/// for bit), or one for the whole region without a grid. Appended to `out`.
inline void emitRegion(const std::vector<Triangle>& inside, const std::optional<CellGrid>& grid, std::uint32_t feature,
                       PieceKind kind, std::uint32_t source, std::vector<Footprint>& out) {
  if (!grid) {
    FootprintBuilder builder;
    for (const auto& t : inside) builder.addTriangle(t[0], t[1], t[2]);
    if (!builder.empty()) {
      out.push_back(builder.finish(feature, -1, kind));
      out.back().source = source;
    }
    return;
  }
  std::map<int, FootprintBuilder> cells;
  for (const auto& t : inside) {
    splitIntoCells(makeClipPolygon({t[0], t[1], t[2]}), *grid,
                   [&](int cell, const std::vector<glm::dvec2>& pts) { triangulateConvex(pts, cells[cell]); });
  }
  for (auto& [cell, builder] : cells) {
    if (builder.empty()) continue;
    out.push_back(builder.finish(feature, cell, kind));
    out.back().source = source;
  }
}

// ---------------------------------------------------------------------------------------------
// Arcs

/// Number of chords for a full circle of radius r so that the sagitta r (1 − cos(π/n)) is at
/// most `tolerance`: a multiple of 4 (the quarter points are exact), at least 8, at most
/// kMaxArcSegments (a non-positive or non-finite tolerance gets the maximum).
inline constexpr int kMaxArcSegments = 16384;
inline int circleSegments(double r, double tolerance) {
  if (!(tolerance > 0.0) || !std::isfinite(tolerance)) return kMaxArcSegments;
  const double ratio = tolerance / (2.0 * r);
  if (ratio >= 1.0) return 8;
  // 1 − cos(π/n) = 2 sin²(π/(2n)) ≤ tolerance / r  ⇔  π/(2n) ≤ asin(√(tolerance / 2r))
  const double n = std::numbers::pi / (2.0 * std::asin(std::sqrt(ratio)));
  if (!(n < static_cast<double>(kMaxArcSegments))) return kMaxArcSegments;
  int segments = std::max(8, static_cast<int>(std::ceil(n)));
  segments = (segments + 3) / 4 * 4;
  return std::min(segments, kMaxArcSegments);
}

/// The regular polygon of n vertices (a multiple of 4, circleSegments) inscribed in the circle
/// (centre, r), counter-clockwise, its first vertex at centre + r · direction (direction a unit
/// vector), quarter points exactly on ±direction and ±perp(direction).
inline std::vector<glm::dvec2> discPolygon(const glm::dvec2& centre, double r, const glm::dvec2& direction, int n) {
  const int quarter = n / 4;
  std::vector<glm::dvec2> pts(static_cast<std::size_t>(n));
  const glm::dvec2 u = direction;
  const glm::dvec2 v(-direction.y, direction.x);
  for (int k = 0; k < quarter; ++k) {
    const double angle = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n);
    const double c = k == 0 ? 1.0 : std::cos(angle);
    const double s = k == 0 ? 0.0 : std::sin(angle);
    // rotations by multiples of 90° are exact: (c, s) → (−s, c) → (−c, −s) → (s, −c)
    const std::array<glm::dvec2, 4> local = {glm::dvec2(c, s), glm::dvec2(-s, c), glm::dvec2(-c, -s),
                                             glm::dvec2(s, -c)};
    for (int q = 0; q < 4; ++q) {
      const glm::dvec2& l = local[static_cast<std::size_t>(q)];
      pts[static_cast<std::size_t>(q * quarter + k)] = centre + r * (l.x * u + l.y * v);
    }
  }
  return pts;
}

}  // namespace gis::overlay::detail
