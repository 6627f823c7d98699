// simplificationError (terrain/geometric_error.hpp) checked by brute force. On many small random
// windows (cliffs of hundreds of metres, spikes, flat, terraces, noise, nodata posts) the 3D
// Hausdorff distance between the coarse surface and the child-level surface, estimated by dense
// sampling of both surfaces with exact point-to-triangle distances to the other one, never
// exceeds the bound, also under vertical exaggeration. And the bound is not loose where it
// should not be: a vertical cliff costs about one coarse cell diagonal, not its height; smooth
// terrain gets exactly the vertical error.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "terrain/geometric_error.hpp"
#include "terrain/quadtree.hpp"
#include "triangle_distance.hpp"

namespace gis::test {
namespace {

using terrain::exaggeratedError;
using terrain::interpolateCell;
using terrain::simplificationError;
using Triangle = std::array<glm::dvec3, 3>;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

double distanceToTriangle(const glm::dvec3& p, const Triangle& t) {
  return glm::length(p - closestPointOnTriangle(p, t[0], t[1], t[2]));
}

TEST(PointTriangleDistance, MatchesDenseSampling) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Triangle t{glm::dvec3(u(rng), u(rng), u(rng)), glm::dvec3(u(rng), u(rng), u(rng)),
                     glm::dvec3(u(rng), u(rng), u(rng))};
    const glm::dvec3 p(u(rng), u(rng), u(rng));
    const double exact = distanceToTriangle(p, t);
    double sampled = std::numeric_limits<double>::infinity();
    constexpr int m = 200;
    for (int i = 0; i <= m; ++i) {
      for (int j = 0; i + j <= m; ++j) {
        const glm::dvec3 q = (t[0] * double(i) + t[1] * double(j) + t[2] * double(m - i - j)) / double(m);
        sampled = std::min(sampled, glm::length(p - q));
      }
    }
    ASSERT_LE(exact, sampled + 1e-9);
    ASSERT_GE(exact, sampled - 0.2);  // the sampling step is ≤ 20·√2/200
  }
}

/// A node's (2n + 1)² child-level posts, row-major, NaN at nodata.
struct Window {
  int n = 2;
  glm::dvec2 spacing{20.0, 20.0};
  std::vector<float> posts;
  [[nodiscard]] int side() const { return 2 * n + 1; }
  [[nodiscard]] float at(int i, int j) const { return posts[static_cast<std::size_t>(j * side() + i)]; }
  float& at(int i, int j) { return posts[static_cast<std::size_t>(j * side() + i)]; }
};

Window makeWindow(int n, glm::dvec2 spacing, float fill = 0.0F) {
  Window w;
  w.n = n;
  w.spacing = spacing;
  w.posts.assign(static_cast<std::size_t>(w.side() * w.side()), fill);
  return w;
}

/// The coarse surface of coarse cell (ci, cj) at child post (i, j) of that cell.
double coarseAt(const Window& w, int ci, int cj, int i, int j) {
  const int i0 = 2 * ci, j0 = 2 * cj;
  return interpolateCell(w.at(i0, j0), w.at(i0 + 2, j0), w.at(i0, j0 + 2), w.at(i0 + 2, j0 + 2), 0.5 * (i - i0),
                         0.5 * (j - j0));
}

struct BruteForce {
  double hausdorff = 0.0;  ///< the larger of the two sampled one-sided distances
  double vertical = 0.0;   ///< largest |coarse − child| at the valid child posts of drawn coarse cells
};

