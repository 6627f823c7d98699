// Fuzzes the vector reader (geo::readVectorLayer) through GDAL's in-memory files: input that
// starts with '{' or '[' is a GeoJSON file (a TopoJSON one when GDAL's TopoJSON driver claims it:
// several layers), anything else a CSV file (a WKT column holds geometries; no CRS, so the reader
// assumes UTM 25 S). Only those drivers are registered: the subject is our reading of what OGR
// yields, not every OGR driver.
//
// Invariants: readVectorLayer returns (no throw, no crash); a failure carries an Error naming
// the file; a source of several layers read without a layer name fails listing them, and each
// layer read by name keeps the invariants; every feature read has finite coordinates, rings of
// at least 3 points and lines of at least 2; every attribute text is UTF-8 (whatever bytes the
// file holds); every feature OGR yields is either read or named (file, layer, feature) in an
// Error, unless reading stopped with an Error naming the file and layer.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include <cpl_http.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <ogr_api.h>

#include "geo/frame.hpp"
#include "geo/vector.hpp"

namespace {

std::string g_input;  // for messages

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "vector_reader_fuzzer: %s\ninput: %.2000s\n", what.c_str(), g_input.c_str());
  std::abort();
}

void check(bool ok, const std::string& what) {
  if (!ok) fail(what);
}

/// GDAL may fetch a CRS named by URL (a GeoJSON "link" CRS): no network for fuzz inputs.
CPLHTTPResult* noNetwork(const char* /*url*/, CSLConstList /*options*/, GDALProgressFunc /*progress*/,
                         void* /*progressArg*/, CPLHTTPFetchWriteFunc /*write*/, void* /*writeArg*/,
                         void* /*userData*/) {
  auto* result = static_cast<CPLHTTPResult*>(CPLCalloc(1, sizeof(CPLHTTPResult)));
  result->nStatus = 1;
  result->pszErrBuf = CPLStrdup("the fuzzer allows no network access");
  return result;
}

const gis::geo::SceneFrame& frame() {
  static const gis::geo::SceneFrame f = [] {
    gis::Result<gis::geo::SceneFrame> r =
        gis::geo::SceneFrame::fromCrs("EPSG:32725", glm::dvec3(292000.0, 9115000.0, 0.0));
    if (!r) {
      std::fprintf(stderr, "vector_reader_fuzzer: no frame (EPSG:32725)\n");
      std::abort();
    }
    return *r;
  }();
  return f;
}

/// Features OGR yields from the file's layer `name` (empty: the first), counted as the reader
/// walks them; -1 if it cannot open it.
std::int64_t ogrFeatureCount(const std::string& path, const std::string& name) {
  CPLPushErrorHandler(CPLQuietErrorHandler);
  std::int64_t n = -1;
  if (GDALDatasetH ds = GDALOpenEx(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, nullptr, nullptr)) {
    OGRLayerH layer = name.empty() ? (GDALDatasetGetLayerCount(ds) > 0 ? GDALDatasetGetLayer(ds, 0) : nullptr)
                                   : GDALDatasetGetLayerByName(ds, name.c_str());
    if (layer != nullptr) {
      OGR_L_ResetReading(layer);
      n = 0;
      while (OGRFeatureH f = OGR_L_GetNextFeature(layer)) {
        OGR_F_Destroy(f);
        ++n;
      }
    }
    GDALClose(ds);
  }
  CPLPopErrorHandler();
  return n;
}

