// The deferred per-pixel technique against the CPU reference on the same depth buffer, as the
// stencil polyhedra are judged (overlay_gltest.cpp): Olinda through the scene renderer from
// top-down, oblique and grazing cameras and from inside road and polygon volumes, MSAA per
// sample, lines in pixels from afar and from on the road, colours by category and hidden
// features, and edits shown at the next frame. The case matrix from extreme cameras and far from
// the frame origin is in extreme_cases_gltest.cpp.
#include <array>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "olinda_scene.hpp"
#include "overlay_compare.hpp"
#include "random_features.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 256;
constexpr int kHeight = 192;

using overlay_test::atSample;
using overlay_test::compare;
using overlay_test::Comparison;
using overlay_test::deferredTechnique;
using overlay_test::drawTerrainAndTechnique;
using overlay_test::percent;

class DeferredGlTest : public GlTest {};

void add(Comparison& total, const Comparison& c) {
  total.covered += c.covered;
  total.wrong += c.wrong;
  total.edgeWrong += c.edgeWrong;
}

/// Olinda drawn by the deferred technique through the scene renderer.
OlindaScene loadOlindaDeferred() {
  const overlay::TechniqueInfo* deferred = overlay::findTechnique("deferred");
  EXPECT_NE(deferred, nullptr);
  return loadOlinda(deferred);
}

TEST_F(DeferredGlTest, OlindaMatchesTheCpuReferenceFromManyCameras) {
  OlindaScene olinda = loadOlindaDeferred();
  ASSERT_TRUE(olinda.renderer);
  ASSERT_GE(olinda.layers.size(), 3u);
  glm::dvec3 lo, hi;
  scene::terrainBox(*olinda.scene, 1.0, lo, hi);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;
  std::mt19937 rng(4242);
  std::uniform_real_distribution<double> ux(lo.x + 300, hi.x - 300), uy(lo.y + 300, hi.y - 300), unit(0.0, 1.0);
  const overlay::OverlayLayer* streets = nullptr;
  for (const overlay::OverlayLayer* l : olinda.layers)
    if (l->kind() == overlay::LayerKind::Line && l->name() == "streets") streets = l;
  ASSERT_NE(streets, nullptr);
  Comparison total;
  for (int trial = 0; trial < 30; ++trial) {
    const int kind = trial % 5;
    scene::Camera camera;
    camera.fovYDeg = 40.0;
    const glm::dvec2 t(ux(rng), uy(rng));
    const double h = olinda.scene->bounds->fullResolutionHeightAt(t);
    const double g = std::isnan(h) ? 0.0 : h;
    switch (kind) {
      case 0:  // straight down
        camera.eye = glm::dvec3(t + glm::dvec2(0.0, -1.0), g + 300.0 + 2000.0 * unit(rng));
        camera.target = glm::dvec3(t, g);
        break;
      case 1: {  // oblique
        const double a = 6.283 * unit(rng), d = 500.0 + 1500.0 * unit(rng);
        camera.eye = glm::dvec3(t + d * glm::dvec2(std::cos(a), std::sin(a)), g + 0.6 * d);
        camera.target = glm::dvec3(t, g);
        break;
      }
      case 2: {  // grazing at about 1°
        const double a = 6.283 * unit(rng), d = 1500.0;
        camera.eye = glm::dvec3(t + d * glm::dvec2(std::cos(a), std::sin(a)), g + 90.0 + d * 0.0175);
        camera.target = glm::dvec3(t, g + 90.0);
        break;
      }
      case 3: {  // 1.5 m over a street vertex
        const geo::Feature& f =
            streets->features()[std::uniform_int_distribution<std::size_t>(0, streets->features().size() - 1)(rng)];
        if (f.lines.empty() || f.lines.front().empty()) continue;
        const glm::dvec2 p = f.lines.front().front();
        const double ph = olinda.scene->bounds->fullResolutionHeightAt(p);
        camera.eye = glm::dvec3(p, (std::isnan(ph) ? 0.0 : ph) + 1.5);
        camera.target = glm::dvec3(p + glm::dvec2(80.0, 30.0), std::isnan(ph) ? 0.0 : ph);
        camera.nearPlane = 0.5;
        break;
      }
      default:  // 3 m above the ground inside a tract
        camera.eye = glm::dvec3(t, g + 3.0);
        camera.target = glm::dvec3(t + glm::dvec2(200.0, 50.0), g);
        camera.nearPlane = 0.5;
        break;
    }
    olinda.renderer->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
    const glm::dmat4 viewProj = camera.projection(static_cast<double>(kWidth) / kHeight) * camera.view();
    add(total, compare(target, viewProj, olinda.layers, "deferred #" + std::to_string(trial)));
  }
  std::printf("Olinda, deferred: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%)\n",
              total.covered, total.wrong, total.edgeWrong, percent(total.edgeWrong, total.covered));
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 100000u);
}

