#pragma once
// Features kept in a file and read one at a time (issue 23, point 4: what is resident follows
// the view, not the dataset). A writer (the scene's layer cache) stores features one after
// another (binary_io.hpp: geometry, then attributes) and an index of where each starts with the
// boxes of its points; a FeatureFile holds that index (about 80 bytes a feature) and reads a
// feature from the file when asked. Reads are positioned (pread): safe from any thread at once.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "geo/feature.hpp"

namespace gis::geo {

/// Where a feature is stored and what a reader needs to know of it without reading it.
struct FeatureFileEntry {
  std::uint64_t offset = 0;    ///< first byte of the feature in the file
  std::uint64_t vertices = 0;  ///< Feature::vertexCount()
  /// Boxes of the feature's finite points: of its polygons' rings (outer and holes), and of its
  /// lines. Empty (lo > hi) when it has none.
  glm::dvec2 ringLo{1.0}, ringHi{-1.0};
  glm::dvec2 lineLo{1.0}, lineHi{-1.0};

  /// The entry of `feature` stored at `offset`.
  static FeatureFileEntry of(const Feature& feature, std::uint64_t offset);
};

class FeatureFile {
 public:
  /// The features of `path`, read through `fd` (taken: closed with this, or on failure), as
  /// `entries` index them (in file order; the last ends at `end`). The caller has verified the
  /// bytes (a checked file's section, geo/checked_file.hpp); the descriptor keeps the file read
  /// the one verified, whatever is renamed over its path later. `content`: the writer's hash of
  /// the features, for whoever keys things on them. Null with `error` set when the index does
  /// not fit the file.
  static std::shared_ptr<const FeatureFile> open(const std::string& path, int fd, std::vector<FeatureFileEntry> entries,
                                                 std::uint64_t end, std::uint64_t content, std::string* error);
  FeatureFile(const FeatureFile&) = delete;
  FeatureFile& operator=(const FeatureFile&) = delete;
  ~FeatureFile();

  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  [[nodiscard]] const FeatureFileEntry& entry(std::size_t i) const { return entries_[i]; }
  [[nodiscard]] std::uint64_t vertexCount() const { return vertices_; }
  [[nodiscard]] std::uint64_t content() const { return content_; }
  [[nodiscard]] const std::string& path() const { return path_; }
  /// Feature i as stored. Throws std::runtime_error naming the file and the feature when it
  /// cannot be read (the file was changed or damaged since it was opened).
  [[nodiscard]] Feature read(std::size_t i) const;

 private:
  FeatureFile() = default;
  std::string path_;
  int fd_ = -1;
  std::vector<FeatureFileEntry> entries_;
  std::uint64_t end_ = 0;
  std::uint64_t content_ = 0;
  std::uint64_t vertices_ = 0;
};

}  // namespace gis::geo
