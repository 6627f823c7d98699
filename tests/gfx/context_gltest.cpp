// The headless context and the GL core around it: version and capabilities, debug output,
// embedded shaders, move-only handles, queries, MSAA targets.
#include <algorithm>

#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "shaders/embedded.hpp"

namespace gis::test {
namespace {

using ContextGlTest = GlTest;

const char* kFullScreenVert = R"(#version 450 core
void main() {
  // One triangle that covers the viewport.
  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.5, 1.0);
})";
const char* kSolidFrag = R"(#version 450 core
uniform vec4 u_color;
out vec4 o_color;
void main() { o_color = u_color; })";

TEST_F(ContextGlTest, IsOpenGl45CoreWithWhatThePassesNeed) {
  const gfx::GlInfo& info = context()->info();
  EXPECT_GE(info.major * 10 + info.minor, 45) << info.version;
  EXPECT_TRUE(info.clipControl);
  EXPECT_TRUE(info.pipelineStatistics);
  EXPECT_TRUE(info.timerQuery);
  EXPECT_TRUE(context()->headless());
  GLint profile = 0;
  glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
  EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
}

TEST_F(ContextGlTest, DebugOutputCountsErrors) {
  glEnable(0xFFFF);  // GL_INVALID_ENUM on purpose
  glFinish();
  EXPECT_EQ(context()->debug().errorCount(), 1u);
  EXPECT_FALSE(context()->debug().errorMessages().empty());
  context()->debug().reset();  // the fixture fails on any error left
}

TEST_F(ContextGlTest, EmbeddedShadersCompile) {
  const auto names = shaders::names();
  EXPECT_NE(std::find(names.begin(), names.end(), "terrain_chunk.vert"), names.end());
  Result<gfx::Program> program =
      gfx::Program::build({{"terrain_chunk.vert", {}}, {"terrain_chunk.frag", {"UNUSED_DEFINE 1"}}});
  ASSERT_TRUE(program.ok()) << program.diagnostics.items().front().toString();
  EXPECT_NE(program->id(), 0u);
}

TEST_F(ContextGlTest, BrokenShaderIsAnErrorNamingTheFile) {
  Result<gfx::Program> missing = gfx::Program::build({{"no_such.vert", {}}});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.diagnostics.items().front().toString().find("no_such.vert"), std::string::npos);
  Result<gfx::Program> broken = gfx::Program::fromSources(
      {{GL_FRAGMENT_SHADER, "#version 450 core\nvoid main() { nonsense; }\n"}}, "broken.frag");
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.diagnostics.items().front().toString().find("broken.frag"), std::string::npos);
  context()->debug().reset();  // a failed compile may be reported through debug output too
}

TEST_F(ContextGlTest, HandlesAreMoveOnlyOwners) {
  static_assert(!std::is_copy_constructible_v<gfx::BufferHandle>);
  static_assert(!std::is_copy_assignable_v<gfx::TextureHandle>);
  static_assert(std::is_nothrow_move_constructible_v<gfx::FramebufferHandle>);
  GLuint id = 0;
  {
    gfx::BufferHandle a = gfx::createBuffer();
    id = a.id();
    EXPECT_TRUE(glIsBuffer(id));
    gfx::BufferHandle b = std::move(a);
    EXPECT_EQ(a.id(), 0u);  // NOLINT(bugprone-use-after-move): moved-from state is specified
    EXPECT_EQ(b.id(), id);
    EXPECT_TRUE(glIsBuffer(id));
  }
  EXPECT_FALSE(glIsBuffer(id));
}

TEST_F(ContextGlTest, QueriesCountFragmentsAndTime) {
  constexpr int kSize = 64;
  gfx::RenderTarget target(kSize, kSize);
  ASSERT_TRUE(target.complete());
  Result<gfx::Program> program =
      gfx::Program::fromSources({{GL_VERTEX_SHADER, kFullScreenVert}, {GL_FRAGMENT_SHADER, kSolidFrag}}, "solid");
  ASSERT_TRUE(program.ok());
  gfx::VertexArrayHandle vao = gfx::createVertexArray();
  gfx::beginRenderPass(cache_, target, {glm::vec4(0.0F), 0.0F, 0});
  gfx::PipelineState state = gfx::kOpaque;
  state.depth.test = false;
  cache_.apply(state);
  cache_.useProgram(*program);
  program->set("u_color", glm::vec4(1.0F));
  cache_.bindVertexArray(vao.id());

  gfx::GpuTimer timer;
  gfx::PipelineStatistics statistics;
  ASSERT_TRUE(statistics.available());
  timer.begin();
  statistics.begin();
  glDrawArrays(GL_TRIANGLES, 0, 3);
  statistics.end();
  timer.end();
  const gfx::PipelineCounts counts = statistics.result();
  EXPECT_EQ(counts.samplesPassed, static_cast<std::uint64_t>(kSize * kSize));
  EXPECT_GE(counts.fragmentShaderInvocations, static_cast<std::uint64_t>(kSize * kSize));
  EXPECT_EQ(counts.verticesSubmitted, 3u);
  EXPECT_EQ(counts.primitivesSubmitted, 1u);
  const std::optional<std::uint64_t> ns = timer.nanoseconds();
  ASSERT_TRUE(ns.has_value());
  EXPECT_GT(*ns, 0u);
}

TEST_F(ContextGlTest, MultisampledTargetResolves) {
  constexpr int kSize = 32;
  gfx::RenderTarget msaa(kSize, kSize, 4);
  ASSERT_TRUE(msaa.multisampled());
  ASSERT_TRUE(msaa.complete());
  gfx::RenderTarget single(kSize, kSize);
  gfx::beginRenderPass(cache_, msaa, {glm::vec4(0.25F, 0.5F, 0.75F, 1.0F), 0.5F, 7});
  msaa.resolveInto(single);
  const auto color = gfx::readColorRgba8(single);
  const auto depth = gfx::readDepth(single);
  const auto stencil = gfx::readStencil(single);
  for (std::size_t i = 0; i < depth.size(); ++i) {
    EXPECT_NEAR(color[i * 4 + 0], 64, 1);
    EXPECT_NEAR(color[i * 4 + 2], 191, 1);
    EXPECT_FLOAT_EQ(depth[i], 0.5F);
    EXPECT_EQ(stencil[i], 7);
  }
}

}  // namespace
}  // namespace gis::test
