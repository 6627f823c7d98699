// Viewer scripts: every action reads into its fields, paths resolve against the script file, and
// every broken step is an error naming the file and "step N" that stops the whole script.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <variant>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/viewer_script.hpp"
#include "temp_dir_test.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class ViewerScript : public TempDirTest {};

bool hasDiagnostic(const Diagnostics& d, Severity severity, const std::string& file, const std::string& feature,
                   const std::string& text) {
  for (const Diagnostic& item : d.items()) {
    if (item.severity == severity && item.file == file && item.feature == feature &&
        item.message.find(text) != std::string::npos)
      return true;
  }
  return false;
}

std::string dump(const Diagnostics& d) {
  std::string out;
  for (const Diagnostic& item : d.items()) out += item.toString() + "\n";
  return out;
}

/// The step's action as a `Step`; std::get throws, failing the test, when it is another action.
template <typename Step>
const Step& as(const app::ScriptStep& step) {
  return std::get<Step>(step.action);
}

/// A script of one good step, then `step`, then another good step.
json scriptAround(const json& step) {
  return json{{"steps", json::array({json{{"action", "home"}}, step, json{{"wait", 1}}})}};
}

const json kCamera = json::parse(R"({"eye": {"lon": -34.88, "lat": -8.05, "h": 3000},
                                     "target": {"lon": -34.87, "lat": -7.99, "h": 0}})");

