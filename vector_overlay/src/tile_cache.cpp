#include "tile_cache.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <system_error>
#include <thread>
#include <type_traits>

#include <unistd.h>

#include "geo/binary_io.hpp"

namespace gis::overlay::detail {
namespace {

constexpr std::uint32_t kMagic = 0x54564753;  // "SGVT"
constexpr std::uint32_t kVersion = 3;
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

bool writeTile(const std::filesystem::path& file, std::uint64_t fingerprint, const LayerTile& tile) {
  // Two programs (or two renderers' workers) may write the same tile at once.
  return geo::io::writeFileAtomically(file, [&](std::ostream& out) {
    Writer w(out);
    w.value(kMagic);
    w.value(kVersion);
    w.value(fingerprint);
    w.value(tile.key.level);
    w.value(tile.key.x);
    w.value(tile.key.y);
    w.value(tile.key.width);
    w.value(tile.groundError);
    const LayerGeometry& g = tile.geometry;
    // The lean section first (its length before it, so that a full read skips it): the tile as
    // a far view draws it, read with a few large reads.
    const std::streampos lengthAt = out.tellp();
    w.value(std::uint64_t{0});
    w.array(tile.featureIndex);
    g.writeLean(w);
    w.value(kMagic);
    const std::streampos leanEnd = out.tellp();
    out.seekp(lengthAt);
    w.value(static_cast<std::uint64_t>(leanEnd - lengthAt) - sizeof(std::uint64_t));
    out.seekp(leanEnd);
    // The full section: features and pieces with their footprints.
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
    w.value(kMagic);  // the end: a file cut short fails here
  });
}

namespace {

/// Reads a tile file's header: whether it holds this format, fingerprint and key; its ground
/// error and the length of its lean section.
bool readHeader(Reader& r, std::uint64_t fingerprint, const TileKey& key, double& error, std::uint64_t& leanLength) {
  std::uint32_t magic = 0, version = 0;
  std::uint64_t stored = 0;
  TileKey k;
  return r.value(magic) && magic == kMagic && r.value(version) && version == kVersion && r.value(stored) &&
         stored == fingerprint && r.value(k.level) && r.value(k.x) && r.value(k.y) && r.value(k.width) && k == key &&
         r.value(error) && r.value(leanLength);
}

}  // namespace

std::optional<std::size_t> tileBytes(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  Reader r(in);
  double error = 0.0;
  std::uint64_t leanLength = 0;
  if (!readHeader(r, fingerprint, key, error, leanLength)) return std::nullopt;
  return static_cast<std::size_t>(leanLength);
}

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

std::optional<LayerTile> readTile(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key,
                                  const LayerGeometry& source, const HeightBoundsProvider& bounds,
                                  const LayerBuildOptions& options,
                                  const std::function<FeatureStyle(std::uint32_t)>& styleOf, bool lean) {
  // A lean read leaves the GPU arrays in the file for the upload (ArraysInFile), read through
  // a descriptor opened first: if the file was replaced meanwhile (a writer renames a new one
  // into place), the two would differ, and the arrays are read now instead.
  std::shared_ptr<ArraysInFile> arrays;
  if (lean) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) arrays = std::make_shared<ArraysInFile>(fd);
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  if (arrays) {
    struct stat a {
    }, b{};
    if (::fstat(arrays->descriptor(), &a) != 0 || ::stat(file.c_str(), &b) != 0 || a.st_ino != b.st_ino ||
        a.st_dev != b.st_dev)
      arrays.reset();
  }
  Reader r(in);
  double error = 0.0;
  std::uint64_t leanLength = 0;
  if (!readHeader(r, fingerprint, key, error, leanLength)) return std::nullopt;
  std::uint32_t magic = 0;
  if (lean) {
    std::vector<std::uint32_t> index;
    if (!r.array(index)) return std::nullopt;
    std::vector<FeatureStyle> styles(index.size());
    for (std::size_t i = 0; i < index.size(); ++i) {
      if (index[i] >= source.sharedFeatures().size()) return std::nullopt;
      styles[i] = styleOf(index[i]);
    }
    std::optional<LayerGeometry> g = LayerGeometry::readLean(r, source.name(), source.kind(), source.style(),
                                                             std::move(styles), bounds, options, std::move(arrays));
    if (!g || !r.value(magic) || magic != kMagic) return std::nullopt;
    return LayerTile{key, std::move(*g), std::move(index), error, true};
  }
  if (!r.skip(leanLength)) return std::nullopt;
  std::size_t count = 0;
  // A feature takes at least its index, fid, three counts; a piece over 100 bytes.
  if (!r.count(count, 36)) return std::nullopt;
  std::vector<geo::Feature> features(count);
  std::vector<FeatureStyle> styles(count);
  std::vector<std::vector<Polyhedron>> pieces(count);
  std::vector<std::uint32_t> index(count);
  for (std::size_t i = 0; i < count; ++i) {
    std::size_t n = 0;
    if (!r.value(index[i]) || index[i] >= source.sharedFeatures().size() || !geo::io::readGeometry(r, features[i]) ||
        !r.count(n, 100))
      return std::nullopt;
    styles[i] = styleOf(index[i]);
    pieces[i].resize(n);
    for (Polyhedron& p : pieces[i]) {
      if (!readPiece(r, p)) return std::nullopt;
      p.footprint.feature = static_cast<std::uint32_t>(i);
    }
  }
  if (!r.value(magic) || magic != kMagic) return std::nullopt;
  LayerTile tile{key,
                 LayerGeometry::assemble(source.name(), source.kind(), source.style(), std::move(features),
                                         std::move(styles), std::move(pieces), bounds, options),
                 std::move(index), error, true};
  return tile;
}

}  // namespace gis::overlay::detail
