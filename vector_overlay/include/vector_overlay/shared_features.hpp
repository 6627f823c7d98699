#pragma once
// A layer's features, held once however many hold them (docs/design.md §5, issue 23 point 4): in
// memory, shared with whoever else holds them (the scene that read them, the layer's outline, a
// rebuild for another style) and copied only when edited while shared; or kept in a file
// (geo::FeatureFile) and read one at a time, so that what is resident follows the tiles being
// built, not the dataset. Reads are const and safe from any thread; edits are not.
#include <cstddef>
#include <initializer_list>
#include <memory>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "geo/feature.hpp"
#include "geo/feature_file.hpp"

namespace gis::overlay {

class SharedFeatures {
 public:
  SharedFeatures() : features_(std::make_shared<std::vector<geo::Feature>>()) {}
  // NOLINTNEXTLINE(google-explicit-constructor): a vector of features is taken as is
  SharedFeatures(std::vector<geo::Feature> features)
      : features_(std::make_shared<std::vector<geo::Feature>>(std::move(features))) {}
  SharedFeatures(std::initializer_list<geo::Feature> features)
      : features_(std::make_shared<std::vector<geo::Feature>>(features)) {}
  // NOLINTNEXTLINE(google-explicit-constructor)
  SharedFeatures(std::shared_ptr<const std::vector<geo::Feature>> features)
      : features_(features ? std::move(features) : std::make_shared<const std::vector<geo::Feature>>()) {}
  /// The features of `file`, read when asked (get), all of them only if all() is called.
  explicit SharedFeatures(std::shared_ptr<const geo::FeatureFile> file);

  [[nodiscard]] std::size_t size() const;
  /// Feature i: in memory the feature itself (no copy), on disk read from the file (throws
  /// std::runtime_error naming the file if it cannot be read).
  [[nodiscard]] std::shared_ptr<const geo::Feature> get(std::size_t i) const;
  /// The box of feature i's finite points: of its lines (`lines`) or of its polygons' rings;
  /// empty (lo > hi) when it has none. From the file's index on disk: nothing is read.
  [[nodiscard]] std::pair<glm::dvec2, glm::dvec2> box(std::size_t i, bool lines) const;
  /// Every source vertex (Feature::vertexCount summed); from the index on disk.
  [[nodiscard]] std::size_t vertexCount() const;
  /// All features in memory. On disk they are read once, on the first call, and kept: for the
  /// whole-load techniques, the CPU reference and edits, not for what draws per tile.
  [[nodiscard]] const std::vector<geo::Feature>& all() const;
  [[nodiscard]] const geo::Feature& operator[](std::size_t i) const { return all()[i]; }
  /// Whether the features are read from a file one at a time (all() has not been called).
  [[nodiscard]] bool onDisk() const;
  /// A hash of the features stated by their file (FeatureFile::content), 0 in memory.
  [[nodiscard]] std::uint64_t fileContent() const;
  /// The features' polygon rings as lines, one line feature per feature (a polygon layer's
  /// outline; fids kept, no attributes): computed now in memory, per read on disk.
  [[nodiscard]] SharedFeatures outlines() const;
  /// Whether another holder shares these features (an edit would copy them first).
  [[nodiscard]] bool shared() const;
  /// The features to change: read into memory first on disk, copied first while shared.
  [[nodiscard]] std::vector<geo::Feature>& edit();

 private:
  struct Disk;
  std::shared_ptr<const std::vector<geo::Feature>> features_;  ///< in memory (null on disk)
  std::shared_ptr<Disk> disk_;                                 ///< on disk
};

/// A polygon feature's rings as lines (outer ring and holes, each closed), fid kept.
geo::Feature outlineOf(const geo::Feature& polygon);

}  // namespace gis::overlay