TEST_F(ViewerScript, EveryActionReadsItsFields) {
  const std::string file = (dir_ / "script.json").string();
  json j = json::parse(R"({
    "window": [960, 640],
    "steps": [
      {"camera": {"eye_xyz": [0, -100, 50], "target_xyz": [0, 0, 0], "fov_y_deg": 40}, "seconds": 1.5},
      {"camera": {"eye_xyz": [1, 2, 3], "target_xyz": [0, 0, 0]}},
      {"wait": 10},
      {"action": "toggle_layer", "layer": "streets"},
      {"action": "set_layer", "layer": "census tracts", "visible": true, "opacity": 0.5, "color": "#ff8800",
       "width": 4},
      {"action": "set_layer", "layer": "roads", "visible": false},
      {"action": "overlays", "on": false},
      {"action": "method", "value": "paper"},
      {"action": "exaggeration", "value": 2.0},
      {"action": "lasso", "op": "xor", "points": [[10, 20], [300.5, 40], [150, 200]]},
      {"action": "invert"},
      {"action": "clear_selection"},
      {"action": "identify", "x": 100, "y": 80.5, "out": "identify.json"},
      {"action": "export", "path": "selected.json"},
      {"action": "screenshot", "path": "shot.png", "ui": false},
      {"action": "home"},
      {"action": "key", "key": "o"},
      {"action": "quit"}
    ]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, file);
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_TRUE(s.diagnostics.empty()) << dump(s.diagnostics);
  EXPECT_EQ(s->file, file);
  ASSERT_TRUE(s->window.has_value());
  EXPECT_EQ(s->window->x, 960);
  EXPECT_EQ(s->window->y, 640);
  const std::vector<app::ScriptStep>& st = s->steps;
  ASSERT_EQ(st.size(), 18u);
  for (std::size_t i = 0; i < st.size(); ++i) EXPECT_EQ(st[i].index, i + 1);

  EXPECT_TRUE(std::holds_alternative<app::CameraStep>(st[0].action));
  EXPECT_EQ(as<app::CameraStep>(st[0]).camera["fov_y_deg"], 40);
  EXPECT_EQ(as<app::CameraStep>(st[0]).camera["eye_xyz"], json::array({0, -100, 50}));
  EXPECT_EQ(as<app::CameraStep>(st[0]).cameraFile, file);
  EXPECT_DOUBLE_EQ(as<app::CameraStep>(st[0]).seconds, 1.5);
  EXPECT_TRUE(std::holds_alternative<app::CameraStep>(st[1].action));
  EXPECT_DOUBLE_EQ(as<app::CameraStep>(st[1]).seconds, 0.0);  // absent: a jump

  EXPECT_TRUE(std::holds_alternative<app::WaitStep>(st[2].action));
  EXPECT_EQ(as<app::WaitStep>(st[2]).frames, 10);

  EXPECT_TRUE(std::holds_alternative<app::ToggleLayerStep>(st[3].action));
  EXPECT_EQ(as<app::ToggleLayerStep>(st[3]).layer, "streets");

  EXPECT_TRUE(std::holds_alternative<app::SetLayerStep>(st[4].action));
  EXPECT_EQ(as<app::SetLayerStep>(st[4]).layer, "census tracts");
  EXPECT_EQ(as<app::SetLayerStep>(st[4]).visible, std::optional<bool>(true));
  ASSERT_TRUE(as<app::SetLayerStep>(st[4]).opacity.has_value());
  EXPECT_FLOAT_EQ(*as<app::SetLayerStep>(st[4]).opacity, 0.5F);
  ASSERT_TRUE(as<app::SetLayerStep>(st[4]).color.has_value());
  EXPECT_FLOAT_EQ(as<app::SetLayerStep>(st[4]).color->x, 1.0F);
  EXPECT_FLOAT_EQ(as<app::SetLayerStep>(st[4]).color->y, 136.0F / 255.0F);
  EXPECT_FLOAT_EQ(as<app::SetLayerStep>(st[4]).color->z, 0.0F);
  EXPECT_FLOAT_EQ(as<app::SetLayerStep>(st[4]).color->w, 1.0F);
  EXPECT_EQ(as<app::SetLayerStep>(st[4]).width, std::optional<double>(4.0));
  // Only what is given is set.
  EXPECT_EQ(as<app::SetLayerStep>(st[5]).visible, std::optional<bool>(false));
  EXPECT_FALSE(as<app::SetLayerStep>(st[5]).opacity.has_value());
  EXPECT_FALSE(as<app::SetLayerStep>(st[5]).color.has_value());
  EXPECT_FALSE(as<app::SetLayerStep>(st[5]).width.has_value());

  EXPECT_TRUE(std::holds_alternative<app::OverlaysStep>(st[6].action));
  EXPECT_FALSE(as<app::OverlaysStep>(st[6]).on);
  EXPECT_TRUE(std::holds_alternative<app::MethodStep>(st[7].action));
  EXPECT_EQ(as<app::MethodStep>(st[7]).name, "paper");
  EXPECT_TRUE(std::holds_alternative<app::ExaggerationStep>(st[8].action));
  EXPECT_DOUBLE_EQ(as<app::ExaggerationStep>(st[8]).value, 2.0);

  EXPECT_TRUE(std::holds_alternative<app::LassoStep>(st[9].action));
  EXPECT_EQ(as<app::LassoStep>(st[9]).op, overlay::SelectionOp::Xor);
  ASSERT_EQ(as<app::LassoStep>(st[9]).points.size(), 3u);
  EXPECT_DOUBLE_EQ(as<app::LassoStep>(st[9]).points[1].x, 300.5);
  EXPECT_DOUBLE_EQ(as<app::LassoStep>(st[9]).points[1].y, 40.0);

  EXPECT_TRUE(std::holds_alternative<app::InvertStep>(st[10].action));
  EXPECT_TRUE(std::holds_alternative<app::ClearSelectionStep>(st[11].action));

  EXPECT_TRUE(std::holds_alternative<app::IdentifyStep>(st[12].action));
  EXPECT_DOUBLE_EQ(as<app::IdentifyStep>(st[12]).at.x, 100.0);
  EXPECT_DOUBLE_EQ(as<app::IdentifyStep>(st[12]).at.y, 80.5);
  EXPECT_EQ(as<app::IdentifyStep>(st[12]).out, (dir_ / "identify.json").string());

  EXPECT_TRUE(std::holds_alternative<app::ExportStep>(st[13].action));
  EXPECT_EQ(as<app::ExportStep>(st[13]).path, (dir_ / "selected.json").string());

  EXPECT_TRUE(std::holds_alternative<app::ScreenshotStep>(st[14].action));
  EXPECT_EQ(as<app::ScreenshotStep>(st[14]).path, (dir_ / "shot.png").string());
  EXPECT_FALSE(as<app::ScreenshotStep>(st[14]).ui);

  EXPECT_TRUE(std::holds_alternative<app::HomeStep>(st[15].action));
  EXPECT_TRUE(std::holds_alternative<app::KeyStep>(st[16].action));
  EXPECT_EQ(as<app::KeyStep>(st[16]).key, "o");
  EXPECT_TRUE(std::holds_alternative<app::QuitStep>(st[17].action));
}

