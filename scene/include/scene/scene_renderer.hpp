#pragma once
// Draws a loaded scene into any framebuffer, headless or windowed, pass by pass (docs/design.md §4):
// the terrain, then the vector layers as stencil polyhedra (the selection passes join later).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>

#include <glm/vec4.hpp>

#include "gfx/program.hpp"
#include "gfx/queries.hpp"
#include "gfx/state_cache.hpp"
#include "scene/camera.hpp"
#include "scene/scene_loader.hpp"
#include "terrain/terrain_engine.hpp"
#include "terrain/tile_pager.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::scene {

struct RenderSettings {
  double lodTolerancePixels = 1.5;
  bool wireframe = false;
  bool imagery = true;  ///< off: hillshade
  /// A hypsometric tint (terrain::ElevationRamp::hypsometric) wherever there is no imagery to
  /// show: this range of true heights (low, high; unexaggerated, e.g. terrain::demHeightRange)
  /// mapped onto the ramp, shaded by the hillshade. nullopt: grey hillshade.
  std::optional<std::pair<double, double>> elevationRamp;
  bool measure = false;  ///< wrap passes in GPU timer and pipeline-statistics queries (waits)
  /// Paged terrain: wait until every tile the view wants is loaded (still images), instead of
  /// drawing coarser parents while they load (flights).
  bool waitForTiles = false;
  /// While a still waits more than a second for a tiled technique's tiles: the fraction done
  /// (TechniqueFrame::tileProgress; e.g. consoleProgress).
  std::function<void(double)> tileProgress;
  bool overlays = true;  ///< draw the vector layers
  /// A sky behind the terrain (by the view ray's elevation) instead of the plain background.
  /// Only for a target without the mask attachment (the sky writes colour 0 alone).
  bool sky = false;
  overlay::OverlaySettings overlay;
};

struct OverlayBuildSettings {
  /// How the vector layers are drawn (overlay::techniques()); null: the default, ours.
  const overlay::TechniqueInfo* technique = nullptr;
  int textureSize = 0;        ///< techniques that rasterise textures: texels per side (0: the technique's default)
  int cellPosts = 16;         ///< pieces are split at cells of this many DEM posts (tightness)
  bool adaptiveSplit = true;  ///< keep the split only where it pays (overlay::LayerBuildOptions)
  bool uniteLines = false;    ///< one piece per cell for a line feature's shapes (overlay::FootprintOptions)
  int lineCellPosts = 2;      ///< united lines are cut at cells of this many DEM posts (a divisor of cellPosts)
  double chordToleranceMetres = 0.02;
  /// A tiled technique keeps its tiles on disk for the next run, in the scene's cache directory
  /// under vector-tiles/ (scene_loader.hpp: cacheDirectoryFor).
  bool tileCache = true;
};

struct PassStats {
  double gpuMilliseconds = 0.0;
  gfx::PipelineCounts counts;
};

struct FrameStats {
  PassStats terrain;
  terrain::TerrainDrawStats terrainDraw;
  std::size_t terrainCulled = 0;
  int finestLevel = 0;
  int coarsestLevel = 0;
  double selectMilliseconds = 0.0;               ///< CPU time of the LOD selection
  std::vector<overlay::LayerFrameStats> layers;  ///< per drawn overlay layer (fill, then outline)
  bool draped = false;                           ///< the layers came from a drape (the terrain shader drew them)
  std::size_t texturesBuilt = 0;                 ///< draping: textures (or tiles) rasterised in this frame
  double textureSeconds = 0.0;                   ///< and the time that took (part of the frame)
  std::size_t tilesMissing = 0;                  ///< paged terrain: tiles wanted but not loaded (parents drawn)
  std::size_t tilesArrived = 0;                  ///< paged terrain: tiles that became resident this frame
  overlay::TechniqueFrameStats overlayTiles;     ///< a tiled technique's tile counts (its layers moved to `layers`)
  terrain::TilePagerStats pager;
};

inline constexpr glm::vec4 kBackground{0.06F, 0.07F, 0.09F, 1.0F};

/// The overlay passes' view of a camera at the given aspect (width / height).
overlay::OverlayView overlayViewOf(const Camera& camera, double aspect);

/// What became of one scene layer's features, over all its passes (fill and outline): nothing
/// the user gave is lost without a count (and a message naming each feature).
struct LayerSummary {
  std::size_t features = 0;         ///< read from the source, plus those the reader left out
  std::size_t skippedReading = 0;   ///< left out by the reader for errors
  std::size_t skippedBuilding = 0;  ///< read, but left out of a pass's polyhedra for errors
  std::size_t nothingToDraw = 0;    ///< fine, but no pieces in any pass (outside the terrain, ...)
  std::size_t drawnFeatures = 0;    ///< with pieces in some pass
  std::size_t pieces = 0;
  std::size_t triangles = 0;
  bool built = false;  ///< the layer is visible and was built
  [[nodiscard]] std::size_t skipped() const { return skippedReading + skippedBuilding; }
};

class SceneRenderer {
 public:
  /// Uploads the scene to the current context: terrain and the visible vector layers.
  static Result<SceneRenderer> create(const LoadedScene& scene, const OverlayBuildSettings& overlays = {});

  /// Rebuilds the overlay layers (another technique, or after a change of exaggeration).
  Diagnostics buildOverlays(const LoadedScene& scene, const OverlayBuildSettings& overlays);

