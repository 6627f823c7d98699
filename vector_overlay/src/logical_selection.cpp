#include "vector_overlay/logical_selection.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "lasso_geometry.hpp"
#include "reference_geometry.hpp"

namespace gis::overlay {
namespace {

using lasso_geometry::pixelOf;
using reference::Box;

/// Pixels a point must lie outside a lasso's bounding box to be outside without the polygon
/// test: far more than any rounding of the projection or of the crossing rule.
constexpr double kBoxMargin = 1.0;
/// Pixels a box's projection must keep from every edge of a lasso's polygon to lie inside it:
/// far more than the rounding of the projection and of the crossing rule.
constexpr double kInsideMargin = 1e-3;
/// Grid blocks of at most this many samples are tested sample by sample.
constexpr std::size_t kLeafSamples = 64;
/// Boundary samples are classified in runs of this many consecutive ones.
constexpr std::size_t kBoundaryRun = 32;

/// Whether the segment a–b meets the box [lo, hi] (conservative: true when unsure).
bool segmentMeetsBox(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& lo, const glm::dvec2& hi) {
  if (std::max(a.x, b.x) < lo.x || std::min(a.x, b.x) > hi.x || std::max(a.y, b.y) < lo.y || std::min(a.y, b.y) > hi.y)
    return false;
  const glm::dvec2 d = b - a;
  bool positive = false, negative = false;
  for (int corner = 0; corner < 4; ++corner) {
    const glm::dvec2 q((corner & 1) != 0 ? hi.x : lo.x, (corner & 2) != 0 ? hi.y : lo.y);
    const double side = reference::cross(d, q - a);
    if (side > 0.0) {
      positive = true;
    } else if (side < 0.0) {
      negative = true;
    } else {
      return true;  // on the line, or NaN
    }
  }
  return positive && negative;
}

/// The band of a lasso's edges (SelectionEvaluator::Prepared) holding pixel row y.
std::uint32_t bandOf(double y, double y0, double scale, std::uint32_t bands) {
  const double b = std::floor((y - y0) * scale);
  if (!(b > 0.0)) return 0;
  return b >= bands - 1.0 ? bands - 1 : static_cast<std::uint32_t>(b);
}

/// The grid's sample (c, r): the one formula for every use, so blocks hold their samples.
glm::dvec2 gridPoint(const glm::dvec2& origin, double spacing, std::size_t c, std::size_t r) {
  return origin + glm::dvec2((static_cast<double>(c) + 0.5) * spacing, (static_cast<double>(r) + 0.5) * spacing);
}

/// Points a + (b − a)·k/n for k = 0 … n − 1 with n the smallest count making pieces ≤ spacing.
template <typename Emit>
void densify(const glm::dvec2& a, const glm::dvec2& b, double spacing, Emit&& emit) {
  const double length = glm::length(b - a);
  const double pieces = std::ceil(length / spacing);
  const auto n = static_cast<std::size_t>(std::clamp(pieces, 1.0, 1e7));
  for (std::size_t k = 0; k < n; ++k) emit(a + (b - a) * (static_cast<double>(k) / static_cast<double>(n)), k, n);
}

LineShape shapeOf(const ReferenceLayer& layer, std::size_t i) {
  return i < layer.shapes.size() ? layer.shapes[i] : LineShape{};
}

/// The box of everything feature i can cover (lines in pixels: at the widths of `scale`).
Box featureBox(const ReferenceLayer& layer, std::size_t i, const PixelScale& scale) {
  const geo::Feature& feature = (*layer.features)[i];
  Box box;
  if (layer.kind == LayerKind::Polygon) {
    for (const geo::Polygon& polygon : feature.polygons)
      if (reference::polygonUsable(polygon)) box.add(reference::polygonBounds(polygon));
    return box;
  }
  const LineShape shape = shapeOf(layer, i);
  if (!reference::shapeUsable(shape)) return box;
  double half = shape.inPixels() ? 0.0 : 0.5 * shape.width;  // the widest this frame draws it
  for (std::size_t l = 0; l < feature.lines.size(); ++l) {
    const geo::LineString& line = feature.lines[l];
    for (std::size_t v = 0; v < line.size(); ++v) {
      if (!reference::finite(line[v])) continue;
      box.add(line[v]);
      if (shape.inPixels())
        half = std::max(half, halfWidthAt(shape, scale, glm::dvec3(line[v], shape.anchorHeight(l, v))));
    }
  }
  if (box.empty()) return box;
  box.lo -= glm::dvec2(half);
  box.hi += glm::dvec2(half);
  return box;
}

/// The grid over a feature's box: its spacing (the asked one, coarser when capped) and size.
struct Grid {
  glm::dvec2 origin{0.0};
  double spacing = 0.0;
  std::size_t columns = 0, rows = 0;
  [[nodiscard]] glm::dvec2 at(std::size_t c, std::size_t r) const { return gridPoint(origin, spacing, c, r); }
};

Grid gridOver(const Box& box, const FeatureSelectionOptions& options) {
  Grid grid;
  grid.origin = box.lo;
  const glm::dvec2 size = box.hi - box.lo;
  double spacing = options.sampleSpacing;
  const auto cells = [&](double s) {
    return std::max(1.0, std::ceil(size.x / s)) * std::max(1.0, std::ceil(size.y / s));
  };
  const double cap = static_cast<double>(std::max<std::size_t>(options.maxGridSamplesPerFeature, 1));
  while (cells(spacing) > cap) spacing *= std::max(1.01, std::sqrt(cells(spacing) / cap));
  grid.spacing = spacing;
  grid.columns = static_cast<std::size_t>(std::max(1.0, std::ceil(size.x / spacing)));
  grid.rows = static_cast<std::size_t>(std::max(1.0, std::ceil(size.y / spacing)));
  return grid;
}

/// The samples of feature i's boundary (logical_selection.hpp) at `spacing`, not yet lifted.
std::vector<glm::dvec2> boundarySamples(const ReferenceLayer& layer, std::size_t i, double spacing,
                                        const PixelScale& scale) {
  std::vector<glm::dvec2> out;
  const geo::Feature& feature = (*layer.features)[i];
  const auto push = [&out](const glm::dvec2& p, std::size_t, std::size_t) { out.push_back(p); };
  if (layer.kind == LayerKind::Polygon) {
    for (const geo::Polygon& polygon : feature.polygons) {
      if (!reference::polygonUsable(polygon)) continue;
      const auto ring = [&](const geo::Ring& points) {
        for (std::size_t k = 0; k < points.size(); ++k)
          densify(points[k], points[(k + 1) % points.size()], spacing, push);
      };
      ring(polygon.outer);
      for (const geo::Ring& hole : polygon.holes) ring(hole);
    }
    return out;
  }
  const LineShape shape = shapeOf(layer, i);
  for (std::size_t l = 0; l < feature.lines.size(); ++l) {
    const geo::LineString& line = feature.lines[l];
    if (!std::all_of(line.begin(), line.end(), reference::finite)) continue;
    const auto half = [&](std::size_t v) {
      return halfWidthAt(shape, scale, glm::dvec3(line[v], shape.anchorHeight(l, v)));
    };
    for (std::size_t v = 0; v < line.size(); ++v) {
      out.push_back(line[v]);
      if (v + 1 == line.size() || line[v + 1] == line[v]) continue;
      const glm::dvec2 along = glm::normalize(line[v + 1] - line[v]);
      const glm::dvec2 normal(-along.y, along.x);
      const double h0 = half(v), h1 = half(v + 1);
      densify(line[v], line[v + 1], spacing, [&](const glm::dvec2& p, std::size_t k, std::size_t n) {
        const double t = static_cast<double>(k) / static_cast<double>(n);
        const double h = 0.999 * (h0 + (h1 - h0) * t);
        out.push_back(p);
        out.push_back(p + normal * h);
        out.push_back(p - normal * h);
      });
      const double h = 0.999 * h1;
      out.push_back(line[v + 1] + normal * h);
      out.push_back(line[v + 1] - normal * h);
    }
  }
  return out;
}

/// The frame points sampling feature i's coverage (logical_selection.hpp), not yet lifted: the
/// grid's covered samples, then the boundary's.
std::vector<glm::dvec2> featureSamples(const ReferenceLayer& layer, std::size_t i, const Box& box,
                                       const FeatureSelectionOptions& options, double& spacing) {
  const Grid grid = gridOver(box, options);
  spacing = grid.spacing;
  std::vector<glm::dvec2> out;
  for (std::size_t r = 0; r < grid.rows; ++r) {
    for (std::size_t c = 0; c < grid.columns; ++c) {
      const glm::dvec2 p = grid.at(c, r);
      if (featureCovers(layer, i, p, options.scale)) out.push_back(p);
    }
  }
  const std::vector<glm::dvec2> boundary = boundarySamples(layer, i, spacing, options.scale);
  out.insert(out.end(), boundary.begin(), boundary.end());
  return out;
}

/// The search of one feature's samples for a selected and an unselected one
/// (logical_selection.hpp): boundary runs and grid blocks answered whole where the evaluator can,
/// the rest tested sample by sample, until both are found.
class FeatureSearch {
 public:
  using Side = SelectionEvaluator::Side;

