// The globe overlay's CPU reference (globe_overlay.hpp): the depth buffer's points, in geodetic
// coordinates, tested against the layers' polygons.
#include <glm/gtc/matrix_inverse.hpp>

#include <cmath>

#include "globe/globe_overlay.hpp"
#include "globe/globe_selection.hpp"

namespace gis::globe {

namespace {

/// The ECEF point of pixel (col, row) at `depth`, through `inverse` (of view.eyeViewProj()).
glm::dvec3 unprojectWith(const glm::dmat4& inverse, const GlobeView& view, int col, int row, float depth) {
  const double x = (col + 0.5) / view.width * 2.0 - 1.0;
  const double y = 1.0 - (row + 0.5) / view.height * 2.0;
  const glm::dvec4 p = inverse * glm::dvec4(x, y, static_cast<double>(depth), 1.0);
  return view.eye + glm::dvec3(p) / p.w;
}

/// Calls visit(i, point) for every pixel i (row 0 = top) whose depth shows terrain, with its ECEF point.
template <typename Visit>
void forEachGroundPixel(const std::vector<float>& depth, const GlobeView& view, Visit&& visit) {
  const glm::dmat4 inverse = glm::inverse(view.eyeViewProj());
  for (int row = 0; row < view.height; ++row) {
    for (int col = 0; col < view.width; ++col) {
      const std::size_t i =
          static_cast<std::size_t>(row) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(col);
      if (i < depth.size() && depth[i] > 0.0F) visit(i, unprojectWith(inverse, view, col, row, depth[i]));
    }
  }
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
  forEachGroundPixel(depth, view, [&](std::size_t i, const glm::dvec3& point) {
    const Geodetic g = toGeodetic(point);
    for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
      if (layers[l]->contains(point, g.lon, g.lat)) mask[i] |= 1U << l;
    }
  });
  return mask;
}

overlay::OverlayView overlayViewOf(const GlobeView& view) {
  overlay::OverlayView v;
  v.viewProj = view.viewProj();
  v.eye = view.eye;
  v.nearPlane = view.near;
  v.fovYRadians = view.fovYDeg * 3.14159265358979323846 / 180.0;
  v.aspect = view.aspect();
  return v;
}

double horizonReach(const glm::dvec3& eye, double maxGroundHeight) {
  const double b = kSemiMinor, top = kSemiMajor + std::max(maxGroundHeight, 0.0);
  const double r = std::max(glm::length(eye), b);
  return std::sqrt(r * r - b * b) + std::sqrt(top * top - b * b);
}

overlay::Lasso lassoIn(const GlobeView& view, std::vector<glm::dvec2> points, double maxGroundHeight) {
  overlay::Lasso lasso;
  lasso.distance = horizonReach(view.eye, maxGroundHeight);
  lasso.points = std::move(points);
  lasso.viewProj = view.viewProj();
  lasso.width = view.width;
  lasso.height = view.height;
  return lasso;
}

std::vector<std::uint8_t> selectionMask(const std::vector<float>& depth, const GlobeView& view,
                                        std::span<const overlay::SelectionStep> steps) {
  std::vector<std::uint8_t> mask(depth.size(), 0);
  forEachGroundPixel(depth, view, [&](std::size_t i, const glm::dvec3& point) {
    if (overlay::selectedAt(steps, point)) mask[i] = 1;
  });
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
