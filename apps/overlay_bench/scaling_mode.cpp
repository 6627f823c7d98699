// overlay_bench --mode scaling: how start time, memory and frame time grow with the vector load
// (and the DEM), scene by scene of --scenes, against the terrain alone.
// - Start time and memory come from fresh processes, as a user meets them: overlay_render draws
//   the scene's still frame twice in a row with the same arguments, "cold" (the scene's cached
//   vector tiles and layers removed and its files dropped from the page cache first, so read
//   from the disk and built as on a first run after a reboot) and "warm" (straight after); its stats.json gives the
//   time to the first frame, the peak RSS and the GPU memory. Terrain only is overlay_render --overlays off: the layers
//   are not even read.
// - Frame time comes from this process: every method draws the same frames of the methods path
//   in turn (variants.cpp), and per segment of the path the median frame time and the median
//   ratio to terrain only on the same frames are kept.
// The methods: terrain only, the tiled stencil technique at every scale, and the techniques that
// build every piece of every feature at load ("whole-load") only on scenes of at most
// --whole-load-max-vertices vector vertices: above, their memory outgrows the machine. Methods are
// found by what they are in the registry, never by their place in it.
// Writes scaling.md (the tables), scaling.json (everything), the plots, and per scene the frames'
// own tables (DIR/<scene>/frames.*) and the start runs' stats.json and logs (DIR/<scene>/start/).
#include "scaling_mode.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "scene/json_file.hpp"
#include "scene/scene_loader.hpp"
#include "svg_plot.hpp"
#include "variants.hpp"

namespace gis::bench {
namespace {

namespace fs = std::filesystem;

constexpr const char* kTerrainOnly = "terrain only";
constexpr const char* kTerrainColour = "#7f7f7f";
constexpr const char* kTooBig = "not run: whole-load at this size needs more memory than the machine has";
/// The segments of a projected scene's methods path, in the order it flies them.
constexpr const char* kSegments[] = {"top-down", "oblique", "horizon", "close-up"};

struct ScalingMethod {
  std::string name;  ///< "terrain only", or the technique's name
  const overlay::TechniqueInfo* technique = nullptr;
  bool overlays = true;
  bool wholeLoad = false;  ///< builds every piece of every feature at load
  [[nodiscard]] std::string colour() const { return overlays ? std::string(technique->plotColour) : kTerrainColour; }
};

/// Terrain only, then the stencil techniques that build per tile, then the whole-load ones: the
/// tiled run tells the scene's vector vertices before a whole-load technique is given the scene.
std::vector<ScalingMethod> scalingMethods() {
  std::vector<ScalingMethod> methods{{kTerrainOnly, &overlay::defaultTechnique(), false, false}};
  for (const bool wholeLoad : {false, true}) {
    for (const overlay::TechniqueInfo& t : overlay::techniques()) {
      if (t.usesTextures() || (t.construction != overlay::PieceConstruction::Tiled) != wholeLoad) continue;
      methods.push_back({std::string(t.name), &t, true, wholeLoad});
    }
  }
  return methods;
}

/// What one overlay_render run gave (its stats.json).
struct StillRun {
  std::string problem;   ///< empty when it ran and wrote its stats
  double seconds = 0.0;  ///< the process, start to exit, as waited for here
  double firstFrameSeconds = 0.0, loadSeconds = 0.0;
  std::size_t peakRssBytes = 0, terrainGpuBytes = 0;
  std::size_t overlayGpuBytes = 0;  ///< the layers' buffers and what the technique holds beyond them
  double terrainGpuMs = 0.0, overlayGpuMs = 0.0;
  std::size_t vectorVertices = 0, demPosts = 0;
  std::uintmax_t droppedBytes = 0;  ///< cold run: the scene's files dropped from the page cache first
  [[nodiscard]] bool ok() const { return problem.empty(); }
};

/// One method's start on one scene: both runs, or why it was not run.
struct StartFigures {
  ScalingMethod method;
  std::string notRun;
  StillRun cold, warm;
};

struct SceneResult {
  std::string scene, stem;
  std::optional<std::size_t> vectorVertices;
  std::size_t demPosts = 0;
  std::vector<StartFigures> start;
  json frames;  ///< runVariants' result; null when the frames could not be drawn
};

double megabytes(double bytes) { return bytes / 1048576.0; }

std::string fixed(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, v);
  return text;
}

std::string slug(std::string name) {
  std::replace(name.begin(), name.end(), ' ', '-');
  return name;
}

/// The overlay_render of --overlay-render, or the one built beside this program (the same build
/// directory: apps/), or in a layout of one directory per program; nothing when none can run.
std::optional<fs::path> findOverlayRender(const ScalingOptions& s) {
  if (!s.overlayRender.empty()) {
    if (::access(s.overlayRender.c_str(), X_OK) == 0) return fs::path(s.overlayRender);
    std::fprintf(stderr, "overlay_bench: --overlay-render %s: not an executable\n", s.overlayRender.c_str());
    return std::nullopt;
  }
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = self.parent_path();
    for (const fs::path& candidate : {dir / "overlay_render", dir / ".." / "overlay_render" / "overlay_render"}) {
      if (::access(candidate.c_str(), X_OK) == 0) return candidate.lexically_normal();
    }
  }
  std::fprintf(stderr, "overlay_bench: no overlay_render beside %s: build it, or give --overlay-render PATH\n",
               ec ? "this program" : self.c_str());
  return std::nullopt;
}

