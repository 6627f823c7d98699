#pragma once
// Vector overlays on the globe (docs/globe.md): polygons in longitude/latitude made into closed
// stencil polyhedra on the WGS 84 ellipsoid, per drawn terrain tile, and their CPU reference.
//
// - A ring's edges are geodesics: points are added along each so that no piece is longer than
//   maxSegmentMetres (GeographicLib). Between those points an edge is drawn as the wall through
//   the ellipsoid normals at its ends: the plane through both ends that holds their mean normal
//   (edgeSide); the reference classifies with that same plane.
// - Rings are unwrapped (consecutive longitudes differ by less than 180°) so that a ring across the
//   antimeridian is one ring. A ring that winds once around a pole (Antarctica's coast) is closed
//   along that pole: points at latitude ±90 stand for the pole, and an edge between two of them
//   runs along it (it has no length; its walls have no area).
// - Pieces: a polygon clipped to a drawn tile's box — widened a little so neighbouring tiles'
//   pieces overlap, which the stencil count (≠ 0) allows — its cap triangulated with points inside
//   it every few posts (so no cap triangle cuts the ground for the ellipsoid's curvature), extruded
//   along the normals between the ground's bounds there (the terrain's bounds contract).
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "geo/feature.hpp"
#include "gfx/program.hpp"
#include "gfx/state_cache.hpp"
#include "globe/geo_grid.hpp"
#include "globe/globe_terrain.hpp"
#include "globe/globe_view.hpp"
#include "globe/tile.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/deferred_lookup.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/layer_geometry.hpp"
#include "vector_overlay/overlay_renderer.hpp"
#include "vector_overlay/shared_features.hpp"
#include "vector_overlay/style.hpp"
#include "vector_overlay/technique.hpp"

