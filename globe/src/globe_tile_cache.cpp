// The globe's tiles on disk (globe_overlay.hpp, GlobeOverlaySettings::cacheDir): a tile's pieces
// as a checked file (geo/checked_file.hpp), one section, read back only when whole and sound.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"
#include "globe_detail.hpp"

namespace gis::globe::detail {

namespace {

constexpr std::uint32_t kMagic = 0x54474753;  // "SGGT"
constexpr std::uint32_t kVersion = 1;

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

std::filesystem::path tileCachePath(const std::string& dir, std::uint64_t key, const TileKey& tile, int widthClass) {
  char folder[17];
  std::snprintf(folder, sizeof(folder), "%016llx", static_cast<unsigned long long>(key));
  return std::filesystem::path(dir) / "globe-tiles" / folder /
         (std::to_string(tile.level) + "-" + std::to_string(tile.x) + "-" + std::to_string(tile.y) + "-" +
          std::to_string(widthClass) + ".bin");
}

bool writeTilePieces(const std::filesystem::path& file, const TilePieces& pieces) {
  std::error_code error;
  std::filesystem::create_directories(file.parent_path(), error);
  if (error) return false;
  return static_cast<bool>(geo::io::writeCheckedFile(file, [&](std::ostream& out, geo::io::SectionMarks& marks) {
    marks.begin();
    geo::io::Writer w(out);
    w.value(kMagic);
    w.value(kVersion);
    w.value(pieces.origin);
    w.value(pieces.maxHalfWidth);
    w.array(pieces.vertices);
    w.array(pieces.indices);
    w.array(pieces.pieces);
    w.array(pieces.scaling);
  }));
}

std::optional<TilePieces> readTilePieces(const std::filesystem::path& file, bool& damaged) {
  damaged = false;
  geo::io::CheckedStatus status = geo::io::CheckedStatus::Ok;
  std::string why;
  const std::shared_ptr<const geo::io::CheckedFile> checked = geo::io::CheckedFile::open(file, status, why);
  if (!checked) {
    damaged = status == geo::io::CheckedStatus::Damaged;
    return std::nullopt;
  }
  std::optional<std::string> bytes = checked->sections() == 1 ? checked->read(0) : std::nullopt;
  TilePieces out;
  bool sound = bytes.has_value();
  if (sound) {
    std::istringstream in(std::move(*bytes));
    geo::io::Reader r(in);
    std::uint32_t magic = 0, version = 0;
    sound = r.value(magic) && r.value(version) && magic == kMagic && version == kVersion && r.value(out.origin) &&
            r.value(out.maxHalfWidth) && r.array(out.vertices) && r.array(out.indices) && r.array(out.pieces) &&
            r.array(out.scaling);
  }
  // What the GPU would read out of bounds, or numbers no builder writes: damaged.
  if (sound) {
    sound = finite(out.origin) && std::isfinite(out.maxHalfWidth) &&
            (out.scaling.empty() || out.scaling.size() == out.vertices.size());
    for (std::size_t i = 0; sound && i < out.indices.size(); ++i) sound = out.indices[i] < out.vertices.size();
    for (std::size_t i = 0; sound && i < out.pieces.size(); ++i) {
      const TilePieces::Piece& p = out.pieces[i];
      sound = std::uint64_t{p.firstIndex} + p.indexCount <= out.indices.size() && p.bottomCount <= p.indexCount &&
              finite(p.boxLo) && finite(p.boxHi) && std::isfinite(p.lo) && std::isfinite(p.hi);
    }
  }
  if (!sound) {
    damaged = true;
    return std::nullopt;
  }
  return out;
}

}  // namespace gis::globe::detail
