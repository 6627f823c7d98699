#pragma once
// What the modes of overlay_bench share: options, setting up, paths, percentiles, memory, the
// result file.
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli.hpp"
#include "gfx/context.hpp"
#include "scene/camera_path.hpp"
#include "scene/frame_scene.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"

namespace gis::bench {

using nlohmann::json;

struct Options {
  std::string scene, out, mode = "terrain";
  int width = 1200, height = 1000, frames = 90;
  int maxVolumes = 500, repeats = 5;  ///< lasso mode
  /// Methods mode: the sizes (texels per side) each texture technique is drawn at, by its name
  /// (--texture-sizes NAME=…); one not named here is drawn at its default size.
  std::map<std::string, std::vector<int>, std::less<>> textureSizes;
  int errorEvery = 3;                 ///< methods mode: error on every n-th frame
  int msaa = 0;                       ///< methods mode: samples per pixel (0 = off)
  std::vector<std::string> segments;  ///< methods mode: path segments to draw (empty = all)
  std::vector<std::string> scenes;    ///< scaling mode: the scenes, in order
  double lodTolerance = 1.5;
  std::optional<scene::TerrainPaging> paging;

  [[nodiscard]] std::vector<int> textureSizesOf(const overlay::TechniqueInfo& technique) const {
    const auto found = textureSizes.find(technique.name);
    return found != textureSizes.end() ? found->second : std::vector<int>{technique.defaultTextureSize};
  }
};

/// "VmRSS" or "VmHWM" of this process in bytes (Linux).
std::size_t processMemory(const char* key);

/// The p-th percentile of `v`, the sample nearest its rank; 0 for none.
double percentile(std::vector<double> v, double p);

/// Writes bench.json, prints it, and fails the run on any GL error.
int finish(const Options& o, const nlohmann::json& result, gfx::Context& context);

/// What every mode starts from: the scene file, the loaded scene and a headless GL context.
/// Renderers made after it go before it (their GL objects need the context).
struct BenchSetup {
  scene::SceneDescription description;
  scene::Scene scene;  ///< in its frame: projected, or on the globe
  std::unique_ptr<gfx::Context> context;
  double loadSeconds = 0.0;  ///< reading the scene file and loading the scene
};

/// Loads `o.scene` (without its vector layers unless `withLayers`) and makes the context; nothing,
/// with the problems reported, if either fails.
std::optional<BenchSetup> setUp(const Options& o, bool withLayers);

/// The render settings under which several methods draw the same frames: the options' LOD
/// tolerance and every tile waited for, so the terrain is the same (the exaggeration is the
/// scene's, held by its bounds).
scene::RenderSettings comparisonSettings(const Options& o);

/// The fly-through (top-down, oblique, horizon) over the scene's terrain, `o.frames` frames.
std::vector<scene::PathFrame> flyThroughOf(const Options& o, const BenchSetup& setup);

/// Milliseconds since `start`.
double msSince(std::chrono::steady_clock::time_point start);

/// Close-up frames: the eye 1.5 m over the ground on a road's centre line looking along it, or
/// over the vertex centroid of an area, looking across it 10° down; roads and areas taken in turn
/// from the scene's layers (deterministic). Eyes inside a piece make the frame's pieces z-fail.
std::vector<scene::PathFrame> closeUpPath(const BenchSetup& setup, int frames);

/// A frame of a path in either frame, and the segment it belongs to.
struct BenchFrame {
  scene::FrameCamera camera;
  std::string segment;
};

/// A flight over the scene in its frame (bench_paths.cpp): the fly-through of a projected scene
/// (flyThroughOf), or the globe's path (methodsPath).
std::vector<BenchFrame> flightPath(const Options& o, const BenchSetup& setup);

/// The methods' path (bench_paths.cpp). A projected scene: the fly-through (o.frames) and
/// o.frames / 3 close-up frames, keeping the segments of `o.segments` (all when empty). A scene
/// on the globe: o.frames frames from space down to a few kilometres (the data's middle from
/// 9,000 km, the continent from 3,000 km and 500 km, low over its edge, across the antimeridian,
/// over the south pole); data smaller than 200 km along a path of its own: above it, obliquely,
/// low over an edge, 100 m up.
std::vector<BenchFrame> methodsPath(const Options& o, const BenchSetup& setup);

/// Mode "terrain": the fly-through, terrain only (terrain_mode.cpp).
int runTerrain(const Options& o);
/// Mode "overlay": terrain only, ours and the paper's on each frame of the flight (flightPath;
/// overlay_mode.cpp), in either frame.
int runOverlay(const Options& o);
/// Mode "methods": every method on the same frames, with frame time, memory, build time and the
/// error against the CPU reference (methods_mode.cpp).
int runMethods(const Options& o);
/// Mode "ablation": ours with each saving of docs/design.md §9 switched off alone, on the same frames
/// (methods_mode.cpp).
int runAblation(const Options& o);
/// Mode "scaling": terrain only, ours and the paper's on each of o.scenes (oblique segment unless
/// --segments): frame time against vector vertices and against DEM posts (scaling_mode.cpp).
int runScaling(const Options& o);
/// Mode "lasso": the time of lasso selection against the number of volumes (lasso_mode.cpp).
int runLasso(const Options& o);

}  // namespace gis::bench