/// Both surfaces as triangles, by coarse cell, with heights times k; then the two one-sided
/// distances sampled on an m-step barycentric grid of every child triangle drawn at both levels
/// (the coarse surface is linear over each child triangle: the child triangulation refines the
/// coarse one). Conventions as simplificationError's: a coarse cell with a nodata corner is not
/// drawn and is skipped; a child cell is drawn when its four posts are valid; over child cells
/// not drawn inside a drawn coarse cell (a hole filled at the coarse level) nothing is compared.
BruteForce bruteForce(const Window& w, double k = 1.0, int m = 5) {
  const int n = w.n;
  auto position = [&](int i, int j, double h) { return glm::dvec3(i * w.spacing.x, j * w.spacing.y, k * h); };
  auto valid = [&](int i, int j) { return !std::isnan(w.at(i, j)); };
  auto cellIndex = [&](int ci, int cj) { return static_cast<std::size_t>(cj * n + ci); };
  std::vector<std::vector<Triangle>> coarse(static_cast<std::size_t>(n * n)), child(coarse.size());
  std::vector<Triangle> childSources, coarseSources;  // the same footprints, child and coarse heights
  std::vector<std::size_t> sourceCell;                // their coarse cell
  double vertical = 0.0;
  for (int cj = 0; cj < n; ++cj) {
    for (int ci = 0; ci < n; ++ci) {
      const int i0 = 2 * ci, j0 = 2 * cj;
      const bool coarseDrawn = valid(i0, j0) && valid(i0 + 2, j0) && valid(i0, j0 + 2) && valid(i0 + 2, j0 + 2);
      if (coarseDrawn) {
        const glm::dvec3 a = position(i0, j0, w.at(i0, j0)), b = position(i0 + 2, j0, w.at(i0 + 2, j0));
        const glm::dvec3 d = position(i0, j0 + 2, w.at(i0, j0 + 2)), e = position(i0 + 2, j0 + 2, w.at(i0 + 2, j0 + 2));
        coarse[cellIndex(ci, cj)] = {Triangle{a, d, e}, Triangle{a, e, b}};
        for (int j = j0; j <= j0 + 2; ++j) {
          for (int i = i0; i <= i0 + 2; ++i) {
            if (valid(i, j)) vertical = std::max(vertical, std::abs(w.at(i, j) - coarseAt(w, ci, cj, i, j)));
          }
        }
      }
      for (int j = j0; j < j0 + 2; ++j) {
        for (int i = i0; i < i0 + 2; ++i) {
          if (!(valid(i, j) && valid(i + 1, j) && valid(i, j + 1) && valid(i + 1, j + 1))) continue;
          const std::array<std::array<int, 2>, 3> t0{{{i, j}, {i, j + 1}, {i + 1, j + 1}}};
          const std::array<std::array<int, 2>, 3> t1{{{i, j}, {i + 1, j + 1}, {i + 1, j}}};
          for (const auto& t : {t0, t1}) {
            Triangle fine, rough;
            for (std::size_t v = 0; v < 3; ++v) {
              fine[v] = position(t[v][0], t[v][1], w.at(t[v][0], t[v][1]));
              rough[v] = position(t[v][0], t[v][1], coarseAt(w, ci, cj, t[v][0], t[v][1]));
            }
            child[cellIndex(ci, cj)].push_back(fine);
            if (coarseDrawn) {
              childSources.push_back(fine);
              coarseSources.push_back(rough);
              sourceCell.push_back(cellIndex(ci, cj));
            }
          }
        }
      }
    }
  }
  BruteForce out;
  out.vertical = vertical;
  // Distance from p to the union of `cells`' triangles: the own cell first, then the cells whose
  // bounding box is nearer than the best distance so far.
  struct Box {
    glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
  };
  auto boxes = [&](const std::vector<std::vector<Triangle>>& cells) {
    std::vector<Box> result(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
      for (const Triangle& t : cells[c]) {
        for (const glm::dvec3& v : t) {
          result[c].lo = glm::min(result[c].lo, v);
          result[c].hi = glm::max(result[c].hi, v);
        }
      }
    }
    return result;
  };
  const std::vector<Box> coarseBoxes = boxes(coarse), childBoxes = boxes(child);
  auto distanceTo = [&](const std::vector<std::vector<Triangle>>& cells, const std::vector<Box>& cellBoxes,
                        std::size_t start, const glm::dvec3& p) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t visit = 0; visit < cells.size(); ++visit) {
      const std::size_t c = visit == 0 ? start : (visit == start ? 0 : visit);  // the own cell first
      if (cells[c].empty() || glm::length(p - glm::clamp(p, cellBoxes[c].lo, cellBoxes[c].hi)) >= best) continue;
      for (const Triangle& t : cells[c]) best = std::min(best, distanceToTriangle(p, t));
    }
    return best;
  };
  for (std::size_t s = 0; s < childSources.size(); ++s) {
    for (int a = 0; a <= m; ++a) {
      for (int b = 0; a + b <= m; ++b) {
        const double wa = double(a) / m, wb = double(b) / m, wc = 1.0 - wa - wb;
        const Triangle& f = childSources[s];
        const Triangle& r = coarseSources[s];
        out.hausdorff =
            std::max(out.hausdorff, distanceTo(coarse, coarseBoxes, sourceCell[s], f[0] * wa + f[1] * wb + f[2] * wc));
        out.hausdorff =
            std::max(out.hausdorff, distanceTo(child, childBoxes, sourceCell[s], r[0] * wa + r[1] * wb + r[2] * wc));
      }
    }
  }
  return out;
}

