// overlay_bench: headless benchmark. This version measures the terrain (mode "terrain"): a
// scripted fly-through (top-down, oblique, horizon) at a fixed resolution, frame by frame with
// glFinish, reporting frame-time median and p95, triangles and chunks per frame, LOD selection
// time, CPU and GPU memory, and the deterministic fragment counts. Writes bench.json and
// frames.csv. Frame times are wall time on a shared machine: compare within one run.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/camera_path.hpp"
#include "app/cli.hpp"
#include "app/scene.hpp"
#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "gfx/context.hpp"
#include "gfx/render_target.hpp"
#include "terrain/tile_pager.hpp"

namespace {

using nlohmann::json;
using namespace gis;

constexpr const char* kUsage =
    "usage: overlay_bench --scene S.json [--mode terrain] [--width W --height H] [--frames N]\n"
    "                     [--lod-tolerance PX] [--paging auto|always|never] --out DIR\n";

struct Options {
  std::string scene, out, mode = "terrain";
  int width = 1200, height = 1000, frames = 90;
  double lodTolerance = 1.5;
  std::optional<app::TerrainPaging> paging;
};

/// "VmRSS" or "VmHWM" of this process in bytes (Linux).
std::size_t processMemory(const char* key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(key, 0) == 0) return static_cast<std::size_t>(std::stoull(line.substr(line.find(':') + 1))) * 1024;
  }
  return 0;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(
      std::clamp(p / 100.0 * static_cast<double>(v.size() - 1), 0.0, static_cast<double>(v.size() - 1)) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

std::string parseArgs(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (i + 1 >= argc) return std::string(a) + " needs a value";
    const std::string_view v = argv[++i];
    std::optional<int> n;
    if (a == "--scene")
      o.scene = v;
    else if (a == "--out")
      o.out = v;
    else if (a == "--mode")
      o.mode = v;
    else if (a == "--width" && (n = app::parseInt(v)) && *n > 0 && *n <= 16384)
      o.width = *n;
    else if (a == "--height" && (n = app::parseInt(v)) && *n > 0 && *n <= 16384)
      o.height = *n;
    else if (a == "--frames" && (n = app::parseInt(v)) && *n >= 3)
      o.frames = *n;
    else if (a == "--lod-tolerance" && app::parseDouble(v) && *app::parseDouble(v) >= 0.0)
      o.lodTolerance = *app::parseDouble(v);
    else if (a == "--paging" && v == "auto")
      o.paging = app::TerrainPaging::Auto;
    else if (a == "--paging" && v == "always")
      o.paging = app::TerrainPaging::Always;
    else if (a == "--paging" && v == "never")
      o.paging = app::TerrainPaging::Never;
    else
      return "bad argument " + std::string(a) + " " + std::string(v);
  }
  if (o.scene.empty() || o.out.empty()) return "--scene and --out are required";
  if (o.mode != "terrain") return "--mode: only \"terrain\" is available in this version";
  return {};
}

