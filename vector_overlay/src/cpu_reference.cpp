// The CPU reference (docs/design.md §7): coverage of layers at the terrain points of a depth image.
// Independent of the GPU code and of the footprint construction: the coverage rules are
// evaluated as point predicates (reference_geometry.hpp). A uniform grid over the part of the
// data the image sees selects the candidate polygons and line primitives per point.
#include "vector_overlay/cpu_reference.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "reference_geometry.hpp"

namespace gis::overlay {
namespace {

using reference::BandedPolygon;
using reference::Box;
using reference::LinePrimitive;

constexpr std::size_t kMaskLayers = 32;

// ---------------------------------------------------------------------------------------------
// Per-feature access to a ReferenceLayer

bool featureVisible(const ReferenceLayer& layer, std::size_t i) {
  return i >= layer.visible.size() || layer.visible[i];
}

LineShape featureShape(const ReferenceLayer& layer, std::size_t i) {
  return i < layer.shapes.size() ? layer.shapes[i] : LineShape{};
}

// ---------------------------------------------------------------------------------------------
// Unprojection

/// Window coordinates (pixels from the top-left corner, y down) plus window depth → frame.
class Unprojector {
 public:
  explicit Unprojector(const DepthImage& image) : origin_(image.origin), width_(image.width), height_(image.height) {
    const glm::dmat4 inverse = glm::inverse(image.viewProj);
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m_[static_cast<std::size_t>(4 * r + c)] = inverse[c][r];
    }
  }

  // In scalars: the reference unprojects every pixel and eight probes of each edge pixel, and
  // under AddressSanitizer each glm temporary of a vector expression is a stack object with red
  // zones poisoned and cleared at every call (this function took 28 % of a GL test there, 3.6 %
  // in the release build).
  [[nodiscard]] std::optional<glm::dvec3> at(double px, double py, double depth) const {
    const double nx = 2.0 * px / static_cast<double>(width_) - 1.0;
    const double ny = 1.0 - 2.0 * py / static_cast<double>(height_);
    const auto row = [&](std::size_t r) {
      return m_[4 * r] * nx + m_[4 * r + 1] * ny + m_[4 * r + 2] * depth + m_[4 * r + 3];
    };
    const double w = row(3);
    if (!(std::abs(w) > 0.0)) return std::nullopt;
    const double x = origin_.x + row(0) / w, y = origin_.y + row(1) / w, z = origin_.z + row(2) / w;
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return std::nullopt;
    return glm::dvec3(x, y, z);
  }

 private:
  std::array<double, 16> m_{};  ///< the inverse of the view-projection, row by row
  glm::dvec3 origin_;
  int width_;
  int height_;
};

bool validImage(const DepthImage& image) {
  const bool ok = image.width > 0 && image.height > 0 &&
                  image.depth.size() == static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  assert((ok || (image.width == 0 && image.height == 0)) && "depth must hold width × height values");
  return ok;
}

/// Window depth of a pixel, or nullopt for background (0, or anything not a positive number).
std::optional<double> pixelDepth(const DepthImage& image, int x, int y) {
  const float d =
      image.depth[static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x)];
  if (!(d > 0.0F) || !std::isfinite(d)) return std::nullopt;
  return static_cast<double>(d);
}

/// The terrain points of all pixels (row 0 = top).
struct PixelPoints {
  std::vector<glm::dvec3> point;
  std::vector<double> depth;  ///< window depth; 0 for background
  std::vector<std::uint8_t> valid;
};

PixelPoints unprojectAll(const DepthImage& image, const Unprojector& unprojector) {
  const std::size_t n = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  PixelPoints out{std::vector<glm::dvec3>(n, glm::dvec3(0.0)), std::vector<double>(n, 0.0),
                  std::vector<std::uint8_t>(n, 0)};
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x);
      const std::optional<double> d = pixelDepth(image, x, y);
      if (!d) continue;
      const std::optional<glm::dvec3> p = unprojector.at(x + 0.5, y + 0.5, *d);
      if (!p) continue;
      out.point[i] = *p;
      out.depth[i] = *d;
      out.valid[i] = 1;
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Index

