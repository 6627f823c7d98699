// Layer analysis on the overlay stencil core, against the CPU reference on the same depth buffer:
// - overlap of two layers (And, Or, Xor, Subtract of their coverage): the stencil flags after
//   marking equal the reference's coverage of each layer, and each operator's cover (mask value
//   per operator) equals the operator applied to the reference, at every pixel that does not
//   straddle a feature edge; at most 0.5 % of covered pixels differ on edges; the stencil is 0
//   afterwards. One layer overlaps 64 deep at a point (more than one 63-piece group).
// - open volumes: our closed volumes count 0 on every pixel from every camera, the eye inside
//   volumes and the near plane cutting them included (the clipped pieces are capped); a face
//   taken out of the index buffer shows as exactly its own screen image, wherever it is (top
//   cap, a wall, the bottom cap hidden under the terrain).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/trigonometric.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "random_features.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 256;
constexpr int kHeight = 192;
const double kFov = glm::radians(45.0);
constexpr double kAspect = static_cast<double>(kWidth) / kHeight;

struct Camera {
  glm::dvec3 eye{0.0}, target{0.0};
  double nearPlane = 1.0;
  std::string kind;
  [[nodiscard]] glm::dmat4 viewProj() const {
    return gfx::reversedInfinitePerspective(kFov, kAspect, nearPlane) * gfx::lookAt(eye, target, glm::dvec3(0, 0, 1));
  }
  [[nodiscard]] overlay::OverlayView view() const { return {viewProj(), eye, nearPlane, kFov, kAspect}; }
};

