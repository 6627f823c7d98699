#include "terrain/quadtree.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "terrain/geometric_error.hpp"
#include "terrain/tile_pager.hpp"

namespace gis::terrain {
namespace {

/// Running min/max of valid heights.
struct Range {
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  void add(float h) {
    if (!std::isnan(h)) {
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
  }
  [[nodiscard]] bool valid() const { return lo <= hi; }
};

}  // namespace

TerrainQuadtree::TerrainQuadtree(std::shared_ptr<const TerrainGrid> grid, int chunkCells)
    : grid_(std::move(grid)), chunkCells_(chunkCells) {
  assert(chunkCells_ >= 2 && (chunkCells_ & (chunkCells_ - 1)) == 0 && "chunk size must be a power of two");
  const int cells = std::max(grid_->width, grid_->height) - 1;
  while ((chunkCells_ << rootLevel_) < cells) ++rootLevel_;
  std::size_t offset = 0;
  for (int level = 0; level <= rootLevel_; ++level) {
    levelOffset_.push_back(offset);
    offset += static_cast<std::size_t>(nodesPerSide(level)) * static_cast<std::size_t>(nodesPerSide(level));
  }
  nodes_.resize(offset);
  computeLevel0();
  for (int level = 1; level <= rootLevel_; ++level) computeLevel(level);
}

TerrainQuadtree::TerrainQuadtree(std::shared_ptr<TilePager> pager)
    : pager_(std::move(pager)), chunkCells_(pager_->file().chunkCells()) {
  const TilePyramidFile& file = pager_->file();
  grid_ = std::make_shared<const TerrainGrid>(file.geometry());
  rootLevel_ = file.rootLevel();
  pinnedLevel_ = file.pinnedLevel();
  std::size_t offset = 0;
  for (int level = 0; level <= rootLevel_; ++level) {
    levelOffset_.push_back(offset);
    offset += static_cast<std::size_t>(nodesPerSide(level)) * static_cast<std::size_t>(nodesPerSide(level));
  }
  nodes_ = file.nodes();
  assert(nodes_.size() == offset);
}

float TerrainQuadtree::pagedPost(int level, int i, int j) const {
  const NodeId id{level, std::min(i / chunkCells_, nodesPerSide(level) - 1),
                  std::min(j / chunkCells_, nodesPerSide(level) - 1)};
  const int ti = i - id.x * chunkCells_, tj = j - id.y * chunkCells_;
  const auto k = static_cast<std::size_t>(tj * (chunkCells_ + 1) + ti);
  if (level >= pinnedLevel_) {
    const float* tile = pager_->pinnedTile(id);
    return tile == nullptr ? kNoData : tile[k];
  }
  const TileData tile = pager_->load(id);
  return tile ? (*tile)[k] : kNoData;
}

bool TerrainQuadtree::resident(const NodeId& n) const { return !pager_ || pager_->resident(n); }

TileData TerrainQuadtree::chunkPosts(const NodeId& n) const {
  if (pager_) return pager_->find(n);
  auto posts = std::make_shared<std::vector<float>>();
  posts->reserve(static_cast<std::size_t>((chunkCells_ + 1) * (chunkCells_ + 1)));
  for (int j = 0; j <= chunkCells_; ++j) {
    for (int i = 0; i <= chunkCells_; ++i) {
      const glm::ivec2 p = vertexPost(n, i, j);
      posts->push_back(post(p.x, p.y));
    }
  }
  return posts;
}

const NodeInfo& TerrainQuadtree::info(const NodeId& n) const { return nodes_[index(n)]; }

std::size_t TerrainQuadtree::nodeCount() const { return nodes_.size(); }

void TerrainQuadtree::computeLevel0() {
  const int side = nodesPerSide(0);
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      Range range;
      const int c0 = x * chunkCells_, r0 = y * chunkCells_;
      const int c1 = std::min(c0 + chunkCells_, grid_->width - 1), r1 = std::min(r0 + chunkCells_, grid_->height - 1);
      for (int r = r0; r <= r1; ++r) {
        for (int c = c0; c <= c1; ++c) range.add(grid_->at(c, r));
      }
      NodeInfo& node = nodes_[index({0, x, y})];
      node.hasData = range.valid();
      node.minHeight = node.hasData ? range.lo : 0.0F;
      node.maxHeight = node.hasData ? range.hi : 0.0F;
      node.geometricError = 0.0F;
    }
  }
}

void TerrainQuadtree::computeLevel(int level) {
  const int side = nodesPerSide(level);
  const int childStride = 1 << (level - 1);
  std::vector<float> window(static_cast<std::size_t>((2 * chunkCells_ + 1) * (2 * chunkCells_ + 1)));
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const NodeId id{level, x, y};
      NodeInfo& node = nodes_[index(id)];
      Range range;
      float childError = 0.0F;
      for (const NodeId& child : id.children()) {
        const NodeInfo& c = info(child);
        if (!c.hasData) continue;
        range.add(c.minHeight);
        range.add(c.maxHeight);
        childError = std::max(childError, c.geometricError);
      }
      node.hasData = range.valid();
      node.minHeight = node.hasData ? range.lo : 0.0F;
      node.maxHeight = node.hasData ? range.hi : 0.0F;
      if (!node.hasData) continue;
      // The child level's surface refines this level's (same diagonal direction): compare the
      // two on the node's (2N + 1)² child-level posts; add the children's own error (triangle
      // inequality of the Hausdorff distance).
      const int c0 = x * chunkCells_ << level, r0 = y * chunkCells_ << level;
      for (int j = 0; j <= 2 * chunkCells_; ++j) {
        for (int i = 0; i <= 2 * chunkCells_; ++i) {
          window[static_cast<std::size_t>(j * (2 * chunkCells_ + 1) + i)] =
              post(c0 + i * childStride, r0 + j * childStride);
        }
      }
      const double own =
          simplificationError(window, chunkCells_, glm::abs(grid_->step) * static_cast<double>(childStride));
      // Round up so that the float bound is never below the double value.
      const double total = own + static_cast<double>(childError);
      node.geometricError =
          total > 0.0 ? std::nextafter(static_cast<float>(total), std::numeric_limits<float>::infinity()) : 0.0F;
    }
  }
}

