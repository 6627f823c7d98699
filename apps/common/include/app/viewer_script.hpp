#pragma once
// Viewer scripts (`terrain_viewer --script FILE`): a list of steps that drives the real window —
// camera keyframes, the panel's actions, screenshots — so CI can test the viewer under Xvfb.
//
//   {"window": [960, 640],                      optional: window size in screen coordinates
//    "steps": [
//      {"camera": {...} or "camera.json", "seconds": 1.5},   eased move (0 or absent: a jump)
//      {"wait": 10},                                          frames to draw
//      {"action": "toggle_layer", "layer": "streets"},
//      {"action": "set_layer", "layer": "census tracts",      any of visible, opacity, color, width
//       "visible": true, "opacity": 0.5, "color": "#ff8800", "width": 4},
//      {"action": "overlays", "on": false},                   all vector layers on / off
//      {"action": "method", "value": "stencil" | "paper" | "drape", "drape_size": 2048},
//      {"action": "exaggeration", "value": 2.0},
//      {"action": "lasso", "op": "single" | "or" | "and" | "xor" | "subtract",
//       "points": [[x, y], ...]},                             framebuffer pixels, origin top-left
//      {"action": "invert"}, {"action": "clear_selection"},
//      {"action": "identify", "x": 100, "y": 80, "out": "identify.json"},   "out" optional
//      {"action": "export", "path": "selected.json"},
//      {"action": "screenshot", "path": "shot.png", "ui": true},           ui false: scene only
//      {"action": "home"},
//      {"action": "key", "key": "o"},                          one character, or a name: "F12", "escape"
//      {"action": "drag", "button": "left", "points": [[x, y], ...],      the mouse, through the
//       "frames": 6, "modifiers": ["shift"]},                 viewer's own input handling (below)
//      {"action": "click", "at": [x, y], "modifiers": []},
//      {"action": "scroll", "at": [x, y], "amount": 1},       wheel steps, positive zooms in
//      {"action": "hold_keys", "keys": ["w"], "frames": 10, "modifiers": ["shift"]},
//      {"action": "resize", "window": [640, 480]},            screen coordinates
//      {"action": "save_state", "path": "state.json"},        camera, selection, identify (a test's view)
//      {"action": "view", "wireframe": true, "imagery": false,  the panel's view switches, any of them
//       "debug_pieces": true, "lod_tolerance": 2, "fov": 50, "panel": true, "hud": false},
//      {"action": "drop", "paths": ["roads.geojson"]},         as files dropped on the window
//      {"action": "live", "until_file": "go", "max_frames": 600},  the real mouse and keys (e.g. from
//                                                             xdotool) until the file exists
//      {"action": "quit"}]}
//
// Mouse and key actions are played through the same input handling as a person's mouse and
// keys, one input state per frame: a drag presses at the first point, moves `frames` frames
// along each segment and releases at the last point; a click presses and releases; a scroll is
// one frame. They go to the scene, not the panel. The script then waits until the camera has
// settled before the next step.
//
// A camera is a camera file's content (docs/command-line.md, "Camera files"), or a path to a
// camera file (read here; a camera.json of overlay_render works). Colours are "#rrggbb",
// "#rrggbbaa" or [r, g, b] / [r, g, b, a] in [0, 1]. Paths are relative to the script file.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>

#include "core/diagnostics.hpp"

namespace gis::app {

enum class ScriptAction {
  Camera,
  Wait,
  ToggleLayer,
  SetLayer,
  Overlays,
  Method,
  Exaggeration,
  Lasso,
  Invert,
  ClearSelection,
  Identify,
  Export,
  Screenshot,
  Home,
  Key,
  Drag,
  Click,
  Scroll,
  HoldKeys,
  Resize,
  SaveState,
  View,
  Drop,
  Live,
  Quit
};

enum class MouseButton { Left, Right, Middle };

/// Modifier keys held during a scripted mouse or key action.
struct Modifiers {
  bool shift = false;
  bool ctrl = false;
  bool alt = false;
};

/// One step of a script. Only the fields of its action are set.
struct ScriptStep {
  ScriptAction action = ScriptAction::Wait;
  std::size_t index = 0;  ///< position in "steps", from 1 (messages say "step N")

  // Camera
  nlohmann::json camera;   ///< the spec, parsed later against the scene frame (app::parseCameraSpec)
  std::string cameraFile;  ///< where the spec came from (the script or the camera file it names), for messages
  double seconds = 0.0;    ///< eased move over this long; 0: a jump

  // Wait (frames to draw), Drag (frames per segment), HoldKeys (frames held), Live (at most),
  // Method (the drape's texels per side; 0: unchanged)
  int frames = 0;

  // ToggleLayer, SetLayer
  std::string layer;
  std::optional<bool> visible;
  std::optional<float> opacity;    ///< [0, 1]
  std::optional<glm::vec4> color;  ///< straight RGBA in [0, 1]
  std::optional<double> width;     ///< > 0, in the layer's width unit (metres or pixels)

  // Overlays
  bool on = true;

  // Method ("stencil" or "paper"), Key (one character as typed, or a lower-case key name)
  std::string text;

  // Exaggeration (> 0), Scroll (wheel steps, non-zero)
  double value = 0.0;

  // Lasso
  std::string lassoOp;  ///< "single", "or", "and", "xor" or "subtract"
  /// Lasso (at least 3), Drag (at least 2): framebuffer pixels, x from the left, y from the top.
  std::vector<glm::dvec2> points;

  // Identify, Click, Scroll
  glm::dvec2 at{0.0};  ///< framebuffer pixel, as lasso points

  // Drag, Click, HoldKeys
  MouseButton button = MouseButton::Left;
  Modifiers modifiers;
  std::vector<std::string> keys;  ///< HoldKeys: key names as Key's

  // Resize
  glm::ivec2 window{0};  ///< screen coordinates

  // View: only what is given changes
  std::optional<bool> wireframe, imagery, debugPieces, panel, hud;
  std::optional<double> lodTolerance;  ///< pixels, > 0
  std::optional<double> fovYDeg;       ///< degrees, in (0, 180)

  // Drop: resolved like `path`
  std::vector<std::string> paths;

  // Live: the window's own input until `path` exists; more than `frames` frames fail the step

  /// Identify: where to write the result (empty: not written); Export, Screenshot, SaveState: the
  /// file; Live: the file whose existence ends it.
  /// Resolved against the script file's directory when relative (and then absolute).
  std::string path;

  // Screenshot
  bool ui = true;  ///< false: the scene only, without the panel
};

struct ViewerScript {
  std::optional<glm::ivec2> window;  ///< screen coordinates; none: the viewer's default
  std::vector<ScriptStep> steps;
  std::string file;  ///< the script, as named to the parser
};

/// Reads a parsed script; `file` names it in messages and its directory resolves relative paths.
/// A step that cannot be run (unknown action, missing or mistyped field, a non-finite number, a
/// negative wait, an unknown method, lasso operator or key, a lasso with fewer than 3 points) is
/// an error naming the file and "step N" (from 1); every broken step is reported, and then the
/// script fails as a whole (no value): a script is a test program, and running part of it would
/// hide the mistake. Unknown keys, at the top or in a step, are warnings.
Result<ViewerScript> parseViewerScript(const nlohmann::json& j, const std::string& file);

/// Reads a script file. A file that cannot be opened or is not JSON fails with an error naming it.
Result<ViewerScript> loadViewerScript(const std::string& path);

}  // namespace gis::app
