#include "viewer.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string_view>
#include <system_error>
#include <variant>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "app/json_file.hpp"
#include "app/scene.hpp"
#include "core/log.hpp"
#include "geo/vector.hpp"
#include "gfx/image_io.hpp"
#include "gfx/window_context.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::viewer {
namespace {

/// Scripted runs advance time by a fixed step per frame, so keyframes take the same frames on
/// any machine.
constexpr double kScriptFrameSeconds = 1.0 / 30.0;

std::string attributeText(const geo::AttributeValue& v) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, std::monostate>) {
          return "";
        } else if constexpr (std::is_same_v<T, std::string>) {
          return x;
        } else {
          return app::jsonText(nlohmann::json(x), -1);
        }
      },
      v);
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool isRasterFile(const std::string& path) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  return ext == ".tif" || ext == ".tiff" || ext == ".asc" || ext == ".img" || ext == ".vrt" || ext == ".hgt" ||
         ext == ".dem" || ext == ".bil";
}

bool isVectorFile(const std::string& path) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  return ext == ".geojson" || ext == ".shp" || ext == ".gpkg" || ext == ".kml" || ext == ".gml" || ext == ".csv" ||
         ext == ".fgb" || ext == ".gpx";
}

}  // namespace

// GLFW calls plain functions; they reach the viewer through the window's user pointer.
struct Callbacks {
  static Viewer& of(GLFWwindow* w) { return *static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }
  static void scroll(GLFWwindow* w, double, double dy) {
    if (!ImGui::GetIO().WantCaptureMouse) of(w).scroll_ += dy;
  }
  static void drop(GLFWwindow* w, int count, const char** paths) {
    for (int i = 0; i < count; ++i) of(w).dropped_.emplace_back(paths[i]);
  }
  static void key(GLFWwindow* w, int key, int, int action, int) {
    if (action == GLFW_PRESS && !ImGui::GetIO().WantCaptureKeyboard) of(w).keysPressed_.push_back(key);
  }
};

nlohmann::json Identified::toJson() const {
  nlohmann::json features = nlohmann::json::array();
  for (const Hit& h : hits) {
    nlohmann::json attributes = nlohmann::json::object();
    for (const auto& [k, v] : h.attributes) attributes[k] = v;
    features.push_back({{"layer", h.layer}, {"fid", h.fid}, {"attributes", attributes}});
  }
  nlohmann::json j = {
      {"frame", {frame.x, frame.y, frame.z}}, {"terrain_height", terrainHeight}, {"features", features}};
  if (lonLatH) j["lon_lat_h"] = {lonLatH->x, lonLatH->y, lonLatH->z};
  return j;
}

Viewer::~Viewer() {
  if (selectionJob_.valid()) selectionJob_.wait();  // it reads the scene and the layers
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  // GL objects go while the context is current.
  selectionRenderer_.reset();
  target_.reset();
  renderer_.reset();
}

