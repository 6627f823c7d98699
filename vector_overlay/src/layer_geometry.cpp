#include "vector_overlay/layer_geometry.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>
#include <unordered_map>
#include <variant>

#include <unistd.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include "core/hash.hpp"
#include "footprint_geometry.hpp"
#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"
#include "vector_overlay/pieces_fingerprint.hpp"
#include "vector_overlay/validation.hpp"

namespace gis::overlay {
namespace {

std::string attributeText(const geo::AttributeValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return std::to_string(*i);
  if (const auto* d = std::get_if<double>(&v)) {
    std::ostringstream out;
    out << *d;
    return out.str();
  }
  if (const auto* s = std::get_if<std::string>(&v)) return *s;
  return {};
}

std::optional<double> attributeNumber(const geo::AttributeValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* s = std::get_if<std::string>(&v)) {
    try {
      std::size_t used = 0;
      const double x = std::stod(*s, &used);
      if (used == s->size()) return x;
    } catch (...) {
    }
  }
  return std::nullopt;
}

std::uint8_t unorm8(float v) { return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0F, 1.0F) * 255.0F)); }

constexpr double kOriginGrid = 1024.0;  ///< metres: vertices are floats relative to an origin near them

}  // namespace

namespace {

/// Feature f's style (resolveFeatureStyles).
FeatureStyle resolveStyle(const LayerStyle& style, LayerKind kind, const geo::Feature& f, Diagnostics* diagnostics,
                          const std::string& layerName, bool minWidthInPixels) {
  {
    FeatureStyle s;
    glm::vec4 colour = style.color;
    if (!style.colorAttribute.empty()) {
      const auto a = f.attributes.find(style.colorAttribute);
      if (a != f.attributes.end()) {
        const auto c = style.categories.find(attributeText(a->second));
        if (c != style.categories.end()) colour = c->second;
      }
    }
    s.color = glm::vec4(colour.x, colour.y, colour.z, colour.w * style.opacity);
    if (kind == LayerKind::Line && style.widthPixels > 0.0) {
      s.shape.width = style.widthCap();
      s.shape.widthPixels = style.widthPixels;
    } else if (kind == LayerKind::Line) {
      s.shape.width = style.widthMetres;
      if (!style.widthAttribute.empty()) {
        const auto a = f.attributes.find(style.widthAttribute);
        if (a != f.attributes.end() && !std::holds_alternative<std::monostate>(a->second)) {
          if (const std::optional<double> w = attributeNumber(a->second); w && *w > 0.0 && std::isfinite(*w)) {
            s.shape.width = *w;
          } else if (diagnostics != nullptr) {
            std::ostringstream message;
            message << "'" << style.widthAttribute << "' = '" << attributeText(a->second)
                    << "' is not a positive number of metres; drawn " << style.widthMetres
                    << " m wide (the layer's width)";
            diagnostics->add(detail::featureError(Severity::Warning, layerName, f.fid, message.str()));
          }
        }
      }
      s.shape.join = style.join;
      s.shape.cap = style.cap;
      s.shape.miterLimit = style.miterLimit;
      if (minWidthInPixels && style.minWidthPixels > 0.0 && style.join == LineJoin::Round &&
          style.cap == LineCap::Round) {
        // At least minWidthPixels on screen: the width in metres becomes the least width. Round
        // joins and caps only: a miter, bevel or square end reaches a width-dependent distance
        // beyond the round footprint, which generalisation may move (lineShapeSlack) by more
        // than half a pixel once the width is a pixel.
        s.shape.minWidth = s.shape.width;
        s.shape.widthPixels = style.minWidthPixels;
        s.shape.width = std::max(s.shape.width, style.widthCap());
      }
    }
    return s;
  }
}

}  // namespace

std::vector<FeatureStyle> resolveFeatureStyles(const LayerStyle& style, LayerKind kind,
                                               const std::vector<geo::Feature>& features, Diagnostics* diagnostics,
                                               const std::string& layerName, bool minWidthInPixels) {
  std::vector<FeatureStyle> out;
  out.reserve(features.size());
  for (const geo::Feature& f : features)
    out.push_back(resolveStyle(style, kind, f, diagnostics, layerName, minWidthInPixels));
  return out;
}

std::vector<FeatureStyle> resolveFeatureStyles(const LayerStyle& style, LayerKind kind, const SharedFeatures& features,
                                               Diagnostics* diagnostics, const std::string& layerName,
                                               bool minWidthInPixels) {
  if (!features.onDisk())
    return resolveFeatureStyles(style, kind, features.all(), diagnostics, layerName, minWidthInPixels);
  const bool attributes = !style.colorAttribute.empty() ||
                          (kind == LayerKind::Line && style.widthPixels <= 0.0 && !style.widthAttribute.empty());
  std::vector<FeatureStyle> out;
  out.reserve(features.size());
  if (!attributes) {
    // Every feature alike: nothing to read.
    out.assign(features.size(), resolveStyle(style, kind, geo::Feature{}, diagnostics, layerName, minWidthInPixels));
    return out;
  }
  for (std::size_t i = 0; i < features.size(); ++i)
    out.push_back(resolveStyle(style, kind, *features.get(i), diagnostics, layerName, minWidthInPixels));
  return out;
}

void assignAnchorHeights(FeatureStyle& style, const geo::Feature& feature, const HeightBoundsProvider& bounds) {
  if (!style.shape.inPixels()) return;
  const HeightBounds global = bounds.globalBounds();
  style.shape.anchorHeights.assign(feature.lines.size(), {});
  for (std::size_t k = 0; k < feature.lines.size(); ++k) {
    for (const glm::dvec2& p : feature.lines[k]) {
      const glm::dvec2 point[1] = {p};
      const HeightBounds b = bounds.boundsOver(point);
      const bool usable = b.valid() && std::isfinite(b.lo) && std::isfinite(b.hi);
      const double mid = usable ? 0.5 * (b.lo + b.hi) : 0.5 * (global.lo + global.hi);
      style.shape.anchorHeights[k].push_back(std::isfinite(mid) ? mid : 0.0);
    }
  }
}

namespace {

/// The footprint extruded between its bounds (the global bounds where it has none).
Polyhedron extrude(Footprint f, const HeightBoundsProvider& bounds, double slack) {
  Polyhedron p;
  p.boxMin = glm::dvec2(std::numeric_limits<double>::infinity());
  p.boxMax = -p.boxMin;
  for (const glm::dvec2& v : f.vertices) {
    p.boxMin = glm::min(p.boxMin, v);
    p.boxMax = glm::max(p.boxMax, v);
  }
  const HeightBounds b = slack > 0.0 ? bounds.boundsOverWithin(f.vertices, slack) : bounds.boundsOver(f.vertices);
  p.lo = b.lo;
  p.hi = b.hi;
  if (!b.valid() || !std::isfinite(b.lo) || !std::isfinite(b.hi)) {
    const HeightBounds g = bounds.globalBounds();
    p.lo = g.lo;
    p.hi = g.hi;
  }
  p.overSurface = bounds.coversFootprint(f.vertices);
  p.footprint = std::move(f);
  return p;
}

/// Length of a footprint's boundary (its walls' length).
double perimeter(const Footprint& f) {
  double length = 0.0;
  for (const auto& e : f.boundary) length += glm::length(f.vertices[e[1]] - f.vertices[e[0]]);
  return length;
}

/// Where the parts of one shape (cut at the cells) would have walls of more than `splitGain` of
/// the area the whole shape's walls have (1 m added to every height range, for the padding and
/// the per-piece cost), the parts are welded back into one piece under their joint bounds. The
/// union of the parts is the same region, and joint bounds hold every part's surface, so the
/// bounds contract holds either way.
std::vector<Polyhedron> mergeWhereSplitDoesNotPay(std::vector<Polyhedron> pieces, const LayerBuildOptions& options,
                                                  std::vector<Footprint> wholeShapes) {
  // The shapes unsplit, by source, where they lie inside the grid (then a shape is exactly the
  // union of its parts, with fewer triangles and walls than the parts welded together).
  const CellGrid& grid = *options.footprints.cells;
  const glm::dvec2 gridMin = grid.origin, gridMax = grid.origin + grid.cellSize * glm::dvec2(grid.columns, grid.rows);
  std::unordered_map<std::uint32_t, Footprint> whole;
  for (Footprint& f : wholeShapes) {
    bool inside = !f.triangles.empty();
    for (const glm::dvec2& v : f.vertices)
      inside = inside && glm::all(glm::greaterThanEqual(v, gridMin)) && glm::all(glm::lessThanEqual(v, gridMax));
    if (inside) whole.emplace(f.source, std::move(f));
  }
  std::vector<Polyhedron> out;
  out.reserve(pieces.size());
  for (std::size_t first = 0; first < pieces.size();) {
    std::size_t last = first + 1;
    while (last < pieces.size() && pieces[last].footprint.source == pieces[first].footprint.source &&
           !pieces[last].footprint.scalable())
      ++last;
    if (last - first == 1 || pieces[first].footprint.scalable()) {
      out.push_back(std::move(pieces[first]));
      first = last;
      continue;
    }
    detail::FootprintBuilder builder;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, splitWalls = 0.0;
    bool overSurface = true;
    for (std::size_t k = first; k < last; ++k) {
      const Polyhedron& p = pieces[k];
      lo = std::min(lo, p.lo);
      hi = std::max(hi, p.hi);
      overSurface = overSurface && p.overSurface;
      splitWalls += perimeter(p.footprint) * (p.hi - p.lo + 1.0);
      const Footprint& f = p.footprint;
      for (const auto& t : f.triangles) builder.addTriangle(f.vertices[t[0]], f.vertices[t[1]], f.vertices[t[2]]);
    }
    const auto unsplit = whole.find(pieces[first].footprint.source);
    Footprint merged;
    if (unsplit != whole.end()) {
      merged = std::move(unsplit->second);
      merged.cell = -1;
    } else {
      merged = builder.finish(pieces[first].footprint.feature, -1, pieces[first].footprint.kind);
      merged.source = pieces[first].footprint.source;
    }
    const double wholeWalls = perimeter(merged) * (hi - lo + 1.0);
    if (splitWalls < options.splitGain * wholeWalls || merged.triangles.empty()) {
      for (std::size_t k = first; k < last; ++k) out.push_back(std::move(pieces[k]));
    } else {
      Polyhedron p;
      p.boxMin = glm::dvec2(std::numeric_limits<double>::infinity());
      p.boxMax = -p.boxMin;
      for (std::size_t k = first; k < last; ++k) {
        p.boxMin = glm::min(p.boxMin, pieces[k].boxMin);
        p.boxMax = glm::max(p.boxMax, pieces[k].boxMax);
      }
      p.lo = lo;
      p.hi = hi;
      p.overSurface = overSurface;
      p.footprint = std::move(merged);
      out.push_back(std::move(p));
    }
    first = last;
  }
  return out;
}

/// Whether the feature's box (widened by a line's half width) misses the grid's extent.
bool outsideGrid(const geo::Feature& feature, LayerKind kind, const FeatureStyle& style, const CellGrid& g) {
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  auto add = [&](const glm::dvec2& v) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  };
  for (const geo::Polygon& polygon : feature.polygons) std::for_each(polygon.outer.begin(), polygon.outer.end(), add);
  for (const geo::LineString& line : feature.lines) std::for_each(line.begin(), line.end(), add);
  const double reach =
      kind == LayerKind::Line ? 0.5 * (style.shape.minWidth > 0.0 ? style.shape.minWidth : style.shape.width) : 0.0;
  const glm::dvec2 gridMax = g.origin + g.cellSize * glm::dvec2(g.columns, g.rows);
  return hi.x + reach < g.origin.x || hi.y + reach < g.origin.y || lo.x - reach > gridMax.x || lo.y - reach > gridMax.y;
}

