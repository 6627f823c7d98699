// Joins and caps of lines on the globe (globe_detail.hpp, pointShape): footprints.hpp's rules in
// the tangent plane at the point, for the reference, its edge band and both line builders.
#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "globe/ellipsoid.hpp"
#include "globe_detail.hpp"

namespace gis::globe::detail {

namespace {

/// The side direction of the band from a to b (the normal of the plane through the chord and the
/// ends' mean normal), in the tangent plane at a point with normal n.
glm::dvec3 bandSide(const glm::dvec3& a, const glm::dvec3& na, const glm::dvec3& b, const glm::dvec3& nb,
                    const glm::dvec3& n) {
  const glm::dvec3 m = glm::normalize(glm::cross(glm::normalize(na + nb), b - a));
  return glm::normalize(m - n * glm::dot(n, m));
}

}  // namespace

PointShape pointShape(const GlobeLine& line, const std::vector<glm::dvec2>& points, std::size_t k, bool given) {
  PointShape shape;
  if (k >= points.size() || isPole(points[k].y)) return shape;
  if (line.round()) {
    shape.kind = PointShape::Kind::Disc;
    return shape;
  }
  const glm::dvec2 p = points[k];
  const glm::dvec3 c = toEcef(p.x, p.y, 0.0), n = surfaceNormal(p.x, p.y);
  // The pieces before and after the point, past repeated points.
  std::size_t before = k, after = k;
  while (before > 0 && toEcef(points[before - 1].x, points[before - 1].y, 0.0) == c) --before;
  while (after + 1 < points.size() && toEcef(points[after + 1].x, points[after + 1].y, 0.0) == c) ++after;
  const bool in = before > 0, out = after + 1 < points.size();
  glm::dvec3 uIn(0.0), uOut(0.0);
  if (in) {
    const glm::dvec2 q = points[before - 1];
    uIn = bandSide(toEcef(q.x, q.y, 0.0), surfaceNormal(q.x, q.y), c, n, n);
  }
  if (out) {
    const glm::dvec2 q = points[after + 1];
    uOut = bandSide(c, n, toEcef(q.x, q.y, 0.0), surfaceNormal(q.x, q.y), n);
  }
  const auto polygon = [&shape](std::vector<glm::dvec3> directions, std::vector<char> border) {
    shape.kind = PointShape::Kind::Polygon;
    shape.directions = std::move(directions);
    shape.border = std::move(border);
  };
  if (in && out) {
    const overlay::LineJoin join = given ? line.join : overlay::LineJoin::Bevel;
    if (join == overlay::LineJoin::Round) {
      shape.kind = PointShape::Kind::Disc;
      return shape;
    }
    const double turn = glm::dot(glm::cross(uIn, uOut), n);
    const double cosine = std::clamp(glm::dot(uIn, uOut), -1.0, 1.0);
    if (turn == 0.0 || cosine <= -1.0 + 1e-15) return shape;  // straight on, or a reversal: nothing
    const double s = turn > 0.0 ? -1.0 : 1.0;                 // the outside of the turn
    const glm::dvec3 a = s * uIn, b = s * uOut;
    const double halfCosine = std::sqrt(0.5 * (1.0 + cosine));  // cos(θ / 2)
    if (join == overlay::LineJoin::Miter && halfCosine > 0.0 && 1.0 / halfCosine <= line.miterLimit) {
      const glm::dvec3 m = s * (uIn + uOut) / (1.0 + cosine);
      if (s < 0.0) {
        polygon({glm::dvec3(0.0), a, m, b}, {0, 1, 1, 0});
      } else {
        polygon({glm::dvec3(0.0), b, m, a}, {0, 1, 1, 0});
      }
    } else if (s < 0.0) {
      polygon({glm::dvec3(0.0), a, b}, {0, 1, 0});
    } else {
      polygon({glm::dvec3(0.0), b, a}, {0, 1, 0});
    }
    return shape;
  }
  if (!in && !out) return shape;  // a line of one point: only its disc, when round (above)
  if (line.cap == overlay::LineCap::Round) {
    shape.kind = PointShape::Kind::Disc;
  } else if (line.cap == overlay::LineCap::Square) {
    // The band's end extended by the half width: t ahead (an end) or behind (a start).
    const glm::dvec3 t = in ? glm::cross(uIn, n) : -glm::cross(uOut, n);
    const glm::dvec3 u = glm::cross(n, t);
    polygon({-u, -u + t, u + t, u}, {1, 1, 1, 0});
  } else {
    // Flat: nothing, but the band's end is a border (for the reference's edge band).
    const glm::dvec3 u = in ? uIn : uOut;
    shape.directions = {-u, u};
    shape.border = {1, 0};
  }
  return shape;
}

bool inPointShape(const PointShape& shape, const glm::dvec3& centre, const glm::dvec3& normal, double halfWidth,
                  const glm::dvec3& point) {
  const glm::dvec3 d = point - centre;
  const glm::dvec3 across = d - normal * glm::dot(d, normal);
  switch (shape.kind) {
    case PointShape::Kind::None:
      return false;
    case PointShape::Kind::Disc:
      return glm::length(across) <= halfWidth;
    case PointShape::Kind::Polygon:
      break;
  }
  const std::size_t n = shape.directions.size();
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec3 a = halfWidth * shape.directions[i], b = halfWidth * shape.directions[(i + 1) % n];
    if (glm::dot(glm::cross(b - a, across - a), normal) < 0.0) return false;
  }
  return true;
}

}  // namespace gis::globe::detail