namespace gis::globe {

namespace detail {
struct PolygonIndex;
struct BoxGrid;
struct Prepared;
struct LineJoins;
struct LineGrid;
}  // namespace detail

/// One polygon of a feature, prepared: its rings (the first the outer one) unwrapped, densified,
/// closed along a pole where they wind around one. Points are (lon, lat) degrees.
struct GlobePolygon {
  std::uint32_t feature = 0;
  std::uint32_t group = 0;   ///< its colour: GlobeLayer::colors()[group]
  std::uint32_t source = 0;  ///< which of its feature's polygons it is
  std::vector<std::vector<glm::dvec2>> rings;
  LonLatRect box;                                     ///< of the rings, in their unwrapped longitudes
  std::shared_ptr<const detail::PolygonIndex> index;  ///< for contains()
};

/// How far (degrees of arc, times the cosine of the latitude) the rings a tile of `level` is cut
/// from may stray from the true ones: 1/64 of a post. The terrain keeps posts at most 8 pixels
/// apart along their parallels (TerrainOptions::maxPostPixels), so the drawn edges are within
/// 1/8 of a pixel of the true ones: the reference's edge band holds the difference.
double simplifyTolerance(int level);
/// Lines from afar (GlobeLayer::lineShapesIn) may stray this many times simplifyTolerance from
/// the true ones: within half a pixel, as lines do in a projected frame's tiles. (Areas keep 1/8.)
inline constexpr double kLineGeneralisation = 4.0;

/// The side of edge p → q (unwrapped (lon, lat) degrees) a point (ECEF) is on: > 0 north of an
/// edge that runs east (south of one that runs west). The edge's plane holds both ends on the
/// ellipsoid and their mean normal.
double edgeSide(const glm::dvec2& p, const glm::dvec2& q, const glm::dvec3& point);

/// Whether a point (ECEF, and its longitude and latitude) is in the polygon: even-odd over its
/// rings, each edge as edgeSide draws it.
bool contains(const GlobePolygon& polygon, const glm::dvec3& point, double lonDeg, double latDeg);

struct GlobeLayerOptions {
  double maxSegmentMetres = 1000.0;  ///< geodesic densification
  /// Lines (the features' line strings, and with `outlines` the polygons' rings): their width in
  /// metres on the ground, round joins and caps. Drawn as a band along each piece of the line
  /// and a disc at each point it was given with, inscribed in the circle with its chords within
  /// `chordTolerance` of it (as in a projected frame: footprints.hpp) but at most 256 sides
  /// (within r (1 − cos(π/256)) = 7.5·10⁻⁵ r for a line wider than 530 m).
  double lineWidthMetres = 10.0;
  double chordTolerance = 0.02;
  /// Draw the polygons' rings as lines (an outline layer) instead of their areas. (Like a fill
  /// and its outline in a projected frame, the two are layers of their own, each with its bit in
  /// the mask; a reader unites them: scene/globe_scene.hpp, LoadedGlobeScene::layerFileIndex.)
  bool outlines = false;
  /// Per feature (in the order given to build), optional: its colour (straight alpha, opacity
  /// applied; empty: the layer's colour for all) and its line width in metres (empty, or a
  /// width that is not positive and finite: lineWidthMetres). Features of one colour are drawn
  /// together, one mark and cover per colour.
  std::vector<glm::vec4> featureColors;
  std::vector<double> featureWidthMetres;
  /// Lines in pixels (LineShape, footprints.hpp, on the globe; docs/globe.md, "Lines in
  /// pixels"): > 0, every line is this many pixels wide on screen, at least its width in metres
  /// (lineWidthMetres or featureWidthMetres; 0 for a style's `width_px`) and at most
  /// lineMaxWidthMetres. A style's `width_px` gives widthPixels with no width in metres; its
  /// `min_width_px` a width in metres and widthPixels = min_width_px.
  double lineWidthPixels = 0.0;
  double lineMaxWidthMetres = 1e7;
  /// Joins at the points the source gave, and caps at the lines' ends (footprints.hpp's rules, in
  /// the tangent plane at the point); points added along a geodesic join with a bevel.
  overlay::LineJoin join = overlay::LineJoin::Round;
  overlay::LineCap cap = overlay::LineCap::Round;
  double miterLimit = 4.0;
  /// The ground a line in pixels measures its distance to the eye from: each point raised to
  /// heightAt there (the anchor). None: the ellipsoid.
  std::shared_ptr<const GeoGrid> anchorGround;
};

/// A line of a layer, for the CPU reference: within halfWidth of its geodesic pieces.
struct GlobeLine {
  std::uint32_t feature = 0;
  std::uint32_t group = 0;  ///< its colour: GlobeLayer::colors()[group]
  double halfWidth = 0.0;   ///< in metres (a line in pixels: the least)
  /// A line in pixels (GlobeLayerOptions::lineWidthPixels): its half width at a point is
  /// max(min(widthPixels / 2 · pixel size at its anchor, maxHalfWidth), halfWidth); 0: halfWidth.
  double widthPixels = 0.0;
  double maxHalfWidth = 0.0;
  overlay::LineJoin join = overlay::LineJoin::Round;
  overlay::LineCap cap = overlay::LineCap::Round;
  double miterLimit = 4.0;
  /// Round joins and caps: every point is a disc.
  [[nodiscard]] bool round() const { return join == overlay::LineJoin::Round && cap == overlay::LineCap::Round; }
  /// How far its joins and caps may reach from their point, in half widths (a miter's limit, a
  /// square's corner): what a tile's pieces, cut from generalised points, are bounded by.
  [[nodiscard]] double shapeReach() const { return round() ? 1.0 : std::max(miterLimit, 1.5); }
  /// Joins and caps other than round: each point's shape (made once, for the reference), and how
  /// far the farthest reaches, in half widths.
  std::shared_ptr<const detail::LineJoins> joins;
  double reach = 1.0;
  /// A line in pixels: per point, the anchor ground's height there (GlobeLayerOptions::anchorGround).
  std::vector<float> anchors;
  std::vector<glm::dvec2> points;   ///< unwrapped (lon, lat), densified
  std::vector<char> given;          ///< per point, 1 where the source gave it (0: added along a geodesic)
  std::vector<glm::dvec3> surface;  ///< the points on the ellipsoid (ECEF)
  LonLatRect box;                   ///< of the points, widened by the half width
  /// Its pieces (i: points i, i + 1) in a grid over its box, each widened by the half width:
  /// bucketColumns of bucketWidth degrees from box.west by rows of bucketHeight degrees from
  /// box.south, row by row.
  double bucketWidth = 360.0, bucketHeight = 180.0;
  std::size_t bucketColumns = 1;
  std::vector<std::vector<std::uint32_t>> buckets;
  /// The buckets' column and row a point's longitude (unwrapped into the box) and latitude fall
  /// in, clamped to the grid.
  [[nodiscard]] std::size_t bucketColumn(double lon) const;
  [[nodiscard]] std::size_t bucketRow(double lat) const;
};

class GlobeLayer final {
 public:
  /// Features with polygons or lines in (lon, lat) degrees on WGS 84, in memory or on disk (read
  /// one at a time: the scene's layers as loadLayers read them, shared with both frames). A
  /// broken polygon (fewer than 3 points, a latitude beyond ±90, a coordinate that is not finite)
  /// is left out with an Error naming the layer, feature and polygon; the rest is kept.
  static Result<GlobeLayer> build(std::string name, const overlay::SharedFeatures& features, glm::vec4 color,
                                  const GlobeLayerOptions& options = {});

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const glm::vec4& color() const { return color_; }
  /// The colours its features are drawn in (GlobePolygon::group), the layer's colour first.
  [[nodiscard]] const std::vector<glm::vec4>& colors() const { return colors_; }
  /// Every area as prepared (the CPU reference, identify, the lookup, `stencil` and `paper` ask
  /// for them): prepared the first time asked (thread-safe) from the features, on disk or edited,
  /// and kept. What a tile draws never makes them (areasIn), so a view's tiles keep only the
  /// areas' boxes resident.
  [[nodiscard]] const std::vector<GlobePolygon>& polygons() const;
  /// Whether polygons() has been made.
  [[nodiscard]] bool allAreasPrepared() const;
  /// The lines as prepared (densified along geodesics, put on the ellipsoid, anchored, bucketed
  /// for the reference). Prepared the first time anything asks (a tile to build, the reference,
  /// an edit; thread-safe), not at build: a warm start whose tiles come from disk never needs
  /// them. Their problems were named at build.
  [[nodiscard]] const std::vector<GlobeLine>& lines() const;
  /// Whether lines() has been made.
  [[nodiscard]] bool allLinesPrepared() const;
  /// Whether the layer has a line to draw (known at build, without preparing them).
  [[nodiscard]] bool hasLines() const { return hasLines_; }
  /// The box (unwrapped lon/lat) of its areas and of its lines' given points widened by their
  /// reach; empty (west > east) without either. Known at build.
  [[nodiscard]] LonLatRect extent() const { return extent_; }
  /// An area as build found it (polygons()[k] has the same feature, group and source).
  struct Area {
    std::uint32_t feature = 0, group = 0, source = 0;
    LonLatRect box;  ///< holds its prepared rings, in their unwrapped longitudes (from its points as given)
  };
  /// The areas: every polygon (lines are drawn from lineShapesIn), in polygons()' order.
  [[nodiscard]] std::size_t areaCount() const { return areas_.size(); }
  [[nodiscard]] const Area& area(std::size_t k) const { return areas_[k]; }
  /// What a tile of `level` draws of the areas whose boxes meet `rect` (unwrapped longitudes;
  /// an area 360° east or west of it too): their features read (from disk, or as edited) and
  /// prepared (a few recent ones kept), cut to `rect` grown by a margin (a post of the level,
  /// and more than four times its tolerance: what the cut adds lies outside `rect`; where a
  /// border two areas share crosses it, both are cut at the same point), and generalised
  /// together within simplifyTolerance(level)
  /// (overlay::CoverageGeneraliser, as a projected tile's polygons are: a border two areas share
  /// is simplified once, so they meet exactly), an island within the tolerance of one chord left
  /// out; an area's own rings where the level would leave out less than a tenth of its points.
  /// `level` outside [0, kMaxLevel): their own rings (cut with a margin of a hundredth of `rect`).
  /// Each in its own unwrapped longitudes (an area reaching `rect` in two turns is given once per
  /// turn), in polygons()' order, boxed as cut; no point index (contains() does not take them).
  /// What is resident follows the tiles drawn. Thread-safe.
  [[nodiscard]] std::vector<GlobePolygon> areasIn(const LonLatRect& rect, int level) const;
  /// What tile `key` draws of the lines (docs/globe.md, "Lines"): the shapes (bands, joins,
  /// caps) of each line's runs that reach the tile widened by its half width, made for this tile
  /// only, so that nothing resident grows with lines no drawn tile reaches. A run cut at the
  /// tile's window gets a cap there, outside the window. Where the level's tolerance (kLineGeneralisation ×
  /// simplifyTolerance, in metres at the line's highest latitude) is more than four times the
  /// chord tolerance, the shapes are those of the centreline generalised to a quarter of that
  /// tolerance (Douglas–Peucker on its points on the ellipsoid; the last 32 MB made are kept),
  /// arcs within another quarter, rings simplified within the other half; elsewhere of the line's
  /// own points. Thread-safe.
  /// Lines in pixels: the lines width class `widthClass` scales are left out (buildTilePieces);
  /// the others are drawn at their least width, or with `pixelMetres` > 0 (a drape's texel) at
  /// widthPixels times that, within their least and largest widths. `detailLevel` ≥ 0: generalised
  /// as for tiles of that level instead of key.level (kMaxLevel: the lines' own points).
  [[nodiscard]] std::vector<GlobePolygon> lineShapesIn(const TileKey& key, int widthClass = 0, double pixelMetres = 0.0,
                                                       int detailLevel = -1) const;
  /// A line as build found it (lines()[j] has the same feature, group and source): its feature,
  /// colour group, which of its feature's lines it is (a polygon's rings for an outline layer),
  /// and a box that holds its prepared points grown by its half width times its shapes' reach.
  struct LineEntry {
    std::uint32_t feature = 0, group = 0, source = 0;
    LonLatRect box;
  };
  /// The lines (what lines() holds once made).
  [[nodiscard]] std::size_t lineCount() const { return lineEntries_.size(); }
  [[nodiscard]] const LineEntry& lineEntry(std::size_t j) const { return lineEntries_[j]; }
  /// The lines whose boxes, grown by `reach` metres more and a post, may meet tile `key` (a
  /// superset: lineRunsIn says which do), in order. (A box holds its line's shapes at its least
  /// width; a wider one, in pixels, asks for the difference times lineShapeReach().)
  [[nodiscard]] std::vector<std::uint32_t> linesNear(const TileKey& key, double reach) const;
  /// A line as a tile draws it: as prepared (from lines() once made; else read from its feature
  /// and prepared now, the last 64 MB kept), and its points at a level: its centreline
  /// generalised for it (lineShapesIn), or its own points.
  struct TileLine {
    std::shared_ptr<const GlobeLine> line;
    std::shared_ptr<const std::vector<glm::dvec2>> points;
    bool generalised = false;
  };
  /// Line j at `level` (null line if it cannot be prepared). Thread-safe.
  [[nodiscard]] TileLine lineAt(std::size_t j, int level) const;
  /// The runs [first, last] of `line`'s points whose pieces meet tile `key` grown by `reach`
  /// metres and a post.
  [[nodiscard]] static std::vector<std::pair<std::size_t, std::size_t>> lineRunsIn(const TileLine& line,
                                                                                   const TileKey& key, double reach);
  /// The tolerance of line `line` at `level` (metres): lineShapesIn.
  static double lineTolerance(const GlobeLine& line, int level);
  /// Whether width class `widthClass` draws the line in pixels (else in metres: lineShapesIn).
  static bool scalesLine(const GlobeLine& line, int widthClass);
  /// Of the lines in pixels: the least of their widths in metres and the greatest largest width.
  [[nodiscard]] double leastLineHalfWidth() const { return leastHalfWidth_; }
  [[nodiscard]] double widestLineHalfWidth() const { return widestHalfWidth_; }