  FeatureSearch(const ReferenceLayer& layer, std::size_t feature, const SelectionEvaluator& evaluator,
                const TerrainHeightFunction& height, const FeatureSelectionOptions& options)
      : layer_(layer), feature_(feature), evaluator_(evaluator), height_(height), options_(options) {}

  void run(const Box& box) {
    const HeightBounds z = boundsOver(box.lo, box.hi);
    if (!z.valid()) return;
    rootSides_.assign(evaluator_.stepCount(), Side::Unknown);
    const std::optional<bool> answer =
        evaluator_.classify(glm::dvec3(box.lo, z.lo), glm::dvec3(box.hi, z.hi), rootSides_);
    if (answer == false) return;  // no sample can be selected
    grid_ = gridOver(box, options_);
    searchBoundary(boundarySamples(layer_, feature_, grid_.spacing, options_.scale));
    if (!open()) return;
    buildOutline();
    std::vector<std::uint32_t> all(outline_.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<std::uint32_t>(k);
    searchGrid(0, grid_.columns, 0, grid_.rows, all, rootSides_);
  }

  [[nodiscard]] bool selected() const { return selected_; }
  [[nodiscard]] bool unselected() const { return unselected_; }
  [[nodiscard]] std::size_t samples() const { return samples_; }
  [[nodiscard]] std::size_t selectedSamples() const { return selectedSamples_; }
  [[nodiscard]] double spacing() const { return grid_.spacing; }

 private:
  [[nodiscard]] bool open() const { return !selected_ || !unselected_; }
  /// Whether a sample with this answer would still tell something.
  [[nodiscard]] bool wanted(bool answer) const { return answer ? !selected_ : !unselected_; }
  void record(bool answer) {
    ++samples_;
    selectedSamples_ += answer ? 1u : 0u;
    (answer ? selected_ : unselected_) = true;
  }
  [[nodiscard]] HeightBounds boundsOver(const glm::dvec2& lo, const glm::dvec2& hi) const {
    if (options_.heightBounds) return options_.heightBounds(lo, hi);
    return {options_.minHeight, options_.maxHeight};
  }

  /// The boxes of the feature's ring edges (polygons) or line primitives (lines): a ground box
  /// that meets none of them is covered by the feature wholly or not at all.
  void buildOutline() {
    const geo::Feature& feature = (*layer_.features)[feature_];
    if (layer_.kind == LayerKind::Polygon) {
      for (const geo::Polygon& polygon : feature.polygons) {
        if (!reference::polygonUsable(polygon)) continue;
        polygons_.push_back(&polygon);
        reference::forEachRingEdge(polygon, [this](const glm::dvec2& a, const glm::dvec2& b) {
          Box box;
          box.add(a);
          box.add(b);
          box.padForRounding();  // the crossing rule decides alike for every point of a box it misses
          outline_.push_back(box);
        });
      }
      return;
    }
    const LineShape shape = shapeOf(layer_, feature_);
    if (!reference::shapeUsable(shape)) return;
    for (std::size_t l = 0; l < feature.lines.size(); ++l) {
      reference::forEachLinePrimitive(feature.lines[l], l, shape, options_.scale,
                                      [this](const reference::LinePrimitive& prim) {
                                        primitives_.push_back(prim);
                                        outline_.push_back(prim.bounds());
                                        return false;
                                      });
    }
  }

  /// featureCovers at a point of a ground box that only the outline pieces `near` meet.
  [[nodiscard]] bool covers(const glm::dvec2& p, std::span<const std::uint32_t> near) const {
    if (layer_.kind == LayerKind::Polygon)
      return std::any_of(polygons_.begin(), polygons_.end(),
                         [&p](const geo::Polygon* polygon) { return reference::insideEvenOdd(*polygon, p); });
    return std::any_of(near.begin(), near.end(), [&](std::uint32_t k) { return primitives_[k].contains(p); });
  }

  /// Tests a covered sample (given the block's answer, if any); nothing when off the terrain.
  void test(const glm::dvec2& p, const std::optional<bool>& answer, const std::vector<Side>& sides) {
    const double z = height_(p);
    if (!std::isfinite(z)) return;
    record(answer ? *answer : evaluator_.selectedWith(glm::dvec3(p, z), sides));
  }

  void searchBoundary(const std::vector<glm::dvec2>& samples) {
    std::vector<Side> sides;
    for (std::size_t start = 0; start < samples.size() && open(); start += kBoundaryRun) {
      const std::size_t end = std::min(samples.size(), start + kBoundaryRun);
      Box box;
      for (std::size_t k = start; k < end; ++k) box.add(samples[k]);
      const HeightBounds z = boundsOver(box.lo, box.hi);
      if (!z.valid()) continue;
      sides = rootSides_;
      const std::optional<bool> answer = evaluator_.classify(glm::dvec3(box.lo, z.lo), glm::dvec3(box.hi, z.hi), sides);
      for (std::size_t k = start; k < end && open() && (!answer || wanted(*answer)); ++k)
        test(samples[k], answer, sides);
    }
  }

  /// The grid block [c0, c1) × [r0, r1), whose outline pieces are among `pieces`.
  void searchGrid(std::size_t c0, std::size_t c1, std::size_t r0, std::size_t r1, std::span<const std::uint32_t> pieces,
                  const std::vector<Side>& outerSides) {
    if (!open()) return;
    const glm::dvec2 lo = grid_.at(c0, r0), hi = grid_.at(c1 - 1, r1 - 1);
    const Box box{lo, hi};
    std::vector<std::uint32_t> near;
    for (const std::uint32_t k : pieces)
      if (outline_[k].intersects(box)) near.push_back(k);
    const bool whole = near.empty();  // covered wholly or not at all
    if (whole && !covers(lo, near)) return;
    const HeightBounds z = boundsOver(lo, hi);
    if (!z.valid()) return;
    std::vector<Side> sides = outerSides;
    const std::optional<bool> answer = evaluator_.classify(glm::dvec3(lo, z.lo), glm::dvec3(hi, z.hi), sides);
    if (answer && !wanted(*answer)) return;
    if ((c1 - c0) * (r1 - r0) <= kLeafSamples || (answer && whole)) {
      for (std::size_t r = r0; r < r1; ++r) {
        for (std::size_t c = c0; c < c1; ++c) {
          if (!open() || (answer && !wanted(*answer))) return;
          const glm::dvec2 p = grid_.at(c, r);
          if (whole || covers(p, near)) test(p, answer, sides);
        }
      }
      return;
    }
    const std::size_t cm = c1 - c0 > 1 ? (c0 + c1) / 2 : c1;
    const std::size_t rm = r1 - r0 > 1 ? (r0 + r1) / 2 : r1;
    searchGrid(c0, cm, r0, rm, near, sides);
    if (cm < c1) searchGrid(cm, c1, r0, rm, near, sides);
    if (rm < r1) searchGrid(c0, cm, rm, r1, near, sides);
    if (cm < c1 && rm < r1) searchGrid(cm, c1, rm, r1, near, sides);
  }

  const ReferenceLayer& layer_;
  std::size_t feature_;
  const SelectionEvaluator& evaluator_;
  const TerrainHeightFunction& height_;
  const FeatureSelectionOptions& options_;
  Grid grid_;
  std::vector<Box> outline_;
  std::vector<const geo::Polygon*> polygons_;         ///< the usable ones
  std::vector<reference::LinePrimitive> primitives_;  ///< lines: outline_[k] is primitives_[k]'s box
  std::vector<Side> rootSides_;
  bool selected_ = false, unselected_ = false;
  std::size_t samples_ = 0, selectedSamples_ = 0;
};

}  // namespace

SelectionEvaluator::SelectionEvaluator(std::span<const SelectionStep> steps) : steps_(steps) {
  prepared_.reserve(steps.size());
  for (const SelectionStep& s : steps) {
    Prepared p;
    const Lasso& l = s.lasso;
    p.usable = s.op != SelectionOp::Invert && l.points.size() >= 3 && l.width >= 1 && l.height >= 1;
    p.nearPlane = lasso_geometry::nearPlaneOf(l.viewProj);
    Box box;
    for (const glm::dvec2& q : l.points) box.add(q);
    p.lo = box.lo - glm::dvec2(kBoxMargin);
    p.hi = box.hi + glm::dvec2(kBoxMargin);
    p.usable = p.usable && !box.empty();
    if (p.usable) {
      // About two edges per band.
      const std::size_t n = l.points.size();
      const auto bands = static_cast<std::uint32_t>(std::clamp<std::size_t>(n / 2, 1, 4096));
      const double height = box.hi.y - box.lo.y;
      p.bandY0 = box.lo.y;
      p.bandScale = height > 0.0 ? bands / height : 0.0;
      p.bandStart.assign(bands + 1, 0);
      const auto forEachEdgeBand = [&](auto&& fn) {
        for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
          const double y0 = std::min(l.points[i].y, l.points[j].y), y1 = std::max(l.points[i].y, l.points[j].y);
          const std::uint32_t last = bandOf(y1, p.bandY0, p.bandScale, bands);
          for (std::uint32_t b = bandOf(y0, p.bandY0, p.bandScale, bands); b <= last; ++b)
            fn(b, static_cast<std::uint32_t>(i));
        }
      };
      forEachEdgeBand([&p](std::uint32_t b, std::uint32_t) { ++p.bandStart[b + 1]; });
      for (std::uint32_t b = 0; b < bands; ++b) p.bandStart[b + 1] += p.bandStart[b];
      p.bandEdges.resize(p.bandStart[bands]);
      std::vector<std::uint32_t> next(p.bandStart.begin(), p.bandStart.end() - 1);
      forEachEdgeBand([&p, &next](std::uint32_t b, std::uint32_t i) { p.bandEdges[next[b]++] = i; });
    }
    prepared_.push_back(p);
  }
}

bool SelectionEvaluator::misses(std::size_t k, const glm::dvec3& lo, const glm::dvec3& hi) const {
  const Prepared& p = prepared_[k];
  if (!p.usable) return true;  // insideLasso is false everywhere
  const Lasso& lasso = steps_[k].lasso;
  bool allBefore = true, allBeyond = true, allInFront = true;
  glm::dvec2 pixelLo(std::numeric_limits<double>::infinity()), pixelHi(-std::numeric_limits<double>::infinity());
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec3 q((corner & 1) != 0 ? hi.x : lo.x, (corner & 2) != 0 ? hi.y : lo.y,
                       (corner & 4) != 0 ? hi.z : lo.z);
    const glm::dvec4 c = lasso.viewProj * glm::dvec4(q, 1.0);
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.w)) return false;
    // w is affine in the point: a condition on all 8 corners holds on the whole box.
    allBefore = allBefore && c.w < p.nearPlane;
    allBeyond = allBeyond && c.w > lasso.distance;
    allInFront = allInFront && c.w >= p.nearPlane;
    if (c.w > 0.0) {
      const glm::dvec2 pixel((c.x / c.w + 1.0) * 0.5 * lasso.width, (1.0 - c.y / c.w) * 0.5 * lasso.height);
      pixelLo = glm::min(pixelLo, pixel);
      pixelHi = glm::max(pixelHi, pixel);
    }
  }
  if (allBefore || allBeyond) return true;
  // In front of the eye the projection maps the box into the hull of its projected corners.
  return allInFront && (pixelHi.x < p.lo.x || pixelLo.x > p.hi.x || pixelHi.y < p.lo.y || pixelLo.y > p.hi.y);
}