/// A Warning saying why a feature that is not broken gives nothing to draw, so that nothing
/// vanishes silently.
void reportNothingToDraw(const geo::Feature& feature, LayerKind kind, const FeatureStyle& style,
                         const FootprintOptions& fo, const std::string& layerName, Diagnostics& diagnostics) {
  const bool hasGeometry = kind == LayerKind::Polygon ? !feature.polygons.empty() : !feature.lines.empty();
  const char* what = kind == LayerKind::Polygon ? "polygon" : "line";
  std::string why = std::string("has no ") + what + " geometry: nothing to draw";
  if (hasGeometry) {
    why = "has no area to draw (a single point with flat caps?)";
    if (fo.cells && outsideGrid(feature, kind, style, *fo.cells)) why = "lies outside the terrain: nothing to draw";
  }
  diagnostics.add(detail::featureError(Severity::Warning, layerName, feature.fid, why));
}

}  // namespace

FeatureOutcome checkFeature(const geo::Feature& feature, std::uint32_t featureIndex, LayerKind kind,
                            const FeatureStyle& style, const std::string& layerName, const LayerBuildOptions& options,
                            Diagnostics& diagnostics) {
  // The footprints without cells (no clipping, no bounds): the same problems as a build finds.
  FootprintOptions fo = options.footprints;
  fo.cells.reset();
  fo.uniteLines = false;
  // Arcs with the fewest chords: their shapes, not their smoothness, decide what is drawn.
  fo.chordTolerance = 1e30;
  fo.chordTolerancePixels = 1e30;
  const std::size_t errorsBefore = diagnostics.count(Severity::Error);
  // A line with a least width in pixels is checked at that width in metres: its widths per frame
  // change no problem a build finds, and pieces of the largest width cost far more to make.
  LineShape shape = style.shape;
  if (shape.inPixels() && shape.minWidth > 0.0) {
    shape.width = shape.minWidth;
    shape.widthPixels = shape.minWidth = 0.0;
  }
  // Polygons: their rings checked and repaired as a build would, not triangulated (a 300 k
  // vertex coastline takes seconds; a triangulation that fails, which no input has made yet,
  // is reported when a tile first builds the polygon).
  bool nothing = false;
  if (kind == LayerKind::Polygon) {
    nothing = usablePolygons(feature, layerName, diagnostics).empty();
  } else {
    const std::vector<Footprint> footprints = lineFootprints(feature, featureIndex, layerName, shape, fo, diagnostics);
    nothing = std::none_of(footprints.begin(), footprints.end(),
                           [](const Footprint& f) { return !f.triangles.empty() && !f.vertices.empty(); });
  }
  if (diagnostics.count(Severity::Error) > errorsBefore && nothing) return FeatureOutcome::Skipped;
  const bool outside = options.footprints.cells && outsideGrid(feature, kind, style, *options.footprints.cells);
  if (nothing || outside) {
    reportNothingToDraw(feature, kind, style, options.footprints, layerName, diagnostics);
    return FeatureOutcome::NothingToDraw;
  }
  return FeatureOutcome::Drawn;
}

std::vector<Polyhedron> buildPolyhedra(const geo::Feature& feature, std::uint32_t featureIndex, LayerKind kind,
                                       const FeatureStyle& style, const std::string& layerName,
                                       const HeightBoundsProvider& bounds, const LayerBuildOptions& options,
                                       Diagnostics& diagnostics) {
  FootprintOptions fo = options.footprints;
  if (options.paperVariant) {
    fo.cells.reset();
    fo.uniteLines = false;  // the seed paper's pieces: one per segment, join and cap
  }
  const std::size_t errorsBefore = diagnostics.count(Severity::Error);
  std::vector<Footprint> footprints =
      kind == LayerKind::Polygon ? polygonFootprints(feature, featureIndex, layerName, fo, diagnostics)
                                 : lineFootprints(feature, featureIndex, layerName, style.shape, fo, diagnostics);
  const bool nothing = std::none_of(footprints.begin(), footprints.end(),
                                    [](const Footprint& f) { return !f.triangles.empty() && !f.vertices.empty(); });
  if (nothing && options.reportEmpty && diagnostics.count(Severity::Error) == errorsBefore)
    reportNothingToDraw(feature, kind, style, fo, layerName, diagnostics);
  std::vector<Polyhedron> out;
  out.reserve(footprints.size());
  HeightBounds featureBounds{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (Footprint& f : footprints) {
    if (f.triangles.empty() || f.vertices.empty()) continue;
    Polyhedron p = extrude(std::move(f), bounds, options.boundsSlack);
    featureBounds.lo = std::min(featureBounds.lo, p.lo);
    featureBounds.hi = std::max(featureBounds.hi, p.hi);
    out.push_back(std::move(p));
  }
  if (options.adaptiveSplit && fo.cells && !options.paperVariant) {
    // The same shapes unsplit (their problems were reported above).
    FootprintOptions unsplit = fo;
    unsplit.cells.reset();
    Diagnostics repeated;
    std::vector<Footprint> whole =
        kind == LayerKind::Polygon ? polygonFootprints(feature, featureIndex, layerName, unsplit, repeated)
                                   : lineFootprints(feature, featureIndex, layerName, style.shape, unsplit, repeated);
    out = mergeWhereSplitDoesNotPay(std::move(out), options, std::move(whole));
  }
  if (options.paperVariant) {
    // One bound pair per feature, as the seed paper builds them.
    for (Polyhedron& p : out) {
      p.lo = featureBounds.lo;
      p.hi = featureBounds.hi;
    }
  }
  return out;
}

bool mayContain(const Polyhedron& p, const glm::dvec3& point, double pad, double margin) {
  if (point.z < p.lo - pad - margin || point.z > p.hi + pad + margin) return false;
  const glm::dvec2 q(point);
  if (q.x < p.boxMin.x - margin || q.y < p.boxMin.y - margin || q.x > p.boxMax.x + margin ||
      q.y > p.boxMax.y + margin) {
    return false;
  }
  // Inside the footprint: inside one of its triangles, or within margin of one (a released
  // footprint, LayerGeometry::releaseFootprints: anywhere in the box).
  const Footprint& f = p.footprint;
  if (f.triangles.empty()) return true;
  for (const auto& t : f.triangles) {
    const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], c = f.vertices[t[2]];
    auto edge = [&](const glm::dvec2& u, const glm::dvec2& v) {
      // Signed distance of q to the line u→v, positive on the left (inside for a CCW triangle).
      const glm::dvec2 d = v - u;
      const double len = glm::length(d);
      if (len == 0.0) return std::numeric_limits<double>::infinity();
      return (d.x * (q.y - u.y) - d.y * (q.x - u.x)) / len;
    };
    if (edge(a, b) >= -margin && edge(b, c) >= -margin && edge(c, a) >= -margin) return true;
  }
  return false;
}

