// Layer analysis on the overlay stencil core: where two layers overlap, and where a layer's
// volumes are not closed (after the stencil-volume-intersections article; docs/design.md §4 and §6).
#include <algorithm>

#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::overlay {
namespace {

/// The smallest rectangle holding both (an empty rectangle holds nothing).
glm::vec4 unite(const glm::vec4& a, const glm::vec4& b) {
  const bool emptyA = !(a.z > a.x && a.w > a.y), emptyB = !(b.z > b.x && b.w > b.y);
  if (emptyA) return b;
  if (emptyB) return a;
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.z, b.z), std::max(a.w, b.w)};
}

}  // namespace

AnalysisMarks OverlayRenderer::markOverlap(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& a,
                                           const OverlayLayer& b, const OverlaySettings& settings) {
  const std::array<const OverlayLayer*, 1> chunksA{&a}, chunksB{&b};
  return markOverlap(cache, view, chunksA, chunksB, settings);
}

AnalysisMarks OverlayRenderer::markOverlap(gfx::StateCache& cache, const OverlayView& view,
                                           std::span<const OverlayLayer* const> a,
                                           std::span<const OverlayLayer* const> b, const OverlaySettings& settings) {
  AnalysisMarks marks;
  std::vector<const OverlayLayer*> all(a.begin(), a.end());
  all.insert(all.end(), b.begin(), b.end());
  const PixelScale scale = beginFrame(cache, view, settings, all);
  beginMeasure(settings);
  for (int k = 0; k < 2; ++k) {
    LayerFrameStats& stats = k == 0 ? marks.a : marks.b;
    stats.grouped = true;
    // Each chunk (a layer, or one of its tiles) is marked and collected into the layer's flag.
    for (const OverlayLayer* chunk : k == 0 ? a : b) {
      const OverlayLayer& layer = *chunk;
      const Pieces pieces = classify(view, layer, settings, false, stats);
      if (pieces.order.empty()) continue;
      marks.rect = unite(marks.rect, rectOf(view, pieces, 0, pieces.order.size()));
      // Groups only where the layer may overlap deeper than the count holds (OverlayLayer::maxOverlap).
      FlagMarkStates states = k == 0 ? kOverlapMarkA : kOverlapMarkB;
      if (!settings.forceGroups && layer.maxOverlap() <= states.countMask) states.groupSize = pieces.order.size();
      const bool inPixels = bindLayer(view, layer, scale);
      markIntoFlag(cache, view, layer, pieces, settings, scale, inPixels, states, stats);
      endLayer(inPixels);
    }
  }
  endMeasure(settings, marks.gpuMilliseconds, marks.fragments);
  return marks;
}

void OverlayRenderer::coverOverlap(gfx::StateCache& cache, const AnalysisMarks& marks, OverlapOp op,
                                   const glm::vec4& colour, float maskValue) {
  switch (op) {
    case OverlapOp::And:
      cache.apply(kOverlapAnd);
      break;
    case OverlapOp::Or:
      cache.apply(kOverlapOr);
      break;
    case OverlapOp::Subtract:
      cache.apply(kOverlapSubtract);
      break;
    case OverlapOp::Xor:
      cache.apply(kOverlapXorFirst);
      drawRect(cache, marks.rect, colour, maskValue);
      cache.apply(kOverlapXorLast);
      break;
  }
  drawRect(cache, marks.rect, colour, maskValue);
}

AnalysisMarks OverlayRenderer::countOpenFaces(gfx::StateCache& cache, const OverlayView& view,
                                              const OverlayLayer& layer, const OverlaySettings& settings) {
  const std::array<const OverlayLayer*, 1> chunks{&layer};
  return countOpenFaces(cache, view, chunks, settings);
}

AnalysisMarks OverlayRenderer::countOpenFaces(gfx::StateCache& cache, const OverlayView& view,
                                              std::span<const OverlayLayer* const> chunks,
                                              const OverlaySettings& settings) {
  AnalysisMarks marks;
  const PixelScale scale = beginFrame(cache, view, settings, chunks);
  beginMeasure(settings);
  for (const OverlayLayer* chunk : chunks) {
    const OverlayLayer& layer = *chunk;
    // Every face: bottom caps too, and the pieces near the eye clipped and capped.
    const Pieces pieces = classify(view, layer, settings, true, marks.a);
    if (pieces.order.empty()) continue;
    marks.rect = unite(marks.rect, rectOf(view, pieces, 0, pieces.order.size()));
    const bool inPixels = bindLayer(view, layer, scale);
    cache.apply(kCountFaces);
    multiDraw(cache, pieces.zPass);
    // Pieces near the eye are closed on the clip plane; a layer with nothing left to clip from (a
    // lean tile) leaves them out of the count (marks.uncountedPieces says how many).
    if (!layer.geometry().footprintsReleased()) {
      drawClipped(cache, layer, uploadClippedPieces(view, layer, pieces.zFailSlots, settings, scale, true), inPixels);
    } else {
      marks.uncountedPieces += pieces.zFailSlots.size();
    }
    endLayer(inPixels);
  }
  endMeasure(settings, marks.gpuMilliseconds, marks.fragments);
  return marks;
}

void OverlayRenderer::coverOpenFaces(gfx::StateCache& cache, const AnalysisMarks& marks, const glm::vec4& colour,
                                     float maskValue) {
  cache.apply(kCoverOpenFaces);
  drawRect(cache, marks.rect, colour, maskValue);
}

LayerFrameStats OverlayRenderer::drawPieces(gfx::StateCache& cache, const OverlayView& view, const OverlayLayer& layer,
                                            const glm::vec4& zPassColour, const glm::vec4& zFailColour,
                                            const OverlaySettings& settings) {
  const std::array<const OverlayLayer*, 1> chunks{&layer};
  return drawPieces(cache, view, chunks, zPassColour, zFailColour, settings);
}

LayerFrameStats OverlayRenderer::drawPieces(gfx::StateCache& cache, const OverlayView& view,
                                            std::span<const OverlayLayer* const> chunks, const glm::vec4& zPassColour,
                                            const glm::vec4& zFailColour, const OverlaySettings& settings) {
  LayerFrameStats stats;
  const PixelScale scale = beginFrame(cache, view, settings, chunks);
  for (const OverlayLayer* chunk : chunks) {
    const OverlayLayer& layer = *chunk;
    const Pieces pieces = classify(view, layer, settings, true, stats);
    if (pieces.order.empty()) continue;
    const bool inPixels = bindLayer(view, layer, scale);
    cache.apply(kDebugPieces);
    program_.set("u_maskBit", 0.0F);
    program_.set("u_debugColor", zPassColour);
    multiDraw(cache, pieces.zPass);
    program_.set("u_debugColor", zFailColour);
    std::vector<std::size_t> entries(pieces.zFailSlots.size());
    for (std::size_t k = 0; k < entries.size(); ++k) entries[k] = k;
    drawZFail(cache, view, layer, pieces, entries, kDebugPieces, settings, scale, inPixels);
    program_.set("u_debugColor", glm::vec4(0.0F));
    endLayer(inPixels);
  }
  return stats;
}

}  // namespace gis::overlay
