// overlay_bench: headless benchmark. The options and the choice of mode; each mode is in its file:
// terrain_mode.cpp, overlay_mode.cpp, methods_mode.cpp (methods, ablation), scaling_mode.cpp and
// lasso_mode.cpp. Frame times are wall time on a shared machine: compare within one run.
#include <limits>
#include <string>
#include <string_view>

#include "app/cli.hpp"
#include "app/option_parser.hpp"
#include "bench_common.hpp"
#include "scaling_mode.hpp"

namespace {

using namespace gis;
using namespace gis::bench;

constexpr const char* kUsage =
    "usage: overlay_bench --scene S.json [--mode terrain|overlay|methods|ablation|scaling|lasso] [--width W "
    "--height "
    "H] [--frames N]\n"
    "                     [--lod-tolerance PX] [--paging auto|always|never] [--max-volumes N]\n"
    "                     [--repeats R] [--texture-sizes TECHNIQUE=512,1024,...]...\n"
    "                     [--error-every N] [--msaa 0|2|4|8]\n"
    "                     [--segments top-down,oblique,horizon,close-up] --out DIR\n"
    "--mode methods: terrain only and every overlay technique on the same frames, a technique that\n"
    "  rasterises textures at each of its --texture-sizes (repeatable, e.g. drape=512,4096; \"none\":\n"
    "  leave it out; default: its default size): frame time, memory, build time and wrong pixels against\n"
    "  the CPU reference (every --error-every frames), GPU time and fragments per pass, per path segment\n"
    "  (--segments: which; close-up puts the eye 1.5 m over roads and areas); writes methods.json,\n"
    "  methods.csv, methods.md and plots; --msaa: multisampled targets, the error judged on sample 0.\n"
    "  A scene on the globe (docs/globe.md) is flown from 9,000 km down to a few kilometres (space,\n"
    "  continent, regional, low over an edge, across the antimeridian, over the south pole; data smaller\n"
    "  than 200 km: above it, obliquely, low over an edge, 100 m up); its passes are timed and counted\n"
    "  together (their figures are the mark's). --mode overlay and ablation fly the same path (the\n"
    "  ablation without the projected frame's piece splits); the other modes draw projected scenes\n"
    "--mode ablation: ours with each saving switched off alone (z-fail everywhere, bottom caps in z-pass,\n"
    "  no frustum culling, cover with the pieces, one cover rectangle, no split at cells) and with\n"
    "  lines united per cell, the same\n"
    "  figures; ablation.json\n"
    "--mode scaling --scenes A.json,B.json,... [--overlay-render PATH] [--whole-load-max-vertices N]:\n"
    "  per scene, terrain only, stencil-tiles, and the techniques that build everything at load (stencil,\n"
    "  paper) only up to N vector vertices (default 500000). Start: overlay_render (PATH; default the one\n"
    "  beside overlay_bench) draws the still twice, cold (the scene's files dropped from the page cache)\n"
    "  and warm: first frame s, peak RSS, GPU MB; terrain only is --overlays off. Frames: the methods\n"
    "  path in this process (every segment unless --segments), per segment the median frame time and\n"
    "  its ratio to terrain only. scaling.md, scaling.json and plots against vector vertices; default\n"
    "  size 800 x 600\n";

/// Sets `o.segments` from "a,b,…"; false when a name is not a segment of the path.
bool setSegments(Options& o, std::string_view list) {
  o.segments.clear();
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    const std::string name(list.substr(start, comma - start));
    if (name != "top-down" && name != "oblique" && name != "horizon" && name != "close-up") return false;
    o.segments.push_back(name);
    start = comma + 1;
  }
  return true;
}

/// Sets `sizes` from "a,b,…" (or "none": no sizes); false when one is not a size in [16, 16384].
bool setSizes(std::vector<int>& sizes, std::string_view value) {
  sizes.clear();
  const std::string list = value == "none" ? std::string() : std::string(value);
  for (std::size_t start = 0; start < list.size();) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    const std::optional<int> size = app::parseInt(list.substr(start, comma - start));
    if (!size || *size < 16 || *size > 16384) return false;
    sizes.push_back(*size);
    start = comma + 1;
  }
  return true;
}

/// The techniques that rasterise textures, "a, b".
std::string textureTechniqueNames() {
  std::string names;
  for (const overlay::TechniqueInfo& t : overlay::techniques()) {
    if (t.usesTextures()) names += (names.empty() ? "" : ", ") + std::string(t.name);
  }
  return names;
}

