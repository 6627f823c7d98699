#include "geo/dem_source.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <new>
#include <optional>
#include <sstream>

#include <gdal_utils.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "core/hash.hpp"
#include "geo/gdal_support.hpp"

namespace gis::geo {

namespace {

namespace fs = std::filesystem;

using detail::DatasetPtr;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Files a DEM folder holds that are meant as rasters: one that cannot be read is named.
bool rasterName(const std::string& path) {
  const std::string name = lower(fs::path(path).filename().string());
  if (endsWith(name, ".hgt.zip")) return true;
  for (const char* ext : {".tif", ".tiff", ".hgt", ".vrt", ".img", ".asc", ".dem", ".bil", ".dt0", ".dt1", ".dt2",
                          ".nc", ".grd", ".flt", ".jp2", ".xyz", ".gpkg"}) {
    if (endsWith(name, ext)) return true;
  }
  return false;
}

/// Sidecar files that GDAL may identify but that are never tiles of their own.
bool sidecarName(const std::string& path) {
  const std::string name = lower(fs::path(path).filename().string());
  for (const char* ext : {".aux.xml", ".ovr", ".msk", ".tfw", ".prj", ".hdr", ".xml", ".txt", ".md", ".json"}) {
    if (endsWith(name, ext)) return true;
  }
  return false;
}

/// The widest DEM resampled into one projected frame (metres a side).
constexpr double kMaxRegionMetres = 4000e3;

std::string formatNumber(double v, int precision = 6) {
  std::ostringstream out;
  out.precision(precision);
  out << v;
  return out.str();
}

/// One input file as opened.
struct Tile {
  std::string path;
  RasterInfo info;
  detail::SrsPtr srs;
  double metresPerUnit = 1.0;  ///< heights: (raw · scale + offset) · metresPerUnit
  double scale = 1.0, offset = 0.0;
  std::optional<double> nodata;
};

/// Tiles that form one raster: one file, or a VRT mosaic of tiles sharing CRS, resolution,
/// height conversion and nodata.
struct Group {
  std::vector<std::string> files;
  DatasetPtr dataset;
  GDALRasterBand* band = nullptr;
  RasterInfo info;  ///< of the mosaic; path = the first file
  detail::SrsPtr srs;
  double scale = 1.0, offset = 0.0, metresPerUnit = 1.0;
  std::optional<double> nodata;
  double spacingMetres = 0.0;  ///< finest post spacing, measured in the frame when opened in one
};

bool sameGroup(const Tile& a, const Group& g) {
  const auto& x = a.info.geoTransform.c;
  const auto& y = g.info.geoTransform.c;
  const auto close = [](double p, double q) { return std::abs(p - q) <= 1e-9 * std::max(std::abs(p), std::abs(q)); };
  const bool northUp = x[2] == 0.0 && x[4] == 0.0 && y[2] == 0.0 && y[4] == 0.0 && x[1] > 0.0 && x[5] < 0.0;
  const bool sameNodata = a.nodata.has_value() == g.nodata.has_value() &&
                          (!a.nodata || *a.nodata == *g.nodata || (std::isnan(*a.nodata) && std::isnan(*g.nodata)));
  return northUp && close(x[1], y[1]) && close(x[5], y[5]) && a.srs->IsSame(g.srs.get()) != 0 && a.scale == g.scale &&
         a.offset == g.offset && a.metresPerUnit == g.metresPerUnit && sameNodata;
}

/// Expands folders into the raster files they hold (sorted); other files stay as given.
std::vector<std::string> expandPaths(const std::vector<std::string>& paths, Diagnostics& problems,
                                     Diagnostics& diagnostics) {
  std::vector<std::string> files;
  for (const std::string& path : paths) {
    std::error_code ec;
    if (!fs::is_directory(path, ec)) {
      files.push_back(path);
      continue;
    }
    std::vector<std::string> found;
    std::size_t ignored = 0;
    for (fs::recursive_directory_iterator it(path, fs::directory_options::skip_permission_denied, ec), end;
         !ec && it != end; it.increment(ec)) {
      if (!it->is_regular_file(ec)) continue;
      const std::string file = it->path().string();
      if (sidecarName(file)) continue;
      if (rasterName(file)) {
        found.push_back(file);
        continue;
      }
      detail::QuietGdal quiet;
      GDALDriverH driver = GDALIdentifyDriverEx(file.c_str(), GDAL_OF_RASTER, nullptr, nullptr);
      if (driver != nullptr) {
        found.push_back(file);
      } else {
        ++ignored;
      }
    }
    if (ec) problems.add({Severity::Warning, path, "", "", "cannot list the folder: " + ec.message()});
    if (found.empty()) {
      problems.add({Severity::Warning, path, "", "",
                    "the folder holds no raster GDAL can read" +
                        (ignored > 0 ? " (" + std::to_string(ignored) + " other files)" : std::string())});
    } else if (ignored > 0) {
      diagnostics.add({Severity::Info, path, "", "",
                       std::to_string(ignored) + " file" + (ignored == 1 ? " is" : "s are") +
                           " not a raster and left out of the DEM"});
    }
    std::sort(found.begin(), found.end());
    files.insert(files.end(), found.begin(), found.end());
  }
  return files;
}

/// Opens one tile; nullopt with the reason in `problems` (a Warning naming the file).
std::optional<Tile> openTile(const std::string& path, const DemSpec& spec, const detail::SrsPtr& crsOverride,
                             double unitOverride, Diagnostics& problems, Diagnostics& diagnostics) {
  auto problem = [&](const std::string& message) {
    problems.add({Severity::Warning, path, "", "", message});
    return std::nullopt;
  };
  detail::QuietGdal quiet;
  DatasetPtr ds(GDALDataset::FromHandle(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!ds) return problem("cannot open raster: " + detail::QuietGdal::lastMessage("not a raster GDAL can read"));
  Tile tile;
  tile.path = path;
  tile.info.path = path;
  tile.info.width = ds->GetRasterXSize();
  tile.info.height = ds->GetRasterYSize();
  tile.info.bandCount = ds->GetRasterCount();
  if (spec.band < 1 || spec.band > tile.info.bandCount) {
    return problem("band " + std::to_string(spec.band) + " does not exist (the raster has " +
                   std::to_string(tile.info.bandCount) + " band" + (tile.info.bandCount == 1 ? "" : "s") +
                   ", numbered from 1)");
  }
  if (tile.info.width <= 0 || tile.info.height <= 0) return problem("raster is empty");
  std::array<double, 6> gt{};
  if (ds->GetGeoTransform(gt.data()) != CE_None) {
    return problem("raster has no geotransform: it cannot be placed on the Earth");
  }
  tile.info.geoTransform.c = gt;
  if (!tile.info.geoTransform.finite()) return problem("the raster's geotransform has a NaN or infinite value");
  if (crsOverride) {
    tile.srs = detail::cloneTraditional(*crsOverride);
  } else if (const OGRSpatialReference* srs = ds->GetSpatialRef(); srs != nullptr && !srs->IsEmpty()) {
    tile.srs = detail::cloneTraditional(*srs);
  } else {
    return problem("raster has no CRS; give the DEM's CRS in the scene (terrain.crs)");
  }
  tile.info.crsWkt = detail::toWkt(*tile.srs);
  tile.info.crsIsGeographic = tile.srs->IsGeographic() != 0;
  tile.info.crsIsProjected = tile.srs->IsProjected() != 0;
  if (!tile.info.crsIsGeographic && !tile.info.crsIsProjected) {
    return problem("raster CRS is neither projected nor geographic");
  }
  GDALRasterBand* band = ds->GetRasterBand(spec.band);
  int has = 0;
  const double nodata = band->GetNoDataValue(&has);
  if (has != 0) tile.nodata = nodata;
  tile.info.nodata = tile.nodata;
  has = 0;
  const double scale = band->GetScale(&has);
  if (has != 0 && std::isfinite(scale) && scale != 0.0) tile.scale = scale;
  has = 0;
  const double offset = band->GetOffset(&has);
  if (has != 0 && std::isfinite(offset)) tile.offset = offset;
  if (unitOverride > 0.0) {
    tile.metresPerUnit = unitOverride;
  } else {
    // The band's unit first, then a compound CRS's vertical unit.
    const char* unitType = band->GetUnitType();
    std::string unit = unitType != nullptr ? unitType : "";
    if (unit.empty() && tile.srs->IsCompound() != 0) {
      const double toMetre = tile.srs->GetTargetLinearUnits("VERT_CS");
      if (toMetre > 0.0 && std::isfinite(toMetre)) tile.metresPerUnit = toMetre;
    } else if (!unit.empty()) {
      const double m = metresPerHeightUnit(unit);
      if (m > 0.0) {
        tile.metresPerUnit = m;
      } else {
        diagnostics.add({Severity::Warning, path, "", "",
                         "unknown height unit '" + unit + "': heights taken as metres (say terrain.height_unit)"});
      }
    } else if (tile.info.crsIsProjected && tile.srs->GetLinearUnits() < 0.9) {
      diagnostics.add({Severity::Warning, path, "", "",
                       "the CRS is in feet but the heights declare no unit: taken as metres (if they are feet, "
                       "say terrain.height_unit \"ft\" or \"us-ft\")"});
    }
  }
  tile.info.path = path;
  return tile;
}

/// Points along the boundary of a raster's post rectangle (pixel centres), in its CRS.
std::vector<glm::dvec2> boundaryPoints(const RasterInfo& info, int perEdge = 32) {
  std::vector<glm::dvec2> pts;
  const double c0 = 0.5, r0 = 0.5, c1 = info.width - 0.5, r1 = info.height - 0.5;
  for (int i = 0; i <= perEdge; ++i) {
    const double t = static_cast<double>(i) / perEdge;
    pts.push_back(info.geoTransform.pixelToCrs(c0 + t * (c1 - c0), r0));
    pts.push_back(info.geoTransform.pixelToCrs(c0 + t * (c1 - c0), r1));
    pts.push_back(info.geoTransform.pixelToCrs(c0, r0 + t * (r1 - r0)));
    pts.push_back(info.geoTransform.pixelToCrs(c1, r0 + t * (r1 - r0)));
  }
  return pts;
}

}  // namespace

double metresPerHeightUnit(const std::string& unit) {
  std::string u = lower(unit);
  u.erase(std::remove_if(u.begin(), u.end(), [](char c) { return c == ' ' || c == '_' || c == '-'; }), u.end());
  if (u == "m" || u == "metre" || u == "meter" || u == "metres" || u == "meters") return 1.0;
  if (u == "ft" || u == "foot" || u == "feet" || u == "internationalfoot" || u == "intlfoot") return 0.3048;
  if (u == "usft" || u == "ftus" || u == "ussurveyfoot" || u == "footus" || u == "usfoot" || u == "ussurveyfeet")
    return 1200.0 / 3937.0;
  if (u == "km" || u == "kilometre" || u == "kilometer") return 1000.0;
  if (u == "cm" || u == "centimetre" || u == "centimeter") return 0.01;
  if (u == "dm" || u == "decimetre" || u == "decimeter") return 0.1;
  if (u == "mm" || u == "millimetre" || u == "millimeter") return 0.001;
  return 0.0;
}

Result<std::string> writeFlatDem(const std::string& path, const std::array<double, 4>& box) {
  auto fail = [&](const std::string& message) {
    return Result<std::string>::failure({Severity::Error, path, "", "", message});
  };
  detail::ensureGdalRegistered();
  const double west = box[0], south = box[1], east = box[2], north = box[3];
  if (!(std::isfinite(west) && std::isfinite(south) && std::isfinite(east) && std::isfinite(north)) || west > east ||
      south > north || south < -90.0 || north > 90.0) {
    return fail("no extent to make flat ground for");
  }
  const UtmZone zone = utmZoneOf(0.5 * (west + east), 0.5 * (south + north));
  if (zone.zone < 1) return fail("no UTM zone for the extent's centre");
  Result<SceneFrame> utm = SceneFrame::fromCrs("EPSG:" + std::to_string(zone.epsgWgs84()), glm::dvec3(0.0));
  if (!utm) return fail("cannot make the UTM frame EPSG:" + std::to_string(zone.epsgWgs84()));
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (int k = 0; k <= 16; ++k) {
    const double t = k / 16.0;
    const double lon = west + t * (east - west), lat = south + t * (north - south);
    for (const glm::dvec2 p :
         {glm::dvec2(lon, south), glm::dvec2(lon, north), glm::dvec2(west, lat), glm::dvec2(east, lat)}) {
      if (const auto q = utm->fromLonLat(p.x, p.y, 0.0)) {
        lo = glm::min(lo, glm::dvec2(*q));
        hi = glm::max(hi, glm::dvec2(*q));
      }
    }
  }
  if (!(lo.x <= hi.x && lo.y <= hi.y)) return fail("the extent cannot be projected to UTM");
  // A square around the data, with a margin: the ground reads as ground, not as a strip.
  const double side = std::max(hi.x - lo.x, hi.y - lo.y);
  const double half = 0.5 * side + std::max(100.0, 0.1 * side);
  const glm::dvec2 mid = 0.5 * (lo + hi);
  lo = mid - half;
  hi = mid + half;
  constexpr int kPosts = 257;
  const double spacing = std::max(hi.x - lo.x, hi.y - lo.y) / (kPosts - 1);
  const int w = std::max(2, static_cast<int>(std::ceil((hi.x - lo.x) / spacing)) + 1);
  const int h = std::max(2, static_cast<int>(std::ceil((hi.y - lo.y) / spacing)) + 1);
  detail::QuietGdal quiet;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) return fail("GDAL has no GTiff driver");
  DatasetPtr ds(driver->Create(path.c_str(), w, h, 1, GDT_Float32, nullptr));
  if (!ds) return fail("cannot write flat ground: " + detail::QuietGdal::lastMessage("GTiff create failed"));
  std::array<double, 6> gt{lo.x - 0.5 * spacing, spacing, 0.0, hi.y + 0.5 * spacing, 0.0, -spacing};
  ds->SetGeoTransform(gt.data());
  OGRSpatialReference srs;
  srs.importFromEPSG(zone.epsgWgs84());
  ds->SetSpatialRef(&srs);
  std::vector<float> zeros(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0F);
  if (ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, w, h, zeros.data(), w, h, GDT_Float32, 0, 0, nullptr) != CE_None) {
    return fail("cannot write flat ground: " + detail::QuietGdal::lastMessage("RasterIO failed"));
  }
  Result<std::string> r;
  r.value = path;
  return r;
}

