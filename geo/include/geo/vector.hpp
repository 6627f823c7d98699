#pragma once
// Vector reading through OGR (GeoJSON, Shapefile, GeoPackage and whatever else OGR reads):
// polygons with holes, multi-parts and line strings with their attributes, reprojected into
// the scene frame; long edges in geographic CRSs densified along geodesics first.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <glm/vec2.hpp>

#include "core/diagnostics.hpp"
#include "geo/feature.hpp"
#include "geo/frame.hpp"

namespace gis::geo {

enum class GeometryKind { Polygon, Line, Mixed, Empty };

struct VectorLayer {
  std::string path;
  std::string name;
  std::string sourceCrsWkt;
  GeometryKind kind = GeometryKind::Empty;
  std::vector<Feature> features;  ///< only the good ones; the broken ones are in diagnostics
  /// Vector tiles (MBTiles, a folder of MVT tiles): the largest distance (metres, on the
  /// ground) of a position from the source's, from the tiles' quantisation; 0 for other sources.
  double quantisationMetres = 0.0;

  [[nodiscard]] std::size_t vertexCount() const;
};

struct VectorReadOptions {
  /// Layer to read; empty = the first layer of the data source.
  std::string layer;
  /// When the source CRS is geographic (longitude/latitude), an edge means the geodesic between
  /// its ends. Points along it are added wherever the geodesic, projected into the frame,
  /// departs from the projected chord by more than this (metres): the drawn edge is then within
  /// this of the true one. 1 mm is below the precision of any lon/lat source (7 decimals of a
  /// degree are 1 cm) and under the overlay's 0.5 px at any view but one closer than 2.5 m
  /// (docs/overlay.md). Edges shorter than a few km need none: in a UTM zone a geodesic's
  /// image bows by κL²/8 with κ ≤ 1e-8 /m, 0.3 mm over 1 km at 200 km from the central meridian.
  /// +infinity: no points for the shape.
  double geodesicToleranceMetres = 1e-3;
  /// And points along the geodesic so that no piece is longer than this (metres, on the
  /// ellipsoid; +infinity: no limit by length).
  double maxGeodesicSegmentMetres = std::numeric_limits<double>::infinity();
  /// CRS assumed when the file has none (OGR user input, e.g. "OGC:CRS84"); empty = error.
  std::string assumedCrs;
  /// Read only the features that may meet this box (frame coordinates, [min, max]): the box is
  /// mapped into the source CRS (its outline sampled, the bounds widened by 1 %) and given to
  /// OGR as a spatial filter, which the drivers with an index answer from it (GeoPackage's and
  /// SpatiaLite's R-tree, FlatGeobuf's packed R-tree, a Shapefile's .qix, PostGIS's GiST).
  /// Every feature that meets the box is read; some that do not may be read too. None: all.
  std::optional<std::array<glm::dvec2, 2>> filter;
  /// Each good feature, as it is read, handed here instead of kept in VectorLayer::features
  /// (which then stays empty): a layer of any size read in the memory of one feature (the
  /// scene's layer cache writes them to its file so). Empty: kept.
  std::function<void(Feature&&)> sink;
  /// Called with the fraction of the layer's features read, about every percent, where the
  /// source knows its feature count without a scan (GeoPackage, Shapefile, FlatGeobuf, PostGIS).
  std::function<void(double)> progress;
};

/// Names of the layers in a vector data source.
Result<std::vector<std::string>> listVectorLayers(const std::string& path);

/// Reads one layer into the frame. `path` may be any OGR source (a file, a folder of
/// Shapefiles, a "PG:" connection string for PostGIS, an MBTiles file or a folder of MVT tiles,
/// read at its deepest zoom level with each feature's tile pieces stitched). A broken feature (empty or unsupported
/// geometry, NaN/Inf coordinates, a point that cannot be projected, a ring with fewer than 3 distinct points) is left
/// out with an error naming file, layer and feature; the good features still load. Only a file that cannot be opened, a
/// missing layer or an unknown CRS fail as a whole.
Result<VectorLayer> readVectorLayer(const std::string& path, const SceneFrame& frame,
                                    const VectorReadOptions& options = {});

/// The extent of every layer of a vector data source in WGS 84 longitude/latitude degrees:
/// {west, south, east, north}. Fails naming the file when it cannot be opened, holds no
/// features with coordinates, or a layer has no CRS.
Result<std::array<double, 4>> vectorExtentLonLat(const std::string& path);

/// Points along the geodesic from a to b (lon/lat degrees, on the given ellipsoid) such that no
/// piece is longer than maxSegmentMetres; includes a, excludes b.
std::vector<glm::dvec2> densifyGeodesic(const glm::dvec2& a, const glm::dvec2& b, double maxSegmentMetres,
                                        double semiMajor, double flattening);

/// Maps lon/lat to a plane (the frame); nothing for a point that cannot be mapped.
using GeodesicProjection = std::function<std::optional<glm::dvec2>(const glm::dvec2&)>;

/// Points along the geodesic from a to b (lon/lat degrees, on the given ellipsoid) such that the
/// polyline through them, mapped by `project`, stays within toleranceMetres of the mapped
/// geodesic (judged at a quarter, half and three quarters of every piece); includes a, excludes b.
std::vector<glm::dvec2> densifyGeodesicWithin(const glm::dvec2& a, const glm::dvec2& b, double toleranceMetres,
                                              double semiMajor, double flattening, const GeodesicProjection& project);

}  // namespace gis::geo
