#include "vector_overlay/lasso.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <glm/matrix.hpp>

#include "lasso_geometry.hpp"
#include "vector_overlay/footprints.hpp"

namespace gis::overlay {
namespace {

using lasso_geometry::insideEvenOdd;
using lasso_geometry::nearPlaneOf;

constexpr SelectionOp kOps[] = {SelectionOp::Single, SelectionOp::Or,       SelectionOp::And,
                                SelectionOp::Xor,    SelectionOp::Subtract, SelectionOp::Invert};

}  // namespace

std::optional<SelectionOp> parseSelectionOp(const std::string& text) {
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (SelectionOp op : kOps)
    if (lower == selectionOpName(op)) return op;
  return std::nullopt;
}

const char* selectionOpName(SelectionOp op) {
  switch (op) {
    case SelectionOp::Single:
      return "single";
    case SelectionOp::Or:
      return "or";
    case SelectionOp::And:
      return "and";
    case SelectionOp::Xor:
      return "xor";
    case SelectionOp::Subtract:
      return "subtract";
    case SelectionOp::Invert:
      return "invert";
  }
  return "?";
}

LassoVolume buildLassoVolume(const Lasso& lasso, const std::string& name, Diagnostics& diagnostics) {
  LassoVolume volume;
  const auto fail = [&](const std::string& problem) {
    diagnostics.add(Diagnostic{Severity::Error, lasso.file, "", lasso.label.empty() ? name : lasso.label,
                               problem + "; the lasso selects nothing"});
    return LassoVolume{};
  };
  if (lasso.width < 1 || lasso.height < 1)
    return fail("viewport of " + std::to_string(lasso.width) + " × " + std::to_string(lasso.height) + " pixels");
  const double determinant = glm::determinant(lasso.viewProj);
  const double nearPlane = nearPlaneOf(lasso.viewProj);
  if (!std::isfinite(determinant) || determinant == 0.0 || !(nearPlane > 0.0)) {
    return fail("camera matrix is not an invertible reversed-Z perspective");
  }
  if (!(lasso.distance > nearPlane)) return fail("selection distance not beyond the near plane");
  // The region by the even-odd rule, triangulated with exact predicates in the lasso's own
  // pixel coordinates (the polygon code of the overlays does exactly that), then taken to
  // normalised device coordinates (y up: the orientation flips, so triangles and boundary
  // edges are reversed to stay counter-clockwise).
  geo::Feature feature;
  geo::Polygon polygon;
  polygon.outer = lasso.points;
  feature.polygons.push_back(std::move(polygon));
  Diagnostics local;
  std::vector<Footprint> region = polygonFootprints(feature, 0, name, FootprintOptions{}, local);
  if (region.empty()) return fail("polygon has no area (fewer than 3 distinct points, collinear or not finite)");
  Footprint& f = region.front();
  for (glm::dvec2& v : f.vertices) v = {2.0 * v.x / lasso.width - 1.0, 1.0 - 2.0 * v.y / lasso.height};
  for (auto& t : f.triangles) std::swap(t[1], t[2]);
  for (auto& e : f.boundary) std::swap(e[0], e[1]);

  // Every region vertex on the near plane (ndc z = 1) and on the dark cap (ndc z = near /
  // distance), as finite points (w = 1); at infinity as the ray's direction away from the eye
  // (w = 0 exactly: the sign of a direction matters, that of a rounded w would not be safe).
  const glm::dmat4 inverse = glm::inverse(lasso.viewProj);
  const glm::dvec3 eye = pixelScaleOf(lasso.viewProj, lasso.height).eye;
  const bool infinite = std::isinf(lasso.distance);
  const double farZ = infinite ? 0.5 : nearPlane / lasso.distance;
  std::vector<glm::dvec4> lightCap, darkCap;
  for (const glm::dvec2& v : f.vertices) {
    const glm::dvec4 n = inverse * glm::dvec4(v, 1.0, 1.0);
    const glm::dvec4 d = inverse * glm::dvec4(v, farZ, 1.0);
    const glm::dvec3 nearPoint = glm::dvec3(n) / n.w;
    lightCap.emplace_back(nearPoint, 1.0);
    // At infinity: the direction of the ray through the near point (from the eye).
    darkCap.push_back(infinite ? glm::dvec4(nearPoint - eye, 0.0) : glm::dvec4(glm::dvec3(d) / d.w, 1.0));
  }
  for (const auto& t : f.triangles) volume.triangles.push_back({lightCap[t[0]], lightCap[t[1]], lightCap[t[2]]});
  volume.lightCapTriangles = volume.triangles.size();
  for (const auto& t : f.triangles) volume.triangles.push_back({darkCap[t[0]], darkCap[t[2]], darkCap[t[1]]});
  volume.darkCapTriangles = f.triangles.size();
  // Walls: the region lies left of each boundary edge a → b; outward is to its right.
  for (const auto& e : f.boundary) {
    const glm::dvec4 &na = lightCap[e[0]], &nb = lightCap[e[1]], &fa = darkCap[e[0]], &fb = darkCap[e[1]];
    volume.triangles.push_back({na, fa, fb});
    volume.triangles.push_back({na, fb, nb});
  }
  return volume;
}

bool insideLasso(const Lasso& lasso, const glm::dvec3& point) {
  if (lasso.points.size() < 3 || lasso.width < 1 || lasso.height < 1) return false;
  const std::optional<glm::dvec2> pixel = lasso_geometry::pixelOf(lasso, nearPlaneOf(lasso.viewProj), point);
  return pixel && insideEvenOdd(lasso.points, *pixel);
}

bool selectedAt(std::span<const SelectionStep> steps, const glm::dvec3& point, bool geometry) {
  if (!geometry) return false;
  bool a = false;
  for (const SelectionStep& s : steps)
    a = lasso_geometry::apply(s.op, a, s.op != SelectionOp::Invert && insideLasso(s.lasso, point));
  return a;
}

std::vector<std::uint8_t> selectionMask(const DepthImage& image, std::span<const SelectionStep> steps) {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(std::max(0, image.width) * std::max(0, image.height)), 0);
  if (image.depth.size() != mask.size()) return {};
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::optional<glm::dvec3> p = unprojectPixel(image, x, y);
      if (p && selectedAt(steps, *p))
        mask[static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x)] = 1;
    }
  }
  return mask;
}

}  // namespace gis::overlay