  /// Whether a point is in the layer (the CPU reference): in one of its areas (the polygons it
  /// was built from), or within half the width of one of its lines (exactly; the drawn discs
  /// lie within the chord tolerance inside). Lines in pixels take their widths from `scale`
  /// (the view's; with none, their least widths).
  [[nodiscard]] bool contains(const glm::dvec3& point, double lonDeg, double latDeg,
                              const overlay::PixelScale& scale = {}) const;
  /// A digest of everything its tiles' pieces are made from (areas as prepared; lines as their
  /// features give them, with their widths, joins, caps and colour groups; the anchor ground's
  /// posts, tolerances, and the builder's version): what the tile cache on disk is keyed by, known
  /// without preparing the lines. Colours are not in it (they are applied when a tile is uploaded).
  [[nodiscard]] std::uint64_t fingerprint() const { return fingerprint_; }
  /// Which build this is: a number no other build of this process had (copies keep it). The
  /// renderer keeps its GPU tiles per build, so a layer built again (another style, another
  /// scene at the same address) never draws the old one's tiles.
  [[nodiscard]] std::uint64_t serial() const { return serial_; }
  /// Lines in pixels: > 0 (GlobeLayerOptions::lineWidthPixels).
  [[nodiscard]] double lineWidthPixels() const { return widthPixels_; }
  /// How far its lines' joins and caps reach from their points, in half widths (GlobeLine::shapeReach).
  [[nodiscard]] double lineShapeReach() const { return roundLines() ? 1.0 : std::max(options_.miterLimit, 1.5); }
  /// Whether its lines have round joins and caps (GlobeLayerOptions::join, cap).
  [[nodiscard]] bool roundLines() const {
    return options_.join == overlay::LineJoin::Round && options_.cap == overlay::LineCap::Round;
  }
  /// The ground lines in pixels are anchored on (null: the ellipsoid).
  [[nodiscard]] const GeoGrid* anchorGround() const { return anchorGround_.get(); }
  /// The half width of line `line` at its point k as seen with `scale`.
  [[nodiscard]] double halfWidthAt(const GlobeLine& line, std::size_t k, const overlay::PixelScale& scale) const;

