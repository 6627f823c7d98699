// terrain_viewer: the desktop viewer (GLFW + Dear ImGui; docs/viewer.md). `?` in the window
// lists the keys. With no display it says so and points at overlay_render (docs/design.md §8).
#include <cstdio>
#include <string>
#include <string_view>

#include "app/cli.hpp"
#include "app/option_parser.hpp"
#include "gfx/context.hpp"
#include "gfx/window_context.hpp"
#include "viewer.hpp"

namespace {

constexpr const char* kUsage =
    "usage: terrain_viewer [SCENE.json | DEM | VECTOR] [--script SCRIPT.json]\n"
    "Opens the scene in a window (default samples/olinda/scene.json). In the window: left drag\n"
    "orbits, right drag pans, the wheel zooms to the cursor, click identifies, F flies (WASD QE),\n"
    "L draws lassos, O toggles the vector layers, ? lists every key.\n"
    "--script: run a viewer script (camera keyframes, actions, screenshots; docs/viewer.md) and exit:\n"
    "  status 0 when every step ran, 1 otherwise.\n"
    "Exit status 3: no display (render headless with overlay_render instead).\n";

}  // namespace

static int viewerMain(int argc, char** argv) {
  gis::viewer::ViewerOptions options;
  options.scene = "samples/olinda/scene.json";
  bool help = false;
  gis::app::OptionParser parser;
  parser.help(help);
  parser.custom(
      "--script",
      [&](std::string_view file) {
        options.script = std::string(file);
        return true;
      },
      "a file");
  parser.positional(options.scene);
  const std::string error = parser.parse(argc, argv);
  if (help) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!error.empty()) {
    std::fprintf(stderr, "terrain_viewer: %s\n%s", error.c_str(), kUsage);
    return 2;
  }
  if (!gis::gfx::windowSystemAvailable()) {
    std::fprintf(stderr,
                 "terrain_viewer: no display to open a window on (DISPLAY is not set or not reachable).\n"
                 "Render the scene headless instead:\n"
                 "  overlay_render --scene %s --out out/\n",
                 options.scene.c_str());
    return 3;
  }
  return gis::viewer::Viewer::run(options);
}

int main(int argc, char** argv) {
  gis::keepFreedHeapForFrames();
  return gis::app::guardedMain("terrain_viewer", [&] { return viewerMain(argc, argv); });
}
