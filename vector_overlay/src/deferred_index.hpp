#pragma once
// The deferred technique's index of one layer (techniques/deferred_technique.cpp): an adaptive
// quadtree over the layer's coverage whose leaves list what can cover their points, in the
// layout overlay_deferred.frag reads. Built on the CPU from the layer as the CPU reference sees
// it (ReferenceLayer), with the reference's own predicates, so the per-pixel test is the
// reference's test on the pixel's ground point.
//
// Precision: every coordinate a leaf holds is relative to the leaf's corner (float), and the
// shader finds the pixel's ground point as integer cell coordinates at the finest level plus a
// float remainder (deferred::Frame), never as an absolute float position. Edges and segments
// are clipped to the leaf grown by an eighth of its size (and the largest half width), so no
// stored coordinate is far from its corner.
//
// Polygons (even-odd per polygon, union over a feature's polygons): each leaf has a reference
// point c = (X, Yc) inside it, chosen in the widest gaps between the leaf's vertices (so no
// vertex lies on x = X and no edge near c), and for every polygon whose edges meet the leaf,
// its parity at c (the reference's rule, over all its edges). A point's parity is that parity
// flipped by each edge of the leaf that the path from the point along +x or −x to x = X, then
// along x = X to c, crosses. The path stays in the leaf, so the leaf's edges are all it can
// cross; where the two legs meet, the edge's side of x = X is decided from the same stored
// crossing height, so the legs never disagree. Polygons that cover a leaf without an edge in it
// are listed with parity 1 and no edges.
//
// What one feature may cost is bounded: the root covers at most the region where ground points
// can be (BuildOptions::region, the terrain's extent), a node that one primitive of a line in
// metres covers wholly (and no earlier feature meets) is a leaf holding a square for it, and the
// splits a feature forces for size are counted against a budget (maxSizeSplitsPerFeature, and 4
// per entry of it). A line 1e15 m wide (the widest accepted) then costs a handful of leaves within
// the terrain, and at most the budget without a region, not the whole quadtree down to
// maxLeafSize.
//
// Lines: the reference's primitives (bands, discs, convex joins), anchored at their vertices.
// Lines in pixels are stored at unit half width and scaled per frame by their anchors' widths
// (halfWidthAt), so the index holds for every view; they are binned at their largest width.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/deferred_lookup.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay::deferred {

/// A quadtree node (std430 uvec4). Internal: `count` == kInternal and the four children are at
/// first .. first + 3 (x low/high, then y low/high: child = first + cx + 2 cy). Leaf: `count`
/// entries from `first` (groups of a polygon layer, items of a line layer); x, y: the reference
/// point's coordinates relative to the leaf's corner (float bits).
struct Node {
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  std::uint32_t x = 0;
  std::uint32_t y = 0;
};
inline constexpr std::uint32_t kInternal = 0xFFFFFFFFU;
/// Index::grid entries: the node in the low bits, its level from bit 27.
inline constexpr std::uint32_t kGridLevelShift = 27;
inline constexpr std::uint32_t kGridNodeMask = (1U << kGridLevelShift) - 1;

/// One polygon in a leaf: its parity at the leaf's reference point, and its edges there.
struct Group {
  std::uint32_t feature = 0;
  std::uint32_t parity = 0;
  std::uint32_t first = 0;  ///< into edges
  std::uint32_t count = 0;
};

/// An edge clipped to its leaf, relative to the leaf's corner, with where it crosses x = X.
struct Edge {
  float ax = 0.0F, ay = 0.0F, bx = 0.0F, by = 0.0F;
  float crossY = 0.0F;  ///< kCrossesX: the height at which it crosses x = X
  std::uint32_t flags = 0;
  float pad0 = 0.0F, pad1 = 0.0F;
};
inline constexpr std::uint32_t kCrossesX = 1U;     ///< the edge crosses x = X
inline constexpr std::uint32_t kRightOfX = 2U;     ///< it does not, and lies right of it
inline constexpr std::uint32_t kRisingRight = 4U;  ///< (b.x − a.x)(b.y − a.y) > 0

