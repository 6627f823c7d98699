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
/// Orbit (right drag, Ctrl+left drag): radians of heading and pitch per pixel.
constexpr double kOrbitPerPixel = 0.005;
constexpr double kLookPerPixel = 0.003;  ///< fly: radians the view turns per pixel dragged (a projected frame's)
/// Arrow keys: heading and pitch steps, radians.
constexpr double kArrowHeading = 10.0 * kRadiansPerDegree;
constexpr double kArrowPitch = 5.0 * kRadiansPerDegree;

/// The pose that looks at `target` from `eye` (ECEF): its distance, and heading and pitch in the
/// target's east-north-up frame (scene::GlobePose).
scene::GlobePose poseLooking(const glm::dvec3& eye, const glm::dvec3& target) {
  scene::GlobePose p;
  p.target = globe::toGeodetic(target);
  const glm::dvec3 d = eye - target;
  p.distance = glm::length(d);
  if (!(p.distance > 0.0)) return p;
  const glm::dmat3 enu = globe::enuBasis(p.target.lon, p.target.lat);
  const glm::dvec3 local(glm::dot(d, enu[0]), glm::dot(d, enu[1]), glm::dot(d, enu[2]));
  p.pitch = std::asin(std::clamp(local.z / p.distance, -1.0, 1.0));
  // The view looks along −d: its heading is that of (−east, −north). Looking straight down (within
  // the rounding of the ECEF points) it has none: north up.
  p.heading = std::hypot(local.x, local.y) <= 1e-9 * p.distance ? 0.0 : std::atan2(-local.x, -local.y);
  return p;
}

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

