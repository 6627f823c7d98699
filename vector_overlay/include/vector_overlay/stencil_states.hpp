#pragma once
// The render states of the overlay passes (docs/design.md §4) as named values. A test compares them with
// the tables of the seed papers (Dai 2008 §3.2–3.3 and docs/design.md §4); the renderer uses nothing
// else. Reversed-Z: a fragment "passes the depth test" when it is nearer than the terrain
// (GREATER).
#include <cstddef>
#include <cstdint>

#include "gfx/pipeline_state.hpp"

namespace gis::overlay {

namespace detail {

inline constexpr gfx::ColorMask kNoColor{false, false, false, false};

inline constexpr gfx::StencilFace stencilFace(gfx::CompareFunc func, gfx::StencilOp depthFail, gfx::StencilOp depthPass,
                                              std::uint8_t ref = 0, std::uint8_t readMask = 0xFF,
                                              std::uint8_t writeMask = 0xFF) {
  return gfx::StencilFace{func, ref, readMask, writeMask, gfx::StencilOp::Keep, depthFail, depthPass};
}

/// Mark passes: no colour, no depth write, depth test on, depth clamp on, both faces in one draw.
inline constexpr gfx::PipelineState markState(gfx::StencilFace front, gfx::StencilFace back) {
  return gfx::PipelineState{
      gfx::DepthState{true, false, gfx::CompareFunc::Greater, true}, gfx::StencilState{true, front, back},
      gfx::BlendState{},
      gfx::RasterState{gfx::CullMode::None, true, kNoColor, gfx::PolygonMode::Fill, 0.0F, 0.0F, true}};
}

/// Cover passes: one face set, stencil NOTEQUAL 0, zero where colour is written, premultiplied
/// alpha, no depth test (the stencil says where), depth clamp on.
inline constexpr gfx::PipelineState coverState(gfx::CullMode cull) {
  const gfx::StencilFace face = stencilFace(gfx::CompareFunc::NotEqual, gfx::StencilOp::Zero, gfx::StencilOp::Zero);
  return gfx::PipelineState{gfx::DepthState{false, false, gfx::CompareFunc::Greater, true},
                            gfx::StencilState{true, face, face}, gfx::kBlendPremultipliedOver,
                            gfx::RasterState{cull, true, gfx::ColorMask{}, gfx::PolygonMode::Fill, 0.0F, 0.0F, true}};
}

}  // namespace detail

/// z-pass (the eye outside the polyhedron): front faces +1, back faces −1 where the depth test
/// passes; wrapping, so the order of faces does not matter.
inline constexpr gfx::PipelineState kMarkZPass =
    detail::markState(detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::Keep, gfx::StencilOp::IncrWrap),
                      detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::Keep, gfx::StencilOp::DecrWrap));

/// z-fail (the eye inside, or possibly inside): back faces +1, front faces −1 where the depth
/// test fails; every face, caps included.
inline constexpr gfx::PipelineState kMarkZFail =
    detail::markState(detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::DecrWrap, gfx::StencilOp::Keep),
                      detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::IncrWrap, gfx::StencilOp::Keep));

/// Cover of z-pass polyhedra: their front faces cover every pixel they marked.
inline constexpr gfx::PipelineState kCoverZPass = detail::coverState(gfx::CullMode::Back);
/// Cover of z-fail polyhedra: their back faces (the eye is inside: they surround it).
inline constexpr gfx::PipelineState kCoverZFail = detail::coverState(gfx::CullMode::Front);
/// The same cover drawn as one screen rectangle over the layer's pieces (layers of one colour).
inline constexpr gfx::PipelineState kCoverRect = detail::coverState(gfx::CullMode::None);

// The seed paper's variant (Dai 2008 §3.2–3.3): saturating INCR/DECR in two culled draws (back
// faces first in z-fail, then front faces), and the bounding box of each polyhedron as the cover
// (front faces with the depth test in z-pass, back faces without it in z-fail). Kept for the
// benchmark; we zero the stencil in the cover as well, so layers need no clear between them.
inline constexpr gfx::PipelineState paperMark(bool zFail, bool backFaces) {
  const gfx::StencilOp op = zFail == backFaces ? gfx::StencilOp::Incr : gfx::StencilOp::Decr;
  const gfx::StencilFace face = zFail ? detail::stencilFace(gfx::CompareFunc::Always, op, gfx::StencilOp::Keep)
                                      : detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::Keep, op);
  gfx::PipelineState s = detail::markState(face, face);
  s.raster.cull = backFaces ? gfx::CullMode::Front : gfx::CullMode::Back;
  return s;
}
inline constexpr gfx::PipelineState kPaperMarkZPassFront = paperMark(false, false);
inline constexpr gfx::PipelineState kPaperMarkZPassBack = paperMark(false, true);
inline constexpr gfx::PipelineState kPaperMarkZFailBack = paperMark(true, true);
inline constexpr gfx::PipelineState kPaperMarkZFailFront = paperMark(true, false);

