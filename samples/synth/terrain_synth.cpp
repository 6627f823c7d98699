// terrain_synth: writes a deterministic synthetic DEM (Float32 GeoTIFF) with fractal relief,
// vertical cliffs, isolated spikes, flat plains and nodata holes for the terrain engine's stiff
// cases and the benchmark; optionally a scene file that shows it.
#include <charconv>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "synth/synthetic_dem.hpp"
#include "synth/synthetic_vectors.hpp"

namespace {

namespace fs = std::filesystem;
using gis::synth::SyntheticDemOptions;
using gis::synth::SyntheticDemSummary;

constexpr const char* kUsage =
    "usage: terrain_synth --out FILE.tif [--size N] [--seed S] [--spacing M] [--relief M]\n"
    "                     [--no-cliffs] [--no-spikes] [--no-plains] [--no-holes] [--nodata-border]\n"
    "                     [--crs CRS [--origin X,Y]] [--scene SCENE.json [--vector-scale K\n"
    "                     [--vectors-only]] [--road-width M]]\n"
    "Writes a deterministic synthetic DEM: N x N posts (default 1025, 33 .. 65537) of fractal\n"
    "relief (--relief metres, default 600) at --spacing CRS units (default 20), EPSG:32633 unless\n"
    "--crs; --origin is the top-left corner (default 500000,5000000; in a geographic CRS such as\n"
    "EPSG:4326 the defaults are 6,50 and 3 arc-seconds, as an SRTM tile), with vertical cliffs (>= 300 m), single-post "
    "spikes (>= 500 m), perfectly flat plains\n"
    "and nodata holes placed from --seed (default 1). --nodata-border makes everything outside an\n"
    "irregular boundary nodata. --scene also writes a scene file for overlay_render and\n"
    "terrain_viewer. --vector-scale K also writes K times the seed paper's vector load (K x 8 areas\n"
    "with 151 points each, K x 144 roads with 18,800 points per 144, --road-width metres wide,\n"
    "default 10) as SCENE_areas.gpkg and SCENE_roads.gpkg next to the scene, as its two layers;\n"
    "with --vectors-only the DEM written before with the same options is kept.\n"
    "Exit status: 0 ok, 1 I/O error, 2 bad arguments.\n";

struct Options {
  SyntheticDemOptions dem;
  std::string out;
  std::string scene;
  int vectorScale = 0;       ///< 0: no vector layers
  bool vectorsOnly = false;  ///< the DEM at --out exists: write only the vectors and the scene
  double roadWidth = 10.0;
};

template <typename T>
std::optional<T> parseNumber(std::string_view text) {
  T value{};
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

/// Returns an error message, or an empty string when the options are good.
std::string parseArgs(int argc, char** argv, Options& o) {
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  bool spacingGiven = false, originGiven = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view a = args[i];
    auto value = [&]() -> std::optional<std::string_view> {
      if (i + 1 >= args.size()) return std::nullopt;
      return args[++i];
    };
    auto setString = [&](std::string& target) {
      const auto v = value();
      if (!v || v->empty()) return std::string(a) + " needs a value";
      target = std::string(*v);
      return std::string();
    };
    auto setNumber = [&](auto& target, const char* what) {
      const auto v = value();
      using T = std::remove_reference_t<decltype(target)>;
      const std::optional<T> n = v ? parseNumber<T>(*v) : std::nullopt;
      if (!n) return std::string(a) + " needs " + what + (v ? ", not '" + std::string(*v) + "'" : std::string());
      target = *n;
      return std::string();
    };
    std::string error;
    if (a == "--out")
      error = setString(o.out);
    else if (a == "--scene")
      error = setString(o.scene);
    else if (a == "--crs")
      error = setString(o.dem.crs);
    else if (a == "--size")
      error = setNumber(o.dem.size, "an integer");
    else if (a == "--seed")
      error = setNumber(o.dem.seed, "an unsigned 64-bit integer");
    else if (a == "--spacing") {
      error = setNumber(o.dem.spacing, "a number");
      spacingGiven = true;
    } else if (a == "--origin") {
      const auto v = value();
      const std::string text = v ? std::string(*v) : std::string();
      const std::size_t comma = text.find(',');
      const auto x =
          comma == std::string::npos ? std::nullopt : parseNumber<double>(std::string_view(text).substr(0, comma));
      const auto y =
          comma == std::string::npos ? std::nullopt : parseNumber<double>(std::string_view(text).substr(comma + 1));
      if (!x || !y) {
        error = "--origin needs X,Y (the top-left corner in CRS units), not '" + text + "'";
      } else {
        o.dem.originX = *x;
        o.dem.originY = *y;
        originGiven = true;
      }
    } else if (a == "--relief")
      error = setNumber(o.dem.reliefMetres, "a number");
    else if (a == "--no-cliffs")
      o.dem.cliffs = false;
    else if (a == "--no-spikes")
      o.dem.spikes = false;
    else if (a == "--no-plains")
      o.dem.plains = false;
    else if (a == "--no-holes")
      o.dem.nodataHoles = false;
    else if (a == "--nodata-border")
      o.dem.nodataBorder = true;
    else if (a == "--vector-scale")
      error = setNumber(o.vectorScale, "an integer");
    else if (a == "--vectors-only")
      o.vectorsOnly = true;
    else if (a == "--road-width")
      error = setNumber(o.roadWidth, "a number");
    else
      error = "unknown argument '" + std::string(a) + "'";
    if (!error.empty()) return error;
  }
  if (o.out.empty()) return "--out is required";
  if (!o.dem.crs.empty() && gis::synth::isGeographicCrs(o.dem.crs)) {
    // Longitude/latitude: an SRTM-like tile unless told otherwise.
    if (!spacingGiven) o.dem.spacing = gis::synth::kGeographicSpacing;
    if (!originGiven) {
      o.dem.originX = gis::synth::kGeographicOriginX;
      o.dem.originY = gis::synth::kGeographicOriginY;
    }
  }
  if (o.vectorScale != 0 && o.scene.empty()) return "--vector-scale needs --scene";
  if (o.vectorScale != 0 && (o.vectorScale < 1 || o.vectorScale > 10000)) return "--vector-scale must be 1 .. 10000";
  if (o.vectorsOnly && o.vectorScale == 0) return "--vectors-only needs --vector-scale";
  if (!(o.roadWidth > 0.0)) return "--road-width must be positive";
  return gis::synth::checkSyntheticDemOptions(o.dem);
}

/// "[#########               ]  37%" on stderr, redrawn when the percentage changes.
class ProgressBar {
 public:
  void operator()(double fraction) {
    const int percent = static_cast<int>(fraction * 100.0);
    if (percent == last_) return;
    last_ = percent;
    const auto filled = static_cast<std::size_t>(percent) * kWidth / 100;
    std::fprintf(stderr, "\r[%s%s] %3d%%", std::string(filled, '#').c_str(), std::string(kWidth - filled, ' ').c_str(),
                 percent);
    std::fflush(stderr);
  }
  void finish() const {
    if (last_ >= 0) std::fputc('\n', stderr);
  }

