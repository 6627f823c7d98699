#include "globe_render.hpp"

#include <filesystem>

#include <nlohmann/json.hpp>

#include "app/cli.hpp"
#include "frame_output.hpp"
#include "gfx/context.hpp"
#include "gfx/image_io.hpp"
#include "gfx/render_target.hpp"
#include "globe/globe_renderer.hpp"
#include "scene/camera.hpp"
#include "scene/frame_readback.hpp"
#include "scene/globe_scene.hpp"
#include "vector_overlay/texture_drape.hpp"

namespace gis::app {

namespace {

using nlohmann::json;

json matrixJson(const glm::dmat4& m) {
  json out = json::array();
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) out.push_back(m[c][r]);
  }
  return out;
}

}  // namespace

int runGlobeRender(const scene::SceneDescription& description, const std::string& reason, const GlobeRenderOptions& o) {
  scene::SceneDescription d = description;
  if (!o.overlays) d.layers.clear();
  Result<scene::LoadedGlobeScene> loaded = scene::loadGlobeScene(d);
  report(loaded.diagnostics);
  if (!loaded) return 1;
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  report(context.diagnostics);
  if (!context) return 1;

  globe::GlobeView view = scene::globeStillView(*loaded, o.width, o.height);
  if (!o.camera.empty()) {
    Result<scene::CameraSpec> spec = scene::loadCameraFile(o.camera);
    report(spec.diagnostics);
    if (!spec) return 1;
    Result<globe::GlobeView> placed = scene::globeViewOf(*spec, *loaded->heights, o.width, o.height, o.camera);
    report(placed.diagnostics);
    if (!placed) return 1;
    view = *placed;
  }
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, o.msaa, true);
  globe::GlobeRenderer renderer(loaded->heights);
  renderer.setImagery(loaded->imagery);
  std::vector<const globe::GlobeLayer*> layers;
  for (const globe::GlobeLayer& l : loaded->layers) layers.push_back(&l);
  // A still waits for every drawn tile's imagery (built a few tiles a frame).
  for (int k = 0; k < 4096 && loaded->imagery; ++k) {
    if (renderer.render(cache, {target.framebuffer(), o.width, o.height, true}, view, {}).terrain.imageryPending == 0)
      break;
  }
  globe::GlobeOverlaySettings overlaySettings = scene::globeOverlaySettings(loaded->description);
  overlaySettings.technique = o.technique;
  overlaySettings.textureSize = o.textureSize;
  const globe::GlobeFrameStats stats =
      renderer.render(cache, {target.framebuffer(), o.width, o.height, true}, view, layers, true, overlaySettings);
  runClock().firstFrameDone();
  const std::filesystem::path out(o.out);
  std::filesystem::create_directories(out);
  // An analysis that fails (its lasso file, a file it writes) still leaves the frame's files and
  // stats.json with its messages, as the projected path does; the exit status says it failed.
  json analyses = json::object();
  Diagnostics analysisDiagnostics;
  const int analysisStatus =
      drawGlobeAnalyses(o.analyses, cache, target, renderer, *loaded, view, out, analyses, analysisDiagnostics);
  if (analysisStatus == 2) return analysisStatus;  // a layer named that is not in the scene: nothing drawn

  // color.png, depth.tiff and mask.png (bit i for the scene file's layer i), read as the projected
  // path reads them (resolved with MSAA, a layer's bit where half the samples have it).
  const scene::FrameImages images = scene::readFrame(cache, target, loaded->layerFileIndex);
  bool ok = writeFrameImages(out, o.width, o.height, images.rgb, images.depth, images.mask);
  const globe::Geodetic eye = globe::toGeodetic(view.eye), at = globe::toGeodetic(view.target);
  json camera = {{"width", o.width},
                 {"height", o.height},
                 {"frame", "globe"},
                 {"crs", "EPSG:4978 (WGS 84 earth-centred, metres)"},
                 {"view_proj_ecef", matrixJson(view.viewProj())},
                 {"eye_ecef", {view.eye.x, view.eye.y, view.eye.z}},
                 {"depth", "reversed-Z: near / distance along the view axis, 0 = background"},
                 {"near", view.near},
                 {"fov_y_deg", view.fovYDeg},
                 {"eye", {{"lon", eye.lon}, {"lat", eye.lat}, {"h", eye.h}}},
                 {"target", {{"lon", at.lon}, {"lat", at.lat}, {"h", at.h}}}};
  json layersJson = json::array();
  for (std::size_t l = 0; l < loaded->layers.size(); ++l) {
    layersJson.push_back({{"name", loaded->layers[l].name()},
                          {"polygons", loaded->layers[l].polygons().size()},
                          {"mask_bit", loaded->layerFileIndex[l]},
                          {"covered_pixels", l < images.coveredPixels.size() ? images.coveredPixels[l] : 0U}});
  }
  json diagnostics = json::array();
  for (const Diagnostic& m : loaded.diagnostics.items()) diagnostics.push_back(m.toString());
  for (const Diagnostic& m : analysisDiagnostics.items()) diagnostics.push_back(m.toString());
  json s = {{"frame", "globe"},
            {"method", o.method},
            {"globe_reason", reason},
            {"width", o.width},
            {"height", o.height},
            {"msaa", images.samples},
            {"load_seconds", loaded->loadSeconds},
            {"first_frame_seconds", runClock().firstFrameSeconds},
            {"cpu_peak_bytes", peakResidentBytes()},
            {"dem",
             {{"width", loaded->heights->width()},
              {"height", loaded->heights->height()},
              {"step_deg", loaded->heights->step()},
              {"vertical_datum", loaded->heights->verticalSource()},
              {"vertical_exaggeration", loaded->heights->exaggeration()},
              {"paged", loaded->heights->paged()},
              {"resident_bytes", loaded->heights->residentBytes()},
              {"blocks_read", loaded->heights->blocksRead()},
              {"posts_read", loaded->heights->postsRead()}}},
            {"terrain",
             {{"tiles", stats.terrain.tiles},
              {"triangles", stats.terrain.triangles},
              {"select_ms", stats.selectMilliseconds},
              {"gpu_ms", stats.terrainGpuMilliseconds},
              {"fragments", stats.terrainFragments},
              {"imagery_source_pixels_read", loaded->imagery ? loaded->imagery->sourcePixelsRead() : 0U}}},
            {"overlay",
             {{"pieces", stats.overlay.pieces},
              {"z_fail_pieces", stats.overlay.zFailPieces},
              {"culled_pieces", stats.overlay.culledPieces},
              {"triangles", stats.overlay.triangles},
              {"tiles_built", stats.overlay.builtTiles},
              {"deferred_layers", stats.overlay.deferredLayers},
              {"deferred_index_bytes", stats.overlay.deferredBytes},
              {"deferred_pending", stats.overlay.deferredPending},
              {"gpu_ms", stats.overlayGpuMilliseconds},
              {"fragments", stats.overlayFragments},
              {"primitives", stats.overlayPrimitives}}},

            {"layers", layersJson},
            {"diagnostics", diagnostics}};
  // The layers' tiles (over the terrain's drawn tiles), as a projected scene's "tiles" block, and
  // what the globe's disk cache did.
  json tiles = tilesJson(stats.overlay.tiles, stats.overlay.residentBytes);
  tiles.update({{"missing", stats.overlay.missingTiles},
                {"built_anew", stats.overlay.builtTiles},
                {"written_to_disk", stats.overlay.writtenTiles},
                {"repaired", stats.overlay.repairedTiles},
                {"evicted", stats.overlay.evictedTiles},
                {"gpu_budget_bytes", overlaySettings.gpuBudgetBytes}});
  if (stats.overlay.draped || globe::drapes(o.technique)) {
    // Draping: the textures (in longitude and latitude), as a projected scene's "drape" block.
    json drape = {{"tiles_built", stats.overlay.texturesBuilt},
                  {"gpu_bytes", stats.overlay.drapeGpuBytes},
                  {"build_s", stats.overlay.textureSeconds}};
    if (const overlay::TextureDrape* single = renderer.overlay().textureDrape()) {
      drape.update(
          {{"size", single->size()},
           {"triangles", single->stats().triangles},
           {"texel_deg", {single->extent().size.x / single->size(), single->extent().size.y / single->size()}}});
    } else {
      drape["tile_size"] = o.textureSize > 0 ? o.textureSize : 256;
    }
    s["drape"] = drape;
  } else {
    s["tiles"] = tiles;
  }
  s.update(analyses);
  ok = writeJson(out / "camera.json", camera) && ok;
  ok = writeJson(out / "stats.json", s) && ok;
  if (!ok) return 1;
  if (analysisStatus != 0) return analysisStatus;
  return (*context)->debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace gis::app
