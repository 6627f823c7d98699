#pragma once
// Small deterministic terrains with the stiff cases (cliffs, a spike, a flat plain, nodata
// holes, a nodata border, extreme heights, far from the frame origin) for terrain and overlay
// tests, built in memory.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "terrain/terrain_grid.hpp"

namespace gis::test {

struct StiffTerrainOptions {
  int width = 257;
  int height = 257;
  double spacing = 20.0;
  unsigned seed = 1;
  bool cliffs = true;
  bool spike = true;
  bool plain = true;
  bool holes = true;
  /// Nodata everywhere outside the disc inscribed in the grid (a DEM clipped to a region).
  bool nodataBorder = false;
  /// When lowest < highest, heights are mapped linearly onto [lowest, highest] (e.g. the Dead
  /// Sea shore to Everest: −430 m to 8,850 m).
  double lowest = 0.0;
  double highest = 0.0;
  /// Frame coordinates of the grid's centre (e.g. a UTM northing near 10^7 m with the frame
  /// origin left at 0).
  glm::dvec2 centre{0.0};
};

inline std::shared_ptr<terrain::TerrainGrid> makeStiffTerrain(const StiffTerrainOptions& o = {}) {
  auto grid = std::make_shared<terrain::TerrainGrid>();
  grid->width = o.width;
  grid->height = o.height;
  grid->origin = o.centre + glm::dvec2(-0.5 * o.spacing * (o.width - 1), 0.5 * o.spacing * (o.height - 1));
  grid->step = glm::dvec2(o.spacing, -o.spacing);
  grid->heights.resize(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height));
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> phase(0.0, 6.283);
  double ph[6];
  for (double& p : ph) p = phase(rng);
  for (int r = 0; r < o.height; ++r) {
    for (int c = 0; c < o.width; ++c) {
      const double x = c / 37.0, y = r / 41.0;
      double h = 120.0 * std::sin(x + ph[0]) * std::cos(0.7 * y + ph[1]) + 40.0 * std::sin(3.1 * x + 2.3 * y + ph[2]) +
                 12.0 * std::sin(9.7 * x - 7.3 * y + ph[3]) + 4.0 * std::cos(23.0 * x + 19.0 * y + ph[4]);
      if (o.cliffs && c > o.width / 3) h += 400.0;       // a vertical cliff along a column
      if (o.cliffs && r > c + o.height / 5) h -= 250.0;  // a diagonal cliff
      if (o.plain) {
        const double dx = c - 0.7 * o.width, dy = r - 0.3 * o.height;
        if (dx * dx + dy * dy < 0.01 * o.width * o.width) h = 55.0;  // perfectly flat lake
      }
      grid->heights[static_cast<std::size_t>(r * o.width + c)] = static_cast<float>(h);
    }
  }
  if (o.spike) grid->heights[static_cast<std::size_t>((o.height / 2) * o.width + o.width / 4)] += 900.0F;
  if (o.holes) {
    for (int r = o.height / 8; r < o.height / 8 + o.height / 10; ++r) {
      for (int c = o.width / 2; c < o.width / 2 + o.width / 12; ++c) {
        grid->heights[static_cast<std::size_t>(r * o.width + c)] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  }
  if (o.lowest < o.highest) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (float h : grid->heights) {
      if (!std::isnan(h)) {
        lo = std::min(lo, h);
        hi = std::max(hi, h);
      }
    }
    const double scale = (o.highest - o.lowest) / std::max(1e-9, static_cast<double>(hi - lo));
    for (float& h : grid->heights) {
      if (!std::isnan(h)) h = static_cast<float>(o.lowest + (h - lo) * scale);
    }
  }
  if (o.nodataBorder) {
    const double cx = 0.5 * (o.width - 1), cy = 0.5 * (o.height - 1), r = 0.5 * std::min(o.width - 1, o.height - 1);
    for (int row = 0; row < o.height; ++row) {
      for (int c = 0; c < o.width; ++c) {
        if ((c - cx) * (c - cx) + (row - cy) * (row - cy) > r * r) {
          grid->heights[static_cast<std::size_t>(row * o.width + c)] = std::numeric_limits<float>::quiet_NaN();
        }
      }
    }
  }
  return grid;
}

}  // namespace gis::test
