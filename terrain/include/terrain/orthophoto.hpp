#pragma once
// Orthophoto colours for the terrain: imagery bands stretched to 8-bit RGB, and the mapping from
// frame coordinates to image coordinates through the imagery's own georeference.
#include <cstdint>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"

namespace gis::terrain {

struct Orthophoto {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  ///< top row first; alpha 0 where the imagery has nodata
};

struct StretchOptions {
  /// Per-band linear stretch between these percentiles of the valid samples (satellite bands
  /// use a fraction of the 8-bit range; a 2–98 % stretch is what GIS viewers show by default).
  double lowPercentile = 2.0;
  double highPercentile = 98.0;
};

/// Imagery with 1 (grey) or 3 (RGB) channels → RGBA8 with a percentile stretch per channel.
Result<Orthophoto> makeOrthophoto(const geo::Raster& imagery, const StretchOptions& options = {});

}  // namespace gis::terrain
