// Fuzzes the three JSON file parsers of the programs with the same bytes: scene files
// (scene::parseScene), lasso files (scene::parseLassoFile) and viewer scripts
// (app::parseViewerScript). Each must return, never throw or crash; a failure carries an Error
// naming the file; a value is sane: the numbers the parser checks are in their ranges and
// finite, or an Error names the key that was wrong (scene files keep what they could read).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "app/viewer_script.hpp"
#include "geo/frame.hpp"
#include "scene/lasso_file.hpp"
#include "scene/scene.hpp"
#include "vector_overlay/technique.hpp"

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

const char* const kScene = "/fuzz/scene.json";
const char* const kLasso = "/fuzz/lasso.json";

[[noreturn]] void fail(const std::string& what, const std::string& input) {
  std::fprintf(stderr, "app_files_fuzzer: %s\ninput: %.2000s\n", what.c_str(), input.c_str());
  std::abort();
}

void check(bool ok, const std::string& what, const std::string& input) {
  if (!ok) fail(what, input);
}

bool finite(double v) { return std::isfinite(v); }

/// At least one Error naming `file`.
bool errorNaming(const gis::Diagnostics& d, const std::string& file) {
  for (const gis::Diagnostic& x : d.items()) {
    if (x.severity == gis::Severity::Error && x.file == file) return true;
  }
  return false;
}

/// An Error whose message starts with 'key' (scene files say "'terrain.band': ...").
bool errorOnKey(const gis::Diagnostics& d, const std::string& key) {
  const std::string quoted = "'" + key + "'";
  for (const gis::Diagnostic& x : d.items()) {
    if (x.severity == gis::Severity::Error && x.message.rfind(quoted, 0) == 0) return true;
  }
  return false;
}

void checkScene(const std::string& text) {
  gis::Result<gis::scene::SceneDescription> r;
  try {
    r = gis::scene::parseScene(text, kScene);
  } catch (const std::exception& e) {
    fail(std::string("parseScene threw: ") + e.what(), text);
  }
  for (const gis::Diagnostic& d : r.diagnostics.items()) check(!d.file.empty(), "a diagnostic names no file", text);
  if (!r.ok()) {
    check(errorNaming(r.diagnostics, kScene), "parseScene failed without an Error naming the file", text);
    return;
  }
  const gis::scene::SceneDescription& s = *r;
  // A value out of range is fine only when an Error names its key.
  auto sane = [&](bool ok, const std::string& key) {
    if (!ok && !errorOnKey(r.diagnostics, key)) fail("scene value '" + key + "' is out of range unreported", text);
  };
  check(s.path == kScene && !s.dem.empty(), "scene without its path or DEM", text);
  sane(s.demBand >= 1, "terrain.band");
  sane(s.verticalExaggeration > 0.0 && finite(s.verticalExaggeration), "terrain.vertical_exaggeration");
  sane(s.chunkCells >= 8 && s.chunkCells <= 256 && (s.chunkCells & (s.chunkCells - 1)) == 0, "terrain.chunk_cells");
  sane(s.memoryBudgetMb >= 16.0 && finite(s.memoryBudgetMb), "terrain.memory_budget_mb");
  sane(s.gpuBudgetMb >= 16.0 && finite(s.gpuBudgetMb), "terrain.gpu_budget_mb");
  sane(s.imageryBands.size() == 1 || s.imageryBands.size() == 3, "imagery.bands");
  for (std::size_t i = 0; i < s.layers.size(); ++i) {
    const gis::scene::LayerDescription& l = s.layers[i];
    check(!l.source.empty() && !l.name.empty(), "a layer without source or name", text);
    const gis::overlay::LayerStyle& st = l.style;
    // Layers with errors are left out, so a kept layer's style must be in range.
    const std::string where = "layer " + std::to_string(i) + " style ";
    check(st.opacity >= 0.0F && st.opacity <= 1.0F, where + "opacity out of [0, 1]", text);
    check(st.outlineWidthMetres >= 0.0F && std::isfinite(st.outlineWidthMetres), where + "outline_width_m", text);
    check(st.outlineWidthPixels >= 0.0F && std::isfinite(st.outlineWidthPixels), where + "outline_width_px", text);
    check(st.widthMetres > 0.0 && finite(st.widthMetres), where + "width_m", text);
    check(st.widthPixels >= 0.0 && finite(st.widthPixels), where + "width_px", text);
    check(st.maxWidthMetres >= 0.0 && finite(st.maxWidthMetres), where + "max_width_m", text);
    check(st.minWidthPixels >= 0.0 && st.minWidthPixels <= 1e3, where + "min_width_px", text);
    for (float c : {st.color.x, st.color.y, st.color.z, st.color.w, st.outlineColor.x, st.outlineColor.w}) {
      check(c >= 0.0F && c <= 1.0F, where + "colour channel out of [0, 1]", text);
    }
  }
  if (s.camera) {
    sane(s.camera->fovYDeg > 0.0 && s.camera->fovYDeg < 180.0, "camera 'fov_y_deg'");
    sane(!s.camera->nearPlane || *s.camera->nearPlane > 0.0, "camera 'near'");
  }
}

