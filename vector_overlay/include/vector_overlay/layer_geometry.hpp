#pragma once
// One vector layer's stencil polyhedra on the CPU (docs/design.md §5): each feature's footprints
// (footprints.hpp) extruded between the height bounds of their cells into closed, outward-wound
// polyhedra, and the vertex and index arrays the GPU draws, with one slot per piece so that
// editing a feature rewrites only its pieces. No GL: a LayerGeometry can be built on any thread
// (given a HeightBoundsProvider that may be read from it), tested without a context, and handed
// to the GL thread, where OverlayLayer uploads it (prepare on a worker, upload on the GL thread).
//
// A piece's vertices are stored relative to an origin near it (1 km grid) as
// (x, y, height, side): height is the bound from the HeightBoundsProvider (lo for side −1, hi
// for side +1); the shader moves caps by side · pad, with a pad that grows with the distance
// from the eye (depth precision), so padding is a per-frame setting. Indices of a piece are
// [bottom cap | walls | top cap], so z-pass draws can leave out the bottom cap.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "core/height_bounds.hpp"
#include "geo/feature.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/shared_features.hpp"
#include "vector_overlay/style.hpp"

namespace gis::geo::io {
class Writer;
class Reader;
}  // namespace gis::geo::io

namespace gis::overlay {

/// How one feature is drawn, resolved from the layer style and its attributes.
struct FeatureStyle {
  glm::vec4 color{1.0F};  ///< straight alpha, opacity applied
  LineShape shape;        ///< line layers
  bool visible = true;
};

/// The style of each feature of a layer: colour from `colorAttribute` through the categorical
/// map (else the layer colour), width from `widthAttribute` (else the layer width). A width
/// attribute that is present but not a positive finite number gets the layer width and a
/// Warning naming the layer and the feature (when `diagnostics` is given).
std::vector<FeatureStyle> resolveFeatureStyles(const LayerStyle& style, LayerKind kind,
                                               const std::vector<geo::Feature>& features,
                                               Diagnostics* diagnostics = nullptr, const std::string& layerName = {},
                                               bool minWidthInPixels = false);
/// The same for features that may be on disk: read one at a time, and only when the style takes
/// anything from their attributes.
std::vector<FeatureStyle> resolveFeatureStyles(const LayerStyle& style, LayerKind kind, const SharedFeatures& features,
                                               Diagnostics* diagnostics = nullptr, const std::string& layerName = {},
                                               bool minWidthInPixels = false);

struct LayerBuildOptions {
  FootprintOptions footprints;
  /// The seed paper's construction: one bound pair per feature (no split at cells).
  bool paperVariant = false;
  /// Keep a shape split at the cells only where that pays: when the parts' walls, each as high
  /// as its own bounds, have less than `splitGain` of the area of the whole shape's walls under
  /// the shape's bounds (flat ground, or a thin road whose pieces are short, keeps one piece).
  /// Off: every shape is split at every cell it meets.
  bool adaptiveSplit = true;
  double splitGain = 0.7;
  /// Features are built on this many threads (the result is the same on any number). Above 1,
  /// the HeightBoundsProvider is read from all of them at once: give more only for a provider
  /// that allows it (terrain::QuadtreeHeightBounds does).
  unsigned threads = 1;
  /// Keep the features and their styles, build no pieces: a tiled technique builds them per
  /// tile and level of detail (tiled_layer.hpp). Visible features count as drawn.
  bool deferPieces = false;
  /// Honour LayerStyle::minWidthPixels (lines in metres at least that wide on screen): the tiled
  /// technique does, building each tile at the widths its view needs; the whole-load techniques
  /// draw the widths in metres.
  bool minWidthInPixels = false;
  /// Warn about features that are fine but give nothing to draw (outside the terrain, no
  /// geometry). Off for a tile's build: a feature near a tile need not reach into it.
  bool reportEmpty = true;
  /// Pieces' bounds may also hold the surface this many metres around them
  /// (HeightBoundsProvider::boundsOverWithin): cheaper to find, a little taller. Tiles of
  /// coarse levels, seen from afar, use their ground error.
  double boundsSlack = 0.0;
  /// Once this is set (from any thread), the build stops early and fails: a tile no longer
  /// wanted. Not part of what the pieces depend on.
  const std::atomic<bool>* cancel = nullptr;
  /// With deferPieces: where the features' checks are kept for the next run (empty: nowhere),
  /// in a file named after what they depend on (the features, their line shapes, the layer's
  /// name and kind, the chords and cells, the code), with their messages.
  std::string checkCacheDirectory;
};

/// A colour (straight alpha) as a vertex holds it: 8 bits a channel, rounded.
std::array<std::uint8_t, 4> rgba8(const glm::vec4& colour);

/// The seed paper's construction covers each piece by its box: the box's 12 triangles as indices
/// of its 8 corners (corner k: bit 0 = +x, bit 1 = +y, bit 2 = top), wound outward.
inline constexpr std::array<std::uint32_t, 36> kBoxFaces{0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                                         2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};

/// Lines in pixels: sets the shape's anchor heights (LineShape) to the middle of the bounds at
/// each vertex of the feature. Other styles are left alone.
void assignAnchorHeights(FeatureStyle& style, const geo::Feature& feature, const HeightBoundsProvider& bounds);

/// A closed polyhedron: a footprint extruded between [lo, hi] (exaggerated metres).
struct Polyhedron {
  Footprint footprint;
  double lo = 0.0;
  double hi = 0.0;
  /// The terrain is drawn under the whole footprint (no nodata, inside the DEM), so in z-pass the
  /// bottom cap can never pass the depth test and is left out.
  bool overSurface = false;
  glm::dvec2 boxMin{0.0}, boxMax{0.0};  ///< of the footprint
};

/// Builds the polyhedra of one feature under the bounds contract. A feature that cannot be used
/// gets Errors (footprints.hpp); one that is fine but gives nothing to draw (outside the grid,
/// no geometry of the layer's kind) gets a Warning saying so.
std::vector<Polyhedron> buildPolyhedra(const geo::Feature& feature, std::uint32_t featureIndex, LayerKind kind,
                                       const FeatureStyle& style, const std::string& layerName,
                                       const HeightBoundsProvider& bounds, const LayerBuildOptions& options,
                                       Diagnostics& diagnostics);

/// True if the point may lie inside the polyhedron extruded with padding `pad` (exaggerated
/// metres), within `margin` metres: in the footprint (or within margin of it) and between
/// lo − pad − margin and hi + pad + margin. Conservative: false means certainly outside.
bool mayContain(const Polyhedron& p, const glm::dvec3& point, double pad, double margin);

struct LayerStats {
  std::size_t features = 0;
  std::size_t skippedFeatures = 0;  ///< left out for errors (each named in the diagnostics)
  std::size_t emptyFeatures = 0;    ///< fine but nothing to draw (outside the terrain, no geometry): a Warning each
  std::size_t pieces = 0;
  std::size_t triangles = 0;
  std::size_t gpuBytes = 0;
  double buildSeconds = 0.0;
  /// deferPieces: whether the features' checks were read from LayerBuildOptions::checkCacheDirectory.
  bool checksFromCache = false;
};

/// What became of one feature of a layer.
enum class FeatureOutcome : std::uint8_t {
  Drawn,          ///< has pieces
  Skipped,        ///< left out for errors (named in the build's diagnostics)
  NothingToDraw,  ///< fine, but no pieces: outside the terrain, no geometry (a Warning says so)
  Hidden,         ///< not visible (style) or removed
};

/// What buildPolyhedra would make of the feature (Drawn, Skipped for errors, NothingToDraw),
/// with the same diagnostics, from its footprints uncut and without height bounds: how a layer
/// built with LayerBuildOptions::deferPieces checks its features at load.
FeatureOutcome checkFeature(const geo::Feature& feature, std::uint32_t featureIndex, LayerKind kind,
                            const FeatureStyle& style, const std::string& layerName, const LayerBuildOptions& options,
                            Diagnostics& diagnostics);

/// What OverlayLayer::validate found.
struct LayerValidation {
  Diagnostics problems;  ///< one Error per broken piece, naming the layer, feature and piece
  std::size_t pieces = 0;
  /// Largest distance (metres) between a vertex as stored for the GPU (float, relative to its
  /// origin) and the footprint's vertex (double, frame): the volumes' position error.
  double maxPositionError = 0.0;
  /// Largest error (metres) of a stored height bound.
  double maxHeightError = 0.0;
};

/// What an edit changed in a LayerGeometry's arrays since the GPU copy was last brought up to
/// date: [begin, end) of the vertices and of the indices (empty when begin >= end).
struct GeometryChange {
  std::size_t vertexBegin = std::numeric_limits<std::size_t>::max();
  std::size_t vertexEnd = 0;
  std::size_t indexBegin = std::numeric_limits<std::size_t>::max();
  std::size_t indexEnd = 0;
  [[nodiscard]] bool empty() const { return vertexBegin >= vertexEnd && indexBegin >= indexEnd; }
  void add(std::size_t v0, std::size_t v1, std::size_t i0, std::size_t i1);
};

/// A hash of the features and of what their pieces take from their styles (visibility, fid,
/// line shape, geometry, and the colours when they differ between features: the vertices hold
/// them), and of the layer's kind (LayerGeometry::contentFingerprint).
std::uint64_t featuresFingerprint(const std::vector<geo::Feature>& features, const std::vector<FeatureStyle>& styles,
                                  LayerKind kind);
/// The same for features that may be on disk: there the file's content hash stands for their
/// geometry and fids (nothing is read).
std::uint64_t featuresFingerprint(const SharedFeatures& features, const std::vector<FeatureStyle>& styles,
                                  LayerKind kind);

/// What cached pieces take from their features' colours (their vertices hold them): 0 when all
/// are one colour (drawn with it as a uniform, so a new colour needs no new pieces), else a hash
/// of them. featuresFingerprint holds the same; a frame that keys its tiles otherwise adds this.
std::uint64_t coloursFingerprint(std::span<const glm::vec4> colours);

/// A lean layer's GPU arrays left in its file (a coarse tile read from the disk cache,
/// LayerGeometry::readLean): the uploader copies them into its buffers a slice at a time, so the
/// host never holds them whole beside the GPU's copy (on llvmpipe both are host memory).
class ArraysInFile {
 public:
  /// Takes `fd` (closed with this).
  explicit ArraysInFile(int fd) : fd_(fd) {}
  ArraysInFile(const ArraysInFile&) = delete;
  ArraysInFile& operator=(const ArraysInFile&) = delete;
  ~ArraysInFile();
  std::uint64_t verticesAt = 0, indicesAt = 0, scalingAt = 0, normalsAt = 0;  ///< file offsets
  std::size_t vertexCount = 0, indexCount = 0, scalingCount = 0, normalsCount = 0;
  [[nodiscard]] int descriptor() const { return fd_; }
  /// Calls `slice(data, offset, bytes)` for the file's [at, at + bytes) a slice of at most
  /// `sliceBytes` at a time (offset from `at`); false when the file cannot be read.
  bool read(std::uint64_t at, std::uint64_t bytes,
            const std::function<void(const void*, std::uint64_t, std::uint64_t)>& slice,
            std::size_t sliceBytes = std::size_t{8} << 20U) const;

