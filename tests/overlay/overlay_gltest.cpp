// The overlay core against the CPU reference on the same depth buffer (docs/design.md §7): the GPU mask
// (bit per layer, from the real mark and cover passes) must equal the reference's coverage at
// every pixel that does not straddle a feature edge, and differ on at most 0.5 % of covered
// pixels on edges. Olinda (real tracts and streets, with outlines) from top-down, oblique and
// grazing cameras, with the eye inside polygon and road volumes and the near plane cutting
// them; stiff synthetic terrain (400 m cliffs, a spike, holes) with features over cliffs, under
// forced coarse levels of detail and with tiles still loading (the bounds contract).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <random>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/image_io.hpp"
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
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 256;
constexpr int kHeight = 192;

using overlay_test::atSample;
using overlay_test::compare;
using overlay_test::Comparison;
using overlay_test::drawTerrainAndLayers;
using overlay_test::percent;
using overlay_test::referenceLayers;

/// Build options that split pieces at the terrain's 16-cell chunks, as the scene renderer does.
overlay::LayerBuildOptions splitAtChunks(const terrain::TerrainGrid& grid) {
  overlay::LayerBuildOptions options;
  overlay::CellGrid cells;
  cells.origin = grid.postPosition(0, grid.height - 1);
  cells.cellSize = 16 * grid.step.x;
  cells.columns = cells.rows = (grid.width - 1) / 16;
  options.footprints.cells = cells;
  return options;
}

class OverlayGlTest : public GlTest {};

TEST_F(OverlayGlTest, OlindaMatchesTheCpuReferenceFromManyCameras) {
  OlindaScene olinda = loadOlinda();
  ASSERT_TRUE(olinda.renderer);
  auto& scene = olinda.scene;
  auto& renderer = olinda.renderer;
  const std::vector<const overlay::OverlayLayer*>& layers = olinda.layers;
  ASSERT_GE(layers.size(), 2u);

  glm::dvec3 lo, hi;
  scene::terrainBox(*scene, 1.0, lo, hi);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  std::mt19937 rng(4242);
  std::uniform_real_distribution<double> ux(lo.x + 300, hi.x - 300), uy(lo.y + 300, hi.y - 300);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Street vertices, to put the eye inside road volumes.
  const overlay::OverlayLayer* streets = nullptr;
  for (const overlay::OverlayLayer& l : renderer->overlayLayers()) {
    if (l.kind() == overlay::LayerKind::Line && l.name() == "streets") streets = &l;
  }
  ASSERT_NE(streets, nullptr);

  Comparison total;
  const char* kinds[] = {"top-down", "oblique", "grazing", "inside road", "inside polygon", "near plane cuts"};
  // The same cameras twice: as classified (z-pass unless a piece may hold the eye or meet the
  // near plane), then with every piece forced through the z-fail path.
  for (int trial = 0; trial < 72; ++trial) {
    if (trial == 36) rng.seed(4242);
    settings.overlay.forceZFail = trial >= 36;
    const int kind = trial % 6;
    scene::Camera camera;
    camera.fovYDeg = 40.0;
    const glm::dvec2 target2(ux(rng), uy(rng));
    const double ground = scene->bounds->fullResolutionHeightAt(target2);
    const double g = std::isnan(ground) ? 0.0 : ground;
    switch (kind) {
      case 0:  // straight down (tiny tilt for lookAt)
        camera.eye = glm::dvec3(target2 + glm::dvec2(0.0, -1.0), g + 300.0 + 2000.0 * unit(rng));
        camera.target = glm::dvec3(target2, g);
        break;
      case 1: {  // oblique
        const double a = 6.283 * unit(rng), d = 500.0 + 1500.0 * unit(rng);
        camera.eye = glm::dvec3(target2 + d * glm::dvec2(std::cos(a), std::sin(a)), g + 0.6 * d);
        camera.target = glm::dvec3(target2, g);
        break;
      }
      case 2: {  // grazing at about 1°
        const double a = 6.283 * unit(rng), d = 1500.0;
        camera.eye = glm::dvec3(target2 + d * glm::dvec2(std::cos(a), std::sin(a)), g + 90.0 + d * 0.0175);
        camera.target = glm::dvec3(target2, g + 90.0);
        break;
      }
      case 3: {  // the eye low over a street vertex: inside its road volume
        const geo::Feature& f =
            streets->features()[std::uniform_int_distribution<std::size_t>(0, streets->features().size() - 1)(rng)];
        if (f.lines.empty() || f.lines.front().empty()) continue;
        const glm::dvec2 p = f.lines.front().front();
        const double h = scene->bounds->fullResolutionHeightAt(p);
        camera.eye = glm::dvec3(p, (std::isnan(h) ? 0.0 : h) + 1.5);
        camera.target = glm::dvec3(p + glm::dvec2(80.0, 30.0), std::isnan(h) ? 0.0 : h);
        camera.nearPlane = 0.5;
        break;
      }
      case 4:  // a few metres above the ground inside a tract
        camera.eye = glm::dvec3(target2, g + 3.0);
        camera.target = glm::dvec3(target2 + glm::dvec2(200.0, 50.0), g);
        camera.nearPlane = 0.5;
        break;
      default:  // a far near plane that cuts the volumes in front of a low eye
        camera.eye = glm::dvec3(target2, g + 25.0);
        camera.target = glm::dvec3(target2 + glm::dvec2(150.0, 0.0), g);
        camera.nearPlane = 30.0;
        break;
    }
    const scene::FrameStats stats = renderer->render(cache_, target.framebuffer(), kWidth, kHeight, camera, settings);
    const double aspect = static_cast<double>(kWidth) / kHeight;
    Comparison c = compare(target, camera.projection(aspect) * camera.view(), layers,
                           std::string(kinds[kind]) + " #" + std::to_string(trial));
    for (const overlay::LayerFrameStats& s : stats.layers) c.zFailPieces += s.zFailPieces;
    total.covered += c.covered;
    total.wrong += c.wrong;
    total.edgeWrong += c.edgeWrong;
    total.zFailPieces += c.zFailPieces;
  }
  std::printf("Olinda: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%), %zu z-fail pieces\n",
              total.covered, total.wrong, total.edgeWrong, percent(total.edgeWrong, total.covered), total.zFailPieces);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 100000u);
  EXPECT_GT(total.zFailPieces, 0u) << "no camera put the eye inside a volume";
}

