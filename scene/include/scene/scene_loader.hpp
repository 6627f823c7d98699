#pragma once
// Loads what a scene file names (CPU side): the frame, the terrain quadtree and its height
// bounds, the orthophoto resampled into the frame, and the vector layers, collecting every
// message. Only a DEM that cannot be read fails the scene; broken imagery or layers are reported
// and left out, the rest still renders.
#include <memory>
#include <optional>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/vector.hpp"
#include "scene/scene.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/quadtree.hpp"
#include "terrain/terrain_engine.hpp"
#include "terrain/tile_pyramid.hpp"
#include "vector_overlay/shared_features.hpp"

namespace gis::scene {

struct LoadedLayer {
  LayerDescription description;
  /// What was read, but for its features: those are in `features`.
  geo::VectorLayer data;
  std::size_t skippedFeatures = 0;  ///< features left out for errors (named in diagnostics)
  /// The features read (only the good ones), shared with the overlay layers built from them:
  /// one copy however many layers draw them. Read from the scene's cache directory they stay
  /// on disk, read one at a time by the tiles that need them (SharedFeatures::onDisk); all()
  /// reads them into memory for whoever needs them all.
  overlay::SharedFeatures features;

  [[nodiscard]] std::size_t vertexCount() const { return features.vertexCount(); }
};

struct LoadedScene {
  SceneDescription description;
  geo::SceneFrame frame;
  std::shared_ptr<const terrain::TerrainQuadtree> quadtree;
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds;
  std::optional<terrain::FrameOrthophoto> orthophoto;
  std::vector<LoadedLayer> layers;
  std::size_t nodataPosts = 0;
  double loadSeconds = 0.0;
  /// For a paged DEM: the tile pyramid, and its build statistics if it was built this time.
  std::string pyramidPath;
  std::optional<terrain::PyramidBuildStats> pyramidBuild;
  std::size_t layersFromCache = 0;  ///< vector layers read from the cache instead of their source
  [[nodiscard]] bool paged() const { return quadtree->paged(); }
};

struct LoadOptions {
  /// Overrides the scene's paging choice.
  std::optional<TerrainPaging> paging;
  /// Progress of a tile-pyramid build; empty = a progress bar on stderr.
  terrain::PyramidProgress progress;
  /// Keep the vector layers as read in the scene's cache directory, and read them from there
  /// while their files, the frame and the reader are unchanged (scene/src/layer_cache.hpp).
  bool layerCache = true;
};

Result<LoadedScene> loadScene(const SceneDescription& description, const LoadOptions& options = {});

/// The scene's vector layers read into `frame` (a projected scene's, or geo::SceneFrame::wgs84LonLat
/// for the globe, whose layers keep their points as given: the globe densifies along geodesics),
/// each through the layer cache in `cacheDirectory` (cacheDirectoryFor's; empty: none, all in
/// memory) unless options.layerCache is off; from the cache the features stay on disk. Every
/// message is named after our layer and added to `diagnostics`. A layer that cannot be read is
/// reported and left out. `fromCache` (if given) counts the layers read from the cache. Both
/// frames' scenes read their layers here.
std::vector<LoadedLayer> loadLayers(const SceneDescription& description, const geo::SceneFrame& frame,
                                    const std::string& cacheDirectory, const LoadOptions& options,
                                    Diagnostics& diagnostics, std::size_t* fromCache = nullptr);

/// The layers' indices in draw order (LayerStyle::drawOrder, earlier layers below; ties in the
/// scene file's order): how both frames order what they draw.
std::vector<std::size_t> drawOrderOf(const std::vector<LoadedLayer>& layers);

/// A scene for a DEM opened alone: a file in any CRS, a folder of tiles or a VRT.
SceneDescription sceneForDem(const std::string& path);

/// A scene for a vector file opened alone: flat ground (height 0) in memory, covering the file's
/// extent with a margin, under the file as the scene's one layer (its kind from what it holds).
Result<SceneDescription> sceneForVectorFile(const std::string& path);

/// The layers a vector file makes when added to a scene: one per layer of the data source (a
/// GeoPackage may hold several), named after the file (and the layer), the kind from what each
/// holds, colours from a small palette starting at its `index`-th.
Result<std::vector<LayerDescription>> layersForVectorFile(const std::string& path, const geo::SceneFrame& frame,
                                                          std::size_t index);

/// Where the tile pyramid of the scene's DEM lives (the scene's cache directory, made if needed,
/// else the user's cache directory).
std::string pyramidPathFor(const SceneDescription& description);

/// The scene's cache directory (its `cache_dir`, else ".stencil-gis-cache" beside the scene file),
/// made if needed. When that cannot be written (a read-only folder, a path that is a file) the
/// user's cache folder ($XDG_CACHE_HOME/stencil-gis, else ~/.cache/stencil-gis); when neither
/// can, or the cache is disabled, empty: no cache. `warning` (if given) says which fallback was
/// taken and why, empty when none was.
std::string cacheDirectoryFor(const SceneDescription& description, std::string* warning = nullptr);

/// What a cache directory holds.
struct CacheUsage {
  std::uintmax_t bytes = 0;
  std::size_t files = 0;
};
CacheUsage cacheUsage(const std::string& directory);

/// Empties a cache directory (the viewer's "clear cache"): everything in it is ours and
/// disposable. Files open in this process stay readable until closed (their folders' entries
/// go); what a later load or tile needs is built again. Returns what was removed.
CacheUsage clearCache(const std::string& directory);

/// A scratch folder for files that must exist on disk even without a cache (a paged DEM's
/// pyramid): the system's temporary folder, per user.
std::string scratchDirectory();

/// What overlay pieces built on the scene's terrain depend on, as text for a cache's fingerprint:
/// the DEM files (path, size, date), band, chunk size, grid, paging and vertical exaggeration.
std::string terrainCacheKey(const LoadedScene& scene);

/// A progress bar on stderr (redrawn in place on a terminal, a line per 10 % otherwise).
terrain::PyramidProgress consoleProgress(std::string label);

/// The box that holds the terrain (frame coordinates, with the given exaggeration).
void terrainBox(const LoadedScene& scene, double exaggeration, glm::dvec3& boxMin, glm::dvec3& boxMax);

/// The camera a still image of the scene is drawn from: the camera file's when `cameraFile` is
/// not empty, else the scene file's (`description`, read from `sceneFile`), else the overview of
/// the terrain at the bounds' exaggeration.
Result<Camera> stillCamera(const std::string& cameraFile, const SceneDescription& description,
                           const std::string& sceneFile, const LoadedScene& scene);

}  // namespace gis::scene
