#include "analyze/allan/dynamic_allan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace imuqual::allan {
namespace {

std::vector<float> White(size_t n, double sigma, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0, sigma);
  std::vector<float> out(n);
  for (float& v : out) v = static_cast<float>(nd(rng));
  return out;
}

// The overlapping Allan deviation at m of a gap-free slice, written out.
double DirectOadev(std::span<const float> y, int64_t m, double tau0) {
  std::vector<double> x(y.size() + 1, 0.0);
  for (size_t i = 0; i < y.size(); ++i) x[i + 1] = x[i] + y[i] * tau0;
  double sum = 0;
  const int64_t terms = static_cast<int64_t>(x.size()) - 2 * m;
  for (int64_t i = 0; i < terms; ++i) {
    const double d = x[i + 2 * m] - 2 * x[i + m] + x[i];
    sum += d * d;
  }
  const double tau = m * tau0;
  return std::sqrt(sum / (2.0 * tau * tau * terms));
}

// GIVEN a white-noise record, WHEN its dynamic Allan deviation is computed
// with the defaults, THEN the windows are a quarter of the record, start
// every quarter window, the last ends at the record's end, and each window's
// curve is the OADEV of its own samples.
TEST(DynamicAllanTest, WindowsAreTheirOwnRecords) {
  const double tau0 = 0.01;
  const std::vector<float> y = White(40000, 0.1, 1);
  const Result<DynamicAllan> d = ComputeDynamicAllan(y, tau0);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_NEAR(d->window_s, 100.0, 1e-12);
  EXPECT_NEAR(d->step_s, 25.0, 1e-12);
  ASSERT_EQ(d->windows.size(), 13u);
  for (size_t i = 0; i < d->windows.size(); ++i) {
    const DynamicAllanWindow& w = d->windows[i];
    EXPECT_NEAR(w.start_s, 25.0 * static_cast<double>(i), 1e-9);
    EXPECT_EQ(w.valid_samples, 10000);
    ASSERT_FALSE(w.curve.points.empty());
    const size_t first = static_cast<size_t>(std::llround(w.start_s / tau0));
    const std::span<const float> slice(y.data() + first, 10000);
    for (const CurvePoint& p : w.curve.points) {
      EXPECT_LE(p.m, 10000 / 9);
      EXPECT_NEAR(p.dev, DirectOadev(slice, p.m, tau0), 1e-9 * p.dev) << "window " << i << " m " << p.m;
      EXPECT_LT(p.lo, p.dev);
      EXPECT_GT(p.hi, p.dev);
    }
  }
  // A step that does not divide the record: the last window still ends at its end.
  DynamicAllanOptions o;
  o.window_s = 120;
  o.step_s = 70;
  const Result<DynamicAllan> e = ComputeDynamicAllan(y, tau0, {}, o);
  ASSERT_TRUE(e.ok());
  ASSERT_EQ(e->windows.size(), 5u);  // 0, 70, 140, 210, then 280 (= 400 - 120)
  EXPECT_NEAR(e->windows.back().start_s, 280.0, 1e-9);
}

// GIVEN white noise with a level step in its middle, WHEN the windows are
// compared, THEN those holding the step read far above the others at their
// longest tau, and the others agree with one another within their intervals.
TEST(DynamicAllanTest, AStepLiftsTheWindowsThatHoldIt) {
  const double tau0 = 0.01;
  std::vector<float> y = White(80000, 0.1, 2);
  for (size_t i = 40000; i < y.size(); ++i) y[i] += 0.05f;
  DynamicAllanOptions o;
  o.window_s = 100;
  o.step_s = 100;
  const Result<DynamicAllan> d = ComputeDynamicAllan(y, tau0, {}, o);
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->windows.size(), 8u);
  // The step lies on the boundary of windows 3 and 4: no window holds it.
  o.step_s = 50;
  const Result<DynamicAllan> s = ComputeDynamicAllan(y, tau0, {}, o);
  ASSERT_TRUE(s.ok());
  const double quiet = s->windows.front().curve.points.back().dev;
  for (const DynamicAllanWindow& w : s->windows) {
    const CurvePoint& last = w.curve.points.back();
    const bool holds = w.start_s < 400 && w.start_s + w.length_s > 400;
    if (holds) {
      EXPECT_GT(last.dev, 3 * quiet) << "window at " << w.start_s;
    } else {
      EXPECT_LT(last.lo, 2 * quiet) << "window at " << w.start_s;
      EXPECT_GT(last.hi, quiet / 2) << "window at " << w.start_s;
    }
  }
}

