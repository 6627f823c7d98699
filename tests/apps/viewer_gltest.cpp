// Runs the real terrain_viewer window under Xvfb with a script (camera keyframe, overlays off and
// on, a lasso, export, identify, screenshots) and checks what it wrote against the CPU reference
// computed from the viewer's own depth and camera:
// - the terrain is visible (not background) without overlays;
// - with overlays, a pixel covered by the tracts' fill alone (away from feature edges) is the
//   fill's colour blended over the same pixel without overlays; an uncovered pixel is unchanged;
// - the panel and HUD are drawn over the scene (the window screenshot differs from the scene one
//   where they are, and nowhere else is touched in a corner they leave free);
// - the lasso highlight changes exactly the pixels the CPU twin selects (away from its edges);
// - the export holds features, identify names the point and the features under it.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "app/scene_loader.hpp"
#include "app/scene_renderer.hpp"
#include "gfx/image_io.hpp"
#include "gl_test.hpp"
#include "vector_overlay/cpu_reference.hpp"
#include "vector_overlay/lasso.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kWidth = 480;
constexpr int kHeight = 360;

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

glm::dmat4 matrix(const json& a) {
  glm::dmat4 m(0.0);
  for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = a.at(static_cast<std::size_t>(i)).get<double>();
  return m;
}

glm::dvec3 rgbAt(const gfx::Image8& image, std::size_t i) {
  return glm::dvec3(image.pixels[3 * i], image.pixels[3 * i + 1], image.pixels[3 * i + 2]);
}

double maxDifference(const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 d = glm::abs(a - b);
  return std::max({d.x, d.y, d.z});
}

class ViewerScriptTest : public GlTest {};

