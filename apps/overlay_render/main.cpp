// overlay_render: draws a scene headless and writes what tests, scripts and people need
// (DESIGN §8): color.png, depth.tiff, mask.png, camera.json, stats.json (+ selection.png,
// overlap.png, open_volumes.png).
#include <algorithm>
#include <charconv>
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

#include "app/camera.hpp"
#include "app/cli.hpp"
#include "app/json_file.hpp"
#include "app/lasso_file.hpp"
#include "app/scene.hpp"
#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "app/scene_selection.hpp"
#include "core/log.hpp"
#include "gfx/context.hpp"
#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/logical_selection.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/selection_renderer.hpp"
#include "vector_overlay/selection_states.hpp"
#include "vector_overlay/stencil_states.hpp"

namespace {

using nlohmann::json;
using namespace gis;
using app::parseDouble;
using app::parseInt;
using app::report;

constexpr const char* kUsage =
    "usage: overlay_render --scene S.json [--camera C.json] [--width W --height H] [--msaa N]\n"
    "                      [--lasso L.json] [--overlap A,B [--overlap-op OP]] [--open-volumes]\n"
    "                      [--lod-tolerance PX] [--exaggeration X] [--method M [--drape-size N]]\n"
    "                      --out DIR\n"
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
    "--method M: how the vector layers are drawn (default: the first):\n";

/// The usage, with one line per overlay technique of the registry.
std::string usage() {
  std::string text = kUsage;
  for (const overlay::TechniqueInfo& t : overlay::techniques()) {
    text += "  " + std::string(t.name) + ": " + std::string(t.description) + "\n";
  }
  text += "--drape-size N: texels per side of a texture technique's texture (default 2048)\n";
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
  int drapeSize = 2048;
};

std::optional<overlay::OverlapOp> overlapOpOf(std::string_view name) {
  if (name == "and") return overlay::OverlapOp::And;
  if (name == "or") return overlay::OverlapOp::Or;
  if (name == "xor") return overlay::OverlapOp::Xor;
  if (name == "subtract") return overlay::OverlapOp::Subtract;
  return std::nullopt;
}

const char* overlapOpName(overlay::OverlapOp op) {
  switch (op) {
    case overlay::OverlapOp::And:
      return "and";
    case overlay::OverlapOp::Or:
      return "or";
    case overlay::OverlapOp::Xor:
      return "xor";
    case overlay::OverlapOp::Subtract:
      return "subtract";
  }
  return "?";
}

/// Returns an error message, or an empty string when the options are good.
std::string parseArgs(int argc, char** argv, Options& o) {
  const std::vector<std::string_view> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view a = args[i];
    auto value = [&]() -> std::optional<std::string_view> {
      if (i + 1 >= args.size()) return std::nullopt;
      return args[++i];
    };
    auto setString = [&](std::string& target) {
      const auto v = value();
      if (!v) return std::string(a) + " needs a value";
      target = std::string(*v);
      return std::string();
    };
    auto setInt = [&](int& target, int lo, int hi) {
      const auto v = value();
      const std::optional<int> n = v ? parseInt(*v) : std::nullopt;
      if (!n || *n < lo || *n > hi) {
        return std::string(a) + " needs an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
      }
      target = *n;
      return std::string();
    };
    auto setDouble = [&](double& target, double lo, double hi) {
      const auto v = value();
      const std::optional<double> x = v ? parseDouble(*v) : std::nullopt;
      if (!x || *x < lo || *x > hi) {
        return std::string(a) + " needs a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
      }
      target = *x;
      return std::string();
    };
    std::string error;
    if (a == "--scene")
      error = setString(o.scene);
    else if (a == "--camera")
      error = setString(o.camera);
    else if (a == "--lasso")
      error = setString(o.lasso);
    else if (a == "--overlap")
      error = setString(o.overlap);
    else if (a == "--overlap-op") {
      const auto v = value();
      const std::optional<overlay::OverlapOp> op = v ? overlapOpOf(*v) : std::nullopt;
      if (op)
        o.overlapOp = *op;
      else
        error = "--overlap-op needs one of and, or, xor, subtract";
    } else if (a == "--open-volumes")
      o.openVolumes = true;
    else if (a == "--out")
      error = setString(o.out);
    else if (a == "--width")
      error = setInt(o.width, 1, 16384);
    else if (a == "--height")
      error = setInt(o.height, 1, 16384);
    else if (a == "--msaa")
      error = setInt(o.msaa, 0, 32);
    else if (a == "--lod-tolerance")
      error = setDouble(o.lodTolerance, 0.0, 1000.0);
    else if (a == "--method") {
      std::string m;
      error = setString(m);
      o.technique = overlay::findTechnique(m);
      if (o.technique == nullptr && error.empty()) {
        error = "--method: " + overlay::techniqueNameList() + ", not '" + m + "'";
      }
    } else if (a == "--drape-size")
      error = setInt(o.drapeSize, 1, 65536);
    else if (a == "--exaggeration") {
      double x = 1.0;
      error = setDouble(x, 0.001, 1000.0);
      o.exaggeration = x;
    } else
      error = "unknown argument '" + std::string(a) + "'";
    if (!error.empty()) return error;
  }
  if (o.scene.empty()) return "--scene is required";
  if (o.out.empty()) return "--out is required";
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

json countsJson(const gfx::PipelineCounts& c) {
  return {{"vertices_submitted", c.verticesSubmitted},
          {"primitives_submitted", c.primitivesSubmitted},
          {"vertex_shader_invocations", c.vertexShaderInvocations},
          {"clipping_input_primitives", c.clippingInputPrimitives},
          {"clipping_output_primitives", c.clippingOutputPrimitives},
          {"fragment_shader_invocations", c.fragmentShaderInvocations},
          {"samples_passed", c.samplesPassed}};
}

bool writeJson(const std::filesystem::path& path, const json& j) {
  std::ofstream out(path);
  out << app::jsonText(j) << "\n";
  return static_cast<bool>(out);
}

struct SelectionOutput {
  std::vector<std::uint8_t> pixels;  ///< 255 = selected, top row first
  overlay::SelectionFrameStats stats;
};

/// Marks the selection into the stencil of the drawn scene, reads it, then highlights it (and
/// draws the volumes when asked) into the colour.
std::optional<SelectionOutput> drawSelection(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                             const app::SelectionRequest& request, const app::Camera& camera, int width,
                                             int height, Diagnostics& all) {
  Result<overlay::SelectionRenderer> renderer = overlay::SelectionRenderer::create();
  report(renderer.diagnostics);
  all.append(renderer.diagnostics);
  if (!renderer) return std::nullopt;
  const Diagnostics built = renderer->setSteps(request.steps);
  report(built);
  all.append(built);
  const overlay::OverlayView view = app::overlayViewOf(camera, static_cast<double>(width) / height);
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);  // the overlay mask stays as the layers left it
  overlay::SelectionSettings settings;
  settings.scheme = request.scheme;
  settings.measure = true;
  SelectionOutput out;
  out.stats = renderer->select(cache, view, settings);
  const std::vector<std::uint8_t> stencil = gfx::readStencil(target);
  const std::vector<float> depth = gfx::readDepth(target);
  out.pixels.resize(stencil.size());
  for (std::size_t i = 0; i < stencil.size(); ++i) {
    const bool selected = request.scheme == overlay::SelectionScheme::Runs ? (stencil[i] & overlay::kSelectedBit) != 0
                                                                           : depth[i] > 0.0F && stencil[i] == 1;
    out.pixels[i] = selected ? 255 : 0;
  }
  renderer->highlight(cache, request.highlight, settings);
  if (request.showVolumes) renderer->drawVolumes(cache, view, *request.showVolumes);
  gfx::enableMaskWrites(target.framebuffer(), true);
  return out;
}