TEST_F(ViewerScript, MouseKeysAndWindowActionsReadTheirFields) {
  json j = json::parse(R"({"steps": [
      {"action": "drag", "button": "right", "points": [[10, 20], [30.5, 40], [50, 60]], "frames": 4,
       "modifiers": ["shift", "alt"]},
      {"action": "drag", "points": [[1, 2], [3, 4]]},
      {"action": "click", "at": [7, 8.5], "modifiers": ["ctrl"]},
      {"action": "scroll", "at": [100, 50], "amount": -2.5},
      {"action": "scroll", "at": [1, 1]},
      {"action": "hold_keys", "keys": ["w", "Q"], "frames": 12, "modifiers": ["shift"]},
      {"action": "resize", "window": [640, 480]},
      {"action": "save_state", "path": "state.json"},
      {"action": "method", "value": "drape", "drape_size": 4096},
      {"action": "method", "value": "drape"},
      {"action": "method", "value": "drape-tiles", "drape_size": 256}]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, (dir_ / "s.json").string());
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_TRUE(s.diagnostics.empty()) << dump(s.diagnostics);
  const std::vector<app::ScriptStep>& st = s->steps;
  ASSERT_EQ(st.size(), 11u);
  EXPECT_TRUE(std::holds_alternative<app::DragStep>(st[0].action));
  EXPECT_EQ(as<app::DragStep>(st[0]).button, app::MouseButton::Right);
  ASSERT_EQ(as<app::DragStep>(st[0]).points.size(), 3u);
  EXPECT_DOUBLE_EQ(as<app::DragStep>(st[0]).points[1].x, 30.5);
  EXPECT_EQ(as<app::DragStep>(st[0]).frames, 4);
  EXPECT_TRUE(as<app::DragStep>(st[0]).modifiers.shift);
  EXPECT_FALSE(as<app::DragStep>(st[0]).modifiers.ctrl);
  EXPECT_TRUE(as<app::DragStep>(st[0]).modifiers.alt);
  // Defaults: the left button, 6 frames per segment, no modifiers.
  EXPECT_EQ(as<app::DragStep>(st[1]).button, app::MouseButton::Left);
  EXPECT_EQ(as<app::DragStep>(st[1]).frames, 6);
  EXPECT_FALSE(as<app::DragStep>(st[1]).modifiers.shift || as<app::DragStep>(st[1]).modifiers.ctrl ||
               as<app::DragStep>(st[1]).modifiers.alt);
  EXPECT_TRUE(std::holds_alternative<app::ClickStep>(st[2].action));
  EXPECT_DOUBLE_EQ(as<app::ClickStep>(st[2]).at.y, 8.5);
  EXPECT_TRUE(as<app::ClickStep>(st[2]).modifiers.ctrl);
  EXPECT_TRUE(std::holds_alternative<app::ScrollStep>(st[3].action));
  EXPECT_DOUBLE_EQ(as<app::ScrollStep>(st[3]).at.x, 100.0);
  EXPECT_DOUBLE_EQ(as<app::ScrollStep>(st[3]).amount, -2.5);
  EXPECT_DOUBLE_EQ(as<app::ScrollStep>(st[4]).amount, 1.0);  // one step in by default
  EXPECT_TRUE(std::holds_alternative<app::HoldKeysStep>(st[5].action));
  EXPECT_EQ(as<app::HoldKeysStep>(st[5]).keys, (std::vector<std::string>{"w", "Q"}));
  EXPECT_EQ(as<app::HoldKeysStep>(st[5]).frames, 12);
  EXPECT_TRUE(as<app::HoldKeysStep>(st[5]).modifiers.shift);
  EXPECT_TRUE(std::holds_alternative<app::ResizeStep>(st[6].action));
  EXPECT_EQ(as<app::ResizeStep>(st[6]).window, glm::ivec2(640, 480));
  EXPECT_TRUE(std::holds_alternative<app::SaveStateStep>(st[7].action));
  EXPECT_EQ(as<app::SaveStateStep>(st[7]).path, (dir_ / "state.json").string());
  EXPECT_TRUE(std::holds_alternative<app::MethodStep>(st[8].action));
  EXPECT_EQ(as<app::MethodStep>(st[8]).name, "drape");
  EXPECT_EQ(as<app::MethodStep>(st[8]).drapeSize, 4096);
  EXPECT_EQ(as<app::MethodStep>(st[9]).drapeSize, 0);  // the viewer's size stays
  EXPECT_EQ(as<app::MethodStep>(st[10]).name, "drape-tiles");
  EXPECT_EQ(as<app::MethodStep>(st[10]).drapeSize, 256);
}

