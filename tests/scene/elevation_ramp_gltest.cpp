// The elevation colour ramp (issue 25) drawn by the scene renderer, on a synthetic ridge of two
// planes (so the hillshade is a known constant on each side) with a nodata hole, seen from
// above at 3× exaggeration:
// - every pixel away from the ridge, the hole and the image border has the colour of
//   ElevationRamp::colorAt at its true height times hillshadeFactor of its plane's drawn normal,
//   within 2/255 per channel (about 20,000 pixels, both clamped ends and every segment);
// - with the ramp off the frame is bit for bit the frame drawn before the ramp was on (the grey
//   hillshade, also checked against its formula), depth and holes included;
// - imagery, where shown, covers the ramp; with imagery off the ramp is everywhere.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/type_precision.hpp>
#include <glm/mat4x4.hpp>

#include "gfx/render_target.hpp"
#include "gl_test.hpp"
#include "scene/scene_loader.hpp"
#include "scene/scene_renderer.hpp"
#include "terrain/elevation_ramp.hpp"
#include "terrain/height_bounds.hpp"
#include "terrain/terrain_engine.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

constexpr int kSize = 192;
constexpr int kPosts = 257;
constexpr double kSpacing = 20.0;

constexpr double kExaggeration = 3.0;
constexpr std::pair<double, double> kRange{150.0, 800.0};  // the view sees about 50 … 970 m
constexpr glm::u8vec3 kPhotoColour{200, 40, 160};
constexpr int kTolerance = 2;  // per channel, of 255

/// True height of the ridge: two planes meeting along y = 0 (a row of posts at every level).
double ridgeHeight(const glm::dvec2& p) { return 300.0 + 0.12 * p.x + 0.2 * std::abs(p.y); }
/// Normal of the drawn (exaggerated) plane on the side of y.
glm::dvec3 ridgeNormal(double y, double exaggeration) {
  return {-exaggeration * 0.12, -exaggeration * 0.2 * (y < 0.0 ? -1.0 : 1.0), 1.0};
}

scene::LoadedScene ridgeScene(bool photo) {
  auto grid = std::make_shared<terrain::TerrainGrid>();
  grid->width = kPosts;
  grid->height = kPosts;
  const double half = 0.5 * kSpacing * (kPosts - 1);
  grid->origin = glm::dvec2(-half, half);
  grid->step = glm::dvec2(kSpacing, -kSpacing);
  grid->heights.resize(static_cast<std::size_t>(kPosts * kPosts));
  for (int r = 0; r < kPosts; ++r) {
    for (int c = 0; c < kPosts; ++c) {
      const bool hole = r >= 40 && r < 60 && c >= 180 && c < 210;
      grid->heights[static_cast<std::size_t>(r * kPosts + c)] =
          hole ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(ridgeHeight(grid->postPosition(c, r)));
    }
  }
  Result<geo::SceneFrame> frame = geo::SceneFrame::fromCrs("EPSG:32633", glm::dvec3(500000.0, 4000000.0, 0.0));
  EXPECT_TRUE(frame.ok());
  auto quadtree = std::make_shared<const terrain::TerrainQuadtree>(grid);
  auto bounds = std::make_shared<terrain::QuadtreeHeightBounds>(quadtree);
  std::optional<terrain::FrameOrthophoto> orthophoto;
  if (photo) {
    // A solid colour over the western half.
    terrain::FrameOrthophoto o;
    o.image.width = 16;
    o.image.height = 32;
    for (int k = 0; k < o.image.width * o.image.height; ++k) {
      o.image.rgba.insert(o.image.rgba.end(), {kPhotoColour.x, kPhotoColour.y, kPhotoColour.z, 255});
    }
    o.frameTransform.c = {-half, half / o.image.width, 0.0, half, 0.0, -2.0 * half / o.image.height};
    orthophoto = std::move(o);
  }
  scene::SceneDescription description;
  description.path = std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/ridge.json";
  description.dem = std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/ridge.tif";  // a name only: nothing is read
  description.cacheDir = std::string(STENCIL_GIS_TEST_OUTPUT_DIR) + "/cache";
  scene::LoadedScene scene{
      description, std::move(*frame), quadtree, bounds, std::move(orthophoto), {}, 0, 0.0, {}, {}, 0};
  return scene;
}

scene::Camera topDown() {
  scene::Camera camera;
  camera.eye = glm::dvec3(0.0, 0.0, 9000.0);
  camera.target = glm::dvec3(0.0, 0.0, 0.0);
  camera.up = glm::dvec3(0.0, 1.0, 0.0);
  camera.fovYDeg = 30.0;
  return camera;
}

