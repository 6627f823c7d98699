// The globe overlay on the GPU against the CPU reference on the same depth buffer (docs/globe.md):
// 0 wrong pixels away from edges from space, oblique and grazing, across the antimeridian, over
// both poles and from 1 m above the ground.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "globe/globe_terrain.hpp"
#include "globe_scene.hpp"
#include "sample_positions.hpp"
#include "scene/globe_renderer.hpp"
#include "test_paths.hpp"
#include "vector_overlay/globe_overlay.hpp"

namespace gis::globe {
namespace {

class GlobeOverlayGl : public test::GlTest {
 protected:
  static void SetUpTestSuite() {
    test::GlTest::SetUpTestSuite();
    grid() = test::globe_scene::syntheticGrid(0.5);
  }
  static std::shared_ptr<const GeoGrid>& grid() {
    static std::shared_ptr<const GeoGrid> g;
    return g;
  }

  struct Outcome {
    std::size_t covered = 0, wrong = 0, edgeWrong = 0, terrain = 0, tiles = 0, pieces = 0, zFail = 0;
    std::vector<float> depth;
    std::vector<std::uint32_t> expected;
    std::vector<std::uint8_t> edges, rgba;
  };

  /// Draws the terrain and the layers for the view and compares the mask with the reference.
  /// With `kept`, the layers are drawn by that renderer (its tiles kept from earlier frames, under
  /// `settings`' budget); else by a new one.
  Outcome drawAndCompare(const GlobeView& view, const std::vector<const GlobeLayer*>& layers, const std::string& label,
                         GlobeOverlayRenderer* kept = nullptr, const GlobeOverlaySettings& settings = {},
                         const std::shared_ptr<const GeoGrid>& heights = nullptr, int samples = 0) {
    const std::shared_ptr<const GeoGrid> ground = heights ? heights : grid();
    GlobeTerrain terrain(ground);
    GlobeOverlayRenderer own;
    GlobeOverlayRenderer& overlay = kept != nullptr ? *kept : own;
    gfx::RenderTarget target(view.width, view.height, samples, true);
    const std::vector<DrawnTile> tiles = drawnTiles(terrain, view);
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F, 0.0F, 0.0F, 1.0F), gfx::kReversedZFar, 0});
    gfx::enableMaskWrites(target.framebuffer(), false);
    terrain.draw(cache_, view, tiles);
    gfx::enableMaskWrites(target.framebuffer(), true);
    GlobeOverlaySettings drawn = settings;
    drawn.targetFramebuffer = target.framebuffer();
    overlay.draw(cache_, view, tiles, *ground, layers, drawn);
    if (target.multisampled()) {
      // Each sample against the reference at that sample (its position in the pixel).
      gfx::RenderTarget single(view.width, view.height, 0, true);
      Outcome all;
      for (int k = 0; k < target.samples(); ++k) {
        GLfloat position[2] = {0.5F, 0.5F};
        glGetMultisamplefv(GL_SAMPLE_POSITION, static_cast<GLuint>(k), position);
        target.copySampleInto(cache_, single, k);
        const Outcome o = compareWithReference(
            single, view, layers, overlay, label + " sample " + std::to_string(k),
            test::overlay_test::atSample(view.eyeViewProj(), position[0], position[1], view.width, view.height));
        all.covered += o.covered;
        all.wrong += o.wrong;
        all.edgeWrong += o.edgeWrong;
        all.terrain += o.terrain;
        all.expected.insert(all.expected.end(), o.expected.begin(), o.expected.end());
      }
      all.tiles = tiles.size();
      all.pieces = overlay.stats().pieces;
      return all;
    }
    Outcome o = compareWithReference(target, view, layers, overlay, label, view.eyeViewProj());
    o.tiles = tiles.size();
    o.pieces = overlay.stats().pieces;
    o.zFail = overlay.stats().zFailPieces;
    return o;
  }

  /// The tiles the terrain draws for the view: its own choice, or with forcedLevel_ ≥ 0 those no
  /// finer than that level (each tile's ancestor there; one level, so no edge is stitched).
  std::vector<DrawnTile> drawnTiles(const GlobeTerrain& terrain, const GlobeView& view) const {
    std::vector<DrawnTile> tiles = terrain.select(view);
    if (forcedLevel_ < 0) return tiles;
    std::vector<DrawnTile> forced;
    for (const DrawnTile& t : tiles) {
      TileKey k = t.key;
      while (k.level > forcedLevel_) k = k.parent();
      if (std::none_of(forced.begin(), forced.end(), [&](const DrawnTile& f) { return f.key.contains(k); })) {
        std::erase_if(forced, [&](const DrawnTile& f) { return k.contains(f.key); });
        forced.push_back({k, 0});
      }
    }
    return forced;
  }
  int forcedLevel_ = -1;

  /// The mask in the single-sampled `target` against the reference on its depth, the image's
  /// matrix `viewProj` (the view's, or one moved to a sample's position).
  Outcome compareWithReference(const gfx::RenderTarget& target, const GlobeView& view,
                               const std::vector<const GlobeLayer*>& layers, const GlobeOverlayRenderer& overlay,
                               const std::string& label, const glm::dmat4& viewProj) {
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> gpu = gfx::readMask(target);
    std::filesystem::create_directories(STENCIL_GIS_TEST_OUTPUT_DIR);
    std::string file = label;
    for (char& ch : file) ch = std::isalnum(static_cast<unsigned char>(ch)) != 0 ? ch : '_';
    const std::vector<std::uint8_t> rgba = gfx::readColorRgba8(target);
    (void)gfx::writeImage8(std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/" + file + ".png", view.width, view.height, 4,
                           rgba);
    overlay::DepthImage image = depthImageOf(view, depth);
    image.viewProj = viewProj;
    const std::vector<std::uint32_t> expected = overlay::referenceMask(image, referenceLayersOf(layers, image));
    std::vector<std::uint8_t> edges = overlay::edgePixels(image, referenceLayersOf(layers, image));
    // A frame drawn coarser for the budget is exact only farther than its stated error from edges:
    // the band grown by the error beyond the half pixel the terrain's detail keeps.
    const int grow = static_cast<int>(std::ceil(overlay.stats().tiles.tileErrorPixels - 0.5));
    for (int g = 0; g < grow; ++g) {
      const std::vector<std::uint8_t> band = edges;
      for (int y = 0; y < view.height; ++y)
        for (int x = 0; x < view.width; ++x)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int nx = std::clamp(x + dx, 0, view.width - 1), ny = std::clamp(y + dy, 0, view.height - 1);
              if (band[static_cast<std::size_t>(ny * view.width + nx)] != 0)
                edges[static_cast<std::size_t>(y * view.width + x)] = 1;
            }
    }
    Outcome o;
    int reported = 0;
    for (std::size_t i = 0; i < gpu.size(); ++i) {
      o.terrain += depth[i] > 0.0F ? 1U : 0U;
      o.covered += expected[i] != 0 ? 1U : 0U;
      if (gpu[i] == expected[i]) continue;
      if (edges[i] != 0) {
        ++o.edgeWrong;
        continue;
      }
      ++o.wrong;
      if (reported++ < 5) {
        ADD_FAILURE() << label << ": pixel (" << i % static_cast<std::size_t>(view.width) << ", "
                      << i / static_cast<std::size_t>(view.width) << ") GPU " << gpu[i] << ", reference " << expected[i]
                      << ", depth " << depth[i];
      }
    }
    std::printf("%-28s pieces %5zu (z-fail %3zu) terrain px %6zu covered %6zu wrong %zu edge-wrong %zu\n",
                label.c_str(), overlay.stats().pieces, overlay.stats().zFailPieces, o.terrain, o.covered, o.wrong,
                o.edgeWrong);
    EXPECT_EQ(o.wrong, 0u) << label;
    o.depth = depth;
    o.expected = expected;
    o.edges = edges;
    o.rgba = rgba;
    return o;
  }

  static GlobeView view(const Geodetic& eye, const Geodetic& target, double fov = 45.0) {
    return GlobeView::looking(toEcef(eye), toEcef(target), fov, 256, 256,
                              grid() ? grid()->heightAt(eye.lon, eye.lat) : 0.0);
  }
};

struct Layers {
  GlobeLayer all, boxes, field, lines, outlines, road;
};

using test::globe_scene::lineFeature;

/// The wide lines 3 pixels wide, anchored on `ground` (lines in pixels: drawn by the lookup in
/// views that keep them within its widest reach class, else by pieces).
Result<GlobeLayer> routesInPixels(std::shared_ptr<const GeoGrid> ground) {
  GlobeLayerOptions pixels;
  pixels.lineWidthPixels = 3.0;
  pixels.lineWidthMetres = 0.0;
  pixels.anchorGround = std::move(ground);
  return GlobeLayer::build("routes 3 px", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.6F, 0.1F, 0.8F), pixels);
}

