#pragma once
// The geometry rows of the robustness case matrix (docs/robustness.md): messy and extreme
// polygons and roads placed over a terrain's extent, each with what must happen to it. Shared
// by the unit test (pieces closed, outward, bounded, covering what the reference covers) and the
// GL test (pixels against the CPU reference from extreme cameras).
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "geo/vector.hpp"
#include "vector_overlay/style.hpp"

namespace gis::test {

/// What a case must give.
enum class Outcome {
  Drawn,             ///< pieces, no error
  DrawnWithWarning,  ///< pieces, a Warning (e.g. an unusable width attribute: the layer's width is used)
  Skipped,           ///< no pieces, an Error naming layer and feature
  PartlyDrawn,       ///< pieces for the good parts, an Error for the bad ones
  NothingThere,      ///< no pieces (outside the terrain, or an empty feature), a Warning saying so
};

struct GeometryCase {
  std::string name;
  overlay::LayerKind kind = overlay::LayerKind::Polygon;
  geo::Feature feature;  ///< lines: width in attribute "width_m"
  Outcome outcome = Outcome::Drawn;
};

/// The cases over the square [lo, hi] (a terrain's extent). Line widths are in the feature's
/// "width_m" attribute; fids are the case's index.
inline std::vector<GeometryCase> geometryCases(const glm::dvec2& lo, const glm::dvec2& hi) {
  const glm::dvec2 size = hi - lo;
  auto at = [&](double fx, double fy) { return lo + glm::dvec2(fx, fy) * size; };
  auto ring = [&](std::initializer_list<std::pair<double, double>> fractions) {
    geo::Ring r;
    for (const auto& [fx, fy] : fractions) r.push_back(at(fx, fy));
    return r;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  std::vector<GeometryCase> cases;
  auto polygon = [&](std::string name, std::vector<geo::Polygon> polygons, Outcome outcome) {
    GeometryCase c;
    c.name = std::move(name);
    c.feature.polygons = std::move(polygons);
    c.outcome = outcome;
    cases.push_back(std::move(c));
  };
  auto line = [&](std::string name, std::vector<geo::LineString> lines, double width, Outcome outcome) {
    GeometryCase c;
    c.name = std::move(name);
    c.kind = overlay::LayerKind::Line;
    c.feature.lines = std::move(lines);
    c.feature.attributes["width_m"] = width;
    c.outcome = outcome;
    cases.push_back(std::move(c));
  };

  // ---- polygons
  polygon("bow-tie (self-intersecting)", {{ring({{0.05, 0.05}, {0.2, 0.2}, {0.2, 0.05}, {0.05, 0.2}}), {}}},
          Outcome::Drawn);
  polygon("duplicate and collinear points",
          {{ring({{0.25, 0.05},
                  {0.25, 0.05},
                  {0.3, 0.05},
                  {0.35, 0.05},
                  {0.4, 0.05},
                  {0.4, 0.05},
                  {0.4, 0.12},
                  {0.4, 0.2},
                  {0.25, 0.2},
                  {0.25, 0.2},
                  {0.25, 0.05}}),
            {}}},
          Outcome::Drawn);
  polygon("zero-area ring", {{ring({{0.45, 0.05}, {0.5, 0.1}, {0.55, 0.15}, {0.5, 0.1}}), {}}}, Outcome::Skipped);
  polygon("hole touching the shell at a vertex and along an edge",
          {{ring({{0.6, 0.05}, {0.8, 0.05}, {0.8, 0.2}, {0.6, 0.2}}),
            {ring({{0.6, 0.05}, {0.7, 0.1}, {0.65, 0.15}}), ring({{0.75, 0.2}, {0.8, 0.12}, {0.8, 0.2}})}}},
          Outcome::Drawn);
  polygon("spike (zero-width excursion)",
          {{ring({{0.05, 0.3}, {0.2, 0.3}, {0.2, 0.37}, {0.35, 0.375}, {0.2, 0.37}, {0.2, 0.45}, {0.05, 0.45}}), {}}},
          Outcome::Drawn);
  polygon("sliver 1 mm wide", {{ring({{0.4, 0.3}, {0.55, 0.45}, {0.55 + 1e-3 / size.x, 0.45}}), {}}}, Outcome::Drawn);
  polygon("NaN coordinate", {{{at(0.6, 0.3), glm::dvec2(nan, at(0, 0.4).y), at(0.7, 0.4)}, {}}}, Outcome::Skipped);
  polygon("infinite coordinate", {{{at(0.6, 0.3), glm::dvec2(inf, at(0, 0.4).y), at(0.7, 0.4)}, {}}}, Outcome::Skipped);
  polygon("absurd coordinates (1e300 m)", {{{glm::dvec2(1e300, 0.0), glm::dvec2(0.0, 1e300), glm::dvec2(-1e300)}, {}}},
          Outcome::Skipped);
  polygon("one good part, one NaN part",
          {{ring({{0.75, 0.3}, {0.9, 0.3}, {0.9, 0.45}}), {}}, {{glm::dvec2(nan), at(0.8, 0.4), at(0.85, 0.45)}, {}}},
          Outcome::PartlyDrawn);
  polygon("covering the whole DEM", {{ring({{-0.5, -0.5}, {1.5, -0.5}, {1.5, 1.5}, {-0.5, 1.5}}), {}}}, Outcome::Drawn);
  polygon("lying outside the DEM", {{ring({{1.2, 1.2}, {1.4, 1.2}, {1.4, 1.4}}), {}}}, Outcome::NothingThere);
  polygon("straddling the DEM's edge", {{ring({{-0.1, 0.5}, {0.1, 0.5}, {0.1, 0.6}, {-0.1, 0.6}}), {}}},
          Outcome::Drawn);
  polygon("flat ground (on the lake)", {{ring({{0.67, 0.67}, {0.73, 0.67}, {0.73, 0.73}, {0.67, 0.73}}), {}}},
          Outcome::Drawn);
  polygon("empty geometry", {}, Outcome::NothingThere);

  // ---- roads
  line("hairpin turns", {{at(0.05, 0.55), at(0.3, 0.55), at(0.05, 0.56), at(0.3, 0.57)}}, 12.0, Outcome::Drawn);
  line("zero-length segments", {{at(0.35, 0.55), at(0.35, 0.55), at(0.5, 0.6), at(0.5, 0.6), at(0.5, 0.6)}}, 10.0,
       Outcome::Drawn);
  {
    geo::LineString zigzag;
    for (int k = 0; k < 40; ++k) zigzag.push_back(at(0.55 + 0.004 * k, 0.55) + glm::dvec2(0.0, (k % 2) * 1.0));
    line("width 30 m over 1 m segments", {zigzag}, 30.0, Outcome::Drawn);
  }
  line("width 1 cm", {{at(0.75, 0.55), at(0.95, 0.62), at(0.8, 0.7)}}, 0.01, Outcome::Drawn);
  line("width 5 km", {{at(0.3, 0.8), at(0.6, 0.85)}}, 5000.0, Outcome::Drawn);
  line("single point", {{at(0.1, 0.7)}}, 40.0, Outcome::Drawn);
  line("one good line, one NaN line", {{at(0.1, 0.8), at(0.25, 0.9)}, {at(0.2, 0.8), glm::dvec2(nan, 0.0)}}, 8.0,
       Outcome::PartlyDrawn);
  line("negative width attribute", {{at(0.7, 0.8), at(0.9, 0.9)}}, -5.0, Outcome::DrawnWithWarning);
  line("absurd width (1e20 m)", {{at(0.7, 0.85), at(0.9, 0.95)}}, 1e20, Outcome::Skipped);
  line("lying outside the DEM", {{at(-0.5, -0.5), at(-0.3, -0.2)}}, 10.0, Outcome::NothingThere);
  line("text width attribute", {{at(0.6, 0.95), at(0.9, 0.97)}}, 0.0, Outcome::DrawnWithWarning);
  cases.back().feature.attributes["width_m"] = std::string("wide");

  for (std::size_t i = 0; i < cases.size(); ++i) cases[i].feature.fid = static_cast<std::int64_t>(i);
  return cases;
}

/// A star-shaped polygon of `n` vertices around `centre` (radius between 0.6 r and r).
inline geo::Feature starPolygon(const glm::dvec2& centre, double r, int n) {
  geo::Feature f;
  f.fid = 1000;
  geo::Polygon p;
  p.outer.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double a = 6.283185307179586 * k / n;
    const double rr = r * (0.8 + 0.2 * std::sin(977.0 * a) * std::cos(13.0 * a));
    p.outer.push_back(centre + rr * glm::dvec2(std::cos(a), std::sin(a)));
  }
  f.polygons.push_back(std::move(p));
  return f;
}

}  // namespace gis::test