/// A uniform grid of buckets of item indices (each bucket in increasing item order).
class Grid {
 public:
  /// Items with their boxes (empty boxes are left out), restricted to `region`.
  void build(const std::vector<Box>& boxes, const Box& region) {
    extent_ = Box{};
    std::size_t kept = 0;
    for (const Box& b : boxes) {
      if (!b.intersects(region)) continue;
      extent_.add(b.intersection(region));
      ++kept;
    }
    start_.assign(2, 0);
    items_.clear();
    columns_ = rows_ = 1;
    if (kept == 0) return;
    const double w = extent_.hi.x - extent_.lo.x;
    const double h = extent_.hi.y - extent_.lo.y;
    const double target = std::min(2.0 * static_cast<double>(kept), 4.0e6);  // cells
    double cell = std::sqrt(w * h / target);
    cell = std::max({cell, std::max(w, h) / target, std::numeric_limits<double>::min()});
    columns_ = static_cast<int>(std::clamp(std::ceil(w / cell), 1.0, 4096.0));
    rows_ = static_cast<int>(std::clamp(std::ceil(h / cell), 1.0, 4096.0));
    scaleX_ = w > 0.0 ? columns_ / w : 0.0;
    scaleY_ = h > 0.0 ? rows_ / h : 0.0;
    const std::size_t cells = static_cast<std::size_t>(columns_) * static_cast<std::size_t>(rows_);
    std::vector<std::uint32_t> counts(cells + 1, 0);
    auto eachCell = [this, &region](const Box& b, auto&& fn) {
      const Box c = b.intersection(region);
      const int c0 = column(c.lo.x);
      const int c1 = column(c.hi.x);
      const int r0 = row(c.lo.y);
      const int r1 = row(c.hi.y);
      for (int r = r0; r <= r1; ++r)
        for (int col = c0; col <= c1; ++col)
          fn(static_cast<std::size_t>(r) * static_cast<std::size_t>(columns_) + static_cast<std::size_t>(col));
    };
    for (const Box& b : boxes)
      if (b.intersects(region)) eachCell(b, [&counts](std::size_t cellIndex) { ++counts[cellIndex + 1]; });
    for (std::size_t c = 0; c < cells; ++c) counts[c + 1] += counts[c];
    start_ = counts;
    items_.resize(counts[cells]);
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (boxes[i].intersects(region))
        eachCell(boxes[i], [this, &counts, i](std::size_t cellIndex) {
          items_[counts[cellIndex]++] = static_cast<std::uint32_t>(i);
        });
  }

  /// Calls fn(item) for the items of all cells meeting the box (an item may come more than
  /// once); stops when fn returns true and returns whether it did.
  template <typename Fn>
  bool forCells(const Box& box, Fn&& fn) const {
    if (!extent_.intersects(box)) return false;
    const Box b = box.intersection(extent_);
    for (int r = row(b.lo.y), r1 = row(b.hi.y); r <= r1; ++r) {
      for (int c = column(b.lo.x), c1 = column(b.hi.x); c <= c1; ++c) {
        const std::size_t cell =
            static_cast<std::size_t>(r) * static_cast<std::size_t>(columns_) + static_cast<std::size_t>(c);
        for (std::uint32_t k = start_[cell]; k < start_[cell + 1]; ++k)
          if (fn(items_[k])) return true;
      }
    }
    return false;
  }

  /// Candidates for a point of the region (none outside the extent).
  [[nodiscard]] std::span<const std::uint32_t> candidates(const glm::dvec2& p) const {
    if (!extent_.contains(p)) return {};
    const std::size_t c =
        static_cast<std::size_t>(row(p.y)) * static_cast<std::size_t>(columns_) + static_cast<std::size_t>(column(p.x));
    return std::span<const std::uint32_t>(items_).subspan(start_[c], start_[c + 1] - start_[c]);
  }

 private:
  [[nodiscard]] int column(double x) const { return cellOf((x - extent_.lo.x) * scaleX_, columns_); }
  [[nodiscard]] int row(double y) const { return cellOf((y - extent_.lo.y) * scaleY_, rows_); }
  static int cellOf(double t, int count) {
    const double f = std::floor(t);
    if (!(f > 0.0)) return 0;
    if (f >= static_cast<double>(count - 1)) return count - 1;
    return static_cast<int>(f);
  }

