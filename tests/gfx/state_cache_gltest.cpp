// The state cache is the only code that changes pipeline state and binds objects. It must make
// GL hold exactly the state and bindings asked for (checked by reading GL back with glGet*), skip
// redundant calls, leave nothing of one pass in the next, and never skip binding a new object
// that got the name of a deleted one.
#include <array>
#include <cstdio>
#include <optional>
#include <random>
#include <vector>

#include "gfx/program.hpp"
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

/// The bindings the cache tracks, as GL holds them.
struct GlBindings {
  GLuint framebuffer = 0;
  gfx::Viewport viewport;
  GLuint program = 0;
  GLuint vertexArray = 0;
  std::array<GLuint, 4> textures{};  ///< GL_TEXTURE_2D of units 0-3
  std::array<GLuint, 4> uniformBuffers{};
  std::array<GLuint, 4> storageBuffers{};
  GLuint indirectBuffer = 0;
  bool operator==(const GlBindings&) const = default;
};

GLuint glName(GLenum pname) {
  GLint v = 0;
  glGetIntegerv(pname, &v);
  return static_cast<GLuint>(v);
}

GLuint glIndexedName(GLenum pname, GLuint index) {
  GLint v = 0;
  glGetIntegeri_v(pname, index, &v);
  return static_cast<GLuint>(v);
}

GlBindings queryGlBindings() {
  GlBindings b;
  b.framebuffer = glName(GL_DRAW_FRAMEBUFFER_BINDING);
  GLint v[4] = {0, 0, 0, 0};
  glGetIntegerv(GL_VIEWPORT, v);
  b.viewport = {v[0], v[1], v[2], v[3]};
  b.program = glName(GL_CURRENT_PROGRAM);
  b.vertexArray = glName(GL_VERTEX_ARRAY_BINDING);
  // Texture bindings per unit are read through the active unit (the cache never changes it).
  for (GLuint unit = 0; unit < b.textures.size(); ++unit) {
    glActiveTexture(GL_TEXTURE0 + unit);
    b.textures[unit] = glName(GL_TEXTURE_BINDING_2D);
  }
  glActiveTexture(GL_TEXTURE0);
  for (GLuint i = 0; i < b.uniformBuffers.size(); ++i) {
    b.uniformBuffers[i] = glIndexedName(GL_UNIFORM_BUFFER_BINDING, i);
    b.storageBuffers[i] = glIndexedName(GL_SHADER_STORAGE_BUFFER_BINDING, i);
  }
  b.indirectBuffer = glName(GL_DRAW_INDIRECT_BUFFER_BINDING);
  return b;
}

gfx::Program trivialProgram() {
  Result<gfx::Program> p = gfx::Program::fromSources(
      {{GL_VERTEX_SHADER, "#version 450 core\nvoid main() { gl_Position = vec4(0.0, 0.0, 0.0, 1.0); }\n"},
       {GL_FRAGMENT_SHADER, "#version 450 core\nout vec4 c;\nvoid main() { c = vec4(1.0); }\n"}},
      "trivial");
  EXPECT_TRUE(p.ok());
  return p.ok() ? std::move(*p) : gfx::Program{};
}

gfx::TextureHandle texture2d() {
  gfx::TextureHandle t = gfx::createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(t.id(), 1, GL_RGBA8, 4, 4);
  return t;
}

gfx::BufferHandle buffer() { return gfx::createBufferWithData(nullptr, 256); }

/// A few objects of every kind the cache binds; any of them may be deleted and made again.
struct Objects {
  std::vector<std::optional<gfx::RenderTarget>> targets;
  std::vector<gfx::Program> programs;
  std::vector<gfx::VertexArrayHandle> vertexArrays;
  std::vector<gfx::TextureHandle> textures;
  std::vector<gfx::BufferHandle> buffers;

  Objects() {
    for (int k = 0; k < 3; ++k) {
      targets.emplace_back(std::in_place, 8 + 4 * k, 6 + 2 * k);
      programs.push_back(trivialProgram());
      vertexArrays.push_back(gfx::createVertexArray());
      textures.push_back(texture2d());
      buffers.push_back(buffer());
    }
  }
};

