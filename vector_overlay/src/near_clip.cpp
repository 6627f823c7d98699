#include "vector_overlay/near_clip.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include <glm/geometric.hpp>

namespace gis::overlay {
namespace {

/// Clips one piece's faces at a time against the plane w = wMin of clip space, into triangles
/// relative to the eye; with `capped`, closes each piece on the plane.
class NearClipper {
 public:
  NearClipper(const OverlayView& view, bool capped, std::vector<ClippedVertex>& out)
      : wRow_(view.viewProj[0][3], view.viewProj[1][3], view.viewProj[2][3]),
        // w of clip space is the distance along the view direction; the near plane is at w = near.
        wEye_(glm::dot(wRow_, view.eye) + view.viewProj[3][3]),  // 0 for a perspective through the eye
        wMin_(0.5 * view.nearPlane),
        capped_(capped),
        out_(&out) {}

  /// The next piece, drawn in `rgba`.
  void begin(const std::uint8_t* rgba) {
    std::copy(rgba, rgba + 4, rgba_.begin());
    cuts_.clear();
  }

  /// A face of the piece (relative to the eye, wound outward).
  void triangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const std::array<glm::dvec3, 3> v{a, b, c};
    std::array<double, 3> w{};
    int inside = 0;
    for (int k = 0; k < 3; ++k) {
      w[static_cast<std::size_t>(k)] = glm::dot(wRow_, v[static_cast<std::size_t>(k)]) + wEye_;
      inside += w[static_cast<std::size_t>(k)] >= wMin_ ? 1 : 0;
    }
    if (inside == 0) return;
    // Sutherland–Hodgman against one plane: a triangle or a quad (two triangles), same winding.
    // The polygon runs along the plane from where it leaves the kept side to where it enters.
    std::vector<glm::dvec3> poly;
    glm::dvec3 entry(0.0), exit(0.0);
    for (std::size_t k = 0; k < 3 && inside < 3; ++k) {
      const std::size_t n = (k + 1) % 3;
      const bool in = w[k] >= wMin_, nextIn = w[n] >= wMin_;
      if (in) poly.push_back(v[k]);
      if (in != nextIn) {
        poly.push_back(cut(v[k], v[n], w[k], w[n]));
        (in ? exit : entry) = poly.back();
      }
    }
    if (capped_ && inside < 3) cuts_.push_back({entry, exit});
    // A face whose plane passes through the eye is seen edge on: it covers no area, but
    // rounded to float its image becomes a sliver of either orientation with meaningless
    // depths, which would count. Leave it out when the eye is within 1e-5 of the distance to
    // the face from its plane (its image is then under 0.01 px wide); a wall shared by two
    // pieces of the layer goes from both, which keeps their sum.
    const glm::dvec3 normal = glm::cross(b - a, c - a);
    const double nearest = std::min({glm::length(a), glm::length(b), glm::length(c)});
    if (std::abs(glm::dot(normal, a)) <= 1e-5 * nearest * glm::length(normal)) return;
    if (inside == 3) {
      for (const glm::dvec3& q : v) emit(q);
      return;
    }
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      emit(poly[0]);
      emit(poly[k]);
      emit(poly[k + 1]);
    }
  }

  /// The piece is done. The cap: the section of the piece by the plane, bounded by the cut edges
  /// run the other way round (entry → exit), drawn as a fan from one point of it. Overlapping fan
  /// triangles of opposite orientation cancel, so every pixel counts the section's winding
  /// number — 1 inside, 0 outside — without triangulating it; it faces the eye, as the kept
  /// side's boundary there must. Shared cut points are bit-identical, so the fan is watertight.
  void end() {
    if (cuts_.empty()) return;
    const glm::dvec3 o = cuts_.front()[0];
    for (const auto& [entry, exit] : cuts_) {
      emit(o);
      emit(entry);
      emit(exit);
    }
  }

 private:
  void emit(const glm::dvec3& q) {
    out_->push_back({static_cast<float>(q.x),
                     static_cast<float>(q.y),
                     static_cast<float>(q.z),
                     0.0F,
                     {rgba_[0], rgba_[1], rgba_[2], rgba_[3]}});
  }
  /// The point where edge (a, b) meets the plane, computed from the endpoints in a fixed order
  /// so that the two faces sharing the edge get the same point, bit for bit.
  [[nodiscard]] glm::dvec3 cut(glm::dvec3 a, glm::dvec3 b, double wa, double wb) const {
    if (std::tie(b.x, b.y, b.z) < std::tie(a.x, a.y, a.z)) {
      std::swap(a, b);
      std::swap(wa, wb);
    }
    const double t = (wMin_ - wa) / (wb - wa);
    return a + t * (b - a);
  }

  glm::dvec3 wRow_;
  double wEye_, wMin_;
  bool capped_;
  std::vector<ClippedVertex>* out_;
  std::array<std::uint8_t, 4> rgba_{};
  std::vector<std::array<glm::dvec3, 2>> cuts_;
};

