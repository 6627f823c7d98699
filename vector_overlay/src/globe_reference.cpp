// The globe overlay's CPU reference (globe_overlay.hpp): the depth buffer's points, in geodetic
// coordinates, tested against the layers' polygons.
#include <glm/gtc/matrix_inverse.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>

#include "globe_detail.hpp"
#include "vector_overlay/globe_overlay.hpp"
#include "vector_overlay/globe_selection.hpp"

namespace gis::globe {

overlay::DepthImage depthImageOf(const GlobeView& view, std::span<const float> depth) {
  overlay::DepthImage image;
  image.width = view.width;
  image.height = view.height;
  image.depth = depth;
  image.viewProj = view.eyeViewProj();
  image.origin = view.eye;
  return image;
}

namespace {

/// A world point's geodetic coordinates, kept for the last point asked on this thread: the
/// reference asks each layer in turn about the same pixel's point (referenceMask, the edge band's
/// probes), which took one conversion per layer and point (a quarter of a globe accuracy test's
/// time with eight layers).
Geodetic geodeticOf(const glm::dvec3& world) {
  thread_local glm::dvec3 last(std::numeric_limits<double>::quiet_NaN());  // never equal to a point
  thread_local Geodetic kept;
  if (world != last) {
    kept = toGeodetic(world);
    last = world;
  }
  return kept;
}

}  // namespace

overlay::PixelScale pixelScaleOf(const overlay::DepthImage& image) {
  overlay::PixelScale scale = overlay::pixelScaleOf(image.viewProj, image.height);
  scale.eye += image.origin;  // the matrix is relative to it
  return scale;
}

overlay::PixelScale pixelScaleOf(const GlobeView& view) {
  overlay::PixelScale scale = overlay::pixelScaleOf(view.eyeViewProj(), view.height);
  scale.eye += view.eye;
  return scale;
}

overlay::OverlayView overlayViewOf(const GlobeView& view) {
  overlay::OverlayView v;
  v.viewProj = view.viewProj();
  v.eye = view.eye;
  v.nearPlane = view.near;
  v.fovYRadians = view.fovYDeg * 3.14159265358979323846 / 180.0;
  v.aspect = view.aspect();
  return v;
}

double horizonReach(const glm::dvec3& eye, double maxGroundHeight) {
  const double b = kSemiMinor, top = kSemiMajor + std::max(maxGroundHeight, 0.0);
  const double r = std::max(glm::length(eye), b);
  return std::sqrt(r * r - b * b) + std::sqrt(top * top - b * b);
}

overlay::Lasso lassoIn(const GlobeView& view, std::vector<glm::dvec2> points, double maxGroundHeight) {
  overlay::Lasso lasso;
  lasso.distance = horizonReach(view.eye, maxGroundHeight);
  lasso.points = std::move(points);
  lasso.viewProj = view.viewProj();
  lasso.width = view.width;
  lasso.height = view.height;
  return lasso;
}

namespace {

/// A piece of a layer's border on the ellipsoid: an area ring's edge (halfWidth 0), or a line's
/// piece, whose border lies halfWidth from it. Its walls hold the normals at its ends.
struct BorderPiece {
  glm::dvec3 a{0.0}, b{0.0};      ///< ends on the ellipsoid (ECEF)
  glm::dvec3 na{0.0}, nb{0.0};    ///< their normals
  bool endA = true, endB = true;  ///< whether an end counts as a point (not at a pole)
  double halfWidth = 0.0;         ///< at a (a line in pixels: at b, halfWidthB)
  double halfWidthB = 0.0;
  std::uint32_t layer = 0;
  glm::dvec3 lo{0.0}, hi{0.0};  ///< box of the ends, widened by the half width and the chord's sag
};

/// The distance from `point` to the piece measured across the normals (the walls are vertical):
/// to its segment where the point is beside it, else to its nearer end.
double acrossDistance(const BorderPiece& piece, const glm::dvec3& point) {
  double best = std::numeric_limits<double>::infinity();
  const auto toEnd = [&](const glm::dvec3& end, const glm::dvec3& n) {
    const glm::dvec3 d = point - end;
    return glm::length(d - n * glm::dot(d, n));
  };
  if (piece.endA) best = std::min(best, toEnd(piece.a, piece.na));
  if (piece.endB) best = std::min(best, toEnd(piece.b, piece.nb));
  const glm::dvec3 along = piece.b - piece.a;
  const double length = glm::length(along);
  if (length > 0.0) {
    const double s = glm::dot(point - piece.a, along / length);
    if (s >= 0.0 && s <= length) {
      const glm::dvec3 m = glm::normalize(glm::cross(glm::normalize(piece.na + piece.nb), along));
      best = std::min(best, std::abs(glm::dot(point - piece.a, m)));
    }
  }
  return best;
}

/// A bounding volume hierarchy over the layers' border pieces, for "every piece within r of a
/// point".
class BorderIndex {
 public:
  explicit BorderIndex(std::vector<BorderPiece> pieces) : pieces_(std::move(pieces)) {
    order_.resize(pieces_.size());
    std::iota(order_.begin(), order_.end(), 0U);
    nodes_.reserve(2 * pieces_.size());  // leaves of at least one piece: fewer than 2n nodes
    if (!pieces_.empty()) build(0, order_.size());
  }
  /// Calls visit(piece) for every piece whose box lies within `radius` of the point.
  template <typename Visit>
  void near(const glm::dvec3& point, double radius, Visit&& visit) const {
    if (nodes_.empty()) return;
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
      const Node& node = nodes_[stack.back()];
      stack.pop_back();
      if (boxDistance(node.lo, node.hi, point) > radius) continue;
      if (node.count > 0) {
        for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
          const BorderPiece& p = pieces_[order_[k]];
          if (boxDistance(p.lo, p.hi, point) <= radius) visit(p);
        }
      } else {
        stack.push_back(node.first);
        stack.push_back(node.first + 1);
      }
    }
  }

