#include "app/labels.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <queue>
#include <type_traits>
#include <variant>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace gis::app {
namespace {

// ---- Polygons ----

double ringArea(const geo::Ring& ring) {
  double twice = 0.0;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    twice += ring[j].x * ring[i].y - ring[i].x * ring[j].y;
  }
  return 0.5 * twice;
}

double netArea(const geo::Polygon& polygon) {
  if (polygon.outer.size() < 3) return 0.0;
  double area = std::abs(ringArea(polygon.outer));
  for (const geo::Ring& hole : polygon.holes) {
    if (hole.size() >= 3) area -= std::abs(ringArea(hole));
  }
  return std::max(area, 0.0);
}

double segmentDistanceSquared(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  double t = len2 > 0.0 ? glm::dot(p - a, ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  const glm::dvec2 d = p - (a + t * ab);
  return glm::dot(d, d);
}

// Distance from p to the nearest edge of any ring, positive inside (even-odd over the outer
// ring and the holes), negative outside or in a hole.
double signedDistance(const geo::Polygon& polygon, const glm::dvec2& p) {
  bool inside = false;
  double best = std::numeric_limits<double>::infinity();
  auto ring = [&](const geo::Ring& r) {
    if (r.size() < 2) return;
    for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
      const glm::dvec2& a = r[j];
      const glm::dvec2& b = r[i];
      if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) inside = !inside;
      best = std::min(best, segmentDistanceSquared(p, a, b));
    }
  };
  ring(polygon.outer);
  for (const geo::Ring& hole : polygon.holes) ring(hole);
  const double d = std::sqrt(best);
  return inside ? d : -d;
}

glm::dvec2 ringCentroid(const geo::Ring& ring) {
  double twice = 0.0;
  glm::dvec2 sum{0.0};
  const glm::dvec2 origin = ring[0];  // near the ring: no cancellation far from the frame's origin
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const glm::dvec2 a = ring[j] - origin;
    const glm::dvec2 b = ring[i] - origin;
    const double cross = a.x * b.y - b.x * a.y;
    twice += cross;
    sum += (a + b) * cross;
  }
  if (twice == 0.0) return ring[0];
  return origin + sum / (3.0 * twice);
}

// A square of the search: its centre's signed distance and the most any point in it can have
// (distance is 1-Lipschitz, so at most the centre's plus the half-diagonal).
struct Cell {
  glm::dvec2 centre;
  double half;
  double distance;
  double bound;
};

Cell makeCell(const geo::Polygon& polygon, const glm::dvec2& centre, double half) {
  const double d = signedDistance(polygon, centre);
  return {centre, half, d, d + half * std::sqrt(2.0)};
}

// Seeds found by scanlines: on each of a few horizontal lines across the box, the middle of the
// widest inside stretch. Inside by construction (even-odd, as signedDistance), and on the axis of
// a thin sliver at any angle, where cells would need to shrink to the sliver's width first.
template <typename Visit>
void scanlineSeeds(const geo::Polygon& polygon, double loY, double hiY, int lines, Visit&& visit) {
  std::vector<double> xs;
  for (int k = 0; k < lines; ++k) {
    const double y = loY + (hiY - loY) * (k + 0.5) / lines;
    xs.clear();
    auto ring = [&](const geo::Ring& r) {
      for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
        const glm::dvec2& a = r[j];
        const glm::dvec2& b = r[i];
        if ((a.y > y) != (b.y > y)) xs.push_back(a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y));
      }
    };
    ring(polygon.outer);
    for (const geo::Ring& hole : polygon.holes) {
      if (hole.size() >= 2) ring(hole);
    }
    std::sort(xs.begin(), xs.end());
    double widest = 0.0;
    double middle = 0.0;
    for (std::size_t i = 0; i + 1 < xs.size(); i += 2) {
      if (xs[i + 1] - xs[i] > widest) {
        widest = xs[i + 1] - xs[i];
        middle = 0.5 * (xs[i] + xs[i + 1]);
      }
    }
    if (widest > 0.0) visit(glm::dvec2(middle, y));
  }
}

// ---- Lines ----

double lineLength(const geo::LineString& line) {
  double length = 0.0;
  for (std::size_t i = 1; i < line.size(); ++i) length += glm::distance(line[i - 1], line[i]);
  return length;
}

// ---- Text ----

std::string realText(double v) {
  char buffer[64];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof buffer, v);
  return r.ec == std::errc{} ? std::string(buffer, r.ptr) : std::string{};
}

// ---- Placement ----

bool overlaps(const ScreenRect& a, const ScreenRect& b) {
  return a.min.x < b.max.x && b.min.x < a.max.x && a.min.y < b.max.y && b.min.y < a.max.y;
}

