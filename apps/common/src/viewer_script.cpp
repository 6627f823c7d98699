#include "app/viewer_script.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <string_view>
#include <utility>

#include "scene/json_file.hpp"
#include "vector_overlay/style.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::app {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

/// Key names as GLFW calls its keys (lower case, '_' for spaces); F1–F25 are added below.
constexpr std::array<std::string_view, 15> kKeyNames{"escape",  "enter",     "tab",  "backspace", "insert",
                                                     "delete",  "right",     "left", "down",      "up",
                                                     "page_up", "page_down", "home", "end",       "space"};

/// A key name in lower case, or nothing if it names no key we know: a typo fails the script
/// before it runs instead of pressing nothing.
std::optional<std::string> keyName(const std::string& text) {
  if (text.size() == 1) {
    if (text[0] >= 0x20 && text[0] <= 0x7e) return text;  // printable ASCII, as typed
    return std::nullopt;
  }
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
  if (std::find(kKeyNames.begin(), kKeyNames.end(), lower) != kKeyNames.end()) return lower;
  for (int f = 1; f <= 25; ++f) {
    if (lower == "f" + std::to_string(f)) return lower;
  }
  return std::nullopt;
}

/// "#rrggbb", "#rrggbbaa" (overlay::parseHexColor, as scene files) or [r, g, b(, a)] in [0, 1].
std::optional<glm::vec4> readColour(const json& c) {
  if (c.is_string()) {
    glm::vec4 out(1.0F);
    if (overlay::parseHexColor(c.get<std::string>(), out)) return out;
    return std::nullopt;
  }
  if (!c.is_array() || (c.size() != 3 && c.size() != 4)) return std::nullopt;
  std::array<float, 4> channels{0.0F, 0.0F, 0.0F, 1.0F};
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!c[i].is_number()) return std::nullopt;
    const double v = c[i].get<double>();
    if (!(v >= 0.0 && v <= 1.0)) return std::nullopt;  // also refuses NaN
    channels[i] = static_cast<float>(v);
  }
  return glm::vec4(channels[0], channels[1], channels[2], channels[3]);
}

bool isPixel(const json& p) {
  return p.is_array() && p.size() == 2 && p[0].is_number() && p[1].is_number() && std::isfinite(p[0].get<double>()) &&
         std::isfinite(p[1].get<double>());
}

/// [width, height] in screen coordinates, integers 1 to 16384.
std::optional<glm::ivec2> windowSize(const json& w) {
  const auto size = [](const json& v) {
    return v.is_number_integer() && v.get<long long>() >= 1 && v.get<long long>() <= 16384;
  };
  if (!w.is_array() || w.size() != 2 || !size(w[0]) || !size(w[1])) return std::nullopt;
  return glm::ivec2(w[0].get<int>(), w[1].get<int>());
}

constexpr const char* kWindowExpected =
    "'window': expected [width, height] in screen coordinates (integers 1 to 16384), got ";

constexpr const char* kKeyNameList =
    "one printable character or a key name (escape, enter, tab, backspace, insert, delete, left, right, up, down, "
    "page_up, page_down, home, end, space, f1-f25)";

/// `relative` against `base` (absolute), as scene files resolve their paths.
std::string resolvePath(const fs::path& base, const std::string& relative) {
  const fs::path p(relative);
  return (p.is_absolute() ? p : base / p).lexically_normal().string();
}

/// Reads the fields of one step. Every problem is kept, so one run of the parser reports all of
/// a step's mistakes; keys that were never asked for are unknown.
class StepReader {
 public:
  /// `base`: the script's directory (absolute), against which relative paths resolve.
  StepReader(const json& entry, const fs::path& base, std::vector<std::string>& problems)
      : entry_(entry), base_(base), problems_(problems) {}

  [[nodiscard]] bool has(const char* key) const { return entry_.contains(key); }

  /// The value of `key`, or null when absent (a problem if `required`).
  const json* field(const char* key, bool required) {
    known_.insert(key);
    if (!entry_.contains(key)) {
      if (required) problem(std::string("missing '") + key + "'");
      return nullptr;
    }
    return &entry_[key];
  }