/// A line primitive relative to its leaf's corner (four vec4, std430). `header`: kind in bits
/// 0–1, the convex vertex count in bits 2–4, the feature from bit 5.
///   Segment: p0 = (a.x, a.y, f0, header), p1 = (u.x, u.y, length, half), p2 = (anchor height
///            of the line's segment's start, of its end, f1): the part [f0, f1] of the line's
///            segment, from a along the unit direction u; `half` for widths in metres.
///   Band:    p0 = (origin.x, origin.y, t0, header), p1 = (u.x, u.y, t1, half), p2.x anchor
///            height: square caps (unit half width when in pixels).
///   Disc:    p0 = (centre.x, centre.y, radius, header), p2.x anchor height.
///   Convex:  p0 = (anchor.x, anchor.y, 0, header), p1 = (o0, o1), p3 = (o2, o3) vertex offsets
///            from the anchor, counter-clockwise; p2.x anchor height.
struct Item {
  std::array<float, 16> v{};
};
enum class ItemKind : std::uint32_t { Segment = 0, Band = 1, Disc = 2, Convex = 3 };
inline constexpr std::uint32_t kFeatureShift = 5;

/// Per feature, as the shader reads it: colour (straight alpha) and, for lines in pixels, the
/// half-width rule (widthPixels / 2, minWidth / 2, width / 2; all 0 for widths in metres).
struct FeatureParams {
  glm::vec4 color{0.0F};
  glm::vec4 width{0.0F};
};

struct BuildOptions {
  std::size_t maxEntriesPerLeaf = 4;  ///< a leaf with more is split (down to maxDepth)
  int maxDepth = 20;
  /// Leaves holding anything are at most this large (metres): stored coordinates stay small
  /// next to the pixels seen from 1 m (float keeps 2^-24 of this).
  double maxLeafSize = 1024.0;
  int coverLevel = 5;  ///< nodes at this depth (or leaves above it) with content are the cover boxes
  int gridLevel = 9;   ///< the finest level of the lookup grid (Index::grid)
  /// Lines in pixels: the largest half width binned (metres); wider ones are clamped to it.
  double maxReach = std::numeric_limits<double>::infinity();
  /// Where ground points can be (frame coordinates, [min, max]): the terrain's extent, as the
  /// stencil technique clips its pieces to it (CellGrid). The index then covers what the layer
  /// covers there and no more, so that a line 1e15 m wide costs what one covering the terrain
  /// does. None: wherever the layer reaches.
  std::optional<std::array<glm::dvec2, 2>> region;
  /// Splits a feature may force because a node holding it is larger than maxLeafSize: this many,
  /// plus 4 per edge or line primitive of it. Beyond, its entries stay in larger leaves (their
  /// float coordinates less precise), so that one feature reaching far beyond the rest — 1e15 m
  /// wide, with no region — costs memory by its vertices, not by its extent. Far above what a
  /// feature within a frame takes (a polygon edge of 20,000 km takes about 30,000).
  std::uint32_t maxSizeSplitsPerFeature = 1U << 16;
  /// Lines in space (buildWorld): the ground's heights lie within ± this of the ellipsoid (what a
  /// leaf wholly inside a primitive must allow for).
  double heightRange = 0.0;
};