 private:
  int fd_ = -1;
};

class LayerGeometry {
 public:
  /// Builds every feature's polyhedra. Broken features are reported in `diagnostics` and left
  /// out; the rest is kept. Pure: no GL, no shared state (thread-safe for distinct layers when
  /// `bounds` may be read concurrently). `bounds` must outlive the geometry (edits read it).
  static Result<LayerGeometry> build(std::string name, LayerKind kind, const LayerStyle& style, SharedFeatures features,
                                     const HeightBoundsProvider& bounds, const LayerBuildOptions& options = {});

  /// The same with the features' styles resolved already (one per feature; their anchor
  /// heights are assigned here).
  static Result<LayerGeometry> build(std::string name, LayerKind kind, const LayerStyle& style, SharedFeatures features,
                                     std::vector<FeatureStyle> styles, const HeightBoundsProvider& bounds,
                                     const LayerBuildOptions& options = {});

  /// A layer from pieces built before (a tile read from the disk cache): per feature its
  /// polyhedra, added as build() adds them (the same arrays and slots).
  static LayerGeometry assemble(std::string name, LayerKind kind, const LayerStyle& style,
                                std::vector<geo::Feature> features, std::vector<FeatureStyle> styles,
                                std::vector<std::vector<Polyhedron>> pieces, const HeightBoundsProvider& bounds,
                                const LayerBuildOptions& options);

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] LayerKind kind() const { return kind_; }
  [[nodiscard]] const LayerStyle& style() const { return style_; }
  [[nodiscard]] const LayerBuildOptions& options() const { return options_; }
  /// The height bounds the layer was built (or last refreshed) with; null for a default one.
  [[nodiscard]] const HeightBoundsProvider* bounds() const { return bounds_; }
  [[nodiscard]] const std::vector<geo::Feature>& features() const { return features_.all(); }
  /// The features as shared (another layer built from them shares them too).
  [[nodiscard]] const SharedFeatures& sharedFeatures() const { return features_; }
  /// A layer built with deferPieces: a hash of its features as built (their geometry, fids,
  /// visibility and line shapes, and the layer's kind); 0 otherwise and after an edit.
  [[nodiscard]] std::uint64_t contentFingerprint() const { return contentFingerprint_; }
  [[nodiscard]] const std::vector<FeatureStyle>& featureStyles() const { return styles_; }
  /// Counts and build time (gpuBytes is OverlayLayer's business: 0 here).
  [[nodiscard]] const LayerStats& stats() const { return stats_; }
  [[nodiscard]] const std::vector<FeatureOutcome>& featureOutcomes() const { return outcomes_; }
  [[nodiscard]] bool paperVariant() const { return options_.paperVariant; }
  /// > 0 when the layer's lines are drawn in pixels (LayerStyle::widthPixels).
  [[nodiscard]] double widthPixels() const {
    if (kind_ != LayerKind::Line) return 0.0;
    if (style_.widthPixels > 0.0) return style_.widthPixels;
    return options_.minWidthInPixels ? style_.minWidthPixels : 0.0;
  }

