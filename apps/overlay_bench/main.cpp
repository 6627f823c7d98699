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
// - mode "methods" (methods_mode.cpp): every method, texture draping at several sizes included,
//   on the same frames, with the error against the CPU reference: error against frame time.
// - mode "lasso": one camera, the terrain drawn once, then the GPU time of lasso selection for
//   1–500 random volumes (mixed operators, and Or only), interleaved with the time of one
//   full-screen pass, so every figure is a ratio to that pass; a least-squares line through
//   time against volumes gives the time per volume. Writes lasso.json and lasso.csv.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/camera_path.hpp"
#include "app/cli.hpp"
#include "app/json_file.hpp"
#include "app/scene.hpp"
#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "bench_common.hpp"
#include "gfx/context.hpp"
#include "gfx/pipeline_state.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/render_target.hpp"
#include "terrain/tile_pager.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace {

using nlohmann::json;
using namespace gis;
using namespace gis::bench;

constexpr const char* kUsage =
    "usage: overlay_bench --scene S.json [--mode terrain|overlay|methods|ablation|scaling|lasso] [--width W --height "
    "H] "
    "[--frames N]\n"
    "                     [--lod-tolerance PX] [--paging auto|always|never] [--max-volumes N]\n"
    "                     [--repeats R] [--drape-sizes 512,1024,...] [--tile-sizes 256,512]\n"
    "                     [--error-every N] [--msaa 0|2|4|8]\n"
    "                     [--segments top-down,oblique,horizon,close-up] --out DIR\n"
    "--mode methods: terrain only, our stencil polyhedra, the paper's construction and texture draping\n"
    "  at each --drape-sizes and per tile at each --tile-sizes (\"none\": no such method) on the same frames: frame "
    "time, memory, build time and wrong pixels against\n"
    "  the CPU reference (every --error-every frames), GPU time and fragments per pass, per path segment\n"
    "  (--segments: which; close-up puts the eye 1.5 m over roads and areas); writes methods.json,\n"
    "  methods.csv, methods.md and plots; --msaa: multisampled targets, the error judged on sample 0\n"
    "--mode ablation: ours with each saving switched off alone (z-fail everywhere, bottom caps in z-pass,\n"
    "  no frustum culling, cover with the pieces, one cover rectangle, no split at cells), the same\n"
    "  figures; ablation.json\n"
    "--mode scaling --scenes A.json,B.json,...: terrain only, ours and the paper's on each scene (the\n"
    "  oblique segment unless --segments): scaling.md, frame time against vector vertices and DEM posts\n";

