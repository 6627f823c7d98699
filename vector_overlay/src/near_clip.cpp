#include "vector_overlay/near_clip.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

#include <glm/geometric.hpp>

namespace gis::overlay {

std::vector<ClippedVertex> clipAtNearPlane(const OverlayView& view, const LayerGeometry& layer,
                                           std::span<const std::size_t> slots, const CapPadding& padding,
                                           const PixelScale& scale, bool capped) {
  // w of clip space is the distance along the view direction; the near plane is at w = near.
  const glm::dmat4& m = view.viewProj;
  const glm::dvec3 wRow(m[0][3], m[1][3], m[2][3]);
  const double wEye = glm::dot(wRow, view.eye) + m[3][3];  // 0 for a perspective through the eye
  const double wMin = 0.5 * view.nearPlane;
  std::vector<ClippedVertex> out;
  auto emit = [&](const glm::dvec3& q, const std::uint8_t* rgba) {
    out.push_back({static_cast<float>(q.x),
                   static_cast<float>(q.y),
                   static_cast<float>(q.z),
                   0.0F,
                   {rgba[0], rgba[1], rgba[2], rgba[3]}});
  };
  // The point where edge (a, b) meets the plane, computed from the endpoints in a fixed order
  // so that the two faces sharing the edge get the same point, bit for bit.
  auto cut = [&](glm::dvec3 a, glm::dvec3 b, double wa, double wb) {
    if (std::tie(b.x, b.y, b.z) < std::tie(a.x, a.y, a.z)) {
      std::swap(a, b);
      std::swap(wa, wb);
    }
    const double t = (wMin - wa) / (wb - wa);
    return a + t * (b - a);
  };
  for (std::size_t slot : slots) {
    const Polyhedron& p = layer.polyhedra()[slot];
    const FeatureStyle& style = layer.featureStyles()[p.footprint.feature];
    const std::uint8_t rgba[4] = {
        static_cast<std::uint8_t>(std::lround(std::clamp(style.color.x, 0.0F, 1.0F) * 255.0F)),
        static_cast<std::uint8_t>(std::lround(std::clamp(style.color.y, 0.0F, 1.0F) * 255.0F)),
        static_cast<std::uint8_t>(std::lround(std::clamp(style.color.z, 0.0F, 1.0F) * 255.0F)),
        static_cast<std::uint8_t>(std::lround(std::clamp(style.color.w, 0.0F, 1.0F) * 255.0F))};
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
    // With `capped`: the cut edges (entry, exit) of the piece's faces, for the cap on the plane.
    std::vector<std::array<glm::dvec3, 2>> cuts;
    auto triangle = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
      const std::array<glm::dvec3, 3> v{a, b, c};
      std::array<double, 3> w{};
      int inside = 0;
      for (int k = 0; k < 3; ++k) {
        w[static_cast<std::size_t>(k)] = glm::dot(wRow, v[static_cast<std::size_t>(k)]) + wEye;
        inside += w[static_cast<std::size_t>(k)] >= wMin ? 1 : 0;
      }
      if (inside == 0) return;
      // Sutherland–Hodgman against one plane: a triangle or a quad (two triangles), same winding.
      // The polygon runs along the plane from where it leaves the kept side to where it enters.
      std::vector<glm::dvec3> poly;
      glm::dvec3 entry(0.0), exit(0.0);
      for (std::size_t k = 0; k < 3 && inside < 3; ++k) {
        const std::size_t n = (k + 1) % 3;
        const bool in = w[k] >= wMin, nextIn = w[n] >= wMin;
        if (in) poly.push_back(v[k]);
        if (in != nextIn) {
          poly.push_back(cut(v[k], v[n], w[k], w[n]));
          (in ? exit : entry) = poly.back();
        }
      }
      if (capped && inside < 3) cuts.push_back({entry, exit});
      // A face whose plane passes through the eye is seen edge on: it covers no area, but
      // rounded to float its image becomes a sliver of either orientation with meaningless
      // depths, which would count. Leave it out when the eye is within 1e-5 of the distance to
      // the face from its plane (its image is then under 0.01 px wide); a wall shared by two
      // pieces of the layer goes from both, which keeps their sum.
      const glm::dvec3 normal = glm::cross(b - a, c - a);
      const double nearest = std::min({glm::length(a), glm::length(b), glm::length(c)});
      if (std::abs(glm::dot(normal, a)) <= 1e-5 * nearest * glm::length(normal)) return;
      if (inside == 3) {
        for (const glm::dvec3& q : v) emit(q, rgba);
        return;
      }
      for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
        emit(poly[0], rgba);
        emit(poly[k], rgba);
        emit(poly[k + 1], rgba);
      }
    };
    for (const auto& t : f.triangles) {
      triangle(bottom[t[0]], bottom[t[2]], bottom[t[1]]);
      triangle(top[t[0]], top[t[1]], top[t[2]]);
    }
    for (const auto& e : f.boundary) {
      triangle(bottom[e[0]], bottom[e[1]], top[e[1]]);
      triangle(bottom[e[0]], top[e[1]], top[e[0]]);
    }
    // The cap: the section of the piece by the plane, bounded by the cut edges run the other
    // way round (entry → exit), drawn as a fan from one point of it. Overlapping fan triangles
    // of opposite orientation cancel, so every pixel counts the section's winding number — 1
    // inside, 0 outside — without triangulating it; it faces the eye, as the kept side's
    // boundary there must. Shared cut points are bit-identical, so the fan is watertight.
    if (!cuts.empty()) {
      const glm::dvec3 o = cuts.front()[0];
      for (const auto& [entry, exit] : cuts) {
        emit(o, rgba);
        emit(entry, rgba);
        emit(exit, rgba);
      }
    }
  }
  return out;
}

}  // namespace gis::overlay
