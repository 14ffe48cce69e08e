#include "analyze/judge/early_decision.h"

#include <gtest/gtest.h>

#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <random>

#include "analyze/judge/plan.h"

namespace imuqual::judge {
namespace {

std::vector<double> EvenFractions(int looks, double first) {
  std::vector<double> f;
  for (int k = 0; k < looks; ++k) f.push_back(first + (1.0 - first) * k / looks);
  return f;
}

TEST(SequentialBounds, OneLookIsTheNormalQuantileOfTheSpentAlpha) {
  const std::vector<double> f = {0.4};
  auto b = SequentialBounds(f, 0.01);
  ASSERT_TRUE(b.ok());
  const double p = SpentAlpha(0.4, 0.01);
  const double z = boost::math::quantile(boost::math::complement(boost::math::normal(), p));
  EXPECT_NEAR((*b)[0], z, 1e-6);
}

TEST(SequentialBounds, SpendExactlyTheSpendingFunction) {
  const std::vector<double> f = EvenFractions(40, 1.0 / 6);
  for (double alpha : {0.05, 0.01, 0.001}) {
    auto b = SequentialBounds(f, alpha);
    ASSERT_TRUE(b.ok());
    EXPECT_NEAR(CrossingProbability(f, *b), SpentAlpha(f.back(), alpha), 1e-3 * alpha);
    // Later looks need more evidence per look than a single test would, but
    // far less than a Bonferroni split over the looks.
    const double bonferroni =
        boost::math::quantile(boost::math::complement(boost::math::normal(), alpha / f.size()));
    for (double z : *b) EXPECT_LT(z, bonferroni + 1e-9);
  }
}

// The boundaries hold their level for a Brownian statistic: measured by
// simulation, independent of the recursion.
TEST(SequentialBounds, MonteCarloCrossingRateIsTheSpentAlpha) {
  const std::vector<double> f = EvenFractions(30, 0.2);
  const double alpha = 0.05;
  auto b = SequentialBounds(f, alpha);
  ASSERT_TRUE(b.ok());
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> g;
  const int paths = 40000;
  int crossed = 0;
  for (int p = 0; p < paths; ++p) {
    double s = 0, prev = 0;
    for (size_t k = 0; k < f.size(); ++k) {
      s += std::sqrt(f[k] - prev) * g(rng);
      prev = f[k];
      if (s / std::sqrt(f[k]) >= (*b)[k]) {
        ++crossed;
        break;
      }
    }
  }
  const double expected = SpentAlpha(f.back(), alpha);
  const double rate = static_cast<double>(crossed) / paths;
  EXPECT_NEAR(rate, expected, 4 * std::sqrt(expected * (1 - expected) / paths))
      << "crossed " << crossed << " of " << paths;
}

TEST(SequentialBounds, RejectsBadInput) {
  const std::vector<double> bad = {0.5, 0.4};
  EXPECT_FALSE(SequentialBounds(bad, 0.01).ok());
  const std::vector<double> good = {0.5};
  EXPECT_FALSE(SequentialBounds(good, 0.7).ok());
  EXPECT_FALSE(SequentialBounds(std::vector<double>{}, 0.01).ok());
}

// Curve evidence with a sign: positive, the truth above the bound.
BoundEvidence Signed(std::function<double(double)> f) {
  return [f](const pb::Measurement&, double bound) {
    SideEvidence e;
    e.above = f(bound);
    e.below = -f(bound);
    e.above_source = e.below_source = "curve evidence";
    return e;
  };
}

pb::TestPlan Plan(const std::string& extra = "") {
  auto plan = ParsePlanText(R"(
    name: "t" axes { name: "x" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 3600
    limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
    limits { measurement: "tau_at_minimum" axis_kind: GYRO low: 2 high: 120 unit: "s" }
    limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
    early_decision { risk: 0.01 min_duration_s: 600 })" +
                                extra,
                            "t");
  EXPECT_TRUE(plan.ok()) << plan.status().message();
  return *plan;
}

pb::Measurement M(const std::string& name, double value, double u, const pb::TestPlan& plan,
                  pb::Qualifier q = pb::MEASURED) {
  pb::Measurement m;
  m.set_axis("x");
  m.set_name(name);
  m.set_value(value);
  m.set_unit(name == "tau_at_minimum" ? "s" : "deg/h");
  if (u > 0) m.set_uncertainty(u);
  m.set_qualifier(q);
  AxisDesc axis{"x", pb::GYRO};
  const pb::Limit* limit = FindLimit(plan, name, &axis);
  if (limit) {
    if (limit->has_low()) m.set_low(limit->low());
    if (limit->has_high()) m.set_high(limit->high());
    if (limit->has_marginal_high()) m.set_marginal_high(limit->marginal_high());
  }
  return m;
}

pb::Measurement Gaps(double value) {
  pb::Measurement m;
  m.set_name("gap_fraction");
  m.set_value(value);
  m.set_unit("1");
  m.set_high(0.001);
  return m;
}

TEST(LookSchedule, EveryPeriodFromTheMinimumDurationBeforeTheHorizon) {
  const LookSchedule s = MakeLookSchedule(Plan());
  ASSERT_EQ(s.times_s.size(), 50u);  // 600, 660, ..., 3540
  EXPECT_EQ(s.times_s.front(), 600);
  EXPECT_EQ(s.times_s.back(), 3540);
  EXPECT_DOUBLE_EQ(s.fractions.front(), 600.0 / 3600);
  EXPECT_TRUE(MakeLookSchedule(pb::TestPlan()).times_s.empty());
}

TEST(PlanValidation, EarlyDecisionFieldsAreCheckedWithTheirLine) {
  auto bad = ParsePlanText(
      "name: \"t\" axes { name: \"x\" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 600\n"
      "early_decision {\n risk: 0.5\n min_duration_s: 60 }\n",
      "p.textproto");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("early_decision.risk"), std::string::npos)
      << bad.status().message();
  auto short_horizon = ParsePlanText(
      "name: \"t\" axes { name: \"x\" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 600\n"
      "early_decision { risk: 0.01 min_duration_s: 900 }\n",
      "p.textproto");
  ASSERT_FALSE(short_horizon.ok());
  EXPECT_NE(short_horizon.status().message().find("horizon"), std::string::npos);
  // Looks beyond kMaxLooks are refused; a plan that got past the check
  // (forged on the bus) gets the first kMaxLooks, not an endless schedule.
  auto too_many = ParsePlanText(
      "name: \"t\" axes { name: \"x\" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 600\n"
      "early_decision { risk: 0.01 min_duration_s: 1 look_period_s: 0.5 }\n",
      "p.textproto");
  ASSERT_FALSE(too_many.ok());
  EXPECT_NE(too_many.status().message().find("look_period_s"), std::string::npos)
      << too_many.status().message();
  pb::TestPlan forged = Plan();
  forged.mutable_early_decision()->set_min_duration_s(1);
  forged.mutable_early_decision()->set_look_period_s(1e-9);
  forged.mutable_early_decision()->set_horizon_s(1e6);
  EXPECT_EQ(MakeLookSchedule(forged).times_s.size(), static_cast<size_t>(kMaxLooks));
}

TEST(EarlyDecider, ClearlyGoodUnitPassesAtTheFirstLook) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  ASSERT_TRUE(d.ok());
  std::vector<pb::Measurement> ms = {M("bias_instability", 9.0, 0.8, plan),
                                     M("tau_at_minimum", 12, 3, plan), Gaps(0.01)};
  int asked = 0;
  const Look look = d->Evaluate(
      0, ms,
      [&](const std::string& axis) {
        EXPECT_EQ(axis, "x");
        ++asked;
        return true;
      },
      Signed([](double bound) { return bound < 12 ? 9.0 : -9.0; }));
  EXPECT_EQ(look.unit, Decision::kPass);
  EXPECT_EQ(asked, 1);  // once per axis and look
  EXPECT_EQ(d->decided_look(), 0);
  EXPECT_EQ(d->decided_time_s(), 600);
  ASSERT_EQ(look.entries.size(), 2u);  // the gap fraction does not decide
  EXPECT_GT(look.z, 2.5);
}