TEST_F(ViewerScript, DefaultsWhenOptionalFieldsAreAbsent) {
  json j = json::parse(R"({"steps": [{"action": "screenshot", "path": "a.png"},
                                     {"action": "identify", "x": 1, "y": 2},
                                     {"action": "method", "value": "stencil"},
                                     {"action": "overlays", "on": true}]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, (dir_ / "s.json").string());
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_FALSE(s->window.has_value());
  EXPECT_TRUE(as<app::ScreenshotStep>(s->steps[0]).ui);
  EXPECT_TRUE(as<app::IdentifyStep>(s->steps[1]).out.empty());  // no "out": the result is not written
  EXPECT_EQ(as<app::MethodStep>(s->steps[2]).name, "stencil");
  EXPECT_TRUE(as<app::OverlaysStep>(s->steps[3]).on);
}

TEST_F(ViewerScript, ColoursAsHexOrArrays) {
  const auto colourOf = [&](const json& c) -> std::optional<glm::vec4> {
    Result<app::ViewerScript> s = app::parseViewerScript(
        json{{"steps", json::array({json{{"action", "set_layer"}, {"layer", "a"}, {"color", c}}})}}, "s.json");
    if (!s.ok()) return std::nullopt;
    return as<app::SetLayerStep>(s->steps[0]).color;
  };
  const std::optional<glm::vec4> withAlpha = colourOf("#00ff0080");
  ASSERT_TRUE(withAlpha.has_value());
  EXPECT_FLOAT_EQ(withAlpha->y, 1.0F);
  EXPECT_FLOAT_EQ(withAlpha->w, 128.0F / 255.0F);
  const std::optional<glm::vec4> rgb = colourOf(json::array({0.25, 0.5, 1}));
  ASSERT_TRUE(rgb.has_value());
  EXPECT_FLOAT_EQ(rgb->x, 0.25F);
  EXPECT_FLOAT_EQ(rgb->z, 1.0F);
  EXPECT_FLOAT_EQ(rgb->w, 1.0F);
  const std::optional<glm::vec4> rgba = colourOf(json::array({0, 0, 0, 0.75}));
  ASSERT_TRUE(rgba.has_value());
  EXPECT_FLOAT_EQ(rgba->w, 0.75F);
  EXPECT_FALSE(colourOf("#ff88").has_value());
  EXPECT_FALSE(colourOf("orange").has_value());
  EXPECT_FALSE(colourOf(json::array({0, 0})).has_value());
  EXPECT_FALSE(colourOf(json::array({0, 0, 2})).has_value());
}

TEST_F(ViewerScript, KeysAreCharactersOrNames) {
  const auto keyOf = [](const std::string& key) -> std::optional<std::string> {
    Result<app::ViewerScript> s =
        app::parseViewerScript(json{{"steps", json::array({json{{"action", "key"}, {"key", key}}})}}, "s.json");
    if (!s.ok()) return std::nullopt;
    return as<app::KeyStep>(s->steps[0]).key;
  };
  EXPECT_EQ(keyOf("o"), std::optional<std::string>("o"));
  EXPECT_EQ(keyOf("O"), std::optional<std::string>("O"));  // a character stays as typed
  EXPECT_EQ(keyOf("+"), std::optional<std::string>("+"));
  EXPECT_EQ(keyOf("F12"), std::optional<std::string>("f12"));
  EXPECT_EQ(keyOf("Escape"), std::optional<std::string>("escape"));
  EXPECT_EQ(keyOf("page_down"), std::optional<std::string>("page_down"));
  EXPECT_FALSE(keyOf("F26").has_value());
  EXPECT_FALSE(keyOf("escpae").has_value());
  EXPECT_FALSE(keyOf("\t").has_value());
}

