#include "gfx/camera.hpp"

#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/gl.hpp"

namespace gis::gfx {

glm::dmat4 reversedInfinitePerspective(double fovYRadians, double aspect, double near) {
  const double f = 1.0 / std::tan(fovYRadians / 2.0);
  glm::dmat4 m(0.0);
  m[0][0] = f / aspect;
  m[1][1] = f;
  m[2][3] = -1.0;  // w_clip = −z_eye
  m[3][2] = near;  // z_clip = near  →  depth = near / −z_eye
  return m;
}

glm::dmat4 lookAt(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up) {
  const glm::dvec3 forward = glm::normalize(target - eye);
  glm::dvec3 u = up;
  if (glm::length(glm::cross(forward, u)) < 1e-9) {
    u = std::abs(forward.y) < 0.9 ? glm::dvec3(0.0, 1.0, 0.0) : glm::dvec3(1.0, 0.0, 0.0);
  }
  return glm::lookAtRH(eye, target, u);
}

glm::mat4 relativeToCentre(const glm::dmat4& viewProj, const glm::dvec3& centre) {
  return glm::mat4(viewProj * glm::translate(glm::dmat4(1.0), centre));
}

void enableReversedZ() { glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE); }

std::array<glm::dvec4, 6> frustumPlanes(const glm::dmat4& m) {
  auto row = [&](int i) { return glm::dvec4(m[0][i], m[1][i], m[2][i], m[3][i]); };
  const glm::dvec4 r0 = row(0), r1 = row(1), r2 = row(2), r3 = row(3);
  // Clip space of GL_ZERO_TO_ONE: −w ≤ x, y ≤ w and 0 ≤ z ≤ w (reversed-Z: z = w at the near
  // plane, z → 0 at infinity).
  return {r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 - r2, r2};
}

bool boxInFrustum(const std::array<glm::dvec4, 6>& planes, const glm::dvec3& lo, const glm::dvec3& hi, bool nearPlane) {
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (!nearPlane && i >= 4) break;
    const glm::dvec4& p = planes[i];
    const glm::dvec3 positive(p.x >= 0 ? hi.x : lo.x, p.y >= 0 ? hi.y : lo.y, p.z >= 0 ? hi.z : lo.z);
    if (p.x * positive.x + p.y * positive.y + p.z * positive.z + p.w < 0.0) return false;
  }
  return true;
}

}  // namespace gis::gfx
