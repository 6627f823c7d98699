#pragma once
// The contract between a terrain and the overlay (docs/design.md §5): for a 2D footprint in the scene
// frame, heights [lo, hi] that contain the surface *as drawn* over it — at whatever level of
// detail can be on screen there, with vertical exaggeration applied. Our terrain implements it;
// a GIS client with its own terrain implements it for theirs. It lives in core so that the
// terrain and the overlay stand side by side: neither library needs the other.
#include <cstdint>
#include <span>

#include <glm/vec2.hpp>

namespace gis {

struct HeightBounds {
  double lo = 0.0;
  double hi = 0.0;
  [[nodiscard]] bool valid() const { return lo <= hi; }
  [[nodiscard]] double span() const { return hi - lo; }
};

class HeightBoundsProvider {
 public:
  virtual ~HeightBoundsProvider() = default;
  /// Bounds over the convex hull of `footprint` (frame coordinates, metres). Outside the
  /// terrain, implementations return bounds that are still safe (e.g. the global range).
  [[nodiscard]] virtual HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const = 0;
  /// Bounds that may also hold the surface up to `slackMetres` outside the footprint: looser, and
  /// cheaper for a provider that can use it (pieces seen from afar, whose walls may be a little
  /// taller). Still under the contract: the surface over the footprint lies within them. The
  /// default is boundsOver.
  [[nodiscard]] virtual HeightBounds boundsOverWithin(std::span<const glm::dvec2> footprint, double slackMetres) const {
    (void)slackMetres;
    return boundsOver(footprint);
  }
  /// Bounds of the whole terrain as drawn.
  [[nodiscard]] virtual HeightBounds globalBounds() const = 0;
  /// True if the terrain is drawn over the whole convex hull of `footprint` (inside the DEM, no
  /// nodata there): then nothing below the surface can be seen through it, and z-pass
  /// polyhedra leave out their bottom caps. The safe default says no.
  [[nodiscard]] virtual bool coversFootprint(std::span<const glm::dvec2> footprint) const {
    (void)footprint;
    return false;
  }
  /// Changes whenever the surface as drawn changes for the same footprint (another vertical
  /// exaggeration): bounds read before are stale and must be read again. A provider whose
  /// surface never changes keeps 0.
  [[nodiscard]] virtual std::uint64_t revision() const { return 0; }
};

}  // namespace gis