  /// Clears colour, depth (reversed-Z: 0) and stencil, selects the terrain chunks for this view
  /// and draws all passes, at the vertical exaggeration of the scene's bounds (LoadedScene::
  /// bounds->setExaggeration): layers whose bounds it made stale are refreshed first.
  FrameStats render(gfx::StateCache& cache, GLuint framebuffer, int width, int height, const Camera& camera,
                    const RenderSettings& settings);

  [[nodiscard]] const terrain::TerrainEngine& terrainEngine() const { return *terrain_; }
  [[nodiscard]] const terrain::LodSelection& lastSelection() const { return selection_; }
  /// The overlay layers in draw order (a polygon layer's outline follows its fill).
  [[nodiscard]] const std::vector<overlay::OverlayLayer>& overlayLayers() const { return layers_; }
  /// The stencil passes, for analysis on the frame just drawn (OverlayRenderer::markOverlap ...),
  /// whatever technique draws the layers.
  [[nodiscard]] overlay::OverlayRenderer& overlayRenderer() { return *overlay_; }
  /// What drew overlay layer i in the last frame, for analyses on it (OverlayRenderer::
  /// markOverlap, countOpenFaces, drawPieces): the layer itself, or the tiles a tiled technique
  /// drew for it (valid until the next frame or edit).
  [[nodiscard]] std::vector<const overlay::OverlayLayer*> drawnChunks(std::size_t i) const {
    if (technique_ && techniqueInfo_->construction == overlay::PieceConstruction::Tiled)
      return technique_->drawnChunks(i);
    return {&layers_.at(i)};
  }
  /// For editing features (the next frame shows the change; call invalidateOverlays).
  [[nodiscard]] overlay::OverlayLayer& overlayLayer(std::size_t i) {
    if (technique_) technique_->stopReading();  // a tiled technique's workers read the layers
    return layers_[i];
  }
  /// After an edit of overlayLayer(i) inside the frame-coordinate box [lo, hi]: what the
  /// technique derived from the layers there is made again at the next frame.
  void invalidateOverlays(const glm::dvec2& lo, const glm::dvec2& hi) {
    if (technique_) technique_->invalidate(lo, hi);
  }
  /// After an edit of feature `feature` of overlayLayer(i) (replaceFeature, setFeatureStyle,
  /// removeFeature), [lo, hi] holding it before and after (widened by its width): the technique
  /// updates what it derived from it (a tiled technique: that feature in its resident tiles).
  void featureChanged(std::size_t i, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) {
    if (technique_) technique_->featureChanged(i, feature, lo, hi);
  }
  /// Shows or hides one overlay layer from the next frame on (no rebuild; mask bits keep their
  /// places). A rebuild shows every layer again.
  void setShown(std::size_t overlayLayer, bool shown) {
    if (technique_ && shown_.at(overlayLayer) != shown) technique_->invalidate();
    shown_.at(overlayLayer) = shown;
  }
  [[nodiscard]] bool shown(std::size_t overlayLayer) const { return shown_.at(overlayLayer); }
  /// The technique that draws the layers.
  [[nodiscard]] const overlay::TechniqueInfo& technique() const { return *techniqueInfo_; }
  /// The texture over the whole terrain, if the technique drapes one (as last built: at the
  /// first frame that draws overlays, and again after a change).
  [[nodiscard]] const overlay::TextureDrape* textureDrape() const {
    return technique_ ? technique_->textureDrape() : nullptr;
  }
  /// GPU bytes the technique holds beyond the layers (textures, tiles).
  [[nodiscard]] std::size_t techniqueGpuBytes() const { return technique_ ? technique_->gpuBytes() : 0; }
  /// What the technique said while drawing so far, each message once (OverlayTechnique::drawDiagnostics).
  [[nodiscard]] Diagnostics techniqueDiagnostics() const {
    return technique_ ? technique_->drawDiagnostics() : Diagnostics{};
  }
  /// What became of scene layer `sceneLayer`'s features as last built.
  [[nodiscard]] LayerSummary layerSummary(const LoadedScene& scene, std::size_t sceneLayer) const;
  /// Which scene layer each overlay layer draws, and whether it is that layer's outline.
  [[nodiscard]] const std::vector<std::pair<std::size_t, bool>>& overlaySources() const { return sources_; }

 private:
  SceneRenderer() = default;
  std::optional<terrain::TerrainEngine> terrain_;
  /// The one owner of the vertical exaggeration (QuadtreeHeightBounds::setExaggeration): the
  /// terrain is drawn with it and the layers' bounds follow it.
  std::shared_ptr<terrain::QuadtreeHeightBounds> bounds_;
  std::optional<overlay::OverlayRenderer> overlay_;  ///< analysis passes
  std::vector<overlay::OverlayLayer> layers_;
  std::vector<std::pair<std::size_t, bool>> sources_;
  std::vector<bool> shown_;
  const overlay::TechniqueInfo* techniqueInfo_ = &overlay::defaultTechnique();
  std::unique_ptr<overlay::OverlayTechnique> technique_;
  terrain::LodSelection selection_;
  std::optional<gfx::GpuTimer> timer_;
  std::optional<gfx::PipelineStatistics> statistics_;
  /// The sky's program and an empty vertex array for its full-screen triangle, made at first use.
  std::optional<gfx::Program> sky_;
  gfx::VertexArrayHandle emptyVao_;
  void drawSky(gfx::StateCache& cache, const Camera& camera, double aspect, int width, int height);
};

}  // namespace gis::scene
