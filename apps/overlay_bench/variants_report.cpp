// The variants' figures for people: the tables printed and as Markdown (docs/benchmarks.md;
// scripts/benchmarks.sh puts them there), and error against frame time as SVG plots.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "svg_plot.hpp"
#include "variants.hpp"

namespace gis::bench {
namespace {

/// `t`'s fragments over `base`'s.
double fragmentsOver(const Tally& t, const Tally& base) {
  return static_cast<double>(t.fragments()) / static_cast<double>(std::max<std::uint64_t>(base.fragments(), 1));
}

double fragmentsPerCoveredPixel(const Tally& t) {
  return t.covered > 0 ? static_cast<double>(t.fragments()) / static_cast<double>(t.covered) : 0.0;
}

double megabytes(std::size_t bytes) { return static_cast<double>(bytes) / 1048576.0; }

/// The whole path, one line per method.
void printTable(const std::vector<Method>& methods) {
  const Method& ours = methods[1];
  std::printf("%-24s %9s %9s %9s %10s %10s %10s %11s %10s %12s %8s %8s\n", "method", "median ms", "p95 ms", "x terrain",
              "GPU terr", "GPU mark", "GPU cover", "frag x ours", "wrong %", "wrong % away", "GPU MB", "build s");
  for (const Method& m : methods) {
    const Tally& t = m.all;
    std::printf("%-24s %9.2f %9.2f %9.3f %10.2f %10.2f %10.2f %11.2f %10.4f %12.4f %8.1f %8.3f\n", m.name.c_str(),
                median(t.ms), percentile(t.ms, 95), m.overlays ? median(t.ratio) : 1.0, median(t.terrainGpuMs),
                median(t.markGpuMs), median(t.coverGpuMs), fragmentsOver(t, ours.all), t.wrongPct(), t.wrongAwayPct(),
                megabytes(m.gpuBytes), m.buildSeconds);
  }
}

/// Per segment: the ratio to terrain only, fragments against ours on the same segment (the
/// grazing views are the horizon segment), error away from edges.
void printSegmentTable(const std::vector<Method>& methods) {
  const Method& ours = methods[1];
  std::printf("\n%-24s %-10s %9s %11s %12s %12s\n", "method", "segment", "x terrain", "frag x ours", "frag/cov px",
              "wrong % away");
  for (const Method& m : methods) {
    if (!m.overlays) continue;
    for (const auto& [name, st] : m.segments) {
      std::printf("%-24s %-10s %9.3f %11.2f %12.2f %12.4f\n", m.name.c_str(), name.c_str(), median(st.ratio),
                  fragmentsOver(st, ours.segments.at(name)), fragmentsPerCoveredPixel(st), st.wrongAwayPct());
    }
  }
}

/// Error against frame time: one point per method (and per drape size); over all terrain
/// pixels, and away from feature edges.
void writePlots(const Options& o, const std::vector<Method>& methods, const std::string& stem) {
  for (const bool away : {false, true}) {
    std::vector<PlotPoint> points;
    for (const Method& m : methods) {
      if (!m.overlays) continue;
      const std::string colour(m.technique->plotColour);
      points.push_back({median(m.all.ratio), away ? m.all.wrongAwayPct() : m.all.wrongPct(), m.name, colour});
    }
    PlotAxes axes;
    axes.title = std::string(away ? "Error away from feature edges" : "Error") + " against frame time (" +
                 std::to_string(o.width) + " × " + std::to_string(o.height) + ")";
    axes.xLabel = "median frame time / terrain only, same frame";
    axes.yLabel = away ? "wrong pixels away from edges, %" : "wrong pixels, % of terrain pixels";
    axes.logY = true;
    std::ofstream(std::filesystem::path(o.out) / (stem + (away ? "_error_away_vs_time.svg" : "_error_vs_time.svg")))
        << scatterSvg(points, axes);
  }
}

/// The two tables as Markdown.
void writeMarkdown(const Options& o, const std::vector<Method>& methods, const std::string& stem) {
  const Method& ours = methods[1];
  std::ofstream md(std::filesystem::path(o.out) / (stem + ".md"));
  md << "| method | median ms | p95 ms | × terrain | GPU ms terrain / mark / cover | fragments × ours | fragments per "
        "covered pixel | wrong % | wrong % away from edges | GPU MB | build s | edit ms |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Method& m : methods) {
    const Tally& t = m.all;
    char row[384];
    std::snprintf(row, sizeof(row),
                  "| %s | %.1f | %.1f | %.3f | %.1f / %.1f / %.1f | %.2f | %.1f | %.4g | %.4g | %.1f | %.2f | %.1f |\n",
                  m.name.c_str(), median(t.ms), percentile(t.ms, 95), m.overlays ? median(t.ratio) : 1.0,
                  median(t.terrainGpuMs), median(t.markGpuMs), median(t.coverGpuMs), fragmentsOver(t, ours.all),
                  fragmentsPerCoveredPixel(t), t.wrongPct(), t.wrongAwayPct(), megabytes(m.gpuBytes), m.buildSeconds,
                  m.editMs);
    md << row;
  }
  md << "\nPer path segment (fragments against ours on the same segment; the horizon segment is the grazing "
        "view):\n\n| method | segment | × terrain | fragments × ours | wrong % away from edges | z-fail pieces |\n"
        "|---|---|---|---|---|---|\n";
  for (const Method& m : methods) {
    if (!m.overlays) continue;
    for (const auto& [name, st] : m.segments) {
      char row[256];
      std::snprintf(row, sizeof(row), "| %s | %s | %.3f | %.2f | %.4g | %zu |\n", m.name.c_str(), name.c_str(),
                    median(st.ratio), fragmentsOver(st, ours.segments.at(name)), st.wrongAwayPct(), st.zFailPieces);
      md << row;
    }
  }
}

}  // namespace

void reportVariants(const Options& o, const std::vector<Method>& methods, const std::string& stem) {
  printTable(methods);
  printSegmentTable(methods);
  writePlots(o, methods, stem);
  writeMarkdown(o, methods, stem);
}

}  // namespace gis::bench
