// scene::FrameRenderer as an interactive program drives it (the viewer, issue 41): the same
// switches in both frames, on the Olinda sample drawn in its projected frame and on the globe
// ("frame": "globe"), each frame from the scene's own camera:
// - the imagery switch changes the ground's colour and never the layers' mask;
// - with every layer hidden the mask is empty and the colour is the frame without overlays;
//   shown again, the frame is as it was, bit for bit;
// - a layer restyled in another colour keeps its mask and its pixels change colour;
// - identify: at pixels a layer's bit covers (away from every edge of the reference), the layer
//   names a feature there (FrameRenderer::featuresAt).
#include <algorithm>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "frame_accuracy.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/frame_scene.hpp"
#include "scene/scene.hpp"
#include "test_paths.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

const std::string kScene = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json";
constexpr int kWidth = 256, kHeight = 192;

struct Frame {
  std::vector<std::uint8_t> rgba;
  std::vector<std::uint32_t> mask;
  std::vector<float> depth;
};

class FrameRendererGlTest : public GlTest, public ::testing::WithParamInterface<scene::FrameKind> {
 protected:
  /// A frame once everything it needs has arrived: a flight's frame draws what is there (the
  /// globe reads its imagery a few tiles a frame), so frames are drawn until none is pending.
  Frame draw(scene::FrameRenderer& renderer, const scene::FrameCamera& camera, const scene::FrameOptions& options) {
    gfx::RenderTarget target(kWidth, kHeight, 0, true);
    for (int k = 0; k < 1000; ++k) {
      const scene::FrameFigures f = renderer.drawFrame(cache_, target, camera, options);
      if (f.terrainPending == 0 && f.tilesMissing == 0 && f.terrain.tilesMissing == 0) break;
    }
    return {gfx::readColorRgba8(target), gfx::readMask(target), gfx::readDepth(target)};
  }
};