TEST_F(DeferredGlTest, MsaaIsExactPerSample) {
  OlindaScene olinda = loadOlindaDeferred();
  ASSERT_TRUE(olinda.renderer);
  glm::dvec3 lo, hi;
  scene::terrainBox(*olinda.scene, 1.0, lo, hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  gfx::RenderTarget msaa(kWidth, kHeight, 4, true), single(kWidth, kHeight, 0, true);
  ASSERT_EQ(msaa.samples(), 4);
  scene::RenderSettings settings;
  settings.waitForTiles = true;
  Comparison total;
  std::size_t mixed = 0;  // pixels whose samples disagree: the edges are anti-aliased
  for (const glm::dvec3& offset : {glm::dvec3(-900, -1400, 1300), glm::dvec3(800, 200, 500)}) {
    scene::Camera camera;
    camera.eye = centre + offset;
    camera.target = centre;
    camera.fovYDeg = 40.0;
    olinda.renderer->render(cache_, msaa.framebuffer(), kWidth, kHeight, camera, settings);
    const glm::dmat4 viewProj = camera.projection(static_cast<double>(kWidth) / kHeight) * camera.view();
    std::vector<std::vector<std::uint32_t>> masks;
    for (int k = 0; k < 4; ++k) {
      GLfloat position[2] = {0.5F, 0.5F};
      glGetMultisamplefv(GL_SAMPLE_POSITION, static_cast<GLuint>(k), position);
      msaa.copySampleInto(cache_, single, k);
      add(total, compare(single, atSample(viewProj, position[0], position[1], kWidth, kHeight), olinda.layers,
                         "deferred msaa sample " + std::to_string(k)));
      masks.push_back(gfx::readMask(single));
    }
    for (std::size_t i = 0; i < masks[0].size(); ++i)
      mixed += masks[0][i] != masks[1][i] || masks[0][i] != masks[2][i] || masks[0][i] != masks[3][i];
  }
  std::printf("deferred, MSAA 4x: %zu covered samples, %zu wrong away from edges, %zu on edges; %zu mixed pixels\n",
              total.covered, total.wrong, total.edgeWrong, mixed);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(mixed, 100u);
}

/// A stiff terrain with its engine and bounds, for layers built by hand.
struct Terrain {
  std::shared_ptr<terrain::TerrainQuadtree> tree;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds;
  std::optional<terrain::TerrainEngine> engine;
  glm::dvec2 lo{0.0}, hi{0.0};
};

Terrain makeTerrain(int posts, std::uint32_t seed) {
  Terrain t;
  t.tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = posts, .height = posts, .seed = seed}), 16);
  t.bounds = std::make_shared<terrain::QuadtreeHeightBounds>(t.tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(t.tree, nullptr);
  EXPECT_TRUE(engine.ok());
  if (engine) t.engine.emplace(std::move(*engine));
  const terrain::TerrainGrid& grid = t.tree->grid();
  t.lo = grid.postPosition(0, grid.height - 1);
  t.hi = grid.postPosition(grid.width - 1, 0);
  return t;
}

