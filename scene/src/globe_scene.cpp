#include "scene/globe_scene.hpp"

#include "scene/scene_loader.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "vector_overlay/layer_geometry.hpp"

namespace gis::scene {

namespace {

constexpr double kUtmReachMetres = 337000.0;  ///< 0.1 % scale error from the central meridian
constexpr double kMetresPerDegreeEquator = 111319.49;

/// The DEM's box in longitude/latitude (west, south, east, north), if its CRS is geographic.
std::optional<std::array<double, 4>> geographicBox(const geo::RasterInfo& info) {
  if (!info.crsIsGeographic) return std::nullopt;
  const glm::dvec2 a = info.geoTransform.pixelToCrs(0.0, 0.0);
  const glm::dvec2 b = info.geoTransform.pixelToCrs(info.width, info.height);
  return std::array<double, 4>{std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y)};
}

/// A line's widths on the globe as in a projected frame (LineShape): `pixels` > 0 keeps that
/// width on screen, up to max_width_m (unbounded when not given: the globe builds its tiles per
/// width class, so a river stays 1.5 px wide from space; a projected frame's whole-load
/// techniques cap width_px at 50 m); otherwise `metres`, at least min_width_px wide on screen.
void setLineWidths(globe::GlobeLayerOptions& build, double pixels, double metres, const overlay::LayerStyle& style,
                   const std::shared_ptr<const globe::GeoGrid>& ground) {
  build.anchorGround = ground;
  build.lineMaxWidthMetres = style.maxWidthMetres > 0.0 ? style.maxWidthMetres : 1e7;
  if (pixels > 0.0) {
    build.lineWidthPixels = pixels;
    build.lineWidthMetres = 0.0;
  } else {
    build.lineWidthMetres = metres;
    build.lineWidthPixels = style.minWidthPixels > 0.0 ? style.minWidthPixels : 0.0;
  }
}

}  // namespace

Result<std::string> globeReason(const SceneDescription& description) {
  Result<std::string> out;
  if (description.frame == FrameKind::Globe) {
    out.value = "the scene asks for the globe (\"frame\": \"globe\")";
    return out;
  }
  if (description.frame == FrameKind::Projected) {
    out.value = std::string();
    return out;
  }
  Result<geo::RasterInfo> info = geo::inspectRaster(description.dem);
  out.diagnostics = info.diagnostics;
  if (!info.ok()) return out;
  const std::optional<std::array<double, 4>> box = geographicBox(*info);
  out.value = std::string();
  if (!box) return out;  // a projected DEM keeps its own CRS
  const auto [west, south, east, north] = *box;
  if (east - west >= 180.0 || west < -180.0 || east > 180.0) {
    out.value = "the DEM spans " + std::to_string(east - west) + "° of longitude or crosses ±180°";
    return out;
  }
  if (north > 84.0 || south < -80.0) {
    out.value = "the DEM reaches beyond UTM's latitudes (84° N, 80° S)";
    return out;
  }
  const double centreLon = 0.5 * (west + east);
  const double meridian = std::floor((centreLon + 180.0) / 6.0) * 6.0 - 177.0;
  const double widestLat = (south <= 0.0 && north >= 0.0) ? 0.0 : std::min(std::abs(south), std::abs(north));
  const double reach = std::max(meridian - west, east - meridian) * kMetresPerDegreeEquator *
                       std::cos(widestLat * 3.14159265358979323846 / 180.0);
  if (reach > kUtmReachMetres) {
    out.value = "the DEM reaches " + std::to_string(static_cast<long>(reach / 1000.0)) +
                " km from its UTM zone's central meridian (beyond 337 km the scale error passes 0.1 %)";
  }
  return out;
}

std::optional<globe::GlobeTechnique> globeTechniqueNamed(std::string_view name) {
  if (name == "stencil-tiles") return globe::GlobeTechnique::StencilTiles;
  if (name == "stencil") return globe::GlobeTechnique::Stencil;
  if (name == "paper") return globe::GlobeTechnique::Paper;
  if (name == "deferred") return globe::GlobeTechnique::Deferred;
  if (name == "auto") return globe::GlobeTechnique::Auto;
  if (name == "drape") return globe::GlobeTechnique::Drape;
  if (name == "drape-tiles") return globe::GlobeTechnique::DrapeTiles;
  return std::nullopt;
}

globe::GlobeOverlaySettings globeOverlaySettings(const SceneDescription& description) {
  globe::GlobeOverlaySettings settings;
  settings.gpuBudgetBytes = static_cast<std::size_t>(std::max(16.0, description.gpuBudgetMb) * 1024.0 * 1024.0);
  settings.cacheDir = cacheDirectoryFor(description);
  return settings;
}

