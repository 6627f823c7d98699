// Every variant draws the same frames of the methods path in turn — terrain only first, whose frame
// time is the base of the ratios and whose depth the CPU reference is computed on (the terrain is
// the same for all) — so that ratios come from one run. On every n-th frame the GPU layer mask of
// each variant is compared with the CPU reference: wrong pixels over all terrain pixels, and away
// from feature edges.
#include "variants.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string_view>
#include <tuple>
#include <utility>

#include "gfx/gl.hpp"
#include "gfx/render_target.hpp"
#include "scene/json_file.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::bench {

void Tally::add(const Tally& t) {
  ms.insert(ms.end(), t.ms.begin(), t.ms.end());
  ratio.insert(ratio.end(), t.ratio.begin(), t.ratio.end());
  terrainGpuMs.insert(terrainGpuMs.end(), t.terrainGpuMs.begin(), t.terrainGpuMs.end());
  markGpuMs.insert(markGpuMs.end(), t.markGpuMs.begin(), t.markGpuMs.end());
  coverGpuMs.insert(coverGpuMs.end(), t.coverGpuMs.begin(), t.coverGpuMs.end());
  pixels += t.pixels;
  wrong += t.wrong;
  pixelsAway += t.pixelsAway;
  wrongAway += t.wrongAway;
  covered += t.covered;
  markFragments += t.markFragments;
  coverFragments += t.coverFragments;
  markTriangles += t.markTriangles;
  coverTriangles += t.coverTriangles;
  zFailPieces += t.zFailPieces;
  drawnPieces += t.drawnPieces;
}

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

