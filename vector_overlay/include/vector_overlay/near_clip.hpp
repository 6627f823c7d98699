#pragma once
// Near-plane clipping of z-fail pieces on the CPU (docs/design.md §4). GL clips each triangle on its
// own, and at the eye plane independent clipping of neighbouring faces leaves one-pixel cracks;
// so the pieces that may hold the eye or reach it through the near plane are clipped here, at
// half the near distance, with shared edges cut bit-identically, and (for counting open faces)
// closed again on the clip plane. Pure and thread-safe: no GL.
#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "vector_overlay/footprints.hpp"
#include "vector_overlay/layer_geometry.hpp"

namespace gis::overlay {

/// The camera of the frame, as the terrain was drawn with it.
struct OverlayView {
  glm::dmat4 viewProj{1.0};  ///< frame → clip (reversed-Z, infinite far plane, depth clamp)
  glm::dvec3 eye{0.0};       ///< frame coordinates
  double nearPlane = 1.0;    ///< metres
  double fovYRadians = 0.785;
  double aspect = 1.0;
};

/// How far caps are moved out at a distance from the eye, as the volume shader does it:
/// base + perMetre · d + perMetreSquared · d² (OverlaySettings, and the depth format's term);
/// world pieces' caps further by their layer's reach (OverlayLayer::capReach: x below, y above).
struct CapPadding {
  double base = 0.05;
  double perMetre = 2e-6;
  double perMetreSquared = 0.0;
  glm::dvec2 reach{0.0};
  [[nodiscard]] double at(double distance) const {
    return base + perMetre * distance + perMetreSquared * distance * distance;
  }
};

/// A vertex of a clipped triangle: relative to the eye, in the layout of the volume shader's
/// vertex stream (side 0: already padded).
struct ClippedVertex {
  float x, y, z, side;
  std::uint8_t rgba[4];
};

/// The faces of the given pieces of `layer` as triangles relative to the eye, lines in pixels
/// at `scale` and caps padded by `padding`, clipped at half the near distance; faces seen edge
/// on from the eye are left out. With `capped`, each clipped piece is closed on the plane by a
/// fan over its cut edges (its section counts 1 inside, 0 outside).
///
/// Both frames: a projected frame's pieces are cut from their footprints and bounds; world
/// pieces (the globe's, LayerGeometry::alongNormals) from the triangles the GPU draws, placed as
/// the volume shader places them (caps along the normals, lines in pixels at this frame's
/// width). Either needs the layer's CPU copy (not footprintsReleased()).
std::vector<ClippedVertex> clipAtNearPlane(const OverlayView& view, const LayerGeometry& layer,
                                           std::span<const std::size_t> slots, const CapPadding& padding,
                                           const PixelScale& scale, bool capped);

}  // namespace gis::overlay