/// Strings of the document that could name a file outside the fuzzer's folder (the lasso and
/// script parsers read camera files): such inputs are not given to them, so that no fuzz input
/// reads /dev/zero or the like. Names without a slash stay in the folder.
bool namesOtherFiles(const json& root) {
  std::vector<const json*> stack{&root};
  while (!stack.empty()) {
    const json* j = stack.back();
    stack.pop_back();
    if (j->is_string()) {
      const std::string& s = j->get_ref<const std::string&>();
      if (s.find('/') != std::string::npos || s.find('\\') != std::string::npos) return true;
    } else if (j->is_structured()) {
      for (const json& child : *j) stack.push_back(&child);
    }
  }
  return false;
}

struct Fixture {
  fs::path dir;
  gis::geo::SceneFrame frame;
  gis::scene::Camera camera;
};

Fixture makeFixture() {
  // A folder with a camera file, for lassos and steps that name one ("camera.json").
  const fs::path dir = fs::temp_directory_path() / ("stencil-gis-app-files-fuzzer-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "camera.json") << R"({"eye_xyz": [0, -500, 300], "target_xyz": [0, 0, 0], "fov_y_deg": 45})";
  gis::Result<gis::geo::SceneFrame> frame =
      gis::geo::SceneFrame::fromCrs("EPSG:32725", glm::dvec3(292000.0, 9115000.0, 0.0));
  if (!frame) {
    std::fprintf(stderr, "app_files_fuzzer: no frame (EPSG:32725)\n");
    std::abort();
  }
  gis::scene::Camera camera;
  camera.eye = glm::dvec3(0.0, -800.0, 600.0);
  camera.target = glm::dvec3(0.0);
  return Fixture{dir, *frame, camera};
}

const Fixture& fixture() {
  static const Fixture f = makeFixture();
  return f;
}

void removeFixture() {
  std::error_code ignored;
  fs::remove_all(fixture().dir, ignored);
}

void checkLasso(const json& j, const std::string& text) {
  const Fixture& f = fixture();
  gis::Result<gis::scene::SelectionRequest> r;
  try {
    r = gis::scene::parseLassoFile(j, kLasso, f.dir.string(), f.frame, f.camera, 640, 480);
  } catch (const std::exception& e) {
    fail(std::string("parseLassoFile threw: ") + e.what(), text);
  }
  if (!r.ok()) {
    check(errorNaming(r.diagnostics, kLasso), "parseLassoFile failed without an Error naming the file", text);
    return;
  }
  for (const gis::Diagnostic& d : r.diagnostics.items()) check(!d.file.empty(), "a diagnostic names no file", text);
  const gis::scene::SelectionRequest& s = *r;
  check(!s.sampleSpacing || (*s.sampleSpacing > 0.0 && finite(*s.sampleSpacing)), "sample spacing out of range", text);
  check(s.highlight.opacity >= 0.0F && s.highlight.opacity <= 1.0F, "highlight opacity out of [0, 1]", text);
  for (const gis::overlay::SelectionStep& step : s.steps) {
    if (step.op == gis::overlay::SelectionOp::Invert) continue;
    const gis::overlay::Lasso& l = step.lasso;
    check(l.points.size() >= 3, "a lasso with fewer than 3 points", text);
    for (const glm::dvec2& p : l.points) check(finite(p.x) && finite(p.y), "a lasso point not finite", text);
    check(l.width >= 1 && l.height >= 1 && l.width <= 65536 && l.height <= 65536, "a lasso viewport out of range",
          text);
    check(l.distance > 0.0, "a lasso distance not positive", text);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) check(finite(l.viewProj[c][k]), "a lasso camera matrix not finite", text);
  }
}

