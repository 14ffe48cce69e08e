#include "analyze/allan/stationarity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

namespace imuqual::allan {
namespace {

constexpr double kTau0 = 0.01;  // 100 Hz

CompositeModel White(double n) { return {{{TermKind::kWhite, n}}}; }

std::vector<double> WhiteRecord(double n, int samples, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, n / std::sqrt(kTau0));
  std::vector<double> y(samples);
  for (double& v : y) v = g(rng);
  return y;
}

// Each term's structure function reproduces its AVAR:
// AVAR(tau) = (4 D(tau) - D(2 tau)) / (2 tau^2) (composite_model.h's closed
// forms, continuous time: tau >> tau0 for the terms whose discrete AVAR has
// a 1/m correction).
TEST(PhaseStructureFunctionTest, ReproducesEachTermsAvar) {
  const double tau0 = 0.01;
  const std::vector<ModelTerm> terms = {
      {TermKind::kQuantization, 2e-4},      {TermKind::kWhite, 3e-3},
      {TermKind::kFlicker, 1e-3},           {TermKind::kRandomWalk, 5e-5},
      {TermKind::kGaussMarkov, 2e-3, 30.0}, {TermKind::kSinusoid, 1e-3, 0, 0.0371}};
  for (const ModelTerm& t : terms) {
    const CompositeModel model{{t}};
    for (double tau : {10.0, 100.0, 1000.0}) {
      const double d1 = PhaseStructureFunction(model, tau0, tau);
      const double d2 = PhaseStructureFunction(model, tau0, 2 * tau);
      const double avar = (4 * d1 - d2) / (2 * tau * tau);
      const double expected = TermAvar(t, tau / tau0, tau0);
      // The random walk's discrete AVAR has a (2 m^2 + 1)/(2 m^2) factor;
      // at m >= 1000 it is within 1e-6.
      EXPECT_NEAR(avar / expected, 1.0, 1e-5) << TermKindName(t.kind) << " tau " << tau;
    }
  }
}

TEST(BinMeansTest, MeansOfFiniteSamplesAndHalfEmptyBinsAreNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> y = {1, 3, nan, 4, nan, nan, 5, 7, 9};
  // Bins of 2: {1,3} {nan,4} {nan,nan} {5,7}; the 9 left over is no bin.
  const std::vector<double> m = BinMeans(y, 2, 4);
  ASSERT_EQ(m.size(), 4u);
  EXPECT_EQ(m[0], 2.0);
  EXPECT_EQ(m[1], 4.0);  // one of two finite: half is enough
  EXPECT_TRUE(std::isnan(m[2]));
  EXPECT_EQ(m[3], 6.0);
  // A bin past the end of the record is NaN, not read out of bounds.
  const std::vector<double> past = BinMeans(y, 4, 3);
  EXPECT_EQ(past[0], 8.0 / 3.0);
  EXPECT_TRUE(std::isnan(past[2]));
}

TEST(StationarityTest, FalseAlarmsAtTheStatedRate) {
  // GIVEN 200 white records with their true model; WHEN scanned at a 5 %
  // level (the threshold calibrated on records drawn from the model); THEN
  // the alarm fraction is 5 % within three Monte Carlo standard errors, on
  // either side: the level is the rate, not a bound far above it (Bonferroni
  // over the candidates gave a fraction of the level).
  int alarms = 0;
  constexpr int kRecords = 200;
  constexpr double kLevel = 0.05;
  StationarityOptions o;
  o.false_alarm = kLevel;
  for (int seed = 0; seed < kRecords; ++seed) {
    const std::vector<double> y = WhiteRecord(1e-3, 30000, 100 + seed);
    auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0, o);
    ASSERT_TRUE(scan.ok()) << scan.status().message();
    ASSERT_TRUE(scan->scanned);
    alarms += scan->events.empty() ? 0 : 1;
  }
  const double se = std::sqrt(kLevel * (1 - kLevel) * kRecords);
  std::printf("false alarms: %d of %d records at a %g level\n", alarms, kRecords, kLevel);
  EXPECT_NEAR(alarms, kLevel * kRecords, 3 * se);
}