inline constexpr gfx::PipelineState paperCover(bool zFail) {
  gfx::PipelineState s = detail::coverState(zFail ? gfx::CullMode::Front : gfx::CullMode::Back);
  s.depth.test = !zFail;  // z-pass: the box's front faces lie in front of the marked terrain
  // Another feature's box behind the terrain fails the depth test there: it must keep the mark
  // for the box that covers it (zeroing on depth fail lost those pixels).
  if (!zFail) {
    s.stencil.front.depthFail = gfx::StencilOp::Keep;
    s.stencil.back.depthFail = gfx::StencilOp::Keep;
  }
  return s;
}
inline constexpr gfx::PipelineState kPaperCoverZPass = paperCover(false);
inline constexpr gfx::PipelineState kPaperCoverZFail = paperCover(true);

// More than 255 pieces of one layer over a pixel would wrap the 8-bit count to zero. Layers
// that may overlap that deeply (OverlayLayer::maxOverlap) are drawn in groups of at most 127
// pieces: the count lives in the low 7 bits (mark with write mask 0x7F: wrapping mod 128), a
// collect pass after each group turns every non-zero count into the flag 0x80 (count zeroed),
// and one cover pass at the end colours the flagged pixels once and clears them.
inline constexpr std::uint8_t kGroupFlag = 0x80;
inline constexpr std::uint8_t kGroupCountMask = 0x7F;
inline constexpr std::size_t kGroupSize = 127;

inline constexpr gfx::PipelineState groupedMark(gfx::PipelineState s, std::uint8_t countMask = kGroupCountMask) {
  s.stencil.front.writeMask = countMask;
  s.stencil.back.writeMask = countMask;
  return s;
}
inline constexpr gfx::PipelineState kMarkZPassGrouped = groupedMark(kMarkZPass);
inline constexpr gfx::PipelineState kMarkZFailGrouped = groupedMark(kMarkZFail);

/// (count ≠ 0) → flag, count zeroed; other bits kept.
inline constexpr gfx::PipelineState collectState(gfx::CullMode cull, std::uint8_t flag = kGroupFlag,
                                                 std::uint8_t countMask = kGroupCountMask) {
  const gfx::StencilFace face =
      detail::stencilFace(gfx::CompareFunc::NotEqual, gfx::StencilOp::Replace, gfx::StencilOp::Replace, flag, countMask,
                          static_cast<std::uint8_t>(flag | countMask));
  gfx::PipelineState s = detail::coverState(cull);
  s.stencil = gfx::StencilState{true, face, face};
  s.blend = gfx::BlendState{};
  s.raster.colorMask = detail::kNoColor;
  return s;
}
/// After a group: (count ≠ 0) → 0x80. Front faces of z-pass pieces, back faces of z-fail ones.
inline constexpr gfx::PipelineState kCollectZPass = collectState(gfx::CullMode::Back);
inline constexpr gfx::PipelineState kCollectZFail = collectState(gfx::CullMode::Front);
inline constexpr gfx::PipelineState kCollectRect = collectState(gfx::CullMode::None);

/// The three states that mark a layer into a stencil flag, group by group.
struct FlagMarkStates {
  gfx::PipelineState markZPass, markZFail, collect;
  std::uint8_t flag, countMask;
  std::size_t groupSize;
};
inline constexpr FlagMarkStates flagMarkStates(std::uint8_t flag, std::uint8_t countMask) {
  return {groupedMark(kMarkZPass, countMask),
          groupedMark(kMarkZFail, countMask),
          collectState(gfx::CullMode::None, flag, countMask),
          flag,
          countMask,
          countMask};
}
inline constexpr FlagMarkStates kGroupedMark = flagMarkStates(kGroupFlag, kGroupCountMask);