 private:
  static constexpr std::size_t kWidth = 40;
  int last_ = -1;
};

/// `path` named relative to the scene's folder when it can be.
std::string relativeToScene(const Options& o, const std::string& path) {
  std::error_code ec;
  fs::path p = fs::relative(fs::absolute(path), fs::absolute(o.scene).parent_path(), ec);
  if (ec || p.empty()) p = fs::absolute(path);
  return p.generic_string();
}

/// The scene file: the DEM, named relative to the scene's folder, and the vector layers if any
/// (the seed paper's look: semi-transparent yellow habitation areas, red roads).
bool writeScene(const Options& o, const gis::synth::SyntheticVectorSummary* vectors, std::string& error) {
  const fs::path scene = fs::absolute(o.scene);
  nlohmann::ordered_json j;
  j["name"] = "synthetic terrain, seed " + std::to_string(o.dem.seed) + ", " + std::to_string(o.dem.size) + " x " +
              std::to_string(o.dem.size) + " posts" +
              (vectors != nullptr ? ", " + std::to_string(o.vectorScale) + " x the paper's vector load" : "");
  j["terrain"] = {{"dem", relativeToScene(o, o.out)}, {"band", 1}, {"vertical_exaggeration", 1.0}};
  j["layers"] = nlohmann::json::array();
  if (vectors != nullptr) {
    j["layers"].push_back({{"name", "habitation"},
                           {"kind", "polygon"},
                           {"source", relativeToScene(o, vectors->areasPath)},
                           {"layer", "areas"},
                           {"style", {{"color", "#ffd400"}, {"opacity", 0.5}}}});
    j["layers"].push_back({{"name", "roads"},
                           {"kind", "line"},
                           {"source", relativeToScene(o, vectors->roadsPath)},
                           {"layer", "roads"},
                           {"style",
                            {{"color", "#d62728"},
                             {"opacity", 0.9},
                             {"width_m", o.roadWidth},
                             {"width_attribute", "width_m"},
                             {"join", "round"},
                             {"cap", "round"}}}});
  }
  std::ofstream out(scene);
  out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
  out.close();
  if (!out) error = o.scene + ": cannot write the scene file";
  return static_cast<bool>(out);
}

int run(const Options& o) {
  // Check the scene's folder first: a big DEM takes minutes.
  if (!o.scene.empty()) {
    const fs::path folder = fs::absolute(o.scene).parent_path();
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) {
      std::fprintf(stderr, "terrain_synth: %s: cannot write the scene file: folder %s does not exist\n",
                   o.scene.c_str(), folder.string().c_str());
      return 1;
    }
  }
  SyntheticDemSummary s;
  if (o.vectorsOnly) {
    // The DEM is there already (written with the same options): only its layout is needed.
    std::error_code ec;
    if (!fs::is_regular_file(o.out, ec)) {
      std::fprintf(stderr, "terrain_synth: %s: --vectors-only needs the DEM written before\n", o.out.c_str());
      return 1;
    }
    gis::Result<gis::synth::SyntheticTerrain> terrain = gis::synth::SyntheticTerrain::create(o.dem);
    for (const gis::Diagnostic& d : terrain.diagnostics.items())
      std::fprintf(stderr, "terrain_synth: %s\n", d.toString().c_str());
    if (!terrain) return 1;
    s = terrain->layout();
  } else {
    const auto start = std::chrono::steady_clock::now();
    ProgressBar bar;
    gis::Result<SyntheticDemSummary> written =
        gis::synth::writeSyntheticDem(o.out, o.dem, [&bar](double fraction) { bar(fraction); });
    bar.finish();
    for (const gis::Diagnostic& d : written.diagnostics.items())
      std::fprintf(stderr, "terrain_synth: %s\n", d.toString().c_str());
    if (!written) return 1;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    s = *written;
    std::error_code ec;
    const auto bytes = fs::file_size(o.out, ec);
    std::printf(
        "%s: %d x %d posts at %g %s, seed %llu: heights %.2f .. %.2f m; %zu cliffs, %zu spikes, %zu plains, %zu "
        "holes%s; %zu nodata posts; %.1f MB in %.2f s\n",
        o.out.c_str(), s.size, s.size, s.spacing,
        !o.dem.crs.empty() && gis::synth::isGeographicCrs(o.dem.crs) ? "degrees" : "CRS units",
        static_cast<unsigned long long>(s.seed), s.minHeight, s.maxHeight, s.cliffs.size(), s.spikes.size(),
        s.plains.size(), s.holes.size(), s.border.enabled ? ", nodata border" : "", s.nodataPosts,
        ec ? 0.0 : static_cast<double>(bytes) / 1e6, seconds);
  }