struct Index {
  LayerKind kind = LayerKind::Polygon;
  bool inPixels = false;  ///< some feature's widths are in pixels
  /// A line layer whose items are primitives in space (buildWorld): each leaf's relative to the
  /// point of the ellipsoid at the leaf's corner (WorldItem).
  bool world = false;
  glm::dvec2 origin{0.0};     ///< the root's corner (frame coordinates)
  double size = 0.0;          ///< the root's side (metres); 0: empty
  int depth = 0;              ///< the deepest leaf's level: integer coordinates are at this level
  std::vector<Node> nodes;    ///< nodes[0] is the root
  std::vector<Group> groups;  ///< polygon layers
  std::vector<Edge> edges;
  std::vector<Item> items;  ///< line layers
  std::vector<FeatureParams> features;
  /// A 2^gridLevel × 2^gridLevel grid over the root (row-major, y up): per cell the node where
  /// the walk goes on (the leaf holding it, or its node at gridLevel) and that node's level
  /// (kGridLevelShift), so that a lookup starts gridLevel levels down.
  int gridLevel = 0;
  std::vector<std::uint32_t> grid;
  /// Boxes (frame coordinates) holding every point the layer can cover, a few hundred at most:
  /// the technique draws only where they project.
  std::vector<std::array<glm::dvec2, 2>> cover;
  std::size_t polygons = 0, primitives = 0;  ///< indexed source items
  double reach = 0.0;                        ///< the largest half width of its lines in pixels as binned (0: none)

  [[nodiscard]] bool empty() const { return size <= 0.0 || nodes.empty(); }
  [[nodiscard]] std::size_t bytes() const {
    return nodes.size() * sizeof(Node) + groups.size() * sizeof(Group) + edges.size() * sizeof(Edge) +
           items.size() * sizeof(Item) + features.size() * sizeof(FeatureParams) + grid.size() * sizeof(std::uint32_t);
  }
  /// Side of a cell at the finest level.
  [[nodiscard]] double cellSize() const { return size / static_cast<double>(1ULL << depth); }
};

/// Builds the index of a layer (its visible features; colours from `colors`, one per feature,
/// straight alpha). Lines in pixels take their anchors' heights from the layer's shapes.
Index build(const ReferenceLayer& layer, std::span<const glm::vec4> colors, const BuildOptions& options = {});

/// A world primitive in a leaf (Index::world), relative to C, the leaf's corner on the ellipsoid
/// (chart.unproject). Header: kind in bits 0–1 (0 convex, 1 band, 2 disc, 3 the whole leaf), bit 2
/// set for a line in pixels (its half widths from its feature's FeatureParams at its anchors),
/// bit 3 set when a convex shape's plane basis starts from x (below), the feature from bit 5.
///   Band:   p0 = (a − C, header), p1 = (along, length), p2 = (normal, r0), p3 = (r1, anchor0,
///           anchor1): the anchors' heights along the ellipsoid's normal at a and at the end.
///   Disc:   p0 = (a − C, header), p1 = (normal, r0), p2.x = anchor0.
///   Convex: p0 = (a − C, header), p1 = (normal, r0, or anchor0 in pixels), p2 = (c0, c1),
///           p3 = (c2, c3): the corners in half widths in the basis e1 = normalize(normal × z)
///           (× x with bit 3), e2 = normal × e1, a triangle's last corner repeated.
/// Builds the index of a frame's lines in space in one chart (Part::worldLines): binned by their
/// chart boxes; `featureCount` features coloured by `colors`, lines in pixels by `widths`
/// (Part::lineWidths), their largest half width clamped to options.maxReach.
Index buildWorld(std::span<const WorldLinePrimitive> primitives, const DeferredChart& chart, std::size_t featureCount,
                 std::span<const glm::vec4> colors, std::span<const glm::dvec3> widths,
                 const BuildOptions& options = {});

/// What the shader needs of the camera to find a ground point in the index (deferred::Frame in
/// the shader's uniforms): the eye as integer cells at the finest level plus a remainder.
struct EyeCells {
  glm::ivec2 cell{0};
  glm::vec2 remainder{0.0F};  ///< metres, in [0, cellSize) unless the eye is very far away
};
EyeCells eyeCells(const Index& index, const glm::dvec3& eye);

/// The shader's test on the CPU (float, as the GPU computes it), for tests: the feature
/// covering a ground point given relative to the eye (float, as reconstructed from depth), or
/// -1. `scale` gives lines in pixels their widths.
std::int64_t coveringFeature(const Index& index, const EyeCells& eye, const glm::vec3& relativeToEye,
                             const glm::dvec3& eyePosition, const PixelScale& scale);

}  // namespace gis::overlay::deferred