/// A random window of one of several kinds, possibly with nodata posts.
Window randomWindow(std::mt19937& rng) {
  std::uniform_int_distribution<int> sizes(2, 8), kinds(0, 6);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const double sx = uniform(1.0, 60.0);
  const double sy = unit(rng) < 0.5 ? sx : uniform(1.0, 60.0);
  Window w = makeWindow(sizes(rng), {sx, sy});
  const int side = w.side();
  const double amplitude = uniform(0.0, 80.0), base = uniform(-100.0, 1500.0);
  const double fx = uniform(0.0, 3.0) / (side * sx), fy = uniform(0.0, 3.0) / (side * sy);
  const double px = uniform(0.0, 6.3), py = uniform(0.0, 6.3);
  auto smooth = [&](int i, int j) {
    return base + amplitude * std::sin(fx * i * sx * 6.283 + px) * std::cos(fy * j * sy * 6.283 + py);
  };
  const int kind = kinds(rng);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) w.at(i, j) = static_cast<float>(kind == 3 ? base : smooth(i, j));
  }
  if (kind == 1 || kind == 6) {  // 1–3 straight cliffs of 100–900 m in random directions
    const int cliffs = 1 + static_cast<int>(unit(rng) * 3.0);
    for (int c = 0; c < cliffs; ++c) {
      const double angle = unit(rng) < 0.5 ? 1.5708 * std::floor(uniform(0.0, 4.0)) : uniform(0.0, 6.283);
      const double ox = uniform(0.0, side - 1.0), oy = uniform(0.0, side - 1.0);
      const double drop = uniform(100.0, 900.0) * (unit(rng) < 0.5 ? 1.0 : -1.0);
      for (int j = 0; j < side; ++j) {
        for (int i = 0; i < side; ++i) {
          if ((i - ox) * std::cos(angle) + (j - oy) * std::sin(angle) > 0.0) w.at(i, j) += static_cast<float>(drop);
        }
      }
    }
  }
  if (kind == 2 || kind == 6) {  // single-post spikes and pits of 300–1000 m
    const int spikes = 1 + static_cast<int>(unit(rng) * 3.0);
    std::uniform_int_distribution<int> post(0, side - 1);
    for (int s = 0; s < spikes; ++s) {
      w.at(post(rng), post(rng)) += static_cast<float>(uniform(300.0, 1000.0) * (unit(rng) < 0.7 ? 1.0 : -1.0));
    }
  }
  if (kind == 4) {  // noise: every post independent
    for (float& h : w.posts) h = static_cast<float>(uniform(0.0, 1000.0));
  }
  if (kind == 5) {  // terraces: many parallel cliffs of 100–400 m
    const double step = uniform(100.0, 400.0);
    for (float& h : w.posts) h = static_cast<float>(step * std::round(3.0 * h / step));
  }
  const double holes = unit(rng);
  if (holes < 0.25) {  // scattered nodata posts
    const double p = uniform(0.03, 0.3);
    for (float& h : w.posts) {
      if (unit(rng) < p) h = kNaN;
    }
  } else if (holes < 0.35) {  // a nodata block
    std::uniform_int_distribution<int> post(0, side - 1);
    const int i0 = post(rng), j0 = post(rng), i1 = post(rng), j1 = post(rng);
    for (int j = std::min(j0, j1); j <= std::max(j0, j1); ++j) {
      for (int i = std::min(i0, i1); i <= std::max(i0, i1); ++i) w.at(i, j) = kNaN;
    }
  }
  return w;
}

// Float posts of up to ~2 km, distances computed in double: this covers the rounding.
double tolerance(double bound) { return 1e-6 * (1.0 + bound); }

