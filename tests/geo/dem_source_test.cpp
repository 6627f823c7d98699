// DEMs as people have them (issue 20): geographic and foreign-CRS DEMs resampled once into the
// scene frame, tile mosaics (SRTM .hgt with voids, GeoTIFF tiles of other CRSs and resolutions),
// height units, and bad input. The resampled grid is checked against the source at the source's
// own posts; the error figures printed here are those in docs/terrain.md.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dem_files.hpp"
#include "geo/dem_source.hpp"
#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "synth/synthetic_dem.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using geo::DemSource;
using geo::DemSpec;
using geo::FrameDem;

std::string outputDir(const std::string& name) {
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / (std::to_string(::getpid()) + "-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

const Diagnostic* find(const Diagnostics& d, Severity severity, const std::string& text) {
  for (const Diagnostic& item : d.items()) {
    if (item.severity == severity && item.message.find(text) != std::string::npos) return &item;
  }
  return nullptr;
}

std::string allMessages(const Diagnostics& d) {
  std::string out;
  for (const Diagnostic& item : d.items()) out += item.toString() + "\n";
  return out;
}

DemSpec specOf(std::vector<std::string> paths, int band = 1) {
  DemSpec spec;
  spec.paths = std::move(paths);
  spec.band = band;
  return spec;
}

/// A DEM opened in the frame made for it, read whole.
struct Opened {
  std::optional<geo::SceneFrame> frame;
  std::optional<FrameDem> dem;
  std::vector<float> heights;
  Diagnostics diagnostics;
};

Opened openInFrame(const DemSpec& spec, const geo::SceneFrame* frame = nullptr) {
  Opened o;
  Result<DemSource> source = DemSource::open(spec);
  o.diagnostics.append(source.diagnostics);
  if (!source) return o;
  if (frame != nullptr) {
    o.frame = *frame;
  } else {
    Result<geo::SceneFrame> made = geo::SceneFrame::forRaster(source->extent());
    o.diagnostics.append(made.diagnostics);
    if (!made) return o;
    o.frame = std::move(*made);
  }
  Result<FrameDem> dem = FrameDem::open(*source, *o.frame);
  o.diagnostics.append(dem.diagnostics);
  if (!dem) return o;
  o.dem = std::move(*dem);
  EXPECT_TRUE(o.dem->read(0, o.dem->info().height, o.heights, o.diagnostics)) << allMessages(o.diagnostics);
  return o;
}

struct ErrorFigures {
  double max = 0.0, rms = 0.0;
  std::size_t compared = 0;
  std::size_t holesWhereSourceIsComplete = 0;  ///< frame holes at a source post with 2x2 data around it
};

/// The resampled grid against the source at the source's own posts: the frame grid's bilinear
/// surface at each valid source post against the stored height (in metres: `toMetres`).
ErrorFigures compareAtSourcePosts(const Opened& o, const std::string& sourcePath, double toMetres = 1.0,
                                  int stride = 1) {
  ErrorFigures e;
  Result<geo::Raster> source = geo::readRaster(sourcePath);
  EXPECT_TRUE(source.ok());
  if (!source) return e;
  const geo::RasterInfo& si = source->info;
  Result<geo::CrsTransform> toFrame = o.frame->transformFrom(si.crsWkt);
  EXPECT_TRUE(toFrame.ok());
  if (!toFrame) return e;
  const geo::RasterInfo& fi = o.dem->info();
  double sum = 0.0;
  for (int r = 2; r + 2 < si.height; r += stride) {
    for (int c = 2; c + 2 < si.width; c += stride) {
      const float h = source->at(c, r);
      if (std::isnan(h)) continue;
      const std::optional<glm::dvec2> p = toFrame->transform(si.pixelCentre(c, r));
      if (!p) continue;
      const std::optional<glm::dvec2> px = fi.geoTransform.crsToPixel(*p);
      const double g = bilinearAt(o.heights, fi.width, fi.height, px->x - 0.5, px->y - 0.5);
      if (std::isnan(g)) {
        // Expected only next to a hole of the source: the frame posts around the point (a frame
        // spacing away) each blend the source posts around them, so its 5x5 neighbourhood has a NaN.
        bool complete = true;
        for (int dr = -2; dr <= 2; ++dr)
          for (int dc = -2; dc <= 2; ++dc) complete = complete && !std::isnan(source->at(c + dc, r + dr));
        e.holesWhereSourceIsComplete += complete ? 1u : 0u;
        continue;
      }
      const double d = g - static_cast<double>(h) * toMetres;
      e.max = std::max(e.max, std::abs(d));
      sum += d * d;
      ++e.compared;
    }
  }
  e.rms = e.compared > 0 ? std::sqrt(sum / static_cast<double>(e.compared)) : 0.0;
  return e;
}

constexpr double kArcSecond3 = 1.0 / 1200.0;

/// A Float32 GeoTIFF in EPSG:4326 of n × n posts at 3", top-left post at (lon0, lat0).
DemFileOptions geographicTile(int n, double lon0, double lat0, double step = kArcSecond3) {
  DemFileOptions o;
  o.width = n;
  o.height = n;
  o.geoTransform = {lon0 - 0.5 * step, step, 0.0, lat0 + 0.5 * step, 0.0, -step};
  o.crs = "EPSG:4326";
  return o;
}

TEST(DemSource, GeographicDemGoesIntoTheUtmFrameOfItsCentreAtItsFinestSpacing) {
  // Heights linear in longitude and latitude: 0.3 m of height per metre east, so a post placed
  // 3 cm wrong shows as a 1 cm error.
  const std::string dir = outputDir("linear");
  const std::string path = dir + "/linear.tif";
  DemFileOptions o = geographicTile(241, 6.0, 50.0);
  writeDemFile(path, o, [&](int c, int r) {
    const double lon = 6.0 + c * kArcSecond3, lat = 50.0 - r * kArcSecond3;
    return 500.0 + 21000.0 * (lon - 6.0) + 9000.0 * (lat - 49.9);
  });
  const Opened opened = openInFrame(specOf({path}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  EXPECT_EQ(opened.frame->epsg(), 32632) << "6.1°E 49.9°N is in UTM zone 32N";
  EXPECT_TRUE(opened.dem->resampled());
  // 3" of longitude at 49.9°N is 59.8 m, of latitude 92.6 m: the finer one.
  EXPECT_NEAR(opened.dem->spacing(), 59.8, 0.3);
  EXPECT_NE(find(opened.diagnostics, Severity::Info, "resampled"), nullptr) << allMessages(opened.diagnostics);
  const ErrorFigures e = compareAtSourcePosts(opened, path);
  std::printf("linear field (0.3 m/m): %zu source posts, max %.4f m, RMS %.4f m\n", e.compared, e.max, e.rms);
  EXPECT_GT(e.compared, 230u * 230u);
  EXPECT_LT(e.max, 0.01);
  EXPECT_EQ(e.holesWhereSourceIsComplete, 0u);
  // Posts outside the source's rectangle (the tile is a trapezoid in UTM) are holes, the others
  // are heights.
  const geo::RasterInfo& fi = opened.dem->info();
  Result<geo::CrsTransform> toLonLat = opened.frame->transformTo("EPSG:4326");
  ASSERT_TRUE(toLonLat.ok());
  std::size_t inside = 0, outside = 0;
  for (int r = 0; r < fi.height; r += 3) {
    for (int c = 0; c < fi.width; c += 3) {
      const glm::dvec2 ll = *toLonLat->transform(fi.pixelCentre(c, r));
      const double u = (ll.x - 6.0) / kArcSecond3, v = (50.0 - ll.y) / kArcSecond3;
      const float h =
          opened
              .heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(fi.width) + static_cast<std::size_t>(c)];
      if (u > 1e-3 && v > 1e-3 && u < 240 - 1e-3 && v < 240 - 1e-3) {
        ++inside;
        EXPECT_FALSE(std::isnan(h)) << c << " " << r;
      } else if (u < -1e-3 || v < -1e-3 || u > 240 + 1e-3 || v > 240 + 1e-3) {
        ++outside;
        EXPECT_TRUE(std::isnan(h)) << c << " " << r;
      }
    }
  }
  EXPECT_GT(inside, 1000u);
  EXPECT_GT(outside, 10u);
}

TEST(DemSource, NodataIsNeverBlendedIntoAHeight) {
  // Rough relief with a void and a nodata border: a post is a height exactly when the four
  // source posts around it are.
  const std::string dir = outputDir("holes");
  const std::string path = dir + "/holes.tif";
  DemFileOptions o = geographicTile(161, -43.2, -22.9);
  o.nodata = -32768.0;
  writeDemFile(path, o, [&](int c, int r) {
    if ((c - 80) * (c - 80) + (r - 70) * (r - 70) < 15 * 15) return -32768.0;
    if (c + r < 20) return -32768.0;
    return 300.0 + 200.0 * std::sin(c * 0.37) * std::cos(r * 0.23) + 40.0 * ((c * 7 + r * 13) % 5);
  });
  const Opened opened = openInFrame(specOf({path}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  EXPECT_EQ(opened.frame->epsg(), 32723) << "43.1°W 23°S is in UTM zone 23S";
  Result<geo::Raster> source = geo::readRaster(path);
  ASSERT_TRUE(source.ok());
  Result<geo::CrsTransform> toSource = opened.frame->transformTo(source->info.crsWkt);
  ASSERT_TRUE(toSource.ok());
  const geo::RasterInfo& fi = opened.dem->info();
  std::size_t heights = 0, holes = 0;
  for (int r = 0; r < fi.height; ++r) {
    for (int c = 0; c < fi.width; ++c) {
      const glm::dvec2 p = *toSource->transform(fi.pixelCentre(c, r));
      const glm::dvec2 uv = *source->info.geoTransform.crsToPixel(p) - glm::dvec2(0.5);
      const double expected = bilinearAt(source->samples, source->info.width, source->info.height, uv.x, uv.y);
      const float h =
          opened
              .heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(fi.width) + static_cast<std::size_t>(c)];
      // Away from the hole's edge by a thousandth of a post, where rounding decides.
      const double fu = uv.x - std::floor(uv.x), fv = uv.y - std::floor(uv.y);
      if (std::min({fu, 1.0 - fu, fv, 1.0 - fv}) < 1e-3) continue;
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(h)) << "a hole blended into a height at post " << c << ", " << r;
        ++holes;
      } else {
        ASSERT_FALSE(std::isnan(h)) << "a height lost at post " << c << ", " << r;
        // The source position of a frame post is interpolated between exact ones 8 posts apart:
        // off by at most 1e-4 of a source post (a few millimetres), i.e. by 1e-4 of the height
        // range of the four posts around it.
        const int c0 = static_cast<int>(std::floor(uv.x)), r0 = static_cast<int>(std::floor(uv.y));
        double lo4 = 1e30, hi4 = -1e30;
        for (int dr = 0; dr <= 1; ++dr) {
          for (int dc = 0; dc <= 1; ++dc) {
            lo4 = std::min(lo4, static_cast<double>(source->at(std::min(c0 + dc, source->info.width - 1),
                                                               std::min(r0 + dr, source->info.height - 1))));
            hi4 = std::max(hi4, static_cast<double>(source->at(std::min(c0 + dc, source->info.width - 1),
                                                               std::min(r0 + dr, source->info.height - 1))));
          }
        }
        EXPECT_NEAR(h, expected, 1e-3 + 1e-6 * std::abs(expected) + 1e-4 * (hi4 - lo4)) << c << ", " << r;
        ++heights;
      }
    }
  }
  EXPECT_GT(heights, 10000u);
  EXPECT_GT(holes, 1000u);
  const ErrorFigures e = compareAtSourcePosts(opened, path);
  std::printf("rough relief with holes: %zu source posts, max %.2f m, RMS %.2f m\n", e.compared, e.max, e.rms);
  EXPECT_EQ(e.holesWhereSourceIsComplete, 0u);
}

TEST(DemSource, ResamplingErrorOfTheStiffSyntheticRelief) {
  // The figures of docs/terrain.md: terrain_synth's relief (cliffs, spikes, plains, holes) as a
  // geographic DEM of 3" posts, against itself at its own posts.
  const std::string path = outputDir("synth") + "/synth.tif";
  ASSERT_TRUE(synth::writeSyntheticDem(path, synth::geographicDemOptions(257, 5)).ok());
  const Opened opened = openInFrame(specOf({path}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  const ErrorFigures e = compareAtSourcePosts(opened, path);
  std::printf(
      "terrain_synth --crs EPSG:4326 (3\" posts, %.1f m frame posts): %zu source posts, max %.2f m, RMS "
      "%.2f m\n",
      opened.dem->spacing(), e.compared, e.max, e.rms);
  EXPECT_GT(e.compared, 200u * 200u);
  EXPECT_EQ(e.holesWhereSourceIsComplete, 0u);
  // Bilinear of bilinear: bounded by the largest height step between neighbouring posts (the
  // cliffs and spikes), and far below it on average.
  Result<geo::Raster> source = geo::readRaster(path);
  ASSERT_TRUE(source.ok());
  double step = 0.0;
  for (int r = 0; r + 1 < source->info.height; ++r) {
    for (int c = 0; c + 1 < source->info.width; ++c) {
      const double h = source->at(c, r), a = source->at(c + 1, r), b = source->at(c, r + 1);
      if (!std::isnan(h) && !std::isnan(a)) step = std::max(step, std::abs(a - h));
      if (!std::isnan(h) && !std::isnan(b)) step = std::max(step, std::abs(b - h));
    }
  }
  EXPECT_LE(e.max, step);
  EXPECT_LT(e.rms, 0.05 * step);

  // Real relief: Olinda's SRTM heights (the sample DEM, 90 m in UTM 25S) back at SRTM's own
  // 3" in longitude/latitude (nearest post: heights unchanged), then resampled into the frame.
  const std::string olinda = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/olinda_dem_utm25s.tif";
  const std::string lonLat = outputDir("olinda") + "/olinda_lonlat.tif";
  const std::string command =
      "gdalwarp -q -overwrite -t_srs EPSG:4326 -tr 0.000833333333333 0.000833333333333 -r near " + olinda + " " +
      lonLat;
  ASSERT_EQ(std::system(command.c_str()), 0);
  const Opened real = openInFrame(specOf({lonLat}));
  ASSERT_TRUE(real.dem.has_value()) << allMessages(real.diagnostics);
  EXPECT_EQ(real.frame->epsg(), 32725);
  const ErrorFigures o = compareAtSourcePosts(real, lonLat);
  std::printf("Olinda SRTM relief at 3\" (%.1f m frame posts): %zu source posts, max %.2f m, RMS %.2f m\n",
              real.dem->spacing(), o.compared, o.max, o.rms);
  EXPECT_GT(o.compared, 10000u);
  EXPECT_EQ(o.holesWhereSourceIsComplete, 0u);
  // SRTM's post-to-post roughness: bilinear of bilinear smooths it by a few metres.
  EXPECT_LT(o.rms, 3.0);
  // Finer frame posts (terrain.resolution_m) follow the source more closely.
  double previous = o.rms;
  for (const double fraction : {0.5, 0.25}) {
    DemSpec finer = specOf({lonLat});
    finer.resolutionMetres = real.dem->spacing() * fraction;
    const Opened f = openInFrame(finer);
    ASSERT_TRUE(f.dem.has_value());
    const ErrorFigures e2 = compareAtSourcePosts(f, lonLat);
    std::printf("  at %.1f m frame posts: max %.2f m, RMS %.2f m\n", f.dem->spacing(), e2.max, e2.rms);
    EXPECT_LT(e2.rms, previous);
    previous = e2.rms;
  }
}

TEST(DemSource, ProjectedDemInAnotherCrsIsResampledIntoTheFrame) {
  // A UTM 33N DEM near the zone edge, read into a UTM 32N frame.
  const std::string dir = outputDir("utm33");
  const std::string path = dir + "/utm33.tif";
  DemFileOptions o;
  o.width = o.height = 101;
  o.geoTransform = {290000.0, 30.0, 0.0, 5550000.0, 0.0, -30.0};
  o.crs = "EPSG:32633";
  writeDemFile(path, o, [](int c, int r) { return 100.0 + 3.0 * c + 2.0 * r; });
  Result<geo::SceneFrame> frame = geo::SceneFrame::fromCrs("EPSG:32632", glm::dvec3(720000.0, 5545000.0, 0.0));
  ASSERT_TRUE(frame.ok());
  const Opened opened = openInFrame(specOf({path}), &*frame);
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  EXPECT_TRUE(opened.dem->resampled());
  EXPECT_NEAR(opened.dem->spacing(), 30.0, 0.5);
  const ErrorFigures e = compareAtSourcePosts(opened, path);
  std::printf("UTM 33N into 32N (linear, 0.1 m/m): max %.4f m, RMS %.4f m\n", e.max, e.rms);
  EXPECT_GT(e.compared, 95u * 95u);
  EXPECT_LT(e.max, 0.005);
  // Its own frame reads it as it is.
  const Opened own = openInFrame(specOf({path}));
  ASSERT_TRUE(own.dem.has_value());
  EXPECT_FALSE(own.dem->resampled());
  Result<geo::Raster> source = geo::readRaster(path);
  ASSERT_TRUE(source.ok());
  EXPECT_EQ(own.heights, source->samples);
}

TEST(DemSource, HeightUnitsScaleAndOffsetBecomeMetres) {
  const std::string dir = outputDir("units");
  DemFileOptions o;
  o.width = o.height = 33;
  o.geoTransform = {290000.0, 10.0, 0.0, 9120000.0, 0.0, -10.0};
  o.crs = "EPSG:32725";
  auto value = [](int c, int r) { return 1000.0 + c + 10.0 * r; };
  struct Case {
    std::string name, unit, override;
    std::optional<double> scale, offset;
    double metresPer;  // of the stored value
    double offsetMetres;
  };
  const std::vector<Case> cases = {
      {"feet", "ft", "", std::nullopt, std::nullopt, 0.3048, 0.0},
      {"us-feet", "US survey foot", "", std::nullopt, std::nullopt, 1200.0 / 3937.0, 0.0},
      {"scaled", "m", "", 0.1, -50.0, 0.1, -50.0},
      {"scaled-feet", "ft", "", 0.5, 10.0, 0.5 * 0.3048, 10.0 * 0.3048},
      {"override", "", "ft", std::nullopt, std::nullopt, 0.3048, 0.0},
  };
  for (const Case& k : cases) {
    const std::string path = dir + "/" + k.name + ".tif";
    DemFileOptions ok = o;
    ok.unit = k.unit;
    ok.scale = k.scale;
    ok.offset = k.offset;
    writeDemFile(path, ok, value);
    DemSpec spec = specOf({path});
    spec.heightUnit = k.override;
    const Opened opened = openInFrame(spec);
    ASSERT_TRUE(opened.dem.has_value()) << k.name << allMessages(opened.diagnostics);
    EXPECT_FALSE(opened.dem->resampled());
    for (int r = 0; r < 33; r += 8) {
      for (int c = 0; c < 33; c += 8) {
        EXPECT_NEAR(opened.heights[static_cast<std::size_t>(r * 33 + c)], value(c, r) * k.metresPer + k.offsetMetres,
                    1e-3)
            << k.name;
      }
    }
  }
  // A unit nobody knows is said, and taken as metres.
  const std::string path = dir + "/cubits.tif";
  DemFileOptions odd = o;
  odd.unit = "cubit";
  writeDemFile(path, odd, value);
  const Opened opened = openInFrame(specOf({path}));
  ASSERT_TRUE(opened.dem.has_value());
  EXPECT_NE(find(opened.diagnostics, Severity::Warning, "unknown height unit 'cubit'"), nullptr);
  EXPECT_FLOAT_EQ(opened.heights[0], 1000.0F);
  EXPECT_DOUBLE_EQ(geo::metresPerHeightUnit("ftUS"), 1200.0 / 3937.0);
  EXPECT_DOUBLE_EQ(geo::metresPerHeightUnit("metre"), 1.0);
  EXPECT_EQ(geo::metresPerHeightUnit("furlong"), 0.0);
}

/// The field of the SRTM tests: smooth, continuous across tiles, metres.
double srtmField(double lon, double lat) {
  return 400.0 + 900.0 * (lon - 6.0) + 600.0 * (lat - 49.0) + 120.0 * std::sin(9.0 * lon) * std::cos(7.0 * lat);
}

TEST(DemSource, SrtmMosaicOfFourHgtTilesWithVoidsHasNoSeam) {
  const std::string dir = outputDir("srtm");
  const std::string tiles = dir + "/tiles";
  fs::create_directories(tiles);
  // Voids: a disc in one tile and a strip crossing the seam of two others.
  auto field = [](double lon, double lat) {
    if ((lon - 6.3) * (lon - 6.3) + (lat - 50.6) * (lat - 50.6) < 0.05 * 0.05) return std::nan("");
    if (lon > 7.2 && lon < 7.25 && lat > 49.8 && lat < 50.2) return std::nan("");
    return srtmField(lon, lat);
  };
  for (int lat : {49, 50})
    for (int lon : {6, 7}) writeHgtTile(tiles, lon, lat, 1201, field);
  const Opened opened = openInFrame(specOf({tiles}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  Result<DemSource> source = DemSource::open(specOf({tiles}));
  ASSERT_TRUE(source.ok());
  EXPECT_EQ(source->files().size(), 4u);
  EXPECT_EQ(source->groups().size(), 1u) << "one mosaic of four tiles";
  EXPECT_EQ(source->groups().front().width, 2401);
  EXPECT_EQ(opened.frame->epsg(), 32632);
  const geo::RasterInfo& fi = opened.dem->info();
  Result<geo::CrsTransform> toLonLat = opened.frame->transformTo("EPSG:4326");
  ASSERT_TRUE(toLonLat.ok());
  // Every post within the mosaic and off the voids is a height, on the seams too (a crack would
  // be a line of holes), and matches the field within the whole-metre rounding of .hgt.
  std::size_t checked = 0, seam = 0, voids = 0;
  double worst = 0.0;
  std::mt19937 rng(20);
  std::uniform_int_distribution<int> col(0, fi.width - 1), row(0, fi.height - 1);
  auto check = [&](int c, int r) {
    const glm::dvec2 ll = *toLonLat->transform(fi.pixelCentre(c, r));
    if (ll.x < 6.001 || ll.x > 7.999 || ll.y < 49.001 || ll.y > 50.999) return;
    const float h =
        opened.heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(fi.width) + static_cast<std::size_t>(c)];
    // A void reaches one post (3") beyond its edge.
    bool nearVoid = false;
    for (double dx : {-0.0009, 0.0, 0.0009})
      for (double dy : {-0.0009, 0.0, 0.0009}) nearVoid = nearVoid || std::isnan(field(ll.x + dx, ll.y + dy));
    if (nearVoid) {
      if (std::isnan(field(ll.x, ll.y))) {
        EXPECT_TRUE(std::isnan(h)) << "void filled at " << ll.x << ", " << ll.y;
        ++voids;
      }
      return;
    }
    ASSERT_FALSE(std::isnan(h)) << "a hole at " << ll.x << ", " << ll.y;
    worst = std::max(worst, std::abs(h - srtmField(ll.x, ll.y)));
    ++checked;
    seam += std::abs(ll.x - 7.0) < 0.002 || std::abs(ll.y - 50.0) < 0.002 ? 1u : 0u;
  };
  for (int k = 0; k < 200000; ++k) check(col(rng), row(rng));
  // Along both seams, every post through the corner where the four tiles meet.
  const std::optional<glm::dvec3> seamPoint = opened.frame->fromLonLat(7.0, 50.0, 0.0);
  ASSERT_TRUE(seamPoint.has_value());
  const glm::dvec2 centre =
      *fi.geoTransform.crsToPixel(glm::dvec2(opened.frame->frameToProjected(*seamPoint))) - glm::dvec2(0.5);
  for (int d = -900; d <= 900; ++d) {
    const int cc = static_cast<int>(centre.x), rr = static_cast<int>(centre.y);
    if (rr + d >= 0 && rr + d < fi.height) check(cc, rr + d);
    if (cc + d >= 0 && cc + d < fi.width) check(cc + d, rr);
  }
  std::printf("SRTM 2x2 mosaic: %zu posts checked (%zu on seams, %zu in voids), worst %.2f m against the field\n",
              checked, seam, voids, worst);
  EXPECT_GT(checked, 100000u);
  EXPECT_GT(seam, 100u);
  EXPECT_GT(voids, 50u);
  // Rounding to whole metres (0.5 m) plus bilinear over 3" of a smooth field.
  EXPECT_LT(worst, 2.0);

  // A list of the tiles and a VRT of them give the same grid.
  std::vector<std::string> list;
  for (const auto& entry : fs::directory_iterator(tiles)) list.push_back(entry.path().string());
  std::sort(list.begin(), list.end());
  const Opened listed = openInFrame(specOf(list));
  ASSERT_TRUE(listed.dem.has_value());
  EXPECT_EQ(listed.heights.size(), opened.heights.size());
  EXPECT_TRUE(std::equal(listed.heights.begin(), listed.heights.end(), opened.heights.begin(),
                         [](float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); }));
  const std::string vrt = dir + "/mosaic.vrt";
  const std::string command = "gdalbuildvrt -q " + vrt + " " + tiles + "/*.hgt";
  ASSERT_EQ(std::system(command.c_str()), 0);
  const Opened fromVrt = openInFrame(specOf({vrt}));
  ASSERT_TRUE(fromVrt.dem.has_value()) << allMessages(fromVrt.diagnostics);
  EXPECT_TRUE(std::equal(fromVrt.heights.begin(), fromVrt.heights.end(), opened.heights.begin(),
                         [](float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); }));
}

TEST(DemSource, OneAndThreeArcSecondHgtTilesMeetWithoutAGap) {
  // SRTM 1" (3601²) beside SRTM 3" (1201²): two groups, the frame at the 1" spacing.
  const std::string dir = outputDir("srtm-1-3");
  writeHgtTile(dir, 6, 49, 3601, srtmField);
  writeHgtTile(dir, 7, 49, 1201, srtmField);
  const Opened opened = openInFrame(specOf({dir}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  Result<DemSource> source = DemSource::open(specOf({dir}));
  ASSERT_TRUE(source.ok());
  ASSERT_EQ(source->groups().size(), 2u);
  EXPECT_EQ(source->groups().front().width, 3601);
  EXPECT_NEAR(opened.dem->spacing(), 20.1, 0.2) << "1\" of longitude at 49.5°N";
  const geo::RasterInfo& fi = opened.dem->info();
  Result<geo::CrsTransform> toLonLat = opened.frame->transformTo("EPSG:4326");
  ASSERT_TRUE(toLonLat.ok());
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> col(0, fi.width - 1), row(0, fi.height - 1);
  std::size_t checked = 0, seam = 0;
  double worst = 0.0;
  auto check = [&](int c, int r) {
    const glm::dvec2 ll = *toLonLat->transform(fi.pixelCentre(c, r));
    if (ll.x < 6.001 || ll.x > 7.999 || ll.y < 49.001 || ll.y > 49.999) return;
    const float h =
        opened.heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(fi.width) + static_cast<std::size_t>(c)];
    ASSERT_FALSE(std::isnan(h)) << "a hole at " << ll.x << ", " << ll.y;
    worst = std::max(worst, std::abs(h - srtmField(ll.x, ll.y)));
    ++checked;
    seam += std::abs(ll.x - 7.0) < 0.001 ? 1u : 0u;
  };
  for (int k = 0; k < 100000; ++k) check(col(rng), row(rng));
  // Every post of a row across the seam at 7°E.
  const glm::dvec3 onSeam = *opened.frame->fromLonLat(7.0, 49.5, 0.0);
  const glm::dvec2 at = *fi.geoTransform.crsToPixel(glm::dvec2(opened.frame->frameToProjected(onSeam)));
  for (int d = -200; d <= 200; ++d) check(static_cast<int>(at.x) + d, static_cast<int>(at.y));
  std::printf("1\" + 3\" .hgt: %d x %d frame posts, %zu checked (%zu at the seam), worst %.2f m\n", fi.width, fi.height,
              checked, seam, worst);
  EXPECT_GT(checked, 30000u);
  EXPECT_GT(seam, 5u);
  EXPECT_LT(worst, 2.0);
}

TEST(DemSource, TilesOfOtherCrssAndResolutionsMeetWithoutAGap) {
  // West: 0.1° of 3" posts in EPSG:4326. East: the next 0.1° at 1" posts. North of both: a UTM
  // 32N tile at 25 m. The field is continuous; the frame grid must be too.
  const std::string dir = outputDir("mixed");
  auto field = [](double lon, double lat) { return srtmField(lon, lat); };
  DemFileOptions west = geographicTile(121, 6.0, 50.0);
  writeDemFile(dir + "/west.tif", west,
               [&](int c, int r) { return field(6.0 + c * kArcSecond3, 50.0 - r * kArcSecond3); });
  const double s1 = 1.0 / 3600.0;
  DemFileOptions east = geographicTile(361, 6.1, 50.0, s1);
  writeDemFile(dir + "/east.tif", east, [&](int c, int r) { return field(6.1 + c * s1, 50.0 - r * s1); });
  Result<geo::SceneFrame> utm = geo::SceneFrame::fromCrs("EPSG:32632", glm::dvec3(0.0));
  ASSERT_TRUE(utm.ok());
  const glm::dvec3 nw = *utm->fromLonLat(6.0, 50.1, 0.0);
  DemFileOptions north;
  north.width = 600;
  north.height = 200;
  north.crs = "EPSG:32632";
  const double x0 = std::floor(nw.x / 25.0) * 25.0, y0 = std::ceil(nw.y / 25.0) * 25.0;
  north.geoTransform = {x0 - 12.5, 25.0, 0.0, y0 + 12.5, 0.0, -25.0};
  Result<geo::CrsTransform> utmToLonLat = utm->transformTo("EPSG:4326");
  ASSERT_TRUE(utmToLonLat.ok());
  writeDemFile(dir + "/north.tif", north, [&](int c, int r) {
    const glm::dvec2 ll = *utmToLonLat->transform(glm::dvec2(x0 + 25.0 * c, y0 - 25.0 * r));
    return field(ll.x, ll.y);
  });
  const Opened opened = openInFrame(specOf({dir}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  Result<DemSource> source = DemSource::open(specOf({dir}));
  ASSERT_TRUE(source.ok());
  EXPECT_EQ(source->groups().size(), 3u);
  EXPECT_NEAR(opened.dem->spacing(), 59.8 / 3.0, 0.2) << "the finest tile's spacing";
  const geo::RasterInfo& fi = opened.dem->info();
  Result<geo::CrsTransform> toLonLat = opened.frame->transformTo("EPSG:4326");
  ASSERT_TRUE(toLonLat.ok());
  std::size_t checked = 0;
  double worst = 0.0;
  for (int r = 0; r < fi.height; r += 2) {
    for (int c = 0; c < fi.width; c += 2) {
      const glm::dvec2 ll = *toLonLat->transform(fi.pixelCentre(c, r));
      // Inside the two geographic tiles (the UTM tile overlaps their north edge).
      if (ll.x < 6.001 || ll.x > 6.199 || ll.y < 49.901 || ll.y > 49.999) continue;
      const float h =
          opened
              .heights[static_cast<std::size_t>(r) * static_cast<std::size_t>(fi.width) + static_cast<std::size_t>(c)];
      ASSERT_FALSE(std::isnan(h)) << "a gap at " << ll.x << ", " << ll.y;
      worst = std::max(worst, std::abs(h - field(ll.x, ll.y)));
      ++checked;
    }
  }
  EXPECT_GT(checked, 10000u);
  EXPECT_LT(worst, 1.0);
  std::printf("3\" + 1\" + UTM tiles: %zu posts, worst %.3f m against the field\n", checked, worst);
}

TEST(DemSource, AnUnreadableTileIsNamedAndTheRestLoads) {
  const std::string dir = outputDir("broken-tile");
  writeHgtTile(dir, 6, 49, 1201, srtmField);
  writeHgtTile(dir, 7, 49, 1201, srtmField);
  const std::string broken = dir + "/" + hgtName(6, 50);
  std::ofstream(broken) << "not elevation data";
  std::ofstream(dir + "/README.txt") << "tiles from somewhere";
  const Opened opened = openInFrame(specOf({dir}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  const Diagnostic* named = find(opened.diagnostics, Severity::Warning, "left out of the DEM");
  ASSERT_NE(named, nullptr) << allMessages(opened.diagnostics);
  EXPECT_EQ(named->file, broken);
  EXPECT_EQ(find(opened.diagnostics, Severity::Warning, "README"), nullptr) << "a text file is no tile";
  // A tile without the band asked for is named too.
  Result<DemSource> band2 = DemSource::open(specOf({dir + "/" + hgtName(6, 49), dir + "/" + hgtName(7, 49)}, 2));
  EXPECT_FALSE(band2.ok());
  EXPECT_NE(find(band2.diagnostics, Severity::Error, "band 2 does not exist"), nullptr);
}

TEST(DemSource, BadInputFailsNamingTheFile) {
  const std::string dir = outputDir("bad");
  // No CRS: an error naming the file and the scene key that fixes it; with the key it loads.
  const std::string noCrs = dir + "/no_crs.tif";
  DemFileOptions o = geographicTile(33, 6.0, 50.0);
  o.crs.clear();
  writeDemFile(noCrs, o, [](int c, int r) { return 100.0 + c + r; });
  Result<DemSource> none = DemSource::open(specOf({noCrs}));
  ASSERT_FALSE(none.ok());
  const Diagnostic* error = find(none.diagnostics, Severity::Error, "no CRS");
  ASSERT_NE(error, nullptr) << allMessages(none.diagnostics);
  EXPECT_EQ(error->file, noCrs);
  EXPECT_NE(error->message.find("terrain.crs"), std::string::npos);
  DemSpec withCrs = specOf({noCrs});
  withCrs.crs = "EPSG:4326";
  const Opened given = openInFrame(withCrs);
  ASSERT_TRUE(given.dem.has_value()) << allMessages(given.diagnostics);
  EXPECT_EQ(given.frame->epsg(), 32632);
  // An empty folder, a folder of text, a file that does not exist, a CRS nobody knows.
  fs::create_directories(dir + "/empty");
  Result<DemSource> empty = DemSource::open(specOf({dir + "/empty"}));
  ASSERT_FALSE(empty.ok());
  ASSERT_NE(find(empty.diagnostics, Severity::Error, "holds no raster"), nullptr);
  EXPECT_EQ(find(empty.diagnostics, Severity::Error, "holds no raster")->file, dir + "/empty");
  fs::create_directories(dir + "/text");
  std::ofstream(dir + "/text/notes.txt") << "hello";
  EXPECT_FALSE(DemSource::open(specOf({dir + "/text"})).ok());
  Result<DemSource> missing = DemSource::open(specOf({dir + "/missing.tif"}));
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.diagnostics.items().front().file, dir + "/missing.tif");
  DemSpec badCrs = specOf({noCrs});
  badCrs.crs = "EPSG:999999";
  EXPECT_NE(find(DemSource::open(badCrs).diagnostics, Severity::Error, "terrain.crs"), nullptr);
  // A continent is more than one projected frame holds: said, not drawn distorted.
  const std::string continent = dir + "/continent.tif";
  DemFileOptions wide = geographicTile(61, -10.0, 60.0, 1.0);
  writeDemFile(continent, wide, [](int c, int r) { return 10.0 * (c + r); });
  const Opened tooWide = openInFrame(specOf({continent}));
  EXPECT_FALSE(tooWide.dem.has_value());
  EXPECT_NE(find(tooWide.diagnostics, Severity::Error, "more than one projected frame holds"), nullptr)
      << allMessages(tooWide.diagnostics);
  DemSpec badUnit = specOf({noCrs});
  badUnit.heightUnit = "cubit";
  EXPECT_FALSE(DemSource::open(badUnit).ok());
}

TEST(DemSource, FlatGroundCoversALonLatBox) {
  const std::string dir = outputDir("flat");
  Result<std::string> flat = geo::writeFlatDem("/vsimem/test/flat.tif", {-35.0, -8.1, -34.8, -7.9});
  ASSERT_TRUE(flat.ok()) << allMessages(flat.diagnostics);
  const Opened opened = openInFrame(specOf({*flat}));
  ASSERT_TRUE(opened.dem.has_value()) << allMessages(opened.diagnostics);
  EXPECT_EQ(opened.frame->epsg(), 32725);
  EXPECT_FALSE(opened.dem->resampled());
  for (float h : opened.heights) ASSERT_EQ(h, 0.0F);
  Result<geo::CrsTransform> toLonLat = opened.frame->transformTo("EPSG:4326");
  const geo::RasterInfo& fi = opened.dem->info();
  const glm::dvec2 nw = *toLonLat->transform(fi.pixelCentre(0, 0));
  const glm::dvec2 se = *toLonLat->transform(fi.pixelCentre(fi.width - 1, fi.height - 1));
  EXPECT_LT(nw.x, -35.0);
  EXPECT_GT(nw.y, -7.9);
  EXPECT_GT(se.x, -34.8);
  EXPECT_LT(se.y, -8.1);
  EXPECT_FALSE(geo::writeFlatDem("/vsimem/test/bad.tif", {1.0, 2.0, 0.0, 1.0}).ok());
}

}  // namespace
}  // namespace gis::test