/// Draws the layers from (eye, at) with the technique and compares them with the reference; every
/// layer is looked up (none left to the pieces).
Comparison drawAndCompare(gfx::StateCache& cache, gfx::RenderTarget& target, Terrain& t,
                          overlay::OverlayTechnique& technique, const std::vector<const overlay::OverlayLayer*>& layers,
                          const glm::dvec3& eye, const glm::dvec3& at, const std::string& label) {
  const double fov = glm::radians(45.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj =
      gfx::reversedInfinitePerspective(fov, aspect, 0.5) * gfx::lookAt(eye, at, glm::dvec3(0, 0, 1));
  overlay::TechniqueFrameStats stats;
  drawTerrainAndTechnique(cache, target, *t.engine, technique,
                          terrain::selectLod(*t.tree, {eye, viewProj, kHeight, fov}), {viewProj, eye, 0.5, fov, aspect},
                          layers, {}, 1.0, &stats);
  EXPECT_EQ(stats.deferredLayers, layers.size()) << label;
  return compare(target, viewProj, layers, label);
}

TEST_F(DeferredGlTest, LinesInPixelsMatchTheReferenceFromFarAndFromOnTheRoad) {
  Terrain t = makeTerrain(257, 11);
  ASSERT_TRUE(t.engine);
  std::mt19937 rng(23);
  overlay::LayerStyle round, miter;
  round.widthPixels = 3.0;
  round.maxWidthMetres = 40.0;
  miter.widthPixels = 2.0;
  miter.maxWidthMetres = 25.0;
  miter.join = overlay::LineJoin::Miter;
  miter.cap = overlay::LineCap::Square;
  const std::vector<geo::Feature> roundLines = randomLines(rng, t.lo, t.hi, 20),
                                  miterLines = randomLines(rng, t.lo, t.hi, 20);
  overlay::LayerBuildOptions options;
  options.deferPieces = true;
  Result<overlay::OverlayLayer> a =
      overlay::OverlayLayer::build("round", overlay::LayerKind::Line, round, roundLines, *t.bounds, options);
  Result<overlay::OverlayLayer> b =
      overlay::OverlayLayer::build("miter", overlay::LayerKind::Line, miter, miterLines, *t.bounds, options);
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<const overlay::OverlayLayer*> layers{&*a, &*b};
  std::unique_ptr<overlay::OverlayTechnique> technique = deferredTechnique(t.bounds.get());
  ASSERT_TRUE(technique);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::uniform_real_distribution<double> ux(t.lo.x, t.hi.x), uy(t.lo.y, t.hi.y), unit(0.0, 1.0);
  Comparison total;
  for (int trial = 0; trial < 16; ++trial) {
    glm::dvec3 eye, at;
    if (trial < 8) {  // from afar: a few pixels wide at every distance
      const glm::dvec2 p(ux(rng), uy(rng));
      const double angle = 6.283 * unit(rng), d = 300.0 + 3000.0 * unit(rng);
      eye = glm::dvec3(p + d * glm::dvec2(std::cos(angle), std::sin(angle)), 400.0 + 2500.0 * unit(rng));
      at = glm::dvec3(p, 0.0);
    } else {  // standing on a road, looking along it
      const geo::LineString& line =
          (trial % 2 == 0 ? roundLines : miterLines)[static_cast<std::size_t>(trial)].lines[0];
      const glm::dvec2 p = line[2] + (unit(rng) - 0.5) * glm::dvec2(2.0, 2.0);
      eye = glm::dvec3(p, t.bounds->fullResolutionHeightAt(p) + 1.0 + 8.0 * unit(rng));
      at = glm::dvec3(line[3], t.bounds->fullResolutionHeightAt(line[3]));
    }
    add(total, drawAndCompare(cache_, target, t, *technique, layers, eye, at, "pixels #" + std::to_string(trial)));
  }
  std::printf("deferred, lines in pixels: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%)\n",
              total.covered, total.wrong, total.edgeWrong, percent(total.edgeWrong, total.covered));
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 5000u);
}

