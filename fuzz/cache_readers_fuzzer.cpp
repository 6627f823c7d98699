// Fuzzes the readers of the vector caches (docs/cache.md): a layer as read
// (scene::detail::readLayerCache, then geo::FeatureFile::read of every feature), a built tile
// (overlay::detail::tileBytes and readTile, lean and whole, and the lean section alone through
// LayerGeometry::readLean in memory; the same file as a tile of world pieces, readWorldTile, as
// the globe reads its tiles) and a deferred layer's checks
// (readChecks, reached through LayerGeometry::build with deferPieces and a checkCacheDirectory).
//
// Random bytes almost never match a section's XXH3 digest, so most inputs are WRAPPED: the input
// is split into section payloads at kSeparator and written with geo::io::writeCheckedFile, so
// that the digests hold and the parsers behind them see the bytes. A valid header (magic,
// version, the key the reader asks for) is put first unless the flags say the input gives it.
// Now and then the table itself is edited after the wrap (its digest made to hold again), and
// some inputs are written raw, as the file, for the table's own parsing.
//
// The input: byte 0 is the flags, the rest the parts (split at kSeparator).
//   bits 0–1  which reader: 0 layer file, 1 tile file (tileBytes, readTile lean and whole),
//             2 checks file, 3 raw: the rest of the input is the file, given to all three
//   bits 2–3  the layer the tile and checks readers read for (makeFixture: areas, roads in
//             metres, roads in pixels, areas built the seed paper's way)
//   bits 4–5  both set: the first part is the header section as given (no header made)
//   bit 6     the last part is a list of table edits (a 16-bit place, a byte to xor), applied
//             to the section table after the wrap, the table's digest then made to hold
//
// Invariants: no crash, undefined behaviour, leak or unbounded allocation (ASan, UBSan,
// -rss_limit_mb); a file is either rejected, and said to be damaged with a reason, or read into
// something that passes the checks its users rely on:
// - a layer file's features each read back as its index entry says (the same vertex count and
//   boxes), or the read throws naming the file; the entries' boxes are finite or empty;
// - a tile read whole: every piece's triangles and boundary index its vertices, its centres
//   and directions (lines in pixels) one per vertex, its coordinates and bounds finite and within
//   ±1e15 m, lo ≤ hi, its box ordered (with STENCIL_GIS_FUZZ_STRICT_PIECES=1 every piece must
//   also pass overlay::polyhedronProblems: closed, outward and bounded);
// - a tile read whole or lean: every slot indexes within the index array, every index within
//   the vertices (read from the file slice by slice for a lean tile), the seed paper's box
//   indices too, its origin and feature exist, the scaling stream (lines in pixels) has a
//   vertex's worth or none; origins, piece bounds and boxes finite; one outcome and one style
//   per feature, each feature one of the layer's;
// - a lean section is read from its file exactly when it is read alone in memory;
// - checks read back have one outcome per feature; a rejected checks file is named in a warning.
// Any violation prints what and aborts, so that libFuzzer keeps the input.
//
// STENCIL_GIS_FUZZ_WRITE_SEEDS=<folder> makes the harness write its seeds (real cache files'
// sections, in the input format above) to <folder> and exit: fuzz/corpus/cache_readers/.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"
#include "geo/feature_file.hpp"
#include "geo/vector.hpp"
#include "layer_cache.hpp"
#include "tile_cache.hpp"
#include "vector_overlay/layer_geometry.hpp"
#include "vector_overlay/near_clip.hpp"
#include "vector_overlay/tiled_layer.hpp"
#include "vector_overlay/validation.hpp"

namespace {

namespace fs = std::filesystem;
using gis::Diagnostics;
using gis::Result;
using gis::Severity;
using gis::geo::Feature;
using gis::geo::io::CheckedFile;
using gis::geo::io::CheckedStatus;
using gis::overlay::CellGrid;
using gis::overlay::FeatureOutcome;
using gis::overlay::FeatureStyle;
using gis::overlay::LayerBuildOptions;
using gis::overlay::LayerGeometry;
using gis::overlay::LayerKind;
using gis::overlay::LayerStyle;
using gis::overlay::LayerTile;
using gis::overlay::Polyhedron;
using gis::overlay::TileKey;

constexpr std::string_view kSeparator = "|SECT|";
constexpr std::uint32_t kLayerMagic = 0x4c564753;  // scene/src/layer_cache.cpp
constexpr std::uint32_t kLayerVersion = 4;
constexpr std::uint32_t kTileMagic = 0x54564753;  // vector_overlay/src/tile_cache.cpp
constexpr std::uint32_t kTileVersion = 5;
constexpr std::uint32_t kChecksMagic = 0x4B484353;  // vector_overlay/src/layer_geometry.cpp
constexpr std::uint64_t kLayerKey = 0x5eed1a7e5eed1a7eULL;
constexpr std::uint64_t kFingerprint = 0x7115eed7115eedULL;
const TileKey kTileKey{2, 1, 3, 0};
constexpr double kGroundError = 1.5;
constexpr double kMaxCoordinate = 1e15;  // overlay::ValidationOptions::maxCoordinate

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "cache_readers_fuzzer: invariant broken: %s\n", what.c_str());
  std::abort();
}

void require(bool ok, const std::string& what) {
  if (!ok) fail(what);
}

bool verbose();

/// With STENCIL_GIS_FUZZ_VERBOSE=1: what a reader made of the input.
void say(const std::string& what) {
  if (verbose()) std::fprintf(stderr, "cache_readers_fuzzer: %s\n", what.c_str());
}

