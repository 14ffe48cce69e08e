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
  ms[0].set_qualifier(pb::UPPER_BOUND);
  ms[0].set_note("upper bound (95 %): not in the selected model");
  j = Judge(*plan, {{"x", pb::GYRO}}, &ms);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "x: fit_rate_random_walk 12 deg/h/sqrt(h) (upper bound) above high limit 10 "
            "deg/h/sqrt(h)");
}

// The reason of a NaN value says "not measurable" from model_inadequate, not
// from its note's wording.
TEST(JudgeTest, NotMeasurableComesFromTheFlagNotTheNote) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  pb::Limit* lim = plan.add_limits();
  lim->set_measurement("fit_rate_random_walk");
  lim->set_high(10);
  lim->set_unit("deg/h/sqrt(h)");
  pb::Measurement m = M("x", "fit_rate_random_walk", std::nan(""), "deg/h/sqrt(h)");
  m.set_qualifier(pb::NOT_MEASURABLE);
  m.set_note("not measurable: something else");
  std::vector<pb::Measurement> ms = {m};
  Judgement j = Judge(plan, {{"x", pb::GYRO}}, &ms);
  EXPECT_EQ(j.verdict, pb::FAIL);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0], "x: fit_rate_random_walk not measured (not measurable: something else)");
  EXPECT_EQ(ms[0].decision_rule(), pb::Limit::SIMPLE);
}

// ---- Decision rules (ISO 14253-1, JCGM 106:2012) ----

// A one-measurement plan: bias_instability in [low, high] (either optional)
// under `rule`, guard_k `k` (<= 0: not set).
pb::TestPlan RulePlan(pb::Limit::DecisionRule rule, double k, bool low, bool high) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  plan.add_axes()->set_name("gx");
  plan.mutable_axes(0)->set_kind(pb::GYRO);
  pb::Limit* lim = plan.add_limits();
  lim->set_measurement("bias_instability");
  lim->set_axis_kind(pb::GYRO);
  lim->set_unit("deg/h");
  if (low) lim->set_low(2);
  if (high) lim->set_high(10);
  lim->set_decision_rule(rule);
  if (k > 0) lim->set_guard_k(k);
  EXPECT_TRUE(ValidatePlan(plan).ok()) << ValidatePlan(plan).message();
  return plan;
}

// Judges value ± u (u < 0: no uncertainty) under `plan`.
pb::Measurement JudgeOne(const pb::TestPlan& plan, double value, double u, Judgement* j = nullptr,
                         pb::Qualifier qualifier = pb::QUALIFIER_NONE) {
  std::vector<pb::Measurement> ms = {M("gx", "bias_instability", value, "deg/h")};
  if (u >= 0) ms[0].set_uncertainty(u);
  ms[0].set_qualifier(qualifier);
  Judgement local = Judge(plan, {{"gx", pb::GYRO}}, &ms);
  if (j != nullptr) *j = local;
  EXPECT_EQ(local.verdict, ms[0].outcome());
  return ms[0];
}

pb::Outcome OutcomeOf(const pb::TestPlan& plan, double value, double u) {
  return JudgeOne(plan, value, u).outcome();
}

TEST(DecisionRuleTest, SimpleIgnoresTheUncertainty) {
  const pb::TestPlan plan = RulePlan(pb::Limit::SIMPLE, 2, true, true);
  EXPECT_EQ(OutcomeOf(plan, 9.9, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 10, 0.5), pb::PASS);  // inclusive
  EXPECT_EQ(OutcomeOf(plan, 10.1, 0.5), pb::FAIL);
  EXPECT_EQ(OutcomeOf(plan, 2.1, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 1.9, 0.5), pb::FAIL);
  const pb::Measurement m = JudgeOne(plan, 9.9, 0.5);
  EXPECT_EQ(m.decision_rule(), pb::Limit::SIMPLE);
  EXPECT_FALSE(m.has_guard_band());
}

