// overlay_bench --mode methods: error against frame time. Every method draws the same frames of
// the fly-through in turn — terrain only, our stencil polyhedra, the seed paper's construction,
// texture draping at each size — so that ratios come from one run. On every n-th frame the GPU
// layer mask of each method is compared with the CPU reference on that frame's depth (the
// terrain is the same for all methods): wrong pixels over all terrain pixels, and away from
// feature edges. Writes methods.json, methods.csv, methods.md (the table), error_vs_time.svg and
// error_away_vs_time.svg, and prints the table.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "app/camera_path.hpp"
#include "app/cli.hpp"
#include "app/json_file.hpp"
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

/// What one method measured over some frames (the whole path, or one of its segments).
struct Tally {
  std::vector<double> ms;     ///< wall time per frame, glFinish to glFinish
  std::vector<double> ratio;  ///< frame time over terrain only, per frame
  std::size_t pixels = 0, wrong = 0, pixelsAway = 0, wrongAway = 0;
  std::size_t covered = 0;                              ///< pixels the reference covers, over the judged frames
  std::uint64_t markFragments = 0, coverFragments = 0;  ///< over the judged frames
  std::uint64_t markTriangles = 0, coverTriangles = 0;
  std::size_t zFailPieces = 0, drawnPieces = 0;
  std::vector<double> terrainGpuMs, markGpuMs, coverGpuMs;  ///< per judged frame (GPU timer queries)

  [[nodiscard]] std::uint64_t fragments() const { return markFragments + coverFragments; }
  [[nodiscard]] double wrongPct() const {
    return pixels > 0 ? 100.0 * static_cast<double>(wrong) / static_cast<double>(pixels) : 0.0;
  }
  [[nodiscard]] double wrongAwayPct() const {
    return pixelsAway > 0 ? 100.0 * static_cast<double>(wrongAway) / static_cast<double>(pixelsAway) : 0.0;
  }
};

struct Method {
  Method(std::string n, const overlay::TechniqueInfo& t, int size, bool withOverlays)
      : name(std::move(n)), technique(&t), drapeSize(size), overlays(withOverlays) {}
  std::string name;
  const overlay::TechniqueInfo* technique = nullptr;
  int drapeSize = 0;  ///< texture techniques: texels per side
  bool overlays = true;
  int cellPosts = 16;         ///< pieces split at cells of this many DEM posts (the ablation turns it off)
  bool adaptiveSplit = true;  ///< the split kept only where it pays (the ablation splits everywhere)
  std::function<void(overlay::OverlaySettings&)> adjust;  ///< the ablation's switch, if any
  std::optional<app::SceneRenderer> renderer;             ///< its own, or empty when it shares another's
  app::SceneRenderer* shared = nullptr;                   ///< the renderer it draws with
  Tally all;
  std::map<std::string, Tally> segments;
  std::size_t gpuBytes = 0;
  std::size_t triangles = 0;   ///< of the built polyhedra
  double buildSeconds = 0.0;   ///< polyhedra or drape build; for tiles, all tiles of the path
  std::size_t tilesBuilt = 0;  ///< DrapeTiles: tiles rasterised over the path
  double editMs = 0.0;         ///< a one-feature edit: pieces rebuilt, and the drape (tiles) again
};

/// Draws every variant on the methods path of o.scene, prints and writes the tables and plots
/// (stem.json, .csv, .md, _error*_vs_time.svg); the result JSON also into `result` if given.
int runVariants(const Options& o, std::vector<Method> methods, const std::string& stem, json* result = nullptr);

}  // namespace

int runMethods(const Options& o) {
  std::vector<Method> methods;
  methods.emplace_back("terrain only", overlay::defaultTechnique(), 0, false);
  for (const overlay::TechniqueInfo& t : overlay::techniques()) {
    if (!t.usesTextures()) {
      methods.emplace_back(std::string(t.label), t, 0, true);
      continue;
    }
    // A texture technique at each size asked for (its name, with spaces, and the size).
    std::string name(t.name);
    std::replace(name.begin(), name.end(), '-', ' ');
    for (const int size : o.textureSizesOf(t)) methods.emplace_back(name + " " + std::to_string(size), t, size, true);
  }
  return runVariants(o, std::move(methods), "methods");
}

