#pragma once
// The scene's vector layers as read, kept on disk for the next run (issue 23, "a second run
// starts in seconds"): reading a large layer through OGR checks every polygon's validity (GEOS),
// reprojects every point and densifies lon/lat edges, about 3 s for 900 k vertices. A cached
// layer holds the features as read (in the scene frame) and every diagnostic the read gave, so
// a warm start says the same things. Its features are indexed (geo::FeatureFile) and read one at
// a time, when a tile needs them: the scene keeps the index, not the features.
//
// The key covers what the result depends on: the source's absolute path and layer, the size and
// modification time of the file and of its sidecars (a Shapefile's .dbf, .shx, .prj: every file
// of the same stem beside it), the frame (CRS and origin), the read options, and the SHA-1 of the
// reader's code. Sources that are not one file (a PostGIS table, a folder of vector tiles) are
// not cached: they may change without a file telling.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "core/diagnostics.hpp"
#include "geo/checked_file.hpp"
#include "geo/feature_file.hpp"
#include "geo/frame.hpp"
#include "geo/vector.hpp"

namespace gis::scene::detail {

/// The key of reading `source` with `options` into `frame`; none when it is not cached.
std::optional<std::uint64_t> layerCacheKey(const std::string& source, const geo::SceneFrame& frame,
                                           const geo::VectorReadOptions& options);

/// The file in `directory` that holds the layer of `key`.
std::string layerCacheFile(const std::string& directory, std::uint64_t key);

/// A layer as stored: what was read and said (its features left in the file), and the file's
/// features, read one at a time (null when the read failed).
struct CachedLayer {
  Result<geo::VectorLayer> read;
  std::shared_ptr<const geo::FeatureFile> features;
};

/// What reading a layer's file gave: the layer, or why not (no file: Missing, quietly built;
/// any file that is not whole and this layer's: Damaged, rebuilt with a warning).
struct LayerCacheRead {
  std::optional<CachedLayer> layer;
  geo::io::CheckedStatus status = geo::io::CheckedStatus::Missing;
  std::string why;
};

/// The layer and its diagnostics as stored. Verifies every section's checksum (the features'
/// bodies included, read through once) and reads the header and the features' index (about 80
/// bytes a feature): the features stay on disk.
LayerCacheRead readLayerCache(const std::string& file, std::uint64_t key);

/// What writing a layer's file gave: what `read` returned (none if it never ran), and whether
/// the file was written (else why not).
struct LayerCacheWrite {
  std::optional<Result<geo::VectorLayer>> result;
  geo::io::WriteOutcome outcome;
};

/// Reads a layer into the cache: `read` reads it, handing each good feature to the sink it is
/// given (geo::VectorReadOptions::sink), which writes it to the file at once; what it returns
/// (its diagnostics, a failure too, and the layer without its features) is stored after them.
/// The layer is read in the memory of one feature, whatever its size. When the file cannot be
/// written (outcome false) the features handed to the sink are lost: read again.
LayerCacheWrite writeLayerCache(
    const std::string& file, std::uint64_t key,
    const std::function<Result<geo::VectorLayer>(const std::function<void(geo::Feature&&)>&)>& read);

}  // namespace gis::scene::detail