// w = k u = 2 * 0.5 = 1: INCONCLUSIVE within 1 of either bound, both sides.
TEST(DecisionRuleTest, GuardedIsInconclusiveWhileTheIntervalStraddlesABound) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, true, true);  // k defaults to 2
  // High bound 10.
  EXPECT_EQ(OutcomeOf(plan, 8.9, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 9.0, 0.5), pb::PASS);  // exactly w inside: not straddling
  EXPECT_EQ(OutcomeOf(plan, 9.1, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 10.0, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 10.9, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 11.0, 0.5), pb::FAIL);
  EXPECT_EQ(OutcomeOf(plan, 11.1, 0.5), pb::FAIL);
  // Low bound 2.
  EXPECT_EQ(OutcomeOf(plan, 3.1, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 2.9, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 1.1, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 0.9, 0.5), pb::FAIL);
  const pb::Measurement m = JudgeOne(plan, 9.5, 0.5);
  EXPECT_EQ(m.decision_rule(), pb::Limit::GUARDED);
  ASSERT_TRUE(m.has_guard_band());
  EXPECT_DOUBLE_EQ(m.guard_band(), 1.0);
}

TEST(DecisionRuleTest, GuardedAcceptancePassesOnlyWellInside) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED_ACCEPTANCE, 3, true, true);  // w = 1.5
  EXPECT_EQ(OutcomeOf(plan, 8.4, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 8.5, 0.5), pb::PASS);  // exactly w inside
  EXPECT_EQ(OutcomeOf(plan, 8.6, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 10.0, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 10.01, 0.5), pb::FAIL);  // any way outside
  EXPECT_EQ(OutcomeOf(plan, 3.6, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 3.4, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 2.0, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 1.99, 0.5), pb::FAIL);
  EXPECT_DOUBLE_EQ(JudgeOne(plan, 9, 0.5).guard_band(), 1.5);
  EXPECT_EQ(JudgeOne(plan, 9, 0.5).decision_rule(), pb::Limit::GUARDED_ACCEPTANCE);
}

TEST(DecisionRuleTest, GuardedRejectionFailsOnlyWellOutside) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED_REJECTION, 0, true, true);  // w = 1
  EXPECT_EQ(OutcomeOf(plan, 9.99, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 10.0, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 10.5, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 10.99, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 11.0, 0.5), pb::FAIL);  // exactly w outside
  EXPECT_EQ(OutcomeOf(plan, 2.0, 0.5), pb::PASS);
  EXPECT_EQ(OutcomeOf(plan, 1.5, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 0.9, 0.5), pb::FAIL);
}

// tau_at_minimum is guarded on ln tau: its u is tau x u(ln tau), so with
// u(ln tau) = 0.25 and k = 2 the band around 100 s is 60.7-164.9 s, not
// 50-150 s. A high limit of 160 s is then still within the band (linear:
// passed); a low limit of 55 s is outside it (linear: inconclusive).
TEST(DecisionRuleTest, TauAtMinimumIsGuardedOnItsLogScale) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  plan.add_axes()->set_name("gx");
  plan.mutable_axes(0)->set_kind(pb::GYRO);
  pb::Limit* lim = plan.add_limits();
  lim->set_measurement("tau_at_minimum");
  lim->set_axis_kind(pb::GYRO);
  lim->set_unit("s");
  lim->set_high(160);
  lim->set_decision_rule(pb::Limit::GUARDED_ACCEPTANCE);
  ASSERT_TRUE(ValidatePlan(plan).ok()) << ValidatePlan(plan).message();
  auto judge = [&](double tau, double u_ln, std::string* reason = nullptr) {
    std::vector<pb::Measurement> ms = {M("gx", "tau_at_minimum", tau, "s")};
    ms[0].set_uncertainty(tau * u_ln);
    Judgement j = Judge(plan, {{"gx", pb::GYRO}}, &ms);
    if (reason != nullptr && !j.reasons.empty()) *reason = j.reasons[0];
    return ms[0];
  };
  std::string reason;
  const pb::Measurement m = judge(100, 0.25, &reason);
  EXPECT_EQ(m.outcome(), pb::INCONCLUSIVE);
  EXPECT_DOUBLE_EQ(m.guard_band(), 50);  // w = k u, the record's unit
  EXPECT_NE(reason.find("on ln: 60.65-164.9 s"), std::string::npos) << reason;
  EXPECT_EQ(judge(96, 0.25).outcome(), pb::PASS);          // 96 e^0.5 = 158.3
  EXPECT_EQ(judge(98, 0.25).outcome(), pb::INCONCLUSIVE);  // 161.6
  lim->clear_high();
  lim->set_low(55);
  EXPECT_EQ(judge(100, 0.25).outcome(), pb::PASS);         // 60.65 > 55
  EXPECT_EQ(judge(90, 0.25).outcome(), pb::INCONCLUSIVE);  // 54.6
  EXPECT_EQ(judge(54, 0.25).outcome(), pb::FAIL);
  // The early decision's evidence counts sigmas on the same scale.
  EXPECT_NEAR(SigmasAbove(m, 160), std::log(100.0 / 160) / 0.25, 1e-12);
  pb::Measurement bi = M("gx", "bias_instability", 9, "deg/h");
  bi.set_uncertainty(0.5);
  EXPECT_DOUBLE_EQ(SigmasAbove(bi, 10), -2);
}

