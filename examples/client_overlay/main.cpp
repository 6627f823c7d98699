// A GIS client with its own terrain (here a sine-wave surface drawn with its own shader) draws a
// polygon layer and a road layer on it with the stencil core of gis::vector_overlay: it gives
// the overlay its depth-filled framebuffer, its camera and a HeightBoundsProvider of its own.
// Exits 0 when both layers cover pixels and GL reported no error; writes client_overlay.ppm.
// It asks the package for the overlay component only (CMakeLists.txt).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "gfx/camera.hpp"
#include "gfx/context.hpp"
#include "gfx/program.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace {

double surface(double x, double y) { return 20.0 * std::sin(x / 150.0) * std::cos(y / 200.0); }

/// The client's terrain: heights within ±20 m; the bound over any footprint is the range of
/// the surface there, made safe by sampling densely and adding the largest variation between
/// samples (the surface's slope is at most 20/150 + 20/200 per metre).
class ClientBounds final : public gis::overlay::HeightBoundsProvider {
 public:
  gis::overlay::HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override {
    if (footprint.empty()) return globalBounds();
    glm::dvec2 lo = footprint[0], hi = footprint[0];
    for (const glm::dvec2& p : footprint) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const double step = 5.0, slope = 20.0 / 150.0 + 20.0 / 200.0;
    double zlo = 1e300, zhi = -1e300;
    for (double x = lo.x; x <= hi.x + step; x += step) {
      for (double y = lo.y; y <= hi.y + step; y += step) {
        const double z = surface(std::min(x, hi.x), std::min(y, hi.y));
        zlo = std::min(zlo, z);
        zhi = std::max(zhi, z);
      }
    }
    const double margin = slope * step * std::sqrt(2.0);
    return {zlo - margin, zhi + margin};
  }
  gis::overlay::HeightBounds globalBounds() const override { return {-20.0, 20.0}; }
};

/// The frame as a binary PPM (a client has its own image output; this keeps the example free of
/// any image library). `rgba` is top row first.
void writePpm(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgba) {
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << width << ' ' << height << "\n255\n";
  for (std::size_t i = 0; i + 3 < rgba.size(); i += 4) out.write(reinterpret_cast<const char*>(&rgba[i]), 3);
}

const char* kVertex = R"(#version 450 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_mvp;
out float v_height;
void main() { v_height = a_position.z; gl_Position = u_mvp * vec4(a_position, 1.0); })";
const char* kFragment = R"(#version 450 core
in float v_height;
out vec4 o_color;
void main() { o_color = vec4(0.3 + v_height / 60.0, 0.45, 0.3, 1.0); })";

}  // namespace