/// selection.png, the logical selection (features, DEM posts), its agreement with the pixels and
/// the GeoJSON exports; adds a "selection" block to stats.
bool writeSelection(const std::filesystem::path& out, const SelectionOutput& selection,
                    const app::SelectionRequest& request, const app::LoadedScene& scene,
                    const app::SceneRenderer& renderer, const app::Camera& camera, const std::vector<float>& depth,
                    int width, int height, Diagnostics& all, json& stats) {
  bool ok = true;
  const Result<bool> png = gfx::writeImage8((out / "selection.png").string(), width, height, 1, selection.pixels);
  report(png.diagnostics);
  ok = ok && png.ok();
  const std::span<const overlay::SelectionStep> steps(request.steps);
  // The CPU twin on the same depth buffer.
  const double aspect = static_cast<double>(width) / height;
  const overlay::DepthImage image{width, height, depth, camera.projection(aspect) * camera.view()};
  const std::vector<std::uint8_t> twin = overlay::selectionMask(image, steps);
  std::size_t selectedPixels = 0, disagreeing = 0;
  for (std::size_t i = 0; i < twin.size() && i < selection.pixels.size(); ++i) {
    selectedPixels += selection.pixels[i] != 0 ? 1u : 0u;
    disagreeing += (selection.pixels[i] != 0) != (twin[i] != 0) ? 1u : 0u;
  }
  const app::SceneSelection chosen =
      app::selectInScene(scene, renderer, steps, camera, width, height, request.sampleSpacing);
  json layers = json::array();
  for (const app::LayerSelection& l : chosen.layers) {
    const overlay::OverlayLayer& drawn = renderer.overlayLayers()[l.overlayLayer];
    json features = json::array();
    for (const overlay::FeatureSelection& f : l.features) {
      features.push_back({{"fid", drawn.features()[f.feature].fid},
                          {"fully_inside", f.fullyInside},
                          {"samples", f.samples},
                          {"selected_samples", f.selectedSamples}});
    }
    const std::string& name = scene.layers[l.sceneLayer].description.name;
    layers.push_back({{"name", name},
                      {"selected", l.features.size()},
                      {"fully_inside", l.fullyInside},
                      {"file", "selected_" + app::layerSlug(name) + ".geojson"},
                      {"features", features}});
  }
  const Diagnostics exported = app::exportSelection(scene, renderer, chosen, out / "selected_features.json", out);
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
                        {"sample_spacing_m", chosen.sampleSpacing},
                        {"layers", layers},
                        {"dem_posts", posts}};
  return ok;
}

