#pragma once
// The registry's entries (each defined in its technique's file) and what their files share.
#include "vector_overlay/technique.hpp"

namespace gis::overlay {

extern const TechniqueInfo kStencilTechnique;
extern const TechniqueInfo kPaperTechnique;
extern const TechniqueInfo kDrapeTechnique;
extern const TechniqueInfo kTiledDrapeTechnique;
extern const TechniqueInfo kTiledStencilTechnique;
extern const TechniqueInfo kDeferredTechnique;
extern const TechniqueInfo kAutoTechnique;

/// The deferred technique as `auto` drives it (deferred_technique.cpp).
class DeferredLookup : public OverlayTechnique {
 public:
  /// Whether it draws the layer exactly in this view (target `height` pixels high) within
  /// `maxIndexBytes`: polygons and lines in metres always, if their index fits; lines in pixels
  /// while their widths anywhere in the layer stay within a reach class (its lines binned at
  /// maxReach × 2^c, c ≤ 12; an index per class, made when a view needs it).
  [[nodiscard]] virtual bool canDraw(const OverlayLayer& layer, const OverlayView& view, int height,
                                     std::size_t maxIndexBytes) = 0;
};

/// The deferred technique with lines in pixels binned at most `maxReach` × 2^c metres wide,
/// the class c chosen per view (for layers whose widths in pixels have no useful largest width in
/// metres, as LayerStyle::minWidthPixels gives them).
Result<std::unique_ptr<DeferredLookup>> createDeferredLookup(const TechniqueOptions& options, double maxReach);

}  // namespace gis::overlay
