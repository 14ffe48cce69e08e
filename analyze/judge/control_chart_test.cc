// Control charts: exact limits on a small chart, the in-control false-alarm
// rate of "beyond 3 sigma" at its 0.27 % over 200 simulated charts, and a
// planted shift of the process mean found.
#include "analyze/judge/control_chart.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace imuqual::judge {
namespace {

TEST(ControlChartTest, C4MatchesItsTable) {
  EXPECT_NEAR(C4(2), 0.7979, 1e-4);
  EXPECT_NEAR(C4(5), 0.9400, 1e-4);
  EXPECT_NEAR(C4(10), 0.9727, 1e-4);
  EXPECT_NEAR(C4(25), 0.9896, 1e-4);
}

TEST(ControlChartTest, LimitsOfASmallChartAreExact) {
  auto c = MakeControlChart({{"L1", {1, 2, 3}}, {"L2", {2, 3, 4}}});
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_DOUBLE_EQ(c->centre, 2.5);
  const double sigma = 1 / C4(5);  // pooled s = 1 on 4 degrees of freedom
  EXPECT_NEAR(c->sigma, sigma, 1e-12);
  EXPECT_NEAR(c->points[0].mean_ucl, 2.5 + 3 * sigma / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(c->points[0].mean_lcl, 2.5 - 3 * sigma / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(c->points[1].sd_centre, C4(3) * sigma, 1e-12);
  EXPECT_EQ(c->flagged, 0);
  // Too little to set limits from, said.
  EXPECT_FALSE(MakeControlChart({{"L1", {1, 2}}, {"L2", {3}}}).ok());
  EXPECT_FALSE(MakeControlChart({{"L1", {1, 2}}, {"L2", {}}}).ok());
}

TEST(ControlChartTest, AnInControlProcessRaisesBeyondThreeSigmaAtItsRate) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> unit(20, 2);
  int points = 0, beyond = 0, any = 0;
  for (int k = 0; k < 200; ++k) {
    std::vector<Subgroup> g(50);
    for (int i = 0; i < 50; ++i) {
      g[i].label = std::to_string(i);
      for (int j = 0; j < 5; ++j) g[i].values.push_back(unit(rng));
    }
    auto c = MakeControlChart(g);
    ASSERT_TRUE(c.ok());
    for (const ChartPoint& p : c->points) {
      ++points;
      for (const std::string& r : p.mean_rules) beyond += r == "beyond 3 sigma";
      any += !p.mean_rules.empty();
    }
  }
  const double rate = static_cast<double>(beyond) / points;
  std::printf("in control: beyond 3 sigma %.4f of %d points (0.0027 nominal), any rule %.4f\n",
              rate, points, static_cast<double>(any) / points);
  // 0.0027 +- 3 Monte Carlo sd (sqrt(0.0027 / 10000) = 0.00052).
  EXPECT_NEAR(rate, 0.0027, 0.0016);
}

TEST(ControlChartTest, AShiftOfTheProcessMeanIsFlaggedAgainstItsBaseline) {
  // 30 subgroups in control (the baseline), then the mean moves 1.5 sigma
  // of a subgroup mean: the run rules find it within the next 15 in most
  // charts, and rarely flag the baseline itself.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> unit(0, 1);
  int found = 0, false_before = 0;
  constexpr int kCharts = 200;
  for (int k = 0; k < kCharts; ++k) {
    std::vector<Subgroup> g(45);
    for (int i = 0; i < 45; ++i) {
      g[i].label = std::to_string(i);
      const double shift = i >= 30 ? 1.5 / std::sqrt(5.0) : 0;
      for (int j = 0; j < 5; ++j) g[i].values.push_back(unit(rng) + shift);
    }
    auto c = MakeControlChart(g, /*baseline=*/30);
    ASSERT_TRUE(c.ok());
    bool after = false, before = false;
    for (int i = 0; i < 45; ++i) {
      if (c->points[i].mean_rules.empty()) continue;
      (i >= 30 ? after : before) = true;
    }
    found += after;
    false_before += before;
  }
  std::printf("shift of 1.5 sigma(mean): found in %d of %d charts; a flag before it in %d\n",
              found, kCharts, false_before);
  EXPECT_GE(found, static_cast<int>(0.9 * kCharts));
  // About 1.3 % of in-control points flag by some rule: of 30, 1 - 0.987^30.
  EXPECT_LE(false_before, static_cast<int>(0.45 * kCharts));
}

}  // namespace
}  // namespace imuqual::judge
