#include "globe_analysis.hpp"

#include <chrono>

#include <nlohmann/json.hpp>

#include "analysis_report.hpp"
#include "app/cli.hpp"
#include "core/log.hpp"
#include "gfx/image_io.hpp"
#include "globe/globe_selection.hpp"
#include "scene/frame_readback.hpp"
#include "scene/globe_selection.hpp"
#include "scene/lasso_file.hpp"

namespace gis::app {

namespace {

using nlohmann::json;

/// The area layer (not an outline) named `name`.
std::optional<std::size_t> layerNamed(const scene::LoadedGlobeScene& scene, const std::string& name) {
  for (std::size_t l = 0; l < scene.layers.size(); ++l) {
    if (scene.layers[l].name() == name) return l;
  }
  return std::nullopt;
}

int drawOverlap(const GlobeAnalysisRequest& request, gfx::StateCache& cache, const gfx::RenderTarget& target,
                globe::GlobeRenderer& renderer, const scene::LoadedGlobeScene& scene, const globe::GlobeView& view,
                const std::vector<float>& depth, const std::filesystem::path& out, json& stats) {
  const std::size_t comma = request.overlap.find(',');
  const std::string nameA = request.overlap.substr(0, comma), nameB = request.overlap.substr(comma + 1);
  const std::optional<std::size_t> a = layerNamed(scene, nameA), b = layerNamed(scene, nameB);
  if (!a || !b) {
    std::string names;
    for (const globe::GlobeLayer& l : scene.layers) names += (names.empty() ? "" : ", ") + l.name();
    logError(scene.description.path + ": --overlap: no drawn layer named '" + (a ? nameB : nameA) +
             "' (layers: " + names + ")");
    return 2;
  }
  overlay::OverlayRenderer* overlays = renderer.overlay().renderer();
  if (overlays == nullptr) return 1;
  // The stencil core's analysis on the tiles' chunks, as in a projected frame.
  const auto chunksA = renderer.overlay().chunks(view, renderer.tiles(), renderer.heights(), scene.layers[*a]);
  const auto chunksB = renderer.overlay().chunks(view, renderer.tiles(), renderer.heights(), scene.layers[*b]);
  const scene::OverlapPixels overlap =
      scene::drawOverlap(cache, target, *overlays, chunksA, chunksB, request.overlapOp, globe::overlayViewOf(view));

  const overlay::DepthImage image = globe::depthImageOf(view, depth);
  const std::vector<const globe::GlobeLayer*> pair{&scene.layers[*a], &scene.layers[*b]};
  const std::vector<std::uint32_t> expected = overlay::referenceMask(image, globe::coverageOf(pair, image));
  const std::vector<std::uint8_t> edges = overlay::edgePixels(image, globe::edgeLayersOf(pair, image));
  const OverlapCounts counts = countOverlap(overlap.flags, expected, edges, request.overlapOp);
  const Result<bool> png = gfx::writeImage8((out / "overlap.png").string(), view.width, view.height, 1, counts.pixels);
  report(png.diagnostics);
  stats["overlap"] = overlapJson(counts, nameA, nameB, request.overlapOp, overlap.marks);
  return png.ok() ? 0 : 1;
}

int drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target, globe::GlobeRenderer& renderer,
                    const scene::LoadedGlobeScene& scene, const globe::GlobeView& view,
                    const std::filesystem::path& out, json& stats) {
  overlay::OverlayRenderer* overlays = renderer.overlay().renderer();
  if (overlays == nullptr) return 1;
  std::vector<scene::ChunkedLayer> layers;
  for (const globe::GlobeLayer& layer : scene.layers)
    layers.push_back({layer.name(), renderer.overlay().chunks(view, renderer.tiles(), renderer.heights(), layer)});
  const scene::OpenVolumePixels open =
      scene::drawOpenVolumes(cache, target, *overlays, layers, globe::overlayViewOf(view));
  const Result<bool> png =
      gfx::writeImage8((out / "open_volumes.png").string(), view.width, view.height, 1, open.pixels);
  report(png.diagnostics);
  stats["open_volumes"] = openVolumesJson(open);
  return png.ok() ? 0 : 1;
}

int drawSelection(const GlobeAnalysisRequest& request, gfx::StateCache& cache, const gfx::RenderTarget& target,
                  const scene::LoadedGlobeScene& scene, const globe::GlobeView& view, const std::vector<float>& depth,
                  const std::filesystem::path& out, json& stats, Diagnostics& diagnostics) {
  Result<scene::SelectionRequest> lassos = scene::loadGlobeLassoFile(request.lasso, view, *scene.heights);
  report(lassos.diagnostics);
  diagnostics.append(lassos.diagnostics);
  if (!lassos) return 1;
  Result<scene::SelectionPixels> drawn = scene::drawSelection(cache, target, *lassos, globe::overlayViewOf(view));
  report(drawn.diagnostics);
  diagnostics.append(drawn.diagnostics);
  if (!drawn) return 1;
  const overlay::DepthImage image = globe::depthImageOf(view, depth);
  const std::vector<std::uint8_t> twin = overlay::selectionMask(image, lassos->steps);
  // The twin's edge band: where its answer changes within a pixel's neighbours.
  const std::vector<std::uint32_t> twinBits(twin.begin(), twin.end());
  const std::vector<std::uint8_t> edges = overlay::maskEdges(twinBits, image);
  std::size_t selected = 0, differing = 0, differingAwayFromEdges = 0;
  for (std::size_t i = 0; i < twin.size() && i < drawn->pixels.size(); ++i) {
    const bool gpu = drawn->pixels[i] != 0, cpu = twin[i] != 0;
    selected += gpu ? 1U : 0U;
    differing += gpu != cpu ? 1U : 0U;
    differingAwayFromEdges += gpu != cpu && edges[i] == 0 ? 1U : 0U;
  }
  const Result<bool> png =
      gfx::writeImage8((out / "selection.png").string(), view.width, view.height, 1, drawn->pixels);
  report(png.diagnostics);
  // The features: the selection's logical twin.
  const auto logicalStart = std::chrono::steady_clock::now();
  const scene::GlobeSelection chosen = scene::selectOnGlobe(scene, lassos->steps, view, lassos->sampleSpacing);
  const double logicalSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - logicalStart).count();
  json layers = json::array();
  for (const scene::GlobeLayerSelection& l : chosen.layers) {
    const overlay::SharedFeatures* features =
        l.layer < scene.layerFeatures.size() ? &scene.layerFeatures[l.layer] : nullptr;
    json list = json::array();
    for (const overlay::FeatureSelection& f : l.features) {
      const std::int64_t fid = features && f.feature < features->size() ? features->get(f.feature)->fid : -1;
      list.push_back({{"fid", fid},
                      {"fully_inside", f.fullyInside},
                      {"samples", f.samples},
                      {"selected_samples", f.selectedSamples},
                      {"spacing_m", f.spacing}});
    }
    // The scene file's name for the layer, as the export's files and properties have it.
    const scene::LayerDescription* described = scene::sceneLayerOf(scene, l.layer);
    const std::string name = described != nullptr ? described->name : scene.layers[l.layer].name();
    layers.push_back({{"name", name},
                      {"selected", l.features.size()},
                      {"fully_inside", l.fullyInside},
                      {"file", scene::selectedLayerFileName(name)},
                      {"features", list}});
  }
  // The GeoJSON exports, as a projected scene's: the combined RFC 7946 file and one per layer.
  const Diagnostics exported = scene::exportGlobeSelection(scene, chosen, out / "selected_features.json", out);
  report(exported);
  diagnostics.append(exported);
  const bool written = !exported.hasErrors();
  const overlay::SelectionFrameStats& s = drawn->stats;
  stats["selection"] = {{"steps", lassos->steps.size()},
                        {"scheme", lassos->scheme == overlay::SelectionScheme::Runs ? "runs" : "report"},
                        {"volumes", s.volumes},
                        {"triangles", s.triangles},
                        {"screen_passes", s.screenPasses},
                        {"gpu_ms", s.gpuMilliseconds},
                        {"fragments", s.fragments},
                        {"selected_pixels", selected},
                        {"pixels_differing_from_cpu_twin", differing},
                        {"differing_away_from_edges", differingAwayFromEdges},
                        {"sample_spacing_m", chosen.sampleSpacing},
                        {"logical_seconds", logicalSeconds},
                        {"tested_samples", chosen.testedSamples},
                        {"layers", layers},
                        {"dem_posts", nullptr}};  // not computed on the globe
  return png.ok() && written ? 0 : 1;
}

}  // namespace

int drawGlobeAnalyses(const GlobeAnalysisRequest& request, gfx::StateCache& cache, const gfx::RenderTarget& target,
                      globe::GlobeRenderer& renderer, const scene::LoadedGlobeScene& scene,
                      const globe::GlobeView& view, const std::filesystem::path& out, json& stats,
                      Diagnostics& diagnostics) {
  if (request.overlap.empty() && request.lasso.empty() && !request.openVolumes) return 0;
  const std::vector<float> depth = gfx::readDepth(target);
  if (!request.overlap.empty()) {
    if (const int status = drawOverlap(request, cache, target, renderer, scene, view, depth, out, stats); status != 0)
      return status;
  }
  if (request.openVolumes) {
    if (const int status = drawOpenVolumes(cache, target, renderer, scene, view, out, stats); status != 0)
      return status;
  }
  if (!request.lasso.empty()) return drawSelection(request, cache, target, scene, view, depth, out, stats, diagnostics);
  return 0;
}

}  // namespace gis::app