Layers makeLayers() {
  const auto features = test::globe_scene::features();
  std::vector<geo::Feature> large(features.begin(), features.end() - 1);
  Result<GlobeLayer> all = GlobeLayer::build("features", large, glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  Result<GlobeLayer> field = GlobeLayer::build("field", {features.back()}, glm::vec4(0.9F, 0.9F, 0.2F, 0.6F));
  std::vector<geo::Feature> boxes(1);
  boxes[0].polygons.push_back(test::globe_scene::box(-70.0, -40.0, -50.0, -10.0));
  boxes[0].polygons.push_back(test::globe_scene::box(160.0, -30.0, 200.0, -10.0));  // written past 180
  boxes[0].polygons.push_back(test::globe_scene::box(-20.0, 60.0, 40.0, 85.0));
  Result<GlobeLayer> second = GlobeLayer::build("boxes", boxes, glm::vec4(0.9F, 0.4F, 0.1F, 0.5F));
  // Lines 30 km wide: a route over the continent, one across ±180°, one near the north pole,
  // and a 10 m road across the field.
  GlobeLayerOptions wide;
  wide.lineWidthMetres = 30000.0;
  Result<GlobeLayer> lines =
      GlobeLayer::build("lines", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), wide);
  GlobeLayerOptions road;
  road.lineWidthMetres = 10.0;
  Result<GlobeLayer> roads =
      GlobeLayer::build("road", {lineFeature({{8.5 - 0.002, 47.3 + 0.004}, {8.5 + 0.01, 47.3 + 0.0041}})},
                        glm::vec4(0.2F, 0.2F, 0.2F, 0.9F), road);
  // The boxes' outlines, 20 km wide.
  GlobeLayerOptions outline;
  outline.outlines = true;
  outline.lineWidthMetres = 20000.0;
  Result<GlobeLayer> outlines = GlobeLayer::build("box outlines", boxes, glm::vec4(0.0F, 0.0F, 0.0F, 1.0F), outline);
  EXPECT_TRUE(all.ok() && second.ok() && field.ok() && lines.ok() && roads.ok() && outlines.ok());
  return {std::move(*all),   std::move(*second),   std::move(*field),
          std::move(*lines), std::move(*outlines), std::move(*roads)};
}

