// The viewer's actions on the layers and the selection, and its exports: what the panel, the
// keys and the script call.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <span>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "gfx/gl.hpp"

#include <nlohmann/json.hpp>

#include "gfx/image_io.hpp"
#include "scene/frame_scene.hpp"
#include "scene/json_file.hpp"
#include "scene/scene.hpp"
#include "vector_overlay/globe_selection.hpp"
#include "viewer.hpp"

namespace gis::viewer {

std::optional<bool> Viewer::layerShown(std::size_t sceneLayer) const {
  std::optional<bool> shown;
  if (globe_) {
    for (const std::size_t j : globeLayersOf(sceneLayer)) shown = shown.value_or(false) || globe_->shown[j] != 0;
    return shown;
  }
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (renderer_->overlaySources()[j].first == sceneLayer) shown = shown.value_or(false) || renderer_->shown(j);
  }
  return shown;
}

bool Viewer::sceneLayerShown(std::size_t sceneLayer) const {
  if (globe_) {
    // On the globe a scene layer may be drawn as an area and an outline: shown if either is.
    for (const std::size_t j : globeLayersOf(sceneLayer))
      if (j < globe_->shown.size() && globe_->shown[j] != 0) return true;
    return false;
  }
  return scene_ && layerShown(sceneLayer).value_or(false);
}

void Viewer::setLayerShown(std::size_t sceneLayer, bool shown) {
  if (globe_) {
    for (const std::size_t j : globeLayersOf(sceneLayer)) globe_->shown[j] = static_cast<char>(shown);
    return;
  }
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (renderer_->overlaySources()[j].first == sceneLayer) renderer_->setShown(j, shown);
  }
}

void Viewer::setExaggeration(double exaggeration) {
  finishSelection();  // the selection job reads the heights
  if (globe_) {
    // The globe's heights own it: its terrain, the layers' tiles (their bounds, and the anchors of
    // lines in pixels) and the camera's ground are made again from the exaggerated heights.
    GlobeMode& g = *globe_;
    if (exaggeration == globeScene().heights->exaggeration()) return;
    globeScene().heights = globe::GeoGrid::exaggerated(globeScene().heights, exaggeration);
    g.renderer = std::make_unique<globe::GlobeRenderer>(globeScene().heights);
    if (globeScene().imagery) g.renderer->setImagery(globeScene().imagery);
    const scene::GlobePose pose = g.controller->pose();
    g.controller->setGround(globeScene().heights.get());
    g.controller->setPose(pose);
    g.maxGroundHeight = std::max(globeScene().heights->bounds({-180.0, -90.0, 180.0, 90.0}).second, 0.0);
    rebuildGlobeLayers();
    selectionChanged();
    return;
  }
  // The bounds own it; the renderer refreshes the pieces' heights at the next frame (no
  // rebuild of the footprints).
  projected().bounds->setExaggeration(exaggeration);
  selectionChanged();
}

double Viewer::exaggeration() const {
  if (globe_) return globeScene().heights->exaggeration();
  return scene_ ? projected().bounds->exaggeration() : 1.0;
}

void Viewer::useTechnique(const overlay::TechniqueInfo& technique, int textureSize) {
  technique_ = &technique;
  const std::span<const int> sizes = technique.textureSizes;
  if (textureSize > 0) {
    drapeSize_ = textureSize;
  } else if (technique.usesTextures() && std::find(sizes.begin(), sizes.end(), drapeSize_) == sizes.end()) {
    drapeSize_ = technique.defaultTextureSize;
  }
  if (!globe_) rebuildOverlays();  // the globe's renderer takes both at its next frame
}

