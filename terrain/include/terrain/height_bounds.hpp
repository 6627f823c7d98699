#pragma once
// Height bounds under the bounds contract (docs/design.md §5): for a footprint, [lo, hi] contains the
// surface as drawn at *any* level of detail that can be on screen there — any level of the
// quadtree, stitched or not, including a coarse parent drawn while a tile loads — with
// vertical exaggeration applied.
//
// Why it holds: a level-l chunk draws, over a point p, a convex combination of the corners of the
// level-l cell containing p, except along a stitched edge, where the odd edge vertices are
// averages of the corners of the level-(l+1) cell containing p. So the union, over levels, of the
// corner heights of the level-l cells meeting the footprint bounds every surface that can be
// drawn there. The bound is static (no per-frame record) and gets looser where coarse levels'
// cells reach far outside a small footprint; docs/terrain.md gives measured tightness.
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/height_bounds.hpp"
#include "terrain/quadtree.hpp"

namespace gis::terrain {

/// Min/max over rectangles of a grid, exact, in O(perimeter) via a 2×2 min/max pyramid. The
/// base is either a DEM's posts (NaN = nodata, ignored) or given per-cell ranges (lo > hi =
/// empty), e.g. a tile pyramid's pinned-level cells.
class MinMaxPyramid {
 public:
  explicit MinMaxPyramid(const TerrainGrid& grid);
  /// Ranges of a width × height grid of cells; the spans must outlive the pyramid.
  MinMaxPyramid(int width, int height, std::span<const float> lo, std::span<const float> hi);
  /// Min and max over [c0, c1] × [r0, r1] (inclusive, clamped to the grid); lo > hi when
  /// there is no data.
  void query(int c0, int r0, int c1, int r1, float& lo, float& hi) const;
  [[nodiscard]] std::size_t bytes() const;

 private:
  struct Level {
    int width = 0, height = 0;
    std::vector<float> lo, hi;
  };
  void build();
  void baseRange(int c, int r, float& lo, float& hi) const;
  void queryLevel(std::size_t k, int c0, int r0, int c1, int r1, float& lo, float& hi) const;
  const TerrainGrid* grid_ = nullptr;
  int width_ = 0, height_ = 0;
  std::span<const float> baseLo_, baseHi_;
  std::vector<Level> levels_;  ///< levels_[k] holds blocks of 2^(k+1) base cells a side
};

class QuadtreeHeightBounds final : public HeightBoundsProvider {
 public:
  explicit QuadtreeHeightBounds(std::shared_ptr<const TerrainQuadtree> tree, double exaggeration = 1.0);

  /// The one owner of the vertical exaggeration: the terrain is drawn with it, and overlay
  /// layers built on these bounds see the new revision() and read their bounds again.
  void setExaggeration(double exaggeration) {
    if (exaggeration == exaggeration_) return;
    exaggeration_ = exaggeration;
    ++revision_;
  }
  [[nodiscard]] std::uint64_t revision() const override { return revision_; }
  [[nodiscard]] double exaggeration() const { return exaggeration_; }

  [[nodiscard]] HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override;
  /// With a slack of a post or more (a tree in memory): the levels whose cells (and parents) lie
  /// within the slack of the footprint are bounded at once by the posts within the slack (at
  /// least 3 posts: level 0's cells and their stitched parents),
  /// read from the min/max pyramid in bands (O(bands · log) instead of a clip per cell); the
  /// coarser levels as boundsOver does.
  [[nodiscard]] HeightBounds boundsOverWithin(std::span<const glm::dvec2> footprint, double slackMetres) const override;
  [[nodiscard]] HeightBounds globalBounds() const override;
  /// Inside the DEM's posts and no nodata anywhere in the DEM (a conservative answer).
  [[nodiscard]] bool coversFootprint(std::span<const glm::dvec2> footprint) const override;

  /// Bounds for drawing only levels ≥ `finestLevel` (for measuring what finer LODs would gain).
  [[nodiscard]] HeightBounds boundsOverLevels(std::span<const glm::dvec2> footprint, int finestLevel,
                                              int coarsestLevel) const;

  /// Height of the full-resolution DEM surface (exaggerated); NaN at nodata.
  [[nodiscard]] double fullResolutionHeightAt(const glm::dvec2& frameXy) const;

 private:
  /// Range of the level's surface over the convex polygon `hull` (grid coordinates), reading
  /// the cells [c0, c1] × [r0, r1] of the level; lo > hi when nothing is drawn there.
  void exactLevelRange(const std::vector<glm::dvec2>& hull, int level, int c0, int r0, int c1, int r1, float& lo,
                       float& hi) const;

  std::shared_ptr<const TerrainQuadtree> tree_;
  std::optional<MinMaxPyramid> pyramid_;
  bool hasNodata_ = true;
  double exaggeration_;
  std::uint64_t revision_ = 0;
};

}  // namespace gis::terrain
