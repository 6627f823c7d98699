// The globe's charts of the deferred lookup (globe_overlay.hpp, deferredParts): a layer's areas in
// each face of the cube about the earth's centre.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "globe/globe_overlay.hpp"

namespace gis::globe {

namespace {

using Points = std::vector<glm::dvec3>;

/// Sutherland–Hodgman against the half-space `distance(p) ≥ 0` (a plane through the centre): the
/// ring's chords are straight in space, so where one crosses the plane is exact.
template <typename Distance>
Points clipRing(const Points& in, const Distance& distance) {
  Points out;
  if (in.empty()) return out;
  glm::dvec3 s = in.back();
  double ds = distance(s);
  for (const glm::dvec3& e : in) {
    const double de = distance(e);
    if ((de >= 0.0) != (ds >= 0.0)) out.push_back(s + (e - s) * (ds / (ds - de)));
    if (de >= 0.0) out.push_back(e);
    s = e;
    ds = de;
  }
  return out;
}

/// Even-odd of a point over rings in a plane (a ray towards +x).
bool insideRings(const std::vector<geo::Ring>& rings, const glm::dvec2& p) {
  bool inside = false;
  for (const geo::Ring& ring : rings) {
    for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
      const glm::dvec2& a = ring[i];
      const glm::dvec2& b = ring[j];
      if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y)) inside = !inside;
    }
  }
  return inside;
}

/// Whether a ring's points all lie on one line (a meridian gone out and back, as a ring around a
/// pole closed along the other one leaves in a face): no area, and not a polygon's outer ring to
/// the index.
bool flat(const geo::Ring& ring) {
  const auto other = std::find_if(ring.begin(), ring.end(), [&](const glm::dvec2& p) { return p != ring.front(); });
  if (other == ring.end()) return true;
  const glm::dvec2 d = *other - ring.front();
  return std::all_of(ring.begin(), ring.end(), [&](const glm::dvec2& p) {
    const glm::dvec2 e = p - ring.front();
    return d.x * e.y - d.y * e.x == 0.0;
  });
}

}  // namespace

std::vector<overlay::DeferredLayer::Part> deferredParts(const GlobeLayer& layer, double lowest, double highest) {
  using overlay::DeferredChart;
  const glm::dvec3 radii(kSemiMajor, kSemiMajor, kSemiMinor);
  const double limit = 1.0 + DeferredChart::kFaceMargin;
  std::vector<overlay::DeferredLayer::Part> parts;
  for (int face = 0; face < 6; ++face) {
    overlay::DeferredLayer::Part part;
    part.chart = DeferredChart::cubeFace(face, radii);
    const DeferredChart& chart = part.chart;
    part.region = {glm::dvec2(-limit * chart.scale), glm::dvec2(limit * chart.scale)};
    part.lowest = lowest;
    part.highest = highest;
    part.features.resize(layer.featureCount());
    // Where each polygon's parity is checked against the reference: a point of the face off its
    // middle lines (where synthetic edges run).
    const glm::dvec2 probeChart = glm::dvec2(0.0123457, 0.0234567) * chart.scale;
    const glm::dvec3 probe = chart.unproject(probeChart);
    const Geodetic probeAt = toGeodetic(probe);
    // The grown face's square, as a ring: flips the parity everywhere in the face.
    const geo::Ring square{{-limit * chart.scale, -limit * chart.scale},
                           {limit * chart.scale, -limit * chart.scale},
                           {limit * chart.scale, limit * chart.scale},
                           {-limit * chart.scale, limit * chart.scale}};
    bool any = false;
    const std::vector<GlobePolygon>& polygons = layer.polygons();
    for (std::size_t k = 0; k < layer.areaCount(); ++k) {
      const GlobePolygon& polygon = polygons[k];
      std::vector<geo::Ring> rings;
      for (const auto& ring : polygon.rings) {
        Points points;
        points.reserve(ring.size());
        for (const glm::dvec2& p : ring) points.push_back(toEcef(p.x, p.y, 0.0));
        // The face's pyramid grown by the margin: |east·p|, |north·p| ≤ limit · axis·p.
        for (const glm::dvec3& side : {chart.east, -chart.east, chart.north, -chart.north}) {
          points = clipRing(points,
                            [&](const glm::dvec3& p) { return limit * glm::dot(chart.axis, p) - glm::dot(side, p); });
        }
        if (points.size() < 3) continue;
        geo::Ring projected;
        projected.reserve(points.size());
        for (const glm::dvec3& p : points) projected.push_back(chart.project(p));
        if (!flat(projected)) rings.push_back(std::move(projected));
      }
      // The plane's even-odd counts from its infinity, the reference's from its own rule (a ring
      // around a pole closed along it, longitudes unwrapped): both flip across the same edges,
      // so they differ by a constant over the face. Where they differ, the square flips it.
      if (insideRings(rings, probeChart) != contains(polygon, probe, probeAt.lon, probeAt.lat)) rings.push_back(square);
      if (rings.empty()) continue;
      geo::Polygon out;
      out.outer = std::move(rings.front());
      out.holes.assign(std::make_move_iterator(rings.begin() + 1), std::make_move_iterator(rings.end()));
      part.features[polygon.feature].polygons.push_back(std::move(out));
      any = true;
    }
    if (any) parts.push_back(std::move(part));
  }
  return parts;
}

}  // namespace gis::globe
