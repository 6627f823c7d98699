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
#include "vector_overlay/technique.hpp"

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

/// Makes each method's renderer; methods that build the same polyhedra (terrain only, ours and the
/// ablation's switches at draw time) share one: the same terrain, and the memory of one copy. False
/// when one cannot be made.
bool buildRenderers(const Options& o, scene::Scene& scene, std::vector<Method>& methods) {
  std::map<std::tuple<std::string_view, int, int, bool, bool>, scene::FrameRenderer*> built;
  for (Method& m : methods) {
    scene::StillSettings settings;
    settings.technique = m.technique;
    settings.textureSize = m.drapeSize;
    settings.lodTolerancePixels = o.lodTolerance;
    settings.cellPosts = m.cellPosts;
    settings.adaptiveSplit = m.adaptiveSplit;
    settings.uniteLines = m.uniteLines;
    const std::tuple<std::string_view, int, int, bool, bool> key{m.technique->name, m.cellPosts, m.drapeSize,
                                                                 m.adaptiveSplit, m.uniteLines};
    if (const auto found = built.find(key); found != built.end()) {
      m.shared = found->second;
    } else {
      Result<std::unique_ptr<scene::FrameRenderer>> r = scene::FrameRenderer::create(scene, settings);
      app::report(r.diagnostics);
      if (!r) return false;
      m.renderer = std::move(*r);
      m.shared = m.renderer.get();
      built[key] = m.shared;
    }
    if (m.overlays) {
      const scene::LayersBuilt layers = m.shared->layersBuilt();
      m.gpuBytes += layers.gpuBytes;
      m.buildSeconds += layers.buildSeconds;
      m.triangles += layers.triangles;
    }
  }
  return true;
}

/// The CPU reference of a judged frame, from terrain only's depth, and the terrain-only time the
/// other methods' frames are divided by.
struct FrameReference {
  std::vector<float> depth;
  /// Per reference kind (FrameRenderer::referenceKind: layers built alike), the expected mask,
  /// its edges and coverage.
  struct Truth {
    std::vector<std::uint32_t> expected;
    std::vector<std::uint8_t> edges;
    std::size_t covered = 0;
  };
  std::map<int, Truth> truths;
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
  /// Per reference kind, the first renderer that draws it: its layers give the reference.
  std::map<int, scene::FrameRenderer*> referenceRenderers;
  gfx::StateCache cache;
  gfx::RenderTarget target;
  std::optional<gfx::RenderTarget> sample;  ///< MSAA: sample 0 of each judged frame
  scene::FrameOptions options;

  VariantBench(const Options& options, std::vector<Method>& variants);
  [[nodiscard]] const gfx::RenderTarget& readable() const { return sample ? *sample : target; }
  void optionsFor(const Method& m);
  void drawPath(const std::vector<BenchFrame>& path, const std::string& stem);
  MethodFrame drawFrame(Method& m, std::size_t k, const scene::FrameCamera& camera, bool judged, FrameReference& ref);
  void count(Method& m, const scene::FrameCamera& camera, Tally& frame);
  void judge(const Method& m, const scene::FrameCamera& camera, Tally& frame, FrameReference& ref);
  void edit(Method& m, const scene::FrameCamera& camera);
  /// An untimed frame (its time in ms): what a method builds in a frame before it draws.
  double untimed(Method& m, const scene::FrameCamera& camera, scene::FrameFigures* figures = nullptr);
};

VariantBench::VariantBench(const Options& opts, std::vector<Method>& variants)
    : o(opts), methods(variants), target(opts.width, opts.height, opts.msaa, true) {
  for (const Method& m : methods) {
    if (m.overlays) referenceRenderers.try_emplace(m.shared->referenceKind(), m.shared);
  }
  if (target.multisampled()) sample.emplace(o.width, o.height, 0, true);
}

void VariantBench::optionsFor(const Method& m) {
  options.overlays = m.overlays;
  options.measure = false;
  options.overlay = overlay::OverlaySettings{};
  if (m.adjust) m.adjust(options.overlay);
}

