// Lasso selection on the GPU against its CPU twin on the same depth buffer (docs/design.md §6–§7): random
// lassos (concave, self-intersecting) drawn from random cameras over stiff terrain, chained with
// random operators (2–50, Invert included), evaluated from the camera they were drawn with and
// from others — eye inside a volume, volumes reaching past the far end of the terrain, dark caps
// at a distance — in both stencil schemes. Every pixel whose terrain point is not within a
// hair of a volume's boundary must agree; the few that are may differ.
#include <algorithm>
#include <cstdio>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "selection_scene.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/logical_selection.hpp"
#include "vector_overlay/selection_renderer.hpp"
#include "vector_overlay/selection_states.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = kSelectionWidth;
constexpr int kHeight = kSelectionHeight;
using Camera = LassoCamera;

Camera cameraAt(const glm::dvec3& eye, const glm::dvec3& target) { return lassoCameraAt(eye, target); }
std::vector<glm::dvec2> randomPolygon(std::mt19937& rng) { return randomLassoPolygon(rng); }

class SelectionGlTest : public SelectionSceneTest {
 protected:
  struct Outcome {
    std::size_t selected = 0, wrong = 0, boundaryWrong = 0;
  };

  struct Drawn {
    std::vector<std::uint8_t> stencil;
    std::vector<float> depth;
  };

  /// Draws the terrain from `view` (at the LOD tolerance given; 0 draws the DEM exactly) and the
  /// selection; reads the stencil and the depth, then clears the selection.
  Drawn drawSelection(const Camera& view, const std::vector<overlay::SelectionStep>& steps,
                      overlay::SelectionScheme scheme, double lodTolerance = 1.5) {
    gfx::RenderTarget target(kWidth, kHeight, 0, true);
    gfx::enableReversedZ();
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
    gfx::enableMaskWrites(target.framebuffer(), false);
    const double fov = glm::radians(50.0);
    terrain::LodOptions lodOptions;
    lodOptions.pixelTolerance = lodTolerance;
    const terrain::LodSelection lod =
        terrain::selectLod(*tree_, terrain::LodView{view.eye, view.viewProj, kHeight, fov}, lodOptions);
    engine_->draw(cache_, view.viewProj, view.eye, lod, 1.0);
    (void)selection_->setSteps(steps);  // bad lassos are reported there and select nothing
    overlay::SelectionSettings settings;
    settings.scheme = scheme;
    const overlay::OverlayView ov{view.viewProj, view.eye, 1.0, fov, static_cast<double>(kWidth) / kHeight};
    selection_->select(cache_, ov, settings);
    Drawn d{gfx::readStencil(target), gfx::readDepth(target)};
    selection_->clear(cache_);
    return d;
  }

  /// Draws the terrain from `view`, the selection, reads the stencil and compares with the twin.
  Outcome drawAndCompare(const Camera& view, const std::vector<overlay::SelectionStep>& steps,
                         overlay::SelectionScheme scheme, const std::string& label) {
    const Drawn drawn = drawSelection(view, steps, scheme);
    const std::vector<std::uint8_t>& stencil = drawn.stencil;
    const std::vector<float>& depth = drawn.depth;
    const overlay::DepthImage image{kWidth, kHeight, depth, view.viewProj};
    const std::vector<std::uint8_t> expected = overlay::selectionMask(image, steps);
    Outcome r;
    int reported = 0;
    for (std::size_t i = 0; i < stencil.size(); ++i) {
      const bool geometry = depth[i] > 0.0F;
      const bool gpu = scheme == overlay::SelectionScheme::Runs ? (stencil[i] & overlay::kSelectedBit) != 0
                                                                : geometry && stencil[i] == 1;
      if (scheme == overlay::SelectionScheme::Runs && (!geometry || !gpu)) {
        EXPECT_EQ(stencil[i], 0u) << label << ": leftover stencil bits at pixel " << i;
      }
      r.selected += expected[i];
      if (gpu == (expected[i] != 0)) continue;
      // Within a hair of a volume's boundary (float vertices, depth precision)?
      const int x = static_cast<int>(i % kWidth), y = static_cast<int>(i / kWidth);
      const std::optional<glm::dvec3> p = overlay::unprojectPixel(image, x, y);
      bool nearBoundary = !p.has_value();
      if (p) {
        const double d = 2e-4 * glm::length(*p - view.eye) + 0.01;
        for (const glm::dvec3& o : {glm::dvec3(d, 0, 0), glm::dvec3(-d, 0, 0), glm::dvec3(0, d, 0),
                                    glm::dvec3(0, -d, 0), glm::dvec3(0, 0, d), glm::dvec3(0, 0, -d)}) {
          nearBoundary = nearBoundary || overlay::selectedAt(steps, *p + o) != (expected[i] != 0);
        }
      }
      if (nearBoundary) {
        ++r.boundaryWrong;
      } else {
        ++r.wrong;
        if (reported++ < 5) {
          ADD_FAILURE() << label << ": pixel (" << x << ", " << y << ") GPU " << gpu << ", CPU " << int(expected[i])
                        << ", stencil " << int(stencil[i]);
        }
      }
    }
    return r;
  }
};

