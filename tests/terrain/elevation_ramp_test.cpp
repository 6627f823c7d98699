// The elevation ramp on the CPU: stops, interpolation, clamping, the height range of a DEM, and
// the hypsometric ramp's stops told apart under simulated colour-vision deficiencies.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "terrain/elevation_ramp.hpp"
#include "terrain/quadtree.hpp"

namespace gis::test {
namespace {

using terrain::ElevationRamp;

TEST(ElevationRampTest, StopsAreHitAndSegmentsInterpolatedLinearly) {
  const ElevationRamp& ramp = ElevationRamp::hypsometric();
  const auto stops = ramp.stops();
  ASSERT_GE(stops.size(), 2u);
  ASSERT_LE(stops.size(), ElevationRamp::kMaxStops);
  EXPECT_EQ(stops.front().t, 0.0);
  EXPECT_EQ(stops.back().t, 1.0);
  for (std::size_t k = 0; k < stops.size(); ++k) {
    EXPECT_LT(glm::distance(ramp.colorAt(stops[k].t), stops[k].color), 1e-6F) << k;
    if (k == 0) continue;
    EXPECT_LT(stops[k - 1].t, stops[k].t);
    for (const double f : {0.25, 0.5, 0.9}) {
      const double t = stops[k - 1].t + f * (stops[k].t - stops[k - 1].t);
      const glm::vec3 expected =
          stops[k - 1].color * static_cast<float>(1.0 - f) + stops[k].color * static_cast<float>(f);
      EXPECT_LT(glm::distance(ramp.colorAt(t), expected), 1e-6F) << k << " " << f;
    }
  }
}

TEST(ElevationRampTest, ClampsOutsideTheRangeAndIsContinuous) {
  const ElevationRamp& ramp = ElevationRamp::hypsometric();
  EXPECT_EQ(ramp.colorAt(-3.0), ramp.stops().front().color);
  EXPECT_EQ(ramp.colorAt(7.0), ramp.stops().back().color);
  EXPECT_EQ(ramp.colorAt(std::numeric_limits<double>::quiet_NaN()), ramp.stops().front().color);
  // No jump: a step of 1e-4 in t changes a channel by at most 1e-4 × the steepest segment.
  glm::vec3 previous = ramp.colorAt(0.0);
  for (int k = 1; k <= 10000; ++k) {
    const glm::vec3 c = ramp.colorAt(k * 1e-4);
    EXPECT_LT(glm::length(c - previous), 5e-4F) << k;
    previous = c;
  }
}

TEST(ElevationRampTest, NormalisesTrueHeightsOverTheRange) {
  EXPECT_EQ(ElevationRamp::normalised(100.0, 100.0, 300.0), 0.0);
  EXPECT_EQ(ElevationRamp::normalised(250.0, 100.0, 300.0), 0.75);
  EXPECT_EQ(ElevationRamp::normalised(-50.0, 100.0, 300.0), 0.0);
  EXPECT_EQ(ElevationRamp::normalised(900.0, 100.0, 300.0), 1.0);
  EXPECT_EQ(ElevationRamp::normalised(120.0, 120.0, 120.0), 0.0);  // a flat DEM
  EXPECT_EQ(ElevationRamp::normalised(std::numeric_limits<double>::quiet_NaN(), 0.0, 1.0), 0.0);
}

TEST(ElevationRampTest, DemHeightRangeIsTheValidPostsRange) {
  auto grid = std::make_shared<terrain::TerrainGrid>();
  grid->width = 33;
  grid->height = 17;
  grid->heights.assign(33 * 17, 12.5F);
  grid->heights[40] = -431.0F;
  grid->heights[300] = 8848.0F;
  grid->heights[301] = std::numeric_limits<float>::quiet_NaN();
  const terrain::TerrainQuadtree tree(grid, 8);
  const auto range = terrain::demHeightRange(tree);
  ASSERT_TRUE(range.has_value());
  EXPECT_EQ(range->first, -431.0);
  EXPECT_EQ(range->second, 8848.0);
}

// Colour-vision deficiencies simulated as Machado, Oliveira and Fernandes (2009) do at full
// severity: a 3 × 3 matrix on linear RGB. Every pair of stops stays at least 15 ΔE*ab apart
// (CIE 1976; 2.3 is a just-noticeable difference) for each kind of dichromat.
glm::dvec3 linear(const glm::dvec3& srgb) {
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) {
    out[c] = srgb[c] <= 0.04045 ? srgb[c] / 12.92 : std::pow((srgb[c] + 0.055) / 1.055, 2.4);
  }
  return out;
}

glm::dvec3 lab(const glm::dvec3& linearRgb) {
  const glm::dvec3 rgb = glm::clamp(linearRgb, 0.0, 1.0);
  const glm::dvec3 xyz(0.4124 * rgb.x + 0.3576 * rgb.y + 0.1805 * rgb.z,
                       0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z,
                       0.0193 * rgb.x + 0.1192 * rgb.y + 0.9505 * rgb.z);
  const auto f = [](double v) { return v > 0.008856 ? std::cbrt(v) : 7.787 * v + 16.0 / 116.0; };
  const double fx = f(xyz.x / 0.95047), fy = f(xyz.y), fz = f(xyz.z / 1.08883);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

TEST(ElevationRampTest, HypsometricStopsStayApartForColourBlindViewers) {
  // Rows as printed in the paper; glm matrices are column-major, hence the transpose.
  const std::array<std::pair<const char*, glm::dmat3>, 4> vision{{
      {"normal", glm::dmat3(1.0)},
      {"deuteranopia", glm::transpose(glm::dmat3(0.367322, 0.860646, -0.227968, 0.280085, 0.672501, 0.047413, -0.011820,
                                                 0.042940, 0.968881))},
      {"protanopia", glm::transpose(glm::dmat3(0.152286, 1.052583, -0.204868, 0.114503, 0.786281, 0.099216, -0.003882,
                                               -0.048116, 1.051998))},
      {"tritanopia", glm::transpose(glm::dmat3(1.255528, -0.076749, -0.178779, -0.078411, 0.930809, 0.147602, 0.004733,
                                               0.691367, 0.303900))},
  }};
  const auto stops = ElevationRamp::hypsometric().stops();
  for (const auto& [name, m] : vision) {
    for (std::size_t i = 0; i < stops.size(); ++i) {
      for (std::size_t j = i + 1; j < stops.size(); ++j) {
        const double difference =
            glm::distance(lab(m * linear(glm::dvec3(stops[i].color))), lab(m * linear(glm::dvec3(stops[j].color))));
        EXPECT_GE(difference, 15.0) << name << ": stops " << i << " and " << j;
      }
    }
  }
}

}  // namespace
}  // namespace gis::test
