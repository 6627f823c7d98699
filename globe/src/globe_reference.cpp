// The globe overlay's CPU reference (globe_overlay.hpp): the depth buffer's points, in geodetic
// coordinates, tested against the layers' polygons.
#include <glm/gtc/matrix_inverse.hpp>

#include "globe/globe_overlay.hpp"

namespace gis::globe {

namespace {

/// The ECEF point of pixel (col, row) at `depth`, through `inverse` (of view.eyeViewProj()).
glm::dvec3 unprojectWith(const glm::dmat4& inverse, const GlobeView& view, int col, int row, float depth) {
  const double x = (col + 0.5) / view.width * 2.0 - 1.0;
  const double y = 1.0 - (row + 0.5) / view.height * 2.0;
  const glm::dvec4 p = inverse * glm::dvec4(x, y, static_cast<double>(depth), 1.0);
  return view.eye + glm::dvec3(p) / p.w;
}

}  // namespace

bool unprojectPixel(const GlobeView& view, int col, int row, float depth, glm::dvec3& out) {
  if (!(depth > 0.0F)) return false;  // reversed-Z: 0 is infinitely far (background)
  out = unprojectWith(glm::inverse(view.eyeViewProj()), view, col, row, depth);
  return true;
}

std::vector<std::uint32_t> referenceMask(const std::vector<float>& depth, const GlobeView& view,
                                         const std::vector<const GlobeLayer*>& layers) {
  std::vector<std::uint32_t> mask(depth.size(), 0);
  const glm::dmat4 inverse = glm::inverse(view.eyeViewProj());
  for (int row = 0; row < view.height; ++row) {
    for (int col = 0; col < view.width; ++col) {
      const std::size_t i =
          static_cast<std::size_t>(row) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(col);
      if (!(depth[i] > 0.0F)) continue;
      const glm::dvec3 point = unprojectWith(inverse, view, col, row, depth[i]);
      const Geodetic g = toGeodetic(point);
      for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
        if (layers[l]->contains(point, g.lon, g.lat)) mask[i] |= 1U << l;
      }
    }
  }
  return mask;
}

std::vector<std::uint8_t> edgePixels(const std::vector<std::uint32_t>& mask, const std::vector<float>& depth, int width,
                                     int height) {
  std::vector<std::uint8_t> edges(mask.size(), 0);
  const auto at = [&](int c, int r) {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c);
  };
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const std::size_t i = at(c, r);
      const bool terrain = depth[i] > 0.0F;
      for (int dr = -1; dr <= 1 && edges[i] == 0; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= width || rr >= height) continue;
          const std::size_t j = at(cc, rr);
          if (mask[j] != mask[i] || (depth[j] > 0.0F) != terrain) {
            edges[i] = 1;
            break;
          }
        }
      }
    }
  }
  return edges;
}

}  // namespace gis::globe
