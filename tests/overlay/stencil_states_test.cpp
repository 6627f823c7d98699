// The overlay passes' render states against the tables they come from: the seed paper's mask
// creation (Dai 2008 §3.2: z-pass increments front faces and decrements back faces where the
// depth test passes; z-fail increments back faces and decrements front faces where it fails)
// and cover (§3.3: stencil NOTEQUAL 0; front faces in z-pass, back faces in z-fail), with
// docs/design.md §4's changes: wrapping ops in one two-sided draw, depth clamp, zeroing cover ops and
// premultiplied-alpha blending. Each row of the table is written out here and compared with
// the named state the renderer uses.
#include <algorithm>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace gis::test {
namespace {

using gfx::CompareFunc;
using gfx::CullMode;
using gfx::StencilOp;

struct Row {
  const char* pass;
  const gfx::PipelineState* state;
  // What the table says:
  CullMode drawnFaces;  ///< which faces are culled (None = both drawn in one draw)
  StencilOp frontDepthPass, frontDepthFail, backDepthPass, backDepthFail;
  CompareFunc stencilFunc;
  bool colour, depthTest, depthWrite, depthClamp, blend;
};

constexpr StencilOp K = StencilOp::Keep;

const Row kTable[] = {
    // pass            state                    culled           front pass            front fail            back pass
    // back fail             stencil test           colour depthT depthW clamp  blend
    {"mark z-pass", &overlay::kMarkZPass, CullMode::None, StencilOp::IncrWrap, K, StencilOp::DecrWrap, K,
     CompareFunc::Always, false, true, false, true, false},
    {"mark z-fail", &overlay::kMarkZFail, CullMode::None, K, StencilOp::DecrWrap, K, StencilOp::IncrWrap,
     CompareFunc::Always, false, true, false, true, false},
    {"cover z-pass", &overlay::kCoverZPass, CullMode::Back, StencilOp::Zero, StencilOp::Zero, StencilOp::Zero,
     StencilOp::Zero, CompareFunc::NotEqual, true, false, false, true, true},
    {"cover z-fail", &overlay::kCoverZFail, CullMode::Front, StencilOp::Zero, StencilOp::Zero, StencilOp::Zero,
     StencilOp::Zero, CompareFunc::NotEqual, true, false, false, true, true},
    // The paper's variant: saturating ops, one face set per draw.
    {"paper z-pass front", &overlay::kPaperMarkZPassFront, CullMode::Back, StencilOp::Incr, K, StencilOp::Incr, K,
     CompareFunc::Always, false, true, false, true, false},
    {"paper z-pass back", &overlay::kPaperMarkZPassBack, CullMode::Front, StencilOp::Decr, K, StencilOp::Decr, K,
     CompareFunc::Always, false, true, false, true, false},
    {"paper z-fail back", &overlay::kPaperMarkZFailBack, CullMode::Front, K, StencilOp::Incr, K, StencilOp::Incr,
     CompareFunc::Always, false, true, false, true, false},
    {"paper z-fail front", &overlay::kPaperMarkZFailFront, CullMode::Back, K, StencilOp::Decr, K, StencilOp::Decr,
     CompareFunc::Always, false, true, false, true, false},
    // A box behind the terrain fails the depth test: it keeps the mark for the box that covers it.
    {"paper cover z-pass", &overlay::kPaperCoverZPass, CullMode::Back, StencilOp::Zero, K, StencilOp::Zero, K,
     CompareFunc::NotEqual, true, true, false, true, true},
    {"paper cover z-fail", &overlay::kPaperCoverZFail, CullMode::Front, StencilOp::Zero, StencilOp::Zero,
     StencilOp::Zero, StencilOp::Zero, CompareFunc::NotEqual, true, false, false, true, true},
};

// Deep overlaps (more than 255 pieces of a layer at a pixel): marks count in the low 7 bits, a
// collect pass turns a non-zero count into the flag 0x80, the final cover colours flagged pixels.
TEST(StencilStates, GroupedSchemeForDeepOverlaps) {
  for (const gfx::PipelineState* s : {&overlay::kMarkZPassGrouped, &overlay::kMarkZFailGrouped}) {
    EXPECT_EQ(s->stencil.front.writeMask, 0x7F);
    EXPECT_EQ(s->stencil.back.writeMask, 0x7F);
  }
  gfx::PipelineState ungrouped = overlay::kMarkZPassGrouped;
  ungrouped.stencil.front.writeMask = ungrouped.stencil.back.writeMask = 0xFF;
  EXPECT_EQ(ungrouped, overlay::kMarkZPass);
  for (const gfx::PipelineState* s : {&overlay::kCollectZPass, &overlay::kCollectZFail}) {
    EXPECT_EQ(s->stencil.front.func, CompareFunc::NotEqual);
    EXPECT_EQ(s->stencil.front.readMask, 0x7F);  // count ≠ 0
    EXPECT_EQ(s->stencil.front.ref, 0x80);
    EXPECT_EQ(s->stencil.front.depthPass, StencilOp::Replace);  // → exactly the flag
    EXPECT_EQ(s->stencil.front.depthFail, StencilOp::Replace);
    EXPECT_EQ(s->stencil.front.writeMask, 0xFF);
    EXPECT_FALSE(s->raster.colorMask.r || s->raster.colorMask.a);
    EXPECT_FALSE(s->depth.test);
  }
  EXPECT_EQ(overlay::kCollectZPass.raster.cull, CullMode::Back);
  EXPECT_EQ(overlay::kCollectZFail.raster.cull, CullMode::Front);
  for (const gfx::PipelineState* s : {&overlay::kCoverFlaggedZPass, &overlay::kCoverFlaggedZFail}) {
    EXPECT_EQ(s->stencil.front.func, CompareFunc::Equal);
    EXPECT_EQ(s->stencil.front.readMask, 0x80);
    EXPECT_EQ(s->stencil.front.ref, 0x80);
    EXPECT_EQ(s->stencil.front.depthPass, StencilOp::Zero);
    EXPECT_EQ(s->blend, gfx::kBlendPremultipliedOver);
  }
  // Modular arithmetic in 7 bits under the write mask: 0x80 + 1 → 0x81, 0x80 − 1 → 0xFF.
  auto masked = [](std::uint8_t old, std::uint8_t computed) {
    return static_cast<std::uint8_t>((old & 0x80) | (computed & 0x7F));
  };
  EXPECT_EQ(masked(0x80, 0x81), 0x81);
  EXPECT_EQ(masked(0x80, 0x7F), 0xFF);
  EXPECT_EQ(masked(0xFF, 0x00), 0x80);  // 127 + 1 wraps to 0, the flag stays
}

TEST(StencilStates, MatchTheTables) {
  for (const Row& row : kTable) {
    SCOPED_TRACE(row.pass);
    const gfx::PipelineState& s = *row.state;
    EXPECT_EQ(s.raster.cull, row.drawnFaces);
    EXPECT_TRUE(s.stencil.test);
    EXPECT_EQ(s.stencil.front.depthPass, row.frontDepthPass);
    EXPECT_EQ(s.stencil.front.depthFail, row.frontDepthFail);
    EXPECT_EQ(s.stencil.back.depthPass, row.backDepthPass);
    EXPECT_EQ(s.stencil.back.depthFail, row.backDepthFail);
    EXPECT_EQ(s.stencil.front.stencilFail, K);
    EXPECT_EQ(s.stencil.back.stencilFail, K);
    EXPECT_EQ(s.stencil.front.func, row.stencilFunc);
    EXPECT_EQ(s.stencil.back.func, row.stencilFunc);
    EXPECT_EQ(s.stencil.front.ref, 0);
    EXPECT_EQ(s.stencil.front.readMask, 0xFF);
    EXPECT_EQ(s.stencil.front.writeMask, 0xFF);
    const bool colour = s.raster.colorMask.r || s.raster.colorMask.g || s.raster.colorMask.b || s.raster.colorMask.a;
    EXPECT_EQ(colour, row.colour);
    EXPECT_EQ(s.depth.test, row.depthTest);
    if (s.depth.test) {
      EXPECT_EQ(s.depth.func, CompareFunc::Greater) << "reversed-Z: nearer passes";
    }
    EXPECT_EQ(s.depth.write, row.depthWrite);
    EXPECT_EQ(s.depth.clamp, row.depthClamp);
    EXPECT_EQ(s.blend.enabled, row.blend);
    if (row.blend) {
      EXPECT_EQ(s.blend, gfx::kBlendPremultipliedOver);
    }
  }
}

// Counting, as the table implies, along one ray: the terrain point is inside k of n closed
// volumes; z-pass counts crossings in front of the point from an eye outside them all, z-fail
// counts crossings behind it. Both give k (mod 256, hence the wrapping ops), whatever the order.
TEST(StencilStates, CountingRulesGiveTheNumberOfVolumesHoldingThePoint) {
  // Volumes along the ray as [enter, exit] distances; the terrain point at distance 10.
  const std::pair<double, double> volumes[] = {{2, 4}, {8, 12}, {9, 30}, {11, 13}, {1, 40}};
  const double point = 10.0;
  int inside = 0, zPass = 0, zFail = 0;
  for (const auto& [enter, exit] : volumes) {
    inside += enter < point && point < exit ? 1 : 0;
    // z-pass: front face (enter) +1, back face (exit) −1 where nearer than the point.
    zPass += (enter < point ? 1 : 0) - (exit < point ? 1 : 0);
    // z-fail: back face (exit) +1, front face (enter) −1 where farther than the point.
    zFail += (exit > point ? 1 : 0) - (enter > point ? 1 : 0);
  }
  EXPECT_EQ(zPass, inside);
  EXPECT_EQ(zFail, inside);
  EXPECT_EQ(inside, 3);
}

/// One stencil update as GL defines it: the test compares (ref & readMask) with (stencil &
/// readMask); the op chosen by the outcome is written under the write mask.
std::uint8_t stencilUpdate(const gfx::StencilFace& f, std::uint8_t s, bool depthPasses) {
  const int ref = f.ref & f.readMask, value = s & f.readMask;
  bool pass = true;
  switch (f.func) {
    case CompareFunc::Never:
      pass = false;
      break;
    case CompareFunc::Less:
      pass = ref < value;
      break;
    case CompareFunc::LessEqual:
      pass = ref <= value;
      break;
    case CompareFunc::Equal:
      pass = ref == value;
      break;
    case CompareFunc::NotEqual:
      pass = ref != value;
      break;
    case CompareFunc::GreaterEqual:
      pass = ref >= value;
      break;
    case CompareFunc::Greater:
      pass = ref > value;
      break;
    case CompareFunc::Always:
      pass = true;
      break;
  }
  const StencilOp op = !pass ? f.stencilFail : (depthPasses ? f.depthPass : f.depthFail);
  int out = s;
  switch (op) {
    case StencilOp::Keep:
      break;
    case StencilOp::Zero:
      out = 0;
      break;
    case StencilOp::Replace:
      out = f.ref;
      break;
    case StencilOp::Incr:
      out = std::min(s + 1, 255);
      break;
    case StencilOp::IncrWrap:
      out = (s + 1) & 0xFF;
      break;
    case StencilOp::Decr:
      out = std::max(s - 1, 0);
      break;
    case StencilOp::DecrWrap:
      out = (s + 255) & 0xFF;
      break;
    case StencilOp::Invert:
      out = ~s & 0xFF;
      break;
  }
  return static_cast<std::uint8_t>((s & ~f.writeMask) | (out & f.writeMask));
}

// The overlap analysis's states, run on one pixel through the stencil's own arithmetic: layer A
// has nA pieces over the pixel's terrain point and layer B nB (each counts +1, in any order
// with pairs of crossings in front that cancel), marked group by group and collected into the
// flags; then every operator's cover must fire exactly where its truth table says, and leave 0.
TEST(StencilStates, OverlapMarksAndCoversFollowTheTruthTable) {
  EXPECT_EQ(overlay::kOverlapFlagA & overlay::kOverlapFlagB, 0);
  EXPECT_EQ(overlay::kOverlapCountMask & overlay::kOverlapFlags, 0);
  EXPECT_LE(overlay::kOverlapMarkA.groupSize, std::size_t{overlay::kOverlapCountMask});
  EXPECT_EQ(overlay::kOverlapMarkA.markZPass.stencil.front.writeMask, overlay::kOverlapCountMask);
  EXPECT_EQ(overlay::kOverlapMarkA.collect.stencil.front.writeMask,
            overlay::kOverlapFlagA | overlay::kOverlapCountMask);
  EXPECT_EQ(overlay::kOverlapMarkB.collect.stencil.front.writeMask,
            overlay::kOverlapFlagB | overlay::kOverlapCountMask);
  EXPECT_EQ(overlay::kGroupedMark.collect, overlay::kCollectRect);
  EXPECT_EQ(overlay::kGroupedMark.markZFail, overlay::kMarkZFailGrouped);
  // Front faces in front of the point (+1) and, for the crossings that cancel, back faces (−1).
  auto mark = [&](std::uint8_t s, const overlay::FlagMarkStates& states, int pieces, int pairs) {
    int done = 0;
    while (done < pieces || (pieces == 0 && done == 0)) {
      const int group = std::min<int>(pieces - done, static_cast<int>(states.groupSize));
      for (int k = 0; k < group; ++k) s = stencilUpdate(states.markZPass.stencil.front, s, true);
      for (int k = 0; k < pairs; ++k) {
        s = stencilUpdate(states.markZPass.stencil.back, s, true);
        s = stencilUpdate(states.markZPass.stencil.front, s, true);
      }
      s = stencilUpdate(states.collect.stencil.front, s, true);
      done += std::max(group, 1);
    }
    return s;
  };
  struct Op {
    const char* name;
    overlay::OverlapOp op;
    std::vector<const gfx::PipelineState*> passes;
    bool (*truth)(bool, bool);
  };
  const Op ops[] = {
      {"and", overlay::OverlapOp::And, {&overlay::kOverlapAnd}, [](bool a, bool b) { return a && b; }},
      {"or", overlay::OverlapOp::Or, {&overlay::kOverlapOr}, [](bool a, bool b) { return a || b; }},
      {"subtract", overlay::OverlapOp::Subtract, {&overlay::kOverlapSubtract}, [](bool a, bool b) { return a && !b; }},
      {"xor",
       overlay::OverlapOp::Xor,
       {&overlay::kOverlapXorFirst, &overlay::kOverlapXorLast},
       [](bool a, bool b) { return a != b; }},
  };
  for (const Op& op : ops) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(overlay::overlapHolds(op.op, (k & 1) != 0, (k & 2) != 0), op.truth((k & 1) != 0, (k & 2) != 0))
          << op.name;
    }
  }
  for (int nA : {0, 1, 2, 62, 63, 64, 127, 128, 200, 256}) {
    for (int nB : {0, 1, 63, 64, 129}) {
      std::uint8_t s = mark(0, overlay::kOverlapMarkA, nA, 3);
      s = mark(s, overlay::kOverlapMarkB, nB, 2);
      EXPECT_EQ(s & overlay::kOverlapCountMask, 0) << nA << ", " << nB;
      EXPECT_EQ((s & overlay::kOverlapFlagA) != 0, nA > 0) << nA << ", " << nB;
      EXPECT_EQ((s & overlay::kOverlapFlagB) != 0, nB > 0) << nA << ", " << nB;
      for (const Op& op : ops) {
        std::uint8_t t = s;
        bool coloured = false;
        for (const gfx::PipelineState* pass : op.passes) {
          const gfx::StencilFace& f = pass->stencil.front;
          EXPECT_EQ(f.readMask, overlay::kOverlapFlags);
          // The cover colours where the stencil test passes (no depth test).
          const int ref = f.ref & f.readMask, value = t & f.readMask;
          const bool passes = f.func == CompareFunc::Equal ? ref == value : ref != value;
          ASSERT_TRUE(f.func == CompareFunc::Equal || f.func == CompareFunc::NotEqual);
          coloured = coloured || passes;
          t = stencilUpdate(f, t, true);
          EXPECT_TRUE(pass->raster.colorMask.r && !pass->depth.test);
        }
        EXPECT_EQ(coloured, op.truth(nA > 0, nB > 0)) << op.name << " " << nA << ", " << nB;
        EXPECT_EQ(t, 0) << op.name << ": the stencil is not returned to 0";
      }
    }
  }
}

