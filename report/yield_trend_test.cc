// Yield trends: each unit once, in the group of its first run; a retest
// does not make a first pass; Wilson's interval at its textbook value.
#include "report/yield_trend.h"

#include <gtest/gtest.h>

#include <cmath>

#include "report/control_chart_view.h"

namespace imuqual::report {
namespace {

constexpr int64_t kDay = 86'400'000'000;
// 2026-11-23 (a Monday, ISO week 48) 00:00 UTC.
constexpr int64_t kMonday = 1'795'392'000'000'000;

TEST(YieldTrendTest, WilsonIntervalMatchesItsTextbookValue) {
  double low, high;
  WilsonInterval(8, 10, &low, &high);
  EXPECT_NEAR(low, 0.4902, 1e-4);
  EXPECT_NEAR(high, 0.9433, 1e-4);
  WilsonInterval(0, 0, &low, &high);
  EXPECT_TRUE(std::isnan(low));
}

TEST(YieldTrendTest, EachUnitCountsOnceInTheGroupOfItsFirstRun) {
  ASSERT_EQ(IsoWeekLabel(kMonday), "2026-W48");
  const std::vector<store::RunVerdictRow> runs = {
      // Week 48: U1 passes; U2 fails, is retested on st-2 in week 49 and
      // passes (final PASS, first pass no); U3 is inconclusive.
      {"r1", "L", "U1", "st-1", "PASS", kMonday},
      {"r2", "L", "U2", "st-1", "FAIL", kMonday + kDay},
      {"r3", "L", "U3", "st-1", "INCONCLUSIVE", kMonday + 2 * kDay},
      {"r4", "L", "U2", "st-2", "PASS", kMonday + 8 * kDay},
      // Week 49: U4 aborted, never judged; U5 marginal.
      {"r5", "L", "U4", "st-2", "ABORTED", kMonday + 9 * kDay},
      {"r6", "L", "U5", "st-2", "MARGINAL", kMonday + 10 * kDay},
  };
  const std::vector<YieldRow> weeks = YieldTrend(runs, YieldBy::kWeek);
  ASSERT_EQ(weeks.size(), 2u);
  EXPECT_EQ(weeks[0].group, "2026-W48");
  EXPECT_EQ(weeks[0].units, 3);
  EXPECT_EQ(weeks[0].runs, 4);
  EXPECT_EQ(weeks[0].pass, 2);  // U1, and U2 by its retest
  EXPECT_EQ(weeks[0].inconclusive, 1);
  EXPECT_DOUBLE_EQ(weeks[0].final_yield, 1.0);              // 2 of 2 judged PASS/FAIL
  EXPECT_DOUBLE_EQ(weeks[0].first_pass_yield, 1.0 / 3.0);  // U1 only, of U1 U2 U3
  EXPECT_EQ(weeks[1].group, "2026-W49");
  EXPECT_EQ(weeks[1].units, 2);
  EXPECT_EQ(weeks[1].other, 1);
  EXPECT_DOUBLE_EQ(weeks[1].final_yield, 1.0);
  EXPECT_DOUBLE_EQ(weeks[1].first_pass_yield, 1.0);  // U5; U4 never judged
  const std::vector<YieldRow> stations = YieldTrend(runs, YieldBy::kStation);
  ASSERT_EQ(stations.size(), 2u);
  EXPECT_EQ(stations[0].group, "st-1");
  EXPECT_EQ(stations[0].units, 3);  // U2 counts where it was first tested
  EXPECT_EQ(stations[1].units, 2);
}

}  // namespace
}  // namespace imuqual::report