int runOverlay(const Options& o);
int runLasso(const Options& o);

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
    else if (a == "--max-volumes" && (n = app::parseInt(v)) && *n >= 2 && *n <= 500)
      o.maxVolumes = *n;
    else if (a == "--repeats" && (n = app::parseInt(v)) && *n >= 1 && *n <= 100)
      o.repeats = *n;
    else if (a == "--lod-tolerance" && app::parseDouble(v) && *app::parseDouble(v) >= 0.0)
      o.lodTolerance = *app::parseDouble(v);
    else if (a == "--drape-sizes" || a == "--tile-sizes") {
      std::vector<int>& sizes = o.textureSizes[a == "--drape-sizes" ? "drape" : "drape-tiles"];
      sizes.clear();
      const std::string list = v == "none" ? std::string() : std::string(v);
      for (std::size_t start = 0; start < list.size();) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        const std::optional<int> size = app::parseInt(list.substr(start, comma - start));
        if (!size || *size < 16 || *size > 16384)
          return std::string(a) + ": a comma-separated list of sizes 16 to 16384 (or \"none\")";
        sizes.push_back(*size);
        start = comma + 1;
      }
    } else if (a == "--error-every" && (n = app::parseInt(v)) && *n >= 1)
      o.errorEvery = *n;
    else if (a == "--msaa" && (n = app::parseInt(v)) && (*n == 0 || *n == 1 || *n == 2 || *n == 4 || *n == 8))
      o.msaa = *n;
    else if (a == "--scenes") {
      o.scenes.clear();
      std::string list(v);
      for (std::size_t start = 0; start <= list.size();) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        if (comma > start) o.scenes.push_back(list.substr(start, comma - start));
        start = comma + 1;
      }
    } else if (a == "--segments") {
      o.segments.clear();
      std::string list(v);
      for (std::size_t start = 0; start <= list.size();) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        const std::string name = list.substr(start, comma - start);
        if (name != "top-down" && name != "oblique" && name != "horizon" && name != "close-up")
          return "--segments: a comma-separated list of top-down, oblique, horizon, close-up";
        o.segments.push_back(name);
        start = comma + 1;
      }
    } else if (a == "--paging" && v == "auto")
      o.paging = app::TerrainPaging::Auto;
    else if (a == "--paging" && v == "always")
      o.paging = app::TerrainPaging::Always;
    else if (a == "--paging" && v == "never")
      o.paging = app::TerrainPaging::Never;
    else
      return "bad argument " + std::string(a) + " " + std::string(v);
  }
  if (o.mode == "scaling" && o.scene.empty() && !o.scenes.empty()) o.scene = o.scenes.front();
  if (o.mode == "scaling" && o.scenes.empty()) return "--mode scaling needs --scenes A.json,B.json,...";
  if (o.scene.empty() || o.out.empty()) return "--scene and --out are required";
  if (o.mode != "terrain" && o.mode != "overlay" && o.mode != "lasso" && o.mode != "methods" && o.mode != "ablation" &&
      o.mode != "scaling")
    return "--mode: \"terrain\", \"overlay\", \"methods\", \"ablation\", \"scaling\" or \"lasso\"";
  return {};
}

int run(const Options& o) {
  if (o.mode == "overlay") return runOverlay(o);
  if (o.mode == "lasso") return runLasso(o);
  if (o.mode == "methods") return runMethods(o);
  if (o.mode == "ablation") return runAblation(o);
  if (o.mode == "scaling") return runScaling(o);
  std::optional<BenchSetup> setup = setUp(o, false /* terrain mode */);
  if (!setup) return 1;
  app::SceneDescription* description = &setup->description;
  app::LoadedScene* scene = &setup->scene;
  std::unique_ptr<gfx::Context>* context = &setup->context;
  const double loadSeconds = setup->loadSeconds;
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
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  app::LoadedScene* scene = &setup->scene;
  std::unique_ptr<gfx::Context>* context = &setup->context;
  // Two renderers: ours and the paper's construction (the terrain is the same).
  app::OverlayBuildSettings ours, paper;
  paper.technique = overlay::findTechnique("paper");
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene, ours);
  app::report(renderer.diagnostics);
  Result<app::SceneRenderer> paperRenderer = app::SceneRenderer::create(*scene, paper);
  if (!renderer || !paperRenderer) return 1;

  const std::vector<app::PathFrame> path = flyThroughOf(o, *setup);
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, 0, true);
  app::RenderSettings settings = comparisonSettings(o, *setup);  // the same terrain for the three methods

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

// ---- mode "lasso" ----

constexpr std::array<std::size_t, 9> kVolumeCounts{1, 2, 5, 10, 20, 50, 100, 200, 500};
constexpr std::uint32_t kLassoSeed = 2016;  // Rainer 2016, the seed report

/// A random star-shaped (concave) lasso in pixels (y down), on screen: 20–40 vertices
/// alternating between an outer and an inner radius, covering 2–5 % of the screen.
std::vector<glm::dvec2> starLasso(std::mt19937& rng, int width, int height) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::size_t vertices = 2 * (10 + static_cast<std::size_t>(unit(rng) * 10.999));
  const double w = width, h = height;
  const double fraction = 0.02 + 0.03 * unit(rng), inner = 0.4 + 0.3 * unit(rng);
  // Area of a star with radii R and inner·R: ≈ π·R²·inner.
  const double outer = std::min(std::sqrt(fraction * w * h / (std::numbers::pi * inner)), 0.45 * std::min(w, h));
  const glm::dvec2 centre(outer + (w - 2.0 * outer) * unit(rng), outer + (h - 2.0 * outer) * unit(rng));
  const double phase = 2.0 * std::numbers::pi * unit(rng);
  std::vector<glm::dvec2> points;
  for (std::size_t k = 0; k < vertices; ++k) {
    const double a = phase + 2.0 * std::numbers::pi * (static_cast<double>(k) + 0.3 * (unit(rng) - 0.5)) /
                                 static_cast<double>(vertices);
    const double r = outer * (k % 2 == 0 ? 1.0 : inner) * (0.85 + 0.3 * unit(rng));
    points.push_back(centre + r * glm::dvec2(std::cos(a), std::sin(a)));
  }
  return points;
}

