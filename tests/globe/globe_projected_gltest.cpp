// The projected frame and the globe agree on a regional scene (docs/globe.md): Olinda's census
// tracts drawn on the globe, and every ground pixel of that image classified by the projected
// frame's CPU reference (the tracts read into the scene's UTM frame, as the projected renderer
// draws them). Away from the tracts' edges the two agree on every pixel. The stated tolerance is
// the edges' own: the projected reader keeps a tract's edges within 1 mm of the geodesic
// (geo::VectorReadOptions::geodesicToleranceMetres), the globe draws them within millimetres of
// it, and a pixel here is metres wide.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "scene/globe_renderer.hpp"
#include "scene/globe_scene.hpp"
#include "scene/scene_loader.hpp"
#include "test_paths.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::globe {
namespace {

class GlobeProjectedGl : public test::GlTest {};

TEST_F(GlobeProjectedGl, OlindaTractsAgreeWithTheProjectedFrame) {
  Result<scene::SceneDescription> description =
      scene::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  ASSERT_TRUE(description.ok());
  description->layers.resize(1);  // the census tracts (polygons)
  description->imagery.reset();
  ASSERT_EQ(description->layers[0].kind, overlay::LayerKind::Polygon);
  scene::LoadOptions options;
  options.layerCache = false;
  Result<scene::LoadedScene> projected = scene::loadScene(*description, options);
  ASSERT_TRUE(projected.ok());
  ASSERT_EQ(projected->layers.size(), 1u);
  const std::vector<geo::Feature>& tracts = projected->layers[0].features.all();
  overlay::ReferenceLayer reference;
  reference.name = "census tracts";
  reference.kind = overlay::LayerKind::Polygon;
  reference.features = &tracts;

  scene::SceneDescription onGlobe = *description;
  onGlobe.frame = scene::FrameKind::Globe;
  Result<scene::LoadedGlobeScene> globe = scene::loadGlobeScene(onGlobe);
  ASSERT_TRUE(globe.ok());
  ASSERT_EQ(globe->layers.size(), 2u);  // the tracts and their outline
  const std::vector<const GlobeLayer*> layers{&globe->layers[0]};
  GlobeRenderer renderer(globe->heights);

  // Olinda is at about (−34.86, −8.01).
  struct Case {
    std::string label;
    Geodetic eye, target;
  };
  const std::vector<Case> cases{{"from 6 km above", {-34.86, -8.02, 6000.0}, {-34.86, -8.0, 0.0}},
                                {"oblique from the sea", {-34.80, -8.05, 1500.0}, {-34.86, -8.00, 0.0}},
                                {"low over the tracts", {-34.855, -8.015, 200.0}, {-34.845, -8.005, 0.0}}};
  for (const Case& c : cases) {
    const GlobeView view = GlobeView::looking(toEcef(c.eye), toEcef(c.target), 45.0, 256, 256,
                                              globe->heights->heightAt(c.eye.lon, c.eye.lat));
    gfx::RenderTarget target(256, 256, 0, true);
    renderer.render(cache_, {target.framebuffer(), 256, 256, true}, view, layers);
    const std::vector<float> depth = gfx::readDepth(target);
    const std::vector<std::uint32_t> gpu = gfx::readMask(target);
    // Each ground point, in the projected frame, by the projected reference.
    std::vector<std::uint32_t> inFrame(gpu.size(), 0);
    for (int row = 0; row < 256; ++row) {
      for (int col = 0; col < 256; ++col) {
        const std::size_t i = static_cast<std::size_t>(row) * 256 + static_cast<std::size_t>(col);
        glm::dvec3 point;
        const std::optional<glm::dvec3> seen = overlay::unprojectDepth(depthImageOf(view, {}), col, row, depth[i]);
        if (!seen) continue;
        point = *seen;
        const Geodetic g = toGeodetic(point);
        const std::optional<glm::dvec3> f = projected->frame.fromLonLat(g.lon, g.lat, g.h);
        ASSERT_TRUE(f.has_value());
        inFrame[i] = overlay::coveringFeature(reference, glm::dvec2(*f)).has_value() ? 1U : 0U;
      }
    }
    const std::vector<std::uint8_t> edges = overlay::maskEdges(inFrame, depthImageOf(view, depth));
    std::size_t covered = 0, away = 0, wrong = 0, edgeWrong = 0;
    for (std::size_t i = 0; i < gpu.size(); ++i) {
      covered += inFrame[i];
      away += depth[i] > 0.0F && edges[i] == 0 ? 1U : 0U;
      if (gpu[i] == inFrame[i]) continue;
      if (edges[i] != 0) {
        ++edgeWrong;
      } else if (wrong++ < 5) {
        ADD_FAILURE() << c.label << ": pixel (" << i % 256 << ", " << i / 256 << ") globe " << gpu[i]
                      << ", projected frame " << inFrame[i];
      }
    }
    std::printf("%-24s covered %6zu, %6zu ground pixels away from edges, differing %zu (on edges %zu)\n",
                c.label.c_str(), covered, away, wrong, edgeWrong);
    EXPECT_EQ(wrong, 0u) << c.label;
    EXPECT_GT(covered, 2000u) << c.label;
  }
}

}  // namespace
}  // namespace gis::globe
