#include "terrain/lod.hpp"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <unordered_map>
#include <unordered_set>

#include "gfx/camera.hpp"
#include "terrain/geometric_error.hpp"

namespace gis::terrain {
namespace {

struct NodeBox {
  glm::dvec3 lo, hi;
};

NodeBox nodeBox(const TerrainQuadtree& tree, const NodeId& n, double exaggeration) {
  const auto extent = tree.frameExtent(n);
  const NodeInfo& info = tree.info(n);
  double zlo = info.minHeight * exaggeration, zhi = info.maxHeight * exaggeration;
  if (zlo > zhi) std::swap(zlo, zhi);
  return {glm::dvec3(extent[0], zlo), glm::dvec3(extent[1], zhi)};
}

double distanceToBox(const glm::dvec3& p, const NodeBox& box) {
  const glm::dvec3 q = glm::clamp(p, box.lo, box.hi);
  return glm::length(p - q);
}

class Selector {
 public:
  Selector(const TerrainQuadtree& tree, const LodView& view, const LodOptions& options)
      : tree_(tree), view_(view), options_(options), planes_(gfx::frustumPlanes(view.viewProj)) {
    pixelsPerRadian_ = view.viewportHeight / (2.0 * std::tan(view.fovYRadians / 2.0));
  }

  LodSelection run() {
    descend(tree_.root());
    balance();
    LodSelection out;
    out.balanceSplits = splits_;
    out.balanceMerges = merges_;
    out.missing = std::move(missing_);
    // Coarse first: a parent's tile is wanted before its children's.
    std::stable_sort(out.missing.begin(), out.missing.end(),
                     [](const NodeId& a, const NodeId& b) { return a.level > b.level; });
    for (const auto& [key, id] : cut_) {
      out.cut.push_back(id);
      const NodeInfo& info = tree_.info(id);
      if (!info.hasData) continue;
      if (!visible(id)) {
        ++out.culled;
        if (!options_.includeCulled) continue;
      }
      out.chunks.push_back({id, stitchMask(id), screenError(id)});
    }
    // Deterministic order: coarse first, then by position.
    auto order = [](const NodeId& a, const NodeId& b) {
      return std::tie(b.level, a.y, a.x) < std::tie(a.level, b.y, b.x);
    };
    std::sort(out.chunks.begin(), out.chunks.end(),
              [&](const SelectedChunk& a, const SelectedChunk& b) { return order(a.id, b.id); });
    std::sort(out.cut.begin(), out.cut.end(), order);
    return out;
  }

 private:
  [[nodiscard]] bool resident(const NodeId& n) const {
    return options_.resident ? options_.resident(n) : tree_.resident(n);
  }
  /// Notes the children of n that are not resident (wanted: the view needs n refined).
  void want(const NodeId& n) {
    for (const NodeId& c : n.children()) {
      if (!resident(c) && wanted_.emplace(c.key()).second) missing_.push_back(c);
    }
  }
  [[nodiscard]] bool childrenResident(const NodeId& n) const {
    if (n.level == 0) return false;
    for (const NodeId& c : n.children()) {
      if (!resident(c)) return false;
    }
    return true;
  }
  [[nodiscard]] bool visible(const NodeId& n) const {
    const NodeBox box = nodeBox(tree_, n, options_.exaggeration);
    return gfx::boxInFrustum(planes_, box.lo, box.hi);
  }
  [[nodiscard]] double screenError(const NodeId& n) const {
    const double error = exaggeratedError(tree_.info(n).geometricError, options_.exaggeration);
    if (error == 0.0) return 0.0;
    const double distance = distanceToBox(view_.eye, nodeBox(tree_, n, options_.exaggeration));
    if (distance <= 0.0) return std::numeric_limits<double>::infinity();
    return error * pixelsPerRadian_ / distance;
  }
  [[nodiscard]] bool needsRefinement(const NodeId& n) const {
    if (n.level == 0 || !tree_.info(n).hasData) return false;
    if (options_.coarsestAllowedLevel >= 0 && n.level <= options_.coarsestAllowedLevel) return false;
    if (options_.finestForcedLevel >= 0 && n.level > options_.finestForcedLevel) return true;
    if (!visible(n)) return false;
    return screenError(n) > options_.pixelTolerance;
  }
  bool wantsRefinement(const NodeId& n) {
    if (!needsRefinement(n)) return false;
    if (childrenResident(n)) return true;
    want(n);  // drawn coarse meanwhile
    return false;
  }

