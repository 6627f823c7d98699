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

}  // namespace gis::gfx
