#pragma once
// Globe test scenes: a synthetic global DEM (relief everywhere, seas below 0) and polygons that
// exercise the globe: a continent-sized one, one across the antimeridian, a cap around the north
// pole, an Antarctica-like ring with its pole edge (as GMT writes it), one with a hole, a small one.
#include <cmath>
#include <memory>
#include <vector>

#include "geo/feature.hpp"
#include "globe/geo_grid.hpp"

namespace gis::test::globe_scene {

/// Heights in metres on a `step`-degree global grid (posts at cell centres), −2,000 … +5,000 m.
inline std::shared_ptr<const globe::GeoGrid> syntheticGrid(double step = 0.5, double scale = 1.0) {
  const int w = static_cast<int>(std::lround(360.0 / step)), h = static_cast<int>(std::lround(180.0 / step));
  std::vector<float> heights(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  constexpr double d = 3.14159265358979323846 / 180.0;
  for (int r = 0; r < h; ++r) {
    const double lat = 90.0 - (r + 0.5) * step;
    for (int c = 0; c < w; ++c) {
      const double lon = -180.0 + (c + 0.5) * step;
      double v = 1500.0 * std::sin(3.0 * lon * d) * std::cos(2.0 * lat * d) +
                 900.0 * std::sin(11.0 * lon * d + 1.0) * std::sin(7.0 * lat * d) +
                 400.0 * std::cos(31.0 * lon * d) * std::sin(23.0 * lat * d + 0.5) + 1200.0;
      heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(w) + static_cast<std::size_t>(c)] =
          static_cast<float>(v * scale);
    }
  }
  return std::make_shared<globe::GeoGrid>(w, h, -180.0 + 0.5 * step, 90.0 - 0.5 * step, step, std::move(heights));
}

inline geo::Polygon box(double west, double south, double east, double north) {
  return {{{west, south}, {east, south}, {east, north}, {west, north}}, {}};
}

/// Features, each with one polygon, in (lon, lat).
inline std::vector<geo::Feature> features() {
  std::vector<geo::Feature> out;
  const auto add = [&](geo::Polygon p) {
    geo::Feature f;
    f.fid = static_cast<std::int64_t>(out.size());
    f.polygons.push_back(std::move(p));
    out.push_back(std::move(f));
  };
  // 0: a continent-sized wedge (South America's size).
  add({{{-80.0, 10.0}, {-35.0, -5.0}, {-40.0, -25.0}, {-70.0, -55.0}, {-75.0, -15.0}}, {}});
  // 1: across the antimeridian (Fiji, Chukotka): longitudes written in [−180, 180].
  add({{{170.0, -20.0}, {-170.0, -22.0}, {-165.0, -8.0}, {175.0, -5.0}}, {}});
  // 2: the Arctic cap north of 78°, a ring with no pole point (closed along the north pole).
  {
    geo::Polygon p;
    for (int k = 0; k < 36; ++k) p.outer.emplace_back(-180.0 + k * 10.0, 78.0 + 3.0 * std::sin(k * 0.7));
    add(p);
  }
  // 3: Antarctica as GMT writes it: along the coast from −180 to 180, down to the pole, along it.
  {
    geo::Polygon p;
    for (int k = 0; k <= 36; ++k) p.outer.emplace_back(-180.0 + k * 10.0, -72.0 + 4.0 * std::cos(k * 0.9));
    p.outer.emplace_back(180.0, -90.0);
    p.outer.emplace_back(-180.0, -90.0);
    add(p);
  }
  // 4: a polygon with a hole (Europe's size).
  {
    geo::Polygon p = box(0.0, 40.0, 30.0, 60.0);
    p.holes.push_back({{10.0, 45.0}, {10.0, 52.0}, {20.0, 52.0}, {20.0, 45.0}});
    add(p);
  }
  // 5: a small field, 1 km across, at (8.5°, 47.3°) (for views from 1 m above ground).
  add(box(8.5, 47.3, 8.5 + 1000.0 / 75500.0, 47.3 + 1000.0 / 111200.0));
  return out;
}

inline geo::Feature lineFeature(std::vector<glm::dvec2> points) {
  geo::Feature f;
  f.lines.push_back(std::move(points));
  return f;
}

/// Lines to draw 30 km wide: a route over the continent with two joins, one across ±180°, one
/// near the north pole.
inline std::vector<geo::Feature> wideLines() {
  return {lineFeature({{-75.0, -5.0}, {-55.0, -25.0}, {-45.0, -15.0}}), lineFeature({{165.0, -35.0}, {-170.0, -28.0}}),
          lineFeature({{-30.0, 80.0}, {60.0, 88.5}, {150.0, 82.0}})};
}

}  // namespace gis::test::globe_scene
