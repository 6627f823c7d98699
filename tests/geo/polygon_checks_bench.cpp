// Benchmark (not run by CTest): the vector reader's validity checks on one feature shaped like a
// real land border (many_holes.hpp) — by default a shell of 10^5 vertices with 10^4 lakes as
// holes, one of them wholly outside the shell and one crossing it — read cold with
// geo::readVectorLayer in the Olinda frame (UTM 25 S). Prints the size, the time to read and the
// reader's messages.
//
//   polygon_checks_bench [--shell N] [--holes H] [--islands P] [--valid] [--repeat K]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "geo/frame.hpp"
#include "geo/vector.hpp"
#include "many_holes.hpp"

int main(int argc, char** argv) {
  gis::test::ManyHolesShape shape;
  shape.shellVertices = 100000;
  shape.holes = 10000;
  shape.outsideHole = shape.crossingHole = true;
  int repeat = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool value = i + 1 < argc;
    if (a == "--shell" && value) {
      shape.shellVertices = std::atoi(argv[++i]);
    } else if (a == "--holes" && value) {
      shape.holes = std::atoi(argv[++i]);
    } else if (a == "--islands" && value) {
      shape.islands = std::atoi(argv[++i]);
    } else if (a == "--repeat" && value) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--valid") {
      shape.outsideHole = shape.crossingHole = false;
    } else {
      std::fprintf(stderr, "usage: %s [--shell N] [--holes H] [--islands P] [--valid] [--repeat K]\n", argv[0]);
      return 2;
    }
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "polygon_checks_bench";
  std::filesystem::create_directories(dir);
  const std::string path =
      (dir / ("shape_" + std::to_string(shape.shellVertices) + "_" + std::to_string(shape.holes) + "_" +
              std::to_string(shape.islands) + (shape.outsideHole ? "_invalid" : "_valid") + ".geojson"))
          .string();
  gis::test::writeManyHoles(path, shape);
  gis::Result<gis::geo::SceneFrame> frame =
      gis::geo::SceneFrame::fromCrs("EPSG:32725", glm::dvec3(300000.0, 9110000.0, 0.0));
  if (!frame) {
    std::fprintf(stderr, "cannot make the frame\n");
    return 1;
  }
  std::printf("one feature: shell of %d vertices, %d holes of %d, %d islands; %ld vertices; %s\n", shape.shellVertices,
              shape.holes, shape.holeVertices, shape.islands, shape.vertexCount(),
              shape.outsideHole ? "a hole outside the shell and one crossing it" : "valid");
  for (int k = 0; k < repeat; ++k) {
    const auto start = std::chrono::steady_clock::now();
    gis::Result<gis::geo::VectorLayer> layer = gis::geo::readVectorLayer(path, *frame);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!layer) {
      std::fprintf(stderr, "read failed: %s\n", layer.diagnostics.items().front().toString().c_str());
      return 1;
    }
    std::printf("read %d: %.3f s, %zu features, %zu vertices\n", k + 1, seconds, layer->features.size(),
                layer->vertexCount());
    if (k == 0) {
      for (const gis::Diagnostic& d : layer.diagnostics.items()) std::printf("  %s\n", d.toString().c_str());
    }
  }
  std::filesystem::remove(path);
  return 0;
}