// The plan's default rule and guard_k apply to limits that choose none; a
// limit's own beat them.
TEST(DecisionRuleTest, PlanDefaultsAndLimitOverrides) {
  pb::TestPlan plan = RulePlan(pb::Limit::RULE_DEFAULT, 0, false, true);
  EXPECT_EQ(OutcomeOf(plan, 9.5, 0.5), pb::PASS);  // SIMPLE by default
  EXPECT_EQ(JudgeOne(plan, 9.5, 0.5).decision_rule(), pb::Limit::SIMPLE);
  plan.set_default_decision_rule(pb::Limit::GUARDED);
  EXPECT_EQ(OutcomeOf(plan, 9.5, 0.5), pb::INCONCLUSIVE);  // w = 2 * 0.5
  EXPECT_EQ(JudgeOne(plan, 9.5, 0.5).decision_rule(), pb::Limit::GUARDED);
  plan.set_default_guard_k(0.5);  // w = 0.25
  EXPECT_EQ(OutcomeOf(plan, 9.5, 0.5), pb::PASS);
  EXPECT_DOUBLE_EQ(JudgeOne(plan, 9.5, 0.5).guard_band(), 0.25);
  plan.mutable_limits(0)->set_guard_k(4);  // w = 2
  EXPECT_EQ(OutcomeOf(plan, 8.5, 0.5), pb::INCONCLUSIVE);
  plan.mutable_limits(0)->set_decision_rule(pb::Limit::SIMPLE);
  EXPECT_EQ(OutcomeOf(plan, 8.5, 0.5), pb::PASS);
  EXPECT_FALSE(JudgeOne(plan, 8.5, 0.5).has_guard_band());
}

// Marginal limits stay simple whatever the rule: the guard band only acts at
// low and high.
TEST(DecisionRuleTest, MarginalLimitsStaySimple) {
  pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, false, true);
  plan.mutable_limits(0)->set_marginal_high(8);
  EXPECT_EQ(OutcomeOf(plan, 7.9, 0.5), pb::PASS);  // within w of 8: still PASS
  EXPECT_EQ(OutcomeOf(plan, 8.1, 0.5), pb::MARGINAL);
  EXPECT_EQ(OutcomeOf(plan, 9.1, 0.5), pb::INCONCLUSIVE);  // the high bound decides
  plan.mutable_limits(0)->set_decision_rule(pb::Limit::GUARDED_REJECTION);
  EXPECT_EQ(OutcomeOf(plan, 10.5, 0.5), pb::INCONCLUSIVE);
  EXPECT_EQ(OutcomeOf(plan, 9.9, 0.5), pb::MARGINAL);
}

// Without an uncertainty a guarded rule is applied as simple acceptance, and
// the measurement says so.
TEST(DecisionRuleTest, NoUncertaintyMeansSimpleAcceptanceSaidSo) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED_ACCEPTANCE, 0, false, true);
  Judgement j;
  pb::Measurement m = JudgeOne(plan, 9.9, -1, &j);
  EXPECT_EQ(m.outcome(), pb::PASS);
  EXPECT_EQ(m.decision_rule(), pb::Limit::SIMPLE);
  EXPECT_FALSE(m.has_guard_band());
  EXPECT_EQ(m.note(), "no uncertainty: simple acceptance");
  m = JudgeOne(plan, 10.5, -1, &j);
  EXPECT_EQ(m.outcome(), pb::FAIL);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "gx: bias_instability 10.5 deg/h above high limit 10 deg/h (no uncertainty: simple "
            "acceptance)");
  // A NaN uncertainty is none either.
  m = JudgeOne(plan, 9.9, std::nan(""));
  EXPECT_EQ(m.outcome(), pb::PASS);
  EXPECT_EQ(m.decision_rule(), pb::Limit::SIMPLE);
  // An existing note is kept, the remark appended once.
  std::vector<pb::Measurement> ms = {M("gx", "bias_instability", 9.9, "deg/h")};
  ms[0].set_note("minimum at the longest tau");
  Judge(plan, {{"gx", pb::GYRO}}, &ms);
  Judge(plan, {{"gx", pb::GYRO}}, &ms);
  EXPECT_EQ(ms[0].note(), "minimum at the longest tau; no uncertainty: simple acceptance");
}