void Viewer::globeHome() {
  GlobeMode& g = *globe_;
  const glm::ivec2 fb = framebufferSize();
  const std::optional<scene::CameraSpec>& spec = g.scene.description.camera;
  if (spec && spec->eyeLonLatH && spec->targetLonLatH) {
    // The scene's own camera, as its author placed it, seen in the part of the window the panel
    // leaves free.
    const globe::GlobeView v = scene::globeStillView(g.scene, std::max(fb.x, 1), std::max(fb.y, 1));
    g.controller->setPose(poseLooking(v.eye, v.target));
    g.controller->centreIn(glm::ivec2(std::max(fb.x, 1), std::max(fb.y, 1)), freeRegion());
    return;
  }
  const std::array<double, 4>& e = g.scene.extent;
  // Framed in the part of the window the panel leaves free, as in a projected frame.
  g.controller->home(e[0], e[1], e[2], e[3], glm::ivec2(std::max(fb.x, 1), std::max(fb.y, 1)), freeRegion());
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

void Viewer::handleGlobeInput(double seconds, const InputFrame& in) {
  GlobeMode& g = *globe_;
  scene::GlobeCameraController& c = *g.controller;
  const glm::ivec2 fb = framebufferSize();
  if (!in.uiMouse) {
    const glm::dvec2 pixel = in.cursor, last = lastPixel_;
    if (in.left && !leftDown_) {
      pressCursor_ = pixel;
      dragged_ = false;
      if (lassoTool_) lassoPoints_.assign(1, pixel);
    }
    // With the lasso tool a left drag draws the lasso (as in a projected scene): every cursor
    // position taken in the frame, so a fast drag keeps its shape.
    const bool lassoing = lassoTool_ && in.left && !lassoPoints_.empty();
    if (lassoing) {
      if (glm::length(pixel - pressCursor_) > 3.0) dragged_ = true;
      for (const glm::dvec2& p : in.cursorPath) {
        if (glm::length(p - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(p);
      }
      if (glm::length(pixel - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(pixel);
    }
    // A drag starts once the cursor is 3 px from the press; the globe then follows it from there.
    const bool leftDrags = in.left && leftDown_ && !lassoTool_;
    const bool dragStarts = leftDrags && !dragged_ && glm::length(pixel - pressCursor_) > 3.0;
    if (dragStarts) dragged_ = true;
    const bool orbit =
        (in.right && rightDown_) || (in.middle && middleDown_) || (leftDrags && dragged_ && in.modifiers.ctrl);
    if (g.fly && (orbit || (leftDrags && dragged_))) {
      // Fly: every drag turns the view about the eye (as a projected frame's fly does).
      const glm::dvec2 move = dragStarts ? pixel - pressCursor_ : pixel - last;
      if (move != glm::dvec2(0.0)) c.look(move.x * kLookPerPixel, move.y * kLookPerPixel);
    } else if (orbit) {
      const glm::dvec2 move = dragStarts ? pixel - pressCursor_ : pixel - last;
      if (move != glm::dvec2(0.0)) c.orbit(move.x * kOrbitPerPixel, move.y * kOrbitPerPixel);
    } else if (leftDrags && dragged_) {
      const glm::dvec2 from = dragStarts ? pressCursor_ : last;
      if (from != pixel) c.grab(from, pixel, fb);
    }
    if (!in.left && leftDown_) {
      if (lassoTool_ && lassoPoints_.size() >= 3) {
        overlay::SelectionOp op = lassoOpOf(in.modifiers);
        if (steps_.empty() && op != overlay::SelectionOp::Single) op = overlay::SelectionOp::Single;
        addLasso(op, std::exchange(lassoPoints_, {}));
      } else if (!dragged_ && measureTool_) {
        if (const std::optional<glm::dvec2> ground = measurePointAt(pixel)) addMeasurePoint(*ground);
      } else if (!dragged_) {
        identified_ = identify(pixel);
      }
      lassoPoints_.clear();
    }
    if (in.scroll != 0.0) c.zoomToCursor(in.scroll, pixel, fb);
  }
  leftDown_ = in.left;
  rightDown_ = in.right;
  middleDown_ = in.middle;
  lastPixel_ = in.cursor;
  if (!in.uiKeyboard && g.fly) {
    // The keys of a projected frame's fly: WASD over the ground, Q and E down and up, Shift faster.
    auto key = [&](int k) { return std::find(in.held.begin(), in.held.end(), k) != in.held.end() ? 1.0 : 0.0; };
    const glm::dvec3 move(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_W) - key(GLFW_KEY_S),
                          key(GLFW_KEY_E) - key(GLFW_KEY_Q));
    if (move != glm::dvec3(0.0)) c.fly(move * (in.modifiers.shift ? 4.0 : 1.0), seconds);
  }
  if (!in.uiKeyboard) {
    for (const InputFrame::KeyPress& k : in.pressed) globeKeyPressed(k.key, k.modifiers);
  }
}

void Viewer::globeKeyPressed(int key, const app::Modifiers& modifiers) {
  GlobeMode& g = *globe_;
  scene::GlobeCameraController& c = *g.controller;
  const glm::ivec2 fb = framebufferSize();
  switch (key) {
    case GLFW_KEY_ESCAPE:
      // Backs out of one thing at a time, as in a projected scene.
      if (!lassoPoints_.empty()) {
        lassoPoints_.clear();
      } else if (lassoTool_) {
        lassoTool_ = false;
      } else if (!measurePoints_.empty()) {
        clearMeasure();
      } else if (measureTool_) {
        measureTool_ = false;
      } else if (showHelp_) {
        showHelp_ = false;
      } else if (identified_) {
        identified_.reset();
      }
      break;
    case GLFW_KEY_H:
    case GLFW_KEY_HOME:
      goHome();
      break;
    case GLFW_KEY_N:
      northUp();
      break;
    case GLFW_KEY_LEFT:
      c.orbit(-kArrowHeading, 0.0);
      break;
    case GLFW_KEY_RIGHT:
      c.orbit(kArrowHeading, 0.0);
      break;
    case GLFW_KEY_UP:
      c.orbit(0.0, -kArrowPitch);
      break;
    case GLFW_KEY_DOWN:
      c.orbit(0.0, kArrowPitch);
      break;
    case GLFW_KEY_PAGE_UP:
      c.zoomToCursor(1.0, glm::dvec2(fb) * 0.5, fb);
      break;
    case GLFW_KEY_PAGE_DOWN:
      c.zoomToCursor(-1.0, glm::dvec2(fb) * 0.5, fb);
      break;
    case GLFW_KEY_F:
      g.fly = !g.fly;
      message(g.fly ? "fly: W A S D move, Q E down and up, Shift faster, drag to look" : "orbit");
      break;
    default:
      sharedKeyPressed(key, modifiers);
      break;
  }
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
