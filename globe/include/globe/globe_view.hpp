#pragma once
// A camera on the globe (docs/globe.md): eye and target in ECEF (double), reversed-Z infinite
// perspective. Everything drawn is relative to the eye: the GPU gets the rotation-only
// view-projection and positions as (high − eyeHigh) + (low − eyeLow) (ellipsoid.hpp,
// SplitPosition), so no float ever holds an earth-sized coordinate.
#include <array>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "globe/ellipsoid.hpp"

namespace gis::globe {

struct GlobeView {
  glm::dvec3 eye{kSemiMajor * 3.0, 0.0, 0.0};
  glm::dvec3 target{0.0};
  glm::dvec3 up{0.0, 0.0, 1.0};  ///< a hint; the view keeps it as upright as it can
  double fovYDeg = 45.0;
  int width = 256, height = 256;
  double near = 1.0;  ///< metres

  /// A view from `eye` towards `target` with north (the surface normal's side of +z) up and the
  /// near plane at a fraction of the eye's height above `groundHeight` (at least 1 cm).
  static GlobeView looking(const glm::dvec3& eye, const glm::dvec3& target, double fovYDeg, int width, int height,
                           double groundHeight = 0.0);

  [[nodiscard]] double aspect() const { return static_cast<double>(width) / static_cast<double>(height); }
  /// World (ECEF) → clip, in double (the CPU reference unprojects with its inverse).
  [[nodiscard]] glm::dmat4 viewProj() const;
  /// Eye-relative (p − eye) → clip: what the shaders use, narrowed once.
  [[nodiscard]] glm::dmat4 eyeViewProj() const;
  /// The eye's split position (uniforms u_eyeHigh, u_eyeLow).
  [[nodiscard]] SplitPosition eyeSplit() const { return splitPosition(eye); }
  /// Frustum planes in eye-relative coordinates (gfx::frustumPlanes of eyeViewProj).
  [[nodiscard]] std::array<glm::dvec4, 6> eyeFrustum() const;
  /// Metres per pixel at distance d along the view axis.
  [[nodiscard]] double pixelSizeAt(double distance) const;
};

}  // namespace gis::globe
