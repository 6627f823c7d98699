// overlay_render: draws a scene headless and writes what tests, scripts and people need
// (docs/design.md §8): color.png, depth.tiff, mask.png, camera.json, stats.json (+ selection.png,
// overlap.png, open_volumes.png).
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>

#include "analysis_report.hpp"
#include "app/cli.hpp"
#include "app/option_parser.hpp"
#include "core/log.hpp"
#include "frame_output.hpp"
#include "geo/checked_file.hpp"
#include "gfx/context.hpp"
#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "scene/camera.hpp"
#include "scene/frame_readback.hpp"
#include "scene/frame_renderer.hpp"
#include "scene/frame_scene.hpp"
#include "scene/json_file.hpp"
#include "scene/lasso_file.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "scene/selection_export.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/logical_selection.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/selection_renderer.hpp"
#include "vector_overlay/selection_states.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace {

using nlohmann::json;
using namespace gis;
using app::peakResidentBytes;
using app::report;
using app::runClock;

constexpr const char* kUsage =
    "usage: overlay_render --scene S.json [--camera C.json] [--width W --height H] [--msaa N]\n"
    "                      [--lasso L.json] [--overlap A,B [--overlap-op OP]] [--open-volumes]\n"
    "                      [--lod-tolerance PX] [--exaggeration X] [--method M [--drape-size N]]\n"
    "                      [--overlays on|off] [--cache-dir DIR | --no-cache] --out DIR\n"
    "Draws the scene headless (OpenGL 4.5 core via EGL) and writes into DIR:\n"
    "  color.png   the frame, top row first\n"
    "  depth.tiff  float32 depth as stored (reversed-Z: 1 at the near plane, 0 = background)\n"
    "  mask.png    8-bit, bit i set where the scene file's layer i is drawn\n"
    "  camera.json view/proj (column-major), depth convention, frame crs and origin\n"
    "  stats.json  sizes, GPU times, pipeline statistics, load messages\n"
    "--lasso: lasso selection (selection.png, selected_features.json; docs/command-line.md)\n"
    "--overlap A,B: highlight where scene layers A and B both cover the terrain (overlap.png);\n"
    "  --overlap-op and|or|xor|subtract chooses the combination (default and)\n"
    "--open-volumes: show where a layer's stencil volumes are not closed (open_volumes.png)\n"
    "--lod-tolerance: largest projected terrain error in pixels (default 1.5; 0 = exact DEM)\n"
    "--exaggeration: vertical exaggeration (default: the scene's)\n"
    "--overlays off: the terrain alone, the vector layers neither read nor built nor drawn (the\n"
    "  terrain's share of the start time and memory; default on)\n"
    "--cache-dir DIR: the scene's cache there (default: the scene's cache_dir, else .stencil-gis-cache\n"
    "  beside the scene file; the user's cache folder when that cannot be written)\n"
    "--no-cache: no cache on disk: every layer read from its source, every tile built\n"
    "--method M: how the vector layers are drawn (default: the first):\n";

/// The usage, with one line per overlay technique of the registry.
std::string usage() {
  std::string text = kUsage;
  for (const overlay::TechniqueInfo& t : overlay::techniques()) {
    text += "  " + std::string(t.name) + ": " + std::string(t.description) + "\n";
  }
  text +=
      "--drape-size N: texels per side of a texture technique's texture or tile (default: the technique's,\n"
      "  drape 2048, drape-tiles 256)\n";
  return text;
}

struct Options {
  std::string scene;
  std::string camera;
  std::string lasso;
  std::string overlap;  ///< "A,B"
  overlay::OverlapOp overlapOp = overlay::OverlapOp::And;
  bool openVolumes = false;
  std::string out;
  int width = 1024;
  int height = 768;
  int msaa = 0;
  double lodTolerance = 1.5;
  std::optional<double> exaggeration;
  const overlay::TechniqueInfo* technique = &overlay::defaultTechnique();
  int drapeSize = 0;  ///< 0: the technique's own (TechniqueInfo::defaultTextureSize)
  bool overlays = true;
  std::string cacheDir;  ///< overrides the scene's
  bool noCache = false;

  /// The scene file's description with the cache options applied.
  void applyCache(scene::SceneDescription& d) const {
    if (!cacheDir.empty()) d.cacheDir = std::filesystem::absolute(cacheDir).string();
    d.cacheDisabled = noCache;
  }
};