// An upper bound at or below a high limit proves conformance whatever the
// guard band; above it, it proves nothing under a guarded rule and FAILs
// under simple acceptance (as ever).
TEST(DecisionRuleTest, UpperBounds) {
  for (pb::Limit::DecisionRule rule :
       {pb::Limit::GUARDED, pb::Limit::GUARDED_ACCEPTANCE, pb::Limit::GUARDED_REJECTION}) {
    const pb::TestPlan plan = RulePlan(rule, 0, false, true);
    Judgement j;
    pb::Measurement m = JudgeOne(plan, 9.9, 0.5, &j, pb::UPPER_BOUND);
    EXPECT_EQ(m.outcome(), pb::PASS) << DecisionRuleName(rule);
    EXPECT_EQ(m.decision_rule(), rule);
    EXPECT_FALSE(m.has_guard_band());
    m = JudgeOne(plan, 9.9, -1, &j, pb::UPPER_BOUND);  // no uncertainty: no matter
    EXPECT_EQ(m.outcome(), pb::PASS);
    EXPECT_EQ(m.decision_rule(), rule);
    EXPECT_EQ(m.note(), "");
    m = JudgeOne(plan, 10.2, -1, &j, pb::UPPER_BOUND);
    EXPECT_EQ(m.outcome(), pb::INCONCLUSIVE) << DecisionRuleName(rule);
    ASSERT_EQ(j.reasons.size(), 1u);
    EXPECT_EQ(j.reasons[0], std::string("gx: bias_instability 10.2 deg/h (upper bound): only an "
                                        "upper bound, above the high limit 10 deg/h: "
                                        "inconclusive (") +
                                DecisionRuleName(rule) + ")");
  }
  const pb::TestPlan simple = RulePlan(pb::Limit::SIMPLE, 0, false, true);
  EXPECT_EQ(JudgeOne(simple, 10.2, -1, nullptr, pb::UPPER_BOUND).outcome(), pb::FAIL);
  EXPECT_EQ(JudgeOne(simple, 9.9, -1, nullptr, pb::UPPER_BOUND).outcome(), pb::PASS);
  // Below a low limit an upper bound proves non-conformance; above it, a
  // guarded rule cannot tell.
  const pb::TestPlan low = RulePlan(pb::Limit::GUARDED, 0, true, false);
  EXPECT_EQ(JudgeOne(low, 1.5, -1, nullptr, pb::UPPER_BOUND).outcome(), pb::FAIL);
  EXPECT_EQ(JudgeOne(low, 5, -1, nullptr, pb::UPPER_BOUND).outcome(), pb::INCONCLUSIVE);
  const pb::TestPlan low_simple = RulePlan(pb::Limit::SIMPLE, 0, true, false);
  EXPECT_EQ(JudgeOne(low_simple, 5, -1, nullptr, pb::UPPER_BOUND).outcome(), pb::PASS);
}

// A bias instability read at the curve's last point (the curve has not
// turned up) is an upper bound of the true minimum: judged like one.
TEST(DecisionRuleTest, AnUnresolvedMinimumIsJudgedAsAnUpperBound) {
  const pb::TestPlan guarded = RulePlan(pb::Limit::GUARDED, 0, false, true);
  Judgement j;
  pb::Measurement m = JudgeOne(guarded, 10.4, 0.1, &j, pb::MINIMUM_NOT_RESOLVED);
  EXPECT_EQ(m.outcome(), pb::INCONCLUSIVE);  // w = 0.2 would have made it a FAIL
  EXPECT_FALSE(m.has_guard_band());
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "gx: bias_instability 10.4 deg/h (minimum not resolved): only an upper bound, above "
            "the high limit 10 deg/h: inconclusive (guarded)");
  EXPECT_EQ(JudgeOne(guarded, 9.9, 0.5, nullptr, pb::MINIMUM_NOT_RESOLVED).outcome(), pb::PASS);
  const pb::TestPlan simple = RulePlan(pb::Limit::SIMPLE, 0, false, true);
  EXPECT_EQ(JudgeOne(simple, 10.4, 0.1, nullptr, pb::MINIMUM_NOT_RESOLVED).outcome(), pb::FAIL);
}

