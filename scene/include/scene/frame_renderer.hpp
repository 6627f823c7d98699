#pragma once
// Draws a Scene in its frame, behind one interface (docs/frames.md, "One scene, one set of
// programs"): a projected scene through SceneRenderer, a globe scene through globe::GlobeRenderer.
// What a program does with a frame — draw a still, read it back, mark two layers' overlap or the
// open volumes, select features with a lasso and export them, report what was drawn — it does
// once, through this; only what differs between the frames is behind it.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/diagnostics.hpp"
#include "gfx/render_target.hpp"
#include "gfx/state_cache.hpp"
#include "scene/frame_readback.hpp"
#include "scene/frame_scene.hpp"
#include "scene/scene_renderer.hpp"
#include "scene/selected_features.hpp"
#include "vector_overlay/logical_selection.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::scene {

struct StillSettings {
  /// How the vector layers are drawn (overlay::techniques()); every technique draws in both frames.
  const overlay::TechniqueInfo* technique = &overlay::defaultTechnique();
  int textureSize = 0;                       ///< texture techniques: texels per side (0: the technique's default)
  double lodTolerancePixels = 1.5;           ///< the projected terrain's largest error in pixels
  std::function<void(double)> tileProgress;  ///< while a still waits for a tiled technique's tiles
  /// How a projected frame splits its pieces (scene::OverlayBuildSettings; the ablation's
  /// switches). The globe's tiles split at their own cells.
  int cellPosts = 16;
  bool adaptiveSplit = true;
  bool uniteLines = false;
};

/// How one frame of a flight is drawn (FrameRenderer::drawFrame). Every tile the view needs is
/// waited for, so that methods compared on a frame draw the same terrain.
struct FrameOptions {
  bool overlays = true;  ///< off: the terrain alone
  /// Wait for every tile the view needs (the same terrain for every method compared); off, a
  /// flight's frame draws what is there (a paged projected terrain draws the parents of tiles
  /// still loading).
  bool waitForTiles = true;
  bool measure = false;  ///< GPU timer and pipeline statistics queries around the passes (they wait)
  /// The stencil passes' switches (docs/design.md §9, the ablation's); a projected frame's.
  overlay::OverlaySettings overlay;
  // How the ground looks (the viewer's switches); a frame ignores what it has no use for.
  bool imagery = true;  ///< off: the terrain shaded (and tinted by height) instead of the scene's imagery
  /// Where no imagery is shown, the terrain tinted by these true heights (low, high) on the
  /// hypsometric ramp; none: grey hillshade (a projected frame's; the globe tints by height).
  std::optional<std::pair<double, double>> elevationRamp;
  bool sky = false;                 ///< a sky behind the terrain (a projected frame's; the globe draws space)
  bool wireframe = false;           ///< the projected terrain's triangles as lines
  double lodTolerancePixels = 0.0;  ///< the projected terrain's largest error in pixels; 0: the renderer's
};

/// What one frame drew and cost; GPU times and counts with FrameOptions::measure.
struct FrameFigures {
  /// The terrain as drawn: its tiles (a projected frame's chunks), triangles, tiles built in this
  /// frame, the level of detail's selection time, and the fragments (measured frames only).
  struct Terrain {
    std::size_t tiles = 0, triangles = 0, built = 0;
    double selectMs = 0.0;
    std::uint64_t fragments = 0;
    int finestLevel = -1;  ///< a projected frame's
    /// A paged projected terrain: tiles wanted but not loaded (parents drawn), tiles arrived in
    /// this frame, and the bytes its tile cache holds.
    std::size_t tilesMissing = 0, tilesArrived = 0, tileBytes = 0;
  } terrain;
  double terrainGpuMs = 0.0;
  /// The layers' passes: marking the stencil and covering the marked pixels (each layer's apart,
  /// in both frames).
  double markGpuMs = 0.0, coverGpuMs = 0.0;
  std::uint64_t markFragments = 0, coverFragments = 0;
  std::uint64_t markTriangles = 0, coverTriangles = 0;
  std::size_t zFailPieces = 0, drawnPieces = 0;
  /// Per drawn layer (FrameRenderer::drawnLayerCount; on the globe the shown ones, at most 32):
  /// the fragments of its mark and its cover.
  struct LayerPasses {
    std::uint64_t markFragments = 0, coverFragments = 0;
    double gpuMs = 0.0;  ///< its passes' GPU time
    std::size_t pieces = 0, zFailPieces = 0;
  };
  std::vector<LayerPasses> layers;
  /// Adds one drawn layer's measured passes (its entry in `layers`, and to the sums above).
  void addLayerPasses(const overlay::LayerFrameStats& passes);
  double overlayGpuMs = 0.0;   ///< the layers' passes (measured frames only)
  std::size_t tilesBuilt = 0;  ///< a tiled technique's tiles built in this frame
  /// Work still arriving: the layers' tiles still building (ancestors drawn meanwhile), the
  /// terrain's tiles still loading or its imagery still to come. The frame is not final.
  std::size_t tilesMissing = 0, terrainPending = 0;
  std::size_t terrainResidentTiles = 0;  ///< a paged terrain's tiles in memory
  /// The deferred lookup: layers it drew, layers whose indices are still building (drawn by
  /// pieces meanwhile), and its indices' bytes.
  std::size_t deferredLayers = 0, deferredPending = 0, deferredBytes = 0;
  bool draped = false;            ///< the terrain drew the layers from textures
  std::size_t drapeBytes = 0;     ///< and the textures' GPU bytes
  std::size_t texturesBuilt = 0;  ///< draping: textures (or tiles of them) rasterised in this frame
  double textureSeconds = 0.0;    ///< and the time that took
};

