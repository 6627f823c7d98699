#pragma once
// The logical side of lasso selection (DESIGN §6–§7): given the steps of a selection (lasso.hpp),
// which vector features and which DEM posts are selected — in the world, not only where they
// are seen: a feature hidden behind a hill but inside the volumes is selected, as points of a
// point cloud are in the seed report.
//
// Precisely:
// - a DEM post is selected when its point (post position, height as drawn: exaggerated) is
//   selected by selectedAt; nodata posts never are;
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
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/footprints.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::overlay {

/// Height of the terrain as drawn at a frame point (exaggeration applied); NaN where there is
/// none (outside the DEM, nodata).
using TerrainHeightFunction = std::function<double(const glm::dvec2&)>;

struct FeatureSelectionOptions {
  double sampleSpacing = 5.0;  ///< metres
  /// A feature whose grid would hold more samples gets a coarser grid (reported per feature).
  std::size_t maxGridSamplesPerFeature = std::size_t{1} << 20;
  /// Widths of lines in pixels (LineShape::widthPixels) are taken from this camera; with the
  /// default zero scale only their centre lines count.
  PixelScale scale{};
  /// Heights the terrain can take (used to skip features no volume reaches before sampling
  /// them); the default, unbounded, never skips.
  double minHeight = -std::numeric_limits<double>::infinity();
  double maxHeight = std::numeric_limits<double>::infinity();
};

struct FeatureSelection {
  std::size_t feature = 0;  ///< index in the layer's features
  bool fullyInside = false;
  std::size_t samples = 0;          ///< samples on the terrain
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
/// a batch's bounding box. Same answer as selectedAt (geometry = true) on every point.
class SelectionEvaluator {
 public:
  explicit SelectionEvaluator(std::span<const SelectionStep> steps);
  /// out[i] = selectedAt(steps, points[i]).
  void evaluate(std::span<const glm::dvec3> points, std::vector<std::uint8_t>& out) const;
  /// Whether every point of the box [lo, hi] gets the same answer, which the steps give with no
  /// lasso containing anything (then that answer is returned).
  [[nodiscard]] std::optional<bool> constantOver(const glm::dvec3& lo, const glm::dvec3& hi) const;

 private:
  struct Prepared {
    double nearPlane = 0.0;
    glm::dvec2 lo{0.0}, hi{0.0};  ///< the polygon's bounding box in pixels
    bool usable = false;
  };
  /// Whether no point of the box lies in step k's volume (conservative: false when unsure).
  [[nodiscard]] bool misses(std::size_t k, const glm::dvec3& lo, const glm::dvec3& hi) const;
  [[nodiscard]] bool chainWith(const std::vector<std::uint8_t>& inside) const;

  std::span<const SelectionStep> steps_;
  std::vector<Prepared> prepared_;
};

}  // namespace gis::overlay
