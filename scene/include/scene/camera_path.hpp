#pragma once
// Scripted fly-throughs for benchmarks: top-down, oblique and horizon views over a terrain box.
#include <string>
#include <vector>

#include "scene/camera.hpp"

namespace gis::scene {

struct PathFrame {
  Camera camera;
  std::string segment;  ///< "top-down", "oblique" or "horizon"
};

/// `frames` cameras over the box (frame coordinates): a third looking straight down while
/// flying across, a third oblique (40° down) circling the centre, a third near the ground
/// looking at the horizon. Deterministic.
std::vector<PathFrame> flyThrough(const glm::dvec3& boxMin, const glm::dvec3& boxMax, int frames,
                                  double fovYDeg = 45.0);

}  // namespace gis::scene