/// Returns an error message, or an empty string when the options are good.
std::string parseArgs(int argc, char** argv, Options& o) {
  app::OptionParser parser;
  parser.option("--scene", o.scene);
  parser.option("--camera", o.camera);
  parser.option("--lasso", o.lasso);
  parser.option("--overlap", o.overlap);
  parser.choice<overlay::OverlapOp>("--overlap-op", o.overlapOp,
                                    {{"and", overlay::OverlapOp::And},
                                     {"or", overlay::OverlapOp::Or},
                                     {"xor", overlay::OverlapOp::Xor},
                                     {"subtract", overlay::OverlapOp::Subtract}});
  parser.flag("--open-volumes", o.openVolumes);
  parser.option("--out", o.out);
  parser.option("--width", o.width, 1, 16384);
  parser.option("--height", o.height, 1, 16384);
  parser.option("--msaa", o.msaa, 0, 32);
  parser.option("--lod-tolerance", o.lodTolerance, 0.0, 1000.0);
  parser.custom(
      "--method", [&](std::string_view name) { return (o.technique = overlay::findTechnique(name)) != nullptr; },
      "a value",
      [](std::string_view name) {
        return "--method: " + overlay::techniqueNameList() + ", not '" + std::string(name) + "'";
      });
  parser.option("--drape-size", o.drapeSize, 1, 65536);
  parser.option("--exaggeration", o.exaggeration, 0.001, 1000.0);
  parser.choice<bool>("--overlays", o.overlays, {{"on", true}, {"off", false}});
  parser.option("--cache-dir", o.cacheDir);
  parser.flag("--no-cache", o.noCache);
  if (std::string error = parser.parse(argc, argv); !error.empty()) return error;
  if (o.scene.empty()) return "--scene is required";
  if (o.out.empty()) return "--out is required";
  if (o.noCache && !o.cacheDir.empty()) return "--cache-dir and --no-cache exclude each other";
  if (!o.overlap.empty() && std::count(o.overlap.begin(), o.overlap.end(), ',') != 1) {
    return "--overlap needs two layer names separated by a comma";
  }
  return {};
}

json diagnosticsJson(const Diagnostics& diagnostics) {
  json a = json::array();
  for (const Diagnostic& d : diagnostics.items()) a.push_back(d.toString());
  return a;
}

/// The scene and the camera it is drawn from (no GL yet).
struct Setup {
  scene::SceneDescription description;
  scene::Scene scene;
  scene::FrameCamera camera;
  std::optional<scene::SelectionRequest> lasso;
};

/// The GL side: the context, then the renderer (declared after it, so that its GL objects go while
/// the context is current).
struct Gpu {
  std::unique_ptr<gfx::Context> context;
  std::unique_ptr<scene::FrameRenderer> renderer;
};

/// The frame drawn, with the analyses drawn over it, and read back.
struct Frame {
  overlay::OverlayView view;
  std::optional<scene::SelectionPixels> selection;
  std::optional<scene::OverlapPixels> overlap;
  std::optional<scene::OpenVolumePixels> open;
  scene::FrameImages images;
};

/// What the output files are made from.
struct Drawn {
  const Options& o;
  const Setup& setup;
  const scene::FrameRenderer& renderer;
  const Frame& frame;
};