TEST_F(ViewerScript, RelativePathsResolveAgainstTheScriptsDirectory) {
  const std::string file = (dir_ / "scripts" / "s.json").string();
  json j = json::parse(R"({"steps": [
      {"action": "screenshot", "path": "out/shot.png"},
      {"action": "export", "path": "../selected.json"},
      {"action": "identify", "x": 0, "y": 0, "out": "/var/tmp/identify.json"},
      {"action": "screenshot", "path": "/abs/dir/../shot.png"}]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, file);
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_EQ(as<app::ScreenshotStep>(s->steps[0]).path, (dir_ / "scripts" / "out" / "shot.png").string());
  EXPECT_EQ(as<app::ExportStep>(s->steps[1]).path, (dir_ / "selected.json").string());
  EXPECT_EQ(as<app::IdentifyStep>(s->steps[2]).out, "/var/tmp/identify.json");
  EXPECT_EQ(as<app::ScreenshotStep>(s->steps[3]).path, "/abs/shot.png");  // absolute: only normalised
}

TEST_F(ViewerScript, ARelativeScriptNameStillGivesAbsolutePaths) {
  Result<app::ViewerScript> s =
      app::parseViewerScript(json::parse(R"({"steps": [{"action": "export", "path": "sel.json"}]})"), "sub/s.json");
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_EQ(as<app::ExportStep>(s->steps[0]).path, (fs::current_path() / "sub" / "sel.json").string());
}

TEST_F(ViewerScript, CameraMayBeACameraFileBesideTheScript) {
  const std::string cameraFile = write("cams/view.json", kCamera.dump());
  const std::string file = write("s.json", R"({"steps": [{"camera": "cams/view.json", "seconds": 2}]})");
  Result<app::ViewerScript> s = app::loadViewerScript(file);
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  ASSERT_EQ(s->steps.size(), 1u);
  EXPECT_EQ(as<app::CameraStep>(s->steps[0]).camera, kCamera);
  EXPECT_EQ(as<app::CameraStep>(s->steps[0]).cameraFile, cameraFile);
  EXPECT_DOUBLE_EQ(as<app::CameraStep>(s->steps[0]).seconds, 2.0);
}

TEST_F(ViewerScript, AMissingCameraFileIsAnErrorOfTheStep) {
  const std::string file = write("s.json", R"({"steps": [{"wait": 1}, {"camera": "nope.json"}]})");
  Result<app::ViewerScript> s = app::loadViewerScript(file);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, file, "step 2", "nope.json")) << dump(s.diagnostics);
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, (dir_ / "nope.json").string(), "", "cannot open"))
      << dump(s.diagnostics);
}

struct BrokenStep {
  const char* what;
  json step;
  const char* mentions;  ///< part of the message
};

