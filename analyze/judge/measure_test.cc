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

// A curve that never turns up (white noise and flicker, no random walk):
// the model's minimum over the analysed taus is at their end. Reported with
// its u, not as an upper bound: on simulated records where a fit left the
// random walk out, the truth's minimum lay above that minimum in 68-91 %, so
// the value is the midpoint up to the minimum with the random walk the data
// allow at 1 sigma, the half-span in its u.
TEST(MeasureNoiseModelTest, AModelMinimumAtTheEdgeIsNotCalledABound) {
  allan::CompositeModel model;
  model.terms.push_back({allan::TermKind::kWhite, 0.1 / 60});
  model.terms.push_back({allan::TermKind::kFlicker, 1.0 / 3600});
  const allan::Curve curve = ExactCurve(model);
  const std::vector<pb::Measurement> ms = MeasureNoiseModel("x", pb::GYRO, curve);
  const pb::Measurement* b = Find(ms, kFitBiasInstability);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(b->qualifier(), pb::QUALIFIER_NONE);
  EXPECT_NE(b->note().find("minimum at the edge of the analysed taus"), std::string::npos)
      << b->note();
  EXPECT_NE(b->note().find("random walk the data allow at 1 sigma"), std::string::npos)
      << b->note();
  EXPECT_NE(b->uncertainty_method().find("half the rise"), std::string::npos)
      << b->uncertainty_method();
  // The exact curve's minimum (its longest tau), as B in deg/h: the value
  // lies above it by the half-span, which its u holds.
  double truth = INFINITY;
  for (const allan::CurvePoint& p : curve.points) truth = std::min(truth, p.dev * 3600 / 0.664);
  ASSERT_TRUE(b->has_uncertainty());
  EXPECT_GT(b->value(), truth * (1 + 1e-3));
  EXPECT_LE(b->value() - truth, b->uncertainty() * (1 + 1e-6));
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
  EXPECT_EQ(r->qualifier(), pb::UPPER_BOUND);
  EXPECT_TRUE(r->uncertainty_method().starts_with("none: upper bound only"))
      << r->uncertainty_method();
  // Measured terms: how their sigma was obtained.
  for (const pb::Measurement* m : {n, k, b}) {
    EXPECT_EQ(m->qualifier(), pb::QUALIFIER_NONE) << m->name();
    EXPECT_TRUE(m->uncertainty_method().starts_with("parametric bootstrap")) << m->name();
  }
  // The model and its adequacy.
  const pb::Measurement* p = Find(ms, kNoiseModelPValue);
  ASSERT_NE(p, nullptr);
  EXPECT_GT(p->value(), 0.01);
  EXPECT_TRUE(p->note().starts_with("model N+K,")) << p->note();
  EXPECT_EQ(p->qualifier(), pb::QUALIFIER_NONE);
  EXPECT_FALSE(p->uncertainty_method().empty());
  // The selected model's own parameters, for plots.
  const pb::Measurement* white = Find(ms, "model_white_noise");
  ASSERT_NE(white, nullptr);
  EXPECT_EQ(white->unit(), "deg/sqrt(h)");
  EXPECT_NEAR(white->value(), 0.1, 0.1 * 0.01);
  EXPECT_NE(Find(ms, "model_rate_random_walk"), nullptr);
  EXPECT_TRUE(white->uncertainty_method().starts_with("parametric bootstrap"))
      << white->uncertainty_method();
  for (const pb::Measurement& m : ms) {
    EXPECT_FALSE(m.model_inadequate()) << m.name();
    EXPECT_FALSE(m.uncertainty_method().empty()) << m.name();
    EXPECT_EQ(m.has_uncertainty(), !m.uncertainty_method().starts_with("none")) << m.name();
  }
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
    EXPECT_EQ(m.qualifier(), pb::NOT_MEASURABLE) << m.name();
    EXPECT_EQ(m.uncertainty_method(), "none: not measurable (noise model inadequate)");
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
  for (const pb::Measurement& m : kept) {
    if (m.name().starts_with("fit_") && std::isfinite(m.value())) {
      EXPECT_EQ(m.qualifier(), pb::MODEL_INADEQUATE) << m.name();
    }
  }
}