int Viewer::run(const ViewerOptions& options) {
  Viewer v;
  if (!v.open(options)) return 1;
  GLFWwindow* window = v.context_->window();
  double last = glfwGetTime();
  while (!glfwWindowShouldClose(window) && !v.quit_) {
    glfwPollEvents();
    const double now = glfwGetTime();
    const double seconds = v.script_ ? kScriptFrameSeconds : std::clamp(now - last, 0.0, 0.25);
    v.frameMs_ = 0.9 * v.frameMs_ + 0.1 * (now - last) * 1000.0;
    last = now;
    v.frame(seconds);
  }
  if (!v.script_) {
    glm::ivec2 size(0);
    glfwGetWindowSize(window, &size.x, &size.y);
    if (size.x > 0 && size.y > 0) v.settings_.windowSize = size;
    if (const auto path = app::settingsPath()) {
      for (const Diagnostic& d : app::saveViewerSettings(v.settings_, *path).items()) logWarning(d.toString());
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
    for (const Diagnostic& d : script.diagnostics.items()) {
      (d.severity == Severity::Error ? logError : logWarning)(d.toString());
    }
    if (!script) return false;
    script_ = std::move(*script);
  } else if (const auto path = app::settingsPath()) {
    Result<app::ViewerSettings> loaded = app::loadViewerSettings(*path);
    for (const Diagnostic& d : loaded.diagnostics.items()) logWarning(d.toString());
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
    for (const Diagnostic& d : created.diagnostics.items()) logError(d.toString());
    return false;
  }
  context_ = std::move(*created);
  GLFWwindow* window = context_->window();
  glfwSetWindowUserPointer(window, this);
  glfwSetScrollCallback(window, Callbacks::scroll);
  glfwSetDropCallback(window, Callbacks::drop);
  glfwSetKeyCallback(window, Callbacks::key);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // our settings file keeps what matters
  // High-DPI: scale the panel with the monitor's content scale.
  float scaleX = 1.0F, scaleY = 1.0F;
  glfwGetWindowContentScale(window, &scaleX, &scaleY);
  if (scaleX > 1.0F) {
    ImGui::GetStyle().ScaleAllSizes(scaleX);
    ImGui::GetIO().FontGlobalScale = scaleX;
  }
  ImGui_ImplGlfw_InitForOpenGL(window, true);  // chains to our callbacks
  ImGui_ImplOpenGL3_Init("#version 450 core");
  imgui_ = true;

  Result<overlay::SelectionRenderer> selection = overlay::SelectionRenderer::create();
  for (const Diagnostic& d : selection.diagnostics.items()) logError(d.toString());
  if (!selection) return false;
  selectionRenderer_ = std::move(*selection);
  render_.lodTolerancePixels = settings_.lodTolerancePixels;
  render_.waitForTiles = script_.has_value();  // scripted screenshots show the finished view
  // A scene that does not load leaves the window open with the messages, ready for another.
  if (!loadPath(options.scene)) {
    logInfo("terrain_viewer: nothing to show; the window waits for a scene, a DEM or a vector file dropped on it");
  }
  return true;
}

bool Viewer::loadPath(const std::string& path) {
  auto report = [this](const Diagnostics& diagnostics) {
    for (const Diagnostic& d : diagnostics.items()) message(d.toString(), d.severity == Severity::Error);
  };
  if (isVectorFile(path)) {
    if (!description_) {
      // A vector file alone: over flat ground covering its extent.
      Result<app::SceneDescription> alone = app::sceneForVectorFile(path);
      report(alone.diagnostics);
      return alone && useScene(std::move(*alone));
    }
    // A new layer of the current scene: its kind from what the file holds.
    // After every layer of the scene, those its file left out included.
    std::size_t next = description_->layers.size();
    for (const app::LayerDescription& l : description_->layers) next = std::max(next, l.fileIndex + 1);
    Result<std::vector<app::LayerDescription>> layers = app::layersForVectorFile(path, scene_->frame, next);
    report(layers.diagnostics);
    if (!layers) return false;
    app::SceneDescription grown = *description_;
    grown.layers.insert(grown.layers.end(), layers->begin(), layers->end());
    return useScene(std::move(grown));
  }
  std::error_code ec;
  if (isRasterFile(path) || std::filesystem::is_directory(path, ec)) return useScene(app::sceneForDem(path));
  Result<app::SceneDescription> description = app::loadSceneFile(path);
  report(description.diagnostics);
  if (!description) return false;
  return useScene(std::move(*description));
}

bool Viewer::useScene(app::SceneDescription description) {
  finishSelection();  // its job reads the scene about to go
  Result<app::LoadedScene> scene = app::loadScene(description);
  for (const Diagnostic& d : scene.diagnostics.items()) message(d.toString(), d.severity == Severity::Error);
  if (!scene) return false;
  // Drop the old renderer before building the new one: GPU memory for one scene at a time.
  renderer_.reset();
  app::OverlayBuildSettings build;
  build.technique = technique_;
  build.textureSize = drapeSize_;
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene, build);
  for (const Diagnostic& d : renderer.diagnostics.items()) message(d.toString(), d.severity == Severity::Error);
  if (!renderer) return false;
  scene_ = std::move(*scene);
  renderer_ = std::move(*renderer);
  description_ = std::move(description);
  render_.verticalExaggeration = description_->verticalExaggeration;
  scene_->bounds->setExaggeration(render_.verticalExaggeration);
  glm::dvec3 lo, hi;
  app::terrainBox(*scene_, render_.verticalExaggeration, lo, hi);
  app::Camera home = app::overviewCamera(lo, hi, settings_.fovYDeg);
  if (description_->camera) {
    Result<app::Camera> placed = app::placeCamera(*description_->camera, scene_->frame, description_->path);
    if (placed) home = *placed;
  }
  if (controller_) {
    controller_->setHome(home);
    controller_->jumpTo(home);
  } else {
    controller_.emplace(home);
  }
  clearSelection();
  identified_.reset();
  glfwSetWindowTitle(
      context_->window(),
      ("terrain_viewer — " + (description_->name.empty() ? description_->path : description_->name)).c_str());
  return true;
}

void Viewer::message(const std::string& text, bool error) {
  (error ? logError : logInfo)(text);
  // Diagnostics say "error: " themselves.
  messages_.push_back((error && text.rfind("error: ", 0) != 0 ? "error: " : "") + text);
  if (messages_.size() > 200) messages_.erase(messages_.begin(), messages_.begin() + 100);
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

app::Camera Viewer::camera() const {
  app::Camera c = controller_->camera();
  c.fovYDeg = settings_.fovYDeg;
  return c;
}

std::optional<bool> Viewer::layerShown(std::size_t sceneLayer) const {
  std::optional<bool> shown;
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (renderer_->overlaySources()[j].first == sceneLayer) shown = shown.value_or(false) || renderer_->shown(j);
  }
  return shown;
}

void Viewer::setLayerShown(std::size_t sceneLayer, bool shown) {
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (renderer_->overlaySources()[j].first == sceneLayer) renderer_->setShown(j, shown);
  }
}

void Viewer::setExaggeration(double exaggeration) {
  finishSelection();  // the selection job reads the heights
  // The pieces' height bounds follow (no rebuild of the footprints).
  render_.verticalExaggeration = exaggeration;
  scene_->bounds->setExaggeration(exaggeration);
  for (std::size_t j = 0; j < renderer_->overlayLayers().size(); ++j) {
    renderer_->overlayLayer(j).refreshBounds(*scene_->bounds);
  }
  selectionChanged();
}

