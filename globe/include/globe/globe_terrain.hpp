#pragma once
// The globe's terrain (docs/globe.md): the geographic quadtree of tile.hpp sampled from a
// GeoGrid, drawn relative to the eye. Per frame, select() picks the tiles a view needs: split
// while a tile's geometric error covers more than maxScreenError pixels, culled by the frustum
// and the ellipsoid's horizon, then balanced so that neighbours (across the antimeridian too)
// differ by at most one level; a tile beside a coarser neighbour stitches that edge (leaves out
// its odd posts there), so the surface is closed: crack-free, with every shared vertex computed
// from the same double and split the same way in both tiles.
//
// The bounds contract in ellipsoidal heights (what the overlay relies on): over any box within a
// drawn tile of level L (and a strip of its neighbours along its sides), the surface drawn lies
// between lo − triangleSag(6.5 posts) and hi, where (lo, hi) = GeoGrid::bounds of the box widened
// by five posts of level L (groundBounds). Why: a point there lies in a triangle of this tile or
// of a neighbour at most one level coarser, whose corners are within five posts of level L
// (two of the neighbour's, or four along its stitched edge, and a diagonal) and are DEM samples,
// and a flat triangle at most 6.5 posts long sags below its lowest corner by triangleSag.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "gfx/state_cache.hpp"
#include "gfx/surface_drape.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_imagery.hpp"
#include "globe/globe_view.hpp"
#include "globe/tile.hpp"

namespace gis::globe {

struct TerrainOptions {
  double maxScreenError = 2.0;  ///< pixels
  /// Posts at most this many pixels apart (0: no limit): the terrain's colours (heights, and
  /// imagery later) and the overlay's pieces follow the view, not only its geometric error.
  double maxPostPixels = 8.0;
  int maxLevel = 20;              ///< finest level drawn
  std::size_t cacheTiles = 4096;  ///< GPU meshes kept (least recently drawn go first)
  float occluderHeight = 0.0F;    ///< the horizon test's ellipsoid (≤ the lowest ground)
  /// Imagery textures (setImagery): built on the GL thread while drawing, at most this many tiles
  /// and (after the first) this many milliseconds a frame; the rest keep the height tint until a
  /// later frame builds them (TerrainStats::imageryPending).
  std::size_t imageryTilesPerFrame = 16;
  double imageryMillisecondsPerFrame = 50.0;
  /// GPU memory for the textures: beyond it the least recently drawn tiles (mesh and texture)
  /// go first, never those of the frame being drawn.
  double imageryGpuBudgetMb = 256.0;
};

struct DrawnTile {
  TileKey key;
  /// Edges whose neighbour is one level coarser (stitched): bit 0 west, 1 east, 2 south, 3 north.
  std::uint8_t stitch = 0;
};

struct TerrainStats {
  std::size_t tiles = 0;           ///< drawn in the last frame
  std::size_t triangles = 0;       ///< drawn in the last frame
  std::size_t uploads = 0;         ///< meshes built and uploaded in the last frame
  std::size_t resident = 0;        ///< meshes on the GPU
  std::size_t meshBytes = 0;       ///< and their vertex buffers' bytes
  std::size_t imageryTiles = 0;    ///< drawn with their imagery texture in the last frame
  std::size_t imageryBuilt = 0;    ///< imagery textures built in the last frame
  std::size_t imageryPending = 0;  ///< drawn tiles the imagery reaches whose texture is not built yet
  std::size_t imageryBytes = 0;    ///< imagery textures on the GPU
};

/// The bounds of the contract above over `box` for tiles of `level` (heights in metres above the
/// ellipsoid): (lo − sag, hi).
std::pair<double, double> groundBounds(const GeoGrid& heights, const LonLatRect& box, int level);
/// groundBounds of a tile's own box.
std::pair<double, double> terrainBounds(const GeoGrid& heights, const TileKey& key);

/// A box in ECEF metres holding every point of `box` (longitude and latitude, latitudes clamped
/// to ±90) between heights lo and hi above the ellipsoid: its points sampled 9 × 9, grown by
/// how far the surface between samples bulges out of them.
std::pair<glm::dvec3, glm::dvec3> ecefBoxOf(const LonLatRect& box, double lo, double hi);

/// A tile's mesh as drawn, without GL (for tests and CPU references): the ECEF positions of its
/// kTilePosts² posts, row j (from the south) by column i (from the west): index j · kTilePosts + i.
std::vector<glm::dvec3> tilePostPositions(const GeoGrid& heights, const TileKey& key);
/// The triangles of stitch variant `stitch` (DrawnTile::stitch) as index triples into those posts,
/// counter-clockwise seen from outside the ellipsoid; the same for every tile.
std::vector<std::uint16_t> tileTriangles(std::uint8_t stitch);

class GlobeTerrain {
 public:
  explicit GlobeTerrain(std::shared_ptr<const GeoGrid> heights, TerrainOptions options = {});
  ~GlobeTerrain();
  GlobeTerrain(const GlobeTerrain&) = delete;
  GlobeTerrain& operator=(const GlobeTerrain&) = delete;

  [[nodiscard]] const GeoGrid& heights() const { return *heights_; }
  [[nodiscard]] const TerrainOptions& options() const { return options_; }

  /// Drapes imagery over the tiles it reaches (none: the height tint everywhere). Textures built
  /// for earlier imagery are dropped.
  void setImagery(std::shared_ptr<const GlobeImagery> imagery);
  [[nodiscard]] const std::shared_ptr<const GlobeImagery>& imagery() const { return imagery_; }

  /// The tiles the view needs (no GL): they cover, without overlap, every part of the globe the
  /// view may see.
  [[nodiscard]] std::vector<DrawnTile> select(const GlobeView& view) const;

  /// Draws the tiles into the bound target (depth and colour, mask writes must be off unless
  /// draped), building and uploading the meshes it lacks. With a texture drape (the projected
  /// frame's, gfx::SurfaceDrape, whose plane is longitude and latitude here): its layers
  /// blended over each tile it covers and their bits written to the mask. Needs a current GL 4.5
  /// context.
  void draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
            const gfx::SurfaceDrape* drape = nullptr);

  [[nodiscard]] const TerrainStats& stats() const { return stats_; }

 private:
  struct Gpu;
  std::shared_ptr<const GeoGrid> heights_;
  TerrainOptions options_;
  std::shared_ptr<const GlobeImagery> imagery_;
  struct Lod;
  std::unique_ptr<Gpu> gpu_;
  std::unique_ptr<Lod> lod_;  ///< per-tile errors and bounds, cached across frames (select is const)
  TerrainStats stats_;
};

}  // namespace gis::globe
