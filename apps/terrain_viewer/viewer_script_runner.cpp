// A viewer script, run frame by frame: each step's action on the viewer (app/viewer_script.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <variant>
#include <vector>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <nlohmann/json.hpp>

#include "scene/json_file.hpp"
#include "viewer.hpp"

namespace gis::viewer {

void Viewer::advanceScript(double seconds, const InputFrame& window) {
  if (loading_) return;  // the next steps act on the scene being read
  if (live_) {
    // The real mouse and keys, as without a script, until the test says it is done and every
    // event that came before is handled (they are taken a frame at a time, and slow frames may
    // still hold some when the file appears).
    handleInput(seconds, window);
    std::error_code ec;
    if (events_.empty() && std::filesystem::exists(live_->first, ec)) {
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
}

namespace {

/// Without a scene (it failed to load) only what needs none runs.
bool needsScene(const app::ScriptAction& action) {
  if (const auto* shot = std::get_if<app::ScreenshotStep>(&action)) return !shot->ui;
  return !std::holds_alternative<app::WaitStep>(action) && !std::holds_alternative<app::SaveStateStep>(action) &&
         !std::holds_alternative<app::DropStep>(action) && !std::holds_alternative<app::ResizeStep>(action) &&
         !std::holds_alternative<app::QuitStep>(action);
}

}  // namespace

/// Runs one step's action on the viewer, a call per action: false when it failed (reported).
struct StepRunner {
  Viewer& v;
  const std::string& where;  ///< the script and the step, for messages

  std::optional<std::size_t> sceneLayer(const std::string& name) const {
    for (std::size_t i = 0; v.description_ && i < v.description_->layers.size(); ++i) {
      if (v.description_->layers[i].name == name) return i;
    }
    v.message(where + ": no layer named '" + name + "'", true);
    return std::nullopt;
  }

  /// Writes `j` to `path`; false (reported) when it cannot.
  bool write(const std::string& path, const nlohmann::json& j) const {
    const bool written = scene::writeJsonFile(path, j);
    if (!written) v.message(where + ": cannot write " + path, true);
    return written;
  }

  /// The GLFW keys of key names; none when the viewer lacks one (reported).
  std::optional<std::vector<int>> keyCodes(const std::vector<std::string>& names) const {
    std::vector<int> codes;
    for (const std::string& name : names) {
      const int code = Viewer::keyCode(name);
      if (code == GLFW_KEY_UNKNOWN) {
        v.message(where + ": the viewer has no key '" + name + "'", true);
        return std::nullopt;
      }
      codes.push_back(code);
    }
    return codes;
  }

  /// A press at the first point, `frames` frames along each segment, a release at the last.
  void playMouse(app::MouseButton button, const app::Modifiers& modifiers, const std::vector<glm::dvec2>& path,
                 int frames) const {
    InputFrame in;
    in.modifiers = modifiers;
    const auto press = [&](bool down) {
      in.left = down && button == app::MouseButton::Left;
      in.right = down && button == app::MouseButton::Right;
      in.middle = down && button == app::MouseButton::Middle;
    };
    // First the cursor arrives with the button up, so the press happens where it should.
    in.cursor = path.front();
    v.scriptInput_.push_back(in);
    press(true);
    v.scriptInput_.push_back(in);
    for (std::size_t i = 1; i < path.size(); ++i) {
      for (int f = 1; f <= frames; ++f) {
        in.cursor = glm::mix(path[i - 1], path[i], static_cast<double>(f) / frames);
        v.scriptInput_.push_back(in);
      }
    }
    press(false);
    v.scriptInput_.push_back(in);
  }

  bool operator()(const app::CameraStep& step) const {
    if (v.globe_) {
      v.message(where + ": a projected camera on the globe: use {\"globe_camera\": {...}}", true);
      return false;
    }
    Result<scene::CameraSpec> spec = scene::parseCameraSpec(step.camera, step.cameraFile);
    v.message(spec.diagnostics, where, true);
    if (!spec) return false;
    Result<scene::Camera> placed = scene::placeCamera(*spec, v.projected().frame, where);
    v.message(placed.diagnostics, where, true);
    if (!placed) return false;
    v.settings_.fovYDeg = spec->fovYDeg;
    if (step.seconds > 0.0) {
      v.controller_->animateTo(*placed, step.seconds);
      v.animating_ = true;
    } else {
      v.controller_->jumpTo(*placed);
    }
    return true;
  }

  bool operator()(const app::WaitStep& step) const {
    v.waitFrames_ = step.frames;
    return true;
  }

  bool operator()(const app::ToggleLayerStep& step) const {
    const auto i = sceneLayer(step.layer);
    if (!i) return false;
    v.setLayerShown(*i, !v.layerShown(*i).value_or(false));
    return true;
  }

  bool operator()(const app::SetLayerStep& step) const {
    const auto i = sceneLayer(step.layer);
    if (!i) return false;
    overlay::LayerStyle& style = v.description_->layers[*i].style;
    if (step.color) style.color = *step.color;
    if (step.opacity) style.opacity = *step.opacity;
    if (step.width) style.widthMetres = static_cast<float>(*step.width);
    if (step.outlineColor) style.outlineColor = *step.outlineColor;
    if (step.outlineWidth) {
      style.outlineWidthMetres = static_cast<float>(*step.outlineWidth);
      style.outlineWidthPixels = 0.0F;
    }
    bool rebuild = step.color || step.opacity || step.width || step.outlineColor || step.outlineWidth;
    if (step.colorAttribute && step.colorAttribute->empty()) {
      style.colorAttribute.clear();
      style.categories.clear();
      rebuild = true;
    } else if (step.colorAttribute) {
      if (!v.setCategories(*i, *step.colorAttribute)) {
        v.message(where + ": cannot colour '" + step.layer + "' by '" + *step.colorAttribute + "'", true);
        return false;
      }
      rebuild = true;
    }
    if (rebuild) v.rebuildOverlays();
    if (step.visible) v.setLayerShown(*i, *step.visible);
    if (step.labelAttribute) v.setLabels(*i, *step.labelAttribute);
    return true;
  }

  bool operator()(const app::TableStep& step) const {
    const auto i = sceneLayer(step.layer);
    if (!i) return false;
    if (step.close) {
      v.table_.reset();
      return true;
    }
    if (!v.table_ || v.table_->sceneLayer != *i) v.openTable(*i);
    if (!v.table_) return false;
    AttributeTable& t = *v.table_;
    const auto column = [&](const std::string& name) -> std::optional<int> {
      const auto c = std::find(t.columns.begin(), t.columns.end(), name);
      if (c != t.columns.end()) return static_cast<int>(c - t.columns.begin());
      v.message(where + ": the layer '" + step.layer + "' has no attribute '" + name + "'", true);
      return std::nullopt;
    };
    if (step.search) std::snprintf(t.search.data(), t.search.size(), "%s", step.search->c_str());
    if (step.searchIn) {
      const std::optional<int> c = column(*step.searchIn);
      if (!c) return false;
      t.searchColumn = *c;
    }
    if (step.sortBy) {
      if (*step.sortBy == "fid") {
        t.sortColumn = 0;
      } else {
        const std::optional<int> c = column(*step.sortBy);
        if (!c) return false;
        t.sortColumn = *c + 1;
      }
      t.sortAscending = !step.descending;
      t.showSort = true;
    }
    v.refreshTableRows();
    if (step.select) {
      t.selectedRows.clear();
      const std::vector<geo::Feature>& features = *v.featuresOf(t.sceneLayer);
      for (const std::int64_t fid : *step.select) {
        const auto f =
            std::find_if(features.begin(), features.end(), [&](const geo::Feature& x) { return x.fid == fid; });
        if (f == features.end()) {
          v.message(where + ": the layer '" + step.layer + "' has no feature " + std::to_string(fid), true);
          return false;
        }
        t.selectedRows.insert(static_cast<std::size_t>(f - features.begin()));
      }
    }
    if (step.zoomTo == "layer") {
      v.zoomToLayer(*i);
      v.animating_ = true;
    } else if (step.zoomTo == "rows") {
      v.zoomToFeatures(t.sceneLayer, std::vector<std::size_t>(t.selectedRows.begin(), t.selectedRows.end()));
      v.animating_ = true;
    }
    return true;
  }

  bool operator()(const app::MeasureStep& step) const {
    if (!v.measureAtPixels(step.points, step.closed)) {
      v.message(where + ": a measured point is not on the terrain", true);
      return false;
    }
    return true;
  }

  bool operator()(const app::OverlaysStep& step) const {
    v.render_.overlays = step.on;
    return true;
  }

  bool operator()(const app::MethodStep& step) const {
    v.useTechnique(*overlay::findTechnique(step.name), step.drapeSize);  // checked when the script was read
    return true;
  }

  bool operator()(const app::ExaggerationStep& step) const {
    v.setExaggeration(step.value);
    return true;
  }

  bool operator()(const app::LassoStep& step) const {
    v.addLasso(step.op, step.points);
    return true;
  }

  bool operator()(const app::InvertStep&) const {
    v.invertSelection();
    return true;
  }

  bool operator()(const app::ClearSelectionStep&) const {
    v.clearSelection();
    return true;
  }

  bool operator()(const app::IdentifyStep& step) const {
    v.identified_ = v.identify(step.at);
    if (step.out.empty()) return true;
    return write(step.out, v.identified_ ? v.identified_->toJson() : nlohmann::json(nullptr));
  }

  bool operator()(const app::ExportStep& step) const { return v.exportSelection(step.path); }

  bool operator()(const app::ScreenshotStep& step) const {
    v.pendingShot_ = {std::filesystem::path(step.path), step.ui};
    return true;
  }

  bool operator()(const app::HomeStep&) const {
    v.goHome();
    v.animating_ = true;
    return true;
  }

  bool operator()(const app::KeyStep& step) const {
    std::optional<std::vector<int>> codes = keyCodes({step.key});
    if (!codes) return false;
    InputFrame in;
    in.cursor = v.lastPixel_;
    for (const int code : *codes) in.pressed.push_back({code, {}});
    v.scriptInput_.push_back(in);
    return true;
  }

  bool operator()(const app::HoldKeysStep& step) const {
    std::optional<std::vector<int>> codes = keyCodes(step.keys);
    if (!codes) return false;
    InputFrame in;
    in.cursor = v.lastPixel_;
    in.modifiers = step.modifiers;
    in.held = std::move(*codes);
    v.scriptInput_.insert(v.scriptInput_.end(), static_cast<std::size_t>(step.frames), in);
    return true;
  }

  bool operator()(const app::DragStep& step) const {
    playMouse(step.button, step.modifiers, step.points, step.frames);
    return true;
  }

  bool operator()(const app::ClickStep& step) const {
    playMouse(step.button, step.modifiers, {step.at}, 0);
    return true;
  }

  bool operator()(const app::ScrollStep& step) const {
    InputFrame in;
    in.cursor = step.at;
    in.scroll = step.amount;
    v.scriptInput_.push_back(in);
    return true;
  }

  bool operator()(const app::ResizeStep& step) const {
    glfwSetWindowSize(v.context_->window(), step.window.x, step.window.y);
    v.waitFrames_ = 2;  // the window system answers within a frame or two
    return true;
  }

  bool operator()(const app::ViewStep& step) const {
    if (step.wireframe) v.render_.wireframe = *step.wireframe;
    if (step.imagery) v.settings_.imagery = *step.imagery;
    if (step.debugPieces) v.debugPieces_ = *step.debugPieces;
    if (step.panel) v.settings_.showPanel = *step.panel;
    if (step.hud) v.settings_.showHud = *step.hud;
    if (step.legend) v.showLegend_ = *step.legend;
    if (step.labels) v.showLabels_ = *step.labels;
    if (step.lodTolerance) v.settings_.lodTolerancePixels = *step.lodTolerance;
    if (step.fovYDeg) v.settings_.fovYDeg = *step.fovYDeg;
    return true;
  }

  bool operator()(const app::LiveStep& step) const {
    v.live_ = {std::filesystem::path(step.untilFile), step.maxFrames};
    v.events_.clear();  // forget what arrived before: only the live input counts
    return true;
  }

  bool operator()(const app::DropStep& step) const {
    v.dropped_.insert(v.dropped_.end(), step.paths.begin(), step.paths.end());
    v.waitFrames_ = 1;  // loaded at the start of the next frame, as a person's drop
    return true;
  }

  bool operator()(const app::SaveStateStep& step) const {
    v.finishSelection();  // the state holds the logical selection of every lasso so far
    return write(step.path, v.state());
  }

  bool operator()(const app::GlobeCameraStep& step) const {
    if (!v.globe_) {
      v.message(where + ": a globe camera needs a scene on the globe (this one is projected: use \"camera\")", true);
      return false;
    }
    scene::GlobePose p;
    p.target.lon = step.lon;
    p.target.lat = step.lat;
    p.distance = step.distance;
    p.heading = std::remainder(step.heading * std::numbers::pi / 180.0, 2.0 * std::numbers::pi);
    p.pitch = step.pitch * std::numbers::pi / 180.0;
    v.globe_->controller->setPose(p);
    v.animating_ = true;  // the next steps see a frame drawn from it
    return true;
  }

  bool operator()(const app::QuitStep&) const {
    v.quit_ = true;
    return true;
  }
};

bool Viewer::runStep(const app::ScriptStep& step) {
  const std::string where = script_->file + ": step " + std::to_string(step.index);
  if (!scene_ && needsScene(step.action)) {
    message(where + ": no scene is loaded", true);
    return false;
  }
  return std::visit(StepRunner{*this, where}, step.action);
}

}  // namespace gis::viewer