/// Stiff terrain (cliffs, a spike, nodata holes) with an area layer, a road layer, roads in
/// pixels and the paper's construction of the areas.
class LayerAnalysisTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    tree_ = std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 257, .height = 257, .seed = 5}), 16);
    bounds_ = std::make_shared<terrain::QuadtreeHeightBounds>(tree_, 1.0);
    Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree_, nullptr);
    Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
    ASSERT_TRUE(engine.ok() && overlays.ok());
    engine_.emplace(std::move(*engine));
    overlays_.emplace(std::move(*overlays));
    const terrain::TerrainGrid& grid = tree_->grid();
    lo_ = grid.postPosition(0, grid.height - 1);
    hi_ = grid.postPosition(grid.width - 1, 0);
    centre_ = 0.5 * (lo_ + hi_) + glm::dvec2(-480.0, 480.0);  // the middle of a 320 m cell
    overlay::CellGrid cells;
    cells.origin = lo_;
    cells.cellSize = 16 * grid.step.x;
    cells.columns = cells.rows = (grid.width - 1) / 16;
    options_.footprints.cells = cells;
  }

  /// 64 nested squares around centre_, each inside one cell (one piece), then random areas:
  /// the smallest square is 64 pieces deep, one more than a group of 63 counts (a 64-piece group
  /// would wrap its 6-bit count to 0 there).
  std::vector<geo::Feature> areaFeatures(std::mt19937& rng) const {
    std::vector<geo::Feature> out;
    for (int i = 0; i < 64; ++i) {
      geo::Feature f;
      f.fid = 1000 + i;
      const double r = 15.0 + 1.5 * i, a = 0.02 * i;
      geo::Polygon p;
      for (int k = 0; k < 4; ++k) {
        const double t = a + 1.5708 * k;
        p.outer.push_back(centre_ + r * glm::dvec2(std::cos(t), std::sin(t)));
      }
      f.polygons.push_back(std::move(p));
      out.push_back(std::move(f));
    }
    for (geo::Feature& f : randomPolygons(rng, lo_, hi_, 30)) out.push_back(std::move(f));
    return out;
  }

  overlay::OverlayLayer build(const std::string& name, overlay::LayerKind kind, const overlay::LayerStyle& style,
                              std::vector<geo::Feature> features, bool paper = false) {
    overlay::LayerBuildOptions options = options_;
    options.paperVariant = paper;
    Result<overlay::OverlayLayer> layer =
        overlay::OverlayLayer::build(name, kind, style, std::move(features), *bounds_, options);
    if (!layer) {
      ADD_FAILURE() << name << ": " << layer.diagnostics.items().front().toString();
      std::abort();
    }
    return std::move(*layer);
  }

  [[nodiscard]] double groundAt(const glm::dvec2& p) const {
    const double h = bounds_->fullResolutionHeightAt(p);
    return std::isnan(h) ? 0.0 : h;
  }

  /// Cameras of every kind: oblique, top-down, grazing, over the deep squares, the eye 2 m over
  /// a point of `inside` (in its volume), and a far near plane cutting the volumes.
  std::vector<Camera> cameras(std::mt19937& rng, const overlay::OverlayLayer& inside, int count) const {
    std::uniform_real_distribution<double> ux(lo_.x + 400, hi_.x - 400), uy(lo_.y + 400, hi_.y - 400), unit(0.0, 1.0);
    const overlay::ReferenceLayer ref = overlay::referenceLayerOf(inside);
    std::vector<Camera> out;
    for (int i = 0; i < count; ++i) {
      const glm::dvec2 t(ux(rng), uy(rng));
      const double g = groundAt(t), a = 6.283 * unit(rng);
      const glm::dvec2 dir(std::cos(a), std::sin(a));
      Camera c;
      switch (i % 6) {
        case 0:
          c = {glm::dvec3(t + (600.0 + 2000.0 * unit(rng)) * dir, g + 500.0 + 1500.0 * unit(rng)),
               {t, g},
               1.0,
               "oblique"};
          break;
        case 1:
          c = {glm::dvec3(t + glm::dvec2(0.0, -1.0), g + 800.0 + 2000.0 * unit(rng)), {t, g}, 1.0, "top-down"};
          break;
        case 2:
          c = {glm::dvec3(t + 1800.0 * dir, g + 100.0 + 1800.0 * 0.02), {t, g + 100.0}, 1.0, "grazing"};
          break;
        case 3:
          c = {glm::dvec3(centre_ + 900.0 * dir, groundAt(centre_) + 700.0),
               {centre_, groundAt(centre_)},
               1.0,
               "deep squares"};
          break;
        case 4: {
          glm::dvec2 p = t;
          for (int tries = 0; tries < 200 && !overlay::coveringFeature(ref, p); ++tries) p = {ux(rng), uy(rng)};
          c = {glm::dvec3(p, groundAt(p) + 2.0), {p + 300.0 * dir, groundAt(p)}, 0.5, "eye inside"};
          break;
        }
        default:
          c = {glm::dvec3(t, g + 25.0), {t + 200.0 * dir, g}, 30.0, "near plane cuts"};
          break;
      }
      c.kind += " #" + std::to_string(i);
      out.push_back(c);
    }
    return out;
  }

  /// Clears the target and draws the terrain (no overlay) with the camera.
  void drawTerrain(gfx::RenderTarget& target, const Camera& c) {
    gfx::enableReversedZ();
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
    gfx::enableMaskWrites(target.framebuffer(), false);
    const glm::dmat4 viewProj = c.viewProj();
    engine_->draw(cache_, viewProj, c.eye, terrain::selectLod(*tree_, {c.eye, viewProj, kHeight, kFov}), 1.0);
    gfx::enableMaskWrites(target.framebuffer(), true);
  }

  std::shared_ptr<terrain::TerrainQuadtree> tree_;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds_;
  std::optional<terrain::TerrainEngine> engine_;
  std::optional<overlay::OverlayRenderer> overlays_;
  overlay::LayerBuildOptions options_;
  glm::dvec2 lo_{0.0}, hi_{0.0}, centre_{0.0};
};