// The plan's noise-model range: the points below it are not fitted, and
// every model value's note says from where and why; an inadequate model's
// note says where it misses.
TEST(MeasureNoiseModelTest, ThePlansRangeIsFittedAndSaidOnEveryValue) {
  allan::Curve curve = ExactCurve(WhitePlusRandomWalk());
  for (size_t i = 0; i < 3; ++i) curve.points[i].dev *= 0.5;  // a filter's flattening
  NoiseModelOptions options;
  options.min_tau_s = curve.points[3].tau_s;
  options.range_reason = "the part's decimation filter";
  const std::vector<pb::Measurement> ms = MeasureNoiseModel("x", pb::GYRO, curve, options);
  const pb::Measurement* p = Find(ms, kNoiseModelPValue);
  ASSERT_NE(p, nullptr);
  EXPECT_GT(p->value(), 0.01) << p->note();
  ASSERT_DOUBLE_EQ(options.min_tau_s, 0.08);
  const std::string said = "fitted at tau >= 0.08 s (the part's decimation filter)";
  EXPECT_NE(p->note().find(said), std::string::npos) << p->note();
  const pb::Measurement* n = Find(ms, kFitAngleRandomWalk);
  ASSERT_NE(n, nullptr);
  EXPECT_NEAR(n->value(), 0.1, 0.1 * 0.01);
  EXPECT_NE(n->note().find(said), std::string::npos) << n->note();

  // Over every point the flattened taus are a misfit the record locates.
  const std::vector<pb::Measurement> all = MeasureNoiseModel("x", pb::GYRO, curve);
  const pb::Measurement* q = Find(all, kNoiseModelPValue);
  ASSERT_NE(q, nullptr);
  EXPECT_LT(q->value(), 0.01) << q->note();
  EXPECT_NE(q->note().find("; largest misfits 0."), std::string::npos)
      << q->note();
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
  for (const pb::Measurement& m : ms) {
    EXPECT_EQ(m.qualifier(), pb::NOT_MEASURABLE) << m.name();
    EXPECT_EQ(m.uncertainty_method(), "none: not measured") << m.name();
  }
}

// ---- MeasureAxis: qualifiers and uncertainty methods ----

// White noise only: the curve falls to its last point, so the minimum is
// not resolved and no +1/2 slope is seen (RRW an upper bound).
TEST(MeasureAxisTest, UnresolvedMinimumAndUpperBoundReadOffs) {
  allan::CompositeModel white;
  white.terms.push_back({allan::TermKind::kWhite, 0.1 / 60});
  const std::vector<pb::Measurement> ms = MeasureAxis("x", pb::GYRO, ExactCurve(white), 0.0);
  for (std::string_view name : {kBiasInstability, kBiasInstabilityIeee, kTauAtMinimum}) {
    const pb::Measurement* m = Find(ms, name);
    ASSERT_NE(m, nullptr) << name;
    EXPECT_EQ(m->qualifier(), pb::MINIMUM_NOT_RESOLVED) << name;
    EXPECT_NE(m->note().find("(upper bound)"), std::string::npos) << m->note();
  }
  const pb::Measurement* b = Find(ms, kBiasInstability);
  ASSERT_TRUE(b->has_uncertainty());
  EXPECT_TRUE(b->uncertainty_method().starts_with(
      "the least of the bottom's points within an octave, drawn 4000 times"))
      << b->uncertainty_method();
  EXPECT_TRUE(Find(ms, kBiasInstabilityIeee)
                  ->uncertainty_method()
                  .ends_with("times this curve's level; divided by 0.664 like the value"));
  // The tau of a minimum that is the curve's last point has no standard
  // uncertainty: the curve may fall further.
  const pb::Measurement* tau = Find(ms, kTauAtMinimum);
  EXPECT_FALSE(tau->has_uncertainty());
  EXPECT_EQ(tau->uncertainty_method(), "none: the minimum is at the longest tau (not resolved)");
  const pb::Measurement* k = Find(ms, kRateRandomWalk);
  ASSERT_NE(k, nullptr);
  EXPECT_EQ(k->qualifier(), pb::UPPER_BOUND);
  EXPECT_EQ(k->uncertainty_method(), "none: upper bound only");
  const pb::Measurement* n = Find(ms, kAngleRandomWalk);
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->qualifier(), pb::QUALIFIER_NONE);
  ASSERT_TRUE(n->has_uncertainty());
  EXPECT_GT(n->uncertainty(), 0);
  EXPECT_LT(n->uncertainty(), 0.1 * n->value());
  EXPECT_TRUE(
      n->uncertainty_method().starts_with("weighted fit of AVAR x tau = N^2 + b/tau + c tau"));
  EXPECT_FALSE(Find(ms, kBiasOffset)->has_uncertainty());
  EXPECT_TRUE(Find(ms, kBiasOffset)->uncertainty_method().starts_with("none: the mean"));
  EXPECT_EQ(Find(ms, kBiasOffset)->qualifier(), pb::QUALIFIER_NONE);
}

