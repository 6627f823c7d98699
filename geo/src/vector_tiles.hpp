#pragma once
// Mapbox Vector Tiles as a vector source (an MBTiles file, or a folder of {z}/{x}/{y}.pbf tiles
// with metadata.json), read through GDAL's MBTiles and MVT drivers. Tiles clip their features:
// a feature that crosses tiles comes once per tile (with the same mvt_id), each piece reaching
// a little into the neighbour (the tile buffer). The reader gives each source feature once:
// polygon pieces united (GEOS, so no clip edge becomes an outline), line pieces as the parts of
// one feature (the overlay unites a line's shapes). Positions are quantised to a grid of
// `extent` units a tile side, which the reader states as an error bound.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <ogrsf_frmts.h>

namespace gis::geo::detail {

struct OgrFeatureDeleter {
  void operator()(OGRFeature* f) const { OGRFeature::DestroyFeature(f); }
};
using FeaturePtr = std::unique_ptr<OGRFeature, OgrFeatureDeleter>;

/// A folder of MVT tiles (metadata.json and numbered zoom folders): the folder of its deepest
/// zoom level, which GDAL's MVT driver opens. Any other path: itself.
std::string vectorTilePath(const std::string& path);

/// The zoom level of a dataset of vector tiles (MBTiles: its ZOOM_LEVEL metadata; MVT: the
/// opened folder's name); nothing for other datasets.
std::optional<int> vectorTileZoom(GDALDataset& ds, const std::string& openedPath);

/// The largest ground distance (metres) between a drawn position and the source's, for tiles
/// of `zoom` quantised to `extent` units a side: a vertex is rounded by half a unit along each
/// axis (√2/2 units); where an edge crosses a tile edge, the crossing is snapped along the tile
/// edge by up to half a unit more (stitchedTileFeatures). Units of Web Mercator metres, longer
/// than the ground's by 1/cos(latitude), so the bound holds at any latitude.
double vectorTileQuantisation(int zoom, int extent = 4096);

/// Every feature of the layer (its spatial filter applied), those that share an mvt_id as one:
/// polygons united, lines gathered; the feature id is the mvt_id. Positions are snapped to the
/// grid of tiles of `zoom` with 4096 units a side (the tiles' own, up to GDAL's rounding), so
/// that pieces meeting on a tile edge share it exactly. `unitedFailures` counts the groups
/// whose union GEOS could not make (their pieces are kept as parts).
std::vector<FeaturePtr> stitchedTileFeatures(OGRLayer& layer, int zoom, std::size_t& unitedFailures);

}  // namespace gis::geo::detail
