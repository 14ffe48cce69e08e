// Early decisions inside the run analysis: looks at exact device times
// whatever the batches, the analysis stopping at the decision, and a unit at
// a limit judged on its full record as without early decisions.
#include <gtest/gtest.h>

#include <cmath>

#include "acquire/imu_simulator.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "analyze/service/run_analyzer.h"

namespace imuqual::analyze {
namespace {

constexpr double kRate = 50;

pb::TestPlan Plan(bool early) {
  auto plan = judge::ParsePlanText(std::string(R"pb(
    name: "arw" axes { name: "x" kind: GYRO } nominal_rate_hz: 50 min_duration_s: 600 warmup_s: 2
    limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 unit: "deg/sqrt(h)" }
    limits { measurement: "gap_fraction" high: 0.001 unit: "1" })pb") +
                                       (early ? "early_decision { risk: 0.01 min_duration_s: 60 "
                                                "look_period_s: 30 }"
                                              : ""),
                                   "test");
  EXPECT_TRUE(plan.ok()) << plan.status().message();
  return *plan;
}

// White noise with the given ARW, `seconds` of it after the warm-up, fed in
// batches of `batch` samples (stopping once decided, as a station does).
struct Fed {
  RunOutcome outcome;
  int64_t samples_fed = 0;
};
Fed Feed(const pb::TestPlan& plan, double arw, uint64_t seed, int batch, double seconds,
         double step_at_s = -1, double step = 0) {
  pb::SimTruth truth;
  truth.set_seed(seed);
  truth.set_actual_rate_hz(kRate);
  pb::AxisTruth* a = truth.add_axes();
  a->set_axis("x");
  a->set_random_walk(arw / 60.0);
  auto sim = sim::ImuSimulator::Create(truth);
  RunDescription d;
  d.run_id = "R";
  d.serial = "U";
  d.nominal_rate_hz = kRate;
  d.axes = {{"x", pb::GYRO}};
  d.plan = plan;
  auto analyzer = RunAnalyzer::Create(d);
  EXPECT_TRUE(sim.ok() && analyzer.ok());
  const int64_t total = std::llround((plan.warmup_s() + seconds) * kRate);
  std::vector<std::vector<float>> samples(1);
  int64_t counter = 0;
  for (int64_t seq = 0; counter < total && !analyzer->decided(); ++seq) {
    const int n = static_cast<int>(std::min<int64_t>(batch, total - counter));
    samples[0].clear();
    sim->Generate(n, samples);
    for (int i = 0; i < n && step_at_s >= 0; ++i) {  // a level step after the warm-up
      if (static_cast<double>(counter + i) / kRate - plan.warmup_s() >= step_at_s) {
        samples[0][i] += static_cast<float>(step);
      }
    }
    BatchView v;
    v.seq = seq;
    v.first_sample = counter;
    v.nominal_rate_hz = kRate;
    v.samples.emplace_back(samples[0]);
    EXPECT_TRUE(analyzer->AddBatch(v).ok());
    counter += n;
  }
  analyzer->Finish(0, counter);
  return {analyzer->Outcome(true), counter};
}

const pb::Measurement* Find(const RunOutcome& o, std::string_view name) {
  for (const pb::Measurement& m : o.measurements) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

TEST(EarlyDecisionRun, DecidedUnitStopsAtTheLookWhateverTheBatches) {
  const pb::TestPlan plan = Plan(true);
  const Fed a = Feed(plan, 0.2, 11, 50, 600);
  const Fed b = Feed(plan, 0.2, 11, 37, 600);  // other batch boundaries, same samples
  ASSERT_TRUE(a.outcome.early.has_value());
  EXPECT_EQ(a.outcome.early->unit, judge::Decision::kPass);
  EXPECT_EQ(a.outcome.early->decided_at_s, 60);
  EXPECT_EQ(a.outcome.judgement.verdict, pb::PASS);
  // The record analysed ends at the look: 60 s, the rest of the batch is counted apart.
  EXPECT_EQ(a.outcome.samples, 60 * 50);
  EXPECT_EQ(b.outcome.samples, 60 * 50);
  EXPECT_EQ(a.outcome.samples_after_decision, a.samples_fed - 2 * 50 - 60 * 50);
  // Same decision, same measurements, bit for bit.
  ASSERT_EQ(a.outcome.measurements.size(), b.outcome.measurements.size());
  for (size_t i = 0; i < a.outcome.measurements.size(); ++i) {
    const pb::Measurement& x = a.outcome.measurements[i];
    const pb::Measurement& y = b.outcome.measurements[i];
    if (x.name() == judge::kMeasuredRate || x.name() == judge::kRateError ||
        x.name() == judge::kTimingJitter) {
      continue;
    }
    EXPECT_EQ(x.name(), y.name());
    EXPECT_TRUE(x.value() == y.value() || (std::isnan(x.value()) && std::isnan(y.value())))
        << x.name();
    EXPECT_EQ(x.outcome(), y.outcome()) << x.name();
    EXPECT_EQ(x.note(), y.note()) << x.name();
  }
  const pb::Measurement* t = Find(a.outcome, judge::kDecisionTime);
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->value(), 60);
  EXPECT_NE(t->note().find("decided PASS at look 1 of 18"), std::string::npos) << t->note();
  const pb::Measurement* arw = Find(a.outcome, judge::kAngleRandomWalk);
  ASSERT_NE(arw, nullptr);
  EXPECT_NE(arw->note().find("decided PASS at 60 s (look 1)"), std::string::npos) << arw->note();
  // The record is long enough for the early decision's minimum duration.
  const pb::Measurement* duration = Find(a.outcome, judge::kDuration);
  ASSERT_NE(duration, nullptr);
  EXPECT_EQ(duration->outcome(), pb::PASS);
}

// A unit decided early is scanned for stationarity on the record analysed
// to its decision: a qualifier-only event is named in the reasons, and a
// limit on the count (read at the end, never at a look) judges it.
TEST(EarlyDecisionRun, StationarityIsScannedOnTheDecidedRecord) {
  pb::TestPlan plan = Plan(true);
  pb::ReferenceNoiseModel* r = plan.mutable_stationarity()->add_reference_model();
  r->set_axis_kind(pb::GYRO);
  r->set_source("the simulated white noise");
  r->set_random_walk(0.2 / 60);
  // A step of 0.05 deg/s (15 sd of a 1 s bin mean) at 30 s.
  const Fed q = Feed(plan, 0.2, 11, 50, 600, 30, 0.05);
  ASSERT_TRUE(q.outcome.early.has_value());
  EXPECT_EQ(q.outcome.early->decided_at_s, 60);
  EXPECT_EQ(q.outcome.judgement.verdict, pb::PASS);
  const pb::Measurement* n = Find(q.outcome, judge::kStationarityEvents);
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->value(), 1) << n->note();
  ASSERT_FALSE(q.outcome.judgement.reasons.empty());
  EXPECT_NE(q.outcome.judgement.reasons.back().find("x: stationarity: 1 event: level step"),
            std::string::npos)
      << q.outcome.judgement.reasons.back();

