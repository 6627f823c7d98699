#include "geo/feature.hpp"

namespace gis::geo {

std::size_t Feature::vertexCount() const {
  std::size_t n = 0;
  for (const Polygon& p : polygons) {
    n += p.outer.size();
    for (const Ring& h : p.holes) n += h.size();
  }
  for (const LineString& l : lines) n += l.size();
  return n;
}

}  // namespace gis::geo