SelectionEvaluator::Side SelectionEvaluator::sideOf(std::size_t k, const glm::dvec3& lo, const glm::dvec3& hi) const {
  const Prepared& p = prepared_[k];
  if (steps_[k].op == SelectionOp::Invert || misses(k, lo, hi)) return Side::Outside;
  const Lasso& lasso = steps_[k].lasso;
  glm::dvec2 pixelLo(std::numeric_limits<double>::infinity()), pixelHi(-std::numeric_limits<double>::infinity());
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec3 q((corner & 1) != 0 ? hi.x : lo.x, (corner & 2) != 0 ? hi.y : lo.y,
                       (corner & 4) != 0 ? hi.z : lo.z);
    const glm::dvec4 c = lasso.viewProj * glm::dvec4(q, 1.0);
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.w)) return Side::Unknown;
    // w is affine in the point: the box lies between the near plane and the distance when its
    // corners do, with room for the rounding of w at a point inside.
    const double slack = 1e-9 * (std::abs(c.w) + std::abs(q.x) + std::abs(q.y) + std::abs(q.z) + 1.0);
    if (!(c.w > 0.0) || !(c.w >= p.nearPlane + slack) || !(c.w + slack <= lasso.distance)) return Side::Unknown;
    const glm::dvec2 pixel((c.x / c.w + 1.0) * 0.5 * lasso.width, (1.0 - c.y / c.w) * 0.5 * lasso.height);
    pixelLo = glm::min(pixelLo, pixel);
    pixelHi = glm::max(pixelHi, pixel);
  }
  // In front of the eye the box projects into the hull of its corners, so into their pixel box;
  // with no edge of the polygon near that box, the crossing rule answers alike all over it.
  pixelLo -= glm::dvec2(kInsideMargin);
  pixelHi += glm::dvec2(kInsideMargin);
  const std::vector<glm::dvec2>& ring = lasso.points;
  // The bands meeting the box's rows hold every edge that can meet it.
  const auto bands = static_cast<std::uint32_t>(p.bandStart.size() - 1);
  const std::uint32_t last = bandOf(pixelHi.y, p.bandY0, p.bandScale, bands);
  for (std::uint32_t band = bandOf(pixelLo.y, p.bandY0, p.bandScale, bands); band <= last; ++band) {
    for (std::uint32_t e = p.bandStart[band]; e < p.bandStart[band + 1]; ++e) {
      const std::uint32_t i = p.bandEdges[e];
      if (segmentMeetsBox(ring[i == 0 ? ring.size() - 1 : i - 1], ring[i], pixelLo, pixelHi)) return Side::Unknown;
    }
  }
  return lasso_geometry::insideEvenOdd(ring, 0.5 * (pixelLo + pixelHi)) ? Side::Inside : Side::Outside;
}