  Box extent_;
  int columns_ = 1;
  int rows_ = 1;
  double scaleX_ = 0.0;
  double scaleY_ = 0.0;
  std::vector<std::uint32_t> start_;
  std::vector<std::uint32_t> items_;
};

/// One layer's visible features as indexed items (polygons or line primitives), in feature order.
class LayerIndex {
 public:
  LayerIndex(const ReferenceLayer& layer, const Box& region, const PixelScale& scale)
      : region_(region), polygonLayer_(layer.kind == LayerKind::Polygon) {
    std::vector<Box> boxes;
    if (layer.features != nullptr) {
      const std::vector<geo::Feature>& features = *layer.features;
      for (std::size_t i = 0; i < features.size(); ++i) {
        if (!featureVisible(layer, i)) continue;
        const auto feature = static_cast<std::uint32_t>(i);
        if (polygonLayer_) {
          for (const geo::Polygon& polygon : features[i].polygons) {
            if (!reference::polygonUsable(polygon)) continue;
            if (!reference::polygonBounds(polygon).intersects(region)) continue;
            polygons_.emplace_back(polygon, feature);
            boxes.push_back(polygons_.back().bounds());
          }
        } else {
          const LineShape shape = featureShape(layer, i);
          if (!reference::shapeUsable(shape)) continue;
          for (std::size_t k = 0; k < features[i].lines.size(); ++k) {
            reference::forEachLinePrimitive(features[i].lines[k], k, shape, scale, [&](const LinePrimitive& prim) {
              const Box box = prim.bounds();
              if (box.intersects(region)) {
                primitives_.push_back(prim);
                primitiveFeature_.push_back(feature);
                boxes.push_back(box);
              }
              return false;
            });
          }
        }
      }
    }
    grid_.build(boxes, region);
  }

  /// How the layer's coverage behaves over a pixel's footprint q (inside the region), given
  /// whether it covers the footprint's centre. Uncovered centre: exact (the footprint straddles
  /// an edge iff some piece meets it). Covered centre: uniform if one piece contains the whole
  /// footprint, otherwise undecided (the footprint may lie across seams between pieces).
  enum class Over { Uniform, Straddles, Undecided };
  [[nodiscard]] Over overFootprint(const reference::Quad& q, bool centreCovered) const {
    const Box qb = reference::boundsOf(q);
    const bool decided = grid_.forCells(qb, [&](std::uint32_t item) {
      if (polygonLayer_) {
        const BandedPolygon& polygon = polygons_[item];
        if (!centreCovered) return polygon.edgeMeets(q);
        return polygon.contains(q[0]) && !polygon.edgeMeets(q);
      }
      return centreCovered ? primitives_[item].containsAll(q) : primitives_[item].meets(q);
    });
    if (centreCovered) return decided ? Over::Uniform : Over::Undecided;
    return decided ? Over::Straddles : Over::Uniform;
  }

  /// The first (lowest-index) feature covering p; p must lie in the region.
  [[nodiscard]] std::optional<std::uint32_t> first(const glm::dvec2& p) const {
    assert(region_.contains(p));
    for (const std::uint32_t item : grid_.candidates(p)) {
      if (polygonLayer_) {
        if (polygons_[item].contains(p)) return polygons_[item].feature();
      } else if (primitives_[item].contains(p)) {
        return primitiveFeature_[item];
      }
    }
    return std::nullopt;
  }

 private:
  Box region_;
  bool polygonLayer_;
  std::vector<BandedPolygon> polygons_;
  std::vector<LinePrimitive> primitives_;
  std::vector<std::uint32_t> primitiveFeature_;
  Grid grid_;
};

