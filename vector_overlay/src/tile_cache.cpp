#include "tile_cache.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>
#include <thread>
#include <type_traits>

#include <unistd.h>

#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"

namespace gis::overlay::detail {
namespace {

constexpr std::uint32_t kMagic = 0x54564753;  // "SGVT"
constexpr std::uint32_t kVersion = 5;         // 4: checked sections (geo/checked_file.hpp); 5: world pieces
/// No coordinate or height of a piece lies beyond this (ValidationOptions::maxCoordinate).
constexpr double kMaxCoordinate = 1e15;
using geo::io::Reader;
using geo::io::Writer;

void writePiece(Writer& w, const Polyhedron& p) {
  const Footprint& f = p.footprint;
  w.value(f.feature);
  w.value(f.cell);
  w.value(f.source);
  w.value(static_cast<std::uint8_t>(f.kind));
  w.array(f.vertices);
  w.array(f.triangles);
  w.array(f.boundary);
  w.array(f.centres);
  w.array(f.directions);
  w.value(p.lo);
  w.value(p.hi);
  w.value(static_cast<std::uint8_t>(p.overSurface ? 1 : 0));
  w.value(p.boxMin);
  w.value(p.boxMax);
}

bool readPiece(Reader& r, Polyhedron& p) {
  Footprint& f = p.footprint;
  std::uint8_t kind = 0, over = 0;
  if (!r.value(f.feature) || !r.value(f.cell) || !r.value(f.source) || !r.value(kind) || kind > 4) return false;
  f.kind = static_cast<PieceKind>(kind);
  if (!r.array(f.vertices) || !r.array(f.triangles) || !r.array(f.boundary) || !r.array(f.centres) ||
      !r.array(f.directions))
    return false;
  if (!r.value(p.lo) || !r.value(p.hi) || !r.value(over) || !r.value(p.boxMin) || !r.value(p.boxMax)) return false;
  p.overSurface = over != 0;
  // What validation asks of a piece's numbers (validation.hpp): finite, within ±1e15 m, lo ≤ hi,
  // and a box that is one (fuzzing found a piece with hi = -5e300 below lo read as it was).
  const auto bounded = [](double v) { return std::isfinite(v) && std::abs(v) <= kMaxCoordinate; };
  const auto boundedPoint = [&](const glm::dvec2& v) { return bounded(v.x) && bounded(v.y); };
  if (!bounded(p.lo) || !bounded(p.hi) || p.lo > p.hi || !boundedPoint(p.boxMin) || !boundedPoint(p.boxMax) ||
      p.boxMin.x > p.boxMax.x || p.boxMin.y > p.boxMax.y)
    return false;
  if (!std::all_of(f.vertices.begin(), f.vertices.end(), boundedPoint)) return false;
  for (const glm::dvec3& c : f.centres)
    if (!boundedPoint(glm::dvec2(c)) || !bounded(c.z)) return false;
  for (const glm::dvec2& d : f.directions)
    if (!std::isfinite(d.x) || !std::isfinite(d.y)) return false;
  // Indices within the piece's vertices (a damaged file must not index out of bounds).
  for (const auto& t : f.triangles)
    for (const std::uint32_t k : t)
      if (k >= f.vertices.size()) return false;
  for (const auto& e : f.boundary)
    for (const std::uint32_t k : e)
      if (k >= f.vertices.size()) return false;
  return f.centres.empty() || (f.centres.size() == f.vertices.size() && f.directions.size() == f.vertices.size());
}

}  // namespace

std::filesystem::path tileFileIn(const std::filesystem::path& folder, const TileKey& key) {
  return folder / (std::to_string(key.level) + "-" + std::to_string(key.x) + "-" + std::to_string(key.y) +
                   (key.width > 0 ? "-w" + std::to_string(key.width) : std::string()) + ".tile");
}

bool writeTile(const std::filesystem::path& file, std::uint64_t fingerprint, const LayerTile& tile) {
  // Two programs (or two renderers' workers) may write the same tile at once: each its own
  // temporary file, renamed into place. Three checked sections: the header, the lean tile, the
  // whole tile.
  return geo::io::writeCheckedFile(file,
                                   [&](std::ostream& out, geo::io::SectionMarks& marks) {
                                     Writer w(out);
                                     marks.begin();
                                     w.value(kMagic);
                                     w.value(kVersion);
                                     w.value(fingerprint);
                                     w.value(tile.key.level);
                                     w.value(tile.key.x);
                                     w.value(tile.key.y);
                                     w.value(tile.key.width);
                                     w.value(tile.groundError);
                                     const LayerGeometry& g = tile.geometry;
                                     // The lean section: the tile as a far view draws it, read with a few large reads.
                                     marks.begin();
                                     w.array(tile.featureIndex);
                                     g.writeLean(w);
                                     // The whole section: features and pieces with their footprints
                                     // (world pieces have neither: lean is whole for them).
                                     marks.begin();
                                     if (g.alongNormals()) {
                                       w.value(std::uint64_t{0});
                                       return;
                                     }
                                     w.value(static_cast<std::uint64_t>(g.features().size()));
                                     // Per feature: its index in the layer, its geometry, its live pieces.
                                     std::vector<std::vector<std::size_t>> slotsOf(g.features().size());
                                     for (std::size_t s = 0; s < g.slots().size(); ++s)
                                       if (g.slots()[s].live) slotsOf[g.slots()[s].feature].push_back(s);
                                     for (std::size_t i = 0; i < g.features().size(); ++i) {
                                       w.value(tile.featureIndex.at(i));
                                       geo::io::writeGeometry(w, g.features()[i]);
                                       w.value(static_cast<std::uint64_t>(slotsOf[i].size()));
                                       for (const std::size_t s : slotsOf[i]) writePiece(w, g.polyhedra()[s]);
                                     }
                                   })
      .written;
}

namespace {

/// Opens a tile file and checks its header section: whether it holds this format, fingerprint
/// and key (its ground error). Null when missing; `damage` says why a file that is there was not
/// used (any file under the tile's name that fails is damaged: its name says what it holds).
std::shared_ptr<const geo::io::CheckedFile> openTile(const std::filesystem::path& file, std::uint64_t fingerprint,
                                                     const TileKey& key, double& error, std::string* damage) {
  geo::io::CheckedStatus status = geo::io::CheckedStatus::Missing;
  std::string why;
  std::shared_ptr<const geo::io::CheckedFile> checked = geo::io::CheckedFile::open(file, status, why);
  const auto damaged = [&](const std::string& what) {
    if (damage != nullptr) *damage = what;
    return nullptr;
  };
  if (!checked) return status == geo::io::CheckedStatus::Damaged ? damaged(why) : nullptr;
  if (checked->sections() != 3) return damaged("not a tile file");
  const std::optional<std::string> header = checked->read(0);
  if (!header) return damaged("its header does not match its checksum");
  std::istringstream in(*header);
  Reader r(in);
  std::uint32_t magic = 0, version = 0;
  std::uint64_t stored = 0;
  TileKey k;
  if (!(r.value(magic) && magic == kMagic && r.value(version) && version == kVersion && r.value(stored) &&
        stored == fingerprint && r.value(k.level) && r.value(k.x) && r.value(k.y) && r.value(k.width) && k == key &&
        r.value(error)))
    return damaged("its header is not this tile's");
  return checked;
}

/// A lean tile's GPU arrays, left in its file for the upload (ArraysInFile), read through a copy
/// of the descriptor that was verified (null when it cannot be copied: then read whole).
std::shared_ptr<ArraysInFile> arraysIn(const geo::io::CheckedFile& checked) {
  const int fd = ::dup(checked.descriptor());
  return fd >= 0 ? std::make_shared<ArraysInFile>(fd) : nullptr;
}

}  // namespace

std::optional<std::size_t> tileBytes(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key) {
  double error = 0.0;
  const std::shared_ptr<const geo::io::CheckedFile> checked = openTile(file, fingerprint, key, error, nullptr);
  if (!checked) return std::nullopt;
  return static_cast<std::size_t>(checked->section(1).length);
}

std::optional<LayerTile> readTile(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key,
                                  const LayerGeometry& source, const HeightBoundsProvider& bounds,
                                  const LayerBuildOptions& options,
                                  const std::function<FeatureStyle(std::uint32_t)>& styleOf, bool lean,
                                  std::string* damage) {
  double error = 0.0;
  const std::shared_ptr<const geo::io::CheckedFile> checked = openTile(file, fingerprint, key, error, damage);
  if (!checked) return std::nullopt;
  const auto damaged = [&](const std::string& what) {
    if (damage != nullptr) *damage = what;
    return std::nullopt;
  };
  // Every byte used is verified first; all of them are read through the one descriptor opened
  // and checked (a writer renaming a new file into place meanwhile changes nothing here).
  const std::size_t section = lean ? 1 : 2;
  if (!checked->verify(section))
    return damaged(lean ? "its lean tile does not match its checksum" : "its pieces do not match their checksum");
  geo::io::SectionStream in(*checked, section);
  Reader r(in);
  if (lean) {
    std::shared_ptr<ArraysInFile> arrays = arraysIn(*checked);
    std::vector<std::uint32_t> index;
    if (!r.array(index)) return damaged("its lean tile cannot be read");
    std::vector<FeatureStyle> styles(index.size());
    for (std::size_t i = 0; i < index.size(); ++i) {
      if (index[i] >= source.sharedFeatures().size()) return damaged("it names features the layer does not have");
      styles[i] = styleOf(index[i]);
    }
    std::optional<LayerGeometry> g = LayerGeometry::readLean(r, source.name(), source.kind(), source.style(),
                                                             std::move(styles), bounds, options, std::move(arrays));
    if (!g) return damaged("its lean tile cannot be read");
    return LayerTile{key, std::move(*g), std::move(index), error, true};
  }
  std::size_t count = 0;
  // A feature takes at least its index, fid, three counts; a piece over 100 bytes.
  if (!r.count(count, 36)) return damaged("its pieces cannot be read");
  std::vector<geo::Feature> features(count);
  std::vector<FeatureStyle> styles(count);
  std::vector<std::vector<Polyhedron>> pieces(count);
  std::vector<std::uint32_t> index(count);
  for (std::size_t i = 0; i < count; ++i) {
    std::size_t n = 0;
    if (!r.value(index[i]) || index[i] >= source.sharedFeatures().size() || !geo::io::readGeometry(r, features[i]) ||
        !r.count(n, 100))
      return damaged("its pieces cannot be read");
    styles[i] = styleOf(index[i]);
    pieces[i].resize(n);
    for (Polyhedron& p : pieces[i]) {
      if (!readPiece(r, p)) return damaged("its pieces cannot be read");
      p.footprint.feature = static_cast<std::uint32_t>(i);
    }
  }
  LayerTile tile{key,
                 LayerGeometry::assemble(source.name(), source.kind(), source.style(), std::move(features),
                                         std::move(styles), std::move(pieces), bounds, options),
                 std::move(index), error, true};
  return tile;
}

std::optional<LayerTile> readWorldTile(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key,
                                       const std::string& name, std::span<const glm::vec4> groupColours, bool lean,
                                       std::string* damage) {
  double error = 0.0;
  const std::shared_ptr<const geo::io::CheckedFile> checked = openTile(file, fingerprint, key, error, damage);
  if (!checked) return std::nullopt;
  const auto damaged = [&](const std::string& what) {
    if (damage != nullptr) *damage = what;
    return std::nullopt;
  };
  if (!checked->verify(1)) return damaged("its lean tile does not match its checksum");
  geo::io::SectionStream in(*checked, 1);
  Reader r(in);
  std::shared_ptr<ArraysInFile> arrays = lean ? arraysIn(*checked) : nullptr;
  std::vector<std::uint32_t> index;
  if (!r.array(index) || !index.empty()) return damaged("its lean tile cannot be read");
  std::vector<FeatureStyle> styles(groupColours.size());
  for (std::size_t g = 0; g < styles.size(); ++g) styles[g].color = groupColours[g];
  std::optional<LayerGeometry> g = LayerGeometry::readWorldLean(r, name, std::move(styles), std::move(arrays));
  if (!g) return damaged("its lean tile cannot be read");
  return LayerTile{key, std::move(*g), {}, error, true};
}

}  // namespace gis::overlay::detail

