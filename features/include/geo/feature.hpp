#pragma once
// Vector features as plain values in the scene frame: what the geo library reads (through
// GDAL/OGR) and the overlay library draws. Their own target (gis::features), so that the overlay
// needs none of GDAL, PROJ or GeographicLib: a GIS client that reads its data itself fills these.
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include <glm/vec2.hpp>

namespace gis::geo {

/// A ring in frame coordinates. Not closed: the last point is not a copy of the first.
using Ring = std::vector<glm::dvec2>;
using LineString = std::vector<glm::dvec2>;

struct Polygon {
  Ring outer;
  std::vector<Ring> holes;
};

using AttributeValue = std::variant<std::monostate, std::int64_t, double, std::string>;

/// One feature. A multi-polygon has several polygons; a multi-line several lines.
struct Feature {
  std::int64_t fid = -1;
  std::vector<Polygon> polygons;
  std::vector<LineString> lines;
  std::map<std::string, AttributeValue> attributes;

  [[nodiscard]] std::size_t vertexCount() const;
};

}  // namespace gis::geo
