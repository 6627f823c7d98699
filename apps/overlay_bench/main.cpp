// overlay_bench: headless benchmark.
// - mode "terrain": a scripted fly-through (top-down, oblique, horizon) at a fixed resolution,
//   frame by frame with glFinish, reporting frame-time median and p95, triangles and chunks per
//   frame, LOD selection time, CPU and GPU memory, and the deterministic fragment counts.
// - mode "overlay": the same path, each frame drawn three ways in turn — terrain only, our
//   stencil polyhedra, the seed paper's construction — so that the ratios come from one run;
//   plus, on every 3rd frame, GPU time and fragment counts per layer against the pixels each
//   layer covers (fragments per covered pixel), and the latency of a one-feature edit.
// Writes bench.json and frames.csv. Frame times are wall time on a shared machine: compare
// within one run.
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
    "usage: overlay_bench --scene S.json [--mode terrain|overlay] [--width W --height H] [--frames N]\n"
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
  if (o.mode != "terrain" && o.mode != "overlay") return "--mode: \"terrain\" or \"overlay\"";
  return {};
}

int runOverlay(const Options& o);

/// Writes bench.json, prints it, and fails the run on any GL error.
int finish(const Options& o, const json& result, gfx::Context& context) {
  std::ofstream(std::filesystem::path(o.out) / "bench.json") << result.dump(2) << '\n';
  std::printf("%s\n", result.dump(2).c_str());
  return context.debug().errorCount() == 0 ? 0 : 1;
}

int run(const Options& o) {
  if (o.mode == "overlay") return runOverlay(o);
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
  return finish(o, result, **context);
}

struct MethodFrames {
  std::vector<double> ms;
  std::map<std::string, std::vector<double>> bySegment;
};

