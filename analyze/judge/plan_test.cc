#include "analyze/judge/plan.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/strings.h"

namespace imuqual::judge {
namespace {

constexpr char kGood[] = R"pb(
name: "t"
axes { name: "x" kind: GYRO }
axes { name: "ax" kind: ACCEL }
nominal_rate_hz: 200
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "bias_instability" axis_kind: ACCEL high: 50 unit: "ug" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
)pb";

// Returns the error message of parsing `text` ("" if it parses).
std::string ErrorOf(const std::string& text) {
  auto plan = ParsePlanText(text, "p.textproto");
  return plan.ok() ? "" : plan.status().message();
}

TEST(PlanTest, ParsesAGoodPlan) {
  auto plan = ParsePlanText(kGood, "good");
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  EXPECT_EQ(plan->axes_size(), 2);
  EXPECT_EQ(plan->limits(0).high(), 20);
  EXPECT_EQ(PlanStopRule(*plan), "bins9");
}

TEST(PlanTest, SyntaxErrorNamesLineAndField) {
  const std::string err = ErrorOf("name: \"t\"\nnominal_rate_hz: 100\nbias_instabilty: 3\n");
  EXPECT_EQ(err.rfind("p.textproto:3:", 0), 0u) << err;
  EXPECT_NE(err.find("bias_instabilty"), std::string::npos) << err;
}

TEST(PlanTest, WrongUnitNamesLineFieldAndRightUnit) {
  const std::string err = ErrorOf(
      "nominal_rate_hz: 100\n"
      "limits {\n"
      "  measurement: \"bias_instability\"\n"
      "  axis_kind: GYRO\n"
      "  high: 20\n"
      "  unit: \"deg/hr\"\n"
      "}\n");
  EXPECT_EQ(err, "p.textproto:6: limits[0].unit: 'deg/hr' is not the unit of bias_instability "
                 "on gyro axes (deg/h)");
}

TEST(PlanTest, RejectsBadPlans) {
  struct Case {
    const char* text;
    const char* expect;  // substring of the error
  };
  const Case cases[] = {
      {"nominal_rate_hz: 0", "nominal_rate_hz: must be a positive rate"},
      {"nominal_rate_hz: 100 warmup_s: -1", "warmup_s"},
      {"nominal_rate_hz: 100 axes { name: \"x\" kind: GYRO } axes { name: \"x\" kind: GYRO }",
       "axes[1].name: duplicate axis 'x'"},
      {"nominal_rate_hz: 100 axes { name: \"x\" }", "axes[0].kind"},
      {"nominal_rate_hz: 100 axes { name: \"a b\" kind: GYRO }", "axes[0].name"},
      {"nominal_rate_hz: 100 limits { measurement: \"nope\" high: 1 unit: \"s\" }",
       "unknown measurement 'nope'"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" unit: \"s\" }",
       "needs low, high or both"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" low: 5 high: 2 unit: \"s\" }",
       "low 5 is above high 2"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" high: 5 marginal_high: 6 "
       "unit: \"s\" }",
       "marginal_high: must lie within"},
      {"nominal_rate_hz: 100 limits { measurement: \"bias_instability\" high: 5 unit: \"deg/h\" }",
       "set axis_kind"},
      {"nominal_rate_hz: 100 limits { measurement: \"angle_random_walk\" axis_kind: ACCEL high: 5 "
       "unit: \"deg/sqrt(h)\" }",
       "not defined on accelerometer axes"},
      {"nominal_rate_hz: 100 limits { measurement: \"duration\" low: 5 unit: \"s\" axes: \"q\" }",
       "no axis named 'q'"},
      {"nominal_rate_hz: 100 stop_rule: \"bins8\"", "stop_rule"},
      {"nominal_rate_hz: 100 grid { kind: EXPLICIT }", "grid.tau_s"},
      {"nominal_rate_hz: 100 grid { kind: LOG_DENSE points_per_decade: 0 }",
       "grid.points_per_decade"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" high: 5 unit: \"s\" "
       "decision_rule: GUARDED guard_k: 0 }",
       "limits[0].guard_k: must be a finite number > 0"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" high: 5 unit: \"s\" "
       "guard_k: -1 }",
       "limits[0].guard_k: must be a finite number > 0"},
      {"nominal_rate_hz: 100 limits { measurement: \"tau_at_minimum\" high: 5 unit: \"s\" "
       "guard_k: inf }",
       "limits[0].guard_k: must be a finite number > 0"},
      {"nominal_rate_hz: 100 default_guard_k: nan", "default_guard_k: must be a finite number > 0"},
      {"nominal_rate_hz: 100 default_guard_k: 0", "default_guard_k: must be a finite number > 0"},
      {"nominal_rate_hz: 100 noise_model_range { axis_kind: ACCEL min_tau_s: 2 reason: \"f\" }",
       "noise_model_range[0].min_tau_s: must be in [0, 1] s"},
      {"nominal_rate_hz: 100 noise_model_range { axis_kind: ACCEL min_tau_s: 0.2 }",
       "noise_model_range[0].reason: must say why"},
      {"nominal_rate_hz: 100 noise_model_range { axis_kind: ACCEL min_tau_s: 0.2 reason: \"f\" } "
       "noise_model_range { axis_kind: ACCEL min_tau_s: 0.1 reason: \"g\" }",
       "noise_model_range[1].axis_kind: a second range for ACCEL axes"},
      {"nominal_rate_hz: 100 sensor_range { full_scale: 300 }",
       "sensor_range[0].axis_kind: must be GYRO or ACCEL"},
      {"nominal_rate_hz: 100 sensor_range { axis_kind: GYRO }",
       "sensor_range[0].full_scale: must be a finite number > 0 (deg/s), got 0"},
      {"nominal_rate_hz: 100 sensor_range { axis_kind: ACCEL full_scale: inf }",
       "sensor_range[0].full_scale: must be a finite number > 0 (g)"},
      {"nominal_rate_hz: 100 sensor_range { axis_kind: GYRO full_scale: 300 } "
       "sensor_range { axis_kind: GYRO full_scale: 450 }",
       "sensor_range[1].axis_kind: a second range for GYRO axes"},
      {"nominal_rate_hz: 100 stationarity { false_alarm: 0.6 }",
       "stationarity.false_alarm: must be in [0.001, 0.5)"},
      {"nominal_rate_hz: 100 stationarity { bin_s: -1 }", "stationarity.bin_s: must be >= 0 s"},
      {"nominal_rate_hz: 100 stationarity { noise_level_tolerance: inf }",
       "stationarity.noise_level_tolerance: must be a factor's excess of at most 10"},
      {"nominal_rate_hz: 100 stationarity { reference_model { random_walk: 0.01 source: \"s\" } }",
       "stationarity.reference_model[0].axis_kind: must be GYRO or ACCEL"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO random_walk: 0.01 } "
       "}",
       "stationarity.reference_model[0].source: must say where the model comes from"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO source: \"s\" "
       "rate_ramp: 1e-6 } }",
       "stationarity.reference_model[0]: has no random term"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO source: \"s\" "
       "random_walk: -1 } }",
       "stationarity.reference_model[0].random_walk: must be a finite number >= 0, got -1"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO source: \"s\" "
       "random_walk: 0.01 gauss_markov { sigma: 0.01 } } }",
       "stationarity.reference_model[0].gauss_markov[0].correlation_time_s: must be a finite "
       "number > 0 s"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO source: \"s\" "
       "random_walk: 0.01 sinusoids { amplitude: 0.01 frequency_hz: 60 } } }",
       "stationarity.reference_model[0].sinusoids[0].frequency_hz: must be in (0, 50] Hz"},
      {"nominal_rate_hz: 100 stationarity { reference_model { axis_kind: GYRO source: \"s\" "
       "random_walk: 0.01 } reference_model { axis_kind: GYRO source: \"t\" random_walk: 0.02 } }",
       "stationarity.reference_model[1].axis_kind: a second model for GYRO axes"},
      {"nominal_rate_hz: 100 axes { name: \"x\" kind: GYRO } axes { name: \"ax\" kind: ACCEL } "
       "stationarity { on_event: EVENT_FAIL reference_model { axis_kind: GYRO source: \"s\" "
       "random_walk: 0.01 } }",
       "stationarity.on_event: EVENT_FAIL needs a reference_model for ACCEL axes (axis 'ax')"},
      {"nominal_rate_hz: 100 stationarity { on_event: EVENT_MARGINAL reference_model { axis_kind: "
       "GYRO source: \"s\" random_walk: 0.01 } }",
       "stationarity.on_event: EVENT_MARGINAL needs a reference_model for ACCEL axes (the plan "
       "names no axes"},
      {"nominal_rate_hz: 100 limits { measurement: \"stationarity_events\" high: 0 unit: \"1\" }",
       "limits[0].measurement: stationarity_events needs the plan's stationarity block"},
      {"nominal_rate_hz: 100 axes { name: \"x\" kind: GYRO } stationarity { } "
       "limits { measurement: \"stationarity_events\" high: 0 unit: \"1\" }",
       "limits[0]: a limit on stationarity_events needs a stationarity.reference_model for GYRO "
       "axes (axis 'x')"},
      {"nominal_rate_hz: 100 limits { measurement: \"judged_segment\" low: 600 unit: \"s\" }",
       "limits[0].measurement: judged_segment needs stationarity.on_event JUDGE_LONGEST_SEGMENT"},
      {"nominal_rate_hz: 100 axes { name: \"x\" kind: GYRO } stationarity { on_event: "
       "JUDGE_LONGEST_SEGMENT reference_model { axis_kind: GYRO source: \"s\" random_walk: 0.01 "
       "} } early_decision { risk: 0.01 min_duration_s: 600 }",
       "stationarity.on_event: JUDGE_LONGEST_SEGMENT cannot go with early_decision"},
      {"nominal_rate_hz: 100 min_duration_s: 600 stationarity { bin_s: 30 }",
       "stationarity.bin_s: 30 s leaves fewer than the 32 bins a scan needs in 600 s"},
      {"nominal_rate_hz: 100 min_duration_s: 36000 stationarity { bin_s: 1 }",
       "stationarity.bin_s: 1 s makes more than 2000 bins"},
  };
  for (const Case& c : cases) {
    const std::string err = ErrorOf(c.text);
    EXPECT_NE(err.find(c.expect), std::string::npos) << c.text << "\n -> " << err;
    EXPECT_EQ(err.rfind("p.textproto:", 0), 0u) << err;
  }
}