TEST_F(OverlayGlTest, StiffTerrainUnderCoarseAndLoadingLodsMissesNoPixel) {
  auto tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 257, .height = 257, .seed = 3}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  ASSERT_TRUE(engine.ok());
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(overlays.ok());
  const terrain::TerrainGrid& grid = tree->grid();
  const glm::dvec2 lo = grid.postPosition(0, grid.height - 1), hi = grid.postPosition(grid.width - 1, 0);

  std::mt19937 rng(17);
  const overlay::LayerBuildOptions options = splitAtChunks(grid);
  overlay::LayerStyle area, road;
  area.opacity = 0.5F;
  road.widthAttribute = "width_m";
  road.join = overlay::LineJoin::Miter;
  road.cap = overlay::LineCap::Square;
  Result<overlay::OverlayLayer> polygons = overlay::OverlayLayer::build(
      "areas", overlay::LayerKind::Polygon, area, randomPolygons(rng, lo, hi, 25), *bounds, options);
  Result<overlay::OverlayLayer> lines = overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, road,
                                                                     randomLines(rng, lo, hi, 30), *bounds, options);
  ASSERT_TRUE(polygons.ok() && lines.ok());
  const std::vector<const overlay::OverlayLayer*> layers{&*polygons, &*lines};

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), unit(0.0, 1.0);
  Comparison total;
  for (int trial = 0; trial < 24; ++trial) {
    const glm::dvec2 t(ux(rng), uy(rng));
    const double a = 6.283 * unit(rng), d = 300.0 + 3000.0 * unit(rng);
    const glm::dvec3 eye(t + d * glm::dvec2(std::cos(a), std::sin(a)), 600.0 + 2500.0 * unit(rng));
    const double fov = glm::radians(45.0), aspect = static_cast<double>(kWidth) / kHeight;
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, glm::dvec3(t, 0.0), glm::dvec3(0, 0, 1));
    terrain::LodView view{eye, viewProj, kHeight, fov};
    terrain::LodOptions lod;
    lod.pixelTolerance = 1.0;
    if (trial % 3 == 1) lod.coarsestAllowedLevel = std::uniform_int_distribution<int>(1, tree->rootLevel())(rng);
    if (trial % 3 == 2) {
      const unsigned salt = static_cast<unsigned>(rng());
      lod.resident = [salt](const terrain::NodeId& n) {
        return ((n.key() * 2654435761u) ^ salt) % 3 != 0 || n.level > 2;
      };
    }
    const terrain::LodSelection selection = terrain::selectLod(*tree, view, lod);
    overlay::OverlaySettings os;
    os.forceGroups = trial % 2 == 1;  // the grouped scheme must give the same pixels
    drawTerrainAndLayers(cache_, target, *engine, *overlays, selection, {viewProj, eye, 1.0, fov, aspect}, layers, os);
    const Comparison c = compare(target, viewProj, layers, "stiff #" + std::to_string(trial));
    total.covered += c.covered;
    total.wrong += c.wrong;
    total.edgeWrong += c.edgeWrong;
  }
  std::printf("stiff: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%)\n", total.covered,
              total.wrong, total.edgeWrong, percent(total.edgeWrong, total.covered));
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 20000u);
}