namespace {

std::size_t vectorVertices(const scene::LoadedScene& scene) {
  std::size_t n = 0;
  for (const scene::LoadedLayer& l : scene.layers) {
    n += l.vertexCount();
  }
  return n;
}

/// Makes each method's renderer; methods that build the same polyhedra (terrain only, ours and the
/// ablation's switches at draw time) share one: the same terrain, and the memory of one copy. False
/// when one cannot be made.
bool buildRenderers(const scene::LoadedScene& scene, std::vector<Method>& methods) {
  std::map<std::tuple<std::string_view, int, int, bool, bool>, scene::SceneRenderer*> built;
  for (Method& m : methods) {
    scene::OverlayBuildSettings build;
    build.technique = m.technique;
    build.cellPosts = m.cellPosts;
    build.adaptiveSplit = m.adaptiveSplit;
    build.uniteLines = m.uniteLines;
    build.textureSize = m.drapeSize;
    const std::tuple<std::string_view, int, int, bool, bool> key{m.technique->name, m.cellPosts, m.drapeSize,
                                                                 m.adaptiveSplit, m.uniteLines};
    if (const auto found = built.find(key); found != built.end()) {
      m.shared = found->second;
    } else {
      Result<scene::SceneRenderer> r = scene::SceneRenderer::create(scene, build);
      app::report(r.diagnostics);
      if (!r) return false;
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
  return true;
}

/// The CPU reference of a judged frame, from terrain only's depth, and the terrain-only time the
/// other methods' frames are divided by.
struct FrameReference {
  std::vector<float> depth;
  /// Per kind of widths (0: as ours draws them, lines at least min_width_px wide; 1: in metres, as
  /// the techniques that build at load draw them), the expected mask, its edges and coverage.
  std::array<std::vector<std::uint32_t>, 2> expected;
  std::array<std::vector<std::uint8_t>, 2> edges;
  std::array<std::size_t, 2> covered{};
  double terrainMs = 0.0;
};

/// One method's figures on one frame: its frame time, and what it adds to the tallies.
struct MethodFrame {
  double ms = 0.0;
  Tally tally;
};

/// The variants drawing the path into one target.
struct VariantBench {
  const Options& o;
  std::vector<Method>& methods;
  /// Of ours' layers, and of the first method's that draws widths in metres (empty if none).
  std::array<std::vector<overlay::ReferenceLayer>, 2> reference;
  gfx::StateCache cache;
  gfx::RenderTarget target;
  std::optional<gfx::RenderTarget> sample;  ///< MSAA: sample 0 of each judged frame
  scene::RenderSettings settings;
  double aspect = 1.0;

  VariantBench(const Options& options, std::vector<Method>& variants);
  [[nodiscard]] const gfx::RenderTarget& readable() const { return sample ? *sample : target; }
  void settingsFor(const Method& m);
  void drawPath(const std::vector<scene::PathFrame>& path, const std::string& stem);
  MethodFrame drawFrame(Method& m, std::size_t k, const scene::Camera& camera, bool judged, FrameReference& ref);
  void count(Method& m, const scene::Camera& camera, Tally& frame);
  void judge(const Method& m, const scene::Camera& camera, Tally& frame, FrameReference& ref);
  void edit(Method& m, const scene::Camera& camera);
};

VariantBench::VariantBench(const Options& options, std::vector<Method>& variants)
    : o(options),
      methods(variants),
      target(options.width, options.height, options.msaa, true),
      settings(comparisonSettings(options)),  // the same terrain for every method
      aspect(static_cast<double>(options.width) / static_cast<double>(options.height)) {
  for (const overlay::OverlayLayer& l : methods[1].shared->overlayLayers()) {
    reference[0].push_back(overlay::referenceLayerOf(l));
  }
  for (const Method& m : methods) {
    if (!m.overlays || m.technique->construction == overlay::PieceConstruction::Tiled) continue;
    for (const overlay::OverlayLayer& l : m.shared->overlayLayers())
      reference[1].push_back(overlay::referenceLayerOf(l));
    break;
  }
  if (target.multisampled()) sample.emplace(o.width, o.height, 0, true);
}

void VariantBench::settingsFor(const Method& m) {
  settings.overlays = m.overlays;
  settings.overlay = overlay::OverlaySettings{};
  if (m.adjust) m.adjust(settings.overlay);
}

/// Every frame of the path with every method, one line of stem.csv per frame and method.
void VariantBench::drawPath(const std::vector<scene::PathFrame>& path, const std::string& stem) {
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (stem + ".csv"));
  csv << "frame,segment,method,ms,wrong_pixels,terrain_pixels,wrong_away_from_edges,pixels_away_from_edges,covered_"
         "pixels,mark_fragments,cover_fragments,gpu_ms_terrain,gpu_ms_mark,gpu_ms_cover,z_fail_pieces\n";
  for (std::size_t k = 0; k < path.size(); ++k) {
    const std::string& segment = path[k].segment;
    const bool judged = k % static_cast<std::size_t>(o.errorEvery) == 0;
    FrameReference ref;
    for (Method& m : methods) {
      const MethodFrame drawn = drawFrame(m, k, path[k].camera, judged, ref);
      const Tally& frame = drawn.tally;
      m.all.add(frame);
      m.segments[segment].add(frame);
      csv << k << ',' << segment << ',' << m.name << ',' << drawn.ms << ',' << frame.wrong << ',' << frame.pixels << ','
          << frame.wrongAway << ',' << frame.pixelsAway << ',' << frame.covered << ',' << frame.markFragments << ','
          << frame.coverFragments << ',' << (judged ? frame.terrainGpuMs.back() : 0.0) << ','
          << (frame.markGpuMs.empty() ? 0.0 : frame.markGpuMs.back()) << ','
          << (frame.coverGpuMs.empty() ? 0.0 : frame.coverGpuMs.back()) << ',' << frame.zFailPieces << '\n';
    }
  }
}

/// The frame timed; on a judged frame also counted and judged.
MethodFrame VariantBench::drawFrame(Method& m, std::size_t k, const scene::Camera& camera, bool judged,
                                    FrameReference& ref) {
  MethodFrame f;  // this frame's figures, added to the whole path's and the segment's
  Tally& frame = f.tally;
  settingsFor(m);
  if (m.technique->construction == overlay::PieceConstruction::Tiled && m.overlays) {
    // Tiles are built on worker threads while parents stand in; here the frame first waits for
    // them (untimed, counted as build time), so that the timed frame draws what a flight draws
    // once they have arrived.
    glFinish();
    const auto build = std::chrono::steady_clock::now();
    const scene::FrameStats built = m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
    glFinish();
    m.tilesBuilt += built.overlayTiles.tilesBuilt;
    m.buildSeconds += built.overlayTiles.tilesBuilt > 0 ? 1e-3 * msSince(build) : 0.0;
    m.gpuBytes = std::max(m.gpuBytes, m.shared->techniqueGpuBytes());
  }
  if (m.technique->construction == overlay::PieceConstruction::Features && m.overlays && !m.indexed) {
    // The technique builds its index at its first frame: that frame is its build time.
    glFinish();
    const auto build = std::chrono::steady_clock::now();
    (void)m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
    glFinish();
    m.buildSeconds += 1e-3 * msSince(build);
    m.indexed = true;
  }
  if (m.technique->construction == overlay::PieceConstruction::Features && m.overlays)
    m.gpuBytes = std::max(m.gpuBytes, m.shared->techniqueGpuBytes());
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  const scene::FrameStats stats = m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
  glFinish();
  f.ms = msSince(start);
  if (stats.texturesBuilt > 0 && m.shared->textureDrape() != nullptr) {
    // The one drape was built in this frame: its build time, not a frame time.
    m.buildSeconds = stats.textureSeconds;
    m.gpuBytes = m.shared->techniqueGpuBytes();
  } else if (k > 0) {  // frame 0 uploads the first chunks (and builds the first
                       // tiles)
    frame.ms.push_back(f.ms);
    if (!m.overlays) ref.terrainMs = f.ms;
    if (m.overlays && ref.terrainMs > 0.0) frame.ratio.push_back(f.ms / ref.terrainMs);
  }
  if (judged) {
    count(m, camera, frame);
    judge(m, camera, frame, ref);
  }
  if (m.technique->usesTextures() && m.shared->textureDrape() == nullptr) {
    // Tiles are rasterised as the view moves: their time is part of the frame's.
    m.gpuBytes = std::max(m.gpuBytes, m.shared->techniqueGpuBytes());
    m.tilesBuilt += stats.texturesBuilt;
    m.buildSeconds += stats.textureSeconds;
  }
  return f;
}

/// The same frame again with the queries on (they wait, so untimed): GPU time per pass,
/// fragments and triangles.
void VariantBench::count(Method& m, const scene::Camera& camera, Tally& frame) {
  settings.measure = true;
  const scene::FrameStats counted = m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
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
}

/// Terrain only computes the frame's reference on its depth; the others' masks are judged against
/// it, pixel by pixel.
void VariantBench::judge(const Method& m, const scene::Camera& camera, Tally& frame, FrameReference& ref) {
  if (sample) target.copySampleInto(cache, *sample, 0);
  if (!m.overlays) {
    ref.depth = gfx::readDepth(readable());
    const overlay::DepthImage image{o.width, o.height, ref.depth, camera.projection(aspect) * camera.view()};
    for (std::size_t k = 0; k < 2; ++k) {
      if (k == 1 && reference[1].empty()) continue;
      ref.expected[k] = overlay::referenceMask(image, reference[k]);
      ref.edges[k] = overlay::edgePixels(image, reference[k]);
      ref.covered[k] = static_cast<std::size_t>(
          std::count_if(ref.expected[k].begin(), ref.expected[k].end(), [](std::uint32_t bits) { return bits != 0; }));
    }
    return;
  }
  // Each method against the reference of the widths it draws.
  const std::size_t k = m.technique->construction == overlay::PieceConstruction::Tiled || reference[1].empty() ? 0 : 1;
  const std::vector<std::uint32_t> mask = gfx::readMask(readable());
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (!(ref.depth[i] > 0.0F)) continue;
    const bool bad = mask[i] != ref.expected[k][i];
    ++frame.pixels;
    frame.wrong += bad ? 1u : 0u;
    if (ref.edges[k][i] == 0) {
      ++frame.pixelsAway;
      frame.wrongAway += bad ? 1u : 0u;
    }
  }
  frame.covered = ref.covered[k];
}

/// A vertex of the layer's first feature moved by 10 m, and the box of that feature; nothing when
/// it has no vertex to move.
std::optional<geo::Feature> movedFirstFeature(const overlay::OverlayLayer& layer, glm::dvec2& lo, glm::dvec2& hi) {
  geo::Feature feature = layer.features().front();
  lo = glm::dvec2(std::numeric_limits<double>::infinity());
  hi = glm::dvec2(-std::numeric_limits<double>::infinity());
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
    return std::nullopt;
  }
  return feature;
}

