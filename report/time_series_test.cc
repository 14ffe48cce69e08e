#include "report/time_series.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace imuqual::report {
namespace {

constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

// GIVEN 10007 counters of two channels (a gap of 500 counters in channel 0
// only, counters 7000..7099 missing altogether), streamed into at most 600
// bins: THEN the width is the smallest power of two that fits, and every bin
// holds exactly the min, max, sum and count of its counters, as computed
// directly from the series.
TEST(EnvelopeBuilderTest, BinsHoldExactlyTheirCountersWhateverTheMerging) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 1);
  const int64_t first = 123456, n = 10007;
  std::vector<double> a(n), b(n);
  std::vector<bool> present(n, true);
  for (int64_t k = 0; k < n; ++k) {
    a[k] = (k >= 2000 && k < 2500) ? kNone : noise(rng) + 1e-3 * static_cast<double>(k);
    b[k] = 25.0 + noise(rng) * 0.1;
    if (k >= 7000 && k < 7100) present[k] = false;
  }
  EnvelopeBuilder builder(2, 600);
  for (int64_t k = 0; k < n; ++k) {
    if (!present[k]) continue;
    const double v[2] = {a[k], b[k]};
    builder.Add(first + k, v);
  }
  EXPECT_EQ(builder.width(), 32);  // 10007 / 16 > 600 >= 10007 / 32
  EXPECT_EQ(builder.first(), first);
  const auto& bins = builder.bins();
  ASSERT_EQ(bins.size(), static_cast<size_t>((n + 31) / 32));
  int empty_a = 0, empty_b = 0;
  for (size_t i = 0; i < bins.size(); ++i) {
    EXPECT_EQ(bins[i].first, first + static_cast<int64_t>(i) * 32);
    const std::vector<double>* series[2] = {&a, &b};
    for (int c = 0; c < 2; ++c) {
      double lo = INFINITY, hi = -INFINITY, sum = 0;
      int64_t count = 0;
      for (int64_t k = static_cast<int64_t>(i) * 32; k < std::min<int64_t>(n, (i + 1) * 32); ++k) {
        const double v = (*series[c])[k];
        if (!present[k] || std::isnan(v)) continue;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        sum += v;
        ++count;
      }
      ASSERT_EQ(bins[i].n[c], count) << "bin " << i << " channel " << c;
      if (count == 0) {
        (c == 0 ? empty_a : empty_b)++;
        continue;
      }
      EXPECT_EQ(bins[i].min[c], lo);
      EXPECT_EQ(bins[i].max[c], hi);
      EXPECT_NEAR(bins[i].sum[c], sum, 1e-9 * (1 + std::abs(sum)));
    }
  }
  // 2000..2499 covers bins 63..77 wholly (2016..2495), 7000..7099 bins 219..220 (7008..7071).
  EXPECT_EQ(empty_a, 15 + 2);
  EXPECT_EQ(empty_b, 2);
}

// Counters may be negative (a device's signed counter): bins still start
// at the first one.
TEST(EnvelopeBuilderTest, NegativeCountersAreBinnedFromTheFirst) {
  EnvelopeBuilder builder(1, 600);
  for (int64_t k = -10; k < 10; ++k) {
    const double v[1] = {static_cast<double>(k)};
    builder.Add(k, v);
  }
  EXPECT_EQ(builder.first(), -10);
  ASSERT_EQ(builder.bins().size(), 20u);
  EXPECT_EQ(builder.bins()[0].n[0], 1);
  EXPECT_EQ(builder.bins()[0].min[0], -10);
}

// A stuck sensor (a constant) draws a flat line, not rounding noise blown
// up into a drift, and a zero or absurd rate draws no endless axis.
TEST(TimeSeriesPlotTest, ConstantsAndBadRatesStayFinite) {
  EnvelopeBuilder builder(1, 100);
  for (int64_t k = 0; k < 1000; ++k) {
    const double v[1] = {0.1 + (k % 3) * 1e-17};
    builder.Add(k, v);
  }
  TimeSeriesPlot plot;
  plot.panels = {{"x drift [deg/h]", "#1f77b4", 0, false, 0.1, 3600}};
  for (double rate : {100.0, 0.0, 1e-320, std::numeric_limits<double>::infinity()}) {
    plot.counters_per_second = rate;
    const std::string svg = plot.ToSvg(builder);
    EXPECT_EQ(svg.find("e-1"), std::string::npos) << rate;  // no ticks at 1e-13 deg/h
    EXPECT_EQ(svg.find("nan"), std::string::npos) << rate;
    EXPECT_EQ(svg.find("inf"), std::string::npos) << rate;
  }
}

