// overlay_bench --mode globe: a scene on the globe (docs/globe.md), drawn along a path from space
// down to a few kilometres (the data's middle from 9,000 km, the continent from 3,000 km and
// 500 km, low over its edge, across the antimeridian, over the south pole); regional data
// (smaller than 200 km) along a path of its own: above it, obliquely, low over an edge, 100 m up. Each frame is drawn
// once to build what it needs, then timed with the terrain alone and with the overlays, one after
// the other (GPU timer queries): the ratio of the two is taken frame by frame, as the machine is
// shared. Each frame's mask is compared with the CPU reference of the same depth buffer
// (globe::coverageOf, edgePixels): wrong pixels away from edges are counted, and the run's exit
// status is 3 when there are any. The same frames by the deferred lookup (where it has layers to
// draw) and, with --texture-sizes drape-tiles=N, by texture draping per tile at N² texels a tile
// (the baseline of other viewers: its error is measured, not failed on). Writes bench.json and
// frames.csv.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>

#include "bench_common.hpp"
#include "gfx/render_target.hpp"
#include "globe/globe_renderer.hpp"
#include "scene/globe_scene.hpp"

namespace gis::bench {

namespace {

struct GlobeFrame {
  std::string segment;
  globe::Geodetic eye, target;
};

/// Where the path looks: the scene camera's target, else the middle of the data.
globe::Geodetic focusOf(const scene::LoadedGlobeScene& s) {
  if (s.description.camera && s.description.camera->targetLonLatH) {
    const glm::dvec3 t = *s.description.camera->targetLonLatH;
    return {t.x, t.y, 0.0};
  }
  const auto [west, south, east, north] = s.extent;
  return {0.5 * (west + std::min(east, west + 360.0)), 0.5 * (south + north), 0.0};
}

/// The point of the layers' rings nearest the focus (an edge to fly low over), else the focus.
globe::Geodetic edgeNear(const scene::LoadedGlobeScene& s, const globe::Geodetic& focus) {
  globe::Geodetic best = focus;
  double nearest = std::numeric_limits<double>::max();
  const glm::dvec3 f = globe::toEcef(focus);
  for (const globe::GlobeLayer& layer : s.layers) {
    for (const globe::GlobePolygon& p : layer.polygons()) {
      for (const auto& ring : p.rings) {
        for (std::size_t k = 0; k < ring.size(); k += 16) {
          const double d = glm::length(globe::toEcef(ring[k].x, ring[k].y, 0.0) - f);
          if (d < nearest) {
            nearest = d;
            best = {ring[k].x, ring[k].y, 0.0};
          }
        }
      }
    }
  }
  return best;
}

/// The data's size, metres: the larger side of its box.
double extentMetres(const scene::LoadedGlobeScene& s) {
  const auto [west, south, east, north] = s.extent;
  const double midLat = 0.5 * (south + north) * 3.14159265358979323846 / 180.0;
  return 111320.0 * std::max((std::min(east, west + 360.0) - west) * std::cos(midLat), north - south);
}

/// The path over regional data (a city, a county: smaller than 200 km): from above it, obliquely
/// over it, low over its edge, and a few hundred metres above its middle.
std::vector<GlobeFrame> regionalPath(const scene::LoadedGlobeScene& s, int frames) {
  const globe::Geodetic focus = focusOf(s);
  const globe::Geodetic edge = edgeNear(s, focus);
  const double size = extentMetres(s), degrees = size / 111320.0;
  const int per = std::max(1, frames / 4);
  std::vector<GlobeFrame> out;
  const auto ground = [&](double lon, double lat) { return std::max(s.heights->heightAt(lon, lat), 0.0); };
  const auto segment = [&](const std::string& name, auto&& at) {
    for (int k = 0; k < per; ++k) {
      GlobeFrame f = at(per == 1 ? 0.0 : static_cast<double>(k) / (per - 1));
      f.segment = name;
      out.push_back(f);
    }
  };
  segment("above the data", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.2;
    return GlobeFrame{{}, {l, focus.lat, 1.2 * size}, {l, focus.lat, 0.0}};
  });
  segment("oblique over the data", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.3;
    return GlobeFrame{{}, {l, focus.lat - 0.6 * degrees, 0.3 * size}, {l, focus.lat, ground(l, focus.lat)}};
  });
  segment("low over an edge", [&](double t) {
    const double l = edge.lon + degrees * (t - 0.5) * 0.05;
    const double h = ground(l, edge.lat);
    return GlobeFrame{{}, {l, edge.lat - 0.02 * degrees, h + 0.02 * size}, {l, edge.lat, h}};
  });
  segment("street level", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.02;
    const double h = ground(l, focus.lat);
    return GlobeFrame{{}, {l, focus.lat - 0.004 * degrees, h + 100.0}, {l, focus.lat, h}};
  });
  return out;
}

