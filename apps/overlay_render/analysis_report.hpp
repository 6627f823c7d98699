#pragma once
// What overlay_render reports of a layer-overlap analysis and of open volumes, in either frame:
// the GPU's flags against the CPU reference's bits on the same depth.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/frame_readback.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::app {

using overlay::overlapOpName;

struct OverlapCounts {
  std::vector<std::uint8_t> pixels;  ///< 255 where the GPU's answer holds (overlap.png)
  std::size_t inA = 0, inB = 0, both = 0, selected = 0, differing = 0, differingAwayFromEdges = 0;
};

/// `flags`: the stencil after marking (kOverlapFlagA/B); `expected`: the reference's bits (1: in A,
/// 2: in B); `edges`: 1 where the reference may differ within a pixel.
inline OverlapCounts countOverlap(const std::vector<std::uint8_t>& flags, const std::vector<std::uint32_t>& expected,
                                  const std::vector<std::uint8_t>& edges, overlay::OverlapOp op) {
  OverlapCounts c;
  c.pixels.assign(flags.size(), 0);
  for (std::size_t i = 0; i < flags.size() && i < expected.size(); ++i) {
    const bool a = (flags[i] & overlay::kOverlapFlagA) != 0, b = (flags[i] & overlay::kOverlapFlagB) != 0;
    c.inA += a ? 1U : 0U;
    c.inB += b ? 1U : 0U;
    c.both += a && b ? 1U : 0U;
    const bool gpu = overlay::overlapHolds(op, a, b),
               cpu = overlay::overlapHolds(op, (expected[i] & 1U) != 0, (expected[i] & 2U) != 0);
    c.pixels[i] = gpu ? 255 : 0;
    c.selected += gpu ? 1U : 0U;
    c.differing += gpu != cpu ? 1U : 0U;
    c.differingAwayFromEdges += gpu != cpu && i < edges.size() && edges[i] == 0 ? 1U : 0U;
  }
  return c;
}

/// stats.json's "overlap" block: the counts, the layers' names, the operator and the marking.
inline nlohmann::json overlapJson(const OverlapCounts& c, const std::string& nameA, const std::string& nameB,
                                  overlay::OverlapOp op, const overlay::AnalysisMarks& marks) {
  const overlay::LayerFrameStats &a = marks.a, &b = marks.b;
  return {{"pixels", c.selected},
          {"a_pixels", c.inA},
          {"b_pixels", c.inB},
          {"both_pixels", c.both},
          {"pixels_differing_from_cpu_reference", c.differing},
          {"differing_away_from_edges", c.differingAwayFromEdges},
          {"layers", {nameA, nameB}},
          {"op", overlapOpName(op)},
          {"groups", a.groups + b.groups},
          {"pieces", a.zPassPieces + a.zFailPieces + b.zPassPieces + b.zFailPieces},
          {"gpu_ms", marks.gpuMilliseconds},
          {"fragments", marks.fragments}};
}

/// stats.json's "open_volumes" block.
inline nlohmann::json openVolumesJson(const scene::OpenVolumePixels& open) {
  nlohmann::json layers = nlohmann::json::array();
  for (const scene::OpenVolumeLayer& layer : open.layers) {
    const overlay::LayerFrameStats& s = layer.marks.a;
    layers.push_back({{"name", layer.name},
                      {"open_pixels", layer.openPixels},
                      {"pieces_counted", s.zPassPieces + s.zFailPieces - layer.marks.uncountedPieces},
                      {"pieces_clipped_and_capped", s.zFailPieces - layer.marks.uncountedPieces},
                      {"pieces_left_out_near_the_eye", layer.marks.uncountedPieces},
                      {"gpu_ms", layer.marks.gpuMilliseconds},
                      {"fragments", layer.marks.fragments}});
  }
  return {{"open_pixels", open.openPixels}, {"layers", layers}};
}

}  // namespace gis::app
