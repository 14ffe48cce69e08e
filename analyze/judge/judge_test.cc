#include "analyze/judge/judge.h"

#include <gtest/gtest.h>

#include <cmath>

#include "analyze/judge/plan.h"

namespace imuqual::judge {
namespace {

pb::Measurement M(const std::string& axis, const std::string& name, double v,
                  const std::string& unit) {
  pb::Measurement m;
  m.set_axis(axis);
  m.set_name(name);
  m.set_value(v);
  m.set_unit(unit);
  return m;
}

pb::TestPlan Plan() {
  auto plan =
      ParsePlanText(R"pb(
                      nominal_rate_hz: 100
                      min_duration_s: 3600
                      axes { name: "x" kind: GYRO }
                      axes { name: "y" kind: GYRO }
                      limits {
                        measurement: "bias_instability"
                        axis_kind: GYRO
                        high: 20
                        marginal_high: 16
                        unit: "deg/h"
                      }
                      limits { measurement: "bias_instability" axes: "y" high: 10 unit: "deg/h" }
                      limits {
                        measurement: "tau_at_minimum"
                        axis_kind: GYRO
                        low: 2
                        high: 100
                        marginal_low: 5
                        unit: "s"
                      }
                      limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
                    )pb",
                    "t");
  EXPECT_TRUE(plan.ok()) << plan.status().ToString();
  return *plan;
}

const std::vector<AxisDesc> kAxes = {{"x", pb::GYRO}, {"y", pb::GYRO}};

TEST(EvaluateTest, BandsAndEdges) {
  pb::Limit lim;
  lim.set_low(1);
  lim.set_marginal_low(2);
  lim.set_marginal_high(8);
  lim.set_high(10);
  EXPECT_EQ(Evaluate(lim, 0.999), pb::FAIL);
  EXPECT_EQ(Evaluate(lim, 1), pb::MARGINAL);  // limits are inclusive
  EXPECT_EQ(Evaluate(lim, 2), pb::PASS);
  EXPECT_EQ(Evaluate(lim, 8), pb::PASS);
  EXPECT_EQ(Evaluate(lim, 9), pb::MARGINAL);
  EXPECT_EQ(Evaluate(lim, 10), pb::MARGINAL);
  EXPECT_EQ(Evaluate(lim, 10.001), pb::FAIL);
  EXPECT_EQ(Evaluate(lim, std::nan("")), pb::FAIL);
}

TEST(JudgeTest, AllInsideIsPass) {
  std::vector<pb::Measurement> ms = {
      M("x", "bias_instability", 12, "deg/h"), M("y", "bias_instability", 9, "deg/h"),
      M("x", "tau_at_minimum", 12, "s"),       M("y", "tau_at_minimum", 11, "s"),
      M("", "gap_fraction", 0, "1"),           M("", "duration", 7200, "s")};
  Judgement j = Judge(Plan(), kAxes, &ms);
  EXPECT_EQ(j.verdict, pb::PASS);
  EXPECT_TRUE(j.reasons.empty());
  EXPECT_EQ(ms[0].high(), 20);
  EXPECT_EQ(ms[1].high(), 10);  // the axis-specific limit wins over the kind limit
  EXPECT_FALSE(ms[1].has_marginal_high());
  EXPECT_EQ(ms[5].low(), 3600);  // min_duration_s became a limit
}

TEST(JudgeTest, FailAndMarginalGiveReasonsAndFailWins) {
  std::vector<pb::Measurement> ms = {
      M("x", "bias_instability", 17, "deg/h"), M("y", "bias_instability", 10.5, "deg/h"),
      M("x", "tau_at_minimum", 12, "s"),       M("y", "tau_at_minimum", 3, "s"),
      M("", "gap_fraction", 0, "1"),           M("", "duration", 7200, "s")};
  Judgement j = Judge(Plan(), kAxes, &ms);
  EXPECT_EQ(j.verdict, pb::FAIL);
  ASSERT_EQ(j.reasons.size(), 3u);
  EXPECT_EQ(j.reasons[0], "x: bias_instability 17 deg/h marginal (above 16 deg/h)");
  EXPECT_EQ(j.reasons[1], "y: bias_instability 10.5 deg/h above high limit 10 deg/h");
  EXPECT_EQ(j.reasons[2], "y: tau_at_minimum 3 s marginal (below 5 s)");
  EXPECT_EQ(ms[0].outcome(), pb::MARGINAL);
  EXPECT_EQ(ms[1].outcome(), pb::FAIL);
}

TEST(JudgeTest, MissingMeasurementsAndShortRunsFail) {
  std::vector<pb::Measurement> ms = {M("x", "bias_instability", 12, "deg/h"),
                                     M("", "duration", 600, "s")};
  Judgement j = Judge(Plan(), kAxes, &ms);
  EXPECT_EQ(j.verdict, pb::FAIL);
  bool saw_short = false, saw_missing = false;
  for (const std::string& r : j.reasons) {
    if (r == "duration 600 s below low limit 3600 s") saw_short = true;
    if (r == "y: bias_instability not measured (no value was produced)") saw_missing = true;
  }
  EXPECT_TRUE(saw_short);
  EXPECT_TRUE(saw_missing);
}

TEST(JudgeTest, NoLimitsMeansNotJudged) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  std::vector<pb::Measurement> ms = {M("x", "bias_instability", 12, "deg/h")};
  EXPECT_EQ(Judge(plan, kAxes, &ms).verdict, pb::OUTCOME_UNSET);
  EXPECT_EQ(ms[0].outcome(), pb::OUTCOME_UNSET);
}

