#pragma once
// What a terrain shader samples when the layers are draped (textures made by a drape technique of
// the overlay): one texture over an extent, or a texture array with a layer per drawn tile. Both
// frames' terrains take it, so it lives below them and the overlay (docs/frames.md).
#include <cstdint>
#include <functional>
#include <optional>
#include <tuple>

#include <glm/vec2.hpp>

#include "gfx/gl.hpp"

namespace gis::gfx {

struct SurfaceDrape {
  GLuint color = 0;        ///< premultiplied RGBA, mip-mapped
  GLuint mask = 0;         ///< R32F layer bits
  glm::dvec2 origin{0.0};  ///< the extent's minimum corner, frame coordinates
  glm::dvec2 size{1.0};    ///< frame units (metres, or degrees on the globe)
  /// Per tile: texture arrays, and for each drawn tile its array layer and extent (origin,
  /// size); a tile without one is drawn undraped. Then color, mask, origin and size are unused.
  GLuint colorArray = 0;
  GLuint maskArray = 0;
  std::function<std::optional<std::tuple<int, glm::dvec2, glm::dvec2>>(std::uint64_t tileKey)> tileOf;
};

}  // namespace gis::gfx