TEST_F(GlobeOverlayGl, ExactFromSpaceObliqueGrazingAntimeridianPolesAndTheGround) {
  const Layers layers = makeLayers();
  const std::vector<const GlobeLayer*> all{&layers.all,   &layers.boxes,    &layers.field,
                                           &layers.lines, &layers.outlines, &layers.road};
  struct Case {
    std::string label;
    Geodetic eye, target;
    double fov = 45.0;
    std::size_t minCovered = 200;
    bool eyeInside = false;  ///< in pieces of the field and the road: drawn z-fail, clipped at the near plane
  };
  const double field = grid()->heightAt(8.5, 47.3);
  const std::vector<Case> cases{
      {"space 10,000 km", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}, 45.0, 2000},
      {"space 20,000 km", {150.0, 10.0, 2e7}, {150.0, 10.0, -6e6}, 45.0, 500},
      {"oblique 800 km", {-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
      {"grazing 3 km", {-37.5, -8.0, 3000.0}, {-33.0, -6.0, 1500.0}},
      {"antimeridian 4,000 km", {180.0, -14.0, 4e6}, {180.0, -14.0, 0.0}},
      {"antimeridian oblique", {165.0, -40.0, 6e5}, {-178.0, -21.0, 0.0}},
      {"north pole from above", {0.0, 90.0, 3e6}, {0.0, 90.0, 0.0}},
      {"north pole oblique", {30.0, 70.0, 4e5}, {120.0, 89.0, 0.0}},
      {"south pole from above", {0.0, -90.0, 6e6}, {0.0, -90.0, 0.0}},
      {"south pole low", {45.0, -86.0, 20000.0}, {-135.0, -89.0, 0.0}},
      {"1 m above the ground", {8.5, 47.30407, grid()->heightAt(8.5, 47.30407) + 1.0}, {8.5005, 47.304, field}, 60.0},
      {"in the road, 0.5 m up",
       {8.505, 47.30406, grid()->heightAt(8.505, 47.30406) + 0.5},
       {8.509, 47.30409, field},
       60.0,
       200,
       true},
  };
  for (const Case& c : cases) {
    const Outcome o = drawAndCompare(view(c.eye, c.target, c.fov), all, c.label);
    EXPECT_GE(o.covered, c.minCovered) << c.label << ": the view must show the features";
    if (c.eyeInside) {
      EXPECT_GT(o.zFail, 0U) << c.label << ": pieces hold the eye";
    }
  }
}

TEST_F(GlobeOverlayGl, TheDeferredLookupDrawsAreasAndLinesExactlyInEveryFaceOfTheCube) {
  const Layers layers = makeLayers();
  // The world north of a coast near 72° S, with a hole: a ring around the south pole closed along
  // the north one, whose inside the plane of a face sees the other way round (deferredParts).
  geo::Feature north;
  {
    geo::Polygon p;
    for (int k = 0; k <= 36; ++k) p.outer.emplace_back(-180.0 + k * 10.0, -72.0 + 4.0 * std::cos(k * 0.9));
    p.outer.emplace_back(180.0, 90.0);
    p.outer.emplace_back(-180.0, 90.0);
    p.holes.push_back(test::globe_scene::box(-20.0, 10.0, 15.0, 35.0).outer);
    north.polygons.push_back(std::move(p));
  }
  Result<GlobeLayer> world = GlobeLayer::build("north of the coast", {north}, glm::vec4(0.1F, 0.8F, 0.3F, 0.4F));
  ASSERT_TRUE(world.ok());
  // Lines in pixels first (the lookup's where the view keeps their widths within its widest reach
  // class, else their pieces'), then the areas and the lines in metres (the lookup: their
  // primitives in space, lines 30 km, 20 km and 10 m wide): every layer keeps its bit and order.
  Result<GlobeLayer> routes = routesInPixels(grid());
  ASSERT_TRUE(routes.ok());
  const std::vector<const GlobeLayer*> drawn{&*routes,      &*world,       &layers.all,  &layers.boxes,
                                             &layers.field, &layers.lines, &layers.road, &layers.outlines};
  for (const GlobeLayer* layer : drawn) EXPECT_TRUE(deferredDraws(*layer)) << layer->name();
  GlobeOverlaySettings settings;
  settings.technique = GlobeTechnique::Deferred;
  struct Case {
    std::string label;
    Geodetic eye, target;
    double fov = 45.0;
  };
  const double field = grid()->heightAt(8.5, 47.3);
  std::vector<Case> cases{
      {"lookup space 10,000 km", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
      {"lookup space 20,000 km", {150.0, 10.0, 2e7}, {150.0, 10.0, -6e6}},
      {"lookup face corner", {45.0, 35.26, 4e6}, {45.0, 35.26, 0.0}},
      // Close over the edge between faces 3 (−y) and 5 (−z), which the 20 km outline of the
      // boxes' south side crosses near 57° W: a face's index reaches a thousandth beyond it.
      {"lookup face edge 40 km", {-57.0, -40.1, 40000.0}, {-57.0, -40.0, 0.0}},
      {"lookup oblique 800 km", {-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
      {"lookup grazing 3 km", {-37.5, -8.0, 3000.0}, {-33.0, -6.0, 1500.0}},
      {"lookup antimeridian", {165.0, -40.0, 6e5}, {-178.0, -21.0, 0.0}},
      {"lookup north pole", {0.0, 90.0, 3e6}, {0.0, 90.0, 0.0}},
      {"lookup south pole low", {45.0, -86.0, 20000.0}, {-135.0, -89.0, 0.0}},
      {"lookup 1 m above", {8.5, 47.30407, grid()->heightAt(8.5, 47.30407) + 1.0}, {8.5005, 47.304, field}, 60.0},
  };
  // And cameras at random: anywhere, from 1 km to 20,000 km, looking down at a point up to twice
  // their height away.
  std::mt19937 random(20261129);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < 8; ++k) {
    const double lon = -180.0 + 360.0 * unit(random), lat = -88.0 + 176.0 * unit(random);
    const double height = std::pow(10.0, 3.0 + 4.3 * unit(random));
    const double reach = 2.0 * height * unit(random) / 111000.0, bearing = 6.283185307 * unit(random);
    const double tlat = std::clamp(lat + reach * std::cos(bearing), -89.0, 89.0);
    const double tlon = lon + reach * std::sin(bearing) / std::max(0.05, std::cos(tlat * 0.0174533));
    cases.push_back({"lookup random " + std::to_string(k),
                     {lon, lat, grid()->heightAt(lon, lat) + height},
                     {tlon, tlat, grid()->heightAt(tlon, tlat)}});
  }
  std::size_t covered = 0, everyLayer = 0;
  GlobeOverlayRenderer renderer;  // one for every view: the layers' indices are built once
  for (const Case& c : cases) {
    const Outcome o = drawAndCompare(view(c.eye, c.target, c.fov), drawn, c.label, &renderer, settings);
    const std::size_t lookedUp = renderer.stats().deferredLayers;
    EXPECT_TRUE(lookedUp == 7U || lookedUp == 8U) << c.label << ": " << lookedUp << " layers looked up";
    everyLayer += lookedUp == 8U ? 1U : 0U;
    EXPECT_GT(renderer.stats().deferredBytes, 0U) << c.label;
    if (c.label.rfind("lookup random", 0) != 0) {
      EXPECT_GE(o.covered, 200U) << c.label << ": the view must show them";
    }
    covered += o.covered;
  }
  EXPECT_GE(covered, 100000U);
  // The routes in pixels too from 800 km and nearer (7 of the fixed views at least).
  EXPECT_GE(everyLayer, 7U);
}

TEST_F(GlobeOverlayGl, MsaaIsExactPerSampleWithThePiecesAndTheLookup) {
  // 4× MSAA on the globe, as in a projected frame (overlay_gltest's MsaaIsExactPerSample): every
  // sample of the mask against the reference evaluated at that sample's position, with the
  // pieces and with the lookup (areas, and lines by their primitives in space).
  const Layers layers = makeLayers();
  const std::vector<const GlobeLayer*> drawn{&layers.lines, &layers.outlines, &layers.all, &layers.boxes};
  struct Case {
    std::string label;
    Geodetic eye, target;
  };
  const std::vector<Case> cases{{"msaa space", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
                                {"msaa oblique 800 km", {-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}}};
  for (const GlobeTechnique technique : {GlobeTechnique::StencilTiles, GlobeTechnique::Deferred}) {
    GlobeOverlaySettings settings;
    settings.technique = technique;
    std::size_t covered = 0, edgeWrong = 0, mixed = 0;
    for (const Case& c : cases) {
      const std::string label = c.label + (technique == GlobeTechnique::Deferred ? " lookup" : " pieces");
      const Outcome o = drawAndCompare(view(c.eye, c.target), drawn, label, nullptr, settings, nullptr, 4);
      EXPECT_EQ(o.wrong, 0U) << label;
      covered += o.covered;
      edgeWrong += o.edgeWrong;
      // The samples of a pixel see different ground where an edge passes: MSAA anti-aliases.
      const std::size_t pixels = o.expected.size() / 4;
      for (std::size_t i = 0; i < pixels; ++i) mixed += o.expected[i] != o.expected[pixels + i] ? 1U : 0U;
    }
    std::printf(
        "MSAA 4x on the globe (%s): %zu covered samples, %zu differing on edges, %zu pixels with mixed "
        "samples\n",
        technique == GlobeTechnique::Deferred ? "lookup" : "pieces", covered, edgeWrong, mixed);
    // Samples answered per pixel instead (the lookup reading one sample's depth, say) would
    // differ from their reference on the hundreds of mixed pixels: far more than this.
    EXPECT_GT(covered, 50000U);
    EXPECT_LE(edgeWrong, covered / 1000);
    EXPECT_GT(mixed, 100U);
  }
}

TEST_F(GlobeOverlayGl, TheLookupsIndicesBuildAsideAndAutoMeasuresBothWays) {
  // In a flight (no wait), a layer whose indices are still building is drawn by its pieces; once
  // built, the lookup draws it. `auto` draws the pieces first, then the lookup once the pieces
  // are measured; every frame exact either way.
  const Layers layers = makeLayers();
  // Lines in pixels first (from 10,000 km beyond the lookup's widest reach class: their pieces),
  // then two area layers.
  Result<GlobeLayer> routes = routesInPixels(grid());
  ASSERT_TRUE(routes.ok());
  std::vector<const GlobeLayer*> drawn{&*routes, &layers.all, &layers.boxes};
  const GlobeView v = view({-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6});
  GlobeTerrain terrain(grid());
  gfx::RenderTarget target(v.width, v.height, 0, true);
  const std::vector<DrawnTile> tiles = terrain.select(v);
  // Draws a frame without comparing it: the renderer's stats.
  const auto frame = [&](GlobeOverlayRenderer& renderer, GlobeOverlaySettings settings) {
    gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F, 0.0F, 0.0F, 1.0F), gfx::kReversedZFar, 0});
    terrain.draw(cache_, v, tiles);
    settings.targetFramebuffer = target.framebuffer();
    renderer.draw(cache_, v, tiles, *grid(), drawn, settings);
    return renderer.stats();
  };
  for (const GlobeTechnique technique : {GlobeTechnique::Deferred, GlobeTechnique::Auto}) {
    const std::string name = technique == GlobeTechnique::Deferred ? "deferred flight" : "auto";
    GlobeOverlaySettings settings;
    settings.technique = technique;
    settings.waitForTiles = false;
    GlobeOverlayRenderer renderer;
    const GlobeOverlayStats first = frame(renderer, settings);
    EXPECT_EQ(first.deferredLayers, 0U) << name << ": the first frame draws the pieces";
    if (technique == GlobeTechnique::Deferred) {
      EXPECT_EQ(first.deferredPending, 2U) << name;
      drawAndCompare(v, drawn, name + " while building", &renderer, settings);
    }
    bool lookedUp = false;
    const auto start = std::chrono::steady_clock::now();
    while (!lookedUp && std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
      lookedUp = frame(renderer, settings).deferredLayers == 2;
      if (!lookedUp) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(lookedUp) << name << ": the lookup draws the two area layers once their indices are built";
    const Outcome o = drawAndCompare(v, drawn, name + " built", &renderer, settings);
    EXPECT_GE(o.covered, 2000U) << name;
  }
  // A layer no longer drawn (another style builds another layer) leaves its indices once they
  // pass a quarter of the budget (here just the two area layers' indices): the boxes' leave.
  GlobeOverlaySettings tight;
  tight.technique = GlobeTechnique::Deferred;
  GlobeOverlayRenderer probe;
  tight.gpuBudgetBytes = 4 * frame(probe, tight).deferredBytes;
  GlobeOverlayRenderer renderer;
  const GlobeOverlayStats both = frame(renderer, tight);
  EXPECT_EQ(both.deferredLayers, 2U);
  EXPECT_EQ(both.deferredHeldBytes, both.deferredBytes);
  drawn.pop_back();
  drawn.push_back(&layers.field);
  const GlobeOverlayStats other = frame(renderer, tight);
  EXPECT_EQ(other.deferredLayers, 2U);
  EXPECT_EQ(other.deferredHeldBytes, other.deferredBytes) << "the boxes' indices left";
  // With no budget, no index is drawn (each would pass a quarter of it): the pieces draw all.
  GlobeOverlaySettings none = tight;
  none.gpuBudgetBytes = 0;
  GlobeOverlayRenderer empty;
  const GlobeOverlayStats nothing = frame(empty, none);
  EXPECT_EQ(nothing.deferredLayers, 0U);
  EXPECT_EQ(nothing.deferredHeldBytes, 0U);
}

TEST_F(GlobeOverlayGl, StencilAndPaperBuildTheLayersOnceAndTheirCapsReachTheCoarserTerrainDrawnOverThem) {
  // `stencil` and `paper` (the seed paper's construction, covered by the pieces' boxes) on the
  // globe: each layer's pieces built once (full detail, widths in metres, over
  // tiles of about 5 km), for every view from space to 1 m above the ground, exact against the
  // reference. Their bounds hold the terrain drawn at their tiles' level and finer; where coarser
  // tiles are drawn over them (from afar, or forced by a coarse terrain: the bounds contract's
  // test at forced coarse LODs) their caps move out in that frame, and only then.
  const auto features = test::globe_scene::features();
  std::vector<geo::Feature> region(1);
  region[0].polygons.push_back(test::globe_scene::box(8.0, 47.0, 8.6, 47.4));
  region[0].polygons[0].holes.push_back(test::globe_scene::box(8.2, 47.1, 8.3, 47.2).outer);
  Result<GlobeLayer> areas = GlobeLayer::build("region", region, glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  Result<GlobeLayer> field = GlobeLayer::build("field", {features.back()}, glm::vec4(0.9F, 0.9F, 0.2F, 0.6F));
  GlobeLayerOptions metres;
  metres.lineWidthMetres = 300.0;
  Result<GlobeLayer> roads =
      GlobeLayer::build("roads",
                        {lineFeature({{8.05, 47.05}, {8.25, 47.35}, {8.55, 47.1}}),
                         lineFeature({{8.5 - 0.002, 47.3 + 0.004}, {8.5 + 0.01, 47.3 + 0.0041}})},
                        glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), metres);
  ASSERT_TRUE(areas.ok() && field.ok() && roads.ok());
  const std::vector<const GlobeLayer*> drawn{&*areas, &*field, &*roads};
  // Rough ground under them (a regional grid of 200 m posts, the ellipsoid elsewhere): coarse
  // terrain tiles lie hundreds of metres off what the finer ones draw there.
  constexpr double kStep = 0.002;
  constexpr int kColumns = 1000, kRows = 750;
  std::vector<float> rough(static_cast<std::size_t>(kColumns) * kRows);
  for (int r = 0; r < kRows; ++r) {
    for (int col = 0; col < kColumns; ++col) {
      const double lon = 7.5 + col * kStep, lat = 48.0 - r * kStep;
      rough[static_cast<std::size_t>(r) * kColumns + static_cast<std::size_t>(col)] =
          static_cast<float>(900.0 + 600.0 * std::sin(40.0 * lon) * std::cos(35.0 * lat) +
                             150.0 * std::sin(700.0 * lon + 0.3) * std::sin(650.0 * lat));
    }
  }
  const auto heights = std::make_shared<const GeoGrid>(kColumns, kRows, 7.5, 48.0, kStep, std::move(rough));
  const auto at = [&](const Geodetic& eye, const Geodetic& target, double fov) {
    return GlobeView::looking(toEcef(eye), toEcef(target), fov, 256, 256, heights->heightAt(eye.lon, eye.lat));
  };
  struct Case {
    std::string label;
    Geodetic eye, target;
    double fov = 45.0;
    int forced = -1;  ///< the terrain drawn no finer than this level
    std::size_t minCovered = 200;
  };
  const Geodetic nearEye{8.5, 47.30407, heights->heightAt(8.5, 47.30407) + 1.0},
      nearTarget{8.5005, 47.304, heights->heightAt(8.5005, 47.304)};
  const std::vector<Case> cases{
      {"stencil space 10,000 km", {8.3, 47.2, 1e7}, {8.3, 47.2, -6e6}, 3.0},
      {"stencil oblique 800 km", {6.0, 42.0, 8e5}, {8.3, 47.2, 0.0}, 10.0},
      {"stencil 60 km", {8.3, 46.9, 6e4}, {8.3, 47.2, 0.0}},
      {"stencil grazing 5 km", {8.1, 46.95, 5000.0}, {8.4, 47.3, 500.0}},
      {"stencil 1 m above the ground", nearEye, nearTarget, 60.0},
      {"stencil 60 km terrain at level 5", {8.3, 46.9, 6e4}, {8.3, 47.2, 0.0}, 45.0, 5},
      {"stencil grazing 5 km terrain at level 7", {8.1, 46.95, 5000.0}, {8.4, 47.3, 500.0}, 45.0, 7},
      {"stencil 1 m up terrain at level 10", nearEye, nearTarget, 60.0, 10},
  };
  for (const GlobeTechnique technique : {GlobeTechnique::Stencil, GlobeTechnique::Paper}) {
    const std::string name = technique == GlobeTechnique::Paper ? "paper" : "stencil";
    GlobeOverlaySettings settings;
    settings.technique = technique;
    GlobeOverlayRenderer renderer;
    for (std::size_t k = 0; k < cases.size(); ++k) {
      const Case& c = cases[k];
      const GlobeView v = at(c.eye, c.target, c.fov);
      forcedLevel_ = c.forced;
      const Outcome o = drawAndCompare(v, drawn, name + c.label.substr(7), &renderer, settings, heights);
      EXPECT_GE(o.covered, c.minCovered) << c.label << ": the view must show the layers";
      // Built once, at the first frame.
      EXPECT_EQ(renderer.stats().builtTiles > 0, k == 0) << c.label;
      EXPECT_EQ(renderer.stats().tiles.tilesBuilt, 0U) << c.label << ": no layer may fall back to its tiles";
      // The caps reach out only where coarser terrain is drawn over them: the field's (1 km).
      const std::vector<DrawnTile> tiles = drawnTiles(GlobeTerrain(heights), v);
      const LonLatRect fieldBox = field->extent().expanded(0.01, 0.01);
      int coarsest = kMaxLevel;
      for (const DrawnTile& t : tiles) {
        const LonLatRect r = t.key.rect();
        if (r.west <= fieldBox.east && fieldBox.west <= r.east && r.south <= fieldBox.north &&
            fieldBox.south <= r.north)
          coarsest = std::min(coarsest, t.key.level);
      }
      double reach = 0.0;
      for (const overlay::OverlayLayer* chunk : renderer.chunks(v, tiles, *heights, *field)) {
        reach = std::max({reach, chunk->capReach().x, chunk->capReach().y});
        EXPECT_EQ(chunk->paperVariant(), technique == GlobeTechnique::Paper) << c.label;
      }
      std::printf("%-40s the field under terrain of level %2d: caps reach %.1f m\n", c.label.c_str(), coarsest, reach);
      if (coarsest >= kWholeLoadLevel) {
        EXPECT_EQ(reach, 0.0) << c.label;
      } else {
        EXPECT_GT(reach, 0.0) << c.label;
      }
    }
    forcedLevel_ = -1;
    // An edit (the region's hole closed, then opened again): the edited layer is built whole
    // again at the next frame, exact.
    geo::Feature edited = region[0];
    if (technique == GlobeTechnique::Stencil) edited.polygons[0].holes.clear();
    Result<std::vector<LonLatRect>> changed = areas->replaceFeature(0, edited);
    ASSERT_TRUE(changed.ok() && !changed.diagnostics.hasErrors());
    renderer.featureChanged(*areas, *changed);
    const Outcome afterEdit = drawAndCompare(at(cases[2].eye, cases[2].target, cases[2].fov), drawn,
                                             name + " 60 km after an edit", &renderer, settings, heights);
    EXPECT_GT(renderer.stats().builtTiles, 0U) << name;
    const double holeLon = 8.25, holeLat = 47.15;
    EXPECT_EQ(areas->contains(toEcef(holeLon, holeLat, 0.0), holeLon, holeLat), technique == GlobeTechnique::Stencil);
    EXPECT_GT(afterEdit.covered, 10000U);
    // A layer over more tiles than a whole build takes (boxes 20°–40° wide): drawn by its view's
    // tiles instead, still exact, beside the layers built whole.
    const Layers large = makeLayers();
    const std::vector<const GlobeLayer*> mixed{&large.boxes, &*areas};
    const Outcome o = drawAndCompare(view({-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}), mixed, name + " too large: tiles",
                                     &renderer, settings);
    EXPECT_GE(o.covered, 2000U);
    EXPECT_GT(renderer.stats().tiles.tilesBuilt, 0U) << "the boxes fall back to their tiles";
    // Two small features a continent apart: built whole around each, not over the box of both.
    std::vector<geo::Feature> apart(2);
    apart[0].polygons.push_back(test::globe_scene::box(-60.5, -20.5, -59.5, -19.5));
    apart[1].polygons.push_back(test::globe_scene::box(-35.5, -8.5, -34.5, -7.5));
    Result<GlobeLayer> two = GlobeLayer::build("two squares", apart, glm::vec4(0.9F, 0.4F, 0.1F, 0.5F));
    ASSERT_TRUE(two.ok());
    const Outcome both = drawAndCompare(view({-48.0, -14.0, 4e6}, {-48.0, -14.0, 0.0}), {&*two},
                                        name + " two squares apart", &renderer, settings);
    EXPECT_GE(both.covered, 100U);
    EXPECT_EQ(renderer.stats().tiles.tilesBuilt, 0U) << "built whole, not by tiles";
  }
}

TEST_F(GlobeOverlayGl, TheTilesStayUnderTheGpuBudgetAndEveryFrameStaysExact) {
  // One renderer over a flight (space, the continent, the antimeridian, a pole, back to the
  // start) with a budget of 1 MiB: after each frame the resident tiles hold at most the budget or,
  // when this frame's own tiles need more, just those; tiles leave and are built again, and every
  // frame is exact.
  const Layers layers = makeLayers();
  const std::vector<const GlobeLayer*> all{&layers.all, &layers.boxes, &layers.lines, &layers.outlines};
  GlobeOverlaySettings settings;
  settings.gpuBudgetBytes = std::size_t{1} << 20U;
  GlobeOverlayRenderer overlay;
  const std::vector<std::pair<Geodetic, Geodetic>> flight{{{-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
                                                          {{-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
                                                          {{165.0, -40.0, 6e5}, {-178.0, -21.0, 0.0}},
                                                          {{30.0, 70.0, 4e5}, {120.0, 89.0, 0.0}},
                                                          {{-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}}};
  std::size_t evicted = 0, rebuilt = 0;
  for (std::size_t k = 0; k < flight.size(); ++k) {
    drawAndCompare(view(flight[k].first, flight[k].second), all, "budget frame " + std::to_string(k), &overlay,
                   settings);
    const GlobeOverlayStats& s = overlay.stats();
    std::printf("budget frame %zu: drawn %zu tiles (%zu bytes), built %zu, resident %zu (%zu bytes), evicted %zu\n", k,
                s.drawnTiles, s.drawnBytes, s.builtTiles, s.residentTiles, s.residentBytes, s.evictedTiles);
    EXPECT_LE(s.residentBytes, std::max(settings.gpuBudgetBytes, s.drawnBytes)) << k;
    EXPECT_GT(s.drawnTiles, 0U) << k;
    evicted += s.evictedTiles;
    if (k + 1 == flight.size()) rebuilt = s.builtTiles;
  }
  EXPECT_GT(evicted, 0U) << "the flight must need more than the budget";
  EXPECT_GT(rebuilt, 0U) << "the first view's tiles left and came back";
}

TEST_F(GlobeOverlayGl, AFrameWhoseTilesExceedTheBudgetIsDrawnCoarserWithinIt) {
  // The tile residency of both frames keeps the GPU budget for one frame too: a view whose tiles
  // take more than the budget at the terrain's detail is drawn from their ancestors (levels up
  // until they fit, the error doubling per level), within the budget, exact farther than that
  // error from edges, and says so (tiles.tileErrorPixels); with room, the same view is drawn at
  // the terrain's detail again.
  const Layers layers = makeLayers();
  const std::vector<const GlobeLayer*> all{&layers.all, &layers.boxes, &layers.lines, &layers.outlines};
  const GlobeView v = view({-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0});
  GlobeOverlayRenderer roomy;
  const Outcome full = drawAndCompare(v, all, "budget: room", &roomy);
  const GlobeOverlayStats room = roomy.stats();
  EXPECT_EQ(room.tiles.tileErrorPixels, 0.5);
  EXPECT_GT(room.drawnBytes, 0U);
  GlobeOverlaySettings tight;
  tight.gpuBudgetBytes = room.drawnBytes / 3;
  GlobeOverlayRenderer squeezed;
  drawAndCompare(v, all, "budget: a third of the frame", &squeezed, tight);
  const GlobeOverlayStats& s = squeezed.stats();
  std::printf("budget %zu of %zu bytes: drawn %zu bytes, finest level %d (%d with room), error %.1f px\n",
              tight.gpuBudgetBytes, room.drawnBytes, s.drawnBytes, s.tiles.finestTileLevel, room.tiles.finestTileLevel,
              s.tiles.tileErrorPixels);
  EXPECT_LE(s.drawnBytes, tight.gpuBudgetBytes);
  EXPECT_LE(s.residentBytes, tight.gpuBudgetBytes);
  EXPECT_LT(s.tiles.finestTileLevel, room.tiles.finestTileLevel);
  EXPECT_GT(s.tiles.tileErrorPixels, 0.5);
  EXPECT_GT(s.drawnTiles, 0U);
  // Room again: the terrain's detail, the same pixels as the first renderer's.
  GlobeOverlaySettings roomAgain;
  const Outcome back = drawAndCompare(v, all, "budget: room again", &squeezed, roomAgain);
  EXPECT_EQ(squeezed.stats().tiles.tileErrorPixels, 0.5);
  EXPECT_EQ(back.covered, full.covered);
}

TEST_F(GlobeOverlayGl, LinesInPixelsKeepTheirWidthOnScreenFromSpaceToTheGround) {
  // Lines 3 px wide (a style's width_px) and a 10 m road at least 2 px wide (min_width_px): from
  // space the routes stay 3 px wide instead of vanishing; near the ground the road is its width
  // in metres. Each frame against the reference with the view's widths, 0 wrong pixels away from
  // edges; the pieces of the far tiles take their width in the shader (a width class above 0).
  GlobeLayerOptions pixels;
  pixels.lineWidthPixels = 3.0;
  pixels.lineWidthMetres = 0.0;
  pixels.anchorGround = grid();
  Result<GlobeLayer> routes =
      GlobeLayer::build("routes 3 px", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), pixels);
  GlobeLayerOptions least;
  least.lineWidthMetres = 10.0;
  least.lineWidthPixels = 2.0;
  least.anchorGround = grid();
  Result<GlobeLayer> road = GlobeLayer::build(
      "road 10 m, 2 px at least",
      {test::globe_scene::lineFeature({{8.5 - 0.002, 47.3 + 0.004}, {8.5 + 0.01, 47.3 + 0.0041}, {8.6, 47.5}})},
      glm::vec4(0.2F, 0.2F, 0.2F, 0.9F), least);
  ASSERT_TRUE(routes.ok() && road.ok());
  const std::vector<const GlobeLayer*> layers{&*routes, &*road};
  struct Case {
    std::string label;
    Geodetic eye, target;
    double fov = 45.0;
    std::size_t minCovered = 0;  ///< about the lines' length in pixels times their width, less a margin
  };
  const double field = grid()->heightAt(8.5, 47.3);
  const std::vector<Case> cases{
      {"px space 10,000 km", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}, 45.0, 200},
      {"px space 20,000 km", {150.0, 10.0, 2e7}, {150.0, 10.0, -6e6}, 45.0, 40},
      {"px oblique 800 km", {-62.0, -38.0, 8e5}, {-55.0, -22.0, 0.0}, 45.0, 150},
      {"px antimeridian oblique", {165.0, -40.0, 6e5}, {-178.0, -21.0, 0.0}, 45.0, 200},
      {"px north pole oblique", {30.0, 70.0, 4e5}, {120.0, 89.0, 0.0}, 45.0, 10},
      {"px road from 30 km", {8.55, 47.2, 30000.0}, {8.55, 47.4, field}, 45.0, 100},
      {"px road from 50 m", {8.5, 47.3035, field + 50.0}, {8.503, 47.30405, field}, 60.0, 300},
  };
  // By their pieces, then by the lookup (the projected frame's widths in pixels, at their anchors,
  // per pixel in space): the lookup draws both layers in every view but from space, where the
  // widest 3 px would pass its widest reach class (the pieces draw them there).
  for (const GlobeTechnique technique : {GlobeTechnique::StencilTiles, GlobeTechnique::Deferred}) {
    const bool lookup = technique == GlobeTechnique::Deferred;
    GlobeOverlaySettings settings;
    settings.technique = technique;
    GlobeOverlayRenderer overlay;
    std::size_t lookedUp = 0;
    const auto draw = [&](const GlobeView& v, const std::string& label) {
      const Outcome o = drawAndCompare(v, layers, (lookup ? "lookup " : "") + label, &overlay, settings);
      lookedUp += overlay.stats().deferredLayers == 2U ? 1U : 0U;
      return o;
    };
    for (const Case& c : cases) {
      const Outcome o = draw(view(c.eye, c.target, c.fov), c.label);
      EXPECT_GE(o.covered, c.minCovered) << c.label << ": the lines must show, as wide as asked";
    }
    // Random views over the first route, from 20 km to 5,000 km, looking down or obliquely.
    std::mt19937 random(41);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int k = 0; k < 8; ++k) {
      const double t = unit(random);
      const Geodetic target{-75.0 + 20.0 * t, -5.0 - 20.0 * t, 0.0};
      const double height = 2e4 * std::pow(250.0, unit(random));
      const double away = height / 111000.0 * unit(random);  // up to 45° off the vertical
      const double bearing = 6.283185307179586 * unit(random);
      const Geodetic eye{target.lon + away * std::cos(bearing), target.lat + away * std::sin(bearing), height};
      draw(view(eye, target), "px random " + std::to_string(k));
    }
    if (lookup) {
      EXPECT_GE(lookedUp, 10U) << "the lookup draws the lines in pixels in most views";
      // The GPU budget is a promise: with a quarter of it just below the largest index the lookup
      // drew, that layer (and those before it) are drawn by their pieces, still exactly.
      const GlobeView v = view(cases[2].eye, cases[2].target, cases[2].fov);
      GlobeOverlayRenderer fresh;
      drawAndCompare(v, layers, "lookup budget full", &fresh, settings);
      ASSERT_EQ(fresh.stats().deferredLayers, 2U);
      const std::size_t largest = fresh.stats().deferredHeldBytes;  // both layers' indices at this view
      GlobeOverlaySettings tight = settings;
      tight.gpuBudgetBytes = 4 * (largest / 2);  // at least one of the two is larger than half of both
      GlobeOverlayRenderer small;
      drawAndCompare(v, layers, "lookup budget tight", &small, tight);
      EXPECT_LT(small.stats().deferredLayers, 2U) << "an index over a quarter of the budget is not drawn";
      EXPECT_LE(small.stats().deferredBytes, tight.gpuBudgetBytes / 4);
      EXPECT_EQ(small.stats().deferredPending, 0U);
    } else {
      EXPECT_EQ(lookedUp, 0U);
    }
  }
  // From space the routes are built for a width class that scales them, and nearly 3 px wide:
  // the reference's covered pixels over the route's length (about 4,000 km at 10,000 km: 130 px).
  const GlobeView far = view({-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6});
  EXPECT_GT(lineWidthClass(*routes, TileKey{3, 4, 4}, *grid(), pixelScaleOf(far)), 0);
  EXPECT_EQ(lineWidthClass(*routes, TileKey{3, 4, 4}, *grid(), overlay::PixelScale{}), 0);
}

TEST_F(GlobeOverlayGl, VerticalExaggerationRaisesTheGroundAndEveryFrameStaysExact) {
  // The globe's exaggeration lives in its heights (GeoGrid::exaggerated): the terrain, the pieces'
  // bounds and the anchors of lines in pixels read the exaggerated ground, each point moved along
  // its normal, so what a layer covers is where it was. 4×: 0 wrong pixels away from edges from
  // space, obliquely over the relief, grazing it and a metre above it; the terrain is drawn
  // higher than at 1× (the depth differs), and heights are 4 times those read.
  const std::shared_ptr<const GeoGrid> high = GeoGrid::exaggerated(grid(), 4.0);
  ASSERT_NE(high.get(), grid().get());
  EXPECT_EQ(high->exaggeration(), 4.0);
  EXPECT_EQ(&high->unexaggerated(), grid().get());
  EXPECT_EQ(GeoGrid::exaggerated(high, 1.0).get(), grid().get()) << "1× is the grid as read";
  EXPECT_EQ(GeoGrid::exaggerated(high, 2.0)->heightAt(-37.0, -7.0), 2.0 * grid()->heightAt(-37.0, -7.0))
      << "an exaggeration replaces the last, it does not multiply it";
  EXPECT_EQ(high->heightAt(-37.0, -7.0), 4.0 * grid()->heightAt(-37.0, -7.0));
  const LonLatRect box{-40.0, -10.0, -30.0, 0.0};
  EXPECT_EQ(high->bounds(box).second, 4.0 * grid()->bounds(box).second);
  EXPECT_NE(high->contentDigest(), grid()->contentDigest()) << "tiles kept on disk are the exaggeration's own";
  const Layers layers = makeLayers();
  GlobeLayerOptions pixels;
  pixels.lineWidthPixels = 3.0;
  pixels.lineWidthMetres = 0.0;
  pixels.anchorGround = high;
  Result<GlobeLayer> routes =
      GlobeLayer::build("routes 3 px", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), pixels);
  ASSERT_TRUE(routes.ok());
  const std::vector<const GlobeLayer*> all{&layers.all, &layers.boxes, &layers.field, &*routes, &layers.road};
  const auto at = [&](const Geodetic& eye, const Geodetic& target, double fov) {
    return GlobeView::looking(toEcef(eye), toEcef(target), fov, 256, 256, high->heightAt(eye.lon, eye.lat));
  };
  const double field = high->heightAt(8.5, 47.3);
  struct Case {
    std::string label;
    Geodetic eye, target;
    double fov = 45.0;
  };
  const std::vector<Case> cases{
      {"4x space 10,000 km", {-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
      {"4x oblique 800 km", {-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
      {"4x grazing 20 km", {-37.5, -8.0, high->heightAt(-37.5, -8.0) + 20000.0}, {-33.0, -6.0, 0.0}},
      {"4x south pole low", {45.0, -86.0, high->heightAt(45.0, -86.0) + 20000.0}, {-135.0, -89.0, 0.0}},
      {"4x 1 m above the ground", {8.5, 47.30407, high->heightAt(8.5, 47.30407) + 1.0}, {8.5005, 47.304, field}, 60.0},
  };
  GlobeOverlayRenderer overlay;
  std::size_t covered = 0;
  for (const Case& c : cases) {
    const Outcome o = drawAndCompare(at(c.eye, c.target, c.fov), all, c.label, &overlay, {}, high);
    covered += o.covered;
  }
  EXPECT_GT(covered, 5000U) << "the views must show the layers";
  // The same oblique view over the relief at 1× and at 4×: the ground is drawn elsewhere.
  const GlobeView oblique = at({-37.5, -8.0, high->heightAt(-37.5, -8.0) + 20000.0}, {-33.0, -6.0, 0.0}, 45.0);
  const Outcome flat = drawAndCompare(oblique, {&layers.all}, "1x grazing 20 km");
  const Outcome raised = drawAndCompare(oblique, {&layers.all}, "4x grazing 20 km again", nullptr, {}, high);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < flat.depth.size(); ++i) moved += flat.depth[i] != raised.depth[i] ? 1U : 0U;
  EXPECT_GT(moved, flat.depth.size() / 4) << "the exaggerated relief is drawn";
}

TEST_F(GlobeOverlayGl, OneFeatureEditedRebuildsOnlyTheTilesItReaches) {
  // Editing one feature (GlobeLayer::replaceFeature, GlobeOverlayRenderer::featureChanged): the
  // tiles the feature reached before and reaches now are built again, the others stay on the GPU;
  // every frame after the edit is exact against the reference of the edited layer; the edited layer
  // is the one built from the edited features (same fingerprint). An edit that breaks the feature
  // is named, and leaves it out.
  std::vector<geo::Feature> areas = test::globe_scene::features();
  areas.pop_back();  // the field
  GlobeLayerOptions wide;
  wide.lineWidthMetres = 30000.0;
  std::vector<geo::Feature> routes = test::globe_scene::wideLines();
  Result<GlobeLayer> area = GlobeLayer::build("areas", areas, glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  Result<GlobeLayer> line = GlobeLayer::build("routes", routes, glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), wide);
  ASSERT_TRUE(area.ok() && line.ok());
  const std::vector<const GlobeLayer*> layers{&*area, &*line};
  const GlobeView europe = view({15.0, 48.0, 3e6}, {15.0, 48.0, 0.0});
  const GlobeView america = view({-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6});
  GlobeOverlayRenderer overlay;
  drawAndCompare(europe, layers, "edit: Europe before", &overlay);
  drawAndCompare(america, layers, "edit: South America before", &overlay);
  const std::size_t resident = overlay.stats().residentTiles;

  // Europe's box moved 4° east and its hole closed; the first route bent through Europe.
  geo::Feature moved = areas[4];
  moved.polygons = {test::globe_scene::box(4.0, 40.0, 34.0, 60.0)};
  Result<std::vector<LonLatRect>> areaBoxes = area->replaceFeature(4, moved);
  ASSERT_TRUE(areaBoxes.ok() && !areaBoxes.diagnostics.hasErrors());
  geo::Feature bent = routes[0];
  bent.lines = {{{-75.0, -5.0}, {-55.0, -25.0}, {5.0, 45.0}, {25.0, 50.0}}};
  Result<std::vector<LonLatRect>> lineBoxes = line->replaceFeature(0, bent);
  ASSERT_TRUE(lineBoxes.ok() && !lineBoxes.diagnostics.hasErrors());
  const std::size_t dropped = overlay.featureChanged(*area, *areaBoxes) + overlay.featureChanged(*line, *lineBoxes);
  EXPECT_GT(dropped, 0U);
  EXPECT_LT(dropped, resident) << "tiles the edits do not reach stay";
  const Outcome after = drawAndCompare(europe, layers, "edit: Europe after", &overlay);
  EXPECT_GT(overlay.stats().builtTiles, 0U);
  EXPECT_GT(after.covered, 1000U);
  // Where the moved box now reaches and the closed hole was, the edited layer covers.
  const double eastEdge = 33.0, holeLat = 48.0;
  EXPECT_TRUE(area->contains(toEcef(eastEdge, holeLat, 0.0), eastEdge, holeLat));
  EXPECT_TRUE(area->contains(toEcef(15.0, holeLat, 0.0), 15.0, holeLat));
  EXPECT_FALSE(area->contains(toEcef(2.0, holeLat, 0.0), 2.0, holeLat));

  // The edited layers are the ones built from the edited features: the same pieces, on disk too.
  areas[4] = moved;
  routes[0] = bent;
  Result<GlobeLayer> freshArea = GlobeLayer::build("areas", areas, glm::vec4(0.2F, 0.5F, 0.9F, 0.6F));
  Result<GlobeLayer> freshLine = GlobeLayer::build("routes", routes, glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), wide);
  ASSERT_TRUE(freshArea.ok() && freshLine.ok());
  EXPECT_EQ(area->fingerprint(), freshArea->fingerprint());
  EXPECT_EQ(line->fingerprint(), freshLine->fingerprint());
  const TileKey europeTile{4, 17, 8};
  const overlay::LayerGeometry edited = buildTilePieces(*area, europeTile, *grid()),
                               fresh = buildTilePieces(*freshArea, europeTile, *grid());
  EXPECT_EQ(edited.indices(), fresh.indices());
  EXPECT_EQ(edited.vertices().size(), fresh.vertices().size());

  // Over South America only the tiles the bent route reaches are built again.
  const Outcome far = drawAndCompare(america, layers, "edit: South America after", &overlay);
  std::printf("South America after the edits: %zu of %zu tiles built again\n", overlay.stats().builtTiles, far.tiles);
  EXPECT_LT(overlay.stats().builtTiles, far.tiles);

  // A broken edit is named; the feature is left out, the rest still drawn exactly.
  geo::Feature broken = areas[4];
  broken.polygons[0].outer[1].y = std::numeric_limits<double>::quiet_NaN();
  Result<std::vector<LonLatRect>> refused = area->replaceFeature(4, broken);
  EXPECT_TRUE(refused.diagnostics.hasErrors());
  ASSERT_EQ(refused.diagnostics.items().size(), 1U);
  EXPECT_EQ(refused.diagnostics.items()[0].feature, std::to_string(broken.fid));
  EXPECT_EQ(refused.diagnostics.items()[0].layer, "areas");
  ASSERT_TRUE(refused.ok());
  overlay.featureChanged(*area, *refused);
  EXPECT_FALSE(area->contains(toEcef(15.0, holeLat, 0.0), 15.0, holeLat));
  drawAndCompare(europe, layers, "edit: Europe, broken feature left out", &overlay);
}

TEST_F(GlobeOverlayGl, MiterAndBevelJoinsSquareAndFlatCapsInMetresAndPixels) {
  // A zigzag with sharp and slight turns, 40 km wide in metres and 8 px wide in pixels, with each
  // join and cap: every view against the reference (the joins and caps in the tangent plane at
  // their point), 0 wrong pixels away from edges. Square caps cover more than flat ones and
  // miters more than bevels, in the reference and so on the GPU.
  const std::vector<geo::Feature> zigzag{test::globe_scene::lineFeature(
      {{-72.0, -12.0}, {-64.0, -22.0}, {-63.0, -8.0}, {-55.0, -16.0}, {-50.0, -15.5}, {-47.0, -24.0}})};
  const auto make = [&](const std::string& name, overlay::LineJoin join, overlay::LineCap cap, bool pixels) {
    GlobeLayerOptions o;
    o.join = join;
    o.cap = cap;
    o.miterLimit = 6.0;
    if (pixels) {
      o.lineWidthPixels = 8.0;
      o.lineWidthMetres = 0.0;
      o.anchorGround = grid();
    } else {
      o.lineWidthMetres = 40000.0;
    }
    Result<GlobeLayer> l = GlobeLayer::build(name, zigzag, glm::vec4(0.9F, 0.2F, 0.1F, 0.8F), o);
    EXPECT_TRUE(l.ok()) << name;
    return std::move(*l);
  };
  using overlay::LineCap;
  using overlay::LineJoin;
  const GlobeLayer miterSquare = make("miter square 40 km", LineJoin::Miter, LineCap::Square, false);
  const GlobeLayer bevelFlat = make("bevel flat 40 km", LineJoin::Bevel, LineCap::Flat, false);
  const GlobeLayer miterFlatPx = make("miter flat 8 px", LineJoin::Miter, LineCap::Flat, true);
  const GlobeLayer bevelSquarePx = make("bevel square 8 px", LineJoin::Bevel, LineCap::Square, true);
  struct Case {
    std::string label;
    Geodetic eye, target;
  };
  const std::vector<Case> cases{{"joins from 4,000 km", {-60.0, -16.0, 4e6}, {-60.0, -16.0, 0.0}},
                                {"joins oblique", {-75.0, -35.0, 1.2e6}, {-62.0, -15.0, 0.0}},
                                {"a miter close up", {-64.0, -24.5, 4e5}, {-64.0, -22.0, 0.0}},
                                {"an end close up", {-47.0, -27.0, 3e5}, {-47.0, -24.0, 0.0}}};
  // By their pieces and by the lookup (the joins' and caps' polygons in space, per pixel). The
  // lines 40 km wide in metres, densified every kilometre, would make indices of some 570 MB each
  // (no primitive covers a leaf: bands 1 km long, bevels at the added points slivers): over a
  // quarter of the GPU budget, so their pieces draw them in `deferred` too (the budget is a
  // promise), and those in pixels are the lookup's.
  for (const GlobeTechnique technique : {GlobeTechnique::StencilTiles, GlobeTechnique::Deferred}) {
    const bool lookup = technique == GlobeTechnique::Deferred;
    GlobeOverlaySettings settings;
    settings.technique = technique;
    GlobeOverlayRenderer overlay;
    for (const std::vector<const GlobeLayer*>& pair :
         std::vector<std::vector<const GlobeLayer*>>{{&miterSquare, &bevelFlat}, {&miterFlatPx, &bevelSquarePx}}) {
      for (const Case& c : cases) {
        const Outcome o =
            drawAndCompare(view(c.eye, c.target), pair, (lookup ? "lookup " : "") + c.label + " " + pair[0]->name(),
                           &overlay, settings);
        const bool inPixels = pair[0] == &miterFlatPx;
        EXPECT_EQ(overlay.stats().deferredLayers, lookup && inPixels ? 2U : 0U) << c.label;
        EXPECT_EQ(overlay.stats().deferredPending, 0U) << c.label;
        // Held: within a quarter of the budget, or no more than this frame's.
        EXPECT_LE(overlay.stats().deferredHeldBytes,
                  std::max(settings.gpuBudgetBytes / 4, overlay.stats().deferredBytes))
            << c.label;
        std::size_t first = 0, second = 0;
        for (const std::uint32_t m : o.expected) {
          first += (m & 1U) != 0 ? 1U : 0U;
          second += (m & 2U) != 0 ? 1U : 0U;
        }
        EXPECT_GT(first, 100U) << c.label;
        if (pair[0] == &miterSquare) {
          EXPECT_GT(first, second) << c.label << ": miters and square caps cover more";
        }
      }
    }
  }
}

TEST_F(GlobeOverlayGl, TilesAreKeptOnDiskAndADamagedOneIsBuiltAgain) {
  // A first renderer builds the tiles and writes them; a second reads every one back and draws
  // the same image; a tile whose file is damaged is built again (and rewritten); a layer that
  // changes (another width) reads none of the old ones.
  const std::filesystem::path dir =
      std::filesystem::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("tile_cache_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const Layers layers = makeLayers();
  GlobeLayerOptions pixels;
  pixels.lineWidthPixels = 3.0;
  pixels.lineWidthMetres = 0.0;
  pixels.anchorGround = grid();
  pixels.join = overlay::LineJoin::Miter;
  Result<GlobeLayer> routes =
      GlobeLayer::build("routes 3 px", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), pixels);
  ASSERT_TRUE(routes.ok());
  const std::vector<const GlobeLayer*> all{&layers.all, &layers.boxes, &*routes, &layers.outlines};
  GlobeOverlaySettings settings;
  settings.cacheDir = dir.string();
  const GlobeView v = view({-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6});
  const auto draw = [&](const std::string& label) {
    GlobeOverlayRenderer overlay;
    Outcome o = drawAndCompare(v, all, label, &overlay, settings);
    const GlobeOverlayStats& s = overlay.stats();
    std::printf("%s: built %zu, read %zu, written %zu, repaired %zu\n", label.c_str(), s.builtTiles, s.readTiles,
                s.writtenTiles, s.repairedTiles);
    return std::make_pair(std::move(o.rgba), s);
  };
  const auto [first, built] = draw("cache cold");
  EXPECT_GT(built.writtenTiles, 0U);
  EXPECT_EQ(built.readTiles, 0U);
  const auto [second, warm] = draw("cache warm");
  EXPECT_EQ(warm.readTiles, built.writtenTiles);
  EXPECT_EQ(warm.builtTiles, 0U);
  EXPECT_EQ(warm.repairedTiles, 0U);
  EXPECT_TRUE(first == second) << "the tiles read back draw the same image";
  // Damage one file: a byte in its middle.
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (e.is_regular_file() && e.file_size() > 1000) files.push_back(e.path());
  }
  ASSERT_FALSE(files.empty());
  {
    std::fstream f(files.front(), std::ios::in | std::ios::out | std::ios::binary);
    const auto middle = static_cast<std::streamoff>(std::filesystem::file_size(files.front()) / 2);
    f.seekg(middle);
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ 0x5A);
    f.seekp(middle);
    f.write(&c, 1);
  }
  const auto [third, repaired] = draw("cache one damaged");
  EXPECT_EQ(repaired.repairedTiles, 1U);
  EXPECT_EQ(repaired.builtTiles, 1U);
  EXPECT_EQ(repaired.readTiles, built.writtenTiles - 1);
  EXPECT_TRUE(first == third) << "the damaged tile built again draws the same image";
  const auto [fourth, again] = draw("cache rewritten");
  EXPECT_EQ(again.repairedTiles, 0U);
  EXPECT_EQ(again.readTiles, built.writtenTiles);
  // Another width: another fingerprint, nothing read.
  pixels.lineWidthPixels = 4.0;
  Result<GlobeLayer> wider =
      GlobeLayer::build("routes 4 px", test::globe_scene::wideLines(), glm::vec4(0.9F, 0.1F, 0.1F, 0.8F), pixels);
  ASSERT_TRUE(wider.ok());
  EXPECT_NE(wider->fingerprint(), routes->fingerprint());
  GlobeOverlayRenderer overlay;
  drawAndCompare(v, {&*wider}, "cache another layer", &overlay, settings);
  EXPECT_EQ(overlay.stats().readTiles, 0U);
  // The cache's housekeeping, as a projected scene's (overlay::pruneTileFolders): a folder no layer
  // opened for 30 days (another build, grid or code) goes; those opened lately stay.
  const std::filesystem::path stale = dir / "globe-tiles" / "00000000deadbeef";
  std::filesystem::create_directories(stale);
  std::ofstream(stale / "0-0-0-0.bin") << "an old tile";
  std::filesystem::last_write_time(stale, std::filesystem::file_time_type::clock::now() - std::chrono::hours(24 * 31));
  std::size_t folders = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir / "globe-tiles")) folders += e.is_directory() ? 1U : 0U;
  GlobeOverlayRenderer later;
  drawAndCompare(v, {&*wider}, "cache pruned", &later, settings);
  EXPECT_EQ(later.stats().prunedFolders, 1U);
  EXPECT_FALSE(std::filesystem::exists(stale));
  std::size_t left = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir / "globe-tiles")) left += e.is_directory() ? 1U : 0U;
  EXPECT_EQ(left, folders - 1);
  std::filesystem::remove_all(dir);
}