  /// Editing one feature (docs/globe.md, "Edits"): feature f (an index into the features the layer
  /// was built from; f == the count appends one) becomes `feature`, prepared as build prepares
  /// it, in its colour group; the other features' areas and lines are kept. The layer is then the
  /// one build makes from the edited features (the same fingerprint: tiles kept on disk for it
  /// serve it), its serial stays (the GPU's tiles elsewhere stay), and the areas' levels and the
  /// lines' generalised centrelines are made again as tiles ask. Returns the boxes (longitude and
  /// latitude, unwrapped) the feature reached before and reaches now, grown by its lines' reach:
  /// the tiles over them must be built again (GlobeOverlayRenderer::featureChanged). A feature
  /// that cannot be used is left out with an Error naming it, as build does.
  Result<std::vector<LonLatRect>> replaceFeature(std::size_t f, const geo::Feature& feature);
  /// The number of features the layer was built from (edits may append one).
  [[nodiscard]] std::size_t featureCount() const { return featureGroups_.size(); }

 private:
  /// One feature's areas and lines as prepared, and its messages.
  struct FeatureParts {
    std::vector<GlobeLine> lines;
    std::vector<GlobePolygon> polygons;
    Diagnostics diagnostics;
  };
  static constexpr std::size_t kAllLines = std::numeric_limits<std::size_t>::max();
  /// Prepares feature f's areas (`areas`; with the index contains() takes, or with `checkOnly`
  /// only checked: their rings as given, unwrapped, and a box that holds them as prepared) or
  /// lines (`!areas`; all, or its line `onlyLine` alone) into `part`.
  void prepareFeature(std::uint32_t f, const geo::Feature& feature, std::uint32_t group, FeatureParts& part, bool areas,
                      bool checkOnly = false, std::size_t onlyLine = kAllLines) const;
  /// Checks feature f's lines as prepareFeature would use them (problems into `part`), and returns
  /// a digest of them and of what their pieces take from the options; widens `box` by them and
  /// sets `any` when one is usable.
  /// Each usable line's entry is appended to `entries`.
  std::uint64_t checkLines(std::uint32_t f, const geo::Feature& feature, std::uint32_t group, FeatureParts& part,
                           LonLatRect& box, bool& any, std::vector<LineEntry>& entries) const;
  /// Feature f's half width in metres (its own, else the layer's).
  [[nodiscard]] double featureHalfWidth(std::uint32_t f) const;
  /// Every feature's lines, prepared (lines()).
  [[nodiscard]] std::vector<GlobeLine> prepareLines() const;
  /// The boxes feature f's areas and lines reach (lines grown by their reach at their widest).
  [[nodiscard]] std::vector<LonLatRect> featureBoxes(std::uint32_t f) const;
  GlobeLayerOptions options_;
  std::vector<std::uint32_t> featureGroups_;  ///< per feature: its colour group
  std::string name_;
  glm::vec4 color_{1.0F};
  std::vector<glm::vec4> colors_;
  /// The areas as build found them (boxes, not rings: areasIn prepares what a tile draws), and
  /// by their boxes.
  std::vector<Area> areas_;
  std::shared_ptr<const detail::BoxGrid> areaGrid_;
  std::vector<std::uint64_t> areaDigests_;  ///< per feature: a digest of its areas as prepared
  /// Every area once prepared (polygons()), as the lines are: shared by copies, replaced by an edit.
  struct LazyAreas {
    std::mutex mutex;
    std::shared_ptr<const std::vector<GlobePolygon>> polygons;
    std::atomic<const std::vector<GlobePolygon>*> made{nullptr};
  };
  std::shared_ptr<LazyAreas> allAreas_ = std::make_shared<LazyAreas>();
  /// The areas and lines tiles asked for lately, as prepared (areasIn, lineAt: a large feature
  /// reaches many tiles), under byte bounds; made again by an edit.
  std::shared_ptr<detail::Prepared> prepared_;
  /// Area k as prepared (from polygons() once made, else through prepared_); null if it cannot be.
  [[nodiscard]] std::shared_ptr<const GlobePolygon> preparedArea(std::size_t k) const;
  /// Features an edit replaced or appended (a new map per edit: copies keep theirs).
  std::shared_ptr<const std::map<std::uint32_t, std::shared_ptr<const geo::Feature>>> edited_;
  /// Feature f as the layer has it: as edited, else from the features it was built from.
  [[nodiscard]] std::shared_ptr<const geo::Feature> featureAt(std::uint32_t f) const;
  /// Every feature's areas, prepared (polygons()).
  [[nodiscard]] std::vector<GlobePolygon> prepareAreas() const;
  /// The lines once prepared (lines()): shared by copies, replaced (never changed) by an edit.
  /// Made under the mutex, then read through the atomic pointers without it (the reference asks
  /// for both at every point it tests).
  struct LazyLines {
    std::mutex mutex;
    std::shared_ptr<const std::vector<GlobeLine>> lines;
    std::shared_ptr<const detail::LineGrid> grid;  ///< the lines by their boxes, for the reference
    std::atomic<const std::vector<GlobeLine>*> linesMade{nullptr};
    std::atomic<const detail::LineGrid*> gridMade{nullptr};
  };
  /// The lines' grid (made with them).
  [[nodiscard]] const detail::LineGrid& lineGrid() const;
  std::shared_ptr<LazyLines> lines_ = std::make_shared<LazyLines>();
  overlay::SharedFeatures features_;        ///< what the areas and lines are prepared from
  std::vector<std::uint64_t> lineDigests_;  ///< per feature: checkLines' digest
  std::uint64_t anchorDigest_ = 0;          ///< of the anchor ground's posts
  bool hasLines_ = false;
  LonLatRect extent_{0.0, 0.0, -1.0, -1.0};
  double chordTolerance_ = 0.02, maxSegment_ = 1000.0;
  double widthPixels_ = 0.0;
  double leastHalfWidth_ = 0.0, widestHalfWidth_ = 0.0;
  std::uint64_t fingerprint_ = 0;
  std::uint64_t serial_ = 0;
  std::shared_ptr<const GeoGrid> anchorGround_;
  /// The lines as build found them, and by their boxes (linesNear).
  std::vector<LineEntry> lineEntries_;
  std::shared_ptr<const detail::BoxGrid> lineBoxes_;
  [[nodiscard]] std::uint64_t digestForCache() const;
};

/// The pieces of `layer` over tile `key`, bounded by the ground of `heights` (heights contract:
/// globe_terrain.hpp), as a layer of world pieces of the overlay pipeline
/// (overlay::LayerGeometry::ofWorldPieces: ECEF relative to the tile's middle, caps padded along
/// the surface normals; its features the layer's colour groups, GlobeLayer::colors()).
/// `widthClass` (lines in pixels, lineWidthClass): the lines the class scales are built as
/// pieces that take their width in the shader, at most the class's width; the others (and every
/// line in class 0) in metres.
overlay::LayerGeometry buildTilePieces(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                                       int widthClass = 0);

/// The globe's `stencil` (GlobeTechnique::Stencil), built once for every view as the projected
/// frame's is: the layer at full detail (its own points), widths in metres, over the tiles of
/// kWholeLoadLevel (about 5 km: their pieces' floats, relative to the tile's middle, hold a
/// quarter of a millimetre), bounded for the terrain drawn at that level and every finer one.
/// Where a coarser terrain tile is drawn over one (a view from afar), its caps move out along the
/// normals by wholeLoadCapReach in that frame (OverlayLayer::setCapReach): the bounds contract's
/// dynamic scheme, so the pieces stay shallow for the near views that need their precision.
inline constexpr int kWholeLoadLevel = 12;
/// A layer whose features (each one's box grown by its reach) meet more tiles of kWholeLoadLevel
/// than this is not built whole (its view's tiles are drawn instead, and the renderer says so).
inline constexpr std::size_t kWholeLoadMaxTiles = 16384;
struct WholeLoadTile {
  TileKey key;
  std::optional<overlay::LayerGeometry> geometry;  ///< its pieces (none: not built)
  bool empty = true;                               ///< no pieces
  /// Of its pieces: the highest bottom, and the lowest ground its top caps hold (heights).
  double highestLow = 0.0, lowestHigh = 0.0;
};
/// `paper`: the seed paper's construction (GlobeTechnique::Paper): one bound pair per feature (the
/// terrain over its whole box), a piece per line shape (not united), each covered by its box.
WholeLoadTile buildWholeLoadPieces(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                                   bool paper = false);
/// One frame's drawn terrain tiles coarser than kWholeLoadLevel, found by key: what the tiles
/// built whole ask of them each frame (a few lookups per tile, not a pass over every drawn tile).
class CoarseDrawnTiles {
 public:
  explicit CoarseDrawnTiles(const std::vector<DrawnTile>& drawn);
  /// The levels (bit L: level L) of those coarser than `level` that meet `box` (unwrapped: a tile
  /// meets it a turn east or west too), boundaries included.
  [[nodiscard]] std::uint32_t levelsMeeting(const LonLatRect& box, int level) const;

