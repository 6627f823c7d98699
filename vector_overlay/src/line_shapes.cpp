// The shapes of a line from its stations (line_shapes.hpp): footprints.hpp's rules for segments,
// joins and caps, in each station's own plane.
#include "vector_overlay/line_shapes.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "footprint_geometry.hpp"

namespace gis::overlay {
namespace {

glm::dvec2 perp(const glm::dvec2& d) { return {-d.y, d.x}; }

/// Unit directions to points on a circle from angle a0 to a1 (radians, a1 > a0:
/// counter-clockwise), both ends included, `full` chords per full circle.
std::vector<glm::dvec2> arc(double a0, double a1, int full) {
  const int m = std::max(1, static_cast<int>(std::ceil((a1 - a0) / (2.0 * std::numbers::pi) * full)));
  std::vector<glm::dvec2> directions;
  directions.reserve(static_cast<std::size_t>(m + 1));
  for (int k = 0; k <= m; ++k) {
    const double a = a0 + (a1 - a0) * k / m;
    directions.emplace_back(std::cos(a), std::sin(a));
  }
  return directions;
}

/// Unit directions of the regular polygon of `full` vertices whose first vertex lies in the
/// unit direction `direction`.
std::vector<glm::dvec2> disc(const glm::dvec2& direction, int full) {
  // discPolygon's points are centre + r · (unit vector): with centre 0 and r = 1 exactly those.
  return detail::discPolygon(glm::dvec2(0.0), 1.0, direction, full);
}

/// The corners of one station in the given directions.
std::vector<ShapeCorner> around(std::uint32_t station, const std::vector<glm::dvec2>& directions) {
  std::vector<ShapeCorner> corners;
  corners.reserve(directions.size());
  for (const glm::dvec2& d : directions) corners.push_back({station, d});
  return corners;
}

class Shaper {
 public:
  Shaper(std::span<const LineStation> stations, const LineShapeRules& rules,
         const std::function<void(PieceKind, std::vector<ShapeCorner>)>& add)
      : stations_(stations), rules_(rules), add_(add) {}

  /// The cap at station s, the line leaving it in the unit direction `outward`. A round cap
  /// whose end segment is at least wedgeLength long needs only the outer half disc: the rectangle
  /// holds the other half (same union, half the triangles).
  void cap(std::uint32_t s, const glm::dvec2& outward, double segmentLength) const {
    const glm::dvec2 n = perp(outward);
    switch (rules_.cap) {
      case LineCap::Round:
        if (segmentLength >= rules_.wedgeLength && !rules_.wholeDiscs) {
          const double a = std::atan2(outward.y, outward.x);
          add_(PieceKind::Cap, around(s, arc(a - 0.5 * std::numbers::pi, a + 0.5 * std::numbers::pi, rules_.chords)));
        } else {
          add_(PieceKind::Cap, around(s, disc(n, rules_.chords)));
        }
        break;
      case LineCap::Square:
        add_(PieceKind::Cap, around(s, {-n, outward - n, outward + n, n}));
        break;
      case LineCap::Flat:
        break;
    }
  }