bool SelectionEvaluator::insideStep(std::size_t k, const glm::dvec3& point) const {
  const Lasso& lasso = steps_[k].lasso;
  const Prepared& p = prepared_[k];
  if (!p.usable) return false;
  const std::optional<glm::dvec2> pixel = pixelOf(lasso, p.nearPlane, point);
  if (!pixel || !(pixel->x >= p.lo.x && pixel->x <= p.hi.x && pixel->y >= p.lo.y && pixel->y <= p.hi.y)) return false;
  // lasso_geometry::insideEvenOdd on the edges of the pixel's band.
  const std::uint32_t band =
      bandOf(pixel->y, p.bandY0, p.bandScale, static_cast<std::uint32_t>(p.bandStart.size() - 1));
  const std::vector<glm::dvec2>& ring = lasso.points;
  bool inside = false;
  for (std::uint32_t e = p.bandStart[band]; e < p.bandStart[band + 1]; ++e) {
    const std::uint32_t i = p.bandEdges[e];
    if (reference::crossesRay(ring[i == 0 ? ring.size() - 1 : i - 1], ring[i], *pixel)) inside = !inside;
  }
  return inside;
}

std::optional<bool> SelectionEvaluator::classify(const glm::dvec3& lo, const glm::dvec3& hi,
                                                 std::vector<Side>& sides) const {
  sides.resize(steps_.size(), Side::Unknown);
  bool known = true, a = false;
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    if (sides[k] == Side::Unknown) sides[k] = sideOf(k, lo, hi);
    known = known && sides[k] != Side::Unknown;
    a = lasso_geometry::apply(steps_[k].op, a, sides[k] == Side::Inside);
  }
  if (!known) return std::nullopt;
  return a;
}