TEST_F(StateCacheGlTest, GlHoldsExactlyTheBindingsAskedForInRandomSequences) {
  std::mt19937 rng(7);
  Objects o;
  const auto index = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  const auto unit = [&] { return static_cast<GLuint>(index(4)); };
  const auto name = [&](GLuint id) { return std::bernoulli_distribution(0.2)(rng) ? 0u : id; };
  gfx::StateCache foreign;  // other GL code, binding behind cache_'s back
  // What GL must hold: set as the cache is asked, and read back once foreign code ran.
  cache_.bindDrawTarget(0, 1, 1);
  cache_.useProgram(0);
  cache_.bindVertexArray(0);
  cache_.bindIndirectBuffer(0);
  for (GLuint u = 0; u < 4; ++u) {
    cache_.bindTexture(u, 0);
    cache_.bindUniformBuffer(u, 0);
    cache_.bindStorageBuffer(u, 0);
  }
  GlBindings expected = queryGlBindings();
  for (int step = 0; step < 3000; ++step) {
    SCOPED_TRACE(step);
    switch (index(10)) {
      case 0: {
        const gfx::RenderTarget& t = *o.targets[index(3)];
        const GLuint fbo = name(t.framebuffer());
        cache_.bindDrawTarget(fbo, t.width(), t.height());
        expected.framebuffer = fbo;
        expected.viewport = {0, 0, t.width(), t.height()};
        break;
      }
      case 1: {
        const GLuint p = name(o.programs[index(3)].id());
        cache_.useProgram(p);
        expected.program = p;
        break;
      }
      case 2: {
        const GLuint vao = name(o.vertexArrays[index(3)].id());
        cache_.bindVertexArray(vao);
        expected.vertexArray = vao;
        break;
      }
      case 3: {
        const GLuint u = unit(), t = name(o.textures[index(3)].id());
        cache_.bindTexture(u, t);
        expected.textures[u] = t;
        break;
      }
      case 4: {
        const GLuint i = unit(), b = name(o.buffers[index(3)].id());
        cache_.bindUniformBuffer(i, b);
        expected.uniformBuffers[i] = b;
        break;
      }
      case 5: {
        const GLuint i = unit(), b = name(o.buffers[index(3)].id());
        cache_.bindStorageBuffer(i, b);
        expected.storageBuffers[i] = b;
        break;
      }
      case 6: {
        const GLuint b = name(o.buffers[index(3)].id());
        cache_.bindIndirectBuffer(b);
        expected.indirectBuffer = b;
        break;
      }
      case 7: {
        // Delete one object of a kind and make another, which GL likely names as the deleted
        // one: what GL holds is whatever deletion left (read back).
        const std::size_t k = index(3);
        switch (index(5)) {
          case 0:
            o.targets[k].reset();
            o.targets[k].emplace(8 + 4 * static_cast<int>(k), 6 + 2 * static_cast<int>(k));
            break;
          case 1:
            o.programs[k] = gfx::Program{};
            o.programs[k] = trivialProgram();
            // A deleted current program stays current (and its name taken) until another is
            // used: use none, so that every name read back below names a live object.
            cache_.useProgram(0);
            break;
          case 2:
            o.vertexArrays[k].reset();
            o.vertexArrays[k] = gfx::createVertexArray();
            break;
          case 3:
            o.textures[k].reset();
            o.textures[k] = texture2d();
            break;
          default:
            o.buffers[k].reset();
            o.buffers[k] = buffer();
            break;
        }
        expected = queryGlBindings();
        break;
      }
      case 8: {
        // Foreign code binds something, then the cache is told.
        foreign.invalidate();
        foreign.bindVertexArray(o.vertexArrays[index(3)].id());
        foreign.bindTexture(unit(), o.textures[index(3)].id());
        foreign.useProgram(o.programs[index(3)]);
        foreign.bindDrawTarget(o.targets[index(3)]->framebuffer(), 3, 2);
        cache_.invalidate();
        expected = queryGlBindings();
        break;
      }
      default: {
        // Redundant: the cache issues no call.
        const std::size_t before = cache_.glCallCount();
        cache_.bindDrawTarget(gfx::DrawTarget{expected.framebuffer, expected.viewport});
        cache_.useProgram(expected.program);
        cache_.bindVertexArray(expected.vertexArray);
        const GLuint u = unit();
        cache_.bindTexture(u, expected.textures[u]);
        cache_.bindUniformBuffer(u, expected.uniformBuffers[u]);
        cache_.bindStorageBuffer(u, expected.storageBuffers[u]);
        cache_.bindIndirectBuffer(expected.indirectBuffer);
        // After invalidate() or a deletion the cache knows nothing yet, and these calls bind;
        // now it knows, and the same calls again issue nothing.
        EXPECT_LE(cache_.glCallCount() - before, 8u);
        const std::size_t again = cache_.glCallCount();
        cache_.useProgram(expected.program);
        cache_.bindVertexArray(expected.vertexArray);
        cache_.bindTexture(u, expected.textures[u]);
        cache_.bindStorageBuffer(u, expected.storageBuffers[u]);
        EXPECT_EQ(cache_.glCallCount(), again);
        break;
      }
    }
    const GlBindings actual = queryGlBindings();
    ASSERT_EQ(actual, expected);
    ASSERT_EQ(cache_.drawTarget(), (gfx::DrawTarget{actual.framebuffer, actual.viewport}));
  }
}

