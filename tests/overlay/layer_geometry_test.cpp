// The CPU half of an overlay layer (layer_geometry.hpp) and the near-plane clipping
// (near_clip.hpp), without a GL context: a layer built on worker threads is the same as one
// built on this thread, edits say exactly what the GPU copy must take again, and the z-fail
// pieces clipped at the near plane (and capped there) stay closed volumes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "geo/binary_io.hpp"
#include "gfx/camera.hpp"
#include "random_features.hpp"
#include "vector_overlay/layer_geometry.hpp"
#include "vector_overlay/near_clip.hpp"
#include "vector_overlay/tiled_layer.hpp"

namespace gis::test {
namespace {

using namespace gis::overlay;

/// A wavy surface z = 40 sin(x/300) cos(y/200): bounds over a footprint from dense samples of
/// its box plus the largest change between samples. Read-only, so safe from any thread.
class WavyBounds final : public HeightBoundsProvider {
 public:
  explicit WavyBounds(double exaggeration = 1.0) : exaggeration_(exaggeration) {}
  [[nodiscard]] HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override {
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
    for (const glm::dvec2& p : footprint) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    if (footprint.empty()) return globalBounds();
    HeightBounds b{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    const double step = 20.0;
    for (double x = lo.x; x <= hi.x + step; x += step) {
      for (double y = lo.y; y <= hi.y + step; y += step) {
        const double z = at(glm::dvec2(std::min(x, hi.x), std::min(y, hi.y)));
        b.lo = std::min(b.lo, z);
        b.hi = std::max(b.hi, z);
      }
    }
    const double margin = exaggeration_ * 40.0 * (1.0 / 300.0 + 1.0 / 200.0) * step;
    return {b.lo - margin, b.hi + margin};
  }
  [[nodiscard]] HeightBounds globalBounds() const override { return {-40.0 * exaggeration_, 40.0 * exaggeration_}; }
  [[nodiscard]] double at(const glm::dvec2& p) const {
    return exaggeration_ * 40.0 * std::sin(p.x / 300.0) * std::cos(p.y / 200.0);
  }

 private:
  double exaggeration_;
};

LayerBuildOptions onCells() {
  LayerBuildOptions o;
  CellGrid g;
  g.origin = glm::dvec2(-3000.0);
  g.cellSize = 250.0;
  g.columns = g.rows = 24;
  o.footprints.cells = g;
  return o;
}

bool sameArrays(const LayerGeometry& a, const LayerGeometry& b) {
  return a.vertices().size() == b.vertices().size() && a.indices() == b.indices() &&
         std::memcmp(a.vertices().data(), b.vertices().data(), a.vertices().size() * sizeof(LayerGeometry::Vertex)) ==
             0 &&
         a.slots().size() == b.slots().size();
}

// Cached pieces (vector tiles, checks) are found by this hash. Their vertices hold each
// feature's colour, drawn as they are when the colours differ (by category): such colours are in
// the hash. A layer of one colour is drawn with it as a uniform, so its colour is not (changing
// it keeps the cache).
TEST(LayerGeometry, FingerprintHoldsColoursThatDifferBetweenFeatures) {
  std::vector<geo::Feature> features(3);
  for (std::size_t i = 0; i < features.size(); ++i) {
    features[i].fid = static_cast<std::int64_t>(i);
    const double x = 100.0 * static_cast<double>(i);
    features[i].polygons.push_back({{{x, 0.0}, {x + 50.0, 0.0}, {x + 50.0, 50.0}}, {}});
  }
  const auto hash = [&](const std::vector<glm::vec4>& colours) {
    std::vector<FeatureStyle> styles(features.size());
    for (std::size_t i = 0; i < styles.size(); ++i) styles[i].color = colours[i];
    return featuresFingerprint(features, styles, LayerKind::Polygon);
  };
  const glm::vec4 orange(1.0F, 0.5F, 0.0F, 0.45F), blue(0.1F, 0.4F, 0.7F, 0.45F);
  EXPECT_EQ(hash({orange, orange, orange}), hash({blue, blue, blue})) << "one colour: drawn as a uniform";
  EXPECT_NE(hash({orange, blue, orange}), hash({orange, orange, orange}));
  EXPECT_NE(hash({orange, blue, orange}), hash({blue, orange, orange}));
  EXPECT_EQ(hash({orange, blue, orange}), hash({orange, blue, orange}));
}

TEST(LayerGeometry, BuiltOnWorkerThreadsIsTheSameAsOnThisOneAndValid) {
  std::mt19937 rng(5);
  const glm::dvec2 lo(-2800.0), hi(2800.0);
  const std::vector<geo::Feature> areas = randomPolygons(rng, lo, hi, 30), roads = randomLines(rng, lo, hi, 40);
  const WavyBounds bounds;
  LayerStyle road;
  road.widthAttribute = "width_m";
  auto buildAreas = [&] { return LayerGeometry::build("areas", LayerKind::Polygon, {}, areas, bounds, onCells()); };
  auto buildRoads = [&] { return LayerGeometry::build("roads", LayerKind::Line, road, roads, bounds, onCells()); };
  std::future<Result<LayerGeometry>> a = std::async(std::launch::async, buildAreas);
  std::future<Result<LayerGeometry>> r = std::async(std::launch::async, buildRoads);
  Result<LayerGeometry> areasHere = buildAreas(), roadsHere = buildRoads();
  Result<LayerGeometry> areasThere = a.get(), roadsThere = r.get();
  ASSERT_TRUE(areasHere.ok() && roadsHere.ok() && areasThere.ok() && roadsThere.ok());
  EXPECT_TRUE(sameArrays(*areasHere, *areasThere));
  EXPECT_TRUE(sameArrays(*roadsHere, *roadsThere));
  for (const LayerGeometry* g : {&*areasHere, &*roadsHere}) {
    const LayerValidation v = g->validate();
    EXPECT_TRUE(v.problems.empty()) << v.problems.items().front().toString();
    EXPECT_GE(v.pieces, 30u);
    EXPECT_LT(v.maxPositionError, 1e-3);
    EXPECT_EQ(g->stats().gpuBytes, 0u);  // the GPU is OverlayLayer's business
  }
}

TEST(LayerGeometry, AnyNumberOfBuildThreadsGivesTheSameLayer) {
  // More features than one block of the build (2,048), some broken: the arrays, the slots, the
  // outcomes and the messages (in feature order) are the same on 1, 2 and 5 threads.
  std::mt19937 rng(17);
  std::vector<geo::Feature> roads = randomLines(rng, glm::dvec2(-2800.0), glm::dvec2(2800.0), 2300);
  for (const std::size_t k : {5U, 2047U, 2048U, 2299U}) {
    roads[k].lines.front().front().x = std::numeric_limits<double>::quiet_NaN();
  }
  const WavyBounds bounds;
  LayerStyle road;
  road.widthAttribute = "width_m";
  std::optional<Result<LayerGeometry>> first;
  for (const unsigned threads : {1U, 2U, 5U}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    LayerBuildOptions options = onCells();
    options.threads = threads;
    Result<LayerGeometry> built = LayerGeometry::build("roads", LayerKind::Line, road, roads, bounds, options);
    ASSERT_TRUE(built.ok());
    EXPECT_EQ(built.diagnostics.count(Severity::Error), 4u);
    if (!first) {
      first.emplace(std::move(built));
      continue;
    }
    const LayerGeometry &a = **first, &b = *built;
    EXPECT_TRUE(sameArrays(a, b));
    ASSERT_EQ(a.slots().size(), b.slots().size());
    for (std::size_t i = 0; i < a.slots().size(); ++i) {
      EXPECT_EQ(a.slots()[i].feature, b.slots()[i].feature);
      EXPECT_EQ(a.slots()[i].baseVertex, b.slots()[i].baseVertex);
      EXPECT_EQ(a.slots()[i].firstIndex, b.slots()[i].firstIndex);
    }
    EXPECT_EQ(a.featureOutcomes(), b.featureOutcomes());
    ASSERT_EQ(first->diagnostics.items().size(), built.diagnostics.items().size());
    for (std::size_t i = 0; i < built.diagnostics.items().size(); ++i) {
      EXPECT_EQ(first->diagnostics.items()[i].toString(), built.diagnostics.items()[i].toString());
    }
  }
}

TEST(LayerGeometry, LayersShareTheirFeaturesUntilOneIsEdited) {
  std::mt19937 rng(4);
  const WavyBounds bounds;
  const auto read = std::make_shared<const std::vector<geo::Feature>>(
      randomPolygons(rng, glm::dvec2(-2000.0), glm::dvec2(2000.0), 8));
  const std::vector<geo::Feature> before = *read;
  LayerBuildOptions deferred = onCells();
  deferred.deferPieces = true;
  Result<LayerGeometry> a = LayerGeometry::build("a", LayerKind::Polygon, {}, read, bounds, onCells());
  Result<LayerGeometry> b = LayerGeometry::build("b", LayerKind::Polygon, {}, read, bounds, deferred);
  ASSERT_TRUE(a.ok() && b.ok());
  // No copy: both layers read the vector the scene read.
  EXPECT_EQ(&a->features(), read.get());
  EXPECT_EQ(&b->features(), read.get());
  EXPECT_TRUE(a->sharedFeatures().shared());

  // An edit copies the features of the edited layer only; the others and the source keep theirs.
  geo::Feature moved = a->features()[2];
  for (glm::dvec2& p : moved.polygons.front().outer) p += glm::dvec2(90.0, 10.0);
  EXPECT_TRUE(a->replaceFeature(2, moved).empty());
  EXPECT_NE(&a->features(), read.get());
  EXPECT_EQ(a->features()[2].polygons.front().outer, moved.polygons.front().outer);
  EXPECT_EQ(&b->features(), read.get());
  EXPECT_EQ(read->at(2).polygons.front().outer, before.at(2).polygons.front().outer);
  EXPECT_TRUE(a->validate().problems.empty());
  // Ours alone now: the next edit changes it in place.
  const std::vector<geo::Feature>* own = &a->features();
  EXPECT_FALSE(a->sharedFeatures().shared());
  EXPECT_TRUE(a->replaceFeature(3, a->features()[3]).empty());
  EXPECT_EQ(&a->features(), own);
}

TEST(LayerGeometry, DeferredChecksAreReadFromTheirCacheWhileNothingTheyDependOnChanged) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("layer_checks_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::mt19937 rng(12);
  const WavyBounds bounds;
  std::vector<geo::Feature> roads = randomLines(rng, glm::dvec2(-2000.0), glm::dvec2(2000.0), 10);
  geo::Feature broken;  // one point: an Error, named
  broken.fid = 77;
  broken.lines.push_back({glm::dvec2(5.0, 5.0)});
  roads.push_back(broken);
  geo::Feature outside;  // far beyond the cells: a Warning, nothing to draw
  outside.fid = 78;
  outside.lines.push_back({glm::dvec2(9e4, 9e4), glm::dvec2(9.1e4, 9e4)});
  roads.push_back(outside);
  LayerStyle road;
  road.widthMetres = 6.0F;
  LayerBuildOptions options = onCells();
  options.deferPieces = true;
  options.checkCacheDirectory = dir.string();
  const auto build = [&](const std::vector<geo::Feature>& features) {
    Result<LayerGeometry> g = LayerGeometry::build("roads", LayerKind::Line, road, features, bounds, options);
    EXPECT_TRUE(g.ok());
    return g;
  };
  const auto messages = [](const Diagnostics& d) {
    std::vector<std::string> out;
    for (const Diagnostic& m : d.items()) out.push_back(m.toString());
    return out;
  };
  const Result<LayerGeometry> first = build(roads);
  EXPECT_FALSE(first->stats().checksFromCache);
  ASSERT_FALSE(first.diagnostics.items().empty()) << "the broken features are named";
  // Again: read, with the same outcomes and messages.
  const Result<LayerGeometry> second = build(roads);
  EXPECT_TRUE(second->stats().checksFromCache);
  EXPECT_EQ(second->featureOutcomes(), first->featureOutcomes());
  EXPECT_EQ(messages(second.diagnostics), messages(first.diagnostics));
  EXPECT_EQ(second->contentFingerprint(), first->contentFingerprint());
  // Another feature, or another width: checked again.
  std::vector<geo::Feature> moved = roads;
  moved[2].lines[0][0] += glm::dvec2(1.0, 0.0);
  EXPECT_FALSE(build(moved)->stats().checksFromCache);
  road.widthMetres = 8.0F;
  EXPECT_FALSE(build(roads)->stats().checksFromCache);
  EXPECT_TRUE(build(roads)->stats().checksFromCache);
  // A damaged file: checked again (and written again).
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    std::filesystem::resize_file(entry.path(), std::filesystem::file_size(entry.path()) / 2);
  const Result<LayerGeometry> repaired = build(roads);
  EXPECT_FALSE(repaired->stats().checksFromCache);
  EXPECT_TRUE(build(roads)->stats().checksFromCache);
  std::filesystem::remove_all(dir);
}

TEST(LayerGeometry, ALeanCopyReadsBackAsReleasedAndDamagedOnesAreRefused) {
  std::mt19937 rng(21);
  const WavyBounds bounds;
  LayerStyle road;
  road.widthMetres = 5.0F;
  const std::vector<geo::Feature> roads = randomLines(rng, glm::dvec2(-2000.0), glm::dvec2(2000.0), 6);
  Result<LayerGeometry> built = LayerGeometry::build("roads", LayerKind::Line, road, roads, bounds, onCells());
  ASSERT_TRUE(built.ok());
  std::ostringstream out;
  {
    geo::io::Writer w(out);
    built->writeLean(w);
  }
  const std::string bytes = out.str();
  const auto read = [&](const std::string& data) {
    std::istringstream in(data);
    geo::io::Reader r(in);
    return LayerGeometry::readLean(r, "roads", LayerKind::Line, road, built->featureStyles(), bounds, onCells());
  };
  // The same with the GPU arrays left in the file (a lean tile's read, ArraysInFile): the same
  // checks, the arrays read a slice at a time.
  const std::string file = ::testing::TempDir() + "lean_copy_" + std::to_string(::getpid()) + ".bin";
  const auto readInFile = [&](const std::string& data) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << data;
    std::ifstream in(file, std::ios::binary);
    geo::io::Reader r(in);
    return LayerGeometry::readLean(r, "roads", LayerKind::Line, road, built->featureStyles(), bounds, onCells(),
                                   std::make_shared<ArraysInFile>(::open(file.c_str(), O_RDONLY | O_CLOEXEC)));
  };
  const auto indicesInFile = [](const LayerGeometry& g) {
    std::vector<std::uint32_t> indices(g.arraysInFile()->indexCount);
    EXPECT_TRUE(g.arraysInFile()->read(
        g.arraysInFile()->indicesAt, indices.size() * sizeof(std::uint32_t),
        [&](const void* data, std::uint64_t offset, std::uint64_t n) {
          std::memcpy(reinterpret_cast<char*>(indices.data()) + offset, data, static_cast<std::size_t>(n));
        },
        64));  // small slices: the slicing is what is tested
    return indices;
  };
  {
    const std::optional<LayerGeometry> inFile = readInFile(bytes);
    ASSERT_TRUE(inFile.has_value());
    ASSERT_NE(inFile->arraysInFile(), nullptr);
    EXPECT_TRUE(inFile->vertices().empty());
    EXPECT_EQ(inFile->vertexCount(), built->vertices().size());
    EXPECT_EQ(inFile->indexCount(), built->indices().size());
    EXPECT_EQ(indicesInFile(*inFile), built->indices());
  }
  // Whole: the same arrays and slots, pieces' boxes and bounds, no footprints.
  const std::optional<LayerGeometry> lean = read(bytes);
  ASSERT_TRUE(lean.has_value());
  EXPECT_TRUE(sameArrays(*lean, *built));
  EXPECT_TRUE(lean->footprintsReleased());
  EXPECT_EQ(lean->featureOutcomes(), built->featureOutcomes());
  EXPECT_EQ(lean->box3(), built->box3());
  EXPECT_EQ(lean->maxOverlap(), built->maxOverlap());
  for (std::size_t k = 0; k < lean->polyhedra().size(); ++k) {
    EXPECT_EQ(lean->polyhedra()[k].lo, built->polyhedra()[k].lo);
    EXPECT_EQ(lean->polyhedra()[k].boxMax, built->polyhedra()[k].boxMax);
    EXPECT_TRUE(lean->polyhedra()[k].footprint.vertices.empty());
  }
  // Cut short anywhere: refused.
  for (std::size_t n = 0; n < bytes.size(); n += 1 + bytes.size() / 997) {
    EXPECT_FALSE(read(bytes.substr(0, n)).has_value()) << "cut at " << n;
    if (n % 7 == 0) {
      EXPECT_FALSE(readInFile(bytes.substr(0, n)).has_value()) << "cut at " << n << ", in a file";
    }
  }
  // Bytes changed at random: refused, or read with every index within its arrays (the checks a
  // draw relies on; the sanitizer build would see any read beyond them here).
  std::uniform_int_distribution<std::size_t> at(0, bytes.size() - 1);
  std::uniform_int_distribution<int> value(0, 255);
  for (int trial = 0; trial < 400; ++trial) {
    std::string damaged = bytes;
    for (int k = 0; k < 1 + trial % 4; ++k) damaged[at(rng)] = static_cast<char>(value(rng));
    const std::optional<LayerGeometry> g = read(damaged);
    // Left in a file, the indices are checked slice by slice: the same answer.
    const std::optional<LayerGeometry> f = readInFile(damaged);
    ASSERT_EQ(f.has_value(), g.has_value()) << "trial " << trial;
    if (!g) continue;
    const std::vector<std::uint32_t> fileIndices = indicesInFile(*f);
    ASSERT_EQ(fileIndices, g->indices());
    for (const LayerGeometry::PieceSlot& s : g->slots()) {
      ASSERT_LE(std::uint64_t{s.firstIndex} + s.indexCount, g->indices().size());
      for (std::uint32_t i = s.firstIndex; i < s.firstIndex + s.indexCount; ++i)
        ASSERT_LT(std::uint64_t{s.baseVertex} + g->indices()[i], g->vertices().size());
      ASSERT_LT(s.origin, g->origins().size());
    }
    (void)g->box3();
    (void)g->maxOverlap();
  }
  std::filesystem::remove(file);
}

TEST(LayerGeometry, WorldPiecesReadBackLeanWithTheirNormalsGroupsAndWidths) {
  // Two pieces of world pieces (another frame's: ECEF about an origin), in two colour groups,
  // as lines in pixels: a normal and a scaling per vertex.
  using Vertex = LayerGeometry::Vertex;
  std::vector<Vertex> vertices;
  std::vector<glm::vec4> normals, scaling;
  std::vector<std::uint32_t> indices;
  std::vector<LayerGeometry::WorldPiece> pieces;
  for (std::uint32_t p = 0; p < 2; ++p) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    for (int k = 0; k < 6; ++k) {
      const auto x = static_cast<float>(100U * p + 10U * static_cast<std::uint32_t>(k / 2)),
                 side = (k % 2) == 0 ? -1.0F : 1.0F;
      vertices.push_back(Vertex{x, static_cast<float>(k), side * 5.0F, side, {0, 0, 0, 255}});
      normals.emplace_back(0.0F, 0.0F, 1.0F, 0.0F);
      scaling.emplace_back(1.0F, 0.0F, 0.0F, 2.0F);
    }
    const auto first = static_cast<std::uint32_t>(indices.size());
    for (const std::uint32_t i : {0U, 2U, 4U, 1U, 5U, 3U, 0U, 1U, 2U}) indices.push_back(base + i);
    pieces.push_back({first, 3, 9, glm::dvec3(100.0 * p, 0.0, -5.0), glm::dvec3(100.0 * p + 20.0, 5.0, 5.0), p});
  }
  const std::vector<glm::vec4> colours{{1.0F, 0.0F, 0.0F, 1.0F}, {0.0F, 0.0F, 1.0F, 0.5F}};
  LayerGeometry::WorldLines lines;
  lines.scaling = scaling;
  lines.widthPixels = 3.0;
  lines.maxWidth = 64.0;
  const glm::dvec3 origin(6378137.0, 10.0, -20.0);
  const LayerGeometry built =
      LayerGeometry::ofWorldPieces("routes", origin, vertices, normals, indices, pieces, colours, lines);
  EXPECT_EQ(built.kind(), LayerKind::Line);
  EXPECT_FALSE(built.uniformColor().has_value()) << "two colours";
  // What a frame keys such tiles by: nothing for one colour, the colours where they differ.
  EXPECT_EQ(coloursFingerprint(std::vector<glm::vec4>{colours[0], colours[0]}), 0U);
  EXPECT_NE(coloursFingerprint(colours), 0U);
  EXPECT_NE(coloursFingerprint(colours), coloursFingerprint(std::vector<glm::vec4>{colours[1], colours[0]}));
  EXPECT_EQ(built.vertices()[0].rgba[0], 255);
  EXPECT_EQ(built.vertices()[6].rgba[2], 255);
  EXPECT_EQ(built.vertices()[6].rgba[3], 128);
  std::ostringstream out;
  {
    geo::io::Writer w(out);
    built.writeLean(w);
  }
  const std::string bytes = out.str();
  std::vector<FeatureStyle> styles(2);
  styles[0].color = colours[0];
  styles[1].color = colours[1];
  const auto read = [&](const std::string& data, std::vector<FeatureStyle> as) {
    std::istringstream in(data);
    geo::io::Reader r(in);
    return LayerGeometry::readWorldLean(r, "routes", std::move(as));
  };
  const std::optional<LayerGeometry> lean = read(bytes, styles);
  ASSERT_TRUE(lean.has_value());
  EXPECT_TRUE(lean->alongNormals());
  EXPECT_EQ(lean->worldOrigins(), built.worldOrigins());
  EXPECT_EQ(lean->kind(), LayerKind::Line);
  EXPECT_EQ(lean->widthPixels(), 3.0);
  EXPECT_EQ(lean->style().maxWidthMetres, 64.0);
  EXPECT_TRUE(sameArrays(*lean, built));
  EXPECT_EQ(lean->normals(), built.normals());
  EXPECT_EQ(lean->scaling(), built.scaling());
  EXPECT_EQ(lean->box3(), built.box3());
  EXPECT_EQ(lean->featureOutcomes(), built.featureOutcomes());
  // One colour for both groups: drawn with it as a uniform (the colour is the reader's).
  const std::optional<LayerGeometry> oneColour = read(bytes, {styles[1], styles[1]});
  ASSERT_TRUE(oneColour.has_value());
  ASSERT_TRUE(oneColour->uniformColor().has_value());
  EXPECT_NEAR(oneColour->uniformColor()->w, 0.5F, 1.0F / 255.0F);
  // Not a plane's layer, nor the other way round; another number of groups; cut short: refused.
  {
    std::istringstream in(bytes);
    geo::io::Reader r(in);
    const WavyBounds bounds;
    EXPECT_FALSE(LayerGeometry::readLean(r, "routes", LayerKind::Line, {}, styles, bounds, {}).has_value());
  }
  EXPECT_FALSE(read(bytes, {styles[0]}).has_value());
  for (std::size_t n = 0; n < bytes.size(); n += 1 + bytes.size() / 301)
    EXPECT_FALSE(read(bytes.substr(0, n), styles).has_value()) << "cut at " << n;
  // Bytes changed at random: refused, or every index and origin within its arrays.
  std::mt19937 rng(5);
  std::uniform_int_distribution<std::size_t> at(0, bytes.size() - 1);
  std::uniform_int_distribution<int> value(0, 255);
  for (int trial = 0; trial < 300; ++trial) {
    std::string damaged = bytes;
    for (int k = 0; k < 1 + trial % 4; ++k) damaged[at(rng)] = static_cast<char>(value(rng));
    const std::optional<LayerGeometry> g = read(damaged, styles);
    if (!g) continue;
    ASSERT_EQ(g->normals().size(), g->vertices().size());
    for (const LayerGeometry::PieceSlot& s : g->slots()) {
      ASSERT_LE(std::uint64_t{s.firstIndex} + s.indexCount, g->indices().size());
      for (std::uint32_t i = s.firstIndex; i < s.firstIndex + s.indexCount; ++i)
        ASSERT_LT(std::uint64_t{s.baseVertex} + g->indices()[i], g->vertices().size());
      ASSERT_LT(s.origin, g->worldOrigins().size());
      ASSERT_LT(s.feature, 2U);
    }
  }
}

TEST(LayerGeometry, TileFoldersNoLayerOpensAnyMoreLeaveOldestFirst) {
  // A cache folder with the tiles of three older versions of a layer (other features, terrain
  // or code) beside this one's: opened an hour, a day and 40 days ago, and one opened a moment
  // ago by another layer (or process).
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(::testing::TempDir()) / ("tile_folders_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const auto folder = [&](const std::string& name, std::chrono::minutes age, std::size_t bytes) {
    fs::create_directories(dir / name);
    std::ofstream(dir / name / "0-0-0.tile", std::ios::binary) << std::string(bytes, 'x');
    fs::last_write_time(dir / name, fs::file_time_type::clock::now() - age);
  };
  folder("hour", std::chrono::minutes(60), 3000);
  folder("day", std::chrono::minutes(60 * 24), 3000);
  folder("month", std::chrono::minutes(60 * 24 * 40), 10);
  folder("moment", std::chrono::minutes(1), 3000);
  std::mt19937 rng(3);
  const WavyBounds bounds;
  LayerBuildOptions options = onCells();
  options.deferPieces = true;
  Result<LayerGeometry> source =
      LayerGeometry::build("areas", LayerKind::Polygon, {},
                           randomPolygons(rng, glm::dvec2(-2000.0), glm::dvec2(2000.0), 4), bounds, options);
  ASSERT_TRUE(source.ok());
  const auto open = [&](std::uintmax_t budget) {
    TilingOptions tiling;
    tiling.cacheDirectory = dir.string();
    tiling.cacheKey = "terrain";
    tiling.cacheBudgetBytes = budget;
    return std::make_unique<LayerTiling>(*source, bounds, options, tiling);
  };
  // Within the budget: only the folder unused for a month goes.
  const auto roomy = open(std::uintmax_t{1} << 30U);
  EXPECT_TRUE(fs::is_directory(roomy->cacheFolder()));
  EXPECT_FALSE(fs::exists(dir / "month"));
  EXPECT_TRUE(fs::exists(dir / "day") && fs::exists(dir / "hour") && fs::exists(dir / "moment"));
  // Over it: the least recently opened leave until it holds; the one opened a moment ago and
  // this layer's own stay.
  const auto tight = open(7000);
  EXPECT_EQ(tight->cacheFolder(), roomy->cacheFolder());
  EXPECT_FALSE(fs::exists(dir / "day"));
  EXPECT_TRUE(fs::exists(dir / "hour")) << "6,000 bytes are left: within 7,000";
  const auto tighter = open(1);
  EXPECT_FALSE(fs::exists(dir / "hour"));
  EXPECT_TRUE(fs::exists(dir / "moment"));
  EXPECT_TRUE(fs::is_directory(tighter->cacheFolder()));
  fs::remove_all(dir);
}

TEST(LayerGeometry, EditsNameExactlyWhatTheGpuCopyMustTakeAgain) {
  std::mt19937 rng(9);
  const WavyBounds bounds;
  Result<LayerGeometry> built =
      LayerGeometry::build("areas", LayerKind::Polygon, {},
                           randomPolygons(rng, glm::dvec2(-2000.0), glm::dvec2(2000.0), 12), bounds, onCells());
  ASSERT_TRUE(built.ok());
  LayerGeometry& g = *built;
  EXPECT_TRUE(g.takeChanges().empty()) << "a new geometry is uploaded whole";

  // Replacing a feature appends its new pieces at the end (the old slots die in place).
  const std::size_t vertices = g.vertices().size(), indices = g.indices().size();
  geo::Feature moved = g.features()[3];
  for (glm::dvec2& p : moved.polygons.front().outer) p += glm::dvec2(130.0, -40.0);
  EXPECT_TRUE(g.replaceFeature(3, moved).empty());
  const GeometryChange appended = g.takeChanges();
  EXPECT_EQ(appended.vertexBegin, vertices);
  EXPECT_EQ(appended.vertexEnd, g.vertices().size());
  EXPECT_EQ(appended.indexBegin, indices);
  EXPECT_EQ(appended.indexEnd, g.indices().size());
  EXPECT_TRUE(g.takeChanges().empty());
  EXPECT_TRUE(g.validate().problems.empty());

  // Another exaggeration: every live piece's heights change, no index does, and the stored
  // heights are the new bounds.
  const WavyBounds taller(3.0);
  g.refreshBounds(taller);
  const GeometryChange heights = g.takeChanges();
  EXPECT_LT(heights.vertexBegin, heights.vertexEnd);
  EXPECT_GE(heights.indexBegin, heights.indexEnd);
  const LayerValidation v = g.validate();
  EXPECT_TRUE(v.problems.empty());
  EXPECT_LT(v.maxHeightError, 1e-3);
  for (std::size_t k = 0; k < g.slots().size(); ++k) {
    if (!g.slots()[k].live) continue;
    const Polyhedron& p = g.polyhedra()[k];
    const HeightBounds want = taller.boundsOver(p.footprint.vertices);
    EXPECT_DOUBLE_EQ(p.lo, want.lo);
    EXPECT_DOUBLE_EQ(p.hi, want.hi);
  }

  // Removing a feature frees its slots without touching the arrays.
  g.removeFeature(5);
  EXPECT_TRUE(g.takeChanges().empty());
  EXPECT_EQ(g.featureOutcomes()[5], FeatureOutcome::Hidden);
}

/// Directed edges of a triangle soup, by their endpoints' bits.
using Point = std::tuple<float, float, float>;
std::map<std::pair<Point, Point>, int> directedEdges(const std::vector<ClippedVertex>& t) {
  std::map<std::pair<Point, Point>, int> edges;
  for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
    for (std::size_t k = 0; k < 3; ++k) {
      const ClippedVertex& a = t[i + k];
      const ClippedVertex& b = t[i + (k + 1) % 3];
      const Point pa{a.x, a.y, a.z}, pb{b.x, b.y, b.z};
      if (pa != pb) ++edges[{pa, pb}];
    }
  }
  return edges;
}