  // Editing: only the feature's pieces are rebuilt; changes() says what to upload.
  Diagnostics replaceFeature(std::size_t index, geo::Feature feature);
  Diagnostics setFeatureStyle(std::size_t index, const FeatureStyle& style);
  void removeFeature(std::size_t index);  ///< hides it for good (indices stay stable)
  /// A feature with its style resolved already (a tile's, whose features carry no attributes):
  /// replaces feature `index`, or appends it when index == features().size().
  Diagnostics setFeature(std::size_t index, geo::Feature feature, FeatureStyle style);
  /// Re-reads the height bounds of every piece from `bounds` (which replaces the one given to
  /// build): after the surface as drawn changed, e.g. another vertical exaggeration.
  void refreshBounds(const HeightBoundsProvider& bounds);
  /// The bounds provider's surface changed since the bounds were read (HeightBoundsProvider::
  /// revision): call refreshBounds before drawing, or the bounds contract does not hold.
  [[nodiscard]] bool boundsStale() const { return bounds_ != nullptr && bounds_->revision() != boundsRevision_; }
  /// What changed since the last call (and forgets it).
  GeometryChange takeChanges();
  /// Frees the vertex and index arrays once the GPU holds them (a tile that is not edited in
  /// place): then edits other than removeFeature and refreshBounds report an Error and change
  /// nothing (build the layer again), and validate() checks the pieces only.
  void releaseArrays();
  [[nodiscard]] bool arraysReleased() const { return arraysReleased_; }
  /// After releaseArrays: frees the pieces' footprints and the features' geometry too, keeping
  /// each piece's box and bounds (what a z-pass draw, culling and maxOverlap read). Such a
  /// layer's pieces cannot be drawn z-fail (near-plane clipping needs their footprints): draw
  /// it only where OverlayRenderer::mayDrawZFail says no piece in its box3() can be.
  void releaseFootprints();
  [[nodiscard]] bool footprintsReleased() const { return footprintsReleased_; }
  /// The box of the live pieces, heights included (lo > hi without any).
  [[nodiscard]] std::pair<glm::dvec3, glm::dvec3> box3() const;
  /// Writes the layer as releaseFootprints leaves it (the GPU arrays, the pieces' boxes and
  /// bounds, the slots; no footprints, no feature geometry): for a disk cache of coarse tiles
  /// that a reader takes with a few large reads. The arrays must not be released.
  void writeLean(geo::io::Writer& w) const;
  /// A layer written by writeLean, with footprints released (it is uploaded as built; its
  /// colours are those written), or none when the data is damaged or does not fit `styles`.
  /// With `arrays` (the same file open for positioned reads): the GPU arrays are left in the
  /// file (arraysInFile()), their indices checked against the slots slice by slice. A layer of
  /// world pieces is not read here (readWorldLean).
  [[nodiscard]] static std::optional<LayerGeometry> readLean(geo::io::Reader& r, std::string name, LayerKind kind,
                                                             const LayerStyle& style, std::vector<FeatureStyle> styles,
                                                             const HeightBoundsProvider& bounds,
                                                             const LayerBuildOptions& options,
                                                             std::shared_ptr<ArraysInFile> arrays = nullptr);
  /// A layer of world pieces (ofWorldPieces) written by writeLean, its groups' colours from
  /// `groupStyles` (one per group, as written), or none when the data is damaged, is not world
  /// pieces or does not fit them. `arrays` as for readLean.
  [[nodiscard]] static std::optional<LayerGeometry> readWorldLean(geo::io::Reader& r, std::string name,
                                                                  std::vector<FeatureStyle> groupStyles,
                                                                  std::shared_ptr<ArraysInFile> arrays = nullptr);
  /// The GPU arrays still in their file (a lean read), or null: then vertices(), indices() and
  /// scaling() are empty, and vertexCount() and indexCount() say how many there are.
  [[nodiscard]] const ArraysInFile* arraysInFile() const { return arraysInFile_.get(); }
  [[nodiscard]] std::size_t vertexCount() const {
    return arraysInFile_ ? arraysInFile_->vertexCount : vertices_.size();
  }
  [[nodiscard]] std::size_t indexCount() const { return arraysInFile_ ? arraysInFile_->indexCount : indices_.size(); }

