// terrain_viewer: the desktop viewer (GLFW + Dear ImGui). Orbit with the left mouse button,
// pan with the right one, zoom with the wheel; H returns home; Esc quits.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <string_view>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include "app/camera.hpp"
#include "app/scene.hpp"
#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "core/log.hpp"
#include "gfx/context.hpp"
#include "terrain/tile_pager.hpp"

namespace {

using namespace gis;

/// Orbit around a target: yaw about +z, pitch above the horizon, distance.
struct Orbit {
  glm::dvec3 target{0.0};
  double yaw = 0.0;
  double pitch = 0.6;
  double distance = 1000.0;

  [[nodiscard]] app::Camera camera(double fovYDeg) const {
    app::Camera c;
    c.target = target;
    c.eye = target +
            distance * glm::dvec3(std::cos(pitch) * std::sin(yaw), -std::cos(pitch) * std::cos(yaw), std::sin(pitch));
    c.fovYDeg = fovYDeg;
    c.nearPlane = std::max(0.1, distance * 1e-3);
    return c;
  }
};

Orbit orbitFrom(const app::Camera& c) {
  Orbit o;
  o.target = c.target;
  const glm::dvec3 d = c.eye - c.target;
  o.distance = glm::length(d);
  o.pitch = std::asin(std::clamp(d.z / o.distance, -1.0, 1.0));
  o.yaw = std::atan2(d.x, -d.y);
  return o;
}

struct Input {
  double lastX = 0.0, lastY = 0.0;
  bool rotating = false, panning = false;
  double scroll = 0.0;
};
Input gInput;

void onScroll(GLFWwindow*, double, double dy) { gInput.scroll += dy; }

int runViewer(const std::string& scenePath) {
  Result<app::SceneDescription> description = app::loadSceneFile(scenePath);
  for (const Diagnostic& d : description.diagnostics.items()) logWarning(d.toString());
  if (!description) return 1;
  Result<app::LoadedScene> scene = app::loadScene(*description);
  for (const Diagnostic& d : scene.diagnostics.items()) logWarning(d.toString());
  if (!scene) return 1;

  gfx::ContextOptions options;
  options.title = "terrain_viewer — " + (description->name.empty() ? scenePath : description->name);
  options.debug = false;
  Result<std::unique_ptr<gfx::Context>> context = gfx::createWindowContext(options);
  if (!context) {
    for (const Diagnostic& d : context.diagnostics.items()) logError(d.toString());
    return 1;
  }
  GLFWwindow* window = (*context)->window();
  glfwSetScrollCallback(window, onScroll);
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene);
  if (!renderer) {
    for (const Diagnostic& d : renderer.diagnostics.items()) logError(d.toString());
    return 1;
  }

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 450 core");

  glm::dvec3 boxMin, boxMax;
  app::RenderSettings settings;
  settings.verticalExaggeration = description->verticalExaggeration;
  app::terrainBox(*scene, settings.verticalExaggeration, boxMin, boxMax);
  const app::Camera home = app::overviewCamera(boxMin, boxMax);
  Orbit orbit = orbitFrom(home);
  double fovY = home.fovYDeg;
  gfx::StateCache cache;
  app::FrameStats stats;
  int frameIndex = 0;
  double lastTime = glfwGetTime();
  double smoothedFrameMs = 16.0;

  while (!glfwWindowShouldClose(window)) {
    glfwPollEvents();
    const double now = glfwGetTime();
    smoothedFrameMs = 0.9 * smoothedFrameMs + 0.1 * (now - lastTime) * 1000.0;
    lastTime = now;

    ImGuiIO& io = ImGui::GetIO();
    double x = 0.0, y = 0.0;
    glfwGetCursorPos(window, &x, &y);
    if (!io.WantCaptureMouse) {
      gInput.rotating = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
      gInput.panning = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
      const double dx = x - gInput.lastX, dy = y - gInput.lastY;
      if (gInput.rotating) {
        orbit.yaw -= dx * 0.005;
        orbit.pitch = std::clamp(orbit.pitch + dy * 0.005, 0.02, std::numbers::pi / 2 - 0.01);
      } else if (gInput.panning) {
        const double scale = orbit.distance * 0.0015;
        const glm::dvec3 right(std::cos(orbit.yaw), std::sin(orbit.yaw), 0.0);
        const glm::dvec3 forward(-std::sin(orbit.yaw), std::cos(orbit.yaw), 0.0);
        orbit.target += (-dx * right + dy * forward) * scale;
      }
      if (gInput.scroll != 0.0) orbit.distance = std::clamp(orbit.distance * std::pow(0.9, gInput.scroll), 10.0, 1e7);
    }
    gInput.scroll = 0.0;
    gInput.lastX = x;
    gInput.lastY = y;
    if (!io.WantCaptureKeyboard) {
      if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS) glfwSetWindowShouldClose(window, GLFW_TRUE);
      if (glfwGetKey(window, GLFW_KEY_H) == GLFW_PRESS) orbit = orbitFrom(home);
    }

