#include "scene/scene_loader.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>

#include "core/hash.hpp"
#include "core/log.hpp"
#include "geo/checked_file.hpp"
#include "geo/raster.hpp"
#include "layer_cache.hpp"
#include "terrain/terrain_grid.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::scene {

namespace {

/// A stable short name for a path.
std::string pathHash(const std::string& text) { return stableHashHex(text).substr(0, 8); }

/// Whether `dir` is (or can be made) a folder we can write in; else why not.
bool usableDirectory(const std::filesystem::path& dir, std::string& why) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!std::filesystem::is_directory(dir, ec)) {
    why = ec ? ec.message() : "not a folder";
    return false;
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    why = std::strerror(errno);
    return false;
  }
  return true;
}

/// The paged terrain: the pyramid (built when missing or stale), its pager and tree.
Result<std::shared_ptr<const terrain::TerrainQuadtree>> pagedTerrain(const SceneDescription& description,
                                                                     const geo::DemSource& dem, geo::FrameDem& inFrame,
                                                                     const geo::SceneFrame& frame,
                                                                     const LoadOptions& options, LoadedScene& scene) {
  using R = Result<std::shared_ptr<const terrain::TerrainQuadtree>>;
  R r;
  const terrain::PyramidSource source = terrain::PyramidSource::of(dem, description.chunkCells);
  scene.pyramidPath = pyramidPathFor(description);
  Result<std::shared_ptr<const terrain::TilePyramidFile>> file =
      terrain::TilePyramidFile::open(scene.pyramidPath, source);
  if (!file) {
    const std::string why = file.diagnostics.empty() ? "" : file.diagnostics.items().front().message;
    // A damaged pyramid is said (a warning, in the load's messages); a missing or stale one is
    // simply built.
    if (why.find("damaged") != std::string::npos)
      r.diagnostics.add({Severity::Warning,
                         scene.pyramidPath,
                         {},
                         {},
                         "cache file damaged (" + why + "); rebuilt from " + dem.label()});
    logInfo("building the tile pyramid of " + dem.label() + " into " + scene.pyramidPath + " (" + why + ")");
    Result<terrain::PyramidBuildStats> built =
        terrain::buildTilePyramid(inFrame, source, frame, scene.pyramidPath,
                                  options.progress ? options.progress : consoleProgress("tile pyramid"));
    if (!built) {
      r.diagnostics.append(built.diagnostics);
      return r;
    }
    scene.pyramidBuild = *built;
    char line[160];
    std::snprintf(line, sizeof(line), "tile pyramid built in %.1f s: %zu tiles, %.0f MB", built->seconds, built->tiles,
                  static_cast<double>(built->fileBytes) / 1e6);
    logInfo(line);
    file = terrain::TilePyramidFile::open(scene.pyramidPath, source);
    if (!file) {
      r.diagnostics.append(file.diagnostics);
      return r;
    }
  }
  // A tile found damaged while paging rebuilds the pyramid from the DEM (TilePyramidFile::readTile).
  (*file)->setRebuild(
      [source, frame, path = scene.pyramidPath] { return terrain::buildTilePyramid(source, frame, path).ok(); });
  const auto tileBudget = static_cast<std::size_t>(description.memoryBudgetMb / 3.0 * 1024.0 * 1024.0);
  auto pager = std::make_shared<terrain::TilePager>(*file, tileBudget);
  scene.nodataPosts = (*file)->nodataPosts();
  // Said on every load, not only when the pyramid is built.
  if ((*file)->implausiblePosts() > 0) {
    r.diagnostics.add(terrain::implausibleHeightsWarning(dem.label(), (*file)->implausiblePosts()));
  }
  r.value = std::make_shared<const terrain::TerrainQuadtree>(std::move(pager));
  return r;
}

}  // namespace

SceneDescription sceneForDem(const std::string& path) {
  namespace fs = std::filesystem;
  SceneDescription scene;
  scene.path = fs::absolute(path).lexically_normal().string();
  scene.name = fs::path(scene.path).filename().string();
  scene.dem = scene.path;
  scene.demPaths = {scene.path};
  return scene;
}