/// The files a run of the scene reads: the scene file, the DEM, the layers' sources, the imagery
/// and the tile pyramids of a paged DEM (folders are walked). Connection strings are left out.
std::vector<fs::path> sceneFiles(const scene::SceneDescription& d) {
  std::vector<fs::path> paths{d.path};
  for (const std::string& p : d.demPaths.empty() ? std::vector<std::string>{d.dem} : d.demPaths) paths.emplace_back(p);
  for (const scene::LayerDescription& l : d.layers) paths.emplace_back(l.source);
  if (d.imagery) paths.emplace_back(*d.imagery);
  paths.push_back(d.cacheDir.empty() ? fs::path(d.path).parent_path() / ".stencil-gis-cache" : fs::path(d.cacheDir));
  std::vector<fs::path> files;
  for (const fs::path& p : paths) {
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      for (const fs::directory_entry& e :
           fs::recursive_directory_iterator(p, fs::directory_options::skip_permission_denied, ec)) {
        if (e.is_regular_file(ec)) files.push_back(e.path());
      }
    } else if (fs::is_regular_file(p, ec)) {
      files.push_back(p);
    }
  }
  return files;
}

/// Drops the files' pages from the page cache (written back first: a dirty page would stay), so
/// that the next run reads them from the disk; the bytes of the files it could drop.
std::uintmax_t dropFromPageCache(const std::vector<fs::path>& files) {
  std::uintmax_t bytes = 0;
  for (const fs::path& file : files) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue;
    (void)::fdatasync(fd);
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(file, ec);
    if (::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED) == 0 && !ec) bytes += size;
    ::close(fd);
  }
  return bytes;
}

/// Runs `args` (args[0] the program) with its standard output and error into `log`, and waits for
/// it; empty when it exited with status 0, else what became of it.
std::string runProcess(const std::vector<std::string>& args, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));  // posix_spawn's C signature
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int error = ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (error != 0) return "cannot start " + args[0] + ": " + std::strerror(error);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return std::string("lost the process: ") + std::strerror(errno);
  }
  if (WIFSIGNALED(status)) {
    // SIGKILL is most likely the kernel's out-of-memory killer.
    const int number = WTERMSIG(status);
    return "killed by signal " + std::to_string(number) + (number == SIGKILL ? " (out of memory?)" : "");
  }
  if (WEXITSTATUS(status) != 0) return "exit status " + std::to_string(WEXITSTATUS(status));
  return {};
}

