// The viewer on the globe (docs/viewer.md, "On the globe"): a globe scene read on the worker,
// drawn with globe::GlobeRenderer into the offscreen target, flown with
// scene::GlobeCameraController (grab, orbit, zoom to the cursor from space to a metre above the
// ground, home, north up), with its panel, HUD, status bar, identify, the lasso selection and
// script steps, the measure tool (geodesics on WGS 84) and labels. The projected scene's other
// tools are not on the globe yet: asked for, they say so once and do nothing.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <set>
#include <string>
#include <utility>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <nlohmann/json.hpp>

#include "globe/globe_selection.hpp"
#include "scene/frame_scene.hpp"
#include "viewer.hpp"

namespace gis::viewer {
namespace {

using nlohmann::json;

constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

json geodeticJson(const globe::Geodetic& g) { return {{"lon", g.lon}, {"lat", g.lat}, {"h", g.h}}; }

/// The keys and mouse on the globe (?).
void drawGlobeHelpWindow(bool* open) {
  static const std::array<const char*, 2> kRows[] = {
      {"left drag", "grab the globe: it spins from space, pans near the ground"},
      {"right / middle drag, Ctrl+left drag", "orbit about the target: heading and pitch"},
      {"wheel", "zoom to the point under the cursor (space to 1 m above the ground)"},
      {"click", "identify: lon/lat, height and the features under the cursor"},
      {"L", "lasso tool on/off: drag to select"},
      {"M", "measure tool on/off: click points; geodesic and surface lengths, and the area with the ring closed"},
      {"Backspace", "remove the last measured point"},
      {"lasso + Shift / Ctrl / Ctrl+Shift / Alt", "or / subtract / and / xor"},
      {"I / C", "invert / clear the selection"},
      {"Ctrl+Z / Ctrl+Y", "undo / redo the selection"},
      {"H / Home", "home view"},
      {"N", "north up (or click the compass)"},
      {"arrows", "turn (left, right) and tilt (up, down)"},
      {"F", "fly on/off: W A S D move, Q E down / up, Shift faster, drag to look"},
      {"Page Up / Page Down", "zoom in / out at the centre"},
      {"O", "all vector layers on/off"},
      {"P / U", "panel / HUD on/off"},
      {"Ctrl+O", "open a scene, DEM or vector file"},
      {"F12", "screenshot (PNG, working directory)"},
      {"Esc", "drop the lasso being drawn, the lasso tool, the measured points, the measure tool, help or identify"},
      {"Ctrl+Q", "quit"},
  };
  drawKeysWindow("Keys and mouse on the globe (?)", open, kRows);
}

}  // namespace

void Viewer::useGlobeScene(scene::LoadedGlobeScene loaded, const scene::SceneDescription& description) {
  finishSelection();  // its job reads the scene about to go
  // One scene on the GPU at a time.
  renderer_.reset();
  scene_.reset();
  globe_.reset();
  auto g = std::make_unique<GlobeMode>();
  g->scene = std::move(loaded);
  g->renderer = std::make_unique<globe::GlobeRenderer>(g->scene.heights);
  g->overlaySettings = scene::globeOverlaySettings(g->scene.description);
  scene::GlobeCameraSettings camera;
  camera.fovYDeg = settings_.fovYDeg;
  g->controller = std::make_unique<scene::GlobeCameraController>(g->scene.heights.get(), camera);
  g->shown.assign(g->scene.layers.size(), static_cast<char>(1));
  // The DEM's highest post: no ground a lasso's eye sees lies beyond its horizon reach.
  g->maxGroundHeight = std::max(g->scene.heights->bounds({-180.0, -90.0, 180.0, 90.0}).second, 0.0);
  if (g->scene.imagery) g->renderer->setImagery(g->scene.imagery);
  globe_ = std::move(g);
  description_ = description;
  message("on the globe: " + globe_->scene.reason);
  goHome();
  // The tools start empty again.
  steps_.clear();
  undo_.clear();
  redo_.clear();
  selectionChanged();
  lassoTool_ = false;
  lassoPoints_.clear();
  measureTool_ = false;
  clearMeasure();
  table_.reset();
  outlines_.clear();
  labelSets_.clear();
  labelPlacer_.forget();
  identified_.reset();
  demRange_.reset();
  glfwSetWindowTitle(
      context_->window(),
      ("terrain_viewer — " + (description_->name.empty() ? description_->path : description_->name) + " (globe)")
          .c_str());
}

overlay::OverlayView Viewer::drawGlobe(const glm::ivec2& fb, std::vector<ShownChunks>& shown) {
  GlobeMode& g = *globe_;
  g.view = g.controller->view(fb.x, fb.y);
  std::vector<const globe::GlobeLayer*> layers;
  if (render_.overlays) {
    for (std::size_t i = 0; i < g.scene.layers.size(); ++i) {
      if (g.shown[i] != 0) layers.push_back(&g.scene.layers[i]);
    }
  }
  // GPU timer queries wait for the GPU: sample them (every frame in a script).
  const bool timed = frameIndex_ % 30 == 1 || script_.has_value();
  // Tiles still building are drawn by their nearest ancestor meanwhile, as in a projected frame;
  // scripted screenshots show the finished view.
  g.overlaySettings.waitForTiles = script_.has_value();
  g.overlaySettings.technique =
      scene::globeTechniqueNamed(technique_->name).value_or(globe::GlobeTechnique::StencilTiles);
  g.overlaySettings.textureSize = technique_->usesTextures() ? drapeSize_ : 0;
  const globe::GlobeFrameStats s =
      g.renderer->render(cache_, {target_->framebuffer(), fb.x, fb.y, true}, g.view, layers, timed, g.overlaySettings);
  if (timed) {
    g.stats = s;
  } else {
    const double terrainMs = g.stats.terrainGpuMilliseconds, overlayMs = g.stats.overlayGpuMilliseconds;
    g.stats = s;
    g.stats.terrainGpuMilliseconds = terrainMs;
    g.stats.overlayGpuMilliseconds = overlayMs;
  }
  if (debugPieces_ && render_.overlays) {
    // The same debug view of pieces as in a projected frame, on the tiles' chunks.
    if (overlay::OverlayRenderer* overlays = g.renderer->overlay().renderer()) {
      for (const globe::GlobeLayer* layer : layers) {
        shown.push_back(
            {overlays, g.renderer->overlay().chunks(g.view, g.renderer->tiles(), g.renderer->heights(), *layer)});
      }
    }
  }
  // The globe builds the meshes a frame needs in that frame; the layers' tiles come from the
  // workers and imagery a few tiles a frame: draw again until it is all there.
  busy_ = s.terrain.imageryPending > 0 || s.overlay.missingTiles > 0;
  return globe::overlayViewOf(g.view);
}

std::vector<Identified::Hit> Viewer::globeFeaturesAt(const GroundPoint& point) const {
  const GlobeMode& g = *globe_;
  std::vector<Identified::Hit> hits;
  std::set<std::pair<std::size_t, std::uint32_t>> seen;  // a fill and its outline name a feature once
  for (std::size_t i = 0; i < g.scene.layers.size(); ++i) {
    if (g.shown[i] == 0) continue;
    const std::size_t fileIndex = g.scene.layerFileIndex[i];
    const scene::LayerDescription* described = scene::sceneLayerOf(g.scene, i);
    for (const std::uint32_t f : globe::featuresAt(g.scene.layers[i], point.drawn, point.lonLatH->x, point.lonLatH->y,
                                                   globe::pixelScaleOf(g.view))) {
      if (!seen.insert({fileIndex, f}).second) continue;
      Identified::Hit hit;
      hit.layer = described != nullptr ? described->name : g.scene.layers[i].name();
      hit.feature = f;
      if (i < g.scene.layerFeatures.size() && f < g.scene.layerFeatures[i].size()) {
        const std::shared_ptr<const geo::Feature> feature = g.scene.layerFeatures[i].get(f);
        hit.fid = feature->fid;
        for (const auto& [k, v] : feature->attributes) hit.attributes.emplace_back(k, attributeText(v));
      }
      hits.push_back(std::move(hit));
    }
  }
  return hits;
}

void Viewer::drawGlobeHelp() { drawGlobeHelpWindow(&showHelp_); }

void Viewer::drawGlobeView() {
  GlobeMode& g = *globe_;
  if (ImGui::Button("Home (H)")) goHome();
  rememberRect("globe_home");
  ImGui::SameLine();
  if (ImGui::Button("North up (N)")) northUp();
  const scene::GlobePose& pose = g.controller->pose();
  ImGui::Text("heading %.1f°, pitch %.1f°", pose.heading / kRadiansPerDegree, pose.pitch / kRadiansPerDegree);
  ImGui::Text("%s to the target", formatMetres(pose.distance).c_str());
  drawExaggerationSlider();
}

void Viewer::drawGlobeHud() {
  const GlobeMode& g = *globe_;
  beginHud();
  ImGui::Text("globe terrain: %zu triangles, %zu tiles, GPU %.2f ms", g.stats.terrain.triangles, g.stats.terrain.tiles,
              g.stats.terrainGpuMilliseconds);
  if (!render_.overlays) {
    ImGui::TextColored(ImVec4(1.0F, 0.8F, 0.2F, 1.0F), "overlays off (O)");
  } else if (g.stats.overlay.draped) {
    ImGui::Text("overlays: draped by the terrain, %zu textures built, %.0f MB", g.stats.overlay.texturesBuilt,
                static_cast<double>(g.stats.overlay.drapeGpuBytes) / 1048576.0);
  } else {
    ImGui::Text("overlays: GPU %.2f ms, %zu pieces, %zu z-fail", g.stats.overlayGpuMilliseconds, g.stats.overlay.pieces,
                g.stats.overlay.zFailPieces);
    if (g.stats.overlay.deferredPending > 0) {
      ImGui::TextColored(ImVec4(1.0F, 0.8F, 0.2F, 1.0F), "deferred lookup: %zu index%s building (drawn as pieces)",
                         g.stats.overlay.deferredPending, g.stats.overlay.deferredPending == 1 ? "" : "es");
    }
    if (g.stats.overlay.deferredLayers > 0) {
      ImGui::Text("deferred lookup: %zu layer%s, %.0f MB of indices", g.stats.overlay.deferredLayers,
                  g.stats.overlay.deferredLayers == 1 ? "" : "s",
                  static_cast<double>(g.stats.overlay.deferredBytes) / 1048576.0);
    }
  }
  const globe::Geodetic eye = globe::toGeodetic(g.controller->eye());
  ImGui::Text("eye: lon %.6f°, lat %.6f°, height %s above ground, %s above the ellipsoid", eye.lon, eye.lat,
              formatMetres(g.controller->heightAboveGround()).c_str(), formatMetres(eye.h).c_str());
  ImGui::End();
}

json Viewer::globeStateJson() const {
  const GlobeMode& g = *globe_;
  const scene::GlobePose& pose = g.controller->pose();
  const globe::Geodetic eye = globe::toGeodetic(g.controller->eye());
  return {{"camera_mode", g.fly ? "fly" : "orbit"},
          {"globe_reason", g.scene.reason},
          {"globe",
           {{"target", geodeticJson(pose.target)},
            {"distance", pose.distance},
            {"heading", pose.heading},
            {"pitch", pose.pitch},
            {"heading_deg", pose.heading / kRadiansPerDegree},
            {"pitch_deg", pose.pitch / kRadiansPerDegree},
            {"eye", geodeticJson(eye)},
            {"eye_height_above_ground", g.controller->heightAboveGround()},
            {"exaggeration", g.scene.heights->exaggeration()},
            {"extent", {g.scene.extent[0], g.scene.extent[1], g.scene.extent[2], g.scene.extent[3]}},
            {"camera", scene::globeCameraJson(g.view)}}},
          {"drawn",
           {{"ms", frameMs_},
            {"terrain_triangles", g.stats.terrain.triangles},
            {"overlay_fragments", g.stats.overlayFragments},
            {"selection_ms", selectionMs_}}},
          {"terrain", {{"tiles", g.stats.terrain.tiles}, {"triangles", g.stats.terrain.triangles}}},
          {"overlay",
           {{"pieces", g.stats.overlay.pieces},
            {"z_fail_pieces", g.stats.overlay.zFailPieces},
            {"deferred_layers", g.stats.overlay.deferredLayers},
            {"deferred_pending", g.stats.overlay.deferredPending},
            {"draped", g.stats.overlay.draped}}}};
}

}  // namespace gis::viewer