  [[nodiscard]] std::size_t maxOverlap() const;
  /// The ground box of the live pieces (lo > hi without any).
  [[nodiscard]] std::pair<glm::dvec2, glm::dvec2> pieceBox() const {
    (void)maxOverlap();
    return pieceBox_;
  }
  [[nodiscard]] std::optional<glm::vec4> uniformColor() const;
  [[nodiscard]] LayerValidation validate() const;

  /// Where a piece's geometry lies in the arrays.
  struct PieceSlot {
    std::uint32_t feature = 0;
    std::uint32_t origin = 0;         ///< index into origins()
    std::uint32_t baseVertex = 0;     ///< in vertices()
    std::uint32_t firstIndex = 0;     ///< in indices()
    std::uint32_t bottomCount = 0;    ///< indices of the bottom cap (first)
    std::uint32_t indexCount = 0;     ///< all indices
    std::uint32_t boxFirstIndex = 0;  ///< paper variant: the piece's bounding box (36 indices)
    bool live = false;
  };
  /// A vertex as the GPU reads it.
  struct Vertex {
    float x, y, height, side;
    std::uint8_t rgba[4];
  };
  static_assert(sizeof(Vertex) == 20);
  /// Pieces built in world coordinates by a frame of their own (the globe's tiles: ECEF
  /// metres), drawn by the same renderer (docs/frames.md). `vertices` are relative to `origin`,
  /// their height the world z and their side as build() makes them (their colours are written
  /// here); `normals` (one per vertex) is the direction each cap is padded along. Such a piece's
  /// Polyhedron has no footprint: its boxMin/boxMax are the x and y of its world box, lo and hi
  /// its z (box3() is the world box), and it is never over drawn surface (z-pass keeps its
  /// bottom cap). Its z-fail pieces are clipped at the near plane from the arrays, as the GPU
  /// draws them (clipAtNearPlane): once the arrays are released (releaseArrays, a lean read)
  /// footprintsReleased() holds, as for a projected frame's lean tile. The layer's features are its colour groups (no
  /// geometry; fid: the group's number), group g drawn in `groupColours[g]`: one colour for all, and the renderer
  /// covers with rectangles.
  struct WorldPiece {
    std::uint32_t firstIndex = 0;
    std::uint32_t bottomCount = 0;
    std::uint32_t indexCount = 0;
    glm::dvec3 boxLo{0.0}, boxHi{0.0};
    std::uint32_t group = 0;  ///< its colour group (< groupColours.size())
    /// The seed paper's construction (ofWorldPieces' paperVariant): the first of the 36 indices
    /// of the box that covers it.
    std::uint32_t boxFirstIndex = 0;
  };
  /// Lines in pixels among world pieces (LineShape's rule on the globe): `scaling` per vertex
  /// holds its direction (x, y, z: ECEF, in the tangent plane at its centre) and its least half
  /// width, the normal's w how far along the normal the centre's anchor lies from the vertex;
  /// the vertex lies at centre + direction · h, h = max(min(widthPixels / 2 · pixel size at the
  /// anchor, maxWidth / 2), least).
  struct WorldLines {
    std::vector<glm::vec4> scaling;
    double widthPixels = 0.0;
    double maxWidth = 0.0;
  };
  static LayerGeometry ofWorldPieces(std::string name, const glm::dvec3& origin, std::vector<Vertex> vertices,
                                     std::vector<glm::vec4> normals, std::vector<std::uint32_t> indices,
                                     const std::vector<WorldPiece>& pieces, std::span<const glm::vec4> groupColours,
                                     WorldLines lines, bool paperVariant = false);