/// The path: six segments of frames, each moving a little across the data (regionalPath for data
/// smaller than 200 km).
std::vector<GlobeFrame> globePath(const scene::LoadedGlobeScene& s, int frames) {
  if (extentMetres(s) < 2e5) return regionalPath(s, frames);
  const globe::Geodetic focus = focusOf(s);
  const globe::Geodetic edge = edgeNear(s, focus);
  const double lon = focus.lon, lat = focus.lat;
  const int per = std::max(1, frames / 6);
  std::vector<GlobeFrame> out;
  const auto segment = [&](const std::string& name, auto&& at) {
    for (int k = 0; k < per; ++k) {
      const double t = per == 1 ? 0.0 : static_cast<double>(k) / (per - 1);
      GlobeFrame f = at(t);
      f.segment = name;
      out.push_back(f);
    }
  };
  segment("space 9000 km", [&](double t) {
    const double l = lon - 20.0 + 40.0 * t;
    return GlobeFrame{{}, {l, lat, 9e6}, {l, lat, 0.0}};
  });
  segment("continent 3000 km", [&](double t) {
    const double l = lon - 10.0 + 20.0 * t;
    return GlobeFrame{{}, {l, lat - 25.0, 3e6}, {l, lat, 0.0}};
  });
  segment("regional 500 km", [&](double t) {
    const double l = edge.lon - 2.0 + 4.0 * t;
    return GlobeFrame{{}, {l, edge.lat - 4.0, 5e5}, {l, edge.lat, 0.0}};
  });
  segment("low 5 km over an edge", [&](double t) {
    const double l = edge.lon - 0.1 + 0.2 * t;
    const double ground = std::max(s.heights->heightAt(l, edge.lat), 0.0);
    return GlobeFrame{{}, {l, edge.lat - 0.2, ground + 5000.0}, {l, edge.lat, ground}};
  });
  segment("antimeridian 1500 km", [&](double t) {
    const double l = 170.0 + 20.0 * t;
    return GlobeFrame{{}, {l, 60.0, 1.5e6}, {l, 66.0, 0.0}};
  });
  segment("south pole 2000 km", [&](double t) {
    const double l = -180.0 + 90.0 * t;
    return GlobeFrame{{}, {l, -75.0, 2e6}, {l + 180.0, -88.0, 0.0}};
  });
  return out;
}

/// The frame in `target` (drawn from `view`) against the CPU reference of its own depth buffer.
struct FrameError {
  std::size_t covered = 0, wrong = 0, edgeWrong = 0;  ///< wrong: away from edges
};
FrameError frameError(const gfx::RenderTarget& target, const globe::GlobeView& view,
                      const std::vector<const globe::GlobeLayer*>& layers) {
  const std::vector<float> depth = gfx::readDepth(target);
  const std::vector<std::uint32_t> mask = gfx::readMask(target);
  const overlay::DepthImage image = globe::depthImageOf(view, depth);
  const std::vector<std::uint32_t> expected = overlay::referenceMask(image, globe::coverageOf(layers, image));
  const std::vector<std::uint8_t> edges = overlay::edgePixels(image, globe::edgeLayersOf(layers, image));
  FrameError e;
  for (std::size_t i = 0; i < mask.size() && i < expected.size(); ++i) {
    e.covered += expected[i] != 0 ? 1U : 0U;
    if (mask[i] == expected[i]) continue;
    ++(edges[i] != 0 ? e.edgeWrong : e.wrong);
  }
  return e;
}

}  // namespace

