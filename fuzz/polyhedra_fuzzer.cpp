// Fuzzes the polyhedra builder (overlay::buildPolyhedra): the bytes decode into a feature
// (polygons with holes, or lines with a width, join, cap and miter limit, in metres or in
// pixels), a cell grid and a terrain (a plane or a table of posts), and every feature is built
// three ways: split at the cells, split adaptively, and as the seed paper's construction.
//
// Coordinates come mostly from a small integer lattice tied to the grid (so that duplicate,
// collinear and on-the-cell-border points are common), sometimes nudged by a few 1e-9 of a cell,
// sometimes raw doubles from the input (NaN, Inf, huge, subnormal) or a table of extremes.
//
// Invariants: no throw, no crash; every diagnostic names the layer and the feature; a feature
// without pieces says why; every piece is closed, outward and bounded (overlay::polyhedronProblems,
// inside the grid and its cell unless built the paper's way); the terrain under every piece lies
// between its lo and hi, and a piece that is not welded holds the provider's bounds over its
// footprint. Any violation prints what and aborts, so that libFuzzer keeps the input.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "vector_overlay/footprints.hpp"
#include "vector_overlay/height_bounds.hpp"
#include "vector_overlay/overlay_layer.hpp"
#include "vector_overlay/validation.hpp"