Result<std::vector<LayerDescription>> layersForVectorFile(const std::string& path, const geo::SceneFrame& frame,
                                                          std::size_t index) {
  Result<std::vector<LayerDescription>> r;
  Result<std::vector<std::string>> names = geo::listVectorLayers(path);
  if (!names) {
    r.diagnostics = std::move(names.diagnostics);
    return r;
  }
  const glm::vec4 palette[] = {{0.12F, 0.47F, 0.71F, 1.0F},
                               {0.17F, 0.63F, 0.17F, 1.0F},
                               {0.84F, 0.15F, 0.16F, 1.0F},
                               {0.58F, 0.40F, 0.74F, 1.0F},
                               {0.09F, 0.75F, 0.81F, 1.0F}};
  std::vector<LayerDescription> layers;
  const std::string stem = std::filesystem::path(path).stem().string();
  for (const std::string& name : *names) {
    geo::VectorReadOptions options;
    if (names->size() > 1) options.layer = name;
    Result<geo::VectorLayer> probe = geo::readVectorLayer(path, frame, options);
    if (!probe) {
      r.diagnostics.append(probe.diagnostics);
      continue;
    }  // else its messages come once, when the scene with it loads
    LayerDescription layer;
    layer.name = names->size() > 1 ? stem + " / " + name : stem;
    layer.source = std::filesystem::absolute(path).string();
    layer.sourceLayer = options.layer;
    layer.kind = probe->kind == geo::GeometryKind::Line ? overlay::LayerKind::Line : overlay::LayerKind::Polygon;
    layer.style.color = palette[(index + layers.size()) % 5];
    layer.style.opacity = layer.kind == overlay::LayerKind::Polygon ? 0.45F : 0.9F;
    layer.style.widthMetres = 6.0F;
    layer.fileIndex = index + layers.size();
    layers.push_back(std::move(layer));
  }
  if (!layers.empty()) r.value = std::move(layers);
  return r;
}

Result<SceneDescription> sceneForVectorFile(const std::string& path) {
  namespace fs = std::filesystem;
  Result<SceneDescription> r;
  Result<std::array<double, 4>> box = geo::vectorExtentLonLat(path);
  if (!box) {
    r.diagnostics = std::move(box.diagnostics);
    return r;
  }
  const std::string absolute = fs::absolute(path).lexically_normal().string();
  const std::string flat = "/vsimem/stencil-gis/flat-ground-" + pathHash(absolute) + ".tif";
  Result<std::string> written = geo::writeFlatDem(flat, *box);
  if (!written) {
    r.diagnostics = std::move(written.diagnostics);
    return r;
  }
  SceneDescription scene = sceneForDem(flat);
  scene.path = absolute;
  scene.name = fs::path(absolute).filename().string() + " (flat ground)";
  scene.paging = TerrainPaging::Never;
  Result<geo::DemSource> dem = geo::DemSource::open(scene.demSpec());
  Result<geo::SceneFrame> frame = dem ? geo::SceneFrame::forRaster(dem->extent())
                                      : Result<geo::SceneFrame>::failure(dem.diagnostics.items().front());
  if (!frame) {
    r.diagnostics = std::move(frame.diagnostics);
    return r;
  }
  Result<std::vector<LayerDescription>> layers = layersForVectorFile(path, *frame, 0);
  r.diagnostics.append(layers.diagnostics);
  if (!layers) return r;
  scene.layers = std::move(*layers);
  r.diagnostics.add({Severity::Info, absolute, "", "",
                     "opened without a DEM: shown over flat ground at height 0 covering its extent"});
  r.value = std::move(scene);
  return r;
}

