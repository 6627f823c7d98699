#include "terrain/height_bounds.hpp"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>

#include "terrain/tile_pager.hpp"

namespace gis::terrain {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

void merge(float& lo, float& hi, float l, float h) {
  lo = std::min(lo, l);
  hi = std::max(hi, h);
}

}  // namespace

MinMaxPyramid::MinMaxPyramid(const TerrainGrid& grid) : grid_(&grid), width_(grid.width), height_(grid.height) {
  build();
}

MinMaxPyramid::MinMaxPyramid(int width, int height, std::span<const float> lo, std::span<const float> hi)
    : width_(width), height_(height), baseLo_(lo), baseHi_(hi) {
  build();
}

void MinMaxPyramid::baseRange(int c, int r, float& lo, float& hi) const {
  if (grid_ != nullptr) {
    const float v = grid_->at(c, r);
    if (!std::isnan(v)) merge(lo, hi, v, v);  // nodata posts (NaN) are ignored
    return;
  }
  const auto i = static_cast<std::size_t>(r) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(c);
  merge(lo, hi, baseLo_[i], baseHi_[i]);
}

void MinMaxPyramid::build() {
  int w = width_, h = height_;
  // Level 0 of the pyramid reduces the base 2×2; the base is the grid's posts or given ranges.
  auto source = [&](std::size_t k, int c, int r, float& lo, float& hi) {
    if (k == 0) {
      if (c < width_ && r < height_) baseRange(c, r, lo, hi);
      return;
    }
    const Level& s = levels_[k - 1];
    if (c < s.width && r < s.height) {
      const auto i = static_cast<std::size_t>(r * s.width + c);
      merge(lo, hi, s.lo[i], s.hi[i]);
    }
  };
  for (std::size_t k = 0; w > 1 || h > 1; ++k) {
    Level level;
    level.width = (w + 1) / 2;
    level.height = (h + 1) / 2;
    const auto n = static_cast<std::size_t>(level.width) * static_cast<std::size_t>(level.height);
    level.lo.assign(n, kInf);
    level.hi.assign(n, -kInf);
    for (int r = 0; r < level.height; ++r) {
      for (int c = 0; c < level.width; ++c) {
        float lo = kInf, hi = -kInf;
        for (int dr = 0; dr < 2; ++dr) {
          for (int dc = 0; dc < 2; ++dc) source(k, 2 * c + dc, 2 * r + dr, lo, hi);
        }
        level.lo[static_cast<std::size_t>(r * level.width + c)] = lo;
        level.hi[static_cast<std::size_t>(r * level.width + c)] = hi;
      }
    }
    levels_.push_back(std::move(level));
    w = levels_.back().width;
    h = levels_.back().height;
  }
}

std::size_t MinMaxPyramid::bytes() const {
  std::size_t b = 0;
  for (const Level& l : levels_) b += (l.lo.size() + l.hi.size()) * sizeof(float);
  return b;
}

void MinMaxPyramid::query(int c0, int r0, int c1, int r1, float& lo, float& hi) const {
  lo = kInf;
  hi = -kInf;
  c0 = std::max(c0, 0);
  r0 = std::max(r0, 0);
  c1 = std::min(c1, width_ - 1);
  r1 = std::min(r1, height_ - 1);
  if (c0 > c1 || r0 > r1) return;
  queryLevel(0, c0, r0, c1, r1, lo, hi);
}

// Level k of the recursion addresses units of 2^k posts (k = 0: posts). Partial rows and columns
// at the rim are read at this level; the aligned interior goes one level up.
void MinMaxPyramid::queryLevel(std::size_t k, int c0, int r0, int c1, int r1, float& lo, float& hi) const {
  if (c0 > c1 || r0 > r1) return;
  auto read = [&](int c, int r) {
    if (k == 0) {
      baseRange(c, r, lo, hi);
      return;
    }
    const Level& l = levels_[k - 1];
    const auto i = static_cast<std::size_t>(r * l.width + c);
    merge(lo, hi, l.lo[i], l.hi[i]);
  };
  const int ac0 = (c0 + 1) / 2, ar0 = (r0 + 1) / 2;          // first whole parent unit
  const int ac1 = (c1 + 1) / 2 - 1, ar1 = (r1 + 1) / 2 - 1;  // last whole parent unit
  if (k >= levels_.size() || ac0 > ac1 || ar0 > ar1 || (c1 - c0 + 1) * (r1 - r0 + 1) <= 16) {
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) read(c, r);
    }
    return;
  }
  const int ic0 = 2 * ac0, ic1 = 2 * ac1 + 1, ir0 = 2 * ar0, ir1 = 2 * ar1 + 1;
  for (int r = r0; r <= r1; ++r) {
    const bool insideRows = r >= ir0 && r <= ir1;
    for (int c = c0; c <= c1; ++c) {
      if (insideRows && c >= ic0 && c <= ic1) {
        c = ic1;  // skip the interior of this row
        continue;
      }
      read(c, r);
    }
  }
  queryLevel(k + 1, ac0, ar0, ac1, ar1, lo, hi);
}