void Viewer::rebuildOverlays() {
  // Styles, order and the method are baked into the pieces: rebuild (Olinda: a fraction of a
  // second), keeping which layers are hidden.
  finishSelection();  // the selection job reads the layers
  std::vector<bool> hidden(scene_->layers.size(), false);
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (!renderer_->shown(j)) hidden[renderer_->overlaySources()[j].first] = true;
  }
  for (std::size_t i = 0; i < scene_->layers.size(); ++i) {
    scene_->layers[i].description = description_->layers[i];
  }
  app::OverlayBuildSettings build;
  build.technique = technique_;
  build.textureSize = drapeSize_;
  for (const Diagnostic& d : renderer_->buildOverlays(*scene_, build).items()) {
    message(d.toString(), d.severity == Severity::Error);
  }
  for (std::size_t i = 0; i < hidden.size(); ++i) {
    if (hidden[i]) setLayerShown(i, false);
  }
  selectionChanged();
}

void Viewer::addLasso(overlay::SelectionOp op, std::vector<glm::dvec2> points) {
  const glm::ivec2 fb = framebufferSize();
  overlay::SelectionStep step;
  step.op = op;
  step.lasso.points = std::move(points);
  const app::Camera c = camera();
  step.lasso.viewProj = c.projection(aspect()) * c.view();
  step.lasso.width = fb.x;
  step.lasso.height = fb.y;
  // A plain click-drag replaces the selection (Single starts a new chain).
  if (op == overlay::SelectionOp::Single) steps_.clear();
  steps_.push_back(std::move(step));
  selectionChanged();
}

void Viewer::invertSelection() {
  overlay::SelectionStep step;
  step.op = overlay::SelectionOp::Invert;
  steps_.push_back(step);
  selectionChanged();
}

void Viewer::clearSelection() {
  steps_.clear();
  selectionChanged();
}

void Viewer::selectionChanged() {
  // The GPU shows the new selection from the next frame on; the logical one (features, DEM
  // posts: the CPU twin, about a second on Olinda) follows from a worker thread, so drawing a
  // lasso never stalls the frames.
  const Diagnostics diagnostics = selectionRenderer_->setSteps(steps_);
  for (const Diagnostic& d : diagnostics.items()) message(d.toString(), true);
  selected_.reset();
  ++selectionGeneration_;
  if (!selectionJob_.valid()) startSelection();  // else restarted when the running job ends
}