void buildGlobeLayers(LoadedGlobeScene& scene, Diagnostics& diagnostics) {
  scene.layers.clear();
  scene.layerFileIndex.clear();
  scene.layerFeatures.clear();
  for (const std::size_t i : drawOrderOf(scene.sourceLayers)) {
    const LoadedLayer& source = scene.sourceLayers[i];
    const LayerDescription& layer = source.description;
    const overlay::LayerStyle& style = layer.style;
    glm::vec4 color = style.color;
    color.w *= style.opacity;
    globe::GlobeLayerOptions build;
    setLineWidths(build, style.widthPixels, style.widthMetres, style, scene.heights);
    build.join = style.join;  // outlines keep round joins, as in a projected frame
    build.cap = style.cap;
    build.miterLimit = style.miterLimit;
    // Colours by category and widths from an attribute, per feature (the projected frame's
    // resolution: a width that is not a positive number gets the layer's, with a warning).
    if (!style.colorAttribute.empty() || (!style.widthAttribute.empty() && style.widthPixels <= 0.0)) {
      const std::vector<overlay::FeatureStyle> styles =
          overlay::resolveFeatureStyles(style, layer.kind, source.features, &diagnostics, layer.name);
      for (const overlay::FeatureStyle& f : styles) {
        if (!style.colorAttribute.empty()) build.featureColors.push_back(f.color);
        if (!style.widthAttribute.empty() && style.widthPixels <= 0.0)
          build.featureWidthMetres.push_back(f.shape.width);
      }
    }
    Result<globe::GlobeLayer> built = globe::GlobeLayer::build(layer.name, source.features, color, build);
    diagnostics.append(built.diagnostics);
    if (built.ok()) {
      scene.layers.push_back(std::move(*built));
      scene.layerFileIndex.push_back(layer.fileIndex);
      scene.layerFeatures.push_back(source.features);
    }
    // A polygon layer's outline: a layer of its own, with the same bit in mask.png.
    if (layer.kind == overlay::LayerKind::Polygon &&
        (style.outlineWidthMetres > 0.0F || style.outlineWidthPixels > 0.0F)) {
      globe::GlobeLayerOptions outline;
      outline.outlines = true;
      setLineWidths(outline, style.outlineWidthPixels, style.outlineWidthMetres, style, scene.heights);
      glm::vec4 outlineColor = style.outlineColor;
      outlineColor.w *= style.opacity;
      Result<globe::GlobeLayer> lines =
          globe::GlobeLayer::build(layer.name + " (outline)", source.features, outlineColor, outline);
      diagnostics.append(lines.diagnostics);
      if (lines.ok()) {
        scene.layers.push_back(std::move(*lines));
        scene.layerFileIndex.push_back(layer.fileIndex);
        scene.layerFeatures.push_back(source.features);
      }
    }
  }
}