/// Every frame of the path with every method, one line of stem.csv per frame and method.
void VariantBench::drawPath(const std::vector<BenchFrame>& path, const std::string& stem) {
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

double VariantBench::untimed(Method& m, const scene::FrameCamera& camera, scene::FrameFigures* figures) {
  optionsFor(m);
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  const scene::FrameFigures drawn = m.shared->drawFrame(cache, target, camera, options);
  glFinish();
  if (figures != nullptr) *figures = drawn;
  return msSince(start);
}

/// The frame timed; on a judged frame also counted and judged.
MethodFrame VariantBench::drawFrame(Method& m, std::size_t k, const scene::FrameCamera& camera, bool judged,
                                    FrameReference& ref) {
  MethodFrame f;  // this frame's figures, added to the whole path's and the segment's
  Tally& frame = f.tally;
  const overlay::PieceConstruction construction = m.technique->construction;
  if (construction == overlay::PieceConstruction::Tiled && m.overlays) {
    // Tiles are built on worker threads while parents stand in; here the frame first waits for
    // them (untimed, counted as build time), so that the timed frame draws what a flight draws
    // once they have arrived.
    // The lookup's indices are made at the first frame that draws by it: that frame is build
    // time too.
    scene::FrameFigures built;
    const double ms = untimed(m, camera, &built);
    m.tilesBuilt += built.tilesBuilt;
    const bool indexed = m.technique->looksUp && !m.firstDrawn;
    m.firstDrawn = true;
    m.buildSeconds += built.tilesBuilt > 0 || indexed ? 1e-3 * ms : 0.0;
  } else if (m.overlays && !m.firstDrawn && !m.technique->usesTextures() &&
             m.shared->layersBuilt().buildSeconds == 0.0) {
    // The technique builds its layers at its first frame (the lookup's index; the globe's pieces
    // built once): that frame is its build time.
    m.buildSeconds += 1e-3 * untimed(m, camera);
    m.firstDrawn = true;
  }
  optionsFor(m);
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  const scene::FrameFigures stats = m.shared->drawFrame(cache, target, camera, options);
  glFinish();
  f.ms = msSince(start);
  if (stats.texturesBuilt > 0 && m.shared->drapesOneTexture()) {
    // The one drape was built in this frame: its build time, not a frame time.
    m.buildSeconds = stats.textureSeconds;
    m.gpuBytes = m.shared->techniqueGpuBytes();
  } else if (k > 0) {  // frame 0 uploads the first chunks (and builds the first tiles)
    frame.ms.push_back(f.ms);
    if (!m.overlays) ref.terrainMs = f.ms;
    if (m.overlays && ref.terrainMs > 0.0) frame.ratio.push_back(f.ms / ref.terrainMs);
  }
  if (m.overlays && !m.shared->drapesOneTexture())
    m.gpuBytes = std::max(m.gpuBytes, m.shared->layersBuilt().gpuBytes + m.shared->techniqueGpuBytes());
  if (judged) {
    count(m, camera, frame);
    judge(m, camera, frame, ref);
  }
  if (m.technique->usesTextures() && !m.shared->drapesOneTexture()) {
    // Tiles are rasterised as the view moves: their time is part of the frame's.
    m.tilesBuilt += stats.texturesBuilt;
    m.buildSeconds += stats.textureSeconds;
  }
  return f;
}

/// The same frame again with the queries on (they wait, so untimed): GPU time per pass,
/// fragments and triangles.
void VariantBench::count(Method& m, const scene::FrameCamera& camera, Tally& frame) {
  optionsFor(m);
  options.measure = true;
  const scene::FrameFigures counted = m.shared->drawFrame(cache, target, camera, options);
  options.measure = false;
  frame.terrainGpuMs.push_back(counted.terrainGpuMs);
  frame.markFragments += counted.markFragments;
  frame.coverFragments += counted.coverFragments;
  frame.markTriangles += counted.markTriangles;
  frame.coverTriangles += counted.coverTriangles;
  frame.zFailPieces += counted.zFailPieces;
  frame.drawnPieces += counted.drawnPieces;
  if (m.overlays) {
    frame.markGpuMs.push_back(counted.markGpuMs);
    frame.coverGpuMs.push_back(counted.coverGpuMs);
  }
}

/// Terrain only computes the frame's references on its depth; the others' masks are judged against
/// the one of their kind, pixel by pixel.
void VariantBench::judge(const Method& m, const scene::FrameCamera& camera, Tally& frame, FrameReference& ref) {
  if (sample) target.copySampleInto(cache, *sample, 0);
  if (!m.overlays) {
    ref.depth = gfx::readDepth(readable());
    const overlay::DepthImage image = scene::Scene::depthImageOf(camera, o.width, o.height, ref.depth);
    for (const auto& [kind, renderer] : referenceRenderers) {
      std::vector<std::size_t> all(renderer->drawnLayerCount());
      for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
      scene::ReferenceAnswer answer = renderer->referenceOf(all, image);
      FrameReference::Truth& truth = ref.truths[kind];
      truth.covered = static_cast<std::size_t>(
          std::count_if(answer.expected.begin(), answer.expected.end(), [](std::uint32_t bits) { return bits != 0; }));
      truth.expected = std::move(answer.expected);
      truth.edges = std::move(answer.edges);
    }
    return;
  }
  // Each method against the reference of the widths it draws.
  const FrameReference::Truth& truth = ref.truths.at(m.shared->referenceKind());
  const std::vector<std::uint32_t> mask = gfx::readMask(readable());
  for (std::size_t i = 0; i < mask.size() && i < truth.expected.size(); ++i) {
    if (!(ref.depth[i] > 0.0F)) continue;
    const bool bad = mask[i] != truth.expected[i];
    ++frame.pixels;
    frame.wrong += bad ? 1u : 0u;
    if (truth.edges[i] == 0) {
      ++frame.pixelsAway;
      frame.wrongAway += bad ? 1u : 0u;
    }
  }
  frame.covered = truth.covered;
}

/// A one-feature edit, after the path: a vertex of the first feature of the first layer moved by 10
/// m; the time to rebuild its pieces, plus for draping the texture (or the tiles over the feature)
/// rasterised again in the next frame.
void VariantBench::edit(Method& m, const scene::FrameCamera& camera) {
  if (!m.overlays) return;
  const std::optional<double> rebuilt = m.shared->editFirstFeature();
  if (!rebuilt) return;
  m.editMs = *rebuilt;
  scene::FrameFigures after;
  const double frameMs = untimed(m, camera, &after);
  // Draped textures and tiles built again in that frame count as the edit's.
  m.editMs += 1e3 * after.textureSeconds;
  // Tiles built again, or an index made again, in that frame count as the edit's.
  if ((m.technique->construction == overlay::PieceConstruction::Tiled && after.tilesBuilt > 0) || m.technique->looksUp)
    m.editMs += frameMs;
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
  std::size_t posts = 0;
  if (setup.scene.onGlobe()) {
    const globe::GeoGrid& heights = *setup.scene.globe().heights;
    posts = static_cast<std::size_t>(heights.width()) * static_cast<std::size_t>(heights.height());
  } else {
    const terrain::TerrainGrid& grid = setup.scene.projected().quadtree->grid();
    posts = static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height);
  }
  // The exact methods' wrong pixels away from edges (every method but texture draping): the
  // product's promise, 0.
  std::size_t exactWrong = 0;
  for (const Method& m : methods) {
    if (m.overlays && !m.technique->usesTextures()) exactWrong += m.all.wrongAway;
  }
  return {{"mode", o.mode},
          {"frame", setup.scene.onGlobe() ? "globe" : "projected"},
          {"scene", o.scene},
          {"width", o.width},
          {"height", o.height},
          {"msaa", samples},
          {"frames", frames},
          {"error_every", o.errorEvery},
          {"vector_vertices", setup.scene.vectorVertices()},
          {"dem_posts", posts},
          {"methods", table},
          {"exact_methods_wrong_pixels_away_from_edges", exactWrong},
          {"renderer", setup.context->info().renderer},
          {"gl_errors", setup.context->debug().errorCount()}};
}

}  // namespace

