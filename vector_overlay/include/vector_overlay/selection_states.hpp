#pragma once
// Render states of lasso selection (docs/design.md §6) as named values; a test compares them with the
// seed report's tables (Rainer 2016, Tables 1–3) and with the truth table they must produce.
//
// Our scheme keeps the selection in the stencil's top bit (0x80) and counts the volumes being
// added in the low 7 bits, so a run of volumes under one operator costs one mark draw each and
// a single combine pass for the whole run:
// - Or and Subtract runs of up to 127 volumes: mark with +1 / −1 per face (7-bit wrap), then
//   "count ≠ 0" sets (Or) or clears (Subtract) the selection and zeroes the count;
// - Xor runs of any length: every face behind the terrain flips bit 0 (the parity of the count),
//   then "parity 1" flips the selection and clears the parity;
// - And, one volume at a time: "count = 1" keeps the selection (DECR takes 0x81 to 0x80),
//   anything else clears it; this pass must cover the whole screen;
// - Single: like Or, but clearing the selection outside the volume (whole screen);
// - Invert: flips the selection bit where there is geometry.
// Combine passes are screen rectangles at depth 0 with the depth test LESS: they pass exactly
// where something was drawn (reversed-Z: background keeps the far value 0), and every op on
// background pixels is ZERO, so background is never selected whatever the volumes counted
// there (a dark cap at infinity lies at depth 0 too).
#include <cstddef>
#include <cstdint>

#include "gfx/pipeline_state.hpp"