  [[nodiscard]] const std::vector<PieceSlot>& slots() const { return slots_; }
  [[nodiscard]] const std::vector<Polyhedron>& polyhedra() const { return polyhedra_; }
  [[nodiscard]] const std::vector<glm::dvec2>& origins() const { return origins_; }
  [[nodiscard]] const std::vector<Vertex>& vertices() const { return vertices_; }
  [[nodiscard]] const std::vector<std::uint32_t>& indices() const { return indices_; }
  /// Lines in pixels: per vertex (direction x, y, anchor height) (Footprint::directions);
  /// vertices() then holds the centres. Empty for every other layer.
  [[nodiscard]] const std::vector<glm::vec4>& scaling() const { return scaling_; }
  /// A layer of world pieces (ofWorldPieces): its caps are padded along normals() (one per
  /// vertex: x, y, z; w the distance along it to the anchor of a line in pixels), and its pieces'
  /// origins are worldOrigins() (PieceSlot::origin indexes them).
  [[nodiscard]] bool alongNormals() const { return !worldOrigins_.empty(); }
  [[nodiscard]] const std::vector<glm::vec4>& normals() const { return normals_; }
  [[nodiscard]] const std::vector<glm::dvec3>& worldOrigins() const { return worldOrigins_; }

 private:
  LayerGeometry() = default;
  /// The layer's features and styles, with no pieces yet (build and assemble start here).
  static LayerGeometry empty(std::string name, LayerKind kind, const LayerStyle& style, SharedFeatures features,
                             std::vector<FeatureStyle> styles, const HeightBoundsProvider* bounds,
                             const LayerBuildOptions& options);
  /// What readLean and readWorldLean share: reads what writeLean wrote after the fids into
  /// `layer` (made by empty() with its features and styles); false when it is damaged, or world
  /// pieces where `world` is not (or the other way round).
  static bool readLeanInto(geo::io::Reader& r, LayerGeometry& layer, bool world, std::shared_ptr<ArraysInFile> arrays);
  void addPieces(std::uint32_t feature, std::vector<Polyhedron> pieces);
  void freePieces(std::uint32_t feature);
  Diagnostics rebuildFeature(std::size_t index);
  std::uint32_t originFor(const Polyhedron& p);
  void appendGeometry(std::size_t slot, const std::vector<Vertex>& v, const std::vector<std::uint32_t>& i,
                      const std::vector<glm::vec4>& scaling);
  /// Records a feature's outcome and keeps the stats' counts in step.
  void setOutcome(std::size_t feature, FeatureOutcome outcome);

