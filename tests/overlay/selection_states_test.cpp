// Lasso selection states (vector_overlay/selection_states.hpp) against the seed report (Rainer
// 2016): §2.3's z-fail marking, Table 3's reduction states row by row, and both schemes run on a
// software stencil (GL's test and op rules) for random chains, against Table 1's truth table.
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_states.hpp"

namespace gis::test {
namespace {

using gfx::CompareFunc;
using gfx::StencilOp;

// ---- a software stencil: one pixel ----

bool compare(CompareFunc f, std::uint8_t ref, std::uint8_t value) {  // GL: (ref & mask) f (value & mask)
  switch (f) {
    case CompareFunc::Never:
      return false;
    case CompareFunc::Less:
      return ref < value;
    case CompareFunc::LessEqual:
      return ref <= value;
    case CompareFunc::Equal:
      return ref == value;
    case CompareFunc::NotEqual:
      return ref != value;
    case CompareFunc::GreaterEqual:
      return ref >= value;
    case CompareFunc::Greater:
      return ref > value;
    case CompareFunc::Always:
      return true;
  }
  return false;
}

std::uint8_t apply(StencilOp op, std::uint8_t v, std::uint8_t ref) {
  switch (op) {
    case StencilOp::Keep:
      return v;
    case StencilOp::Zero:
      return 0;
    case StencilOp::Replace:
      return ref;
    case StencilOp::Incr:
      return v == 255 ? v : static_cast<std::uint8_t>(v + 1);
    case StencilOp::IncrWrap:
      return static_cast<std::uint8_t>(v + 1);
    case StencilOp::Decr:
      return v == 0 ? v : static_cast<std::uint8_t>(v - 1);
    case StencilOp::DecrWrap:
      return static_cast<std::uint8_t>(v - 1);
    case StencilOp::Invert:
      return static_cast<std::uint8_t>(~v);
  }
  return v;
}

/// One fragment of `face` on a pixel holding `v`; depthPasses: the fragment's depth test.
std::uint8_t fragment(const gfx::StencilFace& face, std::uint8_t v, bool depthPasses) {
  StencilOp op = face.depthPass;
  if (!compare(face.func, face.ref & face.readMask, v & face.readMask)) {
    op = face.stencilFail;
  } else if (!depthPasses) {
    op = face.depthFail;
  }
  const std::uint8_t w = apply(op, v, face.ref);
  return static_cast<std::uint8_t>((v & ~face.writeMask) | (w & face.writeMask));
}

/// A screen pass (quad at depth 0, depth test LESS unless off) over a pixel with or without
/// geometry.
std::uint8_t screen(const gfx::PipelineState& s, std::uint8_t v, bool geometry) {
  return fragment(s.stencil.front, v, !s.depth.test || geometry);
}

/// Marking a volume that holds the pixel's point (inside) or not, z-fail: hidden faces behind
/// the point. Extra hidden front/back pairs (volume parts behind the point) must cancel.
std::uint8_t mark(const gfx::PipelineState& s, std::uint8_t v, bool inside, int pairs) {
  for (int k = 0; k < pairs; ++k) {
    v = fragment(s.stencil.back, v, false);
    v = fragment(s.stencil.front, v, false);
  }
  if (inside) v = fragment(s.stencil.back, v, false);
  return v;
}

TEST(SelectionStates, ReportMarkingIsDepthFail) {
  // §2.3: back faces INCR_WRAP, front faces DECR_WRAP where the depth test fails; Subtract flips.
  EXPECT_EQ(overlay::kReportMarkAdd.stencil.back.depthFail, StencilOp::IncrWrap);
  EXPECT_EQ(overlay::kReportMarkAdd.stencil.front.depthFail, StencilOp::DecrWrap);
  EXPECT_EQ(overlay::kReportMarkSubtract.stencil.back.depthFail, StencilOp::DecrWrap);
  EXPECT_EQ(overlay::kReportMarkSubtract.stencil.front.depthFail, StencilOp::IncrWrap);
  for (const auto* s : {&overlay::kReportMarkAdd, &overlay::kReportMarkSubtract, &overlay::kSelectMarkCount,
                        &overlay::kSelectMarkParity}) {
    EXPECT_EQ(s->stencil.front.func, CompareFunc::Always);
    EXPECT_EQ(s->stencil.front.depthPass, StencilOp::Keep);
    EXPECT_EQ(s->raster.cull, gfx::CullMode::None);  // both faces in one draw
    EXPECT_TRUE(s->depth.test);
    EXPECT_FALSE(s->depth.write);
    EXPECT_TRUE(s->depth.clamp);
    EXPECT_EQ(s->raster.colorMask, (gfx::ColorMask{false, false, false, false}));
  }
}

TEST(SelectionStates, ReportTable3) {
  struct Row {
    const char* op;
    const gfx::PipelineState* state;
    CompareFunc func;
    std::uint8_t ref;
    StencilOp fail;
  };
  const Row table[] = {{"OR", &overlay::kReportReduceOr, CompareFunc::Greater, 1, StencilOp::Replace},
                       {"AND", &overlay::kReportReduceAnd, CompareFunc::Greater, 1, StencilOp::Decr},
                       {"XOR", &overlay::kReportReduceXor, CompareFunc::Greater, 2, StencilOp::Zero},
                       {"SUBTRACT", &overlay::kReportReduceSubtract, CompareFunc::Equal, 1, StencilOp::Zero}};
  for (const Row& r : table) {
    for (const gfx::StencilFace& f : {r.state->stencil.front, r.state->stencil.back}) {
      EXPECT_EQ(f.func, r.func) << r.op;
      EXPECT_EQ(f.ref, r.ref) << r.op;
      EXPECT_EQ(f.readMask, 0xFF) << r.op;
      EXPECT_EQ(f.stencilFail, r.fail) << r.op;
      EXPECT_EQ(f.depthFail, StencilOp::Keep) << r.op;
      EXPECT_EQ(f.depthPass, StencilOp::Keep) << r.op;
    }
    EXPECT_FALSE(r.state->depth.test) << r.op;  // "without depth test"
    EXPECT_EQ(r.state->raster.colorMask, (gfx::ColorMask{false, false, false, false}));
  }
  // Table 2's populations reduce to the selected values of Table 1.
  EXPECT_EQ(screen(overlay::kReportReduceOr, 2, true), 1);
  EXPECT_EQ(screen(overlay::kReportReduceAnd, 2, true), 1);
  EXPECT_EQ(screen(overlay::kReportReduceAnd, 1, true), 0);
  EXPECT_EQ(screen(overlay::kReportReduceXor, 2, true), 0);
  EXPECT_EQ(screen(overlay::kReportReduceSubtract, 255, true), 0);  // −1
}

bool truth(overlay::SelectionOp op, bool a, bool b) {
  switch (op) {
    case overlay::SelectionOp::Single:
      return b;
    case overlay::SelectionOp::Or:
      return a || b;
    case overlay::SelectionOp::And:
      return a && b;
    case overlay::SelectionOp::Xor:
      return a != b;
    case overlay::SelectionOp::Subtract:
      return a && !b;
    case overlay::SelectionOp::Invert:
      return !a;
  }
  return a;
}

TEST(SelectionStates, BothSchemesGiveTheTruthTableForRandomChains) {
  using overlay::SelectionOp;
  std::mt19937 rng(9);
  const SelectionOp ops[] = {SelectionOp::Single, SelectionOp::Or,       SelectionOp::And,
                             SelectionOp::Xor,    SelectionOp::Subtract, SelectionOp::Invert};
  for (int trial = 0; trial < 3000; ++trial) {
    const std::size_t n = 1 + rng() % 300;
    const bool geometry = rng() % 8 != 0;
    std::vector<SelectionOp> chain;
    std::vector<bool> inside;
    std::vector<int> pairs;
    for (std::size_t k = 0; k < n; ++k) {
      // long runs of one operator now and then (past the 127-volume run limit)
      chain.push_back(k > 0 && rng() % 4 != 0 ? chain.back() : ops[rng() % (k == 0 ? 5 : 6)]);
      inside.push_back(rng() % 2 == 0);
      pairs.push_back(static_cast<int>(rng() % 3));
    }
    bool expected = false;
    for (std::size_t k = 0; k < n; ++k) expected = truth(chain[k], expected, inside[k]);
    expected = expected && geometry;
    // The report's scheme, step by step.
    std::uint8_t v = 0;
    for (std::size_t k = 0; k < n; ++k) {
      switch (chain[k]) {
        case SelectionOp::Invert:
          v = screen(overlay::kReportReduceXor, screen(overlay::kReportInvertIncrement, v, geometry), geometry);
          break;
        case SelectionOp::Single:
          v = mark(overlay::kReportMarkAdd, screen(overlay::kSelectClear, v, geometry), inside[k], pairs[k]);
          break;
        case SelectionOp::Subtract:
          v = screen(overlay::kReportReduceSubtract, mark(overlay::kReportMarkSubtract, v, inside[k], pairs[k]),
                     geometry);
          break;
        default: {
          const gfx::PipelineState& reduce = chain[k] == SelectionOp::Or    ? overlay::kReportReduceOr
                                             : chain[k] == SelectionOp::And ? overlay::kReportReduceAnd
                                                                            : overlay::kReportReduceXor;
          v = screen(reduce, mark(overlay::kReportMarkAdd, v, inside[k], pairs[k]), geometry);
        }
      }
    }
    ASSERT_EQ(geometry && v == 1, expected) << "report, trial " << trial;
    // Ours: runs as SelectionRenderer forms them.
    v = 0;
    for (std::size_t k = 0; k < n;) {
      const SelectionOp op = chain[k];
      if (op == SelectionOp::Invert) {
        v = screen(overlay::kSelectInvert, v, geometry);
        ++k;
        continue;
      }
      const SelectionOp follower = op == SelectionOp::Single ? SelectionOp::Or : op;
      const std::size_t limit = op == SelectionOp::And ? 1 : (op == SelectionOp::Xor ? n : overlay::kSelectionRunSize);
      std::size_t end = k + 1;
      while (end < n && end - k < limit && chain[end] == follower) ++end;
      for (std::size_t j = k; j < end; ++j) {
        v = mark(op == SelectionOp::Xor ? overlay::kSelectMarkParity : overlay::kSelectMarkCount, v, inside[j],
                 pairs[j]);
      }
      const gfx::PipelineState& combine = op == SelectionOp::Single     ? overlay::kSelectCombineSingle
                                          : op == SelectionOp::Or       ? overlay::kSelectCombineOr
                                          : op == SelectionOp::And      ? overlay::kSelectCombineAnd
                                          : op == SelectionOp::Subtract ? overlay::kSelectCombineSubtract
                                                                        : overlay::kSelectCombineXor;
      v = screen(combine, v, geometry);
      ASSERT_EQ(v & overlay::kSelectionCountMask, 0) << "count left over, trial " << trial;
      k = end;
    }
    ASSERT_EQ((v & overlay::kSelectedBit) != 0, expected) << "ours, trial " << trial;
    if (!geometry) {
      ASSERT_EQ(v, 0);
    }
    ASSERT_EQ(screen(overlay::kSelectHighlight, v, geometry), 0);
  }
}

}  // namespace
}  // namespace gis::test