/// selection.png, the logical selection (features, DEM posts), its agreement with the pixels and
/// the GeoJSON exports; adds a "selection" block to stats.
bool writeSelection(const std::filesystem::path& out, const Drawn& d, Diagnostics& all, json& stats) {
  const scene::SelectionPixels& selection = *d.frame.selection;
  const scene::SelectionRequest& request = *d.setup.lasso;
  const int width = d.o.width, height = d.o.height;
  bool ok = true;
  const Result<bool> png = gfx::writeImage8((out / "selection.png").string(), width, height, 1, selection.pixels);
  report(png.diagnostics);
  ok = ok && png.ok();
  const std::span<const overlay::SelectionStep> steps(request.steps);
  // The CPU twin on the same depth buffer, and its edge band: where its answer changes within a
  // pixel's neighbours.
  const overlay::DepthImage image = scene::Scene::depthImageOf(d.setup.camera, width, height, d.frame.images.depth);
  const std::vector<std::uint8_t> twin = overlay::selectionMask(image, steps);
  const std::vector<std::uint32_t> twinBits(twin.begin(), twin.end());
  const std::vector<std::uint8_t> edges = overlay::maskEdges(twinBits, image);
  std::size_t selectedPixels = 0, disagreeing = 0, awayFromEdges = 0;
  for (std::size_t i = 0; i < twin.size() && i < selection.pixels.size(); ++i) {
    const bool gpu = selection.pixels[i] != 0, cpu = twin[i] != 0;
    selectedPixels += gpu ? 1U : 0U;
    disagreeing += gpu != cpu ? 1U : 0U;
    awayFromEdges += gpu != cpu && edges[i] == 0 ? 1U : 0U;
  }
  const scene::SelectedFeatures chosen =
      d.renderer.selectFeatures(steps, d.setup.camera, width, height, request.sampleSpacing);
  json layers = json::array();
  for (const scene::SelectedFeatures::Layer& l : chosen.layers) {
    json features = json::array();
    for (std::size_t k = 0; k < l.features.size(); ++k) {
      const overlay::FeatureSelection& f = l.features[k];
      features.push_back({{"fid", l.fids[k]},
                          {"fully_inside", f.fullyInside},
                          {"samples", f.samples},
                          {"selected_samples", f.selectedSamples},
                          {"spacing_m", f.spacing}});
    }
    layers.push_back({{"name", l.name},
                      {"selected", l.features.size()},
                      {"fully_inside", l.fullyInside},
                      {"file", scene::selectedLayerFileName(l.name)},
                      {"features", features}});
  }
  const Diagnostics exported = d.renderer.exportSelection(chosen, out / "selected_features.json", out);
  report(exported);
  all.append(exported);
  ok = ok && !exported.hasErrors();
  json posts = nullptr;
  if (chosen.posts) posts = {{"selected", chosen.posts->selected}, {"with_height", chosen.posts->posts}};
  stats["selection"] = {{"steps", request.steps.size()},
                        {"scheme", request.scheme == overlay::SelectionScheme::Runs ? "runs" : "report"},
                        {"volumes", selection.stats.volumes},
                        {"triangles", selection.stats.triangles},
                        {"screen_passes", selection.stats.screenPasses},
                        {"gpu_ms", selection.stats.gpuMilliseconds},
                        {"fragments", selection.stats.fragments},
                        {"selected_pixels", selectedPixels},
                        {"pixels_differing_from_cpu_twin", disagreeing},
                        {"differing_away_from_edges", awayFromEdges},
                        {"sample_spacing_m", chosen.sampleSpacing},
                        {"logical_seconds", chosen.seconds},
                        {"tested_samples", chosen.testedSamples},
                        {"layers", layers},
                        {"dem_posts", posts}};
  return ok;
}

/// overlap.png and an "overlap" block in stats, with the CPU reference's answer on the same depth.
bool writeOverlap(const std::filesystem::path& out, const Drawn& d, json& stats) {
  const scene::OverlapPixels& overlap = *d.frame.overlap;
  const overlay::OverlapOp op = d.o.overlapOp;
  const int width = d.o.width, height = d.o.height;
  const overlay::DepthImage image = scene::Scene::depthImageOf(d.setup.camera, width, height, d.frame.images.depth);
  const std::array<std::size_t, 2> pair{overlap.a, overlap.b};
  const scene::ReferenceAnswer reference = d.renderer.referenceOf(pair, image);
  const app::OverlapCounts counts = app::countOverlap(overlap.flags, reference.expected, reference.edges, op);
  const Result<bool> png = gfx::writeImage8((out / "overlap.png").string(), width, height, 1, counts.pixels);
  report(png.diagnostics);
  const std::size_t comma = d.o.overlap.find(',');
  stats["overlap"] =
      app::overlapJson(counts, d.o.overlap.substr(0, comma), d.o.overlap.substr(comma + 1), op, overlap.marks);
  return png.ok();
}

/// Reads the scene file, loads the scene in its frame, places the camera and reads the lasso
/// file; nothing, with the problems reported, when one of them fails.
std::optional<Setup> load(const Options& o, Diagnostics& all) {
  Result<scene::SceneDescription> description = scene::loadSceneFile(o.scene);
  report(description.diagnostics);
  all.append(description.diagnostics);
  if (!description) return std::nullopt;
  o.applyCache(*description);
  // Left out before loading, so that nothing of them counts in the time or the memory.
  if (!o.overlays) description->layers.clear();

  Result<scene::Scene> scene = scene::Scene::load(*description, {}, o.exaggeration);
  report(scene.diagnostics);
  all.append(scene.diagnostics);
  if (!scene) return std::nullopt;

  Result<scene::FrameCamera> camera = scene->stillCamera(o.camera, o.scene, o.width, o.height);
  report(camera.diagnostics);
  all.append(camera.diagnostics);
  if (!camera) return std::nullopt;
  Setup s{std::move(*description), std::move(*scene), std::move(*camera), std::nullopt};

  if (!o.lasso.empty()) {
    Result<scene::SelectionRequest> request = s.scene.loadLasso(o.lasso, s.camera, o.width, o.height);
    report(request.diagnostics);
    all.append(request.diagnostics);
    if (!request) return std::nullopt;
    s.lasso = std::move(*request);
  }
  return s;
}