/// The figures of an overlay_render stats.json into `run`.
void readStats(const json& stats, StillRun& run) {
  run.firstFrameSeconds = stats.value("first_frame_seconds", 0.0);
  run.loadSeconds = stats.value("load_seconds", 0.0);
  run.peakRssBytes = stats.value("cpu_peak_bytes", std::size_t{0});
  const json terrain = stats.value("terrain", json::object());
  run.terrainGpuBytes = terrain.value("gpu_bytes", std::size_t{0});
  run.demPosts = terrain.value("posts", std::size_t{0});
  run.terrainGpuMs = stats.value("passes", json::object()).value("terrain", json::object()).value("gpu_ms", 0.0);
  // The same keys in both frames (overlay_render's stats.json).
  run.vectorVertices = stats.value("vector_vertices", std::size_t{0});
  std::size_t passBytes = 0;
  for (const json& layer : stats.value("layers", json::array())) {
    for (const json& pass : layer.value("passes", json::array())) {
      passBytes += pass.value("gpu_bytes", std::size_t{0});
      run.overlayGpuMs += pass.value("gpu_ms", 0.0);
    }
  }
  // A tiled technique's passes count the tiles that drew them, which its "tiles" block holds
  // among every resident tile: those once (before 2026-11-30 they were counted twice). Then what
  // the technique holds beyond them: a drape, the lookup's indices.
  run.overlayGpuBytes = std::max(passBytes, stats.value("tiles", json::object()).value("gpu_bytes", std::size_t{0}));
  for (const char* block : {"drape", "deferred"}) {
    run.overlayGpuBytes += stats.value(block, json::object()).value("gpu_bytes", std::size_t{0});
  }
}

/// How one scene's start runs are made: overlay_render, into a temporary directory, the stats and
/// logs kept in `keep`.
struct StillRunner {
  const Options& o;
  fs::path exe, keep, scratch;
  std::vector<fs::path> files;  ///< of the scene, dropped from the page cache before a cold run
  /// The scene's caches of derived data removed before a cold run: vector tiles and layers as read.
  std::vector<fs::path> caches;

  StillRun run(const ScalingMethod& m, bool cold) const;
};

StillRun StillRunner::run(const ScalingMethod& m, bool cold) const {
  const std::string name = slug(m.name) + (cold ? "-cold" : "-warm");
  const fs::path out = scratch / name;
  std::vector<std::string> args{exe.string(),
                                "--scene",
                                o.scene,
                                "--width",
                                std::to_string(o.width),
                                "--height",
                                std::to_string(o.height),
                                "--lod-tolerance",
                                fixed(o.lodTolerance, 6),
                                "--out",
                                out.string()};
  if (o.msaa > 1) args.insert(args.end(), {"--msaa", std::to_string(o.msaa)});
  if (m.overlays) {
    args.insert(args.end(), {"--method", std::string(m.technique->name)});
  } else {
    args.insert(args.end(), {"--overlays", "off"});
  }
  StillRun r;
  if (cold) {
    std::error_code removed;
    for (const fs::path& c : caches) fs::remove_all(c, removed);
    r.droppedBytes = dropFromPageCache(files);
  }
  std::printf("scaling: %s, %s %s\n", o.scene.c_str(), m.name.c_str(), cold ? "cold" : "warm");
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  r.problem = runProcess(args, keep / (name + ".log"));
  r.seconds = msSince(start) / 1e3;
  std::error_code ec;
  if (r.ok()) {
    std::ifstream in(out / "stats.json");
    const json stats = json::parse(in, nullptr, false);
    if (stats.is_object()) {
      readStats(stats, r);
      fs::copy_file(out / "stats.json", keep / (name + ".stats.json"), fs::copy_options::overwrite_existing, ec);
    } else {
      r.problem = "no stats.json";
    }
  }
  if (!r.ok()) {
    std::fprintf(stderr, "overlay_bench: %s on %s: %s (log: %s)\n", name.c_str(), o.scene.c_str(), r.problem.c_str(),
                 (keep / (name + ".log")).c_str());
  }
  fs::remove_all(out, ec);  // the images: only the figures are wanted
  return r;
}

