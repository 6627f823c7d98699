#include "globe/globe_view.hpp"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"

namespace gis::globe {

GlobeView GlobeView::looking(const glm::dvec3& eye, const glm::dvec3& target, double fovYDeg, int width, int height,
                             double groundHeight) {
  GlobeView v;
  v.eye = eye;
  v.target = target;
  const Geodetic g = toGeodetic(eye);
  // North at the top: the up hint is the local north, unless the view looks straight down or
  // up, where the surface normal's plane holds the view axis anyway.
  const glm::dmat3 enu = enuBasis(g.lon, g.lat);
  const glm::dvec3 dir = glm::normalize(target - eye);
  v.up = std::abs(glm::dot(dir, enu[2])) > 0.999 ? enu[1] : enu[2];
  v.fovYDeg = fovYDeg;
  v.width = width;
  v.height = height;
  const double above = std::max(g.h - groundHeight, 0.0);
  v.near = std::max(0.01, 0.25 * above);
  return v;
}

glm::dmat4 GlobeView::eyeViewProj() const {
  const glm::dmat4 proj = gfx::reversedInfinitePerspective(fovYDeg * 3.14159265358979323846 / 180.0, aspect(), near);
  const glm::dmat4 view = gfx::lookAt(glm::dvec3(0.0), target - eye, up);
  return proj * view;
}

glm::dmat4 GlobeView::viewProj() const { return eyeViewProj() * glm::translate(glm::dmat4(1.0), -eye); }

std::array<glm::dvec4, 6> GlobeView::eyeFrustum() const { return gfx::frustumPlanes(eyeViewProj()); }

double GlobeView::pixelSizeAt(double distance) const {
  return 2.0 * distance * std::tan(0.5 * fovYDeg * 3.14159265358979323846 / 180.0) / height;
}

}  // namespace gis::globe
