#pragma once
// The globe's geographic quadtree (docs/globe.md): level 0 is two 180° × 180° tiles (west and
// east of Greenwich), each tile splits into four of half its size. Every tile is a grid of
// kTileSegments × kTileSegments cells in longitude and latitude; post (i, j) of tile (L, x, y)
// is global post (32x + i, 32y + j) of level L, whose longitude and latitude are formed from
// integers and a power-of-two step, so a post shared by tiles of any levels has the same
// coordinates, bit for bit, in each.
#include <array>
#include <cstdint>

namespace gis::globe {

inline constexpr int kTileSegments = 32;
inline constexpr int kTilePosts = kTileSegments + 1;
inline constexpr int kMaxLevel = 24;  ///< 180° / 2^24 / 32 ≈ 2.4 cm between posts

/// A box in longitude and latitude (degrees); west may be below −180 or east above 180 where a
/// shape is handled unwrapped.
struct LonLatRect {
  double west = 0.0, south = 0.0, east = 0.0, north = 0.0;
  [[nodiscard]] bool empty() const { return !(west < east && south < north); }
  [[nodiscard]] LonLatRect expanded(double dLon, double dLat) const {
    return {west - dLon, south - dLat, east + dLon, north + dLat};
  }
};

struct TileKey {
  int level = 0;
  int x = 0;  ///< 0 ... 2^(level+1) − 1, from −180° eastwards
  int y = 0;  ///< 0 ... 2^level − 1, from −90° northwards
  bool operator==(const TileKey&) const = default;

  /// Degrees a side.
  [[nodiscard]] double size() const { return 180.0 / static_cast<double>(std::uint64_t{1} << level); }
  /// Degrees between posts of this level.
  [[nodiscard]] double postStep() const { return size() / kTileSegments; }
  [[nodiscard]] LonLatRect rect() const {
    const double s = size();
    return {-180.0 + x * s, -90.0 + y * s, -180.0 + (x + 1) * s, -90.0 + (y + 1) * s};
  }
  /// Longitude and latitude of post (i, j), 0 ≤ i, j ≤ kTileSegments (exact: see above).
  [[nodiscard]] double postLon(int i) const { return -180.0 + (x * kTileSegments + i) * postStep(); }
  [[nodiscard]] double postLat(int j) const { return -90.0 + (y * kTileSegments + j) * postStep(); }

  [[nodiscard]] TileKey parent() const { return {level - 1, x >> 1, y >> 1}; }
  /// South-west, south-east, north-west, north-east.
  [[nodiscard]] std::array<TileKey, 4> children() const {
    return {TileKey{level + 1, 2 * x, 2 * y}, TileKey{level + 1, 2 * x + 1, 2 * y},
            TileKey{level + 1, 2 * x, 2 * y + 1}, TileKey{level + 1, 2 * x + 1, 2 * y + 1}};
  }
  [[nodiscard]] int columns() const { return 2 << level; }
  [[nodiscard]] int rows() const { return 1 << level; }
  /// True if `other` is this tile or lies inside it.
  [[nodiscard]] bool contains(const TileKey& other) const {
    return other.level >= level && (other.x >> (other.level - level)) == x && (other.y >> (other.level - level)) == y;
  }
  [[nodiscard]] std::uint64_t id() const {
    return (static_cast<std::uint64_t>(level) << 58) | (static_cast<std::uint64_t>(x) << 29) |
           static_cast<std::uint64_t>(y);
  }
  /// The tile whose id() this is.
  [[nodiscard]] static TileKey fromId(std::uint64_t id) {
    constexpr std::uint64_t kMask = (std::uint64_t{1} << 29) - 1;
    return {static_cast<int>(id >> 58), static_cast<int>((id >> 29) & kMask), static_cast<int>(id & kMask)};
  }
};

struct TileKeyHash {
  std::size_t operator()(const TileKey& k) const { return static_cast<std::size_t>(k.id() * 0x9E3779B97F4A7C15ULL); }
};

}  // namespace gis::globe