void Viewer::rebuildOverlays() {
  // Styles, order and the method are baked into the pieces: rebuild (Olinda: a fraction of a
  // second), keeping which layers are hidden.
  finishSelection();  // the selection job reads the layers
  if (globe_) {
    rebuildGlobeLayers();
    return;
  }
  std::vector<bool> hidden(projected().layers.size(), false);
  for (std::size_t j = 0; j < renderer_->overlaySources().size(); ++j) {
    if (!renderer_->shown(j)) hidden[renderer_->overlaySources()[j].first] = true;
  }
  for (std::size_t i = 0; i < projected().layers.size(); ++i) {
    projected().layers[i].description = description_->layers[i];
  }
  scene::OverlayBuildSettings build;
  build.technique = technique_;
  build.textureSize = drapeSize_;
  message(renderer_->buildOverlays(projected(), build));
  for (std::size_t i = 0; i < hidden.size(); ++i) {
    if (hidden[i]) setLayerShown(i, false);
  }
  outlines_.clear();
  if (table_) table_->dirty = true;
  selectionChanged();
}

void Viewer::rebuildGlobeLayers() {
  // The globe layers again from the features as read (shared, not read again), each source layer
  // with its style as edited; which scene layers are hidden stays. Each build is new to the
  // renderer (GlobeLayer::serial): its tiles are built again, in the new colours and widths.
  GlobeMode& g = *globe_;
  std::set<std::size_t> hidden;
  for (std::size_t j = 0; j < globeScene().layers.size(); ++j)
    if (g.shown[j] == 0) hidden.insert(globeScene().layerFileIndex[j]);
  for (scene::LoadedLayer& source : globeScene().sourceLayers) {
    for (const scene::LayerDescription& d : description_->layers)
      if (d.fileIndex == source.description.fileIndex) source.description = d;
  }
  globeScene().description.layers = description_->layers;
  Diagnostics diagnostics;
  scene::buildGlobeLayers(globeScene(), diagnostics);
  message(diagnostics);
  g.shown.assign(globeScene().layers.size(), static_cast<char>(1));
  for (std::size_t j = 0; j < globeScene().layers.size(); ++j)
    if (hidden.contains(globeScene().layerFileIndex[j])) g.shown[j] = 0;
  identified_.reset();  // its hits index the old layers
  outlines_.clear();
  if (table_) table_->dirty = true;
  selectionChanged();
}

void Viewer::addLasso(overlay::SelectionOp op, std::vector<glm::dvec2> points) {
  const glm::ivec2 fb = framebufferSize();
  overlay::SelectionStep step;
  step.op = op;
  if (globe_) {
    // In the view the lasso was drawn in (the last frame's), reaching that eye's horizon: not
    // through the globe to its other side.
    step.lasso = globe::lassoIn(globe_->view, std::move(points), globe_->maxGroundHeight);
  } else {
    step.lasso.points = std::move(points);
    const scene::Camera c = camera();
    step.lasso.viewProj = c.projection(aspect()) * c.view();
    step.lasso.width = fb.x;
    step.lasso.height = fb.y;
  }
  rememberSelection();
  // A plain click-drag replaces the selection (Single starts a new chain).
  if (op == overlay::SelectionOp::Single) steps_.clear();
  steps_.push_back(std::move(step));
  selectionChanged();
}

void Viewer::rememberSelection() {
  undo_.push_back(steps_);
  if (undo_.size() > 100) undo_.erase(undo_.begin());
  redo_.clear();
}

void Viewer::undoSelection() {
  if (undo_.empty()) return;
  redo_.push_back(std::move(steps_));
  steps_ = std::move(undo_.back());
  undo_.pop_back();
  selectionChanged();
}

void Viewer::redoSelection() {
  if (redo_.empty()) return;
  undo_.push_back(std::move(steps_));
  steps_ = std::move(redo_.back());
  redo_.pop_back();
  selectionChanged();
}

void Viewer::invertSelection() {
  rememberSelection();
  overlay::SelectionStep step;
  step.op = overlay::SelectionOp::Invert;
  steps_.push_back(step);
  selectionChanged();
}

void Viewer::clearSelection() {
  if (!steps_.empty()) rememberSelection();
  steps_.clear();
  selectionChanged();
}

void Viewer::selectionChanged() {
  // The GPU shows the new selection from the next frame on; the logical one (features, DEM
  // posts: the CPU twin, about a second on Olinda) follows from a worker thread, so drawing a
  // lasso never stalls the frames.
  const Diagnostics diagnostics = selectionRenderer_->setSteps(steps_);
  message(diagnostics, {}, true);
  selected_.reset();
  ++selectionGeneration_;
  // Else restarted when the running job ends.
  if (!selectionJob_.valid()) startSelection();
}

