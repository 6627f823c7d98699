#include "terrain/geometric_error.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>

#include <glm/geometric.hpp>

#include "terrain/quadtree.hpp"

namespace gis::terrain {

double simplificationError(std::span<const float> posts, int n, const glm::dvec2& childSpacing) {
  const int side = 2 * n + 1;
  assert(posts.size() == static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  auto at = [&](int i, int j) {
    return static_cast<double>(
        posts[static_cast<std::size_t>(j) * static_cast<std::size_t>(side) + static_cast<std::size_t>(i)]);
  };
  const double diagonal = 2.0 * glm::length(childSpacing);
  double worst = 0.0;
  for (int cj = 0; cj < n; ++cj) {
    for (int ci = 0; ci < n; ++ci) {
      const int i0 = 2 * ci, j0 = 2 * cj;
      const double a = at(i0, j0), b = at(i0 + 2, j0), d = at(i0, j0 + 2), e = at(i0 + 2, j0 + 2);
      if (std::isnan(a) || std::isnan(b) || std::isnan(d) || std::isnan(e)) {
        // Not drawn coarse: where a child cell in it is drawn, the edge of the data moves by up
        // to the cell's diagonal (a DEM's nodata border, a hole's rim).
        bool childDrawn = false;
        for (int dj = 0; dj <= 1 && !childDrawn; ++dj) {
          for (int di = 0; di <= 1 && !childDrawn; ++di) {
            childDrawn = !std::isnan(at(i0 + di, j0 + dj)) && !std::isnan(at(i0 + di + 1, j0 + dj)) &&
                         !std::isnan(at(i0 + di, j0 + dj + 1)) && !std::isnan(at(i0 + di + 1, j0 + dj + 1));
          }
        }
        if (childDrawn) worst = std::max(worst, diagonal);
        continue;
      }
      const double cmin = std::min({a, b, d, e}), cmax = std::max({a, b, d, e});
      double vertical = 0.0, fmin = cmin, fmax = cmax;
      bool complete = true;
      for (int dj = 0; dj <= 2; ++dj) {
        for (int di = 0; di <= 2; ++di) {
          const double h = at(i0 + di, j0 + dj);
          if (std::isnan(h)) {
            complete = false;
            continue;
          }
          const double coarse = interpolateCell(a, b, d, e, 0.5 * di, 0.5 * dj);
          vertical = std::max(vertical, std::abs(coarse - h));
          fmin = std::min(fmin, h);
          fmax = std::max(fmax, h);
        }
      }
      const double excess = std::max({0.0, fmax - cmax, cmin - fmin});
      // Drawn coarse over a child-level hole: the hole's edge moves by up to the diagonal too.
      worst = std::max(worst, complete ? std::min(vertical, diagonal + excess) : std::max(vertical, diagonal));
    }
  }
  return worst;
}

}  // namespace gis::terrain