 private:
  std::unordered_set<TileKey, TileKeyHash> keys_;
  std::uint32_t levels_ = 0;
};
/// The levels of the drawn terrain tiles coarser than the tile's that meet it (its box grown by a
/// hundredth: its pieces reach a little beyond it): all that its caps' reach depends on.
std::uint32_t coarserLevelsOver(const WholeLoadTile& tile, const CoarseDrawnTiles& drawn);
/// How far (below, above) the tile's bottom and top caps must move in a frame whose drawn terrain
/// tiles coarser than its level that meet it are of `levels` (coarserLevelsOver; 0: none, no
/// reach).
glm::dvec2 wholeLoadCapReach(const WholeLoadTile& tile, std::uint32_t levels, const GeoGrid& heights);

/// Lines in pixels: the width class a tile is drawn with from a view (the tiled technique's
/// rule, tiled_layer.hpp): 0 where every line of the layer is at least as wide in metres as
/// widthPixels at the tile's farthest point; else c > 0, whose pieces are at most
/// lineClassWidth(c) metres wide and hold the width in pixels everywhere in the tile (the
/// tile grown by half that width).
int lineWidthClass(const GlobeLayer& layer, const TileKey& key, const GeoGrid& heights,
                   const overlay::PixelScale& scale);
inline double lineClassWidth(int widthClass) { return std::ldexp(1.0, widthClass - 8); }

/// How the globe's layers reach the pixels (overlay_render --method; the registry's names):
/// - StencilTiles (`stencil-tiles`): stencil polyhedra per drawn terrain tile.
/// - Stencil (`stencil`): stencil polyhedra built once for every view, at full detail with widths
///   in metres, over the tiles of kWholeLoadLevel (buildWholeLoadPieces), as the projected frame's
///   `stencil` builds its layers at load (for comparisons); a layer over more than
///   kWholeLoadMaxTiles of them is drawn by its tiles instead (said once).
/// - Paper (`paper`): the seed paper's construction built once as `stencil` is: a bound pair per
///   feature, a piece per line shape, marked with the paper's states and covered by the pieces'
///   boxes (the projected frame's paper variant, overlay_renderer.hpp).
/// - Deferred (`deferred`): the deferred lookup of both frames (vector_overlay/deferred_lookup.hpp)
///   in the six faces of the cube (deferredParts), for the last layers it can draw (deferredDraws:
///   areas, or lines with round joins and caps whose index would fit a quarter of the GPU budget,
///   lines in pixels while the view keeps them within the widest reach class: lookupReach); the
///   layers before them keep their stencil polyhedra. A
///   layer's indices are built on a thread of their own: meanwhile (but in a still, which waits)
///   it is drawn by its pieces.
/// - Auto (`auto`): per frame the cheaper of the two by their measured GPU times (the plan
///   chooser of both frames, vector_overlay/plan_chooser.hpp), the lookup only for layers whose
///   indices are built and fit a quarter of the GPU budget; the first frame draws the pieces.
/// - Drape (`drape`) and DrapeTiles (`drape-tiles`): texture draping, the baseline of other
///   viewers: the projected frame's techniques of the registry, whose textures lie in longitude
///   and latitude here (GlobeDrapeSource, globe_drape.hpp): one over the layers' box, or one per
///   drawn terrain tile. Not exact (the texel decides); what the benchmark compares against.
enum class GlobeTechnique { StencilTiles, Stencil, Paper, Deferred, Auto, Drape, DrapeTiles };
/// Whether the technique drapes textures (the terrain draws the layers).
inline bool drapes(GlobeTechnique technique) {
  return technique == GlobeTechnique::Drape || technique == GlobeTechnique::DrapeTiles;
}

/// Whether the deferred lookup draws the layer (deferredParts): areas only, or lines only (in
/// metres or in pixels) with round joins and caps; others keep their stencil pieces.
bool deferredDraws(const GlobeLayer& layer);

/// The layer's areas in each face of the cube about the earth's centre
/// (overlay::DeferredChart::cubeFace on WGS 84): what the deferred lookup indexes on the globe.
/// Each polygon's rings are taken as chords of the ellipsoid between their prepared points,
/// clipped to the face's pyramid grown by its margin (exactly: a chord crosses a plane through the
/// centre at one point) and projected from the centre. The plane's even-odd then differs from the
/// reference's (a ring around a pole closed along it, a ring around the whole world) by a
/// constant over the face, checked at one point of it and made good by the face's square. The
/// cover boxes lie between `lowest` and `highest` (heights above the ellipsoid).
/// Or, for a layer of lines (deferredDraws), its lines' primitives in space as the reference tests
/// them (overlay::WorldLinePrimitive: a cylinder around the normal at each point, or the polygon of
/// a join or cap other than round across it, a slab along each piece), each in the faces its chart
/// box (its corners projected, grown by what heights between `lowest` and `highest` and the
/// ellipsoid's curvature move their feet) meets; the leaves of its index decide what they hold for
/// ground within ±`heightRange` of the ellipsoid (negative: the larger of |lowest| and |highest|).
/// Lines in pixels are binned at their largest half width within `maxReach` (metres) and take
/// their widths per frame at their anchors (the index is exact while a view keeps them within
/// it: GlobeOverlayRenderer picks the reach per view).
std::vector<overlay::DeferredLayer::Part> deferredParts(const GlobeLayer& layer, double lowest, double highest,
                                                        double heightRange = -1.0,
                                                        double maxReach = std::numeric_limits<double>::infinity());

struct GlobeOverlaySettings {
  GlobeTechnique technique = GlobeTechnique::StencilTiles;
  /// The framebuffer being drawn into (bound; the deferred lookup reads its depth).
  GLuint targetFramebuffer = 0;
  /// The caller times the draw and reports it (GlobeOverlayRenderer::measured), for `auto`;
  /// otherwise `auto` times it itself.
  bool measure = false;
  double padBase = 0.05;  ///< caps move out by padBase + padPerMetre · distance (depth precision)
  double padPerMetre = 2e-6;
  /// GPU bytes the tiles' pieces may hold, all layers (the scene's terrain.gpu_budget_mb, as the
  /// projected frame's tiles): the least recently drawn tiles leave first; the tiles of the
  /// frame being drawn always stay.
  std::size_t gpuBudgetBytes = std::size_t{512} << 20U;
  /// The scene's cache directory (empty: none): each tile's pieces are kept there once built,
  /// under globe-tiles/, keyed by the layer's fingerprint, the grid's digest, the tile and its
  /// width class, as checked files (a damaged one is built again and rewritten). Not with a
  /// paged grid (its digest would need every post).
  std::string cacheDir;
  /// The folders of cacheDir/globe-tiles (one per layer and grid) no layer opened lately are
  /// removed beyond this many bytes, and any unused for 30 days (overlay::pruneTileFolders, as a
  /// projected scene's tiles).
  std::uintmax_t cacheBudgetBytes = std::uintmax_t{4} << 30U;
  /// A still image: wait for every drawn tile's pieces (built on worker threads). Otherwise a
  /// tile that is still building is drawn by its nearest resident ancestor meanwhile (a flight),
  /// as the projected frame's tiles are.
  bool waitForTiles = true;
  /// Texture draping: texels a side of the texture (Drape) or of a tile's (DrapeTiles); 0: the
  /// technique's default (2048, 256).
  int textureSize = 0;
  /// The stencil passes' savings (overlay::OverlaySettings: culling, the cover rectangle and its
  /// screen tiles, z-pass without bottom caps), as both frames' passes have them; the benchmark
  /// switches them off one at a time (overlay_bench --mode ablation). Its pads are padBase and
  /// padPerMetre above.
  overlay::OverlaySettings passes;
};

/// The overlay renderer's settings (vector_overlay/overlay_renderer.hpp) for the globe's.
overlay::OverlaySettings overlaySettingsOf(const GlobeOverlaySettings& settings);

struct GlobeOverlayStats {
  std::size_t pieces = 0;  ///< drawn (in view)
  std::size_t zFailPieces = 0;
  std::size_t culledPieces = 0;   ///< of the drawn tiles, outside the view
  std::size_t triangles = 0;      ///< of the drawn tiles' pieces
  std::size_t builtTiles = 0;     ///< this frame
  std::size_t drawnTiles = 0;     ///< this frame, with pieces (the layers' chunks)
  std::size_t drawnBytes = 0;     ///< their GPU bytes
  std::size_t residentTiles = 0;  ///< after the frame: tiles whose pieces the GPU holds
  std::size_t residentBytes = 0;  ///< and their bytes
  std::size_t evictedTiles = 0;   ///< this frame, for the budget
  std::size_t readTiles = 0;      ///< this frame, from the cache on disk (instead of built)
  std::size_t writtenTiles = 0;   ///< this frame, to the cache on disk
  std::size_t repairedTiles = 0;  ///< this frame, found damaged on disk and built again
  std::size_t prunedFolders = 0;  ///< this frame, old folders removed from the cache on disk
  std::size_t missingTiles = 0;   ///< this frame, still building (an ancestor drawn instead)
  /// GlobeTechnique::Deferred: the layers the deferred lookup drew (the last ones), and the bytes
  /// of their indices.
  std::size_t deferredLayers = 0;
  std::size_t deferredBytes = 0;
  /// Of the layers the lookup could draw, those whose indices are still being built.
  std::size_t deferredPending = 0;
  /// The bytes of every layer's indices held after the frame (those of layers no longer drawn
  /// leave once all pass a quarter of the GPU budget).
  std::size_t deferredHeldBytes = 0;
  /// Texture draping (GlobeTechnique::Drape, DrapeTiles): the terrain drew the layers; textures
  /// (or tiles of them) rasterised in this frame and the time that took, waited for; the GPU
  /// bytes the textures hold.
  bool draped = false;
  std::size_t texturesBuilt = 0;
  double textureSeconds = 0.0;
  std::size_t drapeGpuBytes = 0;
  /// The tile residency's counts for the frame (the projected frame's: stats.json's "tiles" block
  /// in both frames). Its tileErrorPixels is 0.5 (the layers' generalisation follows the drawn
  /// terrain tiles), larger where the frame's tiles would not fit the GPU budget and coarser ones
  /// were drawn (a level up per doubling; such a frame is exact only farther than that from
  /// edges); finestTileLevel the finest level drawn.
  overlay::TechniqueFrameStats tiles;
  /// Per drawn layer (in the order given, at most 32): its passes, as the projected frame counts
  /// them (overlay::OverlayRenderer's and the lookup's per-layer queries, when measured).
  std::vector<overlay::LayerFrameStats> layers;
};

/// The globe's layers over the drawn terrain tiles, drawn by the overlay renderer of both frames
/// (overlay::OverlayRenderer, docs/frames.md): each layer's pieces over each drawn tile
/// (buildTilePieces) are one chunk of the layer, an overlay::OverlayLayer of world pieces
/// (LayerGeometry::ofWorldPieces: ECEF relative to the tile's middle, caps padded along the
/// surface normals). The tiles are held by the projected frame's tile residency
/// (overlay::TileResidency: built on worker threads, kept on the GPU under the budget, coarser
/// detail where a frame's tiles would not fit it, ancestors drawn while tiles build unless
/// waitForTiles). So the stencil core's passes, its analyses (markOverlap, countOpenFaces,
/// drawPieces) and its statistics are the projected frame's, run on chunks().
class GlobeOverlayRenderer {
 public:
  GlobeOverlayRenderer();
  ~GlobeOverlayRenderer();
  GlobeOverlayRenderer(const GlobeOverlayRenderer&) = delete;
  GlobeOverlayRenderer& operator=(const GlobeOverlayRenderer&) = delete;

