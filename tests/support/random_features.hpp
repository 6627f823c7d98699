#pragma once
// Random polygon and line features over a terrain's extent, for the overlay GL tests.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "geo/feature.hpp"

namespace gis::test {

/// Random features over a terrain: quads and rotated polygons with a hole, and polylines.
inline std::vector<geo::Feature> randomPolygons(std::mt19937& rng, const glm::dvec2& lo, const glm::dvec2& hi,
                                                int count) {
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), size(50.0, 1500.0), angle(0.0, 6.283);
  std::vector<geo::Feature> out;
  for (int i = 0; i < count; ++i) {
    geo::Feature f;
    f.fid = i;
    const glm::dvec2 c(ux(rng), uy(rng));
    const double r = size(rng), a0 = angle(rng);
    geo::Polygon p;
    const int n = 5 + i % 7;
    for (int k = 0; k < n; ++k) {
      const double a = a0 + 6.283 * k / n, rr = r * (0.6 + 0.4 * std::sin(3.0 * a));
      p.outer.push_back(c + rr * glm::dvec2(std::cos(a), std::sin(a)));
    }
    if (i % 3 == 0) {
      p.holes.assign(1, {});
      for (int k = 0; k < 4; ++k) {
        const double a = a0 - 6.283 * k / 4;
        p.holes[0].push_back(c + 0.25 * r * glm::dvec2(std::cos(a), std::sin(a)));
      }
    }
    f.polygons.push_back(std::move(p));
    out.push_back(std::move(f));
  }
  return out;
}

inline std::vector<geo::Feature> randomLines(std::mt19937& rng, const glm::dvec2& lo, const glm::dvec2& hi, int count) {
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), step(20.0, 400.0), turn(-2.5, 2.5);
  std::vector<geo::Feature> out;
  for (int i = 0; i < count; ++i) {
    geo::Feature f;
    f.fid = i;
    f.attributes["width_m"] = std::int64_t{4 + (i % 5) * 6};
    geo::LineString line{glm::dvec2(ux(rng), uy(rng))};
    double heading = 6.283 * (i % 8) / 8.0;
    for (int k = 0; k < 6; ++k) {
      heading += turn(rng) * 0.5;
      line.push_back(line.back() + step(rng) * glm::dvec2(std::cos(heading), std::sin(heading)));
    }
    f.lines.push_back(std::move(line));
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace gis::test
