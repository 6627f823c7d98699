#pragma once
// The disk cache of built tiles (tiled_layer.hpp): one file per tile holding its features (as
// generalised and cut for the tile), which feature of the layer each is, and their polyhedra,
// so that a second run reads what the first built instead of building it again. Each file
// holds the tile twice: lean (its GPU arrays and its pieces' boxes, which a far view draws,
// LayerGeometry::writeLean) and whole (features and footprints, for views near it and edits). A file names
// the fingerprint of everything its pieces depend on (the layer's features and styles, the
// build and tiling options, the terrain). Files are checked (geo/checked_file.hpp): a section is
// verified against its checksum before any byte of it is used; a file under a tile's name that
// is not that tile whole is damaged, named, and written again.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "vector_overlay/tiled_layer.hpp"

namespace gis::overlay::detail {

/// The file of tile `key` in a layer's folder of the cache (both frames name them so).
std::filesystem::path tileFileIn(const std::filesystem::path& folder, const TileKey& key);

/// Writes the tile (to a temporary file renamed into place: readers never see half a file).
/// False when it cannot be written (the cache is then simply not used). A tile of world pieces
/// (LayerGeometry::ofWorldPieces) is lean as built: its whole section holds no features.
bool writeTile(const std::filesystem::path& file, std::uint64_t fingerprint, const LayerTile& tile);

/// The tile in `file` if it holds this fingerprint and key, its layer made with the source's
/// name, kind and style, each feature's style in the tile (`styleOf`, by the feature's index in
/// the source), `bounds` and `options` (as LayerTiling::build would). `lean`: as
/// LayerGeometry::releaseFootprints leaves it (the GPU arrays, pieces' boxes and bounds; no
/// footprints, no feature geometry), read with a few large reads.
/// The length of the lean section of the tile in `file` (about its GPU bytes), if the file
/// holds this fingerprint and key; reads the header only.
std::optional<std::size_t> tileBytes(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key);

std::optional<LayerTile> readTile(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key,
                                  const LayerGeometry& source, const HeightBoundsProvider& bounds,
                                  const LayerBuildOptions& options,
                                  const std::function<FeatureStyle(std::uint32_t)>& styleOf, bool lean = false,
                                  std::string* damage = nullptr);

/// A tile of world pieces (another frame's tiles: the globe's) in `file`, if it holds this
/// fingerprint and key (LayerGeometry::readWorldLean), named `name`, its colour groups drawn in
/// `groupColours`. `lean`: its GPU arrays left in the file for the upload (no pieces to clip at
/// the near plane); else read (a tile near the eye). `damage` as readTile.
std::optional<LayerTile> readWorldTile(const std::filesystem::path& file, std::uint64_t fingerprint, const TileKey& key,
                                       const std::string& name, std::span<const glm::vec4> groupColours, bool lean,
                                       std::string* damage = nullptr);

}  // namespace gis::overlay::detail