  pb::Limit* none = plan.add_limits();
  none->set_measurement(std::string(judge::kStationarityEvents));
  none->set_high(0);
  none->set_unit("1");
  ASSERT_TRUE(judge::ValidatePlan(plan).ok()) << judge::ValidatePlan(plan).message();
  const Fed f = Feed(plan, 0.2, 11, 50, 600, 30, 0.05);
  ASSERT_TRUE(f.outcome.early.has_value());
  EXPECT_EQ(f.outcome.early->decided_at_s, 60);  // the limit is not looked at
  EXPECT_EQ(f.outcome.judgement.verdict, pb::FAIL);
  n = Find(f.outcome, judge::kStationarityEvents);
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->outcome(), pb::FAIL);
}

TEST(EarlyDecisionRun, ClearlyBadUnitIsDecidedFail) {
  const Fed f = Feed(Plan(true), 1.5, 5, 50, 600);
  ASSERT_TRUE(f.outcome.early.has_value());
  EXPECT_EQ(f.outcome.early->unit, judge::Decision::kFail);
  EXPECT_EQ(f.outcome.judgement.verdict, pb::FAIL);
  EXPECT_LT(f.outcome.early->decided_at_s, 600);
}

// At the limit: pending at every look, the full record analysed, and the
// verdict that of the same record without early decisions.
TEST(EarlyDecisionRun, UnitAtTheLimitGetsTheFullLengthVerdict) {
  for (uint64_t seed : {1, 2, 3}) {
    const Fed early = Feed(Plan(true), 0.6, seed, 50, 600);
    const Fed full = Feed(Plan(false), 0.6, seed, 50, 600);
    ASSERT_TRUE(early.outcome.early.has_value());
    EXPECT_EQ(early.outcome.early->unit, judge::Decision::kPending) << "seed " << seed;
    EXPECT_EQ(early.outcome.early->looks_done, 18);
    EXPECT_EQ(early.outcome.samples, full.outcome.samples);
    EXPECT_EQ(early.outcome.judgement.verdict, full.outcome.judgement.verdict) << "seed " << seed;
    const pb::Measurement* t = Find(early.outcome, judge::kDecisionTime);
    ASSERT_NE(t, nullptr);
    EXPECT_TRUE(std::isnan(t->value()));
    EXPECT_EQ(t->qualifier(), pb::NOT_MEASURABLE);
    EXPECT_NE(t->note().find("full-length verdict"), std::string::npos);
    EXPECT_EQ(Find(full.outcome, judge::kDecisionTime), nullptr);
  }
}

}  // namespace
}  // namespace imuqual::analyze