/// A one-feature edit, after the path: a vertex of the first feature of the first layer moved by 10
/// m; the time to rebuild its pieces, plus for draping the texture (or the tiles over the feature)
/// rasterised again in the next frame.
void VariantBench::edit(Method& m, const scene::Camera& camera) {
  if (!m.overlays || m.shared->overlayLayers().empty()) return;
  overlay::OverlayLayer& layer = m.shared->overlayLayer(0);
  if (layer.features().empty()) return;
  glm::dvec2 lo, hi;
  const std::optional<geo::Feature> feature = movedFirstFeature(layer, lo, hi);
  if (!feature) return;
  const double margin = 2.0 * layer.style().maxWidthMetres + 20.0;  // widths and outlines
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  (void)layer.replaceFeature(0, *feature);
  m.shared->featureChanged(0, 0, lo - margin, hi + margin);
  m.editMs = msSince(start);
  settingsFor(m);
  const auto frameStart = std::chrono::steady_clock::now();
  const scene::FrameStats after = m.shared->render(cache, target.framebuffer(), o.width, o.height, camera, settings);
  // Draped textures and tiles built again in that frame count as the edit's.
  m.editMs += 1e3 * after.textureSeconds;
  // Tiles built again, or an index made again, in that frame count as the edit's.
  if ((m.technique->construction == overlay::PieceConstruction::Tiled && after.overlayTiles.tilesBuilt > 0) ||
      m.technique->construction == overlay::PieceConstruction::Features)
    m.editMs += msSince(frameStart);
}