int runAblation(const Options& o) {
  // Each saving of DESIGN §9 switched off alone.
  std::vector<Method> methods;
  const overlay::TechniqueInfo& ours = overlay::defaultTechnique();
  methods.emplace_back("terrain only", ours, 0, false);
  methods.emplace_back("ours (all savings)", ours, 0, true);
  const auto variant = [&](std::string name, std::function<void(overlay::OverlaySettings&)> adjust) {
    methods.emplace_back(std::move(name), ours, 0, true);
    methods.back().adjust = std::move(adjust);
  };
  variant("z-fail for every piece", [](overlay::OverlaySettings& s) { s.forceZFail = true; });
  variant("bottom caps in z-pass", [](overlay::OverlaySettings& s) { s.bottomCapsInZPass = true; });
  variant("no frustum culling", [](overlay::OverlaySettings& s) { s.cullPieces = false; });
  variant("cover with the pieces", [](overlay::OverlaySettings& s) { s.rectangleCover = false; });
  variant("one cover rectangle, no tiles", [](overlay::OverlaySettings& s) { s.tiledCover = false; });
  methods.emplace_back("split at every cell", ours, 0, true);
  methods.back().adaptiveSplit = false;
  methods.emplace_back("no split at cells", ours, 0, true);
  methods.back().cellPosts = 1 << 20;
  return runVariants(o, std::move(methods), "ablation");
}