// Layer analysis (--overlap, --open-volumes) on the frame just drawn: marks read back from the
// stencil between the mark and the cover, highlights blended into the colour.
constexpr glm::vec4 kOverlapColour{1.0F, 0.0F, 1.0F, 0.6F};
constexpr glm::vec4 kOpenColour{0.0F, 1.0F, 0.0F, 1.0F};

/// The fill (not the outline) overlay layer of the scene layer with this name.
std::optional<std::size_t> fillLayerNamed(const app::LoadedScene& scene, const app::SceneRenderer& renderer,
                                          std::string_view name) {
  for (std::size_t j = 0; j < renderer.overlaySources().size(); ++j) {
    const auto& [layer, outline] = renderer.overlaySources()[j];
    if (!outline && scene.layers[layer].description.name == name) return j;
  }
  return std::nullopt;
}

struct OverlapOutput {
  std::size_t a = 0, b = 0;         ///< overlay layers
  std::vector<std::uint8_t> flags;  ///< the stencil after marking, top row first
  overlay::AnalysisMarks marks;
};

OverlapOutput drawOverlap(gfx::StateCache& cache, const gfx::RenderTarget& target, app::SceneRenderer& renderer,
                          std::size_t a, std::size_t b, overlay::OverlapOp op, const overlay::OverlayView& view) {
  OverlapOutput out{a, b, {}, {}};
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);  // the overlay mask stays as the layers left it
  overlay::OverlaySettings settings;
  settings.measure = true;
  out.marks = renderer.overlayRenderer().markOverlap(cache, view, renderer.overlayLayers()[a],
                                                     renderer.overlayLayers()[b], settings);
  out.flags = gfx::readStencil(target);
  renderer.overlayRenderer().coverOverlap(cache, out.marks, op, kOverlapColour);
  gfx::enableMaskWrites(target.framebuffer(), true);
  return out;
}

struct OpenVolumesOutput {
  std::vector<std::uint8_t> pixels;  ///< 255 where some layer's volumes are open
  json layers = json::array();
  std::size_t openPixels = 0;
};

