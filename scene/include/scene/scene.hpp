#pragma once
// Scene files (samples/olinda/scene.json): the DEM, the imagery, the vector layers with their
// styles and an optional start camera. Paths are relative to the scene file.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "geo/dem_source.hpp"
#include "scene/camera.hpp"
#include "vector_overlay/style.hpp"

namespace gis::scene {

struct LayerDescription {
  std::string name;
  overlay::LayerKind kind = overlay::LayerKind::Polygon;
  std::string source;       ///< absolute path, or a connection string ("PG:...", /vsi..., a URL)
  std::string sourceLayer;  ///< OGR layer name; empty = first
  overlay::LayerStyle style;
  bool visible = true;
  /// Its place among the layers of the scene file (counting entries left out for errors): its
  /// bit in mask.png, which a layer before it that fails does not move.
  std::size_t fileIndex = 0;
};

/// The frame a scene is drawn in (docs/globe.md): a projected CRS, or the WGS 84 globe. Auto:
/// the globe when the DEM is in longitude/latitude and the data reach where one projected frame
/// would distort them (scene/globe_scene.hpp, globeReason).
enum class FrameKind { Auto, Projected, Globe };

/// Whether the DEM is held in memory or paged from a tile pyramid on disk.
enum class TerrainPaging { Auto, Always, Never };

struct SceneDescription {
  std::string path;  ///< the scene file
  std::string name;
  FrameKind frame = FrameKind::Auto;  ///< "frame": "auto" | "projected" | "globe"
  std::string dem;                    ///< absolute path (the first, when the DEM is several files or folders)
  /// Every file or folder of the DEM (absolute): one, a list, a folder of tiles or a VRT. Empty
  /// means {dem}.
  std::vector<std::string> demPaths;
  int demBand = 1;
  std::string demCrs;          ///< overrides the DEM files' CRS (needed when they have none)
  std::string demHeightUnit;   ///< overrides the heights' unit ("m", "ft", "us-ft")
  double demResolution = 0.0;  ///< metres between the posts of a resampled DEM; 0 = the source's finest
  /// What the DEM's heights are above, for the globe (terrain.vertical_datum: "auto", "ellipsoid",
  /// "egm96", "egm2008"; globe::VerticalDatum). A projected frame draws the heights as they are.
  std::string demVerticalDatum = "auto";
  double verticalExaggeration = 1.0;
  /// Auto: paged when the DEM in memory (about 7 bytes a post with its bounds) would exceed
  /// memoryBudgetMb; a paged DEM keeps a third of the budget for tiles.
  TerrainPaging paging = TerrainPaging::Auto;
  int chunkCells = 64;  ///< cells a side of a quadtree chunk (a power of two, 8 … 256)
  double memoryBudgetMb = 1024.0;
  double gpuBudgetMb = 512.0;
  std::string cacheDir;  ///< where the scene's cache goes; empty = ".stencil-gis-cache" beside the scene
  /// No cache on disk (overlay_render --no-cache): every layer read from its source, every tile
  /// built; a paged DEM's pyramid goes to a scratch folder.
  bool cacheDisabled = false;
  std::optional<std::string> imagery;  ///< absolute path
  std::vector<int> imageryBands{1, 2, 3};
  std::vector<LayerDescription> layers;
  std::optional<CameraSpec> camera;

  /// How to read the DEM.
  [[nodiscard]] geo::DemSpec demSpec() const;
};

/// Reads and validates a scene file. Unknown keys are warnings; a missing DEM or a malformed
/// value is an error naming the scene file and the key.
Result<SceneDescription> loadSceneFile(const std::string& path);
/// Same from JSON text (`path` only names the file in messages and anchors relative paths).
Result<SceneDescription> parseScene(const std::string& text, const std::string& path);

}  // namespace gis::scene
