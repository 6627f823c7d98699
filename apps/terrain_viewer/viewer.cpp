#include "viewer.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <system_error>
#include <utility>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include "app/cli.hpp"
#include "core/log.hpp"
#include "gfx/window_context.hpp"
#include "scene/scene.hpp"
#include "terrain/elevation_ramp.hpp"

namespace gis::viewer {
namespace {

/// Scripted runs advance time by a fixed step per frame, so keyframes take the same frames on
/// any machine.
constexpr double kScriptFrameSeconds = 1.0 / 30.0;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool isRasterFile(const std::string& path) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  return ext == ".tif" || ext == ".tiff" || ext == ".asc" || ext == ".img" || ext == ".vrt" || ext == ".hgt" ||
         ext == ".dem" || ext == ".bil";
}

/// The panel's font: DejaVu Sans (Debian's fonts-dejavu-core) at 15 px, with what the panel
/// writes beyond ASCII: Latin-1 and Latin Extended, punctuation (…, –), super- and subscripts
/// (²), arrows (→), mathematical operators (×, ≤) and geometric shapes (▲ of the compass).
/// ImGui's built-in font (13 px, ASCII only) is the fallback, said once.
std::string loadFont(float scale) {
  static const ImWchar kRanges[] = {0x0020, 0x024F, 0x2000, 0x206F, 0x2070, 0x209F, 0x2190,
                                    0x21FF, 0x2200, 0x22FF, 0x25A0, 0x25FF, 0};
  ImGuiIO& io = ImGui::GetIO();
  for (const char* path : {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"}) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) continue;
    if (io.Fonts->AddFontFromFileTTF(path, 15.0F * scale, nullptr, kRanges) != nullptr) return path;
  }
  logWarning("terrain_viewer: DejaVu Sans not found (Debian: fonts-dejavu-core); the panel uses ImGui's small font");
  io.Fonts->AddFontDefault();
  io.FontGlobalScale = scale;
  return "ImGui's built-in font";
}

bool isVectorFile(const std::string& path) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  return ext == ".geojson" || ext == ".shp" || ext == ".gpkg" || ext == ".kml" || ext == ".gml" || ext == ".csv" ||
         ext == ".fgb" || ext == ".gpx";
}

}  // namespace

Viewer::~Viewer() {
  if (selectionJob_.valid()) selectionJob_.wait();  // it reads the scene and the layers
  if (loading_) loading_->wait();
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  // GL objects go while the context is current.
  selectionRenderer_.reset();
  globe_.reset();
  target_.reset();
  renderer_.reset();
}

int Viewer::run(const ViewerOptions& options) {
  Viewer v;
  if (!v.open(options)) return 1;
  GLFWwindow* window = v.context_->window();
  double last = glfwGetTime();
  while (!glfwWindowShouldClose(window) && !v.quit_) {
    // Draw on change; otherwise sleep until an event (input, a drop, an expose, a resize), or
    // until work in the background may have finished.
    const double wait = v.idleWait();
    const bool waited = wait > 0.0;
    if (!waited) {
      glfwPollEvents();
    } else if (std::isinf(wait)) {
      glfwWaitEvents();
    } else {
      glfwWaitEventsTimeout(wait);
    }
    // Woken with nothing to draw: look at the work in the background, and sleep again unless it
    // changed something.
    if (waited && !v.needsFrame()) {
      v.idleTick();
      if (!v.needsFrame()) continue;
    }
    const double now = glfwGetTime();
    // After a sleep the time since the last frame is no frame time, and no step for motion.
    const double elapsed = waited ? std::min(now - last, 1.0 / 60.0) : now - last;
    const double seconds = v.script_ ? kScriptFrameSeconds : std::clamp(elapsed, 0.0, 0.25);
    if (!waited) v.frameMs_ = 0.9 * v.frameMs_ + 0.1 * elapsed * 1000.0;
    last = now;
    v.frame(seconds);
  }
  if (!v.script_) {
    glm::ivec2 size(0);
    glfwGetWindowSize(window, &size.x, &size.y);
    if (size.x > 0 && size.y > 0) v.settings_.windowSize = size;
    if (const auto path = app::settingsPath()) {
      app::report(app::saveViewerSettings(v.settings_, *path));
    }
  }
  const std::size_t glErrors = v.context_->debug().errorCount();
  if (v.script_ && glErrors > 0) {
    logError("terrain_viewer: " + std::to_string(glErrors) + " GL error(s) during the script");
    return 1;
  }
  return v.scriptFailed_ ? 1 : 0;
}