ScreenRect grown(const ScreenRect& r, float by) { return {r.min - glm::vec2(by), r.max + glm::vec2(by)}; }

}  // namespace

InteriorPoint polygonLabelPoint(const geo::Polygon& polygon, const AnchorOptions& options) {
  const geo::Ring& outer = polygon.outer;
  if (outer.empty()) return {};
  glm::dvec2 lo = outer[0];
  glm::dvec2 hi = outer[0];
  for (const glm::dvec2& p : outer) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::dvec2 extent = hi - lo;
  const double longest = std::max(extent.x, extent.y);
  if (outer.size() < 3 || longest <= 0.0) return {0.5 * (lo + hi), 0.0};

  // Square cells over the box, as wide as its short side, but at most 256 along the long side
  // so that a thin sliver does not start with millions.
  const double size = std::max(std::min(extent.x, extent.y), longest / 256.0);
  const double half = 0.5 * size;
  auto lower = [](const Cell& a, const Cell& b) { return a.bound < b.bound; };
  std::priority_queue<Cell, std::vector<Cell>, decltype(lower)> queue(lower);
  int evaluations = 0;
  for (double x = lo.x; x < hi.x; x += size) {
    for (double y = lo.y; y < hi.y; y += size) {
      queue.push(makeCell(polygon, {x + half, y + half}, half));
      ++evaluations;
    }
  }
  // Seeds that often are the answer or near it: the outer ring's centroid, the box's centre and
  // the scanlines' points.
  Cell best = makeCell(polygon, ringCentroid(outer), 0.0);
  auto seed = [&](const glm::dvec2& p) {
    const Cell cell = makeCell(polygon, p, 0.0);
    if (cell.distance > best.distance) best = cell;
    ++evaluations;
  };
  seed(0.5 * (lo + hi));
  scanlineSeeds(polygon, lo.y, hi.y, 16, seed);

  // Best first by bound: once the top cannot beat the best by the tolerance, nothing can.
  const double smallest = longest * 1e-12;
  while (!queue.empty()) {
    const Cell cell = queue.top();
    queue.pop();
    if (cell.distance > best.distance) best = cell;
    const double tolerance =
        std::max(options.toleranceMetres, options.relativeTolerance * std::max(best.distance, 0.0));
    if (cell.bound - best.distance <= tolerance) break;
    if (evaluations >= options.maxCells || cell.half < smallest) continue;
    const double h = 0.5 * cell.half;
    for (const glm::dvec2 d : {glm::dvec2(-h, -h), glm::dvec2(h, -h), glm::dvec2(-h, h), glm::dvec2(h, h)}) {
      queue.push(makeCell(polygon, cell.centre + d, h));
    }
    evaluations += 4;
  }
  // A polygon with no interior (all its cells outside) keeps its best point, on the boundary.
  return {best.centre, std::max(best.distance, 0.0)};
}

glm::dvec2 lineMidpoint(const geo::LineString& line) {
  if (line.empty()) return glm::dvec2(0.0);
  double remaining = 0.5 * lineLength(line);
  for (std::size_t i = 1; i < line.size(); ++i) {
    const double piece = glm::distance(line[i - 1], line[i]);
    if (piece > 0.0 && remaining <= piece) return line[i - 1] + (line[i] - line[i - 1]) * (remaining / piece);
    remaining -= piece;
  }
  return line.back();  // rounding left a sliver past the last piece
}

std::optional<LabelAnchor> featureLabelAnchor(const geo::Feature& feature, const AnchorOptions& options) {
  LabelAnchor anchor;
  anchor.boundsMin = glm::dvec2(std::numeric_limits<double>::infinity());
  anchor.boundsMax = -anchor.boundsMin;
  auto extend = [&](const std::vector<glm::dvec2>& points) {
    for (const glm::dvec2& p : points) {
      anchor.boundsMin = glm::min(anchor.boundsMin, p);
      anchor.boundsMax = glm::max(anchor.boundsMax, p);
    }
  };
  const geo::Polygon* largest = nullptr;
  for (const geo::Polygon& polygon : feature.polygons) {
    extend(polygon.outer);
    const double area = netArea(polygon);
    if (!polygon.outer.empty() && (largest == nullptr || area > anchor.partSize)) {
      largest = &polygon;
      anchor.partSize = area;
    }
  }
  const geo::LineString* longest = nullptr;
  double longestLength = 0.0;
  for (const geo::LineString& line : feature.lines) {
    extend(line);
    const double length = lineLength(line);
    if (!line.empty() && (longest == nullptr || length > longestLength)) {
      longest = &line;
      longestLength = length;
    }
  }
  if (largest != nullptr) {
    const InteriorPoint p = polygonLabelPoint(*largest, options);
    anchor.point = p.point;
    anchor.clearance = p.clearance;
  } else if (longest != nullptr) {
    anchor.point = lineMidpoint(*longest);
    anchor.partSize = longestLength;
  } else {
    return std::nullopt;
  }
  return anchor;
}

