#include "report/svg_plot.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>

namespace imuqual::report {
namespace {

int SvgWidth(const std::string& svg) {
  std::smatch m;
  EXPECT_TRUE(std::regex_search(svg, m, std::regex("<svg[^>]* width=\"([0-9]+)\"")));
  return m.empty() ? 0 : std::stoi(m[1]);
}

// GIVEN a curve in deg/s drawn in deg/h (y_scale 3600) with the base unit on
// a right axis: the left axis runs over the displayed decades (0.01 deg/s at
// 1 s is 36 deg/h: 10..100 and beyond), the right one names deg/s decades.
TEST(LogLogPlotTest, DatasheetUnitsOnTheLeftBaseUnitOnTheRight) {
  LogLogPlot p;
  p.y_scale = 3600;
  p.y_label = "Allan deviation [deg/h]";
  p.y2_label = "[deg/s]";
  PlotSeries s;
  s.label = "x";
  s.x = {0.1, 1, 10};
  s.y = {0.03, 0.01, 0.004};  // 108, 36, 14.4 deg/h
  p.series.push_back(s);
  p.lines.push_back({"BI limit 20 deg/h", 20.0 / 3600});
  const std::string svg = p.ToSvg();
  EXPECT_NE(svg.find(">1000</text>"), std::string::npos) << svg;  // 108 deg/h: up to 1000
  EXPECT_NE(svg.find(">10</text>"), std::string::npos);
  EXPECT_NE(svg.find(">0.01</text>"), std::string::npos);  // a deg/s decade on the right
  EXPECT_NE(svg.find("[deg/s]"), std::string::npos);
  EXPECT_EQ(svg.find(">0.001</text>"), std::string::npos);  // 3.6 deg/h: below the range
}

// A legend text longer than the legend's width widens the SVG instead of
// running off it; a tooltip is an escaped <title> around its curve.
TEST(LogLogPlotTest, LegendWidensTheSvgAndTooltipsAreEscaped) {
  LogLogPlot p;
  p.width = 600;
  p.legend_width = 150;
  PlotSeries s;
  s.label = "short";
  s.x = {1, 2};
  s.y = {1, 0.7};
  s.tooltip = "U<1> & \"2\"";
  p.series.push_back(s);
  EXPECT_EQ(SvgWidth(p.ToSvg()), 600);
  p.series[0].label = std::string(60, 'w');  // 60 x 7 px + 30 + 20 > 150
  const std::string svg = p.ToSvg();
  EXPECT_GE(SvgWidth(svg), 600 - 150 + 12 + 30 + 60 * 7);
  EXPECT_NE(svg.find("<g><title>U&lt;1&gt; &amp; &quot;2&quot;</title><polyline"),
            std::string::npos)
      << svg;
}

// A marker's label near the right edge of the plot is written to its left
// (anchored at its end), so it stays inside the plot.
TEST(LogLogPlotTest, MarkerLabelTurnsAwayFromTheEdge) {
  LogLogPlot p;
  PlotSeries s;
  s.x = {1, 10, 100};
  s.y = {1, 0.5, 0.6};
  p.series.push_back(s);
  p.markers.push_back({"minimum 0.5 at 100 s, a long label", 100, 0.6, "#000000"});
  const std::string svg = p.ToSvg();
  const size_t at = svg.find("minimum 0.5 at 100 s");
  ASSERT_NE(at, std::string::npos);
  const size_t open = svg.rfind("<text", at);
  EXPECT_NE(svg.substr(open, at - open).find("text-anchor=\"end\""), std::string::npos)
      << svg.substr(open, at - open);
}

// A reference marker (sets_range false) far below the curves neither
// widens the range nor is drawn; its legend entry stays.
TEST(LogLogPlotTest, AReferenceMarkerOutsideTheRangeIsNotDrawn) {
  LogLogPlot p;
  p.marker_labels_in_legend = true;
  PlotSeries s;
  s.x = {1, 10, 100};
  s.y = {1, 0.5, 0.6};
  p.series.push_back(s);
  PlotMarker k{"K=1e-6 @3s", 3, 1e-6, "#7f7f7f"};
  k.sets_range = false;
  p.markers.push_back(k);
  const std::string svg = p.ToSvg();
  EXPECT_EQ(svg.find(">1e-06</text>"), std::string::npos) << svg;  // the range: 0.1..1
  size_t rings = 0;  // the legend's only, not one in the plot
  for (size_t at = svg.find("stroke=\"#7f7f7f\""); at != std::string::npos;
       at = svg.find("stroke=\"#7f7f7f\"", at + 1))
    ++rings;
  EXPECT_EQ(rings, 1u) << svg;
  EXPECT_NE(svg.find("K=1e-6 @3s"), std::string::npos);  // listed in the legend
  p.markers[0].sets_range = true;
  EXPECT_NE(p.ToSvg().find(">1e-06</text>"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::report

namespace imuqual::report {
namespace {

// A series that does not set the range (a model's single term, e.g. a
// sinusoid decades below the data) neither widens the axes nor is drawn
// outside them: the ADIS16405 gx plot spanned 1e-6 to 1e4.
TEST(LogLogPlotTest, ASeriesThatDoesNotSetTheRangeIsDrawnOnlyInsideIt) {
  LogLogPlot p;
  PlotSeries data;
  data.x = {0.1, 1, 10};
  data.y = {0.3, 0.1, 0.03};
  p.series.push_back(data);
  PlotSeries term;
  term.sets_range = false;
  term.markers = false;
  term.x = {0.1, 0.3, 1, 3, 10};
  term.y = {0.05, 1e-6, 1e-7, 0.02, 0.02};  // dips far below, comes back
  p.series.push_back(term);
  const std::string svg = p.ToSvg();
  EXPECT_EQ(svg.find(">1e-06</text>"), std::string::npos) << svg;
  EXPECT_EQ(svg.find(">1e-07</text>"), std::string::npos);
  EXPECT_NE(svg.find(">0.01</text>"), std::string::npos);
  // The term is drawn in two runs (before and after its dip), the data in one.
  size_t polylines = 0;
  for (size_t at = svg.find("<polyline"); at != std::string::npos; at = svg.find("<polyline", at + 1)) {
    ++polylines;
  }
  EXPECT_EQ(polylines, 3u) << svg;
}

}  // namespace
}  // namespace imuqual::report
