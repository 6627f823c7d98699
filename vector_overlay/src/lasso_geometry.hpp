#pragma once
// Private to the lasso code (lasso.cpp, logical_selection.cpp): the pieces of the volume's
// definition (lasso.hpp) shared by the point test and the batched logical selection, so both
// evaluate exactly the same arithmetic.
#include <optional>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "reference_geometry.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::overlay::lasso_geometry {

/// The near plane of a reversed-Z infinite projection: clip z is the constant `near`.
inline double nearPlaneOf(const glm::dmat4& viewProj) { return viewProj[3][2]; }

/// The point's position in the lasso's pixels (x right, y down) when it lies between the near
/// plane and the selection distance; nullopt otherwise (behind, before the near plane, beyond).
inline std::optional<glm::dvec2> pixelOf(const Lasso& lasso, double nearPlane, const glm::dvec3& point) {
  const glm::dvec4 c = lasso.viewProj * glm::dvec4(point, 1.0);
  if (!(c.w >= nearPlane) || c.w > lasso.distance) return std::nullopt;
  return glm::dvec2((c.x / c.w + 1.0) * 0.5 * lasso.width, (1.0 - c.y / c.w) * 0.5 * lasso.height);
}

/// Even-odd point in polygon on the raw ring (repeated points and self-intersections need no
/// repair), with the crossing rule of the CPU reference.
inline bool insideEvenOdd(const std::vector<glm::dvec2>& ring, const glm::dvec2& p) {
  bool inside = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    if (reference::crossesRay(ring[j], ring[i], p)) inside = !inside;
  }
  return inside;
}

/// One step of the chain: the selection so far `a` combined with the volume's answer `b`
/// (ignored by Invert).
inline bool apply(SelectionOp op, bool a, bool b) {
  switch (op) {
    case SelectionOp::Single:
      return b;
    case SelectionOp::Or:
      return a || b;
    case SelectionOp::And:
      return a && b;
    case SelectionOp::Xor:
      return a != b;
    case SelectionOp::Subtract:
      return a && !b;
    case SelectionOp::Invert:
      return !a;
  }
  return a;
}

}  // namespace gis::overlay::lasso_geometry