TEST(EarlyDecider, MinimumAboveTheLimitFailsOnlyOnceSettled) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  ASSERT_TRUE(d.ok());
  std::vector<pb::Measurement> ms = {M("bias_instability", 30.0, 1.0, plan),
                                     M("tau_at_minimum", 12, 3, plan)};
  EXPECT_EQ(d->Evaluate(0, ms, [](const std::string&) { return false; }).unit, Decision::kPending);
  EXPECT_EQ(d->Evaluate(1, ms, [](const std::string&) { return true; }).unit, Decision::kFail);
  // Final.
  EXPECT_EQ(d->Evaluate(2, {M("bias_instability", 5.0, 1.0, plan)}, nullptr).unit, Decision::kFail);
}

TEST(EarlyDecider, UnresolvedMinimumConfirmsOnlyBelow) {
  const pb::TestPlan plan = Plan();
  auto high = EarlyDecider::Create(plan);
  std::vector<pb::Measurement> ms = {
      M("bias_instability", 30.0, 1.0, plan, pb::MINIMUM_NOT_RESOLVED),
      M("tau_at_minimum", 12, 3, plan, pb::MINIMUM_NOT_RESOLVED)};
  const Look look = high->Evaluate(0, ms, [](const std::string&) { return true; });
  EXPECT_EQ(look.unit, Decision::kPending);
  EXPECT_EQ(high->MeasurementDecision("x", "bias_instability"), Decision::kPending);
  // Low enough: the bias instability passes, the unresolved tau stays pending.
  auto low = EarlyDecider::Create(plan);
  ms[0].set_value(5.0);
  EXPECT_EQ(low->Evaluate(0, ms, [](const std::string&) { return true; }).unit, Decision::kPending);
  EXPECT_EQ(low->MeasurementDecision("x", "bias_instability"), Decision::kPass);
  EXPECT_EQ(low->MeasurementDecision("x", "tau_at_minimum"), Decision::kPending);
}

