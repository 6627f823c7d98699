#pragma once
// GL tests of the overlay against the CPU reference on the same depth buffer (docs/design.md §7): draw
// the terrain and the layers into a target with a layer mask, read it back and count the pixels
// where the GPU mask differs from the reference, away from feature edges and on them.
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/mat4x4.hpp>

#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "sample_positions.hpp"
#include "terrain/lod.hpp"
#include "terrain/terrain_engine.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::test::overlay_test {

struct Comparison {
  std::size_t covered = 0;      ///< pixels the reference covers
  std::size_t wrong = 0;        ///< differing pixels away from edges
  std::size_t edgeWrong = 0;    ///< differing pixels on edges
  std::size_t zFailPieces = 0;  ///< pieces drawn z-fail in this frame
};

inline std::vector<overlay::ReferenceLayer> referenceLayers(const std::vector<const overlay::OverlayLayer*>& layers) {
  std::vector<overlay::ReferenceLayer> out;
  for (const overlay::OverlayLayer* l : layers) out.push_back(overlay::referenceLayerOf(*l));
  return out;
}

/// Reads the target back and compares it with the reference; with `failOnWrong` the first
/// differing pixels away from edges are test failures, else they are only counted.
inline Comparison compare(const gfx::RenderTarget& target, const glm::dmat4& viewProj,
                          const std::vector<const overlay::OverlayLayer*>& layers, const std::string& label,
                          bool failOnWrong = true) {
  const std::vector<float> depth = gfx::readDepth(target);
  const std::vector<std::uint32_t> gpu = gfx::readMask(target);
  overlay::DepthImage image{target.width(), target.height(), depth, viewProj};
  const std::vector<overlay::ReferenceLayer> ref = referenceLayers(layers);
  const std::vector<std::uint32_t> expected = overlay::referenceMask(image, ref);
  const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
  Comparison c;
  int reported = 0;
  for (std::size_t i = 0; i < gpu.size(); ++i) {
    c.covered += expected[i] != 0 ? 1u : 0u;
    if (gpu[i] == expected[i]) continue;
    if (edges[i] != 0) {
      ++c.edgeWrong;
    } else {
      ++c.wrong;
      if (failOnWrong && reported++ < 5) {
        ADD_FAILURE() << label << ": pixel (" << i % static_cast<std::size_t>(target.width()) << ", "
                      << i / static_cast<std::size_t>(target.width()) << ") GPU mask " << gpu[i] << ", reference "
                      << expected[i] << ", depth " << depth[i];
      }
    }
  }
  return c;
}

/// Our terrain for the selection, then the layers, into a target with a mask.
inline std::vector<overlay::LayerFrameStats> drawTerrainAndLayers(
    gfx::StateCache& cache, gfx::RenderTarget& target, terrain::TerrainEngine& engine,
    overlay::OverlayRenderer& overlays, const terrain::LodSelection& selection, const overlay::OverlayView& view,
    const std::vector<const overlay::OverlayLayer*>& layers, const overlay::OverlaySettings& settings = {},
    double exaggeration = 1.0) {
  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, target, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
  gfx::enableMaskWrites(target.framebuffer(), false);  // the terrain shader has no mask output
  engine.draw(cache, view.viewProj, view.eye, selection, exaggeration);
  gfx::enableMaskWrites(target.framebuffer(), true);
  return overlays.draw(cache, view, layers, settings);
}

/// The same with a technique (technique.hpp) drawing the layers instead of the renderer, as a
/// still (a tiled technique waits for its tiles); the terrain's tiles are not given (no
/// technique that needs them is drawn this way). `frameStats`: what the technique did.
inline std::vector<overlay::LayerFrameStats> drawTerrainAndTechnique(
    gfx::StateCache& cache, gfx::RenderTarget& target, terrain::TerrainEngine& engine,
    overlay::OverlayTechnique& technique, const terrain::LodSelection& selection, const overlay::OverlayView& view,
    const std::vector<const overlay::OverlayLayer*>& layers, const overlay::OverlaySettings& settings = {},
    double exaggeration = 1.0, overlay::TechniqueFrameStats* frameStats = nullptr) {
  gfx::enableReversedZ();
  gfx::beginRenderPass(cache, target, {glm::vec4(0.1F, 0.1F, 0.1F, 1.0F), gfx::kReversedZFar, 0});
  gfx::enableMaskWrites(target.framebuffer(), false);
  engine.draw(cache, view.viewProj, view.eye, selection, exaggeration);
  gfx::enableMaskWrites(target.framebuffer(), true);
  overlay::TechniqueFrame frame;
  frame.target = {target.framebuffer(), target.width(), target.height()};
  frame.view = view;
  frame.layers = layers;
  frame.settings = settings;
  frame.waitForTiles = true;
  overlay::TechniqueFrameStats stats;
  technique.draw(cache, frame, stats);
  if (frameStats != nullptr) *frameStats = stats;
  return stats.layers;
}

/// The deferred technique (made for tests: fails the test if it cannot be).
inline std::unique_ptr<overlay::OverlayTechnique> deferredTechnique(const HeightBoundsProvider* bounds = nullptr) {
  const overlay::TechniqueInfo* info = overlay::findTechnique("deferred");
  EXPECT_NE(info, nullptr);
  if (info == nullptr) return nullptr;
  overlay::TechniqueOptions options;
  options.bounds = bounds;
  Result<std::unique_ptr<overlay::OverlayTechnique>> made = info->create(options);
  EXPECT_TRUE(made.ok());
  return made ? std::move(*made) : nullptr;
}

inline double percent(std::size_t part, std::size_t whole) {
  return whole == 0 ? 0.0 : 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

}  // namespace gis::test::overlay_test