TEST_F(LayerAnalysisTest, OverlapOfTwoLayersMatchesTheReferenceForEveryOperator) {
  std::mt19937 rng(71);
  overlay::LayerStyle area, road;
  road.widthAttribute = "width_m";
  road.join = overlay::LineJoin::Round;
  road.cap = overlay::LineCap::Round;
  const overlay::OverlayLayer areas = build("areas", overlay::LayerKind::Polygon, area, areaFeatures(rng));
  const overlay::OverlayLayer roads = build("roads", overlay::LayerKind::Line, road, randomLines(rng, lo_, hi_, 40));
  EXPECT_GE(areas.maxOverlap(), 64u);
  const std::vector<overlay::ReferenceLayer> ref{overlay::referenceLayerOf(areas), overlay::referenceLayerOf(roads)};
  constexpr std::array<overlay::OverlapOp, 4> kOps{overlay::OverlapOp::And, overlay::OverlapOp::Or,
                                                   overlay::OverlapOp::Xor, overlay::OverlapOp::Subtract};
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::size_t covered = 0, wrong = 0, edgeWrong = 0, both = 0, deep = 0, zFail = 0, groups = 0;
  std::array<std::size_t, 4> opPixels{};
  int reported = 0;
  for (const Camera& c : cameras(rng, areas, 24)) {
    drawTerrain(target, c);
    std::vector<std::uint8_t> flags;
    for (std::size_t k = 0; k < kOps.size(); ++k) {
      const overlay::AnalysisMarks marks = overlays_->markOverlap(cache_, c.view(), areas, roads);
      zFail += marks.a.zFailPieces + marks.b.zFailPieces;
      groups += marks.a.groups;
      if (k == 0) flags = gfx::readStencil(target);
      overlays_->coverOverlap(cache_, marks, kOps[k], glm::vec4(1.0F, 0.0F, 0.0F, 0.5F), static_cast<float>(1u << k));
    }
    const std::vector<std::uint8_t> stencil = gfx::readStencil(target);
    EXPECT_EQ(std::count(stencil.begin(), stencil.end(), 0), static_cast<long>(stencil.size()))
        << c.kind << ": the stencil is not 0 after the covers";
    const std::vector<std::uint32_t> gpu = gfx::readMask(target);
    const std::vector<float> depth = gfx::readDepth(target);
    const overlay::DepthImage image{kWidth, kHeight, depth, c.viewProj()};
    const std::vector<std::uint32_t> expected = overlay::referenceMask(image, ref);
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
    for (std::size_t i = 0; i < gpu.size(); ++i) {
      const bool a = (expected[i] & 1u) != 0, b = (expected[i] & 2u) != 0;
      covered += a || b ? 1u : 0u;
      both += a && b ? 1u : 0u;
      std::uint32_t want = 0;
      for (std::size_t k = 0; k < kOps.size(); ++k) {
        if (overlay::overlapHolds(kOps[k], a, b)) {
          want |= 1u << k;
          ++opPixels[k];
        }
      }
      const std::uint32_t gotFlags =
          ((flags[i] & overlay::kOverlapFlagA) != 0 ? 1u : 0u) | ((flags[i] & overlay::kOverlapFlagB) != 0 ? 2u : 0u);
      const bool countsLeft = (flags[i] & overlay::kOverlapCountMask) != 0;
      if (gpu[i] == want && gotFlags == (expected[i] & 3u) && !countsLeft) continue;
      if (edges[i] != 0 && !countsLeft) {
        ++edgeWrong;
      } else {
        ++wrong;
        if (reported++ < 8) {
          ADD_FAILURE() << c.kind << ": pixel (" << i % kWidth << ", " << i / kWidth << ") covers " << gpu[i]
                        << " flags " << int{flags[i]} << ", reference " << want << " (layers " << expected[i] << ")";
        }
      }
    }
    // Around the squares' centre, the areas are 64 deep.
    const glm::dvec4 clip = c.viewProj() * glm::dvec4(centre_, groundAt(centre_), 1.0);
    if (clip.w > 0.0 && std::abs(clip.x) < clip.w && std::abs(clip.y) < clip.w) ++deep;
  }
  std::printf(
      "overlap: %zu covered pixels (%zu by both), %zu wrong away from edges, %zu on edges; "
      "and %zu, or %zu, xor %zu, subtract %zu; %zu z-fail pieces, %zu groups\n",
      covered, both, wrong, edgeWrong, opPixels[0], opPixels[1], opPixels[2], opPixels[3], zFail, groups);
  EXPECT_EQ(wrong, 0u);
  EXPECT_LE(edgeWrong, covered / 200);
  EXPECT_GT(both, 2000u) << "too little overlap to test the operators";
  EXPECT_GT(zFail, 0u) << "no camera put the eye inside a volume";
  EXPECT_GE(deep, 3u) << "the 64-deep squares were not in view";
}

