#include "vector_overlay/tiled_layer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "core/hash.hpp"
#include "gfx/camera.hpp"
#include "tile_cache.hpp"
#include "vector_overlay/generalise.hpp"
#include "vector_overlay/pieces_fingerprint.hpp"

namespace gis::overlay {
namespace {

/// Lines with a least width in pixels: their width in metres (the narrowest they are drawn).
double metreWidth(const LineShape& shape) { return shape.minWidth > 0.0 ? shape.minWidth : shape.width; }

/// How far a line's footprint reaches from its centre line (the widest of its shapes; for lines
/// with a least width in pixels, at that least width: tiles of a wider class grow their box).
double lineReach(const LineShape& shape) {
  double k = 1.0;
  if (shape.cap == LineCap::Square) k = std::max(k, std::numbers::sqrt2);
  if (shape.join == LineJoin::Miter) k = std::max(k, std::max(1.0, shape.miterLimit));
  return 0.5 * metreWidth(shape) * k;
}

bool meets(const std::pair<glm::dvec2, glm::dvec2>& a, const glm::dvec2& lo, const glm::dvec2& hi) {
  return !(a.second.x < lo.x || a.second.y < lo.y || a.first.x > hi.x || a.first.y > hi.y);
}

}  // namespace

LayerTiling::LayerTiling(const LayerGeometry& source, const HeightBoundsProvider& bounds,
                         const LayerBuildOptions& options, const TilingOptions& tiling)
    : source_(&source), bounds_(&bounds), options_(options), tiling_(tiling) {
  const std::size_t count = source.sharedFeatures().size();
  reach_.assign(count, 0.0);
  boxes_.assign(count, {glm::dvec2(1.0), glm::dvec2(-1.0)});
  glm::dvec2 all0(std::numeric_limits<double>::infinity()), all1(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < count; ++i) {
    measure(static_cast<std::uint32_t>(i));
    const auto& [lo, hi] = boxes_[i];
    if (!(lo.x <= hi.x && lo.y <= hi.y)) continue;
    all0 = glm::min(all0, lo);
    all1 = glm::max(all1, hi);
  }
  if (options.footprints.cells) {
    grid_ = *options.footprints.cells;
  } else {
    // No terrain grid: one over the features (the pieces are not clipped to a terrain).
    grid_.origin = std::isfinite(all0.x) ? all0 : glm::dvec2(0.0);
    const glm::dvec2 size = std::isfinite(all0.x) ? glm::max(all1 - all0, glm::dvec2(1.0)) : glm::dvec2(1.0);
    grid_.cellSize = std::max(size.x, size.y) / 256.0;
    grid_.columns = static_cast<int>(std::ceil(size.x / grid_.cellSize));
    grid_.rows = static_cast<int>(std::ceil(size.y / grid_.cellSize));
  }
  origin_ = grid_.origin;
  // A small terrain still gets 8 finest tiles a side (of at least a cell): tiles are what
  // culling, detail and the lines' width classes choose between.
  const int cellsAcross = std::max(grid_.columns, grid_.rows);
  const double finest = std::clamp(cellsAcross / 8, 1, std::max(1, tiling_.finestTileCells)) * grid_.cellSize;
  const double extent = std::max(grid_.columns, grid_.rows) * grid_.cellSize;
  finestLevel_ = 0;
  while (finest * static_cast<double>(1 << finestLevel_) < extent && finestLevel_ < 24) ++finestLevel_;
  rootSize_ = finest * static_cast<double>(1 << finestLevel_);
  // Buckets: a grid of at most 128² over the root tile.
  buckets_ = std::clamp(2 << finestLevel_, 1, 128);
  bucket_.assign(static_cast<std::size_t>(buckets_) * static_cast<std::size_t>(buckets_), {});
  for (std::size_t i = 0; i < count; ++i) fill(static_cast<std::uint32_t>(i));
  if (!tiling_.cacheDirectory.empty()) {
    fingerprint_ = fingerprint();
    char name[17];
    std::snprintf(name, sizeof(name), "%016llx", static_cast<unsigned long long>(fingerprint_));
    cacheFolder_ = (std::filesystem::path(tiling_.cacheDirectory) / name).string();
    // Folders no layer opens any more (older features, terrain or code) leave, oldest first.
    (void)pruneTileFolders(tiling_.cacheDirectory, cacheFolder_, tiling_.cacheBudgetBytes);
    cacheRevision_ = tiling_.cacheRevision;
    cacheUsable_ = bounds.revision() == cacheRevision_;
  }
}

std::uint64_t LayerTiling::fingerprint() const {
  StableHasher h;
  h.add(std::string_view("stencil-gis vector tiles 2"));
  h.add(std::string_view(STENCIL_GIS_PIECES_FINGERPRINT));  // the code that builds them
  h.add(tiling_.cacheKey);
  h.add(static_cast<std::uint64_t>(source_->kind()));
  const FootprintOptions& fo = options_.footprints;
  for (const double v :
       {grid_.origin.x, grid_.origin.y, grid_.cellSize, fo.chordTolerance, fo.chordTolerancePixels, options_.splitGain})
    h.add(v);
  for (const int v :
       {grid_.columns, grid_.rows, fo.lineCellDivisions, tiling_.tileResolution, tiling_.finestTileCells,
        tiling_.cellsPerTile, fo.uniteLines ? 1 : 0, options_.adaptiveSplit ? 1 : 0, options_.paperVariant ? 1 : 0})
    h.add(static_cast<std::uint64_t>(static_cast<std::int64_t>(v)));
  // The features as the layer hashed them when it was built, else hashed here alike.
  const std::uint64_t content = source_->contentFingerprint();
  h.add(content != 0 ? content
                     : featuresFingerprint(source_->sharedFeatures(), source_->featureStyles(), source_->kind()));
  return h.value();
}

void LayerTiling::measure(std::uint32_t i) {
  const std::vector<FeatureStyle>& styles = source_->featureStyles();
  reach_[i] = 0.0;
  boxes_[i] = {glm::dvec2(1.0), glm::dvec2(-1.0)};
  if (i >= styles.size() || !styles[i].visible) return;
  // The box of its finite points (the builder reports the others), from the index when the
  // features are on disk: nothing is read. A polygon's holes count (a hole outside its outer
  // ring, which the builder repairs or reports, widens the box: conservative).
  const auto [lo, hi] = source_->sharedFeatures().box(i, source_->kind() == LayerKind::Line);
  if (source_->kind() == LayerKind::Line) {
    const LineShape& shape = styles[i].shape;
    reach_[i] = lineReach(shape);
    slack_ = std::max(slack_, lineShapeSlack(shape.join, shape.cap, shape.miterLimit, metreWidth(shape)));
    if (shape.inPixels() && shape.minWidth > 0.0) {
      minPixels_ = std::max(minPixels_, shape.widthPixels);
      leastMinWidth_ = leastMinWidth_ > 0.0 ? std::min(leastMinWidth_, shape.minWidth) : shape.minWidth;
      widestCap_ = std::max(widestCap_, shape.width);
    }
  }
  if (lo.x <= hi.x && lo.y <= hi.y) boxes_[i] = {lo - reach_[i], hi + reach_[i]};
}

bool LayerTiling::bucketRange(const std::pair<glm::dvec2, glm::dvec2>& box, int& x0, int& y0, int& x1, int& y1) const {
  const auto& [lo, hi] = box;
  if (!(lo.x <= hi.x && lo.y <= hi.y)) return false;
  // Outside the terrain: no tile has it (the full build says "nothing to draw").
  if (hi.x < origin_.x || hi.y < origin_.y || lo.x > origin_.x + rootSize_ || lo.y > origin_.y + rootSize_)
    return false;
  const double bucketSize = rootSize_ / buckets_;
  // Clamped as a double first: a box reaching far beyond the terrain (a width of 1e15 m) must not
  // convert an out-of-range double to int.
  const auto index = [&](double v, double o) {
    return static_cast<int>(std::clamp(std::floor((v - o) / bucketSize), 0.0, static_cast<double>(buckets_ - 1)));
  };
  x0 = index(lo.x, origin_.x);
  x1 = index(hi.x, origin_.x);
  y0 = index(lo.y, origin_.y);
  y1 = index(hi.y, origin_.y);
  return true;
}

void LayerTiling::fill(std::uint32_t i) {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  if (!bucketRange(boxes_[i], x0, y0, x1, y1)) return;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
      bucket_[static_cast<std::size_t>(y) * static_cast<std::size_t>(buckets_) + static_cast<std::size_t>(x)].push_back(
          i);
}

void LayerTiling::update(std::uint32_t i) {
  if (i >= boxes_.size()) return;
  cacheUsable_ = false;  // the tiles on disk hold the features as they were
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  if (bucketRange(boxes_[i], x0, y0, x1, y1)) {
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        auto& b =
            bucket_[static_cast<std::size_t>(y) * static_cast<std::size_t>(buckets_) + static_cast<std::size_t>(x)];
        b.erase(std::remove(b.begin(), b.end(), i), b.end());
      }
    }
  }
  measure(i);
  fill(i);
}

