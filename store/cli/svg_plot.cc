#include "store/cli/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace imuqual::cli {
namespace {

std::string Esc(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string F(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

std::string Tick(double decade) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, decade));
  return buf;
}

bool Drawable(double x, double y) { return x > 0 && y > 0 && std::isfinite(x) && std::isfinite(y); }

}  // namespace

std::string PaletteColor(size_t i) {
  static const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                  "#e377c2", "#17becf", "#bcbd22", "#7f7f7f", "#d62728"};
  return kColors[i % (sizeof kColors / sizeof kColors[0])];
}

std::string LogLogPlot::ToSvg() const {
  // Data range in decades, padded to whole decades.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  auto take = [&](double x, double y) {
    if (!Drawable(x, y)) return;
    x0 = std::min(x0, std::log10(x));
    x1 = std::max(x1, std::log10(x));
    y0 = std::min(y0, std::log10(y));
    y1 = std::max(y1, std::log10(y));
  };
  for (const PlotSeries& s : series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      take(s.x[i], s.y[i]);
      if (i < s.lo.size()) take(s.x[i], s.lo[i]);
      if (i < s.hi.size()) take(s.x[i], s.hi[i]);
    }
  }
  for (const PlotMarker& m : markers) take(m.x, m.y);
  if (!std::isfinite(x0)) {
    x0 = 0;
    x1 = 1;
    y0 = 0;
    y1 = 1;
  }
  for (const PlotLine& l : lines) {
    if (l.y > 0 && std::isfinite(l.y)) {
      y0 = std::min(y0, std::log10(l.y));
      y1 = std::max(y1, std::log10(l.y));
    }
  }
  x0 = std::floor(x0);
  x1 = std::max(std::ceil(x1), x0 + 1);
  y0 = std::floor(y0);
  y1 = std::max(std::ceil(y1), y0 + 1);

  const double left = 80, right = 190, top = 40, bottom = 55;
  const double pw = width - left - right, ph = height - top - bottom;
  auto px = [&](double x) { return left + (std::log10(x) - x0) / (x1 - x0) * pw; };
  auto py = [&](double y) { return top + (y1 - std::log10(y)) / (y1 - y0) * ph; };

  std::string svg;
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width) +
         "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " + std::to_string(width) +
         " " + std::to_string(height) + "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" +
         Esc(title) + "</text>\n";
  // Grid: decades solid, 2..9 faint.
  for (double d = x0; d <= x1 + 1e-9; d += 1) {
    for (int k = 1; k < 10 && d + std::log10(k) <= x1 + 1e-9; ++k) {
      const double x = left + (d + std::log10(k) - x0) / (x1 - x0) * pw;
      svg += "<line x1=\"" + F(x) + "\" y1=\"" + F(top) + "\" x2=\"" + F(x) + "\" y2=\"" +
             F(top + ph) + "\" stroke=\"" + (k == 1 ? "#bbbbbb" : "#eeeeee") + "\"/>\n";
    }
    svg += "<text x=\"" + F(left + (d - x0) / (x1 - x0) * pw) + "\" y=\"" + F(top + ph + 18) +
           "\" text-anchor=\"middle\">" + Tick(d) + "</text>\n";
  }
  for (double d = y0; d <= y1 + 1e-9; d += 1) {
    for (int k = 1; k < 10 && d + std::log10(k) <= y1 + 1e-9; ++k) {
      const double y = top + (y1 - d - std::log10(k)) / (y1 - y0) * ph;
      svg += "<line x1=\"" + F(left) + "\" y1=\"" + F(y) + "\" x2=\"" + F(left + pw) + "\" y2=\"" +
             F(y) + "\" stroke=\"" + (k == 1 ? "#bbbbbb" : "#eeeeee") + "\"/>\n";
    }
    svg += "<text x=\"" + F(left - 8) + "\" y=\"" + F(top + (y1 - d) / (y1 - y0) * ph + 4) +
           "\" text-anchor=\"end\">" + Tick(d) + "</text>\n";
  }
  svg += "<rect x=\"" + F(left) + "\" y=\"" + F(top) + "\" width=\"" + F(pw) + "\" height=\"" +
         F(ph) + "\" fill=\"none\" stroke=\"#333333\"/>\n";
  svg += "<text x=\"" + F(left + pw / 2) + "\" y=\"" + F(height - 12.0) +
         "\" text-anchor=\"middle\">" + Esc(x_label) + "</text>\n";
  svg += "<text transform=\"translate(18," + F(top + ph / 2) +
         ") rotate(-90)\" text-anchor=\"middle\">" + Esc(y_label) + "</text>\n";

  // Bands first, then lines and points on top.
  for (const PlotSeries& s : series) {
    if (s.lo.size() != s.x.size() || s.hi.size() != s.x.size()) continue;
    std::string upper, lower;
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!Drawable(s.x[i], s.lo[i]) || !Drawable(s.x[i], s.hi[i])) continue;
      upper += F(px(s.x[i])) + "," + F(py(s.hi[i])) + " ";
      lower = F(px(s.x[i])) + "," + F(py(s.lo[i])) + " " + lower;
    }
    if (!upper.empty()) {
      svg += "<polygon points=\"" + upper + lower + "\" fill=\"" + s.color +
             "\" fill-opacity=\"0.18\" stroke=\"none\"/>\n";
    }
  }
  for (const PlotLine& l : lines) {
    if (!(l.y > 0) || !std::isfinite(l.y)) continue;
    svg += "<line x1=\"" + F(left) + "\" y1=\"" + F(py(l.y)) + "\" x2=\"" + F(left + pw) +
           "\" y2=\"" + F(py(l.y)) + "\" stroke=\"" + l.color +
           "\" stroke-dasharray=\"6,4\" stroke-width=\"1.5\"/>\n";
    svg += "<text x=\"" + F(left + pw - 4) + "\" y=\"" + F(py(l.y) - 4) + "\" text-anchor=\"end\" fill=\"" +
           l.color + "\">" + Esc(l.label) + "</text>\n";
  }
  for (const PlotSeries& s : series) {
    std::string pts;
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (Drawable(s.x[i], s.y[i])) pts += F(px(s.x[i])) + "," + F(py(s.y[i])) + " ";
    }
    if (pts.empty()) continue;
    svg += "<polyline points=\"" + pts + "\" fill=\"none\" stroke=\"" + s.color +
           "\" stroke-width=\"1.8\"" + (s.dashed ? " stroke-dasharray=\"5,3\"" : "") + "/>\n";
    if (s.markers) {
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!Drawable(s.x[i], s.y[i])) continue;
        svg += "<circle cx=\"" + F(px(s.x[i])) + "\" cy=\"" + F(py(s.y[i])) + "\" r=\"2.6\" fill=\"" +
               s.color + "\"/>\n";
      }
    }
  }
  for (const PlotMarker& m : markers) {
    if (!Drawable(m.x, m.y)) continue;
    svg += "<circle cx=\"" + F(px(m.x)) + "\" cy=\"" + F(py(m.y)) + "\" r=\"5\" fill=\"none\" stroke=\"" +
           m.color + "\" stroke-width=\"2\"/>\n";
    svg += "<text x=\"" + F(px(m.x) + 8) + "\" y=\"" + F(py(m.y) + 16) + "\" fill=\"" + m.color +
           "\">" + Esc(m.label) + "</text>\n";
  }
  // Legend.
  double ly = top + 10;
  for (const PlotSeries& s : series) {
    svg += "<line x1=\"" + F(left + pw + 12) + "\" y1=\"" + F(ly) + "\" x2=\"" + F(left + pw + 36) +
           "\" y2=\"" + F(ly) + "\" stroke=\"" + s.color + "\" stroke-width=\"2\"" +
           (s.dashed ? " stroke-dasharray=\"5,3\"" : "") + "/>\n";
    svg += "<text x=\"" + F(left + pw + 42) + "\" y=\"" + F(ly + 4) + "\">" + Esc(s.label) + "</text>\n";
    ly += 18;
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace imuqual::cli