void Viewer::startSelection() {
  if (steps_.empty() || !scene_ || !renderer_) return;
  const glm::ivec2 fb = framebufferSize();
  const std::vector<overlay::SelectionStep> steps = steps_;
  const app::Camera c = camera();
  const int width = std::max(fb.x, 1), height = std::max(fb.y, 1);
  jobGeneration_ = selectionGeneration_;
  // Reads the scene and the layers only; whatever changes them waits for it first
  // (finishSelection). A paged scene loads tiles while it draws, so it selects in this thread.
  const auto job = [this, steps, c, width, height] {
    const auto start = std::chrono::steady_clock::now();
    app::SceneSelection result = app::selectInScene(*scene_, *renderer_, steps, c, width, height);
    return std::make_pair(std::move(result),
                          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  };
  selectionJob_ = std::async(scene_->paged() ? std::launch::deferred : std::launch::async, job);
}

void Viewer::pollSelection(bool wait) {
  while (selectionJob_.valid()) {
    if (!wait && selectionJob_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    auto [result, ms] = selectionJob_.get();
    if (jobGeneration_ == selectionGeneration_) {
      selected_ = std::move(result);
      selectionMs_ = ms;
      char text[160];
      std::snprintf(text, sizeof(text), "selection: %zu features, %zu DEM posts (%.0f ms)", selected_->featureCount(),
                    selected_->posts ? selected_->posts->selected : std::size_t{0}, selectionMs_);
      message(text);
      return;
    }
    startSelection();  // the lassos changed while it ran
  }
}

void Viewer::finishSelection() { pollSelection(true); }

std::optional<float> Viewer::depthAt(int x, int y) const {
  if (!target_ || x < 0 || y < 0 || x >= target_->width() || y >= target_->height()) return std::nullopt;
  float depth = 0.0F;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, target_->framebuffer());
  glReadPixels(x, target_->height() - 1 - y, 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &depth);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  if (!(depth > 0.0F)) return std::nullopt;  // background (reversed-Z clears to 0)
  return depth;
}

std::optional<glm::dvec3> Viewer::pointAt(const glm::dvec2& pixel) const {
  const int x = static_cast<int>(std::floor(pixel.x)), y = static_cast<int>(std::floor(pixel.y));
  const std::optional<float> depth = depthAt(x, y);
  if (!depth) return std::nullopt;
  const app::Camera c = camera();
  const glm::dvec4 ndc(2.0 * (x + 0.5) / target_->width() - 1.0, 1.0 - 2.0 * (y + 0.5) / target_->height(),
                       static_cast<double>(*depth), 1.0);
  const glm::dvec4 p = glm::inverse(c.projection(aspect()) * c.view()) * ndc;
  if (p.w == 0.0) return std::nullopt;
  return glm::dvec3(p) / p.w;
}

std::optional<Identified> Viewer::identify(const glm::dvec2& pixel) {
  const std::optional<glm::dvec3> world = pointAt(pixel);
  if (!world) return std::nullopt;
  const app::Camera c = camera();
  const glm::dmat4 viewProj = c.projection(aspect()) * c.view();
  Identified id;
  id.frame = *world;
  id.lonLatH = scene_->frame.toLonLat(*world / glm::dvec3(1.0, 1.0, render_.verticalExaggeration));
  id.terrainHeight = scene_->bounds->fullResolutionHeightAt(glm::dvec2(*world)) / render_.verticalExaggeration;
  const overlay::PixelScale scale = overlay::pixelScaleOf(viewProj, target_->height());
  for (std::size_t j = 0; j < renderer_->overlayLayers().size(); ++j) {
    if (renderer_->overlaySources()[j].second || !renderer_->shown(j)) continue;
    const overlay::OverlayLayer& layer = renderer_->overlayLayers()[j];
    const overlay::ReferenceLayer ref = overlay::referenceLayerOf(layer);
    for (std::size_t f = 0; f < layer.features().size(); ++f) {
      if (!overlay::featureCovers(ref, f, glm::dvec2(*world), scale)) continue;
      Identified::Hit hit;
      hit.layer = scene_->layers[renderer_->overlaySources()[j].first].description.name;
      hit.feature = f;
      hit.fid = layer.features()[f].fid;
      for (const auto& [k, v] : layer.features()[f].attributes) hit.attributes.emplace_back(k, attributeText(v));
      id.hits.push_back(std::move(hit));
    }
  }
  return id;
}

bool Viewer::exportSelection(const std::filesystem::path& path) {
  finishSelection();
  if (!selected_ || selected_->featureCount() == 0) {
    message(path.string() + ": nothing selected to export", true);
    return false;
  }
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  const Diagnostics d = app::exportSelection(*scene_, *renderer_, *selected_, path,
                                             path.has_parent_path() ? path.parent_path() : std::filesystem::path("."));
  for (const Diagnostic& m : d.items()) message(m.toString(), m.severity == Severity::Error);
  if (d.hasErrors()) return false;
  message("exported " + std::to_string(selected_->featureCount()) + " features to " + path.string());
  return true;
}

bool Viewer::screenshot(const std::filesystem::path& path, bool ui) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  const glm::ivec2 fb = framebufferSize();
  std::vector<std::uint8_t> rgb;
  bool ok = true;
  if (ui) {
    // The back buffer as it will be shown: scene, panel and HUD.
    std::vector<std::uint8_t> rgba(static_cast<std::size_t>(fb.x) * static_cast<std::size_t>(fb.y) * 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    glReadBuffer(GL_BACK);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, fb.x, fb.y, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    rgb.resize(rgba.size() / 4 * 3);
    const auto w = static_cast<std::size_t>(fb.x), h = static_cast<std::size_t>(fb.y);
    for (std::size_t r = 0; r < h; ++r) {
      for (std::size_t c = 0; c < w; ++c) {
        for (std::size_t k = 0; k < 3; ++k) rgb[(r * w + c) * 3 + k] = rgba[((h - 1 - r) * w + c) * 4 + k];
      }
    }
  } else {
    const std::vector<std::uint8_t> rgba = gfx::readColorRgba8(*target_);
    rgb.resize(rgba.size() / 4 * 3);
    for (std::size_t i = 0; i < rgba.size() / 4; ++i) {
      for (std::size_t k = 0; k < 3; ++k) rgb[i * 3 + k] = rgba[i * 4 + k];
    }
    const std::filesystem::path stem = path.parent_path() / path.stem();
    const Result<bool> depth = gfx::writeImageFloat(stem.string() + "_depth.tiff", target_->width(), target_->height(),
                                                    gfx::readDepth(*target_));
    ok = ok && depth.ok();
    std::ofstream(stem.string() + "_camera.json")
        << app::jsonText(app::cameraToJson(camera(), scene_->frame, target_->width(), target_->height())) << "\n";
  }
  const Result<bool> png =
      gfx::writeImage8(path.string(), ui ? fb.x : target_->width(), ui ? fb.y : target_->height(), 3, rgb);
  for (const Diagnostic& d : png.diagnostics.items()) message(d.toString(), true);
  ok = ok && png.ok();
  if (ok) message("screenshot " + path.string());
  return ok;
}

void Viewer::frame(double seconds) {
  ++frameIndex_;
  // Dropped files: the last scene wins; vector files add layers.
  for (const std::string& path : std::exchange(dropped_, {})) loadPath(path);
  pollSelection(false);

  if (script_ && !quit_) {
    if (live_) {
      // The real mouse and keys, as without a script, until the test says it is done.
      handleInput(seconds, readInput());
      std::error_code ec;
      if (std::filesystem::exists(live_->first, ec)) {
        live_.reset();
        animating_ = true;
      } else if (--live_->second < 0) {
        message(script_->file + ": live input did not end (" + live_->first.string() + " never appeared)", true);
        scriptFailed_ = true;
        quit_ = true;
      }
    } else if (!scriptInput_.empty()) {
      // Played mouse and keys: one input state per frame, then the camera settles.
      handleInput(seconds, scriptInput_.front());
      scriptInput_.pop_front();
      if (scriptInput_.empty()) animating_ = true;
    } else if (animating_) {
      // Wait for the keyframe to be reached.
    } else if (waitFrames_ > 0) {
      --waitFrames_;
    } else {
      while (scriptStep_ < script_->steps.size() && waitFrames_ == 0 && !animating_ && !pendingShot_ && !quit_ &&
             scriptInput_.empty() && !live_) {
        if (!runStep(script_->steps[scriptStep_++])) {
          scriptFailed_ = true;
          quit_ = true;
        }
      }
      if (scriptStep_ >= script_->steps.size() && waitFrames_ == 0 && !animating_ && !pendingShot_ &&
          scriptInput_.empty() && !live_)
        quit_ = true;
    }
  } else if (scene_) {
    handleInput(seconds, readInput());
  } else {
    static_cast<void>(readInput());  // nothing to steer yet
  }
  if (scene_) {
    const bool moving =
        controller_->update(seconds, [this](const glm::dvec2& p) { return scene_->bounds->fullResolutionHeightAt(p); });
    if (animating_ && !moving) animating_ = false;
    drawScene();
  } else {
    animating_ = false;
    const glm::ivec2 fb = framebufferSize();
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, fb.x, fb.y);
    glClearColor(0.11F, 0.12F, 0.14F, 1.0F);
    glClear(GL_COLOR_BUFFER_BIT);
  }

  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  if (!scene_) {
    drawNoScene();
  } else {
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
  if (!target_ || target_->width() != fb.x || target_->height() != fb.y) {
    target_.emplace(fb.x, fb.y, 0, false);
    if (!steps_.empty()) selectionChanged();  // the lassos' pixel viewport is the target's
  }
  render_.measure = frameIndex_ % 30 == 1 || script_.has_value();  // queries wait for the GPU: sample them
  render_.lodTolerancePixels = settings_.lodTolerancePixels;
  render_.imagery = settings_.imagery;
  const app::Camera c = camera();
  const app::FrameStats s = renderer_->render(cache_, target_->framebuffer(), fb.x, fb.y, c, render_);
  if (render_.measure) {
    stats_ = s;
  } else {
    stats_.terrainDraw = s.terrainDraw;
    stats_.finestLevel = s.finestLevel;
    stats_.coarsestLevel = s.coarsestLevel;
    stats_.tilesMissing = s.tilesMissing;
    stats_.pager = s.pager;
  }
  const overlay::OverlayView view = app::overlayViewOf(c, aspect());
  if (!steps_.empty()) {
    selectionRenderer_->select(cache_, view);
    selectionRenderer_->highlight(cache_, highlight_);
  }
  if (debugPieces_ && render_.overlays) {
    for (std::size_t j = 0; j < renderer_->overlayLayers().size(); ++j) {
      if (!renderer_->shown(j)) continue;
      renderer_->overlayRenderer().drawPieces(cache_, view, renderer_->overlayLayers()[j],
                                              glm::vec4(0.1F, 0.8F, 0.2F, 0.35F), glm::vec4(0.9F, 0.1F, 0.1F, 0.5F));
    }
  }
  // Into the window: the panel is drawn over this copy.
  glBlitNamedFramebuffer(target_->framebuffer(), 0, 0, 0, fb.x, fb.y, 0, 0, fb.x, fb.y, GL_COLOR_BUFFER_BIT,
                         GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, fb.x, fb.y);
}

InputFrame Viewer::readInput() {
  GLFWwindow* window = context_->window();
  const ImGuiIO& io = ImGui::GetIO();
  InputFrame in;
  glm::dvec2 cursor(0.0);
  glfwGetCursorPos(window, &cursor.x, &cursor.y);
  in.cursor = toPixels(cursor);
  in.left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  in.right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  in.middle = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  const auto down = [&](int a, int b) {
    return glfwGetKey(window, a) == GLFW_PRESS || glfwGetKey(window, b) == GLFW_PRESS;
  };
  in.modifiers.shift = down(GLFW_KEY_LEFT_SHIFT, GLFW_KEY_RIGHT_SHIFT);
  in.modifiers.ctrl = down(GLFW_KEY_LEFT_CONTROL, GLFW_KEY_RIGHT_CONTROL);
  in.modifiers.alt = down(GLFW_KEY_LEFT_ALT, GLFW_KEY_RIGHT_ALT);
  for (const int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E}) {
    if (glfwGetKey(window, k) == GLFW_PRESS) in.held.push_back(k);
  }
  in.scroll = std::exchange(scroll_, 0.0);
  in.pressed = std::exchange(keysPressed_, {});
  in.uiMouse = io.WantCaptureMouse;
  in.uiKeyboard = io.WantCaptureKeyboard;
  return in;
}