void GeometryChange::add(std::size_t v0, std::size_t v1, std::size_t i0, std::size_t i1) {
  if (v0 < v1) {
    vertexBegin = std::min(vertexBegin, v0);
    vertexEnd = std::max(vertexEnd, v1);
  }
  if (i0 < i1) {
    indexBegin = std::min(indexBegin, i0);
    indexEnd = std::max(indexEnd, i1);
  }
}

void LayerGeometry::releaseArrays() {
  arraysInFile_.reset();
  vertices_ = {};
  indices_ = {};
  scaling_ = {};
  normals_ = {};
  changes_ = GeometryChange{};
  arraysReleased_ = true;
  // World pieces are clipped at the near plane from these arrays: without them, as without a
  // projected frame's footprints, the layer's pieces cannot be drawn z-fail.
  if (alongNormals()) footprintsReleased_ = true;
}

void LayerGeometry::releaseFootprints() {
  releaseArrays();
  const auto free = [](auto& v) { std::decay_t<decltype(v)>().swap(v); };
  for (Polyhedron& p : polyhedra_) {
    free(p.footprint.vertices);
    free(p.footprint.triangles);
    free(p.footprint.boundary);
    free(p.footprint.centres);
    free(p.footprint.directions);
  }
  // The features' geometry too (their fids stay, for messages): a released layer is built again
  // before it is edited.
  std::vector<geo::Feature> bare(features_.size());
  for (std::size_t i = 0; i < bare.size(); ++i) bare[i].fid = features_[i].fid;
  features_ = SharedFeatures(std::move(bare));
  footprintsReleased_ = true;
}

namespace {

constexpr std::uint32_t kChecksMagic = 0x4B484353;  // "SCHK"

/// The checks of a deferred layer's features as written by writeChecks, if `file` holds as
/// many as `outcomes` has and is whole (its checksum verified first). `damage` says why a file
/// that is there was not used (its name says what it holds: any that fails is damaged).
bool readChecks(const std::filesystem::path& file, std::vector<FeatureOutcome>& outcomes,
                std::vector<Diagnostics>& found, std::string& damage) {
  geo::io::CheckedStatus status = geo::io::CheckedStatus::Missing;
  std::string why;
  const std::shared_ptr<const geo::io::CheckedFile> checked = geo::io::CheckedFile::open(file, status, why);
  if (!checked) {
    if (status == geo::io::CheckedStatus::Damaged) damage = why;
    return false;
  }
  const std::optional<std::string> bytes = checked->sections() == 1 ? checked->read(0) : std::nullopt;
  const auto damaged = [&](const std::string& what) {
    damage = what;
    return false;
  };
  if (!bytes) return damaged("its checks do not match their checksum");
  std::istringstream in(*bytes);
  geo::io::Reader r(in);
  std::uint32_t magic = 0;
  std::vector<FeatureOutcome> read;
  if (!r.value(magic) || magic != kChecksMagic || !r.array(read) || read.size() != outcomes.size())
    return damaged("its checks are not this layer's");
  std::vector<Diagnostics> messages(read.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    if (static_cast<std::uint8_t>(read[i]) > static_cast<std::uint8_t>(FeatureOutcome::Hidden))
      return damaged("its checks cannot be read");
    std::size_t n = 0;
    if (!r.count(n, 33)) return damaged("its checks cannot be read");  // severity and four texts' lengths
    for (std::size_t k = 0; k < n; ++k) {
      Diagnostic d;
      std::uint8_t severity = 0;
      if (!r.value(severity) || severity > static_cast<std::uint8_t>(Severity::Error) || !r.text(d.file) ||
          !r.text(d.layer) || !r.text(d.feature) || !r.text(d.message))
        return damaged("its checks cannot be read");
      d.severity = static_cast<Severity>(severity);
      messages[i].add(std::move(d));
    }
  }
  if (!r.value(magic) || magic != kChecksMagic) return damaged("its checks cannot be read");
  outcomes = std::move(read);
  found = std::move(messages);
  return true;
}

/// Writes the checks (to a temporary file renamed into place); false when it cannot.
bool writeChecks(const std::filesystem::path& file, const std::vector<FeatureOutcome>& outcomes,
                 const std::vector<Diagnostics>& found) {
  return geo::io::writeCheckedFile(file,
                                   [&](std::ostream& out, geo::io::SectionMarks& marks) {
                                     geo::io::Writer w(out);
                                     marks.begin();
                                     w.value(kChecksMagic);
                                     w.array(outcomes);
                                     for (const Diagnostics& d : found) {
                                       w.value(static_cast<std::uint64_t>(d.items().size()));
                                       for (const Diagnostic& m : d.items()) {
                                         w.value(static_cast<std::uint8_t>(m.severity));
                                         w.text(m.file);
                                         w.text(m.layer);
                                         w.text(m.feature);
                                         w.text(m.message);
                                       }
                                     }
                                     w.value(kChecksMagic);
                                   })
      .written;
}

/// The seed paper's construction draws each piece's box with this many indices (addPieces).
constexpr std::uint64_t kBoxIndices = 36;

/// A coordinate or height as validation accepts it (ValidationOptions::maxCoordinate).
bool bounded(double v) { return std::isfinite(v) && std::abs(v) <= 1e15; }

/// A piece as a lean layer keeps it: all but the footprint's arrays.
struct LeanPiece {
  std::uint32_t feature = 0;
  std::int32_t cell = -1;
  std::uint32_t source = 0;
  std::uint8_t kind = 0;
  std::uint8_t overSurface = 0;
  double lo = 0.0, hi = 0.0;
  glm::dvec2 boxMin{0.0}, boxMax{0.0};
};

}  // namespace

namespace {

/// The pieces' vertices hold each feature's colour. A layer of one colour is drawn with it as a
/// uniform (LayerGeometry::uniformColor), so only colours that differ between features (by
/// category) are part of what cached pieces depend on; a one-colour layer's hash is unchanged.
void addFeatureColours(StableHasher& h, const std::vector<FeatureStyle>& styles) {
  const auto rgba = [](const FeatureStyle& st) {
    return (std::uint64_t{unorm8(st.color.x)} << 24U) | (std::uint64_t{unorm8(st.color.y)} << 16U) |
           (std::uint64_t{unorm8(st.color.z)} << 8U) | std::uint64_t{unorm8(st.color.w)};
  };
  const bool uniform = std::all_of(styles.begin(), styles.end(),
                                   [&](const FeatureStyle& st) { return rgba(st) == rgba(styles.front()); });
  if (uniform) return;
  h.add(std::string_view("colours by feature"));
  for (const FeatureStyle& st : styles) h.add(rgba(st));
}

}  // namespace

std::uint64_t coloursFingerprint(std::span<const glm::vec4> colours) {
  std::vector<FeatureStyle> styles(colours.size());
  for (std::size_t i = 0; i < colours.size(); ++i) styles[i].color = colours[i];
  if (styles.empty()) return 0;
  StableHasher h;
  addFeatureColours(h, styles);
  StableHasher none;
  return h.value() == none.value() ? 0 : h.value();
}

std::uint64_t featuresFingerprint(const SharedFeatures& features, const std::vector<FeatureStyle>& styles,
                                  LayerKind kind) {
  if (!features.onDisk()) return featuresFingerprint(features.all(), styles, kind);
  StableHasher h;
  h.add(std::string_view("features on disk"));
  h.add(features.fileContent());
  h.add(static_cast<std::uint64_t>(kind));
  h.add(static_cast<std::uint64_t>(features.size()));
  for (std::size_t i = 0; i < features.size() && i < styles.size(); ++i) {
    const FeatureStyle& st = styles[i];
    h.add(static_cast<std::uint64_t>(st.visible ? 1 : 0));
    for (const double v : {st.shape.width, st.shape.miterLimit, st.shape.widthPixels, st.shape.minWidth}) h.add(v);
    h.add(static_cast<std::uint64_t>(st.shape.join) * 8U + static_cast<std::uint64_t>(st.shape.cap));
  }
  addFeatureColours(h, styles);
  return h.value();
}

std::uint64_t featuresFingerprint(const std::vector<geo::Feature>& features, const std::vector<FeatureStyle>& styles,
                                  LayerKind kind) {
  StableHasher h;
  h.add(static_cast<std::uint64_t>(kind));
  h.add(static_cast<std::uint64_t>(features.size()));
  for (std::size_t i = 0; i < features.size(); ++i) {
    const geo::Feature& f = features[i];
    const FeatureStyle& st = styles[i];
    h.add(static_cast<std::uint64_t>(st.visible ? 1 : 0));
    h.add(static_cast<std::uint64_t>(f.fid));
    for (const double v : {st.shape.width, st.shape.miterLimit, st.shape.widthPixels, st.shape.minWidth}) h.add(v);
    h.add(static_cast<std::uint64_t>(st.shape.join) * 8U + static_cast<std::uint64_t>(st.shape.cap));
    const auto points = [&h](const std::vector<glm::dvec2>& ps) {
      h.add(static_cast<std::uint64_t>(ps.size()));
      for (const glm::dvec2& p : ps) {
        h.add(p.x);
        h.add(p.y);
      }
    };
    h.add(static_cast<std::uint64_t>(f.polygons.size()));
    for (const geo::Polygon& p : f.polygons) {
      points(p.outer);
      h.add(static_cast<std::uint64_t>(p.holes.size()));
      for (const geo::Ring& r : p.holes) points(r);
    }
    h.add(static_cast<std::uint64_t>(f.lines.size()));
    for (const geo::LineString& l : f.lines) points(l);
  }
  addFeatureColours(h, styles);
  return h.value();
}

