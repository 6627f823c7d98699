#pragma once
// A scene drawn on the WGS 84 globe (docs/globe.md): its DEM as heights in longitude/latitude
// (globe::GeoGrid), its polygon layers read in longitude/latitude (globe::GlobeLayer), and the
// choice between the globe and a projected frame.
#include <algorithm>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/diagnostics.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_imagery.hpp"
#include "globe/globe_view.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/shared_features.hpp"

namespace gis::scene {

/// Why the scene is drawn on the globe, or empty when it keeps a projected frame. "frame": "globe"
/// or "projected" decide; "auto" (the default) keeps a projected DEM's own CRS (the user chose
/// it) and puts a DEM in longitude/latitude on the globe when one projected frame would distort
/// it: the frame for such a DEM is the UTM zone of its centre, whose scale error k − 1 =
/// 0.9996 (1 + x²/2R²) − 1 passes 0.1 % at x = 337 km from the zone's central meridian, and UTM
/// ends at 84° N and 80° S. So the globe is chosen when the DEM reaches farther than 337 km east
/// or west of that meridian (at its widest latitude), beyond 84° N or 80° S, or across ±180°.
Result<std::string> globeReason(const SceneDescription& description);

struct LoadedGlobeScene {
  SceneDescription description;
  std::string reason;  ///< globeReason's
  std::shared_ptr<const globe::GeoGrid> heights;
  /// The scene's imagery (bands imageryBands), for GlobeRenderer::setImagery; null without one or
  /// when it cannot be read (said in the diagnostics).
  std::shared_ptr<const globe::GlobeImagery> imagery;
  /// The scene's vector layers as read (loadLayers: the projected frame's loader, in longitude and
  /// latitude), through the layer cache as a projected scene's: features on disk, read one at a
  /// time, when the scene has a cache.
  std::vector<LoadedLayer> sourceLayers;
  std::size_t layersFromCache = 0;          ///< source layers read from the cache
  std::vector<globe::GlobeLayer> layers;    ///< what is drawn: a fill and its outline are two, in order
  std::vector<std::size_t> layerFileIndex;  ///< per layer: its place in the scene file (its mask bit)
  /// Per layer: the features it was built from (its source layer's, shared: GlobePolygon::feature
  /// and GlobeLine::feature index them; a fill and its outline share them): what identify shows.
  std::vector<overlay::SharedFeatures> layerFeatures;
  /// The data's box in longitude/latitude (west, south, east, north): the layers', else the
  /// DEM's. West may be below −180 and east above 180 for data across the antimeridian.
  std::array<double, 4> extent{-180.0, -90.0, 180.0, 90.0};
  double loadSeconds = 0.0;
};

/// Reads the DEM (globe::GeoGrid::fromDem: one file, several, folders of tiles or a VRT, any CRS,
/// warped to lon/lat, heights converted to the ellipsoid as terrain.vertical_datum says, refused
/// beyond terrain.memory_budget_mb), the imagery, and the layers: polygons, lines and outlines in metres or in
/// pixels, with the style's joins and caps (outlines round). A layer that cannot be read is reported and
/// left out; only a DEM that cannot be read fails the scene.
Result<LoadedGlobeScene> loadGlobeScene(const SceneDescription& description);

/// Builds the scene's globe layers (layers, layerFileIndex, layerFeatures) from its source layers,
/// each with its description's style (sourceLayers[i].description), in draw order: a polygon
/// layer's fill and, with an outline, its outline; lines in metres or in pixels, with the style's
/// joins and caps. What loadGlobeScene does after reading, and what an edit of a style does
/// again (the viewer). The features are shared, not read again.
void buildGlobeLayers(LoadedGlobeScene& scene, Diagnostics& diagnostics);

/// The globe's way of drawing for a technique of the registry (overlay_render --method, the
/// viewer's methods): every technique of the registry (globe_overlay.hpp, GlobeTechnique); none
/// for a name that is not one.
std::optional<globe::GlobeTechnique> globeTechniqueNamed(std::string_view name);

/// How the scene's layers are drawn on the globe: the overlay's GPU budget is the scene's
/// terrain.gpu_budget_mb, as the projected frame's tiles have it, and its tiles are kept in the
/// scene's cache directory (cacheDirectoryFor: none when the cache is disabled).
globe::GlobeOverlaySettings globeOverlaySettings(const SceneDescription& description);

/// The view of a camera stated in lon/lat/h (eye and target; a scene's "camera", a camera file,
/// overlay_render's globe camera.json), its near plane the camera's "near" or a fraction of the
/// eye's height above `ground`; nothing (an Error naming `where`) for a camera given in frame
/// coordinates (eye_xyz), which mean nothing on the globe.
Result<globe::GlobeView> globeViewOf(const CameraSpec& spec, const globe::GeoGrid& ground, int width, int height,
                                     const std::string& where);

/// The view a still of the scene is drawn from: the scene's camera (eye and target in lon, lat,
/// h), else one from above the data's middle, far enough to hold their extent.
globe::GlobeView globeStillView(const LoadedGlobeScene& scene, int width, int height);

}  // namespace gis::scene
