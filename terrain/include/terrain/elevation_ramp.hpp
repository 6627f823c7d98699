#pragma once
// A hypsometric tint: colour by height for a DEM drawn without imagery. The terrain shader
// interpolates the same stops in the same way (TerrainEngine passes them as uniforms), so a
// legend drawn from colorAt shows the colours on screen before the hillshade darkens them.
#include <cstddef>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

namespace gis::terrain {

class TerrainQuadtree;

struct RampStop {
  double t = 0.0;         ///< normalised height, 0 … 1
  glm::vec3 color{0.0F};  ///< RGB 0 … 1, written to the framebuffer as is
};

class ElevationRamp {
 public:
  static constexpr std::size_t kMaxStops = 8;  ///< the shader's uniform arrays

  /// Stops strictly increasing in t, the first at 0 and the last at 1, 2 … kMaxStops of them
  /// (asserted: a programmer error).
  explicit ElevationRamp(std::vector<RampStop> stops);

  /// Teal lowlands, green, pale yellow, brown, snow white. Lightness alternates (33, 65, 88, 40,
  /// 97 L*), so neighbouring stops stay apart for deuteranopes, protanopes and tritanopes alike
  /// (tests/terrain/elevation_ramp_test.cpp measures it).
  static const ElevationRamp& hypsometric();

  /// Linear between the neighbouring stops; t is clamped to [0, 1] (NaN gives the first stop).
  [[nodiscard]] glm::vec3 colorAt(double t) const;
  [[nodiscard]] std::span<const RampStop> stops() const { return stops_; }

  /// The ramp coordinate of a true height over [low, high]: (height − low) / (high − low),
  /// clamped to [0, 1]; 0 for every height when high ≤ low (a flat DEM).
  static double normalised(double height, double low, double high);

 private:
  std::vector<RampStop> stops_;
};

/// The DEM's true (unexaggerated) heights, lowest and highest valid post: the range a viewer
/// gives RenderSettings::elevationRamp for the whole DEM. nullopt without a valid post.
std::optional<std::pair<double, double>> demHeightRange(const TerrainQuadtree& tree);

}  // namespace gis::terrain