/// Shoelace area of a simple polygon.
double polygonArea(const std::vector<glm::dvec2>& p) {
  double twice = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const glm::dvec2& a = p[i];
    const glm::dvec2& b = p[(i + 1) % p.size()];
    twice += a.x * b.y - a.y * b.x;
  }
  return 0.5 * std::abs(twice);
}

struct LinearFit {
  double intercept = 0.0, slope = 0.0, r2 = 0.0;
};

/// Least squares y = intercept + slope·x, with the coefficient of determination.
LinearFit fitLine(const std::vector<double>& x, const std::vector<double>& y) {
  const auto n = static_cast<double>(x.size());
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    mx += x[i] / n;
    my += y[i] / n;
  }
  double sxx = 0.0, sxy = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
    syy += (y[i] - my) * (y[i] - my);
  }
  LinearFit f;
  f.slope = sxx > 0.0 ? sxy / sxx : 0.0;
  f.intercept = my - f.slope * mx;
  double residual = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double e = y[i] - (f.intercept + f.slope * x[i]);
    residual += e * e;
  }
  f.r2 = syy > 0.0 ? 1.0 - residual / syy : 1.0;
  return f;
}

/// The clocks of a lasso measurement. On a GPU the timer query is the figure. On llvmpipe the
/// "GPU" is this machine's CPU, and its timer query does not cover the rasterization (a
/// 1200 × 1000 full-screen pass reads 0.01–0.5 ms against 4 ms of CPU time). The process CPU
/// time is the work done there: this thread's vertex work and binning plus the rasterizer
/// threads, which block rather than spin, so other processes on a shared machine do not count.
enum Clock : std::size_t { kGpu, kCpu, kWall, kClocks };
constexpr std::array<const char*, kClocks> kClockNames{"gpu", "cpu", "wall"};
using Samples = std::array<std::vector<double>, kClocks>;

double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

struct Sample {
  std::array<double, kClocks> ms{};
  std::uint64_t fragments = 0;
};

/// Times `work` (which returns its GPU milliseconds and fragments) with the GPU idle before and
/// after (glFinish): wall and process CPU time around it.
template <class Work>
Sample timed(Work&& work) {
  glFinish();
  const auto wallStart = std::chrono::steady_clock::now();
  const double cpuStart = processCpuMs();
  Sample s;
  std::tie(s.ms[kGpu], s.fragments) = work();
  glFinish();
  s.ms[kCpu] = processCpuMs() - cpuStart;
  s.ms[kWall] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wallStart).count();
  return s;
}

/// `draw` inside a timer query and a pipeline-statistics query: GPU milliseconds, fragments.
template <class Draw>
std::pair<double, std::uint64_t> queried(gfx::GpuTimer& timer, gfx::PipelineStatistics& statistics, Draw&& draw) {
  timer.begin();
  statistics.begin();
  draw();
  statistics.end();
  timer.end();
  return {static_cast<double>(timer.nanoseconds().value_or(0)) * 1e-6, statistics.result().fragmentShaderInvocations};
}

void add(Samples& samples, const Sample& s) {
  for (std::size_t c = 0; c < kClocks; ++c) samples[c].push_back(s.ms[c]);
}