/// A projected frame's pieces: their footprints extruded between their bounds.
void clipFootprints(NearClipper& clipper, const OverlayView& view, const LayerGeometry& layer,
                    std::span<const std::size_t> slots, const CapPadding& padding, const PixelScale& scale) {
  for (std::size_t slot : slots) {
    const Polyhedron& p = layer.polyhedra()[slot];
    const FeatureStyle& style = layer.featureStyles()[p.footprint.feature];
    clipper.begin(rgba8(style.color).data());
    const Footprint& f = p.footprint;
    // Vertices relative to the eye, lines in pixels at this frame's width and caps padded as
    // the shader does it.
    std::vector<glm::dvec3> bottom(f.vertices.size()), top(f.vertices.size());
    for (std::size_t k = 0; k < f.vertices.size(); ++k) {
      const glm::dvec2 vertex =
          f.scalable() ? glm::dvec2(f.centres[k]) + f.directions[k] * halfWidthAt(style.shape, scale, f.centres[k])
                       : f.vertices[k];
      const glm::dvec2 xy = vertex - glm::dvec2(view.eye);
      for (int side : {-1, 1}) {
        glm::dvec3 q(xy, (side < 0 ? p.lo : p.hi) - view.eye.z);
        q.z += side * padding.at(glm::length(q));
        (side < 0 ? bottom : top)[k] = q;
      }
    }
    for (const auto& t : f.triangles) {
      clipper.triangle(bottom[t[0]], bottom[t[2]], bottom[t[1]]);
      clipper.triangle(top[t[0]], top[t[1]], top[t[2]]);
    }
    for (const auto& e : f.boundary) {
      clipper.triangle(bottom[e[0]], bottom[e[1]], top[e[1]]);
      clipper.triangle(bottom[e[0]], top[e[1]], top[e[0]]);
    }
    clipper.end();
  }
}

/// World pieces: the triangles the GPU draws, each vertex where the volume shader puts it
/// (shaders/overlay_volume.vert, u_alongNormals).
void clipWorldPieces(NearClipper& clipper, const OverlayView& view, const LayerGeometry& layer,
                     std::span<const std::size_t> slots, const CapPadding& padding, const PixelScale& scale) {
  const std::vector<LayerGeometry::Vertex>& vertices = layer.vertices();
  const std::vector<glm::vec4>& normals = layer.normals();
  const std::vector<glm::vec4>& scaling = layer.scaling();
  const std::vector<std::uint32_t>& indices = layer.indices();
  const bool inPixels = layer.widthPixels() > 0.0 && scaling.size() == vertices.size();
  const double halfWidthPerMetre = inPixels ? 0.5 * layer.widthPixels() * scale.metresPerPixel : 0.0;
  const double maxHalfWidth = 0.5 * layer.style().widthCap();
  for (std::size_t slot : slots) {
    const LayerGeometry::PieceSlot& s = layer.slots()[slot];
    if (s.indexCount == 0) continue;
    const glm::dvec3 origin = layer.worldOrigins()[s.origin] - view.eye;
    clipper.begin(vertices[indices[s.firstIndex] + s.baseVertex].rgba);
    const auto at = [&](std::uint32_t index) {
      const std::size_t i = std::size_t{index} + s.baseVertex;
      const LayerGeometry::Vertex& v = vertices[i];
      const glm::dvec3 up(normals[i]);
      glm::dvec3 q = origin + glm::dvec3(v.x, v.y, v.height);
      if (inPixels) {
        const glm::dvec3 centre = q + up * static_cast<double>(normals[i].w);
        const double h = std::max(std::min(halfWidthPerMetre * glm::length(centre), maxHalfWidth),
                                  static_cast<double>(scaling[i].w));
        q += glm::dvec3(scaling[i]) * h;
      }
      const double side = v.side;
      const double reach = side < 0.0 ? -padding.reach.x : side > 0.0 ? padding.reach.y : 0.0;
      return q + up * (side * padding.at(glm::length(q)) + reach);
    };
    for (std::uint32_t k = s.firstIndex; k + 2 < s.firstIndex + s.indexCount; k += 3)
      clipper.triangle(at(indices[k]), at(indices[k + 1]), at(indices[k + 2]));
    clipper.end();
  }
}

}  // namespace

std::vector<ClippedVertex> clipAtNearPlane(const OverlayView& view, const LayerGeometry& layer,
                                           std::span<const std::size_t> slots, const CapPadding& padding,
                                           const PixelScale& scale, bool capped) {
  std::vector<ClippedVertex> out;
  NearClipper clipper(view, capped, out);
  if (layer.alongNormals()) {
    clipWorldPieces(clipper, view, layer, slots, padding, scale);
  } else {
    clipFootprints(clipper, view, layer, slots, padding, scale);
  }
  return out;
}

}  // namespace gis::overlay