TEST(EarlyDecider, ValueAtTheLimitStaysPendingAtEveryLook) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  for (int k = 0; k < static_cast<int>(d->schedule().times_s.size()); ++k) {
    // The uncertainty shrinks as the record grows, the value stays on the limit.
    const double u = 2.0 * std::sqrt(600.0 / d->schedule().times_s[k]);
    const Look look = d->Evaluate(k, {M("bias_instability", 20.0, u, plan)},
                                  [](const std::string&) { return true; });
    EXPECT_EQ(look.unit, Decision::kPending) << "look " << k;
  }
  EXPECT_EQ(d->decided_look(), -1);
}

TEST(EarlyDecider, MarginalBandIsAFlagNotADecision) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  const auto settled = [](const std::string&) { return true; };
  // 17.5 +- 0.3: inside 20 by 8 u: decided PASS although 16 is only 5 u away.
  EXPECT_EQ(d->Evaluate(0, {M("bias_instability", 17.5, 0.3, plan)}, settled).unit,
            Decision::kPass);
}

TEST(EarlyDecider, FlagsAgreeingWithTheFullLengthReadingCanMakeAUnitWait) {
  pb::TestPlan plan = Plan();
  plan.mutable_early_decision()->set_marginal_flags(pb::EarlyDecision::FLAGS_AGREE_FULL_LENGTH);
  const auto settled = [](const std::string&) { return true; };
  // 17.5 +- 0.8 at f = 1/6: 1.5 from 16, less than 2.33 x 0.8 x sqrt(5/6) = 1.70.
  auto near = EarlyDecider::Create(plan);
  const Look wait = near->Evaluate(0, {M("bias_instability", 17.5, 0.8, plan)}, settled);
  EXPECT_EQ(wait.unit, Decision::kPending);
  EXPECT_NE(wait.note.find("marginal flag of x: bias_instability"), std::string::npos) << wait.note;
  // Half-way through the soak the same reading is settled (1.5 >= 2.33 x 0.8 x 0.71 = 1.32 at f ~
  // 0.5).
  const Look later = near->Evaluate(20, {M("bias_instability", 17.5, 0.8, plan)}, settled);
  EXPECT_EQ(later.unit, Decision::kPass);  // MARGINAL by its flag, read on the record
  // Clearly in the band: decided at once.
  auto clear = EarlyDecider::Create(plan);
  EXPECT_EQ(clear->Evaluate(0, {M("bias_instability", 17.5, 0.3, plan)}, settled).unit,
            Decision::kPass);
}

// tau_at_minimum is decided by the curve's evidence; "below" a bound needs a
// settled minimum (more data can only move it to longer taus), "above" not.
TEST(EarlyDecider, TauAtMinimumFollowsTheCurveEvidence) {
  const pb::TestPlan plan = Plan();
  const pb::Measurement tau = M("tau_at_minimum", 12, 0, plan);
  // The minimum is confirmed above 2 s and below 120 s.
  const auto inside = Signed([](double bound) { return bound < 12 ? 9.0 : -9.0; });
  auto unsettled = EarlyDecider::Create(plan);
  EXPECT_EQ(unsettled
                ->Evaluate(
                    0, {tau}, [](const std::string&) { return false; }, inside)
                .unit,
            Decision::kPending);
  auto settled = EarlyDecider::Create(plan);
  const Look look = settled->Evaluate(
      0, {tau}, [](const std::string&) { return true; }, inside);
  EXPECT_EQ(look.unit, Decision::kPass);
  EXPECT_NE(look.entries[0].why.find("curve evidence"), std::string::npos) << look.entries[0].why;
  // Confirmed above 120 s: a FAIL even before the minimum is settled.
  auto beyond = EarlyDecider::Create(plan);
  const auto above = Signed([](double) { return 9.0; });
  EXPECT_EQ(beyond
                ->Evaluate(
                    0, {M("tau_at_minimum", 300, 0, plan)},
                    [](const std::string&) { return false; }, above)
                .unit,
            Decision::kFail);
  // Weak evidence: pending.
  auto weak = EarlyDecider::Create(plan);
  const auto little = Signed([](double bound) { return bound < 12 ? 1.0 : -1.0; });
  EXPECT_EQ(weak->Evaluate(
                    0, {tau}, [](const std::string&) { return true; }, little)
                .unit,
            Decision::kPending);
}