void Viewer::handleInput(double seconds, const InputFrame& in) {
  const glm::dvec2 pixel = in.cursor, lastPixel = lastPixel_;
  const glm::ivec2 fb = framebufferSize();
  const bool left = in.left, right = in.right, middle = in.middle;
  const bool shift = in.modifiers.shift, ctrl = in.modifiers.ctrl, alt = in.modifiers.alt;
  const bool fly = controller_->mode() == app::CameraController::Mode::Fly;

  if (!in.uiMouse) {
    if (left && !leftDown_) {
      pressCursor_ = pixel;
      dragged_ = false;
      if (lassoTool_) lassoPoints_.assign(1, pixel);
      // Orbit about the terrain at the centre of the view: reversed-Z depth is near / distance
      // along the view axis.
      if (!lassoTool_ && !fly) {
        if (const std::optional<float> depth = depthAt(fb.x / 2, fb.y / 2)) {
          controller_->pivotAt(camera().nearPlane / static_cast<double>(*depth));
        }
      }
    }
    if (left && glm::length(pixel - pressCursor_) > 3.0) dragged_ = true;
    if (left && lassoTool_) {
      if (glm::length(pixel - lassoPoints_.back()) >= 2.0) lassoPoints_.push_back(pixel);
    } else if (left && leftDown_ && dragged_) {
      if (fly) {
        controller_->look(pixel - lastPixel);
      } else {
        controller_->orbit(pixel - lastPixel);
      }
    } else if ((right && rightDown_) || (middle && middleDown_)) {
      if (fly) {
        controller_->look(pixel - lastPixel);
      } else {
        controller_->pan(lastPixel, pixel, fb);
      }
    }
    if (!left && leftDown_) {
      if (lassoTool_ && lassoPoints_.size() >= 3) {
        // Modifiers choose the operator (docs/viewer.md): Shift Or, Ctrl Subtract, Ctrl+Shift And, Alt Xor.
        overlay::SelectionOp op = overlay::SelectionOp::Single;
        if (alt) {
          op = overlay::SelectionOp::Xor;
        } else if (ctrl && shift) {
          op = overlay::SelectionOp::And;
        } else if (ctrl) {
          op = overlay::SelectionOp::Subtract;
        } else if (shift) {
          op = overlay::SelectionOp::Or;
        }
        if (steps_.empty() && op != overlay::SelectionOp::Single) op = overlay::SelectionOp::Single;
        addLasso(op, std::exchange(lassoPoints_, {}));
      } else if (!dragged_) {
        identified_ = identify(pixel);
      }
      lassoPoints_.clear();
    }
    if (in.scroll != 0.0) {
      controller_->zoomAt(in.scroll, pixel, fb, pointAt(pixel));
    }
  }
  leftDown_ = left;
  rightDown_ = right;
  middleDown_ = middle;
  lastPixel_ = pixel;

  if (!in.uiKeyboard) {
    if (fly) {
      auto key = [&](int k) { return std::find(in.held.begin(), in.held.end(), k) != in.held.end() ? 1.0 : 0.0; };
      const glm::dvec3 move(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_W) - key(GLFW_KEY_S),
                            key(GLFW_KEY_E) - key(GLFW_KEY_Q));
      if (move != glm::dvec3(0.0)) controller_->fly(move * (shift ? 4.0 : 1.0), seconds);
    }
  }
  for (const int k : in.pressed) {
    switch (k) {
      case GLFW_KEY_ESCAPE:
        if (lassoTool_) {
          lassoTool_ = false;
          lassoPoints_.clear();
        } else if (showHelp_) {
          showHelp_ = false;
        } else {
          glfwSetWindowShouldClose(context_->window(), GLFW_TRUE);
        }
        break;
      case GLFW_KEY_H:
        controller_->goHome();
        break;
      case GLFW_KEY_F:
        controller_->setMode(fly ? app::CameraController::Mode::Orbit : app::CameraController::Mode::Fly);
        break;
      case GLFW_KEY_L:
        lassoTool_ = !lassoTool_;
        break;
      case GLFW_KEY_I:
        if (!steps_.empty()) invertSelection();
        break;
      case GLFW_KEY_C:
        clearSelection();
        break;
      case GLFW_KEY_O:
        render_.overlays = !render_.overlays;
        break;
      case GLFW_KEY_P:
        settings_.showPanel = !settings_.showPanel;
        break;
      case GLFW_KEY_U:
        settings_.showHud = !settings_.showHud;
        break;
      case GLFW_KEY_F12:
        pendingShot_ = {std::filesystem::path("terrain_viewer_" + std::to_string(frameIndex_) + ".png"), true};
        break;
      case GLFW_KEY_SLASH:  // '?' on most layouts (with Shift)
        showHelp_ = !showHelp_;
        break;
      default:
        break;
    }
  }
}

