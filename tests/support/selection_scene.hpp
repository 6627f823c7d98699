#pragma once
// Shared by the lasso GL tests (selection_gltest, selection_image_gltest): a 256 × 192 view of
// the stiff test terrain, random cameras over it and random lassos (stars and scribbles).
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <glm/trigonometric.hpp>

#include "gfx/camera.hpp"
#include "gl_test.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace gis::test {

inline constexpr int kSelectionWidth = 256;
inline constexpr int kSelectionHeight = 192;
inline double selectionFov() { return glm::radians(50.0); }

struct LassoCamera {
  glm::dvec3 eye;
  glm::dmat4 viewProj;
};

inline LassoCamera lassoCameraAt(const glm::dvec3& eye, const glm::dvec3& target) {
  const double aspect = static_cast<double>(kSelectionWidth) / kSelectionHeight;
  return {eye, gfx::reversedInfinitePerspective(selectionFov(), aspect, 1.0) *
                   gfx::lookAt(eye, target, glm::dvec3(0, 0, 1))};
}

/// A random lasso in pixels: a star (concave) or a scribble (self-intersecting).
inline std::vector<glm::dvec2> randomLassoPolygon(std::mt19937& rng) {
  constexpr double w = kSelectionWidth, h = kSelectionHeight;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const glm::dvec2 c(w * (0.2 + 0.6 * unit(rng)), h * (0.2 + 0.6 * unit(rng)));
  const int n = 5 + static_cast<int>(8 * unit(rng));
  std::vector<glm::dvec2> p;
  const bool scribble = unit(rng) < 0.3;
  for (int k = 0; k < n; ++k) {
    if (scribble) {
      p.emplace_back(c.x + (unit(rng) - 0.5) * w * 0.6, c.y + (unit(rng) - 0.5) * h * 0.6);
    } else {
      const double a = 6.283 * k / n, r = (15.0 + 70.0 * unit(rng)) * (k % 2 == 0 ? 1.0 : 0.55);
      p.push_back(c + r * glm::dvec2(std::cos(a), std::sin(a)));
    }
  }
  return p;
}

/// A lasso drawn with camera `c` in the shared viewport.
inline overlay::Lasso lassoFrom(const LassoCamera& c, std::vector<glm::dvec2> points,
                                double distance = std::numeric_limits<double>::infinity()) {
  overlay::Lasso l;
  l.points = std::move(points);
  l.viewProj = c.viewProj;
  l.width = kSelectionWidth;
  l.height = kSelectionHeight;
  l.distance = distance;
  return l;
}

/// The stiff terrain (129² posts at 20 m, seed 21), its engine and a selection renderer.
class SelectionSceneTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    tree_ = std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 129, .height = 129, .seed = 21}), 16);
    bounds_ = std::make_shared<terrain::QuadtreeHeightBounds>(tree_, 1.0);
    Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree_, nullptr);
    Result<overlay::SelectionRenderer> selection = overlay::SelectionRenderer::create();
    ASSERT_TRUE(engine.ok() && selection.ok());
    engine_.emplace(std::move(*engine));
    selection_.emplace(std::move(*selection));
    const terrain::TerrainGrid& grid = tree_->grid();
    lo_ = grid.postPosition(0, grid.height - 1);
    hi_ = grid.postPosition(grid.width - 1, 0);
  }

  /// A camera 200–1700 m from a random point of the terrain (or `target`), 100–1600 m above it.
  [[nodiscard]] LassoCamera randomCamera(std::mt19937& rng, std::optional<glm::dvec2> target = std::nullopt) const {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const glm::dvec2 random = lo_ + (hi_ - lo_) * glm::dvec2(unit(rng), unit(rng));
    const glm::dvec2 t = target.value_or(random);
    const double a = 6.283 * unit(rng), d = 200.0 + 1500.0 * unit(rng);
    const glm::dvec2 e = t + d * glm::dvec2(std::cos(a), std::sin(a));
    return lassoCameraAt(
        glm::dvec3(e, bounds_->fullResolutionHeightAt(glm::clamp(e, lo_, hi_)) + 100.0 + 1500.0 * unit(rng)),
        glm::dvec3(t, 0.0));
  }

  std::shared_ptr<terrain::TerrainQuadtree> tree_;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds_;
  std::optional<terrain::TerrainEngine> engine_;
  std::optional<overlay::SelectionRenderer> selection_;
  glm::dvec2 lo_{0.0}, hi_{0.0};
};

}  // namespace gis::test