int runOverlay(const Options& o) {
  Result<app::SceneDescription> description = app::loadSceneFile(o.scene);
  app::report(description.diagnostics);
  if (!description) return 1;
  app::LoadOptions loadOptions;
  loadOptions.paging = o.paging;
  Result<app::LoadedScene> scene = app::loadScene(*description, loadOptions);
  app::report(scene.diagnostics);
  if (!scene) return 1;
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  app::report(context.diagnostics);
  if (!context) return 1;
  // Two renderers: ours and the paper's construction (the terrain is the same).
  app::OverlayBuildSettings ours, paper;
  paper.method = app::OverlayMethod::Paper;
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene, ours);
  app::report(renderer.diagnostics);
  Result<app::SceneRenderer> paperRenderer = app::SceneRenderer::create(*scene, paper);
  if (!renderer || !paperRenderer) return 1;

  glm::dvec3 lo, hi;
  app::terrainBox(*scene, description->verticalExaggeration, lo, hi);
  const std::vector<app::PathFrame> path = app::flyThrough(lo, hi, o.frames);
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, 0, true);
  app::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.verticalExaggeration = description->verticalExaggeration;
  settings.waitForTiles = true;  // the same terrain for the three methods

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,terrain_ms,stencil_ms,paper_ms,covered_pixels,stencil_fragments,paper_fragments,"
         "stencil_zfail_pieces\n";
  MethodFrames terrainOnly, stencil, paperVariant;
  std::vector<double> fragmentsPerPixel, paperFragmentsPerPixel, ratio;
  std::map<std::string, std::vector<double>> fppBySegment, paperFppBySegment;
  struct LayerCounts {
    std::map<std::string, std::vector<double>> mark, cover;  ///< per covered pixel, by segment
  };
  std::map<std::size_t, LayerCounts> layerCounts;
  constexpr std::size_t kCountEvery = 3;
  auto timed = [&](app::SceneRenderer& r, const app::Camera& camera, bool overlays, bool measure,
                   app::FrameStats& stats) {
    settings.overlays = overlays;
    settings.measure = measure;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    stats = r.render(cache, target.framebuffer(), o.width, o.height, camera, settings);
    glFinish();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  };
  for (std::size_t k = 0; k < path.size(); ++k) {
    const app::Camera& camera = path[k].camera;
    const std::string& segment = path[k].segment;
    app::FrameStats a, b, c;
    const double tMs = timed(*renderer, camera, false, false, a);
    const double sMs = timed(*renderer, camera, true, false, b);
    const double pMs = timed(*paperRenderer, camera, true, false, c);
    if (k > 0) {  // frame 0 builds the first chunks
      terrainOnly.ms.push_back(tMs);
      stencil.ms.push_back(sMs);
      paperVariant.ms.push_back(pMs);
      terrainOnly.bySegment[segment].push_back(tMs);
      stencil.bySegment[segment].push_back(sMs);
      paperVariant.bySegment[segment].push_back(pMs);
      ratio.push_back(sMs / std::max(tMs, 1e-6));
    }
    std::size_t covered = 0;
    std::uint64_t ourFragments = 0, paperFragments = 0;
    std::size_t zFail = 0;
    for (const auto& l : b.layers) zFail += l.zFailPieces;
    if (k % kCountEvery == 0) {
      // Counted frames (queries wait): fragments of mark + cover against the pixels each layer
      // covers (a pixel covered by two layers counts twice: each layer's floor is 2–3).
      app::FrameStats measured;
      timed(*renderer, camera, true, true, measured);
      const std::vector<std::uint32_t> mask = gfx::readMask(target);
      for (std::size_t i = 0; i < measured.layers.size(); ++i) {
        const auto& l = measured.layers[i];
        std::size_t layerCovered = 0;
        for (std::uint32_t m : mask) layerCovered += (m >> i) & 1u;
        covered += layerCovered;
        ourFragments += l.markFragments + l.coverFragments;
        if (layerCovered > 0) {
          LayerCounts& counts = layerCounts[i];
          counts.mark[segment].push_back(static_cast<double>(l.markFragments) / static_cast<double>(layerCovered));
          counts.cover[segment].push_back(static_cast<double>(l.coverFragments) / static_cast<double>(layerCovered));
        }
      }
      timed(*paperRenderer, camera, true, true, measured);
      for (const auto& l : measured.layers) paperFragments += l.markFragments + l.coverFragments;
      if (covered > 0) {
        const double f = static_cast<double>(ourFragments) / static_cast<double>(covered);
        const double g = static_cast<double>(paperFragments) / static_cast<double>(covered);
        fragmentsPerPixel.push_back(f);
        paperFragmentsPerPixel.push_back(g);
        fppBySegment[segment].push_back(f);
        paperFppBySegment[segment].push_back(g);
      }
    }
    csv << k << ',' << segment << ',' << tMs << ',' << sMs << ',' << pMs << ',' << covered << ',' << ourFragments << ','
        << paperFragments << ',' << zFail << '\n';
  }

  // A one-feature edit: move a vertex of the first line (or polygon) feature by 10 m; the time
  // to rebuild its pieces and draw the next frame.
  json edit = nullptr;
  for (std::size_t i = 0; i < renderer->overlayLayers().size(); ++i) {
    overlay::OverlayLayer& layer = renderer->overlayLayer(i);
    if (layer.features().empty()) continue;
    geo::Feature feature = layer.features().front();
    if (!feature.lines.empty() && !feature.lines.front().empty()) {
      feature.lines.front().front() += glm::dvec2(10.0, 0.0);
    } else if (!feature.polygons.empty() && !feature.polygons.front().outer.empty()) {
      feature.polygons.front().outer.front() += glm::dvec2(10.0, 0.0);
    } else {
      continue;
    }
    const auto start = std::chrono::steady_clock::now();
    const Diagnostics d = layer.replaceFeature(0, feature);
    const double rebuildMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    app::FrameStats after;
    const double frameMs = timed(*renderer, path.back().camera, true, false, after);
    edit = {{"layer", layer.name()}, {"rebuild_ms", rebuildMs}, {"next_frame_ms", frameMs}};
    break;
  }

  auto summary = [&](const MethodFrames& m) {
    json segments;
    for (const auto& [name, v] : m.bySegment) {
      segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}};
    }
    return json{{"median_ms", percentile(m.ms, 50)}, {"p95_ms", percentile(m.ms, 95)}, {"segments", segments}};
  };
  json layers = json::array();
  for (std::size_t i = 0; i < renderer->overlayLayers().size(); ++i) {
    const overlay::OverlayLayer& l = renderer->overlayLayers()[i];
    json perPixel;
    for (const auto& [name, v] : layerCounts[i].mark) {
      perPixel[name] = {{"mark_median", percentile(v, 50)},
                        {"cover_median", percentile(layerCounts[i].cover[name], 50)}};
    }
    layers.push_back({{"name", l.name()},
                      {"fragments_per_covered_pixel", perPixel},
                      {"features", l.stats().features},
                      {"skipped_features", l.stats().skippedFeatures},
                      {"pieces", l.stats().pieces},
                      {"triangles", l.stats().triangles},
                      {"gpu_bytes", l.stats().gpuBytes},
                      {"build_seconds", l.stats().buildSeconds}});
  }
  json fpp = {{"stencil_median", percentile(fragmentsPerPixel, 50)},
              {"paper_median", percentile(paperFragmentsPerPixel, 50)}};
  for (const auto& [name, v] : fppBySegment) {
    fpp["segments"][name] = {{"stencil_median", percentile(v, 50)},
                             {"paper_median", percentile(paperFppBySegment[name], 50)}};
  }
  json result = {{"mode", o.mode},
                 {"scene", o.scene},
                 {"width", o.width},
                 {"height", o.height},
                 {"frames", path.size()},
                 {"terrain_only", summary(terrainOnly)},
                 {"stencil", summary(stencil)},
                 {"paper", summary(paperVariant)},
                 {"stencil_over_terrain_ratio_median", percentile(ratio, 50)},
                 {"fragments_per_covered_pixel", fpp},
                 {"layers", layers},
                 {"edit", edit},
                 {"cpu_peak_bytes", processMemory("VmHWM")},
                 {"renderer", (*context)->info().renderer},
                 {"gl_errors", (*context)->debug().errorCount()}};
  return finish(o, result, **context);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return gis::app::programMain(
      argc, argv, "overlay_bench", kUsage, [&](int n, char** v) { return parseArgs(n, v, options); },
      [&] { return run(options); });
}