std::optional<std::string> labelText(const geo::Feature& feature, const std::string& attribute) {
  const auto it = feature.attributes.find(attribute);
  if (it == feature.attributes.end()) return std::nullopt;
  std::string text = std::visit(
      [](const auto& v) -> std::string {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::monostate>) {
          return {};
        } else if constexpr (std::is_same_v<T, std::string>) {
          return v;
        } else if constexpr (std::is_same_v<T, double>) {
          return realText(v);
        } else {
          return std::to_string(v);
        }
      },
      it->second);
  if (text.empty()) return std::nullopt;
  return text;
}

std::vector<FeatureLabel> layerLabels(std::span<const geo::Feature> features, const std::string& attribute,
                                      const AnchorOptions& options) {
  std::vector<FeatureLabel> labels;
  for (std::size_t i = 0; i < features.size(); ++i) {
    std::optional<std::string> text = labelText(features[i], attribute);
    if (!text) continue;
    const std::optional<LabelAnchor> anchor = featureLabelAnchor(features[i], options);
    if (!anchor) continue;
    labels.push_back({i, features[i].fid, std::move(*text), *anchor});
  }
  return labels;
}

ScreenRect labelRect(const LabelCandidate& c, LabelPosition position, float offset) {
  const glm::vec2 half = 0.5F * glm::max(c.size, glm::vec2(0.0F));
  glm::vec2 centre = c.anchor;
  switch (position) {
    case LabelPosition::Centred:
      break;
    case LabelPosition::Above:
      centre.y -= offset + half.y;
      break;
    case LabelPosition::Below:
      centre.y += offset + half.y;
      break;
    case LabelPosition::Right:
      centre.x += offset + half.x;
      break;
    case LabelPosition::Left:
      centre.x -= offset + half.x;
      break;
  }
  return {centre - half, centre + half};
}

bool LabelPlacer::buildGrid(std::span<const LabelCandidate> candidates, const LabelLayout& layout) {
  usable_ = {layout.screen.min + glm::vec2(layout.margin), layout.screen.max - glm::vec2(layout.margin)};
  const bool finite = std::isfinite(usable_.min.x) && std::isfinite(usable_.min.y) && std::isfinite(usable_.max.x) &&
                      std::isfinite(usable_.max.y);
  if (!finite) return false;
  // Cells about the size of a typical label: a query then looks at a few cells of few labels.
  double sum = 0.0;
  std::size_t counted = 0;
  for (const LabelCandidate& c : candidates) {
    const double size = 0.5 * static_cast<double>(c.size.x + c.size.y);
    if (std::isfinite(size)) {
      sum += size;
      ++counted;
    }
  }
  const double typical = counted == 0 ? 64.0 : sum / static_cast<double>(counted);
  const glm::vec2 span = glm::max(usable_.max - usable_.min, glm::vec2(1.0F));
  cellSize_ = std::max(static_cast<float>(std::clamp(1.0 * typical, 8.0, 512.0)), std::max(span.x, span.y) / 256.0F);
  gridOrigin_ = usable_.min;
  columns_ = std::max(1, static_cast<int>(std::ceil(span.x / cellSize_)));
  rows_ = std::max(1, static_cast<int>(std::ceil(span.y / cellSize_)));
  const auto count = static_cast<std::size_t>(columns_) * static_cast<std::size_t>(rows_);
  if (cells_.size() < count) cells_.resize(count);
  for (std::size_t i = 0; i < count; ++i) cells_[i].clear();  // keeps their memory for the next frame
  obstacles_.clear();
  for (const ScreenRect& b : layout.blocked) {
    const ScreenRect r = grown(b, layout.margin);
    if (overlaps(r, usable_)) insert(r);
  }
  return true;
}

LabelPlacer::CellRange LabelPlacer::cellsOf(const ScreenRect& r) const {
  // Clamped while still floats: a huge blocked rectangle must not overflow the conversion.
  auto cell = [&](float v, float origin, int count) {
    return static_cast<int>(std::clamp(std::floor((v - origin) / cellSize_), 0.0F, static_cast<float>(count - 1)));
  };
  return {cell(r.min.x, gridOrigin_.x, columns_), cell(r.min.y, gridOrigin_.y, rows_),
          cell(r.max.x, gridOrigin_.x, columns_), cell(r.max.y, gridOrigin_.y, rows_)};
}

