#include "analyze/service/run_analyzer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string_view>

#include "analyze/judge/measurements.h"

namespace imuqual::analyze {
namespace {

constexpr double kRate = 100;

RunDescription Desc(double warmup_s = 0) {
  RunDescription d;
  d.run_id = std::string("R");
  d.serial = std::string("U");
  d.nominal_rate_hz = kRate;
  d.axes = {{"x", pb::GYRO}, {"ax", pb::ACCEL}};
  d.plan.set_nominal_rate_hz(kRate);
  d.plan.set_warmup_s(warmup_s);
  return d;
}

// A batch of n samples per axis starting at device counter `first`.
struct Batch {
  std::vector<float> x, a;
  BatchView view;
  Batch(int64_t seq, int64_t first, int n, double rate = kRate) {
    for (int i = 0; i < n; ++i) {
      x.push_back(0.01f * static_cast<float>(std::sin(0.1 * (first + i))));
      a.push_back(9.8f + 0.001f * static_cast<float>(std::cos(0.3 * (first + i))));
    }
    view.seq = seq;
    view.first_sample = first;
    view.nominal_rate_hz = rate;
    view.samples = {x, a};
  }
};

TEST(RunAnalyzerTest, CountsGapsFromTheDeviceCounter) {
  // GIVEN 10 batches of 100 samples announced as counters [1000, 2050):
  // the device skips 50 samples after batch 2, and the last batch is lost.
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  int64_t counter = 1000;
  for (int seq = 0; seq < 9; ++seq) {
    if (seq == 3) counter += 50;
    Batch b(seq, counter, 100);
    ASSERT_TRUE(a->AddBatch(b.view).ok());
    counter += 100;
  }
  a->Finish(1000, counter + 100);
  const RunOutcome out = a->Outcome(true);
  // THEN 150 samples are missing: 50 skipped, 100 in the lost batch.
  EXPECT_EQ(out.gap_samples, 150);
  EXPECT_EQ(out.samples, 1050);
}

TEST(RunAnalyzerTest, EveryPointOfLiveAndFinalCurvesHasAChiSquareInterval) {
  // GIVEN 6000 samples of white noise per axis
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  uint64_t state = 12345;
  auto noise = [&] {  // uniform in [-0.5, 0.5): white
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<float>(static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5);
  };
  for (int seq = 0; seq < 60; ++seq) {
    Batch b(seq, seq * 100, 100);
    for (float& v : b.x) v = noise();
    for (float& v : b.a) v = 9.8f + 0.01f * noise();
    ASSERT_TRUE(a->AddBatch(b.view).ok());
  }
  auto check = [](const allan::Curve& curve, const std::string& what) -> int {
    EXPECT_EQ(curve.ci, allan::CiMethod::kChi2) << what;
    int inherited = 0;
    for (const allan::CurvePoint& p : curve.points) {
      SCOPED_TRACE(what + " m=" + std::to_string(p.m));
      EXPECT_TRUE(p.alpha.has_value());
      EXPECT_TRUE(std::isfinite(p.edf) && p.edf > 0);
      EXPECT_LT(p.lo, p.dev);
      EXPECT_GT(p.hi, p.dev);
      inherited += p.alpha_inherited;
    }
    return inherited;
  };
  // WHEN a live (interim) look and the final outcome are taken
  const RunOutcome live = a->Outcome(false);
  a->Finish(0, 6000);
  const RunOutcome final_outcome = a->Outcome(true);
  // THEN every point of every curve has its chi-square interval and alpha,
  // the long-tau points (< 30 clusters) from the nearest identified point,
  // and the final curve is the dense judged one, a superset of the live grid.
  ASSERT_EQ(live.curves.size(), 2u);
  ASSERT_EQ(final_outcome.curves.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const allan::Curve& l = live.curves[i].second;
    const allan::Curve& f = final_outcome.curves[i].second;
    check(l, "live " + live.curves[i].first);
    EXPECT_GT(check(f, "final " + final_outcome.curves[i].first), 0);
    EXPECT_GT(f.points.size(), l.points.size());
    for (const allan::CurvePoint& p : l.points) {
      EXPECT_TRUE(std::any_of(f.points.begin(), f.points.end(),
                              [&](const allan::CurvePoint& q) { return q.m == p.m; }))
          << p.m;
    }
    for (const allan::CurvePoint& p : f.points) {
      if (p.m <= 64) {
        EXPECT_EQ(p.alpha.value_or(99), 0) << "white noise at m=" << p.m;
      }
    }
  }
}

TEST(RunAnalyzerTest, LeadingLossIsAGapToo) {
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  Batch b(2, 200, 100);  // seqs 0 and 1 (counters 0..199) never arrived
  ASSERT_TRUE(a->AddBatch(b.view).ok());
  a->Finish(0, 300);
  EXPECT_EQ(a->Outcome(true).gap_samples, 200);
}

// An announced end far beyond the data (a broken or lying announcement: a
// year of samples at 100 Hz) is refused with its reason, not analysed as
// hours of gap; the run's verdict is ERROR saying so (the station could not
// analyse what was announced: that says nothing about the unit).
TEST(RunAnalyzerTest, AnAbsurdAnnouncedEndIsRefusedNotAnalysed) {
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  Batch b(0, 0, 100);
  ASSERT_TRUE(a->AddBatch(b.view).ok());
  a->Finish(0, int64_t{100} * 86400 * 365);
  const RunOutcome out = a->Outcome(true);
  EXPECT_EQ(out.gap_samples, 0);
  EXPECT_EQ(out.judgement.verdict, pb::ERROR);
  ASSERT_FALSE(out.judgement.reasons.empty());
  EXPECT_NE(out.judgement.reasons[0].find("not analysed as a gap"), std::string::npos)
      << out.judgement.reasons[0];
}

TEST(RunAnalyzerTest, WarmUpIsDiscardedByCounterAndIsNotAGap) {
  auto a = RunAnalyzer::Create(Desc(/*warmup_s=*/1.5));  // 150 samples
  ASSERT_TRUE(a.ok());
  Batch b0(0, 0, 100), b2(2, 200, 100);  // seq 1 (inside the warm-up... partly) lost
  ASSERT_TRUE(a->AddBatch(b0.view).ok());
  ASSERT_TRUE(a->AddBatch(b2.view).ok());
  a->Finish(0, 300);
  const RunOutcome out = a->Outcome(true);
  EXPECT_EQ(out.warmup_samples, 150);
  EXPECT_EQ(out.gap_samples, 50);  // counters 150..199: after the warm-up
  EXPECT_EQ(out.samples, 150);
}

TEST(RunAnalyzerTest, InvalidSamplesAreCountedNotZeroed) {
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  Batch b(0, 0, 100);
  b.x[3] = std::nanf("");
  b.a[4] = INFINITY;
  b.view.samples = {b.x, b.a};
  b.view.flags = {{7, 0, 1}, {8, 1, 2}, {9, 1, 4}};  // saturated, invalid, an unknown bit
  ASSERT_TRUE(a->AddBatch(b.view).ok());
  const RunOutcome out = a->Outcome(false);
  EXPECT_EQ(out.invalid_samples, 4);
  // Each axis its own: x the NaN and the saturated one, a the infinity and the invalid one.
  EXPECT_EQ(out.axis_invalid_samples, (std::vector<int64_t>{2, 2}));
}

// A plan's sensor_range makes a sample at or beyond full scale an invalid
// sample of its axis (deg/s for a gyro, g for an accelerometer); values inside
// it count as before.
TEST(RunAnalyzerTest, SamplesOutOfTheSensorsRangeAreInvalidSamplesOfTheirAxis) {
  RunDescription d = Desc();
  pb::SensorRange* gyro = d.plan.add_sensor_range();
  gyro->set_axis_kind(pb::GYRO);
  gyro->set_full_scale(300);  // deg/s
  pb::SensorRange* accel = d.plan.add_sensor_range();
  accel->set_axis_kind(pb::ACCEL);
  accel->set_full_scale(10);  // g: 98.0665 m/s^2
  auto a = RunAnalyzer::Create(d);
  ASSERT_TRUE(a.ok());
  Batch b(0, 0, 100);
  b.x[10] = 300.0f;   // at the rail
  b.x[11] = -450.0f;  // beyond
  b.x[12] = 299.9f;   // inside: a valid (if large) sample
  b.a[20] = 98.1f;   // just beyond 10 g
  b.a[21] = -98.0f;  // inside 10 g
  // Pinned at the rail as a float holds it (98.06649780 < 98.0665 in double).
  b.a[22] = static_cast<float>(10 * 9.80665);
  b.view.samples = {b.x, b.a};
  ASSERT_TRUE(a->AddBatch(b.view).ok());
  const RunOutcome out = a->Outcome(false);
  EXPECT_EQ(out.axis_invalid_samples, (std::vector<int64_t>{2, 2}));
  // Without the range every one of them is a sample.
  auto plain = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(plain.ok());
  ASSERT_TRUE(plain->AddBatch(b.view).ok());
  EXPECT_EQ(plain->Outcome(false).invalid_samples, 0);
}

TEST(RunAnalyzerTest, InvalidSamplesOfOneAxisAreCountedOnThatAxisOnly) {
  // GIVEN a run whose x axis is clean and whose a axis has 5 NaN and 3 flagged samples
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  for (int seq = 0; seq < 3; ++seq) {
    Batch b(seq, seq * 100, 100);
    if (seq == 1) {
      for (int i : {0, 10, 20, 30, 99}) b.a[i] = std::nanf("");
      b.view.samples = {b.x, b.a};
      b.view.flags = {{40, 1, 1}, {41, 1, 2}, {42, 1, 3}};
    }
    ASSERT_TRUE(a->AddBatch(b.view).ok());
  }
  a->Finish(0, 300);
  // WHEN it is judged
  const RunOutcome out = a->Outcome(true);
  // THEN they count on a only, and the run's total is their sum
  EXPECT_EQ(out.axis_invalid_samples, (std::vector<int64_t>{0, 8}));
  EXPECT_EQ(out.invalid_samples, 8);
}

TEST(RunAnalyzerTest, RejectsBatchesThatDoNotFitAndChangesNothing) {
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  Batch ok(0, 0, 100);
  ASSERT_TRUE(a->AddBatch(ok.view).ok());
  const RunOutcome before = a->Outcome(false);

  Batch backwards(1, 50, 100);
  Status st = a->AddBatch(backwards.view);
  EXPECT_NE(st.message().find("counter went backwards"), std::string::npos) << st.message();
  Batch rate(1, 100, 100, 200.0);
  EXPECT_NE(a->AddBatch(rate.view).message().find("claims 200"), std::string::npos);
  Batch one_axis(1, 100, 100);
  one_axis.view.samples.pop_back();
  EXPECT_FALSE(a->AddBatch(one_axis.view).ok());
  Batch flag(1, 100, 100);
  flag.view.flags = {{100, 0, 1}};
  EXPECT_FALSE(a->AddBatch(flag.view).ok());
  Batch absurd(1, int64_t{1} << 40, 100);
  EXPECT_NE(a->AddBatch(absurd.view).message().find("jumped"), std::string::npos);

  const RunOutcome after = a->Outcome(false);
  EXPECT_EQ(after.samples, before.samples);
  EXPECT_EQ(after.curves[0].second.points.size(), before.curves[0].second.points.size());
  EXPECT_EQ(a->batches_accepted(), 1);
}

// A run that did not end normally is not a FAIL of its unit: stopped by the
// operator it is ABORTED, ended by a failure or gone silent it is ERROR, with
// the reason first; its measurements are still judged as they are.
TEST(RunAnalyzerTest, AbnormalEndsAreAbortedOrErrorNeverFail) {
  RunDescription d = Desc();
  d.plan.set_min_duration_s(3600);  // 3 s of data: the duration limit FAILs
  auto a = RunAnalyzer::Create(d);
  ASSERT_TRUE(a.ok());
  for (int seq = 0; seq < 3; ++seq) {
    Batch b(seq, seq * 100, 100);
    ASSERT_TRUE(a->AddBatch(b.view).ok());
  }
  a->Finish(0, 300);
  auto duration_outcome = [](const RunOutcome& out) {
    for (const pb::Measurement& m : out.measurements) {
      if (m.name() == "duration") return m.outcome();
    }
    return pb::OUTCOME_UNSET;
  };
  // GIVEN it ended normally THEN it FAILs on its duration.
  const RunOutcome normal = a->Outcome(true, EndingForRunState("complete"));
  EXPECT_EQ(normal.judgement.verdict, pb::FAIL);
  EXPECT_EQ(duration_outcome(normal), pb::FAIL);

  // GIVEN the operator stopped it (Ctrl-C, hang-up, SIGTERM).
  RunOutcome out = a->Outcome(true, EndingForRunState("aborted", "shutdown requested"));
  EXPECT_EQ(out.judgement.verdict, pb::ABORTED);
  ASSERT_EQ(out.judgement.reasons.size(), normal.judgement.reasons.size() + 1);
  EXPECT_EQ(out.judgement.reasons[0], "run aborted before completion (shutdown requested)");
  EXPECT_EQ(out.judgement.reasons[1], normal.judgement.reasons[0]);  // the judgement kept
  EXPECT_EQ(duration_outcome(out), pb::FAIL);
  EXPECT_EQ(a->Outcome(true, EndingForRunState("aborted")).judgement.verdict, pb::ABORTED);

  // GIVEN its source failed.
  out = a->Outcome(true, EndingForRunState("aborted", "b1.csv:3002: 'oops' is not a number"));
  EXPECT_EQ(out.judgement.verdict, pb::ERROR);
  EXPECT_EQ(out.judgement.reasons[0],
            "run aborted by a failure: b1.csv:3002: 'oops' is not a number");
  EXPECT_EQ(duration_outcome(out), pb::FAIL);

  // GIVEN its source went silent.
  out = a->Outcome(true, EndingForRunState("incomplete", "acquire silent for 30 s"));
  EXPECT_EQ(out.judgement.verdict, pb::ERROR);
  EXPECT_EQ(out.judgement.reasons[0],
            "run incomplete: its source went silent before ending it (acquire silent for 30 s)");

  EXPECT_EQ(EndingForRunState("complete").verdict, pb::OUTCOME_UNSET);
  // A run its unit's early decision ended is complete, with a reason: a
  // normal ending, judged as such.
  EXPECT_EQ(EndingForRunState("complete", "decided FAIL at 340 s (early decision)").verdict,
            pb::OUTCOME_UNSET);
  EXPECT_EQ(EndingForRunState("running").reason, "");
  // The name archived re-analysis calls gives the same.
  EXPECT_EQ(FailureForRunState("aborted", "x").verdict, pb::ERROR);
}

// An aborted run whose announced range was absurd: ERROR, both reasons.
TEST(RunAnalyzerTest, AbsurdRangeOfAnAbortedRunIsAnError) {
  auto a = RunAnalyzer::Create(Desc());
  ASSERT_TRUE(a.ok());
  Batch b(0, 0, 100);
  ASSERT_TRUE(a->AddBatch(b.view).ok());
  a->Finish(0, int64_t{100} * 86400 * 365);
  const RunOutcome out = a->Outcome(true, EndingForRunState("aborted", "shutdown requested"));
  EXPECT_EQ(out.judgement.verdict, pb::ERROR);
  ASSERT_GE(out.judgement.reasons.size(), 2u);
  EXPECT_NE(out.judgement.reasons[0].find("not analysed as a gap"), std::string::npos);
  EXPECT_EQ(out.judgement.reasons[1], "run aborted before completion (shutdown requested)");
}

// What the station reads of early decisions without computing an Outcome:
// the looks done, the decision, and the device counter where the analysis
// stopped (acquire may stop publishing after it).
TEST(RunAnalyzerTest, EarlyDecisionStateIsReadableBetweenBatches) {
  // GIVEN a gyro of white noise (ARW 0.06 deg/sqrt(h)) under a plan limiting
  // ARW to 0.6 with looks every 20 s from 60 s, after a 10 s warm-up
  RunDescription d = Desc(10);
  d.axes = {{"x", pb::GYRO}};
  d.plan.set_min_duration_s(600);
  pb::Limit* limit = d.plan.add_limits();
  limit->set_measurement("angle_random_walk");
  limit->set_axis_kind(pb::GYRO);
  limit->set_high(0.6);
  d.plan.mutable_early_decision()->set_risk(0.01);
  d.plan.mutable_early_decision()->set_min_duration_s(60);
  d.plan.mutable_early_decision()->set_look_period_s(20);
  auto a = RunAnalyzer::Create(d);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ASSERT_NE(a->decider(), nullptr);
  EXPECT_EQ(a->looks_done(), 0);
  EXPECT_EQ(a->analysed_end_counter(), -1);
  std::mt19937_64 rng(5);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  constexpr int64_t kFirst = 5000;
  constexpr int kBatch = 333;  // not a divisor of the look period: looks fall inside batches
  int64_t counter = kFirst;
  // WHEN batches arrive past the first look (10 s warm-up + 60 s) and on
  for (int64_t seq = 0; counter < kFirst + 100 * kRate; ++seq) {
    std::vector<float> x(kBatch);
    for (float& v : x) v = noise(rng);
    BatchView view;
    view.seq = seq;
    view.first_sample = counter;
    view.nominal_rate_hz = kRate;
    view.samples = {x};
    ASSERT_TRUE(a->AddBatch(view).ok());
    counter += kBatch;
    if (!a->decided()) {
      EXPECT_EQ(a->analysed_end_counter(), counter);  // everything so far
    }
  }
  // THEN the unit is decided PASS at the first look, the analysis stopped at
  // its exact device counter, and later samples are counted, not analysed.
  ASSERT_TRUE(a->decided());
  EXPECT_EQ(a->decider()->unit_decision(), judge::Decision::kPass);
  EXPECT_EQ(a->looks_done(), 1);
  EXPECT_EQ(a->decider()->looks().size(), 1u);
  EXPECT_EQ(a->decider()->decided_time_s(), 60);
  EXPECT_EQ(a->analysed_end_counter(), kFirst + static_cast<int64_t>((10 + 60) * kRate));
  a->Finish(kFirst, counter);
  const RunOutcome out = a->Outcome(true);
  EXPECT_EQ(out.samples, static_cast<int64_t>(60 * kRate));
  EXPECT_EQ(out.samples_after_decision, counter - a->analysed_end_counter());
  EXPECT_EQ(out.judgement.verdict, pb::PASS);
}

// A plan scanning for events against white-noise reference models (the
// truth of the samples below), with `action` on an event.
RunDescription StationarityDesc(pb::Stationarity::OnEvent action) {
  RunDescription d = Desc(10);
  pb::Stationarity* st = d.plan.mutable_stationarity();
  st->set_on_event(action);
  for (pb::AxisKind kind : {pb::GYRO, pb::ACCEL}) {
    pb::ReferenceNoiseModel* r = st->add_reference_model();
    r->set_axis_kind(kind);
    r->set_source("white noise of the test's samples");
    r->set_random_walk(0.01);  // sd 0.1 at 100 Hz
  }
  return d;
}

// 40 min of white noise (sd 0.1) after a 10 s warm-up on both axes, with
// `step` added to x from `step_at_s` after the warm-up on, the batches of
// [gap_from_s, gap_from_s + gap_s) lost, and ax's noise `ax_factor` times
// larger from `ax_change_s` on.
RunOutcome WhiteRun(const RunDescription& d, double step, double step_at_s, double gap_from_s,
                    double ax_change_s = 1e9, double ax_factor = 1, double gap_s = 30) {
  auto a = RunAnalyzer::Create(d);
  EXPECT_TRUE(a.ok());
  std::mt19937_64 rng(42);
  std::normal_distribution<double> g(0, 0.1);
  const int per_batch = 100, batches = 2410;
  for (int seq = 0; seq < batches; ++seq) {
    Batch b(seq, seq * per_batch, per_batch);
    for (int i = 0; i < per_batch; ++i) {
      const double t = (seq * per_batch + i) / kRate - 10;  // after the warm-up
      b.x[i] = static_cast<float>(g(rng) + (t >= step_at_s ? step : 0));
      b.a[i] = static_cast<float>(9.8 + g(rng) * (t >= ax_change_s ? ax_factor : 1));
    }
    const double t0 = seq - 10.0;
    if (t0 >= gap_from_s && t0 < gap_from_s + gap_s) continue;
    EXPECT_TRUE(a->AddBatch(b.view).ok());
  }
  a->Finish(0, batches * per_batch);
  return a->Outcome(true);
}

const pb::Measurement* Find(const RunOutcome& out, std::string_view axis, std::string_view name) {
  for (const pb::Measurement& m : out.measurements) {
    if (m.axis() == axis && m.name() == name) return &m;
  }
  return nullptr;
}

TEST(RunAnalyzerTest, ALevelStepIsFoundArchivedAndJudgedAsThePlanSays) {
  // GIVEN white noise whose 8 s bin means have sd 0.0035 deg/s, a step of
  // 0.035 deg/s (10 of them) on x at 1203 s after the warm-up, 30 s of
  // batches lost at 600 s, under a plan whose events make a unit MARGINAL
  const RunOutcome out =
      WhiteRun(StationarityDesc(pb::Stationarity::EVENT_MARGINAL), 0.035, 1203, 600);
  // THEN x has one event, a level step of +126 deg/h (0.035 deg/s) within
  // 3 sigma, at the bin edge nearest 1203 s; ax has none
  const pb::Measurement* x = Find(out, "x", judge::kStationarityEvents);
  const pb::Measurement* ax = Find(out, "ax", judge::kStationarityEvents);
  ASSERT_NE(x, nullptr);
  ASSERT_NE(ax, nullptr);
  EXPECT_EQ(x->value(), 1) << x->note();
  EXPECT_EQ(ax->value(), 0) << ax->note();
  EXPECT_NE(x->note().find("level step +12"), std::string::npos) << x->note();
  EXPECT_NE(x->note().find("white noise of the test's samples"), std::string::npos);
  const pb::Measurement* size = Find(out, "x", "event_1");
  const pb::Measurement* time = Find(out, "x", "event_1_time");
  ASSERT_NE(size, nullptr);
  ASSERT_NE(time, nullptr);
  EXPECT_EQ(size->unit(), "deg/h");
  ASSERT_TRUE(size->has_uncertainty());
  EXPECT_GT(size->uncertainty(), 0);
  EXPECT_LT(std::abs(size->value() - 126), 3 * size->uncertainty());
  EXPECT_LE(std::abs(time->value() - 1203), 8.01);
  EXPECT_EQ(Find(out, "ax", "event_1"), nullptr);
  // AND the plan's action: x MARGINAL with the event named, ax PASS
  EXPECT_EQ(x->outcome(), pb::MARGINAL);
  EXPECT_EQ(ax->outcome(), pb::PASS);
  EXPECT_EQ(out.judgement.verdict, pb::MARGINAL);
  ASSERT_FALSE(out.judgement.reasons.empty());
  EXPECT_NE(out.judgement.reasons.back().find("x: stationarity: 1 event: level step"),
            std::string::npos)
      << out.judgement.reasons.back();
}

TEST(RunAnalyzerTest, JudgeLongestSegmentJudgesEachAxisOnItsStretchWithoutEvents) {
  // GIVEN the step of 0.035 deg/s on x at 1203 s of the 2400 s record (no
  // batch lost), under a plan that judges each axis's longest stretch
  // without an event and limits bias_offset to +-20 deg/h (the whole
  // record's mean is +63 deg/h: half of it after the step)
  RunDescription d = StationarityDesc(pb::Stationarity::JUDGE_LONGEST_SEGMENT);
  pb::Limit* l = d.plan.add_limits();
  l->set_measurement(std::string(judge::kBiasOffset));
  l->set_axis_kind(pb::GYRO);
  l->set_low(-20);
  l->set_high(20);
  l->set_unit("deg/h");
  const RunOutcome out = WhiteRun(d, 0.035, 1203, 1e9);
  // THEN x is judged on 0 s to a mark at most 8 s before the step's cut (a
  // bin either side of it) and ax on the whole record
  const pb::Measurement* x = Find(out, "x", judge::kJudgedSegment);
  const pb::Measurement* ax = Find(out, "ax", judge::kJudgedSegment);
  ASSERT_NE(x, nullptr);
  ASSERT_NE(ax, nullptr);
  EXPECT_EQ(Find(out, "x", judge::kStationarityEvents)->value(), 1);
  EXPECT_LE(x->value(), 1203 - 8 + 1e-9) << x->note();
  EXPECT_GE(x->value(), 1203 - 8 - 8 - 8 - 1e-9) << x->note();
  EXPECT_NE(x->note().find("the stretch 0-"), std::string::npos) << x->note();
  EXPECT_DOUBLE_EQ(ax->value(), 2400);
  EXPECT_NE(ax->note().find("the whole record"), std::string::npos) << ax->note();
  // AND x's mean, curve and noise model are the stretch's: bias_offset
  // within 5 sigma of 0 (1.0 deg/h), the published curve of its samples
  const pb::Measurement* offset = Find(out, "x", judge::kBiasOffset);
  ASSERT_NE(offset, nullptr);
  EXPECT_LT(std::abs(offset->value()), 5.2) << offset->value();
  EXPECT_EQ(offset->outcome(), pb::PASS);
  for (const auto& [axis, curve] : out.curves) {
    const double want = axis == "x" ? x->value() : 2400;
    EXPECT_NEAR(static_cast<double>(curve.n_phase - 1) / kRate, want, 1e-9) << axis;
  }
  // AND the verdict is the limits' on the stretches, the event named
  EXPECT_EQ(out.judgement.verdict, pb::PASS);
  bool named = false;
  for (const std::string& r : out.judgement.reasons) {
    named |= r.find("x: stationarity: 1 event: level step") != std::string::npos &&
             r.find("JUDGE_LONGEST_SEGMENT: the verdict is the limits' on the stretch 0-") !=
                 std::string::npos;
  }
  EXPECT_TRUE(named) << ::testing::PrintToString(out.judgement.reasons);

  // GIVEN the same under the plan's min_duration_s of 1500 s: neither side
  // of the step is that long, so x is not judged: INCONCLUSIVE, a retest
  d.plan.set_min_duration_s(1500);
  const RunOutcome short_stretch = WhiteRun(d, 0.035, 1203, 1e9);
  EXPECT_EQ(short_stretch.judgement.verdict, pb::INCONCLUSIVE);
  EXPECT_EQ(Find(short_stretch, "x", judge::kJudgedSegment)->outcome(), pb::INCONCLUSIVE);
  EXPECT_EQ(Find(short_stretch, "ax", judge::kJudgedSegment)->outcome(), pb::PASS);
  bool retest = false;
  for (const std::string& r : short_stretch.judgement.reasons) {
    retest |= r.find("x: the stretch without a found event holds") != std::string::npos &&
              r.find("retest") != std::string::npos;
  }
  EXPECT_TRUE(retest) << ::testing::PrintToString(short_stretch.judgement.reasons);

  // GIVEN the step at 800 s and the batches of 900-2000 s lost: the stretch
  // after the step is the longer in time (about 1590 s) but holds about 490
  // s of data, the one before it about 790 s
  d.plan.set_min_duration_s(0);
  const RunOutcome gappy = WhiteRun(d, 0.035, 800, 900, 1e9, 1, 1100);
  // THEN x is judged on the one before, its data its value
  const pb::Measurement* before = Find(gappy, "x", judge::kJudgedSegment);
  ASSERT_NE(before, nullptr);
  EXPECT_EQ(Find(gappy, "x", judge::kJudgedSegmentStart)->value(), 0);
  EXPECT_LE(before->value(), 800 - 8 + 1e-9) << before->note();
  EXPECT_GE(before->value(), 800 - 8 - 16 - 1e-9) << before->note();
  EXPECT_DOUBLE_EQ(Find(gappy, "x", judge::kJudgedSegmentEnd)->value(), before->value());
  // AND ax (no event) on the whole record, its value the record's data
  const pb::Measurement* whole = Find(gappy, "ax", judge::kJudgedSegment);
  EXPECT_DOUBLE_EQ(whole->value(), 2400 - 1100);
  EXPECT_DOUBLE_EQ(Find(gappy, "ax", judge::kJudgedSegmentEnd)->value(), 2400);
  EXPECT_NE(whole->note().find("no event found on the axis"), std::string::npos);
}

TEST(RunAnalyzerTest, TheJudgedStretchDoesNotDependOnBatchBoundaries) {
  // GIVEN one record (white noise, the step of 0.035 deg/s on x at 1203 s
  // after a 10 s warm-up) under JUDGE_LONGEST_SEGMENT, fed in batches of
  // 100 samples and of 137 (a live run and its archived re-analysis may cut
  // it differently)
  const RunDescription d = StationarityDesc(pb::Stationarity::JUDGE_LONGEST_SEGMENT);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0, 0.1);
  const int total = 241000;
  std::vector<float> x(total), ax(total);
  for (int i = 0; i < total; ++i) {
    x[i] = static_cast<float>(g(rng) + (i / kRate - 10 >= 1203 ? 0.035 : 0));
    ax[i] = static_cast<float>(9.8 + g(rng));
  }
  const auto run = [&](int per_batch) {
    auto a = RunAnalyzer::Create(d);
    EXPECT_TRUE(a.ok());
    int64_t seq = 0;
    for (int first = 0; first < total; first += per_batch, ++seq) {
      const int n = std::min(per_batch, total - first);
      BatchView view;
      view.seq = seq;
      view.first_sample = first;
      view.nominal_rate_hz = kRate;
      view.samples = {std::span<const float>(x).subspan(first, n),
                      std::span<const float>(ax).subspan(first, n)};
      EXPECT_TRUE(a->AddBatch(view).ok());
    }
    a->Finish(0, total);
    return a->Outcome(true);
  };
  const RunOutcome by100 = run(100), by137 = run(137);
  // THEN x is judged on a stretch, and every measurement and every point of
  // the published curves is the same, bit for bit
  ASSERT_NE(Find(by100, "x", judge::kJudgedSegmentStart), nullptr);
  EXPECT_GT(Find(by100, "x", judge::kJudgedSegment)->value(), 0);
  EXPECT_LT(Find(by100, "x", judge::kJudgedSegment)->value(), 2400);
  ASSERT_EQ(by100.measurements.size(), by137.measurements.size());
  for (size_t i = 0; i < by100.measurements.size(); ++i) {
    const pb::Measurement& p = by100.measurements[i];
    const pb::Measurement& q = by137.measurements[i];
    EXPECT_EQ(p.name(), q.name());
    if (std::isnan(p.value())) {
      EXPECT_TRUE(std::isnan(q.value())) << p.axis() << " " << p.name();
    } else {
      EXPECT_EQ(p.value(), q.value()) << p.axis() << " " << p.name();
    }
    EXPECT_EQ(p.note(), q.note()) << p.axis() << " " << p.name();
  }
  ASSERT_EQ(by100.curves.size(), by137.curves.size());
  for (size_t c = 0; c < by100.curves.size(); ++c) {
    const allan::Curve& p = by100.curves[c].second;
    const allan::Curve& q = by137.curves[c].second;
    ASSERT_EQ(p.points.size(), q.points.size());
    for (size_t i = 0; i < p.points.size(); ++i) {
      EXPECT_EQ(p.points[i].n, q.points[i].n);
      EXPECT_EQ(p.points[i].dev, q.points[i].dev);
    }
  }
  EXPECT_EQ(by100.judgement.verdict, by137.judgement.verdict);
}

TEST(RunAnalyzerTest, ANoiseLevelChangeIsAnEventWithItsRatio) {
  // GIVEN ax's white noise 20 % larger from 1500 s after the warm-up on
  // (nothing else moves), under a plan whose events make a unit MARGINAL
  const RunOutcome out =
      WhiteRun(StationarityDesc(pb::Stationarity::EVENT_MARGINAL), 0, 0, 600, 1500, 1.2);
  // THEN ax has a noise level change x1.2 within 3 sigma, at the bin
  // boundary nearest 1500 s (its larger noise is now above the white
  // reference, so the level scan may read it as steps or bursts too, as
  // the note warns); x has none
  const pb::Measurement* ax = Find(out, "ax", judge::kStationarityEvents);
  const pb::Measurement* x = Find(out, "x", judge::kStationarityEvents);
  ASSERT_NE(ax, nullptr);
  ASSERT_NE(x, nullptr);
  EXPECT_GE(ax->value(), 1) << ax->note();
  EXPECT_EQ(x->value(), 0) << x->note();
  EXPECT_NE(ax->note().find("noise level x1.2"), std::string::npos) << ax->note();
  int k = 1;
  for (; k <= ax->value(); ++k) {
    const pb::Measurement* e = Find(out, "ax", "event_" + std::to_string(k));
    if (e != nullptr && e->unit() == judge::kNoiseLevelRatioUnit) break;
  }
  const pb::Measurement* ratio = Find(out, "ax", "event_" + std::to_string(k));
  const pb::Measurement* time = Find(out, "ax", "event_" + std::to_string(k) + "_time");
  ASSERT_NE(ratio, nullptr) << ax->note();
  ASSERT_NE(time, nullptr);
  EXPECT_EQ(ratio->unit(), judge::kNoiseLevelRatioUnit);
  EXPECT_EQ(Find(out, "ax", "event_" + std::to_string(k) + "_end"), nullptr);
  ASSERT_TRUE(ratio->has_uncertainty());
  EXPECT_LT(std::abs(ratio->value() - 1.2), 3 * ratio->uncertainty());
  EXPECT_LE(std::abs(time->value() - 1500), 8.01);
  EXPECT_EQ(ax->outcome(), pb::MARGINAL);
  EXPECT_EQ(out.judgement.verdict, pb::MARGINAL);
  // ... and x's scan says what its noise level showed
  EXPECT_NE(x->note().find("noise level (the mean square difference"), std::string::npos)
      << x->note();
}

TEST(RunAnalyzerTest, AnEventUnderQualifierOnlyIsNamedButLeavesTheVerdict) {
  const RunOutcome out =
      WhiteRun(StationarityDesc(pb::Stationarity::QUALIFIER_ONLY), 0.035, 1203, 600);
  const pb::Measurement* x = Find(out, "x", judge::kStationarityEvents);
  ASSERT_NE(x, nullptr);
  EXPECT_EQ(x->value(), 1);
  EXPECT_EQ(x->outcome(), pb::OUTCOME_UNSET);
  EXPECT_NE(out.judgement.verdict, pb::MARGINAL);
  ASSERT_EQ(out.judgement.reasons.size(), 1u);
  EXPECT_NE(out.judgement.reasons[0].find("QUALIFIER_ONLY"), std::string::npos);
}

TEST(RunAnalyzerTest, AStationaryRecordHasNoEventAndPasses) {
  const RunOutcome out = WhiteRun(StationarityDesc(pb::Stationarity::EVENT_FAIL), 0, 0, 600);
  for (std::string_view axis : {"x", "ax"}) {
    const pb::Measurement* m = Find(out, axis, judge::kStationarityEvents);
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->value(), 0) << m->note();
    EXPECT_EQ(m->outcome(), pb::PASS);
    // The record's curve lies on the reference: the bound on the rate holds.
    EXPECT_NE(m->note().find("shows no noise above the reference"), std::string::npos) << m->note();
  }
}