TEST_F(DeferredGlTest, ColoursByCategoryHiddenFeaturesAndEditsShowAtTheNextFrame) {
  Terrain t = makeTerrain(129, 4);
  ASSERT_TRUE(t.engine);
  const glm::dvec2 centre = 0.5 * (t.lo + t.hi);
  std::vector<geo::Feature> squares;
  const char* kinds[] = {"park", "water", "other"};
  for (int i = 0; i < 3; ++i) {
    geo::Feature f;
    f.fid = 10 + i;
    f.attributes["kind"] = std::string(kinds[i]);
    const glm::dvec2 c = centre + glm::dvec2(-500.0 + 500.0 * i, 0.0);
    f.polygons.push_back(
        {{c + glm::dvec2(-200, -200), c + glm::dvec2(200, -200), c + glm::dvec2(200, 200), c + glm::dvec2(-200, 200)},
         {{c + glm::dvec2(-50, -50), c + glm::dvec2(50, -50), c + glm::dvec2(50, 50), c + glm::dvec2(-50, 50)}}});
    squares.push_back(std::move(f));
  }
  // The first square overlaps the second: the first feature's colour shows where both cover.
  squares[0].polygons.push_back({{centre + glm::dvec2(-330, -100), centre + glm::dvec2(-150, -100),
                                  centre + glm::dvec2(-150, 100), centre + glm::dvec2(-330, 100)},
                                 {}});
  overlay::LayerStyle style;
  style.color = glm::vec4(0.0F, 0.0F, 1.0F, 1.0F);
  style.opacity = 1.0F;
  style.colorAttribute = "kind";
  style.categories["park"] = glm::vec4(0.0F, 1.0F, 0.0F, 1.0F);
  style.categories["water"] = glm::vec4(1.0F, 0.0F, 0.0F, 1.0F);
  overlay::LayerBuildOptions options;
  options.deferPieces = true;
  Result<overlay::OverlayLayer> layer =
      overlay::OverlayLayer::build("landuse", overlay::LayerKind::Polygon, style, squares, *t.bounds, options);
  ASSERT_TRUE(layer.ok());
  std::unique_ptr<overlay::OverlayTechnique> technique = deferredTechnique(t.bounds.get());
  ASSERT_TRUE(technique);
  const glm::dvec3 eye(centre + glm::dvec2(0.0, -10.0), 2200.0);
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(fov, aspect, 1.0) *
                              gfx::lookAt(eye, glm::dvec3(centre, 0.0), glm::dvec3(0, 0, 1));
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const std::array<std::array<std::uint8_t, 3>, 3> expected{{{0, 255, 0}, {255, 0, 0}, {0, 0, 255}}};
  auto check = [&](const std::array<bool, 3>& shown, const char* label) {
    SCOPED_TRACE(label);
    drawTerrainAndTechnique(cache_, target, *t.engine, *technique,
                            terrain::selectLod(*t.tree, {eye, viewProj, kHeight, fov}),
                            {viewProj, eye, 1.0, fov, aspect}, {&*layer});
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint8_t> rgba = gfx::readColorRgba8(target);
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    const overlay::DepthImage image{kWidth, kHeight, depth, viewProj};
    const std::vector<overlay::ReferenceLayer> ref = overlay_test::referenceLayers({&*layer});
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
    std::array<std::size_t, 3> seen{};
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const auto i = static_cast<std::size_t>(y * kWidth + x);
        if (edges[i] != 0) continue;
        const std::vector<overlay::PickedFeature> under = overlay::pick(image, ref, x, y);
        std::optional<std::size_t> first;
        for (const overlay::PickedFeature& p : under)
          if (shown[p.feature] && !first) first = p.feature;
        if (!first) {
          ASSERT_EQ(mask[i], 0u) << x << " " << y;
          continue;
        }
        ++seen[*first];
        ASSERT_EQ(mask[i], 1u);
        for (std::size_t c = 0; c < 3; ++c) ASSERT_EQ(rgba[i * 4 + c], expected[*first][c]) << "feature " << *first;
      }
    }
    for (std::size_t f = 0; f < 3; ++f) EXPECT_EQ(seen[f] > 100, shown[f]) << "feature " << f;
  };
  check({true, true, true}, "all shown");
  overlay::FeatureStyle hidden = layer->featureStyles()[1];
  hidden.visible = false;
  EXPECT_TRUE(layer->setFeatureStyle(1, hidden).empty());
  technique->featureChanged(0, 1, centre - glm::dvec2(300.0), centre + glm::dvec2(300.0));
  check({true, false, true}, "the second hidden");
  // Moved: the third square 150 m north.
  geo::Feature moved = layer->features()[2];
  for (glm::dvec2& p : moved.polygons[0].outer) p += glm::dvec2(0.0, 150.0);
  for (geo::Ring& h : moved.polygons[0].holes)
    for (glm::dvec2& p : h) p += glm::dvec2(0.0, 150.0);
  EXPECT_TRUE(layer->replaceFeature(2, moved).empty());
  technique->featureChanged(0, 2, centre - glm::dvec2(800.0), centre + glm::dvec2(800.0));
  check({true, false, true}, "the third moved");
}

}  // namespace
}  // namespace gis::test