TEST_F(SelectionGlTest, RandomChainsFromManyViewpointsMatchTheCpuTwin) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const overlay::SelectionOp ops[] = {overlay::SelectionOp::Or,     overlay::SelectionOp::And,
                                      overlay::SelectionOp::Xor,    overlay::SelectionOp::Subtract,
                                      overlay::SelectionOp::Invert, overlay::SelectionOp::Single};
  Outcome total;
  std::size_t checked = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const Camera drawnFrom = randomCamera(rng);
    const int length = trial < 6 ? 2 : 2 + static_cast<int>(48 * unit(rng));
    std::vector<overlay::SelectionStep> steps;
    for (int k = 0; k < length; ++k) {
      overlay::SelectionStep s;
      s.op = k == 0 ? overlay::SelectionOp::Single : ops[static_cast<std::size_t>(unit(rng) * (k % 7 == 6 ? 6 : 5))];
      // Lassos from the shared camera, sometimes from another one; some end at a distance.
      const Camera& c = unit(rng) < 0.7 ? drawnFrom : randomCamera(rng);
      s.lasso = lassoFrom(c, randomPolygon(rng),
                          unit(rng) < 0.2 ? 500.0 + 2000.0 * unit(rng) : std::numeric_limits<double>::infinity());
      steps.push_back(std::move(s));
    }
    // Evaluated from the camera they were drawn with (walls seen edge on), from another, and
    // from inside the first volume (on a ray through its lasso, beyond the near plane).
    const overlay::Lasso& first = steps[0].lasso;
    glm::dvec2 inPixel(0.0);
    for (const glm::dvec2& q : first.points) inPixel += q;
    inPixel /= static_cast<double>(first.points.size());
    const glm::dmat4 inverse = glm::inverse(first.viewProj);
    const glm::dvec4 h =
        inverse * glm::dvec4(2.0 * inPixel.x / kWidth - 1.0, 1.0 - 2.0 * inPixel.y / kHeight, 0.02, 1.0);
    const glm::dvec3 inside = glm::dvec3(h) / h.w;
    const Camera views[] = {drawnFrom, randomCamera(rng),
                            cameraAt(inside, glm::dvec3(lo_ + (hi_ - lo_) * glm::dvec2(unit(rng), unit(rng)), 0.0))};
    for (const Camera& view : views) {
      for (const auto scheme : {overlay::SelectionScheme::Runs, overlay::SelectionScheme::Report}) {
        const Outcome r = drawAndCompare(
            view, steps, scheme,
            "trial " + std::to_string(trial) + (scheme == overlay::SelectionScheme::Runs ? " runs" : " report"));
        total.selected += r.selected;
        total.wrong += r.wrong;
        total.boundaryWrong += r.boundaryWrong;
        checked += static_cast<std::size_t>(kWidth * kHeight);
      }
    }
  }
  std::printf("selection: %zu pixels checked, %zu selected, %zu wrong away from boundaries, %zu near them\n", checked,
              total.selected, total.wrong, total.boundaryWrong);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.boundaryWrong, total.selected / 200);
  EXPECT_GT(total.selected, 50000u);
}

