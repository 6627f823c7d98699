#pragma once
// View-dependent level of detail: the chunks whose projected geometric error is within a pixel
// tolerance, culled by the view frustum, balanced so neighbours differ by at most one level
// (the finer side then stitches its edge to the coarser one: no cracks, no skirts).
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "terrain/quadtree.hpp"

namespace gis::terrain {

struct LodView {
  glm::dvec3 eye{0.0};        ///< frame coordinates
  glm::dmat4 viewProj{1.0};   ///< frame → clip (reversed-Z, GL_ZERO_TO_ONE)
  int viewportHeight = 1000;  ///< pixels
  double fovYRadians = 0.785;
};

struct LodOptions {
  double pixelTolerance = 1.5;  ///< largest allowed projected geometric error
  double exaggeration = 1.0;
  /// Which nodes can be drawn now; empty = TerrainQuadtree::resident. A node is refined only if
  /// all four children are resident, so a loading tile's parent is drawn meanwhile.
  std::function<bool(const NodeId&)> resident;
  /// For tests: never refine beyond this level (forced coarse LOD); -1 = no limit.
  int coarsestAllowedLevel = -1;
  /// For tests: refine to at least this level where resident (forced fine LOD); -1 = none.
  int finestForcedLevel = -1;
  /// For tests and bounds checks: also list chunks outside the frustum (with stitch masks).
  bool includeCulled = false;
};

struct SelectedChunk {
  NodeId id;
  std::uint8_t stitchMask = 0;  ///< ChunkEdge bits
  double screenError = 0.0;     ///< projected geometric error, pixels
};

struct LodSelection {
  std::vector<SelectedChunk> chunks;  ///< visible chunks with data: what is drawn
  std::vector<NodeId> cut;            ///< every leaf of the refined tree (also culled and empty ones)
  /// Nodes the view wants refined further but whose tiles are not resident (coarsest first):
  /// what to page in next.
  std::vector<NodeId> missing;
  std::size_t culled = 0;
  std::size_t balanceSplits = 0;
  std::size_t balanceMerges = 0;
};

LodSelection selectLod(const TerrainQuadtree& tree, const LodView& view, const LodOptions& options = {});

/// The chunk of a selection that draws the point at continuous global post coordinates, or
/// nullptr if none (culled, outside, or nodata).
const SelectedChunk* chunkAt(const TerrainQuadtree& tree, const LodSelection& selection, double col, double row);

/// Height of the surface as drawn by the selection at a frame point (exaggeration applied);
/// NaN where nothing is drawn.
double drawnHeightAt(const TerrainQuadtree& tree, const LodSelection& selection, double exaggeration,
                     const glm::dvec2& frameXy);

}  // namespace gis::terrain