  void descend(const NodeId& n) {
    if (wantsRefinement(n)) {
      for (const NodeId& c : n.children()) descend(c);
    } else {
      cut_.emplace(n.key(), n);
    }
  }

  /// The leaf of the cut that contains node-sized cell n, at n's level or coarser.
  [[nodiscard]] const NodeId* coveringLeaf(NodeId n) const {
    for (; n.level <= tree_.rootLevel(); n = n.parent()) {
      const auto it = cut_.find(n.key());
      if (it != cut_.end()) return &it->second;
      if (n.level == tree_.rootLevel()) break;
    }
    return nullptr;
  }

  [[nodiscard]] std::array<NodeId, 4> sideNeighbours(const NodeId& n) const {
    return {NodeId{n.level, n.x - 1, n.y}, NodeId{n.level, n.x + 1, n.y}, NodeId{n.level, n.x, n.y - 1},
            NodeId{n.level, n.x, n.y + 1}};
  }

  /// Restricted quadtree: neighbours differ by at most one level. A too-coarse neighbour is split
  /// when its children are resident, otherwise the fine side is merged up (tiles still loading).
  void balance() {
    std::vector<NodeId> work;
    for (const auto& [key, id] : cut_) work.push_back(id);
    while (!work.empty()) {
      const NodeId n = work.back();
      work.pop_back();
      if (cut_.find(n.key()) == cut_.end()) continue;  // replaced meanwhile
      for (const NodeId& side : sideNeighbours(n)) {
        if (!tree_.valid(side)) continue;
        const NodeId* leaf = coveringLeaf(side);
        if (leaf == nullptr || leaf->level <= n.level + 1) continue;
        const NodeId coarse = *leaf;
        if (childrenResident(coarse)) {
          cut_.erase(coarse.key());
          for (const NodeId& c : coarse.children()) {
            cut_.emplace(c.key(), c);
            work.push_back(c);
          }
          ++splits_;
        } else {
          want(coarse);
          mergeInto(n.parent());
          work.push_back(n.parent());
          ++merges_;
        }
        work.push_back(n);  // re-examine (no-op if n was merged away)
        break;
      }
    }
  }

  void mergeInto(const NodeId& p) {
    for (auto it = cut_.begin(); it != cut_.end();) {
      it = p.contains(it->second) ? cut_.erase(it) : std::next(it);
    }
    cut_.emplace(p.key(), p);
  }

  [[nodiscard]] std::uint8_t stitchMask(const NodeId& n) const {
    std::uint8_t mask = 0;
    const std::array<std::uint8_t, 4> bits{kEdgeWest, kEdgeEast, kEdgeNorth, kEdgeSouth};
    const auto sides = sideNeighbours(n);
    for (std::size_t s = 0; s < 4; ++s) {
      if (!tree_.valid(sides[s])) continue;
      const NodeId* leaf = coveringLeaf(sides[s]);
      if (leaf != nullptr && leaf->level == n.level + 1) mask = static_cast<std::uint8_t>(mask | bits[s]);
    }
    return mask;
  }

  const TerrainQuadtree& tree_;
  const LodView& view_;
  const LodOptions& options_;
  std::array<glm::dvec4, 6> planes_;
  double pixelsPerRadian_ = 1.0;
  std::unordered_map<std::uint64_t, NodeId> cut_;
  std::size_t splits_ = 0;
  std::size_t merges_ = 0;
  std::vector<NodeId> missing_;
  std::unordered_set<std::uint64_t> wanted_;
};

}  // namespace

LodSelection selectLod(const TerrainQuadtree& tree, const LodView& view, const LodOptions& options) {
  return Selector(tree, view, options).run();
}

const SelectedChunk* chunkAt(const TerrainQuadtree& tree, const LodSelection& selection, double col, double row) {
  for (const SelectedChunk& c : selection.chunks) {
    const double size = static_cast<double>(tree.chunkCells() << c.id.level);
    const double x0 = c.id.x * size, y0 = c.id.y * size;
    if (col >= x0 && col <= x0 + size && row >= y0 && row <= y0 + size) return &c;
  }
  return nullptr;
}

double drawnHeightAt(const TerrainQuadtree& tree, const LodSelection& selection, double exaggeration,
                     const glm::dvec2& frameXy) {
  const glm::dvec2 g = tree.grid().gridCoordinates(frameXy);
  const SelectedChunk* c = chunkAt(tree, selection, g.x, g.y);
  if (c == nullptr) return std::numeric_limits<double>::quiet_NaN();
  return tree.chunkSurface(c->id, c->stitchMask, g.x, g.y) * exaggeration;
}

}  // namespace gis::terrain