TEST_P(FrameRendererGlTest, TheViewersSwitchesInEitherFrame) {
  Result<scene::SceneDescription> description = scene::loadSceneFile(kScene);
  ASSERT_TRUE(description.ok());
  description->frame = GetParam();
  description->cacheDisabled = true;
  Result<scene::Scene> loaded = scene::Scene::load(*description);
  ASSERT_TRUE(loaded.ok());
  ASSERT_EQ(loaded->onGlobe(), GetParam() == scene::FrameKind::Globe);
  const char* frame = loaded->onGlobe() ? "globe" : "projected";
  Result<scene::FrameCamera> camera = loaded->stillCamera("", kScene, kWidth, kHeight);
  ASSERT_TRUE(camera.ok());
  Result<std::unique_ptr<scene::FrameRenderer>> made = scene::FrameRenderer::create(*loaded, {});
  ASSERT_TRUE(made.ok());
  scene::FrameRenderer& renderer = **made;
  ASSERT_TRUE(renderer.hasImagery()) << "the sample scene has an orthophoto";
  ASSERT_GE(renderer.drawnLayerCount(), 2U);

  const scene::FrameOptions shown;  // every layer, with imagery
  const Frame first = draw(renderer, *camera, shown);
  std::size_t terrain = 0, covered = 0;
  for (std::size_t i = 0; i < first.mask.size(); ++i) {
    terrain += first.depth[i] > 0.0F ? 1U : 0U;
    covered += first.mask[i] != 0 ? 1U : 0U;
  }
  std::printf("%s: %zu terrain pixels, %zu covered by a layer\n", frame, terrain, covered);
  ASSERT_GT(terrain, first.mask.size() / 4);
  ASSERT_GT(covered, 1000U);

  // The imagery switch: the ground's colour, not the mask.
  scene::FrameOptions plain = shown;
  plain.imagery = false;
  const Frame noImagery = draw(renderer, *camera, plain);
  std::size_t recoloured = 0;
  for (std::size_t i = 0; i < first.mask.size(); ++i) {
    if (first.depth[i] > 0.0F && first.mask[i] == 0 &&
        (first.rgba[4 * i] != noImagery.rgba[4 * i] || first.rgba[4 * i + 1] != noImagery.rgba[4 * i + 1]))
      ++recoloured;
  }
  EXPECT_EQ(noImagery.mask, first.mask);
  // (on the globe the orthophoto covers part of the ground seen)
  EXPECT_GT(recoloured, terrain / 8) << frame << ": the imagery switch changed too few pixels";
  EXPECT_EQ(draw(renderer, *camera, shown).rgba, first.rgba) << frame << ": the imagery did not come back";

  // Every layer hidden: no bit, the colour of the frame without overlays; shown again, the frame
  // as it was.
  scene::FrameOptions bare = shown;
  bare.overlays = false;
  const Frame withoutOverlays = draw(renderer, *camera, bare);
  for (std::size_t j = 0; j < renderer.drawnLayerCount(); ++j) renderer.setDrawnLayerShown(j, false);
  const Frame hidden = draw(renderer, *camera, shown);
  EXPECT_EQ(std::count(hidden.mask.begin(), hidden.mask.end(), 0U), static_cast<std::ptrdiff_t>(hidden.mask.size()));
  EXPECT_EQ(hidden.rgba, withoutOverlays.rgba) << frame;
  for (std::size_t j = 0; j < renderer.drawnLayerCount(); ++j) {
    EXPECT_FALSE(renderer.drawnLayerShown(j));
    renderer.setDrawnLayerShown(j, true);
  }
  const Frame again = draw(renderer, *camera, shown);
  EXPECT_EQ(again.mask, first.mask) << frame;
  EXPECT_EQ(again.rgba, first.rgba) << frame;

  // Identify: where the first drawn layer's bit is set away from every edge of the reference, the
  // layer names a feature at the pixel's ground point.
  const overlay::DepthImage image = scene::Scene::depthImageOf(*camera, kWidth, kHeight, first.depth);
  std::vector<std::size_t> all(renderer.drawnLayerCount());
  std::iota(all.begin(), all.end(), std::size_t{0});
  const scene::ReferenceAnswer reference = renderer.referenceOf(all, image);
  std::vector<std::size_t> inside;
  for (std::size_t i = 0; i < first.mask.size(); ++i)
    if ((first.mask[i] & 1U) != 0 && reference.edges[i] == 0) inside.push_back(i);
  std::size_t probed = 0, named = 0;
  for (std::size_t k = 0; k < inside.size(); k += std::max<std::size_t>(inside.size() / 50, 1)) {
    const std::size_t i = inside[k];
    const std::optional<glm::dvec3> world =
        overlay::unprojectPixel(image, static_cast<int>(i % kWidth), static_cast<int>(i / kWidth));
    if (!world) continue;
    ++probed;
    named += renderer.featuresAt(0, *world, *camera, kWidth, kHeight).empty() ? 0U : 1U;
  }
  EXPECT_GT(probed, 10U) << frame;
  EXPECT_EQ(named, probed) << frame << ": identify missed features the mask shows";

  // Restyled in another colour: the same mask, its pixels recoloured; layers hidden stay hidden.
  std::vector<scene::LayerDescription> styles = description->layers;
  const std::size_t fileIndex = renderer.drawnLayerSource(0).fileIndex;
  for (scene::LayerDescription& d : styles)
    if (d.fileIndex == fileIndex) d.style.color = glm::vec4(1.0F, 0.0F, 1.0F, 1.0F);
  const std::size_t last = renderer.drawnLayerCount() - 1;
  renderer.setDrawnLayerShown(last, false);
  const Diagnostics said = renderer.restyle(styles);
  EXPECT_FALSE(said.hasErrors());
  EXPECT_FALSE(renderer.drawnLayerShown(last)) << frame << ": a restyle showed a hidden layer";
  renderer.setDrawnLayerShown(last, true);
  const Frame restyled = draw(renderer, *camera, shown);
  EXPECT_EQ(restyled.mask, first.mask) << frame;
  std::size_t layerPixels = 0, changed = 0;
  for (std::size_t i = 0; i < first.mask.size(); ++i) {
    if (first.mask[i] != 1U) continue;  // the first layer's bit alone
    ++layerPixels;
    changed += restyled.rgba[4 * i] != first.rgba[4 * i] || restyled.rgba[4 * i + 2] != first.rgba[4 * i + 2] ? 1U : 0U;
  }
  std::printf(
      "%s: imagery switch recoloured %zu pixels; identify named %zu of %zu probes; restyle changed %zu of "
      "%zu pixels\n",
      frame, recoloured, named, probed, changed, layerPixels);
  EXPECT_GT(layerPixels, 100U) << frame;
  EXPECT_GT(changed, layerPixels * 9 / 10) << frame;
}

INSTANTIATE_TEST_SUITE_P(BothFrames, FrameRendererGlTest, kBothFrames, frameName);

}  // namespace
}  // namespace gis::test
