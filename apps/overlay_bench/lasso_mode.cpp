// overlay_bench --mode lasso: one camera, the terrain drawn once, then the GPU time of lasso
// selection for 1–500 random volumes (mixed operators, and Or only), interleaved with the time of
// one full-screen pass, so every figure is a ratio to that pass; a least-squares line through time
// against volumes gives the time per volume. In either frame: a projected scene's volumes reach to
// infinity, the globe's to the eye's horizon (scene::Scene::lassoIn). Writes lasso.json and
// lasso.csv.
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
#include <tuple>
#include <utility>
#include <vector>

#include "bench_common.hpp"
#include "gfx/gl.hpp"
#include "gfx/pipeline_state.hpp"
#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/render_target.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/json_file.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/selection_renderer.hpp"

namespace gis::bench {
namespace {

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

/// The random lassos (the same for every N: the first N of the list) and the two operator chains
/// over them.
struct Lassos {
  std::vector<std::size_t> counts;  ///< the N measured
  std::size_t maxVolumes = 0;
  std::vector<std::vector<glm::dvec2>> polygons;  ///< pixels, y down
  double areaFraction = 0.0;                      ///< mean, of the screen
  std::size_t vertices = 0;
  std::vector<LassoSeries> series;
};

Lassos makeLassos(const Options& o) {
  Lassos l;
  for (std::size_t n : kVolumeCounts)
    if (n <= static_cast<std::size_t>(o.maxVolumes)) l.counts.push_back(n);
  l.maxVolumes = l.counts.back();
  const double screenPixels = static_cast<double>(o.width) * o.height;
  std::mt19937 rng(kLassoSeed);
  for (std::size_t i = 0; i < l.maxVolumes; ++i) {
    l.polygons.push_back(starLasso(rng, o.width, o.height));
    l.areaFraction += polygonArea(l.polygons.back()) / (screenPixels * static_cast<double>(l.maxVolumes));
    l.vertices += l.polygons.back().size();
  }
  l.series.resize(2);  // the same lassos, two operator chains
  l.series[0].name = "mixed";
  l.series[1].name = "or";
  constexpr std::array<overlay::SelectionOp, 4> kMix{overlay::SelectionOp::Or, overlay::SelectionOp::Xor,
                                                     overlay::SelectionOp::Subtract, overlay::SelectionOp::And};
  std::uniform_int_distribution<std::size_t> pick(0, kMix.size() - 1);
  for (std::size_t i = 0; i < l.maxVolumes; ++i) {
    l.series[0].ops.push_back(i == 0 ? overlay::SelectionOp::Single : kMix[pick(rng)]);
    l.series[1].ops.push_back(i == 0 ? overlay::SelectionOp::Single : overlay::SelectionOp::Or);
  }
  return l;
}

/// The full-screen passes and stencil clears measured between the selections.
struct PassTimes {
  Samples passMs, clearMs;
  std::uint64_t passFragments = 0;
};

/// The camera, the terrain drawn once under it, and what the selections are timed with.
struct LassoBench {
  const Options& o;
  const scene::Scene& scene;
  gfx::Program& passProgram;
  scene::FrameCamera camera;
  std::string cameraKind;
  overlay::OverlayView view;
  gfx::StateCache cache;
  gfx::RenderTarget target;
  scene::FrameFigures terrainFrame;
  std::size_t terrainPixels = 0;
  gfx::GpuTimer timer;
  gfx::PipelineStatistics statistics;
  gfx::VertexArrayHandle emptyVao = gfx::createVertexArray();