// White noise and rate random walk: a resolved minimum, both slopes seen.
TEST(MeasureAxisTest, ResolvedMinimumIsAMeasuredValue) {
  const std::vector<pb::Measurement> ms =
      MeasureAxis("x", pb::GYRO, ExactCurve(WhitePlusRandomWalk()), 0.0);
  for (const pb::Measurement& m : ms) {
    EXPECT_EQ(m.qualifier(), pb::QUALIFIER_NONE) << m.name() << ": " << m.note();
    EXPECT_FALSE(m.uncertainty_method().empty()) << m.name();
  }
  EXPECT_TRUE(Find(ms, kBiasInstability)->has_uncertainty());
  // The minimum's tau: its u drawn about the bottom's shape, whose vertex
  // the note names.
  const pb::Measurement* tau = Find(ms, kTauAtMinimum);
  ASSERT_TRUE(tau->has_uncertainty()) << tau->uncertainty_method();
  EXPECT_GT(tau->uncertainty(), 0);
  EXPECT_LT(tau->uncertainty(), tau->value());
  EXPECT_TRUE(tau->uncertainty_method().starts_with("drawn about the bottom's shape"));
  EXPECT_TRUE(tau->note().starts_with("the bottom's vertex at ")) << tau->note();
  // A live update leaves the draws to the looks and the final result.
  const std::vector<pb::Measurement> live =
      MeasureAxis("x", pb::GYRO, ExactCurve(WhitePlusRandomWalk()), 0.0, false);
  EXPECT_FALSE(Find(live, kTauAtMinimum)->has_uncertainty());
  EXPECT_EQ(Find(live, kTauAtMinimum)->value(), tau->value());
  EXPECT_TRUE(Find(live, kTauAtMinimum)
                  ->uncertainty_method()
                  .starts_with("none: worked out in the final result"));
  EXPECT_TRUE(Find(ms, kAngleRandomWalk)->has_uncertainty());
  EXPECT_FALSE(Find(ms, kRateRandomWalk)->has_uncertainty());
  EXPECT_TRUE(Find(ms, kRateRandomWalk)->uncertainty_method().starts_with("none: the +1/2 line"));
}

TEST(MeasureAxisTest, NoCurveIsNotMeasurable) {
  const std::vector<pb::Measurement> ms = MeasureAxis("x", pb::GYRO, allan::Curve{}, allan::kNaN);
  ASSERT_FALSE(ms.empty());
  for (const pb::Measurement& m : ms) {
    EXPECT_TRUE(std::isnan(m.value())) << m.name();
    EXPECT_EQ(m.qualifier(), pb::NOT_MEASURABLE) << m.name();
    EXPECT_EQ(m.uncertainty_method(), "none: not measured") << m.name();
  }
}