 private:
  struct Node {
    glm::dvec3 lo{0.0}, hi{0.0};
    std::uint32_t first = 0;  ///< leaf: first in order_; inner: its first child (the second follows)
    std::uint32_t count = 0;  ///< leaf: pieces; inner: 0
  };
  static double boxDistance(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& p) {
    const glm::dvec3 d = glm::max(glm::max(lo - p, p - hi), glm::dvec3(0.0));
    return glm::length(d);
  }
  /// Builds the node of order_[first, last) at the end of nodes_ (iteratively: deep data stays
  /// off the call stack).
  void build(std::size_t first, std::size_t last) {
    struct Job {
      std::size_t node, first, last;
    };
    nodes_.push_back({});
    std::vector<Job> jobs{{0, first, last}};
    while (!jobs.empty()) {
      const Job job = jobs.back();
      jobs.pop_back();
      Node& node = nodes_[job.node];
      node.lo = glm::dvec3(std::numeric_limits<double>::infinity());
      node.hi = -node.lo;
      for (std::size_t k = job.first; k < job.last; ++k) {
        node.lo = glm::min(node.lo, pieces_[order_[k]].lo);
        node.hi = glm::max(node.hi, pieces_[order_[k]].hi);
      }
      if (job.last - job.first <= 4) {
        node.first = static_cast<std::uint32_t>(job.first);
        node.count = static_cast<std::uint32_t>(job.last - job.first);
        continue;
      }
      const glm::dvec3 size = node.hi - node.lo;
      const int axis = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
      const std::size_t middle = (job.first + job.last) / 2;
      const auto centre = [&](std::uint32_t i) { return pieces_[i].lo[axis] + pieces_[i].hi[axis]; };
      std::nth_element(order_.begin() + static_cast<std::ptrdiff_t>(job.first),
                       order_.begin() + static_cast<std::ptrdiff_t>(middle),
                       order_.begin() + static_cast<std::ptrdiff_t>(job.last),
                       [&](std::uint32_t x, std::uint32_t y) { return centre(x) < centre(y); });
      const auto child = static_cast<std::uint32_t>(nodes_.size());
      nodes_[job.node].first = child;
      nodes_[job.node].count = 0;
      nodes_.push_back({});
      nodes_.push_back({});
      jobs.push_back({child, job.first, middle});
      jobs.push_back({child + 1, middle, job.last});
    }
  }
  std::vector<BorderPiece> pieces_;
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
};

/// A border between two points off the ellipsoid (a join's or cap's edge), its walls along `normal`.
BorderPiece borderPiece(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& normal, std::uint32_t layer) {
  BorderPiece piece;
  piece.a = a;
  piece.b = b;
  piece.na = piece.nb = normal;
  piece.layer = layer;
  const double pad = glm::length(b - a) * glm::length(b - a) / (8.0 * kSemiMinor) + 1.0;
  piece.lo = glm::min(a, b) - glm::dvec3(pad);
  piece.hi = glm::max(a, b) + glm::dvec3(pad);
  return piece;
}