namespace {

using gis::overlay::CellGrid;
using gis::overlay::HeightBounds;
using gis::overlay::LayerKind;
using gis::overlay::Polyhedron;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::int64_t kFid = 7;
const char* const kLayer = "fuzz";

/// Reads the fuzz input front to back; zeros once it runs out.
class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  double raw() {
    std::array<std::uint8_t, 8> b{};
    for (std::uint8_t& x : b) x = byte();
    double v = 0.0;
    std::memcpy(&v, b.data(), sizeof v);
    return v;
  }
  template <typename T, std::size_t N>
  T pick(const std::array<T, N>& table) {
    return table[byte() % N];
  }
  [[nodiscard]] bool empty() const { return pos_ >= size_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

constexpr std::array<double, 16> kExtremes{kNaN,
                                           kInf,
                                           -kInf,
                                           1e15,
                                           -1e15,
                                           1.0000001e15,
                                           1e16,
                                           -1e300,
                                           1e300,
                                           -0.0,
                                           5e-324,
                                           std::numeric_limits<double>::max(),
                                           9007199254740993.0,
                                           -9007199254740992.0,
                                           1e-300,
                                           4.5e15};

/// The terrain under the fuzzed features: a plane or bilinear patches between posts, on the
/// grid's extent and continued flat beyond it (the point clamped to the extent).
class FuzzTerrain final : public gis::overlay::HeightBoundsProvider {
 public:
  FuzzTerrain(const CellGrid& grid, Bytes& in) : grid_(grid) {
    table_ = (in.byte() & 1) != 0;
    if (table_) {
      const double scale = in.pick(std::array<double, 4>{1.0, 10.0, 1000.0, 0.001});
      posts_.resize(static_cast<std::size_t>((grid.columns + 1) * (grid.rows + 1)));
      for (double& h : posts_) h = (in.byte() - 128) * scale;
    } else {
      a_ = in.pick(std::array<double, 8>{0.0, 0.5, -1.0, 2.0, 10.0, -0.25, 1e-6, 3.0});
      b_ = in.pick(std::array<double, 8>{0.0, -0.5, 1.0, 7.0, -10.0, 0.125, 1e-9, -3.0});
      c_ = in.pick(std::array<double, 4>{0.0, -430.0, 8850.0, 1e6});
    }
  }

  /// The surface at a point.
  [[nodiscard]] double at(const glm::dvec2& p) const {
    const glm::dvec2 q = clamp(p);
    if (!table_) return plane(q);
    const glm::dvec2 u = (q - grid_.origin) / grid_.cellSize;
    const int i = std::clamp(static_cast<int>(std::floor(u.x)), 0, grid_.columns - 1);
    const int j = std::clamp(static_cast<int>(std::floor(u.y)), 0, grid_.rows - 1);
    const double fx = std::clamp(u.x - i, 0.0, 1.0), fy = std::clamp(u.y - j, 0.0, 1.0);
    const double h00 = post(i, j), h10 = post(i + 1, j), h01 = post(i, j + 1), h11 = post(i + 1, j + 1);
    return (1 - fy) * ((1 - fx) * h00 + fx * h10) + fy * ((1 - fx) * h01 + fx * h11);
  }

  [[nodiscard]] HeightBounds boundsOver(std::span<const glm::dvec2> footprint) const override {
    glm::dvec2 lo(kInf), hi(-kInf);
    for (const glm::dvec2& p : footprint) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) return {kNaN, kNaN};  // the builder falls back to global
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    if (footprint.empty()) return {kNaN, kNaN};
    lo = clamp(lo);
    hi = clamp(hi);
    HeightBounds r{kInf, -kInf};
    if (!table_) {
      for (const glm::dvec2& c : {lo, hi, glm::dvec2(lo.x, hi.y), glm::dvec2(hi.x, lo.y)}) {
        r.lo = std::min(r.lo, plane(c));
        r.hi = std::max(r.hi, plane(c));
      }
      return r;
    }
    // The posts of every cell the box meets.
    const glm::dvec2 u0 = (lo - grid_.origin) / grid_.cellSize, u1 = (hi - grid_.origin) / grid_.cellSize;
    const int i0 = std::clamp(static_cast<int>(std::floor(u0.x)), 0, grid_.columns - 1);
    const int j0 = std::clamp(static_cast<int>(std::floor(u0.y)), 0, grid_.rows - 1);
    const int i1 = std::clamp(static_cast<int>(std::floor(u1.x)), 0, grid_.columns - 1);
    const int j1 = std::clamp(static_cast<int>(std::floor(u1.y)), 0, grid_.rows - 1);
    for (int j = j0; j <= j1 + 1; ++j) {
      for (int i = i0; i <= i1 + 1; ++i) {
        r.lo = std::min(r.lo, post(i, j));
        r.hi = std::max(r.hi, post(i, j));
      }
    }
    return r;
  }

  [[nodiscard]] HeightBounds globalBounds() const override {
    const glm::dvec2 far = grid_.origin + grid_.cellSize * glm::dvec2(grid_.columns, grid_.rows);
    return boundsOver(std::array<glm::dvec2, 2>{grid_.origin, far});
  }

 private:
  [[nodiscard]] glm::dvec2 clamp(const glm::dvec2& p) const {
    const glm::dvec2 far = grid_.origin + grid_.cellSize * glm::dvec2(grid_.columns, grid_.rows);
    return glm::clamp(p, grid_.origin, far);
  }
  [[nodiscard]] double plane(const glm::dvec2& q) const {
    const glm::dvec2 d = q - grid_.origin;
    return a_ * d.x + b_ * d.y + c_;
  }
  [[nodiscard]] double post(int i, int j) const {
    return posts_[static_cast<std::size_t>(j * (grid_.columns + 1) + i)];
  }

  CellGrid grid_;
  bool table_ = false;
  double a_ = 0.0, b_ = 0.0, c_ = 0.0;
  std::vector<double> posts_;
};

/// Everything one input decodes into.
struct Case {
  CellGrid terrainGrid;  ///< always valid: where the terrain is
  CellGrid buildGrid;    ///< what the builder is given (now and then an invalid one)
  LayerKind kind = LayerKind::Polygon;
  gis::overlay::FeatureStyle style;
  gis::overlay::FootprintOptions footprints;
  gis::geo::Feature feature;
};

class Decoder {
 public:
  Decoder(Bytes& in, const CellGrid& grid) : in_(in), grid_(grid) {
    step_ = grid.cellSize / in.pick(std::array<double, 4>{1.0, 2.0, 4.0, 3.0});
  }

  double coordinate(double origin) {
    const std::uint8_t s = in_.byte();
    if (s < 160) return origin + (s % 40 - 8) * step_;
    if (s < 200) return origin + (s % 40 - 8) * step_ + (in_.byte() - 128) * 1e-9 * grid_.cellSize;
    if (s < 240) return in_.raw();
    return kExtremes[s % kExtremes.size()];
  }
  glm::dvec2 point() {
    const double x = coordinate(grid_.origin.x);
    return {x, coordinate(grid_.origin.y)};
  }
  std::vector<glm::dvec2> points(std::size_t most) {
    std::vector<glm::dvec2> out(in_.byte() % (most + 1));
    for (glm::dvec2& p : out) p = point();
    return out;
  }