bool Viewer::open(const ViewerOptions& options) {
  options_ = options;
  if (options.script) {
    Result<app::ViewerScript> script = app::loadViewerScript(*options.script);
    app::report(script.diagnostics);
    if (!script) return false;
    script_ = std::move(*script);
  } else if (const auto path = app::settingsPath()) {
    Result<app::ViewerSettings> loaded = app::loadViewerSettings(*path);
    app::report(loaded.diagnostics);
    settings_ = *loaded;
  }
  gfx::ContextOptions context;
  const glm::ivec2 size = script_ && script_->window ? *script_->window : settings_.windowSize;
  context.width = size.x;
  context.height = size.y;
  context.title = "terrain_viewer";
  context.debug = true;
  context.vsync = !script_;
  Result<std::unique_ptr<gfx::Context>> created = gfx::createWindowContext(context);
  if (!created) {
    app::report(created.diagnostics);
    return false;
  }
  context_ = std::move(*created);
  GLFWwindow* window = context_->window();
  installCallbacks();

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // our settings file keeps what matters
  // High-DPI: scale the panel with the monitor's content scale; the font is rasterised at it.
  float scaleX = 1.0F, scaleY = 1.0F;
  glfwGetWindowContentScale(window, &scaleX, &scaleY);
  const float scale = std::max(scaleX, 1.0F);
  if (scale > 1.0F) ImGui::GetStyle().ScaleAllSizes(scale);
  font_ = loadFont(scale);
  ImGui_ImplGlfw_InitForOpenGL(window, false);  // our queue passes it the events (takeInput)
  ImGui_ImplOpenGL3_Init("#version 450 core");
  imgui_ = true;

  Result<overlay::SelectionRenderer> selection = overlay::SelectionRenderer::create();
  app::report(selection.diagnostics);
  if (!selection) return false;
  selectionRenderer_ = std::move(*selection);
  // Tiles still building are drawn by their nearest ancestor meanwhile; scripted screenshots show
  // the finished view.
  render_.waitForTiles = script_.has_value();
  // A scene that does not load leaves the window open with the messages, ready for another.
  loadPath(options.scene);
  return true;
}

bool Viewer::loadPath(const std::string& path) {
  if (isVectorFile(path)) {
    if (!description_) {
      // A vector file alone: over flat ground covering its extent.
      Result<scene::SceneDescription> alone = scene::sceneForVectorFile(path);
      message(alone.diagnostics);
      return alone && useScene(std::move(*alone));
    }
    // A new layer of the current scene, in either frame: its kind from what the file holds.
    // After every layer of the scene, those its file left out included.
    std::size_t next = description_->layers.size();
    for (const scene::LayerDescription& l : description_->layers) next = std::max(next, l.fileIndex + 1);
    const geo::SceneFrame frame = globe_ ? geo::SceneFrame::wgs84LonLat() : projected().frame;
    Result<std::vector<scene::LayerDescription>> layers = scene::layersForVectorFile(path, frame, next);
    message(layers.diagnostics);
    if (!layers) return false;
    scene::SceneDescription grown = *description_;
    grown.layers.insert(grown.layers.end(), layers->begin(), layers->end());
    return useScene(std::move(grown));
  }
  std::error_code ec;
  if (isRasterFile(path) || std::filesystem::is_directory(path, ec)) return useScene(scene::sceneForDem(path));
  Result<scene::SceneDescription> description = scene::loadSceneFile(path);
  message(description.diagnostics);
  if (!description) return false;
  return useScene(std::move(*description));
}