  std::optional<std::string> string(const char* key, bool required) {
    const json* v = field(key, required);
    if (!v) return std::nullopt;
    if (!v->is_string() || v->get<std::string>().empty()) {
      problem(std::string("'") + key + "': expected a non-empty string, got " + v->dump());
      return std::nullopt;
    }
    return v->get<std::string>();
  }

  /// A file path, resolved against the script's directory; empty when absent or not a path.
  std::string path(const char* key, bool required) {
    const std::optional<std::string> p = string(key, required);
    return p ? resolve(*p) : std::string();
  }

  [[nodiscard]] std::string resolve(const std::string& relative) const { return resolvePath(base_, relative); }

  std::optional<bool> boolean(const char* key, bool required) {
    const json* v = field(key, required);
    if (!v) return std::nullopt;
    if (!v->is_boolean()) {
      problem(std::string("'") + key + "': expected true or false, got " + v->dump());
      return std::nullopt;
    }
    return v->get<bool>();
  }

  /// A finite number; `what` describes the expected range when `ok` refuses the value.
  template <typename Pred>
  std::optional<double> number(const char* key, bool required, const char* what, Pred ok) {
    const json* v = field(key, required);
    if (!v) return std::nullopt;
    if (!v->is_number() || !std::isfinite(v->get<double>()) || !ok(v->get<double>())) {
      problem(std::string("'") + key + "': expected " + what + ", got " + v->dump());
      return std::nullopt;
    }
    return v->get<double>();
  }

  std::optional<double> number(const char* key, bool required) {
    return number(key, required, "a finite number", [](double) { return true; });
  }

  /// At least `minimum` pixel positions [x, y].
  std::vector<glm::dvec2> pixels(const char* key, std::size_t minimum) {
    const json* v = field(key, true);
    std::vector<glm::dvec2> out;
    if (!v) return out;
    bool ok = v->is_array();
    for (const json& p : ok ? *v : json::array()) {
      if (!isPixel(p)) {
        ok = false;
        break;
      }
      out.emplace_back(p[0].get<double>(), p[1].get<double>());
    }
    if (!ok || out.size() < minimum) {
      problem(std::string("'") + key + "': expected at least " + std::to_string(minimum) +
              " pixel positions [x, y] (finite numbers)");
      out.clear();
    }
    return out;
  }

  /// One pixel position [x, y].
  std::optional<glm::dvec2> pixel(const char* key) {
    const json* v = field(key, true);
    if (!v) return std::nullopt;
    if (!isPixel(*v)) {
      problem(std::string("'") + key + "': expected a pixel position [x, y] (finite numbers), got " + v->dump());
      return std::nullopt;
    }
    return glm::dvec2((*v)[0].get<double>(), (*v)[1].get<double>());
  }

  /// A whole number of frames in [1, 100000].
  std::optional<int> frames(const char* key, bool required) {
    const std::optional<double> f = number(key, required, "a whole number of frames from 1 to 100000",
                                           [](double x) { return x >= 1.0 && x <= 1e5 && x == std::floor(x); });
    if (!f) return std::nullopt;
    return static_cast<int>(*f);
  }

  /// "modifiers": a list of "shift", "ctrl" and "alt" (absent: none).
  Modifiers modifiers() {
    Modifiers m;
    const json* v = field("modifiers", false);
    if (!v) return m;
    bool ok = v->is_array();
    for (const json& name : ok ? *v : json::array()) {
      const std::string n = name.is_string() ? name.get<std::string>() : "";
      if (n == "shift") {
        m.shift = true;
      } else if (n == "ctrl") {
        m.ctrl = true;
      } else if (n == "alt") {
        m.alt = true;
      } else {
        ok = false;
      }
    }
    if (!ok) problem("'modifiers': expected a list of \"shift\", \"ctrl\" and \"alt\", got " + v->dump());
    return m;
  }

  void problem(std::string message) { problems_.push_back(std::move(message)); }

  [[nodiscard]] std::vector<std::string> unknownKeys() const {
    std::vector<std::string> unknown;
    for (const auto& item : entry_.items()) {
      if (!known_.count(item.key())) unknown.push_back(item.key());
    }
    return unknown;
  }

 private:
  const json& entry_;
  fs::path base_;
  std::vector<std::string>& problems_;
  std::set<std::string> known_;
};