  LassoBench(const Options& options, const BenchSetup& setup, scene::FrameRenderer& renderer, gfx::Program& program);
  [[nodiscard]] std::vector<overlay::SelectionStep> stepsFor(const Lassos& l, const LassoSeries& s,
                                                             std::size_t n) const;
  Sample fullScreenPass();
  Sample select(LassoSeries::Row& row);
  Sample clear(LassoSeries::Row& row);
  bool buildRows(Lassos& l);
  PassTimes measure(Lassos& l);
};

/// One camera, the flight's first oblique frame (a projected scene's from the south, 40° down;
/// on the globe its path's first oblique frame: terrain fills the view), and the terrain drawn
/// once: the selection reads its depth.
LassoBench::LassoBench(const Options& options, const BenchSetup& setup, scene::FrameRenderer& renderer,
                       gfx::Program& program)
    : o(options), scene(setup.scene), passProgram(program), target(options.width, options.height) {
  Options three = options;
  three.frames = 3;
  const std::vector<BenchFrame> path = flightPath(three, setup);
  const auto oblique = std::find_if(path.begin(), path.end(),
                                    [](const BenchFrame& f) { return f.segment.find("oblique") != std::string::npos; });
  const BenchFrame& chosen = oblique != path.end() ? *oblique : path[path.size() / 2];
  camera = chosen.camera;
  cameraKind = "the first \"" + chosen.segment + "\" frame of the flight";
  scene::FrameOptions drawn;
  drawn.overlays = false;
  terrainFrame = renderer.drawFrame(cache, target, camera, drawn);
  view = scene::Scene::overlayViewOf(camera, o.width, o.height);
  for (float d : gfx::readDepth(target)) terrainPixels += d > 0.0F ? 1u : 0u;
}

std::vector<overlay::SelectionStep> LassoBench::stepsFor(const Lassos& l, const LassoSeries& s, std::size_t n) const {
  std::vector<overlay::SelectionStep> steps(n);
  for (std::size_t i = 0; i < n; ++i) {
    steps[i].op = s.ops[i];
    steps[i].lasso = scene.lassoIn(camera, l.polygons[i], o.width, o.height);
  }
  return steps;
}

Sample LassoBench::fullScreenPass() {
  return timed([&] {
    return queried(timer, statistics, [&] {
      cache.apply(kFullScreenPass);
      cache.useProgram(passProgram);
      passProgram.set("u_rect", glm::vec4(-1.0F, -1.0F, 1.0F, 1.0F));
      passProgram.set("u_color", glm::vec4(0.2F, 0.6F, 1.0F, 0.05F));
      passProgram.set("u_maskBit", 0.0F);
      cache.bindVertexArray(emptyVao.id());
      glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    });
  });
}

Sample LassoBench::select(LassoSeries::Row& row) {
  overlay::SelectionSettings measured;
  measured.measure = true;
  return timed([&] {
    row.stats = row.selection->select(cache, view, measured);
    return std::pair{row.stats.gpuMilliseconds, row.stats.fragments};
  });
}

Sample LassoBench::clear(LassoSeries::Row& row) {
  return timed([&] { return queried(timer, statistics, [&] { row.selection->clear(cache); }); });
}

/// One selection renderer per series and N, its volumes built once and warmed up; false when one
/// cannot be made.
bool LassoBench::buildRows(Lassos& l) {
  for (std::size_t n : l.counts) {
    for (LassoSeries& s : l.series) {
      Result<overlay::SelectionRenderer> selection = overlay::SelectionRenderer::create();
      app::report(selection.diagnostics);
      if (!selection) return false;
      LassoSeries::Row row;
      row.volumes = n;
      row.selection.emplace(std::move(*selection));
      app::report(row.selection->setSteps(stepsFor(l, s, n)));
      // Warm-up, with the queries on as measured (llvmpipe compiles shader variants for them).
      select(row);
      clear(row);
      s.rows.push_back(std::move(row));
    }
  }
  return true;
}

/// The repeats go round every series and N, so that a burst of load on a shared machine spreads
/// over every N instead of bending one point.
PassTimes LassoBench::measure(Lassos& l) {
  PassTimes p;
  fullScreenPass();
  for (int r = 0; r < o.repeats; ++r) {
    for (std::size_t i = 0; i < l.counts.size(); ++i) {
      for (LassoSeries& s : l.series) {
        LassoSeries::Row& row = s.rows[i];
        const Sample sample = select(row);
        add(row.ms, sample);
        row.fragments = sample.fragments;
        add(p.clearMs, clear(row));
        const Sample pass = fullScreenPass();  // interleaved: the same machine state
        add(row.passMs, pass);
        add(p.passMs, pass);
        p.passFragments = pass.fragments;
      }
    }
  }
  return p;
}

/// How the figures are reported: the headline clock, and the median full-screen pass of the whole
/// run that every figure is a ratio to.
struct Units {
  Clock headline = kGpu;
  std::array<double, kClocks> pass{};
  double passFragments = 1.0;
};

/// One series' medians over the repeats: volumes, time per clock, fragments.
struct SeriesMedians {
  std::vector<double> x, fragments;
  std::array<std::vector<double>, kClocks> y;
};

SeriesMedians mediansOf(const LassoSeries& s) {
  SeriesMedians m;
  for (const LassoSeries::Row& row : s.rows) {
    m.x.push_back(static_cast<double>(row.volumes));
    for (std::size_t c = 0; c < kClocks; ++c) m.y[c].push_back(percentile(row.ms[c], 50));
    m.fragments.push_back(static_cast<double>(row.fragments));
  }
  return m;
}

/// The series' table, printed and into lasso.csv; its rows for lasso.json.
json seriesRows(const LassoSeries& s, const SeriesMedians& m, const Units& u, std::ofstream& csv) {
  const std::vector<double>& t = m.y[u.headline];
  std::printf("\nseries %s (%s)\n%7s %9s %12s %8s %10s %9s %9s %12s %10s %7s\n", s.name.c_str(),
              s.name == "or" ? "Single, then Or" : "Single, then Or/Xor/Subtract/And at random", "volumes", "ms",
              "/ full pass", "/ N=1", "ms/volume", "gpu ms", "wall ms", "fragments", "/ full pass", "passes");
  json rows = json::array();
  for (std::size_t i = 0; i < s.rows.size(); ++i) {
    const LassoSeries::Row& row = s.rows[i];
    const double toOne = t[i] / t[0], perVolume = t[i] / m.x[i];
    const double fragmentPasses = m.fragments[i] / u.passFragments;
    std::printf("%7zu %9.3f %12.3f %8.2f %10.4f %9.3f %9.3f %12llu %10.3f %7zu\n", row.volumes, t[i],
                t[i] / u.pass[u.headline], toOne, perVolume, m.y[kGpu][i], m.y[kWall][i],
                static_cast<unsigned long long>(row.fragments), fragmentPasses, row.stats.screenPasses);
    csv << s.name << ',' << row.volumes;
    for (std::size_t c = 0; c < kClocks; ++c) csv << ',' << m.y[c][i];
    for (std::size_t c = 0; c < kClocks; ++c) csv << ',' << m.y[c][i] / u.pass[c];
    csv << ',' << toOne << ',' << perVolume << ',' << row.fragments << ',' << fragmentPasses << ','
        << row.stats.markDraws << ',' << row.stats.screenPasses << ',' << row.stats.triangles << '\n';
    json clocks;
    for (std::size_t c = 0; c < kClocks; ++c) {
      clocks[kClockNames[c]] = {{"median_ms", m.y[c][i]},
                                {"full_screen_passes", m.y[c][i] / u.pass[c]},
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
  return rows;
}

/// Time against volumes on each clock (the headline first), printed; the fits for lasso.json.
json timeFits(const SeriesMedians& m, const Units& u) {
  json fits;
  for (const std::size_t c :
       {static_cast<std::size_t>(u.headline), std::size_t{kGpu}, std::size_t{kCpu}, std::size_t{kWall}}) {
    if (fits.contains(kClockNames[c])) continue;
    const LinearFit f = fitLine(m.x, m.y[c]);
    fits[kClockNames[c]] = {{"slope_ms_per_volume", f.slope},
                            {"slope_full_screen_passes_per_volume", f.slope / u.pass[c]},
                            {"intercept_ms", f.intercept},
                            {"intercept_full_screen_passes", f.intercept / u.pass[c]},
                            {"r2", f.r2}};
    std::printf("fit %-4s ms = a + b*N: b = %.4f ms = %.4f full-screen passes per volume, a = %.3f ms, R2 = %.4f%s\n",
                kClockNames[c], f.slope, f.slope / u.pass[c], f.intercept, f.r2, c == u.headline ? "  <-" : "");
  }
  return fits;
}

/// One series: its table, its fits, and its entry in lasso.json.
json seriesJson(const LassoSeries& s, const Lassos& l, const Units& u, std::ofstream& csv) {
  const SeriesMedians m = mediansOf(s);
  std::map<std::string, std::size_t> opCounts;
  for (std::size_t i = 0; i < l.maxVolumes; ++i) ++opCounts[overlay::selectionOpName(s.ops[i])];
  const json rows = seriesRows(s, m, u, csv);
  const json fits = timeFits(m, u);
  const LinearFit fragmentFit = fitLine(m.x, m.fragments);
  std::printf("fit fragments = a + b*N: b = %.0f = %.4f full-screen passes per volume, a = %.0f, R2 = %.5f\n",
              fragmentFit.slope, fragmentFit.slope / u.passFragments, fragmentFit.intercept, fragmentFit.r2);
  return {{"name", s.name},
          {"operators", opCounts},
          {"rows", rows},
          {"fits", fits},
          {"fit_fragments",
           {{"slope_per_volume", fragmentFit.slope},
            {"slope_full_screen_passes_per_volume", fragmentFit.slope / u.passFragments},
            {"intercept", fragmentFit.intercept},
            {"r2", fragmentFit.r2}}}};
}

/// Medians over the repeats, as ratios to the median full-screen pass of the whole run: printed,
/// into lasso.csv, and the series for lasso.json.
json report(const Options& o, const Lassos& l, const PassTimes& p, const Units& u, const std::string& rendererName,
            bool onGlobe) {
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "lasso.csv");
  csv << "series,volumes,gpu_ms,cpu_ms,wall_ms,gpu_passes,cpu_passes,wall_passes,ratio_to_one_volume,ms_per_volume,"
         "fragments,fragment_passes,mark_draws,screen_passes,triangles\n";
  std::printf("lasso selection (%s frame), %dx%d, %s; times are %s ms (process CPU time on llvmpipe, else GPU timer)\n",
              onGlobe ? "globe" : "projected", o.width, o.height, rendererName.c_str(), kClockNames[u.headline]);
  std::printf("one full-screen pass: %.3f ms %s (gpu %.3f, cpu %.3f, wall %.3f ms), %llu fragments\n",
              u.pass[u.headline], kClockNames[u.headline], u.pass[kGpu], u.pass[kCpu], u.pass[kWall],
              static_cast<unsigned long long>(p.passFragments));
  json series = json::array();
  for (const LassoSeries& s : l.series) series.push_back(seriesJson(s, l, u, csv));
  return series;
}

/// Where the volumes are seen from: a projected camera's eye and target, or the globe's camera.json.
json cameraOf(const LassoBench& b) {
  json c = b.scene.cameraJson(b.camera, b.o.width, b.o.height);
  c["kind"] = b.cameraKind;
  return c;
}

json resultJson(const Options& o, const LassoBench& b, const Lassos& l, const PassTimes& p, const Units& u, json series,
                gfx::Context& context) {
  json passJson, clearJson;
  for (std::size_t c = 0; c < kClocks; ++c) {
    passJson[kClockNames[c]] = {{"median_ms", u.pass[c]}, {"p95_ms", percentile(p.passMs[c], 95)}};
    clearJson[kClockNames[c]] = {{"median_ms", percentile(p.clearMs[c], 50)}};
  }
  passJson["fragments"] = p.passFragments;
  passJson["samples"] = p.passMs[kGpu].size();
  const char* threads = std::getenv("LP_NUM_THREADS");
  const double screenPixels = static_cast<double>(o.width) * o.height;
  return {{"mode", o.mode},
          {"scene", o.scene},
          {"width", o.width},
          {"height", o.height},
          {"frame", b.scene.onGlobe() ? "globe" : "projected"},
          {"camera", cameraOf(b)},
          {"terrain_pixels_fraction", static_cast<double>(b.terrainPixels) / screenPixels},
          {"terrain_triangles", b.terrainFrame.terrain.triangles},
          {"scheme", "runs"},
          {"seed", kLassoSeed},
          {"repeats", o.repeats},
          {"headline_clock", kClockNames[u.headline]},
          {"lassos",
           {{"count", l.maxVolumes},
            {"mean_vertices", static_cast<double>(l.vertices) / static_cast<double>(l.maxVolumes)},
            {"mean_screen_fraction", l.areaFraction}}},
          {"full_screen_pass", passJson},
          {"stencil_clear_pass", clearJson},
          {"series", std::move(series)},
          {"renderer", context.info().renderer},
          {"lp_num_threads", threads != nullptr ? json(threads) : json(nullptr)},
          {"cpu_peak_bytes", processMemory("VmHWM")},
          {"gl_errors", context.debug().errorCount()}};
}

}  // namespace

int runLasso(const Options& o) {
  // The volumes select terrain; the layers are not drawn.
  std::optional<BenchSetup> setup = setUp(o, false);
  if (!setup) return 1;
  gfx::Context& context = *setup->context;
  scene::StillSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(setup->scene, settings);
  app::report(renderer.diagnostics);
  Result<gfx::Program> passProgram = gfx::Program::build({{"overlay_cover.vert", {}}, {"overlay_volume.frag", {}}});
  app::report(passProgram.diagnostics);
  if (!renderer || !passProgram) return 1;
  const std::string rendererName = context.info().renderer;

  LassoBench bench(o, *setup, **renderer, *passProgram);
  Lassos lassos = makeLassos(o);
  if (!bench.buildRows(lassos)) return 1;
  const PassTimes passes = bench.measure(lassos);

  Units units;
  units.headline = rendererName.find("llvmpipe") != std::string::npos ? kCpu : kGpu;
  for (std::size_t c = 0; c < kClocks; ++c) units.pass[c] = percentile(passes.passMs[c], 50);
  units.passFragments = static_cast<double>(std::max<std::uint64_t>(passes.passFragments, 1));
  json series = report(o, lassos, passes, units, rendererName, setup->scene.onGlobe());
  const json result = resultJson(o, bench, lassos, passes, units, std::move(series), context);
  std::ofstream(std::filesystem::path(o.out) / "lasso.json") << scene::jsonText(result) << '\n';
  std::printf("\ngl_errors: %zu; wrote %s\n", context.debug().errorCount(),
              (std::filesystem::path(o.out) / "lasso.json").string().c_str());
  return context.debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace gis::bench