TEST(StationarityTest, FindsAPlantedStepWithItsSize) {
  // GIVEN a white record (N = 1e-3 u sqrt(s), 300 s) with a step of 1e-3 u
  // at 123.4 s: the 1 s bin means have sd 1e-3, so the step's sigma is
  // 1e-3 sqrt(1/123 + 1/177) = 1.2e-4 (z about 8).
  std::vector<double> y = WhiteRecord(1e-3, 30000, 7);
  const double step = 1e-3;
  for (size_t i = 12340; i < y.size(); ++i) y[i] += step;
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok()) << scan.status().message();
  ASSERT_EQ(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_EQ(e.kind, EventKind::kStep);
  // The boundary of the largest z: a step of one bin-mean sd moves it by a
  // few bins.
  EXPECT_NEAR(e.time_s, 123.4, 5 * scan->bin_s);
  EXPECT_TRUE(e.axes[0].named);
  // Within 3 sigma of the truth, the boundary's few bins off included (a
  // fraction bin / length of the size each).
  EXPECT_NEAR(e.axes[0].size, step, 3 * e.axes[0].sigma);
  EXPECT_LT(e.axes[0].sigma, step / 5);
}

TEST(StationarityTest, FindsABurstAndTheLongestStationarySegment) {
  std::vector<double> y = WhiteRecord(1e-3, 60000, 11);
  for (size_t i = 40000; i < 42000; ++i) y[i] += 2e-3;  // 400-420 s: z about 9
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok());
  ASSERT_GE(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_EQ(e.kind, EventKind::kBurst);
  EXPECT_NEAR(e.time_s, 400, 2 * scan->bin_s);
  EXPECT_NEAR(e.time_s + e.window_s, 420, 2 * scan->bin_s + 0.5 * 20);
  const Segment s = LongestStationarySegment(*scan, 600);
  EXPECT_NEAR(s.begin_s, 0, 1e-9);
  EXPECT_NEAR(s.end_s, e.time_s, 1e-9);
}

TEST(StationarityTest, JointEventNamesTheAxesItMoves) {
  // A step on axes 0 and 2 of three, z about 4.2 each (sigma 1.2e-4): below
  // a single axis's Bonferroni threshold (about 4.9), clear together.
  std::vector<std::vector<double>> y;
  for (int a = 0; a < 3; ++a) y.push_back(WhiteRecord(1e-3, 30000, 50 + a));
  for (int a : {0, 2}) {
    for (size_t i = 15000; i < y[a].size(); ++i) y[a][i] += 5e-4;
  }
  auto scan = ScanStationarity({y[0], y[1], y[2]}, {White(1e-3), White(1e-3), White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok());
  ASSERT_GE(scan->events.size(), 1u);
  const StationarityEvent& e = scan->events[0];
  EXPECT_NEAR(e.time_s, 150, 2 * scan->bin_s);
  EXPECT_TRUE(e.joint);
  EXPECT_TRUE(e.axes[0].named);
  EXPECT_FALSE(e.axes[1].named);
  EXPECT_TRUE(e.axes[2].named);
}

TEST(StationarityTest, MissingSamplesAndShortRecords) {
  std::vector<double> y = WhiteRecord(1e-3, 30000, 3);
  for (size_t i = 5000; i < 9000; ++i) y[i] = std::nan("");  // a 40 s gap
  auto scan = ScanStationarity({y}, {White(1e-3)}, kTau0);
  ASSERT_TRUE(scan.ok()) << scan.status().message();
  EXPECT_TRUE(scan->scanned);
  EXPECT_TRUE(scan->events.empty());

  const std::vector<double> shortest(100, 0.0);
  auto too_short = ScanStationarity({shortest}, {White(1e-3)}, kTau0, {.bin_s = 1});
  ASSERT_TRUE(too_short.ok());
  EXPECT_FALSE(too_short->scanned);
  EXPECT_NE(too_short->note.find("too short"), std::string::npos);
}

TEST(StationarityTest, BadArgumentsAreNamed) {
  const std::vector<double> y(1000, 0.0);
  EXPECT_FALSE(ScanStationarity({}, {}, kTau0).ok());
  EXPECT_FALSE(ScanStationarity({y}, {}, kTau0).ok());
  EXPECT_FALSE(ScanStationarity({y}, {White(1)}, 0).ok());
  StationarityOptions o;
  o.false_alarm = 0.7;
  auto s = ScanStationarity({y}, {White(1)}, kTau0, o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("false_alarm"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::allan
