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

/// Convex hull (counter-clockwise, no repeated points) of points; fewer than 3 points when they
/// are collinear.
std::vector<glm::dvec2> convexHull(std::vector<glm::dvec2> pts) {
  std::sort(pts.begin(), pts.end(),
            [](const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 3) return pts;
  auto cross = [](const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
  };
  std::vector<glm::dvec2> hull(2 * pts.size());
  std::size_t k = 0;
  for (const glm::dvec2& p : pts) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p) <= 0.0) --k;
    hull[k++] = p;
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {  // upper chain
    while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0.0) --k;
    hull[k++] = pts[i];
  }
  hull.resize(k - 1);
  return hull;
}

/// Clips a convex polygon to the half-plane side · (coordinate axis of p) ≤ side · bound.
void clipAxis(std::vector<glm::dvec2>& poly, std::vector<glm::dvec2>& scratch, int axis, double bound, double side) {
  scratch.clear();
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2& a = poly[i];
    const glm::dvec2& b = poly[(i + 1) % n];
    const double da = side * (a[axis] - bound), db = side * (b[axis] - bound);
    if (da <= 0.0) scratch.push_back(a);
    if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) scratch.push_back(a + (da / (da - db)) * (b - a));
  }
  poly.swap(scratch);
}

/// Cells of a level whose surface is evaluated exactly over the footprint; beyond, the
/// footprint is large next to the cells and their corner range is as tight.
constexpr long long kMaxExactCells = 2048;

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

HeightBounds QuadtreeHeightBounds::globalBounds() const {
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

HeightBounds QuadtreeHeightBounds::boundsOver(std::span<const glm::dvec2> footprint) const {
  return boundsOverLevels(footprint, 0, tree_->rootLevel());
}

HeightBounds QuadtreeHeightBounds::boundsOverWithin(std::span<const glm::dvec2> footprint, double slackMetres) const {
  const TerrainGrid& grid = tree_->grid();
  const double spacing = std::min(std::abs(grid.step.x), std::abs(grid.step.y));
  // Level l's surface over the footprint is made of its cells meeting it, or their parents'
  // posts where stitched: all within 2^(l+1) · √2 posts of it. Those levels are bounded by every
  // post within the slack (at least 3 posts, for level 0); the coarser ones exactly.
  if (!(slackMetres >= spacing) || tree_->paged() || footprint.empty()) return boundsOver(footprint);
  const double slack = std::max(3.0, slackMetres / spacing);  // in posts
  int fast = -1;
  while (fast < tree_->rootLevel() && std::ldexp(1.5, fast + 2) <= slack) ++fast;
  std::vector<glm::dvec2> hull;
  hull.reserve(footprint.size());
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec2& p : footprint) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return globalBounds();
    hull.push_back(grid.gridCoordinates(p));
    lo = glm::min(lo, hull.back());
    hi = glm::max(hi, hull.back());
  }
  hull = convexHull(std::move(hull));
  float zlo = kInf, zhi = -kInf;
  // Bands of rows: each reads the posts in its rows whose columns lie within the slack of the
  // hull's part in the band widened by the slack (a post within the slack of the hull lies in
  // that rectangle).
  const double band = std::max(1.0, std::floor(slack));
  std::vector<glm::dvec2> part, scratch;
  for (double y0 = std::floor(lo.y - slack); y0 <= hi.y + slack; y0 += band) {
    part = hull;
    if (hull.size() >= 3) {
      clipAxis(part, scratch, 1, y0 - slack, -1.0);
      clipAxis(part, scratch, 1, y0 + band + slack, 1.0);
    }
    if (part.empty()) continue;
    double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo;
    for (const glm::dvec2& p : part) {
      xlo = std::min(xlo, p.x);
      xhi = std::max(xhi, p.x);
    }
    float l = kInf, h = -kInf;
    pyramid_->query(static_cast<int>(std::floor(xlo - slack)), static_cast<int>(y0),
                    static_cast<int>(std::ceil(xhi + slack)), static_cast<int>(y0 + band), l, h);
    merge(zlo, zhi, l, h);
  }
  HeightBounds out{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  if (zlo <= zhi) {
    const double a = zlo * exaggeration_, b = zhi * exaggeration_;
    out = {std::min(a, b), std::max(a, b)};
  }
  if (fast < tree_->rootLevel()) {
    const HeightBounds coarse = boundsOverLevels(footprint, fast + 1, tree_->rootLevel());
    out = {std::min(out.lo, coarse.lo), std::max(out.hi, coarse.hi)};
  }
  return out.valid() ? out : globalBounds();
}