/// What was built for the layers before any frame (a projected scene's layers, built at load).
struct LayersBuilt {
  std::size_t gpuBytes = 0;
  std::size_t triangles = 0;
  double buildSeconds = 0.0;
};

/// One drawn layer as built (FrameRenderer::drawnLayerBuilt): its features, and what was built
/// for it before any frame (zero where frames build its pieces).
struct DrawnLayerBuilt {
  std::string name;
  std::size_t features = 0, skippedFeatures = 0;
  std::size_t pieces = 0, triangles = 0, gpuBytes = 0;
  double buildSeconds = 0.0;
};

/// Which layer of the scene file a drawn layer draws (LayerDescription::fileIndex), and whether it
/// is that layer's outline rather than its fill.
struct DrawnLayerSource {
  std::size_t fileIndex = 0;
  bool outline = false;
};

/// The CPU reference's answer for some drawn layers over a depth buffer: bit k of `expected` for
/// the k-th layer asked for, and 1 in `edges` where the answer may change within the pixel.
struct ReferenceAnswer {
  std::vector<std::uint32_t> expected;
  std::vector<std::uint8_t> edges;
};

class FrameRenderer {
 public:
  /// Uploads `scene` to the current GL context, the layers built for `settings.technique`. The
  /// scene must outlive the renderer.
  static Result<std::unique_ptr<FrameRenderer>> create(Scene& scene, const StillSettings& settings);
  virtual ~FrameRenderer() = default;
  FrameRenderer(const FrameRenderer&) = delete;
  FrameRenderer& operator=(const FrameRenderer&) = delete;

  /// Clears `target` and draws a still from `camera`: the terrain and the layers, timed, after
  /// waiting for every tile (terrain, imagery, a tiled technique's) the view needs.
  virtual void drawStill(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera) = 0;

  /// One frame of a flight into `target` from `camera` (cleared first).
  virtual FrameFigures drawFrame(gfx::StateCache& cache, const gfx::RenderTarget& target, const FrameCamera& camera,
                                 const FrameOptions& options) = 0;
  /// What the layers' build made before the first frame (zero where they are built by frames).
  [[nodiscard]] virtual LayersBuilt layersBuilt() const = 0;
  /// The frame's own description of its terrain for a benchmark (the DEM's size, GPU bytes,
  /// paging).
  [[nodiscard]] virtual nlohmann::json terrainJson() const = 0;
  /// GPU bytes the technique holds beyond what layersBuilt counts (tiles, textures, indices).
  [[nodiscard]] virtual std::size_t techniqueGpuBytes() const = 0;
  /// The technique drapes one texture over the whole terrain (built at its first frame).
  [[nodiscard]] virtual bool drapesOneTexture() const = 0;
  /// Which CPU reference judges this renderer's frames: renderers of one scene with the same kind
  /// build their layers alike (widths in pixels or in metres), so one reference serves them all.
  [[nodiscard]] virtual int referenceKind() const = 0;
  /// A one-feature edit, as a user's: the first point of the first layer's first feature moved
  /// 10 m east, its pieces (and what the technique derived from it) made again by the next
  /// frame. Milliseconds it took; nothing when that feature has no point.
  virtual std::optional<double> editFirstFeature() = 0;

  /// The drawn layers: a bit of the mask each, a polygon layer's fill and outline apart.
  [[nodiscard]] virtual std::size_t drawnLayerCount() const = 0;
  [[nodiscard]] virtual std::string drawnLayerName(std::size_t drawn) const = 0;
  [[nodiscard]] virtual DrawnLayerBuilt drawnLayerBuilt(std::size_t drawn) const = 0;
  /// The drawn layer of the fill (not the outline) of the scene file's layer named `name`.
  [[nodiscard]] virtual std::optional<std::size_t> fillLayerNamed(std::string_view name) const = 0;
  /// The stencil passes for the analyses over the last still (null if the technique has none).
  [[nodiscard]] virtual overlay::OverlayRenderer* analysisPasses() = 0;
  /// What drew drawn layer `drawn` in the last still (the layer, or the tiles drawn for it).
  [[nodiscard]] virtual std::vector<const overlay::OverlayLayer*> chunksOf(std::size_t drawn,
                                                                           const FrameCamera& camera) = 0;
  /// The CPU reference of the source geometry for these drawn layers over `image`.
  [[nodiscard]] virtual ReferenceAnswer referenceOf(std::span<const std::size_t> drawn,
                                                    const overlay::DepthImage& image) const = 0;

