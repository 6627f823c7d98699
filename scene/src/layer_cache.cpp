#include "layer_cache.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <system_error>
#include <thread>

#include <unistd.h>

#include "core/hash.hpp"
#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"
#include "geo/feature_file.hpp"
#include "scene/reader_fingerprint.hpp"

namespace gis::scene::detail {
namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kMagic = 0x4c564753;  // "SGVL"
// 4: checked sections (geo/checked_file.hpp): the header, the features as they are read, then
// what was said and the index.
constexpr std::uint32_t kVersion = 4;

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

LayerCacheRead readLayerCache(const std::string& file, std::uint64_t key) {
  LayerCacheRead result;
  std::shared_ptr<const geo::io::CheckedFile> checked = geo::io::CheckedFile::open(file, result.status, result.why);
  if (!checked) return result;
  const auto damaged = [&](const std::string& why) {
    result.status = geo::io::CheckedStatus::Damaged;
    result.why = why;
    return result;
  };
  // Three sections: the header, the features, the trailer (what was said, the index).
  if (checked->sections() != 3) return damaged("not a layer file");
  const std::optional<std::string> header = checked->read(0);
  if (!header) return damaged("its header does not match its checksum");
  {
    std::istringstream in(*header);
    geo::io::Reader r(in);
    std::uint32_t magic = 0, version = 0;
    std::uint64_t stored = 0;
    if (!r.value(magic) || magic != kMagic || !r.value(version) || version != kVersion || !r.value(stored) ||
        stored != key)
      return damaged("its header is not this layer's");
  }
  if (!checked->verify(1)) return damaged("its features do not match their checksum");
  const std::optional<std::string> trailer = checked->read(2);
  if (!trailer) return damaged("its index does not match its checksum");
  const geo::io::CheckedFile::Section& body = checked->section(1);
  std::istringstream in(*trailer);
  geo::io::Reader r(in);
  CachedLayer cached;
  Result<geo::VectorLayer>& read = cached.read;
  std::uint8_t ok = 0;
  if (!readDiagnostics(r, read.diagnostics) || !r.value(ok)) return damaged("its messages cannot be read");
  if (ok == 0) {
    result.layer = std::move(cached);
    return result;
  }
  geo::VectorLayer layer;
  std::uint8_t kind = 0;
  std::uint64_t content = 0;
  std::vector<geo::FeatureFileEntry> entries;
  if (!r.text(layer.path) || !r.text(layer.name) || !r.text(layer.sourceCrsWkt) || !r.value(kind) ||
      kind > static_cast<std::uint8_t>(geo::GeometryKind::Empty) || !r.value(layer.quantisationMetres) ||
      !r.array(entries) || !r.value(content) || (!entries.empty() && entries.front().offset != body.offset))
    return damaged("its index cannot be read");
  layer.kind = static_cast<geo::GeometryKind>(kind);
  std::string error;
  cached.features = geo::FeatureFile::open(file, ::dup(checked->descriptor()), std::move(entries),
                                           body.offset + body.length, content, &error);
  if (!cached.features) return damaged(error);
  read.value = std::move(layer);
  result.layer = std::move(cached);
  return result;
}

LayerCacheWrite writeLayerCache(
    const std::string& file, std::uint64_t key,
    const std::function<Result<geo::VectorLayer>(const std::function<void(geo::Feature&&)>&)>& read) {
  LayerCacheWrite done;
  // Durable: a layer can take minutes to read again; a crash must not leave a file that
  // names itself whole (its checksums would find it, but the read would be lost).
  done.outcome = geo::io::writeCheckedFile(
      file,
      [&](std::ostream& out, geo::io::SectionMarks& marks) {
        geo::io::Writer w(out);
        marks.begin();
        w.value(kMagic);
        w.value(kVersion);
        w.value(key);
        marks.begin();
        // The features as they are read, each with its entry in the index and its share of the hash.
        std::vector<geo::FeatureFileEntry> entries;
        StableHasher content;
        const auto add = [&](geo::Feature&& f) {
          entries.push_back(geo::FeatureFileEntry::of(f, static_cast<std::uint64_t>(out.tellp())));
          geo::io::writeGeometry(w, f);
          geo::io::writeAttributes(w, f);
          content.add(static_cast<std::uint64_t>(f.fid));
          content.add(static_cast<std::uint64_t>(out.tellp()));  // where it ends: its size
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
        };
        done.result = read(add);
        Result<geo::VectorLayer>& result = *done.result;
        if (result) {
          for (geo::Feature& f : result->features) add(std::move(f));  // a reader that kept them
          result->features.clear();
        }
        marks.begin();
        writeDiagnostics(w, result.diagnostics);
        w.value(static_cast<std::uint8_t>(result ? 1 : 0));
        if (result) {
          const geo::VectorLayer& layer = *result;
          w.text(layer.path);
          w.text(layer.name);
          w.text(layer.sourceCrsWkt);
          w.value(static_cast<std::uint8_t>(layer.kind));
          w.value(layer.quantisationMetres);
          w.array(entries);
          w.value(content.value());
        }
      },
      /*durable=*/true);
  return done;
}

}  // namespace gis::scene::detail
