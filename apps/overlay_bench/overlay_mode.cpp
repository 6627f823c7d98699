// overlay_bench --mode overlay: the flight (flightPath: the fly-through, or the globe's path), in
// either frame, each frame drawn three ways in turn — terrain only, our stencil polyhedra, the
// seed paper's construction — so that the ratios come from one run; plus, on every 3rd frame, GPU time and fragment
// counts per layer against the pixels each layer covers (fragments per covered pixel), and the latency of a one-feature
// edit. Writes bench.json and frames.csv.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "gfx/gl.hpp"
#include "gfx/render_target.hpp"
#include "scene/frame_renderer.hpp"

namespace gis::bench {
namespace {

constexpr std::size_t kCountEvery = 3;

struct MethodFrames {
  std::vector<double> ms;
  std::map<std::string, std::vector<double>> bySegment;

  void add(const std::string& segment, double frameMs) {
    ms.push_back(frameMs);
    bySegment[segment].push_back(frameMs);
  }
};

struct LayerCounts {
  std::map<std::string, std::vector<double>> mark,
      cover;  ///< per covered pixel, by segment
};

/// What the path measured.
struct OverlayFrames {
  MethodFrames terrainOnly, stencil, paper;
  std::vector<double> fragmentsPerPixel, paperFragmentsPerPixel, ratio;
  std::map<std::string, std::vector<double>> fppBySegment, paperFppBySegment;
  std::map<std::size_t, LayerCounts> layerCounts;
};

/// One counted frame's fragments of mark + cover, ours and the paper's, over the pixels the layers
/// cover.
struct FrameCounts {
  std::size_t covered = 0;
  std::uint64_t ours = 0, paper = 0;
};

/// Ours and the paper's construction (the terrain is the same), drawing into one target.
struct OverlayBench {
  const Options& o;
  scene::FrameRenderer& ours;
  scene::FrameRenderer& paper;
  gfx::StateCache cache;
  gfx::RenderTarget target;

  OverlayBench(const Options& options, scene::FrameRenderer& oursRenderer, scene::FrameRenderer& paperRenderer)
      : o(options), ours(oursRenderer), paper(paperRenderer), target(options.width, options.height, 0, true) {}

  /// Milliseconds to draw the frame with `r`, glFinish to glFinish (every tile waited for: the
  /// same terrain for the three methods).
  double timed(scene::FrameRenderer& r, const scene::FrameCamera& camera, bool overlays, bool measure,
               scene::FrameFigures& stats) {
    scene::FrameOptions options;
    options.overlays = overlays;
    options.measure = measure;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    stats = r.drawFrame(cache, target, camera, options);
    glFinish();
    return msSince(start);
  }

  FrameCounts count(const BenchFrame& frame, OverlayFrames& f);
  void drawPath(const std::vector<BenchFrame>& path, OverlayFrames& f);
  json edit(const scene::FrameCamera& camera);
};

/// A counted frame (the queries wait): fragments of mark + cover against the pixels each layer
/// covers (a pixel covered by two layers counts twice: each layer's floor is 2–3).
FrameCounts OverlayBench::count(const BenchFrame& frame, OverlayFrames& f) {
  FrameCounts c;
  scene::FrameFigures measured;
  timed(ours, frame.camera, true, true, measured);
  const std::vector<std::uint32_t> mask = gfx::readMask(target);
  for (std::size_t i = 0; i < ours.drawnLayerCount() && i < 32; ++i) {
    std::size_t layerCovered = 0;
    for (std::uint32_t m : mask) layerCovered += (m >> i) & 1u;
    c.covered += layerCovered;
    if (i >= measured.layers.size() || layerCovered == 0) continue;  // the globe counts its passes together
    const scene::FrameFigures::LayerPasses& l = measured.layers[i];
    LayerCounts& counts = f.layerCounts[i];
    counts.mark[frame.segment].push_back(static_cast<double>(l.markFragments) / static_cast<double>(layerCovered));
    counts.cover[frame.segment].push_back(static_cast<double>(l.coverFragments) / static_cast<double>(layerCovered));
  }
  c.ours = measured.markFragments + measured.coverFragments;
  timed(paper, frame.camera, true, true, measured);
  c.paper = measured.markFragments + measured.coverFragments;
  if (c.covered > 0) {
    const double ourPerPixel = static_cast<double>(c.ours) / static_cast<double>(c.covered);
    const double paperPerPixel = static_cast<double>(c.paper) / static_cast<double>(c.covered);
    f.fragmentsPerPixel.push_back(ourPerPixel);
    f.paperFragmentsPerPixel.push_back(paperPerPixel);
    f.fppBySegment[frame.segment].push_back(ourPerPixel);
    f.paperFppBySegment[frame.segment].push_back(paperPerPixel);
  }
  return c;
}

/// Each frame of the path three ways, one line of frames.csv per frame.
void OverlayBench::drawPath(const std::vector<BenchFrame>& path, OverlayFrames& f) {
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,terrain_ms,stencil_ms,paper_ms,covered_pixels,stencil_fragments,paper_fragments,stencil_zfail_"
         "pieces\n";
  for (std::size_t k = 0; k < path.size(); ++k) {
    const scene::FrameCamera& camera = path[k].camera;
    const std::string& segment = path[k].segment;
    scene::FrameFigures a, b, c;
    const double tMs = timed(ours, camera, false, false, a);
    const double sMs = timed(ours, camera, true, false, b);
    const double pMs = timed(paper, camera, true, false, c);
    if (k > 0) {  // frame 0 builds the first chunks
      f.terrainOnly.add(segment, tMs);
      f.stencil.add(segment, sMs);
      f.paper.add(segment, pMs);
      f.ratio.push_back(sMs / std::max(tMs, 1e-6));
    }
    const FrameCounts counts = k % kCountEvery == 0 ? count(path[k], f) : FrameCounts{};
    csv << k << ',' << segment << ',' << tMs << ',' << sMs << ',' << pMs << ',' << counts.covered << ',' << counts.ours
        << ',' << counts.paper << ',' << b.zFailPieces << '\n';
  }
}

/// A one-feature edit: a vertex of the first feature moved by 10 m; the time to rebuild its
/// pieces and draw the next frame.
json OverlayBench::edit(const scene::FrameCamera& camera) {
  const std::optional<double> rebuildMs = ours.editFirstFeature();
  if (!rebuildMs) return nullptr;
  scene::FrameFigures after;
  const double frameMs = timed(ours, camera, true, false, after);
  return {{"layer", ours.drawnLayerCount() > 0 ? ours.drawnLayerName(0) : std::string()},
          {"rebuild_ms", *rebuildMs},
          {"next_frame_ms", frameMs}};
}

json summaryJson(const MethodFrames& m) {
  json segments;
  for (const auto& [name, v] : m.bySegment) {
    segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}};
  }
  return json{{"median_ms", percentile(m.ms, 50)}, {"p95_ms", percentile(m.ms, 95)}, {"segments", segments}};
}