int Viewer::keyCode(const std::string& name) {
  if (name.size() == 1) {
    const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(name[0])));
    if (c >= 'a' && c <= 'z') return GLFW_KEY_A + (c - 'a');
    if (c >= '0' && c <= '9') return GLFW_KEY_0 + (c - '0');
    switch (c) {
      case '?':
      case '/':
        return GLFW_KEY_SLASH;
      case ' ':
        return GLFW_KEY_SPACE;
      default:
        return GLFW_KEY_UNKNOWN;
    }
  }
  static const std::array<std::pair<std::string_view, int>, 15> kNamed{{{"escape", GLFW_KEY_ESCAPE},
                                                                        {"enter", GLFW_KEY_ENTER},
                                                                        {"tab", GLFW_KEY_TAB},
                                                                        {"backspace", GLFW_KEY_BACKSPACE},
                                                                        {"insert", GLFW_KEY_INSERT},
                                                                        {"delete", GLFW_KEY_DELETE},
                                                                        {"right", GLFW_KEY_RIGHT},
                                                                        {"left", GLFW_KEY_LEFT},
                                                                        {"down", GLFW_KEY_DOWN},
                                                                        {"up", GLFW_KEY_UP},
                                                                        {"page_up", GLFW_KEY_PAGE_UP},
                                                                        {"page_down", GLFW_KEY_PAGE_DOWN},
                                                                        {"home", GLFW_KEY_HOME},
                                                                        {"end", GLFW_KEY_END},
                                                                        {"space", GLFW_KEY_SPACE}}};
  const std::string n = lower(name);
  for (const auto& [text, code] : kNamed) {
    if (n == text) return code;
  }
  for (int f = 1; f <= 25; ++f) {
    if (n == "f" + std::to_string(f)) return GLFW_KEY_F1 + f - 1;
  }
  return GLFW_KEY_UNKNOWN;
}

