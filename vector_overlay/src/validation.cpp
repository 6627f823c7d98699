#include "vector_overlay/validation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include <glm/geometric.hpp>

namespace gis::overlay {

std::uint32_t appendPieceIndices(const Footprint& f, std::vector<std::uint32_t>& idx) {
  const std::size_t first = idx.size();
  for (const auto& t : f.triangles) idx.insert(idx.end(), {2 * t[0], 2 * t[2], 2 * t[1]});  // bottom: clockwise
  const auto bottomCount = static_cast<std::uint32_t>(idx.size() - first);
  for (const auto& e : f.boundary) {
    const std::uint32_t alo = 2 * e[0], ahi = alo + 1, blo = 2 * e[1], bhi = blo + 1;
    idx.insert(idx.end(), {alo, blo, bhi, alo, bhi, ahi});  // outward: the region is on the edge's left
  }
  for (const auto& t : f.triangles) idx.insert(idx.end(), {2 * t[0] + 1, 2 * t[1] + 1, 2 * t[2] + 1});
  return bottomCount;
}

namespace {

std::string describe(const glm::dvec2& p) {
  std::ostringstream s;
  s.precision(17);
  s << '(' << p.x << ", " << p.y << ')';
  return s.str();
}

double cross(const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; }

}  // namespace

std::vector<std::string> polyhedronProblems(const Polyhedron& p, const ValidationOptions& options) {
  std::vector<std::string> problems;
  const Footprint& f = p.footprint;
  const std::size_t n = f.vertices.size();
  if (n == 0 || f.triangles.empty()) problems.emplace_back("empty footprint (no vertices or no triangles)");

  // Bounded: finite coordinates of sane magnitude, lo ≤ hi.
  if (!std::isfinite(p.lo) || !std::isfinite(p.hi)) problems.emplace_back("non-finite height bounds");
  if (!(p.lo <= p.hi)) problems.emplace_back("lo above hi");
  if (std::abs(p.lo) > options.maxCoordinate || std::abs(p.hi) > options.maxCoordinate)
    problems.emplace_back("height bounds beyond the largest coordinate");
  for (std::size_t k = 0; k < n; ++k) {
    const glm::dvec2& v = f.vertices[k];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || std::abs(v.x) > options.maxCoordinate ||
        std::abs(v.y) > options.maxCoordinate) {
      problems.push_back("vertex " + std::to_string(k) + " " + describe(v) + " is not finite or beyond " +
                         "the largest coordinate");
      return problems;  // the rest would only repeat it
    }
  }
  for (const auto& t : f.triangles) {
    if (t[0] >= n || t[1] >= n || t[2] >= n) {
      problems.emplace_back("a triangle refers to a vertex beyond the footprint's");
      return problems;
    }
  }
  for (const auto& e : f.boundary) {
    if (e[0] >= n || e[1] >= n) {
      problems.emplace_back("a boundary edge refers to a vertex beyond the footprint's");
      return problems;
    }
  }

  // Size of the footprint, for the relative tolerances.
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec2& v : f.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  const double size = std::max({hi.x - lo.x, hi.y - lo.y, 1e-300});
  const double magnitude = std::max({std::abs(lo.x), std::abs(lo.y), std::abs(hi.x), std::abs(hi.y), 1.0});
  // Rounding of a cross product of coordinates of this magnitude, relative to the size².
  const double areaSlack = 64.0 * std::numeric_limits<double>::epsilon() * magnitude * size;

  // Caps: counter-clockwise triangles (a sliver of zero area is allowed).
  double area = 0.0;
  std::size_t clockwise = 0;
  for (const auto& t : f.triangles) {
    const glm::dvec2 a = f.vertices[t[0]], b = f.vertices[t[1]], c = f.vertices[t[2]];
    const double twice = cross(b - a, c - a);
    if (twice < -areaSlack) ++clockwise;
    area += 0.5 * twice;
  }
  if (clockwise > 0) problems.push_back(std::to_string(clockwise) + " cap triangle(s) wound clockwise");