QuadtreeHeightBounds::QuadtreeHeightBounds(std::shared_ptr<const TerrainQuadtree> tree, double exaggeration)
    : tree_(std::move(tree)), exaggeration_(exaggeration) {
  if (const TilePager* pager = tree_->pager()) {
    const TilePyramidFile& file = pager->file();
    pyramid_.emplace(file.cellRangeWidth(), file.cellRangeHeight(), file.cellLo(), file.cellHi());
    hasNodata_ = file.nodataPosts() > 0;
  } else {
    pyramid_.emplace(tree_->grid());
    hasNodata_ =
        std::any_of(tree_->grid().heights.begin(), tree_->grid().heights.end(), [](float h) { return std::isnan(h); });
  }
}

overlay::HeightBounds QuadtreeHeightBounds::globalBounds() const {
  const NodeInfo& root = tree_->info(tree_->root());
  if (!root.hasData) return {0.0, 0.0};
  const double a = root.minHeight * exaggeration_, b = root.maxHeight * exaggeration_;
  return {std::min(a, b), std::max(a, b)};
}

bool QuadtreeHeightBounds::coversFootprint(std::span<const glm::dvec2> footprint) const {
  if (hasNodata_ || footprint.empty()) return false;
  const TerrainGrid& grid = tree_->grid();
  for (const glm::dvec2& p : footprint) {
    const glm::dvec2 g = grid.gridCoordinates(p);
    if (!(g.x >= 0.0 && g.y >= 0.0 && g.x <= grid.width - 1 && g.y <= grid.height - 1)) return false;
  }
  return true;
}

overlay::HeightBounds QuadtreeHeightBounds::boundsOver(std::span<const glm::dvec2> footprint) const {
  return boundsOverLevels(footprint, 0, tree_->rootLevel());
}

overlay::HeightBounds QuadtreeHeightBounds::boundsOverLevels(std::span<const glm::dvec2> footprint, int finestLevel,
                                                             int coarsestLevel) const {
  if (footprint.empty()) return globalBounds();
  const TerrainGrid& grid = tree_->grid();
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec2& p : footprint) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return globalBounds();
    const glm::dvec2 g = grid.gridCoordinates(p);
    lo = glm::min(lo, g);
    hi = glm::max(hi, g);
  }
  float zlo = kInf, zhi = -kInf;
  const int maxPost = std::max(grid.width, grid.height) - 1;
  // Cells of a level (size s posts) meeting the box; a box edge on a cell border meets both.
  auto cellsMeeting = [&](int s, int& c0, int& r0, int& c1, int& r1) {
    c0 = static_cast<int>(std::ceil(lo.x / s)) - 1;
    c1 = static_cast<int>(std::floor(hi.x / s));
    r0 = static_cast<int>(std::ceil(lo.y / s)) - 1;
    r1 = static_cast<int>(std::floor(hi.y / s));
  };
  const int pinned = tree_->pinnedLevel();  // 0 for a tree in memory
  const int first = std::max(finestLevel, 0), last = std::min(coarsestLevel, tree_->rootLevel());
  if (tree_->paged() && first < pinned) {
    // Below the pinned level a paged tree has no posts in memory: every finer cell meeting the
    // box lies in a pinned-level cell meeting it, whose full-resolution range the pyramid holds.
    int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
    cellsMeeting(1 << pinned, c0, r0, c1, r1);
    float l = kInf, h = -kInf;
    pyramid_->query(c0, r0, c1, r1, l, h);
    merge(zlo, zhi, l, h);
  }
  for (int level = tree_->paged() ? std::max(first, pinned) : first; level <= last; ++level) {
    const int s = 1 << level;
    int cc0 = 0, cr0 = 0, cc1 = 0, cr1 = 0;
    cellsMeeting(s, cc0, cr0, cc1, cr1);
    // Their corner posts, as post indices of this level.
    const int p0c = std::max(cc0, 0), p1c = std::min(cc1 + 1, maxPost / s + 1);
    const int p0r = std::max(cr0, 0), p1r = std::min(cr1 + 1, maxPost / s + 1);
    if (p0c > p1c || p0r > p1r) continue;
    const long long count = static_cast<long long>(p1c - p0c + 1) * (p1r - p0r + 1);
    float l = kInf, h = -kInf;
    if (count <= 256 && (tree_->paged() || level > 0)) {
      for (int r = p0r; r <= p1r; ++r) {
        for (int c = p0c; c <= p1c; ++c) {
          const float v = tree_->levelPost(level, c, r);
          if (!std::isnan(v)) merge(l, h, v, v);
        }
      }
    } else if (!tree_->paged()) {
      // Every post in the rectangle: exact at level 0, a superset of the corners above it.
      pyramid_->query(p0c * s, p0r * s, p1c * s, p1r * s, l, h);
    } else {
      // The pinned-level cells holding the rectangle's posts (a superset of the corners).
      const int cs = 1 << pinned;
      pyramid_->query(p0c * s / cs, p0r * s / cs, p1c * s / cs, p1r * s / cs, l, h);
    }
    merge(zlo, zhi, l, h);
  }
  if (zlo > zhi) return globalBounds();  // only nodata below: nothing is drawn there
  const double a = zlo * exaggeration_, b = zhi * exaggeration_;
  return {std::min(a, b), std::max(a, b)};
}

double QuadtreeHeightBounds::fullResolutionHeightAt(const glm::dvec2& frameXy) const {
  const glm::dvec2 g = tree_->grid().gridCoordinates(frameXy);
  if (g.x < 0.0 || g.y < 0.0 || g.x > tree_->grid().width - 1 || g.y > tree_->grid().height - 1) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return tree_->levelSurface(0, g.x, g.y) * exaggeration_;
}

}  // namespace gis::terrain
