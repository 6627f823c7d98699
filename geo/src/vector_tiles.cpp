#include "vector_tiles.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <numbers>
#include <system_error>

#include <ogr_geometry.h>

namespace gis::geo::detail {

std::string vectorTilePath(const std::string& path) {
  std::error_code ec;
  const std::filesystem::path folder(path);
  if (!std::filesystem::is_directory(folder, ec) || !std::filesystem::exists(folder / "metadata.json", ec)) return path;
  int deepest = -1;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory(ec) || name.empty() || name.size() > 2 ||
        !std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      continue;
    }
    deepest = std::max(deepest, std::stoi(name));
  }
  return deepest < 0 ? path : (folder / std::to_string(deepest)).string();
}

std::optional<int> vectorTileZoom(GDALDataset& ds, const std::string& openedPath) {
  const char* driver = ds.GetDriverName();
  const std::string name = driver != nullptr ? driver : "";
  auto parse = [](const std::string& text) -> std::optional<int> {
    if (text.empty() || text.size() > 2 ||
        !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      return std::nullopt;
    }
    return std::stoi(text);
  };
  if (name == "MBTiles") {
    const char* zoom = ds.GetMetadataItem("ZOOM_LEVEL");
    return zoom != nullptr ? parse(zoom) : std::nullopt;
  }
  if (name == "MVT") {
    // A zoom folder ("tiles/15") or a single tile ("tiles/15/x/y.pbf").
    std::filesystem::path p(openedPath);
    if (std::filesystem::is_directory(p)) return parse(p.filename().string());
    return parse(p.parent_path().parent_path().filename().string());
  }
  return std::nullopt;
}

double vectorTileQuantisation(int zoom, int extent) {
  constexpr double kEquator = 2.0 * std::numbers::pi * 6378137.0;  // Web Mercator's world width
  const double unit = kEquator / (std::ldexp(1.0, zoom) * extent);
  return 0.5 * unit * (std::numbers::sqrt2 + 1.0);
}

namespace {

/// Moves every vertex to the nearest point of the tiles' grid (Web Mercator metres, `unit` a
/// step from the world's corner). The tiles' own vertices lie on it up to GDAL's rounding, and
/// clip points on tile edges, which are grid lines: afterwards the pieces of one feature share
/// their common edges exactly, and their union leaves no sliver along a tile edge.
void snapToGrid(OGRGeometry& geometry, double unit) {
  constexpr double kHalfWorld = std::numbers::pi * 6378137.0;
  auto snap = [unit](double v) { return std::round((v + kHalfWorld) / unit) * unit - kHalfWorld; };
  auto curve = [&](OGRSimpleCurve& c) {
    for (int i = 0; i < c.getNumPoints(); ++i) c.setPoint(i, snap(c.getX(i)), snap(c.getY(i)));
  };
  if (auto* c = dynamic_cast<OGRSimpleCurve*>(&geometry); c != nullptr) {
    curve(*c);
  } else if (auto* polygon = dynamic_cast<OGRPolygon*>(&geometry); polygon != nullptr) {
    for (OGRLinearRing* ring : *polygon) curve(*ring);
  } else if (auto* collection = dynamic_cast<OGRGeometryCollection*>(&geometry); collection != nullptr) {
    for (OGRGeometry* part : *collection) snapToGrid(*part, unit);
  }
}

}  // namespace

std::vector<FeaturePtr> stitchedTileFeatures(OGRLayer& layer, int zoom, std::size_t& unitedFailures) {
  const double unit = 2.0 * std::numbers::pi * 6378137.0 / (std::ldexp(1.0, zoom) * 4096.0);
  unitedFailures = 0;
  const int idField = layer.GetLayerDefn()->GetFieldIndex("mvt_id");
  struct Group {
    FeaturePtr first;
    std::vector<std::unique_ptr<OGRGeometry>> pieces;
  };
  std::map<std::int64_t, Group> groups;
  std::vector<FeaturePtr> alone;  // no mvt_id: as they come
  layer.ResetReading();
  for (FeaturePtr f(layer.GetNextFeature()); f; f.reset(layer.GetNextFeature())) {
    if (idField < 0 || !f->IsFieldSetAndNotNull(idField)) {
      alone.push_back(std::move(f));
      continue;
    }
    Group& g = groups[f->GetFieldAsInteger64(idField)];
    if (OGRGeometry* geometry = f->StealGeometry(); geometry != nullptr) {
      snapToGrid(*geometry, unit);
      g.pieces.emplace_back(geometry);
    }
    if (!g.first) g.first = std::move(f);
  }
  std::vector<FeaturePtr> out;
  out.reserve(groups.size() + alone.size());
  for (auto& [id, g] : groups) {
    FeaturePtr f = std::move(g.first);
    f->SetFID(id);
    bool polygons = false, lines = false;
    for (const auto& piece : g.pieces) {
      const OGRwkbGeometryType t = wkbFlatten(piece->getGeometryType());
      polygons = polygons || t == wkbPolygon || t == wkbMultiPolygon;
      lines = lines || t == wkbLineString || t == wkbMultiLineString;
    }
    if (g.pieces.size() == 1 || (polygons == lines)) {
      // One piece, or nothing to stitch (points, or a mix: the reader says what it cannot use).
      if (g.pieces.size() == 1) {
        f->SetGeometryDirectly(g.pieces.front().release());
      } else {
        auto collection = std::make_unique<OGRGeometryCollection>();
        for (auto& piece : g.pieces) collection->addGeometryDirectly(piece.release());
        f->SetGeometryDirectly(collection.release());
      }
      out.push_back(std::move(f));
      continue;
    }
    std::unique_ptr<OGRGeometryCollection> parts;
    if (polygons) {
      parts = std::make_unique<OGRMultiPolygon>();
    } else {
      parts = std::make_unique<OGRMultiLineString>();
    }
    for (auto& piece : g.pieces) {
      if (const auto* multi = dynamic_cast<const OGRGeometryCollection*>(piece.get()); multi != nullptr) {
        for (const OGRGeometry* part : *multi) parts->addGeometry(part);
      } else {
        parts->addGeometry(piece.get());
      }
    }
    if (polygons) {
      std::unique_ptr<OGRGeometry> united(parts->UnionCascaded());
      if (united && !united->IsEmpty()) {
        f->SetGeometryDirectly(united.release());
        out.push_back(std::move(f));
        continue;
      }
      ++unitedFailures;
    }
    f->SetGeometryDirectly(parts.release());
    out.push_back(std::move(f));
  }
  for (FeaturePtr& f : alone) out.push_back(std::move(f));
  return out;
}

}  // namespace gis::geo::detail
