#include "scene/camera_path.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace gis::scene {

std::vector<PathFrame> flyThrough(const glm::dvec3& boxMin, const glm::dvec3& boxMax, int frames, double fovYDeg) {
  std::vector<PathFrame> path;
  const glm::dvec3 centre = (boxMin + boxMax) * 0.5;
  const glm::dvec2 size = glm::dvec2(boxMax - boxMin);
  const double extent = std::max(size.x, size.y);
  const double relief = boxMax.z - boxMin.z;
  const int third = std::max(frames / 3, 1);
  for (int k = 0; k < frames; ++k) {
    Camera c;
    c.fovYDeg = fovYDeg;
    const int segment = std::min(k / third, 2);
    const double t = static_cast<double>(k - segment * third) / static_cast<double>(std::max(third - 1, 1));
    PathFrame f;
    if (segment == 0) {
      // Straight down from a height that shows about a tenth of the terrain, flying south→north.
      const double height = boxMax.z + 0.1 * extent / std::tan(fovYDeg * std::numbers::pi / 360.0);
      c.eye = glm::dvec3(centre.x + 0.05 * size.x, boxMin.y + (0.2 + 0.6 * t) * size.y, height);
      c.target = glm::dvec3(c.eye.x, c.eye.y + 1e-3, boxMin.z);
      f.segment = "top-down";
    } else if (segment == 1) {
      const double angle = 2.0 * std::numbers::pi * t, pitch = 40.0 * std::numbers::pi / 180.0;
      const double distance = 0.35 * extent + relief;
      c.target = glm::dvec3(centre.x, centre.y, boxMin.z + 0.5 * relief);
      c.eye = c.target + distance * glm::dvec3(std::cos(pitch) * std::sin(angle), -std::cos(pitch) * std::cos(angle),
                                               std::sin(pitch));
      f.segment = "oblique";
    } else {
      // Close to the ground (above the highest point), looking across the terrain to the horizon.
      c.eye =
          glm::dvec3(boxMin.x + (0.15 + 0.7 * t) * size.x, boxMin.y + 0.1 * size.y, boxMax.z + 0.002 * extent + 20.0);
      c.target = c.eye + glm::dvec3(0.2 * size.x, size.y, -0.02 * extent);
      f.segment = "horizon";
    }
    c.nearPlane = 1.0;
    f.camera = c;
    path.push_back(f);
  }
  return path;
}

}  // namespace gis::scene