bool SelectionEvaluator::selectedWith(const glm::dvec3& point, std::span<const Side> sides) const {
  bool a = false;
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    const bool b = sides[k] == Side::Inside || (sides[k] == Side::Unknown && insideStep(k, point));
    a = lasso_geometry::apply(steps_[k].op, a, b);
  }
  return a;
}

bool SelectionEvaluator::chainWith(const std::vector<std::uint8_t>& inside) const {
  bool a = false;
  for (std::size_t k = 0; k < steps_.size(); ++k) a = lasso_geometry::apply(steps_[k].op, a, inside[k] != 0);
  return a;
}

std::optional<bool> SelectionEvaluator::constantOver(const glm::dvec3& lo, const glm::dvec3& hi) const {
  for (std::size_t k = 0; k < steps_.size(); ++k)
    if (steps_[k].op != SelectionOp::Invert && !misses(k, lo, hi)) return std::nullopt;
  return chainWith(std::vector<std::uint8_t>(steps_.size(), 0));
}

void SelectionEvaluator::evaluate(std::span<const glm::dvec3> points, std::vector<std::uint8_t>& out) const {
  out.assign(points.size(), 0);
  if (points.empty()) return;
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec3& q : points) {
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  std::vector<std::uint8_t> test(steps_.size(), 0);
  for (std::size_t k = 0; k < steps_.size(); ++k) test[k] = misses(k, lo, hi) ? 0 : 1;
  for (std::size_t i = 0; i < points.size(); ++i) {
    bool a = false;
    for (std::size_t k = 0; k < steps_.size(); ++k) {
      const bool b = test[k] != 0 && insideStep(k, points[i]);
      a = lasso_geometry::apply(steps_[k].op, a, b);
    }
    out[i] = a ? 1 : 0;
  }
}

