#pragma once
// The logical side of lasso selection (docs/design.md §6–§7): given the steps of a selection (lasso.hpp),
// which vector features and which DEM posts are selected — in the world, not only where they
// are seen: a feature hidden behind a hill but inside the volumes is selected, as points of a
// point cloud are in the seed report.
//
// Precisely:
// - a DEM post is selected when its point (post position, height as drawn: exaggerated) is
//   selected by selectedAt; nodata posts never are. Blocks of 32 × 32 posts whose box no
//   volume's wall crosses take one answer (SelectionEvaluator::classify);
// - a feature's area on the terrain is its coverage (cpu_reference.hpp: polygons by the
//   even-odd rule, lines with their joins and caps) lifted onto the terrain by a height
//   function. It is sampled: the centres of a square grid of spacing `sampleSpacing` that the
//   feature covers, the vertices and the boundary of every ring (polygons) or the centre line
//   and both offset lines at 0.999 of the half width (lines), densified at the same spacing.
//   Samples where the height function gives NaN (no terrain) are left out. A feature is
//   selected when any sample is, fully inside when every sample is (and it has one).
//   Parts of a feature narrower than the spacing, away from its boundary, can be missed: make
//   the spacing smaller than a pixel's footprint to agree with the pixels.
// - hidden features (ReferenceLayer::visible false) are never selected.
// Batches of points whose bounding box a lasso's volume cannot reach skip that lasso's test;
// the result is bit for bit that of selectedAt on every point.
//
// The samples are not all tested (unless FeatureSelectionOptions::exhaustive): the outcome needs
// one selected sample and, to deny "fully inside", one unselected one. Runs of 32 boundary
// samples and blocks of the grid (split in four down to 64 samples) are classified first as
// boxes — their ground box between the heights the terrain takes there
// (FeatureSelectionOptions::heightBounds) — against each lasso's volume: outside, inside
// (between the near plane and the distance, its projection clear of every edge of the polygon
// by 1e-3 pixel) or unknown. Where no lasso is unknown the box has one answer, and any one of
// its samples on the terrain stands for all; a grid block that no ring edge or line primitive
// meets is covered by the feature wholly or not at all. Only the samples of blocks left unknown
// (near a volume's wall) are tested one by one, and a feature's search stops once both answers
// are found. The outcome (selected, fully inside) is exactly that of testing every sample, with
// Invert, Xor and Subtract too, where samples outside every volume are selected: a feature
// reaching out of the volumes is then selected, and it is not fully inside for a chain that
// leaves the outside unselected. The work follows the length of the walls across the features,
// not the features' area; FeatureSelection::samples counts the samples tested.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "core/height_bounds.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::overlay {

/// Height of the terrain as drawn at a frame point (exaggeration applied); NaN where there is
/// none (outside the DEM, nodata).
using TerrainHeightFunction = std::function<double(const glm::dvec2&)>;

/// Bounds of every finite height the TerrainHeightFunction gives over the ground box [lo, hi];
/// lo > hi when it gives none there (no terrain).
using TerrainBoundsFunction = std::function<HeightBounds(const glm::dvec2& lo, const glm::dvec2& hi)>;

struct FeatureSelectionOptions {
  double sampleSpacing = 5.0;  ///< metres
  /// A feature whose grid would hold more samples gets a coarser grid (reported per feature).
  std::size_t maxGridSamplesPerFeature = std::size_t{1} << 20;
  /// Widths of lines in pixels (LineShape::widthPixels) are taken from this camera; with the
  /// default zero scale only their centre lines count.
  PixelScale scale{};
  /// Heights the terrain can take (to classify boxes of samples against the volumes); the
  /// default, unbounded, classifies none: every sample is tested until both answers are found.
  double minHeight = -std::numeric_limits<double>::infinity();
  double maxHeight = std::numeric_limits<double>::infinity();
  /// Heights over a ground box, tighter than [minHeight, maxHeight] (used without it): the
  /// blocks left unknown along a wall seen at a grazing angle get narrower.
  TerrainBoundsFunction heightBounds;
  /// Every sample tested, no box classified: the same outcome at the cost of the features' area
  /// (the reference the classified search is checked against).
  bool exhaustive = false;
  /// When set, the samples tested over every feature, selected or not, are added to it.
  std::size_t* testedSamples = nullptr;
};