TEST(RunAnalyzerTest, WithoutAReferenceTheRecordsOwnModelIsScanned) {
  RunDescription d = StationarityDesc(pb::Stationarity::QUALIFIER_ONLY);
  d.plan.mutable_stationarity()->clear_reference_model();
  const RunOutcome out = WhiteRun(d, 0.035, 1203, 600);
  const pb::Measurement* x = Find(out, "x", judge::kStationarityEvents);
  ASSERT_NE(x, nullptr);
  EXPECT_NE(x->note().find("the model fitted to this record"), std::string::npos) << x->note();
  EXPECT_NE(x->note().find("not held"), std::string::npos);
}

// A run of `seconds` one-second batches under a plan with
// noise_model_long_taus, each batch filled by fill(batch), to its end.
RunOutcome LongTauRun(int seconds, const std::function<void(Batch*)>& fill) {
  RunDescription d = Desc();
  d.plan.set_noise_model_long_taus(true);
  auto a = RunAnalyzer::Create(d);
  EXPECT_TRUE(a.ok());
  for (int seq = 0; seq < seconds; ++seq) {
    Batch b(seq, seq * 100, 100);
    fill(&b);
    EXPECT_TRUE(a->AddBatch(b.view).ok());
  }
  a->Finish(0, int64_t{100} * seconds);
  return a->Outcome(true);
}