TEST(EarlyDecider, NoUncertaintyOrNotMeasurableStaysPending) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  pb::Measurement none = M("bias_instability", 5.0, 0, plan);
  pb::Measurement nan = M("tau_at_minimum", std::nan(""), 1, plan, pb::NOT_MEASURABLE);
  const Look look = d->Evaluate(0, {none, nan}, [](const std::string&) { return true; });
  EXPECT_EQ(look.unit, Decision::kPending);
  EXPECT_NE(look.entries[0].why.find("no uncertainty to decide on"), std::string::npos)
      << look.entries[0].why;
  EXPECT_EQ(look.entries[1].why, "not measured yet");
}

TEST(JudgeDecided, DecisionsBecomeOutcomesAndTheShortRecordIsLongEnough) {
  const pb::TestPlan plan = Plan();
  auto d = EarlyDecider::Create(plan);
  const auto settled = [](const std::string&) { return true; };
  std::vector<pb::Measurement> look = {M("bias_instability", 17.5, 0.3, plan),
                                       M("tau_at_minimum", 12, 2, plan)};
  const auto inside = Signed([](double bound) { return bound < 12 ? 9.0 : -9.0; });
  ASSERT_EQ(d->Evaluate(0, look, settled, inside).unit, Decision::kPass);
  // The final analysis of the decided record (600 s).
  std::vector<pb::Measurement> final = {M("bias_instability", 17.6, 0.3, plan),
                                        M("tau_at_minimum", 12, 2, plan), Gaps(0)};
  pb::Measurement duration;
  duration.set_name("duration");
  duration.set_value(600);
  duration.set_unit("s");
  final.push_back(duration);
  for (pb::Measurement& m : final) {
    m.clear_low();
    m.clear_high();
    m.clear_marginal_high();
  }
  const Judgement j = JudgeDecided(plan, {{"x", pb::GYRO}}, *d, &final);
  EXPECT_EQ(j.verdict, pb::MARGINAL);
  ASSERT_EQ(j.reasons.size(), 1u);
  EXPECT_NE(j.reasons[0].find("marginal"), std::string::npos) << j.reasons[0];
  EXPECT_NE(final[0].note().find("decided PASS at 600 s (look 1)"), std::string::npos)
      << final[0].note();
  // The flag says when it was read (FLAGS_AT_DECISION, the default), on the
  // record and in the reason.
  EXPECT_EQ(final[0].outcome(), pb::MARGINAL);
  EXPECT_NE(final[0].note().find("MARGINAL flag read at the decision (600 s)"), std::string::npos)
      << final[0].note();
  EXPECT_NE(j.reasons[0].find("MARGINAL flag read at the decision (600 s)"), std::string::npos)
      << j.reasons[0];
  EXPECT_EQ(final[1].note().find("MARGINAL flag"), std::string::npos) << final[1].note();
  EXPECT_EQ(final[3].outcome(), pb::PASS);  // 600 s >= early_decision.min_duration_s
  // Without a decision the plan's own minimum duration applies.
  auto pending = EarlyDecider::Create(plan);
  std::vector<pb::Measurement> again = final;
  for (pb::Measurement& m : again) m.clear_note();
  EXPECT_EQ(JudgeDecided(plan, {{"x", pb::GYRO}}, *pending, &again).verdict, pb::FAIL);
  // A unit pending at every look has the full-length verdict and says so.
  EXPECT_EQ(again[0].outcome(), pb::MARGINAL);
  EXPECT_NE(again[0].note().find("MARGINAL flag read on the full-length record"), std::string::npos)
      << again[0].note();
}

}  // namespace
}  // namespace imuqual::judge