TEST_F(SelectionGlTest, HundredsOfOverlappingOrVolumesStayExact) {
  // 300 Or'ed lassos over one spot: counts far beyond the 8-bit stencil in either scheme's runs.
  std::mt19937 rng(7);
  const Camera camera =
      cameraAt(glm::dvec3(0.5 * (lo_ + hi_) + glm::dvec2(0.0, -900.0), 1200.0), glm::dvec3(0.5 * (lo_ + hi_), 0.0));
  std::vector<overlay::SelectionStep> steps;
  for (int k = 0; k < 300; ++k) {
    overlay::SelectionStep s;
    s.op = k == 0 ? overlay::SelectionOp::Single : overlay::SelectionOp::Or;
    std::vector<glm::dvec2> square;
    const double r = 20.0 + 0.2 * k;
    const glm::dvec2 c(128.0 + 0.1 * (k % 13), 96.0);
    square = {c + glm::dvec2(-r, -r), c + glm::dvec2(r, -r), c + glm::dvec2(r, r), c + glm::dvec2(-r, r)};
    s.lasso = lassoFrom(camera, square, std::numeric_limits<double>::infinity());
    steps.push_back(std::move(s));
  }
  for (const auto scheme : {overlay::SelectionScheme::Runs, overlay::SelectionScheme::Report}) {
    const Outcome r = drawAndCompare(camera, steps, scheme, "300 or");
    EXPECT_EQ(r.wrong, 0u);
    EXPECT_GT(r.selected, 10000u);
  }
  // Then Xor of 256 copies of one lasso (even: nothing changes) and one more (odd: flips).
  const overlay::Lasso one = steps[10].lasso;
  for (int k = 0; k < 257; ++k) steps.push_back({overlay::SelectionOp::Xor, one});
  const Outcome r = drawAndCompare(camera, steps, overlay::SelectionScheme::Runs, "257 xor");
  EXPECT_EQ(r.wrong, 0u);
}

TEST_F(SelectionGlTest, ThousandsOfLassoVolumesStayExact) {
  // 3,000 random lassos (concave, self-crossing) chained with random operators, each drawn from
  // one of a few cameras, evaluated from another: the stencil runs wrap many times over.
  std::mt19937 rng(3000);
  std::vector<Camera> drawnFrom;
  for (int k = 0; k < 4; ++k) drawnFrom.push_back(randomCamera(rng, 0.5 * (lo_ + hi_)));
  const overlay::SelectionOp ops[] = {overlay::SelectionOp::Or, overlay::SelectionOp::And, overlay::SelectionOp::Xor,
                                      overlay::SelectionOp::Subtract};
  std::vector<overlay::SelectionStep> steps;
  for (int k = 0; k < 3000; ++k) {
    overlay::SelectionStep s;
    s.op = k == 0 ? overlay::SelectionOp::Single : ops[rng() % 4];
    // Mostly Or (long runs), with the other operators sprinkled in.
    if (k % 7 != 0 && k > 0) s.op = overlay::SelectionOp::Or;
    s.lasso = lassoFrom(drawnFrom[static_cast<std::size_t>(k) % drawnFrom.size()], randomPolygon(rng));
    steps.push_back(std::move(s));
  }
  const Camera view = randomCamera(rng, 0.5 * (lo_ + hi_));
  for (const auto scheme : {overlay::SelectionScheme::Runs, overlay::SelectionScheme::Report}) {
    const Outcome r = drawAndCompare(view, steps, scheme, "3000 lassos");
    std::printf("3000 lassos (%s): %zu selected, %zu wrong, %zu on boundaries\n",
                scheme == overlay::SelectionScheme::Runs ? "runs" : "report", r.selected, r.wrong, r.boundaryWrong);
    EXPECT_EQ(r.wrong, 0u);
    EXPECT_GT(r.selected + r.boundaryWrong, 0u);
  }
}

