#pragma once
// How vector layers reach the pixels: one interface for every overlay technique, and one
// registry of them that the programs enumerate (overlay_render --method, the viewer's panel and
// scripts, every mode of overlay_bench). Adding a technique is one new file in
// vector_overlay/src/ and one line in technique_registry.cpp.
//
// A frame runs a technique in two steps around the terrain:
//   prepare(): before the terrain is drawn. A technique that drapes (rasterises the layers into
//     textures that the terrain shader samples) builds what it must and returns the textures;
//     the others return nothing.
//   draw(): after the terrain, into the depth-filled target. Stencil techniques mark and cover
//     here (OverlayRenderer); drapes have nothing left to do.
// Both get the target explicitly (never read back from GL) and leave it bound with its viewport.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "gfx/gl.hpp"
#include "gfx/state_cache.hpp"
#include "gfx/surface_drape.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/texture_drape.hpp"
#include "vector_overlay/tiled_layer.hpp"

namespace gis::overlay {

/// The framebuffer a technique draws into (0: the default framebuffer) and its size in pixels.
struct DrawTarget {
  GLuint framebuffer = 0;
  int width = 0;
  int height = 0;
};

/// A terrain tile drawn in this frame, for techniques that work per tile.
struct DrawnTile {
  std::uint64_t key = 0;  ///< the terrain's own key of the tile (stable while it is drawn)
  glm::dvec2 lo{0.0};     ///< frame coordinates of its extent
  glm::dvec2 hi{0.0};
};

/// What the terrain shader samples when a technique drapes (gfx/surface_drape.hpp).
using SurfaceDrape = gfx::SurfaceDrape;

/// One frame as a technique sees it.
struct TechniqueFrame {
  DrawTarget target;
  OverlayView view;
  /// The layers in draw order; layer i gets mask bit i. A null entry is hidden (its bit stays).
  std::span<const OverlayLayer* const> layers;
  std::span<const DrawnTile> tiles;  ///< the terrain tiles drawn in this frame
  /// What a drape rasterises (texture techniques): null for the layers' footprints
  /// (FootprintDrapeSource). The globe gives its own, in longitude and latitude, with no layers.
  const DrapeSource* drapeSource = nullptr;
  OverlaySettings settings;
  /// A still image: wait for everything the view wants (tiles of the right detail) instead of
  /// drawing coarser parents while it builds (a flight).
  bool waitForTiles = false;
  /// While a still waits more than a second for its tiles: called now and then with the fraction
  /// of them done, and with 1 at the end (a progress bar).
  std::function<void(double)> tileProgress;
};

/// What a technique did in one frame.
struct TechniqueFrameStats {
  std::vector<LayerFrameStats> layers;  ///< per layer, for techniques that draw layers in passes
  bool draped = false;                  ///< the terrain shader draws the layers (prepare returned a drape)
  std::size_t texturesBuilt = 0;        ///< textures (or tiles of one) rasterised in this frame
  double textureSeconds = 0.0;          ///< the time that took (part of the frame)
  // Tiled techniques:
  std::size_t tilesDrawn = 0;     ///< tiles drawn (parents standing in for building tiles included)
  std::size_t tilesWanted = 0;    ///< tiles the view wants at its detail
  std::size_t tilesMissing = 0;   ///< of those, still building (a parent drawn instead)
  std::size_t tilesCulled = 0;    ///< tiles left out for lying outside the view
  std::size_t tilesBuilt = 0;     ///< tiles that arrived (built and uploaded) in this frame
  std::size_t tilesFromDisk = 0;  ///< of those, read from the disk cache instead of built
  std::size_t tilesResident = 0;  ///< tiles on the GPU after the frame
  /// Of those, tiles that keep no footprints on the host (LayerGeometry::releaseFootprints):
  /// coarse tiles far from the eye.
  std::size_t tilesLean = 0;
  std::size_t tilesEvicted = 0;  ///< tiles dropped for the budget in this frame
  int finestTileLevel = -1;      ///< the finest level drawn (-1: none)
  /// The screen-space error the tiles were chosen for (TilingOptions::errorPixels), larger
  /// where a frame's tiles would not fit the GPU budget at it (the budget is kept, the detail
  /// coarsened: such a frame is exact only farther than this from edges); 0 without tiles.
  double tileErrorPixels = 0.0;
  std::size_t tileBytes = 0;  ///< GPU bytes of the tiles drawn
  /// The most GPU bytes the resident tiles held in this frame (while tiles arrived): at most
  /// the budget and the tiles that were being built when a detail was given up for it.
  std::size_t tilePeakBytes = 0;
  /// Since the technique was made: the most host bytes that tiles read from the disk cache held
  /// at once between their read and their upload (TilingOptions::hostBytesInFlight, or the
  /// largest tile alone), and the largest such tile (as its file says).
  std::size_t tileHostPeakBytes = 0;
  std::size_t tileLargestReadBytes = 0;
  /// `deferred` and `auto`: the layers the deferred lookup drew in this frame (with `auto` the
  /// last ones; the others were drawn by the stencil polyhedra), and the GPU bytes its indices
  /// hold after it (every layer and reach class built so far).
  std::size_t deferredLayers = 0;
  std::size_t deferredBytes = 0;
};

/// How a technique wants the layers' pieces built (OverlayLayer::build).
enum class PieceConstruction {
  Ours,   ///< split at cells where that pays, tight bounds per piece (docs/design.md §5)
  Paper,  ///< the seed paper's: one bound pair per feature, covered by bounding boxes
  /// None at load (LayerBuildOptions::deferPieces): the technique builds them per tile where it
  /// draws by pieces (`auto` and `deferred` look the others up in the features). Lines at least
  /// LayerStyle::minWidthPixels wide, each tile at the widths its view needs.
  Tiled,
};

class OverlayTechnique {
 public:
  virtual ~OverlayTechnique() = default;
  OverlayTechnique() = default;
  OverlayTechnique(const OverlayTechnique&) = delete;
  OverlayTechnique& operator=(const OverlayTechnique&) = delete;