  /// Reads the still back: colour, depth, and the mask with a bit per layer of the scene file.
  [[nodiscard]] virtual FrameImages readFrame(gfx::StateCache& cache, const gfx::RenderTarget& target) const = 0;

  /// The features the steps select (the lasso's logical twin), at `sampleSpacing` metres (by
  /// default half a pixel's footprint at the camera's target).
  [[nodiscard]] virtual SelectedFeatures selectFeatures(std::span<const overlay::SelectionStep> steps,
                                                        const FrameCamera& camera, int width, int height,
                                                        std::optional<double> sampleSpacing) const = 0;
  /// Their GeoJSON export (selection_export.hpp): one RFC 7946 file at `combined`, and one per
  /// layer in `perLayerDir` in the source's CRS.
  [[nodiscard]] virtual Diagnostics exportSelection(const SelectedFeatures& selected,
                                                    const std::filesystem::path& combined,
                                                    const std::filesystem::path& perLayerDir) const = 0;

  // What an interactive program changes between frames (the viewer's panel).
  /// The ground has imagery to show (FrameOptions::imagery).
  [[nodiscard]] virtual bool hasImagery() const = 0;
  /// Draws with `technique` from the next frame on, a texture technique at `textureSize` texels a
  /// side (0: its default); what the layers' build said into `diagnostics`. False: the frame
  /// cannot draw it (said as an error; nothing changed).
  virtual bool setTechnique(const overlay::TechniqueInfo& technique, int textureSize, Diagnostics& diagnostics) = 0;
  /// The layers built again with these descriptions (their styles edited; matched by fileIndex).
  /// Layers hidden stay hidden.
  virtual Diagnostics restyle(std::span<const LayerDescription> layers) = 0;
  /// The vertical exaggeration: the frame's heights own it (a projected scene's bounds, the globe's
  /// grid of heights). The layers follow by the next frame.
  virtual void setExaggeration(double exaggeration) = 0;
  [[nodiscard]] virtual DrawnLayerSource drawnLayerSource(std::size_t drawn) const = 0;
  /// Whether frames draw a layer (stills draw every layer). On the globe the mask bits of the
  /// layers after a hidden one move down by one (its renderer is given the shown layers only); no
  /// program reads the mask of a frame with hidden layers.
  [[nodiscard]] virtual bool drawnLayerShown(std::size_t drawn) const = 0;
  virtual void setDrawnLayerShown(std::size_t drawn, bool shown) = 0;
  /// Feature `feature` of those drawn layer `drawn` was built from, in the scene's frame (the
  /// source layer's as read), alone: it may be read from disk.
  [[nodiscard]] virtual std::shared_ptr<const geo::Feature> drawnLayerFeature(std::size_t drawn,
                                                                              std::size_t feature) const = 0;
  /// Every feature of drawn layer `drawn` at once (read into memory where they were on disk).
  [[nodiscard]] virtual const std::vector<geo::Feature>* drawnLayerFeatures(std::size_t drawn) const = 0;
  /// The features of drawn layer `drawn` that cover `world` (a point the frame drew: frame
  /// coordinates, or ECEF on the globe) as the CPU reference has them, lines at their widths seen
  /// from `camera` in a target of this size (identify).
  [[nodiscard]] virtual std::vector<std::size_t> featuresAt(std::size_t drawn, const glm::dvec3& world,
                                                            const FrameCamera& camera, int width, int height) const = 0;
  /// What became of the scene file's layer `fileIndex`'s features: read, skipped, drawn.
  [[nodiscard]] virtual LayerSummary layerSummary(std::size_t fileIndex) const = 0;
  /// The one texture the layers are draped with (`drape`), or null.
  [[nodiscard]] virtual const overlay::TextureDrape* textureDrape() const = 0;

  /// What the technique said while drawing so far, each message once.
  [[nodiscard]] virtual Diagnostics techniqueDiagnostics() const = 0;
  /// The frame's own blocks of stats.json for the last still read back as `images`: the ground
  /// ("terrain", and the globe's "dem"), the layers, the overlay's passes, its tiles or drape.
  virtual void reportStill(const FrameImages& images, nlohmann::json& stats) const = 0;

 protected:
  FrameRenderer() = default;
};

}  // namespace gis::scene