void Viewer::startSelection() {
  if (steps_.empty() || (!globe_ && (!scene_ || !renderer_))) return;
  const glm::ivec2 fb = framebufferSize();
  const std::vector<overlay::SelectionStep> steps = steps_;
  jobGeneration_ = selectionGeneration_;
  // Reads the scene and the layers only; whatever changes them waits for it first
  // (finishSelection). Features are sampled at half a pixel's footprint at the view's target.
  if (globe_) {
    const globe::GlobeView view = globe_->view;
    const scene::LoadedGlobeScene* scene = &globeScene();
    selectionJob_ = std::async(std::launch::async, [scene, steps, view] {
      const auto start = std::chrono::steady_clock::now();
      scene::GlobeSelection chosen = scene::selectOnGlobe(*scene, steps, view);
      return scene::selectedFeaturesOf(*scene, std::move(chosen),
                                       std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    });
    return;
  }
  const scene::Camera c = camera();
  const int width = std::max(fb.x, 1), height = std::max(fb.y, 1);
  // A paged scene loads tiles while it draws, so it selects in this thread.
  const auto job = [this, steps, c, width, height] {
    const auto start = std::chrono::steady_clock::now();
    scene::SceneSelection chosen = scene::selectInScene(projected(), *renderer_, steps, c, width, height);
    return scene::selectedFeaturesOf(projected(), *renderer_, std::move(chosen),
                                     std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  };
  selectionJob_ = std::async(projected().paged() ? std::launch::deferred : std::launch::async, job);
}

void Viewer::pollSelection(bool wait) {
  while (selectionJob_.valid()) {
    if (!wait && selectionJob_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) break;
    scene::SelectedFeatures result = selectionJob_.get();
    if (jobGeneration_ == selectionGeneration_) {
      selected_ = std::move(result);
      selectionMs_ = selected_->seconds * 1000.0;
      char text[160];
      if (selected_->posts) {
        std::snprintf(text, sizeof(text), "selection: %zu features, %zu DEM posts (%.0f ms)", selected_->featureCount(),
                      selected_->posts->selected, selectionMs_);
      } else {
        std::snprintf(text, sizeof(text), "selection: %zu features (%.0f ms)", selected_->featureCount(), selectionMs_);
      }
      message(text);
      break;
    }
    startSelection();  // the lassos changed while it ran
  }
}

void Viewer::finishSelection() { pollSelection(true); }

bool Viewer::exportSelection(const std::filesystem::path& path) {
  finishSelection();
  if (!selected_ || selected_->featureCount() == 0) {
    notify(path.string() + ": nothing selected to export", true);
    return false;
  }
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  const std::filesystem::path beside = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const Diagnostics d =
      globe_ ? scene::exportGlobeSelection(globeScene(), std::get<scene::GlobeSelection>(selected_->selection), path,
                                           beside)
             : scene::exportSelection(projected(), *renderer_, std::get<scene::SceneSelection>(selected_->selection),
                                      path, beside);
  message(d);
  if (d.hasErrors()) {
    notify("Export to " + path.string() + " failed: see Messages", true);
    return false;
  }
  notify("Exported " + std::to_string(selected_->featureCount()) + " features to " +
         std::filesystem::absolute(path, ec).lexically_normal().string());
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
    gfx::readFramebuffer(0, GL_BACK, 0, 0, fb.x, fb.y, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
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
        << scene::jsonText(globe_
                               ? scene::globeCameraJson(globe_->view)
                               : scene::cameraToJson(camera(), projected().frame, target_->width(), target_->height()))
        << "\n";
  }
  const Result<bool> png =
      gfx::writeImage8(path.string(), ui ? fb.x : target_->width(), ui ? fb.y : target_->height(), 3, rgb);
  message(png.diagnostics, {}, true);
  ok = ok && png.ok();
  if (ok) {
    notify("Screenshot saved to " + std::filesystem::absolute(path, ec).lexically_normal().string());
  } else {
    notify("Screenshot " + path.string() + " failed: see Messages", true);
  }
  return ok;
}

}  // namespace gis::viewer