TEST(SimplificationError, BoundsTheHausdorffDistanceOnRandomWindows) {
  std::mt19937 rng(2024);
  std::vector<double> ratios;  // estimate / bound, where the bound is positive
  int belowVertical = 0, tight = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Window w = randomWindow(rng);
    const double bound = simplificationError(w.posts, w.n, w.spacing);
    const BruteForce brute = bruteForce(w);
    ASSERT_LE(brute.hausdorff, bound + tolerance(bound))
        << "trial " << trial << " n " << w.n << " spacing " << w.spacing.x << " x " << w.spacing.y;
    // Never above the vertical error, but where nodata moves the data's edge: one diagonal.
    const bool nodata = std::any_of(w.posts.begin(), w.posts.end(), [](float h) { return std::isnan(h); });
    const double edge = nodata ? 2.0 * glm::length(w.spacing) : 0.0;
    ASSERT_LE(bound, std::max(brute.vertical, edge) + tolerance(bound)) << "trial " << trial;
    belowVertical += bound < 0.99 * brute.vertical;
    if (bound > 0.0) {
      ratios.push_back(brute.hausdorff / bound);
      tight += brute.hausdorff >= 0.5 * bound;
    } else {
      ASSERT_LE(brute.hausdorff, 1e-9) << "trial " << trial;
    }
    if (trial % 2 == 0) {  // exaggerated: heights times k, the bound times max(|k|, 1)
      const double k = std::array{0.5, 3.0, -2.0, 0.1, 20.0}[static_cast<std::size_t>(trial / 2 % 5)];
      const double scaled = exaggeratedError(bound, k);
      ASSERT_LE(bruteForce(w, k, 4).hausdorff, scaled + tolerance(scaled)) << "trial " << trial << " k " << k;
    }
  }
  ASSERT_FALSE(ratios.empty());
  std::sort(ratios.begin(), ratios.end());
  const double median = ratios[ratios.size() / 2];
  std::printf("windows with a positive bound: %zu, median estimate/bound %.3f, ≥ 0.5: %d, below vertical: %d\n",
              ratios.size(), median, tight, belowVertical);
  // Not absurdly loose: the sampled Hausdorff distance is typically the same order as the bound.
  EXPECT_GT(median, 0.3);
  EXPECT_GT(belowVertical, 25) << "the 3D bound should beat the vertical error on cliffs";
}

TEST(SimplificationError, AVerticalCliffCostsAboutACoarseCellDiagonal) {
  const glm::dvec2 spacing(20.0, 20.0);
  const double diagonal = 2.0 * glm::length(spacing);
  for (const double height : {300.0, 900.0}) {
    for (int column = 1; column <= 8; ++column) {  // cliff between child columns column − 1 and column
      Window w = makeWindow(4, spacing);
      for (int j = 0; j < w.side(); ++j) {
        for (int i = column; i < w.side(); ++i) w.at(i, j) = static_cast<float>(height);
      }
      const double bound = simplificationError(w.posts, w.n, spacing);
      const BruteForce brute = bruteForce(w, 1.0, 10);
      EXPECT_DOUBLE_EQ(bound, diagonal) << "column " << column;  // min(v = h/2, D + 0)
      EXPECT_DOUBLE_EQ(brute.vertical, 0.5 * height);
      EXPECT_LE(brute.hausdorff, bound);
      EXPECT_GT(brute.hausdorff, 0.25 * bound) << "column " << column;  // about one child spacing
    }
  }
  // A cliff along the diagonal of the cells and one across them.
  for (const bool along : {true, false}) {
    Window w = makeWindow(4, spacing);
    for (int j = 0; j < w.side(); ++j) {
      for (int i = 0; i < w.side(); ++i) {
        if (along ? i > j : i + j > w.side()) w.at(i, j) = 500.0F;
      }
    }
    const double bound = simplificationError(w.posts, w.n, spacing);
    EXPECT_LE(bound, diagonal + 1e-9);
    EXPECT_LE(bruteForce(w, 1.0, 10).hausdorff, bound + tolerance(bound));
  }
}

TEST(SimplificationError, ASpikeThatVanishesCostsItsHeight) {
  Window w = makeWindow(3, {20.0, 20.0}, 40.0F);
  w.at(3, 3) += 800.0F;  // odd post: not a coarse post
  const double bound = simplificationError(w.posts, w.n, w.spacing);
  EXPECT_DOUBLE_EQ(bound, 800.0);
  const BruteForce brute = bruteForce(w, 1.0, 10);
  EXPECT_LE(brute.hausdorff, bound + tolerance(bound));
  EXPECT_GT(brute.hausdorff, 0.95 * bound);
  // A spike on a coarse post stays, only thicker: about a coarse cell.
  Window kept = makeWindow(3, {20.0, 20.0}, 40.0F);
  kept.at(2, 2) += 800.0F;
  const double keptBound = simplificationError(kept.posts, kept.n, kept.spacing);
  EXPECT_DOUBLE_EQ(keptBound, 2.0 * glm::length(kept.spacing));
  EXPECT_LE(bruteForce(kept, 1.0, 10).hausdorff, keptBound + tolerance(keptBound));
}