  /// Draws the layers in order (layer i → mask bit i) over the tiles. Needs the terrain's depth
  /// in the bound target and a zero stencil.
  void draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles, const GeoGrid& heights,
            const std::vector<const GlobeLayer*>& layers, const GlobeOverlaySettings& settings = {});
  [[nodiscard]] const GlobeOverlayStats& stats() const { return stats_; }

  /// The layer's pieces over the tiles, one chunk per tile that has any: those the last draw drew
  /// for it when it was drawn for this view and these tiles, else built (or read) and uploaded
  /// beside the last draw's (with its settings): what overlay::OverlayRenderer's draw and analyses
  /// take for a layer drawn in chunks. Valid until the next draw or chunks(). The last draw's
  /// layers must still live (their tiles are kept beside the new one's). Needs a current GL
  /// context.
  std::vector<const overlay::OverlayLayer*> chunks(const GlobeView& view, const std::vector<DrawnTile>& tiles,
                                                   const GeoGrid& heights, const GlobeLayer& layer);
  /// Texture draping (GlobeTechnique::Drape, DrapeTiles): before the terrain is drawn, the
  /// registry's `drape` or `drape-tiles` rasterises what the frame's tiles lack from the layers
  /// (GlobeDrapeSource: longitude and latitude; layer i → mask bit i), and the terrain samples
  /// what this returns (GlobeTerrain::draw). Nothing for another technique, no layers, or a
  /// technique that cannot be made (its message logged once). The target being drawn
  /// (settings.targetFramebuffer, the view's size) is left bound.
  std::optional<overlay::SurfaceDrape> prepareDrape(gfx::StateCache& cache, const GlobeView& view,
                                                    const std::vector<DrawnTile>& tiles,
                                                    const std::vector<const GlobeLayer*>& layers,
                                                    const GlobeOverlaySettings& settings);
  /// The single texture `drape` drew the last frame with (null for the others).
  [[nodiscard]] const overlay::TextureDrape* textureDrape() const;
  /// The overlay renderer (made on first use; null if its shaders do not build).
  overlay::OverlayRenderer* renderer();
  /// The GPU time of the last draw, as its caller measured it (GlobeOverlaySettings::measure).
  void measured(double milliseconds);
  /// After GlobeLayer::replaceFeature: the layer's tiles over `boxes` (what it returned) leave the
  /// GPU, to be built again when next drawn; its other tiles stay. Returns how many left.
  std::size_t featureChanged(const GlobeLayer& layer, const std::vector<LonLatRect>& boxes);

