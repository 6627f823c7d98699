// Runs the real terrain_viewer window under Xvfb on a small globe scene the test writes itself (a
// global lon/lat DEM and a polygon across the antimeridian) and checks what its scripts wrote:
// - the scene is read onto the globe (the state says so) and home frames the data;
// - the layer's colour is blended exactly over the pixels inside the polygon, and nowhere outside;
// - identify inside names the feature, its attributes and the pixel's lon/lat; outside, none;
// - wheel steps move the eye towards the ground point under the cursor, which stays under it;
// - a left drag grabs the globe (the grabbed point follows the cursor), a right drag orbits,
//   N turns north up, the globe camera step places the camera, and zooming far down stops a
//   metre above the ground with every number finite;
// - fly (F): W moves the eye along the heading, level, and a drag turns the view about the eye;
// - projected-only tools say they are not on the globe yet; GL reports no error (the viewer's
//   scripted run exits 1 on one);
// - the measure tool measures the ground under its pixels along geodesics (scripted and by M and
//   a click) and draws its path; a layer's labels are placed while it is shown;
// - the lasso (L and mouse drags) selects the box: the state lists it, the highlight is blended
//   over the ground inside the lassos and nowhere outside; Shift adds (Or), Ctrl subtracts, and a
//   real Ctrl+Z (xdotool) undoes the subtraction;
// - the script's export writes the selected box as GeoJSON (combined and per layer), as in a
//   projected scene.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include "dem_files.hpp"
#include "gfx/image_io.hpp"
#include "globe/ellipsoid.hpp"
#include "program_output.hpp"
#include "scene/measure.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kWidth = 480;
constexpr int kHeight = 360;
/// The polygon: a box across the antimeridian, 175° E to 175° W, 20° S to 10° S. Its edges are
/// geodesics: within 0.04° of the parallels here, so points 0.2° from the box are classified.
constexpr double kWest = 175.0, kEast = 185.0, kSouth = -20.0, kNorth = -10.0, kMargin = 0.2;
constexpr double kOpacity = 0.5;

/// Longitude unwrapped into [kWest − 180, kWest + 180).
double unwrap(double lon) { return lon - 360.0 * std::floor((lon - (kWest - 180.0)) / 360.0); }

/// +1 inside the polygon by kMargin, −1 outside by kMargin, 0 near its edges.
int classify(double lon, double lat) {
  const double x = unwrap(lon);
  if (x > kWest + kMargin && x < kEast - kMargin && lat > kSouth + kMargin && lat < kNorth - kMargin) return 1;
  if (x < kWest - kMargin || x > kEast + kMargin || lat < kSouth - kMargin || lat > kNorth + kMargin) return -1;
  return 0;
}

/// A column-major 4 × 4 matrix written as 16 numbers.
glm::dmat4 matrix(const json& a) { return matrixOf(a); }

/// The pixel (x right, y down, continuous) an ECEF point projects to.
glm::dvec2 project(const glm::dmat4& viewProj, const glm::dvec3& p) {
  const glm::dvec4 c = viewProj * glm::dvec4(p, 1.0);
  const glm::dvec2 ndc = glm::dvec2(c) / c.w;
  return {(ndc.x + 1.0) * 0.5 * kWidth, (1.0 - ndc.y) * 0.5 * kHeight};
}

/// The ECEF point a pixel's depth shows (reversed-Z), through the inverse view-projection.
glm::dvec3 unproject(const glm::dmat4& inverseViewProj, int x, int y, float depth) {
  const glm::dvec4 ndc(2.0 * (x + 0.5) / kWidth - 1.0, 1.0 - 2.0 * (y + 0.5) / kHeight, static_cast<double>(depth),
                       1.0);
  const glm::dvec4 p = inverseViewProj * ndc;
  return glm::dvec3(p) / p.w;
}

glm::dvec3 ecefOf(const json& identified) {
  return {identified["ecef"][0].get<double>(), identified["ecef"][1].get<double>(),
          identified["ecef"][2].get<double>()};
}

class ViewerGlobeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("globe_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // A global DEM at 1° (pixel-is-area), gentle relief from 200 m to 1,800 m: 180° of longitude
    // or more puts a lon/lat DEM on the globe.
    DemFileOptions o;
    o.width = 360;
    o.height = 180;
    o.geoTransform = {-180.0, 1.0, 0.0, 90.0, 0.0, -1.0};
    o.crs = "EPSG:4326";
    writeDemFile((dir_ / "dem.tif").string(), o, [](int c, int r) {
      return 1000.0 + 600.0 * std::sin(c * 0.21) * std::cos(r * 0.17) + 200.0 * std::sin(r * 0.5);
    });
    std::ofstream(dir_ / "box.geojson") << R"({"type": "FeatureCollection", "features": [
      {"type": "Feature", "properties": {"name": "Fiji box", "code": 7},
       "geometry": {"type": "Polygon", "coordinates": [[[175, -20], [-175, -20], [-175, -10], [175, -10], [175, -20]]]}}
    ]})";
    std::ofstream(dir_ / "scene.json") << R"({"name": "globe test",
      "terrain": {"dem": "dem.tif"},
      "layers": [{"name": "fiji", "kind": "polygon", "source": "box.geojson",
                  "style": {"color": "#ff0000", "opacity": 0.5}}]})";
  }

  /// Runs the viewer on the scene with `script` (written into `dir_` as `name`.json).
  /// `before`: shell commands started first (in the background, with `&`).
  /// The runs hide the panel and go home first (the home view then frames the data in the whole
  /// window: the pixels the tests pick stay on it); `withPanel` keeps the panel as it opens.
  static ::testing::AssertionResult runViewer(const std::string& name, const json& steps,
                                              const std::string& before = "", bool withPanel = false) {
    json all = withPanel ? json::array() : json::array({{{"action", "view"}, {"panel", false}}, {{"action", "home"}}});
    for (const json& step : steps) all.push_back(step);
    const json script = {{"window", {kWidth, kHeight}}, {"steps", all}};
    { std::ofstream(dir_ / (name + ".json")) << script.dump(1); }
    const std::string command = before + std::string(TERRAIN_VIEWER_EXE) + " '" + (dir_ / "scene.json").string() +
                                "' --script " + (dir_ / (name + ".json")).string() + " > " +
                                (dir_ / (name + ".log")).string() + " 2>&1";
    const int status = std::system(command.c_str());
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "the viewer failed:\n" << readText(dir_ / (name + ".log"));
  }

  static json readJson(const std::string& file) { return json::parse(readText(dir_ / file)); }

  static fs::path dir_;
};

fs::path ViewerGlobeTest::dir_;

