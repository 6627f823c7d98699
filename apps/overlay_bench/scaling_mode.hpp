#pragma once
// overlay_bench --mode scaling (scaling_mode.cpp): the options only this mode has.
#include <string>

#include "bench_common.hpp"

namespace gis::bench {

struct ScalingOptions {
  /// The overlay_render executable of the start runs; empty: the one built beside overlay_bench.
  std::string overlayRender;
  /// Scenes with more vector vertices are not drawn with the techniques that build every piece
  /// at load: their memory grows with the whole dataset (about 4 GB at 1.9 M vertices).
  int wholeLoadMaxVertices = 500000;
};

/// Start time, memory and frame time of terrain only and the stencil techniques on each of
/// o.scenes.
int runScaling(const Options& o, const ScalingOptions& s);

}  // namespace gis::bench