TEST_F(OverlayGlTest, MsaaIsExactPerSample) {
  OlindaScene olinda = loadOlinda();
  ASSERT_TRUE(olinda.renderer);
  auto& scene = olinda.scene;
  auto& renderer = olinda.renderer;
  const std::vector<const overlay::OverlayLayer*>& layers = olinda.layers;
  glm::dvec3 lo, hi;
  scene::terrainBox(*scene, 1.0, lo, hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  gfx::RenderTarget msaa(kWidth, kHeight, 4, true), single(kWidth, kHeight, 0, true);
  ASSERT_EQ(msaa.samples(), 4);
  scene::RenderSettings settings;
  settings.waitForTiles = true;  // still images, judged against the reference
  Comparison total;
  std::size_t differingSamples = 0;  // samples of one pixel that disagree: MSAA does anti-alias
  for (const glm::dvec3& offset : {glm::dvec3(-900, -1400, 1300), glm::dvec3(800, 200, 500)}) {
    scene::Camera camera;
    camera.eye = centre + offset;
    camera.target = centre;
    camera.fovYDeg = 40.0;
    renderer->render(cache_, msaa.framebuffer(), kWidth, kHeight, camera, settings);
    const glm::dmat4 viewProj = camera.projection(static_cast<double>(kWidth) / kHeight) * camera.view();
    std::vector<std::vector<std::uint32_t>> masks;
    for (int k = 0; k < 4; ++k) {
      GLfloat position[2] = {0.5F, 0.5F};
      glGetMultisamplefv(GL_SAMPLE_POSITION, static_cast<GLuint>(k), position);
      msaa.copySampleInto(cache_, single, k);
      const Comparison c = compare(single, atSample(viewProj, position[0], position[1], kWidth, kHeight), layers,
                                   "msaa sample " + std::to_string(k));
      total.covered += c.covered;
      total.wrong += c.wrong;
      total.edgeWrong += c.edgeWrong;
      masks.push_back(gfx::readMask(single));
    }
    for (std::size_t i = 0; i < masks[0].size(); ++i) {
      differingSamples += (masks[0][i] != masks[1][i] || masks[0][i] != masks[2][i] || masks[0][i] != masks[3][i]);
    }
  }
  std::printf("MSAA 4x: %zu covered samples, %zu wrong away from edges, %zu on edges; %zu pixels with mixed samples\n",
              total.covered, total.wrong, total.edgeWrong, differingSamples);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(differingSamples, 100u) << "4x MSAA should give anti-aliased edges";
}

TEST_F(OverlayGlTest, EditingOneFeatureShowsInTheNextFrameAndTouchesOnlyItsPieces) {
  auto tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 257, .height = 257, .seed = 5}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  const terrain::TerrainGrid& grid = tree->grid();
  const glm::dvec2 lo = grid.postPosition(0, grid.height - 1), hi = grid.postPosition(grid.width - 1, 0);
  std::mt19937 rng(23);
  overlay::LayerStyle style;
  Result<overlay::OverlayLayer> layer = overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, style,
                                                                     randomPolygons(rng, lo, hi, 12), *bounds);
  ASSERT_TRUE(layer.ok());
  const glm::dvec3 eye(0.5 * (lo + hi) + glm::dvec2(-2500.0, -2500.0), 3500.0);
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(fov, aspect, 1.0) *
                              gfx::lookAt(eye, glm::dvec3(0.5 * (lo + hi), 0.0), glm::dvec3(0, 0, 1));
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  auto frame = [&] {
    terrain::LodView view{eye, viewProj, kHeight, fov};
    const std::vector<const overlay::OverlayLayer*> layers{&*layer};
    drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, view),
                         {viewProj, eye, 1.0, fov, aspect}, layers);
    return compare(target, viewProj, layers, "edit");
  };
  const Comparison before = frame();
  EXPECT_EQ(before.wrong, 0u);
  // Move feature 3 by 400 m: only its slots change; the others keep theirs.
  std::vector<std::vector<std::uint32_t>> slotsBefore;
  auto slotsOf = [&](std::size_t feature) {
    std::vector<std::uint32_t> out;
    for (std::size_t k = 0; k < layer->slots().size(); ++k) {
      if (layer->slots()[k].live && layer->slots()[k].feature == feature) out.push_back(static_cast<std::uint32_t>(k));
    }
    return out;
  };
  for (std::size_t f = 0; f < layer->features().size(); ++f) slotsBefore.push_back(slotsOf(f));
  geo::Feature moved = layer->features()[3];
  for (glm::dvec2& p : moved.polygons[0].outer) p += glm::dvec2(400.0, 0.0);
  for (geo::Ring& h : moved.polygons[0].holes) {
    for (glm::dvec2& p : h) p += glm::dvec2(400.0, 0.0);
  }
  EXPECT_TRUE(layer->replaceFeature(3, moved).empty());
  for (std::size_t f = 0; f < layer->features().size(); ++f) {
    if (f == 3) {
      EXPECT_NE(slotsOf(f), slotsBefore[f]);
    } else {
      EXPECT_EQ(slotsOf(f), slotsBefore[f]) << "feature " << f << " was rebuilt";
    }
  }
  const Comparison after = frame();  // the reference reads the layer's (edited) features
  EXPECT_EQ(after.wrong, 0u);
  layer->removeFeature(5);
  EXPECT_TRUE(slotsOf(5).empty());
  const Comparison removed = frame();
  EXPECT_EQ(removed.wrong, 0u);
  EXPECT_LT(removed.covered, after.covered + 1);
}