TEST_F(ViewerScriptTest, ScreenshotsShowTerrainOverlaysPanelAndSelection) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("viewer_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::vector<std::vector<double>> lasso{{150, 110}, {330, 100}, {350, 250}, {250, 200}, {160, 270}};
  const json script = {
      {"window", {kWidth, kHeight}},
      {"steps",
       json::array({{{"camera", {{"eye_xyz", {1500, -9000, 6000}}, {"target_xyz", {0, 0, 0}}, {"fov_y_deg", 45}}},
                     {"seconds", 0.3}},
                    {{"wait", 1}},
                    {{"action", "screenshot"}, {"path", "with.png"}, {"ui", false}},
                    {{"action", "overlays"}, {"on", false}},
                    {{"action", "screenshot"}, {"path", "without.png"}, {"ui", false}},
                    {{"action", "overlays"}, {"on", true}},
                    {{"action", "screenshot"}, {"path", "window.png"}, {"ui", true}},
                    {{"action", "lasso"}, {"op", "single"}, {"points", lasso}},
                    {{"action", "screenshot"}, {"path", "lasso.png"}, {"ui", false}},
                    {{"action", "export"}, {"path", "selected.json"}},
                    {{"action", "identify"}, {"x", 240}, {"y", 180}, {"out", "identify.json"}},
                    {{"action", "quit"}}})}};
  { std::ofstream(dir / "script.json") << script.dump(1); }
  const std::string command = std::string(TERRAIN_VIEWER_EXE) + " " + STENCIL_GIS_SAMPLES_DIR +
                              "/olinda/scene.json --script " + (dir / "script.json").string() + " > " +
                              (dir / "log.txt").string() + " 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << readText(dir / "log.txt");

  const gfx::Image8 with = *gfx::readImage8((dir / "with.png").string());
  const gfx::Image8 without = *gfx::readImage8((dir / "without.png").string());
  const gfx::Image8 window = *gfx::readImage8((dir / "window.png").string());
  const gfx::Image8 selected = *gfx::readImage8((dir / "lasso.png").string());
  ASSERT_EQ(with.width, kWidth);
  ASSERT_EQ(with.height, kHeight);
  ASSERT_EQ(window.width, kWidth);
  const gfx::ImageFloat depth = *gfx::readImageFloat((dir / "with_depth.tiff").string());
  const json camera = json::parse(readText(dir / "with_camera.json"));
  const glm::dmat4 viewProj = matrix(camera["proj"]) * matrix(camera["view"]);
  const std::size_t pixels = static_cast<std::size_t>(kWidth) * kHeight;

  // Terrain visible without overlays.
  const glm::dvec3 background(std::lround(app::kBackground.x * 255.0F), std::lround(app::kBackground.y * 255.0F),
                              std::lround(app::kBackground.z * 255.0F));
  std::size_t terrain = 0;
  for (std::size_t i = 0; i < pixels; ++i) terrain += depth.pixels[i] > 0.0F ? 1u : 0u;
  std::size_t notBackground = 0;
  for (std::size_t i = 0; i < pixels; ++i)
    notBackground += maxDifference(rgbAt(without, i), background) > 3.0 ? 1u : 0u;
  EXPECT_GT(terrain, pixels / 3) << "the camera keyframe shows little terrain";
  EXPECT_GE(notBackground + pixels / 100, terrain);

  // The CPU reference of the scene's overlay layers on the viewer's depth.
  Result<app::SceneDescription> description =
      app::loadSceneFile(std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/scene.json");
  ASSERT_TRUE(description.ok());
  Result<app::LoadedScene> scene = app::loadScene(*description);
  ASSERT_TRUE(scene.ok());
  Result<app::SceneRenderer> renderer = app::SceneRenderer::create(*scene);
  ASSERT_TRUE(renderer.ok());
  std::vector<overlay::ReferenceLayer> ref;
  for (const overlay::OverlayLayer& l : renderer->overlayLayers()) ref.push_back(overlay::referenceLayerOf(l));
  ASSERT_EQ(renderer->overlaySources()[0], std::make_pair(std::size_t{0}, false));  // the tracts' fill
  const overlay::DepthImage image{kWidth, kHeight, depth.pixels, viewProj};
  const std::vector<std::uint32_t> mask = overlay::referenceMask(image, ref);
  const std::vector<std::uint8_t> edges = overlay::edgePixels(image, ref);
  const overlay::LayerStyle& fill = description->layers[0].style;
  const glm::dvec3 fillColour = glm::round(glm::dvec3(fill.color) * 255.0) / 255.0;  // the vertices hold 8-bit colour
  const double alpha = std::round(static_cast<double>(fill.opacity * fill.color.w) * 255.0) / 255.0;
  std::size_t fillPixels = 0, fillWrong = 0, clearPixels = 0, clearWrong = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    if (edges[i] != 0 || depth.pixels[i] <= 0.0F) continue;
    if (mask[i] == 1u) {
      ++fillPixels;
      const glm::dvec3 expected = 255.0 * (fillColour * alpha) + rgbAt(without, i) * (1.0 - alpha);
      fillWrong += maxDifference(rgbAt(with, i), expected) > 2.5 ? 1u : 0u;
    } else if (mask[i] == 0u) {
      ++clearPixels;
      clearWrong += maxDifference(rgbAt(with, i), rgbAt(without, i)) > 0.0 ? 1u : 0u;
    }
  }
  std::printf("viewer: %zu terrain pixels; %zu fill-only pixels (%zu wrong), %zu uncovered (%zu changed)\n", terrain,
              fillPixels, fillWrong, clearPixels, clearWrong);
  EXPECT_GT(fillPixels, 5000u);
  EXPECT_GT(clearPixels, 5000u);
  EXPECT_EQ(fillWrong, 0u);
  EXPECT_EQ(clearWrong, 0u);

  // Panel and HUD: drawn over the scene; the bottom-right corner they leave free is the scene.
  std::size_t uiPixels = 0, cornerChanged = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
      const bool changed = maxDifference(rgbAt(window, i), rgbAt(with, i)) > 0.0;
      uiPixels += changed ? 1u : 0u;
      if (x >= kWidth - 60 && y >= kHeight - 40) cornerChanged += changed ? 1u : 0u;
    }
  }
  EXPECT_GT(uiPixels, 5000u) << "no panel in the window screenshot";
  EXPECT_EQ(cornerChanged, 0u);

  // The lasso's highlight: where the twin selects, the pixel changed; elsewhere it did not.
  overlay::SelectionStep step;
  step.op = overlay::SelectionOp::Single;
  for (const auto& p : lasso) step.lasso.points.emplace_back(p[0], p[1]);
  step.lasso.viewProj = viewProj;
  step.lasso.width = kWidth;
  step.lasso.height = kHeight;
  const std::vector<overlay::SelectionStep> steps{step};
  const std::vector<std::uint8_t> twin = overlay::selectionMask(image, steps);
  std::size_t inside = 0, insideWrong = 0, outsideWrong = 0;
  for (int y = 1; y + 1 < kHeight; ++y) {
    for (int x = 1; x + 1 < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
      bool edge = false;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) edge = edge || twin[i + static_cast<std::size_t>(dy * kWidth + dx)] != twin[i];
      }
      if (edge) continue;
      const bool changed = maxDifference(rgbAt(selected, i), rgbAt(with, i)) > 0.0;
      if (twin[i] != 0) {
        ++inside;
        insideWrong += changed ? 0u : 1u;
      } else {
        outsideWrong += changed ? 1u : 0u;
      }
    }
  }
  EXPECT_GT(inside, 5000u);
  EXPECT_EQ(insideWrong, 0u);
  EXPECT_EQ(outsideWrong, 0u);

  const json exported = json::parse(readText(dir / "selected.json"));
  EXPECT_EQ(exported["type"], "FeatureCollection");
  EXPECT_GT(exported["features"].size(), 3u);
  const json identified = json::parse(readText(dir / "identify.json"));
  ASSERT_TRUE(identified.is_object()) << "identify found no terrain at the centre";
  EXPECT_EQ(identified["lon_lat_h"].size(), 3u);
  EXPECT_NEAR(identified["lon_lat_h"][0].get<double>(), -34.86, 0.1);  // Olinda
  EXPECT_NEAR(identified["lon_lat_h"][1].get<double>(), -8.0, 0.1);
  const std::size_t centre = static_cast<std::size_t>(180 * kWidth + 240);
  EXPECT_EQ(identified["features"].size(),
            static_cast<std::size_t>(std::popcount(mask[centre] & 1u) + std::popcount(mask[centre] & 4u)))
      << "identify lists the fills and lines under the point";
}

}  // namespace
}  // namespace gis::test
