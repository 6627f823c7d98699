// The globe's charts of the deferred lookup (globe_overlay.hpp, deferredParts): a layer's areas in
// each face of the cube about the earth's centre.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>

#include "globe_detail.hpp"
#include "vector_overlay/globe_overlay.hpp"

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

/// A line layer's parts (deferredParts): its primitives in space, each in the faces it reaches.
std::vector<overlay::DeferredLayer::Part> lineParts(const GlobeLayer& layer, double lowest, double highest,
                                                    double heightRange, double maxReach) {
  using overlay::DeferredChart;
  using overlay::WorldLinePrimitive;
  const glm::dvec3 radii(kSemiMajor, kSemiMajor, kSemiMinor);
  const double limit = 1.0 + DeferredChart::kFaceMargin;
  std::array<overlay::DeferredLayer::Part, 6> parts;
  std::vector<glm::dvec3> widths(layer.featureCount(), glm::dvec3(0.0));
  for (const GlobeLine& line : layer.lines()) {
    if (line.widthPixels > 0.0 && line.feature < widths.size())
      widths[line.feature] = {0.5 * line.widthPixels, line.halfWidth, line.maxHalfWidth};
  }
  for (int face = 0; face < 6; ++face) {
    overlay::DeferredLayer::Part& part = parts[static_cast<std::size_t>(face)];
    part.chart = DeferredChart::cubeFace(face, radii);
    part.region = {glm::dvec2(-limit * part.chart.scale), glm::dvec2(limit * part.chart.scale)};
    part.lowest = lowest;
    part.highest = highest;
    part.heightRange = heightRange;
    part.features.resize(layer.featureCount());
    part.lineWidths = widths;
    part.maxReach = maxReach;
  }
  const double height = heightRange >= 0.0 ? heightRange : std::max(std::abs(lowest), std::abs(highest));
  // A primitive's corners (on the ground), projected into each face they are in front of: the
  // box of a planar quadrilateral's image. A ground point it covers has its foot within
  // height · (its distance / R) of the quadrilateral's plane's (the normals tilt), and the
  // ellipsoid falls away from the plane by (distance)² / 2R: the box is grown by both (in metres,
  // three times in chart units: a face stretches a length by up to 3 at its corners).
  const auto add = [&](const WorldLinePrimitive& primitive, const std::array<glm::dvec3, 4>& corners, double extent) {
    const double grow =
        3.0 * (height * extent / kMinCurvatureRadius + extent * extent / kMinCurvatureRadius + 1e-3 * extent + 1.0);
    for (overlay::DeferredLayer::Part& part : parts) {
      const DeferredChart& chart = part.chart;
      glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
      std::size_t inFront = 0;
      for (const glm::dvec3& c : corners) {
        if (glm::dot(chart.axis, c) <= 0.2 * glm::length(c)) continue;
        ++inFront;
        const glm::dvec2 at = chart.project(c);
        lo = glm::min(lo, at);
        hi = glm::max(hi, at);
      }
      if (inFront == 0) continue;
      if (inFront < corners.size()) {
        // Partly beyond 78° from the face's middle, far outside its region (56° at most) unless
        // it is thousands of kilometres long: then all of the region (it cannot be told more
        // closely).
        if (extent < 2e6) continue;
        lo = part.region[0];
        hi = part.region[1];
      }
      lo -= glm::dvec2(grow);
      hi += glm::dvec2(grow);
      if (hi.x < part.region[0].x || lo.x > part.region[1].x || hi.y < part.region[0].y || lo.y > part.region[1].y)
        continue;
      WorldLinePrimitive p = primitive;
      p.box = {lo, hi};
      part.worldLines.push_back(p);
    }
  };
  // A square of half side r around c across the normal n: what a shape within r of c covers.
  const auto square = [](const glm::dvec3& c, const glm::dvec3& n, double r) {
    const glm::dvec3 any = std::abs(n.z) < 0.9 ? glm::dvec3(0.0, 0.0, 1.0) : glm::dvec3(1.0, 0.0, 0.0);
    const glm::dvec3 e1 = glm::normalize(glm::cross(n, any)) * r;
    const glm::dvec3 e2 = glm::cross(n, e1);
    return std::array<glm::dvec3, 4>{c + e1 + e2, c + e1 - e2, c - e1 - e2, c - e1 + e2};
  };
  for (const GlobeLine& line : layer.lines()) {
    // A line in pixels is binned at the largest half width it takes within the reach (the pass
    // finds its widths per frame at its anchors); a line in metres at its own.
    const bool pixels = line.widthPixels > 0.0;
    const double r = pixels ? std::max(line.halfWidth, std::min(line.maxHalfWidth, maxReach)) : line.halfWidth;
    if (!(r > 0.0) || !std::isfinite(r)) continue;
    const auto anchor = [&line, pixels](std::size_t k) {
      return pixels && k < line.anchors.size() ? static_cast<double>(line.anchors[k]) : 0.0;
    };
    for (std::size_t k = 0; k < line.surface.size(); ++k) {
      const glm::dvec3 c = line.surface[k];
      // The reference's shape at the point (GlobeLine::joins; a disc for round joins and caps):
      // the cylinder around the normal there, or a join's or cap's polygon across it (none at a
      // pole, where a line closed along it runs).
      const detail::PointShape* shape = line.joins && k < line.joins->at.size() ? &line.joins->at[k] : nullptr;
      const bool disc =
          shape == nullptr ? !detail::isPole(line.points[k].y) : shape->kind == detail::PointShape::Kind::Disc;
      const bool polygon = shape != nullptr && shape->kind == detail::PointShape::Kind::Polygon &&
                           shape->directions.size() >= 3 && shape->directions.size() <= 4;
      if (disc || polygon) {
        WorldLinePrimitive point;
        point.kind = disc ? WorldLinePrimitive::Kind::Disc : WorldLinePrimitive::Kind::Convex;
        point.pixels = pixels;
        point.feature = line.feature;
        point.a = c;
        point.normal = surfaceNormalAt(c);
        point.r0 = point.r1 = r;
        point.anchor0 = anchor(k);
        double far = 1.0;
        if (polygon) {
          point.count = static_cast<std::uint32_t>(shape->directions.size());
          for (std::size_t i = 0; i < shape->directions.size(); ++i) {
            point.corners[i] = shape->directions[i];
            far = std::max(far, glm::length(shape->directions[i]));
          }
        }
        add(point, square(c, point.normal, r * far), 2.0 * r * far);
      }
      if (k + 1 == line.surface.size()) continue;
      // The reference's band: the slab along the piece, between the planes through its ends.
      const glm::dvec3 b = line.surface[k + 1], along = b - c;
      const double length = glm::length(along);
      if (!(length > 0.0)) continue;
      WorldLinePrimitive band;
      band.kind = WorldLinePrimitive::Kind::Band;
      band.pixels = pixels;
      band.feature = line.feature;
      band.a = c;
      band.along = along / length;
      band.length = length;
      band.normal = glm::normalize(glm::cross(glm::normalize(surfaceNormalAt(c) + surfaceNormalAt(b)), along));
      band.endA = glm::normalize(detail::bandEndNormal(band.along, band.normal, surfaceNormalAt(c)));
      band.endB = glm::normalize(detail::bandEndNormal(band.along, band.normal, surfaceNormalAt(b)));
      band.r0 = band.r1 = r;
      band.anchor0 = anchor(k);
      band.anchor1 = anchor(k + 1);
      const glm::dvec3 across = band.normal * r;
      add(band, {c + across, b + across, b - across, c - across}, length + 2.0 * r);
    }
  }
  std::vector<overlay::DeferredLayer::Part> out;
  for (overlay::DeferredLayer::Part& part : parts) {
    if (!part.worldLines.empty()) out.push_back(std::move(part));
  }
  return out;
}

}  // namespace

bool deferredDraws(const GlobeLayer& layer) {
  if (!layer.hasLines()) return true;  // areas only
  return layer.areaCount() == 0;
}

std::vector<overlay::DeferredLayer::Part> deferredParts(const GlobeLayer& layer, double lowest, double highest,
                                                        double heightRange, double maxReach) {
  using overlay::DeferredChart;
  if (layer.hasLines()) {
    return deferredDraws(layer) ? lineParts(layer, lowest, highest, heightRange, maxReach)
                                : std::vector<overlay::DeferredLayer::Part>{};
  }
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