TEST_F(OverlayGlTest, MoreThan255OverlappingPiecesOfALayerAreStillExact) {
  auto tree = std::make_shared<terrain::TerrainQuadtree>(
      makeStiffTerrain({.width = 129, .height = 129, .seed = 2, .cliffs = false, .spike = false, .holes = false}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  const glm::dvec2 centre = tree->grid().postPosition(64, 64);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  for (int count : {256, 300}) {
    // `count` squares over a common centre: there the count is 256 (≡ 0 mod 256) or 300.
    std::vector<geo::Feature> squares;
    for (int i = 0; i < count; ++i) {
      geo::Feature f;
      f.fid = i;
      const double r = 300.0 + 2.0 * i, a = 0.01 * i;
      geo::Polygon p;
      for (int k = 0; k < 4; ++k) {
        const double t = a + 1.5708 * k;
        p.outer.push_back(centre + r * glm::dvec2(std::cos(t), std::sin(t)));
      }
      f.polygons.push_back(std::move(p));
      squares.push_back(std::move(f));
    }
    overlay::LayerStyle style;
    Result<overlay::OverlayLayer> layer =
        overlay::OverlayLayer::build("deep", overlay::LayerKind::Polygon, style, squares, *bounds);
    ASSERT_TRUE(layer.ok());
    EXPECT_GE(layer->maxOverlap(), static_cast<std::size_t>(count));
    for (const glm::dvec3& offset : {glm::dvec3(0, -10, 2500), glm::dvec3(-1500, -1200, 900)}) {
      const glm::dvec3 eye = glm::dvec3(centre, 0.0) + offset;
      const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
      const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(fov, aspect, 1.0) *
                                  gfx::lookAt(eye, glm::dvec3(centre, 0.0), glm::dvec3(0, 0, 1));
      terrain::LodView view{eye, viewProj, kHeight, fov};
      const std::vector<const overlay::OverlayLayer*> layers{&*layer};
      const auto stats = drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, view),
                                              {viewProj, eye, 1.0, fov, aspect}, layers);
      EXPECT_TRUE(stats[0].grouped);
      const Comparison c = compare(target, viewProj, layers, std::to_string(count) + " squares");
      EXPECT_EQ(c.wrong, 0u) << count << " squares";
      EXPECT_GT(c.covered, 1000u);
      // Every layer pixel was coloured once and cleared: the stencil is back to zero.
      const std::vector<std::uint8_t> stencil = gfx::readStencil(target);
      EXPECT_EQ(std::count(stencil.begin(), stencil.end(), 0), static_cast<long>(stencil.size()));
    }
  }
}