/// The headless context and the scene's renderer; nothing, with the problems reported, if either
/// cannot be made.
std::optional<Gpu> makeGpu(const Options& o, Setup& s, Diagnostics& all) {
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  report(context.diagnostics);
  if (!context) return std::nullopt;
  Gpu gpu{std::move(*context), nullptr};
  scene::StillSettings settings;
  settings.technique = o.technique;
  settings.textureSize = o.drapeSize;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.tileProgress = scene::consoleProgress("vector tiles");
  Result<std::unique_ptr<scene::FrameRenderer>> renderer = scene::FrameRenderer::create(s.scene, settings);
  report(renderer.diagnostics);
  all.append(renderer.diagnostics);
  if (!renderer) return std::nullopt;
  gpu.renderer = std::move(*renderer);
  return gpu;
}

/// The fill layers --overlap names, into `layers`; false, with the scene's layers listed, when one
/// of them is not drawn.
bool findOverlapLayers(const Options& o, const Setup& s, const scene::FrameRenderer& renderer,
                       std::optional<std::pair<std::size_t, std::size_t>>& layers) {
  if (o.overlap.empty()) return true;
  const std::size_t comma = o.overlap.find(',');
  const std::string nameA = o.overlap.substr(0, comma), nameB = o.overlap.substr(comma + 1);
  const std::optional<std::size_t> a = renderer.fillLayerNamed(nameA);
  const std::optional<std::size_t> b = renderer.fillLayerNamed(nameB);
  if (!a || !b) {
    std::string names;
    for (const scene::LoadedLayer& l : s.scene.layers()) names += (names.empty() ? "" : ", ") + l.description.name;
    logError(o.scene + ": --overlap: no drawn layer named '" + (a ? nameB : nameA) + "' (layers: " + names + ")");
    return false;
  }
  layers.emplace(*a, *b);
  return true;
}

/// Draws the scene, then the selection and the analyses asked for over it, and reads the frame
/// back; nothing when the selection cannot be drawn.
std::optional<Frame> drawFrame(const Options& o, const Setup& s, scene::FrameRenderer& renderer,
                               const std::optional<std::pair<std::size_t, std::size_t>>& overlapLayers,
                               Diagnostics& all) {
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, o.msaa, true);
  Frame frame;
  renderer.drawStill(cache, target, s.camera);
  frame.view = scene::Scene::overlayViewOf(s.camera, o.width, o.height);
  if (s.lasso) {
    Result<scene::SelectionPixels> selection = scene::drawSelection(cache, target, *s.lasso, frame.view);
    report(selection.diagnostics);
    all.append(selection.diagnostics);
    if (!selection) return std::nullopt;
    frame.selection = std::move(*selection);
  }
  overlay::OverlayRenderer* passes = renderer.analysisPasses();
  if (overlapLayers && passes != nullptr) {
    const auto a = renderer.chunksOf(overlapLayers->first, s.camera);
    const auto b = renderer.chunksOf(overlapLayers->second, s.camera);
    frame.overlap = scene::drawOverlap(cache, target, *passes, a, b, o.overlapOp, frame.view);
    frame.overlap->a = overlapLayers->first;
    frame.overlap->b = overlapLayers->second;
  }
  if (o.openVolumes && passes != nullptr) {
    std::vector<scene::ChunkedLayer> layers;
    for (std::size_t j = 0; j < renderer.drawnLayerCount(); ++j)
      layers.push_back({renderer.drawnLayerName(j), renderer.chunksOf(j, s.camera)});
    frame.open = scene::drawOpenVolumes(cache, target, *passes, layers, frame.view);
  }
  frame.images = renderer.readFrame(cache, target);
  // What the technique said while drawing (a tile's problems, a damaged tile file): logged as it
  // came, kept in stats.json with the load's messages.
  all.append(renderer.techniqueDiagnostics());
  return frame;
}

/// color.png, depth.tiff and mask.png.
bool writeImages(const std::filesystem::path& out, const Options& o, const Frame& frame) {
  return app::writeFrameImages(out, o.width, o.height, frame.images.rgb, frame.images.depth, frame.images.mask);
}