/// All layers (at most the 32 of the mask) indexed for the points of one region.
class MaskIndex {
 public:
  MaskIndex(std::span<const ReferenceLayer> layers, const Box& region, const PixelScale& scale)
      : region_(padded(region)) {
    const std::size_t n = std::min(layers.size(), kMaskLayers);
    for (std::size_t i = 0; i < n; ++i) layers_.emplace_back(layers[i], region_, scale);
  }
  [[nodiscard]] std::uint32_t bits(const glm::dvec2& p) const {
    assert(region_.contains(p));
    std::uint32_t bits = 0;
    for (std::size_t i = 0; i < layers_.size(); ++i)
      if (layers_[i].first(p)) bits |= 1U << i;
    return bits;
  }

  /// Whether the mask bits are not the same all over the footprint q (corners in order: top
  /// left, top right, bottom right, bottom left) whose centre has `centreBits`. Undecided layers
  /// are sampled on a 9 × 9 grid of the footprint.
  [[nodiscard]] bool straddles(const reference::Quad& q, std::uint32_t centreBits) const {
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      const bool covered = ((centreBits >> i) & 1U) != 0;
      const LayerIndex::Over over = layers_[i].overFootprint(q, covered);
      if (over == LayerIndex::Over::Straddles) return true;
      if (over == LayerIndex::Over::Uniform) continue;
      constexpr int kSamples = 9;
      for (int b = 0; b < kSamples; ++b) {
        for (int a = 0; a < kSamples; ++a) {
          const double u = a / (kSamples - 1.0);
          const double v = b / (kSamples - 1.0);
          const glm::dvec2 p = (q[0] * (1.0 - u) + q[1] * u) * (1.0 - v) + (q[3] * (1.0 - u) + q[2] * u) * v;
          if (layers_[i].first(p).has_value() != covered) return true;
        }
      }
    }
    return false;
  }

 private:
  static Box padded(Box b) {
    b.padForRounding();  // points interpolated between region points stay inside
    return b;
  }

  Box region_;
  std::vector<LayerIndex> layers_;
};

// ---------------------------------------------------------------------------------------------
// Depth discontinuities

/// Whether the surface jumps between neighbouring pixels p and q (q = p + step): one of them
/// is background, or the window-depth jump between them is much larger than the smaller of the
/// jumps just beyond them along the same line (window depth is affine in screen space on a plane,
/// so on smooth terrain the three jumps are nearly equal; a crease gives a jump between the two
/// others; a silhouette a jump far above them).
class Discontinuities {
 public:
  Discontinuities(const DepthImage& image, const PixelPoints& points) : image_(image), points_(points) {}

  [[nodiscard]] bool between(int px, int py, int dx, int dy) const {
    const int qx = px + dx;
    const int qy = py + dy;
    if (!inside(qx, qy)) return false;
    const bool pv = valid(px, py);
    const bool qv = valid(qx, qy);
    if (pv != qv) return true;
    if (!pv) return false;
    const double dp = depth(px, py);
    const double dq = depth(qx, qy);
    const double jump = std::abs(dq - dp);
    double side = std::numeric_limits<double>::infinity();
    bool anySide = false;
    if (inside(px - dx, py - dy) && valid(px - dx, py - dy)) {
      side = std::min(side, std::abs(dp - depth(px - dx, py - dy)));
      anySide = true;
    }
    if (inside(qx + dx, qy + dy) && valid(qx + dx, qy + dy)) {
      side = std::min(side, std::abs(depth(qx + dx, qy + dy) - dq));
      anySide = true;
    }
    if (!anySide) return false;  // nothing to compare with (e.g. diagonally at an image corner)
    return jump > kRatio * side + kRelative * std::max(dp, dq);
  }

  /// Whether pixel (x, y) touches a discontinuity with any of its 8 neighbours.
  [[nodiscard]] bool touches(int x, int y) const {
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if ((dx != 0 || dy != 0) && between(x, y, dx, dy)) return true;
    return false;
  }

 private:
  static constexpr double kRatio = 4.0;
  static constexpr double kRelative = 1e-5;

  [[nodiscard]] bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < image_.width && y < image_.height; }
  [[nodiscard]] std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(image_.width) + static_cast<std::size_t>(x);
  }
  [[nodiscard]] bool valid(int x, int y) const { return points_.valid[index(x, y)] != 0; }
  [[nodiscard]] double depth(int x, int y) const { return points_.depth[index(x, y)]; }

  const DepthImage& image_;
  const PixelPoints& points_;
};

