#include "analyze/judge/run_admission.h"

#include <gtest/gtest.h>

#include "analyze/judge/plan.h"
#include "common/text_util.h"

namespace imuqual::judge {
namespace {

pb::TestPlan Plan(const std::string& name) {
  auto plan = BuiltinPlan(name);
  EXPECT_TRUE(plan.ok()) << plan.status().message();
  return *plan;
}

// A run as acquire announces it: the plan completed from a 3-gyro, 100 Hz source.
imuqual::run_t Announced(const pb::TestPlan& plan) {
  std::vector<pb::Axis> axes(3);
  const char* names[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    axes[i].set_name(names[i]);
    axes[i].set_kind(pb::GYRO);
  }
  imuqual::run_t r{};
  r.run_id = "20261128T010000Z-SN-7";
  r.unit_serial = "SN-7";
  r.lot = "LOT-1";
  r.station = "bench-A";
  r.slot = "A3";
  r.operator_name = "Ana Müller";
  r.source = "sim:vg700";
  const std::string bytes = CompletedPlan(plan, 100.0, axes).SerializeAsString();
  r.plan_size = static_cast<int32_t>(bytes.size());
  r.plan.assign(bytes.begin(), bytes.end());
  r.plan_sha256 = Sha256Hex(bytes);
  return r;
}

TEST(RunAdmissionTest, TheStationsPlanCompletedFromTheSourceIsAdmitted) {
  const RunAdmission admission({Plan("vg700ca")});
  const Status st = admission.Admit(Announced(Plan("vg700ca")));
  EXPECT_TRUE(st.ok()) << st.message();
  EXPECT_TRUE(RunAdmission().Admit(Announced(Plan("tactical"))).ok());  // no list: any plan
}

TEST(RunAdmissionTest, ALaxerPlanOrAForgedDigestIsRefused) {
  const RunAdmission admission({Plan("vg700ca")});
  pb::TestPlan lax = Plan("vg700ca");
  ASSERT_GT(lax.limits_size(), 0);
  lax.mutable_limits(0)->set_high(2000);  // BI limit 2000 deg/h: everything passes
  Status st = admission.Admit(Announced(lax));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("not a plan this station accepts (" + Plan("vg700ca").name() + ")"),
            std::string::npos)
      << st.message();
  EXPECT_FALSE(admission.Admit(Announced(Plan("tactical"))).ok());

  imuqual::run_t forged = Announced(Plan("vg700ca"));
  forged.plan.back() ^= 1;  // bytes changed, digest kept
  st = RunAdmission().Admit(forged);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("digest does not match"), std::string::npos);
}

TEST(RunAdmissionTest, NamesThatAreNotIdentifiersAreRefused) {
  const RunAdmission admission;
  imuqual::run_t r = Announced(Plan("vg700ca"));
  r.unit_serial = "<script>alert(1)</script>";
  EXPECT_FALSE(admission.Admit(r).ok());
  r = Announced(Plan("vg700ca"));
  r.run_id = "a b";
  EXPECT_FALSE(admission.Admit(r).ok());
  r = Announced(Plan("vg700ca"));
  r.operator_name = "ana\x1b[2J";
  EXPECT_FALSE(admission.Admit(r).ok());
  r = Announced(Plan("vg700ca"));
  r.lot = "";
  EXPECT_FALSE(admission.Admit(r).ok());
}

TEST(RunAdmissionTest, IdentityIsWhatARunIsNotHowFarItGot) {
  const imuqual::run_t first = Announced(Plan("vg700ca"));
  imuqual::run_t later = first;
  later.state = imuqual::run_t::STATE_COMPLETE;
  later.last_seq = 99;
  later.samples_published = 1000;
  later.revision = 2;
  later.end_reason = "x";
  later.host_utime = 5;
  EXPECT_EQ(RunIdentityDifference(first, later), "");
  later.operator_name = "mallory";
  EXPECT_EQ(RunIdentityDifference(first, later), "operator_name");
  later = first;
  later.plan[0] ^= 1;
  EXPECT_EQ(RunIdentityDifference(first, later), "plan");
  later = first;
  later.station = "bench-B";
  EXPECT_EQ(RunIdentityDifference(first, later), "station");
}

}  // namespace
}  // namespace imuqual::judge
