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

}  // namespace gis::overlay