void LayerGeometry::writeLean(geo::io::Writer& w) const {
  std::vector<std::int64_t> fids(features_.size());
  for (std::size_t i = 0; i < fids.size(); ++i) fids[i] = features_[i].fid;
  w.array(fids);
  w.array(outcomes_);
  for (const std::vector<std::uint32_t>& f : featureSlots_) w.array(f);
  w.array(slots_);
  std::vector<LeanPiece> pieces(polyhedra_.size());
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const Polyhedron& p = polyhedra_[k];
    pieces[k] = {p.footprint.feature,
                 p.footprint.cell,
                 p.footprint.source,
                 static_cast<std::uint8_t>(p.footprint.kind),
                 static_cast<std::uint8_t>(p.overSurface ? 1 : 0),
                 p.lo,
                 p.hi,
                 p.boxMin,
                 p.boxMax};
  }
  w.array(pieces);
  w.array(origins_);
  // World pieces (ofWorldPieces): their origins and their lines' widths in pixels; none else.
  w.array(worldOrigins_);
  w.value(alongNormals() ? style_.widthPixels : 0.0);
  w.value(alongNormals() ? style_.maxWidthMetres : 0.0);
  w.array(vertices_);
  w.array(indices_);
  w.array(scaling_);
  w.array(normals_);
  w.value(static_cast<std::uint64_t>(wastedIndices_));
  w.value(stats_);
}

ArraysInFile::~ArraysInFile() {
  if (fd_ >= 0) ::close(fd_);
}

bool ArraysInFile::read(std::uint64_t at, std::uint64_t bytes,
                        const std::function<void(const void*, std::uint64_t, std::uint64_t)>& slice,
                        std::size_t sliceBytes) const {
  std::vector<char> buffer(
      static_cast<std::size_t>(std::min<std::uint64_t>(bytes, std::max<std::size_t>(sliceBytes, 1))));
  for (std::uint64_t done = 0; done < bytes;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buffer.size(), bytes - done));
    std::size_t got = 0;
    while (got < n) {
      const ssize_t k = ::pread(fd_, buffer.data() + got, n - got, static_cast<off_t>(at + done + got));
      if (k < 0 && errno == EINTR) continue;
      if (k <= 0) return false;
      got += static_cast<std::size_t>(k);
    }
    slice(buffer.data(), done, n);
    done += n;
  }
  return true;
}

std::optional<LayerGeometry> LayerGeometry::readLean(geo::io::Reader& r, std::string name, LayerKind kind,
                                                     const LayerStyle& style, std::vector<FeatureStyle> styles,
                                                     const HeightBoundsProvider& bounds,
                                                     const LayerBuildOptions& options,
                                                     std::shared_ptr<ArraysInFile> arrays) {
  std::vector<std::int64_t> fids;
  if (!r.array(fids) || fids.size() != styles.size()) return std::nullopt;
  std::vector<geo::Feature> bare(fids.size());
  for (std::size_t i = 0; i < fids.size(); ++i) bare[i].fid = fids[i];
  LayerGeometry layer = empty(std::move(name), kind, style, std::move(bare), std::move(styles), &bounds, options);
  if (!readLeanInto(r, layer, false, std::move(arrays))) return std::nullopt;
  return layer;
}

std::optional<LayerGeometry> LayerGeometry::readWorldLean(geo::io::Reader& r, std::string name,
                                                          std::vector<FeatureStyle> groupStyles,
                                                          std::shared_ptr<ArraysInFile> arrays) {
  std::vector<std::int64_t> fids;
  if (!r.array(fids) || fids.size() != groupStyles.size()) return std::nullopt;
  std::vector<geo::Feature> bare(fids.size());
  for (std::size_t i = 0; i < fids.size(); ++i) bare[i].fid = fids[i];
  LayerGeometry layer =
      empty(std::move(name), LayerKind::Polygon, {}, std::move(bare), std::move(groupStyles), nullptr, {});
  if (!readLeanInto(r, layer, true, std::move(arrays))) return std::nullopt;
  return layer;
}

bool LayerGeometry::readLeanInto(geo::io::Reader& r, LayerGeometry& layer, bool world,
                                 std::shared_ptr<ArraysInFile> arrays) {
  const std::size_t featureCount = layer.features_.size();
  const LayerBuildOptions& options = layer.options_;
  std::vector<LeanPiece> pieces;
  std::uint64_t wasted = 0;
  if (!r.array(layer.outcomes_) || layer.outcomes_.size() != featureCount) return false;
  layer.featureSlots_.resize(featureCount);
  for (std::vector<std::uint32_t>& f : layer.featureSlots_)
    if (!r.array(f)) return false;
  double worldWidthPixels = 0.0, worldMaxWidth = 0.0;
  if (!r.array(layer.slots_) || !r.array(pieces) || !r.array(layer.origins_) || !r.array(layer.worldOrigins_) ||
      !r.value(worldWidthPixels) || !r.value(worldMaxWidth))
    return false;
  // World pieces where the caller expects them, and only there: their origins, none of a plane's,
  // and their lines' widths numbers a builder writes.
  if (world != !layer.worldOrigins_.empty()) return false;
  if (world) {
    if (!layer.origins_.empty() || !std::isfinite(worldWidthPixels) || worldWidthPixels < 0.0 ||
        !bounded(worldMaxWidth) || worldMaxWidth < 0.0)
      return false;
    for (const glm::dvec3& o : layer.worldOrigins_)
      if (!bounded(o.x) || !bounded(o.y) || !bounded(o.z)) return false;
    if (worldWidthPixels > 0.0) {
      layer.kind_ = LayerKind::Line;
      layer.style_.widthPixels = worldWidthPixels;
      layer.style_.maxWidthMetres = worldMaxWidth;
    }
  }
  if (arrays) {
    if (!r.skipArray(arrays->vertexCount, sizeof(Vertex), arrays->verticesAt) ||
        !r.skipArray(arrays->indexCount, sizeof(std::uint32_t), arrays->indicesAt) ||
        !r.skipArray(arrays->scalingCount, sizeof(glm::vec4), arrays->scalingAt) ||
        !r.skipArray(arrays->normalsCount, sizeof(glm::vec4), arrays->normalsAt))
      return false;
  } else if (!r.array(layer.vertices_) || !r.array(layer.indices_) || !r.array(layer.scaling_) ||
             !r.array(layer.normals_)) {
    return false;
  }
  if (!r.value(wasted) || !r.value(layer.stats_)) return false;
  // Nothing a damaged file holds may index out of bounds.
  const std::size_t slots = layer.slots_.size();
  const std::size_t vertices = arrays ? arrays->vertexCount : layer.vertices_.size();
  const std::size_t indexCount = arrays ? arrays->indexCount : layer.indices_.size();
  const std::size_t scalingCount = arrays ? arrays->scalingCount : layer.scaling_.size();
  const std::size_t normalsCount = arrays ? arrays->normalsCount : layer.normals_.size();
  // Lines in pixels draw a scaling per vertex, world pieces a normal; other layers none (the
  // upload copies what this says into buffers the shader reads per vertex).
  if (pieces.size() != slots || scalingCount != (layer.widthPixels() > 0.0 ? vertices : 0) ||
      normalsCount != (world ? vertices : 0))
    return false;
  const std::size_t originCount = world ? layer.worldOrigins_.size() : layer.origins_.size();
  for (std::size_t i = 0; i < featureCount; ++i) {
    if (static_cast<std::uint8_t>(layer.outcomes_[i]) > static_cast<std::uint8_t>(FeatureOutcome::Hidden)) return false;
    for (const std::uint32_t k : layer.featureSlots_[i])
      if (k >= slots) return false;
  }
  // A flag read as bytes is a bool only if it is 0 or 1 (looked at as a byte, never as a bool).
  layer.stats_.checksFromCache = false;
  for (PieceSlot& s : layer.slots_) {
    std::uint8_t live = 0;
    static_assert(sizeof(s.live) == 1);
    std::memcpy(&live, &s.live, 1);
    if (live > 1) return false;
  }
  layer.polyhedra_.resize(slots);
  for (std::size_t k = 0; k < slots; ++k) {
    const PieceSlot& s = layer.slots_[k];
    const LeanPiece& q = pieces[k];
    if (s.feature >= featureCount || s.origin >= originCount || q.kind > 4) return false;
    // The bounds and box a draw culls and pads by, as validation asks them (validation.hpp:
    // finite, within ±1e15 m, ordered; fuzzing found a lo of -3e305 read as it was).
    if (!bounded(q.lo) || !bounded(q.hi) || q.lo > q.hi || !bounded(q.boxMin.x) || !bounded(q.boxMin.y) ||
        !bounded(q.boxMax.x) || !bounded(q.boxMax.y) || q.boxMin.x > q.boxMax.x || q.boxMin.y > q.boxMax.y)
      return false;
    const std::uint64_t first = s.firstIndex, end = first + s.indexCount;
    if (end > indexCount || s.bottomCount > s.indexCount) return false;
    // The seed paper's construction also draws the piece's box, 36 indices of its own (fuzzing
    // found a lean tile whose box indices were never checked).
    if (options.paperVariant && std::uint64_t{s.boxFirstIndex} + kBoxIndices > indexCount) return false;
    if (!arrays) {
      const auto within = [&](std::uint64_t from, std::uint64_t to) {
        for (std::uint64_t i = from; i < to; ++i)
          if (std::uint64_t{s.baseVertex} + layer.indices_[i] >= vertices) return false;
        return true;
      };
      if (!within(first, end) ||
          (options.paperVariant && !within(s.boxFirstIndex, std::uint64_t{s.boxFirstIndex} + kBoxIndices)))
        return false;
    }
    Polyhedron& p = layer.polyhedra_[k];
    p.footprint.feature = q.feature;
    p.footprint.cell = q.cell;
    p.footprint.source = q.source;
    p.footprint.kind = static_cast<PieceKind>(q.kind);
    p.lo = q.lo;
    p.hi = q.hi;
    p.overSurface = q.overSurface != 0;
    p.boxMin = q.boxMin;
    p.boxMax = q.boxMax;
  }
  for (std::size_t o = 0; o < layer.origins_.size(); ++o) {
    // Origins lie on the grid within ±1e15 m (originFor), so their cells fit 64 bits (fuzzing
    // found an origin of 6e76 converted to an integer).
    if (!bounded(layer.origins_[o].x) || !bounded(layer.origins_[o].y)) return false;
    const glm::dvec2 cell = glm::floor(layer.origins_[o] / kOriginGrid);
    layer.originIndex_.emplace(std::pair{static_cast<std::int64_t>(cell.x), static_cast<std::int64_t>(cell.y)},
                               static_cast<std::uint32_t>(o));
  }
  if (arrays) {
    // The indices in the file, a slice at a time, each against the vertices its slot may use:
    // the largest vertex an index may name, per index, is kept for one slice only. A slot draws
    // its piece's indices, and in the seed paper's construction its box's too.
    struct Range {
      std::uint64_t first = 0, end = 0;
      std::uint64_t room = 0;  ///< vertices − baseVertex
    };
    std::vector<Range> ranges;
    ranges.reserve(options.paperVariant ? 2 * slots : slots);
    for (const PieceSlot& q : layer.slots_) {
      const std::uint64_t room = vertices > q.baseVertex ? vertices - q.baseVertex : 0;
      ranges.push_back({q.firstIndex, std::uint64_t{q.firstIndex} + q.indexCount, room});
      if (options.paperVariant) ranges.push_back({q.boxFirstIndex, std::uint64_t{q.boxFirstIndex} + kBoxIndices, room});
    }
    std::sort(ranges.begin(), ranges.end(), [](const Range& a, const Range& b) { return a.first < b.first; });
    std::vector<std::uint64_t> limit;  // per index of the slice: room + 1 (0: no slot)
    constexpr std::size_t kSlice = std::size_t{1} << 20U;
    std::size_t next = 0;  // in ranges: the first that may still reach this slice
    bool fine = true;
    const bool read = arrays->read(
        arrays->indicesAt, std::uint64_t{indexCount} * sizeof(std::uint32_t),
        [&](const void* data, std::uint64_t offset, std::uint64_t bytes) {
          const std::uint64_t i0 = offset / sizeof(std::uint32_t), n = bytes / sizeof(std::uint32_t);
          limit.assign(static_cast<std::size_t>(n), 0);
          while (next < ranges.size() && ranges[next].end <= i0) ++next;
          for (std::size_t k = next; k < ranges.size(); ++k) {
            const Range& q = ranges[k];
            if (q.first >= i0 + n) break;
            const std::uint64_t from = std::max<std::uint64_t>(q.first, i0);
            const std::uint64_t to = std::min<std::uint64_t>(q.end, i0 + n);
            const std::uint64_t room = q.room;
            for (std::uint64_t i = from; i < to; ++i) {
              std::uint64_t& l = limit[static_cast<std::size_t>(i - i0)];
              l = l == 0 ? room + 1 : std::min(l, room + 1);  // +1: 0 means "no slot"
            }
          }
          std::vector<std::uint32_t> values(static_cast<std::size_t>(n));
          std::memcpy(values.data(), data, static_cast<std::size_t>(bytes));
          for (std::size_t i = 0; i < values.size(); ++i)
            if (limit[i] != 0 && std::uint64_t{values[i]} + 1 >= limit[i]) fine = false;
        },
        kSlice * sizeof(std::uint32_t));
    if (!read || !fine) return false;
    layer.arraysInFile_ = std::move(arrays);
  }
  layer.wastedIndices_ = static_cast<std::size_t>(wasted);
  layer.changes_ = GeometryChange{};  // everything is new: the first upload takes it all
  // World pieces read with their arrays can be clipped at the near plane from them; a plane's
  // lean pieces have no footprints.
  layer.footprintsReleased_ = !world || layer.arraysInFile_ != nullptr;
  return true;
}