TEST(StencilStates, CountingFacesIsFrontPlusOneBackMinusOneWithNoDepthTest) {
  const gfx::PipelineState& s = overlay::kCountFaces;
  EXPECT_FALSE(s.depth.test);
  EXPECT_FALSE(s.depth.write);
  EXPECT_TRUE(s.depth.clamp);
  EXPECT_EQ(s.raster.cull, CullMode::None);
  EXPECT_FALSE(s.raster.colorMask.r || s.raster.colorMask.a);
  EXPECT_EQ(s.stencil.front.depthPass, StencilOp::IncrWrap);
  EXPECT_EQ(s.stencil.back.depthPass, StencilOp::DecrWrap);
  // 300 faces entering and 300 leaving in any order: 0 (mod 256).
  std::uint8_t v = 0;
  for (int k = 0; k < 300; ++k) v = stencilUpdate(s.stencil.front, v, true);
  EXPECT_EQ(v, 300 % 256);
  for (int k = 0; k < 300; ++k) v = stencilUpdate(s.stencil.back, v, true);
  EXPECT_EQ(v, 0);
  EXPECT_EQ(overlay::kCoverOpenFaces.stencil.front.func, CompareFunc::NotEqual);
  EXPECT_EQ(overlay::kCoverOpenFaces.stencil.front.depthPass, StencilOp::Zero);
}

}  // namespace
}  // namespace gis::test