/// stats.json without the analyses' blocks (they add theirs as they are written): what both
/// frames report alike, then the frame's own blocks (FrameRenderer::reportStill).
json statsJson(const Drawn& d, gfx::Context& context, const Diagnostics& all) {
  json stats = {{"scene", d.o.scene},
                {"width", d.o.width},
                {"height", d.o.height},
                {"msaa", d.frame.images.samples},
                {"gl", {{"renderer", context.info().renderer}, {"version", context.info().version}}},
                {"load_seconds", d.setup.scene.loadSeconds()},
                // From the start of the run (options read) to the frame read back: loading, building
                // every layer, drawing. And the process's peak resident memory by then (with Mesa's
                // software rasteriser, GPU buffers live in it too).
                {"first_frame_seconds", runClock().firstFrameSeconds},
                {"cpu_peak_bytes", peakResidentBytes()},
                {"method", d.o.technique->name},
                // The scene's source vertices, every layer's (as read, before any generalisation).
                {"vector_vertices", d.setup.scene.vectorVertices()},
                // The cache: where, and what checking its files cost this run (geo/checked_file.hpp).
                {"cache",
                 {{"directory", scene::cacheDirectoryFor(d.setup.description)},
                  {"verified_bytes", geo::io::verifiedSoFar().bytes},
                  {"verify_seconds", geo::io::verifiedSoFar().seconds}}},
                {"errors", all.count(Severity::Error)},
                {"warnings", all.count(Severity::Warning)},
                {"diagnostics", diagnosticsJson(all)},
                {"gl_errors", context.debug().errorCount()}};
  d.renderer.reportStill(d.frame.images, stats);
  return stats;
}

/// selection.png, overlap.png and open_volumes.png as asked for, with their blocks in stats.
bool writeAnalyses(const std::filesystem::path& out, const Drawn& d, Diagnostics& all, json& stats) {
  bool ok = true;
  if (d.frame.selection) {
    ok = writeSelection(out, d, all, stats) && ok;
    stats["errors"] = all.count(Severity::Error);
    stats["warnings"] = all.count(Severity::Warning);
    stats["diagnostics"] = diagnosticsJson(all);
  }
  if (d.frame.overlap) ok = writeOverlap(out, d, stats) && ok;
  if (const std::optional<scene::OpenVolumePixels>& open = d.frame.open) {
    const Result<bool> png =
        gfx::writeImage8((out / "open_volumes.png").string(), d.o.width, d.o.height, 1, open->pixels);
    report(png.diagnostics);
    ok = ok && png.ok();
    stats["open_volumes"] = app::openVolumesJson(*open);
  }
  return ok;
}

/// Every output file into --out; false when one could not be written.
bool writeOutputs(const Drawn& d, gfx::Context& context, Diagnostics& all) {
  const std::filesystem::path out(d.o.out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    logError(d.o.out + ": cannot create output directory: " + ec.message());
    return false;
  }
  bool ok = writeImages(out, d.o, d.frame);
  json stats = statsJson(d, context, all);
  ok = writeAnalyses(out, d, all, stats) && ok;
  ok = scene::writeJsonFile((out / "camera.json").string(),
                            d.setup.scene.cameraJson(d.setup.camera, d.o.width, d.o.height)) &&
       ok;
  ok = scene::writeJsonFile((out / "stats.json").string(), stats) && ok;
  if (!ok) return false;
  std::printf("%s\n", (std::filesystem::absolute(out) / "color.png").string().c_str());
  return true;
}

int run(const Options& o) {
  runClock().start = std::chrono::steady_clock::now();
  Diagnostics all;
  if ((!o.lasso.empty() || !o.overlap.empty() || o.openVolumes) && o.msaa > 1) {
    logError("--lasso, --overlap and --open-volumes with --msaa " + std::to_string(o.msaa) +
             ": selection and analysis are drawn single-sampled only");
    return 2;
  }
  if ((!o.overlap.empty() || o.openVolumes) && o.technique->looksUp) {
    logError("--overlap and --open-volumes mark the layers' stencil polyhedra, and --method " +
             std::string(o.technique->name) + " looks the layers up instead: use stencil-tiles, stencil or paper");
    return 2;
  }
  std::optional<Setup> setup = load(o, all);
  if (!setup) return 1;
  std::optional<Gpu> gpu = makeGpu(o, *setup, all);
  if (!gpu) return 1;
  std::optional<std::pair<std::size_t, std::size_t>> overlapLayers;
  if (!findOverlapLayers(o, *setup, *gpu->renderer, overlapLayers)) return 2;
  const std::optional<Frame> frame = drawFrame(o, *setup, *gpu->renderer, overlapLayers, all);
  if (!frame) return 1;
  runClock().firstFrameDone();
  if (!writeOutputs(Drawn{o, *setup, *gpu->renderer, *frame}, *gpu->context, all)) return 1;
  return gpu->context->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return gis::app::programMain(
      argc, argv, "overlay_render", usage().c_str(), [&](int n, char** v) { return parseArgs(n, v, options); },
      [&] { return run(options); });
}