std::pair<glm::dvec3, glm::dvec3> LayerGeometry::box3() const {
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    if (!slots_[k].live) continue;
    const Polyhedron& p = polyhedra_[k];
    lo = glm::min(lo, glm::dvec3(p.boxMin, p.lo));
    hi = glm::max(hi, glm::dvec3(p.boxMax, p.hi));
  }
  return {lo, hi};
}

GeometryChange LayerGeometry::takeChanges() {
  GeometryChange c = changes_;
  changes_ = GeometryChange{};
  return c;
}

Result<LayerGeometry> LayerGeometry::build(std::string name, LayerKind kind, const LayerStyle& style,
                                           SharedFeatures features, const HeightBoundsProvider& bounds,
                                           const LayerBuildOptions& options) {
  Diagnostics diagnostics;
  std::vector<FeatureStyle> styles =
      resolveFeatureStyles(style, kind, features, &diagnostics, name, options.minWidthInPixels);
  Result<LayerGeometry> r =
      build(std::move(name), kind, style, std::move(features), std::move(styles), bounds, options);
  diagnostics.append(r.diagnostics);
  r.diagnostics = std::move(diagnostics);
  return r;
}

Result<LayerGeometry> LayerGeometry::build(std::string name, LayerKind kind, const LayerStyle& style,
                                           SharedFeatures features, std::vector<FeatureStyle> styles,
                                           const HeightBoundsProvider& bounds, const LayerBuildOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  LayerGeometry layer = empty(std::move(name), kind, style, std::move(features), std::move(styles), &bounds, options);
  Result<LayerGeometry> r;
  if (!options.deferPieces) {
    for (std::size_t i = 0; i < layer.features_.size(); ++i)
      assignAnchorHeights(layer.styles_[i], layer.features_[i], bounds);
  }
  layer.featureSlots_.resize(layer.features_.size());
  layer.outcomes_.assign(layer.features_.size(), FeatureOutcome::Hidden);
  if (options.deferPieces) {
    // No pieces, but every feature checked as a build would (its footprints, uncut): broken and
    // empty features are named now, not when a tile first meets them. As checked last time
    // when the same features were checked the same way (checkCacheDirectory).
    layer.contentFingerprint_ = featuresFingerprint(layer.features_, layer.styles_, kind);
    std::vector<Diagnostics> found(layer.features_.size());
    std::vector<FeatureOutcome> outcomes(layer.features_.size(), FeatureOutcome::Hidden);
    std::filesystem::path checksFile;
    if (!options.checkCacheDirectory.empty()) {
      StableHasher h;
      h.add(std::string_view("stencil-gis checks 1"));
      h.add(std::string_view(STENCIL_GIS_PIECES_FINGERPRINT));  // the code that checks them
      h.add(layer.contentFingerprint_);
      h.add(layer.name_);
      const FootprintOptions& fo = options.footprints;
      h.add(fo.chordTolerance);
      h.add(fo.chordTolerancePixels);
      h.add(static_cast<std::uint64_t>(fo.cells ? 1 : 0));
      if (fo.cells) {
        for (const double v : {fo.cells->origin.x, fo.cells->origin.y, fo.cells->cellSize}) h.add(v);
        h.add(static_cast<std::uint64_t>(fo.cells->columns) * 65536U + static_cast<std::uint64_t>(fo.cells->rows));
      }
      char file[32];
      std::snprintf(file, sizeof(file), "%016llx.checks", static_cast<unsigned long long>(h.value()));
      checksFile = std::filesystem::path(options.checkCacheDirectory) / file;
    }
    std::string damage;
    layer.stats_.checksFromCache = !checksFile.empty() && readChecks(checksFile, outcomes, found, damage);
    // A damaged file costs the checks, never a feature: said, and written again.
    if (!layer.stats_.checksFromCache && !damage.empty())
      r.diagnostics.add({Severity::Warning,
                         checksFile.string(),
                         layer.name_,
                         {},
                         "cache file damaged (" + damage + "); the features are checked again"});
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
      for (std::size_t i = next.fetch_add(1); i < layer.features_.size(); i = next.fetch_add(1)) {
        if (!layer.styles_[i].visible) continue;
        std::int64_t fid = -1;
        try {
          const std::shared_ptr<const geo::Feature> feature = layer.features_.get(i);  // may read it from disk
          fid = feature->fid;
          outcomes[i] = checkFeature(*feature, static_cast<std::uint32_t>(i), kind, layer.styles_[i], layer.name_,
                                     options, found[i]);
        } catch (const std::exception& e) {  // on a worker thread it would end the program
          outcomes[i] = FeatureOutcome::Skipped;
          found[i].add(detail::featureError(Severity::Error, layer.name_, fid,
                                            std::string("cannot be built (") + e.what() + "); feature skipped"));
        }
      }
    };
    if (!layer.stats_.checksFromCache) {
      {
        std::vector<std::jthread> pool;
        for (unsigned t = 1; t < std::clamp(options.threads, 1U, 64U); ++t) pool.emplace_back(work);
        work();
      }
      if (!checksFile.empty()) (void)writeChecks(checksFile, outcomes, found);
    }
    for (std::size_t i = 0; i < layer.features_.size(); ++i) {
      r.diagnostics.append(found[i]);
      layer.setOutcome(i, outcomes[i]);
    }
    layer.stats_.features = layer.features_.size();
    layer.stats_.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.value = std::move(layer);
    return r;
  }
  // Features in blocks: each block's pieces and messages built on options.threads threads
  // (features taken from a shared counter), then added in feature order. A block at a time,
  // so that no more than one block's pieces wait outside the arrays.
  struct Built {
    std::vector<Polyhedron> pieces;
    Diagnostics diagnostics;
  };
  constexpr std::size_t kBlock = 2048;
  std::vector<Built> built;
  const unsigned threads = std::clamp(options.threads, 1U, 64U);
  for (std::size_t blockStart = 0; blockStart < layer.features_.size(); blockStart += kBlock) {
    const std::size_t blockEnd = std::min(blockStart + kBlock, layer.features_.size());
    built.assign(blockEnd - blockStart, Built{});
    std::atomic<std::size_t> next{blockStart};
    const auto work = [&] {
      for (std::size_t i = next.fetch_add(1); i < blockEnd; i = next.fetch_add(1)) {
        if (!layer.styles_[i].visible) continue;
        if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) return;
        Built& b = built[i - blockStart];
        try {
          b.pieces = buildPolyhedra(layer.features_[i], static_cast<std::uint32_t>(i), kind, layer.styles_[i],
                                    layer.name_, bounds, options, b.diagnostics);
        } catch (const std::exception& e) {  // on a worker thread it would end the program
          b.pieces.clear();
          b.diagnostics.add(detail::featureError(Severity::Error, layer.name_, layer.features_[i].fid,
                                                 std::string("cannot be built (") + e.what() + "); feature skipped"));
        }
      }
    };
    if (threads > 1 && blockEnd - blockStart > 1) {
      std::vector<std::jthread> pool;
      for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
      work();
    } else {
      work();
    }
    if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
      r.diagnostics.add({Severity::Error, "", layer.name_, "", "the build was cancelled"});
      return r;
    }
    for (std::size_t i = blockStart; i < blockEnd; ++i) {
      if (!layer.styles_[i].visible) continue;
      Built& b = built[i - blockStart];
      const bool errors = b.diagnostics.count(Severity::Error) > 0;
      r.diagnostics.append(b.diagnostics);
      layer.setOutcome(i, !b.pieces.empty() ? FeatureOutcome::Drawn
                          : errors          ? FeatureOutcome::Skipped
                                            : FeatureOutcome::NothingToDraw);
      layer.addPieces(static_cast<std::uint32_t>(i), std::move(b.pieces));
    }
  }
  layer.changes_ = GeometryChange{};  // everything is new: the first upload takes it all
  layer.stats_.features = layer.features_.size();
  layer.stats_.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.value = std::move(layer);
  return r;
}

