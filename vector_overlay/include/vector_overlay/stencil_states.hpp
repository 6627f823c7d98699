#pragma once
// The render states of the overlay passes (DESIGN §4) as named values. A test compares them with
// the tables of the seed papers (Dai 2008 §3.2–3.3 and DESIGN §4); the renderer uses nothing
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

inline constexpr gfx::PipelineState groupedMark(gfx::PipelineState s) {
  s.stencil.front.writeMask = kGroupCountMask;
  s.stencil.back.writeMask = kGroupCountMask;
  return s;
}
inline constexpr gfx::PipelineState kMarkZPassGrouped = groupedMark(kMarkZPass);
inline constexpr gfx::PipelineState kMarkZFailGrouped = groupedMark(kMarkZFail);

inline constexpr gfx::PipelineState collectState(gfx::CullMode cull) {
  const gfx::StencilFace face = detail::stencilFace(gfx::CompareFunc::NotEqual, gfx::StencilOp::Replace,
                                                    gfx::StencilOp::Replace, kGroupFlag, kGroupCountMask, 0xFF);
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