std::vector<FeatureSelection> selectFeatures(const ReferenceLayer& layer, std::span<const SelectionStep> steps,
                                             const TerrainHeightFunction& height,
                                             const FeatureSelectionOptions& options) {
  std::vector<FeatureSelection> out;
  if (layer.features == nullptr || !height || !(options.sampleSpacing > 0.0)) return out;
  const SelectionEvaluator evaluator(steps);
  std::vector<glm::dvec3> lifted;
  std::vector<std::uint8_t> flags;
  for (std::size_t i = 0; i < layer.features->size(); ++i) {
    if (i < layer.visible.size() && !layer.visible[i]) continue;
    const Box box = featureBox(layer, i, options.scale);
    if (box.empty()) continue;
    FeatureSelection s;
    s.feature = i;
    if (options.exhaustive) {
      const std::optional<bool> constant =
          evaluator.constantOver(glm::dvec3(box.lo, options.minHeight), glm::dvec3(box.hi, options.maxHeight));
      if (constant == false) continue;
      const std::vector<glm::dvec2> samples = featureSamples(layer, i, box, options, s.spacing);
      lifted.clear();
      for (const glm::dvec2& p : samples) {
        const double z = height(p);
        if (std::isfinite(z)) lifted.emplace_back(p, z);
      }
      if (options.testedSamples != nullptr) *options.testedSamples += lifted.size();
      if (lifted.empty()) continue;
      if (constant.has_value()) {
        flags.assign(lifted.size(), 1);
      } else {
        evaluator.evaluate(lifted, flags);
      }
      s.samples = lifted.size();
      s.selectedSamples = static_cast<std::size_t>(std::count(flags.begin(), flags.end(), std::uint8_t{1}));
      s.fullyInside = s.selectedSamples == s.samples;
    } else {
      FeatureSearch search(layer, i, evaluator, height, options);
      search.run(box);
      if (options.testedSamples != nullptr) *options.testedSamples += search.samples();
      s.samples = search.samples();
      s.selectedSamples = search.selectedSamples();
      s.fullyInside = search.selected() && !search.unselected();
      s.spacing = search.spacing();
    }
    if (s.selectedSamples > 0) out.push_back(s);
  }
  return out;
}

