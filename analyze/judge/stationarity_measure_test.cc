#include "analyze/judge/stationarity_measure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "analyze/judge/judge.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

#include "analyze/judge/testdata/adis_gyro_bins.inc"

// An envelope of the ADIS16405's gyro noise: N 2.6 deg/sqrt(h), above every
// axis's -1/2 line read-off (2.21-2.55; the datasheet's typical is 2.0);
// the datasheet's in-run bias stability, 0.007 deg/s = 25.2 deg/h, as the
// curve minimum of a flicker floor, B = 25.2 / 0.664 = 38 deg/h; K 90
// deg/h/sqrt(h), the step-free axis gx's +1/2 line read-off (the datasheet
// gives none).
pb::TestPlan AdisPlan() {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  for (const char* name : {"gx", "gy", "gz"}) {
    pb::Axis* a = plan.add_axes();
    a->set_name(name);
    a->set_kind(pb::GYRO);
  }
  pb::ReferenceNoiseModel* r = plan.mutable_stationarity()->add_reference_model();
  r->set_axis_kind(pb::GYRO);
  r->set_source("ADIS16405 gyro envelope: datasheet bias stability, measured ARW and RRW");
  r->set_random_walk(2.6 / 60);
  r->set_bias_instability(38.0 / 3600);
  r->set_rate_random_walk(90.0 / 216000);
  return plan;
}

// The recording's three gyro axes as 300 bins of 33.33 s.
std::vector<StationarityAxis> AdisAxes() {
  std::vector<StationarityAxis> axes(3);
  const char* names[] = {"gx", "gy", "gz"};
  for (int a = 0; a < 3; ++a) {
    axes[a].axis = {names[a], pb::GYRO};
    for (const auto& row : kAdisGyroBins) axes[a].bin_means.push_back(row[a]);
  }
  return axes;
}

const pb::Measurement* Find(const std::vector<pb::Measurement>& ms, const std::string& axis,
                            const std::string& name) {
  for (const pb::Measurement& m : ms) {
    if (m.axis() == axis && m.name() == name) return &m;
  }
  return nullptr;
}

TEST(StationarityMeasureTest, ReferenceModelHasThePlansTerms) {
  pb::ReferenceNoiseModel r;
  r.set_random_walk(0.01);
  r.set_rate_random_walk(1e-4);
  pb::GaussMarkov* gm = r.add_gauss_markov();
  gm->set_sigma(0.002);
  gm->set_correlation_time_s(50);
  EXPECT_EQ(ReferenceModel(r).Name(), "N+K+GM");
}

TEST(StationarityMeasureTest, TheAdisStepIsFoundOnGyAndGzNotGx) {
  // GIVEN the recording's three gyro axes as 300 bins of 33.33 s, scanned
  // together against the envelope, as the station scans a run
  const pb::TestPlan plan = AdisPlan();
  const char* names[] = {"gx", "gy", "gz"};
  const std::vector<pb::Measurement> ms = MeasureStationarity(plan, AdisAxes(), 3333 * 0.01, 0.01);
  // THEN gy and gz each have a level step near 0.87 h and gx has none
  // there. (Against a tighter envelope, B 25 deg/h, the joint scan also
  // names a burst on all three axes at 2366-2499 s and the warm-up of gx and
  // gz in the first 5 minutes: both show in the bin means.)
  const auto event_near = [&](const std::string& axis, double t_s) -> const pb::Measurement* {
    const pb::Measurement* n = Find(ms, axis, std::string(kStationarityEvents));
    if (n == nullptr || !(n->value() >= 1)) return nullptr;
    for (int k = 1; k <= n->value(); ++k) {
      const pb::Measurement* t = Find(ms, axis, "event_" + std::to_string(k) + "_time");
      if (t != nullptr && std::abs(t->value() - t_s) < 5 * 33.33) {
        return Find(ms, axis, "event_" + std::to_string(k));
      }
    }
    return nullptr;
  };
  for (const pb::Measurement& m : ms) {
    if (m.name() == kStationarityEvents) {
      std::printf("%s: %s\n", m.axis().c_str(), StationarityEventSummary(m).c_str());
    }
  }
  EXPECT_EQ(event_near("gx", 0.87 * 3600), nullptr);
  for (int a : {1, 2}) {
    SCOPED_TRACE(names[a]);
    const pb::Measurement* size = event_near(names[a], 0.87 * 3600);
    ASSERT_NE(size, nullptr);
    double at = 0;
    for (int k = 1; at == 0; ++k) {
      const pb::Measurement* e = Find(ms, names[a], "event_" + std::to_string(k));
      ASSERT_NE(e, nullptr);
      if (e == size) at = Find(ms, names[a], "event_" + std::to_string(k) + "_time")->value();
    }
    // ... its size within its 1-sigma of the segment means' difference
    // (after - before, deg/h).
    double before = 0, after = 0;
    int nb = 0, na = 0;
    for (int i = 0; i < 300; ++i) {
      if ((i + 0.5) * 33.33 < at) {
        before += kAdisGyroBins[i][a];
        ++nb;
      } else {
        after += kAdisGyroBins[i][a];
        ++na;
      }
    }
    const double segments = (after / na - before / nb) * 3600;
    EXPECT_LT(std::abs(size->value() - segments), size->uncertainty())
        << size->value() << " +- " << size->uncertainty() << " vs " << segments;
  }
}