OpenVolumesOutput drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target, app::SceneRenderer& renderer,
                                  const overlay::OverlayView& view) {
  OpenVolumesOutput out;
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);
  overlay::OverlaySettings settings;
  settings.measure = true;
  out.pixels.assign(static_cast<std::size_t>(target.width()) * static_cast<std::size_t>(target.height()), 0);
  for (const overlay::OverlayLayer& layer : renderer.overlayLayers()) {
    const overlay::AnalysisMarks marks = renderer.overlayRenderer().countOpenFaces(cache, view, layer, settings);
    const std::vector<std::uint8_t> counts = gfx::readStencil(target);
    renderer.overlayRenderer().coverOpenFaces(cache, marks, kOpenColour);
    std::size_t open = 0;
    for (std::size_t i = 0; i < counts.size() && i < out.pixels.size(); ++i) {
      if (counts[i] == 0) continue;
      ++open;
      out.pixels[i] = 255;
    }
    out.layers.push_back({{"name", layer.name()},
                          {"open_pixels", open},
                          {"pieces_counted", marks.a.zPassPieces + marks.a.zFailPieces},
                          {"pieces_clipped_and_capped", marks.a.zFailPieces},
                          {"gpu_ms", marks.gpuMilliseconds},
                          {"fragments", marks.fragments}});
  }
  for (std::uint8_t p : out.pixels) out.openPixels += p != 0 ? 1u : 0u;
  gfx::enableMaskWrites(target.framebuffer(), true);
  return out;
}

/// overlap.png and an "overlap" block in stats, with the CPU reference's answer on the same depth.
bool writeOverlap(const std::filesystem::path& out, const OverlapOutput& overlap, overlay::OverlapOp op,
                  const app::SceneRenderer& renderer, const app::LoadedScene& scene, const glm::dmat4& viewProj,
                  const std::vector<float>& depth, int width, int height, json& stats) {
  const std::vector<overlay::ReferenceLayer> ref{overlay::referenceLayerOf(renderer.overlayLayers()[overlap.a]),
                                                 overlay::referenceLayerOf(renderer.overlayLayers()[overlap.b])};
  const overlay::DepthImage image{width, height, depth, viewProj};
  const std::vector<std::uint32_t> expected = overlay::referenceMask(image, ref);
  const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
  std::vector<std::uint8_t> pixels(overlap.flags.size(), 0);
  std::size_t inA = 0, inB = 0, both = 0, selected = 0, differing = 0, differingAwayFromEdges = 0;
  for (std::size_t i = 0; i < pixels.size() && i < expected.size(); ++i) {
    const bool a = (overlap.flags[i] & overlay::kOverlapFlagA) != 0,
               b = (overlap.flags[i] & overlay::kOverlapFlagB) != 0;
    inA += a ? 1u : 0u;
    inB += b ? 1u : 0u;
    both += a && b ? 1u : 0u;
    const bool gpu = overlay::overlapHolds(op, a, b),
               cpu = overlay::overlapHolds(op, (expected[i] & 1u) != 0, (expected[i] & 2u) != 0);
    pixels[i] = gpu ? 255 : 0;
    selected += gpu ? 1u : 0u;
    differing += gpu != cpu ? 1u : 0u;
    differingAwayFromEdges += gpu != cpu && edges[i] == 0 ? 1u : 0u;
  }
  const Result<bool> png = gfx::writeImage8((out / "overlap.png").string(), width, height, 1, pixels);
  report(png.diagnostics);
  const auto nameOf = [&](std::size_t j) { return scene.layers[renderer.overlaySources()[j].first].description.name; };
  stats["overlap"] = {{"layers", {nameOf(overlap.a), nameOf(overlap.b)}},
                      {"op", overlapOpName(op)},
                      {"pixels", selected},
                      {"a_pixels", inA},
                      {"b_pixels", inB},
                      {"both_pixels", both},
                      {"pixels_differing_from_cpu_reference", differing},
                      {"differing_away_from_edges", differingAwayFromEdges},
                      {"groups", overlap.marks.a.groups + overlap.marks.b.groups},
                      {"gpu_ms", overlap.marks.gpuMilliseconds},
                      {"fragments", overlap.marks.fragments}};
  return png.ok();
}

