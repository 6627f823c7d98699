// Identify on the globe: which features of a layer hold a ground point (the CPU reference's own
// predicates, per feature).
#include <algorithm>

#include "globe_detail.hpp"

namespace gis::globe {

std::vector<std::uint32_t> featuresAt(const GlobeLayer& layer, const glm::dvec3& point, double lonDeg, double latDeg,
                                      const overlay::PixelScale& scale) {
  std::vector<std::uint32_t> out;
  const auto add = [&out](std::uint32_t feature) {
    if (std::find(out.begin(), out.end(), feature) == out.end()) out.push_back(feature);
  };
  // The areas, and the bands and discs a line layer is drawn with (they lie within its width).
  for (const GlobePolygon& p : layer.polygons()) {
    if (contains(p, point, lonDeg, latDeg)) add(p.feature);
  }
  // The lines exactly: within half their width.
  for (const GlobeLine& l : layer.lines()) {
    if (detail::nearLine(layer, l, point, lonDeg, latDeg, scale)) add(l.feature);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace gis::globe
