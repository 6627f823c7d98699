// Lines on the globe (globe_detail.hpp): the stations both line builders hand the shared shape
// rules (overlay::lineShapes), and the reference's joins and caps (pointShape: footprints.hpp's
// rules in the tangent plane at the point, written apart from the builders' for the reference and
// its edge band).
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

GlobeStations globeStations(const std::vector<glm::dvec2>& points, std::size_t first, std::size_t last,
                            const std::vector<char>& given) {
  GlobeStations out;
  if (first > last || last >= points.size()) return out;
  const auto ecef = [&points](std::size_t k) { return toEcef(points[k].x, points[k].y, 0.0); };
  for (std::size_t k = first; k <= last; ++k) {
    const glm::dvec3 c = ecef(k);
    if (!out.centre.empty() && c == out.centre.back()) continue;
    out.centre.push_back(c);
    out.point.push_back(k - first);
  }
  const std::size_t n = out.centre.size();
  out.stations.assign(n, overlay::LineStation{});
  out.normal.resize(n);
  out.e1.resize(n);
  out.e2.resize(n);
  out.pole.resize(n);
  for (std::size_t s = 0; s < n; ++s) {
    const glm::dvec2& p = points[first + out.point[s]];
    const glm::dvec3 nrm = surfaceNormal(p.x, p.y);
    out.normal[s] = nrm;
    out.e1[s] = glm::normalize(glm::cross(nrm, std::abs(nrm.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0)));
    out.e2[s] = glm::cross(nrm, out.e1[s]);
    out.pole[s] = static_cast<char>(isPole(p.y));
    out.stations[s].given = given.empty() || given[first + out.point[s]] != 0;
  }
  // A piece's side: the normal of the plane through its chord and its ends' mean normal (left of
  // the piece); its direction at a station: along the tangent plane there, square to that side.
  const auto side = [](const glm::dvec3& a, const glm::dvec3& na, const glm::dvec3& b, const glm::dvec3& nb) {
    return glm::normalize(glm::cross(glm::normalize(na + nb), b - a));
  };
  const auto planar = [&out](std::size_t s, const glm::dvec3& m) {
    const glm::dvec3 d = glm::normalize(glm::cross(m, out.normal[s]));
    return glm::dvec2(glm::dot(d, out.e1[s]), glm::dot(d, out.e2[s]));
  };
  for (std::size_t s = 0; s + 1 < n; ++s) {
    const glm::dvec3 m = side(out.centre[s], out.normal[s], out.centre[s + 1], out.normal[s + 1]);
    const double length = glm::length(out.centre[s + 1] - out.centre[s]);
    out.stations[s].out = planar(s, m);
    out.stations[s].outLength = length;
    out.stations[s + 1].in = planar(s + 1, m);
    out.stations[s + 1].inLength = length;
  }
  // The points just outside the run (past points at the same place).
  if (n > 0) {
    for (std::size_t k = first; k-- > 0;) {
      const glm::dvec3 c = ecef(k);
      if (c == out.centre.front()) continue;
      const glm::dvec3 m = side(c, surfaceNormal(points[k].x, points[k].y), out.centre.front(), out.normal.front());
      out.stations.front().in = planar(0, m);
      out.stations.front().inLength = glm::length(out.centre.front() - c);
      break;
    }
    for (std::size_t k = last + 1; k < points.size(); ++k) {
      const glm::dvec3 c = ecef(k);
      if (c == out.centre.back()) continue;
      const glm::dvec3 m = side(out.centre.back(), out.normal.back(), c, surfaceNormal(points[k].x, points[k].y));
      out.stations.back().out = planar(n - 1, m);
      out.stations.back().outLength = glm::length(c - out.centre.back());
      break;
    }
  }
  for (overlay::LineStation& st : out.stations) {
    const double cross = st.in.x * st.out.y - st.in.y * st.out.x;
    st.turn = cross > 0.0 ? 1 : (cross < 0.0 ? -1 : 0);
  }
  return out;
}

overlay::LineShapeRules globeShapeRules(const GlobeLine& line, double halfWidth, int chords, bool wholeDiscs) {
  overlay::LineShapeRules rules;
  rules.join = line.join;
  rules.cap = line.cap;
  rules.miterLimit = line.miterLimit;
  rules.halfWidth = halfWidth;
  rules.wedgeLength = 0.0;
  rules.chords = (std::max(chords, 8) + 3) / 4 * 4;
  rules.wholeDiscs = wholeDiscs;
  return rules;
}

namespace {

PointShape shapeAt(const GlobeLine& line, const std::vector<glm::dvec2>& points, std::size_t k, bool given) {
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

}  // namespace

PointShape pointShape(const GlobeLine& line, const std::vector<glm::dvec2>& points, std::size_t k, bool given) {
  PointShape shape = shapeAt(line, points, k, given);
  shape.reach = shape.kind == PointShape::Kind::Disc ? 1.0 : 0.0;
  for (const glm::dvec3& d : shape.directions) shape.reach = std::max(shape.reach, glm::length(d));
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