int run(const Options& o) {
  Diagnostics all;
  if ((!o.lasso.empty() || !o.overlap.empty() || o.openVolumes) && o.msaa > 1) {
    logError("--lasso, --overlap and --open-volumes with --msaa " + std::to_string(o.msaa) +
             ": selection and analysis are drawn single-sampled only");
    return 2;
  }
  Result<app::SceneDescription> description = app::loadSceneFile(o.scene);
  report(description.diagnostics);
  all.append(description.diagnostics);
  if (!description) return 1;

  Result<app::LoadedScene> scene = app::loadScene(*description);
  report(scene.diagnostics);
  all.append(scene.diagnostics);
  if (!scene) return 1;

  const double exaggeration = o.exaggeration.value_or(description->verticalExaggeration);
  scene->bounds->setExaggeration(exaggeration);
  std::optional<app::Camera> camera;
  if (!o.camera.empty()) {
    Result<app::CameraSpec> spec = app::loadCameraFile(o.camera);
    report(spec.diagnostics);
    if (!spec) return 1;
    Result<app::Camera> placed = app::placeCamera(*spec, scene->frame, o.camera);
    report(placed.diagnostics);
    if (!placed) return 1;
    camera = *placed;
  } else if (description->camera) {
    Result<app::Camera> placed = app::placeCamera(*description->camera, scene->frame, o.scene);
    report(placed.diagnostics);
    if (!placed) return 1;
    camera = *placed;
  } else {
    glm::dvec3 lo, hi;
    app::terrainBox(*scene, exaggeration, lo, hi);
    camera = app::overviewCamera(lo, hi);
  }

  std::optional<app::SelectionRequest> lasso;
  if (!o.lasso.empty()) {
    Result<app::SelectionRequest> request = app::loadLassoFile(o.lasso, scene->frame, *camera, o.width, o.height);
    report(request.diagnostics);
    all.append(request.diagnostics);
    if (!request) return 1;
    lasso = std::move(*request);
  }

  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  report(context.diagnostics);
  if (!context) return 1;
  app::OverlayBuildSettings build;
  build.technique = o.technique;
  build.textureSize = o.drapeSize;
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene, build);
  report(renderer.diagnostics);
  all.append(renderer.diagnostics);
  if (!renderer) return 1;

  std::optional<std::pair<std::size_t, std::size_t>> overlapLayers;
  if (!o.overlap.empty()) {
    const std::size_t comma = o.overlap.find(',');
    const std::string nameA = o.overlap.substr(0, comma), nameB = o.overlap.substr(comma + 1);
    const std::optional<std::size_t> a = fillLayerNamed(*scene, *renderer, nameA);
    const std::optional<std::size_t> b = fillLayerNamed(*scene, *renderer, nameB);
    if (!a || !b) {
      std::string names;
      for (const app::LoadedLayer& l : scene->layers) names += (names.empty() ? "" : ", ") + l.description.name;
      logError(o.scene + ": --overlap: no drawn layer named '" + (a ? nameB : nameA) + "' (layers: " + names + ")");
      return 2;
    }
    overlapLayers.emplace(*a, *b);
  }

  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, o.msaa, true);
  app::RenderSettings settings;
  settings.lodTolerancePixels = o.lodTolerance;
  settings.verticalExaggeration = exaggeration;
  settings.measure = true;
  settings.waitForTiles = true;  // a still image: every tile the view needs
  const app::FrameStats frame = renderer->render(cache, target.framebuffer(), o.width, o.height, *camera, settings);
  std::optional<SelectionOutput> selection;
  if (lasso) {
    selection = drawSelection(cache, target, *lasso, *camera, o.width, o.height, all);
    if (!selection) return 1;
  }
  const overlay::OverlayView view = app::overlayViewOf(*camera, static_cast<double>(o.width) / o.height);
  std::optional<OverlapOutput> overlap;
  if (overlapLayers) {
    overlap = drawOverlap(cache, target, *renderer, overlapLayers->first, overlapLayers->second, o.overlapOp, view);
  }
  std::optional<OpenVolumesOutput> open;
  if (o.openVolumes) open = drawOpenVolumes(cache, target, *renderer, view);
  std::optional<gfx::RenderTarget> resolved;
  const gfx::RenderTarget* readable = &target;
  const std::size_t pixels = static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height);
  // The GPU mask has a bit per overlay layer (fills and outlines); mask.png a bit per layer of
  // the scene file, by its place there (a layer that failed to load keeps its bit, unset). With
  // MSAA a pixel has a layer's bit when at least half its samples do.
  std::vector<std::uint8_t> mask(pixels, 0);
  auto addMask = [&](const std::vector<std::uint32_t>& bits, std::vector<int>& votes) {
    for (std::size_t i = 0; i < pixels; ++i) {
      for (std::size_t j = 0; j < renderer->overlaySources().size() && j < 32; ++j) {
        const std::size_t layer = scene->layers[renderer->overlaySources()[j].first].description.fileIndex;
        if ((bits[i] >> j) & 1u && layer < 8) ++votes[i * 8 + layer];
      }
    }
  };
  std::vector<int> votes(pixels * 8, 0);
  int samples = 1;
  if (target.multisampled()) {
    resolved.emplace(o.width, o.height, 0, true);
    samples = target.samples();
    for (int k = 0; k < samples; ++k) {
      target.copySampleInto(cache, *resolved, k);
      std::vector<std::uint32_t> bits = gfx::readMask(*resolved);
      // A sample covered by several overlay layers of one scene layer (fill and outline) votes once.
      std::vector<int> sampleVotes(pixels * 8, 0);
      addMask(bits, sampleVotes);
      for (std::size_t i = 0; i < votes.size(); ++i) votes[i] += sampleVotes[i] > 0 ? 1 : 0;
    }
    target.resolveInto(*resolved);
    readable = &*resolved;
  } else {
    std::vector<int> sampleVotes(pixels * 8, 0);
    addMask(gfx::readMask(target), sampleVotes);
    for (std::size_t i = 0; i < votes.size(); ++i) votes[i] = sampleVotes[i] > 0 ? 1 : 0;
  }
  for (std::size_t i = 0; i < pixels; ++i) {
    for (std::size_t layer = 0; layer < 8; ++layer) {
      if (2 * votes[i * 8 + layer] >= samples) mask[i] = static_cast<std::uint8_t>(mask[i] | (1u << layer));
    }
  }
  std::vector<std::uint8_t> rgba = gfx::readColorRgba8(*readable);
  const std::vector<float> depth = gfx::readDepth(*readable);

  std::vector<std::uint8_t> rgb(rgba.size() / 4 * 3);
  for (std::size_t i = 0, n = rgba.size() / 4; i < n; ++i) {
    for (std::size_t c = 0; c < 3; ++c) rgb[i * 3 + c] = rgba[i * 4 + c];
  }

  const std::filesystem::path out(o.out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    logError(o.out + ": cannot create output directory: " + ec.message());
    return 1;
  }
  bool ok = true;
  for (const auto& written : {gfx::writeImage8((out / "color.png").string(), o.width, o.height, 3, rgb),
                              gfx::writeImageFloat((out / "depth.tiff").string(), o.width, o.height, depth),
                              gfx::writeImage8((out / "mask.png").string(), o.width, o.height, 1, mask)}) {
    report(written.diagnostics);
    ok = ok && written.ok();
  }

  std::size_t terrainPixels = 0;
  for (float d : depth) terrainPixels += d > 0.0F ? 1 : 0;
  json layers = json::array();
  for (std::size_t i = 0; i < scene->layers.size(); ++i) {
    const app::LoadedLayer& layer = scene->layers[i];
    const std::size_t bit = layer.description.fileIndex;
    std::size_t coveredPixels = 0;
    for (std::uint8_t m : mask) coveredPixels += bit < 8 && ((static_cast<unsigned>(m) >> bit) & 1u) != 0u ? 1u : 0u;
    json passes = json::array();
    const app::LayerSummary summary = renderer->layerSummary(*scene, i);
    for (std::size_t j = 0; j < renderer->overlaySources().size(); ++j) {
      if (renderer->overlaySources()[j].first != i) continue;
      const overlay::OverlayLayer& built = renderer->overlayLayers()[j];
      const overlay::LayerFrameStats f = j < frame.layers.size() ? frame.layers[j] : overlay::LayerFrameStats{};
      passes.push_back({{"name", built.name()},
                        {"pieces", built.stats().pieces},
                        {"triangles", built.stats().triangles},
                        {"gpu_bytes", built.stats().gpuBytes},
                        {"build_seconds", built.stats().buildSeconds},
                        {"z_pass_pieces", f.zPassPieces},
                        {"z_fail_pieces", f.zFailPieces},
                        {"culled_pieces", f.culledPieces},
                        {"cover", f.rectangleCover ? "rectangle" : "pieces"},
                        {"gpu_ms", f.gpuMilliseconds},
                        {"mark_fragments", f.markFragments},
                        {"cover_fragments", f.coverFragments}});
    }
    layers.push_back({{"name", layer.description.name},
                      {"kind", layer.description.kind == overlay::LayerKind::Polygon ? "polygon" : "line"},
                      {"source", layer.description.source},
                      {"features", summary.features},
                      {"vertices", layer.data.vertexCount()},
                      {"skipped_features", summary.skipped()},
                      {"skipped_when_read", summary.skippedReading},
                      {"skipped_when_built", summary.skippedBuilding},
                      {"features_with_nothing_to_draw", summary.nothingToDraw},
                      {"drawn_features", summary.drawnFeatures},
                      {"drawn", summary.built},
                      {"mask_bit", bit < 8 ? json(bit) : json(nullptr)},
                      {"covered_pixels", coveredPixels},
                      {"passes", passes}});
  }
  const gfx::Context& ctx = **context;
  const terrain::TerrainQuadtree& tree = *scene->quadtree;
  const terrain::TerrainGrid& grid = tree.grid();
  const terrain::NodeInfo& rootInfo = tree.info(tree.root());
  json stats = {
      {"scene", o.scene},
      {"width", o.width},
      {"height", o.height},
      {"msaa", target.samples()},
      {"gl", {{"renderer", ctx.info().renderer}, {"version", ctx.info().version}}},
      {"load_seconds", scene->loadSeconds},
      {"terrain",
       {{"posts", static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height)},
        {"paged", tree.paged()},
        {"dem_size", {grid.width, grid.height}},
        {"nodata_posts", scene->nodataPosts},
        {"quadtree_levels", tree.rootLevel() + 1},
        {"chunk_cells", tree.chunkCells()},
        {"lod_tolerance_px", o.lodTolerance},
        {"vertical_exaggeration", exaggeration},
        {"chunks", frame.terrainDraw.chunks},
        {"chunks_culled", frame.terrainCulled},
        {"finest_level", frame.finestLevel},
        {"coarsest_level", frame.coarsestLevel},
        {"triangles", frame.terrainDraw.triangles},
        {"select_ms", frame.selectMilliseconds},
        {"gpu_bytes", renderer->terrainEngine().gpuBytes()},
        {"min_height", rootInfo.minHeight},
        {"max_height", rootInfo.maxHeight},
        {"imagery", scene->orthophoto.has_value()},
        {"pixels", terrainPixels}}},
      {"layers", layers},
      {"method", o.technique->name},
      {"passes",
       {{"terrain", {{"gpu_ms", frame.terrain.gpuMilliseconds}, {"pipeline", countsJson(frame.terrain.counts)}}}}},
      {"errors", all.count(Severity::Error)},
      {"warnings", all.count(Severity::Warning)},
      {"diagnostics", diagnosticsJson(all)},
      {"gl_errors", (*context)->debug().errorCount()}};
  if (const overlay::TextureDrape* drape = renderer->textureDrape()) {
    stats["drape"] = {{"size", drape->stats().size},
                      {"triangles", drape->stats().triangles},
                      {"gpu_bytes", drape->stats().gpuBytes},
                      {"build_s", drape->stats().buildSeconds},
                      {"texel_m", {drape->extent().size.x / drape->size(), drape->extent().size.y / drape->size()}}};
  } else if (o.technique->usesTextures()) {
    stats["drape"] = {{"tile_size", o.drapeSize},
                      {"tiles_built", frame.texturesBuilt},
                      {"gpu_bytes", renderer->techniqueGpuBytes()},
                      {"build_s", frame.textureSeconds}};
  }
  if (selection) {
    ok =
        writeSelection(out, *selection, *lasso, *scene, *renderer, *camera, depth, o.width, o.height, all, stats) && ok;
    stats["errors"] = all.count(Severity::Error);
    stats["warnings"] = all.count(Severity::Warning);
    stats["diagnostics"] = diagnosticsJson(all);
  }
  if (overlap) {
    ok = writeOverlap(out, *overlap, o.overlapOp, *renderer, *scene, view.viewProj, depth, o.width, o.height, stats) &&
         ok;
  }
  if (open) {
    const Result<bool> png = gfx::writeImage8((out / "open_volumes.png").string(), o.width, o.height, 1, open->pixels);
    report(png.diagnostics);
    ok = ok && png.ok();
    stats["open_volumes"] = {{"open_pixels", open->openPixels}, {"layers", open->layers}};
  }
  ok = writeJson(out / "camera.json", app::cameraToJson(*camera, scene->frame, o.width, o.height)) && ok;
  ok = writeJson(out / "stats.json", stats) && ok;
  if (!ok) return 1;
  std::printf("%s\n", (std::filesystem::absolute(out) / "color.png").string().c_str());
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return gis::app::programMain(
      argc, argv, "overlay_render", usage().c_str(), [&](int n, char** v) { return parseArgs(n, v, options); },
      [&] { return run(options); });
}