namespace gis::test {
namespace {

TEST_F(DeferredGlTest, AutoMeasuresBothAndEveryFrameIsExact) {
  // `auto` draws with the stencil polyhedra, measures the deferred lookup now and then, and keeps
  // the cheaper: whichever draws, each frame matches the reference.
  const overlay::TechniqueInfo* autoTechnique = overlay::findTechnique("auto");
  ASSERT_NE(autoTechnique, nullptr);
  OlindaScene olinda = loadOlinda(autoTechnique);
  ASSERT_TRUE(olinda.renderer);
  auto& scene = olinda.scene;
  auto& renderer = olinda.renderer;
  const std::vector<const overlay::OverlayLayer*>& layers = olinda.layers;
  glm::dvec3 lo, hi;
  scene::terrainBox(*scene, 1.0, lo, hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;
  Comparison total, byDeferred;
  std::size_t deferredFrames = 0, stencilFrames = 0;
  for (int frame = 0; frame < 60; ++frame) {
    scene::Camera camera;
    camera.eye = centre + glm::dvec3(-900.0 + 2.0 * frame, -1400.0, 1300.0);
    camera.target = centre;
    camera.fovYDeg = 40.0;
    const scene::FrameStats stats = renderer->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
    (stats.overlayTiles.deferredLayers > 0 ? deferredFrames : stencilFrames) += 1;
    if (frame % 6 == 0 || stats.overlayTiles.deferredLayers > 0) {
      const glm::dmat4 viewProj = camera.projection(static_cast<double>(kWidth) / kHeight) * camera.view();
      const bool deferred = stats.overlayTiles.deferredLayers > 0;
      const Comparison c = compare(target, viewProj, layers, "auto frame " + std::to_string(frame), deferred);
      add(deferred ? byDeferred : total, c);
    }
  }
  std::printf(
      "auto: %zu frames by the stencil polyhedra (%zu covered, %zu wrong), %zu with the deferred lookup (%zu covered, "
      "%zu wrong)\n",
      stencilFrames, total.covered, total.wrong, deferredFrames, byDeferred.covered, byDeferred.wrong);
  EXPECT_EQ(byDeferred.wrong, 0u);
  EXPECT_GT(byDeferred.covered, 10000u);
  // The tiles are generalised within 0.5 px of the source, as far as the edge test reaches: on
  // this path one pixel of the tracts flips at frame 30 (stencil-tiles alone does the same; see
  // docs/overlay.md). At most 2 in 10^5.
  EXPECT_LE(total.wrong * 50000, total.covered);
  EXPECT_GT(deferredFrames, 0u) << "the deferred lookup was never measured";
  EXPECT_GT(stencilFrames, 0u);
}

}  // namespace
}  // namespace gis::test

namespace gis::test {
namespace {

TEST_F(DeferredGlTest, ALineAsWideAsTheWidestAcceptedStaysExactInABoundedIndex) {
  // A road whose width_m is 1e15 (the widest footprints.hpp accepts): before, the index split
  // every node it met down to 1 km leaves and the run ended in std::bad_alloc at 23 GB. With the
  // terrain's cell grid (as the scene renderer makes the technique) the index covers the terrain
  // and no more; the mask equals the reference. Two layers: the wide road last behind ordinary
  // ones with flat caps (its flat end crosses the terrain: a real edge in view), and first ahead
  // of them with round caps (it covers the terrain: nothing behind it counts).
  Terrain t = makeTerrain(129, 7);
  ASSERT_TRUE(t.engine);
  std::mt19937 rng(40);
  const glm::dvec2 centre = 0.5 * (t.lo + t.hi);
  geo::Feature wide;
  wide.fid = 1000;
  wide.attributes["width_m"] = 1e15;
  wide.lines.push_back({centre, centre + glm::dvec2(700.0, 250.0)});
  std::vector<geo::Feature> behind = randomLines(rng, t.lo, t.hi, 8);
  behind.push_back(wide);
  std::vector<geo::Feature> ahead{wide};
  for (geo::Feature& f : randomLines(rng, t.lo, t.hi, 8)) ahead.push_back(std::move(f));
  overlay::LayerStyle flat, round;
  flat.widthMetres = round.widthMetres = 8.0;
  flat.widthAttribute = round.widthAttribute = "width_m";
  flat.cap = overlay::LineCap::Flat;
  flat.join = overlay::LineJoin::Miter;
  overlay::LayerBuildOptions options;
  options.deferPieces = true;
  Result<overlay::OverlayLayer> a =
      overlay::OverlayLayer::build("wide last", overlay::LayerKind::Line, flat, behind, *t.bounds, options);
  Result<overlay::OverlayLayer> b =
      overlay::OverlayLayer::build("wide first", overlay::LayerKind::Line, round, ahead, *t.bounds, options);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->stats().skippedFeatures + b->stats().skippedFeatures, 0u);
  const std::vector<const overlay::OverlayLayer*> layers{&*a, &*b};