BorderPiece borderPiece(const glm::dvec2& p, const glm::dvec2& q, double halfWidth, std::uint32_t layer,
                        double halfWidthB = -1.0) {
  BorderPiece piece;
  piece.a = toEcef(p.x, p.y, 0.0);
  piece.b = toEcef(q.x, q.y, 0.0);
  piece.na = surfaceNormal(p.x, p.y);
  piece.nb = surfaceNormal(q.x, q.y);
  piece.endA = !detail::isPole(p.y);
  piece.endB = !detail::isPole(q.y);
  piece.halfWidth = halfWidth;
  piece.halfWidthB = halfWidthB < 0.0 ? halfWidth : halfWidthB;
  piece.layer = layer;
  const double length = glm::length(piece.b - piece.a);
  const double pad = std::max(halfWidth, piece.halfWidthB) + length * length / (8.0 * kSemiMinor) +
                     1.0;  // the chord's sag, and a metre
  piece.lo = glm::min(piece.a, piece.b) - glm::dvec3(pad);
  piece.hi = glm::max(piece.a, piece.b) + glm::dvec3(pad);
  return piece;
}

}  // namespace

namespace {

/// The globe's layers for the CPU reference of both frames (overlay::FrameLayers): their
/// coverage as the view sees it (GlobeLayer::contains at its pixel scale), and for the edge band
/// their borders on the ellipsoid, indexed when it first asks. A footprint straddles a layer
/// where an area's border passes within its reach (the farthest of its corners from its middle)
/// or a line's border does (|distance to the line − half width| ≤ reach, so a line narrower than
/// a pixel, which the probes may not see, has its band too).
class GlobeReferenceLayers final : public overlay::FrameLayers {
 public:
  /// `lo`, `hi`: the box of every point and probe the reference will ask about.
  GlobeReferenceLayers(const std::vector<const GlobeLayer*>& layers, const overlay::PixelScale& scale,
                       const glm::dvec3& lo, const glm::dvec3& hi)
      : layers_(layers.begin(), layers.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(layers.size(), 32))),
        scale_(scale),
        region_(lo, hi) {}
  [[nodiscard]] std::uint32_t bits(const glm::dvec3& world) const override {
    const Geodetic g = geodeticOf(world);
    std::uint32_t out = 0;
    for (std::size_t l = 0; l < layers_.size(); ++l)
      if (layers_[l]->contains(world, g.lon, g.lat, scale_)) out |= 1U << l;
    return out;
  }
  [[nodiscard]] bool straddles(const std::array<glm::dvec3, 4>& footprint, std::uint32_t centreBits) const override {
    (void)centreBits;
    std::call_once(indexed_, [this] { index_.emplace(bordersOf(layers_, scale_, region_)); });
    const glm::dvec3 middle = 0.25 * (footprint[0] + footprint[1] + footprint[2] + footprint[3]);
    double reach = 0.0;
    for (const glm::dvec3& corner : footprint) reach = std::max(reach, glm::length(corner - middle));
    // The pieces are on the ellipsoid and the point above it: a piece whose walls pass within
    // d of it (across the normals) is within d + |height| of it.
    const Geodetic g = toGeodetic(middle);
    std::array<char, 32> outer{}, inner{};  // per layer (at most the mask's 32): no allocation per pixel
    bool edge = false;
    index_->near(middle, reach + std::abs(g.h) + 1.0, [&](const BorderPiece& piece) {
      if (edge) return;
      const double d = acrossDistance(piece, middle);
      if (piece.halfWidth == 0.0 && piece.halfWidthB == 0.0) {
        edge = d <= reach;  // an area's border
      } else {
        outer[piece.layer] |= static_cast<char>(d <= std::max(piece.halfWidth, piece.halfWidthB) + reach);
        inner[piece.layer] |= static_cast<char>(d <= std::min(piece.halfWidth, piece.halfWidthB) - reach);
      }
    });
    for (std::size_t l = 0; l < layers_.size() && !edge; ++l) edge = outer[l] != 0 && inner[l] == 0;
    return edge;
  }