inline constexpr gfx::PipelineState flaggedCover(gfx::CullMode cull) {
  const gfx::StencilFace face = detail::stencilFace(gfx::CompareFunc::Equal, gfx::StencilOp::Zero, gfx::StencilOp::Zero,
                                                    kGroupFlag, kGroupFlag, 0xFF);
  gfx::PipelineState s = detail::coverState(cull);
  s.stencil = gfx::StencilState{true, face, face};
  return s;
}
/// The final cover of a grouped layer: where the flag is set, colour once and zero.
inline constexpr gfx::PipelineState kCoverFlaggedZPass = flaggedCover(gfx::CullMode::Back);
inline constexpr gfx::PipelineState kCoverFlaggedZFail = flaggedCover(gfx::CullMode::Front);
inline constexpr gfx::PipelineState kCoverFlaggedRect = flaggedCover(gfx::CullMode::None);

}  // namespace gis::overlay

namespace gis::overlay {

// Layer overlap analysis (after the stencil-volume-intersections article; docs/design.md §4 states
// reused): layer A is marked into bit 0x80 and layer B into bit 0x40, each in groups of at most
// 63 pieces counted in the low six bits (wrapping mod 64) and collected into its flag after
// every group, so neither the depth of overlap nor the other layer's flag disturbs a count. A
// cover then tests the two flags (read mask 0xC0) against the operator's values.
inline constexpr std::uint8_t kOverlapFlagA = 0x80;
inline constexpr std::uint8_t kOverlapFlagB = 0x40;
inline constexpr std::uint8_t kOverlapFlags = kOverlapFlagA | kOverlapFlagB;
inline constexpr std::uint8_t kOverlapCountMask = 0x3F;
inline constexpr FlagMarkStates kOverlapMarkA = flagMarkStates(kOverlapFlagA, kOverlapCountMask);
inline constexpr FlagMarkStates kOverlapMarkB = flagMarkStates(kOverlapFlagB, kOverlapCountMask);

/// Colours where (stencil & 0xC0) compares to `value` by `func` and zeroes the stencil there;
/// with `last`, zeroes it everywhere else in the rectangle too (the final pass of a cover).
inline constexpr gfx::PipelineState overlapCover(gfx::CompareFunc func, std::uint8_t value, bool last) {
  const gfx::StencilFace face{func,
                              value,
                              kOverlapFlags,
                              0xFF,
                              last ? gfx::StencilOp::Zero : gfx::StencilOp::Keep,
                              gfx::StencilOp::Zero,
                              gfx::StencilOp::Zero};
  gfx::PipelineState s = detail::coverState(gfx::CullMode::None);
  s.stencil = gfx::StencilState{true, face, face};
  return s;
}
/// And: both flags. Or: either. Subtract: A only. Xor: A only, then B only (two passes).
inline constexpr gfx::PipelineState kOverlapAnd = overlapCover(gfx::CompareFunc::Equal, kOverlapFlags, true);
inline constexpr gfx::PipelineState kOverlapOr = overlapCover(gfx::CompareFunc::NotEqual, 0, true);
inline constexpr gfx::PipelineState kOverlapSubtract = overlapCover(gfx::CompareFunc::Equal, kOverlapFlagA, true);
inline constexpr gfx::PipelineState kOverlapXorFirst = overlapCover(gfx::CompareFunc::Equal, kOverlapFlagA, false);
inline constexpr gfx::PipelineState kOverlapXorLast = overlapCover(gfx::CompareFunc::Equal, kOverlapFlagB, true);

// Open volumes (the article's "back faces visible", made exact): every face counted with no
// depth test, front faces +1 and back faces −1, wrapping. Along a ray from outside, a closed
// volume is entered as often as it is left: 0. The cover is kCoverRect (NOTEQUAL 0, zero).
inline constexpr gfx::PipelineState kCountFaces = [] {
  gfx::PipelineState s =
      detail::markState(detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::Keep, gfx::StencilOp::IncrWrap),
                        detail::stencilFace(gfx::CompareFunc::Always, gfx::StencilOp::Keep, gfx::StencilOp::DecrWrap));
  s.depth.test = false;
  return s;
}();
inline constexpr gfx::PipelineState kCoverOpenFaces = kCoverRect;

/// The debug view of the pieces (OverlayRenderer::drawPieces): their front faces where they are
/// nearer than the terrain, blended; no stencil, no depth write.
inline constexpr gfx::PipelineState kDebugPieces = [] {
  gfx::PipelineState s = detail::coverState(gfx::CullMode::Back);
  s.depth.test = true;
  s.stencil = gfx::StencilState{};
  return s;
}();

}  // namespace gis::overlay