void checkLayer(const gis::Result<gis::geo::VectorLayer>& r, const std::string& path, const std::string& name) {
  const gis::Diagnostics& d = r.diagnostics;
  bool errorNamingFile = false;
  for (const gis::Diagnostic& x : d.items()) {
    check(x.file == path, "a diagnostic does not name the file: " + x.toString());
    errorNamingFile = errorNamingFile || x.severity == gis::Severity::Error;
  }
  if (!r.ok()) {
    check(errorNamingFile, "the read failed without an Error naming the file");
    return;
  }
  const gis::geo::VectorLayer& layer = *r;
  check(layer.path == path, "the layer does not name its file");
  for (const gis::geo::Feature& f : layer.features) {
    auto finitePoints = [&](const std::vector<glm::dvec2>& points) {
      for (const glm::dvec2& p : points) {
        check(std::isfinite(p.x) && std::isfinite(p.y),
              "feature " + std::to_string(f.fid) + ": a coordinate is not finite");
      }
    };
    check(!f.polygons.empty() || !f.lines.empty(), "feature " + std::to_string(f.fid) + " has no geometry");
    for (const gis::geo::Polygon& p : f.polygons) {
      check(p.outer.size() >= 3, "feature " + std::to_string(f.fid) + ": an outer ring of fewer than 3 points");
      finitePoints(p.outer);
      for (const gis::geo::Ring& h : p.holes) {
        check(h.size() >= 3, "feature " + std::to_string(f.fid) + ": a hole of fewer than 3 points");
        finitePoints(h);
      }
    }
    for (const gis::geo::LineString& l : f.lines) {
      check(l.size() >= 2, "feature " + std::to_string(f.fid) + ": a line of fewer than 2 points");
      finitePoints(l);
    }
    for (const auto& [key, value] : f.attributes) {
      check(CPLIsUTF8(key.c_str(), -1) != 0, "feature " + std::to_string(f.fid) + ": an attribute name is not UTF-8");
      if (const auto* text = std::get_if<std::string>(&value)) {
        check(CPLIsUTF8(text->c_str(), -1) != 0,
              "feature " + std::to_string(f.fid) + ": attribute '" + key + "' is not UTF-8");
      }
    }
  }
  // Every feature left out is named.
  std::size_t namedErrors = 0;
  bool stopped = false;
  for (const gis::Diagnostic& x : d.items()) {
    if (x.severity != gis::Severity::Error) continue;
    check(x.layer == layer.name, "an Error does not name the layer: " + x.toString());
    if (x.feature.empty()) {
      stopped = true;                                   // "reading stopped after N features"
    } else if (x.feature.rfind("features[", 0) != 0) {  // not a GeoJSON entry OGR skipped
      ++namedErrors;
    }
  }
  const std::int64_t yielded = ogrFeatureCount(path, name);
  const auto accounted = static_cast<std::int64_t>(layer.features.size() + namedErrors);
  if (!stopped && yielded >= 0 && accounted != yielded) {
    fail("OGR yields " + std::to_string(yielded) + " features, the reader read " +
         std::to_string(layer.features.size()) + " and named " + std::to_string(namedErrors) + " left out");
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  frame();  // registers GDAL's drivers (through the reader's own registration)
  // Keep only the drivers under test: no driver that opens other files by name (VRT, …).
  const std::set<std::string> keep{"GeoJSON", "TopoJSON", "CSV"};
  for (int i = GDALGetDriverCount() - 1; i >= 0; --i) {
    GDALDriverH driver = GDALGetDriver(i);
    if (keep.count(GDALGetDriverShortName(driver)) == 0) {
      GDALDeregisterDriver(driver);
      GDALDestroyDriver(driver);
    }
  }
  CPLHTTPPushFetchCallback(noNetwork, nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  g_input.assign(reinterpret_cast<const char*>(data), size);
  std::size_t first = 0;
  while (first < size && (data[first] == ' ' || data[first] == '\n' || data[first] == '\r' || data[first] == '\t'))
    ++first;
  const bool json = first < size && (data[first] == '{' || data[first] == '[');
  const std::string path = json ? "/vsimem/fuzz/input.geojson" : "/vsimem/fuzz/input.csv";

  // GDAL reads the fuzzer's buffer in place (no copy, not owned).
  VSILFILE* file = VSIFileFromMemBuffer(path.c_str(), const_cast<GByte*>(data), static_cast<vsi_l_offset>(size), FALSE);
  if (file == nullptr) fail("cannot create " + path);
  VSIFCloseL(file);

  gis::geo::VectorReadOptions options;
  options.assumedCrs = "EPSG:32725";
  gis::Result<gis::geo::VectorLayer> r;
  try {
    r = gis::geo::readVectorLayer(path, frame(), options);
  } catch (const std::exception& e) {
    fail(std::string("readVectorLayer threw: ") + e.what());
  }
  if (std::getenv("STENCIL_GIS_FUZZ_VERBOSE") != nullptr) {
    for (const gis::Diagnostic& x : r.diagnostics.items()) std::fprintf(stderr, "  %s\n", x.toString().c_str());
    if (r) std::fprintf(stderr, "  %zu features, %zu vertices\n", r->features.size(), r->vertexCount());
  }
  checkLayer(r, path, "");
  // Several layers: refused without a name (listing them), each readable by name.
  if (!r.ok()) {
    gis::Result<std::vector<std::string>> names = gis::geo::listVectorLayers(path);
    if (names && names->size() > 1) {
      bool listed = false;
      for (const gis::Diagnostic& x : r.diagnostics.items()) {
        listed = listed || x.message.find(std::to_string(names->size()) + " layers (") != std::string::npos;
      }
      check(listed, "a source of several layers was refused without listing them");
      for (const std::string& name : *names) {
        options.layer = name;
        gis::Result<gis::geo::VectorLayer> one;
        try {
          one = gis::geo::readVectorLayer(path, frame(), options);
        } catch (const std::exception& e) {
          fail(std::string("readVectorLayer threw: ") + e.what());
        }
        checkLayer(one, path, name);
      }
    }
  }
  VSIRmdirRecursive("/vsimem/fuzz");
  return 0;
}
