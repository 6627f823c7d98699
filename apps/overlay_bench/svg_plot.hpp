#pragma once
// A small scatter plot as SVG, for the benchmark's figures (docs/benchmarks.md): labelled points,
// linear or logarithmic axes, no dependencies.
#include <string>
#include <vector>

namespace gis::bench {

struct PlotPoint {
  double x = 0.0;
  double y = 0.0;
  std::string label;
  std::string colour = "#1f77b4";
};

struct PlotAxes {
  std::string title, xLabel, yLabel;
  bool logX = false, logY = false;
  /// Points with y ≤ 0 on a log axis are drawn at this floor, and labelled "0".
  double logYFloor = 1e-4;
};

/// The SVG text of a scatter plot of `points`.
std::string scatterSvg(const std::vector<PlotPoint>& points, const PlotAxes& axes);

}  // namespace gis::bench