  overlay::TechniqueOptions techniqueOptions;
  techniqueOptions.bounds = t.bounds.get();
  overlay::CellGrid cells;
  cells.origin = t.lo;
  cells.cellSize = 320.0;
  cells.columns = cells.rows = 8;
  techniqueOptions.build.footprints.cells = cells;
  Result<std::unique_ptr<overlay::OverlayTechnique>> made =
      overlay::findTechnique("deferred")->create(techniqueOptions);
  ASSERT_TRUE(made.ok());
  overlay::OverlayTechnique& technique = **made;
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Comparison total;
  for (int trial = 0; trial < 8; ++trial) {
    glm::dvec3 eye, at;
    if (trial == 0) {  // straight down on the flat end
      eye = glm::dvec3(centre + glm::dvec2(0.0, -1.0), 1800.0);
      at = glm::dvec3(centre, 0.0);
    } else if (trial == 1) {  // 1.5 m above the ground by the flat end, looking across it
      const glm::dvec2 p = centre + glm::dvec2(-30.0, 0.0);
      eye = glm::dvec3(p, t.bounds->fullResolutionHeightAt(p) + 1.5);
      at = glm::dvec3(centre + glm::dvec2(200.0, 60.0), t.bounds->fullResolutionHeightAt(centre));
    } else {  // oblique and grazing
      const double angle = 6.283 * unit(rng), d = 600.0 + 2000.0 * unit(rng);
      eye = glm::dvec3(centre + d * glm::dvec2(std::cos(angle), std::sin(angle)), 50.0 + 1500.0 * unit(rng));
      at = glm::dvec3(centre + 300.0 * glm::dvec2(unit(rng) - 0.5, unit(rng) - 0.5), 0.0);
    }
    add(total, drawAndCompare(cache_, target, t, technique, layers, eye, at, "wide #" + std::to_string(trial)));
  }
  const std::size_t bytes = technique.gpuBytes();
  std::printf("deferred, a line 1e15 m wide: %zu covered pixels, %zu wrong away from edges, %zu on edges; %.2f MB\n",
              total.covered, total.wrong, total.edgeWrong, static_cast<double>(bytes) / 1e6);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 100000u);
  // The indices and the depth copy: a few hundred kilobytes for 16 roads and the wide one.
  EXPECT_LT(bytes, std::size_t{8} << 20);
}

}  // namespace
}  // namespace gis::test
