#include "store/cli/plan_soak_command.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "analyze/judge/plan.h"

namespace imuqual::cli {
namespace {

// A one-axis plan limiting the angle random walk only.
constexpr char kPlan[] = R"pb(
name: "arw-only" axes { name: "x" kind: GYRO } nominal_rate_hz: 50 min_duration_s: 600
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 unit: "deg/sqrt(h)" }
early_decision { risk: 0.01 min_duration_s: 60 look_period_s: 30 })pb";

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + std::to_string(::getpid()) + "-" + name;
  std::ofstream(path) << text;
  return path;
}

pb::SimTruth WhiteNoiseUnit(double arw_deg_rt_h) {
  pb::SimTruth t;
  pb::AxisTruth* a = t.add_axes();
  a->set_axis("x");
  a->set_random_walk(arw_deg_rt_h / 60.0);
  return t;
}

TEST(PlanSoak, ClearlyGoodAndClearlyBadUnitsAreDecidedAtTheFirstLook) {
  auto plan = judge::ParsePlanText(kPlan, "test");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  auto records = SimulateSoaks(*plan, {WhiteNoiseUnit(0.2), WhiteNoiseUnit(1.5)},
                               {"good", "bad"}, 6, 7, 2);
  ASSERT_TRUE(records.ok()) << records.status().message();
  for (const SoakRecord& r : *records) {
    EXPECT_TRUE(r.decided) << r.unit;
    EXPECT_EQ(r.fail, r.unit == "bad");
    EXPECT_EQ(r.decided_at_s, 60) << r.unit;
  }
}

TEST(PlanSoak, UnitAtTheLimitStaysPendingToTheHorizon) {
  auto plan = judge::ParsePlanText(kPlan, "test");
  ASSERT_TRUE(plan.ok());
  auto records = SimulateSoaks(*plan, {WhiteNoiseUnit(0.6)}, {"edge"}, 4, 3, 2);
  ASSERT_TRUE(records.ok());
  int pending = 0;
  for (const SoakRecord& r : *records) {
    if (!r.decided) {
      ++pending;
      EXPECT_EQ(r.decided_at_s, 600);
      ASSERT_EQ(r.pending.size(), 1u);
      EXPECT_EQ(r.pending[0], "x angle_random_walk");
    }
  }
  EXPECT_GE(pending, 3);  // a 1 % risk split over looks: deciding one would be a rare error
}

TEST(PlanSoak, PlanWithoutEarlyDecisionIsRefused) {
  auto plan = judge::ParsePlanText(
      "name: \"p\" axes { name: \"x\" kind: GYRO } nominal_rate_hz: 50 min_duration_s: 600",
      "test");
  ASSERT_TRUE(plan.ok());
  auto records = SimulateSoaks(*plan, {WhiteNoiseUnit(0.2)}, {"u"}, 1, 1, 1);
  ASSERT_FALSE(records.ok());
  EXPECT_NE(records.status().message().find("no early_decision"), std::string::npos);
}

TEST(PlanSoak, ModelFileRunsAndBadFilesNameTheirProblem) {
  const std::string plan = Write("plan.textproto", kPlan);
  PlanSoakOptions o;
  o.plan = plan;
  o.records = 2;
  o.model = Write("good.csv", "axis,name,value,unit\nx,model_white_noise,0.2,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 0);
  o.model = Write("other-axis.csv", "axis,name,value,unit\ny,white_noise,0.2,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 1);
  o.model = Write("bad-value.csv", "axis,name,value,unit\nx,white_noise,abc,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 1);
  o.model = Write("bad-unit.csv", "axis,name,value,unit\nx,white_noise,0.2,deg/h\n");
  EXPECT_EQ(PlanSoakCommand(o), 1);
  o.model = Write("no-header.csv", "x,white_noise,0.2,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 1);
  o.profile = "vg700";  // two sources
  EXPECT_EQ(PlanSoakCommand(o), 2);
}

}  // namespace
}  // namespace imuqual::cli
