#include "vector_overlay/shared_features.hpp"

#include <mutex>

namespace gis::overlay {

struct SharedFeatures::Disk {
  std::shared_ptr<const geo::FeatureFile> file;
  bool outlines = false;  ///< read as outlineOf(feature)
  std::once_flag once;
  std::shared_ptr<const std::vector<geo::Feature>> loaded;  ///< all(), once called
};

namespace {

/// Feature f's box as a file's index gives it (geo::FeatureFileEntry::of): one rule for both.
std::pair<glm::dvec2, glm::dvec2> boxOf(const geo::Feature& f, bool lines) {
  const geo::FeatureFileEntry e = geo::FeatureFileEntry::of(f, 0);
  return lines ? std::pair{e.lineLo, e.lineHi} : std::pair{e.ringLo, e.ringHi};
}

}  // namespace

geo::Feature outlineOf(const geo::Feature& polygon) {
  geo::Feature line;
  line.fid = polygon.fid;
  line.attributes = polygon.attributes;
  const auto add = [&line](const geo::Ring& ring) {
    if (ring.size() < 2) return;
    geo::LineString closed = ring;
    closed.push_back(ring.front());
    line.lines.push_back(std::move(closed));
  };
  for (const geo::Polygon& p : polygon.polygons) {
    add(p.outer);
    for (const geo::Ring& h : p.holes) add(h);
  }
  return line;
}

SharedFeatures::SharedFeatures(std::shared_ptr<const geo::FeatureFile> file) : disk_(std::make_shared<Disk>()) {
  disk_->file = std::move(file);
}

std::size_t SharedFeatures::size() const { return features_ ? features_->size() : disk_->file->size(); }

std::shared_ptr<const geo::Feature> SharedFeatures::get(std::size_t i) const {
  if (features_) return {features_, &(*features_)[i]};  // shares the vector's ownership
  if (disk_->loaded) return {disk_->loaded, &(*disk_->loaded)[i]};
  geo::Feature f = disk_->file->read(i);
  return std::make_shared<const geo::Feature>(disk_->outlines ? outlineOf(f) : std::move(f));
}

std::pair<glm::dvec2, glm::dvec2> SharedFeatures::box(std::size_t i, bool lines) const {
  if (features_) return boxOf((*features_)[i], lines);
  const geo::FeatureFileEntry& e = disk_->file->entry(i);
  // An outline's lines are its rings (closing each adds a point already in the box).
  if (lines && !disk_->outlines) return {e.lineLo, e.lineHi};
  if (lines || !disk_->outlines) return {e.ringLo, e.ringHi};
  return {glm::dvec2(1.0), glm::dvec2(-1.0)};  // an outline has no polygons
}

std::size_t SharedFeatures::vertexCount() const {
  if (features_) {
    std::size_t n = 0;
    for (const geo::Feature& f : *features_) n += f.vertexCount();
    return n;
  }
  return static_cast<std::size_t>(disk_->file->vertexCount());  // an outline's: before closing its rings
}

const std::vector<geo::Feature>& SharedFeatures::all() const {
  if (features_) return *features_;
  std::call_once(disk_->once, [this] {
    std::vector<geo::Feature> features(disk_->file->size());
    for (std::size_t i = 0; i < features.size(); ++i) {
      geo::Feature f = disk_->file->read(i);
      features[i] = disk_->outlines ? outlineOf(f) : std::move(f);
    }
    disk_->loaded = std::make_shared<const std::vector<geo::Feature>>(std::move(features));
  });
  return *disk_->loaded;
}

bool SharedFeatures::onDisk() const { return !features_ && !disk_->loaded; }

std::uint64_t SharedFeatures::fileContent() const {
  if (features_) return 0;
  // The same file read as outlines is other features.
  return disk_->outlines ? disk_->file->content() * 0x9E3779B97F4A7C15ULL + 1U : disk_->file->content();
}

SharedFeatures SharedFeatures::outlines() const {
  if (features_ || disk_->loaded || disk_->outlines) {
    const std::vector<geo::Feature>& polygons = all();
    std::vector<geo::Feature> out;
    out.reserve(polygons.size());
    for (const geo::Feature& f : polygons) out.push_back(outlineOf(f));
    return SharedFeatures(std::move(out));
  }
  SharedFeatures s(disk_->file);
  s.disk_->outlines = true;
  return s;
}

bool SharedFeatures::shared() const {
  return features_ ? features_.use_count() > 1 : true;  // a file is everyone's
}

std::vector<geo::Feature>& SharedFeatures::edit() {
  if (!features_) {
    features_ = std::make_shared<std::vector<geo::Feature>>(all());
    disk_.reset();
  } else if (features_.use_count() > 1) {
    features_ = std::make_shared<std::vector<geo::Feature>>(*features_);
  }
  // Ours alone now, and made by us as a non-const vector (make_shared above or in a
  // constructor, or a caller's shared vector no one else holds any more).
  return const_cast<std::vector<geo::Feature>&>(*features_);  // NOLINT(cppcoreguidelines-pro-type-const-cast)
}

}  // namespace gis::overlay
