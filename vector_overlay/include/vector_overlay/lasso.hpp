#pragma once
// Lasso selection (docs/design.md §6, after Rainer 2016): a screen polygon drawn with some camera casts
// a volume into the scene; volumes combine in order with Single / Or / And / Xor / Subtract,
// and Invert flips the selection where there is geometry. This header holds the volumes and
// their CPU twin: which points, pixels, DEM posts and features are selected. The GPU side is
// selection_renderer.hpp; the two must agree.
//
// The volume of a lasso, precisely: the points X whose clip coordinates under the lasso's
// camera (c = viewProj · X) have w ≥ near (beyond the light cap at the near plane), w ≤
// distance (before the dark cap; none at infinity), and whose screen position, in the lasso's
// pixels, lies inside the polygon by the even-odd rule (concave and self-intersecting
// polygons allowed). Its boundary: the triangulated region at the near plane (light cap), a
// wall along the view rays through every boundary edge, the region again at the distance or at
// infinity (dark cap, homogeneous points with w = 0) — closed and wound outward.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::overlay {

enum class SelectionOp : std::uint8_t { Single, Or, And, Xor, Subtract, Invert };

/// "single", "or", "and", "xor", "subtract", "invert" (any case); nullopt otherwise.
std::optional<SelectionOp> parseSelectionOp(const std::string& text);
const char* selectionOpName(SelectionOp op);

/// A screen polygon and the camera it was drawn with.
struct Lasso {
  /// Pixel coordinates in the lasso's viewport: x from the left edge, y from the top edge
  /// (mouse coordinates; the centre of the top-left pixel is (0.5, 0.5)).
  std::vector<glm::dvec2> points;
  /// Frame → clip of the camera it was drawn with: reversed-Z with an infinite far plane, as
  /// every camera of the product (gfx::reversedInfinitePerspective · gfx::lookAt).
  glm::dmat4 viewProj{1.0};
  int width = 1;  ///< viewport, pixels
  int height = 1;
  /// The dark cap's distance along the view direction (metres); infinity: at infinity.
  double distance = std::numeric_limits<double>::infinity();
  /// Where it comes from, for messages: the lasso file and its name there ("lasso 2", counted
  /// from 1 as the file's entries). Empty: the renderer names it by its step.
  std::string file;
  std::string label;
};

/// One step of a selection: an operator and its lasso (Invert has none).
struct SelectionStep {
  SelectionOp op = SelectionOp::Single;
  Lasso lasso;
};

/// The closed volume of a lasso as homogeneous triangles in frame coordinates (w = 0 for points
/// at infinity), wound outward (counter-clockwise seen from outside).
struct LassoVolume {
  std::vector<std::array<glm::dvec4, 3>> triangles;
  std::size_t lightCapTriangles = 0;  ///< the first ones; then the dark cap, then the walls
  std::size_t darkCapTriangles = 0;
  [[nodiscard]] bool empty() const { return triangles.empty(); }
};

/// Builds the volume; a polygon without area (fewer than 3 distinct points, all collinear,
/// non-finite points) or a camera that cannot be inverted gives an empty volume (selects
/// nothing) and an Error naming `name`.
LassoVolume buildLassoVolume(const Lasso& lasso, const std::string& name, Diagnostics& diagnostics);

/// Whether the point lies in the lasso's volume (the definition above; exact even-odd test on
/// the polygon in the lasso's pixel coordinates).
bool insideLasso(const Lasso& lasso, const glm::dvec3& point);

/// Applies the steps in order to one point: Single starts anew with the volume, Or / And / Xor /
/// Subtract combine the selection so far A with the volume B (A ∨ B, A ∧ B, A ⊕ B, A ∧ ¬B),
/// Invert flips it. `geometry` false (background: nothing drawn) is never selected.
bool selectedAt(std::span<const SelectionStep> steps, const glm::dvec3& point, bool geometry = true);

/// Per pixel of the depth image (row 0 = top), 1 where the pixel's terrain point is selected, 0
/// elsewhere and on background: the CPU twin of SelectionRenderer::select.
std::vector<std::uint8_t> selectionMask(const DepthImage& image, std::span<const SelectionStep> steps);

}  // namespace gis::overlay