bool Viewer::useScene(scene::SceneDescription description) {
  // Read on a worker (DEM, tile pyramid, imagery, vector layers: no GL) while the window keeps
  // drawing, with a progress bar; the GPU part follows on this thread when it is done.
  auto load = std::make_unique<PendingLoad>();
  load->progress = std::make_shared<std::atomic<double>>(-1.0);
  load->started = glfwGetTime();
  load->label = description.name.empty() ? description.path : description.name;
  // Read in the frame its data's extent asks for (scene::globeReason): projected, or on the globe.
  scene::LoadOptions options;
  options.progress = [progress = load->progress](double fraction) { progress->store(fraction); };
  load->job =
      std::async(std::launch::async, [description, options] { return scene::Scene::load(description, options); });
  load->description = std::move(description);
  loading_ = std::move(load);
  return true;
}

void Viewer::finishLoad(bool wait) {
  if (!loading_ || (!wait && !loading_->ready())) return;
  const std::unique_ptr<PendingLoad> load = std::move(loading_);
  Result<scene::Scene> loaded = load->job.get();
  lastLoadProgress_ = load->progress->load();
  message(loaded.diagnostics);
  if (!loaded) return;
  finishSelection();  // its job reads the scene about to go
  // Drop the old renderer before building the new one: GPU memory for one scene at a time.
  renderer_.reset();
  globe_.reset();
  if (!showScene(std::move(*loaded), load->description)) return;
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
  glfwSetWindowTitle(context_->window(),
                     ("terrain_viewer — " + (description_->name.empty() ? description_->path : description_->name) +
                      (globe_ ? " (globe)" : ""))
                         .c_str());
}

bool Viewer::showScene(scene::Scene loaded, const scene::SceneDescription& description) {
  // The scene first, in its place: its renderer keeps a reference to it.
  scene_ = std::move(loaded);
  scene::StillSettings settings;
  settings.technique = technique_;
  settings.textureSize = drapeSize_;
  settings.lodTolerancePixels = settings_.lodTolerancePixels;
  Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(*scene_, settings);
  message(renderer.diagnostics);
  if (!renderer) {
    scene_.reset();  // no renderer for it
    description_.reset();
    return false;
  }
  renderer_ = std::move(*renderer);
  description_ = description;
  figures_ = {};
  if (scene_->onGlobe()) {
    // The globe's camera (its own controller: the globe turns under the eye).
    auto g = std::make_unique<GlobeMode>();
    scene::GlobeCameraSettings camera;
    camera.fovYDeg = settings_.fovYDeg;
    g->controller = std::make_unique<scene::GlobeCameraController>(globeScene().heights.get(), camera);
    globe_ = std::move(g);
    message("on the globe: " + globeScene().reason);
    goHome();
    demRange_.reset();
    return true;
  }
  projected().bounds->setExaggeration(description_->verticalExaggeration);
  const scene::Camera home = homeCamera();
  if (controller_) {
    controller_->setHome(home);
    controller_->jumpTo(home);
  } else {
    controller_.emplace(home);
  }
  demRange_ = terrain::demHeightRange(*projected().quadtree);
  return true;
}

void Viewer::notify(const std::string& text, bool error) {
  said_.erase((error && text.rfind("error: ", 0) != 0 ? "error: " : "") + text);  // said again, each time
  message(text, error);
  notice_ = Notice{text, glfwGetTime() + 4.0, error};
}

void Viewer::expireNotice() {
  if (notice_ && glfwGetTime() > notice_->until) notice_.reset();
}