 private:
  struct Gpu;
  /// The layers' chunks for the view (the residency's frame); counts into stats_.
  std::vector<std::vector<const overlay::OverlayLayer*>> tilesFor(const GlobeView& view,
                                                                  const std::vector<DrawnTile>& tiles,
                                                                  const GeoGrid& heights,
                                                                  const std::vector<const GlobeLayer*>& layers,
                                                                  const GlobeOverlaySettings& settings);
  /// The deferred lookup's pass (made on first use; null if its shaders do not build).
  overlay::DeferredPass* deferredPass();
  /// GlobeTechnique::Stencil: the layer's pieces built once (buildWholeLoadPieces, on every core)
  /// and uploaded, their caps' reach set for the drawn tiles; null for a layer too large for it
  /// (kWholeLoadMaxTiles: said once), whose tiles draw it.
  /// GlobeTechnique::Paper (`paper`): the seed paper's construction, built the same way.
  const std::vector<overlay::OverlayLayer>* wholeLoadOf(const GlobeLayer& layer, const GeoGrid& heights,
                                                        const std::vector<DrawnTile>& tiles, bool paper);
  /// Whether the lookup may index the layer within the budget: areas always; lines in space while
  /// their primitives' estimated index at the reach class (overlay::ReachClasses::lineIndexBytes)
  /// is at most a quarter of it (else they keep their pieces).
  bool lookupFits(const GlobeLayer& layer, int reachClass, std::size_t gpuBudgetBytes);
  /// The layer's deferred indices at a reach class (lookupReach), kept per layer and class until
  /// an edit; null while they are being built (started by the first ask) unless `wait`, or when
  /// they came out larger than `maxBytes` (then dropped, and the layer drawn by its pieces at that
  /// class until an edit).
  const overlay::DeferredLayer* deferredOf(const GlobeLayer& layer, const GeoGrid& heights, int reachClass, bool wait,
                                           std::size_t maxBytes);
  /// The reach class whose index draws the layer exactly in this view: -1 for lines binned at
  /// their own widths (areas, lines in metres, lines in pixels whose largest width is within the
  /// narrowest class), the smallest class c (lines in pixels binned at 8 m × 2^c) holding the
  /// widest half width any of them can take on the drawn tiles their extent meets, or beyond
  /// every class a value above them (their pieces draw them).
  int lookupReach(const GlobeLayer& layer, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                  const GeoGrid& heights);
  std::unique_ptr<Gpu> gpu_;
  GlobeOverlayStats stats_;
};