TEST_F(OverlayGlTest, CategoricalColoursAndHiddenFeatures) {
  auto tree = std::make_shared<terrain::TerrainQuadtree>(
      makeStiffTerrain({.width = 129, .height = 129, .seed = 4, .cliffs = false, .spike = false, .holes = false}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  const glm::dvec2 centre = tree->grid().postPosition(64, 64);
  std::vector<geo::Feature> squares;
  const char* kinds[] = {"park", "water", "other"};
  for (int i = 0; i < 3; ++i) {
    geo::Feature f;
    f.fid = 10 + i;
    f.attributes["kind"] = std::string(kinds[i]);
    const glm::dvec2 c = centre + glm::dvec2(-500.0 + 500.0 * i, 0.0);
    f.polygons.push_back(
        {{c + glm::dvec2(-200, -200), c + glm::dvec2(200, -200), c + glm::dvec2(200, 200), c + glm::dvec2(-200, 200)},
         {}});
    squares.push_back(std::move(f));
  }
  overlay::LayerStyle style;
  style.color = glm::vec4(0.0F, 0.0F, 1.0F, 1.0F);
  style.opacity = 1.0F;
  style.colorAttribute = "kind";
  style.categories["park"] = glm::vec4(0.0F, 1.0F, 0.0F, 1.0F);
  style.categories["water"] = glm::vec4(1.0F, 0.0F, 0.0F, 1.0F);
  Result<overlay::OverlayLayer> layer =
      overlay::OverlayLayer::build("landuse", overlay::LayerKind::Polygon, style, squares, *bounds);
  ASSERT_TRUE(layer.ok());
  const glm::dvec3 eye(centre + glm::dvec2(0.0, -10.0), 2200.0);
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(fov, aspect, 1.0) *
                              gfx::lookAt(eye, glm::dvec3(centre, 0.0), glm::dvec3(0, 0, 1));
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  auto draw = [&] {
    terrain::LodView view{eye, viewProj, kHeight, fov};
    drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, view),
                         {viewProj, eye, 1.0, fov, aspect}, {&*layer});
  };
  const std::array<std::array<std::uint8_t, 3>, 3> expected{{{0, 255, 0}, {255, 0, 0}, {0, 0, 255}}};
  auto check = [&](const std::array<bool, 3>& shown) {
    draw();
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint8_t> rgba = gfx::readColorRgba8(target);
    const std::vector<std::uint32_t> mask = gfx::readMask(target);
    overlay::DepthImage image{kWidth, kHeight, depth, viewProj};
    const std::vector<overlay::ReferenceLayer> ref = referenceLayers({&*layer});
    const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
    std::array<std::size_t, 3> seen{};
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const auto i = static_cast<std::size_t>(y * kWidth + x);
        if (edges[i] != 0) continue;
        const std::vector<overlay::PickedFeature> under = overlay::pick(image, ref, x, y);
        if (under.empty()) {
          ASSERT_EQ(mask[i], 0u) << x << " " << y;
          continue;
        }
        const std::size_t f = under.front().feature;
        ASSERT_TRUE(shown[f]) << "a hidden feature was picked";
        ++seen[f];
        ASSERT_EQ(mask[i], 1u);
        for (std::size_t c = 0; c < 3; ++c) ASSERT_EQ(rgba[i * 4 + c], expected[f][c]) << "feature " << f;
      }
    }
    for (std::size_t f = 0; f < 3; ++f) EXPECT_EQ(seen[f] > 100, shown[f]) << "feature " << f;
  };
  check({true, true, true});
  overlay::FeatureStyle hidden = layer->featureStyles()[1];
  hidden.visible = false;
  EXPECT_TRUE(layer->setFeatureStyle(1, hidden).empty());
  check({true, false, true});
}

