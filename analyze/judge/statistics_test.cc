#include "analyze/judge/statistics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace imuqual::judge {
namespace {

// Closed forms are exact; 1e-12 covers the special functions' rounding.
constexpr double kTol = 1e-12;

TEST(StatisticsTest, SummaryAndCapability) {
  const std::vector<double> v = {9, 10, 11, std::nan("")};
  const std::vector<pb::Outcome> o = {pb::PASS, pb::MARGINAL, pb::FAIL, pb::FAIL};
  // mean 10, sd 1; USL 16 -> Cpu = 6/3 = 2; with LSL 7 -> Cpk = min(6, 3)/3 = 1.
  Summary s = Summarize(v, o, std::nullopt, 16.0);
  EXPECT_EQ(s.n, 3);
  EXPECT_DOUBLE_EQ(s.mean, 10);
  EXPECT_DOUBLE_EQ(s.sd, 1);
  EXPECT_EQ(s.min, 9);
  EXPECT_EQ(s.max, 11);
  EXPECT_EQ(s.judged, 4);
  EXPECT_EQ(s.passed, 2);
  EXPECT_EQ(s.marginal, 1);
  EXPECT_DOUBLE_EQ(s.yield, 0.5);
  // Three values give no capability index, only which one the limits call for.
  EXPECT_EQ(s.capability_kind, "Cpu");
  EXPECT_TRUE(std::isnan(s.capability));
  EXPECT_TRUE(std::isnan(s.capability_low));
  EXPECT_TRUE(std::isnan(Summarize(std::vector<double>{5}, {}, 0.0, 9.0).capability));
  s = Summarize(v, {}, 7.0, std::nullopt);
  EXPECT_EQ(s.capability_kind, "Cpl");
  EXPECT_TRUE(std::isnan(s.yield));
}

// Capability from kMinCapabilityN values on, with its 95 % interval.
TEST(StatisticsTest, CapabilityFromTenValuesWithItsInterval) {
  // 10 values: mean 10, sd 1 (five at 10 - a, five at 10 + a, a = sqrt(9/10)).
  const double a = std::sqrt(0.9);
  std::vector<double> v;
  for (int i = 0; i < 5; ++i) {
    v.push_back(10 - a);
    v.push_back(10 + a);
  }
  Summary s = Summarize(v, {}, std::nullopt, 16.0);
  EXPECT_EQ(s.capability_kind, "Cpu");
  EXPECT_NEAR(s.capability, 2.0, 1e-12);  // (16 - 10) / 3
  const double half = 1.959963984540054 * std::sqrt(1.0 / 90 + 4.0 / 18);
  EXPECT_NEAR(s.capability_low, 2.0 - half, 1e-12);
  EXPECT_NEAR(s.capability_high, 2.0 + half, 1e-12);
  s = Summarize(v, {}, 7.0, 16.0);
  EXPECT_EQ(s.capability_kind, "Cpk");
  EXPECT_NEAR(s.capability, 1.0, 1e-12);  // min(6, 3) / 3
  s = Summarize(v, {}, 7.0, std::nullopt);
  EXPECT_EQ(s.capability_kind, "Cpl");
  EXPECT_NEAR(s.capability, 1.0, 1e-12);
  // One value fewer: none.
  v.pop_back();
  EXPECT_TRUE(std::isnan(Summarize(v, {}, 7.0, 16.0).capability));
}

// An INCONCLUSIVE value (a retest candidate) is neither a pass nor a loss.
TEST(StatisticsTest, InconclusiveIsNotInTheYield) {
  const std::vector<double> v = {9, 10, 11, 12};
  const std::vector<pb::Outcome> o = {pb::PASS, pb::INCONCLUSIVE, pb::FAIL, pb::OUTCOME_UNSET};
  const Summary s = Summarize(v, o, std::nullopt, 16.0);
  EXPECT_EQ(s.n, 4);
  EXPECT_EQ(s.judged, 2);
  EXPECT_EQ(s.passed, 1);
  EXPECT_EQ(s.inconclusive, 1);
  EXPECT_DOUBLE_EQ(s.yield, 0.5);
}

TEST(StatisticsTest, WelchTTestAgainstTheTwoDegreeOfFreedomClosedForm) {
  // a = {0, 2}, b = {3, 5}: equal variances 2, n = 2 -> df = 2 exactly,
  // t = -3/sqrt(2); for df = 2, P(T > t) = 1/2 - t / (2 sqrt(2 + t^2)).
  const Summary a = Summarize(std::vector<double>{0, 2}, {}, {}, {});
  const Summary b = Summarize(std::vector<double>{3, 5}, {}, {}, {});
  const TestResult r = WelchTTest(a, b);
  const double t = -3 / std::sqrt(2.0);
  EXPECT_NEAR(r.statistic, t, kTol);
  EXPECT_NEAR(r.p_value, 1 - std::abs(t) / std::sqrt(2 + t * t), kTol);
  EXPECT_TRUE(std::isnan(WelchTTest(Summarize(std::vector<double>{1}, {}, {}, {}), b).p_value));
}

TEST(StatisticsTest, VarianceFTestAgainstTheTwoTwoClosedForm) {
  // a = {0, 1, 2} (var 1), b = {0, 2, 4} (var 4): F = 1/4 on (2, 2) degrees
  // of freedom, whose CDF is x / (1 + x) = 0.2; two-sided p = 0.4.
  const TestResult r = VarianceFTest(Summarize(std::vector<double>{0, 1, 2}, {}, {}, {}),
                                     Summarize(std::vector<double>{0, 2, 4}, {}, {}, {}));
  EXPECT_NEAR(r.statistic, 0.25, kTol);
  EXPECT_NEAR(r.p_value, 0.4, kTol);
}

TEST(StatisticsTest, FisherExactTestAgainstTheTeaTasting) {
  // Fisher's lady tasting tea, table [[3, 1], [1, 3]]: two-sided p = 34/70.
  EXPECT_NEAR(FisherExactTest(3, 4, 1, 4).p_value, 34.0 / 70.0, kTol);
  // Identical rates: p = 1. A stark difference is significant.
  EXPECT_NEAR(FisherExactTest(5, 10, 5, 10).p_value, 1.0, kTol);
  EXPECT_LT(FisherExactTest(95, 100, 70, 100).p_value, 1e-5);
  EXPECT_TRUE(std::isnan(FisherExactTest(1, 0, 1, 2).p_value));
}

TEST(StatisticsTest, HolmStepDown) {
  // m = 4 at 0.05: 0.01 <= 0.0125 yes, 0.02 <= 0.0167 no -> stop.
  const std::vector<double> p = {0.02, 0.01, 0.5, std::nan(""), 0.04};
  const std::vector<bool> s = HolmSignificant(p, 0.05);
  EXPECT_EQ(s, (std::vector<bool>{false, true, false, false, false}));
}

}  // namespace
}  // namespace imuqual::judge