namespace {

std::size_t vectorVertices(const app::LoadedScene& scene) {
  std::size_t n = 0;
  for (const app::LoadedLayer& l : scene.layers) {
    for (const geo::Feature& f : l.data.features) n += f.vertexCount();
  }
  return n;
}

/// Median of a list, 0 for none.
double median(const std::vector<double>& v) { return percentile(v, 50); }

json tallyJson(const Tally& t, const Tally& ours, bool overlays) {
  const double oursFragments = static_cast<double>(std::max<std::uint64_t>(ours.fragments(), 1));
  return {{"median_ms", median(t.ms)},
          {"p95_ms", percentile(t.ms, 95)},
          {"over_terrain_median", overlays ? median(t.ratio) : 1.0},
          {"gpu_ms_terrain_median", median(t.terrainGpuMs)},
          {"gpu_ms_mark_median", median(t.markGpuMs)},
          {"gpu_ms_cover_median", median(t.coverGpuMs)},
          {"wrong_pixels_pct", t.wrongPct()},
          {"wrong_pixels_away_from_edges_pct", t.wrongAwayPct()},
          {"judged_pixels", t.pixels},
          {"covered_pixels", t.covered},
          {"mark_fragments", t.markFragments},
          {"cover_fragments", t.coverFragments},
          {"fragments_over_ours", static_cast<double>(t.fragments()) / oursFragments},
          {"fragments_per_covered_pixel",
           t.covered > 0 ? static_cast<double>(t.fragments()) / static_cast<double>(t.covered) : 0.0},
          {"mark_triangles", t.markTriangles},
          {"cover_triangles", t.coverTriangles},
          {"z_fail_pieces", t.zFailPieces},
          {"drawn_pieces", t.drawnPieces}};
}

int runVariants(const Options& o, std::vector<Method> variants, const std::string& stem, json* summary) {
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  app::LoadedScene* scene = &setup->scene;
  std::unique_ptr<gfx::Context>* context = &setup->context;
  // Declared after the context, so that their GL objects go while it is current.
  std::vector<Method> methods = std::move(variants);
  // Methods that build the same polyhedra (terrain only, ours and the ablation's switches at draw
  // time) share one renderer: the same terrain, and the memory of one copy.
  std::map<std::tuple<std::string_view, int, int, bool>, app::SceneRenderer*> built;
  for (Method& m : methods) {
    app::OverlayBuildSettings build;
    build.technique = m.technique;
    build.cellPosts = m.cellPosts;
    build.adaptiveSplit = m.adaptiveSplit;
    build.textureSize = m.drapeSize;
    const std::tuple<std::string_view, int, int, bool> key{m.technique->name, m.cellPosts, m.drapeSize,
                                                           m.adaptiveSplit};
    if (const auto found = built.find(key); found != built.end()) {
      m.shared = found->second;
    } else {
      Result<app::SceneRenderer> r = app::SceneRenderer::create(*scene, build);
      app::report(r.diagnostics);
      if (!r) return 1;
      m.renderer = std::move(*r);
      m.shared = &*m.renderer;
      built[key] = m.shared;
    }
    if (m.overlays && !m.technique->usesTextures()) {
      for (const overlay::OverlayLayer& l : m.shared->overlayLayers()) {
        m.gpuBytes += l.stats().gpuBytes;
        m.buildSeconds += l.stats().buildSeconds;
        m.triangles += l.stats().triangles;
      }
    }
  }
  std::vector<overlay::ReferenceLayer> reference;
  for (const overlay::OverlayLayer& l : methods[1].shared->overlayLayers()) {
    reference.push_back(overlay::referenceLayerOf(l));
  }

  const std::vector<app::PathFrame> path = methodsPath(o, *setup);
  if (path.empty()) {
    std::fprintf(stderr, "overlay_bench: no frames on the path (--segments)\n");
    return 1;
  }
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, o.msaa, true);
  std::optional<gfx::RenderTarget> sample;  // MSAA: sample 0 of each judged frame
  if (target.multisampled()) sample.emplace(o.width, o.height, 0, true);
  const gfx::RenderTarget& readable = sample ? *sample : target;
  app::RenderSettings settings = comparisonSettings(o, *setup);  // the same terrain for every method
  const double aspect = static_cast<double>(o.width) / static_cast<double>(o.height);

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (stem + ".csv"));
  csv << "frame,segment,method,ms,wrong_pixels,terrain_pixels,wrong_away_from_edges,pixels_away_from_edges,"
         "covered_pixels,mark_fragments,cover_fragments,gpu_ms_terrain,gpu_ms_mark,gpu_ms_cover,z_fail_pieces\n";
  for (std::size_t k = 0; k < path.size(); ++k) {
    const app::Camera& camera = path[k].camera;
    const std::string& segment = path[k].segment;
    const bool judged = k % static_cast<std::size_t>(o.errorEvery) == 0;
    std::vector<float> depth;
    std::vector<std::uint32_t> expected;
    std::vector<std::uint8_t> edges;
    std::size_t covered = 0;
    double terrainMs = 0.0;
    for (Method& m : methods) {
      Tally frame;  // this frame's figures, added to the whole path's and the segment's
      settings.overlays = m.overlays;
      settings.overlay = overlay::OverlaySettings{};
      if (m.adjust) m.adjust(settings.overlay);
      glFinish();
      const auto start = std::chrono::steady_clock::now();
      const app::FrameStats stats = m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
      glFinish();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      if (stats.texturesBuilt > 0 && m.shared->textureDrape() != nullptr) {
        // The one drape was built in this frame: its build time, not a frame time.
        m.buildSeconds = stats.textureSeconds;
        m.gpuBytes = m.shared->techniqueGpuBytes();
      } else if (k > 0) {  // frame 0 uploads the first chunks (and builds the first tiles)
        frame.ms.push_back(ms);
        if (!m.overlays) terrainMs = ms;
        if (m.overlays && terrainMs > 0.0) frame.ratio.push_back(ms / terrainMs);
      }
      if (judged) {
        // The same frame again with the queries on (they wait, so untimed): GPU time per pass,
        // fragments and triangles.
        settings.measure = true;
        const app::FrameStats counted =
            m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
        settings.measure = false;
        frame.terrainGpuMs.push_back(counted.terrain.gpuMilliseconds);
        double mark = 0.0, cover = 0.0;
        for (const overlay::LayerFrameStats& l : counted.layers) {
          frame.markFragments += l.markFragments;
          frame.coverFragments += l.coverFragments;
          frame.markTriangles += l.markTriangles;
          frame.coverTriangles += l.coverTriangles;
          frame.zFailPieces += l.zFailPieces;
          frame.drawnPieces += l.zPassPieces + l.zFailPieces;
          mark += l.markMilliseconds;
          cover += l.coverMilliseconds;
        }
        if (m.overlays) {
          frame.markGpuMs.push_back(mark);
          frame.coverGpuMs.push_back(cover);
        }
        if (sample) target.copySampleInto(cache, *sample, 0);
        if (!m.overlays) {
          depth = gfx::readDepth(readable);
          const overlay::DepthImage image{o.width, o.height, depth, camera.projection(aspect) * camera.view()};
          expected = overlay::referenceMask(image, reference);
          edges = overlay::edgePixels(image, reference);
          covered = static_cast<std::size_t>(
              std::count_if(expected.begin(), expected.end(), [](std::uint32_t bits) { return bits != 0; }));
        } else {
          const std::vector<std::uint32_t> mask = gfx::readMask(readable);
          for (std::size_t i = 0; i < mask.size(); ++i) {
            if (!(depth[i] > 0.0F)) continue;
            const bool bad = mask[i] != expected[i];
            ++frame.pixels;
            frame.wrong += bad ? 1u : 0u;
            if (edges[i] == 0) {
              ++frame.pixelsAway;
              frame.wrongAway += bad ? 1u : 0u;
            }
          }
          frame.covered = covered;
        }
      }
      if (m.technique->usesTextures() && m.shared->textureDrape() == nullptr) {
        // Tiles are rasterised as the view moves: their time is part of the frame's.
        m.gpuBytes = std::max(m.gpuBytes, m.shared->techniqueGpuBytes());
        m.tilesBuilt += stats.texturesBuilt;
        m.buildSeconds += stats.textureSeconds;
      }
      for (Tally* t : {&m.all, &m.segments[segment]}) {
        t->ms.insert(t->ms.end(), frame.ms.begin(), frame.ms.end());
        t->ratio.insert(t->ratio.end(), frame.ratio.begin(), frame.ratio.end());
        t->terrainGpuMs.insert(t->terrainGpuMs.end(), frame.terrainGpuMs.begin(), frame.terrainGpuMs.end());
        t->markGpuMs.insert(t->markGpuMs.end(), frame.markGpuMs.begin(), frame.markGpuMs.end());
        t->coverGpuMs.insert(t->coverGpuMs.end(), frame.coverGpuMs.begin(), frame.coverGpuMs.end());
        t->pixels += frame.pixels;
        t->wrong += frame.wrong;
        t->pixelsAway += frame.pixelsAway;
        t->wrongAway += frame.wrongAway;
        t->covered += frame.covered;
        t->markFragments += frame.markFragments;
        t->coverFragments += frame.coverFragments;
        t->markTriangles += frame.markTriangles;
        t->coverTriangles += frame.coverTriangles;
        t->zFailPieces += frame.zFailPieces;
        t->drawnPieces += frame.drawnPieces;
      }
      csv << k << ',' << segment << ',' << m.name << ',' << ms << ',' << frame.wrong << ',' << frame.pixels << ','
          << frame.wrongAway << ',' << frame.pixelsAway << ',' << frame.covered << ',' << frame.markFragments << ','
          << frame.coverFragments << ',' << (judged ? frame.terrainGpuMs.back() : 0.0) << ','
          << (frame.markGpuMs.empty() ? 0.0 : frame.markGpuMs.back()) << ','
          << (frame.coverGpuMs.empty() ? 0.0 : frame.coverGpuMs.back()) << ',' << frame.zFailPieces << '\n';
    }
  }

  // A one-feature edit per method, after the path: a vertex of the first feature of the first
  // layer moved by 10 m; the time to rebuild its pieces, plus for draping the texture (or the
  // tiles over the feature) rasterised again in the next frame.
  for (Method& m : methods) {
    if (!m.overlays || m.shared->overlayLayers().empty()) continue;
    overlay::OverlayLayer& layer = m.shared->overlayLayer(0);
    if (layer.features().empty()) continue;
    geo::Feature feature = layer.features().front();
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    const auto extend = [&](const std::vector<glm::dvec2>& points) {
      for (const glm::dvec2& p : points) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
      }
    };
    if (!feature.polygons.empty() && !feature.polygons.front().outer.empty()) {
      feature.polygons.front().outer.front() += glm::dvec2(10.0, 0.0);
      for (const geo::Polygon& p : feature.polygons) extend(p.outer);
    } else if (!feature.lines.empty() && !feature.lines.front().empty()) {
      feature.lines.front().front() += glm::dvec2(10.0, 0.0);
      for (const geo::LineString& l : feature.lines) extend(l);
    } else {
      continue;
    }
    const double margin = 2.0 * layer.style().maxWidthMetres + 20.0;  // widths and outlines
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    (void)layer.replaceFeature(0, feature);
    m.shared->invalidateOverlays(lo - margin, hi + margin);
    m.editMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    settings.overlays = true;
    settings.overlay = overlay::OverlaySettings{};
    if (m.adjust) m.adjust(settings.overlay);
    const app::FrameStats after =
        m.shared->render(cache, target.framebuffer(), o.width, o.height, path.back().camera, settings);
    m.editMs += 1e3 * after.textureSeconds;
  }

  const Method& ours = methods[1];
  json table = json::array();
  std::printf("%-24s %9s %9s %9s %10s %10s %10s %11s %10s %12s %8s %8s\n", "method", "median ms", "p95 ms", "x terrain",
              "GPU terr", "GPU mark", "GPU cover", "frag x ours", "wrong %", "wrong % away", "GPU MB", "build s");
  for (const Method& m : methods) {
    const Tally& t = m.all;
    std::printf(
        "%-24s %9.2f %9.2f %9.3f %10.2f %10.2f %10.2f %11.2f %10.4f %12.4f %8.1f %8.3f\n", m.name.c_str(), median(t.ms),
        percentile(t.ms, 95), m.overlays ? median(t.ratio) : 1.0, median(t.terrainGpuMs), median(t.markGpuMs),
        median(t.coverGpuMs),
        static_cast<double>(t.fragments()) / static_cast<double>(std::max<std::uint64_t>(ours.all.fragments(), 1)),
        t.wrongPct(), t.wrongAwayPct(), static_cast<double>(m.gpuBytes) / 1048576.0, m.buildSeconds);
    json entry = tallyJson(t, ours.all, m.overlays);
    entry["method"] = m.name;
    entry["drape_size"] = m.drapeSize;
    entry["gpu_bytes"] = m.gpuBytes;
    entry["triangles"] = m.triangles;
    entry["build_s"] = m.buildSeconds;
    entry["tiles_built"] = m.tilesBuilt;
    entry["edit_ms"] = m.editMs;
    json segments = json::object();
    for (const auto& [name, st] : m.segments) {
      const auto found = ours.segments.find(name);
      segments[name] = tallyJson(st, found != ours.segments.end() ? found->second : ours.all, m.overlays);
    }
    entry["segments"] = segments;
    table.push_back(entry);
  }
  // Per segment: the ratio to terrain only, fragments against ours on the same segment (the
  // grazing views are the horizon segment), error away from edges.
  std::printf("\n%-24s %-10s %9s %11s %12s %12s\n", "method", "segment", "x terrain", "frag x ours", "frag/cov px",
              "wrong % away");
  for (const Method& m : methods) {
    if (!m.overlays) continue;
    for (const auto& [name, st] : m.segments) {
      const Tally& base = ours.segments.at(name);
      std::printf(
          "%-24s %-10s %9.3f %11.2f %12.2f %12.4f\n", m.name.c_str(), name.c_str(), median(st.ratio),
          static_cast<double>(st.fragments()) / static_cast<double>(std::max<std::uint64_t>(base.fragments(), 1)),
          st.covered > 0 ? static_cast<double>(st.fragments()) / static_cast<double>(st.covered) : 0.0,
          st.wrongAwayPct());
    }
  }
  // Error against frame time: one point per method (and per drape size); over all terrain
  // pixels, and away from feature edges.
  for (const bool away : {false, true}) {
    std::vector<PlotPoint> points;
    for (const Method& m : methods) {
      if (!m.overlays) continue;
      const std::string colour(m.technique->plotColour);
      points.push_back({median(m.all.ratio), away ? m.all.wrongAwayPct() : m.all.wrongPct(), m.name, colour});
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

  // The tables as Markdown, for docs/benchmarks.md (scripts/benchmarks.sh puts them there).
  {
    std::ofstream md(std::filesystem::path(o.out) / (stem + ".md"));
    md << "| method | median ms | p95 ms | × terrain | GPU ms terrain / mark / cover | fragments × ours | "
          "fragments per covered pixel | wrong % | wrong % away from edges | GPU MB | build s | edit ms |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    const double oursFragments = static_cast<double>(std::max<std::uint64_t>(ours.all.fragments(), 1));
    for (const Method& m : methods) {
      const Tally& t = m.all;
      char row[384];
      std::snprintf(
          row, sizeof(row),
          "| %s | %.1f | %.1f | %.3f | %.1f / %.1f / %.1f | %.2f | %.1f | %.4g | %.4g | %.1f | %.2f | %.1f |\n",
          m.name.c_str(), median(t.ms), percentile(t.ms, 95), m.overlays ? median(t.ratio) : 1.0,
          median(t.terrainGpuMs), median(t.markGpuMs), median(t.coverGpuMs),
          static_cast<double>(t.fragments()) / oursFragments,
          t.covered > 0 ? static_cast<double>(t.fragments()) / static_cast<double>(t.covered) : 0.0, t.wrongPct(),
          t.wrongAwayPct(), static_cast<double>(m.gpuBytes) / 1048576.0, m.buildSeconds, m.editMs);
      md << row;
    }
    md << "\nPer path segment (fragments against ours on the same segment; the horizon segment is the grazing "
          "view):\n\n| method | segment | × terrain | fragments × ours | wrong % away from edges | z-fail pieces |\n"
          "|---|---|---|---|---|---|\n";
    for (const Method& m : methods) {
      if (!m.overlays) continue;
      for (const auto& [name, st] : m.segments) {
        const Tally& base = ours.segments.at(name);
        char row[256];
        std::snprintf(
            row, sizeof(row), "| %s | %s | %.3f | %.2f | %.4g | %zu |\n", m.name.c_str(), name.c_str(),
            median(st.ratio),
            static_cast<double>(st.fragments()) / static_cast<double>(std::max<std::uint64_t>(base.fragments(), 1)),
            st.wrongAwayPct(), st.zFailPieces);
        md << row;
      }
    }
  }

  const json result = {{"mode", o.mode},
                       {"scene", o.scene},
                       {"width", o.width},
                       {"height", o.height},
                       {"msaa", target.samples()},
                       {"frames", path.size()},
                       {"error_every", o.errorEvery},
                       {"vector_vertices", vectorVertices(*scene)},
                       {"dem_posts", static_cast<std::size_t>(scene->quadtree->grid().width) *
                                         static_cast<std::size_t>(scene->quadtree->grid().height)},
                       {"methods", table},
                       {"renderer", (*context)->info().renderer},
                       {"gl_errors", (*context)->debug().errorCount()}};
  std::ofstream(std::filesystem::path(o.out) / (stem + ".json")) << app::jsonText(result) << '\n';
  if (summary != nullptr) *summary = result;
  std::printf("gl_errors: %zu\n", static_cast<std::size_t>((*context)->debug().errorCount()));
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace

int runScaling(const Options& o) {
  // Each scene in turn: terrain only, ours and the paper's construction on the same frames.
  json rows = json::array();
  for (const std::string& sceneFile : o.scenes) {
    Options so = o;
    so.scene = sceneFile;
    so.out = (std::filesystem::path(o.out) / std::filesystem::path(sceneFile).stem()).string();
    if (so.segments.empty()) so.segments = {"oblique"};
    std::vector<Method> methods;
    // The stencil techniques (those that build polyhedra) at every scale.
    methods.emplace_back("terrain only", overlay::defaultTechnique(), 0, false);
    for (const overlay::TechniqueInfo& t : overlay::techniques()) {
      if (!t.usesTextures()) methods.emplace_back(std::string(t.label), t, 0, true);
    }
    json r;
    if (runVariants(so, std::move(methods), "methods", &r) != 0) return 1;
    rows.push_back(r);
  }
  // The table, and frame time against vector vertices and against DEM posts.
  std::ofstream md(std::filesystem::path(o.out) / "scaling.md");
  md << "| scene | DEM posts | vector vertices | terrain only ms | ours ms | ours × terrain | ours GPU ms mark + cover "
        "| "
        "ours GPU MB | ours build s | paper × terrain |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<PlotPoint> byVertices, byPosts;
  const char* colours[] = {"#7f7f7f", "#1f77b4", "#ff7f0e"};
  for (const json& r : rows) {
    const json& m = r["methods"];
    const std::string stem = std::filesystem::path(r["scene"].get<std::string>()).stem().string();
    const double vertices = r["vector_vertices"].get<double>(), posts = r["dem_posts"].get<double>();
    char row[512];
    std::snprintf(row, sizeof(row), "| %s | %.0f | %.0f | %.1f | %.1f | %.3f | %.1f | %.1f | %.2f | %.3f |\n",
                  stem.c_str(), posts, vertices, m[0]["median_ms"].get<double>(), m[1]["median_ms"].get<double>(),
                  m[1]["over_terrain_median"].get<double>(),
                  m[1]["gpu_ms_mark_median"].get<double>() + m[1]["gpu_ms_cover_median"].get<double>(),
                  m[1]["gpu_bytes"].get<double>() / 1048576.0, m[1]["build_s"].get<double>(),
                  m[2]["over_terrain_median"].get<double>());
    md << row;
    for (std::size_t i = 0; i < 3 && i < m.size(); ++i) {
      const std::string label = i == 0                                                     ? ""
                                : m[i]["method"].get<std::string>() == "stencil polyhedra" ? "ours"
                                                                                           : "paper";
      byVertices.push_back({vertices, m[i]["median_ms"].get<double>(), label, colours[i]});
      byPosts.push_back({posts, m[i]["median_ms"].get<double>(), label, colours[i]});
    }
  }
  PlotAxes axes;
  axes.logX = true;
  axes.yLabel = "median frame time, ms (grey: terrain only, blue: ours, orange: paper's)";
  axes.title = "Frame time against vector vertices";
  axes.xLabel = "vector vertices";
  std::ofstream(std::filesystem::path(o.out) / "scaling_time_vs_vertices.svg") << scatterSvg(byVertices, axes);
  axes.title = "Frame time against DEM size";
  axes.xLabel = "DEM posts";
  std::ofstream(std::filesystem::path(o.out) / "scaling_time_vs_dem.svg") << scatterSvg(byPosts, axes);
  std::ofstream(std::filesystem::path(o.out) / "scaling.json") << app::jsonText(json{{"scenes", rows}}) << '\n';
  std::printf("scaling: %s\n", (std::filesystem::path(o.out) / "scaling.md").string().c_str());
  return 0;
}

std::vector<app::PathFrame> closeUpPath(const BenchSetup& setup, int frames) {
  struct Spot {
    glm::dvec2 point, direction;
  };
  std::vector<Spot> roads, areas;
  for (const app::LoadedLayer& layer : setup.scene.layers) {
    for (const geo::Feature& f : layer.data.features) {
      for (const geo::LineString& line : f.lines) {
        const std::size_t i = line.size() / 2;
        if (i == 0) continue;
        const glm::dvec2 d = line[i] - line[i - 1];
        if (glm::length(d) > 0.0) roads.push_back({0.5 * (line[i] + line[i - 1]), glm::normalize(d)});
      }
      for (const geo::Polygon& p : f.polygons) {
        if (p.outer.size() < 3) continue;
        glm::dvec2 c(0.0);
        for (const glm::dvec2& v : p.outer) c += v;
        areas.push_back({c / static_cast<double>(p.outer.size()), glm::dvec2(1.0, 0.0)});
      }
    }
  }
  std::vector<app::PathFrame> path;
  const auto& bounds = *setup.scene.bounds;
  for (int k = 0; k < frames * 4 && static_cast<int>(path.size()) < frames; ++k) {
    const std::vector<Spot>& list = (k % 2 == 0 && !roads.empty()) || areas.empty() ? roads : areas;
    if (list.empty()) break;
    // Spread over the list: a fixed stride through it.
    const Spot& spot = list[(static_cast<std::size_t>(k) * 7919u) % list.size()];
    const double ground = bounds.fullResolutionHeightAt(spot.point);
    if (!std::isfinite(ground)) continue;
    app::Camera c;
    c.eye = glm::dvec3(spot.point, ground + 1.5);
    const double down = 10.0 * std::numbers::pi / 180.0;
    c.target = c.eye + glm::dvec3(std::cos(down) * spot.direction, -std::sin(down));
    c.nearPlane = 0.1;
    path.push_back({c, "close-up"});
  }
  return path;
}

std::vector<app::PathFrame> methodsPath(const Options& o, const BenchSetup& setup) {
  std::vector<app::PathFrame> all = flyThroughOf(o, setup);
  const std::vector<app::PathFrame> close = closeUpPath(setup, std::max(o.frames / 3, 1));
  all.insert(all.end(), close.begin(), close.end());
  if (o.segments.empty()) return all;
  std::vector<app::PathFrame> kept;
  for (app::PathFrame& f : all) {
    if (std::find(o.segments.begin(), o.segments.end(), f.segment) != o.segments.end()) kept.push_back(std::move(f));
  }
  return kept;
}

}  // namespace gis::bench