TEST(RunAnalyzerTest, NoiseModelLongTausFitTheo1OfTheOneSecondMeans) {
  // GIVEN 1200 s at 100 Hz of white rate noise (0.1 deg/s per sample) and a
  // rate random walk whose Allan minimum (200 s) lies beyond the stop
  // rule's T/9, under a plan with noise_model_long_taus
  std::mt19937_64 rng(77);
  std::normal_distribution<double> g;
  const double k = std::sqrt(3.0) * 0.01 / 200;  // deg/s/sqrt(s)
  double walk = 0;
  std::vector<double> means;  // of each second of x, as the analysis sums them
  const RunOutcome out = LongTauRun(1200, [&](Batch* b) {
    double sum = 0;
    for (int i = 0; i < 100; ++i) {
      walk += k * std::sqrt(1 / kRate) * g(rng);
      b->x[i] = static_cast<float>(0.1 * g(rng) + walk);
      b->a[i] = static_cast<float>(9.8 + 0.01 * g(rng));
      sum += b->x[i];
    }
    means.push_back(sum / 100);
  });
  // THEN x's model is fitted with Theo1 of the one-second means beyond the
  // curve (one octave: 0.3 of 1200 s reaches 360 s), and every model value
  // is the one the offline fit gives with the same moments
  const pb::Measurement* arw = Find(out, "x", judge::kFitAngleRandomWalk);
  ASSERT_NE(arw, nullptr);
  EXPECT_NE(arw->note().find("Theo1 moments to"), std::string::npos) << arw->note();
  EXPECT_NE(arw->note().find("(of the means of 100 samples)"), std::string::npos) << arw->note();
  const allan::Curve* curve = nullptr;
  for (const auto& [axis, c] : out.curves) {
    if (axis == "x") curve = &c;
  }
  ASSERT_NE(curve, nullptr);
  const allan::PhaseRecord phase = allan::PhaseFromRate(std::span<const double>(means), 1.0);
  judge::NoiseModelOptions options;
  options.long_taus = allan::Theo1MomentsBeyond(phase, curve->points.back().tau_s, 100);
  ASSERT_EQ(options.long_taus.size(), 1u);
  EXPECT_LE(0.75 * static_cast<double>(options.long_taus[0].m), 0.3 * 1200);
  // From twice the curve's last tau, m rounded to an even count of means.
  EXPECT_NEAR(0.75 * static_cast<double>(options.long_taus[0].m), 2 * curve->points.back().tau_s,
              1.5);
  int compared = 0;
  for (const pb::Measurement& m : judge::MeasureNoiseModel("x", pb::GYRO, *curve, options)) {
    const pb::Measurement* got = Find(out, "x", m.name());
    ASSERT_NE(got, nullptr) << m.name();
    if (!std::isfinite(m.value())) continue;
    EXPECT_NEAR(got->value(), m.value(), 1e-9 * std::abs(m.value())) << m.name();
    ++compared;
  }
  EXPECT_GE(compared, 3);
}