/// A frame read back: colour (RGBA, top row first) and the frame point under each pixel centre.
struct Frame {
  std::vector<std::uint8_t> rgba;
  std::vector<float> depth;
  std::vector<glm::dvec3> points;  ///< frame coordinates, drawn heights; NaN on background
  [[nodiscard]] glm::ivec3 colour(int col, int row) const {
    const std::size_t k = 4 * static_cast<std::size_t>(row * kSize + col);
    return {rgba[k], rgba[k + 1], rgba[k + 2]};
  }
  [[nodiscard]] const glm::dvec3& point(int col, int row) const {
    return points[static_cast<std::size_t>(row * kSize + col)];
  }
};

/// Pixels whose 3 × 3 neighbourhood is terrain on one side of the ridge (and of the imagery's
/// edge at x = 0): there every fragment, and its screen-space derivatives, lie on one plane.
template <typename F>
void forEachInteriorPixel(const Frame& frame, F&& f) {
  for (int row = 1; row + 1 < kSize; ++row) {
    for (int col = 1; col + 1 < kSize; ++col) {
      const glm::dvec3& p = frame.point(col, row);
      bool interior = !std::isnan(p.x);
      for (int dr = -1; dr <= 1 && interior; ++dr) {
        for (int dc = -1; dc <= 1 && interior; ++dc) {
          const glm::dvec3& q = frame.point(col + dc, row + dr);
          interior = !std::isnan(q.x) && (q.y < 0.0) == (p.y < 0.0) && (q.x < 0.0) == (p.x < 0.0);
        }
      }
      if (interior) f(col, row, p);
    }
  }
}

/// The ramp's colour at the true height under the pixel, shaded as the shader shades its plane.
glm::dvec3 expectedRampColour(const glm::dvec3& p) {
  const double t = terrain::ElevationRamp::normalised(ridgeHeight(glm::dvec2(p)), kRange.first, kRange.second);
  return glm::dvec3(terrain::ElevationRamp::hypsometric().colorAt(t)) *
         terrain::hillshadeFactor(ridgeNormal(p.y, kExaggeration));
}

int deviation(const glm::ivec3& pixel, const glm::dvec3& expected) {
  int worst = 0;
  for (int c = 0; c < 3; ++c) {
    worst = std::max(worst, static_cast<int>(std::abs(pixel[c] - std::lround(255.0 * expected[c]))));
  }
  return worst;
}

class ElevationRampGlTest : public GlTest {
 protected:
  Frame render(scene::SceneRenderer& renderer, const scene::RenderSettings& settings) {
    scene::RenderSettings s = settings;
    s.waitForTiles = true;
    const scene::Camera camera = topDown();
    renderer.render(cache_, target_.framebuffer(), kSize, kSize, camera, s);
    Frame frame;
    frame.rgba = gfx::readColorRgba8(target_);
    frame.depth = gfx::readDepth(target_);
    const glm::dmat4 inverse = glm::inverse(camera.projection(1.0) * camera.view());
    frame.points.resize(frame.depth.size(), glm::dvec3(std::numeric_limits<double>::quiet_NaN()));
    for (int row = 0; row < kSize; ++row) {
      for (int col = 0; col < kSize; ++col) {
        const std::size_t k = static_cast<std::size_t>(row * kSize + col);
        if (frame.depth[k] == gfx::kReversedZFar) continue;
        // Reversed-Z with GL_ZERO_TO_ONE: normalised device depth = stored depth.
        const glm::dvec4 ndc(2.0 * (col + 0.5) / kSize - 1.0, 1.0 - 2.0 * (row + 0.5) / kSize, frame.depth[k], 1.0);
        const glm::dvec4 p = inverse * ndc;
        frame.points[k] = glm::dvec3(p) / p.w;
      }
    }
    return frame;
  }
  gfx::RenderTarget target_{kSize, kSize, 0, true};
};

