// Depth under reversed-Z with an infinite far plane: a ground plane drawn through the same
// eye-relative matrices as the terrain, read back and compared per pixel with the analytic
// depth near / (distance along the view axis) of the ray–plane hit, in the float depth buffer and
// in a 24-bit one (gfx::DepthFormat::Fixed24), whose readback must give the same depths to
// within one step.
#include <cmath>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "gfx/camera.hpp"
#include "gfx/handles.hpp"
#include "gfx/program.hpp"
#include "gfx/render_target.hpp"
#include "gl_test.hpp"

namespace gis::test {
namespace {

constexpr int kWidth = 128;
constexpr int kHeight = 96;
// Depth is a float; interpolating z/w over a plane is exact up to rounding. Stated tolerance:
// 1e-5 relative (≈ 80 float ulps). A 24-bit buffer adds its step, 1 / (2^24 − 1), absolute.
constexpr double kRelativeTolerance = 1e-5;
constexpr double kFixed24Step = 1.0 / 16777215.0;

const char* kVert = R"(#version 450 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_modelViewProj;
void main() { gl_Position = u_modelViewProj * vec4(a_position, 1.0); })";
const char* kFrag = R"(#version 450 core
out vec4 o_color;
void main() { o_color = vec4(1.0); })";

struct Case {
  glm::dvec3 centre;  ///< plane z = centre.z, vertices stored relative to centre
  glm::dvec3 eye;
  glm::dvec3 target;
  double near;
};

class DepthGlTest : public GlTest {
 protected:
  /// Draws a 20 km square of the plane z = centre.z and returns the depth buffer.
  std::vector<float> drawPlane(const Case& c, gfx::DepthFormat format = gfx::DepthFormat::Float32) {
    Result<gfx::Program> program =
        gfx::Program::fromSources({{GL_VERTEX_SHADER, kVert}, {GL_FRAGMENT_SHADER, kFrag}}, "plane");
    EXPECT_TRUE(program.ok());
    const float h = 1.0e4F;
    const std::vector<glm::vec3> quad{{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, -h, 0}, {h, h, 0}, {-h, h, 0}};
    gfx::BufferHandle vbo = gfx::createBufferWithData(quad.data(), quad.size() * sizeof(glm::vec3));
    gfx::VertexArrayHandle vao = gfx::createVertexArray();
    glVertexArrayVertexBuffer(vao.id(), 0, vbo.id(), 0, sizeof(glm::vec3));
    glEnableVertexArrayAttrib(vao.id(), 0);
    glVertexArrayAttribFormat(vao.id(), 0, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao.id(), 0, 0);

    gfx::RenderTarget target(kWidth, kHeight, 0, false, format);
    EXPECT_EQ(target.depthFormat(), format);
    gfx::beginRenderPass(cache_, target, {glm::vec4(0), gfx::kReversedZFar, 0});
    gfx::PipelineState state = gfx::kOpaque;
    state.raster.cull = gfx::CullMode::None;
    cache_.apply(state);
    const glm::dmat4 viewProj = projection(c) * gfx::lookAt(c.eye, c.target, {0, 0, 1});
    cache_.useProgram(*program);
    program->set("u_modelViewProj", gfx::relativeToCentre(viewProj, c.centre));
    cache_.bindVertexArray(vao.id());
    glDrawArrays(GL_TRIANGLES, 0, 6);
    return gfx::readDepth(target);
  }

  static constexpr double kFovY = 50.0 * std::numbers::pi / 180.0;
  static glm::dmat4 projection(const Case& c) {
    return gfx::reversedInfinitePerspective(kFovY, double(kWidth) / kHeight, c.near);
  }

