// overlay_bench --mode terrain: a scripted fly-through (top-down, oblique, horizon) at a fixed
// resolution, frame by frame with glFinish, reporting frame-time median and p95, triangles and
// chunks per frame, LOD selection time, CPU and GPU memory, and the deterministic fragment counts.
// Writes bench.json and frames.csv.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "gfx/gl.hpp"
#include "gfx/render_target.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::bench {
namespace {

/// What the frames of the path measured.
struct TerrainFrames {
  std::vector<double> frameMs;
  std::map<std::string, std::vector<double>> bySegment;
  std::vector<double> triangles, chunks;
  std::size_t framesWaiting = 0, tileBytesPeak = 0;
};

/// Draws each frame of `path`, one line of frames.csv per frame.
TerrainFrames drawPath(const Options& o, scene::SceneRenderer& renderer, const std::vector<scene::PathFrame>& path) {
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height);
  scene::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,frame_ms,select_ms,chunks,triangles,chunks_built,finest_level,fragments,tiles_missing,tiles_"
         "arrived,tile_bytes\n";
  TerrainFrames f;
  for (std::size_t k = 0; k < path.size(); ++k) {
    // Every 10th frame also counts fragments (the query waits, so it is not timed).
    settings.measure = k % 10 == 0;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    const scene::FrameStats s =
        renderer.render(cache, target.framebuffer(), o.width, o.height, path[k].camera, settings);
    glFinish();
    const double ms = msSince(start);
    if (k > 0 && !settings.measure) {  // frame 0 builds the first chunks: reported apart
      f.frameMs.push_back(ms);
      f.bySegment[path[k].segment].push_back(ms);
    }
    f.triangles.push_back(static_cast<double>(s.terrainDraw.triangles));
    f.chunks.push_back(static_cast<double>(s.terrainDraw.chunks));
    csv << k << ',' << path[k].segment << ',' << ms << ',' << s.selectMilliseconds << ',' << s.terrainDraw.chunks << ','
        << s.terrainDraw.triangles << ',' << s.terrainDraw.chunksBuilt << ',' << s.finestLevel << ','
        << (settings.measure ? std::to_string(s.terrain.counts.fragmentShaderInvocations) : "") << ',' << s.tilesMissing
        << ',' << s.tilesArrived << ',' << s.pager.residentBytes + s.pager.pinnedBytes << '\n';
    f.framesWaiting += s.tilesMissing > 0 ? 1u : 0u;
    f.tileBytesPeak = std::max(f.tileBytesPeak, s.pager.residentBytes + s.pager.pinnedBytes);
  }
  return f;
}

json resultJson(const Options& o, const BenchSetup& setup, const scene::SceneRenderer& renderer, std::size_t frames,
                const TerrainFrames& f) {
  const scene::LoadedScene& scene = setup.scene.projected();
  const terrain::TerrainGrid& grid = scene.quadtree->grid();
  json segments;
  for (const auto& [name, v] : f.bySegment) {
    segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}, {"frames", v.size()}};
  }
  const double median = percentile(f.frameMs, 50);
  return {{"mode", o.mode},
          {"scene", o.scene},
          {"dem_size", {grid.width, grid.height}},
          {"width", o.width},
          {"height", o.height},
          {"lod_tolerance_px", o.lodTolerance},
          {"frames", frames},
          {"load_seconds", setup.loadSeconds},
          {"frame_ms", {{"median", median}, {"p95", percentile(f.frameMs, 95)}}},
          {"fps_median", median > 0 ? 1000.0 / median : 0.0},
          {"segments", segments},
          {"triangles_per_frame", {{"median", percentile(f.triangles, 50)}, {"max", percentile(f.triangles, 100)}}},
          {"chunks_per_frame", {{"median", percentile(f.chunks, 50)}, {"max", percentile(f.chunks, 100)}}},
          {"gpu_bytes", renderer.terrainEngine().gpuBytes()},
          {"paged", scene.paged()},
          {"pyramid_build_seconds", scene.pyramidBuild ? json(scene.pyramidBuild->seconds) : json(nullptr)},
          {"frames_drawing_parents_of_loading_tiles", f.framesWaiting},
          {"tile_cache_peak_bytes", f.tileBytesPeak},
          {"tile_cache_budget_bytes", scene.paged() ? scene.quadtree->pager()->budgetBytes() : std::size_t{0}},
          {"cpu_rss_bytes", processMemory("VmRSS")},
          {"cpu_peak_bytes", processMemory("VmHWM")},
          {"renderer", setup.context->info().renderer},
          {"gl_errors", setup.context->debug().errorCount()}};
}

}  // namespace

int runTerrain(const Options& o) {
  std::optional<BenchSetup> setup = setUp(o, false /* terrain mode */);
  if (!setup) return 1;
  if (!projectedOnly(o, *setup)) return 2;
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(setup->scene.projected());
  app::report(renderer.diagnostics);
  if (!renderer) return 1;
  const std::vector<scene::PathFrame> path = flyThroughOf(o, *setup);
  const TerrainFrames frames = drawPath(o, *renderer, path);
  return finish(o, resultJson(o, *setup, *renderer, path.size(), frames), *setup->context);
}

}  // namespace gis::bench
