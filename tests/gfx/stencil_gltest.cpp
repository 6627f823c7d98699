// The stencil buffer as the overlay uses it: triangles counted with INCR into the stencil, a
// quad then tested against the count. Every pixel is checked against a CPU rasterisation of the
// same triangles (pixel centres, edge functions); pixels whose centre lies within kEdgeEps pixels
// of an edge are skipped: GL snaps vertices to a sub-pixel grid (1/256 px on llvmpipe) before the
// tie rules apply, which moves edges by up to a few thousandths of a pixel.
#include <array>
#include <random>
#include <vector>

#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"

namespace gis::test {
namespace {

constexpr int kSize = 96;
constexpr double kEdgeEps = 0.02;  // pixels

const char* kVert = R"(#version 450 core
layout(location = 0) in vec2 a_position;
void main() { gl_Position = vec4(a_position, 0.5, 1.0); })";
const char* kFrag = R"(#version 450 core
uniform vec4 u_color;
out vec4 o_color;
void main() { o_color = u_color; })";

using Triangle = std::array<glm::vec2, 3>;  // NDC

/// Signed distance-like edge value in pixels; > 0 on the left of a→b.
double edge(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p) {
  const glm::dvec2 e = b - a;
  return (e.x * (p.y - a.y) - e.y * (p.x - a.x)) / glm::length(e);
}

/// 1 inside, 0 outside, -1 ambiguous (centre on an edge).
int coversPixelCentre(const Triangle& t, int x, int y) {
  auto toPixels = [](glm::vec2 ndc) { return (glm::dvec2(ndc) + 1.0) * 0.5 * double(kSize); };
  const glm::dvec2 a = toPixels(t[0]), b = toPixels(t[1]), c = toPixels(t[2]);
  const glm::dvec2 p(x + 0.5, y + 0.5);
  double e0 = edge(a, b, p), e1 = edge(b, c, p), e2 = edge(c, a, p);
  const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  if (area < 0) {
    e0 = -e0;
    e1 = -e1;
    e2 = -e2;
  }
  if (std::abs(e0) < kEdgeEps || std::abs(e1) < kEdgeEps || std::abs(e2) < kEdgeEps) return -1;
  return e0 > 0 && e1 > 0 && e2 > 0 ? 1 : 0;
}

class StencilGlTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    Result<gfx::Program> p =
        gfx::Program::fromSources({{GL_VERTEX_SHADER, kVert}, {GL_FRAGMENT_SHADER, kFrag}}, "stencil");
    ASSERT_TRUE(p.ok());
    program_ = std::move(*p);
    vao_ = gfx::createVertexArray();
    glEnableVertexArrayAttrib(vao_.id(), 0);
    glVertexArrayAttribFormat(vao_.id(), 0, 2, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao_.id(), 0, 0);
  }

  void draw(const std::vector<glm::vec2>& vertices, const gfx::PipelineState& state, glm::vec4 color = glm::vec4(1)) {
    gfx::BufferHandle vbo = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(glm::vec2));
    glVertexArrayVertexBuffer(vao_.id(), 0, vbo.id(), 0, sizeof(glm::vec2));
    cache_.apply(state);
    cache_.useProgram(program_);
    program_.set("u_color", color);
    cache_.bindVertexArray(vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(vertices.size()));
  }

  static std::vector<glm::vec2> fullScreenQuad() { return {{-1, -1}, {1, -1}, {1, 1}, {-1, -1}, {1, 1}, {-1, 1}}; }

  gfx::Program program_;
  gfx::VertexArrayHandle vao_;
};

/// Count every triangle into the stencil, colour write off, no depth test, both faces.
gfx::PipelineState markIncr(gfx::StencilOp op = gfx::StencilOp::Incr) {
  gfx::PipelineState s = gfx::kOpaque;
  s.depth.test = false;
  s.depth.write = false;
  s.raster.cull = gfx::CullMode::None;
  s.raster.colorMask = {false, false, false, false};
  s.stencil.test = true;
  s.stencil.front.depthPass = op;
  s.stencil.back.depthPass = op;
  return s;
}

/// Colour where the stencil equals `ref`.
gfx::PipelineState coverEqual(std::uint8_t ref) {
  gfx::PipelineState s = gfx::kOpaque;
  s.depth.test = false;
  s.raster.cull = gfx::CullMode::None;
  s.stencil.test = true;
  s.stencil.front.func = s.stencil.back.func = gfx::CompareFunc::Equal;
  s.stencil.front.ref = s.stencil.back.ref = ref;
  s.stencil.front.writeMask = s.stencil.back.writeMask = 0;
  return s;
}