struct FeatureSelection {
  std::size_t feature = 0;  ///< index in the layer's features
  bool fullyInside = false;
  /// Samples on the terrain whose answer was taken: all of them when exhaustive; else those
  /// tested one by one, and one for each box answered whole that told something.
  std::size_t samples = 0;
  std::size_t selectedSamples = 0;  ///< of which selected
  double spacing = 0.0;             ///< the grid spacing used (larger than asked when capped)
};

/// The selected features of a layer, in feature order.
std::vector<FeatureSelection> selectFeatures(const ReferenceLayer& layer, std::span<const SelectionStep> steps,
                                             const TerrainHeightFunction& height,
                                             const FeatureSelectionOptions& options = {});

/// A DEM's posts: post (c, r) at origin + (c·step.x, r·step.y), heights as drawn (exaggerated),
/// row-major from row 0, NaN at nodata.
struct PostGrid {
  int width = 0;
  int height = 0;
  glm::dvec2 origin{0.0};
  glm::dvec2 step{1.0, -1.0};
  std::function<double(int col, int row)> heightAt;
};

struct PostSelection {
  std::vector<std::uint8_t> mask;  ///< width × height, 1 = selected, row 0 first
  std::size_t selected = 0;
  std::size_t posts = 0;  ///< posts with a height
};

PostSelection selectPosts(const PostGrid& grid, std::span<const SelectionStep> steps);

/// Evaluates a selection on batches of points, skipping the lassos whose volume cannot reach
/// a batch's bounding box, and classifies boxes of points against the volumes. Same answer as
/// selectedAt (geometry = true) on every point.
class SelectionEvaluator {
 public:
  explicit SelectionEvaluator(std::span<const SelectionStep> steps);
  /// out[i] = selectedAt(steps, points[i]).
  void evaluate(std::span<const glm::dvec3> points, std::vector<std::uint8_t>& out) const;
  /// Whether every point of the box [lo, hi] gets the same answer, which the steps give with no
  /// lasso containing anything (then that answer is returned).
  [[nodiscard]] std::optional<bool> constantOver(const glm::dvec3& lo, const glm::dvec3& hi) const;

  /// Where a box of points lies towards one step's volume (Invert steps: Outside).
  enum class Side : std::uint8_t { Outside, Inside, Unknown };
  /// Classifies the box [lo, hi] against every step whose entry of `sides` is Unknown (sides of
  /// a box holding this one stay true for it; start with stepCount() × Unknown). Returns the
  /// answer of every point of the box when no step is left Unknown. Conservative: Unknown when
  /// unsure.
  std::optional<bool> classify(const glm::dvec3& lo, const glm::dvec3& hi, std::vector<Side>& sides) const;
  /// selectedAt(steps, point) for a point of a box classified into `sides`.
  [[nodiscard]] bool selectedWith(const glm::dvec3& point, std::span<const Side> sides) const;
  [[nodiscard]] std::size_t stepCount() const { return steps_.size(); }

 private:
  struct Prepared {
    double nearPlane = 0.0;
    glm::dvec2 lo{0.0}, hi{0.0};  ///< the polygon's bounding box in pixels
    bool usable = false;
    /// The polygon's edges by horizontal bands of pixels: a point's band holds every edge that
    /// can cross its ray (the same crossings as lasso_geometry::insideEvenOdd, fewer tried).
    double bandY0 = 0.0, bandScale = 0.0;
    std::vector<std::uint32_t> bandStart, bandEdges;
  };
  /// Whether no point of the box lies in step k's volume (conservative: false when unsure).
  [[nodiscard]] bool misses(std::size_t k, const glm::dvec3& lo, const glm::dvec3& hi) const;
  /// Where the box lies towards step k's volume: Outside when it misses; Inside or Outside when
  /// it lies in front of the eye between the near plane and the distance and its projection
  /// keeps a margin from every edge of the polygon; else Unknown.
  [[nodiscard]] Side sideOf(std::size_t k, const glm::dvec3& lo, const glm::dvec3& hi) const;
  [[nodiscard]] bool insideStep(std::size_t k, const glm::dvec3& point) const;
  [[nodiscard]] bool chainWith(const std::vector<std::uint8_t>& inside) const;

  std::span<const SelectionStep> steps_;
  std::vector<Prepared> prepared_;
};

}  // namespace gis::overlay