  // Closed: the drawn mesh's directed edges pair up with their reverses, once each.
  std::vector<std::uint32_t> indices;
  appendPieceIndices(f, indices);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (std::size_t k = 0; k + 2 < indices.size(); k += 3) {
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = indices[k + static_cast<std::size_t>(e)];
      const std::uint32_t b = indices[k + static_cast<std::size_t>((e + 1) % 3)];
      if (a == b) continue;  // a wall quad of a zero-length edge would be degenerate; counted below
      ++directed[{a, b}];
    }
  }
  // An edge may be met more than once (two parts of a region touching at a vertex make a
  // vertical wall edge shared by four wall triangles): the winding number stays well defined as
  // long as each direction is met as often as the other.
  std::size_t unpaired = 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != count) ++unpaired;
  }
  if (unpaired > 0) problems.push_back(std::to_string(unpaired) + " edge(s) without their reverse: not closed");
  for (const auto& e : f.boundary) {
    if (e[0] == e[1]) problems.emplace_back("a boundary edge from a vertex to itself");
  }

  // Outward: the signed volume of the mesh as drawn (caps moved out by the padding; computed
  // relative to the footprint's corner so that large coordinates keep their digits) equals
  // area · height.
  const double bottom = p.lo - options.pad, top = p.hi + options.pad;
  const glm::dvec3 corner(lo, bottom);
  auto position = [&](std::uint32_t i) { return glm::dvec3(f.vertices[i / 2], (i % 2) != 0 ? top : bottom) - corner; };
  double volume = 0.0;
  for (std::size_t k = 0; k + 2 < indices.size(); k += 3) {
    const glm::dvec3 a = position(indices[k]), b = position(indices[k + 1]), c = position(indices[k + 2]);
    volume += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  const double height = top - bottom;
  const double expected = area * height;
  const auto terms = static_cast<double>(indices.size());
  const double volumeSlack = options.tolerance * std::abs(expected) + terms * areaSlack * std::max(height, 1.0);
  if (area < -areaSlack * static_cast<double>(std::max<std::size_t>(f.triangles.size(), 1)))
    problems.emplace_back("negative footprint area: wound inward");
  if (!(std::abs(volume - expected) <= volumeSlack)) {
    std::ostringstream s;
    s << "signed volume " << volume << " differs from area · height " << expected;
    problems.push_back(s.str());
  }

  // Inside the grid, and in its cell.
  if (options.grid) {
    const CellGrid& g = *options.grid;
    const double slack = options.tolerance * std::max(g.cellSize, 1.0) +
                         64.0 * std::numeric_limits<double>::epsilon() *
                             std::max(magnitude, std::abs(g.origin.x) + std::abs(g.origin.y));
    const glm::dvec2 gridMax = g.origin + g.cellSize * glm::dvec2(g.columns, g.rows);
    glm::dvec2 cellMin = g.origin, cellMax = gridMax;
    if (f.cell >= 0) {
      if (f.cell >= g.columns * g.rows) {
        problems.push_back("cell " + std::to_string(f.cell) + " is not a cell of the grid");
      } else {
        const int column = f.cell % g.columns, row = f.cell / g.columns;
        cellMin = g.origin + g.cellSize * glm::dvec2(column, row);
        cellMax = cellMin + glm::dvec2(g.cellSize);
      }
    }
    for (std::size_t k = 0; k < n; ++k) {
      const glm::dvec2& v = f.vertices[k];
      if (v.x < cellMin.x - slack || v.y < cellMin.y - slack || v.x > cellMax.x + slack || v.y > cellMax.y + slack) {
        problems.push_back(
            "vertex " + std::to_string(k) + " " + describe(v) +
            (f.cell >= 0 ? " lies outside its cell " + std::to_string(f.cell) : " lies outside the grid"));
        break;
      }
    }
  }
  return problems;
}

}  // namespace gis::overlay