TEST_F(StateCacheGlTest, RedundantBindingsAreNotIssuedAgain) {
  gfx::RenderTarget target(16, 8);
  const gfx::Program program = trivialProgram();
  const gfx::VertexArrayHandle vao = gfx::createVertexArray();
  const gfx::TextureHandle texture = texture2d();
  const gfx::BufferHandle storage = buffer(), indirect = buffer();
  const auto bindAll = [&] {
    cache_.bindDrawTarget(target.framebuffer(), 16, 8);
    cache_.useProgram(program);
    cache_.bindVertexArray(vao.id());
    cache_.bindTexture(2, texture.id());
    cache_.bindStorageBuffer(3, storage.id());
    cache_.bindUniformBuffer(1, storage.id());
    cache_.bindIndirectBuffer(indirect.id());
  };
  bindAll();
  const std::size_t before = cache_.glCallCount();
  bindAll();
  EXPECT_EQ(cache_.glCallCount(), before);
  cache_.bindDrawTarget(target.framebuffer(), 8, 8);  // the viewport only
  EXPECT_EQ(cache_.glCallCount(), before + 1);
  cache_.bindTexture(1, texture.id());  // another unit
  EXPECT_EQ(cache_.glCallCount(), before + 2);
  cache_.invalidate();
  bindAll();
  EXPECT_EQ(cache_.glCallCount(), before + 2 + 8);  // everything again: framebuffer and viewport are two
}

/// Objects made by `make` until one is named `name`, the deleted object's: GL may reuse a name at
/// once (newer Mesa does), later or never (Mesa 22 counts up). The others stay alive meanwhile, so that each
/// try gets another name. Nullopt when no try got it.
template <typename T, typename Make, typename Name>
std::optional<T> sameName(GLuint name, Make make, Name nameOf) {
  std::vector<T> others;
  for (int k = 0; k < 16; ++k) {
    T t = make();
    if (nameOf(t) == name) return t;
    others.push_back(std::move(t));
  }
  return std::nullopt;
}