/// The globe's depth buffer as the CPU reference reads it (overlay::DepthImage): eye-relative
/// (origin the eye, viewProj view.eyeViewProj()), so every reference function of
/// vector_overlay/cpu_reference.hpp works on it: unprojectPixel, referenceMask and edgePixels (with
/// referenceLayersOf), maskEdges, and the lasso's selectionMask.
overlay::DepthImage depthImageOf(const GlobeView& view, std::span<const float> depth);

/// The pixel scale of the camera that drew `image`, or of a view (lines in pixels), ECEF.
overlay::PixelScale pixelScaleOf(const overlay::DepthImage& image);
overlay::PixelScale pixelScaleOf(const GlobeView& view);

/// The layers as the CPU reference of both frames asks for them (overlay::FrameLayers: the mask,
/// overlay::referenceMask(image, referenceLayersOf(layers, image)), and the edge band,
/// overlay::edgePixels): their coverage as the image's camera sees it (contains, lines in pixels
/// at its widths), and a footprint straddles a layer where one of its borders passes within the
/// footprint's reach: an area's ring, or the border of a line's union of capsules (so a line
/// narrower than a pixel has its band too). Drawn shapes generalised by a fraction of a pixel
/// (simplifyTolerance, lineShapesIn) stay inside it. The borders are indexed when the edge band
/// first asks.
overlay::FrameLayersMaker referenceLayersOf(const std::vector<const GlobeLayer*>& layers,
                                            const overlay::DepthImage& image);
/// The same at a pixel scale of one's own: PixelScale{} for lines in pixels at their least
/// widths, as the layers built whole draw them (GlobeTechnique::Stencil, Paper).
overlay::FrameLayersMaker referenceLayersOf(const std::vector<const GlobeLayer*>& layers,
                                            const overlay::PixelScale& scale);

}  // namespace gis::globe

namespace gis::globe {

/// Identify: the features (GlobePolygon::feature, GlobeLine::feature: indices into the features
/// the layer was built from) whose area holds the point (ECEF, and its longitude and latitude),
/// or whose line passes within half its width of it; each once, in increasing order
/// (globe_identify.cpp).
std::vector<std::uint32_t> featuresAt(const GlobeLayer& layer, const glm::dvec3& point, double lonDeg, double latDeg,
                                      const overlay::PixelScale& scale = {});

}  // namespace gis::globe