TEST_F(ViewerGlobeTest, LoadsDrawsNavigatesAndIdentifiesOnTheGlobe) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";

  // The home view as the viewer opens, panel shown: the data framed in the part of the window the
  // panel leaves free (its box's outline inside the free region, its middle in the region's middle,
  // filling a good part of it), as in a projected frame.
  ASSERT_TRUE(
      runViewer("home_panel", json::array({{{"wait", 2}}, {{"action", "save_state"}, {"path", "hp.json"}}}), "", true));
  {
    const json hp = readJson("hp.json");
    const std::vector<double> free = hp["free_region"].get<std::vector<double>>();
    ASSERT_EQ(free.size(), 4U);
    EXPECT_GT(free[0], 50.0) << "the panel is shown";
    // The legend, as in a projected frame: shown, in the free region.
    EXPECT_TRUE(hp["legend"].get<bool>());
    ASSERT_TRUE(hp["windows"].contains("legend")) << hp["windows"].dump();
    EXPECT_GE(hp["windows"]["legend"][0].get<double>(), free[0]);
    const glm::dmat4 viewProj = matrix(hp["globe"]["camera"]["view_proj_ecef"]);
    glm::dvec2 lo(1e9), hi(-1e9);
    for (int i = 0; i <= 8; ++i) {
      for (int j = 0; j <= 8; ++j) {
        if (i != 0 && i != 8 && j != 0 && j != 8) continue;
        const double lon = kWest + i / 8.0 * (kEast - kWest), lat = kSouth + j / 8.0 * (kNorth - kSouth);
        const glm::dvec2 q = project(viewProj, globe::toEcef(lon, lat, 0.0));
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
    }
    std::printf(
        "home with the panel: the data at [%.0f, %.0f] - [%.0f, %.0f], the free region [%.0f, %.0f] - [%.0f, %.0f]\n",
        lo.x, lo.y, hi.x, hi.y, free[0], free[1], free[2], free[3]);
    EXPECT_GE(lo.x, free[0] - 2.0);
    EXPECT_LE(hi.x, free[2] + 2.0);
    EXPECT_GE(lo.y, free[1] - 2.0);
    EXPECT_LE(hi.y, free[3] + 2.0);
    EXPECT_NEAR(0.5 * (lo.x + hi.x), 0.5 * (free[0] + free[2]), 3.0);
    EXPECT_NEAR(0.5 * (lo.y + hi.y), 0.5 * (free[1] + free[3]), 3.0);
    EXPECT_GT(std::max((hi.x - lo.x) / (free[2] - free[0]), (hi.y - lo.y) / (free[3] - free[1])), 0.8);
  }

  // First run: home, the scene with and without overlays.
  ASSERT_TRUE(runViewer("home", json::array({{{"wait", 2}},
                                             {{"action", "save_state"}, {"path", "home_state.json"}},
                                             {{"action", "screenshot"}, {"path", "with.png"}, {"ui", false}},
                                             {{"action", "view"}, {"debug_pieces", true}},
                                             {{"action", "screenshot"}, {"path", "pieces.png"}, {"ui", false}},
                                             {{"action", "view"}, {"debug_pieces", false}},
                                             {{"action", "overlays"}, {"on", false}},
                                             {{"action", "screenshot"}, {"path", "without.png"}, {"ui", false}},
                                             {{"action", "overlays"}, {"on", true}},
                                             {{"action", "screenshot"}, {"path", "window.png"}, {"ui", true}}})));
  const json home = readJson("home_state.json");
  ASSERT_EQ(home["frame"], "globe") << home.dump(1);
  EXPECT_FALSE(home["globe_reason"].get<std::string>().empty());
  ASSERT_EQ(home["layers"].size(), 1U);
  EXPECT_EQ(home["layers"][0]["features"], 1);
  const json& homeGlobe = home["globe"];
  EXPECT_NEAR(unwrap(homeGlobe["target"]["lon"].get<double>()), 180.0, 0.5);
  EXPECT_NEAR(homeGlobe["target"]["lat"].get<double>(), -15.0, 0.5);
  EXPECT_NEAR(homeGlobe["heading"].get<double>(), 0.0, 1e-9);
  EXPECT_GT(homeGlobe["eye_height_above_ground"].get<double>(), 1e5);

  // Home frames the data: the box's corners and edge midpoints are in view, and it spans a good
  // part of the window.
  const glm::dmat4 viewProj = matrix(homeGlobe["camera"]["view_proj_ecef"]);
  glm::dvec2 lo(1e9), hi(-1e9);
  for (const double lon : {kWest, 0.5 * (kWest + kEast), kEast}) {
    for (const double lat : {kSouth, 0.5 * (kSouth + kNorth), kNorth}) {
      const glm::dvec2 p = project(viewProj, globe::toEcef(lon, lat, 1000.0));
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  EXPECT_GE(lo.x, 0.0);
  EXPECT_GE(lo.y, 0.0);
  EXPECT_LE(hi.x, kWidth);
  EXPECT_LE(hi.y, kHeight);
  EXPECT_GT(std::max((hi.x - lo.x) / kWidth, (hi.y - lo.y) / kHeight), 0.5) << "the data is small in the home view";

  // The pixels: inside the polygon the layer's colour over the same pixel without overlays,
  // outside unchanged.
  const gfx::Image8 with = *gfx::readImage8((dir_ / "with.png").string());
  const gfx::Image8 without = *gfx::readImage8((dir_ / "without.png").string());
  {
    // The debug view of pieces, as in a projected frame: the pieces in view tinted (z-pass green
    // from this height) over the frame, nothing else changed.
    const gfx::Image8 pieces = *gfx::readImage8((dir_ / "pieces.png").string());
    ASSERT_EQ(pieces.pixels.size(), with.pixels.size());
    std::size_t tinted = 0, greener = 0;
    for (std::size_t i = 0; i + 2 < with.pixels.size(); i += 3) {
      if (std::equal(with.pixels.begin() + static_cast<std::ptrdiff_t>(i),
                     with.pixels.begin() + static_cast<std::ptrdiff_t>(i + 3),
                     pieces.pixels.begin() + static_cast<std::ptrdiff_t>(i)))
        continue;
      ++tinted;
      greener += pieces.pixels[i + 1] > with.pixels[i + 1] ? 1U : 0U;
    }
    std::printf("debug pieces: %zu pixels tinted, %zu of them greener\n", tinted, greener);
    EXPECT_GT(tinted, 1000U);
    EXPECT_GT(greener, tinted * 9 / 10);
  }
  const gfx::ImageFloat depth = *gfx::readImageFloat((dir_ / "with_depth.tiff").string());
  ASSERT_EQ(with.width, kWidth);
  ASSERT_EQ(with.height, kHeight);
  const json camera = readJson("with_camera.json");
  ASSERT_EQ(camera["frame"], "globe");
  const glm::dmat4 inverse = glm::inverse(matrix(camera["view_proj_ecef"]));
  std::size_t inside = 0, outside = 0, wrongInside = 0, wrongOutside = 0, ground = 0;
  glm::ivec2 inPixel(-1), outPixel(-1);
  double bestIn = 1e9, bestOut = 1e9;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
      if (!(depth.pixels[i] > 0.0F)) continue;
      ++ground;
      const globe::Geodetic g = globe::toGeodetic(unproject(inverse, x, y, depth.pixels[i]));
      const int c = classify(g.lon, g.lat);
      double worst = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double under = without.pixels[3 * i + static_cast<std::size_t>(k)];
        const double layer = k == 0 ? 255.0 : 0.0;
        const double expected = c > 0 ? kOpacity * layer + (1.0 - kOpacity) * under : under;
        worst = std::max(worst, std::abs(with.pixels[3 * i + static_cast<std::size_t>(k)] - expected));
      }
      // Pixels for identify: the one nearest the box's middle, and one well outside it.
      const double fromMiddle = std::hypot(unwrap(g.lon) - 180.0, g.lat + 15.0);
      if (c > 0) {
        ++inside;
        wrongInside += worst > 2.5 ? 1U : 0U;
        if (fromMiddle < bestIn) {
          bestIn = fromMiddle;
          inPixel = {x, y};
        }
      } else if (c < 0) {
        ++outside;
        wrongOutside += worst > 1.0 ? 1U : 0U;
        const double target = std::abs(fromMiddle - 8.0);  // about 8° from the middle
        if (target < bestOut) {
          bestOut = target;
          outPixel = {x, y};
        }
      }
    }
  }
  std::printf("home view: %zu ground pixels, %zu inside the polygon (%zu wrong), %zu outside (%zu wrong)\n", ground,
              inside, wrongInside, outside, wrongOutside);
  EXPECT_GT(inside, 20000U);
  EXPECT_GT(outside, 5000U);
  EXPECT_EQ(wrongInside, 0U);
  EXPECT_EQ(wrongOutside, 0U);
  ASSERT_GE(inPixel.x, 0);
  ASSERT_GE(outPixel.x, 0);

  // Second run: identify, then the mouse and keys through the viewer's own input handling.
  const glm::dvec2 in = glm::dvec2(inPixel) + 0.5, out = glm::dvec2(outPixel) + 0.5;
  const glm::dvec2 zoomAt = glm::dvec2(in.x + 40.0, in.y - 30.0);
  const glm::dvec2 grabFrom(200.5, 200.5), grabTo(260.5, 160.5);
  const auto at = [](const glm::dvec2& p) { return json::array({p.x, p.y}); };
  ASSERT_TRUE(runViewer(
      "navigate",
      json::array(
          {{{"wait", 2}},
           {{"action", "identify"}, {"x", in.x}, {"y", in.y}, {"out", "identify_in.json"}},
           {{"action", "identify"}, {"x", out.x}, {"y", out.y}, {"out", "identify_out.json"}},
           {{"action", "identify"}, {"x", zoomAt.x}, {"y", zoomAt.y}, {"out", "before_zoom.json"}},
           {{"action", "click"}, {"at", at(in)}},
           {{"action", "save_state"}, {"path", "s0.json"}},
           {{"action", "scroll"}, {"at", at(zoomAt)}, {"amount", 2}},
           {{"action", "save_state"}, {"path", "s1.json"}},
           {{"action", "identify"}, {"x", grabFrom.x}, {"y", grabFrom.y}, {"out", "before_grab.json"}},
           {{"action", "drag"}, {"button", "left"}, {"points", {at(grabFrom), at(grabTo)}}, {"frames", 5}},
           {{"action", "save_state"}, {"path", "s2.json"}},
           {{"action", "drag"},
            {"button", "right"},
            {"points", {at(glm::dvec2(240.5, 180.5)), at(glm::dvec2(300.5, 150.5))}}},
           {{"action", "save_state"}, {"path", "s3.json"}},
           {{"action", "key"}, {"key", "n"}},
           {{"action", "save_state"}, {"path", "s4.json"}},
           {{"action", "key"}, {"key", "f"}},
           {{"action", "save_state"}, {"path", "fly0.json"}},
           {{"action", "hold_keys"}, {"keys", {"w"}}, {"frames", 10}},
           {{"action", "save_state"}, {"path", "fly1.json"}},
           {{"action", "drag"},
            {"button", "left"},
            {"points", {at(glm::dvec2(240.5, 180.5)), at(glm::dvec2(290.5, 180.5))}}},
           {{"action", "save_state"}, {"path", "fly2.json"}},
           {{"action", "key"}, {"key", "f"}},
           {{"action", "exaggeration"}, {"value", 2}},
           {{"globe_camera", {{"lon", 179.5}, {"lat", -15.2}, {"distance", 3000}, {"heading", 30}, {"pitch", 60}}}},
           {{"action", "save_state"}, {"path", "s5.json"}},
           {{"action", "scroll"}, {"at", {240.5, 180.5}}, {"amount", 45}},
           {{"action", "scroll"}, {"at", {240.5, 180.5}}, {"amount", 5}},
           {{"action", "save_state"}, {"path", "s6.json"}},
           {{"action", "screenshot"}, {"path", "low.png"}, {"ui", false}},
           {{"action", "exaggeration"}, {"value", 1}},  // the first run's ground: home is its view again
           {{"action", "key"}, {"key", "h"}},
           {{"action", "save_state"}, {"path", "s7.json"}},
           // The identify window closed (Esc) and the HUD hidden, so that they hide none of the
           // measured path.
           {{"action", "key"}, {"key", "escape"}},
           {{"action", "view"}, {"hud", false}},
           {{"action", "screenshot"}, {"path", "window_after.png"}, {"ui", true}},
           // The measure tool: a scripted ring, then M and a click add a point, Esc clears them.
           {{"action", "measure"}, {"points", {at(in), at(out), at(zoomAt)}}, {"closed", true}},
           {{"action", "save_state"}, {"path", "s8.json"}},
           {{"action", "screenshot"}, {"path", "measured.png"}, {"ui", true}},
           {{"action", "key"}, {"key", "m"}},
           {{"action", "click"}, {"at", at(grabFrom)}},
           {{"action", "save_state"}, {"path", "s9.json"}},
           {{"action", "key"}, {"key", "escape"}},
           {{"action", "save_state"}, {"path", "s10.json"}},
           // Labels from an attribute, and none once the layer is hidden. (Esc twice more: the
           // measure tool off, then the identify window closed; no panel: room for the label.)
           {{"action", "key"}, {"key", "escape"}},
           {{"action", "key"}, {"key", "escape"}},
           {{"action", "view"}, {"panel", false}, {"hud", false}},
           {{"action", "set_layer"}, {"layer", "fiji"}, {"label_attribute", "name"}},
           {{"wait", 2}},
           {{"action", "save_state"}, {"path", "s11.json"}},
           {{"action", "screenshot"}, {"path", "labelled.png"}, {"ui", true}},
           {{"action", "toggle_layer"}, {"layer", "fiji"}},
           {{"wait", 2}},
           {{"action", "save_state"}, {"path", "s12.json"}}})));

  // Identify: the feature and its attributes inside, the pixel's lon/lat; nothing outside.
  const json idIn = readJson("identify_in.json");
  ASSERT_EQ(idIn["features"].size(), 1U) << idIn.dump(1);
  EXPECT_EQ(idIn["features"][0]["layer"], "fiji");
  EXPECT_EQ(idIn["features"][0]["attributes"]["name"], "Fiji box");
  EXPECT_EQ(idIn["features"][0]["attributes"]["code"], "7");
  {
    const std::size_t i = static_cast<std::size_t>(inPixel.y) * kWidth + static_cast<std::size_t>(inPixel.x);
    const globe::Geodetic g = globe::toGeodetic(unproject(inverse, inPixel.x, inPixel.y, depth.pixels[i]));
    EXPECT_NEAR(idIn["lon_lat_h"][0].get<double>(), g.lon, 1e-4);
    EXPECT_NEAR(idIn["lon_lat_h"][1].get<double>(), g.lat, 1e-4);
    EXPECT_NEAR(idIn["lon_lat_h"][2].get<double>(), idIn["terrain_height"].get<double>(), 1500.0);
  }
  const json idOut = readJson("identify_out.json");
  ASSERT_TRUE(idOut.is_object()) << "the outside pixel shows no ground";
  EXPECT_TRUE(idOut["features"].empty()) << idOut.dump(1);

  // Zoom to the cursor: the eye comes nearer, towards the point, and the point stays under the cursor.
  const json s0 = readJson("s0.json"), s1 = readJson("s1.json");
  // A click identifies too (the same input handling as a person's).
  ASSERT_TRUE(s0["identified"].is_object()) << s0.dump(1);
  EXPECT_EQ(s0["identified"]["features"].size(), 1U);
  const glm::dvec3 zoomPoint = ecefOf(readJson("before_zoom.json"));
  const auto eyeOf = [](const json& s) {
    const json& e = s["globe"]["camera"]["eye_ecef"];
    return glm::dvec3(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
  };
  const double before = glm::length(eyeOf(s0) - zoomPoint), after = glm::length(eyeOf(s1) - zoomPoint);
  EXPECT_LT(after, 0.8 * before) << before << " → " << after;
  const glm::dvec2 stays = project(matrix(s1["globe"]["camera"]["view_proj_ecef"]), zoomPoint);
  std::printf("zoom: eye %.0f km → %.0f km from the point; it is %.3f px from the cursor\n", before / 1000.0,
              after / 1000.0, glm::length(stays - zoomAt));
  EXPECT_LT(glm::length(stays - zoomAt), 2.0);

  // Grab: the grabbed ground point follows the cursor.
  const json s2 = readJson("s2.json");
  const glm::dvec2 grabbed =
      project(matrix(s2["globe"]["camera"]["view_proj_ecef"]), ecefOf(readJson("before_grab.json")));
  std::printf("grab: the point is %.3f px from the cursor\n", glm::length(grabbed - grabTo));
  EXPECT_LT(glm::length(grabbed - grabTo), 2.0);
  EXPECT_GT(glm::length(grabbed - grabFrom), 30.0);

  // Orbit turns the heading; N turns it back to north.
  const json s3 = readJson("s3.json"), s4 = readJson("s4.json");
  EXPECT_GT(std::abs(s3["globe"]["heading"].get<double>()), 0.1);
  EXPECT_NE(s3["globe"]["pitch"].get<double>(), s2["globe"]["pitch"].get<double>());
  EXPECT_NEAR(s4["globe"]["heading"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(s4["compass_angle"].get<double>(), 0.0, 1e-9);

  // Fly (F): W moves the eye forward along the heading, level, over the ground; a drag turns the
  // view about the eye, which stays.
  {
    const json f0 = readJson("fly0.json"), f1 = readJson("fly1.json"), f2 = readJson("fly2.json");
    EXPECT_EQ(f0["camera_mode"], "fly");
    const glm::dvec3 e0 = eyeOf(f0), e1 = eyeOf(f1), e2 = eyeOf(f2);
    const globe::Geodetic g0 = globe::toGeodetic(e0), g1 = globe::toGeodetic(e1);
    const double heading = f0["globe"]["heading"].get<double>();
    const glm::dmat3 enu = globe::enuBasis(g0.lon, g0.lat);
    const glm::dvec3 along = std::sin(heading) * enu[0] + std::cos(heading) * enu[1];
    std::printf(
        "fly: W moved the eye %.0f m (%.4f along the heading), its height %.0f → %.0f m; a drag moved it %.3f m\n",
        glm::length(e1 - e0), glm::dot(glm::normalize(e1 - e0), along), g0.h, g1.h, glm::length(e2 - e1));
    EXPECT_GT(glm::length(e1 - e0), 1.0);
    EXPECT_GT(glm::dot(glm::normalize(e1 - e0), along), 0.99);
    EXPECT_LT(std::abs(g1.h - g0.h), 0.05 * glm::length(e1 - e0) + 50.0);
    EXPECT_LT(glm::length(e2 - e1), 1e-3 * glm::length(e1 - e0) + 1.0);
    EXPECT_GT(std::abs(std::remainder(f2["globe"]["heading"].get<double>() - f1["globe"]["heading"].get<double>(),
                                      2.0 * std::numbers::pi)),
              0.05);
  }

  // The exaggeration step works on the globe as in a projected scene (no tool says it is missing).
  const json s5 = readJson("s5.json");
  EXPECT_EQ(s5["globe"]["exaggeration"].get<double>(), 2.0);
  EXPECT_EQ(readJson("s4.json")["globe"]["exaggeration"].get<double>(), 1.0);
  for (const json& m : s5["messages"])
    EXPECT_EQ(m.get<std::string>().find("not available on the globe"), std::string::npos) << m;

  // The globe camera step.
  EXPECT_NEAR(unwrap(s5["globe"]["target"]["lon"].get<double>()), 179.5, 1e-6);
  EXPECT_NEAR(s5["globe"]["target"]["lat"].get<double>(), -15.2, 1e-6);
  EXPECT_NEAR(s5["globe"]["distance"].get<double>(), 3000.0, 1e-3);
  EXPECT_NEAR(s5["globe"]["heading_deg"].get<double>(), 30.0, 1e-6);
  EXPECT_NEAR(s5["globe"]["pitch_deg"].get<double>(), 60.0, 1e-6);

  // Down to the metre above the ground: finite, above it.
  const json s6 = readJson("s6.json");
  const double low = s6["globe"]["eye_height_above_ground"].get<double>();
  std::printf("lowest eye: %.4f m above the ground\n", low);
  EXPECT_GE(low, 0.999);
  EXPECT_LT(low, 1.5);
  EXPECT_TRUE(std::isfinite(s6["globe"]["distance"].get<double>()));
  const gfx::ImageFloat lowDepth = *gfx::readImageFloat((dir_ / "low_depth.tiff").string());
  std::size_t lowGround = 0;
  for (const float d : lowDepth.pixels) lowGround += d > 0.0F && std::isfinite(d) ? 1U : 0U;
  EXPECT_GT(lowGround, static_cast<std::size_t>(kWidth * kHeight / 4)) << "no ground 1 m below the eye";

  // Home again: where it started.
  const json s7 = readJson("s7.json");
  EXPECT_NEAR(s7["globe"]["distance"].get<double>(), homeGlobe["distance"].get<double>(),
              1e-6 * homeGlobe["distance"].get<double>());
  EXPECT_NEAR(s7["globe"]["heading"].get<double>(), 0.0, 1e-9);

  // The measure tool on the globe, from the home view the first run's depth shows: its points are
  // the ground under the pixels (unprojected here from that depth), its lengths and area those of
  // scene::measureOnGlobe on them (measure_test checks that against closed forms), to 1e-5.
  const glm::dmat4 homeViewProj = matrix(s7["globe"]["camera"]["view_proj_ecef"]);
  for (int k = 0; k < 16; ++k) {
    const double a = homeViewProj[k / 4][k % 4], b = matrix(camera["view_proj_ecef"])[k / 4][k % 4];
    ASSERT_NEAR(a, b, 1e-9 * std::max(1.0, std::abs(b))) << "home is not the first run's view";
  }
  std::vector<glm::dvec2> measuredLonLat;
  for (const glm::dvec2& p : {in, out, zoomAt}) {
    const int x = static_cast<int>(p.x), y = static_cast<int>(p.y);
    const float d = depth.pixels[static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x)];
    ASSERT_GT(d, 0.0F) << "no ground at " << x << ", " << y;
    const globe::Geodetic g = globe::toGeodetic(unproject(inverse, x, y, d));
    measuredLonLat.emplace_back(g.lon, g.lat);
  }
  const Result<scene::Measurement> expected = scene::measureOnGlobe(measuredLonLat, true, {});
  ASSERT_TRUE(expected.ok());
  const json s8 = readJson("s8.json");
  const json& m = s8["measure"];
  ASSERT_EQ(m["points"], 3) << s8["messages"].dump(1);
  ASSERT_TRUE(m.contains("geodesic_area_m2")) << m.dump(1);
  std::printf("measure: perimeter %.1f m (expected %.1f), area %.4g m² (expected %.4g), surface %.1f m\n",
              m["geodesic_m"].get<double>(), expected->geodesicMetres, m["geodesic_area_m2"].get<double>(),
              *expected->geodesicAreaM2, m["surface_m"].get<double>());
  EXPECT_NEAR(m["geodesic_m"].get<double>(), expected->geodesicMetres, 1e-5 * expected->geodesicMetres);
  EXPECT_NEAR(m["geodesic_area_m2"].get<double>(), *expected->geodesicAreaM2, 1e-5 * *expected->geodesicAreaM2);
  // Over relief of at most 1,000 m per 1° post: longer than the geodesic, and by less than 1 %.
  EXPECT_TRUE(m["surface_complete"].get<bool>());
  EXPECT_GT(m["surface_m"].get<double>(), m["geodesic_m"].get<double>());
  EXPECT_LT(m["surface_m"].get<double>(), 1.01 * m["geodesic_m"].get<double>());
  EXPECT_GE(m["surface_area_m2"].get<double>(), m["geodesic_area_m2"].get<double>());
  // The path is drawn (its yellow), where the same view before had none of it.
  const auto yellow = [](const gfx::Image8& image) {
    std::size_t n = 0;
    for (std::size_t i = 0; i + 2 < image.pixels.size(); i += 3) {
      n += std::abs(image.pixels[i] - 255) <= 3 && std::abs(image.pixels[i + 1] - 235) <= 3 &&
                   std::abs(image.pixels[i + 2] - 60) <= 3
               ? 1U
               : 0U;
    }
    return n;
  };
  const std::size_t yellowBefore = yellow(*gfx::readImage8((dir_ / "window_after.png").string()));
  const std::size_t yellowAfter = yellow(*gfx::readImage8((dir_ / "measured.png").string()));
  std::printf("measure: %zu path pixels drawn (%zu before)\n", yellowAfter, yellowBefore);
  EXPECT_GT(yellowAfter, yellowBefore + 200U);
  // M and a click add a point; Esc clears them.
  const json s9 = readJson("s9.json"), s10 = readJson("s10.json");
  EXPECT_TRUE(s9["measure_tool"].get<bool>());
  EXPECT_EQ(s9["measure"]["points"], 4);
  EXPECT_GT(s9["measure"]["geodesic_m"].get<double>(), m["geodesic_m"].get<double>());
  EXPECT_EQ(s10["measure"]["points"], 0);

  // Labels: the box's name placed once while its layer is shown, none when it is hidden.
  const json s11 = readJson("s11.json"), s12 = readJson("s12.json");
  EXPECT_EQ(s11["layers"][0]["labels"], "name") << s11["messages"].dump(1);
  EXPECT_EQ(s11["labels_placed"], 1) << s11["messages"].dump(1);
  EXPECT_EQ(s12["labels_placed"], 0);
}

/// A screen polygon (pixels, y down).
using ScreenPolygon = std::vector<glm::dvec2>;

/// The distance from p to a polygon's boundary, negative outside it (even-odd).
double signedDistance(const ScreenPolygon& poly, const glm::dvec2& p) {
  bool inside = false;
  double nearest = 1e300;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const glm::dvec2 a = poly[j], b = poly[i];
    if ((b.y > p.y) != (a.y > p.y) && p.x < a.x + (b.x - a.x) * (p.y - a.y) / (b.y - a.y)) inside = !inside;
    const glm::dvec2 ab = b - a;
    const double t = std::clamp(glm::dot(p - a, ab) / std::max(glm::dot(ab, ab), 1e-300), 0.0, 1.0);
    nearest = std::min(nearest, glm::length(p - (a + t * ab)));
  }
  return inside ? nearest : -nearest;
}