  /// The join at station s between the piece arriving and the piece leaving.
  void join(std::uint32_t s) const {
    const LineStation& st = stations_[s];
    if (!st.given) return;  // the pieces meet on the bisector (corner())
    const glm::dvec2 d0 = st.in;
    const glm::dvec2 d1 = st.out;
    const int turn = st.turn;
    if (turn == 0 && d0.x * d1.x + d0.y * d1.y > 0.0) return;  // straight continuation
    if (rules_.join == LineJoin::Round) {
      // With both segments at least w/2 long, the two rectangles hold all of the disc but the
      // outer wedge between their end edges: draw that wedge only (same union, far fewer
      // triangles). Otherwise, and for hairpins, the whole disc.
      if (turn != 0 && st.inLength >= rules_.wedgeLength && st.outLength >= rules_.wedgeLength && !rules_.wholeDiscs) {
        const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
        const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
        double a0 = std::atan2(out0.y, out0.x), a1 = std::atan2(out1.y, out1.x);
        if (turn < 0) std::swap(a0, a1);  // counter-clockwise from a0 to a1
        if (a1 < a0) a1 += 2.0 * std::numbers::pi;
        std::vector<glm::dvec2> directions{glm::dvec2(0.0)};
        const std::vector<glm::dvec2> rim = arc(a0, a1, rules_.chords);
        directions.insert(directions.end(), rim.begin(), rim.end());
        add_(PieceKind::Join, around(s, directions));
      } else {
        add_(PieceKind::Join, around(s, disc(perp(d0), rules_.chords)));
      }
      return;
    }
    // A hairpin (180°) has a flat bevel and an infinite miter: nothing besides the rectangles.
    if (turn == 0) return;
    // Outer normals: on the right of a left turn, on the left of a right turn.
    const glm::dvec2 out0 = turn > 0 ? -perp(d0) : perp(d0);
    const glm::dvec2 out1 = turn > 0 ? -perp(d1) : perp(d1);
    // θ the angle between the segments at the station. With s = d0 + d1: |s| = 2 sin(θ/2),
    // accurate also for nearly reversed directions (where 1 + cos(turn) would cancel to zero).
    // Miter length h / sin(θ/2) ≤ miterLimit · h  ⇔  miterLimit · sin(θ/2) ≥ 1.
    const glm::dvec2 sum = d0 + d1;
    const double sinHalfTheta = 0.5 * std::hypot(sum.x, sum.y);
    // Built by push_back: assigning an initializer list here trips GCC 12's -Warray-bounds at -O3
    // (a false positive in vector::operator=).
    std::vector<glm::dvec2> directions;
    directions.reserve(4);
    directions.push_back(glm::dvec2(0.0));
    directions.push_back(out0);
    if (rules_.join == LineJoin::Miter && rules_.miterLimit * sinHalfTheta >= 1.0) {
      // The intersection of the two outer offset lines lies on the outer bisector (out0 + out1,
      // of length |s|) at distance h / sin(θ/2) = 2h / |s| from the station.
      const glm::dvec2 miter = (2.0 / (sum.x * sum.x + sum.y * sum.y)) * (out0 + out1);
      if (detail::finite(miter) && detail::finite(rules_.halfWidth * miter)) directions.push_back(miter);
    }
    directions.push_back(out1);
    if (turn < 0) std::reverse(directions.begin() + 1, directions.end());
    add_(PieceKind::Join, around(s, directions));
  }

  /// The left side of segment s → s + 1 at station `at` (s or s + 1): perp of the piece's
  /// direction there, or at a station the frame added, the bisector of both pieces' sides,
  /// 1 / cos(θ/2) long (the miter point, shared by both pieces).
  [[nodiscard]] glm::dvec2 side(std::uint32_t at, bool leaving) const {
    const LineStation& st = stations_[at];
    const bool both = st.in != glm::dvec2(0.0) && st.out != glm::dvec2(0.0);
    if (st.given || !both) return perp(leaving ? st.out : st.in);
    const glm::dvec2 n0 = perp(st.in), n1 = perp(st.out);
    const double c = 1.0 + n0.x * n1.x + n0.y * n1.y;
    return c > 1e-9 ? (n0 + n1) / c : perp(leaving ? st.out : st.in);
  }

  void run() const {
    const auto n = static_cast<std::uint32_t>(stations_.size());
    if (n == 0) return;
    if (n == 1) {
      if (!rules_.ends) return;
      if (rules_.cap == LineCap::Round) {
        add_(PieceKind::Cap, around(0, disc(glm::dvec2(1.0, 0.0), rules_.chords)));
      } else if (rules_.cap == LineCap::Square) {
        add_(PieceKind::Cap, around(0, {{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}));
      }
      return;
    }
    const auto end = [&](std::uint32_t s) {
      const LineStation& st = stations_[s];
      const bool hasIn = st.in != glm::dvec2(0.0), hasOut = st.out != glm::dvec2(0.0);
      if (hasIn && hasOut) {
        join(s);
      } else if (hasOut) {
        cap(s, -st.out, st.outLength);
      } else if (hasIn) {
        cap(s, st.in, st.inLength);
      }
    };
    if (rules_.ends) end(0);
    for (std::uint32_t i = 0; i + 1 < n; ++i) {
      const glm::dvec2 na = side(i, true), nb = side(i + 1, false);
      add_(PieceKind::Segment, {{i, -na}, {i + 1, -nb}, {i + 1, nb}, {i, na}});
      if (rules_.ends && i + 2 < n) join(i + 1);
    }
    if (rules_.ends) end(n - 1);
  }

 private:
  std::span<const LineStation> stations_;
  const LineShapeRules& rules_;
  const std::function<void(PieceKind, std::vector<ShapeCorner>)>& add_;
};

}  // namespace

void lineShapes(std::span<const LineStation> stations, const LineShapeRules& rules,
                const std::function<void(PieceKind, std::vector<ShapeCorner>)>& add) {
  Shaper(stations, rules, add).run();
}

}  // namespace gis::overlay