PostSelection selectPosts(const PostGrid& grid, std::span<const SelectionStep> steps) {
  PostSelection out;
  if (grid.width <= 0 || grid.height <= 0 || !grid.heightAt) return out;
  const auto width = static_cast<std::size_t>(grid.width);
  out.mask.assign(width * static_cast<std::size_t>(grid.height), 0);
  const SelectionEvaluator evaluator(steps);
  constexpr int kBlock = 32;
  std::vector<glm::dvec3> points;
  std::vector<std::size_t> index;
  std::vector<std::uint8_t> flags;
  std::vector<SelectionEvaluator::Side> sides;
  for (int r0 = 0; r0 < grid.height; r0 += kBlock) {
    for (int c0 = 0; c0 < grid.width; c0 += kBlock) {
      points.clear();
      index.clear();
      for (int r = r0; r < std::min(r0 + kBlock, grid.height); ++r) {
        for (int c = c0; c < std::min(c0 + kBlock, grid.width); ++c) {
          const double z = grid.heightAt(c, r);
          if (!std::isfinite(z)) continue;
          points.emplace_back(grid.origin + glm::dvec2(c, r) * grid.step, z);
          index.push_back(static_cast<std::size_t>(r) * width + static_cast<std::size_t>(c));
        }
      }
      // A block of posts no volume's wall crosses has one answer.
      glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
      for (const glm::dvec3& q : points) {
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
      sides.clear();
      const std::optional<bool> answer = points.empty() ? std::nullopt : evaluator.classify(lo, hi, sides);
      if (answer) {
        flags.assign(points.size(), static_cast<std::uint8_t>(*answer ? 1 : 0));
      } else {
        evaluator.evaluate(points, flags);
      }
      out.posts += points.size();
      for (std::size_t k = 0; k < points.size(); ++k) {
        out.mask[index[k]] = flags[k];
        out.selected += flags[k];
      }
    }
  }
  return out;
}

}  // namespace gis::overlay