/// The highlight's pixels: over the ground well inside the selection (`selected` > 0), the
/// viewer's highlight (straight colour (1, 0.2, 0.1) at 0.45, blended over the pixel before);
/// well outside it (< 0), the pixel as before.
struct HighlightCount {
  std::size_t inside = 0, outside = 0, wrongInside = 0, wrongOutside = 0;
};

template <typename Selected>
HighlightCount countHighlight(const gfx::Image8& shot, const gfx::Image8& before, const gfx::ImageFloat& depth,
                              Selected selected) {
  constexpr double kColour[3] = {255.0, 0.2 * 255.0, 0.1 * 255.0};
  constexpr double kHighlight = 0.45;
  HighlightCount c;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
      const int s = selected(glm::dvec2(x + 0.5, y + 0.5));
      if (s == 0 || (s > 0 && !(depth.pixels[i] > 0.0F))) continue;
      double worst = 0.0;
      for (std::size_t k = 0; k < 3; ++k) {
        const double under = before.pixels[3 * i + k];
        const double expected = s > 0 ? kHighlight * kColour[k] + (1.0 - kHighlight) * under : under;
        worst = std::max(worst, std::abs(shot.pixels[3 * i + k] - expected));
      }
      if (s > 0) {
        ++c.inside;
        c.wrongInside += worst > 2.5 ? 1U : 0U;
      } else {
        ++c.outside;
        c.wrongOutside += worst > 0.0 ? 1U : 0U;
      }
    }
  }
  return c;
}