TEST(DecisionRuleTest, ZeroUncertaintyRecordsAZeroGuardBand) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, false, true);
  const pb::Measurement m = JudgeOne(plan, 9.99, 0.0);
  EXPECT_EQ(m.outcome(), pb::PASS);
  EXPECT_EQ(m.decision_rule(), pb::Limit::GUARDED);
  ASSERT_TRUE(m.has_guard_band());
  EXPECT_EQ(m.guard_band(), 0.0);
  EXPECT_EQ(m.note(), "");
}

TEST(DecisionRuleTest, AGuardedLimitOfMarginalBoundsOnlyIsSimple) {
  pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, false, true);
  plan.mutable_limits(0)->clear_high();
  plan.mutable_limits(0)->set_marginal_high(8);
  for (double u : {0.5, -1.0}) {
    const pb::Measurement m = JudgeOne(plan, 8.1, u);
    EXPECT_EQ(m.outcome(), pb::MARGINAL);
    EXPECT_EQ(m.decision_rule(), pb::Limit::SIMPLE);
    EXPECT_FALSE(m.has_guard_band());
    EXPECT_EQ(m.note(), "");  // no "no uncertainty" note: there was nothing to guard
  }
}

TEST(DecisionRuleTest, ReasonsNameAxisValueUncertaintyBoundBandAndRule) {
  pb::TestPlan plan = RulePlan(pb::Limit::GUARDED_ACCEPTANCE, 0, true, true);
  Judgement j;
  JudgeOne(plan, 9.8, 0.6, &j);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "gx: bias_instability 9.8 ± 0.6 deg/h within the guard band (w = 1.2) of the high "
            "limit 10 deg/h: inconclusive (guarded acceptance)");
  JudgeOne(plan, 2.5, 0.6, &j);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "gx: bias_instability 2.5 ± 0.6 deg/h within the guard band (w = 1.2) of the low "
            "limit 2 deg/h: inconclusive (guarded acceptance)");
  plan.mutable_limits(0)->set_decision_rule(pb::Limit::GUARDED_REJECTION);
  JudgeOne(plan, 12, 0.5, &j);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_EQ(j.reasons[0],
            "gx: bias_instability 12 ± 0.5 deg/h above high limit 10 deg/h (w = 1, guarded "
            "rejection)");
  JudgeOne(plan, 9, 0.5, &j);
  EXPECT_TRUE(j.reasons.empty());
}

// FAIL beats INCONCLUSIVE beats MARGINAL beats PASS; every one but PASS gives
// a reason, in measurement order.
TEST(DecisionRuleTest, VerdictPrecedence) {
  pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, false, true);
  plan.mutable_limits(0)->set_marginal_high(8);
  plan.add_axes()->set_name("gy");
  plan.mutable_axes(1)->set_kind(pb::GYRO);
  plan.add_axes()->set_name("gz");
  plan.mutable_axes(2)->set_kind(pb::GYRO);
  const std::vector<AxisDesc> axes = {{"gx", pb::GYRO}, {"gy", pb::GYRO}, {"gz", pb::GYRO}};
  auto judge = [&](double x, double y, double z) {
    std::vector<pb::Measurement> ms = {M("gx", "bias_instability", x, "deg/h"),
                                       M("gy", "bias_instability", y, "deg/h"),
                                       M("gz", "bias_instability", z, "deg/h")};
    for (pb::Measurement& m : ms) m.set_uncertainty(0.5);
    return Judge(plan, axes, &ms);
  };
  EXPECT_EQ(judge(5, 5, 5).verdict, pb::PASS);
  EXPECT_EQ(judge(5, 8.5, 5).verdict, pb::MARGINAL);
  Judgement j = judge(9.5, 8.5, 5);
  EXPECT_EQ(j.verdict, pb::INCONCLUSIVE);
  ASSERT_EQ(j.reasons.size(), 2u);
  EXPECT_EQ(j.reasons[0].rfind("gx: ", 0), 0u) << j.reasons[0];
  EXPECT_NE(j.reasons[0].find("inconclusive (guarded)"), std::string::npos) << j.reasons[0];
  EXPECT_EQ(j.reasons[1], "gy: bias_instability 8.5 ± 0.5 deg/h marginal (above 8 deg/h)");
  j = judge(9.5, 8.5, 12);
  EXPECT_EQ(j.verdict, pb::FAIL);
  EXPECT_EQ(j.reasons.size(), 3u);
}