// A value withheld because the axis's noise model failed its J test: the
// plan decides; MARGINAL by default, with the note as the reason.
TEST(JudgeTest, InadequateNoiseModelIsJudgedAsThePlanSays) {
  auto plan = ParsePlanText(R"pb(
                              nominal_rate_hz: 100
                              axes { name: "x" kind: GYRO }
                              limits {
                                measurement: "fit_rate_random_walk"
                                axis_kind: GYRO
                                high: 10
                                unit: "deg/h/sqrt(h)"
                              }
                            )pb",
                            "t");
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  auto withheld = [] {
    pb::Measurement m = M("x", "fit_rate_random_walk", std::nan(""), "deg/h/sqrt(h)");
    m.set_model_inadequate(true);
    m.set_note("not measurable: noise model inadequate (N+B, J-test p = 0.0001 < 0.01)");
    return std::vector<pb::Measurement>{m};
  };
  // GIVEN the default plan WHEN judged THEN MARGINAL with the note as reason.
  std::vector<pb::Measurement> ms = withheld();
  Judgement j = Judge(*plan, {{"x", pb::GYRO}}, &ms);
  EXPECT_EQ(j.verdict, pb::MARGINAL);
  EXPECT_EQ(ms[0].outcome(), pb::MARGINAL);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "x: fit_rate_random_walk not measurable: noise model inadequate (N+B, J-test p = "
            "0.0001 < 0.01)");
  // GIVEN a plan that says FAIL.
  pb::TestPlan strict = *plan;
  strict.set_on_inadequate_model(pb::TestPlan::INADEQUATE_FAIL);
  ms = withheld();
  EXPECT_EQ(Judge(strict, {{"x", pb::GYRO}}, &ms).verdict, pb::FAIL);
  // A NaN for any other reason stays a FAIL (not measured).
  ms = withheld();
  ms[0].set_model_inadequate(false);
  EXPECT_EQ(Judge(*plan, {{"x", pb::GYRO}}, &ms).verdict, pb::FAIL);
  // An upper bound above the limit fails, and the reason says it is a bound.
  ms = {M("x", "fit_rate_random_walk", 12, "deg/h/sqrt(h)")};
  ms[0].set_note("upper bound (95 %): not in the selected model");
  j = Judge(*plan, {{"x", pb::GYRO}}, &ms);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "x: fit_rate_random_walk 12 deg/h/sqrt(h) (upper bound) above high limit 10 "
            "deg/h/sqrt(h)");
}

}  // namespace
}  // namespace imuqual::judge