TEST_F(ViewerScript, EachKindOfBrokenStepIsAnErrorNamingFileAndStep) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<BrokenStep> cases = {
      {"not an object", json::array({1, 2}), "expected an object"},
      {"no kind", json{{"seconds", 1}}, "exactly one of"},
      {"two kinds", json{{"wait", 1}, {"action", "home"}}, "exactly one of"},
      {"unknown action", json{{"action", "fly"}}, "unknown action 'fly'"},
      {"action not a string", json{{"action", 3}}, "'action': expected a string"},
      {"missing layer", json{{"action", "toggle_layer"}}, "missing 'layer'"},
      {"layer of wrong type", json{{"action", "toggle_layer"}, {"layer", 7}}, "'layer'"},
      {"visible of wrong type", json{{"action", "set_layer"}, {"layer", "a"}, {"visible", "yes"}}, "'visible'"},
      {"opacity out of range", json{{"action", "set_layer"}, {"layer", "a"}, {"opacity", 1.5}}, "'opacity'"},
      {"bad colour", json{{"action", "set_layer"}, {"layer", "a"}, {"color", "#xyzxyz"}}, "'color'"},
      {"zero width", json{{"action", "set_layer"}, {"layer", "a"}, {"width", 0}}, "'width'"},
      {"nothing to set", json{{"action", "set_layer"}, {"layer", "a"}}, "nothing to set"},
      {"missing on", json{{"action", "overlays"}}, "missing 'on'"},
      {"unknown method", json{{"action", "method"}, {"value", "raster"}}, "unknown method 'raster'"},
      {"non-finite exaggeration", json{{"action", "exaggeration"}, {"value", inf}}, "'value'"},
      {"negative exaggeration", json{{"action", "exaggeration"}, {"value", -1}}, "'value'"},
      {"unknown op", json{{"action", "lasso"}, {"op", "nand"}, {"points", json::parse("[[0,0],[1,0],[0,1]]")}},
       "unknown operator 'nand'"},
      {"invert as op", json{{"action", "lasso"}, {"op", "invert"}, {"points", json::parse("[[0,0],[1,0],[0,1]]")}},
       "{\"action\": \"invert\"}"},
      {"missing op", json{{"action", "lasso"}, {"points", json::parse("[[0,0],[1,0],[0,1]]")}}, "missing 'op'"},
      {"two points", json{{"action", "lasso"}, {"op", "or"}, {"points", json::parse("[[0,0],[1,0]]")}}, "at least 3"},
      {"NaN point",
       json{{"action", "lasso"},
            {"op", "or"},
            {"points", json::array({json::array({0, 0}), json::array({1, nan}), json::array({0, 1})})}},
       "at least 3"},
      {"points not pairs", json{{"action", "lasso"}, {"op", "or"}, {"points", json::parse("[[0,0,0],[1,0],[0,1]]")}},
       "'points'"},
      {"missing points", json{{"action", "lasso"}, {"op", "or"}}, "missing 'points'"},
      {"NaN identify", json{{"action", "identify"}, {"x", nan}, {"y", 0}}, "'x'"},
      {"missing identify y", json{{"action", "identify"}, {"x", 1}}, "missing 'y'"},
      {"missing export path", json{{"action", "export"}}, "missing 'path'"},
      {"empty screenshot path", json{{"action", "screenshot"}, {"path", ""}}, "'path'"},
      {"ui of wrong type", json{{"action", "screenshot"}, {"path", "a.png"}, {"ui", 1}}, "'ui'"},
      {"unknown key name", json{{"action", "key"}, {"key", "hyper"}}, "unknown key 'hyper'"},
      {"negative wait", json{{"wait", -3}}, "'wait'"},
      {"fractional wait", json{{"wait", 2.5}}, "'wait'"},
      {"wait of wrong type", json{{"wait", "10"}}, "'wait'"},
      {"negative seconds", json{{"camera", kCamera}, {"seconds", -1}}, "'seconds'"},
      {"NaN seconds", json{{"camera", kCamera}, {"seconds", nan}}, "'seconds'"},
      {"camera of wrong type", json{{"camera", 5}}, "'camera'"},
      {"camera without eye", json{{"camera", json{{"target_xyz", json::array({0, 0, 0})}}}}, "'eye'"},
      {"drape size too small", json{{"action", "method"}, {"value", "drape"}, {"drape_size", 8}}, "'drape_size'"},
      {"fractional drape size", json{{"action", "method"}, {"value", "drape"}, {"drape_size", 1000.5}}, "'drape_size'"},
      {"drag of one point", json{{"action", "drag"}, {"points", json::parse("[[0,0]]")}}, "at least 2"},
      {"drag without points", json{{"action", "drag"}}, "missing 'points'"},
      {"unknown button", json{{"action", "click"}, {"at", {1, 2}}, {"button", "fourth"}}, "unknown button 'fourth'"},
      {"unknown modifier", json{{"action", "click"}, {"at", {1, 2}}, {"modifiers", {"meta"}}}, "'modifiers'"},
      {"modifiers not a list", json{{"action", "click"}, {"at", {1, 2}}, {"modifiers", "shift"}}, "'modifiers'"},
      {"click without at", json{{"action", "click"}}, "missing 'at'"},
      {"NaN click", json{{"action", "click"}, {"at", {nan, 2}}}, "'at'"},
      {"zero frames", json{{"action", "drag"}, {"points", json::parse("[[0,0],[5,5]]")}, {"frames", 0}}, "'frames'"},
      {"zero scroll", json{{"action", "scroll"}, {"at", {1, 2}}, {"amount", 0}}, "'amount'"},
      {"hold without frames", json{{"action", "hold_keys"}, {"keys", {"w"}}}, "missing 'frames'"},
      {"hold an unknown key", json{{"action", "hold_keys"}, {"keys", {"w", "hyper"}}, {"frames", 3}}, "'keys'"},
      {"hold no keys", json{{"action", "hold_keys"}, {"keys", json::array()}, {"frames", 3}}, "'keys'"},
      {"resize to zero", json{{"action", "resize"}, {"window", {0, 300}}}, "'window'"},
      {"resize without size", json{{"action", "resize"}}, "missing 'window'"},
      {"save_state without path", json{{"action", "save_state"}}, "missing 'path'"},
  };
  const std::string file = (dir_ / "broken.json").string();
  for (const BrokenStep& c : cases) {
    Result<app::ViewerScript> s = app::parseViewerScript(scriptAround(c.step), file);
    EXPECT_FALSE(s.ok()) << c.what;
    EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, file, "step 2", c.mentions)) << c.what << "\n"
                                                                                           << dump(s.diagnostics);
    // Only the broken step is blamed, and the message as users see it names both.
    for (const Diagnostic& d : s.diagnostics.items()) {
      EXPECT_NE(d.feature, "step 1") << c.what;
      EXPECT_NE(d.feature, "step 3") << c.what;
    }
    EXPECT_NE(s.diagnostics.items().front().toString().find("broken.json"), std::string::npos) << c.what;
    EXPECT_NE(s.diagnostics.items().front().toString().find("step 2"), std::string::npos) << c.what;
  }
}