void LabelPlacer::insert(const ScreenRect& r) {
  const auto index = static_cast<std::uint32_t>(obstacles_.size());
  obstacles_.push_back(r);
  const CellRange c = cellsOf(r);
  for (int y = c.y0; y <= c.y1; ++y) {
    for (int x = c.x0; x <= c.x1; ++x) cells_[static_cast<std::size_t>(y * columns_ + x)].push_back(index);
  }
}

bool LabelPlacer::fits(const ScreenRect& r) const {
  if (!(r.min.x >= usable_.min.x && r.min.y >= usable_.min.y && r.max.x <= usable_.max.x && r.max.y <= usable_.max.y)) {
    return false;  // also false for NaN
  }
  const CellRange c = cellsOf(r);
  for (int y = c.y0; y <= c.y1; ++y) {
    for (int x = c.x0; x <= c.x1; ++x) {
      for (const std::uint32_t i : cells_[static_cast<std::size_t>(y * columns_ + x)]) {
        if (overlaps(r, obstacles_[i])) return false;
      }
    }
  }
  return true;
}

void LabelPlacer::run(std::span<const LabelCandidate> candidates, const LabelLayout& layout) {
  placed_.clear();
  if (!buildGrid(candidates, layout)) return;  // no screen to place on
  auto previousOf = [&](std::int64_t id) -> const Previous* {
    if (previous_.empty()) return nullptr;
    const auto it = std::lower_bound(previous_.begin(), previous_.end(), id,
                                     [](const Previous& p, std::int64_t v) { return p.id < v; });
    return it != previous_.end() && it->id == id ? &*it : nullptr;
  };
  // Sorted as (key, id, index) values rather than indices into the candidates: fewer cache misses.
  order_.clear();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const LabelCandidate& c = candidates[i];
    const double priority = std::isnan(c.priority) ? -std::numeric_limits<double>::infinity() : c.priority;
    const Previous* before = previousOf(c.id);
    const bool bonus = before != nullptr && layout.stabilityBonus != 0.0;
    order_.push_back(
        {bonus ? priority + layout.stabilityBonus : priority, c.id, static_cast<std::uint32_t>(i), before});
  }
  std::sort(order_.begin(), order_.end(), [](const Ranked& a, const Ranked& b) {
    if (a.key != b.key) return a.key > b.key;
    if (a.id != b.id) return a.id < b.id;
    return a.index < b.index;
  });

  for (const Ranked& ranked : order_) {
    const std::uint32_t i = ranked.index;
    const LabelCandidate& c = candidates[i];
    const Previous* before = ranked.previous;
    auto tryAt = [&](LabelPosition position) {
      const ScreenRect r = labelRect(c, position, layout.offset);
      if (!fits(r)) return false;
      placed_.push_back({c.id, i, r, position});
      insert(grown(r, layout.padding));
      return true;
    };
    bool done =
        before != nullptr && before->position &&
        std::find(layout.positions.begin(), layout.positions.end(), *before->position) != layout.positions.end() &&
        tryAt(*before->position);
    for (auto p = layout.positions.begin(); !done && p != layout.positions.end(); ++p) done = tryAt(*p);
  }
}

const std::vector<PlacedLabel>& LabelPlacer::place(std::span<const LabelCandidate> candidates,
                                                   const LabelLayout& layout,
                                                   std::span<const std::int64_t> previousIds) {
  // Ids without positions: the bonus only, positions tried in the layout's order.
  previous_.clear();
  for (const std::int64_t id : previousIds) previous_.push_back({id, std::nullopt});
  std::sort(previous_.begin(), previous_.end(), [](const Previous& a, const Previous& b) { return a.id < b.id; });
  run(candidates, layout);
  return placed_;
}

const std::vector<PlacedLabel>& LabelPlacer::place(std::span<const LabelCandidate> candidates,
                                                   const LabelLayout& layout) {
  previous_.clear();
  for (const PlacedLabel& p : placed_) previous_.push_back({p.id, p.position});
  std::sort(previous_.begin(), previous_.end(), [](const Previous& a, const Previous& b) { return a.id < b.id; });
  run(candidates, layout);
  return placed_;
}

void LabelPlacer::forget() {
  previous_.clear();
  placed_.clear();
}

std::vector<PlacedLabel> placeLabels(std::span<const LabelCandidate> candidates, const LabelLayout& layout,
                                     std::span<const std::int64_t> previousIds) {
  LabelPlacer placer;
  return placer.place(candidates, layout, previousIds);
}

}  // namespace gis::app
