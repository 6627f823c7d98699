// The state cache is the only code that changes pipeline state. It must make GL hold exactly
// the state asked for (checked by reading GL back with glGet*), skip redundant calls, and leave
// nothing of one pass in the next.
#include <random>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"

namespace gis::test {
namespace {

using StateCacheGlTest = GlTest;

template <typename E>
E pick(std::mt19937& rng, int count) {
  return static_cast<E>(std::uniform_int_distribution<int>(0, count - 1)(rng));
}

gfx::StencilFace randomFace(std::mt19937& rng) {
  std::uniform_int_distribution<int> byte(0, 255);
  gfx::StencilFace f;
  f.func = pick<gfx::CompareFunc>(rng, 8);
  f.ref = static_cast<std::uint8_t>(byte(rng));
  f.readMask = static_cast<std::uint8_t>(byte(rng));
  f.writeMask = static_cast<std::uint8_t>(byte(rng));
  f.stencilFail = pick<gfx::StencilOp>(rng, 8);
  f.depthFail = pick<gfx::StencilOp>(rng, 8);
  f.depthPass = pick<gfx::StencilOp>(rng, 8);
  return f;
}

gfx::PipelineState randomState(std::mt19937& rng) {
  std::bernoulli_distribution coin;
  gfx::PipelineState s;
  s.depth = {coin(rng), coin(rng), pick<gfx::CompareFunc>(rng, 8), coin(rng)};
  s.stencil = {coin(rng), randomFace(rng), randomFace(rng)};
  s.blend = {coin(rng),
             pick<gfx::BlendFactor>(rng, 12),
             pick<gfx::BlendFactor>(rng, 12),
             pick<gfx::BlendFactor>(rng, 12),
             pick<gfx::BlendFactor>(rng, 12),
             pick<gfx::BlendEquation>(rng, 5),
             pick<gfx::BlendEquation>(rng, 5)};
  s.raster.cull = pick<gfx::CullMode>(rng, 3);
  s.raster.frontFaceCCW = coin(rng);
  s.raster.colorMask = {coin(rng), coin(rng), coin(rng), coin(rng)};
  s.raster.polygonMode = pick<gfx::PolygonMode>(rng, 2);
  s.raster.polygonOffsetFactor = coin(rng) ? 1.5F : 0.0F;
  s.raster.polygonOffsetUnits = coin(rng) ? -2.0F : 0.0F;
  s.raster.multisample = coin(rng);
  return s;
}

TEST_F(StateCacheGlTest, GlHoldsExactlyWhatWasAppliedForRandomSequences) {
  // Stencil reference values read back clamped to the bound framebuffer's stencil bits:
  // bind an 8-bit stencil target, as every stencil pass does.
  gfx::RenderTarget target(16, 16);
  gfx::beginRenderPass(cache_, target, {});
  std::mt19937 rng(314);
  for (int i = 0; i < 300; ++i) {
    const gfx::PipelineState s = randomState(rng);
    cache_.apply(s);
    const gfx::PipelineState actual = gfx::StateCache::queryGl();
    ASSERT_EQ(actual, s) << "step " << i << "\nwanted:\n" << gfx::toString(s) << "GL holds:\n" << gfx::toString(actual);
  }
}

TEST_F(StateCacheGlTest, NoLeaksBetweenTwoPasses) {
  // Pass 1: a stencil "mark" pass (colour off, depth write off, clamp on, two-sided wrap ops).
  gfx::PipelineState mark = gfx::kOpaque;
  mark.depth.write = false;
  mark.depth.clamp = true;
  mark.raster.cull = gfx::CullMode::None;
  mark.raster.colorMask = {false, false, false, false};
  mark.stencil.test = true;
  mark.stencil.front.depthPass = gfx::StencilOp::IncrWrap;
  mark.stencil.back.depthPass = gfx::StencilOp::DecrWrap;
  gfx::RenderTarget target(16, 16);
  gfx::beginRenderPass(cache_, target, {glm::vec4(0), 0.0F, 0});
  cache_.apply(mark);
  ASSERT_EQ(gfx::StateCache::queryGl(), mark);
  // Pass 2 (with a clear in between, which temporarily opens all write masks): opaque.
  gfx::beginRenderPass(cache_, target, {glm::vec4(0), 0.0F, 0});
  cache_.apply(gfx::kOpaque);
  EXPECT_EQ(gfx::StateCache::queryGl(), gfx::kOpaque) << gfx::toString(gfx::StateCache::queryGl());
}

TEST_F(StateCacheGlTest, RedundantStateIsNotSetAgain) {
  cache_.apply(gfx::kOpaque);
  const std::size_t before = cache_.glCallCount();
  cache_.apply(gfx::kOpaque);
  EXPECT_EQ(cache_.glCallCount(), before);
  gfx::PipelineState blended = gfx::kOpaque;
  blended.blend = gfx::kBlendPremultipliedOver;
  cache_.apply(blended);
  EXPECT_EQ(cache_.glCallCount(), before + 2);  // enable + func; the equation was already ADD
}

TEST_F(StateCacheGlTest, InvalidateResynchronisesAfterForeignGlCode) {
  cache_.apply(gfx::kOpaque);
  // Third-party code (e.g. a UI library) changes state behind the cache's back.
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glDepthMask(GL_FALSE);
  cache_.apply(gfx::kOpaque);  // the cache believes nothing changed
  EXPECT_NE(gfx::StateCache::queryGl(), gfx::kOpaque);
  cache_.invalidate();
  cache_.apply(gfx::kOpaque);
  EXPECT_EQ(gfx::StateCache::queryGl(), gfx::kOpaque);
}

}  // namespace
}  // namespace gis::test
