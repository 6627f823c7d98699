#pragma once
// Deterministic synthetic vector layers for the benchmark: the seed paper's test load (Dai et
// al. 2008: 8 habitation areas with 1,208 points, 144 roads with 18,800 points) and any multiple
// of it, placed over a rectangle of a projected CRS. Areas are star-shaped rings (simple, so valid
// without repair); roads are smooth random walks that turn back at the rectangle's edge. Every
// feature is placed at fractions of the rectangle from the seed, so the same seed over the same
// rectangle gives the same features whatever DEM lies under them.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/diagnostics.hpp"

namespace gis::synth {

/// The paper's load: areas, area points, roads, road points.
inline constexpr int kPaperAreas = 8;
inline constexpr int kPaperAreaPoints = 1208;
inline constexpr int kPaperRoads = 144;
inline constexpr int kPaperRoadPoints = 18800;

struct SyntheticVectorOptions {
  int scale = 1;  ///< multiples of the paper's load, 1 .. 10000
  std::uint64_t seed = 1;
  double minX = 0.0, minY = 0.0, maxX = 0.0, maxY = 0.0;  ///< the rectangle, CRS units (metres)
  std::string crs = "EPSG:32633";                         ///< anything OGR understands
  double roadWidthMetres = 10.0;                          ///< written as each road's width_m
};

struct SyntheticVectorSummary {
  std::string areasPath, roadsPath;
  std::size_t areas = 0, areaPoints = 0;  ///< points without the ring's closing repeat
  std::size_t roads = 0, roadPoints = 0;
  double roadKilometres = 0.0;
};

/// Empty when the options are usable, else what is wrong with them.
std::string checkSyntheticVectorOptions(const SyntheticVectorOptions& options);

/// Writes the areas (layer "areas", polygons with "name") and the roads (layer "roads", line
/// strings with "name" and "width_m") as two GeoPackages; existing files are replaced. Errors
/// name the file.
Result<SyntheticVectorSummary> writeSyntheticVectors(const std::string& areasPath, const std::string& roadsPath,
                                                     const SyntheticVectorOptions& options);

}  // namespace gis::synth
