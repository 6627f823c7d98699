// The caps' padding against depth resolution (docs/depth-precision.md). The overlay moves each
// polyhedron's top cap up and its bottom cap down by pad(s) = padBase + padPerMetre · s, s the
// vertex's distance from the eye (OverlaySettings, the volume vertex shader). The bounds hold the
// terrain, so along any ray the cap is at least pad(s) in front of (behind) the terrain point the
// ray meets: the mark pass counts the cap correctly while pad(s) exceeds what the depth test can
// confuse there. That is, along the ray at distance s:
// - the depth buffer's resolution: the terrain's stored depth and the cap fragment's are each
//   rounded to the format, within half a step: together one step. Reversed-Z stores n / z (n the
//   near plane, z the distance along the view axis, z ≤ s):
//   - float (GL_DEPTH32F_STENCIL8): one ulp ≤ 2^-23 of n / z, i.e. 2^-23 · s along the ray;
//   - 24-bit fixed point (GL_DEPTH24_STENCIL8): one step 1 / (2^24 − 1) of n / z, i.e.
//     z · s / (n (2^24 − 1)) ≤ s² / (n (2^24 − 1)) along the ray;
// - the vertices' float error, for the cap and for the terrain: eye-relative coordinates rounded
//   (√3 · 2^-24 · s) and transformed to clip space in float (about 4 roundings of terms ≤ s).
// This test checks the real defaults (OverlaySettings{}) against that sum with a margin of 2, for
// the near planes the viewer's camera controller picks (0.05 m … 1000 m) and distances from the
// near plane to 10,000 km, and prints where a 24-bit buffer would need more.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "vector_overlay/overlay_renderer.hpp"

namespace gis::test {
namespace {

constexpr double kUnitRoundoff = 0x1p-24;  // float: half an ulp of 1
constexpr double kFixed24Step = 1.0 / (0x1p24 - 1.0);
constexpr double kMargin = 2.0;
constexpr double kFarthest = 1e7;  // 10,000 km
// The camera controller's range of near planes (apps/common/src/camera_controller.cpp: half the
// height above ground, clamped to [0.05 m, 1000 m]); 1 m is the default camera's.
const std::vector<double> kNearPlanes{0.05, 0.1, 1.0, 10.0, 100.0, 1000.0};

enum class Format { Float32, Fixed24 };

/// Distance along the ray within which the depth test cannot tell the cap from the terrain.
double bufferResolution(Format f, double s, double near) {
  return f == Format::Float32 ? 2.0 * kUnitRoundoff * s : s * s / near * kFixed24Step;
}

/// The vertices' float error along the ray, cap and terrain together.
double vertexRounding(double s) { return 2.0 * (std::sqrt(3.0) + 4.0) * kUnitRoundoff * s; }

double required(Format f, double s, double near) { return bufferResolution(f, s, near) + vertexRounding(s); }

double pad(const overlay::OverlaySettings& o, double s) { return o.padBase + o.padPerMetre * s; }

/// Distances from `near` to kFarthest, 20 a decade.
std::vector<double> distances(double near) {
  std::vector<double> out;
  for (double s = near; s < kFarthest; s *= std::pow(10.0, 0.05)) out.push_back(s);
  out.push_back(kFarthest);
  return out;
}

/// The smallest distance ≥ near where pad(s) < margin · required(s) (bisection; the difference is
/// concave in s, positive at the near plane), or infinity if there is none up to 10^12 m.
double firstFailure(const overlay::OverlaySettings& o, Format f, double near, double margin) {
  auto holds = [&](double s) { return pad(o, s) >= margin * required(f, s, near); };
  if (!holds(near)) return near;
  double lo = near, hi = near;
  while (holds(hi)) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e12) return std::numeric_limits<double>::infinity();
  }
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (holds(mid) ? lo : hi) = mid;
  }
  return hi;
}

TEST(CapPadding, TheModelBoundsTheFormatsRealDepthSteps) {
  // The resolution model against the formats themselves: the stored value of a distance and the
  // next value towards the eye are no farther apart than the model says.
  for (double near : kNearPlanes) {
    for (double s : distances(near)) {
      const double stored = near / s;
      const float asFloat = static_cast<float>(stored);
      const float nextFloat = std::nextafter(asFloat, 2.0F);
      const double floatStep = near / static_cast<double>(asFloat) - near / static_cast<double>(nextFloat);
      EXPECT_LE(floatStep, bufferResolution(Format::Float32, s, near) * (1.0 + 1e-6)) << near << " m, " << s << " m";
      const double steps = std::round(stored / kFixed24Step);
      // The last steps (beyond near · 2^24 / 100) hold distances a factor apart: no resolution.
      if (steps < 100.0) continue;
      const double fixedStep = near / (steps * kFixed24Step) - near / ((steps + 1.0) * kFixed24Step);
      EXPECT_LE(fixedStep, bufferResolution(Format::Fixed24, s, near) * 1.02) << near << " m, " << s << " m";
    }
  }
}

TEST(CapPadding, DefaultPadExceedsFloatReversedZResolutionAndVertexRoundingAtEveryDistance) {
  const overlay::OverlaySettings defaults;
  std::printf("pad(s) = %.3g m + %.3g · s; float reversed-Z needs %.3g · s (buffer) + %.3g · s (vertices)\n",
              defaults.padBase, defaults.padPerMetre, bufferResolution(Format::Float32, 1.0, 1.0), vertexRounding(1.0));
  double worstRatio = std::numeric_limits<double>::infinity();
  for (double near : kNearPlanes) {
    double worstHere = std::numeric_limits<double>::infinity(), at = near;
    for (double s : distances(near)) {
      const double ratio = pad(defaults, s) / required(Format::Float32, s, near);
      if (ratio < worstHere) {
        worstHere = ratio;
        at = s;
      }
      EXPECT_GE(ratio, kMargin) << "near " << near << " m: at " << s << " m the pad " << pad(defaults, s)
                                << " m is not " << kMargin << "x the " << required(Format::Float32, s, near)
                                << " m float reversed-Z can confuse";
    }
    std::printf("near %7.2f m: pad / needed >= %.2f (at %.3g m)\n", near, worstHere, at);
    worstRatio = std::min(worstRatio, worstHere);
  }
  std::printf("float reversed-Z: smallest pad / needed %.2f (margin required: %.1f)\n", worstRatio, kMargin);
  EXPECT_TRUE(std::isinf(firstFailure(defaults, Format::Float32, 1.0, kMargin)));
}

TEST(CapPadding, A24BitBufferWouldOutgrowThePadWithinTensOfKilometres) {
  const overlay::OverlaySettings defaults;
  std::printf("24-bit reversed-Z: the pad falls below the depth step at\n");
  for (double near : kNearPlanes) {
    const double fails = firstFailure(defaults, Format::Fixed24, near, 1.0);
    const double failsWithMargin = firstFailure(defaults, Format::Fixed24, near, kMargin);
    std::printf("  near %7.2f m: %10.0f m (with margin %.0f: %10.0f m)\n", near, fails, kMargin, failsWithMargin);
    // The depth step grows as s² / n, the pad as s: a 24-bit buffer always runs out, at about
    // n · 2^24 · padPerMetre for the larger near planes (≈ 34 n), within 100 km for all of them.
    EXPECT_LT(failsWithMargin, fails);
    EXPECT_LT(fails, 1e5) << near;
  }
  // With the default camera's 1 m near plane a 24-bit buffer is short of the pad before 1 km.
  EXPECT_LT(firstFailure(defaults, Format::Fixed24, 1.0, 1.0), 1000.0);
}

}  // namespace
}  // namespace gis::test
