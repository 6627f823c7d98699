#pragma once
// Viewer scripts (`terrain_viewer --script FILE`): a list of steps that drives the real window —
// camera keyframes, the panel's actions, screenshots — so CI can test the viewer under Xvfb.
//
//   {"window": [960, 640],                      optional: window size in screen coordinates
//    "steps": [
//      {"camera": {...} or "camera.json", "seconds": 1.5},   eased move (0 or absent: a jump)
//      {"globe_camera": {"lon": 10, "lat": 50, "distance": 2e6,   a globe scene's camera (a jump):
//       "heading": 0, "pitch": 90}},                          target, metres to it, degrees
//      {"wait": 10},                                          frames to draw
//      {"action": "toggle_layer", "layer": "streets"},
//      {"action": "set_layer", "layer": "census tracts",      any of visible, opacity, color, width
//       "visible": true, "opacity": 0.5, "color": "#ff8800", "width": 4},
//      {"action": "overlays", "on": false},                   all vector layers on / off
//      {"action": "method", "value": "stencil" | "paper" | "drape" | "drape-tiles",  a technique of
//       "drape_size": 2048},                                  overlay::techniques()
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
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>

#include "core/diagnostics.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::app {

enum class MouseButton { Left, Right, Middle };

/// Modifier keys held during a scripted mouse or key action.
struct Modifiers {
  bool shift = false;
  bool ctrl = false;
  bool alt = false;
};

// One struct per action, with the fields of that action only. Paths are resolved against the
// script file's directory when relative (and then absolute).

struct CameraStep {
  nlohmann::json camera;   ///< the spec, parsed later against the scene frame (scene::parseCameraSpec)
  std::string cameraFile;  ///< where the spec came from (the script or the camera file it names), for messages
  double seconds = 0.0;    ///< eased move over this long; 0: a jump
};

/// A globe scene's camera (scene::GlobePose): it looks at the ground at (lon, lat) from `distance`
/// metres, along `heading` (degrees clockwise from north) and `pitch` (degrees below the horizontal,
/// 90 = straight down). A jump.
struct GlobeCameraStep {
  double lon = 0.0, lat = 0.0;  ///< degrees; lon in [-540, 540], lat in [-90, 90]
  double distance = 1e7;        ///< metres, > 0
  double heading = 0.0;         ///< degrees
  double pitch = 90.0;          ///< degrees, in (0, 90]
};

struct WaitStep {
  int frames = 0;  ///< frames to draw
};

struct ToggleLayerStep {
  std::string layer;
};

/// Only what is given changes.
struct SetLayerStep {
  std::string layer;
  std::optional<bool> visible;
  std::optional<float> opacity;    ///< [0, 1]
  std::optional<glm::vec4> color;  ///< straight RGBA in [0, 1]
  std::optional<double> width;     ///< > 0, in the layer's width unit (metres or pixels)
  /// Colours by category of this attribute (a palette over its values); "": one colour.
  std::optional<std::string> colorAttribute;
  std::optional<glm::vec4> outlineColor;  ///< polygons
  std::optional<double> outlineWidth;     ///< polygons: metres, > 0 (0: no outline)
  /// Labels the features with this attribute's values ("": no labels).
  std::optional<std::string> labelAttribute;
};

/// A layer's attribute table: opened, searched, sorted, rows selected (by fid), zoomed to.
struct TableStep {
  std::string layer;
  std::optional<std::string> search;    ///< text searched for, case-insensitive ("" clears)
  std::optional<std::string> searchIn;  ///< an attribute to search in; absent: every column
  std::optional<std::string> sortBy;    ///< "fid" or an attribute
  bool descending = false;
  std::optional<std::vector<std::int64_t>> select;  ///< rows selected, by fid
  std::optional<std::string> zoomTo;                ///< "rows" or "layer"
  bool close = false;
};

/// A measurement: the ground points under these pixels, in order; `closed` also measures the
/// area of the ring.
struct MeasureStep {
  std::vector<glm::dvec2> points;  ///< at least 2 (3 when closed); framebuffer pixels
  bool closed = false;
};

struct OverlaysStep {
  bool on = true;
};

struct MethodStep {
  /// A technique's name (overlay::techniques()), validated here.
  std::string name;
  int drapeSize = 0;  ///< texture draping: texels per side, of the texture or of each tile; 0: unchanged
};

struct ExaggerationStep {
  double value = 0.0;  ///< > 0
};

struct LassoStep {
  overlay::SelectionOp op = overlay::SelectionOp::Single;  ///< never Invert (an action of its own)
  std::vector<glm::dvec2> points;  ///< at least 3; framebuffer pixels, x from the left, y from the top
};

struct InvertStep {};
struct ClearSelectionStep {};
struct HomeStep {};
struct QuitStep {};

struct IdentifyStep {
  glm::dvec2 at{0.0};  ///< framebuffer pixel, as lasso points
  std::string out;     ///< where to write the result; empty: not written
};

struct ExportStep {
  std::string path;
};

struct ScreenshotStep {
  std::string path;
  bool ui = true;  ///< false: the scene only, without the panel
};

/// Key names are strings: the viewer maps them to its window system's keys.
struct KeyStep {
  std::string key;  ///< one character as typed, or a lower-case key name
};

struct DragStep {
  MouseButton button = MouseButton::Left;
  Modifiers modifiers;
  std::vector<glm::dvec2> points;  ///< at least 2, framebuffer pixels as lasso points
  int frames = 6;                  ///< frames per segment
};

struct ClickStep {
  MouseButton button = MouseButton::Left;
  Modifiers modifiers;
  glm::dvec2 at{0.0};  ///< framebuffer pixel
};

struct ScrollStep {
  glm::dvec2 at{0.0};   ///< framebuffer pixel
  double amount = 1.0;  ///< wheel steps, non-zero, positive zooms in
};

struct HoldKeysStep {
  Modifiers modifiers;
  std::vector<std::string> keys;  ///< as KeyStep's
  int frames = 1;                 ///< frames held
};

struct ResizeStep {
  glm::ivec2 window{0};  ///< screen coordinates
};

struct SaveStateStep {
  std::string path;
};

/// Only what is given changes.
struct ViewStep {
  std::optional<bool> wireframe, imagery, debugPieces, panel, hud, legend, labels;
  std::optional<double> lodTolerance;  ///< pixels, > 0
  std::optional<double> fovYDeg;       ///< degrees, in (0, 180)
};

struct DropStep {
  std::vector<std::string> paths;
};

/// The window's own input until `untilFile` exists; more than `maxFrames` frames fail the step.
struct LiveStep {
  std::string untilFile;
  int maxFrames = 3000;
};

using ScriptAction =
    std::variant<CameraStep, WaitStep, ToggleLayerStep, SetLayerStep, OverlaysStep, MethodStep, ExaggerationStep,
                 LassoStep, InvertStep, ClearSelectionStep, IdentifyStep, ExportStep, ScreenshotStep, HomeStep, KeyStep,
                 DragStep, ClickStep, ScrollStep, HoldKeysStep, ResizeStep, SaveStateStep, ViewStep, DropStep, LiveStep,
                 QuitStep, TableStep, MeasureStep, GlobeCameraStep>;

/// One step of a script: its action, read completely, and where it stands in the script.
struct ScriptStep {
  std::size_t index = 0;  ///< position in "steps", from 1 (messages say "step N")
  ScriptAction action;
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
