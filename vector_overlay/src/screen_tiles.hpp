#pragma once
// Where a pass that colours whole screen regions needs to run: the screen rectangles of boxes,
// gathered on a grid of tiles and merged into disjoint rectangles (the stencil covers of
// overlay_renderer.cpp and the deferred technique's passes).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/common.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace gis::overlay {

/// The normalised-device rectangle (x0, y0, x1, y1) holding the box's projection, clamped to the
/// screen; the whole screen when a corner is closer to the eye plane than half the near distance
/// (or behind it). Empty (x1 < x0) when the box projects off screen.
inline glm::vec4 screenRect(const glm::dmat4& viewProj, double nearPlane, const glm::dvec3& lo, const glm::dvec3& hi) {
  glm::dvec2 a(1.0), b(-1.0);
  for (int k = 0; k < 8; ++k) {
    const glm::dvec4 c =
        viewProj * glm::dvec4((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y, (k & 4) != 0 ? hi.z : lo.z, 1.0);
    if (!(c.w > 0.5 * nearPlane)) return {-1.0F, -1.0F, 1.0F, 1.0F};
    const glm::dvec2 ndc(c.x / c.w, c.y / c.w);
    a = glm::min(a, ndc);
    b = glm::max(b, ndc);
  }
  // No slack for rounding is needed: the pass decides per pixel, the rectangle only has to hold
  // every pixel it may colour, and the box holds everything drawn.
  a = glm::clamp(a, glm::dvec2(-1.0), glm::dvec2(1.0));
  b = glm::clamp(b, glm::dvec2(-1.0), glm::dvec2(1.0));
  return {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(b.x), static_cast<float>(b.y)};
}

/// An n × n grid of screen tiles: add rectangles, get the touched tiles as disjoint rectangles
/// (runs of tiles per row, equal runs one above the other merged).
class ScreenTiles {
 public:
  explicit ScreenTiles(int n) : n_(n), touched_(static_cast<std::size_t>(n) * static_cast<std::size_t>(n), 0) {}

  void add(const glm::vec4& r) {
    if (!(r.z >= r.x && r.w >= r.y)) return;
    const int x0 = tile(r.x), x1 = tile(r.z), y0 = tile(r.y), y1 = tile(r.w);
    for (int y = y0; y <= y1; ++y) std::fill_n(touched_.begin() + y * n_ + x0, x1 - x0 + 1, std::uint8_t{1});
  }

  [[nodiscard]] std::vector<glm::vec4> rects() const {
    // Tile edges from one formula, so neighbouring rectangles share their edges exactly (no
    // pixel is drawn twice or missed).
    const int n = n_;
    const auto edge = [n](int i) {
      return i == n ? 1.0F : -1.0F + 2.0F * static_cast<float>(i) / static_cast<float>(n);
    };
    std::vector<glm::vec4> rects;
    std::vector<glm::ivec3> open;  // runs (x0, x1, rect index) of the row below
    for (int y = 0; y < n; ++y) {
      std::vector<glm::ivec3> row;
      for (int x = 0; x < n;) {
        if (touched_[static_cast<std::size_t>(y * n + x)] == 0) {
          ++x;
          continue;
        }
        const int x0 = x;
        while (x < n && touched_[static_cast<std::size_t>(y * n + x)] != 0) ++x;
        // The same run in the row below: grow that rectangle up.
        const auto below =
            std::find_if(open.begin(), open.end(), [&](const glm::ivec3& r) { return r.x == x0 && r.y == x; });
        if (below != open.end()) {
          rects[static_cast<std::size_t>(below->z)].w = edge(y + 1);
          row.push_back(*below);
        } else {
          row.push_back({x0, x, static_cast<int>(rects.size())});
          rects.push_back({edge(x0), edge(y), edge(x), edge(y + 1)});
        }
      }
      open = std::move(row);
    }
    return rects;
  }

 private:
  [[nodiscard]] int tile(float ndc) const {
    return std::clamp(static_cast<int>(std::floor((ndc + 1.0F) * 0.5F * static_cast<float>(n_))), 0, n_ - 1);
  }

  int n_;
  std::vector<std::uint8_t> touched_;
};

}  // namespace gis::overlay
