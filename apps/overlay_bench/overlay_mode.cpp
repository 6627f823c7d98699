// overlay_bench --mode overlay: the fly-through, each frame drawn three ways in turn — terrain
// only, our stencil polyhedra, the seed paper's construction — so that the ratios come from one
// run; plus, on every 3rd frame, GPU time and fragment counts per layer against the pixels each
// layer covers (fragments per covered pixel), and the latency of a one-feature edit. Writes
// bench.json and frames.csv.
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
  scene::SceneRenderer& ours;
  scene::SceneRenderer& paper;
  scene::RenderSettings settings;
  gfx::StateCache cache;
  gfx::RenderTarget target;

  OverlayBench(const Options& options, scene::SceneRenderer& oursRenderer, scene::SceneRenderer& paperRenderer)
      : o(options),
        ours(oursRenderer),
        paper(paperRenderer),
        settings(comparisonSettings(options)),  // the same terrain for the three methods
        target(options.width, options.height, 0, true) {}

  /// Milliseconds to draw the frame with `r`, glFinish to glFinish.
  double timed(scene::SceneRenderer& r, const scene::Camera& camera, bool overlays, bool measure,
               scene::FrameStats& stats) {
    settings.overlays = overlays;
    settings.measure = measure;
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    stats = r.render(cache, target.framebuffer(), o.width, o.height, camera, settings);
    glFinish();
    return msSince(start);
  }

  FrameCounts count(const scene::PathFrame& frame, OverlayFrames& f);
  void drawPath(const std::vector<scene::PathFrame>& path, OverlayFrames& f);
  json edit(const scene::Camera& camera);
};

