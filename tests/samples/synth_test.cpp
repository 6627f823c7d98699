// The synthetic terrain generator (samples/synth): determinism, the GeoTIFF it writes (read back
// through gis::geo::readRaster), every stiff case where the summary says it is, and the program
// terrain_synth (arguments, exit status, scene file).
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <nlohmann/json.hpp>

#include "geo/raster.hpp"
#include "synth/synthetic_dem.hpp"
#include "synth/synthetic_vectors.hpp"
#include "test_paths.hpp"

namespace {

namespace fs = std::filesystem;
using gis::geo::Raster;
using gis::synth::SyntheticDemOptions;
using gis::synth::SyntheticDemSummary;

fs::path outputDir() {
  const fs::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  fs::create_directories(dir);
  return dir;
}

std::string outputPath(const std::string& name) { return (outputDir() / name).string(); }

/// A DEM as written (summary) and as read back.
struct Dem {
  SyntheticDemSummary summary;
  Raster raster;

  [[nodiscard]] int size() const { return raster.info.width; }
  [[nodiscard]] float at(int col, int row) const { return raster.at(col, row); }
  [[nodiscard]] bool valid(int col, int row) const { return !std::isnan(at(col, row)); }
};

Dem generate(const std::string& name, const SyntheticDemOptions& options) {
  const std::string path = outputPath(name);
  gis::Result<SyntheticDemSummary> written = gis::synth::writeSyntheticDem(path, options);
  for (const gis::Diagnostic& d : written.diagnostics.items()) ADD_FAILURE() << d.toString();
  if (!written) throw std::runtime_error("cannot write " + path);
  gis::Result<Raster> read = gis::geo::readRaster(path);
  for (const gis::Diagnostic& d : read.diagnostics.items()) ADD_FAILURE() << d.toString();
  if (!read) throw std::runtime_error("cannot read " + path);
  return {*written, *read};
}

SyntheticDemOptions options(int size, std::uint64_t seed) {
  SyntheticDemOptions o;
  o.size = size;
  o.seed = seed;
  return o;
}

std::vector<std::uint32_t> bits(const Raster& r) {
  std::vector<std::uint32_t> out;
  out.reserve(r.samples.size());
  for (const float f : r.samples) out.push_back(std::bit_cast<std::uint32_t>(f));
  return out;
}

// ---- determinism and the file ----

TEST(Synth, SameSeedGivesIdenticalSamples) {
  const Dem a = generate("same_a.tif", options(257, 42));
  const Dem b = generate("same_b.tif", options(257, 42));
  EXPECT_EQ(bits(a.raster), bits(b.raster));
  ASSERT_EQ(a.summary.cliffs.size(), b.summary.cliffs.size());
  for (std::size_t i = 0; i < a.summary.cliffs.size(); ++i) {
    EXPECT_EQ(a.summary.cliffs[i].col, b.summary.cliffs[i].col);
    EXPECT_EQ(a.summary.cliffs[i].jumpMetres, b.summary.cliffs[i].jumpMetres);
  }
  ASSERT_EQ(a.summary.spikes.size(), b.summary.spikes.size());
  for (std::size_t i = 0; i < a.summary.spikes.size(); ++i) {
    EXPECT_EQ(a.summary.spikes[i].col, b.summary.spikes[i].col);
    EXPECT_EQ(a.summary.spikes[i].row, b.summary.spikes[i].row);
  }
  EXPECT_EQ(a.summary.minHeight, b.summary.minHeight);
  EXPECT_EQ(a.summary.maxHeight, b.summary.maxHeight);
}

TEST(Synth, DifferentSeedGivesDifferentSamples) {
  const Dem a = generate("seed_1.tif", options(129, 1));
  const Dem b = generate("seed_2.tif", options(129, 2));
  std::size_t different = 0;
  for (std::size_t i = 0; i < a.raster.samples.size(); ++i)
    different += std::bit_cast<std::uint32_t>(a.raster.samples[i]) != std::bit_cast<std::uint32_t>(b.raster.samples[i]);
  EXPECT_GT(different, a.raster.samples.size() * 9 / 10);
  EXPECT_NE(a.summary.spikes.front().col * 1000 + a.summary.spikes.front().row,
            b.summary.spikes.front().col * 1000 + b.summary.spikes.front().row);
}

TEST(Synth, SizeGeoTransformNodataAndCrsRoundTrip) {
  SyntheticDemOptions o = options(257, 7);
  o.spacing = 30.0;
  o.originX = 300000.0;
  o.originY = 4100000.0;
  const Dem dem = generate("roundtrip.tif", o);
  const gis::geo::RasterInfo& info = dem.raster.info;
  EXPECT_EQ(info.width, 257);
  EXPECT_EQ(info.height, 257);
  EXPECT_EQ(info.bandCount, 1);
  const std::array<double, 6> gt{300000.0, 30.0, 0.0, 4100000.0, 0.0, -30.0};
  EXPECT_EQ(info.geoTransform.c, gt);
  EXPECT_EQ(dem.summary.geoTransform, gt);
  ASSERT_TRUE(info.nodata.has_value());
  EXPECT_EQ(*info.nodata, -32768.0);
  EXPECT_TRUE(info.crsIsProjected);
  EXPECT_NE(info.crsWkt.find("32633"), std::string::npos);

  // Nodata reads back as NaN: as many as the summary counts, and never -32768 itself.
  std::size_t nan = 0;
  for (const float f : dem.raster.samples) {
    nan += std::isnan(f) ? 1U : 0U;
    EXPECT_NE(f, -32768.0F);
  }
  EXPECT_GT(nan, 0U);
  EXPECT_EQ(nan, dem.summary.nodataPosts);
  EXPECT_EQ(dem.summary.validPosts + dem.summary.nodataPosts, 257U * 257U);

  // Post (col, row) is the pixel centre.
  const auto p = dem.summary.postToCrs(0, 0);
  EXPECT_EQ(p[0], info.pixelCentre(0, 0).x);
  EXPECT_EQ(p[1], info.pixelCentre(0, 0).y);
}

TEST(Synth, FileIsTiledDeflateFloat32) {
  const std::string path = outputPath("layout.tif");
  ASSERT_TRUE(gis::synth::writeSyntheticDem(path, options(300, 3)).ok());
  GDALAllRegister();
  GDALDataset* ds = GDALDataset::FromHandle(GDALOpen(path.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  GDALRasterBand* band = ds->GetRasterBand(1);
  EXPECT_EQ(band->GetRasterDataType(), GDT_Float32);
  int bx = 0, by = 0;
  band->GetBlockSize(&bx, &by);
  EXPECT_EQ(bx, 256);
  EXPECT_EQ(by, 256);
  const char* compression = ds->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  ASSERT_NE(compression, nullptr);
  EXPECT_STREQ(compression, "DEFLATE");
  const char* predictor = ds->GetMetadataItem("PREDICTOR", "IMAGE_STRUCTURE");
  ASSERT_NE(predictor, nullptr);
  EXPECT_STREQ(predictor, "3");
  GDALClose(GDALDataset::ToHandle(ds));
}

TEST(Synth, FileMatchesPerPostEvaluationAcrossBlocks) {
  // 300 rows: one full block of 256 rows and a partial one; every post is evaluated on its own.
  const SyntheticDemOptions o = options(300, 11);
  const Dem dem = generate("blocks.tif", o);
  gis::Result<gis::synth::SyntheticTerrain> terrain = gis::synth::SyntheticTerrain::create(o);
  ASSERT_TRUE(terrain.ok());
  std::size_t mismatches = 0;
  for (int row = 0; row < 300; ++row) {
    for (int col = 0; col < 300; ++col) {
      const float expected = terrain->heightAt(col, row);
      mismatches += std::bit_cast<std::uint32_t>(expected) != std::bit_cast<std::uint32_t>(dem.at(col, row)) &&
                    !(std::isnan(expected) && std::isnan(dem.at(col, row)));
    }
  }
  EXPECT_EQ(mismatches, 0U);
}

// ---- the stiff cases ----

TEST(Synth, CliffsJumpAtLeast300MetresBetweenNeighbours) {
  for (const int size : {129, 257}) {
    for (const std::uint64_t seed : {1U, 2U, 3U}) {
      const Dem dem = generate("cliffs.tif", options(size, seed));
      const auto& cliffs = dem.summary.cliffs;
      ASSERT_EQ(cliffs.size(), 4U);
      EXPECT_EQ(std::count_if(cliffs.begin(), cliffs.end(), [](const auto& c) { return c.axisAligned; }), 2);
      for (std::size_t k = 0; k < cliffs.size(); ++k) {
        const auto& cliff = cliffs[k];
        EXPECT_GE(cliff.jumpMetres, 300.0);
        std::size_t pairs = 0;
        double smallest = 1e9;
        auto check = [&](int c0, int r0, int c1, int r1) {
          if (cliff.highSide(c0, r0) == cliff.highSide(c1, r1)) return;
          if (!dem.valid(c0, r0) || !dem.valid(c1, r1)) return;
          for (std::size_t other = 0; other < cliffs.size(); ++other) {  // both cliffs at once
            if (other != k && cliffs[other].highSide(c0, r0) != cliffs[other].highSide(c1, r1)) return;
          }
          const bool firstHigh = cliff.highSide(c0, r0);
          const double rise = firstHigh ? dem.at(c0, r0) - dem.at(c1, r1) : dem.at(c1, r1) - dem.at(c0, r0);
          smallest = std::min(smallest, rise);
          ++pairs;
        };
        for (int row = 0; row < size; ++row) {
          for (int col = 0; col < size; ++col) {
            if (col + 1 < size) check(col, row, col + 1, row);
            if (row + 1 < size) check(col, row, col, row + 1);
          }
        }
        EXPECT_GE(pairs, static_cast<std::size_t>(size) / 2) << "cliff " << k << ", seed " << seed;
        EXPECT_GE(smallest, 300.0) << "cliff " << k << ", seed " << seed << ", size " << size;
      }
    }
  }
}

TEST(Synth, SpikesRiseAtLeast500MetresAboveAll8Neighbours) {
  for (const std::uint64_t seed : {1U, 5U, 9U}) {
    const Dem dem = generate("spikes.tif", options(257, seed));
    ASSERT_EQ(dem.summary.spikes.size(), 8U);
    for (const auto& s : dem.summary.spikes) {
      EXPECT_EQ(dem.at(s.col, s.row), s.height);
      float highestNeighbour = -1e9F;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          if (dc == 0 && dr == 0) continue;
          ASSERT_TRUE(dem.valid(s.col + dc, s.row + dr));
          highestNeighbour = std::max(highestNeighbour, dem.at(s.col + dc, s.row + dr));
          EXPECT_GE(dem.at(s.col, s.row) - dem.at(s.col + dc, s.row + dr), 500.0F)
              << "spike at " << s.col << "," << s.row << ", seed " << seed;
        }
      }
      EXPECT_EQ(highestNeighbour, s.neighbourMax);
    }
  }
}

TEST(Synth, PlainsAreExactlyFlat) {
  for (const std::uint64_t seed : {1U, 4U}) {
    const Dem dem = generate("plains.tif", options(257, seed));
    ASSERT_EQ(dem.summary.plains.size(), 3U);
    EXPECT_EQ(dem.summary.plains[2].shape, gis::synth::PlainShape::Rectangle);
    for (const auto& p : dem.summary.plains) {
      std::size_t posts = 0;
      for (int row = 0; row < dem.size(); ++row) {
        for (int col = 0; col < dem.size(); ++col) {
          if (!p.contains(col, row)) continue;
          ++posts;
          ASSERT_EQ(dem.at(col, row), p.height)
              << "plain at " << p.col << "," << p.row << ": post " << col << "," << row;
        }
      }
      EXPECT_GE(posts, 12U);
      EXPECT_EQ(posts, p.posts);
    }
  }
}

TEST(Synth, HolesAreNodata) {
  const Dem dem = generate("holes.tif", options(257, 6));
  const auto& holes = dem.summary.holes;
  ASSERT_EQ(holes.size(), 3U);
  std::size_t holePosts = 0;
  for (const auto& h : holes) {
    EXPECT_GT(h.posts, 0U);
    holePosts += h.posts;
  }
  std::size_t nan = 0;
  for (int row = 0; row < dem.size(); ++row) {
    for (int col = 0; col < dem.size(); ++col) {
      bool within = false, beyond = true;
      for (const auto& h : holes) {
        const double d = std::hypot(col - h.col, row - h.row);
        within = within || d <= h.innerRadius;
        beyond = beyond && d > h.outerRadius;
      }
      if (within) {
        EXPECT_FALSE(dem.valid(col, row)) << col << "," << row;
      }
      if (beyond) {
        EXPECT_TRUE(dem.valid(col, row)) << col << "," << row;
      }
      nan += dem.valid(col, row) ? 0U : 1U;
    }
  }
  EXPECT_EQ(nan, holePosts);
  EXPECT_EQ(nan, dem.summary.nodataPosts);
}

TEST(Synth, NodataBorderLeavesOnlyTheInsideValid) {
  SyntheticDemOptions o = options(257, 8);
  o.nodataBorder = true;
  const Dem dem = generate("border.tif", o);
  const auto& border = dem.summary.border;
  ASSERT_TRUE(border.enabled);
  const int last = dem.size() - 1;
  for (int i = 0; i <= last; ++i) {
    EXPECT_FALSE(dem.valid(i, 0));
    EXPECT_FALSE(dem.valid(i, last));
    EXPECT_FALSE(dem.valid(0, i));
    EXPECT_FALSE(dem.valid(last, i));
  }
  std::size_t nan = 0, insideValid = 0, inside = 0;
  for (int row = 0; row <= last; ++row) {
    for (int col = 0; col <= last; ++col) {
      const double d = std::hypot(col - border.col, row - border.row);
      if (d > border.outerRadius) {
        EXPECT_FALSE(dem.valid(col, row));
      }
      if (d <= border.innerRadius) {
        ++inside;
        insideValid += dem.valid(col, row) ? 1U : 0U;
      }
      nan += dem.valid(col, row) ? 0U : 1U;
    }
  }
  std::size_t holePosts = 0;
  for (const auto& h : dem.summary.holes) holePosts += h.posts;
  EXPECT_EQ(insideValid + holePosts, inside);  // holes lie inside the boundary
  EXPECT_EQ(nan, border.posts + holePosts);
  EXPECT_EQ(nan, dem.summary.nodataPosts);
  // The boundary is irregular: the valid region is not a disc.
  EXPECT_GT(border.outerRadius - border.innerRadius, 10.0);
  EXPECT_FALSE(dem.summary.cliffs.empty());
  EXPECT_FALSE(dem.summary.spikes.empty());
}

TEST(Synth, HeightsStayWithinRealisticRange) {
  struct Case {
    int size;
    double relief;
    std::uint64_t seed;
  };
  for (const Case c : {Case{33, 600.0, 1}, Case{129, 0.0, 2}, Case{129, 3000.0, 3}, Case{257, 600.0, 4},
                       Case{257, 3000.0, 5}, Case{129, 1500.0, 12345678901234567ULL}}) {
    SyntheticDemOptions o = options(c.size, c.seed);
    o.reliefMetres = c.relief;
    const Dem dem = generate("range.tif", o);
    float lo = 1e9F, hi = -1e9F;
    for (const float f : dem.raster.samples) {
      if (std::isnan(f)) continue;
      lo = std::min(lo, f);
      hi = std::max(hi, f);
    }
    EXPECT_GE(lo, -430.0F) << c.size << " " << c.relief;
    EXPECT_LE(hi, 8850.0F) << c.size << " " << c.relief;
    EXPECT_EQ(dem.summary.minHeight, static_cast<double>(lo));
    EXPECT_EQ(dem.summary.maxHeight, static_cast<double>(hi));
  }
}

TEST(Synth, FeaturesCanBeSwitchedOff) {
  SyntheticDemOptions o = options(129, 1);
  o.cliffs = o.spikes = o.plains = o.nodataHoles = false;
  const Dem dem = generate("plain_relief.tif", o);
  EXPECT_TRUE(dem.summary.cliffs.empty());
  EXPECT_TRUE(dem.summary.spikes.empty());
  EXPECT_TRUE(dem.summary.plains.empty());
  EXPECT_TRUE(dem.summary.holes.empty());
  EXPECT_FALSE(dem.summary.border.enabled);
  EXPECT_EQ(dem.summary.nodataPosts, 0U);
  // Only the fractal relief: no neighbour jumps anywhere near a cliff's.
  double steepest = 0.0;
  for (int row = 0; row < 129; ++row) {
    for (int col = 0; col + 1 < 129; ++col) {
      ASSERT_TRUE(dem.valid(col, row));
      steepest = std::max(steepest, static_cast<double>(std::abs(dem.at(col, row) - dem.at(col + 1, row))));
    }
  }
  EXPECT_LT(steepest, 200.0);
  EXPECT_GT(dem.summary.maxHeight - dem.summary.minHeight, 200.0);
}

TEST(Synth, PlacementIsAtFractionsOfTheSize) {
  auto a = gis::synth::SyntheticTerrain::create(options(129, 21));
  auto b = gis::synth::SyntheticTerrain::create(options(1025, 21));
  ASSERT_TRUE(a.ok() && b.ok());
  const auto& ca = a->layout().cliffs;
  const auto& cb = b->layout().cliffs;
  ASSERT_EQ(ca.size(), cb.size());
  for (std::size_t i = 0; i < ca.size(); ++i) {
    EXPECT_NEAR(ca[i].col / 128.0, cb[i].col / 1024.0, 0.01);
    EXPECT_NEAR(ca[i].row / 128.0, cb[i].row / 1024.0, 0.01);
    EXPECT_NEAR(ca[i].normalCol, cb[i].normalCol, 1e-12);
    EXPECT_NEAR(ca[i].normalRow, cb[i].normalRow, 1e-12);
  }
}

TEST(Synth, ProgressRisesFromZeroToOne) {
  std::vector<double> seen;
  ASSERT_TRUE(gis::synth::writeSyntheticDem(outputPath("progress.tif"), options(513, 1), [&seen](double f) {
                seen.push_back(f);
              }).ok());
  ASSERT_GE(seen.size(), 3U);  // start and one per block of 256 rows
  EXPECT_EQ(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
}

TEST(Synth, BadOptionsAreRejectedNamingTheFile) {
  const std::string path = outputPath("never_written.tif");
  fs::remove(path);
  std::vector<SyntheticDemOptions> bad(6, options(129, 1));
  bad[0].size = 32;
  bad[1].spacing = 0.0;
  bad[2].reliefMetres = -1.0;
  bad[3].reliefMetres = std::nan("");
  bad[4].crs = "EPSG:99999999";
  bad[5].originX = std::numeric_limits<double>::infinity();
  for (const SyntheticDemOptions& o : bad) {
    EXPECT_FALSE(gis::synth::checkSyntheticDemOptions(o).empty());
    gis::Result<SyntheticDemSummary> r = gis::synth::writeSyntheticDem(path, o);
    EXPECT_FALSE(r.ok());
    ASSERT_EQ(r.diagnostics.items().size(), 1U);
    EXPECT_EQ(r.diagnostics.items()[0].file, path);
    EXPECT_FALSE(gis::synth::SyntheticTerrain::create(o).ok());
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST(Synth, UnwritablePathIsAnErrorNamingTheFile) {
  const std::string path = outputPath("no_such_folder/dem.tif");
  gis::Result<SyntheticDemSummary> r = gis::synth::writeSyntheticDem(path, options(129, 1));
  EXPECT_FALSE(r.ok());
  ASSERT_FALSE(r.diagnostics.items().empty());
  EXPECT_EQ(r.diagnostics.items()[0].file, path);
  EXPECT_NE(r.diagnostics.items()[0].toString().find("no_such_folder/dem.tif"), std::string::npos);
}

// ---- the vector load of the seed paper, and multiples of it ----

/// The features of a GeoPackage layer written by writeSyntheticVectors: per feature its points
/// (a polygon's outer ring without the closing repeat) and whether OGR finds the geometry valid.
struct ReadFeature {
  std::vector<std::array<double, 2>> points;
  bool valid = false;
  double widthMetres = 0.0;
};

std::vector<ReadFeature> readLayer(const std::string& path, const char* layerName) {
  std::vector<ReadFeature> out;
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
  if (!ds) throw std::runtime_error("cannot open " + path);
  OGRLayer* layer = ds->GetLayerByName(layerName);
  if (layer == nullptr) throw std::runtime_error(path + " has no layer " + layerName);
  for (const auto& feature : *layer) {
    ReadFeature f;
    const OGRGeometry* g = feature->GetGeometryRef();
    if (g == nullptr) throw std::runtime_error(path + ": a feature without geometry");
    f.valid = g->IsValid();
    const OGRLineString* line = nullptr;
    if (wkbFlatten(g->getGeometryType()) == wkbPolygon) {
      line = g->toPolygon()->getExteriorRing();
    } else {
      line = g->toLineString();
    }
    for (int i = 0; i < line->getNumPoints(); ++i) f.points.push_back({line->getX(i), line->getY(i)});
    if (wkbFlatten(g->getGeometryType()) == wkbPolygon && f.points.size() > 1 && f.points.front() == f.points.back())
      f.points.pop_back();
    const int width = feature->GetFieldIndex("width_m");
    if (width >= 0) f.widthMetres = feature->GetFieldAsDouble(width);
    out.push_back(std::move(f));
  }
  return out;
}

gis::synth::SyntheticVectorOptions vectorOptions(int scale, std::uint64_t seed) {
  gis::synth::SyntheticVectorOptions o;
  o.scale = scale;
  o.seed = seed;
  o.minX = 500000.0;
  o.maxX = 500000.0 + 327680.0;
  o.minY = 4600000.0;
  o.maxY = 4600000.0 + 327680.0;
  return o;
}

struct Vectors {
  gis::synth::SyntheticVectorSummary summary;
  std::vector<ReadFeature> areas, roads;
};

Vectors writeVectors(const std::string& name, const gis::synth::SyntheticVectorOptions& o) {
  gis::Result<gis::synth::SyntheticVectorSummary> w =
      gis::synth::writeSyntheticVectors(outputPath(name + "_areas.gpkg"), outputPath(name + "_roads.gpkg"), o);
  for (const gis::Diagnostic& d : w.diagnostics.items()) ADD_FAILURE() << d.toString();
  if (!w) throw std::runtime_error("cannot write " + name);
  return {*w, readLayer(w->areasPath, "areas"), readLayer(w->roadsPath, "roads")};
}

std::size_t pointCount(const std::vector<ReadFeature>& features) {
  std::size_t n = 0;
  for (const ReadFeature& f : features) n += f.points.size();
  return n;
}

TEST(SynthVectors, ThePapersLoadExactly) {
  // Dai et al. 2008: 8 areas of 1,208 points, 144 roads of 18,800 points.
  const Vectors v = writeVectors("paper_x1", vectorOptions(1, 7));
  EXPECT_EQ(v.areas.size(), 8u);
  EXPECT_EQ(pointCount(v.areas), 1208u);
  EXPECT_EQ(v.roads.size(), 144u);
  EXPECT_EQ(pointCount(v.roads), 18800u);
  EXPECT_EQ(v.summary.areas, 8u);
  EXPECT_EQ(v.summary.areaPoints, 1208u);
  EXPECT_EQ(v.summary.roads, 144u);
  EXPECT_EQ(v.summary.roadPoints, 18800u);
  EXPECT_GT(v.summary.roadKilometres, 1000.0);
}

TEST(SynthVectors, MultiplesScaleEveryCount) {
  const Vectors v = writeVectors("paper_x3", vectorOptions(3, 7));
  EXPECT_EQ(v.areas.size(), 24u);
  EXPECT_EQ(pointCount(v.areas), 3u * 1208u);
  EXPECT_EQ(v.roads.size(), 432u);
  EXPECT_EQ(pointCount(v.roads), 3u * 18800u);
}

TEST(SynthVectors, AreasAreValidAndEverythingLiesInTheRectangle) {
  const auto o = vectorOptions(2, 11);
  const Vectors v = writeVectors("inside", o);
  for (const std::vector<ReadFeature>* layer : {&v.areas, &v.roads}) {
    for (const ReadFeature& f : *layer) {
      EXPECT_TRUE(f.valid);
      for (const auto& p : f.points) {
        EXPECT_GE(p[0], o.minX);
        EXPECT_LE(p[0], o.maxX);
        EXPECT_GE(p[1], o.minY);
        EXPECT_LE(p[1], o.maxY);
      }
    }
  }
  for (const ReadFeature& r : v.roads) {
    EXPECT_EQ(r.widthMetres, o.roadWidthMetres);
    // Consecutive points are one step apart (0.08 % of the rectangle): no zero-length segments.
    for (std::size_t i = 1; i < r.points.size(); ++i) {
      const double step = std::hypot(r.points[i][0] - r.points[i - 1][0], r.points[i][1] - r.points[i - 1][1]);
      EXPECT_NEAR(step, 0.0008 * 327680.0, 1e-6);
    }
  }
}

TEST(SynthVectors, SameSeedSameFeaturesOtherSeedOthers) {
  const Vectors a = writeVectors("seed_a", vectorOptions(1, 5));
  const Vectors b = writeVectors("seed_b", vectorOptions(1, 5));
  const Vectors c = writeVectors("seed_c", vectorOptions(1, 6));
  ASSERT_EQ(a.roads.size(), b.roads.size());
  for (std::size_t i = 0; i < a.roads.size(); ++i) EXPECT_EQ(a.roads[i].points, b.roads[i].points);
  for (std::size_t i = 0; i < a.areas.size(); ++i) EXPECT_EQ(a.areas[i].points, b.areas[i].points);
  EXPECT_NE(a.roads[0].points, c.roads[0].points);
  EXPECT_NE(a.areas[0].points, c.areas[0].points);
}

TEST(SynthVectors, BadOptionsFailNamingTheFile) {
  auto o = vectorOptions(0, 1);
  const std::string path = outputPath("bad_areas.gpkg");
  gis::Result<gis::synth::SyntheticVectorSummary> w =
      gis::synth::writeSyntheticVectors(path, outputPath("bad_roads.gpkg"), o);
  EXPECT_FALSE(w.ok());
  ASSERT_FALSE(w.diagnostics.items().empty());
  EXPECT_NE(w.diagnostics.items().front().toString().find(path), std::string::npos);
  o = vectorOptions(1, 1);
  o.maxX = o.minX;
  EXPECT_FALSE(gis::synth::writeSyntheticVectors(path, outputPath("bad_roads.gpkg"), o).ok());
  o = vectorOptions(1, 1);
  o.roadWidthMetres = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(gis::synth::writeSyntheticVectors(path, outputPath("bad_roads.gpkg"), o).ok());
  const std::string missing = outputPath("no_such_folder/areas.gpkg");
  w = gis::synth::writeSyntheticVectors(missing, outputPath("bad_roads.gpkg"), vectorOptions(1, 1));
  EXPECT_FALSE(w.ok());
  ASSERT_FALSE(w.diagnostics.items().empty());
  EXPECT_NE(w.diagnostics.items().front().toString().find(missing), std::string::npos);
}

// ---- the program ----

struct ProgramRun {
  int status = -1;
  std::string out, err;
};

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

ProgramRun terrainSynth(const std::string& args) {
  // One pair of capture files per run: CTest may run the tests of this file in parallel.
  static int runs = 0;
  const std::string stem = std::string("cli_") + ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" +
                           std::to_string(++runs);
  const fs::path out = outputDir() / (stem + ".stdout");
  const fs::path err = outputDir() / (stem + ".stderr");
  const std::string command =
      std::string("'") + TERRAIN_SYNTH_EXE + "' " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int raw = std::system(command.c_str());
  ProgramRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = readText(out);
  r.err = readText(err);
  return r;
}

TEST(TerrainSynth, WritesDemAndScene) {
  const fs::path dir = outputDir() / "cli";
  fs::create_directories(dir / "dem");
  const fs::path dem = dir / "dem" / "synthetic.tif";
  const fs::path scene = dir / "scene.json";
  fs::remove(dem);
  const ProgramRun r = terrainSynth("--size 129 --seed 5 --spacing 25 --relief 800 --nodata-border --out '" +
                                    dem.string() + "' --scene '" + scene.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("100%"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[####"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("129 x 129 posts"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cliffs"), std::string::npos) << r.out;

  gis::Result<Raster> read = gis::geo::readRaster(dem.string());
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(read->info.width, 129);
  EXPECT_EQ(read->info.geoTransform.c[1], 25.0);
  EXPECT_TRUE(std::isnan(read->at(0, 0)));  // the nodata border

  const nlohmann::json j = nlohmann::json::parse(readText(scene));
  EXPECT_FALSE(j.at("name").get<std::string>().empty());
  EXPECT_EQ(j.at("terrain").at("dem"), "dem/synthetic.tif");
  EXPECT_EQ(j.at("terrain").at("band"), 1);
  EXPECT_EQ(j.at("terrain").at("vertical_exaggeration"), 1.0);
  EXPECT_TRUE(j.at("layers").is_array());
  EXPECT_TRUE(j.at("layers").empty());
}

TEST(TerrainSynth, GeographicCrsGivesAnSrtmLikeTile) {
  const fs::path dir = outputDir() / "cli_geographic";
  fs::create_directories(dir);
  const fs::path dem = dir / "lonlat.tif";
  ProgramRun r = terrainSynth("--size 65 --crs EPSG:4326 --out '" + dem.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("degrees"), std::string::npos) << r.out;
  gis::Result<Raster> read = gis::geo::readRaster(dem.string());
  ASSERT_TRUE(read.ok());
  EXPECT_TRUE(read->info.crsIsGeographic);
  const double step = 1.0 / 1200.0;
  EXPECT_DOUBLE_EQ(read->info.geoTransform.c[1], step);
  EXPECT_DOUBLE_EQ(read->info.geoTransform.c[0], 6.0);
  EXPECT_DOUBLE_EQ(read->info.geoTransform.c[3], 50.0);
  // --origin and --spacing still win; a malformed origin is refused.
  r = terrainSynth("--size 65 --crs EPSG:4326 --origin -43.5,-22.75 --spacing 0.000277777777777778 --out '" +
                   dem.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  read = gis::geo::readRaster(dem.string());
  ASSERT_TRUE(read.ok());
  EXPECT_DOUBLE_EQ(read->info.geoTransform.c[0], -43.5);
  EXPECT_DOUBLE_EQ(read->info.geoTransform.c[3], -22.75);
  EXPECT_NEAR(read->info.geoTransform.c[1], 1.0 / 3600.0, 1e-15);
  r = terrainSynth("--size 65 --crs EPSG:4326 --origin 6:50 --out '" + dem.string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--origin"), std::string::npos) << r.err;
}

TEST(TerrainSynth, VectorScaleWritesTheLayersIntoTheScene) {
  const fs::path dir = outputDir() / "cli_vectors";
  fs::create_directories(dir);
  const fs::path dem = dir / "dem.tif", scene = dir / "paper.json";
  const std::string common =
      "--size 65 --seed 3 --spacing 100 --out '" + dem.string() + "' --scene '" + scene.string() + "'";
  ProgramRun r = terrainSynth(common + " --vector-scale 2 --road-width 12");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("16 areas, 2416 points"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("288 roads, 37600 points"), std::string::npos) << r.out;
  nlohmann::json j = nlohmann::json::parse(readText(scene));
  ASSERT_EQ(j.at("layers").size(), 2u);
  EXPECT_EQ(j["layers"][0]["kind"], "polygon");
  EXPECT_EQ(j["layers"][0]["source"], "paper_areas.gpkg");
  EXPECT_EQ(j["layers"][1]["kind"], "line");
  EXPECT_EQ(j["layers"][1]["source"], "paper_roads.gpkg");
  EXPECT_EQ(j["layers"][1]["style"]["width_m"], 12.0);
  EXPECT_EQ(readLayer((dir / "paper_roads.gpkg").string(), "roads").size(), 288u);

  // --vectors-only keeps the DEM and writes the other load.
  const auto demTime = fs::last_write_time(dem);
  r = terrainSynth(common + " --vector-scale 1 --vectors-only");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(fs::last_write_time(dem), demTime);
  EXPECT_EQ(readLayer((dir / "paper_roads.gpkg").string(), "roads").size(), 144u);
  // Without the DEM it is an error naming it; without --vector-scale a bad argument.
  r = terrainSynth("--size 65 --out '" + (dir / "none.tif").string() + "' --scene '" + scene.string() +
                   "' --vector-scale 1 --vectors-only");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("none.tif"), std::string::npos) << r.err;
  EXPECT_EQ(terrainSynth(common + " --vectors-only").status, 2);
  EXPECT_EQ(terrainSynth("--size 65 --out '" + dem.string() + "' --vector-scale 1").status, 2);
}

TEST(TerrainSynth, SameArgumentsGiveTheSameFile) {
  const std::string a = outputPath("cli_a.tif"), b = outputPath("cli_b.tif");
  ASSERT_EQ(terrainSynth("--size 65 --seed 9 --no-spikes --out '" + a + "'").status, 0);
  ASSERT_EQ(terrainSynth("--size 65 --seed 9 --no-spikes --out '" + b + "'").status, 0);
  gis::Result<Raster> ra = gis::geo::readRaster(a), rb = gis::geo::readRaster(b);
  ASSERT_TRUE(ra.ok() && rb.ok());
  EXPECT_EQ(bits(*ra), bits(*rb));
}

TEST(TerrainSynth, BadArgumentsExitWith2) {
  const std::string out = " --out '" + outputPath("bad_args.tif") + "'";
  for (const std::string& args : {std::string(""), std::string("--size 129"), "--size abc" + out, "--size 10" + out,
                                  "--size 129.5" + out, "--seed -1" + out, "--spacing 0" + out, "--relief 99999" + out,
                                  "--bogus" + out, "--crs EPSG:99999999" + out, std::string("--out")}) {
    const ProgramRun r = terrainSynth(args);
    EXPECT_EQ(r.status, 2) << args;
    EXPECT_NE(r.err.find("terrain_synth: "), std::string::npos) << args;
    EXPECT_NE(r.err.find("usage:"), std::string::npos) << args;
  }
  const ProgramRun help = terrainSynth("--help");
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("usage:"), std::string::npos);
}

TEST(TerrainSynth, IoErrorsExitWith1NamingTheFile) {
  const std::string dem = outputPath("missing_folder/dem.tif");
  ProgramRun r = terrainSynth("--size 65 --out '" + dem + "'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(dem), std::string::npos) << r.err;

  const std::string scene = outputPath("missing_folder/scene.json");
  r = terrainSynth("--size 65 --out '" + outputPath("io.tif") + "' --scene '" + scene + "'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(scene), std::string::npos) << r.err;
}

}  // namespace
