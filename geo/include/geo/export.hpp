#pragma once
// GeoJSON export of selected vector features (lasso selection: "export selected features as
// GeoJSON, original attributes, original CRS"). Features are re-read from their source file by
// FID, so geometry and attributes are the file's, not the frame's (no densification, no
// projection); GDAL's GeoJSON driver writes them.
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"
#include "geo/vector.hpp"

namespace gis::geo {

/// One selected feature and the properties the selection adds to it.
struct ExportedFeature {
  std::int64_t fid = -1;  ///< OGR FID, as readVectorLayer gives it (Feature::fid)
  /// Properties added to the original attributes (e.g. "selection_fully_inside"). A name equal
  /// to an original attribute replaces that attribute (with a warning).
  std::map<std::string, AttributeValue> extra;
};

/// The selected features of one vector layer.
struct ExportSource {
  std::string path;        ///< the vector file the features were read from
  std::string layer;       ///< OGR layer name; empty = the first layer (as VectorReadOptions::layer)
  std::string assumedCrs;  ///< CRS when the file has none (as VectorReadOptions::assumedCrs)
  std::string label;       ///< the scene's layer name: "selection_layer" in combined files (empty = OGR name)
  std::vector<ExportedFeature> features;
};

/// Writes the features of one source as a GeoJSON FeatureCollection: geometry exactly as in the
/// source (curves are approximated by line segments, with a warning) and in its CRS, every
/// original attribute with its type, the extra properties, the FID as the feature "id". A CRS
/// other than WGS 84 lon/lat goes into a GeoJSON 2008 "crs" member: its OGC URN where it has one
/// (as GDAL writes it), else its WKT as the name (GDAL reads that back; see export.cpp).
/// An FID not in the source is an error naming file, layer and FID; the others are still written.
/// An existing output file is replaced. The output must not be the source file.
Diagnostics exportFeaturesGeoJson(const ExportSource& source, const std::string& outPath);

/// Writes the features of all sources into one RFC 7946 FeatureCollection: WGS 84 lon/lat
/// (reprojected with OGR, traditional GIS axis order), polygons with right-hand-rule rings,
/// coordinates with 1e-15 degree resolution. Fields are the union of the sources' fields (a name
/// with different types in two sources becomes a String field; Integer and Integer64 give
/// Integer64), then "selection_layer" (the label), "selection_fid" and the extra properties.
/// A source that cannot be opened or reprojected, or an FID not found, is an error naming file,
/// layer (and FID); everything else is still written.
Diagnostics exportFeaturesGeoJsonCombined(std::span<const ExportSource> sources, const std::string& outPath);

}  // namespace gis::geo