    const glm::ivec2 size = (*context)->framebufferSize();
    if (size.x > 0 && size.y > 0) {
      settings.measure = frameIndex++ % 30 == 0;  // queries wait for the GPU: sample them
      const app::FrameStats s = renderer->render(cache, 0, size.x, size.y, orbit.camera(fovY), settings);
      if (settings.measure) {
        stats = s;
      } else {
        stats.terrainDraw = s.terrainDraw;
        stats.finestLevel = s.finestLevel;
        stats.coarsestLevel = s.coarsestLevel;
        stats.tilesMissing = s.tilesMissing;
        stats.pager = s.pager;
      }
    }

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
    ImGui::Begin("Scene");
    ImGui::Text("%s", description->name.c_str());
    ImGui::Text("%.1f fps (%.2f ms)", 1000.0 / smoothedFrameMs, smoothedFrameMs);
    ImGui::Text("terrain: %zu chunks (levels %d-%d), %zu triangles", stats.terrainDraw.chunks, stats.finestLevel,
                stats.coarsestLevel, stats.terrainDraw.triangles);
    ImGui::Text("terrain GPU %.2f ms, %.1f MiB cached", stats.terrain.gpuMilliseconds,
                static_cast<double>(renderer->terrainEngine().gpuBytes()) / (1024.0 * 1024.0));
    if (scene->paged()) {
      ImGui::Text("tiles: %zu resident (%.0f of %.0f MiB), %zu loading", stats.pager.residentTiles,
                  static_cast<double>(stats.pager.residentBytes) / (1024.0 * 1024.0),
                  static_cast<double>(scene->quadtree->pager()->budgetBytes()) / (1024.0 * 1024.0),
                  stats.pager.pending);
    }
    float tolerance = static_cast<float>(settings.lodTolerancePixels);
    if (ImGui::SliderFloat("LOD tolerance (px)", &tolerance, 0.25F, 16.0F, "%.2f", ImGuiSliderFlags_Logarithmic)) {
      settings.lodTolerancePixels = static_cast<double>(tolerance);
    }
    float exaggeration = static_cast<float>(settings.verticalExaggeration);
    if (ImGui::SliderFloat("vertical exaggeration", &exaggeration, 0.1F, 20.0F, "%.1f", ImGuiSliderFlags_Logarithmic)) {
      settings.verticalExaggeration = static_cast<double>(exaggeration);
    }
    ImGui::Checkbox("wireframe", &settings.wireframe);
    ImGui::Text("fragments: %llu", static_cast<unsigned long long>(stats.terrain.counts.fragmentShaderInvocations));
    float fov = static_cast<float>(fovY);
    if (ImGui::SliderFloat("field of view", &fov, 10.0F, 90.0F)) fovY = static_cast<double>(fov);
    if (ImGui::Button("Home (H)")) orbit = orbitFrom(home);
    ImGui::Separator();
    ImGui::Checkbox("vector layers", &settings.overlays);
    for (const app::LoadedLayer& layer : scene->layers) {
      ImGui::BulletText("%s: %zu features, %zu vertices", layer.description.name.c_str(), layer.data.features.size(),
                        layer.data.vertexCount());
    }
    ImGui::End();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    cache.invalidate();  // ImGui changed GL state behind the cache's back
    (*context)->swapBuffers();
  }

  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene = "samples/olinda/scene.json";
  if (argc >= 2) {
    const std::string_view a = argv[1];
    if (a == "--help" || a == "-h") {
      std::puts("usage: terrain_viewer [SCENE.json]\nOrbit: left mouse; pan: right mouse; zoom: wheel; H: home.");
      return 0;
    }
    scene = argv[1];
  }
  if (!gfx::windowSystemAvailable()) {
    std::fprintf(stderr,
                 "terrain_viewer: no display to open a window on (DISPLAY is not set or not reachable).\n"
                 "Render the scene headless instead:\n"
                 "  overlay_render --scene %s --out out/\n",
                 scene.c_str());
    return 3;
  }
  return runViewer(scene);
}
