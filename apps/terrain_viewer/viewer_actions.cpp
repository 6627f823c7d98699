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
  for (const std::size_t j : drawnLayersOf(sceneLayer)) shown = shown.value_or(false) || renderer_->drawnLayerShown(j);
  return shown;
}

bool Viewer::sceneLayerShown(std::size_t sceneLayer) const {
  // A scene layer may be drawn as an area and an outline: shown if either is.
  return scene_ && layerShown(sceneLayer).value_or(false);
}

void Viewer::setLayerShown(std::size_t sceneLayer, bool shown) {
  for (const std::size_t j : drawnLayersOf(sceneLayer)) renderer_->setDrawnLayerShown(j, shown);
}

void Viewer::setExaggeration(double exaggeration) {
  finishSelection();  // the selection job reads the heights
  if (exaggeration == this->exaggeration()) return;
  // The frame's heights own it (a projected scene's bounds: the pieces' heights are refreshed at
  // the next frame; the globe's grid: its terrain and the layers' tiles are made again).
  renderer_->setExaggeration(exaggeration);
  if (globe_) {
    // The camera's ground is the new grid.
    GlobeMode& g = *globe_;
    const scene::GlobePose pose = g.controller->pose();
    g.controller->setGround(globeScene().heights.get());
    g.controller->setPose(pose);
    layersRebuilt();  // the layers were built again: their outlines, table and selection too
    return;
  }
  selectionChanged();
}

double Viewer::exaggeration() const { return scene_ ? scene_->exaggeration() : 1.0; }

void Viewer::useTechnique(const overlay::TechniqueInfo& technique, int textureSize) {
  const std::span<const int> sizes = technique.textureSizes;
  int size = drapeSize_;
  if (textureSize > 0) {
    size = textureSize;
  } else if (technique.usesTextures() && std::find(sizes.begin(), sizes.end(), size) == sizes.end()) {
    size = technique.defaultTextureSize;
  }
  if (renderer_) {
    finishSelection();  // the selection job reads the layers
    Diagnostics d;
    const bool drawn = renderer_->setTechnique(technique, size, d);
    message(d);
    if (!drawn) return;
    layersRebuilt();
  }
  technique_ = &technique;
  drapeSize_ = size;
}

void Viewer::rebuildOverlays() {
  // Styles, order and the method are baked into the pieces: rebuild (Olinda: a fraction of a
  // second), keeping which layers are hidden.
  finishSelection();  // the selection job reads the layers
  message(renderer_->restyle(description_->layers));
  layersRebuilt();
}

void Viewer::layersRebuilt() {
  outlines_.clear();
  if (table_) table_->dirty = true;
  selectionChanged();
}

void Viewer::addLasso(overlay::SelectionOp op, std::vector<glm::dvec2> points) {
  const glm::ivec2 fb = framebufferSize();
  overlay::SelectionStep step;
  step.op = op;
  // In the view the lasso was drawn in (the last frame's); on the globe it reaches that eye's
  // horizon, not through the globe to its other side.
  step.lasso = scene_->lassoIn(frameCamera(), std::move(points), fb.x, fb.y);
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
  if (steps_.empty() || !scene_ || !renderer_) return;
  const glm::ivec2 fb = framebufferSize();
  const std::vector<overlay::SelectionStep> steps = steps_;
  jobGeneration_ = selectionGeneration_;
  // Reads the scene and the layers only; whatever changes them waits for it first
  // (finishSelection). Features are sampled at half a pixel's footprint at the view's target.
  const scene::FrameCamera camera = frameCamera();
  const int width = std::max(fb.x, 1), height = std::max(fb.y, 1);
  const scene::FrameRenderer* renderer = renderer_.get();
  const auto job = [renderer, steps, camera, width, height] {
    return renderer->selectFeatures(steps, camera, width, height, std::nullopt);
  };
  // A paged projected scene loads tiles while it draws, so it selects in this thread.
  const bool paged = !globe_ && projected().paged();
  selectionJob_ = std::async(paged ? std::launch::deferred : std::launch::async, job);
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
  const Diagnostics d = renderer_->exportSelection(*selected_, path, beside);
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
    ok = scene::writeJsonFile(stem.string() + "_camera.json",
                              scene_->cameraJson(frameCamera(), target_->width(), target_->height())) &&
         ok;
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