void checkScript(const json& j, const std::string& text) {
  const std::string file = (fixture().dir / "script.json").string();
  gis::Result<gis::app::ViewerScript> r;
  try {
    r = gis::app::parseViewerScript(j, file);
  } catch (const std::exception& e) {
    fail(std::string("parseViewerScript threw: ") + e.what(), text);
  }
  if (!r.ok()) {
    check(errorNaming(r.diagnostics, file), "parseViewerScript failed without an Error naming the file", text);
    return;
  }
  // Every broken step fails the script: a value has no Error.
  check(!r.diagnostics.hasErrors(), "a script with Errors has a value", text);
  const gis::app::ViewerScript& s = *r;
  if (s.window) check(s.window->x >= 1 && s.window->y >= 1, "window size not positive", text);
  for (std::size_t i = 0; i < s.steps.size(); ++i) {
    const gis::app::ScriptStep& st = s.steps[i];
    const std::string where = "step " + std::to_string(i + 1) + ": ";
    check(st.index == i + 1, where + "wrong index", text);
    // Each action's own fields, as typed when read: finite and in range.
    auto points = [&](const std::vector<glm::dvec2>& ps, std::size_t least, const char* what) {
      check(ps.size() >= least, where + what + " with too few points", text);
      for (const glm::dvec2& p : ps) check(finite(p.x) && finite(p.y), where + "a point not finite", text);
    };
    auto pixel = [&](const glm::dvec2& at) { check(finite(at.x) && finite(at.y), where + "'at' not finite", text); };
    std::visit(
        [&](const auto& step) {
          using T = std::decay_t<decltype(step)>;
          if constexpr (std::is_same_v<T, gis::app::CameraStep>) {
            check(finite(step.seconds) && step.seconds >= 0.0, where + "seconds", text);
            check(step.camera.is_object(), where + "camera is not an object", text);
          } else if constexpr (std::is_same_v<T, gis::app::WaitStep>) {
            check(step.frames >= 0, where + "negative wait", text);
          } else if constexpr (std::is_same_v<T, gis::app::SetLayerStep>) {
            if (step.opacity) check(*step.opacity >= 0.0F && *step.opacity <= 1.0F, where + "opacity", text);
            if (step.width) check(*step.width > 0.0 && finite(*step.width), where + "width", text);
            if (step.color) {
              for (int c = 0; c < 4; ++c) {
                check((*step.color)[c] >= 0.0F && (*step.color)[c] <= 1.0F, where + "colour", text);
              }
            }
          } else if constexpr (std::is_same_v<T, gis::app::MethodStep>) {
            check(gis::overlay::findTechnique(step.name) != nullptr, where + "unknown technique", text);
          } else if constexpr (std::is_same_v<T, gis::app::ExaggerationStep>) {
            check(finite(step.value) && step.value > 0.0, where + "exaggeration not positive", text);
          } else if constexpr (std::is_same_v<T, gis::app::LassoStep>) {
            check(step.op != gis::overlay::SelectionOp::Invert, where + "a lasso that inverts", text);
            points(step.points, 3, "lasso");
          } else if constexpr (std::is_same_v<T, gis::app::IdentifyStep> || std::is_same_v<T, gis::app::ClickStep>) {
            pixel(step.at);
          } else if constexpr (std::is_same_v<T, gis::app::ScrollStep>) {
            pixel(step.at);
            check(finite(step.amount) && step.amount != 0.0, where + "scroll of 0", text);
          } else if constexpr (std::is_same_v<T, gis::app::DragStep>) {
            points(step.points, 2, "drag");
            check(step.frames >= 1, where + "drag without frames", text);
          } else if constexpr (std::is_same_v<T, gis::app::ViewStep>) {
            if (step.lodTolerance) {
              check(*step.lodTolerance > 0.0 && finite(*step.lodTolerance), where + "lod_tolerance", text);
            }
            if (step.fovYDeg) check(*step.fovYDeg > 0.0 && *step.fovYDeg < 180.0, where + "fov", text);
          }
        },
        st.action);
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  fixture();
  std::atexit(removeFixture);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  checkScene(text);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception&) {
    return 0;  // not JSON: the scene parser saw it; the other two take parsed documents
  }
  if (namesOtherFiles(j)) return 0;
  checkLasso(j, text);
  checkScript(j, text);
  return 0;
}