TEST_F(StencilGlTest, TriangleIncrementedThenQuadTestedAgainstIt) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<float> coord(-1.2F, 1.2F);
  gfx::RenderTarget target(kSize, kSize);
  for (int round = 0; round < 25; ++round) {
    const Triangle tri{glm::vec2(coord(rng), coord(rng)), glm::vec2(coord(rng), coord(rng)),
                       glm::vec2(coord(rng), coord(rng))};
    gfx::beginRenderPass(cache_, target, {glm::vec4(0, 0, 0, 1), 0.0F, 0});
    draw({tri[0], tri[1], tri[2]}, markIncr());
    draw(fullScreenQuad(), coverEqual(1), glm::vec4(1, 0, 0, 1));
    const auto color = gfx::readColorRgba8(target);
    const auto stencil = gfx::readStencil(target);
    int checked = 0, mismatches = 0;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const int expected = coversPixelCentre(tri, x, y);
        if (expected < 0) continue;
        const std::size_t i = static_cast<std::size_t>((kSize - 1 - y) * kSize + x);  // readback is top row first
        ++checked;
        const bool red = color[i * 4] == 255 && color[i * 4 + 1] == 0;
        mismatches += (red != (expected == 1)) || (stencil[i] != expected);
      }
    }
    EXPECT_EQ(mismatches, 0) << "round " << round << ", " << checked << " pixels checked";
  }
}

TEST_F(StencilGlTest, OverlappingTrianglesCountPerPixel) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-1.0F, 1.0F);
  gfx::RenderTarget target(kSize, kSize);
  std::vector<Triangle> triangles(12);
  std::vector<glm::vec2> vertices;
  for (Triangle& t : triangles) {
    t = {glm::vec2(coord(rng), coord(rng)), glm::vec2(coord(rng), coord(rng)), glm::vec2(coord(rng), coord(rng))};
    vertices.insert(vertices.end(), t.begin(), t.end());
  }
  gfx::beginRenderPass(cache_, target, {glm::vec4(0, 0, 0, 1), 0.0F, 0});
  draw(vertices, markIncr());
  const auto stencil = gfx::readStencil(target);
  int mismatches = 0;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      int count = 0;
      bool ambiguous = false;
      for (const Triangle& t : triangles) {
        const int c = coversPixelCentre(t, x, y);
        ambiguous = ambiguous || c < 0;
        count += c > 0 ? 1 : 0;
      }
      if (ambiguous) continue;
      mismatches += stencil[static_cast<std::size_t>((kSize - 1 - y) * kSize + x)] != count;
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST_F(StencilGlTest, WrapOperationsWrapAndSaturatingOnesSaturate) {
  gfx::RenderTarget target(kSize, kSize);
  std::vector<glm::vec2> layers;
  for (int i = 0; i < 259; ++i) {
    const auto quad = fullScreenQuad();
    layers.insert(layers.end(), quad.begin(), quad.end());
  }
  gfx::beginRenderPass(cache_, target, {glm::vec4(0), 0.0F, 0});
  draw(layers, markIncr(gfx::StencilOp::IncrWrap));
  EXPECT_EQ(gfx::readStencil(target)[0], 259 % 256);
  gfx::beginRenderPass(cache_, target, {std::nullopt, std::nullopt, 0});
  draw(layers, markIncr(gfx::StencilOp::Incr));
  EXPECT_EQ(gfx::readStencil(target)[0], 255);
}

TEST_F(StencilGlTest, TwoSidedOpsCountFrontUpAndBackDown) {
  gfx::RenderTarget target(kSize, kSize);
  gfx::PipelineState s = markIncr(gfx::StencilOp::IncrWrap);
  s.stencil.back.depthPass = gfx::StencilOp::DecrWrap;
  const std::vector<glm::vec2> ccw{{-1, -1}, {1, -1}, {1, 1}};
  const std::vector<glm::vec2> cw{{-1, -1}, {1, 1}, {1, -1}};
  gfx::beginRenderPass(cache_, target, {glm::vec4(0), 0.0F, 0});
  draw(cw, s);  // back face: 0 → 255
  const auto afterBack = gfx::readStencil(target);
  draw(ccw, s);  // front face: 255 → 0
  draw(ccw, s);  // → 1
  const auto afterFront = gfx::readStencil(target);
  // Pixel (x = kSize-2, y = 1 from the bottom) is well inside both triangles.
  const std::size_t i = static_cast<std::size_t>((kSize - 2) * kSize + (kSize - 2));
  EXPECT_EQ(afterBack[i], 255);
  EXPECT_EQ(afterFront[i], 1);
}

}  // namespace
}  // namespace gis::test