  /// Before the terrain is drawn: builds what the frame needs; returns the drape for the terrain
  /// shader, if the technique drapes. Leaves frame.target bound with its viewport.
  std::optional<SurfaceDrape> prepare(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats);
  /// After the terrain: draws the layers into frame.target, whose depth buffer holds the terrain
  /// (reversed-Z). The stencil is 0 before and after; frame.target is left bound.
  void draw(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats);
  /// Everything the technique derived from the layers is stale (another set of layers shown, a
  /// rebuild, a change of exaggeration).
  virtual void invalidate() {}
  /// The features changed inside the frame-coordinate box [lo, hi] only (an edit).
  virtual void invalidate(const glm::dvec2& lo, const glm::dvec2& hi) {
    (void)lo;
    (void)hi;
    invalidate();
  }
  /// A technique that draws layers in chunks of its own (PieceConstruction::Tiled): the chunks
  /// that drew layer i in the last frame (for analyses on that frame), valid until the next
  /// frame or invalidation. Others: empty.
  [[nodiscard]] virtual std::vector<const OverlayLayer*> drawnChunks(std::size_t layer) const {
    (void)layer;
    return {};
  }
  /// Before the layers given to draw() are edited: stop reading them (work in flight ends).
  virtual void stopReading() {}
  /// Feature `feature` of layer `layer` (an index into TechniqueFrame::layers) was edited; [lo, hi]
  /// holds it before and after the edit (widened by its width). The default invalidates the box.
  virtual void featureChanged(std::size_t layer, std::size_t feature, const glm::dvec2& lo, const glm::dvec2& hi) {
    (void)layer;
    (void)feature;
    invalidate(lo, hi);
  }
  /// GPU bytes the technique holds beyond the layers' own buffers (textures, tiles).
  [[nodiscard]] virtual std::size_t gpuBytes() const { return 0; }
  /// What the technique said while drawing so far, each message once (a tiled technique: its
  /// tiles' problems and the cache files it found damaged). They are logged as they come; this
  /// keeps them for whoever reports the run (stats.json).
  [[nodiscard]] virtual Diagnostics drawDiagnostics() const { return {}; }
  /// A technique that drapes one texture over the whole terrain: that texture, as last built.
  [[nodiscard]] virtual const TextureDrape* textureDrape() const { return nullptr; }

 private:
  // What each technique implements; prepare() and draw() bind the target before them. A technique
  // that draws into a framebuffer of its own (a drape) does so in a gfx::RenderPass, which binds
  // the frame's target again as it ends: none can leave another framebuffer bound.
  /// Techniques that do not drape have nothing to prepare: the default returns no drape.
  virtual std::optional<SurfaceDrape> prepareFrame(gfx::StateCache& cache, const TechniqueFrame& frame,
                                                   TechniqueFrameStats& stats) {
    (void)cache;
    (void)frame;
    (void)stats;
    return std::nullopt;
  }
  virtual void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) = 0;
};

/// What every technique may be given when it is made.
struct TechniqueOptions {
  int textureSize = 0;  ///< texels per side of a texture technique's texture (or tile); 0: its default
  DrapeExtent extent;   ///< the terrain's extent (frame coordinates): what a single drape covers
  /// Techniques that build the pieces themselves (PieceConstruction::Tiled): the terrain's
  /// bounds (must outlive the technique) and how to build.
  const HeightBoundsProvider* bounds = nullptr;
  LayerBuildOptions build;
  TilingOptions tiling;
};

/// A technique's entry in the registry.
struct TechniqueInfo {
  std::string_view name;         ///< on the command line, in scripts and JSON
  std::string_view label;        ///< in the viewer's panel and the benchmark's tables
  std::string_view description;  ///< one line for --help: what it is
  std::string_view plotColour;   ///< "#rrggbb" in the benchmark's plots
  PieceConstruction construction = PieceConstruction::Ours;
  /// Techniques that rasterise into textures: texels per side by default, and the sizes the
  /// viewer offers (empty for the others).
  int defaultTextureSize = 0;
  std::span<const int> textureSizes;
  /// Makes the technique; needs a current GL 4.5 context. Fails with a message naming the
  /// technique (a shader that does not compile, a texture size out of range).
  Result<std::unique_ptr<OverlayTechnique>> (*create)(const TechniqueOptions& options) = nullptr;
  /// Draws every layer it can by the deferred per-pixel lookup, which makes no stencil volumes
  /// (`deferred`): the analyses that mark the layers' volumes cannot run on it.
  bool looksUp = false;

  [[nodiscard]] bool usesTextures() const { return defaultTextureSize > 0; }
};

/// Every technique, the default (our stencil polyhedra) first.
std::span<const TechniqueInfo> techniques();
/// The technique called `name`, or null.
const TechniqueInfo* findTechnique(std::string_view name);
/// The default technique.
const TechniqueInfo& defaultTechnique();
/// The names for messages: "stencil, paper, drape or drape-tiles".
std::string techniqueNameList();

}  // namespace gis::overlay