void Viewer::drawLoading() {
  // A load that takes more than a moment; scripted runs show it at once (a test sees it).
  if (!loading_ || glfwGetTime() - loading_->started < (script_ ? 0.0 : 0.3)) return;
  ++loadingFramesShown_;
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(ImVec2(viewport->GetCenter().x, viewport->WorkPos.y + 0.3F * viewport->WorkSize.y),
                          ImGuiCond_Always, ImVec2(0.5F, 0.5F));
  ImGui::SetNextWindowSize(ImVec2(std::min(30.0F * ImGui::GetFontSize(), viewport->WorkSize.x * 0.8F), 0.0F));
  ImGui::Begin("Loading", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoSavedSettings);
  ImGui::TextWrapped("Loading %s", loading_->label.c_str());
  const double fraction = loading_->progress->load();
  if (fraction >= 0.0) {
    // Only a tile pyramid's build reports how far it is.
    char text[64];
    std::snprintf(text, sizeof(text), "building the tile pyramid: %.0f %%", 100.0 * fraction);
    ImGui::ProgressBar(static_cast<float>(fraction), ImVec2(-1.0F, 0.0F), text);
  } else {
    ImGui::TextDisabled("%.0f s", glfwGetTime() - loading_->started);
  }
  ImGui::End();
}

glm::dvec4 Viewer::freeRegion() const {
  const glm::ivec2 fb = framebufferSize();
  const ImGuiIO& io = ImGui::GetIO();
  const glm::dvec2 scale(io.DisplayFramebufferScale.x > 0.0F ? io.DisplayFramebufferScale.x : 1.0F,
                         io.DisplayFramebufferScale.y > 0.0F ? io.DisplayFramebufferScale.y : 1.0F);
  double left = 0.0;
  if (settings_.showPanel) {
    // The panel as last drawn, or as it will first be drawn (drawPanel).
    const double font = panelFont_ > 0.0F ? panelFont_ : 15.0;
    const double windowWidth = fb.x / scale.x;
    const double right = panelRight_ > 0.0F ? panelRight_ : 10.0 + std::min(26.0 * font, 0.6 * windowWidth);
    left = std::min(right * scale.x, 0.7 * fb.x);
  }
  // The status bar's line at the bottom.
  const double bottom = fb.y - 1.6 * (panelFont_ > 0.0F ? panelFont_ : 15.0) * scale.y;
  return {left, 0.0, fb.x, std::max(bottom, 0.5 * fb.y)};
}

scene::Camera Viewer::homeCamera() const {
  // The scene's own camera as its author placed it; otherwise the terrain framed in the part of
  // the window the panel leaves free.
  if (description_->camera) {
    Result<scene::Camera> placed = scene::placeCamera(*description_->camera, projected().frame, description_->path);
    if (placed) return *placed;
  }
  glm::dvec3 lo, hi;
  scene::terrainBox(projected(), projected().bounds->exaggeration(), lo, hi);
  const scene::Camera overview = scene::overviewCamera(lo, hi, settings_.fovYDeg);
  return scene::frameBoxInRegion(overview, lo, hi, framebufferSize(), freeRegion());
}

void Viewer::goHome() {
  if (globe_) {
    globeHome();
    return;
  }
  controller_->setHome(homeCamera());
  controller_->goHome();
}

void Viewer::message(const std::string& text, bool error) {
  // Diagnostics say "error: " themselves.
  std::string line = (error && text.rfind("error: ", 0) != 0 ? "error: " : "") + text;
  // Said once: a repeat (the same warning at each rebuild) only counts.
  if (++said_[line] > 1) return;
  (error ? logError : logInfo)(text);
  messages_.push_back(std::move(line));
  if (messages_.size() > 200) messages_.erase(messages_.begin(), messages_.begin() + 100);
}