json resultJson(const Options& o, const BenchSetup& setup, const std::vector<Method>& methods, int samples,
                std::size_t frames) {
  const Method& ours = methods[1];
  json table = json::array();
  for (const Method& m : methods) {
    json entry = tallyJson(m.all, ours.all, m.overlays);
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
  const terrain::TerrainGrid& grid = setup.scene.quadtree->grid();
  return {{"mode", o.mode},
          {"scene", o.scene},
          {"width", o.width},
          {"height", o.height},
          {"msaa", samples},
          {"frames", frames},
          {"error_every", o.errorEvery},
          {"vector_vertices", vectorVertices(setup.scene)},
          {"dem_posts", static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height)},
          {"methods", table},
          {"renderer", setup.context->info().renderer},
          {"gl_errors", setup.context->debug().errorCount()}};
}

}  // namespace

int runVariants(const Options& o, std::vector<Method> variants, const std::string& stem, json* summary) {
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  // Declared after the context, so that their GL objects go while it is current.
  std::vector<Method> methods = std::move(variants);
  if (!buildRenderers(setup->scene, methods)) return 1;
  const std::vector<scene::PathFrame> path = methodsPath(o, *setup);
  if (path.empty()) {
    std::fprintf(stderr, "overlay_bench: no frames on the path (--segments)\n");
    return 1;
  }
  VariantBench bench(o, methods);
  bench.drawPath(path, stem);
  for (Method& m : methods) bench.edit(m, path.back().camera);
  reportVariants(o, methods, stem);
  const json result = resultJson(o, *setup, methods, bench.target.samples(), path.size());
  std::ofstream(std::filesystem::path(o.out) / (stem + ".json")) << scene::jsonText(result) << '\n';
  if (summary != nullptr) *summary = result;
  gfx::Context& context = *setup->context;
  std::printf("gl_errors: %zu\n", static_cast<std::size_t>(context.debug().errorCount()));
  return context.debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace gis::bench