TEST(SimplificationError, SmoothTerrainGetsTheVerticalError) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const double spacing = 10.0 + 40.0 * unit(rng);
    Window w = makeWindow(2 + trial % 7, {spacing, spacing});
    const double amplitude = spacing * (0.1 + 2.0 * unit(rng)), phase = 6.283 * unit(rng);
    for (int j = 0; j < w.side(); ++j) {
      for (int i = 0; i < w.side(); ++i) {
        w.at(i, j) = static_cast<float>(300.0 + amplitude * std::sin(0.5 * i + phase) * std::cos(0.4 * j));
      }
    }
    const double bound = simplificationError(w.posts, w.n, w.spacing);
    const BruteForce brute = bruteForce(w);
    ASSERT_LT(brute.vertical, 2.0 * glm::length(w.spacing)) << "not smooth, trial " << trial;
    EXPECT_NEAR(bound, brute.vertical, 1e-9) << "trial " << trial;
    EXPECT_LE(brute.hausdorff, bound + tolerance(bound));
  }
}

TEST(SimplificationError, FlatAndPlanarWindowsHaveNoError) {
  EXPECT_EQ(simplificationError(makeWindow(5, {20.0, 20.0}, 123.25F).posts, 5, {20.0, 20.0}), 0.0);
  Window plane = makeWindow(6, {15.0, 25.0});
  for (int j = 0; j < plane.side(); ++j) {
    for (int i = 0; i < plane.side(); ++i) plane.at(i, j) = static_cast<float>(3 * i - 5 * j + 100);
  }
  EXPECT_EQ(simplificationError(plane.posts, plane.n, plane.spacing), 0.0);
}

TEST(SimplificationError, NodataEdgesMoveByACoarseCellAtMost) {
  const glm::dvec2 spacing(20.0, 20.0);
  EXPECT_EQ(simplificationError(makeWindow(3, spacing, kNaN).posts, 3, spacing), 0.0);
  // A 500 m cliff through the middle of coarse column 1 (child column 3 up).
  Window w = makeWindow(3, spacing);
  for (int j = 0; j < w.side(); ++j) {
    for (int i = 3; i < w.side(); ++i) w.at(i, j) = 500.0F;
  }
  const double diagonal = 2.0 * glm::length(spacing);
  EXPECT_DOUBLE_EQ(simplificationError(w.posts, w.n, spacing), diagonal);
  // A nodata post inside a cliff cell, not a corner: the cell falls back to the vertical error.
  Window inner = w;
  inner.at(3, 1) = kNaN;
  EXPECT_DOUBLE_EQ(simplificationError(inner.posts, inner.n, spacing), 250.0);
  EXPECT_LE(bruteForce(inner).hausdorff, 250.0);
  // A nodata corner: the cells around it are not drawn at the coarse level; others still count.
  Window corner = w;
  corner.at(2, 2) = kNaN;
  EXPECT_DOUBLE_EQ(simplificationError(corner.posts, corner.n, spacing), diagonal);
  // Coarse column 0 without its corners at child column 2: not drawn coarse, but its child
  // cells in columns 0-1 are: the data's edge moves by a coarse cell.
  Window none = w;
  for (int j = 0; j < none.side(); j += 2) none.at(2, j) = kNaN;
  EXPECT_DOUBLE_EQ(simplificationError(none.posts, none.n, spacing), diagonal);
  // A flat window whose coarse corners are all nodata but one child cell: the same.
  Window lone = makeWindow(2, spacing, kNaN);
  for (int j = 1; j <= 2; ++j)
    for (int i = 1; i <= 2; ++i) lone.at(i, j) = 7.0F;
  EXPECT_DOUBLE_EQ(simplificationError(lone.posts, lone.n, spacing), diagonal);
  // A flat window with one nodata post that is no coarse corner: a hole the coarse cell covers.
  Window pit = makeWindow(2, spacing, 7.0F);
  pit.at(1, 1) = kNaN;
  EXPECT_DOUBLE_EQ(simplificationError(pit.posts, pit.n, spacing), diagonal);
}

TEST(ExaggeratedError, ScalesByTheLargerOfOneAndTheFactor) {
  EXPECT_DOUBLE_EQ(exaggeratedError(10.0, 1.0), 10.0);
  EXPECT_DOUBLE_EQ(exaggeratedError(10.0, 3.0), 30.0);
  EXPECT_DOUBLE_EQ(exaggeratedError(10.0, -3.0), 30.0);
  EXPECT_DOUBLE_EQ(exaggeratedError(10.0, 0.5), 10.0);
  EXPECT_DOUBLE_EQ(exaggeratedError(10.0, 0.0), 10.0);
  EXPECT_DOUBLE_EQ(exaggeratedError(0.0, 7.0), 0.0);
}

}  // namespace
}  // namespace gis::test