/// The 8 probe points of a pixel's square (corners and edge midpoints) on the ground: the probe
/// rays met with the plane through the pixel's terrain point whose orientation comes from the
/// neighbouring pixels' points (central differences, one-sided at the image border; the
/// horizontal plane when they give none).
class PixelSquares {
 public:
  using Probes = std::array<glm::dvec3, 8>;
  /// Offsets in the pixel (x right, y down): top row, middle row without the centre, bottom row.
  static constexpr std::array<std::array<double, 2>, 8> kOffsets{
      {{0.0, 0.0}, {0.5, 0.0}, {1.0, 0.0}, {0.0, 0.5}, {1.0, 0.5}, {0.0, 1.0}, {0.5, 1.0}, {1.0, 1.0}}};

  PixelSquares(const DepthImage& image, const PixelPoints& points, const Unprojector& unprojector)
      : image_(image), points_(points), unprojector_(unprojector) {}

  /// The probes of a terrain pixel, or nullopt when a probe ray does not meet the plane in front
  /// of the eye (the square reaches over the plane's horizon).
  [[nodiscard]] std::optional<Probes> probes(int x, int y) const {
    const std::size_t i = index(x, y);
    const glm::dvec3 centre = points_.point[i];
    const std::optional<glm::dvec3> tx = tangent(x, y, 1, 0);
    const std::optional<glm::dvec3> ty = tangent(x, y, 0, 1);
    glm::dvec3 normal(0.0, 0.0, 1.0);
    if (tx && ty) {
      const glm::dvec3 c = glm::cross(*tx, *ty);
      if (glm::length(c) > 1e-12 * glm::length(*tx) * glm::length(*ty)) normal = c;
    }
    const double d = points_.depth[i];
    Probes out{};
    for (std::size_t k = 0; k < kOffsets.size(); ++k) {
      const double px = x + kOffsets[k][0];
      const double py = y + kOffsets[k][1];
      // Two points of the probe ray: at the centre's depth and twice as far (half the depth);
      // with the infinite perspective the eye is at parameter −1.
      const std::optional<glm::dvec3> a = unprojector_.at(px, py, d);
      const std::optional<glm::dvec3> b = unprojector_.at(px, py, d / 2.0);
      if (!a || !b) return std::nullopt;
      const double t = glm::dot(centre - *a, normal) / glm::dot(*b - *a, normal);
      if (!std::isfinite(t) || t <= -1.0 + 1e-9) return std::nullopt;
      out[k] = *a + (*b - *a) * t;
      if (!reference::finite(glm::dvec2(out[k]))) return std::nullopt;
    }
    return out;
  }

  /// The corner probes in order round the square.
  static std::array<glm::dvec3, 4> footprint(const Probes& p) { return {p[0], p[2], p[7], p[5]}; }

 private:
  [[nodiscard]] std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(image_.width) + static_cast<std::size_t>(x);
  }
  [[nodiscard]] std::optional<glm::dvec3> point(int x, int y) const {
    if (x < 0 || y < 0 || x >= image_.width || y >= image_.height || points_.valid[index(x, y)] == 0)
      return std::nullopt;
    return points_.point[index(x, y)];
  }
  /// Neighbours of a pixel off silhouettes are terrain without a depth jump.
  [[nodiscard]] std::optional<glm::dvec3> tangent(int x, int y, int dx, int dy) const {
    const std::optional<glm::dvec3> plus = point(x + dx, y + dy);
    const std::optional<glm::dvec3> minus = point(x - dx, y - dy);
    const glm::dvec3 centre = points_.point[index(x, y)];
    if (plus && minus) return *plus - *minus;
    if (plus) return *plus - centre;
    if (minus) return centre - *minus;
    return std::nullopt;
  }

  const DepthImage& image_;
  const PixelPoints& points_;
  const Unprojector& unprojector_;
};

}  // namespace

std::optional<glm::dvec3> unprojectPixel(const DepthImage& image, int x, int y) {
  if (!validImage(image) || x < 0 || y < 0 || x >= image.width || y >= image.height) return std::nullopt;
  const std::optional<double> d = pixelDepth(image, x, y);
  if (!d) return std::nullopt;
  return Unprojector(image).at(x + 0.5, y + 0.5, *d);
}