// The SVG: one panel per channel with its label, the title and labels
// escaped, a band per stretch of bins with values (a gap splits it), and a
// note line per note.
TEST(TimeSeriesPlotTest, PanelsBandsAndEscapedText) {
  EnvelopeBuilder builder(2, 100);
  for (int64_t k = 0; k < 1000; ++k) {
    const double v[2] = {(k >= 400 && k < 600) ? kNone : std::sin(k * 0.01), 20.0};
    builder.Add(k, v);
  }
  TimeSeriesPlot plot;
  plot.title = "unit <script>alert(1)</script> & \"x\"";
  plot.counters_per_second = 100;
  plot.panels = {{"gx [deg/s]", "#1f77b4", 0}, {"temperature [deg C]", "#d62728", 1}};
  plot.notes = {"a note"};
  const std::string svg = plot.ToSvg(builder);
  EXPECT_EQ(svg.find("<script>"), std::string::npos);
  EXPECT_NE(svg.find("unit &lt;script&gt;alert(1)&lt;/script&gt; &amp; &quot;x&quot;"),
            std::string::npos);
  EXPECT_NE(svg.find("gx [deg/s]"), std::string::npos);
  EXPECT_NE(svg.find("temperature [deg C]"), std::string::npos);
  EXPECT_NE(svg.find("device time [s]"), std::string::npos);  // 10 s: seconds
  EXPECT_NE(svg.find("a note"), std::string::npos);
  size_t polygons = 0;
  for (size_t p = svg.find("<polygon"); p != std::string::npos; p = svg.find("<polygon", p + 1))
    ++polygons;
  EXPECT_EQ(polygons, 3u);  // gx before and after its gap, the temperature (constant) once
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  EXPECT_EQ(svg.find("class=\"warmup\""), std::string::npos);  // none asked

  // The warm-up shaded in every panel (2.5 s of the 10 s: a quarter of the
  // plot's width) and named once.
  plot.shaded_s = 2.5;
  plot.shaded_label = "warm-up 2.5 s (not analysed)";
  const std::string shaded = plot.ToSvg(builder);
  size_t rects = 0;
  for (size_t p = shaded.find("class=\"warmup\""); p != std::string::npos;
       p = shaded.find("class=\"warmup\"", p + 1)) {
    ++rects;
    const size_t w = shaded.find("width=\"", p) + 7;
    EXPECT_NEAR(std::stod(shaded.substr(w)), 0.25 * (760 - 78 - 16), 3.0);  // bins end past 10 s
  }
  EXPECT_EQ(rects, 2u);
  EXPECT_NE(shaded.find(">warm-up 2.5 s (not analysed)<"), std::string::npos);
}

// The stationarity scan's events: a step as a dashed line at its time and a
// burst as a band over its stretch, in their own channel's panels only,
// each labelled (escaped) once.
TEST(TimeSeriesPlotTest, EventsAreMarkedOnTheirChannel) {
  EnvelopeBuilder builder(2, 100);
  for (int64_t k = 0; k < 1000; ++k) {
    const double v[2] = {k < 500 ? 0.0 : 1.0, 20.0};
    builder.Add(k, v);
  }
  TimeSeriesPlot plot;
  plot.counters_per_second = 100;
  plot.panels = {{"gx [deg/s]", "#1f77b4", 0},
                 {"gx drift [deg/h]", "#1f77b4", 0, false},
                 {"temperature [deg C]", "#d62728", 1}};
  plot.events = {{0, 5.0, 5.0, "gx step +3600 \u00b1 12 deg/h <b>"},
                 {0, 2.0, 3.0, "gx burst +10 \u00b1 2 deg/h"}};
  const std::string svg = plot.ToSvg(builder);
  size_t lines = 0, bands = 0;
  for (size_t p = svg.find("<line class=\"event\""); p != std::string::npos;
       p = svg.find("<line class=\"event\"", p + 1)) {
    ++lines;
    const size_t x = svg.find("x1=\"", p) + 4;
    EXPECT_NEAR(std::stod(svg.substr(x)), 78 + 0.5 * (760 - 78 - 16), 3.0);  // 5 s of 10 s
  }
  for (size_t p = svg.find("<rect class=\"event\""); p != std::string::npos;
       p = svg.find("<rect class=\"event\"", p + 1)) {
    ++bands;
    const size_t w = svg.find("width=\"", p) + 7;
    EXPECT_NEAR(std::stod(svg.substr(w)), 0.1 * (760 - 78 - 16), 3.0);  // 1 s of 10 s
  }
  EXPECT_EQ(lines, 2u);  // gx's two panels, not the temperature's
  EXPECT_EQ(bands, 2u);
  EXPECT_EQ(svg.find("<b>"), std::string::npos);
  EXPECT_NE(svg.find(">gx step +3600 \u00b1 12 deg/h &lt;b&gt;</text>"), std::string::npos);
  EXPECT_NE(svg.find(">gx burst +10 \u00b1 2 deg/h</text>"), std::string::npos);

  // The stretch gx was judged on (5.5-10 s): a green bar in gx's panels only.
  plot.judged = {{0, 5.5, 10.0, "gx judged on the stretch 5.5-10 s"}};
  const std::string judged = plot.ToSvg(builder);
  size_t bars = 0;
  for (size_t p = judged.find("<rect class=\"judged\""); p != std::string::npos;
       p = judged.find("<rect class=\"judged\"", p + 1)) {
    ++bars;
    const size_t x = judged.find("x=\"", p) + 3;
    EXPECT_NEAR(std::stod(judged.substr(x)), 78 + 0.55 * (760 - 78 - 16), 3.0);
    const size_t w = judged.find("width=\"", p) + 7;
    EXPECT_NEAR(std::stod(judged.substr(w)), 0.45 * (760 - 78 - 16), 3.0);
  }
  EXPECT_EQ(bars, 2u);
  EXPECT_NE(judged.find("<title>gx judged on the stretch 5.5-10 s</title>"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::report
