#pragma once
// The terrain quadtree (chunked LOD). Every node covers a square of N × N cells (N + 1 posts a
// side, N a power of two) of its level's grid; level 0 is the full resolution, level l samples
// every 2^l-th post, the root covers the whole DEM (padded to a power of two with nodata).
// Each node knows the range of full-resolution heights below it and its geometric error: an
// upper bound of the vertical distance between its surface and the full-resolution surface.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include <glm/vec2.hpp>

#include "terrain/terrain_grid.hpp"

namespace gis::terrain {

struct NodeId {
  int level = 0;  ///< 0 = finest
  int x = 0;      ///< column of the node in its level
  int y = 0;      ///< row of the node in its level (row 0 at the grid's first row)
  bool operator==(const NodeId&) const = default;
  [[nodiscard]] NodeId parent() const { return {level + 1, x >> 1, y >> 1}; }
  [[nodiscard]] std::array<NodeId, 4> children() const {
    return {NodeId{level - 1, 2 * x, 2 * y}, NodeId{level - 1, 2 * x + 1, 2 * y}, NodeId{level - 1, 2 * x, 2 * y + 1},
            NodeId{level - 1, 2 * x + 1, 2 * y + 1}};
  }
  [[nodiscard]] std::uint64_t key() const {
    return (static_cast<std::uint64_t>(level) << 58) | (static_cast<std::uint64_t>(x) << 29) |
           static_cast<std::uint64_t>(y);
  }
  /// True if `other` is this node or lies inside it.
  [[nodiscard]] bool contains(const NodeId& other) const {
    return other.level <= level && (other.x >> (level - other.level)) == x && (other.y >> (level - other.level)) == y;
  }
};

struct NodeInfo {
  float minHeight = 0.0F;  ///< of the valid full-resolution posts in the node (unexaggerated)
  float maxHeight = 0.0F;
  float geometricError = 0.0F;
  bool hasData = false;
};

/// Edges of a chunk, as bits of a stitch mask: a set bit means the neighbour across that edge
/// is one level coarser. The chunk then drops its odd vertices on that edge: each is replaced
/// by its even predecessor along the edge, so the cells along the edge become fans whose outer
/// edges are exactly the coarser neighbour's edges (no T-junctions, no skirts).
enum ChunkEdge : std::uint8_t { kEdgeWest = 1, kEdgeEast = 2, kEdgeNorth = 4, kEdgeSouth = 8 };
// (north = the node's first row of posts, south = its last; for a north-up DEM these are the
// geographic directions.)

/// The (N + 1)² posts of a chunk at its level, row-major, NaN at nodata.
using TileData = std::shared_ptr<const std::vector<float>>;

class TilePager;

class TerrainQuadtree {
 public:
  static constexpr int kDefaultChunkCells = 64;

  /// A DEM held in memory.
  explicit TerrainQuadtree(std::shared_ptr<const TerrainGrid> grid, int chunkCells = kDefaultChunkCells);
  /// A DEM paged from a tile pyramid on disk: node ranges and errors come from the pyramid,
  /// posts from its tiles.
  explicit TerrainQuadtree(std::shared_ptr<TilePager> pager);

  /// The DEM's grid; in a paged tree without heights (use post()).
  [[nodiscard]] const TerrainGrid& grid() const { return *grid_; }
  [[nodiscard]] std::shared_ptr<const TerrainGrid> gridPtr() const { return grid_; }
  [[nodiscard]] bool paged() const { return pager_ != nullptr; }
  /// The pager of a paged tree, else null.
  [[nodiscard]] TilePager* pager() const { return pager_.get(); }
  /// Levels from this one up are always in memory (0 for an in-memory tree).
  [[nodiscard]] int pinnedLevel() const { return pinnedLevel_; }
  /// True if the node's posts are in memory (always for an in-memory tree).
  [[nodiscard]] bool resident(const NodeId& n) const;
  /// The node's chunk posts if resident, else null (a paged tree then needs the tile loaded).
  [[nodiscard]] TileData chunkPosts(const NodeId& n) const;
  [[nodiscard]] int chunkCells() const { return chunkCells_; }
  [[nodiscard]] int rootLevel() const { return rootLevel_; }
  [[nodiscard]] NodeId root() const { return {rootLevel_, 0, 0}; }
  [[nodiscard]] int nodesPerSide(int level) const { return 1 << (rootLevel_ - level); }
  [[nodiscard]] bool valid(const NodeId& n) const {
    return n.level >= 0 && n.level <= rootLevel_ && n.x >= 0 && n.y >= 0 && n.x < nodesPerSide(n.level) &&
           n.y < nodesPerSide(n.level);
  }
  [[nodiscard]] const NodeInfo& info(const NodeId& n) const;
  [[nodiscard]] std::size_t nodeCount() const;

