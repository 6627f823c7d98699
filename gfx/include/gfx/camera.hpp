#pragma once
// Camera maths in double: reversed-Z infinite projection and eye-relative view matrices.
#include <array>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace gis::gfx {

/// Infinite reversed-Z perspective for glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE):
/// depth = near / distance along the view axis: 1 at the near plane, → 0 at infinity.
glm::dmat4 reversedInfinitePerspective(double fovYRadians, double aspect, double near);

/// Right-handed look-at (camera looks along −z of its own frame). `up` must not be parallel to
/// target − eye; a fallback up is chosen then.
glm::dmat4 lookAt(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up);

/// proj · view · translate(centre), formed in double and narrowed once: vertices stored relative
/// to `centre` in float keep their precision however far the frame coordinates are.
glm::mat4 relativeToCentre(const glm::dmat4& viewProj, const glm::dvec3& centre);

/// Six planes (a, b, c, d with a·x + b·y + c·z + d ≥ 0 inside) of a reversed-Z frustum: left,
/// right, bottom, top, near, far.
std::array<glm::dvec4, 6> frustumPlanes(const glm::dmat4& viewProj);
/// Conservative box test: false only if the box lies entirely outside one plane. Volumes drawn
/// with depth clamp are not clipped at the near plane: test them with `nearPlane` false (the
/// side planes alone keep what is in front of the eye).
bool boxInFrustum(const std::array<glm::dvec4, 6>& planes, const glm::dvec3& lo, const glm::dvec3& hi,
                  bool nearPlane = true);

/// Turns on reversed-Z clip control on the current context (glClipControl, GL 4.5).
void enableReversedZ();

}  // namespace gis::gfx