/// Flat ground with a little relief: the readers never look at it, assemble reads anchor heights.
class FlatBounds final : public gis::HeightBoundsProvider {
 public:
  [[nodiscard]] gis::HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override {
    (void)footprint;
    return {-12.0, 35.0};
  }
  [[nodiscard]] gis::HeightBounds globalBounds() const override { return {-12.0, 35.0}; }
};

CellGrid grid() {
  CellGrid g;
  g.origin = glm::dvec2(-500.0);
  g.cellSize = 250.0;
  g.columns = g.rows = 4;
  return g;
}

/// The features of the fixtures' layers: a few small shapes over the 4 × 4 cells, crossing
/// their borders (so that pieces are cut), with a hole, a multi-part and attributes.
std::vector<Feature> polygons() {
  std::vector<Feature> out(4);
  out[0].fid = 10;
  out[0].polygons.push_back({{{-400.0, -400.0}, {-100.0, -400.0}, {-100.0, -100.0}, {-400.0, -100.0}},
                             {{{-300.0, -300.0}, {-300.0, -200.0}, {-200.0, -200.0}, {-200.0, -300.0}}}});
  out[0].attributes["name"] = std::string("block");
  out[1].fid = 11;
  out[1].polygons.push_back({{{10.0, 10.0}, {300.0, 40.0}, {120.0, 280.0}}, {}});
  out[1].attributes["height"] = 12.5;
  out[2].fid = 12;
  out[2].polygons.push_back({{{-480.0, 300.0}, {-420.0, 300.0}, {-420.0, 360.0}}, {}});
  out[2].polygons.push_back({{{-200.0, 300.0}, {-20.0, 260.0}, {-60.0, 460.0}, {-150.0, 380.0}}, {}});
  out[2].attributes["floors"] = std::int64_t{3};
  out[3].fid = 13;
  out[3].polygons.push_back(
      {{{240.0, -480.0}, {480.0, -480.0}, {480.0, -240.0}, {360.0, -300.0}, {240.0, -240.0}}, {}});
  return out;
}

std::vector<Feature> lines() {
  std::vector<Feature> out(4);
  out[0].fid = 20;
  out[0].lines.push_back({{-450.0, -450.0}, {-200.0, -180.0}, {60.0, -220.0}});
  out[1].fid = 21;
  out[1].lines.push_back({{100.0, 100.0}, {140.0, 330.0}});
  out[1].lines.push_back({{300.0, 120.0}, {420.0, 140.0}, {430.0, 260.0}});
  out[2].fid = 22;
  out[2].lines.push_back({{-300.0, 400.0}});  // one point: an Error in the checks
  out[3].fid = 23;
  out[3].lines.push_back({{9000.0, 9000.0}, {9100.0, 9000.0}});  // beyond the cells: nothing to draw
  return out;
}

/// A layer the tile and checks readers read for: the source a tiling would have (its features
/// and styles, no pieces), the options its tiles are built with, and where its checks are kept.
struct Fixture {
  std::string name;
  LayerKind kind = LayerKind::Polygon;
  LayerStyle style;
  std::vector<Feature> features;
  LayerBuildOptions options;       ///< a tile's (pieces built)
  LayerBuildOptions checkOptions;  ///< deferPieces, with a checkCacheDirectory
  std::optional<LayerGeometry> source;
  fs::path checksFile;
};

struct World {
  fs::path dir;
  FlatBounds bounds;
  std::vector<Fixture> fixtures;
  bool strictPieces = false;
  bool verbose = false;  ///< STENCIL_GIS_FUZZ_VERBOSE=1: what each reader made of the input
};

World* world = nullptr;

void removeWorld() {
  if (world == nullptr) return;
  std::error_code ec;
  fs::remove_all(world->dir, ec);
}

Fixture makeFixture(int k, const fs::path& dir, const FlatBounds& bounds) {
  Fixture f;
  f.options.footprints.cells = grid();
  f.options.threads = 1;
  switch (k) {
    case 0:
      f.name = "areas";
      f.features = polygons();
      f.style.colorAttribute = "name";  // a colour by category: the vertices hold the colours
      f.style.categories["block"] = glm::vec4(0.2F, 0.4F, 0.9F, 1.0F);
      break;
    case 1:
      f.name = "roads";
      f.kind = LayerKind::Line;
      f.style.widthMetres = 8.0;
      f.style.join = gis::overlay::LineJoin::Bevel;
      f.style.cap = gis::overlay::LineCap::Flat;
      f.options.footprints.uniteLines = true;  // a piece per cell (PieceKind::Line)
      f.features = lines();
      break;
    case 2:
      f.name = "roads in pixels";
      f.kind = LayerKind::Line;
      f.style.widthPixels = 1.5;
      f.style.maxWidthMetres = 10.0;
      f.options.footprints.chordTolerancePixels = 0.5;  // few chords: small seeds
      f.style.join = gis::overlay::LineJoin::Miter;
      f.style.cap = gis::overlay::LineCap::Square;
      f.features = lines();
      f.features.erase(f.features.begin());
      f.features.front().lines.pop_back();  // lines in pixels take many bytes a vertex: small seeds
      break;
    default:
      f.name = "areas, the paper's way";
      f.features = polygons();
      f.options.paperVariant = true;
      break;
  }
  f.checkOptions = f.options;
  f.checkOptions.deferPieces = true;
  f.checkOptions.checkCacheDirectory = (dir / ("checks-" + std::to_string(k))).string();
  Result<LayerGeometry> source = LayerGeometry::build(f.name, f.kind, f.style, f.features, bounds, f.checkOptions);
  require(source.ok(), "the fixture " + f.name + " builds");
  f.source = std::move(source.value);
  for (const fs::directory_entry& e : fs::directory_iterator(f.checkOptions.checkCacheDirectory))
    if (e.path().extension() == ".checks") f.checksFile = e.path();
  require(!f.checksFile.empty(), "the fixture " + f.name + " wrote its checks");
  return f;
}