TEST_F(ViewerGlobeTest, LassoSelectsOnTheGlobe) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";
  ASSERT_EQ(std::system("command -v xdotool > /dev/null"), 0) << "xdotool is needed (scripts/install-deps.sh)";
  // The home view's camera, to place the lassos on the box.
  ASSERT_TRUE(runViewer("lasso_home", json::array({{{"wait", 2}}, {{"action", "save_state"}, {"path", "lh.json"}}})));
  const glm::dmat4 viewProj = matrix(readJson("lh.json")["globe"]["camera"]["view_proj_ecef"]);
  const auto quad = [&](double west, double south, double east, double north) {
    ScreenPolygon q;
    for (const auto& [lon, lat] : {std::pair{west, south}, {east, south}, {east, north}, {west, north}})
      q.push_back(project(viewProj, globe::toEcef(lon, lat, 1000.0)));
    return q;
  };
  // A: the box's middle (part of it); B: ground east of the box; C: all of A and more.
  const ScreenPolygon lassoA = quad(177.5, -17.0, 182.5, -13.0);
  const ScreenPolygon lassoB = quad(185.8, -16.5, 187.2, -12.5);
  const ScreenPolygon lassoC = quad(176.5, -18.0, 183.5, -12.0);
  for (const ScreenPolygon* l : {&lassoA, &lassoB, &lassoC}) {
    for (const glm::dvec2& p : *l) {
      ASSERT_TRUE(p.x > 5.0 && p.x < kWidth - 5.0 && p.y > 5.0 && p.y < kHeight - 5.0)
          << "a lasso corner is out of the home view: " << p.x << ", " << p.y;
    }
  }
  const auto points = [](const ScreenPolygon& l) {
    json out = json::array();
    for (const glm::dvec2& p : l) out.push_back({p.x, p.y});
    return out;
  };
  // A real Ctrl+Z once the viewer has saved c.json and waits in its live step.
  const std::string d = dir_.string();
  const std::string undoer = "( for i in $(seq 1 600); do [ -f '" + d + "/c.json' ] && break; sleep 0.1; done; " +
                             "sleep 0.5; W=$(xdotool search --name terrain_viewer | head -1); " +
                             "xdotool mousemove --window $W 400 300 && sleep 0.3 && xdotool key ctrl+z; sleep 1; " +
                             "touch '" + d + "/undo_go' ) > '" + d + "/xdotool.txt' 2>&1 & ";
  const auto started = std::chrono::steady_clock::now();
  ASSERT_TRUE(
      runViewer("lasso",
                json::array({{{"wait", 2}},
                             {{"action", "screenshot"}, {"path", "before.png"}, {"ui", false}},
                             {{"action", "key"}, {"key", "l"}},
                             {{"action", "drag"}, {"points", points(lassoA)}, {"frames", 3}},
                             {{"action", "screenshot"}, {"path", "a.png"}, {"ui", false}},
                             {{"action", "save_state"}, {"path", "a.json"}},
                             {{"action", "export"}, {"path", "export/a_selected.json"}},
                             {{"action", "save_state"}, {"path", "a_exported.json"}},
                             {{"action", "drag"}, {"points", points(lassoB)}, {"frames", 3}, {"modifiers", {"shift"}}},
                             {{"action", "save_state"}, {"path", "b.json"}},
                             {{"action", "drag"}, {"points", points(lassoC)}, {"frames", 3}, {"modifiers", {"ctrl"}}},
                             {{"action", "screenshot"}, {"path", "c.png"}, {"ui", false}},
                             {{"action", "save_state"}, {"path", "c.json"}},
                             {{"action", "live"}, {"until_file", "undo_go"}, {"max_frames", 3000}},
                             {{"action", "save_state"}, {"path", "d.json"}},
                             {{"action", "screenshot"}, {"path", "d.png"}, {"ui", false}}}),
                undoer));
  std::printf("lasso run: %.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());

  // The state: the box is selected by A (partly inside), kept by A or B, dropped by subtracting
  // C, back after Ctrl+Z.
  const json a = readJson("a.json"), b = readJson("b.json"), c = readJson("c.json"), undone = readJson("d.json");
  EXPECT_EQ(a["lasso_tool"], true);
  EXPECT_EQ(a["selection"]["steps"], json::array({"single"})) << a["selection"].dump(1);
  EXPECT_EQ(a["selection"]["features"], 1) << a["selection"].dump(1);
  ASSERT_EQ(a["selection"]["layers"].size(), 1U) << a["selection"].dump(1);
  EXPECT_EQ(a["selection"]["layers"][0]["name"], "fiji");
  ASSERT_EQ(a["selection"]["layers"][0]["features"].size(), 1U);
  EXPECT_EQ(a["selection"]["layers"][0]["features"][0]["fully_inside"], false);
  EXPECT_GT(a["selection"]["layers"][0]["features"][0]["selected_samples"].get<int>(), 0);
  EXPECT_EQ(b["selection"]["steps"], json::array({"single", "or"}));
  EXPECT_EQ(b["selection"]["features"], 1);
  EXPECT_EQ(c["selection"]["steps"], json::array({"single", "or", "subtract"}));
  EXPECT_EQ(c["selection"]["features"], 0) << c["selection"].dump(1);
  EXPECT_EQ(undone["selection"]["steps"], json::array({"single", "or"})) << readText(dir_ / "xdotool.txt");
  EXPECT_EQ(undone["selection"]["features"], 1);
  EXPECT_EQ(undone["undo_steps"], 2);
  EXPECT_EQ(undone["redo_steps"], 1);
  for (const json& m : undone["messages"])
    EXPECT_EQ(m.get<std::string>().find("lasso"), std::string::npos) << m.get<std::string>();

  // The export step after A: the box as selected (partly inside), in the combined RFC 7946 file
  // with its attributes and in the layer's own file, with its fid, where the source has it.
  const json exportedState = readJson("a_exported.json");
  EXPECT_NE(exportedState["notice"].get<std::string>().find("Exported 1 features"), std::string::npos)
      << exportedState["messages"].dump(1);
  const json combined = readJson("export/a_selected.json");
  EXPECT_EQ(combined["type"], "FeatureCollection");
  ASSERT_EQ(combined["features"].size(), 1U) << combined.dump(1);
  const json& properties = combined["features"][0]["properties"];
  EXPECT_EQ(properties["selection_layer"], "fiji");
  EXPECT_EQ(properties["selection_fid"], a["selection"]["layers"][0]["features"][0]["fid"]);
  EXPECT_EQ(properties["selection_fully_inside"], 0);
  EXPECT_EQ(properties["name"], "Fiji box");
  EXPECT_EQ(properties["code"], 7);
  // Its coordinates: the box's, in lon/lat (across ±180° as GDAL writes RFC 7946).
  std::vector<double> flat;
  const auto collect = [&flat](const json& value, const auto& self) -> void {
    if (value.is_number()) {
      flat.push_back(value.get<double>());
      return;
    }
    for (const json& e : value) self(e, self);
  };
  collect(combined["features"][0]["geometry"]["coordinates"], collect);
  ASSERT_GE(flat.size(), 8U);
  for (std::size_t i = 0; i + 1 < flat.size(); i += 2) {
    EXPECT_NEAR(unwrap(flat[i]), 180.0, 5.0 + 1e-9) << flat[i];
    EXPECT_NEAR(flat[i + 1], -15.0, 5.0 + 1e-9) << flat[i + 1];
  }
  const json own = readJson("export/selected_fiji.geojson");
  ASSERT_EQ(own["features"].size(), 1U) << own.dump(1);
  EXPECT_EQ(own["features"][0]["id"], a["selection"]["layers"][0]["features"][0]["fid"]);
  EXPECT_EQ(own["features"][0]["properties"]["selection_fully_inside"], 0);
  EXPECT_EQ(own["features"][0]["geometry"]["coordinates"][0].size(), 5U) << "the source's ring, not densified";

  // The pixels, 3 px from the lassos' outlines: highlighted over the ground inside the selection,
  // unchanged outside it.
  const gfx::Image8 before = *gfx::readImage8((dir_ / "before.png").string());
  constexpr double kEdge = 3.0;
  const auto in = [](const ScreenPolygon& l, const glm::dvec2& p) {
    const double sd = signedDistance(l, p);
    return sd > kEdge ? 1 : (sd < -kEdge ? -1 : 0);
  };
  const auto combine = [&](const glm::dvec2& p, bool withB, bool minusC) {
    const int ia = in(lassoA, p), ib = withB ? in(lassoB, p) : -1, ic = minusC ? in(lassoC, p) : -1;
    if (ia == 0 || ib == 0 || ic == 0) return 0;
    return (ia > 0 || ib > 0) && ic < 0 ? 1 : -1;
  };
  struct Shot {
    const char* name;
    bool withB, minusC;
  };
  for (const Shot& shot : {Shot{"a", false, false}, Shot{"c", true, true}, Shot{"d", true, false}}) {
    const gfx::Image8 image = *gfx::readImage8((dir_ / (std::string(shot.name) + ".png")).string());
    const gfx::ImageFloat depth = *gfx::readImageFloat((dir_ / (std::string(shot.name) + "_depth.tiff")).string());
    const HighlightCount h =
        countHighlight(image, before, depth, [&](const glm::dvec2& p) { return combine(p, shot.withB, shot.minusC); });
    std::printf("lasso %s: %zu pixels inside (%zu wrong), %zu outside (%zu wrong)\n", shot.name, h.inside,
                h.wrongInside, h.outside, h.wrongOutside);
    EXPECT_GT(h.inside, shot.minusC ? 300U : 2000U) << shot.name;
    EXPECT_GT(h.outside, 50000U) << shot.name;
    EXPECT_EQ(h.wrongInside, 0U) << shot.name;
    EXPECT_EQ(h.wrongOutside, 0U) << shot.name;
  }
}

