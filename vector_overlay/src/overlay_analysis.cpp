// Layer analysis on the overlay stencil core: where two layers overlap, and where a layer's
// volumes are not closed (after the stencil-volume-intersections article; DESIGN §4 and §6).
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
  AnalysisMarks marks;
  const std::array<const OverlayLayer*, 2> layers{&a, &b};
  const PixelScale scale = beginFrame(cache, view, settings, layers);
  beginMeasure(settings);
  for (int k = 0; k < 2; ++k) {
    const OverlayLayer& layer = k == 0 ? a : b;
    LayerFrameStats& stats = k == 0 ? marks.a : marks.b;
    const Pieces pieces = classify(view, layer, settings, false, stats);
    stats.grouped = true;
    if (pieces.order.empty()) continue;
    marks.rect = unite(marks.rect, rectOf(view, pieces, 0, pieces.order.size()));
    // Groups only where the layer may overlap deeper than the count holds (OverlayLayer::maxOverlap).
    FlagMarkStates states = k == 0 ? kOverlapMarkA : kOverlapMarkB;
    if (!settings.forceGroups && layer.maxOverlap() <= states.countMask) states.groupSize = pieces.order.size();
    const bool inPixels = bindLayer(view, layer, scale);
    markIntoFlag(cache, view, layer, pieces, settings, scale, inPixels, states, stats);
    endLayer(inPixels);
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
  AnalysisMarks marks;
  const std::array<const OverlayLayer*, 1> layers{&layer};
  const PixelScale scale = beginFrame(cache, view, settings, layers);
  // Every face: bottom caps too, and the pieces near the eye clipped and capped.
  const Pieces pieces = classify(view, layer, settings, true, marks.a);
  if (!pieces.order.empty()) {
    marks.rect = rectOf(view, pieces, 0, pieces.order.size());
    beginMeasure(settings);
    const bool inPixels = bindLayer(view, layer, scale);
    cache.apply(kCountFaces);
    multiDraw(cache, pieces.zPass);
    drawClipped(cache, layer, uploadClippedPieces(view, layer, pieces.zFailSlots, settings, scale, true), inPixels);
    endLayer(inPixels);
    endMeasure(settings, marks.gpuMilliseconds, marks.fragments);
  }
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
  LayerFrameStats stats;
  const std::array<const OverlayLayer*, 1> layers{&layer};
  const PixelScale scale = beginFrame(cache, view, settings, layers);
  const Pieces pieces = classify(view, layer, settings, true, stats);
  if (!pieces.order.empty()) {
    const bool inPixels = bindLayer(view, layer, scale);
    cache.apply(kDebugPieces);
    program_.set("u_maskBit", 0.0F);
    program_.set("u_debugColor", zPassColour);
    multiDraw(cache, pieces.zPass);
    program_.set("u_debugColor", zFailColour);
    drawClipped(cache, layer, uploadClippedPieces(view, layer, pieces.zFailSlots, settings, scale), inPixels);
    program_.set("u_debugColor", glm::vec4(0.0F));
    endLayer(inPixels);
  }
  return stats;
}

}  // namespace gis::overlay