/// A counted frame (the queries wait): fragments of mark + cover against the pixels each layer
/// covers (a pixel covered by two layers counts twice: each layer's floor is 2–3).
FrameCounts OverlayBench::count(const scene::PathFrame& frame, OverlayFrames& f) {
  FrameCounts c;
  scene::FrameStats measured;
  timed(ours, frame.camera, true, true, measured);
  const std::vector<std::uint32_t> mask = gfx::readMask(target);
  for (std::size_t i = 0; i < measured.layers.size(); ++i) {
    const auto& l = measured.layers[i];
    std::size_t layerCovered = 0;
    for (std::uint32_t m : mask) layerCovered += (m >> i) & 1u;
    c.covered += layerCovered;
    c.ours += l.markFragments + l.coverFragments;
    if (layerCovered > 0) {
      LayerCounts& counts = f.layerCounts[i];
      counts.mark[frame.segment].push_back(static_cast<double>(l.markFragments) / static_cast<double>(layerCovered));
      counts.cover[frame.segment].push_back(static_cast<double>(l.coverFragments) / static_cast<double>(layerCovered));
    }
  }
  timed(paper, frame.camera, true, true, measured);
  for (const auto& l : measured.layers) c.paper += l.markFragments + l.coverFragments;
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
void OverlayBench::drawPath(const std::vector<scene::PathFrame>& path, OverlayFrames& f) {
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,terrain_ms,stencil_ms,paper_ms,covered_pixels,stencil_fragments,paper_fragments,stencil_zfail_"
         "pieces\n";
  for (std::size_t k = 0; k < path.size(); ++k) {
    const scene::Camera& camera = path[k].camera;
    const std::string& segment = path[k].segment;
    scene::FrameStats a, b, c;
    const double tMs = timed(ours, camera, false, false, a);
    const double sMs = timed(ours, camera, true, false, b);
    const double pMs = timed(paper, camera, true, false, c);
    if (k > 0) {  // frame 0 builds the first chunks
      f.terrainOnly.add(segment, tMs);
      f.stencil.add(segment, sMs);
      f.paper.add(segment, pMs);
      f.ratio.push_back(sMs / std::max(tMs, 1e-6));
    }
    std::size_t zFail = 0;
    for (const auto& l : b.layers) zFail += l.zFailPieces;
    const FrameCounts counts = k % kCountEvery == 0 ? count(path[k], f) : FrameCounts{};
    csv << k << ',' << segment << ',' << tMs << ',' << sMs << ',' << pMs << ',' << counts.covered << ',' << counts.ours
        << ',' << counts.paper << ',' << zFail << '\n';
  }
}

/// A one-feature edit: move a vertex of the first line (or polygon) feature by 10 m; the time
/// to rebuild its pieces and draw the next frame.
json OverlayBench::edit(const scene::Camera& camera) {
  for (std::size_t i = 0; i < ours.overlayLayers().size(); ++i) {
    overlay::OverlayLayer& layer = ours.overlayLayer(i);
    if (layer.features().empty()) continue;
    geo::Feature feature = layer.features().front();
    if (!feature.lines.empty() && !feature.lines.front().empty()) {
      feature.lines.front().front() += glm::dvec2(10.0, 0.0);
    } else if (!feature.polygons.empty() && !feature.polygons.front().outer.empty()) {
      feature.polygons.front().outer.front() += glm::dvec2(10.0, 0.0);
    } else {
      continue;
    }
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const geo::Feature* f : {&layer.features().front(), static_cast<const geo::Feature*>(&feature)}) {
      for (const geo::LineString& line : f->lines)
        for (const glm::dvec2& p : line) lo = glm::min(lo, p), hi = glm::max(hi, p);
      for (const geo::Polygon& polygon : f->polygons)
        for (const glm::dvec2& p : polygon.outer) lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
    const double margin = 2.0 * layer.style().maxWidthMetres + 20.0;  // widths and outlines
    const auto start = std::chrono::steady_clock::now();
    const Diagnostics d = layer.replaceFeature(0, feature);
    ours.featureChanged(i, 0, lo - margin, hi + margin);
    const double rebuildMs = msSince(start);
    scene::FrameStats after;
    const double frameMs = timed(ours, camera, true, false, after);
    return {{"layer", layer.name()}, {"rebuild_ms", rebuildMs}, {"next_frame_ms", frameMs}};
  }
  return nullptr;
}

json summaryJson(const MethodFrames& m) {
  json segments;
  for (const auto& [name, v] : m.bySegment) {
    segments[name] = {{"median_ms", percentile(v, 50)}, {"p95_ms", percentile(v, 95)}};
  }
  return json{{"median_ms", percentile(m.ms, 50)}, {"p95_ms", percentile(m.ms, 95)}, {"segments", segments}};
}

json layersJson(const scene::SceneRenderer& renderer, OverlayFrames& f) {
  json layers = json::array();
  for (std::size_t i = 0; i < renderer.overlayLayers().size(); ++i) {
    const overlay::OverlayLayer& l = renderer.overlayLayers()[i];
    json perPixel;
    for (const auto& [name, v] : f.layerCounts[i].mark) {
      perPixel[name] = {{"mark_median", percentile(v, 50)},
                        {"cover_median", percentile(f.layerCounts[i].cover[name], 50)}};
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
  if (!projectedOnly(o, *setup)) return 2;
  // Two renderers: ours and the paper's construction (the terrain is the same).
  scene::OverlayBuildSettings ours, paper;
  paper.technique = overlay::findTechnique("paper");
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(setup->scene.projected(), ours);
  app::report(renderer.diagnostics);
  Result<scene::SceneRenderer> paperRenderer = scene::SceneRenderer::create(setup->scene.projected(), paper);
  if (!renderer || !paperRenderer) return 1;

  const std::vector<scene::PathFrame> path = flyThroughOf(o, *setup);
  OverlayBench bench(o, *renderer, *paperRenderer);
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
                 {"layers", layersJson(*renderer, f)},
                 {"edit", edit},
                 {"cpu_peak_bytes", processMemory("VmHWM")},
                 {"renderer", context.info().renderer},
                 {"gl_errors", context.debug().errorCount()}};
  return finish(o, result, *setup->context);
}

}  // namespace gis::bench
