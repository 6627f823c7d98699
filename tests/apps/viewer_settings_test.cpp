// The viewer's remembered settings: a round trip keeps every value, a first run gets the
// defaults, and a broken file or a bad value is a warning that keeps the rest.
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "app/viewer_settings.hpp"
#include "temp_dir_test.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;

class ViewerSettingsTest : public TempDirTest {
 protected:
  fs::path writeSettings(const std::string& text) const { return write("viewer.json", text); }
};

TEST_F(ViewerSettingsTest, ARoundTripKeepsEveryValue) {
  app::ViewerSettings s;
  s.windowSize = {1024, 700};
  s.lodTolerancePixels = 3.25;
  s.fovYDeg = 60.0;
  s.showHud = false;
  s.showPanel = false;
  s.imagery = false;
  s.exportPath = "/data/out/selection.json";
  const fs::path path = dir_ / "sub" / "dir" / "viewer.json";  // directories are made
  EXPECT_TRUE(app::saveViewerSettings(s, path).empty());
  const Result<app::ViewerSettings> r = app::loadViewerSettings(path);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.diagnostics.empty());
  EXPECT_EQ(r->windowSize, s.windowSize);
  EXPECT_DOUBLE_EQ(r->lodTolerancePixels, 3.25);
  EXPECT_DOUBLE_EQ(r->fovYDeg, 60.0);
  EXPECT_FALSE(r->showHud);
  EXPECT_FALSE(r->showPanel);
  EXPECT_FALSE(r->imagery);
  EXPECT_EQ(r->exportPath, s.exportPath);
}

TEST_F(ViewerSettingsTest, AFirstRunGetsTheDefaultsSilently) {
  const Result<app::ViewerSettings> r = app::loadViewerSettings(dir_ / "missing.json");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.diagnostics.empty());
  EXPECT_EQ(r->windowSize, app::ViewerSettings{}.windowSize);
  EXPECT_TRUE(r->imagery);
}

TEST_F(ViewerSettingsTest, ABrokenFileIsAWarningAndGivesTheDefaults) {
  const fs::path p = writeSettings("{\"window\": [800, 600");
  const Result<app::ViewerSettings> r = app::loadViewerSettings(p);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r.diagnostics.items().size(), 1u);
  EXPECT_EQ(r.diagnostics.items()[0].severity, Severity::Warning);
  EXPECT_EQ(r.diagnostics.items()[0].file, p.string());
  EXPECT_EQ(r->windowSize, app::ViewerSettings{}.windowSize);
}

TEST_F(ViewerSettingsTest, EachBadValueIsAWarningAndTheOthersAreKept) {
  const fs::path p = writeSettings(R"({"window": "big", "lod_tolerance_px": -1, "fov_y_deg": 50, "show_hud": "no",
                               "show_panel": false, "imagery": 1, "export_path": "", "colour": "red"})");
  const Result<app::ViewerSettings> r = app::loadViewerSettings(p);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.diagnostics.items().size(), 5u);  // window, lod, hud, imagery, export path
  for (const char* key : {"window", "lod_tolerance_px", "show_hud", "imagery", "export_path"}) {
    bool named = false;
    for (const Diagnostic& d : r.diagnostics.items()) named = named || d.message.find(key) != std::string::npos;
    EXPECT_TRUE(named) << key;
  }
  const app::ViewerSettings defaults;
  EXPECT_EQ(r->windowSize, defaults.windowSize);
  EXPECT_DOUBLE_EQ(r->lodTolerancePixels, defaults.lodTolerancePixels);
  EXPECT_DOUBLE_EQ(r->fovYDeg, 50.0);
  EXPECT_TRUE(r->showHud);
  EXPECT_FALSE(r->showPanel);
  EXPECT_TRUE(r->imagery);
  EXPECT_EQ(r->exportPath, defaults.exportPath);
}

TEST_F(ViewerSettingsTest, AnOversizedOrTinyWindowIsClampedToAUsableOne) {
  const Result<app::ViewerSettings> r = app::loadViewerSettings(writeSettings(R"({"window": [1e12, 10]})"));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->windowSize, glm::ivec2(16384, 240));
}

TEST_F(ViewerSettingsTest, ThePathFollowsXdgConfigHomeThenHome) {
  const char* xdg = std::getenv("XDG_CONFIG_HOME");
  const char* home = std::getenv("HOME");
  const std::string savedXdg = xdg ? xdg : "", savedHome = home ? home : "";
  setenv("XDG_CONFIG_HOME", "/x/config", 1);
  setenv("HOME", "/home/someone", 1);
  EXPECT_EQ(app::settingsPath(), fs::path("/x/config/stencil-gis/viewer.json"));
  unsetenv("XDG_CONFIG_HOME");
  EXPECT_EQ(app::settingsPath(), fs::path("/home/someone/.config/stencil-gis/viewer.json"));
  unsetenv("HOME");
  EXPECT_FALSE(app::settingsPath().has_value());
  if (xdg) setenv("XDG_CONFIG_HOME", savedXdg.c_str(), 1);
  if (home) setenv("HOME", savedHome.c_str(), 1);
}

}  // namespace
}  // namespace gis::test
