// Every overlay technique through its interface (technique.hpp), as the scene renderer and a
// GIS client drive it: it draws into the target it is given whatever framebuffer is bound when
// it is called, leaves that target bound with its viewport, and the stencil techniques match the
// CPU reference on the same depth buffer (0 wrong pixels away from edges). Drapes hand the
// terrain their textures and rasterise again only what an invalidation names.
#include <cmath>
#include <cstdio>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "overlay_compare.hpp"
#include "random_features.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_terrain.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 224;
constexpr int kHeight = 160;

class TechniqueGlTest : public GlTest {};

/// The bound draw framebuffer and viewport, as GL holds them.
std::pair<GLint, std::array<GLint, 4>> boundTarget() {
  GLint fbo = -1;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &fbo);
  std::array<GLint, 4> viewport{};
  glGetIntegerv(GL_VIEWPORT, viewport.data());
  return {fbo, viewport};
}

TEST_F(TechniqueGlTest, EveryTechniqueDrawsIntoTheTargetItIsGiven) {
  auto tree =
      std::make_shared<terrain::TerrainQuadtree>(makeStiffTerrain({.width = 129, .height = 129, .seed = 5}), 16);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(tree, 1.0);
  Result<terrain::TerrainEngine> engine = terrain::TerrainEngine::create(tree, nullptr);
  ASSERT_TRUE(engine.ok());
  const terrain::TerrainGrid& grid = tree->grid();
  const glm::dvec2 lo = grid.postPosition(0, grid.height - 1), hi = grid.postPosition(grid.width - 1, 0);
  std::mt19937 rng(23);
  const std::vector<geo::Feature> areas = randomPolygons(rng, lo, hi, 12), roads = randomLines(rng, lo, hi, 14);

  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  gfx::RenderTarget elsewhere(32, 24, 0, true);  // bound when the technique is called
  const glm::dvec3 eye(lo.x - 200.0, lo.y - 300.0, 1500.0);
  const double fov = glm::radians(50.0), aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj = gfx::reversedInfinitePerspective(fov, aspect, 1.0) *
                              gfx::lookAt(eye, glm::dvec3(0.5 * (lo + hi), 0.0), glm::dvec3(0, 0, 1));
  const terrain::LodSelection selection = terrain::selectLod(*tree, {eye, viewProj, kHeight, fov}, {});

  for (const overlay::TechniqueInfo& info : overlay::techniques()) {
    SCOPED_TRACE(std::string(info.name));
    overlay::LayerBuildOptions options;
    options.paperVariant = info.construction == overlay::PieceConstruction::Paper;
    overlay::CellGrid cells;
    cells.origin = lo;
    cells.cellSize = 16 * grid.step.x;
    cells.columns = cells.rows = (grid.width - 1) / 16;
    options.footprints.cells = cells;
    overlay::LayerStyle road;
    road.widthAttribute = "width_m";
    Result<overlay::OverlayLayer> polygons =
        overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, {}, areas, *bounds, options);
    Result<overlay::OverlayLayer> lines =
        overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, road, roads, *bounds, options);
    ASSERT_TRUE(polygons.ok() && lines.ok());
    const std::vector<const overlay::OverlayLayer*> layers{&*polygons, &*lines};

    overlay::TechniqueOptions techniqueOptions;
    techniqueOptions.textureSize = info.usesTextures() ? 128 : 0;
    techniqueOptions.extent = overlay::DrapeExtent{lo, hi - lo};
    techniqueOptions.bounds = bounds.get();
    techniqueOptions.build = options;
    techniqueOptions.tiling.finestTileCells = 2;  // several levels on this small terrain
    Result<std::unique_ptr<overlay::OverlayTechnique>> technique = info.create(techniqueOptions);
    ASSERT_TRUE(technique.ok());

    std::vector<overlay::DrawnTile> tiles;
    for (const terrain::SelectedChunk& c : selection.chunks) {
      const auto [tileLo, tileHi] = tree->frameExtent(c.id);
      tiles.push_back({c.id.key(), tileLo, tileHi});
    }
    overlay::TechniqueFrame frame;
    frame.target = {target.framebuffer(), kWidth, kHeight};
    frame.view = {viewProj, eye, 1.0, fov, aspect};
    frame.layers = layers;
    frame.tiles = tiles;

    gfx::beginRenderPass(cache_, target, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
    cache_.bindDrawTarget(elsewhere.framebuffer(), elsewhere.width(), elsewhere.height());
    overlay::TechniqueFrameStats stats;
    const std::optional<overlay::SurfaceDrape> drape = (*technique)->prepare(cache_, frame, stats);
    const auto [preparedFbo, preparedViewport] = boundTarget();
    EXPECT_EQ(preparedFbo, static_cast<GLint>(target.framebuffer()));
    EXPECT_EQ(preparedViewport, (std::array<GLint, 4>{0, 0, kWidth, kHeight}));
    EXPECT_EQ(drape.has_value(), info.usesTextures());
    if (drape) {
      EXPECT_GT(stats.texturesBuilt, 0u);
      EXPECT_TRUE(drape->color != 0 || drape->colorArray != 0);
      EXPECT_GT((*technique)->gpuBytes(), 0u);
      // Nothing changed: nothing is rasterised again; an edit far outside every tile changes
      // nothing either, and invalidate() makes it all again.
      overlay::TechniqueFrameStats again;
      (void)(*technique)->prepare(cache_, frame, again);
      EXPECT_EQ(again.texturesBuilt, 0u);
      (*technique)->invalidate();
      overlay::TechniqueFrameStats rebuilt;
      (void)(*technique)->prepare(cache_, frame, rebuilt);
      EXPECT_EQ(rebuilt.texturesBuilt, stats.texturesBuilt);
      continue;  // the terrain shader draws a drape: methods_gltest judges it through the scene
    }

    gfx::enableMaskWrites(target.framebuffer(), false);
    engine->draw(cache_, viewProj, eye, selection, 1.0);
    gfx::enableMaskWrites(target.framebuffer(), true);
    cache_.bindDrawTarget(elsewhere.framebuffer(), elsewhere.width(), elsewhere.height());
    (*technique)->draw(cache_, frame, stats);
    const auto [drawnFbo, drawnViewport] = boundTarget();
    EXPECT_EQ(drawnFbo, static_cast<GLint>(target.framebuffer()));
    EXPECT_EQ(drawnViewport, (std::array<GLint, 4>{0, 0, kWidth, kHeight}));
    ASSERT_EQ(stats.layers.size(), layers.size());
    const overlay_test::Comparison c = overlay_test::compare(target, viewProj, layers, std::string(info.name));
    std::printf("%s: %zu covered pixels, %zu wrong away from edges, %zu on edges\n", std::string(info.name).c_str(),
                c.covered, c.wrong, c.edgeWrong);
    EXPECT_EQ(c.wrong, 0u);
    EXPECT_GT(c.covered, 2000u);
    EXPECT_LE(c.edgeWrong, c.covered / 100);
  }
}

