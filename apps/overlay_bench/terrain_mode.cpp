// overlay_bench --mode terrain: a flight over the terrain alone (flightPath: a projected scene's
// fly-through — top-down, oblique, horizon — or the globe's path), in either frame, at a fixed
// resolution, frame by frame with glFinish, reporting frame-time median and p95, triangles and
// tiles (chunks) per frame, LOD selection time, CPU and GPU memory, and the deterministic fragment
// counts. Tiles are not waited for: a paged projected terrain draws the parents of tiles still
// loading, as a person's flight does. Writes bench.json and frames.csv.
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
#include "scene/frame_renderer.hpp"

namespace gis::bench {
namespace {

/// What the frames of the path measured.
struct TerrainFrames {
  std::vector<double> frameMs;
  std::map<std::string, std::vector<double>> bySegment;
  std::vector<double> triangles, tiles;
  std::size_t framesWaiting = 0, tileBytesPeak = 0;
};

/// Draws each frame of `path`, one line of frames.csv per frame.
TerrainFrames drawPath(const Options& o, scene::FrameRenderer& renderer, const std::vector<BenchFrame>& path) {
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height);
  scene::FrameOptions options;
  options.overlays = false;
  options.waitForTiles = false;

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,frame_ms,select_ms,chunks,triangles,chunks_built,finest_level,fragments,tiles_missing,tiles_"
         "arrived,tile_bytes\n";
  TerrainFrames f;
  for (std::size_t k = 0; k < path.size(); ++k) {
    // Every 10th frame also counts fragments (the query waits, so it is not timed).
    options.measure = k % 10 == 0;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    const scene::FrameFigures s = renderer.drawFrame(cache, target, path[k].camera, options);
    glFinish();
    const double ms = msSince(start);
    if (k > 0 && !options.measure) {  // frame 0 builds the first tiles: reported apart
      f.frameMs.push_back(ms);
      f.bySegment[path[k].segment].push_back(ms);
    }
    const scene::FrameFigures::Terrain& t = s.terrain;
    f.triangles.push_back(static_cast<double>(t.triangles));
    f.tiles.push_back(static_cast<double>(t.tiles));
    csv << k << ',' << path[k].segment << ',' << ms << ',' << t.selectMs << ',' << t.tiles << ',' << t.triangles << ','
        << t.built << ',' << (t.finestLevel >= 0 ? std::to_string(t.finestLevel) : "") << ','
        << (options.measure ? std::to_string(t.fragments) : "") << ',' << t.tilesMissing << ',' << t.tilesArrived << ','
        << t.tileBytes << '\n';
    f.framesWaiting += t.tilesMissing > 0 ? 1U : 0U;
    f.tileBytesPeak = std::max(f.tileBytesPeak, t.tileBytes);
  }
  return f;
}

json resultJson(const Options& o, const BenchSetup& setup, const scene::FrameRenderer& renderer, std::size_t frames,
                const TerrainFrames& f) {
  json segments;
  for (const auto& [name, v] : f.bySegment) {
    segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}, {"frames", v.size()}};
  }
  const double median = percentile(f.frameMs, 50);
  json out = {{"mode", o.mode},
              {"scene", o.scene},
              {"frame", setup.scene.onGlobe() ? "globe" : "projected"},
              {"width", o.width},
              {"height", o.height},
              {"lod_tolerance_px", o.lodTolerance},
              {"frames", frames},
              {"load_seconds", setup.loadSeconds},
              {"frame_ms", {{"median", median}, {"p95", percentile(f.frameMs, 95)}}},
              {"fps_median", median > 0 ? 1000.0 / median : 0.0},
              {"segments", segments},
              {"triangles_per_frame", {{"median", percentile(f.triangles, 50)}, {"max", percentile(f.triangles, 100)}}},
              {"chunks_per_frame", {{"median", percentile(f.tiles, 50)}, {"max", percentile(f.tiles, 100)}}},
              {"frames_drawing_parents_of_loading_tiles", f.framesWaiting},
              {"tile_cache_peak_bytes", f.tileBytesPeak},
              {"cpu_rss_bytes", processMemory("VmRSS")},
              {"cpu_peak_bytes", processMemory("VmHWM")},
              {"renderer", setup.context->info().renderer},
              {"gl_errors", setup.context->debug().errorCount()}};
  out.update(renderer.terrainJson());  // the frame's own: the DEM's size, GPU bytes, paging
  return out;
}

}  // namespace

int runTerrain(const Options& o) {
  std::optional<BenchSetup> setup = setUp(o, false /* terrain mode */);
  if (!setup) return 1;
  scene::StillSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(setup->scene, settings);
  app::report(renderer.diagnostics);
  if (!renderer) return 1;
  const std::vector<BenchFrame> path = flightPath(o, *setup);
  const TerrainFrames frames = drawPath(o, **renderer, path);
  return finish(o, resultJson(o, *setup, **renderer, path.size(), frames), *setup->context);
}

}  // namespace gis::bench