int runVariants(const Options& o, std::vector<Method> variants, const std::string& stem, json* summary) {
  std::optional<BenchSetup> setup = setUp(o, true);
  if (!setup) return 1;
  // Declared after the context, so that their GL objects go while it is current.
  std::vector<Method> methods = std::move(variants);
  if (setup->scene.onGlobe()) {
    // How a projected frame builds its pieces means nothing to the globe's tiles.
    const auto projectedBuild = [](const Method& m) { return m.projectedBuild; };
    for (const Method& m : methods) {
      if (m.projectedBuild)
        std::printf("left out on the globe (its tiles split at their own cells): %s\n", m.name.c_str());
    }
    methods.erase(std::remove_if(methods.begin(), methods.end(), projectedBuild), methods.end());
  }
  if (!buildRenderers(o, setup->scene, methods)) return 1;
  const std::vector<BenchFrame> path = methodsPath(o, *setup);
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
  std::printf("exact_methods_wrong_pixels_away_from_edges: %zu\n",
              result["exact_methods_wrong_pixels_away_from_edges"].get<std::size_t>());
  std::printf("gl_errors: %zu\n", static_cast<std::size_t>(context.debug().errorCount()));
  return context.debug().errorCount() == 0 ? 0 : 1;
}

}  // namespace gis::bench