TEST(RunAnalyzerTest, NoiseModelLongTausSayWhyThereAreNone) {
  // GIVEN a plan with noise_model_long_taus and 600 s of white noise whose
  // every second has one sample flagged invalid (no whole valid second)
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  const RunOutcome out = LongTauRun(600, [&](Batch* b) {
    for (int i = 0; i < 100; ++i) {
      b->x[i] = static_cast<float>(0.1 * g(rng));
      b->a[i] = static_cast<float>(9.8 + 0.01 * g(rng));
    }
    b->view.flags.push_back({50, 0, 2});
  });
  // THEN x's model values say there are no moments and why; ax has them
  const pb::Measurement* x = Find(out, "x", judge::kFitAngleRandomWalk);
  ASSERT_NE(x, nullptr);
  EXPECT_NE(x->note().find("no Theo1 moments: the longest stretch of whole valid means (0 s)"),
            std::string::npos)
      << x->note();
  const pb::Measurement* ax = Find(out, "ax", judge::kFitVelocityRandomWalk);
  ASSERT_NE(ax, nullptr);
  EXPECT_NE(ax->note().find("Theo1 moments to"), std::string::npos) << ax->note();
}

TEST(RunAnalyzerTest, TemperatureOfTheAnalysedBatchesIsMeasuredAndLimited) {
  // GIVEN a 10 s warm-up and 60 one-second batches whose temperature climbs
  // 0.05 deg C per batch from 20 deg C (the warm-up's readings are 30 deg C,
  // and every fifth batch carries none), under a plan that keeps the range
  // within 2 deg C and the slope within 1 deg C/h
  RunDescription d = Desc(10);
  pb::Limit* range = d.plan.add_limits();
  range->set_measurement("temperature_range");
  range->set_high(2);
  range->set_unit("deg C");
  pb::Limit* slope = d.plan.add_limits();
  slope->set_measurement("temperature_slope");
  slope->set_low(-1);
  slope->set_high(1);
  slope->set_unit("deg C/h");
  auto a = RunAnalyzer::Create(d);
  ASSERT_TRUE(a.ok());
  for (int seq = 0; seq < 70; ++seq) {
    Batch b(seq, seq * 100, 100);
    if (seq < 10) {
      b.view.temperature_c = 30.0;
    } else if (seq % 5 != 0) {
      b.view.temperature_c = 20.0 + 0.05 * (seq - 10);
    }
    ASSERT_TRUE(a->AddBatch(b.view).ok());
  }
  a->Finish(0, 7000);
  const RunOutcome out = a->Outcome(true);
  auto find = [&](std::string_view name) -> const pb::Measurement* {
    for (const pb::Measurement& m : out.measurements) {
      if (m.name() == name) return &m;
    }
    return nullptr;
  };
  // THEN the warm-up's readings are not counted: range 2.9 deg C (batches
  // 11..69 of the ramp), a slope of 0.05 deg C/s = 180 deg C/h, both FAIL.
  const pb::Measurement* r = find(judge::kTemperatureRange);
  const pb::Measurement* s = find(judge::kTemperatureSlope);
  ASSERT_NE(r, nullptr);
  ASSERT_NE(s, nullptr);
  EXPECT_NEAR(r->value(), 0.05 * 58, 1e-9);
  EXPECT_NEAR(s->value(), 180, 1e-6);
  EXPECT_EQ(r->outcome(), pb::FAIL);
  EXPECT_EQ(s->outcome(), pb::FAIL);
  EXPECT_EQ(out.judgement.verdict, pb::FAIL);
}

}  // namespace
}  // namespace imuqual::analyze
