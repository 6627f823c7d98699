#pragma once
// One accuracy check for either frame (issue 41: the frames' tests share their fixtures): a
// scene::Scene drawn through scene::FrameRenderer, as overlay_render and the viewer draw it, and
// its GPU mask (a bit per drawn layer) against the CPU reference of the source geometry on the
// same depth buffer (FrameRenderer::referenceOf, the geodetic one on the globe), as
// overlay_bench's methods mode judges its frames.
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/frame_scene.hpp"
#include "scene/scene.hpp"

namespace gis::test {

struct FrameAccuracy {
  std::size_t covered = 0;    ///< pixels the reference covers
  std::size_t wrong = 0;      ///< differing pixels away from edges
  std::size_t edgeWrong = 0;  ///< differing pixels on edges
  FrameAccuracy& operator+=(const FrameAccuracy& o) {
    covered += o.covered;
    wrong += o.wrong;
    edgeWrong += o.edgeWrong;
    return *this;
  }
};

/// The frames a test runs in, named (INSTANTIATE_TEST_SUITE_P(BothFrames, Suite, kBothFrames,
/// frameName)).
inline const auto kBothFrames = ::testing::Values(scene::FrameKind::Projected, scene::FrameKind::Globe);
inline std::string frameName(const ::testing::TestParamInfo<scene::FrameKind>& param) {
  return param.param == scene::FrameKind::Globe ? "Globe" : "Projected";
}

/// Draws a still from `camera` into a target of this size and compares every drawn layer with
/// the reference; the first pixels wrong away from edges are test failures naming `label`.
inline FrameAccuracy judgeStill(gfx::StateCache& cache, scene::FrameRenderer& renderer,
                                const scene::FrameCamera& camera, int width, int height, const std::string& label) {
  gfx::RenderTarget target(width, height, 0, true);
  renderer.drawStill(cache, target, camera);
  const std::vector<float> depth = gfx::readDepth(target);
  const std::vector<std::uint32_t> gpu = gfx::readMask(target);
  const overlay::DepthImage image = scene::Scene::depthImageOf(camera, width, height, depth);
  std::vector<std::size_t> drawn(renderer.drawnLayerCount());
  std::iota(drawn.begin(), drawn.end(), std::size_t{0});
  const scene::ReferenceAnswer reference = renderer.referenceOf(drawn, image);
  FrameAccuracy a;
  int reported = 0;
  for (std::size_t i = 0; i < gpu.size(); ++i) {
    a.covered += reference.expected[i] != 0 ? 1U : 0U;
    if (gpu[i] == reference.expected[i]) continue;
    if (reference.edges[i] != 0) {
      ++a.edgeWrong;
    } else {
      ++a.wrong;
      if (reported++ < 3) {
        ADD_FAILURE() << label << ": pixel (" << i % static_cast<std::size_t>(width) << ", "
                      << i / static_cast<std::size_t>(width) << ") drawn " << gpu[i] << ", reference "
                      << reference.expected[i] << ", depth " << depth[i];
      }
    }
  }
  return a;
}

}  // namespace gis::test