int main() {
  using namespace gis;
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  if (!context) {
    std::fprintf(stderr, "no OpenGL 4.5 context\n");
    return 1;
  }
  constexpr int kWidth = 320, kHeight = 240, kGrid = 100;
  // The client's terrain mesh: 2 km square, 20 m cells.
  std::vector<float> vertices;
  std::vector<std::uint32_t> indices;
  for (int j = 0; j <= kGrid; ++j) {
    for (int i = 0; i <= kGrid; ++i) {
      const double x = -1000.0 + 20.0 * i, y = -1000.0 + 20.0 * j;
      vertices.insert(vertices.end(),
                      {static_cast<float>(x), static_cast<float>(y), static_cast<float>(surface(x, y))});
    }
  }
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const auto a = static_cast<std::uint32_t>(j * (kGrid + 1) + i), b = a + 1, d = a + kGrid + 1, e = d + 1;
      indices.insert(indices.end(), {a, b, e, a, e, d});
    }
  }
  gfx::BufferHandle vbo = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(float));
  gfx::BufferHandle ibo = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint32_t));
  gfx::VertexArrayHandle vao = gfx::createVertexArray();
  glVertexArrayVertexBuffer(vao.id(), 0, vbo.id(), 0, 3 * sizeof(float));
  glVertexArrayElementBuffer(vao.id(), ibo.id());
  glEnableVertexArrayAttrib(vao.id(), 0);
  glVertexArrayAttribFormat(vao.id(), 0, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao.id(), 0, 0);
  Result<gfx::Program> terrainProgram =
      gfx::Program::fromSources({{GL_VERTEX_SHADER, kVertex}, {GL_FRAGMENT_SHADER, kFragment}}, "client terrain");
  if (!terrainProgram) return 1;

  // The client's layers, in its frame (metres).
  std::vector<geo::Feature> areas(1), roads(1);
  areas[0].fid = 1;
  areas[0].polygons.push_back(
      {{{-400, -300}, {300, -350}, {450, 200}, {-200, 400}}, {{{-50, -50}, {50, -40}, {0, 60}}}});
  roads[0].fid = 7;
  roads[0].lines.push_back({{-900, 600}, {-100, 500}, {200, -100}, {900, -600}});
  const ClientBounds bounds;
  overlay::LayerStyle areaStyle, roadStyle;
  areaStyle.color = glm::vec4(0.95F, 0.55F, 0.15F, 1.0F);
  roadStyle.color = glm::vec4(1.0F, 0.9F, 0.1F, 1.0F);
  roadStyle.opacity = 1.0F;
  roadStyle.widthMetres = 25.0;
  Result<overlay::OverlayLayer> area =
      overlay::OverlayLayer::build("areas", overlay::LayerKind::Polygon, areaStyle, areas, bounds);
  Result<overlay::OverlayLayer> road =
      overlay::OverlayLayer::build("roads", overlay::LayerKind::Line, roadStyle, roads, bounds);
  Result<overlay::OverlayRenderer> overlays = overlay::OverlayRenderer::create();
  if (!area || !road || !overlays) return 1;

  // The client's frame: its camera, its terrain pass, then the overlay.
  const glm::dvec3 eye(-900.0, -1300.0, 900.0);
  const double fov = 0.8, aspect = static_cast<double>(kWidth) / kHeight;
  const glm::dmat4 viewProj =
      gfx::reversedInfinitePerspective(fov, aspect, 1.0) * gfx::lookAt(eye, glm::dvec3(0.0), glm::dvec3(0, 0, 1));
  gfx::StateCache cache;
  gfx::enableReversedZ();
  gfx::RenderTarget target(kWidth, kHeight, 0, true);
  gfx::beginRenderPass(cache, target, {glm::vec4(0.1F, 0.1F, 0.12F, 1.0F), gfx::kReversedZFar, 0});
  gfx::enableMaskWrites(target.framebuffer(), false);
  cache.apply(gfx::kOpaque);
  cache.useProgram(*terrainProgram);
  terrainProgram->set("u_mvp", glm::mat4(viewProj));
  cache.bindVertexArray(vao.id());
  glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(indices.size()), GL_UNSIGNED_INT, nullptr);
  gfx::enableMaskWrites(target.framebuffer(), true);
  const std::vector<const overlay::OverlayLayer*> layers{&*area, &*road};
  overlays->draw(cache, {viewProj, eye, 1.0, fov, aspect}, layers);

  const std::vector<std::uint32_t> mask = gfx::readMask(target);
  std::size_t areaPixels = 0, roadPixels = 0;
  for (std::uint32_t m : mask) {
    areaPixels += m & 1u;
    roadPixels += (m >> 1) & 1u;
  }
  writePpm("client_overlay.ppm", kWidth, kHeight, gfx::readColorRgba8(target));
  const std::size_t errors = (*context)->debug().errorCount();
  std::printf("client_overlay: area %zu pixels, road %zu pixels, %zu GL errors\n", areaPixels, roadPixels, errors);
  return areaPixels > 1000 && roadPixels > 100 && errors == 0 ? 0 : 1;
}