  /// Analytic depth at the centre of pixel (x, y) (y from the bottom), or 0 where the ray misses.
  static double expectedDepth(const Case& c, int x, int y, bool& onPlane) {
    const double t = std::tan(kFovY / 2);
    const double aspect = double(kWidth) / kHeight;
    const glm::dvec3 viewDir((2.0 * (x + 0.5) / kWidth - 1.0) * t * aspect, (2.0 * (y + 0.5) / kHeight - 1.0) * t,
                             -1.0);
    const glm::dmat3 toWorld = glm::transpose(glm::dmat3(gfx::lookAt(c.eye, c.target, {0, 0, 1})));
    const glm::dvec3 dir = toWorld * viewDir;  // its view-axis component is exactly 1
    onPlane = false;
    if (dir.z >= 0.0) return 0.0;
    const double s = (c.centre.z - c.eye.z) / dir.z;  // distance along the view axis
    const glm::dvec3 hit = c.eye + s * dir;
    if (std::abs(hit.x - c.centre.x) > 1.0e4 || std::abs(hit.y - c.centre.y) > 1.0e4) return 0.0;
    onPlane = true;
    return c.near / s;
  }

  void checkCase(const Case& c, gfx::DepthFormat format = gfx::DepthFormat::Float32) {
    const std::vector<float> depth = drawPlane(c, format);
    const double absolute = format == gfx::DepthFormat::Fixed24 ? kFixed24Step : 0.0;
    int onPlane = 0, background = 0, bad = 0, missing = 0;
    double worst = 0.0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        bool hits = false;
        const double expected = expectedDepth(c, x, y, hits);
        const double actual = depth[static_cast<std::size_t>((kHeight - 1 - y) * kWidth + x)];
        if (!hits) {
          // Skip pixels near the plane's far edge or the horizon where coverage is ambiguous.
          if (actual == 0.0) ++background;
          continue;
        }
        ++onPlane;
        if (actual == 0.0) {  // only at the square's edge, where tie rules decide coverage
          ++missing;
          continue;
        }
        const double rel = (std::abs(actual - expected) - absolute) / expected;
        worst = std::max(worst, rel);
        bad += rel > kRelativeTolerance;
      }
    }
    EXPECT_GT(onPlane, kWidth * kHeight / 4);
    EXPECT_GT(background, 0);
    EXPECT_EQ(bad, 0) << "worst relative depth error " << worst;
    EXPECT_LE(missing, kWidth) << "plane pixels left at background depth";
  }
};

TEST_F(DepthGlTest, ObliquePlaneMatchesAnalyticReversedDepth) {
  checkCase({{0, 0, 0}, {0, -800, 300}, {0, 400, 0}, 1.0});
}

TEST_F(DepthGlTest, FarFromTheOriginTheEyeRelativeMatricesKeepPrecision) {
  // UTM-like coordinates: northing near 10^7 m. Vertices are float relative to the centre.
  const glm::dvec3 centre(293770.921, 9115766.079, 40.0);
  checkCase({centre, centre + glm::dvec3(150, -600, 250), centre + glm::dvec3(0, 300, 0), 0.5});
}

TEST_F(DepthGlTest, A24BitBufferReadsBackTheSameDepthsWithinOneStep) {
  checkCase({{0, 0, 0}, {0, -800, 300}, {0, 400, 0}, 1.0}, gfx::DepthFormat::Fixed24);
  checkCase({{0, 0, 0}, {0, -800, 300}, {0, 400, 0}, 100.0}, gfx::DepthFormat::Fixed24);
}

TEST_F(DepthGlTest, NearerIsGreaterAndBackgroundIsZero) {
  const Case c{{0, 0, 0}, {0, -500, 200}, {0, 0, 0}, 1.0};
  const std::vector<float> depth = drawPlane(c);
  // Rows from the bottom of the image look nearer ground than rows higher up.
  const float bottom = depth[static_cast<std::size_t>((kHeight - 1) * kWidth + kWidth / 2)];
  const float middle = depth[static_cast<std::size_t>((kHeight / 2) * kWidth + kWidth / 2)];
  EXPECT_GT(bottom, middle);
  EXPECT_GT(middle, 0.0F);
  EXPECT_EQ(depth[static_cast<std::size_t>(kWidth / 2)], 0.0F);  // top row: sky
}

}  // namespace
}  // namespace gis::test