TEST_F(ElevationRampGlTest, RampColoursFollowTrueHeightsShadedByHillshade) {
  scene::LoadedScene scene = ridgeScene(false);
  scene.bounds->setExaggeration(kExaggeration);
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(scene);
  ASSERT_TRUE(renderer.ok());
  scene::RenderSettings settings;
  settings.elevationRamp = kRange;
  const Frame frame = render(*renderer, settings);
  const std::span<const terrain::RampStop> stops = terrain::ElevationRamp::hypsometric().stops();
  std::vector<int> perSegment(stops.size() + 1, 0);  // below 0, each segment, above 1
  int checked = 0, wrong = 0, worst = 0;
  forEachInteriorPixel(frame, [&](int col, int row, const glm::dvec3& p) {
    // The drawn surface is the exaggerated ridge (the unprojected height says so).
    EXPECT_NEAR(p.z, kExaggeration * ridgeHeight(glm::dvec2(p)), 0.5) << col << ", " << row;
    const int d = deviation(frame.colour(col, row), expectedRampColour(p));
    worst = std::max(worst, d);
    ++checked;
    if (d > kTolerance) {
      if (++wrong <= 5) ADD_FAILURE() << "pixel " << col << ", " << row << " is off by " << d << "/255";
    }
    const double t = (ridgeHeight(glm::dvec2(p)) - kRange.first) / (kRange.second - kRange.first);
    std::size_t bucket = 0;  // the number of stops at or below t; above the last: past it
    while (bucket < stops.size() && t >= stops[bucket].t) ++bucket;
    ++perSegment[t > 1.0 ? stops.size() : bucket];
  });
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(checked, 20000);
  for (std::size_t k = 0; k < perSegment.size(); ++k) EXPECT_GT(perSegment[k], 100) << "segment " << k;
  std::printf("%d pixels checked, worst %d/255\n", checked, worst);
}

TEST_F(ElevationRampGlTest, RampOffDrawsTheGreyHillshadeBitForBit) {
  scene::LoadedScene scene = ridgeScene(false);
  scene.bounds->setExaggeration(kExaggeration);
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(scene);
  ASSERT_TRUE(renderer.ok());
  scene::RenderSettings off;
  scene::RenderSettings on;
  on.elevationRamp = kRange;
  const Frame before = render(*renderer, off);
  const Frame ramp = render(*renderer, on);
  const Frame after = render(*renderer, off);
  EXPECT_EQ(before.rgba, after.rgba);
  EXPECT_EQ(before.depth, after.depth);
  EXPECT_EQ(before.depth, ramp.depth);
  EXPECT_NE(before.rgba, ramp.rgba);
  // The hole: background in both, nothing drawn into it.
  const auto background = [](const Frame& f) { return std::count(f.depth.begin(), f.depth.end(), gfx::kReversedZFar); };
  EXPECT_GT(background(ramp), 100);
  const glm::ivec3 clear(glm::round(255.0F * glm::vec3(scene::kBackground)));
  for (int row = 0; row < kSize; ++row) {
    for (int col = 0; col < kSize; ++col) {
      if (ramp.depth[static_cast<std::size_t>(row * kSize + col)] != gfx::kReversedZFar) continue;
      EXPECT_EQ(ramp.colour(col, row), clear) << col << ", " << row;
    }
  }
  // And the grey is today's formula.
  int checked = 0, wrong = 0;
  forEachInteriorPixel(before, [&](int col, int row, const glm::dvec3& p) {
    const glm::dvec3 grey = glm::dvec3(0.55, 0.57, 0.52) * terrain::hillshadeFactor(ridgeNormal(p.y, kExaggeration));
    ++checked;
    wrong += deviation(before.colour(col, row), grey) > kTolerance ? 1 : 0;
  });
  EXPECT_GT(checked, 20000);
  EXPECT_EQ(wrong, 0);
}

TEST_F(ElevationRampGlTest, ImageryCoversTheRampWhereShown) {
  scene::LoadedScene scene = ridgeScene(true);
  scene.bounds->setExaggeration(kExaggeration);
  Result<scene::SceneRenderer> renderer = scene::SceneRenderer::create(scene);
  ASSERT_TRUE(renderer.ok());
  for (const bool imagery : {true, false}) {
    scene::RenderSettings settings;
    settings.imagery = imagery;
    settings.elevationRamp = kRange;
    const Frame frame = render(*renderer, settings);
    int photo = 0, tinted = 0, wrong = 0;
    forEachInteriorPixel(frame, [&](int col, int row, const glm::dvec3& p) {
      const bool onPhoto = imagery && p.x < 0.0;
      const int d = onPhoto ? deviation(frame.colour(col, row), glm::dvec3(kPhotoColour) / 255.0)
                            : deviation(frame.colour(col, row), expectedRampColour(p));
      (onPhoto ? photo : tinted) += 1;
      wrong += d > kTolerance ? 1 : 0;
    });
    EXPECT_EQ(wrong, 0) << "imagery " << imagery;
    EXPECT_GT(tinted, 8000) << "imagery " << imagery;
    EXPECT_GT(photo, imagery ? 8000 : -1);
  }
}

}  // namespace
}  // namespace gis::test
