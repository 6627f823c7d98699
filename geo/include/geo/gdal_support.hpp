#pragma once
// Helpers shared by the GDAL-based readers (geo's, and the globe's DEM and imagery): one-time
// driver registration, a guard that keeps GDAL from printing (its errors become Diagnostics
// instead), owning pointers, GDAL utilities' options from argument lists, and spatial-reference
// helpers that always use the traditional GIS axis order (x = lon/easting, y = lat/northing).
// Internals: a GIS client needs none of it, and it includes GDAL's headers.
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

namespace gis::geo::detail {

/// Registers GDAL's drivers exactly once per process (safe from any thread).
inline void ensureGdalRegistered() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    // GDAL's block cache defaults to 5 % of RAM; we read each raster once into our own arrays,
    // so a large cache only doubles peak memory on big DEMs. Respect a user's GDAL_CACHEMAX.
    if (CPLGetConfigOption("GDAL_CACHEMAX", nullptr) == nullptr) GDALSetCacheMax64(64LL << 20);
    // GeoJSON bigger than GDAL's default object limit (the world's countries at 10 m are 168 MB)
    // opens: no limit unless the user set one.
    if (CPLGetConfigOption("OGR_GEOJSON_MAX_OBJ_SIZE", nullptr) == nullptr) {
      CPLSetConfigOption("OGR_GEOJSON_MAX_OBJ_SIZE", "0");
    }
  });
}

/// While alive, GDAL errors on this thread go nowhere instead of stderr; the last message is
/// still available through lastMessage(). CPL's handler stack is per thread.
class QuietGdal {
 public:
  QuietGdal() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdal() { CPLPopErrorHandler(); }
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;

  /// GDAL's last error message, or `fallback` when GDAL said nothing.
  [[nodiscard]] static std::string lastMessage(const std::string& fallback) {
    const char* msg = CPLGetLastErrorMsg();
    if (msg == nullptr || *msg == '\0') return fallback;
    return msg;
  }
};

/// A dataset that closes itself.
struct DatasetDeleter {
  void operator()(GDALDataset* ds) const {
    if (ds != nullptr) GDALClose(GDALDataset::ToHandle(ds));
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetDeleter>;

/// Options of a GDAL utility (GDALTranslate, GDALWarp) from a list of arguments, freed with it.
template <typename Options, typename ForBinary, Options* (*New)(char**, ForBinary*), void (*Free)(Options*)>
struct UtilityOptions {
  explicit UtilityOptions(const std::vector<std::string>& args) {
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    options = New(argv.data(), nullptr);
  }
  ~UtilityOptions() {
    if (options != nullptr) Free(options);
  }
  UtilityOptions(const UtilityOptions&) = delete;
  UtilityOptions& operator=(const UtilityOptions&) = delete;
  Options* options = nullptr;
};
using TranslateOptions = UtilityOptions<GDALTranslateOptions, GDALTranslateOptionsForBinary, GDALTranslateOptionsNew,
                                        GDALTranslateOptionsFree>;
using WarpOptions =
    UtilityOptions<GDALWarpAppOptions, GDALWarpAppOptionsForBinary, GDALWarpAppOptionsNew, GDALWarpAppOptionsFree>;

/// While alive, GDAL's messages on this thread are kept (not printed), in order, so that they
/// can reach the diagnostics attached to the file they are about. The last message stays
/// available through QuietGdal::lastMessage as well.
class GdalMessages {
 public:
  struct Message {
    CPLErr level;
    std::string text;
  };
  GdalMessages() {
    CPLPushErrorHandlerEx(&GdalMessages::handler, this);
    CPLErrorReset();
  }
  ~GdalMessages() { CPLPopErrorHandler(); }
  GdalMessages(const GdalMessages&) = delete;
  GdalMessages& operator=(const GdalMessages&) = delete;

  [[nodiscard]] const std::vector<Message>& messages() const { return messages_; }
  /// Takes the messages so far (later ones are kept anew).
  std::vector<Message> take() { return std::exchange(messages_, {}); }
  /// The messages so far joined by "; ", or `fallback` when there are none.
  [[nodiscard]] std::string joined(const std::string& fallback) const {
    std::string out;
    for (const Message& m : messages_) out += (out.empty() ? "" : "; ") + m.text;
    return out.empty() ? fallback : out;
  }

 private:
  static void CPL_STDCALL handler(CPLErr level, CPLErrorNum, const char* text) {
    auto* self = static_cast<GdalMessages*>(CPLGetErrorHandlerUserData());
    if (self == nullptr || level == CE_Debug || text == nullptr) return;
    // The same message again (GDAL repeats some per feature) is kept once; at most 50.
    for (const Message& m : self->messages_) {
      if (m.level == level && m.text == text) return;
    }
    if (self->messages_.size() < 50) self->messages_.push_back({level, text});
  }
  std::vector<Message> messages_;
};

struct SrsDeleter {
  void operator()(OGRSpatialReference* srs) const {
    if (srs != nullptr) srs->Release();
  }
};
using SrsPtr = std::unique_ptr<OGRSpatialReference, SrsDeleter>;

/// A copy of `srs` with traditional GIS axis order.
inline SrsPtr cloneTraditional(const OGRSpatialReference& srs) {
  SrsPtr out(srs.Clone());
  if (out) out->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return out;
}

/// WKT2 (2019) of a spatial reference: keeps bound CRSs and axis definitions intact, so
/// SetFromUserInput() gives the same CRS back. Empty if export fails.
inline std::string toWkt(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  const char* const options[] = {"FORMAT=WKT2_2019", nullptr};
  std::string out;
  if (srs.exportToWkt(&wkt, options) == OGRERR_NONE && wkt != nullptr) out = wkt;
  CPLFree(wkt);
  return out;
}

/// Parses user input (EPSG:xxxx, WKT, PROJ string, OGC:CRS84...) into an SRS with traditional
/// axis order; null with `error` set when OGR does not understand it.
inline SrsPtr parseSrs(const std::string& input, std::string& error) {
  ensureGdalRegistered();
  QuietGdal quiet;
  if (input.empty()) {
    error = "empty CRS definition";
    return nullptr;
  }
  SrsPtr srs(new OGRSpatialReference());
  const char* const options[] = {"ALLOW_NETWORK_ACCESS=NO", nullptr};
  if (srs->SetFromUserInput(input.c_str(), options) != OGRERR_NONE || srs->IsEmpty()) {
    error = "unknown CRS '" + (input.size() > 80 ? input.substr(0, 80) + "..." : input) +
            "': " + QuietGdal::lastMessage("OGR cannot parse it");
    return nullptr;
  }
  srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

/// Text from a data source as UTF-8: as it is when it is UTF-8, else read as Latin-1
/// (ISO-8859-1: every byte is a character, so nothing is lost). `recoded` is set when it was not
/// UTF-8. Files without a declared encoding (a Shapefile without .cpg) give such text.
inline std::string toUtf8(const char* text, bool& recoded) {
  if (text == nullptr) return {};
  if (CPLIsUTF8(text, -1) != 0) return text;
  recoded = true;
  char* converted = CPLRecode(text, CPL_ENC_ISO8859_1, CPL_ENC_UTF8);
  std::string out = converted != nullptr ? converted : "";
  CPLFree(converted);
  return out;
}

}  // namespace gis::geo::detail