TEST(StationarityMeasureTest, AnAxisMissingMostOfItsRecordIsLeftOutNotTheGroup) {
  // GIVEN the recording's gyros with gx's data in only 20 of its 300 bins
  // (a channel that dropped out early), THEN gx says it was not scanned and
  // why, and gy and gz are scanned without it: their 0.87 h step is found.
  std::vector<StationarityAxis> axes = AdisAxes();
  for (size_t i = 20; i < axes[0].bin_means.size(); ++i) axes[0].bin_means[i] = std::nan("");
  const std::vector<pb::Measurement> ms = MeasureStationarity(AdisPlan(), axes, 3333 * 0.01, 0.01);
  const pb::Measurement* gx = Find(ms, "gx", std::string(kStationarityEvents));
  ASSERT_NE(gx, nullptr);
  EXPECT_EQ(gx->qualifier(), pb::NOT_MEASURABLE);
  EXPECT_EQ(gx->note(), "not scanned: data in 20 of its 300 bins (32 needed)");
  for (const char* name : {"gy", "gz"}) {
    SCOPED_TRACE(name);
    const pb::Measurement* n = Find(ms, name, std::string(kStationarityEvents));
    ASSERT_NE(n, nullptr);
    EXPECT_GE(n->value(), 1) << n->note();
    EXPECT_NE(n->note().find("for the gyro axes together (left out, gx: data in 20 of its 300 "
                             "bins (32 needed))"),
              std::string::npos)
        << n->note();
    const pb::Measurement* t = Find(ms, name, "event_1_time");
    ASSERT_NE(t, nullptr);
    EXPECT_LT(std::abs(t->value() - 0.87 * 3600), 5 * 33.33);
  }
}

TEST(StationarityMeasureTest, AStepInMissingDataIsFoundAndTimedAsTheGap) {
  // GIVEN the recording's gyros with bins 198..202 (6599-6766 s) missing on
  // every axis, as if those batches never arrived, and a level step of +400
  // deg/h planted on gy from bin 200 on (inside the gap: a unit reset while
  // the link was down); THEN gy has a step timed as the missing stretch,
  // its size within 3 sigma of 400 deg/h, and gx and gz have none there.
  // The recording's own 3083 s step is still found on gy and gz. (That
  // step is close to the threshold against this envelope: with bins 92..94
  // missing, the bins around it, it is no longer found.)
  const pb::TestPlan plan = AdisPlan();
  std::vector<StationarityAxis> axes = AdisAxes();
  for (StationarityAxis& a : axes) {
    for (int i = 198; i < 203; ++i) a.bin_means[i] = std::nan("");
  }
  for (int i = 200; i < 300; ++i) axes[1].bin_means[i] += 400.0 / 3600;
  const double bin_s = 3333 * 0.01;
  const std::vector<pb::Measurement> ms = MeasureStationarity(plan, axes, bin_s, 0.01);
  for (const pb::Measurement& m : ms) {
    if (m.name() == kStationarityEvents) {
      std::printf("%s: %s\n", m.axis().c_str(), StationarityEventSummary(m).c_str());
    }
  }
  // The event k of `axis` whose time is `t_s` (within 5 bins), 0 if none.
  const auto event_at = [&](const std::string& axis, double t_s) {
    const pb::Measurement* n = Find(ms, axis, std::string(kStationarityEvents));
    for (int k = 1; n != nullptr && k <= n->value(); ++k) {
      const pb::Measurement* t = Find(ms, axis, "event_" + std::to_string(k) + "_time");
      if (t != nullptr && std::abs(t->value() - t_s) < 5 * bin_s) return k;
    }
    return 0;
  };
  for (const char* axis : {"gx", "gz"}) EXPECT_EQ(event_at(axis, 198 * bin_s), 0) << axis;
  const int k = event_at("gy", 198 * bin_s);
  ASSERT_GT(k, 0);
  const pb::Measurement* time = Find(ms, "gy", "event_" + std::to_string(k) + "_time");
  EXPECT_NEAR(time->value(), 198 * bin_s, 1e-6);
  EXPECT_NE(time->uncertainty_method().find("anywhere in the missing stretch, 6599 to 6766 s"),
            std::string::npos)
      << time->uncertainty_method();
  const pb::Measurement* size = Find(ms, "gy", "event_" + std::to_string(k));
  EXPECT_NEAR(size->value(), 400, 3 * size->uncertainty());
  EXPECT_NE(size->note().find("while the record was missing, between 6599 and 6766 s"),
            std::string::npos)
      << size->note();
  for (const char* axis : {"gy", "gz"}) EXPECT_GT(event_at(axis, 3083), 0) << axis;
}

TEST(StationarityMeasureTest, PlanActionsOnACount) {
  pb::TestPlan plan = AdisPlan();
  EXPECT_EQ(StationarityOutcome(plan, 1), pb::OUTCOME_UNSET);  // QUALIFIER_ONLY
  plan.mutable_stationarity()->set_on_event(pb::Stationarity::EVENT_FAIL);
  EXPECT_EQ(StationarityOutcome(plan, 0), pb::PASS);
  EXPECT_EQ(StationarityOutcome(plan, 2), pb::FAIL);
  EXPECT_EQ(StationarityOutcome(plan, std::nan("")), pb::INCONCLUSIVE);
  plan.mutable_stationarity()->set_on_event(pb::Stationarity::EVENT_INCONCLUSIVE);
  EXPECT_EQ(StationarityOutcome(plan, 1), pb::INCONCLUSIVE);
  plan.mutable_stationarity()->set_on_event(pb::Stationarity::EVENT_MARGINAL);
  EXPECT_EQ(StationarityOutcome(plan, 1), pb::MARGINAL);
}

}  // namespace
}  // namespace imuqual::judge