std::string pyramidPathFor(const SceneDescription& description) {
  namespace fs = std::filesystem;
  const fs::path dem = fs::absolute(description.dem).lexically_normal();
  std::string all;
  for (const std::string& p : description.demSpec().paths) all += fs::absolute(p).lexically_normal().string() + "\n";
  const std::string name =
      dem.stem().string() + "-b" + std::to_string(description.demBand) + "-" + pathHash(all) + ".sgpyr";
  const std::string cache = cacheDirectoryFor(description);
  return (fs::path(cache.empty() ? scratchDirectory() : cache) / name).string();
}

std::string cacheDirectoryFor(const SceneDescription& description, std::string* warning) {
  namespace fs = std::filesystem;
  if (description.cacheDisabled) return {};
  const fs::path dir = description.cacheDir.empty()
                           ? fs::absolute(description.path).parent_path() / ".stencil-gis-cache"
                           : fs::path(description.cacheDir);
  std::string why;
  if (usableDirectory(dir, why)) return dir.string();
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const fs::path fallback = xdg != nullptr && *xdg != '\0'     ? fs::path(xdg) / "stencil-gis"
                            : home != nullptr && *home != '\0' ? fs::path(home) / ".cache" / "stencil-gis"
                                                               : fs::path();
  std::string fallbackWhy = "no user cache folder ($XDG_CACHE_HOME and $HOME unset)";
  const bool usable = !fallback.empty() && usableDirectory(fallback, fallbackWhy);
  if (warning != nullptr) {
    *warning = "cache " + dir.string() + ": cannot be written (" + why + "); " +
               (usable ? "using " + fallback.string()
                       : "nor " + (fallback.empty() ? std::string("a user cache folder") : fallback.string()) + " (" +
                             fallbackWhy + "): running without a cache, every layer read from its source");
  }
  return usable ? fallback.string() : std::string();
}

CacheUsage cacheUsage(const std::string& directory) {
  namespace fs = std::filesystem;
  CacheUsage usage;
  std::error_code ec;
  if (directory.empty()) return usage;
  for (fs::recursive_directory_iterator it(directory, fs::directory_options::skip_permission_denied, ec), end;
       !ec && it != end; it.increment(ec)) {
    std::error_code fileError;
    if (!it->is_regular_file(fileError)) continue;
    const std::uintmax_t size = it->file_size(fileError);
    if (fileError) continue;
    usage.bytes += size;
    ++usage.files;
  }
  return usage;
}

CacheUsage clearCache(const std::string& directory) {
  namespace fs = std::filesystem;
  const CacheUsage before = cacheUsage(directory);
  std::error_code ec;
  if (directory.empty() || !fs::is_directory(directory, ec)) return {};
  for (const fs::directory_entry& e : fs::directory_iterator(directory, ec)) {
    std::error_code removeError;
    fs::remove_all(e.path(), removeError);
  }
  const CacheUsage after = cacheUsage(directory);
  return {before.bytes - std::min(before.bytes, after.bytes), before.files - std::min(before.files, after.files)};
}

std::string scratchDirectory() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path dir = fs::temp_directory_path(ec) / ("stencil-gis-scratch-" + std::to_string(::getuid()));
  fs::create_directories(dir, ec);
  return dir.string();
}

std::string terrainCacheKey(const LoadedScene& scene) {
  namespace fs = std::filesystem;
  std::string key;
  for (const std::string& p : scene.description.demSpec().paths) {
    key += fs::absolute(p).lexically_normal().string();
    std::error_code ec;
    const auto size = fs::file_size(p, ec);
    if (!ec) key += " " + std::to_string(size);
    const auto time = fs::last_write_time(p, ec);
    if (!ec) key += " " + std::to_string(time.time_since_epoch().count());
    key += "\n";
  }
  const terrain::TerrainGrid& grid = scene.quadtree->grid();
  char numbers[512];
  std::snprintf(numbers, sizeof(numbers),
                "band %d chunk %d grid %d x %d at %.17g %.17g step %.17g %.17g paged %d "
                "exaggeration %.17g",
                scene.description.demBand, scene.quadtree->chunkCells(), grid.width, grid.height, grid.origin.x,
                grid.origin.y, grid.step.x, grid.step.y, scene.paged() ? 1 : 0, scene.bounds->exaggeration());
  return key + numbers;
}

