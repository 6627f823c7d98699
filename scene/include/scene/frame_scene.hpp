#pragma once
// A loaded scene in either frame (docs/frames.md, "One scene, one set of programs"): the one type
// the programs hold. Its ground is a projected quadtree (LoadedScene: the DEM's chunks, their
// height bounds, the orthophoto) or the globe's grid (LoadedGlobeScene: heights in longitude and
// latitude, the imagery); the source layers are read the same way in both. The camera is a
// variant as well: a projected Camera or a globe::GlobeView.
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "globe/globe_view.hpp"
#include "scene/camera.hpp"
#include "scene/globe_scene.hpp"
#include "scene/lasso_file.hpp"
#include "scene/measure.hpp"
#include "scene/scene.hpp"
#include "scene/scene_loader.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/overlay_renderer.hpp"

namespace gis::scene {

/// Where a frame is seen from: a camera in the scene's frame, or a view of the globe (ECEF).
using FrameCamera = std::variant<Camera, globe::GlobeView>;

/// camera.json of a frame drawn on the globe (overlay_render's, the viewer's screenshots): the
/// view-projection in ECEF, the eye, the target, the near plane and the field of view.
nlohmann::json globeCameraJson(const globe::GlobeView& view);

class Scene {
 public:
  /// Loads what `description` names in the frame globeReason chooses (projected when it cannot
  /// tell: the projected loader then reads the DEM or says why not). `exaggeration` overrides
  /// the scene's vertical exaggeration (description.verticalExaggeration).
  static Result<Scene> load(SceneDescription description, const LoadOptions& options = {},
                            std::optional<double> exaggeration = std::nullopt);

  [[nodiscard]] bool onGlobe() const { return std::holds_alternative<LoadedGlobeScene>(ground_); }
  /// Why the scene is drawn on the globe (globeReason's); empty in a projected frame.
  [[nodiscard]] const std::string& globeReason() const;
  [[nodiscard]] const SceneDescription& description() const;
  /// The scene file's layers as read (those that could not be read are left out), in its order.
  [[nodiscard]] const std::vector<LoadedLayer>& layers() const;
  /// Every source vertex of the layers, as read (before any generalisation).
  [[nodiscard]] std::size_t vectorVertices() const;
  [[nodiscard]] double loadSeconds() const;
  /// The vertical exaggeration the ground is drawn at now (its own: a projected scene's height
  /// bounds, the globe's grid of heights; FrameRenderer::setExaggeration changes it).
  [[nodiscard]] double exaggeration() const;

  // The frame's geometry for the tools that draw on the ground and measure it. A map point is a
  // point of the frame's map: frame x/y, or longitude and latitude (degrees) on the globe.
  /// The ground's height as drawn (exaggerated) at a map point, at the DEM's full resolution.
  [[nodiscard]] double heightAt(const glm::dvec2& map) const;
  /// A map point at a height as drawn, in the frame's world: frame coordinates, or ECEF.
  [[nodiscard]] glm::dvec3 worldPoint(const glm::dvec2& map, double drawnHeight) const;
  /// The map point of a world point (the inverse of worldPoint, heights aside).
  [[nodiscard]] glm::dvec2 mapPoint(const glm::dvec3& world) const;
  /// A path through map points on the ground as drawn: densified to half the DEM's post spacing,
  /// straight in a projected frame, along geodesics on the globe (at least 10 m apart there).
  [[nodiscard]] std::vector<glm::dvec3> groundPath(std::span<const glm::dvec2> points, bool closed) const;
  /// Lengths and areas through map points (a ring when `closed`): geodesic, on the DEM's surface
  /// (true heights, sampled at half its post spacing), and planar (in the scene's CRS, or the
  /// chords on the globe): scene::measure, or scene::measureOnGlobe.
  [[nodiscard]] Result<Measurement> measure(std::span<const glm::dvec2> points, bool closed) const;

  /// The frame's own ground; the one the scene is not in is a caller error (throws).
  [[nodiscard]] LoadedScene& projected() { return std::get<LoadedScene>(ground_); }
  [[nodiscard]] const LoadedScene& projected() const { return std::get<LoadedScene>(ground_); }
  [[nodiscard]] LoadedGlobeScene& globe() { return std::get<LoadedGlobeScene>(ground_); }
  [[nodiscard]] const LoadedGlobeScene& globe() const { return std::get<LoadedGlobeScene>(ground_); }

  /// The camera a still image is drawn from: the camera file's when `cameraFile` is not empty,
  /// else the scene file's (read from `sceneFile`), else one that frames the data.
  [[nodiscard]] Result<FrameCamera> stillCamera(const std::string& cameraFile, const std::string& sceneFile, int width,
                                                int height) const;
  /// Reads a lasso file (lasso_file.hpp) for a frame seen from `camera`.
  [[nodiscard]] Result<SelectionRequest> loadLasso(const std::string& path, const FrameCamera& camera, int width,
                                                   int height) const;
  /// A lasso drawn on screen (pixels, y down) in a target of this size seen from `camera`: its
  /// volume reaches to infinity in a projected frame, to the eye's horizon over the DEM's highest
  /// post on the globe (not through the earth to its far side).
  [[nodiscard]] overlay::Lasso lassoIn(const FrameCamera& camera, std::vector<glm::dvec2> points, int width,
                                       int height) const;
  /// The overlay passes' view of `camera` in a target of this size.
  [[nodiscard]] static overlay::OverlayView overlayViewOf(const FrameCamera& camera, int width, int height);
  /// The CPU reference's view of a depth buffer drawn from `camera` (top row first).
  [[nodiscard]] static overlay::DepthImage depthImageOf(const FrameCamera& camera, int width, int height,
                                                        std::span<const float> depth);
  /// camera.json: the matrices the frame was drawn with and where it was drawn from.
  [[nodiscard]] nlohmann::json cameraJson(const FrameCamera& camera, int width, int height) const;

 private:
  explicit Scene(std::variant<LoadedScene, LoadedGlobeScene> ground) : ground_(std::move(ground)) {}
  std::variant<LoadedScene, LoadedGlobeScene> ground_;
};

}  // namespace gis::scene