TEST(NearClip, PiecesCutAtTheNearPlaneAndCappedThereStayClosed) {
  std::mt19937 rng(13);
  const WavyBounds bounds;
  Result<LayerGeometry> built =
      LayerGeometry::build("areas", LayerKind::Polygon, {},
                           randomPolygons(rng, glm::dvec2(-1500.0), glm::dvec2(1500.0), 10), bounds, onCells());
  ASSERT_TRUE(built.ok());
  const LayerGeometry& g = *built;
  std::vector<std::size_t> slots;
  for (std::size_t k = 0; k < g.slots().size(); ++k) {
    if (g.slots()[k].live) slots.push_back(k);
  }
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int cutSomewhere = 0;
  for (int trial = 0; trial < 40; ++trial) {
    // Eyes near the pieces' heights, a near plane of tens of metres: many pieces are cut.
    const glm::dvec3 eye(1500.0 * u(rng), 1500.0 * u(rng), 40.0 * u(rng));
    const glm::dvec3 target = eye + glm::dvec3(u(rng), u(rng), 0.3 * u(rng));
    OverlayView view;
    view.nearPlane = 20.0 + 60.0 * (u(rng) + 1.0);
    view.eye = eye;
    view.viewProj = gfx::reversedInfinitePerspective(glm::radians(60.0), 1.5, view.nearPlane) *
                    gfx::lookAt(eye, target, glm::dvec3(0.0, 0.0, 1.0));
    const CapPadding padding;
    const std::vector<ClippedVertex> whole = clipAtNearPlane(view, g, slots, padding, PixelScale{}, false);
    const std::vector<ClippedVertex> capped = clipAtNearPlane(view, g, slots, padding, PixelScale{}, true);
    ASSERT_EQ(whole.size() % 3, 0u);
    ASSERT_EQ(capped.size() % 3, 0u);
    cutSomewhere += capped.size() > whole.size() ? 1 : 0;
    // Nothing left in front of the clip plane (w ≥ near / 2, within float rounding).
    const glm::dvec3 w(view.viewProj[0][3], view.viewProj[1][3], view.viewProj[2][3]);
    for (const ClippedVertex& v : capped) {
      const double wv = glm::dot(w, glm::dvec3(v.x, v.y, v.z) + eye) + view.viewProj[3][3];
      EXPECT_GE(wv, 0.5 * view.nearPlane - 1e-3 * (1.0 + std::abs(wv)));
    }
    // Closed: every directed edge has its reverse as often (cut points are bit-identical).
    const auto edges = directedEdges(capped);
    int unmatched = 0;
    for (const auto& [edge, count] : edges) {
      const auto reverse = edges.find({edge.second, edge.first});
      unmatched += reverse == edges.end() || reverse->second != count ? 1 : 0;
    }
    EXPECT_EQ(unmatched, 0) << "trial " << trial;
  }
  EXPECT_GT(cutSomewhere, 5) << "the cameras must cut pieces for the test to mean anything";
}

}  // namespace
}  // namespace gis::test
