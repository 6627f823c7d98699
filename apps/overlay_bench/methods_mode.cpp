// overlay_bench --mode methods: error against frame time. Every method draws the same frames of
// the fly-through in turn — terrain only, our stencil polyhedra, the seed paper's construction,
// texture draping at each size — so that ratios come from one run. On every n-th frame the GPU
// layer mask of each method is compared with the CPU reference on that frame's depth (the
// terrain is the same for all methods): wrong pixels over all terrain pixels, and away from
// feature edges. Writes methods.json, methods.csv, methods.md (the table), error_vs_time.svg and
// error_away_vs_time.svg, and prints the table.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "app/camera_path.hpp"
#include "app/cli.hpp"
#include "app/scene.hpp"
#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "bench_common.hpp"
#include "gfx/gl.hpp"
#include "gfx/render_target.hpp"
#include "svg_plot.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::bench {
namespace {

struct Method {
  Method(std::string n, app::OverlayMethod m, int size, bool withOverlays)
      : name(std::move(n)), method(m), drapeSize(size), overlays(withOverlays) {}
  std::string name;
  app::OverlayMethod method = app::OverlayMethod::Stencil;
  int drapeSize = 0;
  bool overlays = true;
  int cellPosts = 16;  ///< pieces split at cells of this many DEM posts (the ablation turns it off)
  std::function<void(overlay::OverlaySettings&)> adjust;  ///< the ablation's switch, if any
  std::optional<app::SceneRenderer> renderer;
  std::vector<double> ms;
  std::vector<double> ratio;  ///< frame time over terrain only, per frame
  std::size_t pixels = 0, wrong = 0, pixelsAway = 0, wrongAway = 0;
  std::uint64_t fragments = 0;  ///< overlay mark + cover fragments over the judged frames
  std::size_t gpuBytes = 0;
  double buildSeconds = 0.0;
};

int runVariants(const Options& o, std::vector<Method> methods, const std::string& stem);

}  // namespace

int runMethods(const Options& o) {
  std::vector<Method> methods;
  methods.emplace_back("terrain only", app::OverlayMethod::Stencil, 0, false);
  methods.emplace_back("stencil polyhedra", app::OverlayMethod::Stencil, 0, true);
  methods.emplace_back("paper's construction", app::OverlayMethod::Paper, 0, true);
  for (const int size : o.drapeSizes) {
    methods.emplace_back("drape " + std::to_string(size), app::OverlayMethod::Drape, size, true);
  }
  return runVariants(o, std::move(methods), "methods");
}

int runAblation(const Options& o) {
  // Each saving of DESIGN §9 switched off alone.
  std::vector<Method> methods;
  methods.emplace_back("terrain only", app::OverlayMethod::Stencil, 0, false);
  methods.emplace_back("ours (all savings)", app::OverlayMethod::Stencil, 0, true);
  const auto variant = [&](std::string name, std::function<void(overlay::OverlaySettings&)> adjust) {
    methods.emplace_back(std::move(name), app::OverlayMethod::Stencil, 0, true);
    methods.back().adjust = std::move(adjust);
  };
  variant("z-fail for every piece", [](overlay::OverlaySettings& s) { s.forceZFail = true; });
  variant("bottom caps in z-pass", [](overlay::OverlaySettings& s) { s.bottomCapsInZPass = true; });
  variant("no frustum culling", [](overlay::OverlaySettings& s) { s.cullPieces = false; });
  variant("cover with the pieces", [](overlay::OverlaySettings& s) { s.rectangleCover = false; });
  methods.emplace_back("no split at cells", app::OverlayMethod::Stencil, 0, true);
  methods.back().cellPosts = 1 << 20;
  return runVariants(o, std::move(methods), "ablation");
}