TEST_F(ViewerScript, EveryBrokenStepIsReportedAndTheScriptFailsAsAWhole) {
  json j = json::parse(R"({"steps": [{"wait": -1}, {"action": "home"}, {"action": "warp"},
                                     {"action": "lasso", "op": "or", "points": []}]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, "s.json");
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "step 1", "'wait'"));
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "step 3", "unknown action"));
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "step 4", "at least 3"));
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "", "3 of 4 steps cannot be run"))
      << dump(s.diagnostics);
}

TEST_F(ViewerScript, ABadWindowFailsTheScript) {
  for (const char* window : {R"([960])", R"([0, 640])", R"([960.5, 640])", R"("960x640")"}) {
    Result<app::ViewerScript> s =
        app::parseViewerScript(json::parse(std::string(R"({"window": )") + window + R"(, "steps": []})"), "s.json");
    EXPECT_FALSE(s.ok()) << window;
    EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "", "'window'")) << window;
  }
}

TEST_F(ViewerScript, WithoutAStepsArrayTheScriptFails) {
  for (const char* text : {R"({"window": [10, 10]})", R"({"steps": {}})", R"([1, 2])"}) {
    Result<app::ViewerScript> s = app::parseViewerScript(json::parse(text), "s.json");
    EXPECT_FALSE(s.ok()) << text;
    EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "", "'steps'")) << text;
  }
}

TEST_F(ViewerScript, UnknownKeysAreWarnings) {
  json j = json::parse(R"({"title": "demo", "steps": [{"action": "home", "speed": 3}, {"wait": 2}]})");
  Result<app::ViewerScript> s = app::parseViewerScript(j, "s.json");
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_EQ(s.diagnostics.count(Severity::Error), 0u);
  EXPECT_EQ(s.diagnostics.count(Severity::Warning), 2u);
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Warning, "s.json", "", "unknown key 'title'"));
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Warning, "s.json", "step 1", "unknown key 'speed'"));
  EXPECT_EQ(s->steps.size(), 2u);
}

TEST_F(ViewerScript, NoStepsIsAWarning) {
  Result<app::ViewerScript> s = app::parseViewerScript(json::parse(R"({"steps": []})"), "s.json");
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Warning, "s.json", "", "no steps"));
}

