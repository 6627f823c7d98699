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

/// The frame points sampling feature i's coverage (logical_selection.hpp), not yet lifted.
std::vector<glm::dvec2> featureSamples(const ReferenceLayer& layer, std::size_t i, const Box& box,
                                       const FeatureSelectionOptions& options, double& spacing) {
  std::vector<glm::dvec2> out;
  const glm::dvec2 size = box.hi - box.lo;
  spacing = options.sampleSpacing;
  const auto cells = [&](double s) {
    return std::max(1.0, std::ceil(size.x / s)) * std::max(1.0, std::ceil(size.y / s));
  };
  const double cap = static_cast<double>(std::max<std::size_t>(options.maxGridSamplesPerFeature, 1));
  while (cells(spacing) > cap) spacing *= std::max(1.01, std::sqrt(cells(spacing) / cap));
  const auto nx = static_cast<std::size_t>(std::max(1.0, std::ceil(size.x / spacing)));
  const auto ny = static_cast<std::size_t>(std::max(1.0, std::ceil(size.y / spacing)));
  for (std::size_t r = 0; r < ny; ++r) {
    for (std::size_t c = 0; c < nx; ++c) {
      const glm::dvec2 p =
          box.lo + glm::dvec2((static_cast<double>(c) + 0.5) * spacing, (static_cast<double>(r) + 0.5) * spacing);
      if (featureCovers(layer, i, p, options.scale)) out.push_back(p);
    }
  }
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
      return halfWidthAt(shape, options.scale, glm::dvec3(line[v], shape.anchorHeight(l, v)));
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
      bool b = false;
      if (test[k] != 0) {
        const Lasso& lasso = steps_[k].lasso;
        const std::optional<glm::dvec2> pixel = pixelOf(lasso, prepared_[k].nearPlane, points[i]);
        const Prepared& p = prepared_[k];
        b = pixel && pixel->x >= p.lo.x && pixel->x <= p.hi.x && pixel->y >= p.lo.y && pixel->y <= p.hi.y &&
            lasso_geometry::insideEvenOdd(lasso.points, *pixel);
      }
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
    const std::optional<bool> constant =
        evaluator.constantOver(glm::dvec3(box.lo, options.minHeight), glm::dvec3(box.hi, options.maxHeight));
    if (constant == false) continue;
    double spacing = 0.0;
    const std::vector<glm::dvec2> samples = featureSamples(layer, i, box, options, spacing);
    lifted.clear();
    for (const glm::dvec2& p : samples) {
      const double z = height(p);
      if (std::isfinite(z)) lifted.emplace_back(p, z);
    }
    if (lifted.empty()) continue;
    if (constant.has_value()) {
      flags.assign(lifted.size(), 1);
    } else {
      evaluator.evaluate(lifted, flags);
    }
    FeatureSelection s;
    s.feature = i;
    s.samples = lifted.size();
    s.selectedSamples = static_cast<std::size_t>(std::count(flags.begin(), flags.end(), std::uint8_t{1}));
    s.fullyInside = s.selectedSamples == s.samples;
    s.spacing = spacing;
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
      evaluator.evaluate(points, flags);
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