nlohmann::json Viewer::state() const {
  const glm::ivec2 fb = framebufferSize();
  glm::ivec2 window(0);
  glfwGetWindowSize(context_->window(), &window.x, &window.y);
  if (!scene_) {
    return {
        {"scene", nullptr}, {"framebuffer", {fb.x, fb.y}}, {"window", {window.x, window.y}}, {"messages", messages_}};
  }
  const app::OrbitPose& pose = controller_->shownPose();
  nlohmann::json steps = nlohmann::json::array(), lassos = nlohmann::json::array();
  for (const overlay::SelectionStep& st : steps_) {
    steps.push_back(overlay::selectionOpName(st.op));
    nlohmann::json points = nlohmann::json::array();
    for (const glm::dvec2& p : st.lasso.points) points.push_back({p.x, p.y});
    lassos.push_back(points);
  }
  nlohmann::json layers = nlohmann::json::array();
  for (std::size_t i = 0; i < scene_->layers.size(); ++i) {
    const app::LayerSummary summary = renderer_->layerSummary(*scene_, i);
    layers.push_back({{"name", scene_->layers[i].description.name},
                      {"shown", layerShown(i).value_or(false)},
                      {"features", summary.features},
                      {"skipped_features", summary.skipped()},
                      {"features_with_nothing_to_draw", summary.nothingToDraw},
                      {"drawn_features", summary.drawnFeatures}});
  }
  nlohmann::json j = {
      {"mode", controller_->mode() == app::CameraController::Mode::Fly ? "fly" : "orbit"},
      {"camera", app::cameraToJson(camera(), scene_->frame, fb.x, fb.y)},
      {"pose",
       {{"target", {pose.target.x, pose.target.y, pose.target.z}},
        {"yaw", pose.yaw},
        {"pitch", pose.pitch},
        {"distance", pose.distance}}},
      {"framebuffer", {fb.x, fb.y}},
      {"window", {window.x, window.y}},
      {"overlays", render_.overlays},
      {"method", technique_->name},
      {"view",
       {{"wireframe", render_.wireframe},
        {"imagery", settings_.imagery},
        {"debug_pieces", debugPieces_},
        {"panel", settings_.showPanel},
        {"hud", settings_.showHud},
        {"lod_tolerance", settings_.lodTolerancePixels},
        {"fov", settings_.fovYDeg}}},
      {"scene", description_->path},
      {"frame",
       {{"ms", frameMs_},  // smoothed wall time per frame
        {"terrain_triangles", stats_.terrainDraw.triangles},
        {"overlay_fragments", overlayFragments()},
        {"selection_ms", selectionMs_}}},  // the CPU twin's logical selection, last run
      {"messages", messages_},
      {"lasso_tool", lassoTool_},
      {"layers", layers},
      {"selection",
       {{"steps", steps},
        {"lassos", lassos},
        {"features", selected_ ? selected_->featureCount() : 0},
        {"dem_posts", selected_ && selected_->posts ? nlohmann::json(selected_->posts->selected) : nlohmann::json()}}},
      {"identified", identified_ ? identified_->toJson() : nlohmann::json()}};
  return j;
}

