#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gis::bench {
namespace {

constexpr double kWidth = 720.0, kHeight = 440.0;
constexpr double kLeft = 80.0, kRight = 190.0, kTop = 40.0, kBottom = 60.0;

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

std::string escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else if (c == '&') {
      out += "&amp;";
    } else {
      out += c;
    }
  }
  return out;
}

struct Axis {
  double lo = 0.0, hi = 1.0;
  bool log = false;
  [[nodiscard]] double t(double v) const {
    const double a = log ? std::log10(lo) : lo, b = log ? std::log10(hi) : hi;
    const double x = log ? std::log10(v) : v;
    return b > a ? (x - a) / (b - a) : 0.5;
  }
  /// Tick values: decades on a log axis, about five round steps on a linear one.
  [[nodiscard]] std::vector<double> ticks() const {
    std::vector<double> out;
    if (log) {
      for (double d = std::pow(10.0, std::floor(std::log10(lo))); d <= hi * 1.0001; d *= 10.0) {
        if (d >= lo * 0.9999) out.push_back(d);
      }
      return out;
    }
    const double raw = (hi - lo) / 5.0;
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    const double step = raw / magnitude < 2.0 ? magnitude : raw / magnitude < 5.0 ? 2.0 * magnitude : 5.0 * magnitude;
    for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) out.push_back(v);
    return out;
  }
};

Axis axisOf(const std::vector<double>& values, bool log) {
  Axis a;
  a.log = log;
  a.lo = *std::min_element(values.begin(), values.end());
  a.hi = *std::max_element(values.begin(), values.end());
  if (log) {
    a.lo = std::pow(10.0, std::floor(std::log10(a.lo)));
    a.hi = std::pow(10.0, std::ceil(std::log10(a.hi)));
    if (a.hi <= a.lo) a.hi = a.lo * 10.0;
  } else {
    const double pad = std::max(0.05 * (a.hi - a.lo), 1e-9);
    a.lo = std::max(0.0, a.lo - pad);
    a.hi += pad;
  }
  return a;
}

}  // namespace

std::string scatterSvg(const std::vector<PlotPoint>& points, const PlotAxes& axes) {
  std::vector<double> xs, ys;
  for (const PlotPoint& p : points) {
    xs.push_back(p.x);
    ys.push_back(axes.logY ? std::max(p.y, axes.logYFloor) : p.y);
  }
  if (xs.empty()) {
    xs = {1.0};
    ys = {1.0};
  }
  const Axis x = axisOf(xs, axes.logX), y = axisOf(ys, axes.logY);
  const double plotW = kWidth - kLeft - kRight, plotH = kHeight - kTop - kBottom;
  const auto px = [&](double v) { return kLeft + x.t(v) * plotW; };
  const auto py = [&](double v) { return kTop + (1.0 - y.t(v)) * plotH; };
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + number(kWidth) + "\" height=\"" +
                  number(kHeight) + "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  s += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  s += "<text x=\"" + number(kLeft) + "\" y=\"24\" font-size=\"15\">" + escaped(axes.title) + "</text>\n";
  for (const double t : x.ticks()) {
    s += "<line x1=\"" + number(px(t)) + "\" y1=\"" + number(kTop) + "\" x2=\"" + number(px(t)) + "\" y2=\"" +
         number(kTop + plotH) + "\" stroke=\"#ddd\"/>\n";
    s += "<text x=\"" + number(px(t)) + "\" y=\"" + number(kTop + plotH + 16) + "\" text-anchor=\"middle\">" +
         number(t) + "</text>\n";
  }
  for (const double t : y.ticks()) {
    s += "<line x1=\"" + number(kLeft) + "\" y1=\"" + number(py(t)) + "\" x2=\"" + number(kLeft + plotW) + "\" y2=\"" +
         number(py(t)) + "\" stroke=\"#ddd\"/>\n";
    const std::string text = axes.logY && t <= axes.logYFloor * 1.0001 ? "≤" + number(t) : number(t);
    s += "<text x=\"" + number(kLeft - 6) + "\" y=\"" + number(py(t) + 4) + "\" text-anchor=\"end\">" + text +
         "</text>\n";
  }
  s += "<rect x=\"" + number(kLeft) + "\" y=\"" + number(kTop) + "\" width=\"" + number(plotW) + "\" height=\"" +
       number(plotH) + "\" fill=\"none\" stroke=\"#333\"/>\n";
  s += "<text x=\"" + number(kLeft + plotW / 2) + "\" y=\"" + number(kHeight - 16) + "\" text-anchor=\"middle\">" +
       escaped(axes.xLabel) + "</text>\n";
  s += "<text transform=\"translate(18 " + number(kTop + plotH / 2) + ") rotate(-90)\" text-anchor=\"middle\">" +
       escaped(axes.yLabel) + "</text>\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double cx = px(xs[i]), cy = py(ys[i]);
    s += "<circle cx=\"" + number(cx) + "\" cy=\"" + number(cy) + "\" r=\"5\" fill=\"" + points[i].colour + "\"/>\n";
    s += "<text x=\"" + number(cx + 8) + "\" y=\"" + number(cy + 4) + "\">" + escaped(points[i].label) + "</text>\n";
  }
  s += "</svg>\n";
  return s;
}

}  // namespace gis::bench