terrain::PyramidProgress consoleProgress(std::string label) {
  const bool terminal = ::isatty(STDERR_FILENO) != 0;
  auto start = std::chrono::steady_clock::now();
  auto lastDecile = std::make_shared<int>(-1);
  return [label = std::move(label), terminal, start, lastDecile](double fraction) {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0);
    if (terminal) {
      constexpr int kWidth = 40;
      std::string bar(static_cast<std::size_t>(kWidth), ' ');
      std::fill_n(bar.begin(), percent * kWidth / 100, '#');
      std::fprintf(stderr, "\r%s [%s] %3d%% %5.0f s", label.c_str(), bar.c_str(), percent, seconds);
      if (fraction >= 1.0) std::fputc('\n', stderr);
      std::fflush(stderr);
    } else if (percent / 10 != *lastDecile) {
      *lastDecile = percent / 10;
      std::fprintf(stderr, "%s: %d%% (%.0f s)\n", label.c_str(), percent, seconds);
    }
  };
}

std::vector<std::size_t> drawOrderOf(const std::vector<LoadedLayer>& layers) {
  std::vector<std::size_t> order(layers.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return layers[a].description.style.drawOrder < layers[b].description.style.drawOrder;
  });
  return order;
}

std::vector<LoadedLayer> loadLayers(const SceneDescription& description, const geo::SceneFrame& frame,
                                    const std::string& cacheDirectory, const LoadOptions& options,
                                    Diagnostics& diagnostics, std::size_t* fromCache) {
  // A layer read from its source shows its progress where it is large (a bar per small layer
  // would say nothing).
  const auto readProgress = [&options](const std::string& name) -> std::function<void(double)> {
    if (options.progress) return options.progress;
    auto bar = std::make_shared<terrain::PyramidProgress>();
    const auto began = std::chrono::steady_clock::now();
    return [bar, began, name](double fraction) {
      if (!*bar && std::chrono::steady_clock::now() - began < std::chrono::seconds(2)) return;
      if (!*bar) *bar = consoleProgress("vector layer " + name);
      (*bar)(fraction);
    };
  };
  // Temporary files of writers that were killed or ran out of disk are cleared.
  if (!cacheDirectory.empty()) (void)geo::io::removeStaleTemporaries(cacheDirectory, std::chrono::hours(1));
  std::vector<LoadedLayer> layers;
  for (const LayerDescription& layer : description.layers) {
    geo::VectorReadOptions readOptions;
    readOptions.layer = layer.sourceLayer;
    // On the globe the layers keep their points as given: the globe densifies along geodesics.
    if (frame.geographic()) readOptions.geodesicToleranceMetres = std::numeric_limits<double>::infinity();
    // As read last time, when nothing it depends on has changed (layer_cache.hpp).
    const std::optional<std::uint64_t> key = options.layerCache && !cacheDirectory.empty()
                                                 ? detail::layerCacheKey(layer.source, frame, readOptions)
                                                 : std::nullopt;
    const std::string cacheFile = key ? detail::layerCacheFile(cacheDirectory, *key) : std::string();
    std::optional<detail::CachedLayer> cached;
    if (key) {
      detail::LayerCacheRead read = detail::readLayerCache(cacheFile, *key);
      cached = std::move(read.layer);
      // A damaged file costs a read of the source, never a feature: said, and written again.
      if (read.status == geo::io::CheckedStatus::Damaged)
        diagnostics.add({Severity::Warning,
                         cacheFile,
                         layer.name,
                         {},
                         "cache file damaged (" + read.why + "); rebuilt from " + layer.source});
    }
    if (cached) {
      if (fromCache != nullptr) ++*fromCache;
    } else {
      // Streamed into the cache as read, and opened from there: the features stay in the file.
      if (key) {
        const detail::LayerCacheWrite written =
            detail::writeLayerCache(cacheFile, *key, [&](const std::function<void(geo::Feature &&)>& sink) {
              geo::VectorReadOptions streamed = readOptions;
              streamed.sink = sink;
              streamed.progress = readProgress(layer.name);
              return geo::readVectorLayer(layer.source, frame, streamed);
            });
        if (written.outcome) {
          detail::LayerCacheRead read = detail::readLayerCache(cacheFile, *key);
          cached = std::move(read.layer);
          if (!cached)
            diagnostics.add({Severity::Warning,
                             cacheFile,
                             layer.name,
                             {},
                             "cache file cannot be read back (" + read.why + "); the layer is read into memory"});
        } else {
          diagnostics.add(
              {Severity::Warning,
               cacheFile,
               layer.name,
               {},
               "cache file cannot be written (" + written.outcome.error + "); the layer is read into memory"});
        }
      }
      // No cache, or it could not be written: read into memory.
      if (!cached) cached = detail::CachedLayer{geo::readVectorLayer(layer.source, frame, readOptions), nullptr};
    }
    Result<geo::VectorLayer> data = std::move(cached->read);
    // Name our layer in every message about it, beside the file's own layer name.
    for (const Diagnostic& d : data.diagnostics.items()) {
      Diagnostic named = d;
      named.layer = layer.name + (d.layer.empty() || d.layer == layer.name ? "" : " (" + d.layer + ")");
      diagnostics.add(std::move(named));
    }
    if (!data) continue;
    // Features left out when read: one per feature named in an Error (however many it has).
    std::set<std::string> skipped;
    for (const Diagnostic& d : data.diagnostics.items()) {
      if (d.severity == Severity::Error && !d.feature.empty()) skipped.insert(d.feature);
    }
    overlay::SharedFeatures features = cached->features ? overlay::SharedFeatures(cached->features)
                                                        : overlay::SharedFeatures(std::move(data->features));
    data->features = {};
    LoadedLayer loaded{layer, std::move(*data), skipped.size(), std::move(features)};
    layers.push_back(std::move(loaded));
  }
  return layers;
}

