#include "globe/globe_terrain.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <list>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include <glm/geometric.hpp>

#include "gfx/camera.hpp"
#include "gfx/program.hpp"

namespace gis::globe {
namespace {

constexpr double kRadiansPerDegree = 3.14159265358979323846 / 180.0;
/// The greatest radius of curvature of the ellipsoid (the meridian's at the poles, a² / b).
constexpr double kMaxCurvatureRadius = kSemiMajor * kSemiMajor / kSemiMinor;

enum Side { kWest = 0, kEast = 1, kSouth = 2, kNorth = 3 };

std::size_t postIndex(int i, int j) { return static_cast<std::size_t>(j * kTilePosts + i); }

/// How far below its posts a tile's own triangles can sag: triangleSag of a cell's diagonal (the
/// longest edge of an interior triangle; border triangles are covered by the contract's margin).
double meshSag(const TileKey& key) { return triangleSag(std::sqrt(2.0) * key.postStep() * kMetresPerDegreeMax); }

/// Posts of level L around a box that the drawn ground over it comes from, and the longest
/// triangle over it, in posts of level L (globe_terrain.hpp: the contract).
constexpr double kContractReachPosts = 5.0;
constexpr double kContractTrianglePosts = 6.5;

/// The contract's sag (globe_terrain.hpp): what the overlay and the horizon test allow for.
double contractSag(int level) {
  return triangleSag(kContractTrianglePosts * kMetresPerDegreeMax * TileKey{level, 0, 0}.postStep());
}
double contractSag(const TileKey& key) { return contractSag(key.level); }

/// The tile of the same level across `side`; none across a pole. Longitudes wrap.
std::optional<TileKey> neighbour(const TileKey& k, int side) {
  switch (side) {
    case kWest:
      return TileKey{k.level, (k.x + k.columns() - 1) % k.columns(), k.y};
    case kEast:
      return TileKey{k.level, (k.x + 1) % k.columns(), k.y};
    case kSouth:
      return k.y > 0 ? std::optional<TileKey>(TileKey{k.level, k.x, k.y - 1}) : std::nullopt;
    default:
      return k.y + 1 < k.rows() ? std::optional<TileKey>(TileKey{k.level, k.x, k.y + 1}) : std::nullopt;
  }
}

/// The two children of `n`, the neighbour on `side` of some tile, along the edge they share.
std::array<TileKey, 2> childrenFacing(const TileKey& n, int side) {
  const auto c = n.children();  // SW, SE, NW, NE
  switch (side) {
    case kWest:
      return {c[1], c[3]};  // a west neighbour's east children
    case kEast:
      return {c[0], c[2]};  // an east neighbour's west children
    case kSouth:
      return {c[2], c[3]};  // a south neighbour's north children
    default:
      return {c[0], c[1]};  // a north neighbour's south children
  }
}

/// An axis-aligned box in ECEF holding every point of a tile's rectangle at heights in
/// [hLow, hHigh]: a grid of samples at both heights, widened by how far the meridian and parallel
/// arcs between samples can bulge out of their chords (an arc turning by θ with curvature radius
/// ≤ R stays within R θ tan(θ/2) / 2 of its chord; a point inside a cell lies on a parallel arc
/// between two meridian arcs, and heights enter linearly along the normal).
struct Box {
  glm::dvec3 lo{std::numeric_limits<double>::max()};
  glm::dvec3 hi{-std::numeric_limits<double>::max()};
  void add(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
};

/// How far (metres) the surface up to height `hi` bulges out of points sampled `step` degrees
/// apart in longitude and latitude.
double bulgeBetween(double step, double hi) {
  const double theta = step * kRadiansPerDegree;
  const double top = std::max(hi, 0.0);
  const double arc = theta * std::tan(0.5 * theta) * 0.5;
  return ((kMaxCurvatureRadius + top) * arc + (kSemiMajor + top) * arc) * 1.05 + 0.01;
}

/// The tile's boxes over [lo, hi] (its surface: the level of detail's distance) and over
/// [min(lo, occluder), hi] (culling: down to the horizon test's ellipsoid).
std::pair<Box, Box> tileBoxes(const TileKey& key, double lo, double hi, double occluder) {
  const int n = key.level <= 4 ? 9 : (key.level <= 8 ? 5 : 3);
  const LonLatRect r = key.rect();
  const double step = key.size() / (n - 1);
  Box surface, reach;
  for (int j = 0; j < n; ++j) {
    const double lat = j == n - 1 ? r.north : r.south + j * step;
    for (int i = 0; i < n; ++i) {
      const double lon = i == n - 1 ? r.east : r.west + i * step;
      surface.add(toEcef(lon, lat, lo));
      surface.add(toEcef(lon, lat, hi));
      if (occluder < lo) reach.add(toEcef(lon, lat, occluder));
    }
  }
  const double bulge = bulgeBetween(step, hi);
  surface.lo -= glm::dvec3(bulge);
  surface.hi += glm::dvec3(bulge);
  reach.lo = glm::min(reach.lo - glm::dvec3(bulge), surface.lo);
  reach.hi = glm::max(reach.hi + glm::dvec3(bulge), surface.hi);
  return {surface, reach};
}

/// Heights of a tile's posts, as the mesh holds them.
std::vector<double> postHeights(const GeoGrid& heights, const TileKey& key) {
  std::vector<double> h(static_cast<std::size_t>(kTilePosts * kTilePosts));
  for (int j = 0; j < kTilePosts; ++j) {
    const double lat = key.postLat(j);
    for (int i = 0; i < kTilePosts; ++i) h[postIndex(i, j)] = heights.heightAt(key.postLon(i), lat);
  }
  return h;
}

/// Orders a triangle of posts counter-clockwise in (i east, j north), which is counter-clockwise
/// seen from outside the ellipsoid.
void pushTriangle(std::vector<std::uint16_t>& out, glm::ivec2 a, glm::ivec2 b, glm::ivec2 c) {
  const int area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  assert(area != 0);
  if (area < 0) std::swap(b, c);
  for (const glm::ivec2& p : {a, b, c}) out.push_back(static_cast<std::uint16_t>(postIndex(p.x, p.y)));
}

/// The border strip of one side: a zipper by position between the outer row (every post, or the
/// even ones when the side is stitched) and the inner row (posts 1 ... 31 one row in). The four
/// strips meet along the cells' corner diagonals, so they and the interior tile the square.
void pushBorder(std::vector<std::uint16_t>& out, int side, bool stitched) {
  const auto post = [side](int t, int depth) {
    switch (side) {
      case kWest:
        return glm::ivec2(depth, t);
      case kEast:
        return glm::ivec2(kTileSegments - depth, t);
      case kSouth:
        return glm::ivec2(t, depth);
      default:
        return glm::ivec2(t, kTileSegments - depth);
    }
  };
  std::vector<int> outer, inner;
  for (int t = 0; t <= kTileSegments; t += stitched ? 2 : 1) outer.push_back(t);
  for (int t = 1; t < kTileSegments; ++t) inner.push_back(t);
  std::size_t a = 0, b = 0;
  while (a + 1 < outer.size() || b + 1 < inner.size()) {
    const bool advanceOuter = b + 1 == inner.size() || (a + 1 < outer.size() && outer[a + 1] <= inner[b + 1]);
    if (advanceOuter) {
      pushTriangle(out, post(outer[a], 0), post(outer[a + 1], 0), post(inner[b], 1));
      ++a;
    } else {
      pushTriangle(out, post(outer[a], 0), post(inner[b + 1], 1), post(inner[b], 1));
      ++b;
    }
  }
}

std::pair<double, double> boxBounds(const GeoGrid& heights, const LonLatRect& box) { return heights.bounds(box); }

}  // namespace

std::pair<double, double> groundBounds(const GeoGrid& heights, const LonLatRect& box, int level) {
  const double reach = kContractReachPosts * TileKey{level, 0, 0}.postStep();
  const auto [lo, hi] = heights.bounds(box.expanded(reach, reach));
  return {lo - contractSag(level), hi};
}

std::pair<double, double> terrainBounds(const GeoGrid& heights, const TileKey& key) {
  return groundBounds(heights, key.rect(), key.level);
}

std::pair<glm::dvec3, glm::dvec3> ecefBoxOf(const LonLatRect& box, double lo, double hi) {
  constexpr int kSamples = 9;
  const double south = std::clamp(box.south, -90.0, 90.0), north = std::clamp(box.north, -90.0, 90.0);
  const double width = std::min(box.east - box.west, 360.0);
  const double dLon = width / (kSamples - 1), dLat = (north - south) / (kSamples - 1);
  Box out;
  for (int j = 0; j < kSamples; ++j) {
    for (int i = 0; i < kSamples; ++i) {
      out.add(toEcef(box.west + i * dLon, south + j * dLat, lo));
      out.add(toEcef(box.west + i * dLon, south + j * dLat, hi));
    }
  }
  const double bulge = bulgeBetween(std::max(dLon, dLat), hi);
  return {out.lo - glm::dvec3(bulge), out.hi + glm::dvec3(bulge)};
}

std::vector<glm::dvec3> tilePostPositions(const GeoGrid& heights, const TileKey& key) {
  std::vector<glm::dvec3> out(static_cast<std::size_t>(kTilePosts * kTilePosts));
  for (int j = 0; j < kTilePosts; ++j) {
    const double lat = key.postLat(j);
    for (int i = 0; i < kTilePosts; ++i) {
      const double lon = key.postLon(i);
      out[postIndex(i, j)] = toEcef(lon, lat, heights.heightAt(lon, lat));
    }
  }
  return out;
}

std::vector<std::uint16_t> tileTriangles(std::uint8_t stitch) {
  std::vector<std::uint16_t> out;
  // Interior cells (posts 1 ... 31 both ways), split along the south-west → north-east diagonal.
  for (int j = 1; j + 1 < kTileSegments; ++j) {
    for (int i = 1; i + 1 < kTileSegments; ++i) {
      pushTriangle(out, {i, j}, {i + 1, j}, {i + 1, j + 1});
      pushTriangle(out, {i, j}, {i + 1, j + 1}, {i, j + 1});
    }
  }
  for (int side = 0; side < 4; ++side)
    pushBorder(out, side, ((static_cast<unsigned>(stitch) >> static_cast<unsigned>(side)) & 1U) != 0);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Level of detail (no GL).

namespace {

struct TileInfo {
  double error = 0.0;         ///< metres: geometric error of the tile's mesh
  double lo = 0.0, hi = 0.0;  ///< least and greatest height of its posts
};

/// A tile's height range and geometric error (metres). The mesh lies within its posts' range
/// (straight chords between points at most so high stay at most so high; the boxes below hold the
/// points between posts at every height of the range, so the sag needs no margin there).
/// The error is measured: the largest difference between the DEM at the next level's posts and
/// this tile's mesh there (interpolated in longitude and latitude over the interior cells'
/// triangulation), plus the sag of its triangles below the curved surface. Where even the next
/// level's posts are sparser than the DEM's (post step > 2 DEM steps) the measure could miss
/// detail between them, so the error is at least GeoGrid::bounds' range of the tile then. The
/// cells beside a pole are left out: every level collapses the pole to one height (heightAt's
/// there) while the DEM beside it may differ, a step no refinement removes, only narrows.
TileInfo measureTile(const GeoGrid& heights, const TileKey& key, int maxLevel) {
  const std::vector<double> h = postHeights(heights, key);
  TileInfo out;
  const auto [lo, hi] = std::minmax_element(h.begin(), h.end());
  out.lo = *lo;
  out.hi = *hi;
  if (key.level >= maxLevel) return out;                     // never refined
  const TileKey child{key.level + 1, 2 * key.x, 2 * key.y};  // its posts (0 ... 64) cover the tile
  double err = 0.0;
  constexpr int kChildPosts = 2 * kTileSegments + 1;
  for (int jj = 0; jj < kChildPosts; ++jj) {
    if ((jj == 1 && key.y == 0) || (jj == kChildPosts - 2 && key.y == key.rows() - 1)) continue;
    const int j = std::min(jj / 2, kTileSegments - 1);
    const double v = 0.5 * (jj - 2 * j);
    const double lat = child.postLat(jj);
    for (int ii = 0; ii < kChildPosts; ++ii) {
      if (ii % 2 == 0 && jj % 2 == 0) continue;  // this tile's own post
      const int i = std::min(ii / 2, kTileSegments - 1);
      const double u = 0.5 * (ii - 2 * i);
      const double ha = h[postIndex(i, j)], hb = h[postIndex(i + 1, j)];
      const double hc = h[postIndex(i + 1, j + 1)], hd = h[postIndex(i, j + 1)];
      const double mesh = u >= v ? ha + u * (hb - ha) + v * (hc - hb) : ha + v * (hd - ha) + u * (hc - hd);
      err = std::max(err, std::abs(heights.heightAt(child.postLon(ii), lat) - mesh));
    }
  }
  if (key.postStep() > 2.0 * heights.step()) {
    const auto [blo, bhi] = boxBounds(heights, key.rect());
    err = std::max(err, bhi - blo);
  }
  out.error = err + meshSag(key);
  return out;
}

struct Leaf {
  bool culled = false;
  double distance = 0.0;  ///< eye to the tile's box
};

}  // namespace

struct GlobeTerrain::Lod {
  std::mutex mutex;
  std::unordered_map<TileKey, TileInfo, TileKeyHash> tiles;
  double globalLo = 0.0;  ///< the lowest ground anywhere
};

GlobeTerrain::GlobeTerrain(std::shared_ptr<const GeoGrid> heights, TerrainOptions options)
    : heights_(std::move(heights)), options_(options), lod_(std::make_unique<Lod>()) {
  lod_->globalLo = heights_->bounds({-180.0, -90.0, 180.0, 90.0}).first;
}

std::vector<DrawnTile> GlobeTerrain::select(const GlobeView& view) const {
  const GeoGrid& grid = *heights_;
  Lod& lod = *lod_;
  const std::lock_guard lock(lod.mutex);
  if (lod.tiles.size() > (std::size_t{1} << 18)) lod.tiles.clear();  // bounded memory
  const int maxLevel = std::clamp(options_.maxLevel, 0, kMaxLevel);
  const auto info = [&](const TileKey& key) -> const TileInfo& {
    auto found = lod.tiles.find(key);
    if (found != lod.tiles.end()) return found->second;
    return lod.tiles.emplace(key, measureTile(grid, key, maxLevel)).first->second;
  };
  const std::array<glm::dvec4, 6> frustum = view.eyeFrustum();

  std::unordered_map<TileKey, Leaf, TileKeyHash> leaves;
  std::unordered_set<TileKey, TileKeyHash> internal;
  double occluder = 0.0;

  // Culling: the frustum, and the horizon of the ellipsoid at `occluder` (every corner of the box
  // hidden; the hidden region is convex). The box reaches down to the occluder so that a point of
  // the occluder the eye sees always lies in the box of a tile that is drawn.
  const auto classify = [&](const TileKey& key, Leaf& leaf) {
    const TileInfo& t = info(key);
    const auto [surface, box] = tileBoxes(key, t.lo, t.hi, occluder);
    leaf.distance = glm::length(glm::max(glm::max(surface.lo - view.eye, view.eye - surface.hi), glm::dvec3(0.0)));
    const glm::dvec3 lo = box.lo - view.eye, hi = box.hi - view.eye;
    if (!gfx::boxInFrustum(frustum, lo, hi)) {
      leaf.culled = true;
      return;
    }
    bool hidden = true;
    for (int c = 0; c < 8 && hidden; ++c) {
      const glm::dvec3 corner((c & 1) != 0 ? box.hi.x : box.lo.x, (c & 2) != 0 ? box.hi.y : box.lo.y,
                              (c & 4) != 0 ? box.hi.z : box.lo.z);
      hidden = hiddenByEllipsoid(view.eye, corner, occluder);
    }
    leaf.culled = hidden;
  };
  const auto refine = [&](const auto& self, const TileKey& key) -> void {
    Leaf leaf;
    classify(key, leaf);
    if (!leaf.culled && key.level < maxLevel) {
      const double pixel = view.pixelSizeAt(leaf.distance);
      // Posts along the parallel at the tile's equatorward side: near a pole, where columns
      // converge, the tiles around it are not split by this (they would all be: 2^(L+1) of them).
      const LonLatRect r = key.rect();
      const double widest = (r.south <= 0.0 && r.north >= 0.0) ? 0.0 : std::min(std::abs(r.south), std::abs(r.north));
      const double postMetres =
          key.postStep() * kMetresPerDegreeMax * std::cos(widest * 3.14159265358979323846 / 180.0);
      if (pixel <= 0.0 || info(key).error > options_.maxScreenError * pixel ||
          (options_.maxPostPixels > 0.0 && postMetres > options_.maxPostPixels * pixel)) {
        internal.insert(key);
        for (const TileKey& c : key.children()) self(self, c);
        return;
      }
    }
    leaves.emplace(key, leaf);
  };
  // The leaf covering the region of `key` (key itself or an ancestor), if any.
  const auto coveringLeaf = [&](TileKey key) -> std::optional<TileKey> {
    while (true) {
      if (leaves.count(key) != 0) return key;
      if (key.level == 0) return std::nullopt;
      key = key.parent();
    }
  };
  // Splits leaves until edge neighbours differ by at most one level, over every leaf (culled ones
  // too: they are dropped afterwards without breaking the rule for the drawn ones).
  const auto balance = [&] {
    std::vector<TileKey> work;
    work.reserve(leaves.size());
    for (const auto& [key, leaf] : leaves) work.push_back(key);
    while (!work.empty()) {
      const TileKey key = work.back();
      work.pop_back();
      const auto found = leaves.find(key);
      if (found == leaves.end()) continue;
      bool split = false;
      for (int side = 0; side < 4 && !split; ++side) {
        const std::optional<TileKey> n = neighbour(key, side);
        if (!n || internal.count(*n) == 0) continue;
        for (const TileKey& c : childrenFacing(*n, side)) split = split || internal.count(c) != 0;
      }
      if (!split) continue;
      const bool culled = found->second.culled;
      leaves.erase(found);
      internal.insert(key);
      for (const TileKey& c : key.children()) {
        Leaf leaf{true, 0.0};
        if (!culled) classify(c, leaf);  // children of a culled tile are culled
        leaves.emplace(c, leaf);
        work.push_back(c);
      }
      for (int side = 0; side < 4; ++side) {
        const std::optional<TileKey> n = neighbour(key, side);
        if (!n) continue;
        const std::optional<TileKey> cover = coveringLeaf(*n);
        if (cover && cover->level < key.level) work.push_back(*cover);
      }
    }
  };

  // The horizon test may hide a tile only behind an ellipsoid that the drawn meshes enclose: the
  // lowest ground less the sag of the coarsest drawn tile. That depends on what is drawn, so the
  // selection is repeated with the occluder lowered until it holds (two passes, rarely three).
  const double ground = std::min(static_cast<double>(options_.occluderHeight), lod.globalLo);
  double sag = 0.0;
  for (int pass = 0;; ++pass) {
    // Last resort: an occluder deep inside every mesh (almost no horizon culling).
    occluder = pass < 4 ? ground - sag : -0.5 * kSemiMinor;
    leaves.clear();
    internal.clear();
    for (int x = 0; x < 2; ++x) refine(refine, TileKey{0, x, 0});
    balance();
    double drawnSag = 0.0;
    for (const auto& [key, leaf] : leaves) {
      if (!leaf.culled) drawnSag = std::max(drawnSag, contractSag(key));
    }
    if (drawnSag <= sag || pass >= 4) break;
    sag = drawnSag;
  }

  std::vector<std::pair<double, DrawnTile>> drawn;
  for (const auto& [key, leaf] : leaves) {
    if (leaf.culled) continue;
    DrawnTile d{key, 0};
    for (int side = 0; side < 4; ++side) {
      const std::optional<TileKey> n = neighbour(key, side);
      if (n && n->level > 0 && leaves.count(n->parent()) != 0) d.stitch |= static_cast<std::uint8_t>(1U << side);
    }
    drawn.emplace_back(leaf.distance, d);
  }
  // Near to far (early depth rejection), ties by key for a stable order.
  std::sort(drawn.begin(), drawn.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first < b.first : a.second.key.id() < b.second.key.id();
  });
  std::vector<DrawnTile> out;
  out.reserve(drawn.size());
  for (const auto& [distance, d] : drawn) out.push_back(d);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Drawing.

namespace {

struct TileVertex {
  glm::vec3 high;  ///< splitPosition of the ECEF post
  glm::vec3 low;
  float height;  ///< metres above the ellipsoid, for the colour
};
static_assert(sizeof(TileVertex) == 28);

}  // namespace

struct GlobeTerrain::Gpu {
  struct Mesh {
    gfx::BufferHandle vertices;
    gfx::VertexArrayHandle vao;
    std::list<TileKey>::iterator lru;
    enum class Imagery { Unknown, None, Ready } imagery = Imagery::Unknown;
    gfx::TextureHandle texture;
    std::size_t textureBytes = 0;
  };
  gfx::Program program;
  std::array<gfx::BufferHandle, 16> indices;
  std::array<GLsizei, 16> indexCounts{};
  std::unordered_map<TileKey, Mesh, TileKeyHash> meshes;
  std::list<TileKey> lru;  ///< most recently drawn first
  std::size_t textureBytes = 0;
};

void GlobeTerrain::setImagery(std::shared_ptr<const GlobeImagery> imagery) {
  imagery_ = std::move(imagery);
  if (!gpu_) return;
  for (auto& [key, mesh] : gpu_->meshes) {
    mesh.imagery = Gpu::Mesh::Imagery::Unknown;
    mesh.texture = {};
    mesh.textureBytes = 0;
  }
  gpu_->textureBytes = 0;
}

namespace {

/// A tile's texels as a mip-mapped RGBA8 texture (row 0 at the south: t = j / 32).
gfx::TextureHandle uploadTileImage(const TileImage& image) {
  gfx::TextureHandle texture = gfx::createTexture(GL_TEXTURE_2D);
  const GLuint id = texture.id();
  int levels = 1;
  while ((image.size >> levels) > 0) ++levels;
  glTextureStorage2D(id, levels, GL_RGBA8, image.size, image.size);
  glTextureSubImage2D(id, 0, 0, 0, image.size, image.size, GL_RGBA, GL_UNSIGNED_BYTE, image.rgba.data());
  glGenerateTextureMipmap(id);
  glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

}  // namespace

GlobeTerrain::~GlobeTerrain() = default;

void GlobeTerrain::draw(gfx::StateCache& cache, const GlobeView& view, const std::vector<DrawnTile>& tiles,
                        const gfx::SurfaceDrape* drape) {
  stats_ = {};
  if (!gpu_) {
    Result<gfx::Program> program = gfx::Program::build({{"globe_terrain.vert", {}}, {"globe_terrain.frag", {}}});
    assert(program.ok() && "the embedded globe terrain shaders must build");
    if (!program.ok()) return;
    auto gpu = std::make_unique<Gpu>();
    gpu->program = std::move(*program);
    for (std::uint8_t mask = 0; mask < 16; ++mask) {
      const std::vector<std::uint16_t> indices = tileTriangles(mask);
      gpu->indices[mask] = gfx::createBufferWithData(indices.data(), indices.size() * sizeof(std::uint16_t));
      gpu->indexCounts[mask] = static_cast<GLsizei>(indices.size());
    }
    gpu_ = std::move(gpu);
  }
  Gpu& gpu = *gpu_;
  // Back faces culled: every triangle is counter-clockwise seen from outside the ellipsoid.
  cache.apply(gfx::kOpaque);
  cache.useProgram(gpu.program);
  gpu.program.set("u_eyeViewProj", glm::mat4(view.eyeViewProj()));
  const SplitPosition eye = view.eyeSplit();
  gpu.program.set("u_eyeHigh", eye.high);
  gpu.program.set("u_eyeLow", eye.low);
  gpu.program.set("u_imagery", 0);
  bool imageryBound = false;
  gpu.program.set("u_hasImagery", 0);
  // A texture drape: one texture over a box of longitude and latitude, or a layer of the arrays
  // per tile; the tile's uv (linear in both) mapped into it.
  gpu.program.set("u_drape", 1);
  gpu.program.set("u_drapeMask", 2);
  gpu.program.set("u_drapeTiles", 3);
  gpu.program.set("u_drapeTileMask", 4);
  const bool tiledDrape = drape != nullptr && drape->tileOf;
  gpu.program.set("u_hasDrape", drape != nullptr ? 1 : 0);
  gpu.program.set("u_drapeTiled", tiledDrape ? 1 : 0);
  if (drape != nullptr && !tiledDrape) {
    cache.bindTexture(1, drape->color);
    cache.bindTexture(2, drape->mask);
  } else if (tiledDrape) {
    cache.bindTexture(3, drape->colorArray);
    cache.bindTexture(4, drape->maskArray);
  }
  const auto drapeOver = [&](const TileKey& key, const glm::dvec2& origin, const glm::dvec2& size) {
    const LonLatRect r = key.rect();
    gpu.program.set("u_drapeUvBase", glm::vec2((glm::dvec2(r.west, r.south) - origin) / size));
    gpu.program.set("u_drapeUvScale", glm::vec2(glm::dvec2(r.east - r.west, r.north - r.south) / size));
  };
  const auto buildStart = std::chrono::steady_clock::now();

  for (const DrawnTile& tile : tiles) {
    auto found = gpu.meshes.find(tile.key);
    if (found == gpu.meshes.end()) {
      const std::vector<glm::dvec3> positions = tilePostPositions(*heights_, tile.key);
      std::vector<TileVertex> vertices(positions.size());
      for (int j = 0; j < kTilePosts; ++j) {
        for (int i = 0; i < kTilePosts; ++i) {
          const std::size_t k = postIndex(i, j);
          const SplitPosition s = splitPosition(positions[k]);
          const double h = heights_->heightAt(tile.key.postLon(i), tile.key.postLat(j));
          vertices[k] = {s.high, s.low, static_cast<float>(h)};
        }
      }
      Gpu::Mesh mesh;
      mesh.vertices = gfx::createBufferWithData(vertices.data(), vertices.size() * sizeof(TileVertex));
      mesh.vao = gfx::createVertexArray();
      const GLuint vao = mesh.vao.id();
      glVertexArrayVertexBuffer(vao, 0, mesh.vertices.id(), 0, sizeof(TileVertex));
      const std::array<std::pair<GLint, std::size_t>, 3> attributes{
          {{3, offsetof(TileVertex, high)}, {3, offsetof(TileVertex, low)}, {1, offsetof(TileVertex, height)}}};
      for (GLuint a = 0; a < attributes.size(); ++a) {
        glEnableVertexArrayAttrib(vao, a);
        glVertexArrayAttribFormat(vao, a, attributes[a].first, GL_FLOAT, GL_FALSE,
                                  static_cast<GLuint>(attributes[a].second));
        glVertexArrayAttribBinding(vao, a, 0);
      }
      gpu.lru.push_front(tile.key);
      mesh.lru = gpu.lru.begin();
      found = gpu.meshes.emplace(tile.key, std::move(mesh)).first;
      ++stats_.uploads;
    } else {
      gpu.lru.splice(gpu.lru.begin(), gpu.lru, found->second.lru);
    }
    Gpu::Mesh& mesh = found->second;
    if (imagery_ && mesh.imagery == Gpu::Mesh::Imagery::Unknown) {
      if (!imagery_->covers(tile.key)) {
        mesh.imagery = Gpu::Mesh::Imagery::None;
      } else if (stats_.imageryBuilt < std::max<std::size_t>(options_.imageryTilesPerFrame, 1) &&
                 (stats_.imageryBuilt == 0 ||
                  std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - buildStart).count() <
                      options_.imageryMillisecondsPerFrame)) {
        const std::optional<TileImage> image = imagery_->tileImage(tile.key);
        ++stats_.imageryBuilt;
        if (image) {
          mesh.texture = uploadTileImage(*image);
          // The mip chain adds a third.
          mesh.textureBytes = static_cast<std::size_t>(image->size) * static_cast<std::size_t>(image->size) * 4 * 4 / 3;
          gpu.textureBytes += mesh.textureBytes;
          mesh.imagery = Gpu::Mesh::Imagery::Ready;
        } else {
          mesh.imagery = Gpu::Mesh::Imagery::None;
        }
      } else {
        ++stats_.imageryPending;
      }
    }
    const bool textured = mesh.imagery == Gpu::Mesh::Imagery::Ready;
    if (textured) {
      cache.bindTexture(0, mesh.texture.id());
      ++stats_.imageryTiles;
    }
    if (textured != imageryBound) {
      gpu.program.set("u_hasImagery", textured ? 1 : 0);
      imageryBound = textured;
    }
    if (tiledDrape) {
      const auto drawn = drape->tileOf(tile.key.id());
      gpu.program.set("u_hasDrape", drawn ? 1 : 0);
      if (drawn) {
        const auto& [layer, origin, size] = *drawn;
        gpu.program.set("u_drapeLayer", layer);
        drapeOver(tile.key, origin, size);
      }
    } else if (drape != nullptr) {
      drapeOver(tile.key, drape->origin, drape->size);
    }
    const std::uint8_t mask = tile.stitch & 15U;
    glVertexArrayElementBuffer(found->second.vao.id(), gpu.indices[mask].id());
    cache.bindVertexArray(found->second.vao.id());
    glDrawElements(GL_TRIANGLES, gpu.indexCounts[mask], GL_UNSIGNED_SHORT, nullptr);
    ++stats_.tiles;
    stats_.triangles += static_cast<std::size_t>(gpu.indexCounts[mask]) / 3;
  }
  // This frame's meshes are the most recent: the least recently drawn go first, down to the
  // mesh count and the textures' budget (never this frame's own tiles for the textures).
  const auto textureBudget = static_cast<std::size_t>(std::max(options_.imageryGpuBudgetMb, 0.0) * 1024.0 * 1024.0);
  while (!gpu.lru.empty() && (gpu.meshes.size() > std::max<std::size_t>(options_.cacheTiles, 1) ||
                              (gpu.textureBytes > textureBudget && gpu.meshes.size() > tiles.size()))) {
    const auto evicted = gpu.meshes.find(gpu.lru.back());
    gpu.textureBytes -= evicted->second.textureBytes;
    gpu.meshes.erase(evicted);
    gpu.lru.pop_back();
  }
  if (stats_.imageryTiles > 0) cache.bindTexture(0, 0);
  if (drape != nullptr) {
    for (GLuint unit = 1; unit <= 4; ++unit) cache.bindTexture(unit, 0);
  }
  stats_.resident = gpu.meshes.size();
  stats_.meshBytes = gpu.meshes.size() * kTilePosts * kTilePosts * sizeof(TileVertex);
  stats_.imageryBytes = gpu.textureBytes;
}

}  // namespace gis::globe