json layersJson(const scene::FrameRenderer& renderer, OverlayFrames& f) {
  json layers = json::array();
  for (std::size_t i = 0; i < renderer.drawnLayerCount(); ++i) {
    const scene::DrawnLayerBuilt l = renderer.drawnLayerBuilt(i);
    json perPixel;
    for (const auto& [name, v] : f.layerCounts[i].mark) {
      perPixel[name] = {{"mark_median", percentile(v, 50)},
                        {"cover_median", percentile(f.layerCounts[i].cover[name], 50)}};
    }
    layers.push_back({{"name", l.name},
                      {"fragments_per_covered_pixel", perPixel},
                      {"features", l.features},
                      {"skipped_features", l.skippedFeatures},
                      {"pieces", l.pieces},
                      {"triangles", l.triangles},
                      {"gpu_bytes", l.gpuBytes},
                      {"build_seconds", l.buildSeconds}});
  }
  return layers;
}

json fragmentsPerPixelJson(OverlayFrames& f) {
  json fpp = {{"stencil_median", percentile(f.fragmentsPerPixel, 50)},
              {"paper_median", percentile(f.paperFragmentsPerPixel, 50)}};
  for (const auto& [name, v] : f.fppBySegment) {
    fpp["segments"][name] = {{"stencil_median", percentile(v, 50)},
                             {"paper_median", percentile(f.paperFppBySegment[name], 50)}};
  }
  return fpp;
}

}  // namespace

int runOverlay(const Options& o) {
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  // Two renderers: ours and the paper's construction (the terrain is the same).
  scene::StillSettings ours, paper;
  ours.lodTolerancePixels = paper.lodTolerancePixels = o.lodTolerance;
  paper.technique = overlay::findTechnique("paper");
  Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(setup->scene, ours);
  app::report(renderer.diagnostics);
  Result<std::unique_ptr<scene::FrameRenderer>> paperRenderer = scene::FrameRenderer::create(setup->scene, paper);
  app::report(paperRenderer.diagnostics);
  if (!renderer || !paperRenderer) return 1;

  const std::vector<BenchFrame> path = flightPath(o, *setup);
  OverlayBench bench(o, **renderer, **paperRenderer);
  OverlayFrames f;
  bench.drawPath(path, f);
  const json edit = bench.edit(path.back().camera);

  gfx::Context& context = *setup->context;
  json result = {{"mode", o.mode},
                 {"scene", o.scene},
                 {"width", o.width},
                 {"height", o.height},
                 {"frames", path.size()},
                 {"terrain_only", summaryJson(f.terrainOnly)},
                 {"stencil", summaryJson(f.stencil)},
                 {"paper", summaryJson(f.paper)},
                 {"stencil_over_terrain_ratio_median", percentile(f.ratio, 50)},
                 {"fragments_per_covered_pixel", fragmentsPerPixelJson(f)},
                 {"frame", setup->scene.onGlobe() ? "globe" : "projected"},
                 {"layers", layersJson(**renderer, f)},
                 {"edit", edit},
                 {"cpu_peak_bytes", processMemory("VmHWM")},
                 {"renderer", context.info().renderer},
                 {"gl_errors", context.debug().errorCount()}};
  return finish(o, result, *setup->context);
}

}  // namespace gis::bench
