#include "geo/feature_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "geo/binary_io.hpp"

namespace gis::geo {
namespace {

void grow(glm::dvec2& lo, glm::dvec2& hi, const std::vector<glm::dvec2>& points) {
  for (const glm::dvec2& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    if (lo.x > hi.x) {
      lo = hi = p;
      continue;
    }
    lo = glm::dvec2(std::min(lo.x, p.x), std::min(lo.y, p.y));
    hi = glm::dvec2(std::max(hi.x, p.x), std::max(hi.y, p.y));
  }
}

/// A box as FeatureFileEntry::of leaves it: empty (no finite point), or finite and ordered.
bool wellFormed(const glm::dvec2& lo, const glm::dvec2& hi) {
  if (lo == glm::dvec2(1.0) && hi == glm::dvec2(-1.0)) return true;
  return std::isfinite(lo.x) && std::isfinite(lo.y) && std::isfinite(hi.x) && std::isfinite(hi.y) && lo.x <= hi.x &&
         lo.y <= hi.y;
}

bool sameBoxes(const FeatureFileEntry& a, const FeatureFileEntry& b) {
  return a.ringLo == b.ringLo && a.ringHi == b.ringHi && a.lineLo == b.lineLo && a.lineHi == b.lineHi;
}

}  // namespace

FeatureFileEntry FeatureFileEntry::of(const Feature& feature, std::uint64_t offset) {
  FeatureFileEntry e;
  e.offset = offset;
  e.vertices = feature.vertexCount();
  for (const Polygon& p : feature.polygons) {
    grow(e.ringLo, e.ringHi, p.outer);
    for (const Ring& h : p.holes) grow(e.ringLo, e.ringHi, h);
  }
  for (const LineString& l : feature.lines) grow(e.lineLo, e.lineHi, l);
  return e;
}

std::shared_ptr<const FeatureFile> FeatureFile::open(const std::string& path, int fd,
                                                     std::vector<FeatureFileEntry> entries, std::uint64_t end,
                                                     std::uint64_t content, std::string* error) {
  const auto fail = [&](const std::string& why) {
    if (error != nullptr) *error = path + ": " + why;
    return std::shared_ptr<const FeatureFile>();
  };
  std::shared_ptr<FeatureFile> file(new FeatureFile());
  file->path_ = path;
  file->fd_ = fd;
  if (file->fd_ < 0) return fail("cannot be opened");
  struct stat st {};
  if (::fstat(file->fd_, &st) != 0 || st.st_size < 0 || static_cast<std::uint64_t>(st.st_size) < end)
    return fail("shorter than its index says");
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    // Where each feature starts, in order; the boxes a tiling buckets it by, as
    // FeatureFileEntry::of makes them (an infinite one would reach its integer bucket indices).
    if ((i > 0 && entries[i].offset <= previous) || entries[i].offset >= end ||
        !wellFormed(entries[i].ringLo, entries[i].ringHi) || !wellFormed(entries[i].lineLo, entries[i].lineHi))
      return fail("its index is damaged");
    previous = entries[i].offset;
    file->vertices_ += entries[i].vertices;
  }
  file->entries_ = std::move(entries);
  file->end_ = end;
  file->content_ = content;
  return file;
}

FeatureFile::~FeatureFile() {
  if (fd_ >= 0) ::close(fd_);
}

Feature FeatureFile::read(std::size_t i) const {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error(path_ + ": feature " + std::to_string(i) + " cannot be read (" + why + ")");
  };
  if (i >= entries_.size()) fail("no such feature");
  const std::uint64_t begin = entries_[i].offset;
  const std::uint64_t stop = i + 1 < entries_.size() ? entries_[i + 1].offset : end_;
  std::string bytes(static_cast<std::size_t>(stop - begin), '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::pread(fd_, bytes.data() + got, bytes.size() - got, static_cast<off_t>(begin + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail(n < 0 ? std::strerror(errno) : "the file is shorter than when it was opened");
    got += static_cast<std::size_t>(n);
  }
  std::istringstream in(std::move(bytes));
  io::Reader r(in);
  Feature f;
  if (!io::readGeometry(r, f) || !io::readAttributes(r, f)) fail("damaged");
  // The feature is what its entry says: as many vertices, in the same boxes (a tiling chose
  // the tiles it reaches by them; fuzzing found an index whose boxes were not its features').
  if (f.vertexCount() != entries_[i].vertices || !sameBoxes(FeatureFileEntry::of(f, begin), entries_[i]))
    fail("changed since it was indexed");
  return f;
}

}  // namespace gis::geo
