// The deferred lookup's charts and layers (deferred_lookup.hpp).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <future>
#include <limits>
#include <utility>

#include <glm/geometric.hpp>

#include "deferred_pass.hpp"
#include "vector_overlay/cpu_reference.hpp"

namespace gis::overlay {

namespace {

std::uint64_t nextSerial() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

/// The boxes (frame coordinates) holding the ground over chart box [lo, hi] between heights
/// `lowest` and `highest`: in the plane the box itself; on a face the bounding box of a grid of
/// its points on the ellipsoid, the top raised so that the surface between them stays inside.
std::array<glm::dvec3, 2> coverBox(const DeferredChart& chart, const glm::dvec2& lo, const glm::dvec2& hi,
                                   double lowest, double highest) {
  if (chart.face < 0) return {glm::dvec3(lo, lowest), glm::dvec3(hi, highest)};
  constexpr int kSamples = 5;
  std::array<glm::dvec3, kSamples * kSamples> points{};
  for (int j = 0; j < kSamples; ++j) {
    for (int i = 0; i < kSamples; ++i) {
      const glm::dvec2 at = lo + (hi - lo) * glm::dvec2(i, j) / static_cast<double>(kSamples - 1);
      points[static_cast<std::size_t>(j * kSamples + i)] = chart.unproject(at);
    }
  }
  // The widest angle between diagonal neighbours: the surface between four samples lies within
  // the box of the samples raised by 1 / cos of it.
  double widest = 0.0;
  for (int j = 0; j + 1 < kSamples; ++j) {
    for (int i = 0; i + 1 < kSamples; ++i) {
      const glm::dvec3 a = glm::normalize(points[static_cast<std::size_t>(j * kSamples + i)]);
      const glm::dvec3 b = glm::normalize(points[static_cast<std::size_t>((j + 1) * kSamples + i + 1)]);
      const glm::dvec3 c = glm::normalize(points[static_cast<std::size_t>((j + 1) * kSamples + i)]);
      const glm::dvec3 d = glm::normalize(points[static_cast<std::size_t>(j * kSamples + i + 1)]);
      widest = std::max(
          {widest, std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)), std::acos(std::clamp(glm::dot(c, d), -1.0, 1.0))});
    }
  }
  const double raise = 1.0 / std::cos(std::min(widest, 1.0));
  std::array<glm::dvec3, 2> box{glm::dvec3(std::numeric_limits<double>::max()),
                                glm::dvec3(-std::numeric_limits<double>::max())};
  for (const glm::dvec3& p : points) {
    const double r = glm::length(p);
    const glm::dvec3 d = p / r;
    for (const glm::dvec3& q : {d * (r + lowest), d * ((r + highest) * raise)}) {
      box[0] = glm::min(box[0], q);
      box[1] = glm::max(box[1], q);
    }
  }
  return box;
}

}  // namespace

DeferredChart DeferredChart::cubeFace(int face, const glm::dvec3& radii) {
  DeferredChart c;
  c.face = face;
  const int axis = face / 2;
  const double sign = (face % 2) == 0 ? 1.0 : -1.0;
  c.axis = glm::dvec3(0.0);
  c.axis[axis] = sign;
  c.east = glm::dvec3(0.0);
  c.east[(axis + 1) % 3] = 1.0;
  c.north = glm::cross(c.axis, c.east);
  c.scale = radii.x;
  c.radii = radii;
  return c;
}

int DeferredChart::faceOf(const glm::dvec3& point) {
  const glm::dvec3 a = glm::abs(point);
  const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
  return 2 * axis + (point[axis] < 0.0 ? 1 : 0);
}

glm::dvec2 DeferredChart::project(const glm::dvec3& point) const {
  if (face < 0) return {point.x, point.y};
  return scale * glm::dvec2(glm::dot(east, point), glm::dot(north, point)) / glm::dot(axis, point);
}