TEST_F(GlobeOverlayGl, ColoursByFeatureAndWidthsByFeature) {
  // Three fields in colours of their own (the third in the layer's), opaque so each pixel shows
  // its feature's colour exactly; and two roads, 25 km and 80 km wide, across them.
  std::vector<geo::Feature> fields(3);
  fields[0].polygons.push_back(test::globe_scene::box(-70.0, -40.0, -61.0, -30.0));
  fields[1].polygons.push_back(test::globe_scene::box(-59.0, -40.0, -51.0, -30.0));
  fields[2].polygons.push_back(test::globe_scene::box(-49.0, -40.0, -40.0, -30.0));
  const std::vector<glm::vec4> colours{{1.0F, 0.0F, 0.0F, 1.0F}, {0.0F, 1.0F, 0.0F, 1.0F}, {0.0F, 0.0F, 1.0F, 1.0F}};
  GlobeLayerOptions byFeature;
  byFeature.featureColors = {colours[0], colours[1]};
  Result<GlobeLayer> areas = GlobeLayer::build("fields", fields, colours[2], byFeature);
  GlobeLayerOptions widths;
  widths.featureWidthMetres = {25000.0, 80000.0};
  Result<GlobeLayer> roads = GlobeLayer::build(
      "roads", {lineFeature({{-72.0, -33.0}, {-38.0, -34.0}}), lineFeature({{-72.0, -37.0}, {-38.0, -36.0}})},
      glm::vec4(0.0F, 0.0F, 0.0F, 1.0F), widths);
  ASSERT_TRUE(areas.ok() && roads.ok());
  EXPECT_EQ(areas->colors().size(), 3u);
  ASSERT_EQ(roads->lines().size(), 2u);
  EXPECT_EQ(roads->lines()[0].halfWidth, 12500.0);
  EXPECT_EQ(roads->lines()[1].halfWidth, 40000.0);
  const GlobeView v = view({-55.0, -35.0, 2.5e6}, {-55.0, -35.0, 0.0});
  const Outcome o = drawAndCompare(v, {&*areas, &*roads}, "colours and widths by feature");
  std::array<std::size_t, 3> seen{};
  std::size_t wrongColour = 0, narrow = 0, wide = 0;
  for (int row = 0; row < v.height; ++row) {
    for (int col = 0; col < v.width; ++col) {
      const std::size_t i =
          static_cast<std::size_t>(row) * static_cast<std::size_t>(v.width) + static_cast<std::size_t>(col);
      if (o.edges[i] != 0 || o.expected[i] == 0) continue;
      glm::dvec3 p;
      const std::optional<glm::dvec3> ground = overlay::unprojectDepth(depthImageOf(v, {}), col, row, o.depth[i]);
      ASSERT_TRUE(ground);
      p = *ground;
      const Geodetic g = toGeodetic(p);
      if ((o.expected[i] & 2U) != 0) {
        const std::vector<std::uint32_t> road = featuresAt(*roads, p, g.lon, g.lat);
        ASSERT_EQ(road.size(), 1u);
        (road[0] == 0 ? narrow : wide) += 1;
        continue;  // the roads are drawn over the fields
      }
      const std::vector<std::uint32_t> f = featuresAt(*areas, p, g.lon, g.lat);
      ASSERT_EQ(f.size(), 1u);
      ++seen[f[0]];
      // The pixel shows its feature's colour.
      const std::size_t px = i * 4;
      for (int c = 0; c < 3; ++c) {
        const int want = static_cast<int>(colours[f[0]][c] * 255.0F + 0.5F);
        if (std::abs(static_cast<int>(o.rgba[px + static_cast<std::size_t>(c)]) - want) > 1) {
          ++wrongColour;
          break;
        }
      }
    }
  }
  std::printf("fields' pixels %zu %zu %zu, wrong colour %zu; road pixels 25 km %zu, 80 km %zu\n", seen[0], seen[1],
              seen[2], wrongColour, narrow, wide);
  EXPECT_EQ(wrongColour, 0u);
  for (const std::size_t n : seen) EXPECT_GT(n, 500u);
  EXPECT_GT(wide, 3 * narrow);
  EXPECT_GT(narrow, 20u);
}

