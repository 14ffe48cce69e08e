// The noise-model measurements of an axis (measure.h, MeasureNoiseModel) on
// curves built from a known model: what is judged, what is archived, and what
// happens when no model fits.
#include "analyze/judge/measure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

constexpr double kTau0 = 0.01;             // 100 Hz
constexpr int64_t kPhasePoints = 1 << 22;  // 11.6 h: many clusters at every tau

// The exact OADEV of `model` on the octave grid up to a ninth of the record,
// as the analysis would store it (edf and intervals left to the fit).
allan::Curve ExactCurve(const allan::CompositeModel& model) {
  allan::Curve c;
  c.deviation = allan::Deviation::kOadev;
  c.tau0_s = kTau0;
  c.n_phase = kPhasePoints;
  for (int64_t m = 1; m <= kPhasePoints / 9; m *= 2) {
    allan::CurvePoint p;
    p.m = m;
    p.tau_s = m * kTau0;
    p.dev = model.Deviation(static_cast<double>(m), kTau0);
    p.n = kPhasePoints - 2 * m;
    p.stride = 1;
    c.points.push_back(p);
  }
  return c;
}

const pb::Measurement* Find(const std::vector<pb::Measurement>& ms, std::string_view name) {
  for (const pb::Measurement& m : ms) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

// White noise N = 0.1 deg/sqrt(h) and rate random walk K = 3 deg/h/sqrt(h),
// in the base units (deg/s sqrt(s), deg/s/sqrt(s)).
allan::CompositeModel WhitePlusRandomWalk() {
  allan::CompositeModel m;
  m.terms.push_back({allan::TermKind::kWhite, 0.1 / 60});
  m.terms.push_back({allan::TermKind::kRandomWalk, 3.0 / 3600 / 60});
  return m;
}

TEST(MeasureNoiseModelTest, ModelOfAnExactCurveIsJudgedAndArchived) {
  const std::vector<pb::Measurement> ms =
      MeasureNoiseModel("x", pb::GYRO, ExactCurve(WhitePlusRandomWalk()));
  // The judged figures, in datasheet units, with sigmas. Tolerances: an exact
  // curve leaves only the optimiser's convergence (1e-7 in theta) and the
  // model averaging with runners-up that carry little weight.
  const pb::Measurement* n = Find(ms, kFitAngleRandomWalk);
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->unit(), "deg/sqrt(h)");
  EXPECT_NEAR(n->value(), 0.1, 0.1 * 0.01);
  EXPECT_TRUE(n->has_uncertainty());
  const pb::Measurement* k = Find(ms, kFitRateRandomWalk);
  ASSERT_NE(k, nullptr);
  EXPECT_NEAR(k->value(), 3.0, 3.0 * 0.05);
  EXPECT_TRUE(k->has_uncertainty());
  // The model curve's minimum / 0.664: N^2/tau + K^2 tau/3 is least at
  // tau = sqrt(3) N / K, where it is 2 N K / sqrt(3).
  const double n_base = 0.1 / 60, k_base = 3.0 / 3600 / 60;
  const double min_dev = std::sqrt(2 * n_base * k_base / std::sqrt(3.0));
  const pb::Measurement* b = Find(ms, kFitBiasInstability);
  ASSERT_NE(b, nullptr);
  EXPECT_NEAR(b->value(), min_dev * 3600 / 0.664, 0.02 * min_dev * 3600 / 0.664);
  // A term the model leaves out: its upper bound, said so.
  const pb::Measurement* r = Find(ms, kFitRateRamp);
  ASSERT_NE(r, nullptr);
  EXPECT_TRUE(r->note().starts_with("upper bound")) << r->note();
  EXPECT_GT(r->value(), 0);
  EXPECT_FALSE(r->has_uncertainty());
  // The model and its adequacy.
  const pb::Measurement* p = Find(ms, kNoiseModelPValue);
  ASSERT_NE(p, nullptr);
  EXPECT_GT(p->value(), 0.01);
  EXPECT_TRUE(p->note().starts_with("model N+K,")) << p->note();
  // The selected model's own parameters, for plots.
  const pb::Measurement* white = Find(ms, "model_white_noise");
  ASSERT_NE(white, nullptr);
  EXPECT_EQ(white->unit(), "deg/sqrt(h)");
  EXPECT_NEAR(white->value(), 0.1, 0.1 * 0.01);
  EXPECT_NE(Find(ms, "model_rate_random_walk"), nullptr);
  for (const pb::Measurement& m : ms) EXPECT_FALSE(m.model_inadequate()) << m.name();
}

// No model here makes a curve that zigzags by a factor 3 between octaves:
// every judged value is withheld unless the plan asks for it.
TEST(MeasureNoiseModelTest, InadequateModelWithholdsEveryJudgedValue) {
  allan::Curve curve = ExactCurve(WhitePlusRandomWalk());
  for (size_t i = 0; i < curve.points.size(); ++i) curve.points[i].dev *= i % 2 ? 3.0 : 1.0 / 3;
  const std::vector<pb::Measurement> ms = MeasureNoiseModel("x", pb::GYRO, curve);
  int judged = 0;
  for (const pb::Measurement& m : ms) {
    if (!m.name().starts_with("fit_")) continue;
    ++judged;
    EXPECT_TRUE(std::isnan(m.value())) << m.name();
    EXPECT_FALSE(m.has_uncertainty()) << m.name();
    EXPECT_TRUE(m.model_inadequate()) << m.name();
    EXPECT_TRUE(m.note().starts_with("not measurable: noise model inadequate")) << m.note();
  }
  EXPECT_EQ(judged, 5);
  const pb::Measurement* p = Find(ms, kNoiseModelPValue);
  ASSERT_NE(p, nullptr);
  EXPECT_LT(p->value(), 0.01);
  EXPECT_NE(p->note().find("INADEQUATE"), std::string::npos) << p->note();

  NoiseModelOptions keep;
  keep.judge_inadequate_values = true;
  const std::vector<pb::Measurement> kept = MeasureNoiseModel("x", pb::GYRO, curve, keep);
  const pb::Measurement* n = Find(kept, kFitAngleRandomWalk);
  ASSERT_NE(n, nullptr);
  EXPECT_TRUE(std::isfinite(n->value()));
  EXPECT_TRUE(n->model_inadequate());
  EXPECT_NE(n->note().find("judged although the model is inadequate"), std::string::npos)
      << n->note();
}

TEST(MeasureNoiseModelTest, TooShortACurveHasNoModel) {
  allan::Curve curve = ExactCurve(WhitePlusRandomWalk());
  curve.points.resize(3);
  const std::vector<pb::Measurement> ms = MeasureNoiseModel("x", pb::GYRO, curve);
  const pb::Measurement* n = Find(ms, kFitAngleRandomWalk);
  ASSERT_NE(n, nullptr);
  EXPECT_TRUE(std::isnan(n->value()));
  EXPECT_TRUE(n->note().starts_with("no noise model: ")) << n->note();
  EXPECT_FALSE(n->model_inadequate());  // not measured: a FAIL where limited
}

}  // namespace
}  // namespace imuqual::judge