namespace {

int runVariants(const Options& o, std::vector<Method> variants, const std::string& stem) {
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  app::LoadedScene* scene = &setup->scene;
  std::unique_ptr<gfx::Context>* context = &setup->context;
  // Declared after the context, so that their GL objects go while it is current.
  std::vector<Method> methods = std::move(variants);
  for (Method& m : methods) {
    app::OverlayBuildSettings build;
    build.method = m.method;
    build.cellPosts = m.cellPosts;
    if (m.drapeSize > 0) build.drapeSize = m.drapeSize;
    Result<app::SceneRenderer> r = app::SceneRenderer::create(*scene, build);
    app::report(r.diagnostics);
    if (!r) return 1;
    m.renderer = std::move(*r);
    if (m.overlays && m.method != app::OverlayMethod::Drape) {
      for (const overlay::OverlayLayer& l : m.renderer->overlayLayers()) {
        m.gpuBytes += l.stats().gpuBytes;
        m.buildSeconds += l.stats().buildSeconds;
      }
    }
  }
  std::vector<overlay::ReferenceLayer> reference;
  for (const overlay::OverlayLayer& l : methods[1].renderer->overlayLayers()) {
    reference.push_back(overlay::referenceLayerOf(l));
  }

  const std::vector<app::PathFrame> path = flyThroughOf(o, *setup);
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, 0, true);
  app::RenderSettings settings = comparisonSettings(o, *setup);  // the same terrain for every method
  const double aspect = static_cast<double>(o.width) / static_cast<double>(o.height);

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (stem + ".csv"));
  csv << "frame,segment,method,ms,wrong_pixels,terrain_pixels,wrong_away_from_edges,pixels_away_from_edges\n";
  for (std::size_t k = 0; k < path.size(); ++k) {
    const app::Camera& camera = path[k].camera;
    const bool judged = k % static_cast<std::size_t>(o.errorEvery) == 0;
    std::vector<float> depth;
    std::vector<std::uint32_t> expected;
    std::vector<std::uint8_t> edges;
    double terrainMs = 0.0;
    for (Method& m : methods) {
      settings.overlays = m.overlays;
      settings.overlay = overlay::OverlaySettings{};
      if (m.adjust) m.adjust(settings.overlay);
      glFinish();
      const auto start = std::chrono::steady_clock::now();
      const app::FrameStats stats =
          m.renderer->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
      glFinish();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      if (stats.drapeBuildSeconds > 0.0) {
        // The drape was built in this frame: its build time, not a frame time.
        m.buildSeconds = stats.drapeBuildSeconds;
        m.gpuBytes = m.renderer->drape() ? m.renderer->drape()->stats().gpuBytes : 0;
      } else if (k > 0) {  // frame 0 uploads the first chunks
        m.ms.push_back(ms);
        if (!m.overlays) terrainMs = ms;
        if (m.overlays && terrainMs > 0.0) m.ratio.push_back(ms / terrainMs);
      }
      std::size_t wrong = 0, pixels = 0, wrongAway = 0, pixelsAway = 0;
      if (judged) {
        if (!m.overlays) {
          depth = gfx::readDepth(target);
          const overlay::DepthImage image{o.width, o.height, depth, camera.projection(aspect) * camera.view()};
          expected = overlay::referenceMask(image, reference);
          edges = overlay::edgePixels(image, reference);
        } else {
          const std::vector<std::uint32_t> mask = gfx::readMask(target);
          // Fragments: the same frame again with the queries on (they wait, so untimed).
          settings.measure = true;
          const app::FrameStats counted =
              m.renderer->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
          settings.measure = false;
          for (const overlay::LayerFrameStats& l : counted.layers) m.fragments += l.markFragments + l.coverFragments;
          for (std::size_t i = 0; i < mask.size(); ++i) {
            if (!(depth[i] > 0.0F)) continue;
            const bool bad = mask[i] != expected[i];
            ++pixels;
            wrong += bad ? 1u : 0u;
            if (edges[i] == 0) {
              ++pixelsAway;
              wrongAway += bad ? 1u : 0u;
            }
          }
          m.pixels += pixels;
          m.wrong += wrong;
          m.pixelsAway += pixelsAway;
          m.wrongAway += wrongAway;
        }
      }
      csv << k << ',' << path[k].segment << ',' << m.name << ',' << ms << ',' << wrong << ',' << pixels << ','
          << wrongAway << ',' << pixelsAway << '\n';
    }
  }

  json table = json::array();
  const double oursFragments = static_cast<double>(std::max<std::uint64_t>(methods[1].fragments, 1));
  std::printf("%-24s %10s %10s %10s %11s %12s %14s %9s %8s\n", "method", "median ms", "p95 ms", "x terrain",
              "frag x ours", "wrong %", "wrong % away", "GPU MB", "build s");
  for (const Method& m : methods) {
    const double share = m.pixels > 0 ? 100.0 * static_cast<double>(m.wrong) / static_cast<double>(m.pixels) : 0.0;
    const double shareAway =
        m.pixelsAway > 0 ? 100.0 * static_cast<double>(m.wrongAway) / static_cast<double>(m.pixelsAway) : 0.0;
    const double ratio = m.overlays ? percentile(m.ratio, 50) : 1.0;
    const double fragmentRatio = static_cast<double>(m.fragments) / oursFragments;
    std::printf("%-24s %10.2f %10.2f %10.2f %11.2f %12.4f %14.4f %9.1f %8.3f\n", m.name.c_str(), percentile(m.ms, 50),
                percentile(m.ms, 95), ratio, fragmentRatio, share, shareAway,
                static_cast<double>(m.gpuBytes) / 1048576.0, m.buildSeconds);
    table.push_back({{"method", m.name},
                     {"drape_size", m.drapeSize},
                     {"median_ms", percentile(m.ms, 50)},
                     {"p95_ms", percentile(m.ms, 95)},
                     {"over_terrain_median", ratio},
                     {"wrong_pixels_pct", share},
                     {"wrong_pixels_away_from_edges_pct", shareAway},
                     {"judged_pixels", m.pixels},
                     {"overlay_fragments", m.fragments},
                     {"fragments_over_ours", static_cast<double>(m.fragments) / oursFragments},
                     {"gpu_bytes", m.gpuBytes},
                     {"build_s", m.buildSeconds}});
  }
  // Error against frame time: one point per method (and per drape size); over all terrain
  // pixels, and away from feature edges.
  for (const bool away : {false, true}) {
    std::vector<PlotPoint> points;
    for (const Method& m : methods) {
      if (!m.overlays) continue;
      const std::size_t wrong = away ? m.wrongAway : m.wrong, judged = away ? m.pixelsAway : m.pixels;
      const double share = judged > 0 ? 100.0 * static_cast<double>(wrong) / static_cast<double>(judged) : 0.0;
      const std::string colour = m.method == app::OverlayMethod::Drape   ? "#d62728"
                                 : m.method == app::OverlayMethod::Paper ? "#ff7f0e"
                                                                         : "#1f77b4";
      points.push_back({percentile(m.ratio, 50), share, m.name, colour});
    }
    PlotAxes axes;
    axes.title = std::string(away ? "Error away from feature edges" : "Error") + " against frame time (" +
                 std::to_string(o.width) + " × " + std::to_string(o.height) + ")";
    axes.xLabel = "median frame time / terrain only, same frame";
    axes.yLabel = away ? "wrong pixels away from edges, %" : "wrong pixels, % of terrain pixels";
    axes.logY = true;
    std::ofstream(std::filesystem::path(o.out) / (stem + (away ? "_error_away_vs_time.svg" : "_error_vs_time.svg")))
        << scatterSvg(points, axes);
  }

  // The table as Markdown, for docs/benchmarks.md (scripts/benchmarks.sh puts it there).
  {
    std::ofstream md(std::filesystem::path(o.out) / (stem + ".md"));
    md << "| method | median ms | p95 ms | × terrain | fragments × ours | wrong % | wrong % away from edges | GPU MB | "
          "build s |\n"
          "|---|---|---|---|---|---|---|---|---|\n";
    for (const Method& m : methods) {
      char row[256];
      const double share = m.pixels > 0 ? 100.0 * static_cast<double>(m.wrong) / static_cast<double>(m.pixels) : 0.0;
      const double shareAway =
          m.pixelsAway > 0 ? 100.0 * static_cast<double>(m.wrongAway) / static_cast<double>(m.pixelsAway) : 0.0;
      std::snprintf(row, sizeof(row), "| %s | %.1f | %.1f | %.2f | %.2f | %.4g | %.4g | %.1f | %.2f |\n",
                    m.name.c_str(), percentile(m.ms, 50), percentile(m.ms, 95),
                    m.overlays ? percentile(m.ratio, 50) : 1.0, static_cast<double>(m.fragments) / oursFragments, share,
                    shareAway, static_cast<double>(m.gpuBytes) / 1048576.0, m.buildSeconds);
      md << row;
    }
  }

  const json result = {{"mode", o.mode},
                       {"scene", o.scene},
                       {"width", o.width},
                       {"height", o.height},
                       {"frames", path.size()},
                       {"error_every", o.errorEvery},
                       {"methods", table},
                       {"renderer", (*context)->info().renderer},
                       {"gl_errors", (*context)->debug().errorCount()}};
  std::ofstream(std::filesystem::path(o.out) / (stem + ".json")) << result.dump(2) << '\n';
  std::printf("gl_errors: %zu\n", static_cast<std::size_t>((*context)->debug().errorCount()));
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace
}  // namespace gis::bench
