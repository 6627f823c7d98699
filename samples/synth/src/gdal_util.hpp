#pragma once
// GDAL helpers the synthetic data writers share (private to the synth library).
#include <string>

#include <cpl_error.h>
#include <ogr_spatialref.h>

namespace gis::synth::detail {

/// Keeps GDAL from printing while alive; its last message stays available.
class QuietGdal {
 public:
  QuietGdal() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdal() { CPLPopErrorHandler(); }
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;
  static std::string lastMessage(const std::string& fallback) {
    const char* msg = CPLGetLastErrorMsg();
    return msg == nullptr || *msg == '\0' ? fallback : std::string(msg);
  }
};

inline bool parseCrs(const std::string& text, OGRSpatialReference& srs, std::string& error) {
  QuietGdal quiet;
  const char* const options[] = {"ALLOW_NETWORK_ACCESS=NO", nullptr};
  if (srs.SetFromUserInput(text.c_str(), options) != OGRERR_NONE || srs.IsEmpty()) {
    error = "unknown CRS '" + text + "': " + QuietGdal::lastMessage("OGR cannot parse it");
    return false;
  }
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return true;
}

}  // namespace gis::synth::detail
