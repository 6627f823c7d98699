#pragma once
// Where a test finds the project's files and programs. Read when the test runs, from the build
// folder's stencil_gis_test_paths.txt (tests/CMakeLists.txt writes it), not compiled in: a test's
// object is then the same in every checkout and build folder, and the compiler cache shares it
// between clones (CI builds a fresh clone each time; with the paths compiled in, every test source
// that named one was compiled again).
//
// The names are those of the compile definitions they replace, and stand where a `const char*`
// does: std::string(STENCIL_GIS_SAMPLES_DIR) + "/olinda/", fs::path(STENCIL_GIS_TEST_OUTPUT_DIR).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <system_error>

namespace gis::test {

struct TestPaths {
  std::string samples;        ///< the project's samples/
  std::string data;           ///< tests/data/
  std::string outputDir;      ///< beside the test program: <program>_output (for what a test writes)
  std::string overlayRender;  ///< the programs the tests run
  std::string terrainViewer;
  std::string terrainSynth;
};

/// The paths of this test program, found once: the first folder above the program holding
/// stencil_gis_test_paths.txt. A test without them cannot run: it stops, saying why.
inline const TestPaths& testPaths() {
  static const TestPaths paths = [] {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path program = fs::read_symlink("/proc/self/exe", ec);
    std::map<std::string, std::string> entries;
    for (fs::path dir = program.parent_path(); !ec && !dir.empty(); dir = dir.parent_path()) {
      std::ifstream in(dir / "stencil_gis_test_paths.txt");
      for (std::string line; std::getline(in, line);) {
        const std::size_t eq = line.find('=');
        if (eq != std::string::npos) entries[line.substr(0, eq)] = line.substr(eq + 1);
      }
      if (!entries.empty() || dir == dir.root_path()) break;
    }
    if (entries.empty()) {
      std::fprintf(stderr, "%s: no stencil_gis_test_paths.txt in a folder above the program (run it from its build)\n",
                   program.c_str());
      std::abort();
    }
    TestPaths p;
    p.samples = entries["samples"];
    p.data = entries["data"];
    p.outputDir = (program.parent_path() / (program.filename().string() + "_output")).string();
    p.overlayRender = entries["overlay_render"];
    p.terrainViewer = entries["terrain_viewer"];
    p.terrainSynth = entries["terrain_synth"];
    return p;
  }();
  return paths;
}

}  // namespace gis::test

#define STENCIL_GIS_SAMPLES_DIR (::gis::test::testPaths().samples.c_str())
#define STENCIL_GIS_TEST_DATA_DIR (::gis::test::testPaths().data.c_str())
#define STENCIL_GIS_TEST_OUTPUT_DIR (::gis::test::testPaths().outputDir.c_str())
#define OVERLAY_RENDER_EXE (::gis::test::testPaths().overlayRender.c_str())
#define TERRAIN_VIEWER_EXE (::gis::test::testPaths().terrainViewer.c_str())
#define TERRAIN_SYNTH_EXE (::gis::test::testPaths().terrainSynth.c_str())