 private:
  Bytes& in_;
  CellGrid grid_;
  double step_ = 1.0;
};

Case decode(Bytes& in) {
  Case c;
  const std::uint8_t flags = in.byte();
  c.kind = (flags & 1) != 0 ? LayerKind::Line : LayerKind::Polygon;
  const bool pixels = (flags & 2) != 0;

  CellGrid& g = c.terrainGrid;
  g.origin = in.pick(std::array<glm::dvec2, 4>{glm::dvec2(0.0), glm::dvec2(-5000.0, -2500.0),
                                               glm::dvec2(292000.0, 9115000.0), glm::dvec2(-1e6, 9.9e6)});
  g.cellSize = in.pick(std::array<double, 8>{1.0, 10.0, 100.0, 1000.0, 0.25, 1280.0, 37.5, 1e-3});
  const std::uint8_t size = in.byte();
  g.columns = 1 + size % 8;
  g.rows = 1 + (size / 8) % 8;
  c.buildGrid = g;
  if (size >= 0xf0) {  // now and then a grid the builder must refuse
    c.buildGrid.cellSize = in.pick(std::array<double, 4>{0.0, -1.0, kNaN, kInf});
    if ((size & 1) != 0) c.buildGrid.columns = 0;
  }
  c.footprints.cells = c.buildGrid;
  c.footprints.chordTolerance = in.pick(std::array<double, 8>{0.02, 0.02, 0.5, 1e-3, 0.0, kNaN, 10.0, 0.02});

  Decoder d(in, g);
  c.feature.fid = kFid;
  const int parts = 1 + in.byte() % 3;
  for (int k = 0; k < parts; ++k) {
    if (c.kind == LayerKind::Polygon) {
      gis::geo::Polygon p;
      p.outer = d.points(24);
      const int holes = in.byte() % 4;
      for (int h = 0; h < holes; ++h) p.holes.push_back(d.points(12));
      c.feature.polygons.push_back(std::move(p));
    } else {
      c.feature.lines.push_back(d.points(16));
    }
  }
  gis::overlay::LineShape& shape = c.style.shape;
  const std::uint8_t s = in.byte();
  if (s < 0xe0) {
    shape.width = in.pick(
        std::array<double, 8>{g.cellSize * 0.1, 1.0, 5.0, 12.0, g.cellSize, g.cellSize * 3.0, 0.001, g.cellSize * 0.5});
  } else {
    shape.width = s < 0xf0 ? in.raw() : in.pick(std::array<double, 8>{0.0, -1.0, kNaN, kInf, 1e15, 1e16, 1e-300, 2e15});
  }
  shape.join = static_cast<gis::overlay::LineJoin>(in.byte() % 3);
  shape.cap = static_cast<gis::overlay::LineCap>(in.byte() % 3);
  shape.miterLimit = in.pick(std::array<double, 8>{4.0, 1.0, 0.0, -1.0, 1.0001, 1e9, kNaN, kInf});
  if (pixels) shape.widthPixels = in.pick(std::array<double, 4>{3.0, 1.0, 0.5, 40.0});
  return c;
}

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "polyhedra_fuzzer: %s\n", what.c_str());
  std::abort();
}

struct Variant {
  const char* name;
  bool adaptive;
  bool paper;
};
constexpr std::array<Variant, 3> kVariants{
    {{"split at cells", false, false}, {"adaptive", true, false}, {"paper", false, true}}};