LayerGeometry LayerGeometry::empty(std::string name, LayerKind kind, const LayerStyle& style, SharedFeatures features,
                                   std::vector<FeatureStyle> styles, const HeightBoundsProvider* bounds,
                                   const LayerBuildOptions& options) {
  LayerGeometry layer;
  layer.name_ = std::move(name);
  layer.kind_ = kind;
  layer.style_ = style;
  layer.options_ = options;
  layer.features_ = std::move(features);
  layer.bounds_ = bounds;
  layer.boundsRevision_ = bounds != nullptr ? bounds->revision() : 0;
  layer.styles_ = std::move(styles);
  layer.styles_.resize(layer.features_.size());
  return layer;
}

LayerGeometry LayerGeometry::assemble(std::string name, LayerKind kind, const LayerStyle& style,
                                      std::vector<geo::Feature> features, std::vector<FeatureStyle> styles,
                                      std::vector<std::vector<Polyhedron>> pieces, const HeightBoundsProvider& bounds,
                                      const LayerBuildOptions& options) {
  LayerGeometry layer = empty(std::move(name), kind, style, std::move(features), std::move(styles), &bounds, options);
  for (std::size_t i = 0; i < layer.features_.size(); ++i)
    assignAnchorHeights(layer.styles_[i], layer.features_[i], bounds);
  layer.featureSlots_.resize(layer.features_.size());
  layer.outcomes_.assign(layer.features_.size(), FeatureOutcome::Hidden);
  pieces.resize(layer.features_.size());
  for (std::size_t i = 0; i < layer.features_.size(); ++i) {
    if (!layer.styles_[i].visible) continue;
    layer.setOutcome(i, pieces[i].empty() ? FeatureOutcome::NothingToDraw : FeatureOutcome::Drawn);
    layer.addPieces(static_cast<std::uint32_t>(i), std::move(pieces[i]));
  }
  layer.changes_ = GeometryChange{};
  layer.stats_.features = layer.features_.size();
  return layer;
}

LayerGeometry LayerGeometry::ofWorldPieces(std::string name, const glm::dvec3& origin, std::vector<Vertex> vertices,
                                           std::vector<glm::vec4> normals, std::vector<std::uint32_t> indices,
                                           const std::vector<WorldPiece>& pieces,
                                           std::span<const glm::vec4> groupColours, WorldLines lines,
                                           bool paperVariant) {
  // The colour groups as the layer's features: no geometry, their colours as their styles.
  std::vector<geo::Feature> groups(groupColours.size());
  std::vector<FeatureStyle> styles(groupColours.size());
  for (std::size_t g = 0; g < groups.size(); ++g) {
    groups[g].fid = static_cast<std::int64_t>(g);
    styles[g].color = groupColours[g];
  }
  LayerGeometry layer =
      empty(std::move(name), LayerKind::Polygon, {}, std::move(groups), std::move(styles), nullptr, {});
  layer.worldOrigins_.push_back(origin);
  layer.options_.paperVariant = paperVariant;
  layer.featureSlots_.resize(groupColours.size());
  layer.slots_.reserve(pieces.size());
  layer.polyhedra_.reserve(pieces.size());
  for (const WorldPiece& piece : pieces) {
    const std::uint32_t group = std::min<std::uint32_t>(
        piece.group, static_cast<std::uint32_t>(std::max<std::size_t>(groupColours.size(), 1) - 1));
    PieceSlot s;
    s.feature = group;
    s.firstIndex = piece.firstIndex;
    s.bottomCount = piece.bottomCount;
    s.indexCount = piece.indexCount;
    s.boxFirstIndex = piece.boxFirstIndex;
    s.live = true;
    if (group < layer.featureSlots_.size()) {
      layer.featureSlots_[group].push_back(static_cast<std::uint32_t>(layer.slots_.size()));
      const std::array<std::uint8_t, 4> rgba = rgba8(groupColours[group]);
      for (std::uint32_t k = piece.firstIndex; k < piece.firstIndex + piece.indexCount; ++k)
        std::copy(rgba.begin(), rgba.end(), vertices[indices[k]].rgba);
      for (std::uint32_t k = piece.boxFirstIndex; paperVariant && k < piece.boxFirstIndex + kBoxIndices; ++k)
        std::copy(rgba.begin(), rgba.end(), vertices[indices[k]].rgba);
    }
    layer.slots_.push_back(s);
    // The world box as a footprint's box and its bounds (box3() gives it back).
    Polyhedron p;
    p.boxMin = glm::dvec2(piece.boxLo);
    p.boxMax = glm::dvec2(piece.boxHi);
    p.lo = piece.boxLo.z;
    p.hi = piece.boxHi.z;
    layer.polyhedra_.push_back(std::move(p));
    layer.stats_.triangles += piece.indexCount / 3;
  }
  layer.outcomes_.resize(groupColours.size());
  for (std::size_t g = 0; g < groupColours.size(); ++g)
    layer.outcomes_[g] = layer.featureSlots_[g].empty() ? FeatureOutcome::NothingToDraw : FeatureOutcome::Drawn;
  layer.stats_.features = groupColours.size();
  layer.stats_.pieces = pieces.size();
  layer.vertices_ = std::move(vertices);
  layer.normals_ = std::move(normals);
  layer.normals_.resize(layer.vertices_.size(), glm::vec4(0.0F));
  if (!lines.scaling.empty() && lines.widthPixels > 0.0) {
    // Read by OverlayLayer and the renderer as a line layer's widths in pixels.
    layer.kind_ = LayerKind::Line;
    layer.style_.widthPixels = lines.widthPixels;
    layer.style_.maxWidthMetres = lines.maxWidth;
    layer.scaling_ = std::move(lines.scaling);
    layer.scaling_.resize(layer.vertices_.size(), glm::vec4(0.0F));
  }
  layer.indices_ = std::move(indices);
  layer.footprintsReleased_ = false;  // clipped at the near plane from its arrays (clipAtNearPlane)
  layer.changes_ = GeometryChange{};
  return layer;
}

