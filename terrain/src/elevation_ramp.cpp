#include "terrain/elevation_ramp.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "terrain/quadtree.hpp"

namespace gis::terrain {

ElevationRamp::ElevationRamp(std::vector<RampStop> stops) : stops_(std::move(stops)) {
  assert(stops_.size() >= 2 && stops_.size() <= kMaxStops);
  assert(stops_.front().t == 0.0 && stops_.back().t == 1.0);
  assert(std::adjacent_find(stops_.begin(), stops_.end(),
                            [](const RampStop& a, const RampStop& b) { return !(a.t < b.t); }) == stops_.end());
}

const ElevationRamp& ElevationRamp::hypsometric() {
  static const ElevationRamp ramp({{0.0, glm::vec3(0.08F, 0.33F, 0.45F)},
                                   {0.25, glm::vec3(0.46F, 0.68F, 0.36F)},
                                   {0.5, glm::vec3(0.92F, 0.87F, 0.56F)},
                                   {0.75, glm::vec3(0.50F, 0.33F, 0.21F)},
                                   {1.0, glm::vec3(0.97F, 0.97F, 0.97F)}});
  return ramp;
}

glm::vec3 ElevationRamp::colorAt(double t) const {
  // As terrain_chunk.frag: the first segment whose upper stop reaches t, mix(a, b, f).
  const double u = std::isnan(t) ? 0.0 : std::clamp(t, 0.0, 1.0);
  std::size_t k = 1;
  while (k + 1 < stops_.size() && u > stops_[k].t) ++k;
  const RampStop& a = stops_[k - 1];
  const RampStop& b = stops_[k];
  const double f = std::clamp((u - a.t) / (b.t - a.t), 0.0, 1.0);
  return glm::vec3(glm::dvec3(a.color) * (1.0 - f) + glm::dvec3(b.color) * f);
}

double ElevationRamp::normalised(double height, double low, double high) {
  if (!(high > low) || std::isnan(height)) return 0.0;
  return std::clamp((height - low) / (high - low), 0.0, 1.0);
}

std::optional<std::pair<double, double>> demHeightRange(const TerrainQuadtree& tree) {
  const NodeInfo& root = tree.info(tree.root());
  if (!root.hasData) return std::nullopt;
  return std::pair<double, double>(root.minHeight, root.maxHeight);
}

}  // namespace gis::terrain