bool Viewer::runStep(const app::ScriptStep& step) {
  const std::string where = script_->file + ": step " + std::to_string(step.index);
  auto sceneLayer = [&](const std::string& name) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < scene_->layers.size(); ++i) {
      if (scene_->layers[i].description.name == name) return i;
    }
    message(where + ": no layer named '" + name + "'", true);
    return std::nullopt;
  };
  // Without a scene (it failed to load) only what needs none runs.
  const bool needsNoScene = step.action == app::ScriptAction::Wait || step.action == app::ScriptAction::SaveState ||
                            step.action == app::ScriptAction::Drop || step.action == app::ScriptAction::Resize ||
                            step.action == app::ScriptAction::Quit ||
                            (step.action == app::ScriptAction::Screenshot && step.ui);
  if (!scene_ && !needsNoScene) {
    message(where + ": no scene is loaded", true);
    return false;
  }
  switch (step.action) {
    case app::ScriptAction::Camera: {
      Result<app::CameraSpec> spec = app::parseCameraSpec(step.camera, step.cameraFile);
      for (const Diagnostic& d : spec.diagnostics.items()) message(where + ": " + d.toString(), true);
      if (!spec) return false;
      Result<app::Camera> placed = app::placeCamera(*spec, scene_->frame, where);
      for (const Diagnostic& d : placed.diagnostics.items()) message(where + ": " + d.toString(), true);
      if (!placed) return false;
      settings_.fovYDeg = spec->fovYDeg;
      if (step.seconds > 0.0) {
        controller_->animateTo(*placed, step.seconds);
        animating_ = true;
      } else {
        controller_->jumpTo(*placed);
      }
      return true;
    }
    case app::ScriptAction::Wait:
      waitFrames_ = step.frames;
      return true;
    case app::ScriptAction::ToggleLayer: {
      const auto i = sceneLayer(step.layer);
      if (!i) return false;
      setLayerShown(*i, !layerShown(*i).value_or(false));
      return true;
    }
    case app::ScriptAction::SetLayer: {
      const auto i = sceneLayer(step.layer);
      if (!i) return false;
      overlay::LayerStyle& style = description_->layers[*i].style;
      if (step.color) style.color = *step.color;
      if (step.opacity) style.opacity = *step.opacity;
      if (step.width) style.widthMetres = static_cast<float>(*step.width);
      if (step.color || step.opacity || step.width) rebuildOverlays();
      if (step.visible) setLayerShown(*i, *step.visible);
      return true;
    }
    case app::ScriptAction::Overlays:
      render_.overlays = step.on;
      return true;
    case app::ScriptAction::Method:
      technique_ = overlay::findTechnique(step.text);  // checked when the script was read
      if (step.frames > 0) drapeSize_ = step.frames;
      rebuildOverlays();
      return true;
    case app::ScriptAction::Exaggeration:
      setExaggeration(step.value);
      return true;
    case app::ScriptAction::Lasso: {
      const std::optional<overlay::SelectionOp> op = overlay::parseSelectionOp(step.lassoOp);
      if (!op) {
        message(where + ": unknown lasso operator '" + step.lassoOp + "'", true);
        return false;
      }
      addLasso(*op, step.points);
      return true;
    }
    case app::ScriptAction::Invert:
      invertSelection();
      return true;
    case app::ScriptAction::ClearSelection:
      clearSelection();
      return true;
    case app::ScriptAction::Identify: {
      identified_ = identify(step.at);
      if (step.path.empty()) return true;
      std::ofstream out(step.path);
      out << app::jsonText(identified_ ? identified_->toJson() : nlohmann::json(nullptr)) << "\n";
      if (!out) message(where + ": cannot write " + step.path, true);
      return static_cast<bool>(out);
    }
    case app::ScriptAction::Export:
      return exportSelection(step.path);
    case app::ScriptAction::Screenshot:
      pendingShot_ = {std::filesystem::path(step.path), step.ui};
      return true;
    case app::ScriptAction::Home:
      controller_->goHome();
      animating_ = true;
      return true;
    case app::ScriptAction::Key:
    case app::ScriptAction::HoldKeys: {
      std::vector<int> codes;
      for (const std::string& name : step.action == app::ScriptAction::Key ? std::vector{step.text} : step.keys) {
        const int code = keyCode(name);
        if (code == GLFW_KEY_UNKNOWN) {
          message(where + ": the viewer has no key '" + name + "'", true);
          return false;
        }
        codes.push_back(code);
      }
      InputFrame in;
      in.cursor = lastPixel_;
      in.modifiers = step.modifiers;
      if (step.action == app::ScriptAction::Key) {
        in.pressed = codes;
        scriptInput_.push_back(in);
      } else {
        in.held = codes;
        scriptInput_.insert(scriptInput_.end(), static_cast<std::size_t>(step.frames), in);
      }
      return true;
    }
    case app::ScriptAction::Drag:
    case app::ScriptAction::Click: {
      InputFrame in;
      in.modifiers = step.modifiers;
      const auto press = [&](bool down) {
        in.left = down && step.button == app::MouseButton::Left;
        in.right = down && step.button == app::MouseButton::Right;
        in.middle = down && step.button == app::MouseButton::Middle;
      };
      const std::vector<glm::dvec2> path = step.action == app::ScriptAction::Drag ? step.points : std::vector{step.at};
      // First the cursor arrives with the button up, so the press happens where it should.
      in.cursor = path.front();
      scriptInput_.push_back(in);
      press(true);
      scriptInput_.push_back(in);
      for (std::size_t i = 1; i < path.size(); ++i) {
        for (int f = 1; f <= step.frames; ++f) {
          in.cursor = glm::mix(path[i - 1], path[i], static_cast<double>(f) / step.frames);
          scriptInput_.push_back(in);
        }
      }
      press(false);
      scriptInput_.push_back(in);
      return true;
    }
    case app::ScriptAction::Scroll: {
      InputFrame in;
      in.cursor = step.at;
      in.scroll = step.value;
      scriptInput_.push_back(in);
      return true;
    }
    case app::ScriptAction::Resize:
      glfwSetWindowSize(context_->window(), step.window.x, step.window.y);
      waitFrames_ = 2;  // the window system answers within a frame or two
      return true;
    case app::ScriptAction::View:
      if (step.wireframe) render_.wireframe = *step.wireframe;
      if (step.imagery) settings_.imagery = *step.imagery;
      if (step.debugPieces) debugPieces_ = *step.debugPieces;
      if (step.panel) settings_.showPanel = *step.panel;
      if (step.hud) settings_.showHud = *step.hud;
      if (step.lodTolerance) settings_.lodTolerancePixels = *step.lodTolerance;
      if (step.fovYDeg) settings_.fovYDeg = *step.fovYDeg;
      return true;
    case app::ScriptAction::Live:
      live_ = {std::filesystem::path(step.path), step.frames};
      static_cast<void>(readInput());  // forget what arrived before: only the live input counts
      return true;
    case app::ScriptAction::Drop:
      dropped_.insert(dropped_.end(), step.paths.begin(), step.paths.end());
      waitFrames_ = 1;  // loaded at the start of the next frame, as a person's drop
      return true;
    case app::ScriptAction::SaveState: {
      finishSelection();  // the state holds the logical selection of every lasso so far
      std::ofstream out(step.path);
      out << app::jsonText(state()) << "\n";
      if (!out) message(where + ": cannot write " + step.path, true);
      return static_cast<bool>(out);
    }
    case app::ScriptAction::Quit:
      quit_ = true;
      return true;
  }
  return true;
}

}  // namespace gis::viewer