// One reader per action: each asks for its keys (so the others are unknown) and returns the
// step's action; what it finds wrong goes to the StepReader's problems.

ScriptAction readToggleLayer(StepReader& r) { return ToggleLayerStep{.layer = r.string("layer", true).value_or("")}; }

ScriptAction readSetLayer(StepReader& r) {
  SetLayerStep step;
  step.layer = r.string("layer", true).value_or("");
  step.visible = r.boolean("visible", false);
  if (const std::optional<double> o =
          r.number("opacity", false, "a number in [0, 1]", [](double v) { return v >= 0.0 && v <= 1.0; }))
    step.opacity = static_cast<float>(*o);
  if (const json* c = r.field("color", false)) {
    step.color = readColour(*c);
    if (!step.color)
      r.problem("'color': expected \"#rrggbb\", \"#rrggbbaa\" or [r, g, b(, a)] in [0, 1], got " + c->dump());
  }
  step.width = r.number("width", false, "a positive number", [](double v) { return v > 0.0; });
  if (const json* a = r.field("color_attribute", false)) {
    if (a->is_string()) {
      step.colorAttribute = a->get<std::string>();
    } else {
      r.problem("'color_attribute': expected an attribute name (\"\" for one colour), got " + a->dump());
    }
  }
  if (const json* a = r.field("label_attribute", false)) {
    if (a->is_string()) {
      step.labelAttribute = a->get<std::string>();
    } else {
      r.problem("'label_attribute': expected an attribute name (\"\" for no labels), got " + a->dump());
    }
  }
  if (const json* c = r.field("outline_color", false)) {
    step.outlineColor = readColour(*c);
    if (!step.outlineColor)
      r.problem("'outline_color': expected \"#rrggbb\", \"#rrggbbaa\" or [r, g, b(, a)] in [0, 1], got " + c->dump());
  }
  step.outlineWidth =
      r.number("outline_width", false, "a width in metres, 0 or more", [](double v) { return v >= 0.0 && v <= 1e4; });
  bool anyGiven = false;
  for (const char* key :
       {"visible", "opacity", "color", "width", "color_attribute", "outline_color", "outline_width", "label_attribute"})
    anyGiven = anyGiven || r.has(key);
  if (!anyGiven)
    r.problem(
        "nothing to set: give any of 'visible', 'opacity', 'color', 'width', 'color_attribute', 'outline_color', "
        "'outline_width', 'label_attribute'");
  return step;
}

ScriptAction readOverlays(StepReader& r) { return OverlaysStep{.on = r.boolean("on", true).value_or(true)}; }

ScriptAction readMethod(StepReader& r) {
  MethodStep step;
  if (const std::optional<std::string> m = r.string("value", true)) {
    // The overlay techniques of the registry (vector_overlay/technique.hpp).
    if (overlay::findTechnique(*m) != nullptr) {
      step.name = *m;
    } else {
      r.problem("'value': unknown method '" + *m + "'; expected " + overlay::techniqueNameList());
    }
  }
  step.drapeSize =
      static_cast<int>(r.number("drape_size", false, "a whole number of texels from 16 to 16384", [](double v) {
                          return v >= 16.0 && v <= 16384.0 && v == std::floor(v);
                        }).value_or(0.0));
  return step;
}

ScriptAction readExaggeration(StepReader& r) {
  return ExaggerationStep{
      .value = r.number("value", true, "a positive number", [](double v) { return v > 0.0; }).value_or(0.0)};
}

/// Exactly the names overlay::parseSelectionOp reads, less "invert" (an action of its own).
constexpr std::array<std::pair<std::string_view, overlay::SelectionOp>, 5> kLassoOps{
    {{"single", overlay::SelectionOp::Single},
     {"or", overlay::SelectionOp::Or},
     {"and", overlay::SelectionOp::And},
     {"xor", overlay::SelectionOp::Xor},
     {"subtract", overlay::SelectionOp::Subtract}}};