namespace gis::overlay {

inline constexpr std::uint8_t kSelectedBit = 0x80;
inline constexpr std::uint8_t kSelectionCountMask = 0x7F;
inline constexpr std::size_t kSelectionRunSize = 127;  ///< Or / Subtract volumes per combine pass

namespace selection_detail {

inline constexpr gfx::ColorMask kNoColor{false, false, false, false};

/// z-fail marking of closed volumes: no colour, depth test (reversed-Z GREATER) without writes,
/// depth clamp, both faces in one draw with `backOp` on back faces and `frontOp` on front
/// faces where the depth test fails.
inline constexpr gfx::PipelineState markState(gfx::StencilOp backOp, gfx::StencilOp frontOp, std::uint8_t writeMask) {
  const gfx::StencilFace front{gfx::CompareFunc::Always, 0, 0xFF, writeMask, gfx::StencilOp::Keep, frontOp,
                               gfx::StencilOp::Keep};
  const gfx::StencilFace back{gfx::CompareFunc::Always, 0, 0xFF, writeMask, gfx::StencilOp::Keep, backOp,
                              gfx::StencilOp::Keep};
  return gfx::PipelineState{
      gfx::DepthState{true, false, gfx::CompareFunc::Greater, true}, gfx::StencilState{true, front, back},
      gfx::BlendState{},
      gfx::RasterState{gfx::CullMode::None, true, kNoColor, gfx::PolygonMode::Fill, 0.0F, 0.0F, true}};
}

/// A screen rectangle at depth 0: the depth test LESS passes where geometry was drawn.
inline constexpr gfx::PipelineState screenPass(gfx::StencilFace face, bool colour = false) {
  return gfx::PipelineState{gfx::DepthState{true, false, gfx::CompareFunc::Less, false},
                            gfx::StencilState{true, face, face},
                            colour ? gfx::kBlendPremultipliedOver : gfx::BlendState{},
                            gfx::RasterState{gfx::CullMode::None, true, colour ? gfx::ColorMask{} : kNoColor,
                                             gfx::PolygonMode::Fill, 0.0F, 0.0F, false}};
}

inline constexpr gfx::StencilFace combine(gfx::CompareFunc func, std::uint8_t ref, std::uint8_t readMask,
                                          std::uint8_t writeMask, gfx::StencilOp fail, gfx::StencilOp pass) {
  // stencil test fails → fail; background (depth test fails) → ZERO; geometry → pass
  return gfx::StencilFace{func, ref, readMask, writeMask, fail, gfx::StencilOp::Zero, pass};
}

}  // namespace selection_detail

/// Mark a volume into the 7-bit count: back faces +1, front faces −1 where hidden (z-fail).
inline constexpr gfx::PipelineState kSelectMarkCount =
    selection_detail::markState(gfx::StencilOp::IncrWrap, gfx::StencilOp::DecrWrap, kSelectionCountMask);
/// Mark a volume into the parity bit 0: every hidden face flips it.
inline constexpr gfx::PipelineState kSelectMarkParity =
    selection_detail::markState(gfx::StencilOp::Invert, gfx::StencilOp::Invert, 0x01);

// Single and Or test the count against ref & 0x7F = 0 and REPLACE writes the ref itself, 0x80.
/// Single: selected = (count ≠ 0), whole screen.
inline constexpr gfx::PipelineState kSelectCombineSingle = selection_detail::screenPass(
    selection_detail::combine(gfx::CompareFunc::NotEqual, kSelectedBit, kSelectionCountMask, 0xFF, gfx::StencilOp::Zero,
                              gfx::StencilOp::Replace));
/// Or: count ≠ 0 → 0x80, else unchanged.
inline constexpr gfx::PipelineState kSelectCombineOr = selection_detail::screenPass(
    selection_detail::combine(gfx::CompareFunc::NotEqual, kSelectedBit, kSelectionCountMask, 0xFF, gfx::StencilOp::Keep,
                              gfx::StencilOp::Replace));
/// And: count = 1 → DECR (0x81 → 0x80, 0x01 → 0x00), else 0; whole screen.
inline constexpr gfx::PipelineState kSelectCombineAnd = selection_detail::screenPass(selection_detail::combine(
    gfx::CompareFunc::Equal, 1, kSelectionCountMask, 0xFF, gfx::StencilOp::Zero, gfx::StencilOp::Decr));
/// Subtract: count ≠ 0 → 0, else unchanged.
inline constexpr gfx::PipelineState kSelectCombineSubtract = selection_detail::screenPass(selection_detail::combine(
    gfx::CompareFunc::NotEqual, 0, kSelectionCountMask, 0xFF, gfx::StencilOp::Keep, gfx::StencilOp::Zero));
/// Xor: parity 1 → flip bits 7 and 0 (selection flipped, parity cleared), else unchanged.
inline constexpr gfx::PipelineState kSelectCombineXor = selection_detail::screenPass(selection_detail::combine(
    gfx::CompareFunc::NotEqual, 0, 0x01, kSelectedBit | 0x01, gfx::StencilOp::Keep, gfx::StencilOp::Invert));
/// Invert: flip the selection bit where there is geometry.
inline constexpr gfx::PipelineState kSelectInvert =
    selection_detail::screenPass(gfx::StencilFace{gfx::CompareFunc::Always, 0, 0xFF, kSelectedBit, gfx::StencilOp::Keep,
                                                  gfx::StencilOp::Keep, gfx::StencilOp::Invert});
/// Highlight: colour selected pixels (premultiplied blend); zero the stencil everywhere.
inline constexpr gfx::PipelineState kSelectHighlight =
    selection_detail::screenPass(gfx::StencilFace{gfx::CompareFunc::Equal, kSelectedBit, kSelectedBit, 0xFF,
                                                  gfx::StencilOp::Zero, gfx::StencilOp::Zero, gfx::StencilOp::Zero},
                                 true);
/// Clear: zero the stencil everywhere, no colour (also where nothing was drawn).
inline constexpr gfx::PipelineState kSelectClear = [] {
  gfx::PipelineState s = selection_detail::screenPass(gfx::StencilFace{
      gfx::CompareFunc::Always, 0, 0xFF, 0xFF, gfx::StencilOp::Zero, gfx::StencilOp::Zero, gfx::StencilOp::Zero});
  s.depth.test = false;
  return s;
}();

/// "Show volumes": the volumes' faces in front of the terrain, blended, both sides, no stencil.
inline constexpr gfx::PipelineState kSelectShowVolumes{
    gfx::DepthState{true, false, gfx::CompareFunc::Greater, true}, gfx::StencilState{}, gfx::kBlendPremultipliedOver,
    gfx::RasterState{gfx::CullMode::None, true, gfx::ColorMask{}, gfx::PolygonMode::Fill, 0.0F, 0.0F, true}};

// The seed report's scheme (Rainer 2016 §2.3–2.5), kept to compare with: every volume marked
// with +1 inside (−1 for Subtract) on the whole 8-bit value, then one reduction pass per volume
// with Table 3's test (the reference compared against the stencil value, mask 0xFF) and
// stencil-fail op; the other ops keep. The report draws the volume's front faces for the
// reduction; we draw the whole screen, because And must also clear selected pixels that the new
// volume does not cover (the report's front faces miss them). Selected pixels hold 1.
namespace report_detail {
inline constexpr gfx::PipelineState reduce(gfx::CompareFunc func, std::uint8_t ref, gfx::StencilOp fail) {
  gfx::PipelineState s = selection_detail::screenPass(
      gfx::StencilFace{func, ref, 0xFF, 0xFF, fail, gfx::StencilOp::Keep, gfx::StencilOp::Keep});
  s.depth.test = false;  // "without depth test"
  return s;
}
}  // namespace report_detail

/// §2.3: back faces INCR_WRAP, front faces DECR_WRAP where the depth test fails.
inline constexpr gfx::PipelineState kReportMarkAdd =
    selection_detail::markState(gfx::StencilOp::IncrWrap, gfx::StencilOp::DecrWrap, 0xFF);
/// §2.4: Subtract flips the operations (a negative volume).
inline constexpr gfx::PipelineState kReportMarkSubtract =
    selection_detail::markState(gfx::StencilOp::DecrWrap, gfx::StencilOp::IncrWrap, 0xFF);
/// Table 3 (stencil function, reference, stencil-fail operation).
inline constexpr gfx::PipelineState kReportReduceOr =
    report_detail::reduce(gfx::CompareFunc::Greater, 1, gfx::StencilOp::Replace);
inline constexpr gfx::PipelineState kReportReduceAnd =
    report_detail::reduce(gfx::CompareFunc::Greater, 1, gfx::StencilOp::Decr);
inline constexpr gfx::PipelineState kReportReduceXor =
    report_detail::reduce(gfx::CompareFunc::Greater, 2, gfx::StencilOp::Zero);
inline constexpr gfx::PipelineState kReportReduceSubtract =
    report_detail::reduce(gfx::CompareFunc::Equal, 1, gfx::StencilOp::Zero);
/// §2.5, first pass: +1 where there is geometry (the report increments where a far-plane quad
/// fails the depth test; with reversed-Z the quad at depth 0 passes LESS there instead). The
/// second pass is kReportReduceXor.
inline constexpr gfx::PipelineState kReportInvertIncrement = selection_detail::screenPass(gfx::StencilFace{
    gfx::CompareFunc::Always, 0, 0xFF, 0xFF, gfx::StencilOp::Keep, gfx::StencilOp::Keep, gfx::StencilOp::Incr});
/// §2.6: colour the pixels whose value is 1 (where there is geometry); zero the stencil.
inline constexpr gfx::PipelineState kReportHighlight = [] {
  gfx::PipelineState s =
      selection_detail::screenPass(gfx::StencilFace{gfx::CompareFunc::Equal, 1, 0xFF, 0xFF, gfx::StencilOp::Zero,
                                                    gfx::StencilOp::Zero, gfx::StencilOp::Zero},
                                   true);
  return s;
}();

}  // namespace gis::overlay