Result<LoadedScene> loadScene(const SceneDescription& description, const LoadOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  Diagnostics diagnostics;
  auto fail = [&](Diagnostics&& more) {
    Result<LoadedScene> r;
    r.diagnostics = std::move(diagnostics);
    r.diagnostics.append(more);
    return r;
  };

  // The DEM in any CRS, one file or many tiles; the frame from where it lies.
  Result<geo::DemSource> dem = geo::DemSource::open(description.demSpec());
  if (!dem) return fail(std::move(dem.diagnostics));
  diagnostics.append(dem.diagnostics);
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(dem->extent());
  if (!frame) return fail(std::move(frame.diagnostics));
  Result<geo::FrameDem> inFrame = geo::FrameDem::open(*dem, *frame);
  if (!inFrame) return fail(std::move(inFrame.diagnostics));
  diagnostics.append(inFrame.diagnostics);
  const geo::RasterInfo& demInfo = inFrame->info();

  // About 7 bytes a post in memory: the heights and the min/max pyramid of the bounds.
  const double inMemoryMb = 7.0 * static_cast<double>(demInfo.width) * demInfo.height / (1024.0 * 1024.0);
  const TerrainPaging paging = options.paging.value_or(description.paging);
  const bool paged =
      paging == TerrainPaging::Always || (paging == TerrainPaging::Auto && inMemoryMb > description.memoryBudgetMb);

  LoadedScene scene{description, std::move(*frame), nullptr, nullptr, std::nullopt, {}, 0, 0.0, {}, std::nullopt};
  if (paged) {
    Result<std::shared_ptr<const terrain::TerrainQuadtree>> tree =
        pagedTerrain(description, *dem, *inFrame, scene.frame, options, scene);
    if (!tree) return fail(std::move(tree.diagnostics));
    diagnostics.append(tree.diagnostics);
    scene.quadtree = std::move(*tree);
  } else {
    Result<terrain::TerrainGrid> grid = terrain::gridFromDem(*inFrame, scene.frame);
    if (!grid) return fail(std::move(grid.diagnostics));
    diagnostics.append(grid.diagnostics);
    for (float h : grid->heights) scene.nodataPosts += std::isnan(h) ? 1u : 0u;
    scene.quadtree = std::make_shared<const terrain::TerrainQuadtree>(
        std::make_shared<const terrain::TerrainGrid>(std::move(*grid)), description.chunkCells);
  }
  const std::uint64_t posts = static_cast<std::uint64_t>(scene.quadtree->grid().width) *
                              static_cast<std::uint64_t>(scene.quadtree->grid().height);
  if (scene.nodataPosts >= posts) {
    Diagnostics none;
    none.add({Severity::Error, dem->label(), "", "",
              "every one of the DEM's " + std::to_string(posts) + " posts is nodata: there is no terrain to draw"});
    return fail(std::move(none));
  }
  if (scene.nodataPosts > 0) {
    diagnostics.add(
        {Severity::Info, dem->label(), "", "", std::to_string(scene.nodataPosts) + " nodata posts left as holes"});
  }
  scene.bounds = std::make_shared<terrain::QuadtreeHeightBounds>(scene.quadtree, description.verticalExaggeration);

  if (description.imagery) {
    // Resampled once into the scene frame's CRS, so texture coordinates are affine in the frame.
    Result<geo::Raster> imagery =
        geo::readRasterInCrs(*description.imagery, description.imageryBands, scene.frame.crsWkt());
    diagnostics.append(imagery.diagnostics);
    if (imagery) {
      Result<terrain::Orthophoto> photo = terrain::makeOrthophoto(*imagery);
      diagnostics.append(photo.diagnostics);
      if (photo) {
        geo::GeoTransform t = imagery->info.geoTransform;
        t.c[0] -= scene.frame.origin().x;
        t.c[3] -= scene.frame.origin().y;
        scene.orthophoto = terrain::FrameOrthophoto{std::move(*photo), t};
      }
    }
  }

  // The cache: the scene's, else the user's, else none (said once).
  std::string cacheWarning;
  const std::string cacheDirectory = cacheDirectoryFor(description, &cacheWarning);
  if (!cacheWarning.empty()) diagnostics.add({Severity::Warning, {}, {}, {}, cacheWarning});
  scene.layers = loadLayers(description, scene.frame, cacheDirectory, options, diagnostics, &scene.layersFromCache);
  scene.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  Result<LoadedScene> result;
  result.diagnostics = std::move(diagnostics);
  result.value = std::move(scene);
  return result;
}