// A layer of one colour is covered with one screen rectangle; with its pieces it must give the
// same image: colour, mask and a stencil of zeros, also for the eye inside a volume, for
// overlapping translucent features and in the grouped scheme.
TEST_F(OverlayGlTest, RectangleCoverDrawsWhatThePiecesCoverDraws) {
  auto tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 129, .height = 129, .seed = 9}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  const glm::dvec2 centre = tree->grid().postPosition(64, 64);
  std::vector<geo::Feature> areas, roads;
  for (int i = 0; i < 6; ++i) {
    geo::Feature f;
    f.fid = i;
    const glm::dvec2 c = centre + glm::dvec2(-400.0 + 160.0 * i, 60.0 * (i % 3));
    f.polygons.push_back(
        {{c + glm::dvec2(-250, -250), c + glm::dvec2(250, -250), c + glm::dvec2(250, 250), c + glm::dvec2(-250, 250)},
         {}});
    areas.push_back(f);
    geo::Feature r;
    r.fid = i;
    r.lines.push_back({c + glm::dvec2(-600, -300), c, c + glm::dvec2(500, 400)});
    roads.push_back(std::move(r));
  }
  overlay::LayerStyle areaStyle;
  areaStyle.color = glm::vec4(0.2F, 0.5F, 0.9F, 1.0F);
  areaStyle.opacity = 0.5F;
  overlay::LayerStyle roadStyle;
  roadStyle.color = glm::vec4(1.0F, 0.8F, 0.0F, 1.0F);
  roadStyle.widthMetres = 30.0;
  Result<overlay::OverlayLayer> areaLayer =
      overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, areaStyle, areas, *bounds);
  Result<overlay::OverlayLayer> roadLayer =
      overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, roadStyle, roads, *bounds);
  ASSERT_TRUE(areaLayer.ok() && roadLayer.ok());
  ASSERT_TRUE(areaLayer->uniformColor().has_value());
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const double ground = bounds->fullResolutionHeightAt(centre);
  const std::array<glm::dvec3, 3> eyes{glm::dvec3(centre + glm::dvec2(0.0, -1500.0), 2500.0),
                                       glm::dvec3(centre + glm::dvec2(-900.0, -700.0), 900.0),
                                       glm::dvec3(centre, ground + 2.0)};  // inside the volumes
  std::size_t covered = 0;
  for (const glm::dvec3& eye : eyes) {
    const glm::dvec3 at(centre + glm::dvec2(300.0, 200.0), eye.z > 500.0 ? 0.0 : ground);
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, at, glm::dvec3(0, 0, 1));
    for (bool grouped : {false, true}) {
      std::array<std::vector<std::uint8_t>, 2> colour, stencil;
      std::array<std::vector<std::uint32_t>, 2> mask;
      for (int k = 0; k < 2; ++k) {
        overlay::OverlaySettings settings;
        settings.rectangleCover = k == 0;
        settings.forceGroups = grouped;
        terrain::LodView view{eye, viewProj, kHeight, fov};
        const std::vector<overlay::LayerFrameStats> stats =
            drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, view),
                                 {viewProj, eye, 1.0, fov, aspect}, {&*areaLayer, &*roadLayer}, settings);
        for (const overlay::LayerFrameStats& s : stats) EXPECT_EQ(s.rectangleCover, k == 0);
        colour[static_cast<std::size_t>(k)] = gfx::readColorRgba8(target);
        stencil[static_cast<std::size_t>(k)] = gfx::readStencil(target);
        mask[static_cast<std::size_t>(k)] = gfx::readMask(target);
      }
      EXPECT_EQ(colour[0], colour[1]) << "eye " << eye.z << (grouped ? " grouped" : "");
      EXPECT_EQ(mask[0], mask[1]);
      for (std::uint8_t v : stencil[0]) ASSERT_EQ(v, 0u);
      for (std::uint32_t m : mask[0]) covered += m != 0 ? 1u : 0u;
    }
  }
  EXPECT_GT(covered, 20000u);
}