std::optional<glm::dvec3> unprojectDepth(const DepthImage& camera, int x, int y, float depth) {
  if (camera.width <= 0 || camera.height <= 0 || !(depth > 0.0F)) return std::nullopt;
  return Unprojector(camera).at(x + 0.5, y + 0.5, static_cast<double>(depth));
}

void forEachGroundPixel(const DepthImage& image, const std::function<void(std::size_t, const glm::dvec3&)>& visit) {
  if (!validImage(image)) return;
  const Unprojector unprojector(image);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::optional<double> d = pixelDepth(image, x, y);
      if (!d) continue;
      if (const std::optional<glm::dvec3> p = unprojector.at(x + 0.5, y + 0.5, *d))
        visit(static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x), *p);
    }
  }
}

std::vector<std::uint32_t> referenceMask(const DepthImage& image, const FrameLayersMaker& make) {
  if (!validImage(image)) return {};
  const PixelPoints points = unprojectAll(image, Unprojector(image));
  std::vector<std::uint32_t> mask(points.point.size(), 0);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (points.valid[i] == 0) continue;
    lo = glm::min(lo, points.point[i]);
    hi = glm::max(hi, points.point[i]);
  }
  if (!(lo.x <= hi.x)) return mask;  // no ground
  const std::unique_ptr<FrameLayers> layers = make(lo, hi);
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (points.valid[i] != 0) mask[i] = layers->bits(points.point[i]);
  return mask;
}

std::vector<std::uint8_t> maskEdges(std::span<const std::uint32_t> mask, const DepthImage& image) {
  const int width = image.width, height = image.height;
  if (width <= 0 || height <= 0 || mask.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height) ||
      image.depth.size() != mask.size())
    return {};
  std::vector<std::uint8_t> edges(mask.size(), 0);
  const auto at = [&](int c, int r) {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c);
  };
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const std::size_t i = at(c, r);
      const bool ground = image.depth[i] > 0.0F;
      for (int dr = -1; dr <= 1 && edges[i] == 0; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= width || rr >= height) continue;
          const std::size_t j = at(cc, rr);
          if (mask[j] != mask[i] || (image.depth[j] > 0.0F) != ground) {
            edges[i] = 1;
            break;
          }
        }
      }
    }
  }
  return edges;
}

bool featureCovers(const ReferenceLayer& layer, std::size_t i, const glm::dvec2& p, const PixelScale& scale) {
  if (layer.features == nullptr || i >= layer.features->size()) return false;
  const geo::Feature& feature = (*layer.features)[i];
  if (!featureVisible(layer, i)) return false;
  if (layer.kind == LayerKind::Polygon) {
    for (const geo::Polygon& polygon : feature.polygons)
      if (reference::polygonUsable(polygon) && reference::insideEvenOdd(polygon, p)) return true;
    return false;
  }
  const LineShape shape = featureShape(layer, i);
  if (!reference::shapeUsable(shape)) return false;
  for (std::size_t k = 0; k < feature.lines.size(); ++k)
    if (reference::lineMayReach(feature.lines[k], shape, p) &&
        reference::forEachLinePrimitive(feature.lines[k], k, shape, scale,
                                        [&p](const LinePrimitive& prim) { return prim.contains(p); }))
      return true;
  return false;
}

std::optional<std::size_t> coveringFeature(const ReferenceLayer& layer, const glm::dvec2& point,
                                           const PixelScale& scale) {
  if (layer.features == nullptr) return std::nullopt;
  for (std::size_t i = 0; i < layer.features->size(); ++i)
    if (featureCovers(layer, i, point, scale)) return i;
  return std::nullopt;
}

namespace {

/// The projected frame's layers for the reference: their index over the region, in the plane.
class PlaneLayers final : public FrameLayers {
 public:
  PlaneLayers(std::span<const ReferenceLayer> layers, const Box& region, const PixelScale& scale)
      : index_(layers, region, scale) {}
  [[nodiscard]] std::uint32_t bits(const glm::dvec3& world) const override { return index_.bits(glm::dvec2(world)); }
  [[nodiscard]] bool straddles(const std::array<glm::dvec3, 4>& footprint, std::uint32_t centreBits) const override {
    return index_.straddles(
        {glm::dvec2(footprint[0]), glm::dvec2(footprint[1]), glm::dvec2(footprint[2]), glm::dvec2(footprint[3])},
        centreBits);
  }