Result<LoadedGlobeScene> loadGlobeScene(const SceneDescription& description) {
  const auto start = std::chrono::steady_clock::now();
  Result<LoadedGlobeScene> out;
  Result<std::string> reason = globeReason(description);
  out.diagnostics.append(reason.diagnostics);
  globe::GeoGridReadOptions gridOptions;
  gridOptions.vertical = globe::parseVerticalDatum(description.demVerticalDatum).value_or(globe::VerticalDatum::Auto);
  gridOptions.memoryBudgetMb = description.memoryBudgetMb;
  gridOptions.paging = description.paging == TerrainPaging::Always  ? globe::GridPaging::Always
                       : description.paging == TerrainPaging::Never ? globe::GridPaging::Never
                                                                    : globe::GridPaging::Auto;
  // The cache: the scene's, else the user's, else none (said once). A paged grid needs a file
  // even without a cache: a scratch folder then.
  std::string cacheWarning;
  const std::string cacheDirectory = cacheDirectoryFor(description, &cacheWarning);
  if (!cacheWarning.empty()) out.diagnostics.add({Severity::Warning, {}, {}, {}, cacheWarning});
  gridOptions.cacheDir = [cacheDirectory] { return cacheDirectory.empty() ? scratchDirectory() : cacheDirectory; };
  gridOptions.sceneFile = description.path;
  Result<globe::GeoGrid> grid = globe::GeoGrid::fromDem(description.demSpec(), gridOptions);
  out.diagnostics.append(grid.diagnostics);
  if (!grid.ok()) return out;
  LoadedGlobeScene scene;
  scene.description = description;
  scene.reason = reason.ok() ? *reason : std::string();
  // The scene's vertical exaggeration lives in the heights the globe reads (GeoGrid::exaggerated),
  // as a projected scene's lives in its height bounds.
  scene.heights = globe::GeoGrid::exaggerated(std::make_shared<const globe::GeoGrid>(std::move(*grid)),
                                              description.verticalExaggeration);
  const globe::GeoGrid& g = *scene.heights;
  scene.extent = {g.west(), g.north() - (g.height() - 1) * g.step(), g.west() + (g.width() - 1) * g.step(), g.north()};
  if (scene.extent[2] - scene.extent[0] > 360.0) scene.extent[2] = scene.extent[0] + 360.0;

  // The imagery, in any CRS: read per drawn tile later. One that cannot be read is said and left out.
  // Large imagery without overviews gets them built once into the scene's cache.
  if (description.imagery) {
    globe::ImageryOptions imageryOptions;
    if (!cacheDirectory.empty()) imageryOptions.cacheDir = [cacheDirectory] { return cacheDirectory; };
    Result<std::shared_ptr<globe::GlobeImagery>> imagery =
        globe::GlobeImagery::open(*description.imagery, description.imageryBands, imageryOptions);
    out.diagnostics.append(imagery.diagnostics);
    if (imagery.ok()) scene.imagery = std::move(*imagery);
  }

  // The layers, read as a projected scene reads them (in longitude and latitude): one loader.
  scene.sourceLayers = loadLayers(description, geo::SceneFrame::wgs84LonLat(), cacheDirectory, {}, out.diagnostics,
                                  &scene.layersFromCache);
  buildGlobeLayers(scene, out.diagnostics);
  // The layers' box, when there are layers: what a first view should show (known without
  // preparing the lines).
  globe::LonLatRect box{std::numeric_limits<double>::max(), 90.0, -std::numeric_limits<double>::max(), -90.0};
  for (const globe::GlobeLayer& layer : scene.layers) {
    const globe::LonLatRect r = layer.extent();
    if (r.west > r.east) continue;
    box.west = std::min(box.west, r.west);
    box.east = std::max(box.east, r.east);
    box.south = std::min(box.south, r.south);
    box.north = std::max(box.north, r.north);
  }
  if (box.west <= box.east) scene.extent = {box.west, box.south, std::min(box.east, box.west + 360.0), box.north};
  scene.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.value = std::move(scene);
  return out;
}

Result<globe::GlobeView> globeViewOf(const CameraSpec& spec, const globe::GeoGrid& ground, int width, int height,
                                     const std::string& where) {
  if (!spec.eyeLonLatH || !spec.targetLonLatH) {
    return Result<globe::GlobeView>::failure(
        {Severity::Error, where, "", "", "camera: on the globe, 'eye' and 'target' are given in lon/lat/h"});
  }
  const glm::dvec3 e = *spec.eyeLonLatH, t = *spec.targetLonLatH;
  globe::GlobeView view = globe::GlobeView::looking(globe::toEcef(e.x, e.y, e.z), globe::toEcef(t.x, t.y, t.z),
                                                    spec.fovYDeg, width, height, ground.heightAt(e.x, e.y));
  if (spec.nearPlane) view.near = *spec.nearPlane;
  Result<globe::GlobeView> out;
  out.value = view;
  return out;
}

globe::GlobeView globeStillView(const LoadedGlobeScene& scene, int width, int height) {
  if (const std::optional<CameraSpec>& spec = scene.description.camera) {
    if (Result<globe::GlobeView> view = globeViewOf(*spec, *scene.heights, width, height, scene.description.path))
      return *view;
  }
  // From above the middle of the data, far enough that the box's corners are in view.
  const auto [west, south, east, north] = scene.extent;
  const double lon = 0.5 * (west + east), lat = 0.5 * (south + north);
  const glm::dvec3 centre = globe::toEcef(lon, lat, 0.0);
  double radius = 0.0;
  for (const double x : {west, lon, east}) {
    for (const double y : {south, lat, north})
      radius = std::max(radius, glm::length(globe::toEcef(x, y, 0.0) - centre));
  }
  const double fov = 45.0;
  const double distance = std::min(radius / std::tan(0.5 * fov * 3.14159265358979323846 / 180.0) * 1.1 + 1000.0, 3e7);
  const glm::dvec3 up = globe::surfaceNormal(lon, lat);
  return globe::GlobeView::looking(centre + up * distance, centre, fov, width, height, 0.0);
}

}  // namespace gis::scene