TEST_F(StateCacheGlTest, AnObjectNamedAsADeletedBoundOneIsStillBound) {
  // A cache that still held a deleted object as bound would skip binding a new object of the
  // same name; GL unbound the deleted one, so nothing would be bound. Where the driver reuses no
  // name, the cache must still know that GL unbound it (seen for the draw framebuffer).
  int reused = 0;
  {
    std::optional<gfx::VertexArrayHandle> vao = gfx::createVertexArray();
    const GLuint name = vao->id();
    cache_.bindVertexArray(name);
    vao.reset();
    const auto again = sameName<gfx::VertexArrayHandle>(name, gfx::createVertexArray, [](auto& v) { return v.id(); });
    if (again) {
      ++reused;
      cache_.bindVertexArray(again->id());
      EXPECT_EQ(glName(GL_VERTEX_ARRAY_BINDING), name);
    }
  }
  {
    std::optional<gfx::TextureHandle> texture = texture2d();
    const GLuint name = texture->id();
    cache_.bindTexture(1, name);
    texture.reset();
    const auto again = sameName<gfx::TextureHandle>(name, texture2d, [](auto& t) { return t.id(); });
    if (again) {
      ++reused;
      cache_.bindTexture(1, again->id());
      glActiveTexture(GL_TEXTURE1);
      EXPECT_EQ(glName(GL_TEXTURE_BINDING_2D), name);
      glActiveTexture(GL_TEXTURE0);
    }
  }
  {
    std::optional<gfx::BufferHandle> storage = buffer();
    const GLuint name = storage->id();
    cache_.bindStorageBuffer(2, name);
    cache_.bindIndirectBuffer(name);
    storage.reset();
    const auto again = sameName<gfx::BufferHandle>(name, buffer, [](auto& b) { return b.id(); });
    if (again) {
      ++reused;
      cache_.bindStorageBuffer(2, again->id());
      cache_.bindIndirectBuffer(again->id());
      EXPECT_EQ(glIndexedName(GL_SHADER_STORAGE_BUFFER_BINDING, 2), name);
      EXPECT_EQ(glName(GL_DRAW_INDIRECT_BUFFER_BINDING), name);
    }
  }
  {
    std::optional<gfx::RenderTarget> target(std::in_place, 8, 8);
    const GLuint name = target->framebuffer();
    cache_.bindDrawTarget(name, 8, 8);
    target.reset();  // GL binds the default framebuffer
    EXPECT_EQ(cache_.drawTarget().framebuffer, 0u);
    const auto again = sameName<gfx::RenderTarget>(
        name, [] { return gfx::RenderTarget(8, 8); }, [](auto& t) { return t.framebuffer(); });
    if (again) {
      ++reused;
      cache_.bindDrawTarget(again->framebuffer(), 8, 8);
      EXPECT_EQ(glName(GL_DRAW_FRAMEBUFFER_BINDING), name);
    }
  }
  {
    // A current program deleted stays current, its name taken, until another is used.
    std::optional<gfx::Program> program = trivialProgram();
    const GLuint name = program->id();
    cache_.useProgram(name);
    program.reset();
    cache_.useProgram(0);
    const auto again = sameName<gfx::Program>(name, trivialProgram, [](auto& p) { return p.id(); });
    if (again) {
      ++reused;
      cache_.useProgram(*again);
      EXPECT_EQ(glName(GL_CURRENT_PROGRAM), name);
    }
  }
  std::printf("%d of 5 kinds of object got a deleted object's name again\n", reused);
}

TEST_F(StateCacheGlTest, ARenderPassRestoresTheTargetAndViewportBoundBeforeIt) {
  gfx::RenderTarget outer(32, 24), inner(8, 8), innermost(4, 2);
  const gfx::DrawTarget before{outer.framebuffer(), {2, 3, 20, 10}};
  cache_.bindDrawTarget(before);
  {
    const gfx::RenderPass pass(cache_, inner.framebuffer(), 8, 8, {glm::vec4(1.0F), std::nullopt, std::nullopt});
    EXPECT_EQ(glName(GL_DRAW_FRAMEBUFFER_BINDING), inner.framebuffer());
    {
      const gfx::RenderPass nested(cache_, innermost.framebuffer(), 4, 2);
      EXPECT_EQ(queryGlBindings().viewport, (gfx::Viewport{0, 0, 4, 2}));
    }
    EXPECT_EQ(glName(GL_DRAW_FRAMEBUFFER_BINDING), inner.framebuffer());
    EXPECT_EQ(queryGlBindings().viewport, (gfx::Viewport{0, 0, 8, 8}));
  }
  GlBindings gl = queryGlBindings();
  EXPECT_EQ((gfx::DrawTarget{gl.framebuffer, gl.viewport}), before);

  // After foreign code the cache knows nothing: the pass reads what to restore from GL.
  cache_.invalidate();
  { const gfx::RenderPass pass(cache_, inner.framebuffer(), 8, 8); }
  gl = queryGlBindings();
  EXPECT_EQ((gfx::DrawTarget{gl.framebuffer, gl.viewport}), before);
  EXPECT_EQ(cache_.drawTarget(), before);
}

}  // namespace
}  // namespace gis::test