int runGlobe(const Options& o) {
  const auto start = std::chrono::steady_clock::now();
  Result<scene::SceneDescription> description = scene::loadSceneFile(o.scene);
  app::report(description.diagnostics);
  if (!description) return 1;
  Result<scene::LoadedGlobeScene> loaded = scene::loadGlobeScene(*description);
  app::report(loaded.diagnostics);
  if (!loaded) return 1;
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Result<std::unique_ptr<gfx::Context>> context = gfx::createHeadlessContext({});
  app::report(context.diagnostics);
  if (!context) return 1;

  std::vector<const globe::GlobeLayer*> layers;
  std::size_t vertices = 0;
  for (const globe::GlobeLayer& l : loaded->layers) {
    layers.push_back(&l);
    for (const globe::GlobePolygon& p : l.polygons()) {
      for (const auto& ring : p.rings) vertices += ring.size();
    }
  }
  gfx::StateCache cache;
  gfx::RenderTarget target(o.width, o.height, 0, true);
  const globe::GlobeFrameTarget frameTarget{target.framebuffer(), o.width, o.height, true};
  globe::GlobeRenderer renderer(loaded->heights);
  const globe::GlobeOverlaySettings overlaySettings = scene::globeOverlaySettings(loaded->description);
  // The deferred lookup on the same frames, where it has layers to draw (the last layers of areas
  // or of lines: globe::deferredDraws; a layer whose index would not fit, or lines in pixels a
  // view sees beyond the widest reach class, keep their pieces in it).
  globe::GlobeOverlaySettings lookupSettings = overlaySettings;
  lookupSettings.technique = globe::GlobeTechnique::Deferred;
  const bool lookup = !layers.empty() && globe::deferredDraws(*layers.back());
  // Texture draping per tile on the same frames, when asked for: the error against run time of
  // the baseline.
  globe::GlobeOverlaySettings drapeSettings = overlaySettings;
  drapeSettings.technique = globe::GlobeTechnique::DrapeTiles;
  const auto drapeSizes = o.textureSizes.find("drape-tiles");
  const bool drape = !layers.empty() && drapeSizes != o.textureSizes.end() && !drapeSizes->second.empty();
  if (drape) drapeSettings.textureSize = drapeSizes->second.front();
  std::vector<double> drapeRatios;
  std::map<std::string, std::vector<double>> segmentDrapeRatios;
  std::size_t drapeWrong = 0, drapeCovered = 0, drapeBytes = 0;
  double indexSeconds = 0.0;
  std::size_t indexBytes = 0;
  renderer.setImagery(loaded->imagery);
  const std::vector<GlobeFrame> path = globePath(*loaded, o.frames);

  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / "frames.csv");
  csv << "frame,segment,terrain_only_ms,terrain_ms,overlay_ms,ratio,tiles,terrain_triangles,pieces,z_fail_pieces,"
         "overlay_triangles,terrain_fragments,overlay_fragments,build_ms,covered_px,wrong_px,edge_px,"
         "deferred_overlay_ms,deferred_ratio,deferred_fragments,deferred_wrong_px,deferred_layers,drape_ms,drape_"
         "ratio,drape_wrong_px\n";
  std::vector<double> ratios, terrainOnly, withOverlay, lookupRatios;
  std::map<std::string, std::vector<double>> segmentLookupRatios;
  std::map<std::string, std::vector<double>> segmentRatios, segmentTerrain, segmentOverlay;
  std::map<std::string, double> segmentPieces, segmentTiles, segmentTriangles, segmentWrong;
  std::size_t wrongTotal = 0;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const GlobeFrame& f = path[k];
    const double ground = loaded->heights->heightAt(f.eye.lon, f.eye.lat);
    const globe::GlobeView view =
        globe::GlobeView::looking(globe::toEcef(f.eye), globe::toEcef(f.target), 45.0, o.width, o.height, ground);
    // Untimed: builds the tiles and pieces this view needs.
    const auto buildStart = std::chrono::steady_clock::now();
    for (int n = 0; n < 4096; ++n) {  // every tile's imagery built before timing
      if (renderer.render(cache, frameTarget, view, layers, false, overlaySettings).terrain.imageryPending == 0) break;
    }
    glFinish();
    const double buildMs = msSince(buildStart);
    const globe::GlobeFrameStats bare = renderer.render(cache, frameTarget, view, {}, true);
    const globe::GlobeFrameStats full = renderer.render(cache, frameTarget, view, layers, true, overlaySettings);
    const double ratio = (full.terrainGpuMilliseconds + full.overlayGpuMilliseconds) / bare.terrainGpuMilliseconds;
    // The error (every --error-every frames): the frame's mask against the reference of its own
    // depth buffer.
    FrameError error;
    if (k % static_cast<std::size_t>(std::max(1, o.errorEvery)) == 0) error = frameError(target, view, layers);
    const std::size_t covered = error.covered, wrong = error.wrong, edgeWrong = error.edgeWrong;
    wrongTotal += wrong;
    // The same frame by the deferred lookup (its indices built at the first, untimed).
    globe::GlobeFrameStats looked;
    double lookupRatio = 0.0;
    FrameError lookupError;
    if (lookup) {
      if (k == 0) {
        const auto indexStart = std::chrono::steady_clock::now();
        (void)renderer.render(cache, frameTarget, view, layers, false, lookupSettings);
        glFinish();
        indexSeconds = msSince(indexStart) * 1e-3;
      }
      looked = renderer.render(cache, frameTarget, view, layers, true, lookupSettings);
      indexBytes = looked.overlay.deferredBytes;
      lookupRatio = (looked.terrainGpuMilliseconds + looked.overlayGpuMilliseconds) / bare.terrainGpuMilliseconds;
      lookupRatios.push_back(lookupRatio);
      segmentLookupRatios[f.segment].push_back(lookupRatio);
      if (k % static_cast<std::size_t>(std::max(1, o.errorEvery)) == 0) lookupError = frameError(target, view, layers);
      wrongTotal += lookupError.wrong;
    }
    // The same frame draped per tile (its textures rasterised first, untimed).
    globe::GlobeFrameStats draped;
    double drapeRatio = 0.0;
    FrameError drapeError;
    if (drape) {
      (void)renderer.render(cache, frameTarget, view, layers, false, drapeSettings);
      draped = renderer.render(cache, frameTarget, view, layers, true, drapeSettings);
      drapeBytes = std::max(drapeBytes, draped.overlay.drapeGpuBytes);
      drapeRatio = draped.terrainGpuMilliseconds / bare.terrainGpuMilliseconds;
      drapeRatios.push_back(drapeRatio);
      segmentDrapeRatios[f.segment].push_back(drapeRatio);
      if (k % static_cast<std::size_t>(std::max(1, o.errorEvery)) == 0) {
        drapeError = frameError(target, view, layers);
        drapeWrong += drapeError.wrong;
        drapeCovered += drapeError.covered;
      }
    }
    segmentWrong[f.segment] += static_cast<double>(wrong);
    csv << k << ',' << f.segment << ',' << bare.terrainGpuMilliseconds << ',' << full.terrainGpuMilliseconds << ','
        << full.overlayGpuMilliseconds << ',' << ratio << ',' << full.terrain.tiles << ',' << full.terrain.triangles
        << ',' << full.overlay.pieces << ',' << full.overlay.zFailPieces << ',' << full.overlay.triangles << ','
        << bare.terrainFragments << ',' << full.overlayFragments << ',' << buildMs << ',' << covered << ',' << wrong
        << ',' << edgeWrong << ',' << looked.overlayGpuMilliseconds << ',' << lookupRatio << ','
        << looked.overlayFragments << ',' << lookupError.wrong << ',' << looked.overlay.deferredLayers << ','
        << draped.terrainGpuMilliseconds << ',' << drapeRatio << ',' << drapeError.wrong << '\n';
    ratios.push_back(ratio);
    terrainOnly.push_back(bare.terrainGpuMilliseconds);
    withOverlay.push_back(full.terrainGpuMilliseconds + full.overlayGpuMilliseconds);
    segmentRatios[f.segment].push_back(ratio);
    segmentTerrain[f.segment].push_back(bare.terrainGpuMilliseconds);
    segmentOverlay[f.segment].push_back(full.terrainGpuMilliseconds + full.overlayGpuMilliseconds);
    segmentPieces[f.segment] += static_cast<double>(full.overlay.pieces);
    segmentTiles[f.segment] += static_cast<double>(full.terrain.tiles);
    segmentTriangles[f.segment] += static_cast<double>(full.overlay.triangles);
  }
  // A one-feature edit, as the projected overlay mode times it: the first feature of the first
  // layer with its first point moved 10 m east; the time to prepare it again and drop the tiles it
  // reaches, and the next frame from the path's last view (checked against the reference too).
  json edit;
  if (!loaded->layers.empty() && !loaded->layerFeatures.empty() && loaded->layerFeatures[0].size() > 0 &&
      !path.empty()) {
    globe::GlobeLayer& layer = loaded->layers[0];
    geo::Feature feature = *loaded->layerFeatures[0].get(0);
    glm::dvec2* first = !feature.polygons.empty() && !feature.polygons[0].outer.empty() ? &feature.polygons[0].outer[0]
                        : !feature.lines.empty() && !feature.lines[0].empty()           ? &feature.lines[0][0]
                                                                                        : nullptr;
    if (first != nullptr) {
      first->x += 10.0 / (111320.0 * std::max(std::cos(first->y * 3.14159265358979323846 / 180.0), 1e-6));
      const auto editStart = std::chrono::steady_clock::now();
      const Result<std::vector<globe::LonLatRect>> boxes = layer.replaceFeature(0, feature);
      app::report(boxes.diagnostics);
      const std::size_t dropped = boxes ? renderer.overlay().featureChanged(layer, *boxes) : 0;
      const double editMs = msSince(editStart);
      const GlobeFrame& f = path.back();
      const globe::GlobeView view =
          globe::GlobeView::looking(globe::toEcef(f.eye), globe::toEcef(f.target), 45.0, o.width, o.height,
                                    loaded->heights->heightAt(f.eye.lon, f.eye.lat));
      const auto frameStart = std::chrono::steady_clock::now();
      const globe::GlobeFrameStats next = renderer.render(cache, frameTarget, view, layers, true, overlaySettings);
      const double frameMs = msSince(frameStart);
      const std::size_t wrong = frameError(target, view, layers).wrong;
      wrongTotal += wrong;
      edit = {{"layer", layer.name()},
              {"rebuild_ms", editMs},
              {"tiles_dropped", dropped},
              {"next_frame_ms", frameMs},
              {"next_frame_tiles_built", next.overlay.builtTiles},
              {"wrong_pixels", wrong}};
    }
  }
  json segments = json::object();
  for (const auto& [name, r] : segmentRatios) {
    segments[name] = {{"ratio_median", percentile(r, 50.0)},
                      {"terrain_only_ms_median", percentile(segmentTerrain[name], 50.0)},
                      {"with_overlay_ms_median", percentile(segmentOverlay[name], 50.0)},
                      {"tiles_mean", segmentTiles[name] / static_cast<double>(r.size())},
                      {"pieces_mean", segmentPieces[name] / static_cast<double>(r.size())},
                      {"overlay_triangles_mean", segmentTriangles[name] / static_cast<double>(r.size())},
                      {"wrong_pixels", segmentWrong[name]}};
    if (lookup) segments[name]["deferred_ratio_median"] = percentile(segmentLookupRatios[name], 50.0);
    if (drape) segments[name]["drape_tiles_ratio_median"] = percentile(segmentDrapeRatios[name], 50.0);
  }
  const json result = {
      {"mode", "globe"},
      {"scene", o.scene},
      {"width", o.width},
      {"height", o.height},
      {"frames", path.size()},
      {"load_seconds", loadSeconds},
      {"layer_vertices", vertices},
      {"terrain_only_gpu_ms_median", percentile(terrainOnly, 50.0)},
      {"with_overlay_gpu_ms_median", percentile(withOverlay, 50.0)},
      {"overlay_over_terrain_ratio_median", percentile(ratios, 50.0)},
      {"terrain_only_fps_median", 1000.0 / std::max(percentile(terrainOnly, 50.0), 1e-9)},
      {"with_overlay_fps_median", 1000.0 / std::max(percentile(withOverlay, 50.0), 1e-9)},
      {"segments", segments},
      {"deferred", lookup ? json{{"ratio_median", percentile(lookupRatios, 50.0)},
                                 {"index_bytes", indexBytes},
                                 {"index_first_frame_seconds", indexSeconds}}
                          : json()},
      // Draping per tile (--texture-sizes drape-tiles=N): its time over the terrain alone, and the
      // pixels it draws wrong away from edges (of those the reference covers), which the stencil
      // methods draw right.
      {"drape_tiles", drape ? json{{"tile_size", drapeSettings.textureSize},
                                   {"ratio_median", percentile(drapeRatios, 50.0)},
                                   {"wrong_pixels_away_from_edges", drapeWrong},
                                   {"covered_pixels", drapeCovered},
                                   {"gpu_bytes", drapeBytes}}
                            : json()},
      {"edit", edit},
      {"memory_peak_bytes", processMemory("VmHWM")},
      {"wrong_pixels_away_from_edges", wrongTotal},
      {"gl_errors", (**context).debug().errorCount()},
  };
  const int status = finish(o, result, **context);
  if (status == 0 && wrongTotal > 0) {
    logError("overlay_bench --mode globe: " + std::to_string(wrongTotal) +
             " wrong pixels away from edges against the CPU reference (frames.csv)");
    return 3;
  }
  return status;
}

}  // namespace gis::bench
