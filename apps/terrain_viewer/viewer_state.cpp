// What a test of the viewer reads: what is under a pixel (identify) and the viewer's state
// (save_state), as JSON.
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "gfx/gl.hpp"  // before GLFW: libepoxy provides the GL declarations

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "geo/vector.hpp"
#include "scene/json_file.hpp"
#include "scene/scene.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "viewer.hpp"

namespace gis::viewer {
namespace {

nlohmann::json geodeticJson(const globe::Geodetic& g) { return {{"lon", g.lon}, {"lat", g.lat}, {"h", g.h}}; }

}  // namespace

nlohmann::json Identified::toJson() const {
  nlohmann::json features = nlohmann::json::array();
  for (const Hit& h : hits) {
    nlohmann::json attributes = nlohmann::json::object();
    for (const auto& [k, v] : h.attributes) attributes[k] = v;
    features.push_back({{"layer", h.layer}, {"fid", h.fid}, {"feature", h.feature}, {"attributes", attributes}});
  }
  nlohmann::json j = groundPointJson(point);
  j["terrain_height"] = terrainHeight;
  j["features"] = features;
  return j;
}

nlohmann::json groundPointJson(const GroundPoint& point) {
  const glm::dvec3& f = point.drawn;
  // As drawn: frame coordinates in a projected scene, ECEF on the globe.
  nlohmann::json j = {{point.onGlobe ? "ecef" : "frame", {f.x, f.y, f.z}}, {"height", point.height}};
  if (point.onGlobe) j["frame"] = "globe";
  if (point.projected) j["crs_xyz"] = {point.projected->x, point.projected->y, point.projected->z};
  if (point.lonLatH) j["lon_lat_h"] = {point.lonLatH->x, point.lonLatH->y, point.lonLatH->z};
  return j;
}

std::optional<float> Viewer::depthAt(int x, int y) const {
  if (!target_ || x < 0 || y < 0 || x >= target_->width() || y >= target_->height()) return std::nullopt;
  float depth = 0.0F;
  gfx::readFramebuffer(target_->framebuffer(), GL_COLOR_ATTACHMENT0, x, target_->height() - 1 - y, 1, 1,
                       GL_DEPTH_COMPONENT, GL_FLOAT, &depth);
  if (!(depth > 0.0F)) return std::nullopt;  // background (reversed-Z clears to 0)
  return depth;
}

scene::FrameCamera Viewer::frameCamera() const {
  if (globe_) return globe_->view;
  return camera();
}

std::optional<glm::dvec3> Viewer::pointAt(const glm::dvec2& pixel) const {
  const int x = static_cast<int>(std::floor(pixel.x)), y = static_cast<int>(std::floor(pixel.y));
  const std::optional<float> depth = depthAt(x, y);
  if (!depth) return std::nullopt;
  // The image's camera without its depths: the sample read here is its depth.
  return overlay::unprojectDepth(scene::Scene::depthImageOf(frameCamera(), target_->width(), target_->height(), {}), x,
                                 y, *depth);
}

std::optional<GroundPoint> Viewer::groundAt(const glm::dvec2& pixel) const {
  const std::optional<glm::dvec3> world = pointAt(pixel);
  if (!world) return std::nullopt;
  GroundPoint g;
  g.drawn = *world;
  if (globe_) {
    globe::Geodetic at = globe::toGeodetic(*world);
    at.h /= globeScene().heights->exaggeration();
    g.onGlobe = true;
    g.lonLatH = glm::dvec3(at.lon, at.lat, at.h);
    g.height = at.h;
    return g;
  }
  const glm::dvec3 unexaggerated = *world / glm::dvec3(1.0, 1.0, projected().bounds->exaggeration());
  g.projected = projected().frame.frameToProjected(unexaggerated);
  g.lonLatH = projected().frame.toLonLat(unexaggerated);
  g.height = g.projected->z;
  return g;
}

std::string Viewer::crsName() const {
  const std::optional<int> code = projected().frame.epsg();
  return code ? "EPSG:" + std::to_string(*code) : std::string("CRS");
}

std::optional<Identified> Viewer::identify(const glm::dvec2& pixel) {
  const std::optional<GroundPoint> ground = groundAt(pixel);
  if (!ground) return std::nullopt;
  Identified id;
  id.point = *ground;
  if (globe_) {
    id.terrainHeight = globeScene().heights->unexaggerated().heightAt(ground->lonLatH->x, ground->lonLatH->y);
  } else {
    id.terrainHeight =
        projected().bounds->fullResolutionHeightAt(glm::dvec2(ground->drawn)) / projected().bounds->exaggeration();
  }
  // Every shown drawn layer's features there, a fill's and its outline's: each feature once.
  const scene::FrameCamera camera = frameCamera();
  const glm::ivec2 size(target_->width(), target_->height());
  std::set<std::pair<std::size_t, std::size_t>> seen;
  for (std::size_t j = 0; j < renderer_->drawnLayerCount(); ++j) {
    if (!renderer_->drawnLayerShown(j)) continue;
    const std::size_t fileIndex = renderer_->drawnLayerSource(j).fileIndex;
    for (const std::size_t f : renderer_->featuresAt(j, ground->drawn, camera, size.x, size.y)) {
      if (!seen.insert({fileIndex, f}).second) continue;
      Identified::Hit hit;
      hit.layer = sceneLayerNameOf(j);
      hit.feature = f;
      if (const std::shared_ptr<const geo::Feature> feature = renderer_->drawnLayerFeature(j, f)) {
        hit.fid = feature->fid;
        for (const auto& [k, v] : feature->attributes) hit.attributes.emplace_back(k, attributeText(v));
      }
      id.hits.push_back(std::move(hit));
    }
  }
  return id;
}

nlohmann::json Viewer::tableJson() const {
  if (!table_) return nullptr;
  // The fids of the first rows as shown (sorted, searched): what a test of the table checks.
  nlohmann::json fids = nlohmann::json::array();
  if (const std::vector<geo::Feature>* features = featuresOf(table_->sceneLayer)) {
    for (std::size_t r = 0; r < table_->rows.size() && r < 20; ++r) fids.push_back((*features)[table_->rows[r]].fid);
  }
  return {{"layer", description_->layers[table_->sceneLayer].name},
          {"rows", table_->rows.size()},
          {"first_rows", fids},
          {"selected_rows", table_->selectedRows.size()}};
}

nlohmann::json Viewer::measureJson() const {
  if (!measurement_) return {{"points", measurePoints_.size()}};
  const scene::Measurement& m = *measurement_;
  nlohmann::json j = {{"points", measurePoints_.size()}, {"closed", m.closed},
                      {"geodesic_m", m.geodesicMetres},  {"surface_m", m.surfaceMetres},
                      {"planar_m", m.planarMetres},      {"surface_complete", m.surfaceComplete}};
  if (m.geodesicAreaM2) j["geodesic_area_m2"] = *m.geodesicAreaM2;
  if (m.surfaceAreaM2) j["surface_area_m2"] = *m.surfaceAreaM2;
  if (m.planarAreaM2) j["planar_area_m2"] = *m.planarAreaM2;
  return j;
}

nlohmann::json Viewer::keysDownJson() const {
  nlohmann::json keys = nlohmann::json::array();
  for (std::size_t k = 0; k < keysDown_.size(); ++k) {
    if (keysDown_[k]) keys.push_back(k);
  }
  return keys;
}

nlohmann::json Viewer::selectionJson() const {
  // Per layer, the features as overlay_render's stats.json lists them in its selection block.
  nlohmann::json steps = nlohmann::json::array(), lassos = nlohmann::json::array();
  for (const overlay::SelectionStep& st : steps_) {
    steps.push_back(overlay::selectionOpName(st.op));
    nlohmann::json points = nlohmann::json::array();
    for (const glm::dvec2& p : st.lasso.points) points.push_back({p.x, p.y});
    lassos.push_back(points);
  }
  nlohmann::json out = {{"steps", steps}, {"lassos", lassos},     {"selection_ms", selectionMs_},
                        {"features", 0},  {"dem_posts", nullptr}, {"layers", nlohmann::json::array()}};
  if (!selected_) return out;
  nlohmann::json layers = nlohmann::json::array();
  for (const scene::SelectedFeatures::Layer& l : selected_->layers) {
    nlohmann::json list = nlohmann::json::array();
    for (std::size_t k = 0; k < l.features.size(); ++k) {
      const overlay::FeatureSelection& f = l.features[k];
      list.push_back({{"fid", l.fids[k]},
                      {"feature", f.feature},
                      {"fully_inside", f.fullyInside},
                      {"samples", f.samples},
                      {"selected_samples", f.selectedSamples}});
    }
    layers.push_back(
        {{"name", l.name}, {"selected", l.features.size()}, {"fully_inside", l.fullyInside}, {"features", list}});
  }
  out["features"] = selected_->featureCount();
  out["dem_posts"] = selected_->posts ? nlohmann::json(selected_->posts->selected) : nlohmann::json();
  out["layers"] = layers;
  out["sample_spacing_m"] = selected_->sampleSpacing;
  out["tested_samples"] = selected_->testedSamples;
  return out;
}

nlohmann::json Viewer::state() const {
  const glm::ivec2 fb = framebufferSize();
  glm::ivec2 window(0);
  glfwGetWindowSize(context_->window(), &window.x, &window.y);
  if (!scene_) {
    return {
        {"scene", nullptr}, {"framebuffer", {fb.x, fb.y}}, {"window", {window.x, window.y}}, {"messages", messages_}};
  }
  const glm::dvec4 free = freeRegion();
  nlohmann::json rects = nlohmann::json::object();
  for (const auto& [name, r] : uiRects_) rects[name] = {r.x, r.y, r.z, r.w};
  // Per layer of the scene file, as the panel lists them in both frames.
  nlohmann::json layers = nlohmann::json::array();
  for (std::size_t i = 0; i < description_->layers.size(); ++i) {
    const overlay::LayerStyle& style = description_->layers[i].style;
    nlohmann::json categories = nlohmann::json::object();
    for (const auto& [value, c] : style.categories) categories[value] = {c.x, c.y, c.z};
    nlohmann::json layer = {
        {"name", description_->layers[i].name},
        {"color", {style.color.x, style.color.y, style.color.z}},
        {"color_attribute", style.colorAttribute},
        {"categories", categories},
        {"labels", labelSets_.contains(i) ? nlohmann::json(labelSets_.at(i).attribute) : nlohmann::json()},
        {"shown", layerShown(i).value_or(false)},
        {"mask_bit", description_->layers[i].fileIndex}};
    layer.update(frameLayerJson(i));
    layers.push_back(std::move(layer));
  }
  nlohmann::json j = {{"scene", description_->path},
                      {"frame", globe_ ? "globe" : "projected"},
                      {"framebuffer", {fb.x, fb.y}},
                      {"window", {window.x, window.y}},
                      {"free_region", {free.x, free.y, free.z, free.w}},
                      {"exaggeration", exaggeration()},
                      {"ui_rects", rects},
                      {"windows", windowsJson()},
                      {"notice", notice_ ? nlohmann::json(notice_->text) : nlohmann::json()},
                      {"keys_down", keysDownJson()},
                      {"undo_steps", undo_.size()},
                      {"redo_steps", redo_.size()},
                      {"highlighted_features", highlightedCount_},
                      {"loading", {{"frames_shown", loadingFramesShown_}, {"last_progress", lastLoadProgress_}}},
                      {"font", font_},
                      {"elevation_ramp", render_.elevationRamp ? nlohmann::json({render_.elevationRamp->first,
                                                                                 render_.elevationRamp->second})
                                                               : nlohmann::json()},
                      {"file_dialog",
                       {{"open", browser_.open},
                        {"directory", browser_.directory.string()},
                        {"path", std::string(browser_.path.data())},
                        {"error", browser_.error}}},
                      {"labels_placed", labelsPlaced_},
                      {"measure_tool", measureTool_},
                      {"measure", measureJson()},
                      {"legend", showLegend_},
                      {"table", tableJson()},
                      {"compass_angle", compassAngle_},
                      {"scale_bar_m", scaleBarMetres_},
                      {"cursor", cursorGround_ ? groundPointJson(*cursorGround_) : nlohmann::json()},
                      {"overlays", render_.overlays},
                      {"method", technique_->name},
                      {"drape_size", technique_->usesTextures() ? nlohmann::json(drapeSize_) : nlohmann::json(nullptr)},
                      {"view",
                       {{"wireframe", render_.wireframe},
                        {"imagery", settings_.imagery},
                        {"debug_pieces", debugPieces_},
                        {"panel", settings_.showPanel},
                        {"hud", settings_.showHud},
                        {"lod_tolerance", settings_.lodTolerancePixels},
                        {"fov", settings_.fovYDeg}}},
                      {"messages", messages_},
                      {"lasso_tool", lassoTool_},
                      {"layers", layers},
                      {"selection", selectionJson()},
                      {"identified", identified_ ? identified_->toJson() : nlohmann::json()}};
  // The frame's camera and what it drew.
  j.update(frameStateJson());
  return j;
}

nlohmann::json Viewer::frameLayerJson(std::size_t sceneLayer) const {
  const scene::LayerSummary summary = renderer_->layerSummary(description_->layers[sceneLayer].fileIndex);
  nlohmann::json j = {{"features", summary.features}};
  if (globe_) {
    // The globe builds by tiles: what its layers hold (areas and lines) instead of what was drawn.
    std::size_t polygons = 0, lines = 0;
    for (const std::size_t d : drawnLayersOf(sceneLayer)) {
      polygons += globeScene().layers[d].areaCount();
      lines += globeScene().layers[d].lineCount();
    }
    j.update({{"polygons", polygons}, {"lines", lines}});
    return j;
  }
  j.update({{"skipped_features", summary.skipped()},
            {"features_with_nothing_to_draw", summary.nothingToDraw},
            {"drawn_features", summary.drawnFeatures}});
  return j;
}

nlohmann::json Viewer::frameStateJson() const {
  if (globe_) return globeStateJson();
  const glm::ivec2 fb = framebufferSize();
  const scene::OrbitPose& pose = controller_->shownPose();
  return {{"camera_mode", controller_->mode() == scene::CameraController::Mode::Fly ? "fly" : "orbit"},
          {"camera", scene::cameraToJson(camera(), projected().frame, fb.x, fb.y)},
          {"pose",
           {{"target", {pose.target.x, pose.target.y, pose.target.z}},
            {"yaw", pose.yaw},
            {"pitch", pose.pitch},
            {"distance", pose.distance}}},
          {"drawn",
           {{"ms", frameMs_},  // smoothed wall time per frame
            {"terrain_triangles", figures_.terrain.triangles},
            {"overlay_fragments", overlayFragments()},
            {"selection_ms", selectionMs_}}}};  // the CPU twin's logical selection, last run
}

nlohmann::json Viewer::globeStateJson() const {
  const GlobeMode& g = *globe_;
  const scene::GlobePose& pose = g.controller->pose();
  const globe::Geodetic eye = globe::toGeodetic(g.controller->eye());
  return {
      {"camera_mode", g.fly ? "fly" : "orbit"},
      {"globe_reason", globeScene().reason},
      {"globe",
       {{"target", geodeticJson(pose.target)},
        {"distance", pose.distance},
        {"heading", pose.heading},
        {"pitch", pose.pitch},
        {"heading_deg", pose.heading * 180.0 / std::numbers::pi},
        {"pitch_deg", pose.pitch * 180.0 / std::numbers::pi},
        {"eye", geodeticJson(eye)},
        {"eye_height_above_ground", g.controller->heightAboveGround()},
        {"exaggeration", globeScene().heights->exaggeration()},
        {"extent", {globeScene().extent[0], globeScene().extent[1], globeScene().extent[2], globeScene().extent[3]}},
        {"camera", scene::globeCameraJson(g.view)}}},
      {"drawn",
       {{"ms", frameMs_},
        {"terrain_triangles", figures_.terrain.triangles},
        {"overlay_fragments", overlayFragments()},
        {"selection_ms", selectionMs_}}},
      {"terrain", {{"tiles", figures_.terrain.tiles}, {"triangles", figures_.terrain.triangles}}},
      {"overlay",
       {{"pieces", figures_.drawnPieces},
        {"z_fail_pieces", figures_.zFailPieces},
        {"deferred_layers", figures_.deferredLayers},
        {"deferred_pending", figures_.deferredPending},
        {"draped", figures_.draped}}}};
}

}  // namespace gis::viewer
