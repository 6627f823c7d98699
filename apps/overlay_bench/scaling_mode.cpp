// overlay_bench --mode scaling: terrain only, ours and the paper's construction on each scene of
// --scenes (the oblique segment unless --segments), drawn as the methods mode draws them;
// scaling.md, scaling.json, and frame time against vector vertices and against DEM posts.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "bench_common.hpp"
#include "scene/json_file.hpp"
#include "svg_plot.hpp"
#include "variants.hpp"

namespace gis::bench {

int runScaling(const Options& o) {
  // Each scene in turn: terrain only, ours and the paper's construction on the same frames.
  json rows = json::array();
  for (const std::string& sceneFile : o.scenes) {
    Options so = o;
    so.scene = sceneFile;
    so.out = (std::filesystem::path(o.out) / std::filesystem::path(sceneFile).stem()).string();
    if (so.segments.empty()) so.segments = {"oblique"};
    std::vector<Method> methods;
    // The stencil techniques (those that build polyhedra) at every scale.
    methods.emplace_back("terrain only", overlay::defaultTechnique(), 0, false);
    for (const overlay::TechniqueInfo& t : overlay::techniques()) {
      if (!t.usesTextures()) methods.emplace_back(std::string(t.label), t, 0, true);
    }
    json r;
    if (runVariants(so, std::move(methods), "methods", &r) != 0) return 1;
    rows.push_back(r);
  }
  // The table, and frame time against vector vertices and against DEM posts.
  std::ofstream md(std::filesystem::path(o.out) / "scaling.md");
  md << "| scene | DEM posts | vector vertices | terrain only ms | ours ms | ours × terrain | ours GPU ms mark + cover "
        "| ours GPU MB | ours build s | paper × terrain |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<PlotPoint> byVertices, byPosts;
  const char* colours[] = {"#7f7f7f", "#1f77b4", "#ff7f0e"};
  for (const json& r : rows) {
    const json& m = r["methods"];
    const std::string stem = std::filesystem::path(r["scene"].get<std::string>()).stem().string();
    const double vertices = r["vector_vertices"].get<double>(), posts = r["dem_posts"].get<double>();
    char row[512];
    std::snprintf(row, sizeof(row), "| %s | %.0f | %.0f | %.1f | %.1f | %.3f | %.1f | %.1f | %.2f | %.3f |\n",
                  stem.c_str(), posts, vertices, m[0]["median_ms"].get<double>(), m[1]["median_ms"].get<double>(),
                  m[1]["over_terrain_median"].get<double>(),
                  m[1]["gpu_ms_mark_median"].get<double>() + m[1]["gpu_ms_cover_median"].get<double>(),
                  m[1]["gpu_bytes"].get<double>() / 1048576.0, m[1]["build_s"].get<double>(),
                  m[2]["over_terrain_median"].get<double>());
    md << row;
    for (std::size_t i = 0; i < 3 && i < m.size(); ++i) {
      const std::string label = i == 0                                                     ? ""
                                : m[i]["method"].get<std::string>() == "stencil polyhedra" ? "ours"
                                                                                           : "paper";
      byVertices.push_back({vertices, m[i]["median_ms"].get<double>(), label, colours[i]});
      byPosts.push_back({posts, m[i]["median_ms"].get<double>(), label, colours[i]});
    }
  }
  PlotAxes axes;
  axes.logX = true;
  axes.yLabel = "median frame time, ms (grey: terrain only, blue: ours, orange: paper's)";
  axes.title = "Frame time against vector vertices";
  axes.xLabel = "vector vertices";
  std::ofstream(std::filesystem::path(o.out) / "scaling_time_vs_vertices.svg") << scatterSvg(byVertices, axes);
  axes.title = "Frame time against DEM size";
  axes.xLabel = "DEM posts";
  std::ofstream(std::filesystem::path(o.out) / "scaling_time_vs_dem.svg") << scatterSvg(byPosts, axes);
  std::ofstream(std::filesystem::path(o.out) / "scaling.json") << scene::jsonText(json{{"scenes", rows}}) << '\n';
  std::printf("scaling: %s\n", (std::filesystem::path(o.out) / "scaling.md").string().c_str());
  return 0;
}

}  // namespace gis::bench
