#pragma once
// Lasso selection on the globe (docs/globe.md, docs/selection.md): the stencil core's lasso
// volumes (vector_overlay/lasso.hpp) in ECEF. A lasso drawn in a globe view has that view's
// ECEF → clip transform (GlobeView::viewProj); overlay::SelectionRenderer draws its volumes relative
// to the eye (in double until then), so the frame's size costs no precision; the CPU twin takes the
// depth buffer's points in ECEF.
#include <cstdint>
#include <span>
#include <vector>

#include "globe/globe_view.hpp"
#include "vector_overlay/lasso.hpp"
#include "vector_overlay/near_clip.hpp"

namespace gis::globe {

/// The view as the stencil core takes it (overlay::SelectionRenderer::select): frame = ECEF.
overlay::OverlayView overlayViewOf(const GlobeView& view);

/// How far a lasso drawn from `eye` reaches: no ground it can see lies farther, with every height
/// below `maxGroundHeight` (metres above the ellipsoid): the distance to the horizon of the
/// ellipsoid's smallest sphere plus the farthest a ground point can rise into view beyond it. The
/// lasso's dark cap goes there (overlay::Lasso::distance), so a lasso drawn over one side of the
/// globe does not reach through it to the other side.
double horizonReach(const glm::dvec3& eye, double maxGroundHeight = 9000.0);

/// A lasso of screen points (pixels, origin top-left) drawn in `view`, reaching horizonReach.
overlay::Lasso lassoIn(const GlobeView& view, std::vector<glm::dvec2> points, double maxGroundHeight = 9000.0);

// The CPU twin of SelectionRenderer::select on a globe frame is overlay::selectionMask on
// depthImageOf(view, depth) (globe_overlay.hpp).

}  // namespace gis::globe