TEST_F(LayerAnalysisTest, ClosedVolumesCountZeroEverywhereFromEveryCamera) {
  std::mt19937 rng(72);
  overlay::LayerStyle area, road, thin;
  road.widthAttribute = "width_m";
  road.join = overlay::LineJoin::Miter;
  road.cap = overlay::LineCap::Square;
  thin.widthPixels = 3.0;
  thin.maxWidthMetres = 40.0;
  std::vector<geo::Feature> areaList = areaFeatures(rng);
  std::vector<geo::Feature> roadList = randomLines(rng, lo_, hi_, 40);
  std::vector<overlay::OverlayLayer> layers;
  layers.push_back(build("areas", overlay::LayerKind::Polygon, area, areaList));
  layers.push_back(build("roads", overlay::LayerKind::Line, road, roadList));
  layers.push_back(build("roads in pixels", overlay::LayerKind::Line, thin, roadList));
  layers.push_back(build("areas (paper)", overlay::LayerKind::Polygon, area, areaList, true));
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::size_t zFail = 0, open = 0, frames = 0;
  const std::vector<Camera> list = cameras(rng, layers[0], 18);
  for (std::size_t n = 0; n < 2 * list.size(); ++n) {
    const Camera& c = list[n % list.size()];
    overlay::OverlaySettings settings;
    settings.forceZFail = n >= list.size();  // every piece clipped and capped
    drawTerrain(target, c);
    for (const overlay::OverlayLayer& layer : layers) {
      const overlay::AnalysisMarks marks = overlays_->countOpenFaces(cache_, c.view(), layer, settings);
      zFail += marks.a.zFailPieces;
      const std::vector<std::uint8_t> counts = gfx::readStencil(target);
      const auto nonZero =
          static_cast<std::size_t>(std::count_if(counts.begin(), counts.end(), [](auto v) { return v != 0; }));
      EXPECT_EQ(nonZero, 0u) << c.kind << (settings.forceZFail ? " (all z-fail)" : "") << ", " << layer.name();
      open += nonZero;
      overlays_->coverOpenFaces(cache_, marks, glm::vec4(0.0F, 1.0F, 0.0F, 1.0F), 1.0F);
      ++frames;
    }
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    EXPECT_EQ(std::count(mask.begin(), mask.end(), 0u), static_cast<long>(mask.size())) << c.kind;
  }
  std::printf("open faces: %zu frames, %zu open pixels, %zu pieces clipped and capped\n", frames, open, zFail);
  EXPECT_GT(zFail, 1000u);
}

/// The screen image of a triangle in pixel coordinates (x right, y down from the top row).
struct ScreenTriangle {
  std::array<glm::dvec2, 3> p;
  /// Signed distance (pixels) from the triangle's boundary: positive inside.
  [[nodiscard]] double inside(const glm::dvec2& q) const {
    const double area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < 3; ++k) {
      const glm::dvec2 a = p[k], b = p[(k + 1) % 3], e = b - a;
      const double cross = e.x * (q.y - a.y) - e.y * (q.x - a.x);
      d = std::min(d, (area > 0.0 ? cross : -cross) / glm::length(e));
    }
    return d;
  }
};