void terrainBox(const LoadedScene& scene, double exaggeration, glm::dvec3& boxMin, glm::dvec3& boxMax) {
  const terrain::TerrainGrid& g = scene.quadtree->grid();
  const glm::dvec2 a = g.postPosition(0, 0), b = g.postPosition(g.width - 1, g.height - 1);
  const terrain::NodeInfo& root = scene.quadtree->info(scene.quadtree->root());
  const double z0 = root.minHeight * exaggeration, z1 = root.maxHeight * exaggeration;
  boxMin = glm::dvec3(glm::min(a, b), std::min(z0, z1));
  boxMax = glm::dvec3(glm::max(a, b), std::max(z0, z1));
}

Result<Camera> stillCamera(const std::string& cameraFile, const SceneDescription& description,
                           const std::string& sceneFile, const LoadedScene& scene) {
  if (!cameraFile.empty()) {
    Result<CameraSpec> spec = loadCameraFile(cameraFile);
    if (!spec) return {std::nullopt, std::move(spec.diagnostics)};
    Result<Camera> placed = placeCamera(*spec, scene.frame, cameraFile);
    spec.diagnostics.append(placed.diagnostics);
    return {std::move(placed.value), std::move(spec.diagnostics)};
  }
  if (description.camera) return placeCamera(*description.camera, scene.frame, sceneFile);
  glm::dvec3 lo, hi;
  terrainBox(scene, scene.bounds->exaggeration(), lo, hi);
  return {overviewCamera(lo, hi), {}};
}

}  // namespace gis::scene