  /// Full-resolution post height; NaN outside the DEM or at nodata. In a paged tree this reads
  /// the level-0 tile if needed (blocking): meant for queries, not for loops over the DEM.
  [[nodiscard]] float post(int col, int row) const {
    if (col < 0 || row < 0 || col >= grid_->width || row >= grid_->height) return kNoData;
    return pager_ ? pagedPost(0, col, row) : grid_->at(col, row);
  }
  /// Post (i, j) of level `level`'s grid (= post(i·2^level, j·2^level)); from memory without
  /// blocking at levels ≥ pinnedLevel().
  [[nodiscard]] float levelPost(int level, int i, int j) const {
    const int col = i << level, row = j << level;
    if (col < 0 || row < 0 || col >= grid_->width || row >= grid_->height) return kNoData;
    return pager_ ? pagedPost(level, i, j) : grid_->at(col, row);
  }
  /// Global post index of vertex (i, j) ∈ [0, N]² of node n.
  [[nodiscard]] glm::ivec2 vertexPost(const NodeId& n, int i, int j) const {
    return {(n.x * chunkCells_ + i) << n.level, (n.y * chunkCells_ + j) << n.level};
  }
  /// The vertex that vertex (i, j) of a chunk becomes under a stitch mask: odd vertices on a
  /// stitched edge collapse onto their even predecessor along that edge.
  [[nodiscard]] glm::ivec2 stitchedVertex(std::uint8_t stitchMask, int i, int j) const;

  /// The surface of level `level` (no stitching) at continuous global post coordinates; NaN
  /// where the containing cell has a nodata corner (such cells are not drawn).
  [[nodiscard]] double levelSurface(int level, double col, double row) const;
  /// The surface as drawn by chunk n with stitch mask at continuous global post coordinates
  /// inside the node.
  [[nodiscard]] double chunkSurface(const NodeId& n, std::uint8_t stitchMask, double col, double row) const;

  /// Horizontal extent of a node in frame coordinates (min corner, max corner).
  [[nodiscard]] std::array<glm::dvec2, 2> frameExtent(const NodeId& n) const;
  /// The leaf-level node of `level` containing the continuous global post coordinates.
  [[nodiscard]] NodeId nodeAt(int level, double col, double row) const;

  static constexpr float kNoData = std::numeric_limits<float>::quiet_NaN();

 private:
  [[nodiscard]] float pagedPost(int level, int i, int j) const;
  void computeLevel0();
  void computeLevel(int level);
  [[nodiscard]] std::size_t index(const NodeId& n) const {
    return levelOffset_[static_cast<std::size_t>(n.level)] +
           static_cast<std::size_t>(n.y) * static_cast<std::size_t>(nodesPerSide(n.level)) +
           static_cast<std::size_t>(n.x);
  }

  std::shared_ptr<const TerrainGrid> grid_;
  std::shared_ptr<TilePager> pager_;
  int pinnedLevel_ = 0;
  int chunkCells_;
  int rootLevel_ = 0;
  std::vector<std::size_t> levelOffset_;
  std::vector<NodeInfo> nodes_;
};

/// Interpolation inside one cell of a regular grid with the project's diagonal (from corner a
/// (col, row) to corner e (col+1, row+1)): triangles a-d-e and a-e-b. fx, fy ∈ [0, 1].
inline double interpolateCell(double a, double b, double d, double e, double fx, double fy) {
  return fy >= fx ? a + fy * (d - a) + fx * (e - d) : a + fx * (b - a) + fy * (e - b);
}

}  // namespace gis::terrain
