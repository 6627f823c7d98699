#pragma once
// Checks shared by the tests of vector sources read by spatial filter (vector_sources_test,
// postgis_source_test): which features meet a frame box, and that a filtered read holds every
// one of them, each identical to the unfiltered read's.
#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/common.hpp>
#include <glm/vec2.hpp>

#include "geo/vector.hpp"

namespace gis::test {

/// Every diagnostic on its own line, for failure messages.
inline std::string said(const Diagnostics& diagnostics) {
  std::string text;
  for (const Diagnostic& d : diagnostics.items()) text += d.toString() + "\n";
  return text;
}

using Box = std::array<glm::dvec2, 2>;

inline bool inside(const glm::dvec2& p, const Box& b) {
  return p.x >= b[0].x && p.x <= b[1].x && p.y >= b[0].y && p.y <= b[1].y;
}

/// Whether the segment a–b meets the box (clipped against its slabs).
inline bool segmentMeets(const glm::dvec2& a, const glm::dvec2& b, const Box& box) {
  double t0 = 0.0, t1 = 1.0;
  const glm::dvec2 d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    if (d[axis] == 0.0) {
      if (a[axis] < box[0][axis] || a[axis] > box[1][axis]) return false;
      continue;
    }
    double u0 = (box[0][axis] - a[axis]) / d[axis], u1 = (box[1][axis] - a[axis]) / d[axis];
    if (u0 > u1) std::swap(u0, u1);
    t0 = std::max(t0, u0);
    t1 = std::min(t1, u1);
    if (t0 > t1) return false;
  }
  return true;
}

/// Whether p lies inside the ring (even-odd).
inline bool inRing(const glm::dvec2& p, const std::vector<glm::dvec2>& ring) {
  bool in = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const glm::dvec2 a = ring[i], b = ring[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y)) in = !in;
  }
  return in;
}

/// Whether the feature's geometry (frame coordinates) meets the box: an edge meets it, or the
/// box lies inside one of its polygons.
inline bool meets(const geo::Feature& f, const Box& box) {
  auto ringMeets = [&](const std::vector<glm::dvec2>& ring, bool closed) {
    if (ring.size() == 1) return inside(ring[0], box);
    const std::size_t edges = closed ? ring.size() : ring.size() - 1;
    for (std::size_t i = 0; i < edges; ++i) {
      if (segmentMeets(ring[i], ring[(i + 1) % ring.size()], box)) return true;
    }
    return false;
  };
  for (const geo::LineString& line : f.lines) {
    if (ringMeets(line, false)) return true;
  }
  for (const geo::Polygon& p : f.polygons) {
    if (ringMeets(p.outer, true) || inRing(0.5 * (box[0] + box[1]), p.outer)) return true;
    for (const auto& hole : p.holes) {
      if (ringMeets(hole, true)) return true;
    }
  }
  return false;
}

inline bool sameGeometry(const geo::Feature& a, const geo::Feature& b) {
  if (a.lines != b.lines || a.polygons.size() != b.polygons.size()) return false;
  for (std::size_t i = 0; i < a.polygons.size(); ++i) {
    if (a.polygons[i].outer != b.polygons[i].outer || a.polygons[i].holes != b.polygons[i].holes) return false;
  }
  return true;
}

/// What a filtered read gave against the unfiltered read of the same source.
struct FilterCheck {
  std::size_t meeting = 0;  ///< features of the whole layer that meet the box
  std::size_t read = 0;     ///< features the filtered read gave
};

/// Every feature of `all` that meets the box is in `filtered` (by fid), identical; every
/// feature of `filtered` is one of `all`, identical.
inline FilterCheck expectFilteredReadHoldsTheBox(const geo::VectorLayer& all, const geo::VectorLayer& filtered,
                                                 const Box& box) {
  std::map<std::int64_t, const geo::Feature*> byFid;
  for (const geo::Feature& f : filtered.features) byFid[f.fid] = &f;
  EXPECT_EQ(byFid.size(), filtered.features.size()) << "feature ids are unique";
  std::map<std::int64_t, const geo::Feature*> allByFid;
  for (const geo::Feature& f : all.features) allByFid[f.fid] = &f;
  FilterCheck check;
  check.read = filtered.features.size();
  for (const geo::Feature& f : all.features) {
    if (!meets(f, box)) continue;
    ++check.meeting;
    const auto found = byFid.find(f.fid);
    if (found == byFid.end()) {
      ADD_FAILURE() << "feature " << f.fid << " meets the box but was not read";
      continue;
    }
    EXPECT_TRUE(sameGeometry(f, *found->second)) << "feature " << f.fid;
    EXPECT_EQ(f.attributes, found->second->attributes) << "feature " << f.fid;
  }
  for (const geo::Feature& f : filtered.features) {
    const auto found = allByFid.find(f.fid);
    if (found == allByFid.end()) {
      ADD_FAILURE() << "feature " << f.fid << " read with the filter is not in the layer";
      continue;
    }
    EXPECT_TRUE(sameGeometry(f, *found->second)) << "feature " << f.fid;
  }
  return check;
}

/// The middle of the layer's extent: `fraction` of its width and height, centred.
inline Box middleOf(const geo::VectorLayer& layer, double fraction) {
  glm::dvec2 lo(1e300), hi(-1e300);
  auto add = [&](const glm::dvec2& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  };
  for (const geo::Feature& f : layer.features) {
    for (const auto& line : f.lines) std::for_each(line.begin(), line.end(), add);
    for (const auto& p : f.polygons) std::for_each(p.outer.begin(), p.outer.end(), add);
  }
  const glm::dvec2 c = 0.5 * (lo + hi), half = 0.5 * fraction * (hi - lo);
  return {c - half, c + half};
}

}  // namespace gis::test