/// Sets one technique's sizes from "NAME=a,b,…"; false when NAME is not a technique that
/// rasterises textures, or a size is bad.
bool setTextureSizes(Options& o, std::string_view value) {
  const std::size_t equals = value.find('=');
  if (equals == std::string_view::npos) return false;
  const overlay::TechniqueInfo* technique = overlay::findTechnique(value.substr(0, equals));
  if (technique == nullptr || !technique->usesTextures()) return false;
  return setSizes(o.textureSizes[std::string(technique->name)], value.substr(equals + 1));
}

/// Sets `o.scenes` from "a,b,…" (empty names left out).
bool setScenes(Options& o, std::string_view list) {
  o.scenes.clear();
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    if (comma > start) o.scenes.emplace_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  return true;
}

/// Every argument is a flag and its value; a bad one is "bad argument FLAG VALUE".
std::string parseArgs(int argc, char** argv, Options& o, ScalingOptions& scaling) {
  constexpr int kAny = std::numeric_limits<int>::max();
  // The scaling mode's start runs are the 800 x 600 stills, and its frames are drawn at
  // the same size; --width and --height, read after, still rule.
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string_view(argv[i]) == "--mode" && std::string_view(argv[i + 1]) == "scaling") {
      o.width = 800;
      o.height = 600;
    }
  }
  app::OptionParser parser(app::OptionParser::Style::BadArgument);
  parser.option("--scene", o.scene);
  parser.option("--out", o.out);
  parser.option("--mode", o.mode);
  parser.option("--width", o.width, 1, 16384);
  parser.option("--height", o.height, 1, 16384);
  parser.option("--frames", o.frames, 3, kAny);
  parser.option("--max-volumes", o.maxVolumes, 2, 500);
  parser.option("--repeats", o.repeats, 1, 100);
  parser.option("--lod-tolerance", o.lodTolerance, 0.0, std::numeric_limits<double>::max());
  parser.custom(
      "--texture-sizes", [&o](std::string_view v) { return setTextureSizes(o, v); }, "a value",
      [](std::string_view v) {
        return "--texture-sizes: TECHNIQUE=sizes, TECHNIQUE one that rasterises textures (" + textureTechniqueNames() +
               ") and sizes a comma-separated list of 16 to 16384 (or \"none\"), not '" + std::string(v) + "'";
      });
  parser.option("--error-every", o.errorEvery, 1, kAny);
  parser.custom("--msaa", [&o](std::string_view v) {
    const std::optional<int> n = app::parseInt(v);
    if (!n || (*n != 0 && *n != 1 && *n != 2 && *n != 4 && *n != 8)) return false;
    o.msaa = *n;
    return true;
  });
  parser.custom("--scenes", [&o](std::string_view v) { return setScenes(o, v); });
  parser.option("--overlay-render", scaling.overlayRender);
  parser.option("--whole-load-max-vertices", scaling.wholeLoadMaxVertices, 0, kAny);
  parser.custom(
      "--segments", [&o](std::string_view v) { return setSegments(o, v); }, "a value",
      [](std::string_view) { return "--segments: a comma-separated list of top-down, oblique, horizon, close-up"; });
  parser.choice<scene::TerrainPaging>("--paging", o.paging,
                                      {{"auto", scene::TerrainPaging::Auto},
                                       {"always", scene::TerrainPaging::Always},
                                       {"never", scene::TerrainPaging::Never}});
  if (std::string error = parser.parse(argc, argv); !error.empty()) return error;
  if (o.mode == "scaling" && o.scene.empty() && !o.scenes.empty()) o.scene = o.scenes.front();
  if (o.mode == "scaling" && o.scenes.empty()) return "--mode scaling needs --scenes A.json,B.json,...";
  if (o.scene.empty() || o.out.empty()) return "--scene and --out are required";
  if (o.mode != "terrain" && o.mode != "overlay" && o.mode != "lasso" && o.mode != "methods" && o.mode != "ablation" &&
      o.mode != "scaling")
    return "--mode: \"terrain\", \"overlay\", \"methods\", \"ablation\", \"scaling\" or \"lasso\" (a scene on the "
           "globe: "
           "\"methods\")";
  return {};
}

int run(const Options& o, const ScalingOptions& scaling) {
  if (o.mode == "overlay") return runOverlay(o);
  if (o.mode == "lasso") return runLasso(o);
  if (o.mode == "methods") return runMethods(o);
  if (o.mode == "ablation") return runAblation(o);
  if (o.mode == "scaling") return runScaling(o, scaling);
  return runTerrain(o);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  ScalingOptions scaling;
  return gis::app::programMain(
      argc, argv, "overlay_bench", kUsage, [&](int n, char** v) { return parseArgs(n, v, options, scaling); },
      [&] { return run(options, scaling); });
}
