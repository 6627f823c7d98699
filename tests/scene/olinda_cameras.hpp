#pragma once
// Three cameras on the Olinda sample that the scene GL tests judge from: the overview, oblique
// 1.7 km away, and 150 m over the town looking along the coast.
#include <vector>

#include <glm/vec3.hpp>

#include "scene/camera.hpp"
#include "scene/scene_loader.hpp"

namespace gis::test {

inline std::vector<scene::Camera> olindaCameras(const scene::LoadedScene& olinda) {
  glm::dvec3 lo, hi;
  scene::terrainBox(olinda, 1.0, lo, hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  std::vector<scene::Camera> cameras = {scene::overviewCamera(lo, hi)};
  scene::Camera oblique = cameras[0];
  oblique.eye = centre + glm::dvec3(300.0, -1500.0, 700.0);
  oblique.target = centre + glm::dvec3(0.0, 400.0, 0.0);
  cameras.push_back(oblique);
  scene::Camera street = cameras[0];
  street.eye = centre + glm::dvec3(-200.0, -900.0, 150.0);
  street.target = centre + glm::dvec3(100.0, -300.0, 0.0);
  cameras.push_back(street);
  return cameras;
}

}  // namespace gis::test