void Viewer::message(const Diagnostics& diagnostics, const std::string& where, bool errors) {
  for (const DiagnosticGroup& g : groupDiagnostics(diagnostics)) {
    message((where.empty() ? "" : where + ": ") + g.toString(), errors || g.severity == Severity::Error);
  }
}

glm::ivec2 Viewer::framebufferSize() const { return context_->framebufferSize(); }

glm::dvec2 Viewer::toPixels(const glm::dvec2& window) const {
  int w = 0, h = 0;
  glfwGetWindowSize(context_->window(), &w, &h);
  const glm::ivec2 fb = framebufferSize();
  if (w <= 0 || h <= 0) return window;
  return window * glm::dvec2(static_cast<double>(fb.x) / w, static_cast<double>(fb.y) / h);
}

double Viewer::aspect() const {
  const glm::ivec2 fb = framebufferSize();
  return fb.y > 0 ? static_cast<double>(fb.x) / fb.y : 1.0;
}

scene::Camera Viewer::camera() const {
  scene::Camera c = controller_->camera();
  c.fovYDeg = settings_.fovYDeg;
  return c;
}

void Viewer::frame(double seconds) {
  ++frameIndex_;
  // A scene read in the background; dropped files once it is in (the last scene wins; vector
  // files add layers to it).
  finishLoad(false);
  if (!loading_ && !dropped_.empty()) {
    const std::string path = dropped_.front();
    dropped_.erase(dropped_.begin());
    loadPath(path);
  }
  pollSelection(false);

  redrawFrames_ = std::max(redrawFrames_ - 1, 0);
  const InputFrame in = takeInput();  // always: the panel takes its part of the events
  if (script_ && !quit_) {
    advanceScript(seconds, in);
  } else if (scene_) {
    handleInput(seconds, in);
  } else if (!in.uiKeyboard) {
    // Nothing to steer: only opening a file.
    for (const InputFrame::KeyPress& k : in.pressed) {
      if (k.key == GLFW_KEY_O && k.modifiers.ctrl) openFileBrowser();
    }
  }
  cursorGround_.reset();
  if (scene_) {
    if (globe_) {
      moving_ = false;  // the globe's camera jumps: no motion to settle
    } else {
      moving_ = controller_->update(
          seconds, [this](const glm::dvec2& p) { return projected().bounds->fullResolutionHeightAt(p); });
    }
    if (animating_ && !moving_) animating_ = false;
    drawScene();
    // The coordinates under the cursor, unless the panel has it.
    if (cursorInside_ && !ImGui::GetIO().WantCaptureMouse) cursorGround_ = groundAt(lastPixel_);
  } else {
    moving_ = false;
    busy_ = false;
    animating_ = false;
    const glm::ivec2 fb = framebufferSize();
    gfx::beginRenderPass(cache_, 0, fb.x, fb.y, {glm::vec4(0.11F, 0.12F, 0.14F, 1.0F), std::nullopt, std::nullopt});
  }

  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  feedImGuiMouse();
  ImGui::NewFrame();
  drawLoading();
  expireNotice();
  drawFileBrowser();
  if (!scene_) {
    if (!loading_) drawNoScene();
  } else {
    // The same tools in both frames; the panel's view section, the HUD, the help and identify
    // show their frame's own contents.
    drawHighlights();
    drawMeasure();
    if (showLabels_) drawLabels();
    windowRects_.clear();  // recorded again as the windows are drawn below
    drawScaleBar();
    drawCompass();
    drawStatusBar();
    drawLegend();
    drawAttributeTable();
    if (settings_.showPanel) drawPanel();
    if (settings_.showHud) drawHud();
    if (showHelp_) drawHelp();
    if (identified_) drawIdentify();
    drawLassoOutline();
  }
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  cache_.invalidate();  // ImGui changed GL state behind the cache's back

  if (pendingShot_) {
    // A scene-only shot must not wait for a frame whose scene is still moving.
    if (!screenshot(pendingShot_->first, pendingShot_->second)) scriptFailed_ = true;
    pendingShot_.reset();
  }
  context_->swapBuffers();
}

