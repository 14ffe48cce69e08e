#include "report/dynamic_allan_plot.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace imuqual::report {
namespace {

size_t Count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

// GIVEN a record's dynamic Allan deviation, WHEN it is drawn, THEN each
// window is a curve with its span in a tooltip, the first and the last are
// in the legend, the note says how many windows of what length, and every
// text is escaped.
TEST(DynamicAllanPlotTest, EachWindowIsACurve) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> nd(0, 0.1);
  std::vector<float> y(72000);
  for (float& v : y) v = static_cast<float>(nd(rng));
  const auto davar = allan::ComputeDynamicAllan(y, 0.01);
  ASSERT_TRUE(davar.ok());
  ASSERT_EQ(davar->windows.size(), 13u);
  DynamicAllanPlotStyle style;
  style.title = "SN <1> x: dynamic Allan deviation";
  style.y_scale = 3600;
  style.y_label = "Allan deviation [deg/h]";
  style.y2_label = "[deg/s]";
  const std::string svg = DynamicAllanSvg(*davar, style);
  EXPECT_EQ(Count(svg, "<polyline"), 13u);
  EXPECT_NE(svg.find("<title>window 0:00-3:00 (18000 valid samples)</title>"), std::string::npos);
  EXPECT_NE(svg.find("<title>window 9:00-12:00 (18000 valid samples)</title>"), std::string::npos);
  EXPECT_NE(svg.find(">window 0:00-3:00<"), std::string::npos);
  EXPECT_NE(svg.find(">window 9:00-12:00<"), std::string::npos);
  EXPECT_EQ(svg.find(">window 0:45-3:45<"), std::string::npos);  // not in the legend
  EXPECT_NE(svg.find("13 windows of 3:00 every 0:45"), std::string::npos);
  EXPECT_NE(svg.find("SN &lt;1&gt; x"), std::string::npos);
  EXPECT_EQ(svg.find("SN <1>"), std::string::npos);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::report