ScriptAction readLasso(StepReader& r) {
  LassoStep step;
  if (const std::optional<std::string> op = r.string("op", true)) {
    const auto found =
        std::find_if(kLassoOps.begin(), kLassoOps.end(),
                     [&](const std::pair<std::string_view, overlay::SelectionOp>& o) { return o.first == *op; });
    if (found != kLassoOps.end()) {
      step.op = found->second;
    } else {
      r.problem("'op': unknown operator '" + *op + "'; expected one of single, or, and, xor, subtract" +
                (*op == "invert" ? " (invert is {\"action\": \"invert\"})" : ""));
    }
  }
  step.points = r.pixels("points", 3);
  return step;
}

ScriptAction readIdentify(StepReader& r) {
  IdentifyStep step;
  const std::optional<double> x = r.number("x", true), y = r.number("y", true);
  if (x && y) step.at = glm::dvec2(*x, *y);
  step.out = r.path("out", false);
  return step;
}

ScriptAction readExport(StepReader& r) { return ExportStep{.path = r.path("path", true)}; }

ScriptAction readScreenshot(StepReader& r) {
  ScreenshotStep step;
  step.path = r.path("path", true);
  step.ui = r.boolean("ui", false).value_or(true);
  return step;
}

ScriptAction readKey(StepReader& r) {
  KeyStep step;
  if (const std::optional<std::string> k = r.string("key", true)) {
    if (const std::optional<std::string> known = keyName(*k)) {
      step.key = *known;
    } else {
      r.problem("'key': unknown key '" + *k + "'; expected " + kKeyNameList);
    }
  }
  return step;
}

/// "button": "left" (also when absent), "right" or "middle".
MouseButton readButton(StepReader& r) {
  const std::optional<std::string> b = r.string("button", false);
  if (!b || *b == "left") return MouseButton::Left;
  if (*b == "right") return MouseButton::Right;
  if (*b == "middle") return MouseButton::Middle;
  r.problem("'button': unknown button '" + *b + "'; expected \"left\", \"right\" or \"middle\"");
  return MouseButton::Left;
}

ScriptAction readDrag(StepReader& r) {
  DragStep step;
  step.button = readButton(r);
  step.modifiers = r.modifiers();
  step.points = r.pixels("points", 2);
  step.frames = r.frames("frames", false).value_or(6);
  return step;
}

ScriptAction readClick(StepReader& r) {
  ClickStep step;
  step.button = readButton(r);
  step.modifiers = r.modifiers();
  if (const std::optional<glm::dvec2> at = r.pixel("at")) step.at = *at;
  return step;
}

ScriptAction readScroll(StepReader& r) {
  ScrollStep step;
  if (const std::optional<glm::dvec2> at = r.pixel("at")) step.at = *at;
  step.amount = r.number("amount", false, "a non-zero number of wheel steps", [](double v) {
                   return v != 0.0 && std::abs(v) <= 1e3;
                 }).value_or(1.0);
  return step;
}

ScriptAction readHoldKeys(StepReader& r) {
  HoldKeysStep step;
  step.modifiers = r.modifiers();
  step.frames = r.frames("frames", true).value_or(1);
  const json* keys = r.field("keys", true);
  if (!keys) return step;
  bool ok = keys->is_array() && !keys->empty();
  for (const json& k : ok ? *keys : json::array()) {
    const std::optional<std::string> known = k.is_string() ? keyName(k.get<std::string>()) : std::nullopt;
    if (!known) {
      ok = false;
      break;
    }
    step.keys.push_back(*known);
  }
  if (!ok) r.problem(std::string("'keys': expected a list of keys, each ") + kKeyNameList + ", got " + keys->dump());
  return step;
}

ScriptAction readResize(StepReader& r) {
  ResizeStep step;
  if (const json* w = r.field("window", true)) {
    if (const std::optional<glm::ivec2> size = windowSize(*w)) {
      step.window = *size;
    } else {
      r.problem(kWindowExpected + w->dump());
    }
  }
  return step;
}

ScriptAction readSaveState(StepReader& r) { return SaveStateStep{.path = r.path("path", true)}; }

