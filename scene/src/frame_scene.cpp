#include "scene/frame_scene.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <glm/geometric.hpp>

#include <nlohmann/json.hpp>

#include "globe/ellipsoid.hpp"
#include "scene/measure.hpp"
#include "scene/scene_renderer.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/globe_selection.hpp"

namespace gis::scene {

using nlohmann::json;

Result<Scene> Scene::load(SceneDescription description, const LoadOptions& options,
                          std::optional<double> exaggeration) {
  // A reason that cannot be found (a folder of tiles, a VRT the inspection cannot read) keeps the
  // projected frame, whose loader reads such DEMs, or says why it cannot.
  const Result<std::string> reason = scene::globeReason(description);
  Result<Scene> out;
  if (reason.ok() && !reason->empty()) {
    // The globe's heights are exaggerated as they are read (globe::GeoGrid).
    if (exaggeration) description.verticalExaggeration = *exaggeration;
    Result<LoadedGlobeScene> globe = loadGlobeScene(description);
    out.diagnostics.append(globe.diagnostics);
    if (!globe) return out;
    globe->reason = *reason;
    out.value.emplace(Scene(std::move(*globe)));
    return out;
  }
  Result<LoadedScene> projected = loadScene(description, options);
  out.diagnostics.append(projected.diagnostics);
  if (!projected) return out;
  // The projected terrain is exaggerated as it is drawn: its bounds own the factor.
  const double x = exaggeration.value_or(projected->description.verticalExaggeration);
  projected->bounds->setExaggeration(x);
  out.value.emplace(Scene(std::move(*projected)));
  return out;
}

double Scene::exaggeration() const {
  return onGlobe() ? globe().heights->exaggeration() : projected().bounds->exaggeration();
}

double Scene::heightAt(const glm::dvec2& map) const {
  return onGlobe() ? globe().heights->heightAt(map.x, map.y) : projected().bounds->fullResolutionHeightAt(map);
}

glm::dvec3 Scene::worldPoint(const glm::dvec2& map, double drawnHeight) const {
  return onGlobe() ? globe::toEcef(map.x, map.y, drawnHeight) : glm::dvec3(map, drawnHeight);
}

glm::dvec2 Scene::mapPoint(const glm::dvec3& world) const {
  if (!onGlobe()) return glm::dvec2(world);
  const globe::Geodetic g = globe::toGeodetic(world);
  return {g.lon, g.lat};
}

std::vector<glm::dvec3> Scene::groundPath(std::span<const glm::dvec2> points, bool closed) const {
  std::vector<glm::dvec3> path;
  if (onGlobe()) {
    constexpr double kMetresPerDegree = 111'320.0;
    const double step = std::max(10.0, 0.5 * globe().heights->step() * kMetresPerDegree);
    for (const glm::dvec2& p : geodesicPath(points, closed, step)) path.push_back(worldPoint(p, heightAt(p)));
    return path;
  }
  const terrain::TerrainGrid& grid = projected().quadtree->grid();
  const double step = grid.width > 0 ? 0.5 * std::min(std::abs(grid.step.x), std::abs(grid.step.y)) : 15.0;
  const std::size_t n = points.size();
  for (std::size_t i = 0; i + (closed ? 0 : 1) < n; ++i) {
    const glm::dvec2 a = points[i], b = points[(i + 1) % n];
    const int pieces = std::clamp(static_cast<int>(std::ceil(glm::length(b - a) / step)), 1, 4096);
    for (int k = 0; k < pieces; ++k) {
      const glm::dvec2 p = a + (b - a) * (static_cast<double>(k) / pieces);
      path.push_back(worldPoint(p, heightAt(p)));
    }
  }
  if (!closed && n > 0) path.push_back(worldPoint(points.back(), heightAt(points.back())));
  if (closed && !path.empty()) path.push_back(path.front());
  return path;
}

Result<Measurement> Scene::measure(std::span<const glm::dvec2> points, bool closed) const {
  MeasureOptions options;
  if (onGlobe()) {
    // Longitude and latitude, the segments geodesics on WGS 84.
    constexpr double kMetresPerDegree = 111'320.0;
    const std::shared_ptr<const globe::GeoGrid> heights = globe().heights;
    if (heights->width() > 0) options.sampleStepMetres = 0.5 * heights->step() * kMetresPerDegree;
    const auto height = [heights](double lon, double lat) { return heights->unexaggerated().heightAt(lon, lat); };
    return measureOnGlobe(points, closed, height, options);
  }
  const LoadedScene& p = projected();
  const double exaggeration = p.bounds->exaggeration();
  const auto height = [&p, exaggeration](const glm::dvec2& at) {
    return p.bounds->fullResolutionHeightAt(at) / exaggeration;  // true heights
  };
  const terrain::TerrainGrid& grid = p.quadtree->grid();
  if (grid.width > 0) options.sampleStepMetres = 0.5 * std::min(std::abs(grid.step.x), std::abs(grid.step.y));
  return scene::measure(p.frame, points, closed, height, options);
}

const std::string& Scene::globeReason() const {
  static const std::string kNone;
  return onGlobe() ? globe().reason : kNone;
}

const SceneDescription& Scene::description() const { return onGlobe() ? globe().description : projected().description; }

const std::vector<LoadedLayer>& Scene::layers() const { return onGlobe() ? globe().sourceLayers : projected().layers; }

std::size_t Scene::vectorVertices() const {
  std::size_t n = 0;
  for (const LoadedLayer& l : layers()) n += l.vertexCount();
  return n;
}

double Scene::loadSeconds() const { return onGlobe() ? globe().loadSeconds : projected().loadSeconds; }

Result<FrameCamera> Scene::stillCamera(const std::string& cameraFile, const std::string& sceneFile, int width,
                                       int height) const {
  Result<FrameCamera> out;
  if (!onGlobe()) {
    Result<Camera> camera = scene::stillCamera(cameraFile, description(), sceneFile, projected());
    out.diagnostics = std::move(camera.diagnostics);
    if (camera) out.value.emplace(*camera);
    return out;
  }
  if (cameraFile.empty()) {
    out.value.emplace(globeStillView(globe(), width, height));
    return out;
  }
  Result<CameraSpec> spec = loadCameraFile(cameraFile);
  out.diagnostics = std::move(spec.diagnostics);
  if (!spec) return out;
  Result<globe::GlobeView> placed = globeViewOf(*spec, *globe().heights, width, height, cameraFile);
  out.diagnostics.append(placed.diagnostics);
  if (placed) out.value.emplace(*placed);
  return out;
}

Result<SelectionRequest> Scene::loadLasso(const std::string& path, const FrameCamera& camera, int width,
                                          int height) const {
  if (onGlobe()) return loadGlobeLassoFile(path, std::get<globe::GlobeView>(camera), *globe().heights);
  return loadLassoFile(path, projected().frame, std::get<Camera>(camera), width, height);
}

overlay::Lasso Scene::lassoIn(const FrameCamera& camera, std::vector<glm::dvec2> points, int width, int height) const {
  if (const auto* view = std::get_if<globe::GlobeView>(&camera)) {
    const double highest = std::max(globe().heights->bounds({-180.0, -90.0, 180.0, 90.0}).second, 0.0);
    return globe::lassoIn(*view, std::move(points), highest);
  }
  const Camera& c = std::get<Camera>(camera);
  overlay::Lasso lasso;
  lasso.points = std::move(points);
  lasso.viewProj = c.projection(static_cast<double>(width) / height) * c.view();
  lasso.width = width;
  lasso.height = height;
  return lasso;
}

overlay::OverlayView Scene::overlayViewOf(const FrameCamera& camera, int width, int height) {
  if (const auto* view = std::get_if<globe::GlobeView>(&camera)) return globe::overlayViewOf(*view);
  return scene::overlayViewOf(std::get<Camera>(camera), static_cast<double>(width) / height);
}

overlay::DepthImage Scene::depthImageOf(const FrameCamera& camera, int width, int height,
                                        std::span<const float> depth) {
  if (const auto* view = std::get_if<globe::GlobeView>(&camera)) return globe::depthImageOf(*view, depth);
  const Camera& c = std::get<Camera>(camera);
  const double aspect = static_cast<double>(width) / height;
  return {width, height, depth, c.projection(aspect) * c.view()};
}

json globeCameraJson(const globe::GlobeView& view) {
  const globe::Geodetic eye = globe::toGeodetic(view.eye), at = globe::toGeodetic(view.target);
  return {{"width", view.width},
          {"height", view.height},
          {"frame", "globe"},
          {"crs", "EPSG:4978 (WGS 84 earth-centred, metres)"},
          {"view_proj_ecef", matrixToJson(view.viewProj())},
          {"eye_ecef", {view.eye.x, view.eye.y, view.eye.z}},
          {"depth", "reversed-Z: near / distance along the view axis, 0 = background"},
          {"near", view.near},
          {"fov_y_deg", view.fovYDeg},
          {"eye", {{"lon", eye.lon}, {"lat", eye.lat}, {"h", eye.h}}},
          {"target", {{"lon", at.lon}, {"lat", at.lat}, {"h", at.h}}}};
}

json Scene::cameraJson(const FrameCamera& camera, int width, int height) const {
  if (!onGlobe()) return cameraToJson(std::get<Camera>(camera), projected().frame, width, height);
  return globeCameraJson(std::get<globe::GlobeView>(camera));
}

}  // namespace gis::scene