TEST_F(TechniqueGlTest, DrapeBuildsRestoreTheBoundTargetAndViewport) {
  // A drape rasterises into a framebuffer of its own in a gfx::RenderPass: whatever was bound
  // before (any viewport) is bound again after it, known to the cache or read back from GL.
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  const gfx::DrawTarget frameTarget{target.framebuffer(), {4, 2, 100, 50}};
  const std::vector<const overlay::OverlayLayer*> noLayers;
  const overlay::FootprintDrapeSource none(noLayers);
  const overlay::DrapeExtent extent{glm::dvec2(0.0), glm::dvec2(100.0)};
  Result<overlay::TiledDrape> tiles = overlay::TiledDrape::create(32);
  ASSERT_TRUE(tiles.ok());
  for (const bool known : {true, false}) {
    SCOPED_TRACE(known ? "bound through the cache" : "read back after invalidate()");
    cache_.bindDrawTarget(frameTarget);
    if (!known) cache_.invalidate();
    Result<overlay::TextureDrape> drape = overlay::TextureDrape::build(cache_, none, extent, 64);
    ASSERT_TRUE(drape.ok());
    auto [fbo, viewport] = boundTarget();
    EXPECT_EQ(fbo, static_cast<GLint>(target.framebuffer()));
    EXPECT_EQ(viewport, (std::array<GLint, 4>{4, 2, 100, 50}));

    if (!known) cache_.invalidate();
    overlay::TiledDrape::FrameStats stats;
    tiles->beginFrame(1);
    (void)tiles->tile(cache_, none, known ? 1 : 2, extent, stats);
    EXPECT_EQ(stats.tilesBuilt, 1u);
    std::tie(fbo, viewport) = boundTarget();
    EXPECT_EQ(fbo, static_cast<GLint>(target.framebuffer()));
    EXPECT_EQ(viewport, (std::array<GLint, 4>{4, 2, 100, 50}));
  }
}

}  // namespace
}  // namespace gis::test