/// A new private directory under the system's temporary one; nothing if it cannot be made.
std::optional<fs::path> scratchDirectory() {
  std::string pattern = (fs::temp_directory_path() / "overlay_bench_scaling_XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) return std::nullopt;
  return fs::path(pattern);
}

/// Every method's start runs on the scene of `runner.o`, cold then warm; a whole-load technique
/// only when the vector vertices (from an earlier run) are known and within the limit.
std::vector<StartFigures> startRuns(const StillRunner& runner, const ScalingOptions& s,
                                    std::optional<std::size_t>& vertices, std::size_t& demPosts) {
  std::vector<StartFigures> all;
  for (const ScalingMethod& m : scalingMethods()) {
    StartFigures f{m, {}, {}, {}};
    if (m.wholeLoad && !vertices) {
      f.notRun = "not run: the vector vertices are unknown (no tiled run gave them)";
    } else if (m.wholeLoad && *vertices > static_cast<std::size_t>(s.wholeLoadMaxVertices)) {
      f.notRun = std::string(kTooBig) + " (over " + std::to_string(s.wholeLoadMaxVertices) + " vector vertices)";
    } else {
      f.cold = runner.run(m, true);
      f.warm = runner.run(m, false);
      for (const StillRun* r : {&f.cold, &f.warm}) {
        if (!r->ok()) continue;
        demPosts = r->demPosts;
        if (m.overlays && !vertices) vertices = r->vectorVertices;
      }
    }
    all.push_back(std::move(f));
  }
  return all;
}

/// The method's figures in runVariants' result; null when it was not drawn.
const json* framesOf(const json& frames, const std::string& method) {
  if (!frames.is_object() || !frames.contains("methods")) return nullptr;
  for (const json& m : frames.at("methods")) {
    if (m.value("method", "") == method) return &m;
  }
  return nullptr;
}

/// Median frame time and ratio to terrain only on one segment (or "all": the whole path); nothing
/// when the method has no timed frame there.
std::optional<std::pair<double, double>> segmentFigures(const json& frames, const std::string& method,
                                                        const std::string& segment) {
  const json* m = framesOf(frames, method);
  if (m == nullptr) return std::nullopt;
  const json& t = segment == "all" ? *m : m->value("segments", json::object()).value(segment, json());
  if (!t.is_object() || t.value("median_ms", 0.0) <= 0.0) return std::nullopt;
  return std::make_pair(t.value("median_ms", 0.0), t.value("over_terrain_median", 0.0));
}

/// The segments the methods flew over a scene (methods.json): a projected scene's in the order of
/// its path, then any other (the globe's path has segments of its own), by name.
std::vector<std::string> segmentsOf(const json& frames) {
  std::vector<std::string> out;
  const json* terrain = framesOf(frames, kTerrainOnly);
  if (terrain == nullptr) return out;
  const json segments = terrain->value("segments", json::object());
  for (const char* known : kSegments) {
    if (segments.contains(known)) out.emplace_back(known);
  }
  for (const auto& [name, figures] : segments.items()) {
    if (std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
  }
  return out;
}

/// The figures of one run in scaling.json.
json stillJson(const StillRun& r) {
  if (!r.ok()) return {{"problem", r.problem}, {"seconds", r.seconds}};
  return {{"first_frame_s", r.firstFrameSeconds},
          {"load_s", r.loadSeconds},
          {"process_s", r.seconds},
          {"cpu_peak_bytes", r.peakRssBytes},
          {"terrain_gpu_bytes", r.terrainGpuBytes},
          {"overlay_gpu_bytes", r.overlayGpuBytes},
          {"terrain_gpu_ms", r.terrainGpuMs},
          {"overlay_gpu_ms", r.overlayGpuMs},
          {"dropped_from_page_cache_bytes", r.droppedBytes}};
}

json sceneJson(const SceneResult& r) {
  json start = json::array();
  for (const StartFigures& f : r.start) {
    json e = {{"method", f.method.name}, {"overlays", f.method.overlays}, {"whole_load", f.method.wholeLoad}};
    if (!f.notRun.empty()) {
      e["not_run"] = f.notRun;
    } else {
      e["cold"] = stillJson(f.cold);
      e["warm"] = stillJson(f.warm);
    }
    start.push_back(e);
  }
  json segments = json::object();
  for (const std::string& segment : segmentsOf(r.frames)) {
    for (const StartFigures& f : r.start) {
      if (const auto s = segmentFigures(r.frames, f.method.name, segment)) {
        segments[segment][f.method.name] = {{"median_ms", s->first}, {"over_terrain_median", s->second}};
      }
    }
  }
  return {{"scene", r.scene},           {"vector_vertices", r.vectorVertices ? json(*r.vectorVertices) : json(nullptr)},
          {"dem_posts", r.demPosts},    {"start", start},
          {"frame_segments", segments}, {"frames", r.frames}};
}

/// The start table: one row per scene and method.
std::string startTable(const std::vector<SceneResult>& results) {
  std::string md =
      "| scene | vector vertices | DEM posts | method | cold first frame s | warm first frame s | × terrain only "
      "cold / warm | peak RSS MB | terrain GPU MB | overlay GPU MB | still GPU ms terrain / overlay |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SceneResult& r : results) {
    const std::string head = "| " + r.stem + " | " + (r.vectorVertices ? std::to_string(*r.vectorVertices) : "?") +
                             " | " + std::to_string(r.demPosts) + " | ";
    const StillRun* terrainCold = nullptr;
    const StillRun* terrainWarm = nullptr;
    for (const StartFigures& f : r.start) {
      if (!f.method.overlays) {
        terrainCold = &f.cold;
        terrainWarm = &f.warm;
      }
    }
    for (const StartFigures& f : r.start) {
      md += head + f.method.name + " | ";
      const std::string problem = !f.notRun.empty() ? f.notRun : !f.cold.ok() ? "failed: " + f.cold.problem : "";
      if (!problem.empty()) {
        md += problem + " | — | — | — | — | — | — |\n";
        continue;
      }
      const auto over = [](const StillRun& a, const StillRun* base) {
        return base != nullptr && base->ok() && base->firstFrameSeconds > 0.0
                   ? fixed(a.firstFrameSeconds / base->firstFrameSeconds, 2)
                   : std::string("—");
      };
      const bool warm = f.warm.ok();
      md += fixed(f.cold.firstFrameSeconds, 2) + " | " +
            (warm ? fixed(f.warm.firstFrameSeconds, 2) : "failed: " + f.warm.problem) + " | " +
            over(f.cold, terrainCold) + " / " + (warm ? over(f.warm, terrainWarm) : "—") + " | " +
            fixed(megabytes(static_cast<double>(std::max(f.cold.peakRssBytes, warm ? f.warm.peakRssBytes : 0))), 0) +
            " | " + fixed(megabytes(static_cast<double>(f.cold.terrainGpuBytes)), 1) + " | " +
            (f.method.overlays ? fixed(megabytes(static_cast<double>(f.cold.overlayGpuBytes)), 1) : "—") + " | " +
            fixed(f.cold.terrainGpuMs, 1) + " / " + (f.method.overlays ? fixed(f.cold.overlayGpuMs, 1) : "—") + " |\n";
    }
  }
  return md;
}

/// The frame table: one row per scene and path segment, terrain only then each method's time and
/// ratio.
std::string framesTable(const std::vector<SceneResult>& results) {
  const std::vector<ScalingMethod> methods = scalingMethods();
  std::string md = "| scene | vector vertices | segment | terrain only ms |";
  std::string rule = "|---|---|---|---|";
  for (const ScalingMethod& m : methods) {
    if (!m.overlays) continue;
    md += " " + m.name + " ms | × terrain |";
    rule += "---|---|";
  }
  md += "\n" + rule + "\n";
  for (const SceneResult& r : results) {
    if (!r.frames.is_object()) {
      md += "| " + r.stem + " | " + (r.vectorVertices ? std::to_string(*r.vectorVertices) : "?") +
            " | — | failed (see the output) |" + std::string(2 * (methods.size() - 1), '|') + "\n";
      continue;
    }
    for (const std::string& segment : segmentsOf(r.frames)) {
      const auto terrain = segmentFigures(r.frames, kTerrainOnly, segment);
      if (!terrain) continue;  // not on the path (--segments), or no timed frame on it
      md += "| " + r.stem + " | " + (r.vectorVertices ? std::to_string(*r.vectorVertices) : "?") + " | " + segment +
            " | " + fixed(terrain->first, 1) + " |";
      for (const ScalingMethod& m : methods) {
        if (!m.overlays) continue;
        const auto s = segmentFigures(r.frames, m.name, segment);
        md += s ? " " + fixed(s->first, 1) + " | " + fixed(s->second, 3) + " |"
                : std::string(framesOf(r.frames, m.name) != nullptr ? " — | — |" : " not run | — |");
      }
      md += "\n";
    }
  }
  return md;
}

/// The plots: per method, against vector vertices (log), and the frame time against DEM posts.
/// Each method is labelled once, at its last point.
void writePlots(const fs::path& out, const std::vector<SceneResult>& results) {
  struct Series {
    std::string file, title, xLabel, yLabel;
    bool logY = false, byPosts = false;
    double (*value)(const SceneResult&, const StartFigures&, bool& has);
  };
  const Series series[] = {
      {"scaling_first_frame_cold_vs_vertices.svg", "Cold start: first frame against vector vertices", "vector vertices",
       "seconds from the start to the first frame, cold", true, false,
       [](const SceneResult&, const StartFigures& f, bool& has) {
         has = f.notRun.empty() && f.cold.ok();
         return f.cold.firstFrameSeconds;
       }},
      {"scaling_first_frame_warm_vs_vertices.svg", "Warm start: first frame against vector vertices", "vector vertices",
       "seconds from the start to the first frame, warm", true, false,
       [](const SceneResult&, const StartFigures& f, bool& has) {
         has = f.notRun.empty() && f.warm.ok();
         return f.warm.firstFrameSeconds;
       }},
      {"scaling_peak_rss_vs_vertices.svg", "Peak resident memory against vector vertices", "vector vertices",
       "peak RSS to the first frame, MB", true, false,
       [](const SceneResult&, const StartFigures& f, bool& has) {
         has = f.notRun.empty() && f.cold.ok();
         return megabytes(static_cast<double>(std::max(f.cold.peakRssBytes, f.warm.ok() ? f.warm.peakRssBytes : 0)));
       }},
      {"scaling_frame_ratio_vs_vertices.svg", "Frame time over terrain only against vector vertices", "vector vertices",
       "median frame time / terrain only, same frame (whole path)", false, false,
       [](const SceneResult& r, const StartFigures& f, bool& has) {
         const auto s = segmentFigures(r.frames, f.method.name, "all");
         has = f.method.overlays && s.has_value();
         return s ? s->second : 0.0;
       }},
      {"scaling_time_vs_vertices.svg", "Frame time against vector vertices", "vector vertices",
       "median frame time, ms (whole path)", false, false,
       [](const SceneResult& r, const StartFigures& f, bool& has) {
         const auto s = segmentFigures(r.frames, f.method.name, "all");
         has = s.has_value();
         return s ? s->first : 0.0;
       }},
      {"scaling_time_vs_dem.svg", "Frame time against DEM size", "DEM posts", "median frame time, ms (whole path)",
       false, true, [](const SceneResult& r, const StartFigures& f, bool& has) {
         const auto s = segmentFigures(r.frames, f.method.name, "all");
         has = s.has_value();
         return s ? s->first : 0.0;
       }}};
  for (const Series& s : series) {
    std::vector<PlotPoint> points;
    for (const ScalingMethod& m : scalingMethods()) {
      std::size_t last = points.size();
      double lastX = -1.0;
      for (const SceneResult& r : results) {
        const double x =
            s.byPosts ? static_cast<double>(r.demPosts) : static_cast<double>(r.vectorVertices ? *r.vectorVertices : 0);
        if (!(x > 0.0)) continue;
        for (const StartFigures& f : r.start) {
          bool has = false;
          const double y = f.method.name == m.name ? s.value(r, f, has) : 0.0;
          if (!has) continue;
          if (x >= lastX) {
            last = points.size();
            lastX = x;
          }
          points.push_back({x, y, "", m.colour()});
        }
      }
      if (last < points.size()) points[last].label = m.name;
    }
    PlotAxes axes;
    axes.title = s.title;
    axes.xLabel = s.xLabel;
    axes.yLabel = s.yLabel;
    axes.logX = true;
    axes.logY = s.logY;
    std::ofstream(out / s.file) << scatterSvg(points, axes);
  }
}

/// scaling.md: what was measured, the start table and the frame table.
void writeMarkdown(const Options& o, const ScalingOptions& s, const std::vector<SceneResult>& results) {
  std::ofstream md(fs::path(o.out) / "scaling.md");
  md << "Start time and memory: overlay_render's still of the scene's home view at " << o.width << " × " << o.height
     << ", each method in a process of its own, run twice: cold (the scene's cached vector tiles and "
        "layers removed and its files dropped from the page cache first) and warm (straight after). First frame: from "
        "the start of the process to the frame read back; peak "
        "RSS: the larger of the two runs (with a software rasteriser such as llvmpipe, GPU buffers are in it too); "
        "overlay GPU MB: the layers' "
        "buffers or the technique's resident tiles (once), a drape's textures and the lookup's indices. Techniques "
        "that build every piece at load (whole-load) are run "
        "up to "
     << s.wholeLoadMaxVertices << " vector vertices.\n\n"
     << startTable(results) << "\nFrame time per path segment: " << o.frames
     << " fly-through frames and the close-ups (the first frame untimed), every method in turn on each frame in one "
        "process; median frame time, and the median of each frame's time over terrain only's on the same frame.\n\n"
     << framesTable(results);
}

/// The options of one scene's runs: its file, and its own folder of the output.
Options sceneOptions(const Options& o, const SceneResult& r) {
  Options so = o;
  so.scene = r.scene;
  so.out = (fs::path(o.out) / r.stem).string();
  return so;
}

/// The frames of one scene, every method of `start` that ran drawn in this process.
json drawFrames(const Options& so, const std::vector<StartFigures>& start, int& status) {
  std::vector<Method> methods;
  for (const StartFigures& f : start) {
    if (f.notRun.empty()) methods.emplace_back(f.method.name, *f.method.technique, 0, f.method.overlays);
  }
  json r;
  if (runVariants(so, std::move(methods), "frames", &r) != 0) {
    std::fprintf(stderr, "overlay_bench: the frames of %s failed\n", so.scene.c_str());
    status = 1;
  }
  return r.is_object() ? r : json(nullptr);
}

}  // namespace

