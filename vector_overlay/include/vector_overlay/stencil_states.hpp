#pragma once
// The render states of the overlay passes (DESIGN §4) as named values. A test compares them with
// the tables of the seed papers (Dai 2008 §3.2–3.3 and DESIGN §4); the renderer uses nothing
// else. Reversed-Z: a fragment "passes the depth test" when it is nearer than the terrain
// (GREATER).
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

}  // namespace gis::overlay