TEST_F(ViewerScript, LoadsAFile) {
  const std::string file = write("s.json", R"({"steps": [{"action": "screenshot", "path": "shot.png"}]})");
  Result<app::ViewerScript> s = app::loadViewerScript(file);
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  EXPECT_EQ(s->file, file);
  EXPECT_EQ(as<app::ScreenshotStep>(s->steps[0]).path, (dir_ / "shot.png").string());
}

TEST_F(ViewerScript, AMissingFileIsAnErrorNamingIt) {
  const std::string file = (dir_ / "absent.json").string();
  Result<app::ViewerScript> s = app::loadViewerScript(file);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, file, "", "cannot open")) << dump(s.diagnostics);
}

TEST_F(ViewerScript, NotJsonIsAnErrorNamingTheFile) {
  const std::string file = write("s.json", "{ \"steps\": [ nope");
  Result<app::ViewerScript> s = app::loadViewerScript(file);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, file, "", "not JSON")) << dump(s.diagnostics);
}

TEST_F(ViewerScript, GlobeCameraReadsItsFields) {
  Result<app::ViewerScript> s = app::parseViewerScript(json::parse(R"({"steps": [
        {"globe_camera": {"lon": 179.5, "lat": -16.5, "distance": 2.5e6, "heading": 30, "pitch": 45}},
        {"globe_camera": {"lon": -10, "lat": 89, "distance": 100}}]})"),
                                                       "s.json");
  ASSERT_TRUE(s.ok()) << dump(s.diagnostics);
  ASSERT_EQ(s->steps.size(), 2U);
  const auto& a = as<app::GlobeCameraStep>(s->steps[0]);
  EXPECT_DOUBLE_EQ(a.lon, 179.5);
  EXPECT_DOUBLE_EQ(a.lat, -16.5);
  EXPECT_DOUBLE_EQ(a.distance, 2.5e6);
  EXPECT_DOUBLE_EQ(a.heading, 30.0);
  EXPECT_DOUBLE_EQ(a.pitch, 45.0);
  // Heading and pitch default to north up, straight down.
  const auto& b = as<app::GlobeCameraStep>(s->steps[1]);
  EXPECT_DOUBLE_EQ(b.lat, 89.0);
  EXPECT_DOUBLE_EQ(b.heading, 0.0);
  EXPECT_DOUBLE_EQ(b.pitch, 90.0);
}

TEST_F(ViewerScript, BrokenGlobeCamerasAreErrorsNamingTheStep) {
  struct Case {
    const char* what;
    json step;
    const char* mentions;
  };
  const std::vector<Case> cases = {
      {"not an object", json::parse(R"({"globe_camera": [1, 2]})"), "expected an object"},
      {"no distance", json::parse(R"({"globe_camera": {"lon": 1, "lat": 2}})"), "missing 'distance'"},
      {"latitude beyond the pole", json::parse(R"({"globe_camera": {"lon": 1, "lat": 91, "distance": 5}})"), "'lat'"},
      {"zero distance", json::parse(R"({"globe_camera": {"lon": 1, "lat": 2, "distance": 0}})"), "'distance'"},
      {"pitch above the horizon", json::parse(R"({"globe_camera": {"lon": 1, "lat": 2, "distance": 5, "pitch": -3}})"),
       "'pitch'"},
      {"a typo", json::parse(R"({"globe_camera": {"lon": 1, "lat": 2, "distance": 5, "headin": 3}})"),
       "unknown key 'headin'"},
      {"with a camera", json::parse(R"({"globe_camera": {"lon": 1, "lat": 2, "distance": 5}, "wait": 3})"),
       "exactly one of"},
  };
  for (const Case& c : cases) {
    Result<app::ViewerScript> s = app::parseViewerScript(scriptAround(c.step), "s.json");
    EXPECT_FALSE(s.ok()) << c.what;
    EXPECT_TRUE(hasDiagnostic(s.diagnostics, Severity::Error, "s.json", "step 2", c.mentions)) << c.what << "\n"
                                                                                               << dump(s.diagnostics);
  }
}

}  // namespace
}  // namespace gis::test