TEST(PlanTest, NoiseModelRangeOfAnAxisKindElseOfEveryKind) {
  auto plan = ParsePlanText(std::string(kGood) +
                                "noise_model_range { axis_kind: ACCEL min_tau_s: 0.16 "
                                "reason: \"decimation filter\" }\n",
                            "p");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  ASSERT_NE(NoiseModelRangeFor(*plan, pb::ACCEL), nullptr);
  EXPECT_EQ(NoiseModelRangeFor(*plan, pb::ACCEL)->min_tau_s(), 0.16);
  EXPECT_EQ(NoiseModelRangeFor(*plan, pb::GYRO), nullptr);
  plan->add_noise_model_range()->set_min_tau_s(0.04);  // every kind
  ASSERT_NE(NoiseModelRangeFor(*plan, pb::GYRO), nullptr);
  EXPECT_EQ(NoiseModelRangeFor(*plan, pb::GYRO)->min_tau_s(), 0.04);
  EXPECT_EQ(NoiseModelRangeFor(*plan, pb::ACCEL)->min_tau_s(), 0.16);
}

TEST(PlanTest, BuiltinPlansParse) {
  ASSERT_FALSE(BuiltinPlanNames().empty());
  for (const std::string& name : BuiltinPlanNames()) {
    auto plan = BuiltinPlan(name);
    EXPECT_TRUE(plan.ok()) << name << ": " << plan.status().ToString();
  }
  auto vg = BuiltinPlan("vg700ca");
  ASSERT_TRUE(vg.ok());
  EXPECT_EQ(vg->nominal_rate_hz(), 100);
  EXPECT_FALSE(BuiltinPlan("nope").ok());
}