namespace gis::overlay {

std::size_t pruneTileFolders(const std::filesystem::path& directory, const std::filesystem::path& folder,
                             std::uintmax_t budget) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(folder, ec);
  const fs::file_time_type now = fs::file_time_type::clock::now();
  fs::last_write_time(folder, now, ec);  // opened now
  struct Entry {
    fs::path path;
    fs::file_time_type used;
    std::uintmax_t bytes = 0;
  };
  std::vector<Entry> others;
  std::uintmax_t total = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(directory, ec)) {
    if (!e.is_directory(ec)) continue;
    Entry entry{e.path(), e.last_write_time(ec), 0};
    for (const fs::directory_entry& f : fs::recursive_directory_iterator(e.path(), ec))
      if (f.is_regular_file(ec)) entry.bytes += f.file_size(ec);
    total += entry.bytes;
    if (!fs::equivalent(e.path(), folder, ec)) others.push_back(std::move(entry));
  }
  std::sort(others.begin(), others.end(), [](const Entry& a, const Entry& b) { return a.used < b.used; });
  std::size_t removed = 0;
  for (const Entry& e : others) {
    const auto idle = now - e.used;
    if (idle < std::chrono::minutes(10)) continue;
    if (total <= budget && idle < std::chrono::hours(24 * 30)) continue;
    if (fs::remove_all(e.path, ec) > 0 && !ec) {
      total -= std::min(total, e.bytes);
      ++removed;
    }
  }
  return removed;
}

}  // namespace gis::overlay