TEST_F(LayerAnalysisTest, AFaceTakenOutShowsAsExactlyItsScreenImage) {
  // One square area over gentle terrain; the camera looks at its largest piece from outside.
  std::vector<geo::Feature> square(1);
  geo::Polygon p;
  for (const glm::dvec2& d : {glm::dvec2(-1, -1), glm::dvec2(1, -1), glm::dvec2(1, 1), glm::dvec2(-1, 1)}) {
    p.outer.push_back(centre_ + 450.0 * d);
  }
  square[0].polygons.push_back(std::move(p));
  const overlay::OverlayLayer layer = build("square", overlay::LayerKind::Polygon, overlay::LayerStyle{}, square);
  std::size_t slot = 0;
  double largest = -1.0;
  for (std::size_t s = 0; s < layer.polyhedra().size(); ++s) {
    const overlay::Polyhedron& q = layer.polyhedra()[s];
    const double size = (q.boxMax.x - q.boxMin.x) * (q.boxMax.y - q.boxMin.y) * (1.0 + q.hi - q.lo);
    if (size > largest) {
      largest = size;
      slot = s;
    }
  }
  const overlay::Polyhedron& piece = layer.polyhedra()[slot];
  const overlay::OverlayLayer::PieceSlot& s = layer.slots()[slot];
  const glm::dvec2 mid = 0.5 * (piece.boxMin + piece.boxMax);
  const Camera camera{glm::dvec3(mid + glm::dvec2(-900.0, -1200.0), piece.hi + 700.0),
                      {mid, 0.5 * (piece.lo + piece.hi)},
                      1.0,
                      "oblique"};
  const glm::dmat4 viewProj = camera.viewProj();

  // The piece's triangles as the index buffer holds them (vertex 2k at lo, 2k + 1 at hi).
  std::vector<std::uint32_t> indices(s.indexCount);
  glGetNamedBufferSubData(layer.indexBuffer(), static_cast<GLintptr>(s.firstIndex * sizeof(std::uint32_t)),
                          static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)), indices.data());
  auto corner = [&](std::uint32_t v) {
    const glm::dvec2 xy = piece.footprint.vertices[v / 2];
    const glm::dvec4 c = viewProj * glm::dvec4(xy, v % 2 == 0 ? piece.lo : piece.hi, 1.0);
    return glm::dvec2((c.x / c.w + 1.0) * 0.5 * kWidth, (1.0 - c.y / c.w) * 0.5 * kHeight);
  };
  auto screenOf = [&](std::size_t t) {
    return ScreenTriangle{{corner(indices[3 * t]), corner(indices[3 * t + 1]), corner(indices[3 * t + 2])}};
  };
  auto pixelsInside = [&](const ScreenTriangle& tri) {
    std::size_t n = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) n += tri.inside({x + 0.5, y + 0.5}) > 1.0 ? 1u : 0u;
    }
    return n;
  };
  // The triangle with the largest image in each part: bottom cap, walls, top cap.
  const std::size_t triangles = indices.size() / 3, bottom = s.bottomCount / 3,
                    top = triangles - piece.footprint.triangles.size();
  std::array<std::size_t, 3> chosen{};
  std::array<std::size_t, 3> sizes{};
  for (std::size_t t = 0; t < triangles; ++t) {
    const std::size_t part = t < bottom ? 0 : (t < top ? 1 : 2);
    const std::size_t n = pixelsInside(screenOf(t));
    if (n > sizes[part]) {
      sizes[part] = n;
      chosen[part] = t;
    }
  }
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const char* names[] = {"bottom cap", "wall", "top cap"};
  for (std::size_t part = 0; part < 3; ++part) {
    ASSERT_GE(sizes[part], 15u) << names[part] << ": its image is too small to test";
    const std::size_t t = chosen[part];
    // Take the face out (a degenerate triangle), count, put it back.
    const GLintptr at = static_cast<GLintptr>((s.firstIndex + 3 * t) * sizeof(std::uint32_t));
    const std::array<std::uint32_t, 3> degenerate{indices[3 * t], indices[3 * t], indices[3 * t]};
    glNamedBufferSubData(layer.indexBuffer(), at, sizeof(degenerate), degenerate.data());
    drawTerrain(target, camera);
    const overlay::AnalysisMarks marks = overlays_->countOpenFaces(cache_, camera.view(), layer);
    EXPECT_EQ(marks.a.zFailPieces, 0u);
    const std::vector<std::uint8_t> counts = gfx::readStencil(target);
    overlays_->coverOpenFaces(cache_, marks, glm::vec4(0.0F, 1.0F, 0.0F, 1.0F), 1.0F);
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    glNamedBufferSubData(layer.indexBuffer(), at, sizeof(degenerate), &indices[3 * t]);
    const ScreenTriangle tri = screenOf(t);
    std::size_t shown = 0, missed = 0, extra = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
        const double d = tri.inside({x + 0.5, y + 0.5});
        const bool isOpen = counts[i] != 0;
        EXPECT_EQ(isOpen, mask[i] == 1u) << names[part] << ": the cover differs from the counts";
        if (d > 1.0) {
          shown += isOpen ? 1u : 0u;
          missed += isOpen ? 0u : 1u;
        } else if (d < -1.0) {
          extra += isOpen ? 1u : 0u;
        }
      }
    }
    std::printf("%s taken out: %zu of %zu pixels inside its image shown open, %zu outside\n", names[part], shown,
                sizes[part], extra);
    EXPECT_EQ(missed, 0u) << names[part];
    EXPECT_EQ(extra, 0u) << names[part];
  }
  // Put back, the piece is closed again.
  drawTerrain(target, camera);
  const overlay::AnalysisMarks marks = overlays_->countOpenFaces(cache_, camera.view(), layer);
  const std::vector<std::uint8_t> counts = gfx::readStencil(target);
  EXPECT_EQ(std::count(counts.begin(), counts.end(), 0), static_cast<long>(counts.size()));
  overlays_->coverOpenFaces(cache_, marks, glm::vec4(1.0F), 0.0F);
}

}  // namespace
}  // namespace gis::test