TEST(MeasureRunTest, CountsAreExactAndTimingSaysHowItsSigmaWasObtained) {
  std::vector<pb::Measurement> run = MeasureRun(3600, 360000, 10, 0, 3);
  ASSERT_EQ(run.size(), 3u);
  for (const pb::Measurement& m : run) {
    EXPECT_EQ(m.qualifier(), pb::QUALIFIER_NONE) << m.name();
    EXPECT_TRUE(m.uncertainty_method().starts_with("none: a count of samples")) << m.name();
  }
  run = MeasureRun(0, 0, 0, 0, 3);  // no samples: fractions not measurable
  EXPECT_EQ(run[1].qualifier(), pb::NOT_MEASURABLE);
  EXPECT_EQ(run[1].uncertainty_method(), "none: not measured");

  std::vector<pb::Measurement> timing = MeasureTiming(100, 100.01, 0.002, 0.001);
  ASSERT_EQ(timing.size(), 3u);
  EXPECT_TRUE(timing[0].has_uncertainty());
  EXPECT_TRUE(timing[0].uncertainty_method().starts_with("the line under each second's least-late"))
      << timing[0].uncertainty_method();
  EXPECT_TRUE(timing[1].uncertainty_method().starts_with("measured_rate's standard error"));
  EXPECT_TRUE(timing[2].uncertainty_method().starts_with("none:"));
  timing = MeasureTiming(100, 100.01, allan::kNaN, 0.001);
  EXPECT_FALSE(timing[0].has_uncertainty());
  EXPECT_TRUE(timing[0].uncertainty_method().starts_with("none:"));
}

TEST(MeasureTemperatureTest, MeanRangeAndSlopeWithItsStandardError) {
  // GIVEN 120 one-minute batch readings of a unit warming at 0.5 deg C/h
  // from 25 deg C, with +-0.05 deg C of alternating reading noise
  TemperatureReadings r;
  for (int i = 0; i < 120; ++i) {
    const double t = 30.0 + 60.0 * i;  // the middle of each minute
    r.Add(25.0 + 0.5 * t / 3600 + (i % 2 ? 0.05 : -0.05), t, 6000);
  }
  const std::vector<pb::Measurement> m = MeasureTemperature(r);
  ASSERT_EQ(m.size(), 3u);
  // THEN the mean is the middle of the ramp, the range its span plus the
  // noise, the slope 0.5 deg C/h within 3 of its standard errors (0.008)
  EXPECT_EQ(m[0].name(), kTemperatureMean);
  EXPECT_EQ(m[0].unit(), "deg C");
  EXPECT_NEAR(m[0].value(), 25.0 + 0.5 * 1.0, 1e-9);
  EXPECT_EQ(m[1].name(), kTemperatureRange);
  EXPECT_NEAR(m[1].value(), 0.5 * 119.0 / 60 + 0.1, 1e-9);
  EXPECT_EQ(m[2].name(), kTemperatureSlope);
  EXPECT_EQ(m[2].unit(), "deg C/h");
  ASSERT_TRUE(m[2].has_uncertainty());
  EXPECT_GT(m[2].uncertainty(), 0);
  EXPECT_LT(m[2].uncertainty(), 0.01);
  EXPECT_NEAR(m[2].value(), 0.5, 3 * m[2].uncertainty());
  for (const pb::Measurement& x : m) EXPECT_FALSE(x.uncertainty_method().empty()) << x.name();
}

TEST(MeasureTemperatureTest, NoReadingsNoMeasurementsAndTwoReadingsNoSlope) {
  EXPECT_TRUE(MeasureTemperature(TemperatureReadings{}).empty());
  TemperatureReadings r;
  r.Add(24.0, 10, 100);
  r.Add(26.0, 20, 300);
  const std::vector<pb::Measurement> m = MeasureTemperature(r);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_DOUBLE_EQ(m[0].value(), 25.5);  // weighted by samples
  EXPECT_DOUBLE_EQ(m[1].value(), 2.0);
  EXPECT_TRUE(std::isnan(m[2].value()));
  EXPECT_EQ(m[2].qualifier(), pb::NOT_MEASURABLE);
  EXPECT_NE(m[2].note().find("a slope needs 3"), std::string::npos) << m[2].note();
}

}  // namespace
}  // namespace imuqual::judge
