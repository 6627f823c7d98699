// Vector layers from a PostGIS table, through OGR, against a real PostgreSQL + PostGIS server
// that tests/geo/with_postgis.sh starts for this program (STENCIL_GIS_PG names it; without it
// every test fails). The server holds the Olinda tracts and streets loaded with ogr2ogr: read
// from the database they are the features of the files, and a spatial filter (answered by
// PostGIS's GiST index) gives every feature that meets the box.
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "geo/frame.hpp"
#include "geo/raster.hpp"
#include "geo/vector.hpp"
#include "source_checks.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

const std::string kSamples = std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/";

geo::SceneFrame olindaFrame() {
  Result<geo::RasterInfo> info = geo::inspectRaster(kSamples + "olinda_dem_utm25s.tif");
  EXPECT_TRUE(info.ok());
  Result<geo::SceneFrame> frame = geo::SceneFrame::forRaster(*info);
  EXPECT_TRUE(frame.ok());
  return *frame;
}

/// The connection string with_postgis.sh gives, or a failure.
std::string connection() {
  const char* pg = std::getenv("STENCIL_GIS_PG");
  if (pg == nullptr || std::string(pg).rfind("PG:", 0) != 0) {
    ADD_FAILURE() << "STENCIL_GIS_PG is not set: run this program through tests/geo/with_postgis.sh";
    return {};
  }
  return pg;
}

/// Largest distance between corresponding vertices of two features (infinity when their shapes
/// differ in parts or vertex counts).
double vertexDistance(const geo::Feature& a, const geo::Feature& b) {
  double worst = 0.0;
  auto rings = [&](const std::vector<glm::dvec2>& r, const std::vector<glm::dvec2>& s) {
    if (r.size() != s.size()) return false;
    for (std::size_t i = 0; i < r.size(); ++i) worst = std::max(worst, glm::length(r[i] - s[i]));
    return true;
  };
  bool same = a.lines.size() == b.lines.size() && a.polygons.size() == b.polygons.size();
  for (std::size_t i = 0; same && i < a.lines.size(); ++i) same = rings(a.lines[i], b.lines[i]);
  for (std::size_t i = 0; same && i < a.polygons.size(); ++i) {
    same = rings(a.polygons[i].outer, b.polygons[i].outer) && a.polygons[i].holes.size() == b.polygons[i].holes.size();
    for (std::size_t h = 0; same && h < a.polygons[i].holes.size(); ++h)
      same = rings(a.polygons[i].holes[h], b.polygons[i].holes[h]);
  }
  return same ? worst : std::numeric_limits<double>::infinity();
}

/// The table's features are the file's: the same ids, the same vertices within 1 mm, the same
/// errors for the same broken features.
void expectTableIsTheFile(const std::string& table, const std::string& file) {
  const std::string pg = connection();
  ASSERT_FALSE(pg.empty());
  const geo::SceneFrame frame = olindaFrame();
  geo::VectorReadOptions fromTable;
  fromTable.layer = table;
  Result<geo::VectorLayer> db = geo::readVectorLayer(pg, frame, fromTable);
  ASSERT_TRUE(db.ok()) << said(db.diagnostics);
  Result<geo::VectorLayer> files = geo::readVectorLayer(file, frame);
  ASSERT_TRUE(files.ok()) << said(files.diagnostics);
  ASSERT_EQ(db->features.size(), files->features.size());
  EXPECT_EQ(db.diagnostics.count(Severity::Error), files.diagnostics.count(Severity::Error));
  std::map<std::int64_t, const geo::Feature*> byFid;
  for (const geo::Feature& f : files->features) byFid[f.fid] = &f;
  double worst = 0.0;
  for (const geo::Feature& f : db->features) {
    const auto found = byFid.find(f.fid);
    ASSERT_NE(found, byFid.end()) << "feature " << f.fid;
    worst = std::max(worst, vertexDistance(f, *found->second));
  }
  std::printf("%s: %zu features, largest vertex distance to the file's %.3g m\n", table.c_str(), db->features.size(),
              worst);
  EXPECT_LE(worst, 1e-3);
}

TEST(PostGis, TheTractsTableIsTheShapefile) { expectTableIsTheFile("olinda_tracts", kSamples + "olinda1.shp"); }

TEST(PostGis, TheStreetsTableIsTheGeoJsonAndItsBrokenFeaturesAreNamed) {
  expectTableIsTheFile("olinda_streets", kSamples + "olinda_tract_boundaries.geojson");
}

TEST(PostGis, ASpatialFilterGivesEveryFeatureMeetingTheBox) {
  const std::string pg = connection();
  ASSERT_FALSE(pg.empty());
  const geo::SceneFrame frame = olindaFrame();
  for (const std::string table : {"olinda_tracts", "olinda_streets"}) {
    SCOPED_TRACE(table);
    geo::VectorReadOptions options;
    options.layer = table;
    Result<geo::VectorLayer> all = geo::readVectorLayer(pg, frame, options);
    ASSERT_TRUE(all.ok()) << said(all.diagnostics);
    options.filter = middleOf(*all, 0.2);
    Result<geo::VectorLayer> filtered = geo::readVectorLayer(pg, frame, options);
    ASSERT_TRUE(filtered.ok()) << said(filtered.diagnostics);
    const FilterCheck check = expectFilteredReadHoldsTheBox(*all, *filtered, *options.filter);
    std::printf("%s: %zu features meet the box, %zu read of %zu\n", table.c_str(), check.meeting, check.read,
                all->features.size());
    EXPECT_GT(check.meeting, 5u);
    EXPECT_LT(check.read, all->features.size() / 4);
  }
}

TEST(PostGis, AMissingTableIsAnErrorNamingIt) {
  const std::string pg = connection();
  ASSERT_FALSE(pg.empty());
  geo::VectorReadOptions options;
  options.layer = "no_such_table";
  Result<geo::VectorLayer> r = geo::readVectorLayer(pg, olindaFrame(), options);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(said(r.diagnostics).find("no_such_table"), std::string::npos) << said(r.diagnostics);
}

}  // namespace
}  // namespace gis::test