ScriptAction readView(StepReader& r) {
  ViewStep step;
  step.wireframe = r.boolean("wireframe", false);
  step.imagery = r.boolean("imagery", false);
  step.debugPieces = r.boolean("debug_pieces", false);
  step.panel = r.boolean("panel", false);
  step.hud = r.boolean("hud", false);
  step.legend = r.boolean("legend", false);
  step.labels = r.boolean("labels", false);
  step.lodTolerance =
      r.number("lod_tolerance", false, "a number of pixels in (0, 64]", [](double v) { return v > 0.0 && v <= 64.0; });
  step.fovYDeg =
      r.number("fov", false, "a number of degrees in (0, 180)", [](double v) { return v > 0.0 && v < 180.0; });
  bool any = false;
  for (const char* key :
       {"wireframe", "imagery", "debug_pieces", "panel", "hud", "legend", "labels", "lod_tolerance", "fov"})
    any = any || r.has(key);
  if (!any)
    r.problem(
        "nothing to set: give any of 'wireframe', 'imagery', 'debug_pieces', 'panel', 'hud', 'legend', 'labels', "
        "'lod_tolerance', 'fov'");
  return step;
}

ScriptAction readTable(StepReader& r) {
  TableStep step;
  step.layer = r.string("layer", true).value_or("");
  if (const json* v = r.field("search", false)) {
    if (v->is_string()) {
      step.search = v->get<std::string>();
    } else {
      r.problem("'search': expected text, got " + v->dump());
    }
  }
  step.searchIn = r.string("search_in", false);
  step.sortBy = r.string("sort_by", false);
  step.descending = r.boolean("descending", false).value_or(false);
  if (const json* v = r.field("select", false)) {
    bool ok = v->is_array();
    std::vector<std::int64_t> fids;
    for (const json& f : ok ? *v : json::array()) {
      if (!f.is_number_integer()) {
        ok = false;
        break;
      }
      fids.push_back(f.get<std::int64_t>());
    }
    if (ok) {
      step.select = std::move(fids);
    } else {
      r.problem("'select': expected a list of feature ids (whole numbers), got " + v->dump());
    }
  }
  if (const std::optional<std::string> z = r.string("zoom_to", false)) {
    if (*z == "rows" || *z == "layer") {
      step.zoomTo = *z;
    } else {
      r.problem("'zoom_to': expected \"rows\" or \"layer\", got \"" + *z + "\"");
    }
  }
  step.close = r.boolean("close", false).value_or(false);
  return step;
}

ScriptAction readMeasure(StepReader& r) {
  MeasureStep step;
  step.closed = r.boolean("closed", false).value_or(false);
  step.points = r.pixels("points", step.closed ? 3 : 2);
  return step;
}

ScriptAction readLive(StepReader& r) {
  LiveStep step;
  step.untilFile = r.path("until_file", true);
  step.maxFrames = r.frames("max_frames", false).value_or(3000);
  return step;
}

ScriptAction readDrop(StepReader& r) {
  DropStep step;
  const json* paths = r.field("paths", true);
  if (!paths) return step;
  bool ok = paths->is_array() && !paths->empty();
  for (const json& p : ok ? *paths : json::array()) {
    if (!p.is_string() || p.get<std::string>().empty()) {
      ok = false;
      break;
    }
    step.paths.push_back(r.resolve(p.get<std::string>()));
  }
  if (!ok) r.problem("'paths': expected a list of file paths, got " + paths->dump());
  return step;
}

/// An action without fields.
template <typename Step>
ScriptAction readPlain(StepReader&) {
  return Step{};
}

struct ActionReader {
  std::string_view name;
  ScriptAction (*read)(StepReader&);
};

// "camera" and "wait" are steps of their own, not actions: they are the keys of the step.
constexpr std::array<ActionReader, 25> kActions{{{"toggle_layer", readToggleLayer},
                                                 {"set_layer", readSetLayer},
                                                 {"overlays", readOverlays},
                                                 {"method", readMethod},
                                                 {"exaggeration", readExaggeration},
                                                 {"lasso", readLasso},
                                                 {"invert", readPlain<InvertStep>},
                                                 {"clear_selection", readPlain<ClearSelectionStep>},
                                                 {"identify", readIdentify},
                                                 {"export", readExport},
                                                 {"screenshot", readScreenshot},
                                                 {"home", readPlain<HomeStep>},
                                                 {"key", readKey},
                                                 {"drag", readDrag},
                                                 {"click", readClick},
                                                 {"scroll", readScroll},
                                                 {"hold_keys", readHoldKeys},
                                                 {"resize", readResize},
                                                 {"save_state", readSaveState},
                                                 {"view", readView},
                                                 {"drop", readDrop},
                                                 {"live", readLive},
                                                 {"table", readTable},
                                                 {"measure", readMeasure},
                                                 {"quit", readPlain<QuitStep>}}};