TEST_F(SelectionGlTest, LogicalSelectionOfFeaturesAgreesWithThePixels) {
  // Star polygons and polylines over the stiff terrain; random chains of lassos; the GPU's
  // selected pixels against selectFeatures (1.5 m samples on the full-resolution surface, which
  // the terrain draws exactly at LOD tolerance 0). Visual ⊆ logical: a pixel clearly selected
  // (its centre and 8 points one pixel footprint around it on the terrain all selected) and
  // clearly covered by a feature (not an edge pixel of the reference) names a selected feature.
  // Fully inside ⇒ visual: a pixel clearly unselected never shows a fully-inside feature.
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const glm::dvec2 size = hi_ - lo_;
  std::vector<geo::Feature> areas(48), roads(24);
  for (geo::Feature& f : areas) {
    const glm::dvec2 c = lo_ + size * glm::dvec2(0.15 + 0.7 * unit(rng), 0.15 + 0.7 * unit(rng));
    geo::Polygon poly;
    const int n = 5 + static_cast<int>(6 * unit(rng));
    for (int k = 0; k < n; ++k) {
      const double a = 6.283 * k / n, r = (30.0 + 120.0 * unit(rng)) * (k % 2 == 0 ? 1.0 : 0.5);
      poly.outer.push_back(c + r * glm::dvec2(std::cos(a), std::sin(a)));
    }
    f.polygons.push_back(std::move(poly));
  }
  std::vector<overlay::LineShape> shapes;
  for (geo::Feature& f : roads) {
    geo::LineString line;
    glm::dvec2 p = lo_ + size * glm::dvec2(0.1 + 0.8 * unit(rng), 0.1 + 0.8 * unit(rng));
    for (int k = 0; k < 4; ++k) {
      line.push_back(p);
      p = glm::clamp(p + glm::dvec2(200.0 * (unit(rng) - 0.5), 200.0 * (unit(rng) - 0.5)), lo_, hi_);
    }
    f.lines.push_back(std::move(line));
    overlay::LineShape shape;
    shape.width = 8.0 + 20.0 * unit(rng);
    shapes.push_back(shape);
  }
  const std::vector<overlay::ReferenceLayer> layers = {
      {"areas", overlay::LayerKind::Polygon, &areas, {}, {}},
      {"roads", overlay::LayerKind::Line, &roads, shapes, {}},
  };
  const auto height = [this](const glm::dvec2& p) { return bounds_->fullResolutionHeightAt(p); };
  overlay::FeatureSelectionOptions options;
  options.sampleSpacing = 1.5;
  const overlay::SelectionOp ops[] = {overlay::SelectionOp::Or, overlay::SelectionOp::And, overlay::SelectionOp::Xor,
                                      overlay::SelectionOp::Subtract, overlay::SelectionOp::Invert};
  std::size_t checkedSelected = 0, checkedInside = 0, partly = 0, fully = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const Camera view = randomCamera(rng);
    std::vector<overlay::SelectionStep> steps;
    const int length = 1 + trial % 4;
    for (int k = 0; k < length; ++k) {
      const overlay::SelectionOp op =
          k == 0 ? overlay::SelectionOp::Single : ops[static_cast<std::size_t>(unit(rng) * (trial == 5 ? 5 : 4))];
      steps.push_back({op, lassoFrom(unit(rng) < 0.75 ? view : randomCamera(rng), randomPolygon(rng),
                                     std::numeric_limits<double>::infinity())});
    }
    const Drawn drawn = drawSelection(view, steps, overlay::SelectionScheme::Runs, 0.0);
    const overlay::DepthImage image{kWidth, kHeight, drawn.depth, view.viewProj};
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, layers);
    std::set<std::pair<std::size_t, std::size_t>> selected, inside;
    for (std::size_t l = 0; l < layers.size(); ++l) {
      for (const overlay::FeatureSelection& f : overlay::selectFeatures(layers[l], steps, height, options)) {
        selected.insert({l, f.feature});
        if (f.fullyInside) inside.insert({l, f.feature});
        (f.fullyInside ? fully : partly) += 1;
      }
    }
    const double pixelAngle = 2.0 * std::tan(glm::radians(25.0)) / kHeight;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
        const std::optional<glm::dvec3> p = overlay::unprojectPixel(image, x, y);
        if (!p || edges[i] != 0) continue;
        const std::vector<overlay::PickedFeature> under = overlay::pick(image, layers, x, y);
        if (under.empty()) continue;
        const bool gpu = (drawn.stencil[i] & overlay::kSelectedBit) != 0;
        // Clearly one way: the centre and 8 points a pixel footprint away, on the terrain.
        const double r = pixelAngle * glm::length(*p - view.eye);
        bool clear = true;
        for (int a = 0; a < 8 && clear; ++a) {
          const glm::dvec2 q = glm::dvec2(*p) + r * glm::dvec2(std::cos(0.785 * a), std::sin(0.785 * a));
          const double z = height(q);
          clear = std::isfinite(z) && overlay::selectedAt(steps, glm::dvec3(q, z)) == gpu;
        }
        if (!clear || overlay::selectedAt(steps, *p) != gpu) continue;
        for (const overlay::PickedFeature& f : under) {
          checkedInside += inside.count({f.layer, f.feature});
          if (gpu) {
            ++checkedSelected;
            EXPECT_TRUE(selected.count({f.layer, f.feature}) != 0)
                << "trial " << trial << ": pixel (" << x << ", " << y << ") is selected and shows feature " << f.feature
                << " of layer " << f.layer << ", which the logical selection misses";
          } else if (inside.count({f.layer, f.feature}) != 0) {
            ADD_FAILURE() << "trial " << trial << ": pixel (" << x << ", " << y << ") is not selected but shows "
                          << "feature " << f.feature << " of layer " << f.layer << ", logically fully inside";
          }
        }
      }
    }
  }
  std::printf(
      "logical selection: %zu partly and %zu fully selected features; %zu selected feature pixels and %zu pixels of "
      "fully inside features checked\n",
      partly, fully, checkedSelected, checkedInside);
  EXPECT_GT(checkedSelected, 2000u);
  EXPECT_GT(checkedInside, 50u);
  EXPECT_GT(partly, 5u);
  EXPECT_GE(fully, 2u);
}

}  // namespace
}  // namespace gis::test