std::array<std::uint8_t, 4> rgba8(const glm::vec4& colour) {
  return {unorm8(colour.x), unorm8(colour.y), unorm8(colour.z), unorm8(colour.w)};
}

std::uint32_t LayerGeometry::originFor(const Polyhedron& p) {
  const glm::dvec2 centre = 0.5 * (p.boxMin + p.boxMax);
  const glm::dvec2 origin = (glm::floor(centre / kOriginGrid) + 0.5) * kOriginGrid;
  // Origins lie on a 1 km grid: the cell's integer coordinates are the key (coordinates are
  // bounded by 1e15 m, so they fit 64 bits).
  const glm::dvec2 cell = glm::floor(centre / kOriginGrid);
  const std::pair<std::int64_t, std::int64_t> key{static_cast<std::int64_t>(cell.x), static_cast<std::int64_t>(cell.y)};
  const auto [found, added] = originIndex_.try_emplace(key, static_cast<std::uint32_t>(origins_.size()));
  if (!added) return found->second;
  origins_.push_back(origin);
  return static_cast<std::uint32_t>(origins_.size() - 1);
}

void LayerGeometry::addPieces(std::uint32_t feature, std::vector<Polyhedron> pieces) {
  maxOverlap_.reset();
  uniformColor_.reset();
  const FeatureStyle& style = styles_[feature];
  const std::uint8_t rgba[4] = {unorm8(style.color.x), unorm8(style.color.y), unorm8(style.color.z),
                                unorm8(style.color.w)};
  for (Polyhedron& p : pieces) {
    const std::size_t slot = slots_.size();
    PieceSlot s;
    s.feature = feature;
    s.origin = originFor(p);
    s.live = true;
    const glm::dvec2 origin = origins_[s.origin];
    const Footprint& f = p.footprint;
    std::vector<Vertex> v;
    v.reserve(2 * f.vertices.size() + 8);
    // Lines in pixels: the centres here, directions and anchors in the scaling stream.
    const bool scalable = f.scalable();
    std::vector<glm::vec4> scaling;
    const auto minHalf = static_cast<float>(0.5 * styles_[feature].shape.minWidth);
    for (std::size_t k = 0; k < f.vertices.size(); ++k) {
      const glm::vec2 rel(scalable ? glm::dvec2(f.centres[k]) - origin : f.vertices[k] - origin);
      v.push_back({rel.x, rel.y, static_cast<float>(p.lo), -1.0F, {rgba[0], rgba[1], rgba[2], rgba[3]}});
      v.push_back({rel.x, rel.y, static_cast<float>(p.hi), 1.0F, {rgba[0], rgba[1], rgba[2], rgba[3]}});
      if (scalable) {
        const glm::vec4 s4(static_cast<float>(f.directions[k].x), static_cast<float>(f.directions[k].y),
                           static_cast<float>(f.centres[k].z), minHalf);
        scaling.insert(scaling.end(), {s4, s4});
      }
    }
    std::vector<std::uint32_t> idx;
    idx.reserve(6 * f.triangles.size() + 6 * f.boundary.size() + 36);
    s.bottomCount = appendPieceIndices(f, idx);
    s.indexCount = static_cast<std::uint32_t>(idx.size());
    // The piece's bounding box, for the paper variant's cover (only there: 300 bytes a piece).
    const auto boxBase = static_cast<std::uint32_t>(v.size());
    const glm::vec2 b0(p.boxMin - origin), b1(p.boxMax - origin);
    for (int k = 0; k < (options_.paperVariant ? 8 : 0); ++k) {
      const bool top = (k & 4) != 0;
      v.push_back({(k & 1) != 0 ? b1.x : b0.x,
                   (k & 2) != 0 ? b1.y : b0.y,
                   static_cast<float>(top ? p.hi : p.lo),
                   top ? 1.0F : -1.0F,
                   {rgba[0], rgba[1], rgba[2], rgba[3]}});
    }
    s.boxFirstIndex = static_cast<std::uint32_t>(idx.size());
    // Box faces, outward (vertex k: bit 0 = +x, bit 1 = +y, bit 2 = top).
    if (options_.paperVariant) {
      for (const std::uint32_t k : kBoxFaces) idx.push_back(boxBase + k);
    }
    if (widthPixels() > 0.0) scaling.resize(v.size(), glm::vec4(0.0F));  // the box does not scale
    stats_.pieces += 1;
    stats_.triangles += s.indexCount / 3;
    slots_.push_back(s);
    polyhedra_.push_back(std::move(p));
    featureSlots_[feature].push_back(static_cast<std::uint32_t>(slot));
    appendGeometry(slot, v, idx, scaling);
  }
}

LayerValidation LayerGeometry::validate() const {
  LayerValidation v;
  if (alongNormals()) {  // world pieces have no footprints to check them against (their frame's tests do)
    for (const PieceSlot& s : slots_) v.pieces += s.live ? 1U : 0U;
    return v;
  }
  ValidationOptions options;
  if (!options_.paperVariant) options.grid = options_.footprints.cells;
  // Lines in pixels are neither split at the cells nor clipped to the grid (footprints.hpp).
  ValidationOptions unsplit = options;
  unsplit.grid.reset();
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    const PieceSlot& s = slots_[k];
    if (!s.live) continue;
    ++v.pieces;
    const Polyhedron& p = polyhedra_[k];
    std::vector<std::string> problems = polyhedronProblems(p, p.footprint.scalable() ? unsplit : options);
    // The stored geometry: the same triangles, the vertices within float precision.
    std::vector<std::uint32_t> expected;
    appendPieceIndices(p.footprint, expected);
    if (!arraysReleased_ && (s.indexCount != expected.size() ||
                             !std::equal(expected.begin(), expected.end(), indices_.begin() + s.firstIndex))) {
      problems.emplace_back("the stored indices are not the piece's triangles");
    }
    const glm::dvec2 origin = origins_[s.origin];
    const Footprint& f = p.footprint;
    for (std::size_t i = 0; i < 2 * f.vertices.size() && s.baseVertex + i < vertices_.size(); ++i) {
      const Vertex& stored = vertices_[s.baseVertex + i];
      const glm::dvec2 want = f.scalable() ? glm::dvec2(f.centres[i / 2]) : f.vertices[i / 2];
      const glm::dvec2 got = origin + glm::dvec2(stored.x, stored.y);
      v.maxPositionError = std::max(v.maxPositionError, glm::length(got - want));
      v.maxHeightError =
          std::max(v.maxHeightError, std::abs(static_cast<double>(stored.height) - ((i % 2) != 0 ? p.hi : p.lo)));
    }
    for (const std::string& problem : problems) {
      v.problems.add(detail::featureError(Severity::Error, name_, features_[s.feature].fid,
                                          "piece " + std::to_string(k) + ": " + problem));
    }
  }
  return v;
}

std::size_t LayerGeometry::maxOverlap() const {
  if (maxOverlap_) return *maxOverlap_;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  std::size_t live = 0;
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    if (!slots_[k].live) continue;
    ++live;
    lo = glm::min(lo, polyhedra_[k].boxMin);
    hi = glm::max(hi, polyhedra_[k].boxMax);
  }
  pieceBox_ = live > 0 ? std::pair{lo, hi} : std::pair{glm::dvec2(1.0), glm::dvec2(-1.0)};
  if (live <= 255) return *(maxOverlap_ = live);  // cannot exceed the number of pieces
  // Count the pieces' boxes on a grid: a point lies in one cell, every piece holding it has its
  // box over that cell. 256 × 256 first; above 255 (the groups' threshold) once more on a grid
  // 4× finer, which a coarse tile's many thin pieces need.
  const glm::dvec2 size = glm::max(hi - lo, glm::dvec2(1e-9));
  const auto count = [&](int cells) {
    std::vector<std::uint32_t> counts(static_cast<std::size_t>(cells) * static_cast<std::size_t>(cells), 0);
    std::uint32_t worst = 0;
    for (std::size_t k = 0; k < slots_.size(); ++k) {
      if (!slots_[k].live) continue;
      const glm::dvec2 a = (polyhedra_[k].boxMin - lo) / size * static_cast<double>(cells);
      const glm::dvec2 b = (polyhedra_[k].boxMax - lo) / size * static_cast<double>(cells);
      const int x0 = std::clamp(static_cast<int>(std::floor(a.x)), 0, cells - 1);
      const int x1 = std::clamp(static_cast<int>(std::floor(b.x)), 0, cells - 1);
      const int y0 = std::clamp(static_cast<int>(std::floor(a.y)), 0, cells - 1);
      const int y1 = std::clamp(static_cast<int>(std::floor(b.y)), 0, cells - 1);
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x)
          worst = std::max(
              worst,
              ++counts[static_cast<std::size_t>(y) * static_cast<std::size_t>(cells) + static_cast<std::size_t>(x)]);
      }
    }
    return worst;
  };
  std::uint32_t worst = count(256);
  if (worst > 255) worst = count(1024);
  return *(maxOverlap_ = worst);
}