  std::string name_;
  LayerKind kind_ = LayerKind::Polygon;
  LayerStyle style_;
  LayerBuildOptions options_;
  SharedFeatures features_;
  std::vector<FeatureStyle> styles_;
  std::vector<std::vector<std::uint32_t>> featureSlots_;  ///< per feature, its slots
  std::vector<FeatureOutcome> outcomes_;                  ///< per feature
  std::vector<PieceSlot> slots_;
  std::vector<Polyhedron> polyhedra_;  ///< per slot
  std::vector<glm::dvec2> origins_;
  std::map<std::pair<std::int64_t, std::int64_t>, std::uint32_t> originIndex_;  ///< grid cell → index in origins_
  std::vector<Vertex> vertices_;
  std::vector<std::uint32_t> indices_;
  std::vector<glm::vec4> scaling_;                    ///< lines in pixels only, per vertex
  std::vector<glm::vec4> normals_;                    ///< world pieces only, per vertex
  std::vector<glm::dvec3> worldOrigins_;              ///< world pieces only
  std::shared_ptr<const ArraysInFile> arraysInFile_;  ///< the arrays, while still in their file
  std::size_t wastedIndices_ = 0;
  bool arraysReleased_ = false;
  bool footprintsReleased_ = false;
  std::uint64_t contentFingerprint_ = 0;
  GeometryChange changes_;
  LayerStats stats_;
  const HeightBoundsProvider* bounds_ = nullptr;
  std::uint64_t boundsRevision_ = 0;  ///< bounds_->revision() when the bounds were read
  mutable std::pair<glm::dvec2, glm::dvec2> pieceBox_{glm::dvec2(1.0), glm::dvec2(-1.0)};  ///< with maxOverlap_
  mutable std::optional<std::size_t> maxOverlap_;                                          ///< cleared by edits
  mutable std::optional<std::optional<glm::vec4>> uniformColor_;                           ///< cleared by edits
};

/// The layer as the CPU reference and the logical selection see it: its features, their line
/// shapes (line layers) and visibility. Refers to the layer's features: keep the layer alive.
ReferenceLayer referenceLayerOf(const LayerGeometry& layer);

}  // namespace gis::overlay