TEST(PlanTest, ValidatePlanChecksDecodedPlans) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  EXPECT_TRUE(ValidatePlan(plan).ok());
  plan.set_min_duration_s(-5);
  EXPECT_EQ(ValidatePlan(plan).message(), "min_duration_s: must be >= 0 s");
  plan.set_min_duration_s(0);
  plan.set_default_decision_rule(static_cast<pb::Limit::DecisionRule>(9));
  EXPECT_EQ(ValidatePlan(plan).message(), "default_decision_rule: unknown decision rule 9");
}

// A guarded rule is fine on any measurement, with or without guard_k, and a
// plan-wide default.
TEST(PlanTest, AcceptsDecisionRules) {
  auto plan = ParsePlanText(
      R"pb(
        nominal_rate_hz: 100
        default_decision_rule: GUARDED_ACCEPTANCE
        default_guard_k: 1.5
        limits { measurement: "duration" low: 5 unit: "s" decision_rule: GUARDED }
        limits {
          measurement: "gap_fraction"
          high: 0.01
          unit: "1"
          decision_rule: GUARDED_REJECTION
          guard_k: 3
        }
        limits { measurement: "timing_jitter" high: 5 unit: "ms" decision_rule: SIMPLE }
      )pb",
      "p.textproto");
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  EXPECT_EQ(plan->limits(1).guard_k(), 3);
}

}  // namespace
}  // namespace imuqual::judge