TEST_F(GlobeOverlayGl, TheDrapesOfBothFramesLieInLongitudeAndLatitudeAndSharpenWithTheirTexels) {
  // Texture draping on the globe (`drape`, `drape-tiles`: the projected frame's techniques, their
  // textures in longitude and latitude): the baseline, not exact. What must hold:
  // - the single drape: the GPU mask the terrain writes is the drape's texel under each pixel's
  //   ground point, or one within a tenth of a texel of it (the terrain's uv is linear across a
  //   flat triangle, the point's longitude and latitude nearly so: near the poles, on coarse
  //   tiles seen from afar, they part by a few hundredths of a texel);
  // - per tile: away from the reference's edge band, fewer pixels wrong with finer texels, and
  //   few at 512² texels a tile;
  // - the drape draws no pieces, and its layers keep their bits and order (mask bit i: layer i).
  const Layers layers = makeLayers();
  const std::vector<const GlobeLayer*> all{&layers.all, &layers.boxes, &layers.lines};
  const std::vector<std::pair<Geodetic, Geodetic>> views{{{-60.0, -20.0, 1e7}, {-60.0, -20.0, -6e6}},
                                                         {{-30.0, -45.0, 8e5}, {-45.0, -20.0, 0.0}},
                                                         {{180.0, -14.0, 4e6}, {180.0, -14.0, 0.0}},
                                                         {{0.0, 90.0, 3e6}, {0.0, 90.0, 0.0}}};
  const auto draw = [&](GlobeRenderer& renderer, const GlobeView& v, GlobeTechnique technique, int size,
                        gfx::RenderTarget& target) {
    GlobeOverlaySettings settings;
    settings.technique = technique;
    settings.textureSize = size;
    return renderer.render(cache_, {target.framebuffer(), v.width, v.height, true}, v, all, false, settings);
  };
  std::size_t unlike = 0, checked = 0;
  std::array<std::size_t, 2> wrong{}, covered{};
  const std::array<int, 2> tileSizes{64, 512};
  for (std::size_t k = 0; k < views.size(); ++k) {
    const GlobeView v = view(views[k].first, views[k].second);
    gfx::RenderTarget target(v.width, v.height, 0, true);
    {
      GlobeRenderer renderer(grid());
      const GlobeFrameStats s = draw(renderer, v, GlobeTechnique::Drape, 2048, target);
      EXPECT_TRUE(s.overlay.draped);
      EXPECT_EQ(s.overlay.pieces, 0U);
      const overlay::TextureDrape* drape = renderer.overlay().textureDrape();
      ASSERT_NE(drape, nullptr);
      const std::vector<std::uint32_t> texels = drape->readMask();
      const std::vector<float> depth = gfx::readDepth(target);
      const std::vector<std::uint32_t> mask = gfx::readMask(target);
      const overlay::DepthImage image = depthImageOf(v, depth);
      for (int y = 0; y < v.height; ++y) {
        for (int x = 0; x < v.width; ++x) {
          const auto i = static_cast<std::size_t>(y * v.width + x);
          if (!(depth[i] > 0.0F)) continue;
          const std::optional<glm::dvec3> ground = overlay::unprojectDepth(image, x, y, depth[i]);
          if (!ground) continue;
          const Geodetic g = toGeodetic(*ground);
          glm::dvec2 point(g.lon, g.lat);
          if (point.x < drape->extent().origin.x) point.x += 360.0;
          // The texel under the point, or one within a tenth of a texel of it.
          const glm::dvec2 texel = drape->extent().size / double(drape->size());
          bool agrees = false;
          for (const glm::dvec2 by : {glm::dvec2(0.0), glm::dvec2(-0.1, -0.1), glm::dvec2(0.1, -0.1),
                                      glm::dvec2(-0.1, 0.1), glm::dvec2(0.1, 0.1)})
            agrees = agrees || drape->maskAt(texels, point + by * texel) == mask[i];
          ++checked;
          unlike += agrees ? 0U : 1U;
        }
      }
    }
    for (std::size_t s = 0; s < tileSizes.size(); ++s) {
      GlobeRenderer renderer(grid());
      const GlobeFrameStats stats = draw(renderer, v, GlobeTechnique::DrapeTiles, tileSizes[s], target);
      EXPECT_TRUE(stats.overlay.draped);
      EXPECT_EQ(stats.overlay.texturesBuilt, stats.selectedTiles);
      const std::vector<float> depth = gfx::readDepth(target);
      const std::vector<std::uint32_t> gpu = gfx::readMask(target);
      const overlay::DepthImage image = depthImageOf(v, depth);
      const std::vector<std::uint32_t> expected = overlay::referenceMask(image, referenceLayersOf(all, image));
      const std::vector<std::uint8_t> edges = overlay::edgePixels(image, referenceLayersOf(all, image));
      std::size_t w = 0, c = 0;
      for (std::size_t i = 0; i < gpu.size(); ++i) {
        c += expected[i] != 0 ? 1U : 0U;
        w += gpu[i] != expected[i] && edges[i] == 0 ? 1U : 0U;
      }
      std::printf("drape tiles %d² view %zu: %zu tiles, %zu of %zu covered pixels wrong away from edges\n",
                  tileSizes[s], k, stats.selectedTiles, w, c);
      wrong[s] += w;
      covered[s] += c;
    }
  }
  std::printf("single drape 2048²: %zu of %zu pixels unlike their texel\n", unlike, checked);
  EXPECT_GT(checked, 10000U);
  EXPECT_EQ(unlike, 0U);
  EXPECT_GT(covered[1], 5000U);
  EXPECT_LT(wrong[1], wrong[0]) << "finer texels must draw fewer wrong pixels";
  EXPECT_LE(wrong[1], covered[1] / 50) << "512² tiles: at most 2 % of the covered pixels wrong away from edges";
}

}  // namespace
}  // namespace gis::globe