// GIVEN white noise whose level rises 10 % in its last quarter, WHEN the
// first and last windows are compared at the shortest tau, THEN the ratio
// reads 1.10 within its sigma; the same record without the rise reads 1.
TEST(DynamicAllanTest, ALevelChangeAtTheShortestTau) {
  std::vector<float> y = White(200000, 0.1, 8);
  const Result<DynamicAllan> flat = ComputeDynamicAllan(y, 0.01);
  ASSERT_TRUE(flat.ok());
  const std::optional<LevelChange> none = ShortTauLevelChange(*flat);
  ASSERT_TRUE(none.has_value());
  EXPECT_NEAR(none->tau_s, 0.01, 1e-12);
  EXPECT_NEAR(none->first_start_s, 0, 1e-12);
  EXPECT_NEAR(none->last_start_s, 1500, 1e-9);
  EXPECT_GT(none->sigma, 0.002);  // sqrt(2 / (2 edf)) with edf ~ 4e4
  EXPECT_LT(none->sigma, 0.01);
  EXPECT_LT(std::fabs(none->ratio - 1), 3 * none->sigma);
  for (size_t i = 150000; i < y.size(); ++i) y[i] *= 1.1f;
  const Result<DynamicAllan> risen = ComputeDynamicAllan(y, 0.01);
  ASSERT_TRUE(risen.ok());
  const std::optional<LevelChange> change = ShortTauLevelChange(*risen);
  ASSERT_TRUE(change.has_value());
  EXPECT_LT(std::fabs(change->ratio - 1.1), 3 * change->sigma);
  EXPECT_FALSE(ShortTauLevelChange(DynamicAllan{}).has_value());
}

// Invalid samples are gaps, counted per window.
TEST(DynamicAllanTest, InvalidSamplesAreGaps) {
  std::vector<float> y = White(20000, 0.1, 3);
  std::vector<uint8_t> bad(y.size(), 0);
  for (size_t i = 100; i < 200; ++i) bad[i] = 1;
  y[300] = NAN;
  DynamicAllanOptions o;
  o.window_s = 50;
  o.step_s = 50;
  const Result<DynamicAllan> d = ComputeDynamicAllan(y, 0.01, bad, o);
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->windows.size(), 4u);
  EXPECT_EQ(d->windows[0].valid_samples, 5000 - 101);
  EXPECT_EQ(d->windows[1].valid_samples, 5000);
}

TEST(DynamicAllanTest, BadInputIsNamed) {
  const std::vector<float> y = White(1000, 0.1, 4);
  auto error = [&](double tau0, double window, double step, size_t flags) {
    DynamicAllanOptions o;
    o.window_s = window;
    o.step_s = step;
    std::vector<uint8_t> bad(flags, 0);
    const Result<DynamicAllan> d = ComputeDynamicAllan(y, tau0, bad, o);
    EXPECT_FALSE(d.ok());
    return d.ok() ? std::string() : d.status().message();
  };
  EXPECT_NE(error(0, 0, 0, 0).find("tau0 must be > 0"), std::string::npos);
  EXPECT_NE(error(0.01, -1, 0, 0).find("window_s must be >= 0"), std::string::npos);
  EXPECT_NE(error(0.01, 0, NAN, 0).find("step_s must be >= 0"), std::string::npos);
  EXPECT_NE(error(0.01, 0.5, 0, 0).find("too short"), std::string::npos);
  EXPECT_NE(error(0.01, 11, 0, 0).find("longer than the record"), std::string::npos);
  EXPECT_NE(error(0.01, 5, 0.001, 0).find("shorter than one sample"), std::string::npos);
  EXPECT_NE(error(0.01, 5, 0, 10).find("10 invalid flags for 1000 samples"), std::string::npos);
  EXPECT_NE(error(0.01, 1e17, 0, 0)
                .find("the window (1e+17 s) is longer than the "
                      "record (10 s)"),
            std::string::npos);
  EXPECT_NE(error(0.01, 2, 3, 0).find("the step (3 s) is longer than the window (2 s)"),
            std::string::npos);
}

// A window far shorter than the record: the step widens to keep at most
// kMaxWindows curves, the last still ending at the record's end.
TEST(DynamicAllanTest, AtMostMaxWindows) {
  const std::vector<float> y = White(100000, 0.1, 7);
  DynamicAllanOptions o;
  o.window_s = 1;
  o.intervals = false;
  const Result<DynamicAllan> d = ComputeDynamicAllan(y, 0.01, {}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_LE(d->windows.size(), static_cast<size_t>(DynamicAllanOptions::kMaxWindows));
  EXPECT_GE(d->windows.size(), static_cast<size_t>(DynamicAllanOptions::kMaxWindows) - 2);
  EXPECT_NEAR(d->windows.back().start_s + d->windows.back().length_s, 1000.0, 1e-9);
  EXPECT_TRUE(std::isnan(d->windows.front().curve.points.front().lo));  // no intervals asked
}

}  // namespace
}  // namespace imuqual::allan