TEST_F(OverlayGlTest, LinesInPixelsMatchTheReferenceFromFarAndFromOnTheRoad) {
  auto tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 257, .height = 257, .seed = 11}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  ASSERT_TRUE(engine.ok() && overlays.ok());
  const terrain::TerrainGrid& grid = tree->grid();
  const glm::dvec2 lo = grid.postPosition(0, grid.height - 1), hi = grid.postPosition(grid.width - 1, 0);
  std::mt19937 rng(23);
  overlay::LayerStyle round, miter;
  round.widthPixels = 3.0;
  round.maxWidthMetres = 40.0;
  miter.widthPixels = 2.0;
  miter.maxWidthMetres = 25.0;
  miter.join = overlay::LineJoin::Miter;
  miter.cap = overlay::LineCap::Square;
  miter.color = glm::vec4(0.1F, 0.9F, 0.3F, 1.0F);
  std::vector<geo::Feature> roundLines = randomLines(rng, lo, hi, 20), miterLines = randomLines(rng, lo, hi, 20);
  // And one across the terrain's edge: lines in pixels are not clipped to the grid, which
  // validate() must accept.
  const glm::dvec2 mid = 0.5 * (lo + hi);
  miterLines.push_back(geo::Feature{});
  miterLines.back().fid = 999;
  miterLines.back().lines = {{glm::dvec2(mid.x, mid.y), glm::dvec2(hi.x + 30.0, mid.y), glm::dvec2(hi.x + 30.0, hi.y)}};
  const overlay::LayerBuildOptions options = splitAtChunks(grid);
  Result<overlay::OverlayLayer> a =
      overlay::OverlayLayer::build("round", overlay::LayerKind::Line, round, roundLines, *bounds, options);
  Result<overlay::OverlayLayer> b =
      overlay::OverlayLayer::build("miter", overlay::LayerKind::Line, miter, miterLines, *bounds, options);
  ASSERT_TRUE(a.ok() && b.ok());
  for (const overlay::OverlayLayer* layer : {&*a, &*b}) {
    const overlay::LayerValidation v = layer->validate();
    EXPECT_TRUE(v.problems.empty()) << v.problems.items().front().toString();
  }
  ASSERT_GT(a->scalingBuffer(), 0u);
  const std::vector<const overlay::OverlayLayer*> layers{&*a, &*b};

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), unit(0.0, 1.0);
  const double fov = glm::radians(45.0), aspect = static_cast<double>(kWidth) / kHeight;
  Comparison total;
  std::size_t zFail = 0;
  for (int trial = 0; trial < 20; ++trial) {
    glm::dvec3 eye, at;
    if (trial < 10) {  // from afar: the lines are a few pixels wide at every distance
      const glm::dvec2 t(ux(rng), uy(rng));
      const double angle = 6.283 * unit(rng), d = 300.0 + 3000.0 * unit(rng);
      eye = glm::dvec3(t + d * glm::dvec2(std::cos(angle), std::sin(angle)), 400.0 + 2500.0 * unit(rng));
      at = glm::dvec3(t, 0.0);
    } else {  // standing on a road, looking along it: the volume holds the eye
      const geo::LineString& line =
          (trial % 2 == 0 ? roundLines : miterLines)[static_cast<std::size_t>(trial)].lines[0];
      const glm::dvec2 p = line[2] + (unit(rng) - 0.5) * glm::dvec2(2.0, 2.0);
      eye = glm::dvec3(p, bounds->fullResolutionHeightAt(p) + 1.0 + 8.0 * unit(rng));
      at = glm::dvec3(line[3], bounds->fullResolutionHeightAt(line[3]));
    }
    const glm::dmat4 viewProj =
        gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, at, glm::dvec3(0, 0, 1));
    terrain::LodView view{eye, viewProj, kHeight, fov};
    overlay::OverlaySettings settings;
    settings.forceZFail = trial % 4 == 3;  // the CPU-clipped path at this frame's widths
    const std::vector<overlay::LayerFrameStats> stats =
        drawTerrainAndLayers(cache_, target, *engine, *overlays, terrain::selectLod(*tree, view),
                             {viewProj, eye, 1.0, fov, aspect}, layers, settings);
    for (const overlay::LayerFrameStats& s : stats) zFail += s.zFailPieces;
    const Comparison c = compare(target, viewProj, layers, "pixels #" + std::to_string(trial));
    total.covered += c.covered;
    total.wrong += c.wrong;
    total.edgeWrong += c.edgeWrong;
  }
  std::printf("lines in pixels: %zu covered pixels, %zu wrong away from edges, %zu on edges (%.3f %%), %zu z-fail\n",
              total.covered, total.wrong, total.edgeWrong, percent(total.edgeWrong, total.covered), zFail);
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 5000u);
  EXPECT_GT(zFail, 20u);
}

}  // namespace
}  // namespace gis::test

