#pragma once
// The bounds contract between a terrain and the overlay (docs/design.md §5) is core/height_bounds.hpp;
// these names keep clients that spell it overlay::HeightBoundsProvider compiling.
#include "core/height_bounds.hpp"

namespace gis::overlay {

using gis::HeightBounds;
using gis::HeightBoundsProvider;

}  // namespace gis::overlay