glm::dvec2 DeferredChart::ofGround(const glm::dvec3& world) const {
  if (face < 0) return {world.x, world.y};
  const glm::dvec3 g = world / radii;
  const double t = 1.0 / std::sqrt(glm::dot(g, g));
  const double h = glm::length(world) * (1.0 - t);
  const glm::dvec3 n = glm::normalize(world / (radii * radii));
  return project(world - h * n);
}

glm::dvec3 DeferredChart::unproject(const glm::dvec2& chart) const {
  if (face < 0) return {chart, 0.0};
  const glm::dvec3 d = axis + (east * chart.x + north * chart.y) / scale;
  const glm::dvec3 g = d / radii;
  return d / std::sqrt(glm::dot(g, g));
}

int ReachClasses::classFor(const PixelLineWidths& w, double metresPerPixel,
                           const std::function<double(double reach)>& farthest) const {
  if (!std::isfinite(base) || !(w.pixelsHalf > 0.0) || w.largestHalf <= base) return kNatural;
  for (int c = 0; c <= largest; ++c) {
    const double r = reach(c);
    if (w.widestAt(metresPerPixel, farthest(r)) <= r) return c;
  }
  return kBeyond;
}

DeferredLayer::DeferredLayer() : impl_(std::make_unique<Impl>()) {}
DeferredLayer::DeferredLayer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DeferredLayer::~DeferredLayer() = default;
DeferredLayer::DeferredLayer(DeferredLayer&&) noexcept = default;
DeferredLayer& DeferredLayer::operator=(DeferredLayer&&) noexcept = default;

bool DeferredLayer::empty() const {
  return std::all_of(impl_->charts.begin(), impl_->charts.end(), [](const Impl::Chart& c) { return c.index.empty(); });
}

std::size_t DeferredLayer::bytes() const {
  std::size_t n = 0;
  for (const Impl::Chart& c : impl_->charts) n += c.index.bytes();
  return n;
}

std::uint64_t DeferredLayer::serial() const { return impl_->serial; }

DeferredLayer DeferredLayer::build(std::span<const Part> parts, std::span<const glm::vec4> colors) {
  auto impl = std::make_unique<Impl>();
  impl->serial = nextSerial();
  // The charts' indices are independent: built side by side.
  const auto buildPart = [&colors](const Part& part) {
    deferred::BuildOptions options;
    options.region = part.region;
    options.heightRange =
        part.heightRange >= 0.0 ? part.heightRange : std::max(std::abs(part.lowest), std::abs(part.highest));
    Impl::Chart chart{part.chart, {}, {}};
    if (!part.worldLines.empty()) {
      options.maxReach = part.maxReach;  // lines in pixels binned at it (deferred::binnedAtReach)
      chart.index = deferred::buildWorld(part.worldLines, part.chart, std::max(part.features.size(), colors.size()),
                                         colors, part.lineWidths, options);
    } else {
      ReferenceLayer reference;
      reference.kind = LayerKind::Polygon;
      reference.features = &part.features;
      chart.index = deferred::build(reference, colors, options);
    }
    for (const auto& box : chart.index.cover)
      chart.cover.push_back(coverBox(part.chart, box[0], box[1], part.lowest, part.highest));
    return chart;
  };
  std::vector<std::future<Impl::Chart>> built;
  for (std::size_t k = 1; k < parts.size(); ++k)
    built.push_back(std::async(std::launch::async, buildPart, std::cref(parts[k])));
  std::vector<Impl::Chart> charts;
  if (!parts.empty()) charts.push_back(buildPart(parts[0]));
  for (std::future<Impl::Chart>& f : built) charts.push_back(f.get());
  for (Impl::Chart& chart : charts) {
    if (!chart.index.empty()) impl->charts.push_back(std::move(chart));
  }
  return DeferredLayer(std::move(impl));
}

DeferredLayer deferredLayerOf(DeferredChart chart, deferred::Index index,
                              std::vector<std::array<glm::dvec3, 2>> cover) {
  auto impl = std::make_unique<DeferredLayer::Impl>();
  impl->serial = nextSerial();
  impl->charts.push_back({chart, std::move(index), std::move(cover)});
  return DeferredLayer(std::move(impl));
}

}  // namespace gis::overlay
