#include "vector_overlay/globe_drape.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <optional>

namespace gis::globe {

namespace {

/// Metres in a degree of latitude (its mean on WGS 84): a texel's width in metres for lines in
/// pixels, which need no more than that.
constexpr double kMetresPerDegree = 111132.0;

/// The turns (−1, 0, 1: a shape moved 360° west, kept, moved east) at which `box` meets [lo, hi].
template <typename Visit>
void forEachTurn(const LonLatRect& box, const glm::dvec2& lo, const glm::dvec2& hi, const Visit& visit) {
  if (box.south > hi.y || box.north < lo.y) return;
  for (int turn = -1; turn <= 1; ++turn) {
    const double shift = 360.0 * turn;
    if (box.west + shift <= hi.x && box.east + shift >= lo.x) visit(shift);
  }
}

/// Triangulates rings even-odd in the plane of longitude and latitude; nothing (no area, or
/// rings CGAL cannot take) leaves it empty.
overlay::Footprint triangulated(const std::vector<std::vector<glm::dvec2>>& rings) {
  std::vector<std::array<glm::dvec2, 2>> edges;
  for (const std::vector<glm::dvec2>& ring : rings) {
    for (std::size_t k = 0; k < ring.size(); ++k) {
      const glm::dvec2 a = ring[k], b = ring[(k + 1) % ring.size()];
      if (a != b) edges.push_back({a, b});
    }
  }
  try {
    return overlay::evenOddFootprint(edges, {});
  } catch (const std::exception&) {
    return {};
  }
}

void emitFootprint(const overlay::Footprint& f, double shift, const glm::vec4& colour,
                   const overlay::DrapeSource::TriangleSink& emit) {
  const glm::dvec2 by(shift, 0.0);
  for (const auto& t : f.triangles) emit(f.vertices[t[0]] + by, f.vertices[t[1]] + by, f.vertices[t[2]] + by, colour);
}

}  // namespace

int drapeLevel(double texelDegrees) {
  int level = 0;
  while (level + 1 < kMaxLevel && simplifyTolerance(level) > texelDegrees / 8.0) ++level;
  return level;
}

void GlobeDrapeSource::triangles(std::size_t layer, const glm::dvec2& lo, const glm::dvec2& hi, const glm::dvec2& texel,
                                 const TriangleSink& emit) const {
  const GlobeLayer* drawn = layers_[layer];
  if (drawn == nullptr) return;
  int level = drapeLevel(texel.y);
  const std::vector<glm::vec4>& colours = drawn->colors();
  const auto colourOf = [&](std::uint32_t group) { return group < colours.size() ? colours[group] : drawn->color(); };
  // The areas that meet the box, generalised together for the level (as a tile of it draws them).
  for (const GlobePolygon& area : drawn->areasIn(LonLatRect{lo.x, lo.y, hi.x, hi.y}, level)) {
    std::optional<overlay::Footprint> f;
    forEachTurn(area.box, lo, hi, [&](double shift) {
      if (!f) f = triangulated(area.rings);
      emitFootprint(*f, shift, colourOf(area.group), emit);
    });
  }
  if (!drawn->hasLines()) return;
  // The lines' shapes of the level's tiles that meet the box (within the world), a few at most:
  // coarser levels where a box would hold very many (a whole layer's drape from afar).
  const auto clampedColumn = [](double lon, const TileKey& probe) {
    return std::clamp(static_cast<int>(std::floor((lon + 180.0) / probe.size())), 0, probe.columns() - 1);
  };
  const auto clampedRow = [](double lat, const TileKey& probe) {
    return std::clamp(static_cast<int>(std::floor((lat + 90.0) / probe.size())), 0, probe.rows() - 1);
  };
  const glm::dvec2 west(std::max(lo.x, -180.0), std::max(lo.y, -90.0)),
      east(std::min(hi.x, 180.0), std::min(hi.y, 90.0));
  if (!(west.x < east.x && west.y < east.y)) return;
  const auto tileCount = [&](int l) {
    const TileKey probe{l, 0, 0};
    return static_cast<double>(clampedColumn(east.x, probe) - clampedColumn(west.x, probe) + 1) *
           static_cast<double>(clampedRow(east.y, probe) - clampedRow(west.y, probe) + 1);
  };
  while (level > 0 && tileCount(level) > 4096.0) --level;
  const TileKey probe{level, 0, 0};
  const double pixelMetres = texel.y * kMetresPerDegree;
  for (int y = clampedRow(west.y, probe); y <= clampedRow(east.y, probe); ++y) {
    for (int x = clampedColumn(west.x, probe); x <= clampedColumn(east.x, probe); ++x) {
      for (const GlobePolygon& shape : drawn->lineShapesIn(TileKey{level, x, y}, 0, pixelMetres)) {
        // Triangulated only when it meets the box (the tile's runs reach beyond it), once.
        std::optional<overlay::Footprint> f;
        forEachTurn(shape.box, lo, hi, [&](double shift) {
          if (!f) f = triangulated(shape.rings);
          emitFootprint(*f, shift, colourOf(shape.group), emit);
        });
      }
    }
  }
}

}  // namespace gis::globe