int runScaling(const Options& o, const ScalingOptions& s) {
  const std::optional<fs::path> exe = findOverlayRender(s);
  if (!exe) return 1;
  const std::optional<fs::path> scratch = scratchDirectory();
  if (!scratch) {
    std::fprintf(stderr, "overlay_bench: cannot make a temporary directory: %s\n", std::strerror(errno));
    return 1;
  }
  // Every start run before any frame is drawn here: a child started with posix_spawn (vfork)
  // inherits this process's peak RSS through exec (getrusage's ru_maxrss, which overlay_render
  // reports), so this process must still be small when it starts them.
  int status = 0;
  std::vector<SceneResult> results;
  for (const std::string& sceneFile : o.scenes) {
    Result<scene::SceneDescription> description = scene::loadSceneFile(sceneFile);
    app::report(description.diagnostics);
    if (!description) {
      status = 1;
      continue;
    }
    SceneResult r;
    r.scene = sceneFile;
    r.stem = fs::path(sceneFile).stem().string();
    // Two scenes of one name in different folders keep apart.
    for (int n = 2; std::any_of(results.begin(), results.end(), [&](const SceneResult& e) { return e.stem == r.stem; });
         ++n) {
      r.stem = fs::path(sceneFile).stem().string() + "-" + std::to_string(n);
    }
    const Options so = sceneOptions(o, r);
    fs::create_directories(fs::path(so.out) / "start");
    const fs::path cacheDir = scene::cacheDirectoryFor(*description);
    const StillRunner runner{so,
                             *exe,
                             fs::path(so.out) / "start",
                             *scratch,
                             sceneFiles(*description),
                             {cacheDir / "vector-tiles", cacheDir / "vector-layers"}};
    r.start = startRuns(runner, s, r.vectorVertices, r.demPosts);
    results.push_back(std::move(r));
  }
  const std::size_t spawnerPeakBytes = processMemory("VmHWM");
  std::error_code ec;
  fs::remove_all(*scratch, ec);
  for (SceneResult& r : results) {
    r.frames = drawFrames(sceneOptions(o, r), r.start, status);
    if (r.frames.is_object()) {
      if (!r.vectorVertices) r.vectorVertices = r.frames.value("vector_vertices", std::size_t{0});
      if (r.demPosts == 0) r.demPosts = r.frames.value("dem_posts", std::size_t{0});
    }
  }
  writeMarkdown(o, s, results);
  writePlots(o.out, results);
  json scenes = json::array();
  for (const SceneResult& r : results) scenes.push_back(sceneJson(r));
  const json all = {{"mode", "scaling"},
                    {"width", o.width},
                    {"height", o.height},
                    {"frames", o.frames},
                    {"whole_load_max_vertices", s.wholeLoadMaxVertices},
                    {"overlay_render", exe->string()},
                    {"start_runs_spawned_at_peak_rss_bytes", spawnerPeakBytes},
                    {"scenes", scenes}};
  std::ofstream(fs::path(o.out) / "scaling.json") << scene::jsonText(all) << '\n';
  std::printf("scaling: %s\n", (fs::path(o.out) / "scaling.md").string().c_str());
  return status;
}

int runScaling(const Options& o) { return runScaling(o, ScalingOptions{}); }

}  // namespace gis::bench