/// The unit of the lasso figures: one full-screen quad with the stencil test on (the stencil is
/// 0 between selections, so every pixel passes) blending a translucent colour — the cost of one
/// highlight or cover pass over the whole screen.
constexpr gfx::PipelineState kFullScreenPass{
    gfx::DepthState{false, false, gfx::CompareFunc::Always, false},
    gfx::StencilState{true,
                      gfx::StencilFace{gfx::CompareFunc::Equal, 0, 0xFF, 0xFF, gfx::StencilOp::Keep,
                                       gfx::StencilOp::Keep, gfx::StencilOp::Keep},
                      gfx::StencilFace{gfx::CompareFunc::Equal, 0, 0xFF, 0xFF, gfx::StencilOp::Keep,
                                       gfx::StencilOp::Keep, gfx::StencilOp::Keep}},
    gfx::kBlendPremultipliedOver,
    gfx::RasterState{gfx::CullMode::None, true, gfx::ColorMask{}, gfx::PolygonMode::Fill, 0.0F, 0.0F, false}};

struct LassoSeries {
  std::string name;
  std::vector<overlay::SelectionOp> ops;  ///< per volume; the first is Single
  struct Row {
    std::size_t volumes = 0;
    Samples ms;      ///< select(), per repeat
    Samples passMs;  ///< the full-screen passes interleaved with them
    std::uint64_t fragments = 0;
    overlay::SelectionFrameStats stats;
    std::optional<overlay::SelectionRenderer> selection;  ///< its volumes built once
  };
  std::vector<Row> rows;
};