TEST(JudgeTest, OutcomeAndRuleNames) {
  EXPECT_STREQ(OutcomeName(pb::OUTCOME_UNSET), "-");
  EXPECT_STREQ(OutcomeName(pb::PASS), "PASS");
  EXPECT_STREQ(OutcomeName(pb::MARGINAL), "MARGINAL");
  EXPECT_STREQ(OutcomeName(pb::FAIL), "FAIL");
  EXPECT_STREQ(OutcomeName(pb::INCONCLUSIVE), "INCONCLUSIVE");
  EXPECT_STREQ(OutcomeName(pb::ABORTED), "ABORTED");
  EXPECT_STREQ(OutcomeName(pb::ERROR), "ERROR");
  EXPECT_STREQ(DecisionRuleName(pb::Limit::GUARDED_ACCEPTANCE), "guarded acceptance");
}

// An unjudged measurement records no rule.
TEST(JudgeTest, UnjudgedMeasurementsRecordNoRule) {
  const pb::TestPlan plan = RulePlan(pb::Limit::GUARDED, 0, false, true);
  std::vector<pb::Measurement> ms = {M("gx", "tau_at_minimum", 3, "s")};
  ms[0].set_uncertainty(1);
  Judge(plan, {{"gx", pb::GYRO}}, &ms);
  EXPECT_EQ(ms[0].outcome(), pb::OUTCOME_UNSET);
  EXPECT_EQ(ms[0].decision_rule(), pb::Limit::RULE_DEFAULT);
  EXPECT_FALSE(ms[0].has_guard_band());
}

}  // namespace
}  // namespace imuqual::judge

namespace imuqual::judge {
namespace {

// An interim look says "pending" where more data can still move a value
// across a bound, and keeps every other outcome: the "fail?" of a vg700
// unit at 26 of 61 minutes (its curve minimum at its last point, 153 s,
// against tau_at_minimum <= 100) that later passed.
TEST(JudgeInterimTest, WhatMoreDataCanStillMoveAcrossABoundIsPending) {
  pb::TestPlan plan = Plan();
  plan.set_min_duration_s(0);  // as the analysis's interim plan: the length is judged at the end
  auto with_u = [](pb::Measurement m, double u) {
    m.set_uncertainty(u);
    return m;
  };
  std::vector<pb::Measurement> ms = {
      with_u(M("x", "bias_instability", 19.0, "deg/h"), 1.0),  // within 2 u of 20: pending
      with_u(M("y", "bias_instability", 6.0, "deg/h"), 1.0),   // well inside 10: pass
      M("x", "tau_at_minimum", 153.0, "s"),                     // unresolved: pending
      with_u(M("y", "tau_at_minimum", 300.0, "s"), 10.0),       // resolved, far out: fail
      M("", "gap_fraction", 0.0, "1")};
  ms[2].set_qualifier(pb::MINIMUM_NOT_RESOLVED);
  std::vector<pb::Measurement> final_ms = ms;
  const Judgement interim = JudgeInterim(plan, kAxes, &ms);
  EXPECT_EQ(ms[0].outcome(), pb::INCONCLUSIVE);
  EXPECT_EQ(ms[1].outcome(), pb::PASS);
  EXPECT_EQ(ms[2].outcome(), pb::INCONCLUSIVE);
  EXPECT_EQ(ms[3].outcome(), pb::FAIL);
  EXPECT_EQ(ms[4].outcome(), pb::PASS);
  EXPECT_EQ(interim.verdict, pb::FAIL);
  ASSERT_EQ(interim.reasons.size(), 3u);
  EXPECT_EQ(interim.reasons[0],
            "pending: x: bias_instability 19 ± 1 deg/h, within 2 u of the high limit 20 deg/h");
  EXPECT_EQ(interim.reasons[1],
            "pending: x: tau_at_minimum 153 s, the curve's minimum is its last point so far, not "
            "resolved yet");
  EXPECT_NE(interim.reasons[2].find("y: tau_at_minimum 300"), std::string::npos)
      << interim.reasons[2];
  // Without the failing axis the unit is pending, not "fail?".
  std::vector<pb::Measurement> x_only = {ms[0], ms[2], ms[4]};
  EXPECT_EQ(JudgeInterim(plan, {{"x", pb::GYRO}}, &x_only).verdict, pb::INCONCLUSIVE);
  // The final judgement is not touched by any of it.
  Judge(plan, kAxes, &final_ms);
  EXPECT_EQ(final_ms[0].outcome(), pb::MARGINAL);
  EXPECT_EQ(final_ms[2].outcome(), pb::FAIL);
}

}  // namespace
}  // namespace imuqual::judge