// ---------------------------------------------------------------------------------------------
// DemSource

struct DemSource::State {
  DemSpec spec;
  std::vector<Group> groups;
  std::vector<std::string> files;
  RasterInfo extent;
  std::string label;
  std::string fingerprint;
};

DemSource::DemSource(std::shared_ptr<State> state) : state_(std::move(state)) {}
DemSource::DemSource(DemSource&&) noexcept = default;
DemSource& DemSource::operator=(DemSource&&) noexcept = default;
DemSource::~DemSource() = default;

const DemSpec& DemSource::spec() const { return state_->spec; }
const RasterInfo& DemSource::extent() const { return state_->extent; }
const std::vector<std::string>& DemSource::files() const { return state_->files; }
const std::string& DemSource::label() const { return state_->label; }
const std::string& DemSource::fingerprint() const { return state_->fingerprint; }

std::vector<RasterInfo> DemSource::groups() const {
  std::vector<RasterInfo> out;
  for (const Group& g : state_->groups) out.push_back(g.info);
  return out;
}

Result<DemSource> DemSource::open(const DemSpec& spec) {
  detail::ensureGdalRegistered();
  const std::string first = spec.paths.empty() ? std::string() : spec.paths.front();
  auto fail = [&](const std::string& message) {
    return Result<DemSource>::failure({Severity::Error, first, "", "", message});
  };
  if (spec.paths.empty()) return fail("no DEM file given");
  detail::SrsPtr crsOverride;
  if (!spec.crs.empty()) {
    std::string error;
    crsOverride = detail::parseSrs(spec.crs, error);
    if (!crsOverride) return fail("terrain.crs: " + error);
  }
  double unitOverride = 0.0;
  if (!spec.heightUnit.empty()) {
    unitOverride = metresPerHeightUnit(spec.heightUnit);
    if (!(unitOverride > 0.0)) return fail("terrain.height_unit: unknown unit '" + spec.heightUnit + "'");
  }
  if (!(spec.resolutionMetres >= 0.0) || !std::isfinite(spec.resolutionMetres)) {
    return fail("terrain.resolution_m must be a positive number of metres");
  }

  Result<DemSource> r;
  Diagnostics problems;  // per tile: Warnings while some tile is usable, Errors otherwise
  auto state = std::make_shared<State>();
  state->spec = spec;
  state->files = expandPaths(spec.paths, problems, r.diagnostics);

  std::vector<Tile> tiles;
  for (const std::string& file : state->files) {
    std::optional<Tile> tile = openTile(file, spec, crsOverride, unitOverride, problems, r.diagnostics);
    if (tile) tiles.push_back(std::move(*tile));
  }
  if (tiles.empty()) {
    Result<DemSource> failed;
    failed.diagnostics = std::move(r.diagnostics);
    for (Diagnostic d : problems.items()) {
      d.severity = Severity::Error;
      failed.diagnostics.add(std::move(d));
    }
    if (!failed.diagnostics.hasErrors())
      failed.diagnostics.add({Severity::Error, first, "", "", "no DEM tile to read"});
    return failed;
  }
  for (const Diagnostic& d : problems.items()) {
    Diagnostic named = d;
    named.message += "; left out of the DEM (a hole)";
    r.diagnostics.add(std::move(named));
  }

  // Group tiles that can be one mosaic.
  std::vector<std::vector<Tile*>> members;
  for (Tile& tile : tiles) {
    bool placed = false;
    for (std::size_t g = 0; g < state->groups.size() && !placed; ++g) {
      if (sameGroup(tile, state->groups[g])) {
        state->groups[g].files.push_back(tile.path);
        members[g].push_back(&tile);
        placed = true;
      }
    }
    if (placed) continue;
    Group group;
    group.files.push_back(tile.path);
    group.info = tile.info;
    group.srs = detail::cloneTraditional(*tile.srs);
    group.scale = tile.scale;
    group.offset = tile.offset;
    group.metresPerUnit = tile.metresPerUnit;
    group.nodata = tile.nodata;
    state->groups.push_back(std::move(group));
    members.push_back({&tile});
  }
  for (std::size_t g = 0; g < state->groups.size(); ++g) {
    Group& group = state->groups[g];
    detail::QuietGdal quiet;
    if (group.files.size() == 1) {
      group.dataset.reset(GDALDataset::FromHandle(
          GDALOpenEx(group.files.front().c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
    } else {
      std::vector<const char*> names;
      for (const std::string& f : group.files) names.push_back(f.c_str());
      std::vector<std::string> args = {"-b", std::to_string(spec.band), "-resolution", "highest"};
      if (crsOverride) args.insert(args.end(), {"-a_srs", group.info.crsWkt, "-allow_projection_difference"});
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      GDALBuildVRTOptions* options = GDALBuildVRTOptionsNew(argv.data(), nullptr);
      int usageError = 0;
      group.dataset.reset(GDALDataset::FromHandle(
          GDALBuildVRT("", static_cast<int>(names.size()), nullptr, names.data(), options, &usageError)));
      GDALBuildVRTOptionsFree(options);
      if (group.dataset) {
        std::array<double, 6> gt{};
        group.dataset->GetGeoTransform(gt.data());
        group.info.geoTransform.c = gt;
        group.info.width = group.dataset->GetRasterXSize();
        group.info.height = group.dataset->GetRasterYSize();
        group.info.bandCount = group.dataset->GetRasterCount();
      }
    }
    if (!group.dataset) {
      return fail("cannot mosaic the tiles of " + group.files.front() + ": " +
                  detail::QuietGdal::lastMessage("GDALBuildVRT failed"));
    }
    // A VRT of one band holds the selected band as its band 1.
    group.band = group.dataset->GetRasterBand(group.files.size() == 1 ? spec.band : 1);
    if (group.band == nullptr) return fail("cannot read band " + std::to_string(spec.band) + " of the mosaic");
  }

  // The extent: the one CRS's own, or WGS 84 longitude/latitude.
  bool oneCrs = true;
  for (const Group& g : state->groups) oneCrs = oneCrs && g.srs->IsSame(state->groups.front().srs.get()) != 0;
  if (state->groups.size() == 1) {
    state->extent = state->groups.front().info;
  } else {
    detail::SrsPtr target;
    if (oneCrs) {
      target = detail::cloneTraditional(*state->groups.front().srs);
    } else {
      target.reset(new OGRSpatialReference());
      target->SetWellKnownGeogCS("WGS84");
      target->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    }
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const Group& g : state->groups) {
      std::vector<glm::dvec2> pts = boundaryPoints(g.info);
      detail::QuietGdal quiet;
      std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(g.srs.get(), target.get()));
      if (!ct) return fail("cannot transform " + g.files.front() + " into a common CRS");
      for (glm::dvec2& p : pts) {
        double x = p.x, y = p.y;
        int ok = 0;
        if (ct->Transform(1, &x, &y, nullptr, &ok) != 0 && ok != 0 && std::isfinite(x) && std::isfinite(y)) {
          lo = glm::min(lo, glm::dvec2(x, y));
          hi = glm::max(hi, glm::dvec2(x, y));
        }
      }
    }
    if (!(lo.x <= hi.x && lo.y <= hi.y)) return fail("the tiles' extents cannot be transformed into a common CRS");
    RasterInfo e;
    e.path = first;
    e.width = 1;
    e.height = 1;
    e.bandCount = 1;
    e.geoTransform.c = {lo.x, std::max(hi.x - lo.x, 1e-9), 0.0, hi.y, 0.0, -std::max(hi.y - lo.y, 1e-9)};
    e.crsWkt = detail::toWkt(*target);
    e.crsIsGeographic = target->IsGeographic() != 0;
    e.crsIsProjected = target->IsProjected() != 0;
    state->extent = e;
  }

  state->label = state->files.size() == 1 && spec.paths.size() == 1 && state->files.front() == first
                     ? first
                     : first + " (" + std::to_string(tiles.size()) + " tile" + (tiles.size() == 1 ? "" : "s") + ")";
  std::ostringstream id;
  id << "band=" << spec.band << ";crs=" << spec.crs << ";unit=" << spec.heightUnit
     << ";res=" << formatNumber(spec.resolutionMetres, 17) << ";";
  for (const std::string& f : state->files) {
    struct stat st {};
    const bool ok = ::stat(f.c_str(), &st) == 0;
    id << fs::absolute(f).lexically_normal().string() << ":" << (ok ? st.st_size : -1) << ":"
       << (ok ? st.st_mtim.tv_sec : 0) << "." << (ok ? st.st_mtim.tv_nsec : 0) << ";";
  }
  state->fingerprint = id.str();
  r.value = DemSource(std::move(state));
  return r;
}

// ---------------------------------------------------------------------------------------------
// FrameDem

namespace {

/// A group as sampled from the frame: frame CRS → the group's pixel coordinates.
struct GroupSampler {
  Group* group = nullptr;
  std::optional<CrsTransform> toGroup;  ///< frame projected CRS → group CRS
  std::optional<CrsTransform> toFrame;  ///< group CRS → frame projected CRS
};

}  // namespace

struct FrameDem::State {
  std::shared_ptr<DemSource::State> source;
  RasterInfo info;
  bool resampled = false;
  double spacing = 0.0;
  std::vector<GroupSampler> samplers;  ///< finest first
  // Scratch.
  std::vector<float> window;
  std::vector<unsigned char> assigned;
};

FrameDem::FrameDem(std::unique_ptr<State> state) : state_(std::move(state)) {}
FrameDem::FrameDem(FrameDem&&) noexcept = default;
FrameDem& FrameDem::operator=(FrameDem&&) noexcept = default;
FrameDem::~FrameDem() = default;

const RasterInfo& FrameDem::info() const { return state_->info; }
bool FrameDem::resampled() const { return state_->resampled; }
double FrameDem::spacing() const { return state_->spacing; }

std::string FrameDem::fingerprint() const {
  const RasterInfo& i = state_->info;
  std::ostringstream id;
  id << state_->source->fingerprint << "grid=" << i.width << "x" << i.height;
  for (double c : i.geoTransform.c) id << "," << formatNumber(c, 17);
  id << ";frame=" << stableHashHex(i.crsWkt);
  return id.str();
}

Result<FrameDem> FrameDem::open(const DemSource& source, const SceneFrame& frame) {
  auto& src = *source.state_;
  auto fail = [&](const std::string& message) {
    return Result<FrameDem>::failure({Severity::Error, src.label, "", "", message});
  };
  std::string error;
  const detail::SrsPtr frameSrs = detail::parseSrs(frame.crsWkt(), error);
  if (!frameSrs) return fail("scene frame: " + error);

  auto state = std::make_unique<State>();
  state->source = source.state_;
  Result<FrameDem> r;

  // Read as it is: one raster in the frame's CRS, north-up, at the requested spacing.
  const Group& g0 = src.groups.front();
  const auto& c = g0.info.geoTransform.c;
  const bool asIs = src.groups.size() == 1 && g0.srs->IsSame(frameSrs.get()) != 0 && c[2] == 0.0 && c[4] == 0.0 &&
                    c[1] > 0.0 && c[5] < 0.0 &&
                    (src.spec.resolutionMetres == 0.0 ||
                     (std::abs(c[1] - src.spec.resolutionMetres) < 1e-9 * c[1] && std::abs(c[1] + c[5]) < 1e-9 * c[1]));
  for (Group& g : src.groups) {
    GroupSampler s;
    s.group = &g;
    Result<CrsTransform> t = frame.transformTo(g.info.crsWkt);
    if (!t) return fail("cannot transform the scene frame into the CRS of " + g.files.front());
    s.toGroup.emplace(std::move(*t));
    Result<CrsTransform> back = frame.transformFrom(g.info.crsWkt);
    if (!back) return fail("cannot transform " + g.files.front() + " into the scene frame");
    const CrsTransform& toFrame = s.toFrame.emplace(std::move(*back));
    // Finest spacing in metres near the group's centre: neighbouring posts carried into the frame.
    const double cc = 0.5 * g.info.width, cr = 0.5 * g.info.height;
    const auto p = toFrame.transform(g.info.geoTransform.pixelToCrs(cc, cr));
    const auto px = toFrame.transform(g.info.geoTransform.pixelToCrs(cc + 1.0, cr));
    const auto py = toFrame.transform(g.info.geoTransform.pixelToCrs(cc, cr + 1.0));
    if (!p || !px || !py) return fail("the centre of " + g.files.front() + " cannot be placed in the scene frame");
    g.spacingMetres = std::min(glm::length(*px - *p), glm::length(*py - *p));
    state->samplers.push_back(std::move(s));
  }
  std::stable_sort(state->samplers.begin(), state->samplers.end(), [](const GroupSampler& a, const GroupSampler& b) {
    return a.group->spacingMetres < b.group->spacingMetres;
  });

  if (asIs) {
    state->info = g0.info;
    state->info.crsWkt = frame.crsWkt();
    state->info.nodata.reset();
    state->spacing = std::min(c[1], -c[5]);
    state->resampled = false;
  } else {
    double spacing =
        src.spec.resolutionMetres > 0.0 ? src.spec.resolutionMetres : state->samplers.front().group->spacingMetres;
    if (!(spacing > 0.0) || !std::isfinite(spacing)) return fail("cannot find the DEM's post spacing in metres");
    // The extent in the frame: every group's boundary carried over.
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const GroupSampler& s : state->samplers) {
      std::vector<glm::dvec2> pts = boundaryPoints(s.group->info, 256);
      s.toFrame->transform(pts.data(), pts.size());
      for (const glm::dvec2& q : pts) {
        if (!std::isfinite(q.x) || !std::isfinite(q.y)) continue;
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
    }
    if (!(lo.x < hi.x && lo.y < hi.y)) return fail("the DEM's extent cannot be placed in the scene frame");
    // One projected frame holds a region, not a continent: beyond a few thousand kilometres a
    // transverse Mercator's scale error grows past 10 % and far points do not project at all.
    if (hi.x - lo.x > kMaxRegionMetres || hi.y - lo.y > kMaxRegionMetres) {
      return fail("the DEM spans " + formatNumber((hi.x - lo.x) / 1000.0, 4) + " x " +
                  formatNumber((hi.y - lo.y) / 1000.0, 4) +
                  " km in the scene frame: more than one projected frame holds without large distortion (at most " +
                  formatNumber(kMaxRegionMetres / 1000.0, 4) +
                  " km a side); cut it to a region (gdal_translate -projwin), as the globe frame is not built yet");
    }
    // Posts on multiples of the spacing, covering the extent.
    const double x0 = std::floor(lo.x / spacing) * spacing;
    const double y0 = std::ceil(hi.y / spacing) * spacing;
    const double w = std::floor((hi.x - x0) / spacing) + 2.0;
    const double h = std::floor((y0 - lo.y) / spacing) + 2.0;
    if (!(w * h <= 4e9) || w > 1e6 || h > 1e6) {
      return fail("resampled into the scene frame at " + formatNumber(spacing) + " m the DEM would have " +
                  formatNumber(w, 4) + " x " + formatNumber(h, 4) + " posts; give a coarser terrain.resolution_m");
    }
    state->spacing = spacing;
    state->resampled = true;
    RasterInfo& info = state->info;
    info.path = src.label;
    info.width = static_cast<int>(w);
    info.height = static_cast<int>(h);
    info.bandCount = 1;
    // Post (c, r) at (x0 + c·s, y0 − r·s): pixel corners half a spacing up and left.
    info.geoTransform.c = {x0 - 0.5 * spacing, spacing, 0.0, y0 + 0.5 * spacing, 0.0, -spacing};
    info.crsWkt = frame.crsWkt();
    info.crsIsProjected = true;
    std::ostringstream message;
    message << "resampled (bilinear) from " << (src.groups.size() == 1 ? "its CRS" : "the tiles' CRSs")
            << " into the scene frame at " << formatNumber(spacing, 4) << " m posts (" << info.width << " x "
            << info.height << ")";
    r.diagnostics.add({Severity::Info, src.label, "", "", message.str()});
  }
  r.value = FrameDem(std::move(state));
  return r;
}

bool FrameDem::read(int row0, int rows, std::vector<float>& out, Diagnostics& diagnostics) {
  State& s = *state_;
  const RasterInfo& info = s.info;
  detail::QuietGdal quiet;
  auto readError = [&](const std::string& file, const std::string& what) {
    diagnostics.add({Severity::Error, file, "", "", what + ": " + detail::QuietGdal::lastMessage("RasterIO failed")});
    return false;
  };
  if (row0 < 0 || rows < 0 || row0 + rows > info.height) {
    diagnostics.add({Severity::Error, s.source->label, "", "",
                     "rows " + std::to_string(row0) + "+" + std::to_string(rows) + " are outside the grid's " +
                         std::to_string(info.height)});
    return false;
  }
  const std::size_t width = static_cast<std::size_t>(info.width);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  out.assign(static_cast<std::size_t>(rows) * width, nan);
  if (rows == 0) return true;

  // Heights in metres; nodata NaN; implausible +inf.
  auto convert = [](const Group& g, float* v, std::size_t n) {
    const bool hasNodata = g.nodata.has_value() && !std::isnan(*g.nodata);
    const auto nodata = hasNodata ? static_cast<float>(*g.nodata) : 0.0F;
    const double k = g.scale * g.metresPerUnit, o = g.offset * g.metresPerUnit;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::isnan(v[i]) || (hasNodata && v[i] == nodata)) {
        v[i] = std::numeric_limits<float>::quiet_NaN();
        continue;
      }
      const double h = static_cast<double>(v[i]) * k + o;
      v[i] = std::abs(h) <= kMaxPlausibleHeight ? static_cast<float>(h) : std::numeric_limits<float>::infinity();
    }
  };

  if (!s.resampled) {
    Group& g = *s.samplers.front().group;
    if (g.band->RasterIO(GF_Read, 0, row0, info.width, rows, out.data(), info.width, rows, GDT_Float32, 0, 0,
                         nullptr) != CE_None) {
      return readError(g.files.front(), "cannot read rows " + std::to_string(row0) + "+" + std::to_string(rows));
    }
    // As-is reads keep implausible samples for the terrain's check (it counts and names them).
    const bool hasNodata = g.nodata.has_value() && !std::isnan(*g.nodata);
    const auto nodata = hasNodata ? static_cast<float>(*g.nodata) : 0.0F;
    const double k = g.scale * g.metresPerUnit, o = g.offset * g.metresPerUnit;
    for (float& v : out) {
      if (hasNodata && v == nodata) {
        v = nan;
      } else if (k != 1.0 || o != 0.0) {
        v = static_cast<float>(static_cast<double>(v) * k + o);
      }
    }
    return true;
  }

  // Source pixel coordinates on a lattice every kStep posts, exact there and bilinear between:
  // the projections are smooth at this scale (the error is measured in dem_source_test).
  constexpr int kStep = 8;
  std::vector<int> latCols, latRows;
  for (int c = 0; c < info.width - 1; c += kStep) latCols.push_back(c);
  latCols.push_back(info.width - 1);
  for (int r = row0; r < row0 + rows - 1; r += kStep) latRows.push_back(r);
  latRows.push_back(row0 + rows - 1);
  const std::size_t lw = latCols.size(), lh = latRows.size();
  std::vector<int> colCell(width), rowCell(static_cast<std::size_t>(rows));
  for (std::size_t k = 0, c = 0; c < width; ++c) {
    while (k + 2 < lw && latCols[k + 1] <= static_cast<int>(c)) ++k;
    colCell[c] = static_cast<int>(k);
  }
  for (std::size_t k = 0, r = 0; r < static_cast<std::size_t>(rows); ++r) {
    while (k + 2 < lh && latRows[k + 1] <= row0 + static_cast<int>(r)) ++k;
    rowCell[r] = static_cast<int>(k);
  }
  s.assigned.assign(out.size(), 0);
  std::vector<glm::dvec2> lattice(lw * lh);
  auto postXy = [&](double col, double row) { return info.geoTransform.pixelToCrs(col + 0.5, row + 0.5); };

  for (GroupSampler& sampler : s.samplers) {
    Group& g = *sampler.group;
    for (std::size_t j = 0; j < lh; ++j) {
      for (std::size_t i = 0; i < lw; ++i) lattice[j * lw + i] = postXy(latCols[i], latRows[j]);
    }
    sampler.toGroup->transform(lattice.data(), lattice.size());
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (glm::dvec2& p : lattice) {
      if (!std::isfinite(p.x)) continue;
      const std::optional<glm::dvec2> px = g.info.geoTransform.crsToPixel(p);
      p = px ? *px - glm::dvec2(0.5) : glm::dvec2(std::numeric_limits<double>::quiet_NaN());  // post coordinates
      if (!px) continue;
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    // The window of source posts the strip needs (posts are pixel centres).
    const int gw = g.info.width, gh = g.info.height;
    if (!(lo.x <= hi.x && lo.y <= hi.y) || hi.x < -1.0 || hi.y < -1.0 || lo.x > gw || lo.y > gh) continue;
    const int wc0 = std::clamp(static_cast<int>(std::floor(lo.x)) - 2, 0, gw - 1);
    const int wr0 = std::clamp(static_cast<int>(std::floor(lo.y)) - 2, 0, gh - 1);
    const int wc1 = std::clamp(static_cast<int>(std::ceil(hi.x)) + 2, 0, gw - 1);
    const int wr1 = std::clamp(static_cast<int>(std::ceil(hi.y)) + 2, 0, gh - 1);
    if (wc1 <= wc0 || wr1 <= wr0) continue;
    const int ww = wc1 - wc0 + 1, wh = wr1 - wr0 + 1;
    try {
      s.window.resize(static_cast<std::size_t>(ww) * static_cast<std::size_t>(wh));
    } catch (const std::bad_alloc&) {
      diagnostics.add({Severity::Error, g.files.front(), "", "", "not enough memory to read the DEM window"});
      return false;
    }
    if (g.band->RasterIO(GF_Read, wc0, wr0, ww, wh, s.window.data(), ww, wh, GDT_Float32, 0, 0, nullptr) != CE_None) {
      return readError(g.files.front(), "cannot read the DEM");
    }
    convert(g, s.window.data(), s.window.size());
    // Exactly on the raster's last post is inside; a rounding hair beyond it too.
    constexpr double kEdge = 1e-6;
    for (std::size_t r = 0; r < static_cast<std::size_t>(rows); ++r) {
      const std::size_t j = static_cast<std::size_t>(rowCell[r]);
      const double tr = static_cast<double>(row0 + static_cast<int>(r) - latRows[j]) /
                        std::max(1, latRows[j + (lh > 1 ? 1 : 0)] - latRows[j]);
      for (std::size_t c = 0; c < width; ++c) {
        const std::size_t at = r * width + c;
        if (s.assigned[at] != 0) continue;
        const std::size_t i = static_cast<std::size_t>(colCell[c]);
        const std::size_t i1 = i + (lw > 1 ? 1 : 0), j1 = j + (lh > 1 ? 1 : 0);
        const double tc = static_cast<double>(static_cast<int>(c) - latCols[i]) / std::max(1, latCols[i1] - latCols[i]);
        const glm::dvec2 a = lattice[j * lw + i], b = lattice[j * lw + i1];
        const glm::dvec2 d = lattice[j1 * lw + i], e = lattice[j1 * lw + i1];
        glm::dvec2 p;
        if (std::isfinite(a.x) && std::isfinite(b.x) && std::isfinite(d.x) && std::isfinite(e.x)) {
          p = (a * (1.0 - tc) + b * tc) * (1.0 - tr) + (d * (1.0 - tc) + e * tc) * tr;
        } else {  // the lattice has a point that does not transform: this post alone
          glm::dvec2 q = postXy(static_cast<double>(c), static_cast<double>(row0) + static_cast<double>(r));
          if (!sampler.toGroup->transform(&q, 1)) continue;
          const std::optional<glm::dvec2> px = g.info.geoTransform.crsToPixel(q);
          if (!px) continue;
          p = *px - glm::dvec2(0.5);
        }
        if (!(p.x >= -kEdge && p.y >= -kEdge && p.x <= gw - 1 + kEdge && p.y <= gh - 1 + kEdge)) continue;
        const double u = std::clamp(p.x, 0.0, static_cast<double>(gw - 1)) - wc0;
        const double v = std::clamp(p.y, 0.0, static_cast<double>(gh - 1)) - wr0;
        if (u < 0.0 || v < 0.0 || u > ww - 1 || v > wh - 1) continue;  // cannot happen: the window covers it
        const int ci = std::min(static_cast<int>(u), ww - 2), ri = std::min(static_cast<int>(v), wh - 2);
        const double fu = u - ci, fv = v - ri;
        const float* w0 = s.window.data() + static_cast<std::size_t>(ri) * static_cast<std::size_t>(ww) +
                          static_cast<std::size_t>(ci);
        const float* w1 = w0 + ww;
        const float h00 = w0[0], h10 = w0[1], h01 = w1[0], h11 = w1[1];
        // A corner of no weight still counts: a hole's edge post is not a height.
        if (std::isnan(h00) || std::isnan(h10) || std::isnan(h01) || std::isnan(h11)) continue;
        s.assigned[at] = 1;
        if (std::isinf(h00) || std::isinf(h10) || std::isinf(h01) || std::isinf(h11)) {
          out[at] = inf;
          continue;
        }
        out[at] = static_cast<float>((h00 * (1.0 - fu) + h10 * fu) * (1.0 - fv) + (h01 * (1.0 - fu) + h11 * fu) * fv);
      }
    }
  }
  return true;
}

}  // namespace gis::geo