int runLasso(const Options& o) {
  // The volumes select terrain; the layers are not drawn.
  std::optional<BenchSetup> setup = setUp(o, false);
  if (!setup) return 1;
  app::SceneDescription* description = &setup->description;
  app::LoadedScene* scene = &setup->scene;
  std::unique_ptr<gfx::Context>* context = &setup->context;
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene);
  app::report(renderer.diagnostics);
  Result<gfx::Program> passProgram = gfx::Program::build({{"overlay_cover.vert", {}}, {"overlay_volume.frag", {}}});
  app::report(passProgram.diagnostics);
  if (!renderer || !passProgram) return 1;
  const std::string rendererName = (*context)->info().renderer;
  const Clock headline = rendererName.find("llvmpipe") != std::string::npos ? kCpu : kGpu;

  // One camera, the fly-through's first oblique frame (from the south, 40° down: terrain fills
  // the view), and the terrain drawn once: the selection reads its depth.
  glm::dvec3 lo, hi;
  app::terrainBox(*scene, description->verticalExaggeration, lo, hi);
  const std::vector<app::PathFrame> path = app::flyThrough(lo, hi, 3);
  const app::Camera camera =
      std::find_if(path.begin(), path.end(), [](const app::PathFrame& f) { return f.segment == "oblique"; })->camera;
  const double aspect = static_cast<double>(o.width) / static_cast<double>(o.height);
  const glm::dmat4 viewProj = camera.projection(aspect) * camera.view();
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height);
  app::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.verticalExaggeration = description->verticalExaggeration;
  settings.waitForTiles = true;
  settings.overlays = false;
  const app::FrameStats terrainFrame =
      renderer->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
  const overlay::OverlayView view = app::overlayViewOf(camera, aspect);
  std::size_t terrainPixels = 0;
  for (float d : gfx::readDepth(target)) terrainPixels += d > 0.0F ? 1u : 0u;

  // The lassos, drawn with the same camera: the first N of one list for every N.
  std::vector<std::size_t> counts;
  for (std::size_t n : kVolumeCounts)
    if (n <= static_cast<std::size_t>(o.maxVolumes)) counts.push_back(n);
  const std::size_t maxVolumes = counts.back();
  const double screenPixels = static_cast<double>(o.width) * o.height;
  std::mt19937 rng(kLassoSeed);
  std::vector<std::vector<glm::dvec2>> polygons;
  double areaFraction = 0.0;
  std::size_t lassoVertices = 0;
  for (std::size_t i = 0; i < maxVolumes; ++i) {
    polygons.push_back(starLasso(rng, o.width, o.height));
    areaFraction += polygonArea(polygons.back()) / (screenPixels * static_cast<double>(maxVolumes));
    lassoVertices += polygons.back().size();
  }
  std::vector<LassoSeries> series(2);  // the same lassos, two operator chains
  series[0].name = "mixed";
  series[1].name = "or";
  constexpr std::array<overlay::SelectionOp, 4> kMix{overlay::SelectionOp::Or, overlay::SelectionOp::Xor,
                                                     overlay::SelectionOp::Subtract, overlay::SelectionOp::And};
  std::uniform_int_distribution<std::size_t> pick(0, kMix.size() - 1);
  for (std::size_t i = 0; i < maxVolumes; ++i) {
    series[0].ops.push_back(i == 0 ? overlay::SelectionOp::Single : kMix[pick(rng)]);
    series[1].ops.push_back(i == 0 ? overlay::SelectionOp::Single : overlay::SelectionOp::Or);
  }
  const auto stepsFor = [&](const LassoSeries& s, std::size_t n) {
    std::vector<overlay::SelectionStep> steps(n);
    for (std::size_t i = 0; i < n; ++i) {
      steps[i].op = s.ops[i];
      steps[i].lasso = {polygons[i], viewProj, o.width, o.height, std::numeric_limits<double>::infinity(), {}, {}};
    }
    return steps;
  };

  gfx::GpuTimer timer;
  gfx::PipelineStatistics statistics;
  const gfx::VertexArrayHandle emptyVao = gfx::createVertexArray();
  const auto fullScreenPass = [&] {
    return timed([&] {
      return queried(timer, statistics, [&] {
        cache.apply(kFullScreenPass);
        cache.useProgram(*passProgram);
        passProgram->set("u_rect", glm::vec4(-1.0F, -1.0F, 1.0F, 1.0F));
        passProgram->set("u_color", glm::vec4(0.2F, 0.6F, 1.0F, 0.05F));
        passProgram->set("u_maskBit", 0.0F);
        cache.bindVertexArray(emptyVao.id());
        glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
      });
    });
  };
  overlay::SelectionSettings measured;
  measured.measure = true;
  const auto select = [&](LassoSeries::Row& row) {
    return timed([&] {
      row.stats = row.selection->select(cache, view, measured);
      return std::pair{row.stats.gpuMilliseconds, row.stats.fragments};
    });
  };
  const auto clear = [&](LassoSeries::Row& row) {
    return timed([&] { return queried(timer, statistics, [&] { row.selection->clear(cache); }); });
  };
  Samples passMs, clearMs;
  std::uint64_t passFragments = 0;
  // One selection renderer per series and N; the repeats go round all of them, so that a burst
  // of load on a shared machine spreads over every N instead of bending one point.
  for (std::size_t n : counts) {
    for (LassoSeries& s : series) {
      Result<overlay::SelectionRenderer> selection = overlay::SelectionRenderer::create();
      app::report(selection.diagnostics);
      if (!selection) return 1;
      LassoSeries::Row row;
      row.volumes = n;
      row.selection.emplace(std::move(*selection));
      app::report(row.selection->setSteps(stepsFor(s, n)));
      // Warm-up, with the queries on as measured (llvmpipe compiles shader variants for them).
      select(row);
      clear(row);
      s.rows.push_back(std::move(row));
    }
  }
  fullScreenPass();
  for (int r = 0; r < o.repeats; ++r) {
    for (std::size_t i = 0; i < counts.size(); ++i) {
      for (LassoSeries& s : series) {
        LassoSeries::Row& row = s.rows[i];
        const Sample sample = select(row);
        add(row.ms, sample);
        row.fragments = sample.fragments;
        add(clearMs, clear(row));
        const Sample pass = fullScreenPass();  // interleaved: the same machine state
        add(row.passMs, pass);
        add(passMs, pass);
        passFragments = pass.fragments;
      }
    }
  }

  // Medians over the repeats, as ratios to the median full-screen pass of the whole run.
  std::array<double, kClocks> pass{};
  for (std::size_t c = 0; c < kClocks; ++c) pass[c] = percentile(passMs[c], 50);
  const auto passFragmentsD = static_cast<double>(std::max<std::uint64_t>(passFragments, 1));
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "lasso.csv");
  csv << "series,volumes,gpu_ms,cpu_ms,wall_ms,gpu_passes,cpu_passes,wall_passes,ratio_to_one_volume,"
         "ms_per_volume,fragments,fragment_passes,mark_draws,screen_passes,triangles\n";
  std::printf("lasso selection, %dx%d, %s; times are %s ms (process CPU time on llvmpipe, else GPU timer)\n", o.width,
              o.height, rendererName.c_str(), kClockNames[headline]);
  std::printf("one full-screen pass: %.3f ms %s (gpu %.3f, cpu %.3f, wall %.3f ms), %llu fragments\n", pass[headline],
              kClockNames[headline], pass[kGpu], pass[kCpu], pass[kWall],
              static_cast<unsigned long long>(passFragments));
  json seriesJson = json::array();
  for (const LassoSeries& s : series) {
    std::vector<double> x, fragments;
    std::array<std::vector<double>, kClocks> y;
    for (const LassoSeries::Row& row : s.rows) {
      x.push_back(static_cast<double>(row.volumes));
      for (std::size_t c = 0; c < kClocks; ++c) y[c].push_back(percentile(row.ms[c], 50));
      fragments.push_back(static_cast<double>(row.fragments));
    }
    const std::vector<double>& t = y[headline];
    std::map<std::string, std::size_t> opCounts;
    for (std::size_t i = 0; i < maxVolumes; ++i) ++opCounts[overlay::selectionOpName(s.ops[i])];
    std::printf("\nseries %s (%s)\n%7s %9s %12s %8s %10s %9s %9s %12s %10s %7s\n", s.name.c_str(),
                s.name == "or" ? "Single, then Or" : "Single, then Or/Xor/Subtract/And at random", "volumes", "ms",
                "/ full pass", "/ N=1", "ms/volume", "gpu ms", "wall ms", "fragments", "/ full pass", "passes");
    json rows = json::array();
    for (std::size_t i = 0; i < s.rows.size(); ++i) {
      const LassoSeries::Row& row = s.rows[i];
      const double toOne = t[i] / t[0], perVolume = t[i] / x[i];
      const double fragmentPasses = fragments[i] / passFragmentsD;
      std::printf("%7zu %9.3f %12.3f %8.2f %10.4f %9.3f %9.3f %12llu %10.3f %7zu\n", row.volumes, t[i],
                  t[i] / pass[headline], toOne, perVolume, y[kGpu][i], y[kWall][i],
                  static_cast<unsigned long long>(row.fragments), fragmentPasses, row.stats.screenPasses);
      csv << s.name << ',' << row.volumes;
      for (std::size_t c = 0; c < kClocks; ++c) csv << ',' << y[c][i];
      for (std::size_t c = 0; c < kClocks; ++c) csv << ',' << y[c][i] / pass[c];
      csv << ',' << toOne << ',' << perVolume << ',' << row.fragments << ',' << fragmentPasses << ','
          << row.stats.markDraws << ',' << row.stats.screenPasses << ',' << row.stats.triangles << '\n';
      json clocks;
      for (std::size_t c = 0; c < kClocks; ++c) {
        clocks[kClockNames[c]] = {{"median_ms", y[c][i]},
                                  {"full_screen_passes", y[c][i] / pass[c]},
                                  {"repeats_ms", row.ms[c]},
                                  {"interleaved_full_screen_pass_median_ms", percentile(row.passMs[c], 50)}};
      }
      rows.push_back({{"volumes", row.volumes},
                      {"ms", clocks},
                      {"ratio_to_one_volume", toOne},
                      {"ms_per_volume", perVolume},
                      {"fragments", row.fragments},
                      {"fragment_full_screen_passes", fragmentPasses},
                      {"mark_draws", row.stats.markDraws},
                      {"screen_passes", row.stats.screenPasses},
                      {"triangles", row.stats.triangles}});
    }
    json fits;
    for (const std::size_t c :
         {static_cast<std::size_t>(headline), std::size_t{kGpu}, std::size_t{kCpu}, std::size_t{kWall}}) {
      if (fits.contains(kClockNames[c])) continue;
      const LinearFit f = fitLine(x, y[c]);
      fits[kClockNames[c]] = {{"slope_ms_per_volume", f.slope},
                              {"slope_full_screen_passes_per_volume", f.slope / pass[c]},
                              {"intercept_ms", f.intercept},
                              {"intercept_full_screen_passes", f.intercept / pass[c]},
                              {"r2", f.r2}};
      std::printf("fit %-4s ms = a + b*N: b = %.4f ms = %.4f full-screen passes per volume, a = %.3f ms, R2 = %.4f%s\n",
                  kClockNames[c], f.slope, f.slope / pass[c], f.intercept, f.r2, c == headline ? "  <-" : "");
    }
    const LinearFit fragmentFit = fitLine(x, fragments);
    std::printf("fit fragments = a + b*N: b = %.0f = %.4f full-screen passes per volume, a = %.0f, R2 = %.5f\n",
                fragmentFit.slope, fragmentFit.slope / passFragmentsD, fragmentFit.intercept, fragmentFit.r2);
    seriesJson.push_back({{"name", s.name},
                          {"operators", opCounts},
                          {"rows", rows},
                          {"fits", fits},
                          {"fit_fragments",
                           {{"slope_per_volume", fragmentFit.slope},
                            {"slope_full_screen_passes_per_volume", fragmentFit.slope / passFragmentsD},
                            {"intercept", fragmentFit.intercept},
                            {"r2", fragmentFit.r2}}}});
  }
  json passJson, clearJson;
  for (std::size_t c = 0; c < kClocks; ++c) {
    passJson[kClockNames[c]] = {{"median_ms", pass[c]}, {"p95_ms", percentile(passMs[c], 95)}};
    clearJson[kClockNames[c]] = {{"median_ms", percentile(clearMs[c], 50)}};
  }
  passJson["fragments"] = passFragments;
  passJson["samples"] = passMs[kGpu].size();
  const char* threads = std::getenv("LP_NUM_THREADS");
  const json result = {{"mode", o.mode},
                       {"scene", o.scene},
                       {"width", o.width},
                       {"height", o.height},
                       {"camera",
                        {{"kind", "first oblique frame of the fly-through"},
                         {"eye_xyz", {camera.eye.x, camera.eye.y, camera.eye.z}},
                         {"target_xyz", {camera.target.x, camera.target.y, camera.target.z}},
                         {"fov_y_deg", camera.fovYDeg}}},
                       {"terrain_pixels_fraction", static_cast<double>(terrainPixels) / screenPixels},
                       {"terrain_triangles", terrainFrame.terrainDraw.triangles},
                       {"scheme", "runs"},
                       {"seed", kLassoSeed},
                       {"repeats", o.repeats},
                       {"headline_clock", kClockNames[headline]},
                       {"lassos",
                        {{"count", maxVolumes},
                         {"mean_vertices", static_cast<double>(lassoVertices) / static_cast<double>(maxVolumes)},
                         {"mean_screen_fraction", areaFraction}}},
                       {"full_screen_pass", passJson},
                       {"stencil_clear_pass", clearJson},
                       {"series", seriesJson},
                       {"renderer", rendererName},
                       {"lp_num_threads", threads != nullptr ? json(threads) : json(nullptr)},
                       {"cpu_peak_bytes", processMemory("VmHWM")},
                       {"gl_errors", (*context)->debug().errorCount()}};
  std::ofstream(std::filesystem::path(o.out) / "lasso.json") << app::jsonText(result) << '\n';
  std::printf("\ngl_errors: %zu; wrote %s\n", (*context)->debug().errorCount(),
              (std::filesystem::path(o.out) / "lasso.json").string().c_str());
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return gis::app::programMain(
      argc, argv, "overlay_bench", kUsage, [&](int n, char** v) { return parseArgs(n, v, options); },
      [&] { return run(options); });
}