double LayerTiling::widestReach() const {
  return reach_.empty() ? 0.0 : *std::max_element(reach_.begin(), reach_.end());
}

std::pair<glm::dvec2, glm::dvec2> LayerTiling::extent(const TileKey& key) const {
  const double size = tileSize(key.level);
  const glm::dvec2 lo = origin_ + size * glm::dvec2(key.x, key.y);
  return {lo, lo + glm::dvec2(size)};
}

std::optional<std::pair<glm::dvec3, glm::dvec3>> LayerTiling::leanBox(const TileKey& key) const {
  if (key.level >= finestLevel_) return std::nullopt;
  const auto [tileLo, tileHi] = extent(key);
  const double grow = widestReach() + (key.width > 0 ? widthClassCap(key.width) : 0.0);
  const HeightBounds z = bounds_->globalBounds();
  const double slack = groundError(key.level);
  return std::pair{glm::dvec3(tileLo - grow, z.lo - slack), glm::dvec3(tileHi + grow, z.hi + slack)};
}

double LayerTiling::groundError(int level) const {
  if (level >= finestLevel_) return 0.0;
  return tileSize(level) / std::max(1, tiling_.tileResolution) + slack_;
}

std::vector<std::uint32_t> LayerTiling::featuresNear(const TileKey& key) const {
  const auto [tileLo, tileHi] = extent(key);
  // A wider class reaches farther: its lines' boxes are widened by their metre reach only.
  const double grow = key.width > 0 ? widthClassCap(key.width) : 0.0;
  const glm::dvec2 lo = tileLo - grow, hi = tileHi + grow;
  const double bucketSize = rootSize_ / buckets_;
  const auto index = [&](double v, double o) {
    return std::clamp(static_cast<int>(std::floor((v - o) / bucketSize)), 0, buckets_ - 1);
  };
  std::vector<std::uint32_t> out;
  const int x0 = index(lo.x, origin_.x), x1 = index(hi.x, origin_.x);
  const int y0 = index(lo.y, origin_.y), y1 = index(hi.y, origin_.y);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      for (std::uint32_t f :
           bucket_[static_cast<std::size_t>(y) * static_cast<std::size_t>(buckets_) + static_cast<std::size_t>(x)])
        if (meets(boxes_[f], lo, hi)) out.push_back(f);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<TileKey> LayerTiling::select(const OverlayView& view, int viewportHeight, std::size_t* culled,
                                         double errorScale) const {
  std::vector<TileKey> out;
  const std::array<glm::dvec4, 6> planes = gfx::frustumPlanes(view.viewProj);
  const double metresPerPixel = pixelScaleOf(view.viewProj, std::max(1, viewportHeight)).metresPerPixel;
  const HeightBounds global = bounds_->globalBounds();
  const double zLo = std::isfinite(global.lo) ? global.lo - 1.0 : -1e4,
               zHi = std::isfinite(global.hi) ? global.hi + 1.0 : 1e4;
  const double bucketSize = rootSize_ / buckets_;
  const auto occupied = [&](const glm::dvec2& lo, const glm::dvec2& hi) {
    const auto index = [&](double v, double o) {
      return std::clamp(static_cast<int>(std::floor((v - o) / bucketSize)), 0, buckets_ - 1);
    };
    const int x0 = index(lo.x, origin_.x), x1 = index(std::nextafter(hi.x, lo.x), origin_.x);
    const int y0 = index(lo.y, origin_.y), y1 = index(std::nextafter(hi.y, lo.y), origin_.y);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        if (!bucket_[static_cast<std::size_t>(y) * static_cast<std::size_t>(buckets_) + static_cast<std::size_t>(x)]
                 .empty())
          return true;
    return false;
  };
  const glm::dvec2 gridEnd = grid_.origin + grid_.cellSize * glm::dvec2(grid_.columns, grid_.rows);
  std::vector<TileKey> stack{{0, 0, 0}};
  while (!stack.empty()) {
    const TileKey key = stack.back();
    stack.pop_back();
    const auto [lo, hi] = extent(key);
    if (lo.x >= gridEnd.x || lo.y >= gridEnd.y) continue;  // no terrain
    // Lines wider than in metres reach up to their class's width beyond the tile (a child's class
    // is never wider than its parent's: its farthest point is no farther).
    const int width = widthClass(key, view.eye, metresPerPixel, zLo, zHi);
    const double grow = width > 0 ? widthClassCap(width) : 0.0;
    if (!occupied(lo - grow, hi + grow)) continue;  // no feature
    const glm::dvec3 lo3(lo - grow, zLo), hi3(hi + grow, zHi);
    if (!gfx::boxInFrustum(planes, lo3, hi3, false)) {
      if (culled != nullptr) ++*culled;
      continue;
    }
    const double distance = glm::length(view.eye - glm::clamp(view.eye, glm::dvec3(lo, zLo), glm::dvec3(hi, zHi)));
    const double error = groundError(key.level);
    if (key.level >= finestLevel_ || error <= tiling_.errorPixels * errorScale * metresPerPixel * distance) {
      out.push_back({key.level, key.x, key.y, width});
      continue;
    }
    for (int k = 3; k >= 0; --k) stack.push_back({key.level + 1, 2 * key.x + (k & 1), 2 * key.y + (k >> 1), 0});
  }
  std::sort(out.begin(), out.end(), [](const TileKey& a, const TileKey& b) { return a.level < b.level; });
  return out;
}

int LayerTiling::widthClass(const TileKey& key, const glm::dvec3& eye, double metresPerPixel, double zLo,
                            double zHi) const {
  if (minPixels_ <= 0.0 || !(metresPerPixel > 0.0)) return 0;
  const std::pair<glm::dvec2, glm::dvec2> box = extent(key);
  // The farthest point of the tile grown by m (the shader measures from the lines' anchored
  // centres, which lie in it, at heights within the global bounds).
  const auto farthest = [&](double m) {
    const glm::dvec3 a(box.first - m, zLo), b(box.second + m, zHi);
    return glm::length(glm::max(glm::abs(eye - a), glm::abs(eye - b)));
  };
  const double need = minPixels_ * metresPerPixel * farthest(0.0);
  if (!(need > leastMinWidth_)) return 0;  // every such line is at least as wide in metres
  int c = std::clamp(static_cast<int>(std::ceil(std::log2(need))) + 8, 1, 60);
  // Centres are cut to the tile grown by half the class's width.
  while (c < 60 && widthClassCap(c) < widestCap_ &&
         minPixels_ * metresPerPixel * farthest(0.5 * widthClassCap(c)) > widthClassCap(c))
    ++c;
  return c;
}

bool LayerTiling::scalableIn(std::uint32_t i, int c) const {
  if (c <= 0 || i >= source_->featureStyles().size()) return false;
  const LineShape& shape = source_->featureStyles()[i].shape;
  return shape.inPixels() && shape.minWidth > 0.0 && widthClassCap(c) > shape.minWidth;
}

FeatureStyle LayerTiling::tileStyle(const TileKey& key, std::uint32_t i) const {
  FeatureStyle s = source_->featureStyles().at(i);
  LineShape& shape = s.shape;
  if (!(shape.inPixels() && shape.minWidth > 0.0)) return s;
  if (scalableIn(i, key.width)) {
    shape.width = std::min(widthClassCap(key.width), shape.width);
  } else {
    shape.width = shape.minWidth;  // in metres: no pixel on this tile is wider
    shape.widthPixels = 0.0;
    shape.minWidth = 0.0;
  }
  return s;
}

double LayerTiling::generalisation(const TileKey& key) const {
  // Three quarters of the level's error to simplification (build() gives the arcs the rest).
  return key.level < finestLevel_ ? 0.75 * tileSize(key.level) / std::max(1, tiling_.tileResolution) : 0.0;
}

std::optional<geo::Feature> LayerTiling::featureFor(const TileKey& key, std::uint32_t i) const {
  if (source_->kind() == LayerKind::Polygon && generalisation(key) > 0.0) {
    // Generalised with its neighbours (their shared borders once): as the tile's build does.
    const std::vector<std::uint32_t> near = featuresNear(key);
    if (std::find(near.begin(), near.end(), i) == near.end()) return std::nullopt;
    std::vector<std::pair<std::uint32_t, geo::Feature>> all = featuresFor(key, near, nullptr);
    for (auto& [index, feature] : all)
      if (index == i) return std::move(feature);
    return std::nullopt;
  }
  const auto [lo, hi] = extent(key);
  // Lines drawn wider than in metres: their centres cut to the tile grown by the half width.
  const bool scalable = scalableIn(i, key.width);
  const double grow = scalable ? 0.5 * tileStyle(key, i).shape.width : 0.0;
  if (i >= boxes_.size() || !meets(boxes_[i], lo - 2.0 * grow, hi + 2.0 * grow)) return std::nullopt;
  const double epsilon = generalisation(key);
  const std::shared_ptr<const geo::Feature> read = source_->sharedFeatures().get(i);  // on disk: read now
  const geo::Feature& feature = *read;
  geo::Feature g;
  if (epsilon > 0.0) {
    g = generaliseGeometry(feature, epsilon);
  } else {
    g.fid = feature.fid;
    g.polygons = feature.polygons;
    g.lines = feature.lines;
  }
  if (source_->kind() == LayerKind::Line) {
    std::vector<geo::LineString> runs;
    for (const geo::LineString& l : g.lines) {
      if (scalable) {
        appendClipped(l, lo - grow, hi + grow, runs);
      } else {
        appendRunsNear(l, lo, hi, reach_[i], runs);
      }
    }
    if (runs.empty()) return std::nullopt;
    g.lines = std::move(runs);
    g.polygons.clear();
  } else {
    g.lines.clear();
  }
  return g;
}

std::vector<std::pair<std::uint32_t, geo::Feature>> LayerTiling::featuresFor(const TileKey& key,
                                                                             const std::vector<std::uint32_t>& indices,
                                                                             const std::atomic<bool>* cancel) const {
  std::vector<std::pair<std::uint32_t, geo::Feature>> out;
  const auto cancelled = [&] { return cancel != nullptr && cancel->load(std::memory_order_relaxed); };
  const double epsilon = generalisation(key);
  if (source_->kind() != LayerKind::Polygon || !(epsilon > 0.0)) {
    for (const std::uint32_t i : indices) {
      if (cancelled()) return {};
      if (std::optional<geo::Feature> g = featureFor(key, i)) out.emplace_back(i, std::move(*g));
    }
    return out;
  }
  // Polygons: generalised together, so that neighbours' shared borders stay shared (no cracks
  // between them: generaliseCoverage).
  const auto [lo, hi] = extent(key);
  std::vector<std::shared_ptr<const geo::Feature>> read;
  std::vector<std::uint32_t> kept;
  for (const std::uint32_t i : indices) {
    if (cancelled()) return {};
    if (i >= boxes_.size() || !meets(boxes_[i], lo, hi)) continue;
    read.push_back(source_->sharedFeatures().get(i));  // on disk: read now
    kept.push_back(i);
  }
  std::vector<const geo::Feature*> features;
  features.reserve(read.size());
  for (const auto& f : read) features.push_back(f.get());
  std::vector<geo::Feature> generalised = generaliseCoverage(features, epsilon);
  out.reserve(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k) {
    generalised[k].lines.clear();
    out.emplace_back(kept[k], std::move(generalised[k]));
  }
  return out;
}

std::filesystem::path LayerTiling::tileFile(const TileKey& key) const { return detail::tileFileIn(cacheFolder_, key); }

std::optional<std::size_t> LayerTiling::cachedBytes(const TileKey& key) const {
  if (!cacheUsable_ || bounds_->revision() != cacheRevision_) return std::nullopt;
  return detail::tileBytes(tileFile(key), fingerprint_, key);
}

Result<LayerTile> LayerTiling::build(const TileKey& key, const std::atomic<bool>* cancel, bool lean) const {
  // From the disk cache, while it holds what the tile would be built from.
  const bool cached = cacheUsable_ && bounds_->revision() == cacheRevision_;
  const std::filesystem::path file = cached ? tileFile(key) : std::filesystem::path();
  std::string damage;
  if (cached) {
    if (std::optional<LayerTile> tile = detail::readTile(
            file, fingerprint_, key, *source_, *bounds_, tileOptions(key),
            [&](std::uint32_t i) { return tileStyle(key, i); }, lean && key.level < finestLevel_, &damage)) {
      ++tilesRead_;
      tile->fromDisk = true;
      Result<LayerTile> r;
      r.value = std::move(*tile);
      return r;
    }
  }
  Result<LayerTile> built = buildNew(key, cancel);
  // A damaged file costs this build, never a piece: said, and written again.
  if (!damage.empty()) {
    ++tilesDamaged_;
    built.diagnostics.add({Severity::Warning,
                           file.string(),
                           source_->name(),
                           {},
                           "cache file damaged (" + damage + "); tile rebuilt from the layer's features"});
  }
  if (cached && built && detail::writeTile(file, fingerprint_, *built)) {
    ++tilesWritten_;
    // A coarse tile for a view far from it: read back lean, so that its arrays go from the
    // file to the GPU and the built copy (footprints, features, arrays) is freed before the
    // upload instead of after it (at 1000× a root tile holds 0.6 GB of arrays).
    if (lean && key.level < finestLevel_) {
      if (std::optional<LayerTile> tile = detail::readTile(
              file, fingerprint_, key, *source_, *bounds_, tileOptions(key),
              [&](std::uint32_t i) { return tileStyle(key, i); }, true)) {
        tile->fromDisk = false;  // built here
        built.value = std::move(*tile);
      }
    }
  }
  return built;
}

Result<LayerTile> WorldTileCache::fetch(const TileKey& key, const std::string& layerName,
                                        std::span<const glm::vec4> groupColours,
                                        const std::function<LayerGeometry()>& build, bool lean) const {
  Result<LayerTile> out;
  if (folder_.empty()) {
    out.value = LayerTile{key, build(), {}, 0.0, false};
    return out;
  }
  const std::filesystem::path file = detail::tileFileIn(folder_, key);
  std::string damage;
  if (std::optional<LayerTile> tile =
          detail::readWorldTile(file, fingerprint_, key, layerName, groupColours, lean, &damage)) {
    ++read_;
    out.value = std::move(*tile);
    return out;
  }
  if (!damage.empty()) {
    ++damaged_;
    out.diagnostics.add({Severity::Warning,
                         file.string(),
                         layerName,
                         {},
                         "cache file damaged (" + damage + "); tile rebuilt from the layer's features"});
  }
  out.value = LayerTile{key, build(), {}, 0.0, false};
  std::error_code error;
  std::filesystem::create_directories(folder_, error);
  if (!error && detail::writeTile(file, fingerprint_, *out.value)) {
    ++written_;
    // Read back lean: the built arrays go now, and the upload takes them from the file. (Near
    // the eye the built arrays are kept: its pieces are clipped from them.)
    if (std::optional<LayerTile> tile =
            lean ? detail::readWorldTile(file, fingerprint_, key, layerName, groupColours, true) : std::nullopt) {
      tile->fromDisk = false;  // built here
      out.value = std::move(*tile);
    }
  }
  return out;
}

std::optional<std::size_t> WorldTileCache::cachedBytes(const TileKey& key) const {
  if (folder_.empty()) return std::nullopt;
  return detail::tileBytes(detail::tileFileIn(folder_, key), fingerprint_, key);
}

LayerBuildOptions LayerTiling::tileOptions(const TileKey& key) const {
  const auto [lo, hi] = extent(key);
  const double size = tileSize(key.level);
  const double error = key.level < finestLevel_ ? size / std::max(1, tiling_.tileResolution) : 0.0;
  LayerBuildOptions options = options_;
  options.deferPieces = false;
  options.reportEmpty = false;
  options.minWidthInPixels = key.width > 0;  // else every line in metres: no per-vertex widths
  options.threads = 1;
  // The tile's cells: the layer's, or coarser on coarse levels; clipped to the tile and to the
  // terrain's grid.
  CellGrid cells;
  cells.origin = lo;
  cells.cellSize = grid_.cellSize;
  while (cells.cellSize * 2.0 <= size / std::max(1, tiling_.cellsPerTile) + 1e-9 * size) cells.cellSize *= 2.0;
  const glm::dvec2 gridEnd = grid_.origin + grid_.cellSize * glm::dvec2(grid_.columns, grid_.rows);
  const glm::dvec2 end = glm::min(hi, gridEnd);
  cells.columns = std::max(1, static_cast<int>(std::ceil((end.x - lo.x) / cells.cellSize - 1e-9)));
  cells.rows = std::max(1, static_cast<int>(std::ceil((end.y - lo.y) / cells.cellSize - 1e-9)));
  options.footprints.cells = cells;
  options.footprints.chordTolerance = std::max(options.footprints.chordTolerance, 0.25 * error);
  options.boundsSlack = error;
  // Lines thinner than a quarter of the error: their rectangles only (what joins and caps add
  // lies within w/2 of a vertex), the pieces of a sub-pixel road network fall by two thirds.
  options.footprints.segmentsOnly =
      source_->kind() == LayerKind::Line && key.width == 0 && widestReach() <= 0.25 * error;
  return options;
}

Result<LayerTile> LayerTiling::buildNew(const TileKey& key, const std::atomic<bool>* cancel) const {
  std::vector<geo::Feature> local;
  std::vector<FeatureStyle> localStyles;
  std::vector<std::uint32_t> index;
  std::vector<std::pair<std::uint32_t, geo::Feature>> near = featuresFor(key, featuresNear(key), cancel);
  if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) return {std::nullopt, Diagnostics{}};
  for (auto& [i, g] : near) {
    local.push_back(std::move(g));
    localStyles.push_back(tileStyle(key, i));
    index.push_back(i);
  }
  LayerBuildOptions options = tileOptions(key);
  options.cancel = cancel;
  Result<LayerGeometry> built = LayerGeometry::build(source_->name(), source_->kind(), source_->style(),
                                                     std::move(local), std::move(localStyles), *bounds_, options);
  Result<LayerTile> r;
  r.diagnostics = std::move(built.diagnostics);
  if (!built) return r;
  r.value = LayerTile{key, std::move(*built), std::move(index), groundError(key.level)};
  return r;
}

}  // namespace gis::overlay