namespace imuqual::judge {
namespace {

// A plan with several mistakes says all of them at once, each on its own
// line with its file, line and field, a mistyped name with the closest one.
TEST(PlanTest, EveryProblemAtOnceWithDidYouMean) {
  const std::string err = ErrorOf(
      "nominal_rate_hz: 100\n"
      "warmup_s: -5\n"
      "stop_rule: \"bins8\"\n"
      "axes { name: \"gx\" kind: GYRO }\n"
      "limits { measurement: \"bias_instabilty\" axis_kind: GYRO high: 20 unit: \"deg/h\" }\n"
      "limits { measurement: \"tau_at_minimum\" axes: \"gxx\" high: 100 unit: \"s\" }\n"
      "limits { measurement: \"angle_random_walk\" axis_kind: GYRO low: 3 high: 1 "
      "unit: \"deg/sqrt(h)\" }\n");
  const std::vector<std::string> lines = Split(err, '\n');
  ASSERT_EQ(lines.size(), 5u) << err;
  EXPECT_EQ(lines[0], "p.textproto:2: warmup_s: must be >= 0 s");
  EXPECT_EQ(lines[1].rfind("p.textproto:3: stop_rule: 'bins8' is not one of bins9, stable32, "
                           "none (did you mean bins9?)",
                           0),
            0u)
      << lines[1];
  EXPECT_EQ(lines[2].rfind("p.textproto:5: limits[0].measurement: unknown measurement "
                           "'bias_instabilty' (did you mean bias_instability?)",
                           0),
            0u)
      << lines[2];
  EXPECT_EQ(lines[3],
            "p.textproto:6: limits[1].axes: no axis named 'gxx' in the plan (did you mean gx?)");
  EXPECT_EQ(lines[4].rfind("p.textproto:7: limits[2]: low 3 is above high 1", 0), 0u) << lines[4];
  // A field the plan does not have: the one it has closest to it.
  EXPECT_EQ(ErrorOf("nominal_rate_hz: 100\nwarmup: 5\n"),
            "p.textproto:2:7: Message type \"imuqual.pb.TestPlan\" has no field named \"warmup\". "
            "(did you mean warmup_s?)");
}

TEST(PlanTest, SensorRangeIsInDegreesPerSecondOrInG) {
  auto plan = ParsePlanText(std::string(kGood) +
                                "sensor_range { axis_kind: GYRO full_scale: 300 }\n"
                                "sensor_range { axis_kind: ACCEL full_scale: 18 }\n",
                            "p");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  EXPECT_EQ(OutOfRangeAt(*plan, pb::GYRO), 300);                   // deg/s, as gyro samples
  EXPECT_DOUBLE_EQ(OutOfRangeAt(*plan, pb::ACCEL), 18 * 9.80665);  // m/s^2, as accel samples
  EXPECT_TRUE(std::isinf(OutOfRangeAt(pb::TestPlan(), pb::GYRO)));
}

}  // namespace
}  // namespace imuqual::judge