 private:
  MaskIndex index_;
};

}  // namespace

FrameLayersMaker planeLayersOf(std::span<const ReferenceLayer> layers, const PixelScale& scale) {
  return [layers, scale](const glm::dvec3& lo, const glm::dvec3& hi) -> std::unique_ptr<FrameLayers> {
    Box region;
    region.add(glm::dvec2(lo));
    region.add(glm::dvec2(hi));
    return std::make_unique<PlaneLayers>(layers, region, scale);
  };
}

std::vector<std::uint32_t> referenceMask(const DepthImage& image, std::span<const ReferenceLayer> layers) {
  return referenceMask(image, planeLayersOf(layers, pixelScaleOf(image.viewProj, image.height)));
}

std::vector<std::uint8_t> edgePixels(const DepthImage& image, std::span<const ReferenceLayer> layers) {
  return edgePixels(image, planeLayersOf(layers, pixelScaleOf(image.viewProj, image.height)));
}

std::vector<std::uint8_t> edgePixels(const DepthImage& image, const FrameLayersMaker& make) {
  if (!validImage(image)) return {};
  const Unprojector unprojector(image);
  const PixelPoints points = unprojectAll(image, unprojector);
  const Discontinuities jumps(image, points);
  const PixelSquares squares(image, points, unprojector);
  const auto width = static_cast<std::size_t>(image.width);
  std::vector<std::uint8_t> edge(points.point.size(), 0);

  // Silhouettes, and pixels whose square reaches beyond the local surface plane's horizon, are
  // edges outright; the footprints of the others bound the region to index.
  std::vector<std::uint8_t> probed(points.point.size(), 0);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + static_cast<std::size_t>(x);
      if (jumps.touches(x, y)) {
        edge[i] = 1;
        continue;
      }
      if (points.valid[i] == 0) continue;
      const std::optional<PixelSquares::Probes> probes = squares.probes(x, y);
      if (!probes) {
        edge[i] = 1;
        continue;
      }
      for (const glm::dvec3& p : *probes) lo = glm::min(lo, p), hi = glm::max(hi, p);
      lo = glm::min(lo, points.point[i]);
      hi = glm::max(hi, points.point[i]);
      probed[i] = 1;
    }
  }
  if (!(lo.x <= hi.x && lo.y <= hi.y)) return edge;

  const std::unique_ptr<FrameLayers> index = make(lo, hi);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + static_cast<std::size_t>(x);
      if (probed[i] == 0) continue;
      const PixelSquares::Probes probes = *squares.probes(x, y);  // as in the first pass
      const std::uint32_t bits = index->bits(points.point[i]);
      bool differs = false;
      for (std::size_t k = 0; k < probes.size() && !differs; ++k) differs = index->bits(probes[k]) != bits;
      // Features narrower than the probe spacing (thin lines, sharp corners, small holes): the
      // whole footprint (the quadrilateral of the corner probes) against the layers' pieces.
      differs = differs || index->straddles(PixelSquares::footprint(probes), bits);
      edge[i] = differs ? 1 : 0;
    }
  }
  return edge;
}

std::vector<PickedFeature> pick(const DepthImage& image, std::span<const ReferenceLayer> layers, int x, int y) {
  std::vector<PickedFeature> out;
  const std::optional<glm::dvec3> p = unprojectPixel(image, x, y);
  if (!p) return out;
  const glm::dvec2 point(*p);
  const PixelScale scale = pixelScaleOf(image.viewProj, image.height);
  for (std::size_t l = 0; l < layers.size(); ++l) {
    if (layers[l].features == nullptr) continue;
    for (std::size_t f = 0; f < layers[l].features->size(); ++f)
      if (featureCovers(layers[l], f, point, scale)) out.push_back({l, f});
  }
  return out;
}

}  // namespace gis::overlay