TEST_F(ViewerGlobeTest, AVectorFileDroppedOnTheGlobeBecomesALayer) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";
  // A GeoJSON file dropped on a scene drawn on the globe joins it as a layer, as in a projected
  // scene (read in longitude and latitude): drawn over the ground it covers, nothing elsewhere.
  std::ofstream(dir_ / "dropped.geojson") << R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"name": "west half"},
     "geometry": {"type": "Polygon", "coordinates": [[[175, -20], [180, -20], [180, -10], [175, -10], [175, -20]]]}}
  ]})";
  ASSERT_TRUE(runViewer("drop", json::array({{{"wait", 2}},
                                             {{"action", "save_state"}, {"path", "before_drop.json"}},
                                             {{"action", "screenshot"}, {"path", "before_drop.png"}, {"ui", false}},
                                             {{"action", "drop"}, {"paths", {(dir_ / "dropped.geojson").string()}}},
                                             {{"wait", 3}},
                                             {{"action", "home"}},
                                             {{"wait", 1}},
                                             {{"action", "save_state"}, {"path", "after_drop.json"}},
                                             {{"action", "screenshot"}, {"path", "after_drop.png"}, {"ui", false}}})));
  const json before = readJson("before_drop.json"), after = readJson("after_drop.json");
  ASSERT_EQ(before["layers"].size(), 1U);
  ASSERT_EQ(after["layers"].size(), 2U) << after["messages"].dump(1);
  EXPECT_EQ(after["frame"], "globe");
  EXPECT_NE(after["layers"][1]["name"].get<std::string>().find("dropped"), std::string::npos) << after["layers"];
  EXPECT_TRUE(after["layers"][1]["shown"].get<bool>());
  for (const json& m : after["messages"])
    EXPECT_EQ(m.get<std::string>().find("not available on the globe"), std::string::npos) << m;
  // The same home view before and after: the new layer changes the pixels over its half of the
  // box (west of 180°) and none over the other half or outside the box.
  const gfx::Image8 a = *gfx::readImage8((dir_ / "before_drop.png").string());
  const gfx::Image8 b = *gfx::readImage8((dir_ / "after_drop.png").string());
  const gfx::ImageFloat depth = *gfx::readImageFloat((dir_ / "after_drop_depth.tiff").string());
  const glm::dmat4 inverse = glm::inverse(matrix(readJson("after_drop_camera.json")["view_proj_ecef"]));
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  std::size_t westChanged = 0, west = 0, elsewhereChanged = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
      if (!(depth.pixels[i] > 0.0F)) continue;
      const globe::Geodetic g = globe::toGeodetic(unproject(inverse, x, y, depth.pixels[i]));
      const double lon = unwrap(g.lon);
      const bool changed = a.pixels[3 * i] != b.pixels[3 * i] || a.pixels[3 * i + 1] != b.pixels[3 * i + 1] ||
                           a.pixels[3 * i + 2] != b.pixels[3 * i + 2];
      const bool inWest =
          lon > kWest + kMargin && lon < 180.0 - kMargin && g.lat > kSouth + kMargin && g.lat < kNorth - kMargin;
      const bool clearOfIt =
          lon > 180.0 + kMargin || lon < kWest - kMargin || g.lat < kSouth - kMargin || g.lat > kNorth + kMargin;
      west += inWest ? 1U : 0U;
      westChanged += inWest && changed ? 1U : 0U;
      elsewhereChanged += clearOfIt && changed ? 1U : 0U;
    }
  }
  std::printf("dropped layer: %zu of %zu pixels over its half changed, %zu elsewhere\n", westChanged, west,
              elsewhereChanged);
  EXPECT_GT(west, 5000U);
  EXPECT_EQ(westChanged, west);
  EXPECT_EQ(elsewhereChanged, 0U);
}