 private:
  /// Where straddles() can look: a piece is visited when its box lies within reach + |h| + 1 m
  /// of a footprint's middle, which lies in the box; its reach (to a corner, also in the box)
  /// is at most the box's diagonal, and its height at most a corner's plus the diagonal (the
  /// height above the ellipsoid is the distance to it). A piece whose box lies farther from the
  /// box than that is never visited: the region indexes only what the view can reach.
  struct Region {
    Region(const glm::dvec3& boxLo, const glm::dvec3& boxHi) : lo(boxLo), hi(boxHi) {
      const double diagonal = glm::length(hi - lo);
      double height = 0.0;
      for (int corner = 0; corner < 8; ++corner) {
        const glm::dvec3 p((corner & 1) != 0 ? hi.x : lo.x, (corner & 2) != 0 ? hi.y : lo.y,
                           (corner & 4) != 0 ? hi.z : lo.z);
        height = std::max(height, std::abs(toGeodetic(p).h));
      }
      // A metre more than straddles() adds, and a millionth for the rounding of ECEF sums.
      reach = 2.0 * diagonal + height + 2.0 + 1e-6 * glm::length(glm::max(glm::abs(lo), glm::abs(hi)));
    }
    [[nodiscard]] bool reaches(const BorderPiece& piece) const {
      const glm::dvec3 gap = glm::max(glm::max(lo - piece.hi, piece.lo - hi), glm::dvec3(0.0));
      return glm::length(gap) <= reach;
    }
    glm::dvec3 lo, hi;
    double reach = 0.0;
  };

  /// Every border of the layers that the region reaches: areas' rings, lines' sides and the
  /// edges of joins and caps other than round, with the lines' half widths in this view.
  static std::vector<BorderPiece> bordersOf(const std::vector<const GlobeLayer*>& layers,
                                            const overlay::PixelScale& scale, const Region& region) {
    std::vector<BorderPiece> pieces;
    const auto add = [&](const BorderPiece& piece) {
      if (region.reaches(piece)) pieces.push_back(piece);
    };
    for (std::size_t l = 0; l < layers.size() && l < 32; ++l) {
      const auto layer = static_cast<std::uint32_t>(l);
      for (std::size_t k = 0; k < layers[l]->areaCount(); ++k) {
        for (const auto& ring : layers[l]->polygons()[k].rings) {
          for (std::size_t i = 0; i < ring.size(); ++i) {
            const glm::dvec2 p = ring[i], q = ring[(i + 1) % ring.size()];
            if (detail::isPole(p.y) && detail::isPole(q.y) && (p.y > 0) == (q.y > 0)) continue;  // along a pole
            add(borderPiece(p, q, 0.0, layer));
          }
        }
      }
      for (const GlobeLine& line : layers[l]->lines()) {
        // A line in pixels: its half widths in this view (the band between them is the edge's).
        std::vector<double> widths(line.points.size(), line.halfWidth);
        if (line.widthPixels > 0.0) {
          for (std::size_t i = 0; i < widths.size(); ++i) widths[i] = layers[l]->halfWidthAt(line, i, scale);
        }
        for (std::size_t i = 0; i + 1 < line.points.size(); ++i)
          add(borderPiece(line.points[i], line.points[i + 1], widths[i], layer, widths[i + 1]));
        if (line.round()) continue;
        // Joins and caps other than round: their edges that bound the line.
        for (std::size_t k = 0; k < line.points.size(); ++k) {
          if (!line.joins || k >= line.joins->at.size()) break;
          const detail::PointShape& shape = line.joins->at[k];
          const glm::dvec3 n = surfaceNormal(line.points[k].x, line.points[k].y);
          const std::size_t count = shape.directions.size();
          for (std::size_t e = 0; e < shape.border.size(); ++e) {
            if (shape.border[e] == 0) continue;
            add(borderPiece(line.surface[k] + widths[k] * shape.directions[e],
                            line.surface[k] + widths[k] * shape.directions[(e + 1) % count], n, layer));
          }
        }
      }
    }
    return pieces;
  }

  std::vector<const GlobeLayer*> layers_;  ///< the first 32 (the mask's bits)
  overlay::PixelScale scale_;
  Region region_;
  mutable std::once_flag indexed_;
  mutable std::optional<BorderIndex> index_;
};

}  // namespace

overlay::FrameLayersMaker referenceLayersOf(const std::vector<const GlobeLayer*>& layers,
                                            const overlay::DepthImage& image) {
  return referenceLayersOf(layers, pixelScaleOf(image));
}

overlay::FrameLayersMaker referenceLayersOf(const std::vector<const GlobeLayer*>& layers,
                                            const overlay::PixelScale& scale) {
  return [layers, scale](const glm::dvec3& lo, const glm::dvec3& hi) -> std::unique_ptr<overlay::FrameLayers> {
    return std::make_unique<GlobeReferenceLayers>(layers, scale, lo, hi);
  };
}

}  // namespace gis::globe
