#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "offline/plan_soak_command.h"
#include "store/archive.h"
#include "tests/test_util.h"

namespace imuqual::offline {
namespace {

// A one-axis plan limiting the angle random walk only.
constexpr char kPlan[] = R"pb(
  name: "arw-only"
  axes { name: "x" kind: GYRO }
  nominal_rate_hz: 50
  min_duration_s: 600
  limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 unit: "deg/sqrt(h)" }
  early_decision { risk: 0.01 min_duration_s: 60 look_period_s: 30 })pb";

// This process's scratch directory, removed when the test binary exits.
const testing::TempDir& Scratch() {
  static const testing::TempDir dir("plan_soak");
  return dir;
}

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = Scratch().path(name);
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
  auto records =
      SimulateSoaks(*plan, {WhiteNoiseUnit(0.2), WhiteNoiseUnit(1.5)}, {"good", "bad"}, 6, 7, 2);
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
  // A model file that is wrong is bad input: exit 2, as a bad option.
  o.model = Write("other-axis.csv", "axis,name,value,unit\ny,white_noise,0.2,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 2);
  o.model = Write("bad-value.csv", "axis,name,value,unit\nx,white_noise,abc,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 2);
  o.model = Write("bad-unit.csv", "axis,name,value,unit\nx,white_noise,0.2,deg/h\n");
  EXPECT_EQ(PlanSoakCommand(o), 2);
  o.model = Write("no-header.csv", "x,white_noise,0.2,deg/sqrt(h)\n");
  EXPECT_EQ(PlanSoakCommand(o), 2);
  o.profile = "vg700";  // two sources
  EXPECT_EQ(PlanSoakCommand(o), 2);
}

// A past lot's archived noise models: each unit's latest run, units without
// an adequate model on every plan axis left out and counted.
TEST(PlanSoak, LotUsesEachUnitsLatestAdequateModel) {
  const std::string db = Scratch().path("lot.db");
  {
    auto archive = store::Archive::Open(db, store::Archive::Mode::kWrite);
    ASSERT_TRUE(archive.ok()) << archive.status().ToString();
    // serial, start, white noise (deg/sqrt(h); NaN: no model), adequate.
    struct Run {
      const char* serial;
      int64_t start;
      double arw;
      bool adequate;
    };
    for (const Run& r : {Run{"GOOD", 1000, 0.9, true},  // its first run: superseded by the retest
                         Run{"GOOD", 2000, 0.2, true}, Run{"NOFIT", 1500, NAN, true},
                         Run{"BADFIT", 1600, 0.2, false}}) {
      store::RunInfo info;
      info.run_id = std::string(r.serial) + "-" + std::to_string(r.start);
      info.serial = r.serial;
      info.lot = "PAST";
      info.start_utime = r.start;
      info.nominal_rate_hz = 50;
      info.axes = {{"x", pb::GYRO}};
      info.state = "complete";
      auto key = (*archive)->UpsertRun(info);
      ASSERT_TRUE(key.ok()) << key.status().ToString();
      store::ResultRecord result;
      result.verdict = "PASS";
      result.result_utime = r.start + 1;
      if (!std::isnan(r.arw)) {
        pb::Measurement white;
        white.set_axis("x");
        white.set_name(std::string(judge::kModelParameterPrefix) + "white_noise");
        white.set_value(r.arw);
        white.set_unit("deg/sqrt(h)");
        result.measurements.push_back(white);
        pb::Measurement p;
        p.set_axis("x");
        p.set_name(std::string(judge::kNoiseModelPValue));
        p.set_value(r.adequate ? 0.4 : 1e-6);
        if (!r.adequate) p.set_note(std::string(judge::kInadequateModelMark) + ": J test");
        result.measurements.push_back(p);
      }
      ASSERT_TRUE((*archive)->PutResult(*key, result).ok());
    }
  }
  PlanSoakOptions o;
  o.plan = Write("lot-plan.textproto", kPlan);
  o.lot = "PAST";
  o.db = db;
  o.records = 4;
  ::testing::internal::CaptureStdout();
  const int code = PlanSoakCommand(o);
  const std::string out = ::testing::internal::GetCapturedStdout();
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("lot PAST: noise models of 1 units (2 without an adequate model on every "
                     "axis: not used)"),
            std::string::npos)
      << out;
  // GOOD's latest model (0.2 deg/sqrt(h), a third of the limit) is decided
  // PASS in every record; its superseded first run (0.9) would have failed.
  EXPECT_NE(out.find("decided    4 of 4 by the horizon (100.0 %): 4 PASS, 0 FAIL"),
            std::string::npos)
      << out;
  // A lot the archive does not hold: one line naming it.
  o.lot = "NO-SUCH-LOT";
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(PlanSoakCommand(o), 2);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("NO-SUCH-LOT"), std::string::npos) << err;
}

}  // namespace
}  // namespace imuqual::offline
