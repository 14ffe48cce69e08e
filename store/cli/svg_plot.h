// Log-log plots as self-contained SVG (no scripts, no external fonts or
// files): Allan deviation curves with confidence bands, model lines, limit
// lines and marked points. Pure: returns the SVG text.
#ifndef IMUQUAL_STORE_CLI_SVG_PLOT_H_
#define IMUQUAL_STORE_CLI_SVG_PLOT_H_

#include <string>
#include <vector>

namespace imuqual::cli {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;    // points (x, y > 0 are drawn; others skipped)
  std::vector<double> lo, hi;  // optional band around y (same length), e.g. 1-sigma
  std::string color = "#1f77b4";
  bool markers = true;
  bool dashed = false;
};

struct PlotLine {  // a horizontal reference line, e.g. a limit
  std::string label;
  double y = 0;
  std::string color = "#d62728";
};

struct PlotMarker {  // a single labelled point, e.g. the curve minimum
  std::string label;
  double x = 0, y = 0;
  std::string color = "#000000";
};

struct LogLogPlot {
  std::string title;
  std::string x_label = "tau [s]";
  std::string y_label;
  std::vector<PlotSeries> series;
  std::vector<PlotLine> lines;
  std::vector<PlotMarker> markers;
  int width = 760;
  int height = 520;
  std::string ToSvg() const;
};

// A categorical palette colour for series i.
std::string PaletteColor(size_t i);

}  // namespace imuqual::cli

#endif  // IMUQUAL_STORE_CLI_SVG_PLOT_H_