glm::ivec2 TerrainQuadtree::stitchedVertex(std::uint8_t stitchMask, int i, int j) const {
  const int last = chunkCells_;
  if ((i & 1) == 1 && (((stitchMask & kEdgeNorth) && j == 0) || ((stitchMask & kEdgeSouth) && j == last))) {
    return {i - 1, j};
  }
  if ((j & 1) == 1 && (((stitchMask & kEdgeWest) && i == 0) || ((stitchMask & kEdgeEast) && i == last))) {
    return {i, j - 1};
  }
  return {i, j};
}

double TerrainQuadtree::levelSurface(int level, double col, double row) const {
  const double s = static_cast<double>(1 << level);
  const int maxCell = (chunkCells_ << (rootLevel_ - level)) - 1;
  const double u = col / s, v = row / s;
  const int c = std::clamp(static_cast<int>(std::floor(u)), 0, maxCell);
  const int r = std::clamp(static_cast<int>(std::floor(v)), 0, maxCell);
  const double fx = std::clamp(u - c, 0.0, 1.0), fy = std::clamp(v - r, 0.0, 1.0);
  const double a = levelPost(level, c, r), b = levelPost(level, c + 1, r);
  const double d = levelPost(level, c, r + 1), e = levelPost(level, c + 1, r + 1);
  return interpolateCell(a, b, d, e, fx, fy);  // NaN propagates from any nodata corner
}

double TerrainQuadtree::chunkSurface(const NodeId& n, std::uint8_t stitchMask, double col, double row) const {
  const double s = static_cast<double>(1 << n.level);
  const glm::dvec2 p(col / s - n.x * chunkCells_, row / s - n.y * chunkCells_);
  const int ci = std::clamp(static_cast<int>(std::floor(p.x)), 0, chunkCells_ - 1);
  const int cj = std::clamp(static_cast<int>(std::floor(p.y)), 0, chunkCells_ - 1);
  auto height = [&](const glm::ivec2& v) {
    return static_cast<double>(levelPost(n.level, n.x * chunkCells_ + v.x, n.y * chunkCells_ + v.y));
  };
  if (stitchMask == 0) {
    return interpolateCell(height({ci, cj}), height({ci + 1, cj}), height({ci, cj + 1}), height({ci + 1, cj + 1}),
                           std::clamp(p.x - ci, 0.0, 1.0), std::clamp(p.y - cj, 0.0, 1.0));
  }
  // With collapsed edge vertices a cell's triangles may reach into the next cell: search the
  // triangles of the cells around, as the index buffer draws them.
  double best = std::numeric_limits<double>::quiet_NaN();
  double bestInside = -std::numeric_limits<double>::infinity();
  for (int j = std::max(cj - 1, 0); j <= std::min(cj + 1, chunkCells_ - 1); ++j) {
    for (int i = std::max(ci - 1, 0); i <= std::min(ci + 1, chunkCells_ - 1); ++i) {
      const glm::ivec2 a = stitchedVertex(stitchMask, i, j), b = stitchedVertex(stitchMask, i + 1, j);
      const glm::ivec2 d = stitchedVertex(stitchMask, i, j + 1), e = stitchedVertex(stitchMask, i + 1, j + 1);
      for (const std::array<glm::ivec2, 3>& t : {std::array{a, d, e}, std::array{a, e, b}}) {
        const glm::dvec2 v0(t[0]), v1(t[1]), v2(t[2]);
        const double area = (v1.x - v0.x) * (v2.y - v0.y) - (v1.y - v0.y) * (v2.x - v0.x);
        if (area == 0.0) continue;  // collapsed
        const double w1 = ((p.x - v0.x) * (v2.y - v0.y) - (p.y - v0.y) * (v2.x - v0.x)) / area;
        const double w2 = ((v1.x - v0.x) * (p.y - v0.y) - (v1.y - v0.y) * (p.x - v0.x)) / area;
        const double w0 = 1.0 - w1 - w2;
        const double inside = std::min({w0, w1, w2});  // ≥ 0 inside; the least negative wins at edges
        if (inside > bestInside) {
          bestInside = inside;
          best = w0 * height(t[0]) + w1 * height(t[1]) + w2 * height(t[2]);
        }
      }
    }
  }
  return best;
}

std::array<glm::dvec2, 2> TerrainQuadtree::frameExtent(const NodeId& n) const {
  const glm::ivec2 p0 = vertexPost(n, 0, 0);
  const glm::ivec2 p1 = vertexPost(n, chunkCells_, chunkCells_);
  const glm::dvec2 a = grid_->postPosition(p0.x, p0.y), b = grid_->postPosition(p1.x, p1.y);
  return {glm::min(a, b), glm::max(a, b)};
}

NodeId TerrainQuadtree::nodeAt(int level, double col, double row) const {
  const double size = static_cast<double>(chunkCells_ << level);
  const int last = nodesPerSide(level) - 1;
  return {level, std::clamp(static_cast<int>(std::floor(col / size)), 0, last),
          std::clamp(static_cast<int>(std::floor(row / size)), 0, last)};
}

}  // namespace gis::terrain
