#pragma once
// One vector layer on the GPU: a LayerGeometry (layer_geometry.hpp: the polyhedra and their
// vertex and index arrays, built without GL) and the buffers holding it. Edits go to the
// geometry and only what they changed is uploaded again.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"
#include "vector_overlay/height_bounds.hpp"
#include "vector_overlay/layer_geometry.hpp"

namespace gis::overlay {

class OverlayLayer {
 public:
  /// Builds every feature's polyhedra (LayerGeometry::build) and uploads them (needs a current
  /// GL context). Broken features are reported in `diagnostics` and left out; the rest is drawn.
  static Result<OverlayLayer> build(std::string name, LayerKind kind, const LayerStyle& style, SharedFeatures features,
                                    const HeightBoundsProvider& bounds, const LayerBuildOptions& options = {});
  /// Uploads a geometry built elsewhere (e.g. on a worker thread). Needs a current GL context.
  static OverlayLayer upload(LayerGeometry geometry);

  [[nodiscard]] const LayerGeometry& geometry() const { return geometry_; }
  [[nodiscard]] const std::string& name() const { return geometry_.name(); }
  [[nodiscard]] LayerKind kind() const { return geometry_.kind(); }
  [[nodiscard]] const LayerStyle& style() const { return geometry_.style(); }
  [[nodiscard]] const std::vector<geo::Feature>& features() const { return geometry_.features(); }
  [[nodiscard]] const SharedFeatures& sharedFeatures() const { return geometry_.sharedFeatures(); }
  [[nodiscard]] const std::vector<FeatureStyle>& featureStyles() const { return geometry_.featureStyles(); }
  /// The geometry's counts and build time, and the GPU bytes of its buffers.
  [[nodiscard]] LayerStats stats() const {
    LayerStats s = geometry_.stats();
    s.gpuBytes = gpuBytes_;
    return s;
  }
  /// Per feature, what became of it (kept up to date by edits, as are the stats' counts).
  [[nodiscard]] const std::vector<FeatureOutcome>& featureOutcomes() const { return geometry_.featureOutcomes(); }
  [[nodiscard]] bool paperVariant() const { return geometry_.paperVariant(); }

  /// Editing: only the feature's pieces are rebuilt and re-uploaded; the next frame shows it.
  Diagnostics replaceFeature(std::size_t index, geo::Feature feature);
  Diagnostics setFeatureStyle(std::size_t index, const FeatureStyle& style);
  void removeFeature(std::size_t index);  ///< hides it for good (indices stay stable)
  /// LayerGeometry::setFeature (a tile's feature, its style given), uploaded.
  Diagnostics setFeature(std::size_t index, geo::Feature feature, FeatureStyle style);
  /// Frees the CPU copy of the vertex and index arrays (LayerGeometry::releaseArrays).
  void releaseCpuArrays() { geometry_.releaseArrays(); }
  /// LayerGeometry::releaseFootprints (and the arrays).
  void releaseFootprints() { geometry_.releaseFootprints(); }
  /// An upper bound of how many of the layer's pieces overlap at any point (counted on a grid
  /// of their bounding boxes); above 255 the renderer draws the layer in groups.
  [[nodiscard]] std::size_t maxOverlap() const { return geometry_.maxOverlap(); }
  [[nodiscard]] std::pair<glm::dvec2, glm::dvec2> pieceBox() const { return geometry_.pieceBox(); }
  /// The colour (straight alpha, rounded to 8 bits as the vertices hold it) shared by every
  /// visible feature, or none when they differ; the renderer then covers the layer with one
  /// screen rectangle instead of its pieces.
  [[nodiscard]] std::optional<glm::vec4> uniformColor() const { return geometry_.uniformColor(); }
  /// Checks every live piece as drawn (validation.hpp: closed, outward, bounded, inside its
  /// cell) and that the stored vertices are the footprints' within float precision.
  [[nodiscard]] LayerValidation validate() const { return geometry_.validate(); }
  /// The bounds provider's surface changed since the bounds were read (LayerGeometry).
  [[nodiscard]] bool boundsStale() const { return geometry_.boundsStale(); }
  /// Re-reads the height bounds of every piece (after a change of vertical exaggeration).
  void refreshBounds(const HeightBoundsProvider& bounds);

  /// Draw-side view of the pieces (the renderer's business).
  using PieceSlot = LayerGeometry::PieceSlot;
  [[nodiscard]] const std::vector<PieceSlot>& slots() const { return geometry_.slots(); }
  [[nodiscard]] const std::vector<Polyhedron>& polyhedra() const { return geometry_.polyhedra(); }
  [[nodiscard]] const std::vector<glm::dvec2>& origins() const { return geometry_.origins(); }
  [[nodiscard]] GLuint vertexBuffer() const { return vertices_.id(); }
  /// Lines in pixels: per vertex (direction x, y, anchor height) (Footprint::directions); the
  /// vertex buffer then holds the centres. 0 for every other layer.
  [[nodiscard]] GLuint scalingBuffer() const { return scaling_.id(); }
  /// > 0 when the layer's lines are drawn in pixels (LayerStyle::widthPixels).
  [[nodiscard]] double widthPixels() const { return geometry_.widthPixels(); }
  [[nodiscard]] GLuint indexBuffer() const { return indices_.id(); }
  /// World pieces (LayerGeometry::ofWorldPieces): per vertex, the direction its cap is padded
  /// along; 0 for a layer in frame coordinates.
  [[nodiscard]] GLuint normalBuffer() const { return normals_.id(); }
  [[nodiscard]] bool alongNormals() const { return geometry_.alongNormals(); }
  /// World pieces built once for the finer terrain only (the globe's `stencil`): how far (metres,
  /// along the normals) the bottom caps move down and the top caps up in this frame, so that
  /// they hold the coarser surface drawn over them now (the bounds contract's dynamic scheme,
  /// docs/design.md §5). Set by their owner before each frame; 0 otherwise.
  void setCapReach(double below, double above) { capReach_ = glm::dvec2(below, above); }
  [[nodiscard]] glm::dvec2 capReach() const { return capReach_; }
  /// Uploaded from arrays left in a file (LayerGeometry::arraysInFile) that could not be read
  /// at upload: its buffers hold nothing to draw.
  [[nodiscard]] bool broken() const { return broken_; }

 private:
  explicit OverlayLayer(LayerGeometry geometry) : geometry_(std::move(geometry)) {}
  /// Brings the buffers up to date with the geometry's changes (new, larger buffers when it
  /// outgrew them).
  void sync();
  /// New buffers of these capacities holding the whole geometry.
  void reallocate(std::size_t vertexCapacity, std::size_t indexCapacity);

  LayerGeometry geometry_;
  gfx::BufferHandle vertices_, indices_, scaling_, normals_;
  std::size_t vertexCapacity_ = 0, indexCapacity_ = 0;
  std::size_t gpuBytes_ = 0;
  glm::dvec2 capReach_{0.0};
  bool broken_ = false;
};

/// The layer as the CPU reference and the logical selection see it (referenceLayerOf of its
/// geometry). Refers to the layer's features: keep the layer alive.
inline ReferenceLayer referenceLayerOf(const OverlayLayer& layer) { return referenceLayerOf(layer.geometry()); }

}  // namespace gis::overlay
