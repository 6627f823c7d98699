#pragma once
// A land border as OpenStreetMap gives it, made up: one shell of many vertices (a wobbly disc of
// radius 0.5° near Olinda, in longitude/latitude) with many lakes as holes on a grid inside it,
// optionally islands as further parts of a multi-polygon, and optionally two holes that break OGC
// validity: one wholly outside the shell (beyond its edge but inside its bounding box, so that a
// bounding-box test alone cannot tell) and one crossing the shell's edge. For the validity
// checks' test (polygon_checks_test.cpp) and benchmark (polygon_checks_bench.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace gis::test {

struct ManyHolesShape {
  int shellVertices = 20000;
  int holes = 2000;
  int holeVertices = 8;
  int islands = 0;            ///< further parts (a MultiPolygon when > 0), each a small octagon
  bool outsideHole = false;   ///< hole outsideHoleNumber() lies wholly outside the shell
  bool crossingHole = false;  ///< hole crossingHoleNumber() crosses the shell's edge

  /// 1-based, as the reader's messages number holes.
  [[nodiscard]] int outsideHoleNumber() const { return holes / 2 + 1; }
  [[nodiscard]] int crossingHoleNumber() const { return holes / 3 + 1; }
  [[nodiscard]] long vertexCount() const {
    return static_cast<long>(shellVertices) + static_cast<long>(holes) * holeVertices + 8L * islands;
  }
};

namespace many_holes_detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kCentreLon = -34.9, kCentreLat = -8.05, kRadius = 0.5;

/// A closed ring (first point repeated) as GeoJSON coordinates.
inline void writeRing(std::ostream& out, const std::vector<std::array<double, 2>>& ring) {
  char buffer[64];
  out << '[';
  for (std::size_t i = 0; i <= ring.size(); ++i) {
    const auto& p = ring[i % ring.size()];
    std::snprintf(buffer, sizeof buffer, "%s[%.10f,%.10f]", i == 0 ? "" : ",", p[0], p[1]);
    out << buffer;
  }
  out << ']';
}

/// A regular polygon of n vertices about (x, y) (offsets from the centre, degrees), clockwise
/// when `clockwise`.
inline std::vector<std::array<double, 2>> regular(double x, double y, double radius, int n, bool clockwise) {
  std::vector<std::array<double, 2>> ring;
  for (int k = 0; k < n; ++k) {
    const double a = (clockwise ? -1.0 : 1.0) * 2.0 * kPi * k / n + 0.3;
    ring.push_back({kCentreLon + x + radius * std::cos(a), kCentreLat + y + radius * std::sin(a)});
  }
  return ring;
}

}  // namespace many_holes_detail

/// Writes the shape as a GeoJSON of one feature (id 1) to `path`.
inline void writeManyHoles(const std::string& path, const ManyHolesShape& shape) {
  using namespace many_holes_detail;
  std::ofstream out(path);
  out << R"({"type": "FeatureCollection", "features": [{"type": "Feature", "id": 1, "properties": {}, )"
      << R"("geometry": {"type": ")" << (shape.islands > 0 ? "MultiPolygon" : "Polygon") << R"(", "coordinates": )";
  if (shape.islands > 0) out << '[';
  out << '[';
  // The shell: a disc whose radius wobbles by ±5 % (never below 0.95 R).
  std::vector<std::array<double, 2>> shell;
  for (int k = 0; k < shape.shellVertices; ++k) {
    const double a = 2.0 * kPi * k / shape.shellVertices;
    const double r = kRadius * (1.0 + 0.04 * std::sin(29.0 * a) + 0.01 * ((k * 7919) % 13) / 13.0);
    shell.push_back({kCentreLon + r * std::cos(a), kCentreLat + r * std::sin(a)});
  }
  writeRing(out, shell);
  // The lakes on a grid within ±0.6 R (their farthest reach 0.85 R + their radius < 0.95 R).
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(shape.holes))));
  const double spacing = 1.2 * kRadius / side, lake = 0.3 * spacing;
  for (int i = 0; i < shape.holes; ++i) {
    double x = -0.6 * kRadius + (i % side + 0.5) * spacing, y = -0.6 * kRadius + (i / side + 0.5) * spacing;
    if (shape.outsideHole && i + 1 == shape.outsideHoleNumber()) {
      x = y = 0.9 * kRadius;  // 1.27 R from the centre: outside the shell, inside its bounding box
    } else if (shape.crossingHole && i + 1 == shape.crossingHoleNumber()) {
      x = kRadius;  // on the shell's edge at angle 0
      y = 0.0;
    }
    out << ',';
    writeRing(out, regular(x, y, lake, shape.holeVertices, true));
  }
  out << ']';
  // Islands on a ring between 1.5 R and 2 R.
  for (int i = 0; i < shape.islands; ++i) {
    const double a = 2.0 * kPi * i / shape.islands, r = kRadius * (1.5 + 0.5 * (i % 2));
    out << ",[";
    writeRing(out,
              regular(r * std::cos(a), r * std::sin(a), 0.2 * kRadius * kPi / std::max(shape.islands, 4), 8, false));
    out << ']';
  }
  if (shape.islands > 0) out << ']';
  out << "}}]}\n";
}

}  // namespace gis::test