void Viewer::drawScene() {
  const glm::ivec2 fb = framebufferSize();
  if (fb.x <= 0 || fb.y <= 0) return;
  // The globe's layers write their bits into a mask attachment; a projected frame draws without.
  const bool mask = globe_ != nullptr;
  if (!target_ || target_->hasMask() != mask || target_->width() != fb.x || target_->height() != fb.y) {
    target_.emplace(fb.x, fb.y, 0, mask);
    if (!steps_.empty()) selectionChanged();  // the lassos' pixel viewport is the target's
  }
  // The frame's terrain and layers; then, alike in both frames, the selection over them, the
  // pieces' debug view, and the copy into the window.
  if (globe_) globe_->view = globe_->controller->view(fb.x, fb.y);
  const scene::FrameCamera camera = frameCamera();
  // GPU timer queries wait for the GPU: sample them (every frame in a script).
  render_.measure = frameIndex_ % 30 == 1 || script_.has_value();
  render_.lodTolerancePixels = settings_.lodTolerancePixels;
  render_.imagery = settings_.imagery;
  // Without imagery shown, the terrain is tinted by height (with its legend).
  render_.elevationRamp.reset();
  if (!settings_.imagery || !renderer_->hasImagery()) render_.elevationRamp = demRange_;
  // The projected frame draws a sky behind the terrain; the globe's mask attachment keeps its
  // layers' bits (the sky would write colour alone).
  render_.sky = !mask;
  const scene::FrameFigures f = renderer_->drawFrame(cache_, *target_, camera, render_);
  // Work arriving: draw again until it has (tiles built or paged in, imagery, a selection).
  busy_ = f.terrain.tilesMissing > 0 || f.terrainPending > 0 || f.tilesMissing > 0;
  if (render_.measure) {
    figures_ = f;
  } else {
    // The times and counts of the last measured frame stay; what was drawn is this frame's.
    const scene::FrameFigures measured = figures_;
    figures_ = f;
    figures_.terrainGpuMs = measured.terrainGpuMs;
    figures_.overlayGpuMs = measured.overlayGpuMs;
    figures_.markFragments = measured.markFragments;
    figures_.coverFragments = measured.coverFragments;
    figures_.terrain.fragments = measured.terrain.fragments;
    figures_.layers = measured.layers;
  }
  const overlay::OverlayView view = scene::Scene::overlayViewOf(camera, fb.x, fb.y);
  if (!steps_.empty()) {
    // The lassos' volumes marked into the stencil the layers left 0, then the highlight blended
    // over the selected ground; a mask attachment keeps what the layers wrote.
    cache_.bindDrawTarget(target_->framebuffer(), target_->width(), target_->height());
    if (mask) gfx::enableMaskWrites(target_->framebuffer(), false);
    selectionRenderer_->select(cache_, view);
    selectionRenderer_->highlight(cache_, highlight_);
    if (mask) gfx::enableMaskWrites(target_->framebuffer(), true);
  }
  overlay::OverlayRenderer* passes = renderer_->analysisPasses();
  if (debugPieces_ && render_.overlays && passes != nullptr) {
    for (std::size_t j = 0; j < renderer_->drawnLayerCount(); ++j) {
      if (renderer_->drawnLayerShown(j))
        passes->drawPieces(cache_, view, renderer_->chunksOf(j, camera), kZPassPieceColour, kZFailPieceColour);
    }
  }
  // Into the window: the panel is drawn over this copy.
  glBlitNamedFramebuffer(target_->framebuffer(), 0, 0, 0, fb.x, fb.y, 0, 0, fb.x, fb.y, GL_COLOR_BUFFER_BIT,
                         GL_NEAREST);
  cache_.bindDrawTarget(0, fb.x, fb.y);
}

}  // namespace gis::viewer