TEST_F(ViewerGlobeTest, StylesCategoriesAndTheAttributeTableAsInAProjectedScene) {
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "run under xvfb-run";
  // The panel's layer tools on the globe, through the projected scene's code (issue 41): a new
  // colour and opacity, colours by category, the attribute table (search, a row selected, zoom to
  // it from elsewhere), and hiding the layer. Each drawn exactly: the layer's new colour over the
  // ground inside the box, nothing changed outside it.
  ASSERT_TRUE(runViewer(
      "styles",
      json::array({{{"wait", 2}},
                   {{"action", "overlays"}, {"on", false}},
                   {{"action", "screenshot"}, {"path", "plain.png"}, {"ui", false}},
                   {{"action", "overlays"}, {"on", true}},
                   {{"action", "set_layer"}, {"layer", "fiji"}, {"color", "#0000ff"}, {"opacity", 0.75}},
                   {{"wait", 2}},
                   {{"action", "save_state"}, {"path", "blue.json"}},
                   {{"action", "screenshot"}, {"path", "blue.png"}, {"ui", false}},
                   // The deferred lookup draws the same (the panel's methods on the globe).
                   {{"action", "method"}, {"value", "deferred"}},
                   {{"wait", 2}},
                   {{"action", "save_state"}, {"path", "blue_deferred.json"}},
                   {{"action", "screenshot"}, {"path", "blue_deferred.png"}, {"ui", false}},
                   // And the drape per tile, its textures in longitude and latitude (inside and
                   // outside the box alike: classify leaves a margin about its border).
                   {{"action", "method"}, {"value", "drape-tiles"}},
                   {{"wait", 2}},
                   {{"action", "save_state"}, {"path", "blue_drape.json"}},
                   {{"action", "screenshot"}, {"path", "blue_drape.png"}, {"ui", false}},
                   {{"action", "method"}, {"value", "stencil-tiles"}},
                   {{"action", "set_layer"}, {"layer", "fiji"}, {"color_attribute", "name"}},
                   {{"wait", 2}},
                   {{"action", "screenshot"}, {"path", "category.png"}, {"ui", false}},
                   {{"action", "save_state"}, {"path", "category.json"}},
                   {{"action", "set_layer"}, {"layer", "fiji"}, {"visible", false}},
                   {{"wait", 2}},
                   {{"action", "screenshot"}, {"path", "hidden.png"}, {"ui", false}},
                   {{"action", "set_layer"}, {"layer", "fiji"}, {"visible", true}},
                   {{"globe_camera", {{"lon", 10.0}, {"lat", 45.0}, {"distance", 2e6}, {"heading", 0}, {"pitch", 90}}}},
                   {{"wait", 2}},
                   {{"action", "table"}, {"layer", "fiji"}, {"search", "fiji"}, {"select", {0}}, {"zoom_to", "rows"}},
                   {{"wait", 2}},
                   {{"action", "save_state"}, {"path", "table.json"}},
                   {{"action", "view"}, {"panel", false}, {"hud", false}},
                   {{"action", "screenshot"}, {"path", "row.png"}, {"ui", true}},
                   {{"action", "table"}, {"layer", "fiji"}, {"select", json::array()}},
                   {{"wait", 1}},
                   {{"action", "screenshot"}, {"path", "no_row.png"}, {"ui", true}},
                   {{"action", "save_state"}, {"path", "no_row.json"}},
                   {{"action", "table"}, {"layer", "fiji"}, {"search", "no such name"}},
                   {{"action", "save_state"}, {"path", "table_empty.json"}}})));
  const gfx::Image8 plain = *gfx::readImage8((dir_ / "plain.png").string());
  const gfx::ImageFloat depth = *gfx::readImageFloat((dir_ / "plain_depth.tiff").string());
  const glm::dmat4 inverse = glm::inverse(matrix(readJson("plain_camera.json")["view_proj_ecef"]));
  // Each shot against the plain frame: inside the box `colour` at `opacity` over it, outside equal.
  const auto check = [&](const std::string& name, const glm::dvec3& colour, double opacity) {
    const gfx::Image8 shot = *gfx::readImage8((dir_ / (name + ".png")).string());
    ASSERT_EQ(shot.pixels.size(), plain.pixels.size());
    std::size_t inside = 0, outside = 0, wrongInside = 0, wrongOutside = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x);
        if (!(depth.pixels[i] > 0.0F)) continue;
        const globe::Geodetic g = globe::toGeodetic(unproject(inverse, x, y, depth.pixels[i]));
        const int c = classify(g.lon, g.lat);
        if (c == 0) continue;
        double worst = 0.0;
        for (int k = 0; k < 3; ++k) {
          const double under = plain.pixels[3 * i + static_cast<std::size_t>(k)];
          const double expected = c > 0 ? opacity * 255.0 * colour[k] + (1.0 - opacity) * under : under;
          worst = std::max(worst, std::abs(shot.pixels[3 * i + static_cast<std::size_t>(k)] - expected));
        }
        (c > 0 ? inside : outside) += 1;
        (c > 0 ? wrongInside : wrongOutside) += worst > (c > 0 ? 2.5 : 1.0) ? 1U : 0U;
      }
    }
    std::printf("%s: %zu pixels inside (%zu wrong), %zu outside (%zu wrong)\n", name.c_str(), inside, wrongInside,
                outside, wrongOutside);
    EXPECT_GT(inside, 20000U) << name;
    EXPECT_GT(outside, 5000U) << name;
    EXPECT_EQ(wrongInside, 0U) << name;
    EXPECT_EQ(wrongOutside, 0U) << name;
  };
  check("blue", {0.0, 0.0, 1.0}, 0.75);
  check("blue_deferred", {0.0, 0.0, 1.0}, 0.75);
  EXPECT_EQ(readJson("blue_deferred.json")["method"], "deferred");
  EXPECT_EQ(readJson("blue_deferred.json")["overlay"]["deferred_layers"], 1);
  check("blue_drape", {0.0, 0.0, 1.0}, 0.75);
  EXPECT_EQ(readJson("blue_drape.json")["method"], "drape-tiles");
  EXPECT_EQ(readJson("blue_drape.json")["overlay"]["draped"], true);
  // Chosen without a size, a technique draws at its own (256² a tile, not the single drape's 2048²).
  EXPECT_EQ(readJson("blue_drape.json")["drape_size"], 256);
  // One value ("Fiji box"): the first colour of the categories' palette.
  const json category = readJson("category.json");
  check("category", {0.12, 0.47, 0.71}, 0.75);
  check("hidden", {0.0, 0.0, 0.0}, 0.0);
  EXPECT_NEAR(readJson("blue.json")["layers"][0]["color"][2].get<double>(), 1.0, 1e-6);
  EXPECT_EQ(category["layers"].size(), 1U);

  // The table: searched, the row selected, and the camera framing it from Europe.
  const json table = readJson("table.json");
  ASSERT_TRUE(table["table"].is_object()) << table.dump(1);
  EXPECT_EQ(table["table"]["layer"], "fiji");
  EXPECT_EQ(table["table"]["rows"], 1);
  EXPECT_EQ(table["table"]["first_rows"], json::array({0}));
  EXPECT_EQ(table["table"]["selected_rows"], 1);
  EXPECT_NEAR(unwrap(table["globe"]["target"]["lon"].get<double>()), 180.0, 1.0);
  EXPECT_NEAR(table["globe"]["target"]["lat"].get<double>(), -15.0, 1.0);
  EXPECT_EQ(readJson("table_empty.json")["table"]["rows"], 0);
  // The selected row's outline is drawn on the globe in the highlight colour (as in a projected
  // scene), and gone once the row is not selected.
  EXPECT_EQ(table["highlighted_features"], 1);
  EXPECT_EQ(readJson("no_row.json")["highlighted_features"], 0);
  const auto highlightPixels = [&](const std::string& file) {
    const gfx::Image8 image = *gfx::readImage8((dir_ / file).string());
    std::size_t n = 0;
    for (std::size_t i = 0; i + 2 < image.pixels.size(); i += static_cast<std::size_t>(image.channels)) {
      n += std::abs(image.pixels[i] - 255) < 12 && std::abs(image.pixels[i + 1] - 51) < 12 &&
                   std::abs(image.pixels[i + 2] - 25) < 12
               ? 1U
               : 0U;
    }
    return n;
  };
  const std::size_t withRow = highlightPixels("row.png"), withoutRow = highlightPixels("no_row.png");
  std::printf("the selected row's outline: %zu highlight-coloured pixels (%zu without it)\n", withRow, withoutRow);
  EXPECT_GT(withRow, withoutRow + 300);
  // None of these tools says it is not on the globe.
  for (const json& m : table["messages"])
    EXPECT_EQ(m.get<std::string>().find("not available on the globe"), std::string::npos) << m;
}

}  // namespace
}  // namespace gis::test