int run(const Options& o) {
  const auto loadStart = std::chrono::steady_clock::now();
  Result<app::SceneDescription> description = app::loadSceneFile(o.scene);
  app::report(description.diagnostics);
  if (!description) return 1;
  description->layers.clear();  // terrain mode
  app::LoadOptions loadOptions;
  loadOptions.paging = o.paging;
  Result<app::LoadedScene> scene = app::loadScene(*description, loadOptions);
  app::report(scene.diagnostics);
  if (!scene) return 1;
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - loadStart).count();
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  app::report(context.diagnostics);
  if (!context) return 1;
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene);
  app::report(renderer.diagnostics);
  if (!renderer) return 1;

  glm::dvec3 lo, hi;
  app::terrainBox(*scene, description->verticalExaggeration, lo, hi);
  const std::vector<app::PathFrame> path = app::flyThrough(lo, hi, o.frames);
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height);
  app::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.verticalExaggeration = description->verticalExaggeration;

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,frame_ms,select_ms,chunks,triangles,chunks_built,finest_level,fragments,tiles_missing,"
         "tiles_arrived,tile_bytes\n";
  std::vector<double> frameMs;
  std::map<std::string, std::vector<double>> bySegment;
  std::vector<double> triangles, chunks;
  std::size_t framesWaiting = 0, tileBytesPeak = 0;
  for (std::size_t k = 0; k < path.size(); ++k) {
    // Every 10th frame also counts fragments (the query waits, so it is not timed).
    settings.measure = k % 10 == 0;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    const app::FrameStats s =
        renderer->render(cache, target.framebuffer(), o.width, o.height, path[k].camera, settings);
    glFinish();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (k > 0 && !settings.measure) {  // frame 0 builds the first chunks: reported apart
      frameMs.push_back(ms);
      bySegment[path[k].segment].push_back(ms);
    }
    triangles.push_back(static_cast<double>(s.terrainDraw.triangles));
    chunks.push_back(static_cast<double>(s.terrainDraw.chunks));
    csv << k << ',' << path[k].segment << ',' << ms << ',' << s.selectMilliseconds << ',' << s.terrainDraw.chunks << ','
        << s.terrainDraw.triangles << ',' << s.terrainDraw.chunksBuilt << ',' << s.finestLevel << ','
        << (settings.measure ? std::to_string(s.terrain.counts.fragmentShaderInvocations) : "") << ',' << s.tilesMissing
        << ',' << s.tilesArrived << ',' << s.pager.residentBytes + s.pager.pinnedBytes << '\n';
    framesWaiting += s.tilesMissing > 0 ? 1u : 0u;
    tileBytesPeak = std::max(tileBytesPeak, s.pager.residentBytes + s.pager.pinnedBytes);
  }
  const terrain::TerrainGrid& grid = scene->quadtree->grid();
  json segments;
  for (const auto& [name, v] : bySegment) {
    segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}, {"frames", v.size()}};
  }
  const double median = percentile(frameMs, 50);
  json result = {{"mode", o.mode},
                 {"scene", o.scene},
                 {"dem_size", {grid.width, grid.height}},
                 {"width", o.width},
                 {"height", o.height},
                 {"lod_tolerance_px", o.lodTolerance},
                 {"frames", path.size()},
                 {"load_seconds", loadSeconds},
                 {"frame_ms", {{"median", median}, {"p95", percentile(frameMs, 95)}}},
                 {"fps_median", median > 0 ? 1000.0 / median : 0.0},
                 {"segments", segments},
                 {"triangles_per_frame", {{"median", percentile(triangles, 50)}, {"max", percentile(triangles, 100)}}},
                 {"chunks_per_frame", {{"median", percentile(chunks, 50)}, {"max", percentile(chunks, 100)}}},
                 {"gpu_bytes", renderer->terrainEngine().gpuBytes()},
                 {"paged", scene->paged()},
                 {"pyramid_build_seconds", scene->pyramidBuild ? json(scene->pyramidBuild->seconds) : json(nullptr)},
                 {"frames_drawing_parents_of_loading_tiles", framesWaiting},
                 {"tile_cache_peak_bytes", tileBytesPeak},
                 {"tile_cache_budget_bytes", scene->paged() ? scene->quadtree->pager()->budgetBytes() : std::size_t{0}},
                 {"cpu_rss_bytes", processMemory("VmRSS")},
                 {"cpu_peak_bytes", processMemory("VmHWM")},
                 {"renderer", (*context)->info().renderer},
                 {"gl_errors", (*context)->debug().errorCount()}};
  std::ofstream(std::filesystem::path(o.out) / "bench.json") << result.dump(2) << '\n';
  std::printf("%s\n", result.dump(2).c_str());
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return gis::app::programMain(
      argc, argv, "overlay_bench", kUsage, [&](int n, char** v) { return parseArgs(n, v, options); },
      [&] { return run(options); });
}