  std::optional<gis::synth::SyntheticVectorSummary> vectors;
  if (o.vectorScale > 0) {
    const fs::path scene = fs::absolute(o.scene);
    const std::string stem = (scene.parent_path() / scene.stem()).string();
    gis::synth::SyntheticVectorOptions v;
    v.scale = o.vectorScale;
    v.seed = o.dem.seed;
    v.crs = o.dem.crs;
    v.roadWidthMetres = o.roadWidth;
    const double extentX = s.size * s.geoTransform[1], extentY = s.size * -s.geoTransform[5];
    v.minX = s.geoTransform[0];
    v.maxX = s.geoTransform[0] + extentX;
    v.maxY = s.geoTransform[3];
    v.minY = s.geoTransform[3] - extentY;
    const auto vstart = std::chrono::steady_clock::now();
    gis::Result<gis::synth::SyntheticVectorSummary> w =
        gis::synth::writeSyntheticVectors(stem + "_areas.gpkg", stem + "_roads.gpkg", v);
    for (const gis::Diagnostic& d : w.diagnostics.items())
      std::fprintf(stderr, "terrain_synth: %s\n", d.toString().c_str());
    if (!w) return 1;
    vectors = *w;
    std::printf("%s: %zu areas, %zu points; %s: %zu roads, %zu points, %.0f km, %g m wide; in %.2f s\n",
                w->areasPath.c_str(), w->areas, w->areaPoints, w->roadsPath.c_str(), w->roads, w->roadPoints,
                w->roadKilometres, o.roadWidth,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - vstart).count());
  }
  if (!o.scene.empty()) {
    std::string error;
    if (!writeScene(o, vectors ? &*vectors : nullptr, error)) {
      std::fprintf(stderr, "terrain_synth: %s\n", error.c_str());
      return 1;
    }
    std::printf("scene: %s\n", o.scene.c_str());
  }
  return 0;
}

}  // namespace

static int synthMain(int argc, char** argv) {
  if (argc == 2 && (std::string_view(argv[1]) == "--help" || std::string_view(argv[1]) == "-h")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  Options options;
  const std::string error = parseArgs(argc, argv, options);
  if (!error.empty()) {
    std::fprintf(stderr, "terrain_synth: %s\n%s", error.c_str(), kUsage);
    return 2;
  }
  return run(options);
}

int main(int argc, char** argv) {
  // No exception ends the program unreported.
  try {
    return synthMain(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "terrain_synth: internal error: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "terrain_synth: internal error (an unknown exception)\n");
  }
  return 1;
}
