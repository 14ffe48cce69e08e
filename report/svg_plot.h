// Log-log plots as self-contained SVG (no scripts, no external fonts or
// files, no element ids, so several plots can be inlined in one HTML page):
// Allan deviation curves with confidence bands, model lines, limit lines and
// marked points. Pure: returns the SVG text; every text is XML-escaped.
#ifndef IMUQUAL_REPORT_SVG_PLOT_H_
#define IMUQUAL_REPORT_SVG_PLOT_H_

#include <string>
#include <vector>

namespace imuqual::report {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;    // points (x, y > 0 are drawn; others skipped)
  std::vector<double> lo, hi;  // optional band around y (same length), e.g. 1-sigma
  std::string color = "#1f77b4";
  bool markers = true;
  bool dashed = false;
  bool in_legend = true;      // false: drawn, but not listed in the legend
  double stroke_width = 1.8;  // px
  double opacity = 1.0;       // of the line and markers, in (0, 1]
  std::string tooltip;        // shown on hover (an SVG <title>): e.g. the unit and its values
  // false: the plot's range does not grow to show it (a model's single term,
  // whose sinusoid or fast Gauss-Markov part falls decades below the data);
  // its parts outside the range are not drawn.
  bool sets_range = true;
};

// A reference line, e.g. a limit: y(x) = y * x^slope on the log-log axes
// (`y` is the value at x = 1). slope 0 is a horizontal line, and the y range
// grows to show it; a sloped line (e.g. -1/2 for a random-walk limit) is
// clipped to the plot and never changes the range. The label runs along the
// line (or level beside it), where it least overlaps the curves, markers,
// other lines and labels.
struct PlotLine {
  std::string label;
  double y = 0;
  std::string color = "#d62728";
  double slope = 0;
};

struct PlotMarker {  // a single labelled point, e.g. the curve minimum
  std::string label;
  double x = 0, y = 0;
  std::string color = "#000000";
  // false: the plot's range does not grow to show it (a reference point
  // such as a slope line's read-off); outside the range it is not drawn, and
  // its legend entry (marker_labels_in_legend) stays.
  bool sets_range = true;
};

struct LogLogPlot {
  std::string title;
  std::string x_label = "tau [s]";
  std::string y_label;
  // Every y (series, bands, lines, markers) is given in a base unit and drawn
  // times y_scale on the left axis (e.g. 3600: deg/s data in deg/h, the
  // datasheet unit); with y2_label set, a right axis shows the base unit.
  double y_scale = 1;
  std::string y2_label;
  std::vector<PlotSeries> series;
  std::vector<PlotLine> lines;
  std::vector<PlotMarker> markers;
  // false: each marker's label is written next to it; true: listed in the
  // legend under the series (readable when several markers lie close). An
  // empty label is written nowhere.
  bool marker_labels_in_legend = false;
  std::vector<std::string> notes;  // small lines of text under the legend
  int width = 760;
  int height = 520;
  int legend_width = 190;  // px right of the plot area for the legend (the
                           // SVG grows when a legend text needs more)
  // Every text lies inside the SVG: the legend's width follows its longest
  // text, a marker's label turns to the side of the marker that has room.
  std::string ToSvg() const;
};

// A categorical palette colour for series i.
std::string PaletteColor(size_t i);

// A coordinate in px, 2 decimals.
std::string SvgPx(double v);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_SVG_PLOT_H_