namespace gis::test {
namespace {

TEST_F(OverlayGlTest, ExaggerationHasOneOwnerAndTheLayersFollowIt) {
  // Only the scene's bounds are told (as the viewer's slider and --exaggeration do): the terrain
  // is drawn at the new exaggeration and the renderer reads the pieces' bounds again before the
  // frame, so the overlay stays exact at 0.3×, 6× and back at 1×. Low oblique views, where stale
  // bounds at 6× would leave the raised terrain outside the pieces.
  OlindaScene olinda = loadOlinda();
  ASSERT_TRUE(olinda.renderer);
  glm::dvec3 lo, hi;
  scene::terrainBox(*olinda.scene, 1.0, lo, hi);
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const double aspect = static_cast<double>(kWidth) / kHeight;
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> ux(lo.x + 500, hi.x - 500), uy(lo.y + 500, hi.y - 500), unit(0.0, 1.0);
  Comparison total;
  for (const double exaggeration : {0.3, 6.0, 1.0}) {
    olinda.scene->bounds->setExaggeration(exaggeration);
    for (int trial = 0; trial < 4; ++trial) {
      scene::Camera camera;
      camera.fovYDeg = 40.0;
      const glm::dvec2 t(ux(rng), uy(rng));
      const double a = 6.283 * unit(rng), d = 600.0 + 900.0 * unit(rng);
      const double g = olinda.scene->bounds->fullResolutionHeightAt(t);  // exaggerated, as drawn
      camera.eye = glm::dvec3(t + d * glm::dvec2(std::cos(a), std::sin(a)), (std::isnan(g) ? 0.0 : g) + 0.3 * d);
      camera.target = glm::dvec3(t, std::isnan(g) ? 0.0 : g);
      (void)olinda.renderer->render(cache_, target.framebuffer(), kWidth, kHeight, camera, {});
      for (const overlay::OverlayLayer* l : olinda.layers) EXPECT_FALSE(l->boundsStale());
      const Comparison c = compare(target, camera.projection(aspect) * camera.view(), olinda.layers,
                                   "exaggeration " + std::to_string(exaggeration) + " #" + std::to_string(trial));
      total.covered += c.covered;
      total.wrong += c.wrong;
      total.edgeWrong += c.edgeWrong;
    }
  }
  EXPECT_EQ(total.wrong, 0u);
  EXPECT_LE(total.edgeWrong, total.covered / 200);
  EXPECT_GT(total.covered, 20000u);
}

}  // namespace
}  // namespace gis::test