std::string actionList() {
  std::string list;
  for (const ActionReader& a : kActions) list += (list.empty() ? "" : ", ") + std::string(a.name);
  return list;
}

/// {"action": NAME, ...}: the action of that name, or nothing (a problem).
std::optional<ScriptAction> readAction(StepReader& r) {
  const json& a = *r.field("action", true);
  if (!a.is_string()) {
    r.problem("'action': expected a string, got " + a.dump());
    return std::nullopt;
  }
  const std::string name = a.get<std::string>();
  const auto found =
      std::find_if(kActions.begin(), kActions.end(), [&](const ActionReader& n) { return n.name == name; });
  if (found == kActions.end()) {
    r.problem("unknown action '" + name + "'; expected one of " + actionList() +
              " (camera moves and waits are {\"camera\": ...} and {\"wait\": frames})");
    return std::nullopt;
  }
  return found->read(r);
}

/// {"camera": spec or file, "seconds": s}. `file` is the script, for messages about an inline spec.
CameraStep readCamera(StepReader& r, const std::string& file, Diagnostics& d) {
  CameraStep step;
  const json& c = *r.field("camera", true);
  step.cameraFile = file;
  if (c.is_string() && !c.get<std::string>().empty()) {
    step.cameraFile = r.resolve(c.get<std::string>());
    std::optional<json> spec = scene::readJsonFile(step.cameraFile, d);
    if (!spec) {
      r.problem("'camera': cannot read the camera file " + step.cameraFile);
    } else {
      step.camera = std::move(*spec);
    }
  } else if (c.is_object()) {
    step.camera = c;
  } else {
    r.problem("'camera': expected a camera object or the path of a camera file, got " + c.dump());
  }
  // Only what every camera needs: the viewer reads the rest with parseCameraSpec against the
  // scene's frame, which this parser does not know.
  if (!step.camera.is_null()) {
    if (!step.camera.is_object()) {
      r.problem("'camera': " + step.cameraFile + " does not hold a camera object");
    } else {
      if (!step.camera.contains("eye") && !step.camera.contains("eye_xyz"))
        r.problem("'camera': needs 'eye' (lon/lat/h) or 'eye_xyz'");
      if (!step.camera.contains("target") && !step.camera.contains("target_xyz"))
        r.problem("'camera': needs 'target' (lon/lat/h) or 'target_xyz'");
    }
  }
  step.seconds =
      r.number("seconds", false, "a number of seconds >= 0", [](double v) { return v >= 0.0; }).value_or(0.0);
  return step;
}

/// {"globe_camera": {"lon": …, "lat": …, "distance": …, "heading": …, "pitch": …}}.
GlobeCameraStep readGlobeCamera(StepReader& r) {
  GlobeCameraStep step;
  const json& c = *r.field("globe_camera", true);
  if (!c.is_object()) {
    r.problem("'globe_camera': expected an object with lon, lat, distance (and heading, pitch), got " + c.dump());
    return step;
  }
  std::vector<std::string> inner;
  StepReader camera(c, fs::path(), inner);
  step.lon =
      camera.number("lon", true, "degrees in [-540, 540]", [](double v) { return std::abs(v) <= 540.0; }).value_or(0.0);
  step.lat =
      camera.number("lat", true, "degrees in [-90, 90]", [](double v) { return std::abs(v) <= 90.0; }).value_or(0.0);
  step.distance =
      camera.number("distance", true, "metres > 0", [](double v) { return v > 0.0 && v <= 1e9; }).value_or(1e7);
  step.heading = camera.number("heading", false).value_or(0.0);
  step.pitch =
      camera.number("pitch", false, "degrees in (0, 90]", [](double v) { return v > 0.0 && v <= 90.0; }).value_or(90.0);
  for (const std::string& key : camera.unknownKeys()) inner.push_back("unknown key '" + key + "'");
  for (const std::string& problem : inner) r.problem("'globe_camera': " + problem);
  return step;
}