void checkVariant(const Case& c, const FuzzTerrain& terrain, const gis::overlay::FeatureStyle& style,
                  const Variant& v) {
  gis::overlay::LayerBuildOptions options;
  options.footprints = c.footprints;
  options.adaptiveSplit = v.adaptive;
  options.paperVariant = v.paper;
  gis::Diagnostics diagnostics;
  std::vector<Polyhedron> pieces;
  try {
    pieces = gis::overlay::buildPolyhedra(c.feature, 0, c.kind, style, kLayer, terrain, options, diagnostics);
  } catch (const std::exception& e) {
    fail(std::string(v.name) + ": buildPolyhedra threw: " + e.what());
  }
  const std::string fid = std::to_string(kFid);
  for (const gis::Diagnostic& d : diagnostics.items()) {
    if (d.layer != kLayer || d.feature != fid)
      fail(std::string(v.name) + ": a diagnostic names another layer or feature: " + d.toString());
  }
  if (pieces.empty() && diagnostics.empty()) fail(std::string(v.name) + ": no pieces and no diagnostic saying why");

  gis::overlay::ValidationOptions vo;
  if (!v.paper) vo.grid = c.buildGrid;
  // Lines in pixels are not split at the cells nor clipped to the grid (footprints.hpp): no grid
  // for them (as in OverlayLayer::validate).
  gis::overlay::ValidationOptions pixelLines = vo;
  pixelLines.grid.reset();
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const Polyhedron& p = pieces[k];
    const std::string where = std::string(v.name) + ": piece " + std::to_string(k) + " of " +
                              std::to_string(pieces.size()) + " (cell " + std::to_string(p.footprint.cell) + ")";
    const std::vector<std::string> problems =
        gis::overlay::polyhedronProblems(p, p.footprint.scalable() ? pixelLines : vo);
    if (!problems.empty()) {
      std::string all;
      for (const std::string& problem : problems) all += "\n  " + problem;
      fail(where + " is not closed, outward and bounded:" + all);
    }
    const gis::overlay::Footprint& f = p.footprint;
    const double slack = 1e-9 * (1.0 + std::abs(p.lo) + std::abs(p.hi));
    // Not welded (adaptive welding puts the parts' joint bounds on the whole): the provider's
    // own bounds over the footprint.
    if (!v.adaptive) {
      const HeightBounds b = terrain.boundsOver(f.vertices);
      if (b.valid() && std::isfinite(b.lo) && std::isfinite(b.hi) && (b.lo < p.lo - slack || b.hi > p.hi + slack)) {
        fail(where + ": bounds [" + std::to_string(p.lo) + ", " + std::to_string(p.hi) + "] do not hold the " +
             "provider's [" + std::to_string(b.lo) + ", " + std::to_string(b.hi) + "]");
      }
    }
    // The surface at the vertices and inside every triangle lies between lo and hi.
    auto surfaceInside = [&](const glm::dvec2& q, const char* what) {
      const double h = terrain.at(q);
      if (h < p.lo - slack || h > p.hi + slack) {
        fail(where + ": the terrain at " + what + " (" + std::to_string(q.x) + ", " + std::to_string(q.y) + ") is " +
             std::to_string(h) + ", outside [" + std::to_string(p.lo) + ", " + std::to_string(p.hi) + "]");
      }
    };
    for (const glm::dvec2& q : f.vertices) surfaceInside(q, "a vertex");
    for (const auto& t : f.triangles) {
      const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], cc = f.vertices[t[2]];
      surfaceInside((a + b + cc) / 3.0, "a triangle's centre");
      surfaceInside(0.8 * a + 0.1 * b + 0.1 * cc, "a point of a triangle");
    }
  }
}

/// With STENCIL_GIS_FUZZ_VERBOSE set: the decoded case, for bug reports.
void describe(const Case& c) {
  const CellGrid& g = c.buildGrid;
  std::fprintf(stderr, "grid origin (%.17g, %.17g) cell %.17g, %d x %d; %s, chord tolerance %.17g\n", g.origin.x,
               g.origin.y, g.cellSize, g.columns, g.rows, c.kind == LayerKind::Line ? "line" : "polygon",
               c.footprints.chordTolerance);
  const gis::overlay::LineShape& s = c.style.shape;
  if (c.kind == LayerKind::Line) {
    std::fprintf(stderr, "width %.17g, join %d, cap %d, miter limit %.17g, width in pixels %.17g\n", s.width,
                 static_cast<int>(s.join), static_cast<int>(s.cap), s.miterLimit, s.widthPixels);
  }
  auto points = [](const char* what, const std::vector<glm::dvec2>& ps) {
    std::fprintf(stderr, "  %s:", what);
    for (const glm::dvec2& p : ps) std::fprintf(stderr, " (%.17g, %.17g)", p.x, p.y);
    std::fprintf(stderr, "\n");
  };
  for (const gis::geo::Polygon& p : c.feature.polygons) {
    points("outer", p.outer);
    for (const gis::geo::Ring& h : p.holes) points("hole", h);
  }
  for (const gis::geo::LineString& l : c.feature.lines) points("line", l);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  const Case c = decode(in);
  if (std::getenv("STENCIL_GIS_FUZZ_VERBOSE") != nullptr) describe(c);
  const FuzzTerrain terrain(c.terrainGrid, in);
  gis::overlay::FeatureStyle style = c.style;
  if (c.kind == LayerKind::Line) gis::overlay::assignAnchorHeights(style, c.feature, terrain);
  for (const Variant& v : kVariants) checkVariant(c, terrain, style, v);
  return 0;
}