World& theWorld();
bool verbose() { return theWorld().verbose; }

World& theWorld() {
  if (world != nullptr) return *world;
  world = new World();  // lives as long as the process
  const char* tmp = std::getenv("TMPDIR");
  world->dir =
      fs::path(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") / ("cache_readers_fuzzer." + std::to_string(::getpid()));
  fs::remove_all(world->dir);
  fs::create_directories(world->dir);
  std::atexit(removeWorld);
  for (int k = 0; k < 4; ++k) world->fixtures.push_back(makeFixture(k, world->dir, world->bounds));
  const char* strict = std::getenv("STENCIL_GIS_FUZZ_STRICT_PIECES");
  world->strictPieces = strict != nullptr && std::string_view(strict) == "1";
  const char* verbose = std::getenv("STENCIL_GIS_FUZZ_VERBOSE");
  world->verbose = verbose != nullptr && std::string_view(verbose) == "1";
  return *world;
}

// ---- the input ----

struct Input {
  std::uint8_t flags = 0;
  std::string rest;                ///< everything after the flags (the raw file)
  std::vector<std::string> parts;  ///< rest split at kSeparator
  std::string edits;               ///< table edits (flag bit 6): the last part
};

Input parse(const std::uint8_t* data, std::size_t size) {
  Input in;
  if (size > 0) {
    in.flags = data[0];
    in.rest.assign(reinterpret_cast<const char*>(data) + 1, size - 1);
  }
  std::size_t at = 0;
  for (;;) {
    const std::size_t next = in.rest.find(kSeparator, at);
    in.parts.push_back(in.rest.substr(at, next == std::string::npos ? std::string::npos : next - at));
    if (next == std::string::npos) break;
    at = next + kSeparator.size();
  }
  if ((in.flags & 0x40U) != 0 && in.parts.size() > 1) {
    in.edits = std::move(in.parts.back());
    in.parts.pop_back();
  }
  return in;
}

template <typename T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

std::string layerHeader() {
  std::string h;
  put(h, kLayerMagic);
  put(h, kLayerVersion);
  put(h, kLayerKey);
  return h;
}

std::string tileHeader() {
  std::string h;
  put(h, kTileMagic);
  put(h, kTileVersion);
  put(h, kFingerprint);
  put(h, kTileKey.level);
  put(h, kTileKey.x);
  put(h, kTileKey.y);
  put(h, kTileKey.width);
  put(h, kGroundError);
  return h;
}

/// The start of a checks file's one section: the magic and as many outcomes as `fixture` has.
std::string checksHeader(const Fixture& fixture) {
  std::string h;
  put(h, kChecksMagic);
  put(h, static_cast<std::uint64_t>(fixture.features.size()));
  return h;
}

/// Applies table edits to the checked file `file` (its table found from its tail), then makes
/// the table's digest hold again: the table's parsing beyond its digest.
void editTable(const fs::path& file, const std::string& edits) {
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  constexpr std::size_t kTail = sizeof(std::uint64_t) + sizeof(std::uint32_t);
  if (bytes.size() < kTail) return;
  std::uint64_t tableAt = 0;
  std::memcpy(&tableAt, bytes.data() + bytes.size() - kTail, sizeof(tableAt));
  if (tableAt > bytes.size() - kTail || bytes.size() - kTail - tableAt < 2 * sizeof(std::uint64_t)) return;
  const std::size_t tableBytes = bytes.size() - kTail - static_cast<std::size_t>(tableAt);
  const std::size_t editable = tableBytes - sizeof(std::uint64_t);  // not its digest
  char* table = bytes.data() + tableAt;
  for (std::size_t k = 0; k + 3 <= edits.size(); k += 3) {
    const std::size_t place =
        std::size_t{static_cast<std::uint8_t>(edits[k])} | (std::size_t{static_cast<std::uint8_t>(edits[k + 1])} << 8U);
    table[place % editable] = static_cast<char>(table[place % editable] ^ edits[k + 2]);
  }
  const std::uint64_t d = gis::geo::io::digest(table, editable);
  std::memcpy(table + editable, &d, sizeof(d));
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Writes `sections` as a checked file (their digests hold), then applies `edits` to its table.
void writeWrapped(const fs::path& file, const std::vector<std::string>& sections, const std::string& edits) {
  const gis::geo::io::WriteOutcome written =
      gis::geo::io::writeCheckedFile(file, [&](std::ostream& out, gis::geo::io::SectionMarks& marks) {
        for (const std::string& s : sections) {
          marks.begin();
          out.write(s.data(), static_cast<std::streamsize>(s.size()));
        }
      });
  require(written.written, "the harness writes " + file.string() + ": " + written.error);
  if (!edits.empty()) editTable(file, edits);
}

void writeRaw(const fs::path& file, const std::string& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  require(static_cast<bool>(out), "the harness writes " + file.string());
}

// ---- the invariants ----

bool finite(const glm::dvec2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }
bool bounded(double v) { return std::isfinite(v) && std::abs(v) <= kMaxCoordinate; }
bool bounded(const glm::dvec2& p) { return bounded(p.x) && bounded(p.y); }
bool bounded(const glm::dvec3& p) { return bounded(p.x) && bounded(p.y) && bounded(p.z); }

/// An index entry's box: empty as FeatureFileEntry::of leaves it, or finite and ordered.
bool wellFormedBox(const glm::dvec2& lo, const glm::dvec2& hi) {
  if (lo == glm::dvec2(1.0) && hi == glm::dvec2(-1.0)) return true;
  return finite(lo) && finite(hi) && lo.x <= hi.x && lo.y <= hi.y;
}

void checkDiagnostics(const Diagnostics& diagnostics, const std::string& what) {
  for (const gis::Diagnostic& d : diagnostics.items()) {
    const auto severity = static_cast<int>(d.severity);
    require(severity >= 0 && severity <= static_cast<int>(Severity::Error), what + ": a message's severity is one");
  }
}

void checkLayerFile(const fs::path& file) {
  const gis::scene::detail::LayerCacheRead read = gis::scene::detail::readLayerCache(file.string(), kLayerKey);
  if (!read.layer) {
    say("layer file refused: " + read.why);
    require(read.status == CheckedStatus::Damaged && !read.why.empty(),
            "a layer file that is there and refused is damaged, with a reason (status " +
                std::to_string(static_cast<int>(read.status)) + ", '" + read.why + "')");
    return;
  }
  require(read.status == CheckedStatus::Ok, "a layer file read is Ok");
  const gis::scene::detail::CachedLayer& cached = *read.layer;
  checkDiagnostics(cached.read.diagnostics, "a layer file");
  if (!cached.read.ok()) {
    say("layer file read: a read that failed, " + std::to_string(cached.read.diagnostics.items().size()) + " messages");
    require(cached.features == nullptr, "a failed read stored has no features");
    return;
  }
  require(cached.features != nullptr, "a layer read has its features' file");
  require(static_cast<int>(cached.read->kind) >= 0 &&
              static_cast<int>(cached.read->kind) <= static_cast<int>(gis::geo::GeometryKind::Empty),
          "the layer's kind is one");
  const gis::geo::FeatureFile& features = *cached.features;
  std::uint64_t vertices = 0;
  bool all = true;
  for (std::size_t i = 0; i < features.size(); ++i) {
    const gis::geo::FeatureFileEntry& entry = features.entry(i);
    require(wellFormedBox(entry.ringLo, entry.ringHi) && wellFormedBox(entry.lineLo, entry.lineHi),
            "feature " + std::to_string(i) + "'s index boxes are empty or finite and ordered");
    try {
      const Feature f = features.read(i);
      require(f.vertexCount() == entry.vertices, "feature " + std::to_string(i) + " has the vertices its entry says");
      const gis::geo::FeatureFileEntry again = gis::geo::FeatureFileEntry::of(f, entry.offset);
      require(again.ringLo == entry.ringLo && again.ringHi == entry.ringHi && again.lineLo == entry.lineLo &&
                  again.lineHi == entry.lineHi,
              "feature " + std::to_string(i) + " lies in the boxes its entry says");
      vertices += f.vertexCount();
    } catch (const std::runtime_error& e) {
      require(std::string(e.what()).find(file.string()) != std::string::npos,
              std::string("a feature that cannot be read is named with its file: ") + e.what());
      all = false;
    }
  }
  if (all) require(vertices == features.vertexCount(), "the features hold the vertices the index says");
  say("layer file read: " + std::to_string(features.size()) + " features" + (all ? "" : ", some refused"));
}

/// The indices a tile draws: its own, or those left in its file (read as the upload reads them).
std::vector<std::uint32_t> indicesOf(const LayerGeometry& g) {
  const gis::overlay::ArraysInFile* arrays = g.arraysInFile();
  if (arrays == nullptr) return g.indices();
  std::vector<std::uint32_t> indices(arrays->indexCount);
  const bool read = arrays->read(
      arrays->indicesAt, indices.size() * sizeof(std::uint32_t),
      [&](const void* data, std::uint64_t offset, std::uint64_t n) {
        std::memcpy(reinterpret_cast<char*>(indices.data()) + offset, data, static_cast<std::size_t>(n));
      },
      4096);
  require(read, "a lean tile's indices can be read from its file");
  return indices;
}

void checkWholePiece(const Polyhedron& p, std::size_t k, bool strict, const gis::overlay::ValidationOptions& options) {
  const std::string piece = "whole tile, piece " + std::to_string(k) + ": ";
  const gis::overlay::Footprint& f = p.footprint;
  for (const auto& t : f.triangles)
    for (const std::uint32_t v : t) require(v < f.vertices.size(), piece + "a triangle indexes its vertices");
  for (const auto& e : f.boundary)
    for (const std::uint32_t v : e) require(v < f.vertices.size(), piece + "a boundary edge indexes its vertices");
  require(f.centres.empty() || (f.centres.size() == f.vertices.size() && f.directions.size() == f.vertices.size()),
          piece + "centres and directions one per vertex, or none");
  for (const glm::dvec2& v : f.vertices) require(bounded(v), piece + "vertices finite, within 1e15");
  for (const glm::dvec3& c : f.centres) require(bounded(c), piece + "centres finite, within 1e15");
  for (const glm::dvec2& d : f.directions) require(finite(d), piece + "directions finite");
  if (strict) {
    const std::vector<std::string> problems = gis::overlay::polyhedronProblems(p, options);
    if (!problems.empty()) fail(piece + "polyhedronProblems: " + problems.front());
  }
}

/// What a draw, the upload and the tiled technique rely on in a tile's geometry, read whole or
/// lean (`lean`: its pieces have no footprints). `what` names it in a failure.
void checkGeometry(const Fixture& fx, const LayerGeometry& g, bool lean, bool strict, const std::string& what) {
  const std::size_t features = g.sharedFeatures().size();
  require(g.featureOutcomes().size() == features && g.featureStyles().size() == features,
          what + "an outcome and a style per feature");
  for (const FeatureOutcome o : g.featureOutcomes())
    require(static_cast<std::uint8_t>(o) <= static_cast<std::uint8_t>(FeatureOutcome::Hidden),
            what + "each outcome is one");
  require(g.slots().size() == g.polyhedra().size(), what + "a piece per slot");
  for (const glm::dvec2& o : g.origins()) require(bounded(o), what + "origins finite, within 1e15");

  const std::vector<std::uint32_t> indices = indicesOf(g);
  const std::uint64_t vertices = g.vertexCount();
  const gis::overlay::ArraysInFile* arrays = g.arraysInFile();
  const std::size_t scaling = arrays != nullptr ? arrays->scalingCount : g.scaling().size();
  require(scaling == (g.widthPixels() > 0.0 ? vertices : 0),
          what + "the scaling stream has a vertex's worth (lines in pixels) or none (" + std::to_string(scaling) +
              " for " + std::to_string(vertices) + " vertices)");
  const auto within = [&](std::uint64_t first, std::uint64_t count, std::uint32_t base, const std::string& range) {
    require(first + count <= indices.size(), what + range + " within the indices");
    for (std::uint64_t i = first; i < first + count; ++i)
      require(std::uint64_t{base} + indices[static_cast<std::size_t>(i)] < vertices,
              what + range + ": every index within the vertices");
  };
  gis::overlay::ValidationOptions options;
  if (!fx.options.paperVariant) options.grid = fx.options.footprints.cells;
  gis::overlay::ValidationOptions unsplit = options;
  unsplit.grid.reset();
  for (std::size_t k = 0; k < g.slots().size(); ++k) {
    const LayerGeometry::PieceSlot& s = g.slots()[k];
    const std::string slot = "slot " + std::to_string(k);
    require(s.feature < features, what + slot + "'s feature exists");
    require(s.origin < g.origins().size(), what + slot + "'s origin exists");
    require(s.bottomCount <= s.indexCount, what + slot + "'s bottom cap within its indices");
    within(s.firstIndex, s.indexCount, s.baseVertex, slot);
    if (fx.options.paperVariant) within(s.boxFirstIndex, 36, s.baseVertex, slot + "'s box");
    const Polyhedron& p = g.polyhedra()[k];
    require(bounded(p.lo) && bounded(p.hi) && p.lo <= p.hi,
            what + slot + "'s bounds finite and ordered (" + std::to_string(p.lo) + ", " + std::to_string(p.hi) + ")");
    require(bounded(p.boxMin) && bounded(p.boxMax) && p.boxMin.x <= p.boxMax.x && p.boxMin.y <= p.boxMax.y,
            what + slot + "'s box finite and ordered");
    if (!lean) checkWholePiece(p, k, strict, p.footprint.scalable() ? unsplit : options);
  }
  // What a draw and the tiled technique read of it.
  (void)g.box3();
  (void)g.maxOverlap();
  (void)g.pieceBox();
  (void)g.uniformColor();
  if (!lean) (void)g.validate();
  say(what + "read: " + std::to_string(g.slots().size()) + " pieces, " + std::to_string(vertices) + " vertices");
}

/// Whether the tile was read.
bool checkTile(const Fixture& fx, const fs::path& file, bool lean, bool strict) {
  const World& w = theWorld();
  std::string damage;
  const std::optional<LayerTile> tile = gis::overlay::detail::readTile(
      file, kFingerprint, kTileKey, *fx.source, w.bounds, fx.options,
      [&](std::uint32_t i) { return fx.source->featureStyles().at(i); }, lean, &damage);
  const std::string what = std::string(lean ? "lean" : "whole") + " tile of " + fx.name + ": ";
  if (!tile) {
    say(what + "refused: " + damage);
    require(!damage.empty(), what + "a tile file that is there and refused is named damaged");
    return false;
  }
  require(gis::overlay::detail::tileBytes(file, kFingerprint, kTileKey).has_value(),
          what + "a tile read has its size known from its header");
  require(tile->key == kTileKey && tile->groundError == kGroundError, what + "the key and error of the header");
  const LayerGeometry& g = tile->geometry;
  require(tile->featureIndex.size() == g.sharedFeatures().size(), what + "a layer index per feature");
  for (const std::uint32_t i : tile->featureIndex)
    require(i < fx.source->sharedFeatures().size(), what + "each feature one of the layer's");
  require(lean == (g.arraysInFile() != nullptr), what + "a lean tile's arrays stay in its file");
  checkGeometry(fx, g, lean, strict, what);
  return true;
}

/// The colour groups a tile of world pieces is read with (the seed's: two).
const std::vector<glm::vec4>& worldGroupColours() {
  static const std::vector<glm::vec4> colours{{1.0F, 0.0F, 0.0F, 1.0F}, {0.0F, 0.5F, 1.0F, 0.5F}};
  return colours;
}

/// The file read as a tile of world pieces (the globe's, overlay::detail::readWorldTile) with its
/// arrays in memory, as a tile near the eye is: refused and named damaged, or its pieces clipped
/// at the near plane from those arrays (every index they read checked when it was read).
void checkWorldTileInMemory(const fs::path& file) {
  std::string damage;
  const std::optional<LayerTile> tile =
      gis::overlay::detail::readWorldTile(file, kFingerprint, kTileKey, "world", worldGroupColours(), false, &damage);
  if (!tile) {
    require(!damage.empty() || !fs::exists(file), "a world tile file that is there and refused is named damaged");
    return;
  }
  const LayerGeometry& g = tile->geometry;
  require(!g.footprintsReleased() && g.normals().size() == g.vertices().size(),
          "world tile in memory: clippable, a normal per vertex");
  // An eye inside the tile's box, looking down: every piece through the clip.
  const auto [lo, hi] = g.box3();
  gis::overlay::OverlayView view;
  view.eye = 0.5 * (lo + hi);
  if (!std::isfinite(view.eye.x) || !std::isfinite(view.eye.y) || !std::isfinite(view.eye.z))
    view.eye = glm::dvec3(0.0);
  view.viewProj = glm::dmat4(1.0);
  view.viewProj[2][3] = -1.0;  // w = −z
  view.viewProj[3][3] = view.eye.z;
  std::vector<std::size_t> slots;
  for (std::size_t k = 0; k < g.slots().size(); ++k)
    if (g.slots()[k].live) slots.push_back(k);
  gis::overlay::PixelScale scale;
  scale.eye = view.eye;
  scale.metresPerPixel = 1e-3;
  const std::vector<gis::overlay::ClippedVertex> clipped =
      gis::overlay::clipAtNearPlane(view, g, slots, {}, scale, true);
  require(clipped.size() % 3 == 0, "world tile: the clip gives whole triangles");
  say("world tile clipped: " + std::to_string(clipped.size() / 3) + " triangles");
}

/// The file read as a tile of world pieces (the globe's, overlay::detail::readWorldTile): refused
/// and named damaged, or read with its arrays left in the file, every index checked there within
/// its slot's vertices, a normal per vertex (a scaling per vertex for lines in pixels, none
/// else), its slots' origins and groups its own, its boxes ordered. Whether it was read.
bool checkWorldTile(const fs::path& file) {
  std::string damage;
  const std::optional<LayerTile> tile =
      gis::overlay::detail::readWorldTile(file, kFingerprint, kTileKey, "world", worldGroupColours(), true, &damage);
  checkWorldTileInMemory(file);
  if (!tile) {
    say("world tile refused: " + damage);
    require(!damage.empty() || !fs::exists(file), "a world tile file that is there and refused is named damaged");
    return false;
  }
  const LayerGeometry& g = tile->geometry;
  require(g.alongNormals() && g.arraysInFile() != nullptr, "world tile: world pieces, arrays left in the file");
  const gis::overlay::ArraysInFile& arrays = *g.arraysInFile();
  require(arrays.normalsCount == arrays.vertexCount, "world tile: a normal per vertex");
  require(arrays.scalingCount == (g.widthPixels() > 0.0 ? arrays.vertexCount : 0U),
          "world tile: a scaling per vertex for lines in pixels, none else");
  std::vector<std::uint32_t> indices(arrays.indexCount);
  require(arrays.read(arrays.indicesAt, indices.size() * sizeof(std::uint32_t),
                      [&](const void* data, std::uint64_t offset, std::uint64_t n) {
                        std::memcpy(reinterpret_cast<char*>(indices.data()) + offset, data,
                                    static_cast<std::size_t>(n));
                      }),
          "world tile: its indices can be read");
  for (std::size_t k = 0; k < g.slots().size(); ++k) {
    const LayerGeometry::PieceSlot& s = g.slots()[k];
    require(s.origin < g.worldOrigins().size() && s.feature < worldGroupColours().size(),
            "world tile: a slot's origin and group are its own");
    require(std::uint64_t{s.firstIndex} + s.indexCount <= indices.size() && s.bottomCount <= s.indexCount,
            "world tile: a slot's indices are in the array");
    for (std::uint32_t i = s.firstIndex; i < s.firstIndex + s.indexCount; ++i)
      require(std::uint64_t{s.baseVertex} + indices[i] < arrays.vertexCount, "world tile: an index names a vertex");
    const gis::overlay::Polyhedron& p = g.polyhedra()[k];
    require(p.lo <= p.hi && p.boxMin.x <= p.boxMax.x && p.boxMin.y <= p.boxMax.y, "world tile: boxes ordered");
  }
  (void)g.box3();
  (void)g.maxOverlap();
  (void)g.uniformColor();
  say("world tile read: " + std::to_string(g.slots().size()) + " pieces");
  return true;
}

/// A lean section read as a layer in memory (LayerGeometry::readLean without a file: its arrays
/// read and checked whole), as readTile reads its feature index first.
/// Whether it was read.
bool checkLeanInMemory(const Fixture& fx, const std::string& section, bool strict) {
  std::istringstream in(section);
  gis::geo::io::Reader r(in);
  std::vector<std::uint32_t> index;
  if (!r.array(index)) return false;
  std::vector<FeatureStyle> styles;
  for (const std::uint32_t i : index) {
    if (i >= fx.source->featureStyles().size()) return false;
    styles.push_back(fx.source->featureStyles()[i]);
  }
  const std::optional<LayerGeometry> g = LayerGeometry::readLean(
      r, fx.source->name(), fx.source->kind(), fx.source->style(), styles, theWorld().bounds, fx.options);
  const std::string what = "lean layer in memory of " + fx.name + ": ";
  if (!g) {
    say(what + "refused");
    return false;
  }
  require(g->arraysInFile() == nullptr && g->footprintsReleased(), what + "its arrays held, its footprints released");
  checkGeometry(fx, *g, true, strict, what);
  return true;
}

void checkChecks(const Fixture& fx) {
  const World& w = theWorld();
  const Result<LayerGeometry> g =
      LayerGeometry::build(fx.name, fx.kind, fx.style, fx.features, w.bounds, fx.checkOptions);
  require(g.ok(), "a deferred layer builds, whatever its checks file holds");
  checkDiagnostics(g.diagnostics, "checks");
  require(g->featureOutcomes().size() == fx.features.size(), "checks: one outcome per feature");
  for (const FeatureOutcome o : g->featureOutcomes())
    require(static_cast<std::uint8_t>(o) <= static_cast<std::uint8_t>(FeatureOutcome::Hidden),
            "checks: each outcome is one");
  say(std::string("checks ") + (g->stats().checksFromCache ? "read" : "refused"));
  if (g->stats().checksFromCache) return;
  bool named = false;
  for (const gis::Diagnostic& d : g.diagnostics.items())
    named = named || (d.file == fx.checksFile.string() && d.message.find("cache file damaged") != std::string::npos);
  require(named, "a checks file refused is named damaged in a warning");
}

void runLayer(const Input& in, bool givenHeader) {
  const fs::path file = theWorld().dir / "fuzz.layer";
  std::vector<std::string> sections;
  if (!givenHeader) sections.push_back(layerHeader());
  sections.insert(sections.end(), in.parts.begin(), in.parts.end());
  writeWrapped(file, sections, in.edits);
  checkLayerFile(file);
}

void runTile(const Fixture& fx, const Input& in, bool givenHeader) {
  const World& w = theWorld();
  const fs::path file = w.dir / "fuzz.tile";
  std::vector<std::string> sections;
  if (!givenHeader) sections.push_back(tileHeader());
  sections.insert(sections.end(), in.parts.begin(), in.parts.end());
  writeWrapped(file, sections, in.edits);
  (void)gis::overlay::detail::tileBytes(file, kFingerprint, kTileKey);
  const bool lean = checkTile(fx, file, true, w.strictPieces);
  (void)checkTile(fx, file, false, w.strictPieces);
  const bool asWorld = checkWorldTile(file);
  require(!(lean && asWorld), "a tile is a plane's or world pieces, never both");
  // The same lean section read in memory: the same answer (the arrays checked whole there,
  // slice by slice from the file). A wrapped file as made, with its header, is read as a lean
  // tile exactly when its section is read alone.
  const bool asMade = !givenHeader && in.edits.empty() && sections.size() == 3;
  if (sections.size() > 1) {
    const bool inMemory = checkLeanInMemory(fx, sections[1], w.strictPieces);
    require(!lean || inMemory, "a lean tile read from its file is read from memory too");
    require(!asMade || !inMemory || lean, "a lean section read from memory is read from its file too");
  }
}

void runChecks(const Fixture& fx, const Input& in, bool givenHeader) {
  std::vector<std::string> sections = in.parts;
  if (!givenHeader) sections.front().insert(0, checksHeader(fx));
  writeWrapped(fx.checksFile, sections, in.edits);
  checkChecks(fx);
}

void runRaw(const Fixture& fx, const Input& in) {
  const World& w = theWorld();
  const fs::path layer = w.dir / "fuzz.layer", tile = w.dir / "fuzz.tile";
  writeRaw(layer, in.rest);
  checkLayerFile(layer);
  writeRaw(tile, in.rest);
  checkTile(fx, tile, true, w.strictPieces);
  checkTile(fx, tile, false, w.strictPieces);
  checkWorldTile(tile);
  writeRaw(fx.checksFile, in.rest);
  checkChecks(fx);
}

// ---- seeds ----

/// The sections of the checked file `file` (all verified).
std::vector<std::string> sectionsOf(const fs::path& file) {
  CheckedStatus status = CheckedStatus::Missing;
  std::string why;
  const std::shared_ptr<const CheckedFile> checked = CheckedFile::open(file, status, why);
  require(checked != nullptr, "a seed's file opens: " + why);
  std::vector<std::string> out;
  for (std::size_t i = 0; i < checked->sections(); ++i) {
    const std::optional<std::string> s = checked->read(i);
    require(s.has_value(), "a seed's section reads");
    out.push_back(*s);
  }
  return out;
}

void writeSeed(const fs::path& folder, const std::string& name, std::uint8_t flags,
               const std::vector<std::string>& parts) {
  std::string bytes(1, static_cast<char>(flags));
  for (std::size_t k = 0; k < parts.size(); ++k) {
    if (k > 0) bytes += kSeparator;
    bytes += parts[k];
  }
  writeRaw(folder / name, bytes);
  std::printf("%s: %zu bytes\n", name.c_str(), bytes.size());
}

void writeSeeds(const fs::path& folder) {
  World& w = theWorld();
  fs::create_directories(folder);
  const fs::path scratch = w.dir / "seeds";
  fs::create_directories(scratch);
  // Layer files: features of every kind with attributes; a read that failed; an empty layer.
  const auto layerFile = [&](const std::string& name, bool ok, std::vector<Feature> features) {
    const fs::path file = scratch / (name + ".layer");
    const gis::scene::detail::LayerCacheWrite written =
        gis::scene::detail::writeLayerCache(file.string(), kLayerKey, [&](const std::function<void(Feature &&)>& sink) {
          Result<gis::geo::VectorLayer> r;
          r.diagnostics.add({Severity::Warning, "source.gpkg", "roads", "feature 4", "ring repaired"});
          if (!ok) {
            r.diagnostics.add({Severity::Error, "source.gpkg", "roads", "", "cannot be opened"});
            return r;
          }
          gis::geo::VectorLayer layer;
          layer.path = "source.gpkg";
          layer.name = "mixed";
          layer.kind = gis::geo::GeometryKind::Polygon;
          for (Feature& f : features) sink(std::move(f));
          r.value = std::move(layer);
          return r;
        });
    require(written.outcome.written, "a seed layer file is written");
    return file;
  };
  std::vector<Feature> mixed = polygons();
  for (Feature& f : lines()) mixed.push_back(std::move(f));
  mixed[5].attributes["nothing"] = std::monostate{};
  const fs::path layer = layerFile("features", true, mixed);
  std::vector<std::string> s = sectionsOf(layer);
  writeSeed(folder, "layer_features", 0, {s[1], s[2]});
  s = sectionsOf(layerFile("failed", false, {}));
  writeSeed(folder, "layer_failed_read", 0, {s[1], s[2]});
  s = sectionsOf(layerFile("empty", true, {}));
  writeSeed(folder, "layer_empty", 0, {s[1], s[2]});
  {
    std::ifstream in(layer, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    writeSeed(folder, "raw_layer_file", 3, {bytes});
  }
  // The header given, and the table edited (a section's length and a count).
  s = sectionsOf(layer);
  writeSeed(folder, "layer_header_given", 0x30, {s[0], s[1], s[2]});
  writeSeed(folder, "layer_table_edited", 0x40, {s[1], s[2], std::string("\x10\x00\x01\x20\x00\x08", 6)});
  // Tiles and checks of every fixture: a tile of the layer's pieces (every feature), as a
  // tiling would write it.
  const char* names[] = {"areas", "roads", "roads_pixels", "areas_paper"};
  for (std::size_t k = 0; k < w.fixtures.size(); ++k) {
    const Fixture& fx = w.fixtures[k];
    Result<LayerGeometry> built = LayerGeometry::build(fx.name, fx.kind, fx.style, fx.features, w.bounds, fx.options);
    require(built.ok(), "a seed tile builds");
    std::vector<std::uint32_t> index(fx.features.size());
    for (std::size_t i = 0; i < index.size(); ++i) index[i] = static_cast<std::uint32_t>(i);
    const LayerTile tile{kTileKey, std::move(*built), index, kGroundError, false};
    const fs::path file = scratch / (std::string(names[k]) + ".tile");
    require(gis::overlay::detail::writeTile(file, kFingerprint, tile), "a seed tile is written");
    s = sectionsOf(file);
    const auto flags = static_cast<std::uint8_t>(1U | (k << 2U));
    writeSeed(folder, std::string("tile_") + names[k], flags, {s[1], s[2]});
    const std::vector<std::string> checks = sectionsOf(fx.checksFile);
    writeSeed(folder, std::string("checks_") + names[k], static_cast<std::uint8_t>(2U | (k << 2U)),
              {checks[0].substr(checksHeader(fx).size())});
  }
  // A tile of world pieces (the globe's): two pieces in two colour groups, lines in pixels.
  {
    using Vertex = LayerGeometry::Vertex;
    std::vector<Vertex> vertices;
    std::vector<glm::vec4> normals, scaling;
    std::vector<std::uint32_t> indices;
    std::vector<LayerGeometry::WorldPiece> pieces;
    for (std::uint32_t p = 0; p < 2; ++p) {
      const auto base = static_cast<std::uint32_t>(vertices.size());
      for (std::uint32_t k = 0; k < 6; ++k) {
        const float side = (k % 2U) == 0 ? -1.0F : 1.0F;
        vertices.push_back(Vertex{static_cast<float>(100U * p + 10U * (k / 2U)),
                                  static_cast<float>(k),
                                  5.0F * side,
                                  side,
                                  {0U, 0U, 0U, 255U}});
        normals.emplace_back(0.0F, 0.0F, 1.0F, 0.0F);
        scaling.emplace_back(1.0F, 0.0F, 0.0F, 2.0F);
      }
      const auto first = static_cast<std::uint32_t>(indices.size());
      for (const std::uint32_t i : {0U, 2U, 4U, 1U, 5U, 3U, 0U, 1U, 2U}) indices.push_back(base + i);
      pieces.push_back({first, 3, 9, glm::dvec3(100.0 * p, 0.0, -5.0), glm::dvec3(100.0 * p + 20.0, 5.0, 5.0), p});
    }
    LayerGeometry::WorldLines lines{scaling, 3.0, 64.0};
    const LayerTile tile{kTileKey,
                         LayerGeometry::ofWorldPieces("world", glm::dvec3(6378137.0, 0.0, 0.0), vertices, normals,
                                                      indices, pieces, worldGroupColours(), lines),
                         {},
                         kGroundError,
                         false};
    const fs::path file = scratch / "world.tile";
    require(gis::overlay::detail::writeTile(file, kFingerprint, tile), "a seed world tile is written");
    require(checkWorldTile(file), "the seed world tile reads back");
    s = sectionsOf(file);
    writeSeed(folder, "tile_world", 1U, {s[1], s[2]});
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  (void)theWorld();
  if (const char* seeds = std::getenv("STENCIL_GIS_FUZZ_WRITE_SEEDS"); seeds != nullptr && *seeds != '\0') {
    writeSeeds(seeds);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  World& w = theWorld();
  const Input in = parse(data, size);
  const Fixture& fx = w.fixtures[(in.flags >> 2U) & 3U];
  const bool givenHeader = (in.flags & 0x30U) == 0x30U;
  switch (in.flags & 3U) {
    case 0:
      runLayer(in, givenHeader);
      break;
    case 1:
      runTile(fx, in, givenHeader);
      break;
    case 2:
      runChecks(fx, in, givenHeader);
      break;
    default:
      runRaw(fx, in);
      break;
  }
  return 0;
}
