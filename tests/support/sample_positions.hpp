#pragma once
// MSAA in the GL tests: the reference evaluated at each sample of a pixel, in either frame.
#include <glm/mat4x4.hpp>

namespace gis::test::overlay_test {

/// The matrix under which sample position (sx, sy) of each pixel (GL convention: from the
/// pixel's lower-left corner, y up) projects to the pixel's centre: the reference unprojects
/// pixel centres, so this makes it evaluate at the sample.
inline glm::dmat4 atSample(const glm::dmat4& viewProj, double sx, double sy, int width, int height) {
  // x' = x − 2(sx − ½)/W · w (and y alike): a clip-space shift proportional to w, i.e. rows 0
  // and 1 of the matrix gain a multiple of row 3.
  const double dx = -2.0 * (sx - 0.5) / width, dy = -2.0 * (sy - 0.5) / height;
  glm::dmat4 r = viewProj;
  for (int c = 0; c < 4; ++c) {
    r[c][0] += dx * viewProj[c][3];
    r[c][1] += dy * viewProj[c][3];
  }
  return r;
}

}  // namespace gis::test::overlay_test