std::optional<glm::vec4> LayerGeometry::uniformColor() const {
  if (uniformColor_) return *uniformColor_;
  std::optional<std::array<std::uint8_t, 4>> shared;
  bool uniform = true;
  for (std::size_t f = 0; f < featureSlots_.size() && uniform; ++f) {
    if (featureSlots_[f].empty()) continue;  // hidden, removed or without pieces
    const glm::vec4& c = styles_[f].color;
    const std::array<std::uint8_t, 4> rgba{unorm8(c.x), unorm8(c.y), unorm8(c.z), unorm8(c.w)};
    if (!shared) shared = rgba;
    uniform = *shared == rgba;
  }
  std::optional<glm::vec4> colour;
  if (uniform && shared) {
    colour = glm::vec4((*shared)[0], (*shared)[1], (*shared)[2], (*shared)[3]) / 255.0F;
  }
  uniformColor_ = colour;
  return colour;
}

void LayerGeometry::appendGeometry(std::size_t slot, const std::vector<Vertex>& v, const std::vector<std::uint32_t>& i,
                                   const std::vector<glm::vec4>& scaling) {
  PieceSlot& s = slots_[slot];
  s.baseVertex = static_cast<std::uint32_t>(vertices_.size());
  s.firstIndex = static_cast<std::uint32_t>(indices_.size());
  s.boxFirstIndex += s.firstIndex;
  changes_.add(vertices_.size(), vertices_.size() + v.size(), indices_.size(), indices_.size() + i.size());
  vertices_.insert(vertices_.end(), v.begin(), v.end());
  indices_.insert(indices_.end(), i.begin(), i.end());
  if (widthPixels() > 0.0) scaling_.insert(scaling_.end(), scaling.begin(), scaling.end());
}

void LayerGeometry::freePieces(std::uint32_t feature) {
  maxOverlap_.reset();
  uniformColor_.reset();
  for (std::uint32_t slot : featureSlots_[feature]) {
    PieceSlot& s = slots_[slot];
    if (!s.live) continue;
    s.live = false;
    wastedIndices_ += s.indexCount + (options_.paperVariant ? 36 : 0);
    stats_.pieces -= 1;
    stats_.triangles -= s.indexCount / 3;
  }
  featureSlots_[feature].clear();
}

void LayerGeometry::setOutcome(std::size_t feature, FeatureOutcome outcome) {
  auto count = [this](FeatureOutcome o) -> std::size_t* {
    return o == FeatureOutcome::Skipped         ? &stats_.skippedFeatures
           : o == FeatureOutcome::NothingToDraw ? &stats_.emptyFeatures
                                                : nullptr;
  };
  if (std::size_t* before = count(outcomes_[feature])) --*before;
  if (std::size_t* after = count(outcome)) ++*after;
  outcomes_[feature] = outcome;
}

Diagnostics LayerGeometry::rebuildFeature(std::size_t index) {
  Diagnostics diagnostics;
  const std::shared_ptr<const geo::Feature> feature = features_.get(index);  // on disk: read
  if (arraysReleased_) {
    diagnostics.add(detail::featureError(Severity::Error, name_, feature->fid,
                                         "cannot be rebuilt: the layer's arrays were released (build it again)"));
    return diagnostics;
  }
  freePieces(static_cast<std::uint32_t>(index));
  FeatureOutcome outcome = FeatureOutcome::Hidden;
  if (styles_[index].visible && options_.deferPieces) {
    // A tiled technique builds the pieces; here the feature is checked.
    outcome =
        checkFeature(*feature, static_cast<std::uint32_t>(index), kind_, styles_[index], name_, options_, diagnostics);
  } else if (styles_[index].visible && bounds_ != nullptr) {
    std::vector<Polyhedron> pieces = buildPolyhedra(*feature, static_cast<std::uint32_t>(index), kind_, styles_[index],
                                                    name_, *bounds_, options_, diagnostics);
    outcome = !pieces.empty()           ? FeatureOutcome::Drawn
              : diagnostics.hasErrors() ? FeatureOutcome::Skipped
                                        : FeatureOutcome::NothingToDraw;
    addPieces(static_cast<std::uint32_t>(index), std::move(pieces));
  }
  setOutcome(index, outcome);
  return diagnostics;
}

Diagnostics LayerGeometry::replaceFeature(std::size_t index, geo::Feature feature) {
  contentFingerprint_ = 0;
  if (index >= features_.size()) return {};
  features_.edit()[index] = std::move(feature);
  const std::vector<geo::Feature> one{features_.all()[index]};
  Diagnostics diagnostics;
  FeatureStyle style = resolveFeatureStyles(style_, kind_, one, &diagnostics, name_, options_.minWidthInPixels).front();
  style.visible = styles_[index].visible;
  if (bounds_ != nullptr) assignAnchorHeights(style, features_[index], *bounds_);
  styles_[index] = style;
  diagnostics.append(rebuildFeature(index));
  return diagnostics;
}

Diagnostics LayerGeometry::setFeature(std::size_t index, geo::Feature feature, FeatureStyle style) {
  contentFingerprint_ = 0;
  if (index > features_.size()) return {};
  if (index == features_.size()) {
    features_.edit().emplace_back();
    styles_.emplace_back();
    featureSlots_.emplace_back();
    outcomes_.push_back(FeatureOutcome::Hidden);
    stats_.features = features_.size();
  }
  features_.edit()[index] = std::move(feature);
  if (bounds_ != nullptr) assignAnchorHeights(style, features_[index], *bounds_);
  styles_[index] = std::move(style);
  return rebuildFeature(index);
}

Diagnostics LayerGeometry::setFeatureStyle(std::size_t index, const FeatureStyle& style) {
  contentFingerprint_ = 0;
  if (index >= features_.size()) return {};
  styles_[index] = style;
  if (bounds_ != nullptr) assignAnchorHeights(styles_[index], *features_.get(index), *bounds_);
  return rebuildFeature(index);
}

void LayerGeometry::removeFeature(std::size_t index) {
  contentFingerprint_ = 0;
  if (index >= features_.size()) return;
  styles_[index].visible = false;
  freePieces(static_cast<std::uint32_t>(index));
  setOutcome(index, FeatureOutcome::Hidden);
}

void LayerGeometry::refreshBounds(const HeightBoundsProvider& bounds) {
  bounds_ = &bounds;
  boundsRevision_ = bounds.revision();
  if (options_.deferPieces) return;  // no pieces; a tiled technique reads the bounds per tile
  if (arraysReleased_) return;       // the GPU copy cannot follow: the owner builds it again
  if (widthPixels() > 0.0) {
    // The anchors move with the terrain: rebuild every feature.
    for (std::size_t i = 0; i < features_.size(); ++i) {
      if (!styles_[i].visible) continue;
      assignAnchorHeights(styles_[i], features_[i], bounds);
      (void)rebuildFeature(i);
    }
    return;
  }
  for (std::size_t slot = 0; slot < slots_.size(); ++slot) {
    if (!slots_[slot].live) continue;
    Polyhedron& p = polyhedra_[slot];
    const HeightBounds b = bounds.boundsOver(p.footprint.vertices);
    const bool usable = b.valid() && std::isfinite(b.lo) && std::isfinite(b.hi);
    p.lo = usable ? b.lo : bounds.globalBounds().lo;
    p.hi = usable ? b.hi : bounds.globalBounds().hi;
  }
  if (options_.paperVariant) {
    // One bound pair per feature, as built.
    for (const std::vector<std::uint32_t>& pieces : featureSlots_) {
      HeightBounds joint{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
      for (std::uint32_t slot : pieces) {
        joint.lo = std::min(joint.lo, polyhedra_[slot].lo);
        joint.hi = std::max(joint.hi, polyhedra_[slot].hi);
      }
      for (std::uint32_t slot : pieces) {
        polyhedra_[slot].lo = joint.lo;
        polyhedra_[slot].hi = joint.hi;
      }
    }
  }
  for (std::size_t slot = 0; slot < slots_.size(); ++slot) {
    const PieceSlot& s = slots_[slot];
    if (!s.live) continue;
    const Polyhedron& p = polyhedra_[slot];
    // The piece's vertices, and its bounding box's for the paper's variant.
    const std::size_t n = 2 * p.footprint.vertices.size() + (options_.paperVariant ? 8 : 0);
    for (std::size_t k = 0; k < n; ++k) {
      Vertex& v = vertices_[s.baseVertex + k];
      v.height = static_cast<float>(v.side > 0.0F ? p.hi : p.lo);
    }
    changes_.add(s.baseVertex, s.baseVertex + n, 0, 0);
  }
}

ReferenceLayer referenceLayerOf(const LayerGeometry& layer) {
  ReferenceLayer r;
  r.name = layer.name();
  r.kind = layer.kind();
  r.features = &layer.features();
  for (std::size_t i = 0; i < layer.featureStyles().size(); ++i) {
    const FeatureStyle& s = layer.featureStyles()[i];
    if (r.kind == LayerKind::Line) {
      r.shapes.push_back(s.shape);
      // A layer without pieces (LayerBuildOptions::deferPieces) keeps no anchor heights: they
      // are those its tiles' builds give each vertex.
      if (s.shape.inPixels() && s.shape.anchorHeights.empty() && layer.bounds() != nullptr &&
          i < layer.features().size()) {
        FeatureStyle anchored = s;
        assignAnchorHeights(anchored, layer.features()[i], *layer.bounds());
        r.shapes.back() = std::move(anchored.shape);
      }
    }
    r.visible.push_back(s.visible);
  }
  return r;
}

}  // namespace gis::overlay