WaitStep readWait(StepReader& r) {
  const std::optional<double> frames = r.number("wait", true, "a whole number of frames >= 0", [](double v) {
    return v >= 0.0 && v == std::floor(v) && v <= static_cast<double>(std::numeric_limits<int>::max());
  });
  return WaitStep{.frames = frames ? static_cast<int>(*frames) : 0};
}

/// The action of a step, or nothing when it has none to run; problems and unknown keys are
/// reported by the caller.
std::optional<ScriptAction> readStep(StepReader& r, const std::string& file, Diagnostics& d) {
  const bool hasCamera = r.has("camera"), hasWait = r.has("wait"), hasAction = r.has("action"),
             hasGlobe = r.has("globe_camera");
  if ((hasCamera ? 1 : 0) + (hasWait ? 1 : 0) + (hasAction ? 1 : 0) + (hasGlobe ? 1 : 0) != 1) {
    r.field("camera", false);  // the keys are not unknown, only too many or too few
    r.field("wait", false);
    r.field("action", false);
    r.field("globe_camera", false);
    r.problem("expected exactly one of \"camera\", \"globe_camera\", \"wait\" and \"action\"");
    return std::nullopt;
  }
  if (hasCamera) return readCamera(r, file, d);
  if (hasGlobe) return readGlobeCamera(r);
  if (hasWait) return readWait(r);
  return readAction(r);
}

}  // namespace

Result<ViewerScript> parseViewerScript(const json& j, const std::string& file) {
  Result<ViewerScript> result;
  Diagnostics& d = result.diagnostics;
  if (!j.is_object() || !j.contains("steps") || !j["steps"].is_array()) {
    return Result<ViewerScript>::failure({Severity::Error, file, "", "", "expected an object with an array 'steps'"});
  }
  ViewerScript script;
  script.file = file;
  std::error_code ec;
  const fs::path absolute = fs::absolute(fs::path(file), ec);
  const fs::path base = (ec ? fs::path(file) : absolute).parent_path();

  for (const auto& item : j.items()) {
    if (item.key() != "steps" && item.key() != "window")
      d.add({Severity::Warning, file, "", "", "unknown key '" + item.key() + "' ignored"});
  }
  if (j.contains("window")) {
    script.window = windowSize(j["window"]);
    if (!script.window) d.add({Severity::Error, file, "", "", kWindowExpected + j["window"].dump()});
  }

  std::size_t index = 0, broken = 0;
  for (const json& entry : j["steps"]) {
    ++index;
    const std::string name = "step " + std::to_string(index);
    if (!entry.is_object()) {
      d.add({Severity::Error, file, "", name, "expected an object, got " + entry.dump()});
      ++broken;
      continue;
    }
    std::vector<std::string> problems;
    StepReader reader(entry, base, problems);
    std::optional<ScriptAction> action = readStep(reader, file, d);
    for (const std::string& key : reader.unknownKeys())
      d.add({Severity::Warning, file, "", name, "unknown key '" + key + "' ignored"});
    for (const std::string& problem : problems) d.add({Severity::Error, file, "", name, problem});
    if (problems.empty() && action) {
      script.steps.push_back(ScriptStep{.index = index, .action = std::move(*action)});
    } else {
      ++broken;
    }
  }

  if (d.hasErrors()) {
    // A script is a test program: running the steps that could be read would hide the mistake.
    d.add({Severity::Error, file, "", "",
           broken == 0 ? std::string("the script is not run")
                       : std::to_string(broken) + " of " + std::to_string(index) +
                             " steps cannot be run; the script is not run"});
    return result;
  }
  if (script.steps.empty()) d.add({Severity::Warning, file, "", "", "no steps"});
  result.value = std::move(script);
  return result;
}

Result<ViewerScript> loadViewerScript(const std::string& path) {
  Result<ViewerScript> failed;
  const std::optional<json> j = scene::readJsonFile(path, failed.diagnostics);
  if (!j) return failed;
  return parseViewerScript(*j, path);
}

}  // namespace gis::app