HeightBounds QuadtreeHeightBounds::boundsOverLevels(std::span<const glm::dvec2> footprint, int finestLevel,
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
  std::vector<glm::dvec2> hull;
  for (int level = tree_->paged() ? std::max(first, pinned) : first; level <= last; ++level) {
    const int s = 1 << level;
    int cc0 = 0, cr0 = 0, cc1 = 0, cr1 = 0;
    cellsMeeting(s, cc0, cr0, cc1, cr1);
    if (static_cast<long long>(cc1 - cc0 + 1) * (cr1 - cr0 + 1) <= kMaxExactCells) {
      if (hull.empty()) {
        std::vector<glm::dvec2> g;
        g.reserve(footprint.size());
        for (const glm::dvec2& p : footprint) g.push_back(grid.gridCoordinates(p));
        hull = convexHull(std::move(g));
      }
      if (hull.size() >= 3) {
        float l = kInf, h = -kInf;
        exactLevelRange(hull, level, cc0, cr0, cc1, cr1, l, h);
        if (l <= h) {
          merge(zlo, zhi, l, h);
          continue;
        }
        // Nothing of this level is drawn there (nodata): any bound is sound; the posts near
        // the footprint (below) give a tight one.
      }
    }
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

// The level's surface over a cell is two triangles split by the diagonal from corner (c, r) to
// (c + 1, r + 1) (interpolateCell); over the part of the footprint's hull in the cell it is
// linear on each side of the diagonal, so its extremes lie at the vertices of that part or where
// its boundary crosses the diagonal. Cells with a nodata corner are not drawn. A cell on the rim
// of a chunk may be stitched to the coarser neighbour (odd rim vertices collapse onto their even
// predecessor): the triangles over it then have their vertices among the 3 × 3 posts of its
// parent cell (level + 1), so those count as well.
void QuadtreeHeightBounds::exactLevelRange(const std::vector<glm::dvec2>& hull, int level, int c0, int r0, int c1,
                                           int r1, float& lo, float& hi) const {
  const double s = static_cast<double>(1 << level);
  const int n = tree_->chunkCells();
  const bool stitchable = level < tree_->rootLevel();
  std::vector<glm::dvec2> row, part, scratch;
  auto corner = [&](int c, int r) { return tree_->levelPost(level, c, r); };
  for (int r = r0; r <= r1; ++r) {
    // The hull within the row, then only the row's cells it reaches (a thin diagonal piece
    // meets a few cells of each row of its box).
    row = hull;
    clipAxis(row, scratch, 1, r * s, -1.0);
    clipAxis(row, scratch, 1, (r + 1) * s, 1.0);
    if (row.empty()) continue;
    double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo;
    for (const glm::dvec2& p : row) {
      xlo = std::min(xlo, p.x);
      xhi = std::max(xhi, p.x);
    }
    // A vertex on a cell border meets both cells (as cellsMeeting counts them).
    const int rc0 = std::max(c0, static_cast<int>(std::ceil(xlo / s)) - 1);
    const int rc1 = std::min(c1, static_cast<int>(std::floor(xhi / s)));
    for (int c = rc0; c <= rc1; ++c) {
      const float a = corner(c, r), b = corner(c + 1, r), d = corner(c, r + 1), e = corner(c + 1, r + 1);
      if (std::isnan(a) || std::isnan(b) || std::isnan(d) || std::isnan(e)) continue;
      part = row;
      clipAxis(part, scratch, 0, c * s, -1.0);
      clipAxis(part, scratch, 0, (c + 1) * s, 1.0);
      if (part.empty()) continue;
      auto surface = [&](const glm::dvec2& g) {
        const double fx = std::clamp(g.x / s - c, 0.0, 1.0), fy = std::clamp(g.y / s - r, 0.0, 1.0);
        const auto z = static_cast<float>(interpolateCell(a, b, d, e, fx, fy));
        merge(lo, hi, z, z);
      };
      for (std::size_t i = 0; i < part.size(); ++i) {
        const glm::dvec2& p = part[i];
        const glm::dvec2& q = part[(i + 1) % part.size()];
        surface(p);
        const double dp = (p.x / s - c) - (p.y / s - r), dq = (q.x / s - c) - (q.y / s - r);
        if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) surface(p + (dp / (dp - dq)) * (q - p));
      }
      const int ci = ((c % n) + n) % n, ri = ((r % n) + n) % n;
      if (stitchable && (ci == 0 || ci == n - 1 || ri == 0 || ri == n - 1)) {
        const int pc = c - (((c % 2) + 2) % 2), pr = r - (((r % 2) + 2) % 2);
        for (int rr = pr; rr <= pr + 2; ++rr) {
          for (int cc = pc; cc <= pc + 2; ++cc) {
            const float v = corner(cc, rr);
            if (!std::isnan(v)) merge(lo, hi, v, v);
          }
        }
      }
    }
  }
}

double QuadtreeHeightBounds::fullResolutionHeightAt(const glm::dvec2& frameXy) const {
  const glm::dvec2 g = tree_->grid().gridCoordinates(frameXy);
  if (g.x < 0.0 || g.y < 0.0 || g.x > tree_->grid().width - 1 || g.y > tree_->grid().height - 1) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return tree_->levelSurface(0, g.x, g.y) * exaggeration_;
}

}  // namespace gis::terrain
