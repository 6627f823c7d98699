#pragma once
// Feature labels for the viewer: the text of a chosen attribute, a ground anchor per feature
// (computed once per layer) and, every frame, a placement of the projected labels on the screen
// with no two overlapping. No GL and no ImGui here: the viewer projects the anchors, measures the
// text and draws what placeLabels() accepts.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "geo/feature.hpp"

namespace gis::app {

// ---- Anchors on the ground (once per layer) ----

/// How closely polygonLabelPoint() searches for the interior point farthest from the boundary.
/// The search stops when no unexplored cell can beat the best point by more than the larger of
/// the two tolerances, so the point's clearance is at least optimum - tolerance (unless maxCells
/// runs out first: then the best point found, still inside).
struct AnchorOptions {
  double relativeTolerance = 0.02;  ///< of the best clearance found so far
  double toleranceMetres = 0.0;     ///< absolute
  int maxCells = 10000;             ///< distance evaluations at most; bounds the time for huge rings
};

/// A point inside a polygon and its distance to the nearest edge of the outer ring or a hole.
struct InteriorPoint {
  glm::dvec2 point{0.0};
  double clearance = 0.0;  ///< metres; 0 only for a polygon with no area
};

/// The pole of inaccessibility of one polygon (holes count as boundary), found by a quadtree
/// search over its bounding box: never outside the outer ring nor inside a hole.
InteriorPoint polygonLabelPoint(const geo::Polygon& polygon, const AnchorOptions& options = {});

/// The point halfway along a line's length; its first point if it has no length.
glm::dvec2 lineMidpoint(const geo::LineString& line);

/// Where a feature's label stands on the ground (frame x/y, metres); the viewer adds the terrain
/// height there.
struct LabelAnchor {
  glm::dvec2 point{0.0};
  glm::dvec2 boundsMin{0.0};  ///< the whole feature's extent, for skipping features out of view
  glm::dvec2 boundsMax{0.0};
  /// Polygons: the labelled part's area (m²); lines: the labelled part's length (m). A hint
  /// for the caller's priorities.
  double partSize = 0.0;
  double clearance = 0.0;  ///< polygons: the anchor's distance to the part's boundary; lines: 0
};

/// The anchor of a feature: for polygons the label point of the part with the largest area
/// (outer minus holes), else for lines the midpoint of the longest part. None for a feature
/// with neither.
std::optional<LabelAnchor> featureLabelAnchor(const geo::Feature& feature, const AnchorOptions& options = {});

/// A feature's attribute as label text: strings as they are, integers in decimal, reals in
/// their shortest exact form. None when the attribute is missing, null or an empty string.
std::optional<std::string> labelText(const geo::Feature& feature, const std::string& attribute);

struct FeatureLabel {
  std::size_t feature = 0;  ///< index into the layer's features
  std::int64_t fid = -1;
  std::string text;
  LabelAnchor anchor;
};

/// Text and anchor of every feature that has both, in the layer's order.
std::vector<FeatureLabel> layerLabels(std::span<const geo::Feature> features, const std::string& attribute,
                                      const AnchorOptions& options = {});

// ---- Placement on the screen (every frame) ----

/// An axis-aligned rectangle in pixels, y down as ImGui has it: [min, max].
struct ScreenRect {
  glm::vec2 min{0.0F};
  glm::vec2 max{0.0F};
};

/// Where a label goes relative to its anchor.
enum class LabelPosition : std::uint8_t { Centred, Above, Below, Right, Left };

struct LabelCandidate {
  glm::vec2 anchor{0.0F};  ///< the projected ground anchor, pixels
  glm::vec2 size{0.0F};    ///< the text's width and height, pixels
  double priority = 0.0;   ///< higher is placed first (the caller decides: larger, nearer, ...)
  std::int64_t id = 0;     ///< breaks ties in priority (lower first); unique per candidate
};

struct LabelLayout {
  ScreenRect screen;
  float margin = 4.0F;              ///< labels keep this far from the screen's edges and the blocked rectangles
  float padding = 2.0F;             ///< and this far from each other
  std::vector<ScreenRect> blocked;  ///< e.g. the panel and the HUD
  /// Tried in this order until one fits; a label placed in the previous frame (LabelPlacer)
  /// tries its previous position first.
  std::vector<LabelPosition> positions = {LabelPosition::Centred, LabelPosition::Above, LabelPosition::Below,
                                          LabelPosition::Right, LabelPosition::Left};
  float offset = 3.0F;  ///< gap between the anchor and a label that is not centred on it
  /// Added to the priority of a candidate whose id was placed in the previous frame, so labels
  /// do not flicker while the camera moves; +infinity: previous labels always go first (among
  /// themselves by id).
  double stabilityBonus = 0.0;
};

struct PlacedLabel {
  std::int64_t id = 0;
  std::uint32_t candidate = 0;  ///< index into the candidates
  ScreenRect rect;
  LabelPosition position = LabelPosition::Centred;
};

/// The rectangle of a label at a position around its anchor.
ScreenRect labelRect(const LabelCandidate& candidate, LabelPosition position, float offset);

/// Places the candidates greedily by priority (ties by id): each takes the first position whose
/// rectangle lies on the screen within the margins, outside the blocked rectangles and at least
/// `padding` from every label placed before it; a candidate with no such position is left out.
/// The result is in placement order. Overlap queries go through a uniform grid, so the time is
/// about linear in the candidates after the sort.
class LabelPlacer {
 public:
  /// `previousIds`: the ids placed in the previous frame, in any order; they get the stability
  /// bonus. The returned labels stay valid until the next call.
  const std::vector<PlacedLabel>& place(std::span<const LabelCandidate> candidates, const LabelLayout& layout,
                                        std::span<const std::int64_t> previousIds);
  /// As above with this placer's own previous result as the previous frame: its ids get the
  /// bonus and each tries its previous position first.
  const std::vector<PlacedLabel>& place(std::span<const LabelCandidate> candidates, const LabelLayout& layout);
  /// Forgets the previous frame (e.g. when the layer or the attribute changes).
  void forget();

 private:
  struct Previous {
    std::int64_t id;
    std::optional<LabelPosition> position;  ///< none: only the ids were given
  };
  struct Ranked {
    double key;  ///< priority plus any stability bonus
    std::int64_t id;
    std::uint32_t index;
    const Previous* previous;  ///< this id in the previous frame, if it was placed
  };
  struct CellRange {
    int x0, y0, x1, y1;
  };
  void run(std::span<const LabelCandidate> candidates, const LabelLayout& layout);
  bool buildGrid(std::span<const LabelCandidate> candidates, const LabelLayout& layout);
  [[nodiscard]] CellRange cellsOf(const ScreenRect& r) const;
  [[nodiscard]] bool fits(const ScreenRect& r) const;
  void insert(const ScreenRect& r);

  std::vector<Previous> previous_;  ///< sorted by id
  std::vector<PlacedLabel> placed_;
  std::vector<Ranked> order_;
  std::vector<ScreenRect> obstacles_;  ///< placed labels grown by padding, blocked ones by margin
  std::vector<std::vector<std::uint32_t>> cells_;
  ScreenRect usable_;
  glm::vec2 gridOrigin_{0.0F};
  float cellSize_ = 1.0F;
  int columns_ = 0;
  int rows_ = 0;
};

/// One frame without a placer kept between frames.
std::vector<PlacedLabel> placeLabels(std::span<const LabelCandidate> candidates, const LabelLayout& layout,
                                     std::span<const std::int64_t> previousIds = {});

}  // namespace gis::app
