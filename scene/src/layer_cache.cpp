#include "layer_cache.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <thread>

#include <unistd.h>

#include "core/hash.hpp"
#include "geo/binary_io.hpp"
#include "geo/feature_file.hpp"
#include "scene/reader_fingerprint.hpp"

namespace gis::scene::detail {
namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kMagic = 0x4c564753;  // "SGVL"
constexpr std::uint32_t kVersion = 2;         // 2: features indexed, read one at a time

void writeDiagnostics(geo::io::Writer& w, const Diagnostics& diagnostics) {
  w.value(static_cast<std::uint64_t>(diagnostics.items().size()));
  for (const Diagnostic& d : diagnostics.items()) {
    w.value(static_cast<std::uint8_t>(d.severity));
    for (const std::string* s : {&d.file, &d.layer, &d.feature, &d.message}) w.text(*s);
  }
}

bool readDiagnostics(geo::io::Reader& r, Diagnostics& diagnostics) {
  std::size_t n = 0;
  if (!r.count(n)) return false;
  for (std::size_t k = 0; k < n; ++k) {
    Diagnostic d;
    std::uint8_t severity = 0;
    if (!r.value(severity) || severity > static_cast<std::uint8_t>(Severity::Error)) return false;
    d.severity = static_cast<Severity>(severity);
    for (std::string* s : {&d.file, &d.layer, &d.feature, &d.message})
      if (!r.text(*s)) return false;
    diagnostics.add(std::move(d));
  }
  return true;
}

}  // namespace

std::optional<std::uint64_t> layerCacheKey(const std::string& source, const geo::SceneFrame& frame,
                                           const geo::VectorReadOptions& options) {
  std::error_code ec;
  const fs::path path = fs::absolute(source, ec).lexically_normal();
  if (ec || !fs::is_regular_file(path, ec) || options.filter) return std::nullopt;
  StableHasher h;
  h.add(std::string_view("stencil-gis layer cache 1"));
  h.add(std::string_view(STENCIL_GIS_READER_FINGERPRINT));
  h.add(path.string());
  h.add(options.layer);
  h.add(options.assumedCrs);
  h.add(options.geodesicToleranceMetres);
  h.add(options.maxGeodesicSegmentMetres);
  h.add(frame.crsWkt());
  for (int k = 0; k < 3; ++k) h.add(frame.origin()[k]);
  // The file and its sidecars (same stem, any extension), in name order.
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(path.parent_path(), ec)) {
    if (e.path().stem() == path.stem() && e.is_regular_file(ec)) files.push_back(e.path());
  }
  if (ec) return std::nullopt;
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    const auto size = fs::file_size(f, ec);
    const auto time = fs::last_write_time(f, ec);
    if (ec) return std::nullopt;
    h.add(f.filename().string());
    h.add(static_cast<std::uint64_t>(size));
    h.add(static_cast<std::uint64_t>(time.time_since_epoch().count()));
  }
  return h.value();
}

std::string layerCacheFile(const std::string& directory, std::uint64_t key) {
  char name[32];
  std::snprintf(name, sizeof(name), "%016llx.layer", static_cast<unsigned long long>(key));
  return (fs::path(directory) / "vector-layers" / name).string();
}

std::optional<CachedLayer> readLayerCache(const std::string& file, std::uint64_t key) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  geo::io::Reader r(in);
  std::uint32_t magic = 0, version = 0;
  std::uint64_t stored = 0;
  std::uint8_t ok = 0;
  CachedLayer cached;
  Result<geo::VectorLayer>& read = cached.read;
  if (!r.value(magic) || magic != kMagic || !r.value(version) || version != kVersion || !r.value(stored) ||
      stored != key || !readDiagnostics(r, read.diagnostics) || !r.value(ok))
    return std::nullopt;
  if (ok == 0) return cached;
  geo::VectorLayer layer;
  std::uint8_t kind = 0;
  std::size_t count = 0;
  if (!r.text(layer.path) || !r.text(layer.name) || !r.text(layer.sourceCrsWkt) || !r.value(kind) ||
      kind > static_cast<std::uint8_t>(geo::GeometryKind::Empty) || !r.value(layer.quantisationMetres) ||
      !r.count(count, 32))  // a feature: fid, two counts, attributes' count
    return std::nullopt;
  layer.kind = static_cast<geo::GeometryKind>(kind);
  const auto first = static_cast<std::uint64_t>(in.tellg());
  // The footer: the features' hash, where their index starts, the magic.
  std::uint64_t content = 0, indexAt = 0;
  in.seekg(-static_cast<std::streamoff>(2 * sizeof(std::uint64_t) + sizeof(std::uint32_t)), std::ios::end);
  if (!in || !r.value(content) || !r.value(indexAt) || !r.value(magic) || magic != kMagic || indexAt < first)
    return std::nullopt;
  in.seekg(static_cast<std::streamoff>(indexAt));
  geo::io::Reader index(in);
  std::vector<geo::FeatureFileEntry> entries;
  if (!in || !index.array(entries) || entries.size() != count || (count > 0 && entries.front().offset != first))
    return std::nullopt;
  std::string error;
  cached.features = geo::FeatureFile::open(file, std::move(entries), indexAt, content, &error);
  if (!cached.features) return std::nullopt;
  read.value = std::move(layer);
  return cached;
}

bool writeLayerCache(const std::string& file, std::uint64_t key, const Result<geo::VectorLayer>& read) {
  return geo::io::writeFileAtomically(file, [&](std::ostream& out) {
    geo::io::Writer w(out);
    w.value(kMagic);
    w.value(kVersion);
    w.value(key);
    writeDiagnostics(w, read.diagnostics);
    w.value(static_cast<std::uint8_t>(read ? 1 : 0));
    if (!read) return;
    const geo::VectorLayer& layer = *read;
    w.text(layer.path);
    w.text(layer.name);
    w.text(layer.sourceCrsWkt);
    w.value(static_cast<std::uint8_t>(layer.kind));
    w.value(layer.quantisationMetres);
    w.value(static_cast<std::uint64_t>(layer.features.size()));
    std::vector<geo::FeatureFileEntry> entries;
    entries.reserve(layer.features.size());
    StableHasher content;
    for (const geo::Feature& f : layer.features) {
      entries.push_back(geo::FeatureFileEntry::of(f, static_cast<std::uint64_t>(out.tellp())));
      geo::io::writeGeometry(w, f);
      geo::io::writeAttributes(w, f);
      content.add(static_cast<std::uint64_t>(f.fid));
      content.add(static_cast<std::uint64_t>(out.tellp()));  // the size of what was written
      const auto points = [&content](const std::vector<glm::dvec2>& ps) {
        content.add(static_cast<std::uint64_t>(ps.size()));
        for (const glm::dvec2& p : ps) {
          content.add(p.x);
          content.add(p.y);
        }
      };
      for (const geo::Polygon& p : f.polygons) {
        points(p.outer);
        for (const geo::Ring& h : p.holes) points(h);
      }
      for (const geo::LineString& l : f.lines) points(l);
    }
    const auto indexAt = static_cast<std::uint64_t>(out.tellp());
    w.array(entries);
    w.value(content.value());
    w.value(indexAt);
    w.value(kMagic);
  });
}

}  // namespace gis::scene::detail
