#include "analyze/judge/measure.h"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <cstdio>

#include "analyze/allan/gmwm.h"
#include "analyze/allan/model_quantities.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

using allan::NoiseTerm;

pb::Measurement Make(const std::string& axis, std::string_view name, double value,
                     pb::AxisKind kind, const std::string& note = "") {
  return NewMeasurement(axis, name, value, UnitFor(*FindMeasurement(name), kind), note);
}

// How an uncertainty was obtained, or why a measurement has none
// (Measurement.uncertainty_method).
constexpr const char* kMinimumMethod =
    "the least of the bottom's points within an octave, drawn 4000 times about the bottom's shape "
    "(AVAR = a/tau + b + c tau fitted within 2 octaves) with their chi-square spreads (Greenhall "
    "edf of the shape's white + flicker + random-walk mixture) and flicker FM's correlations: "
    "half the 95.45 % quantile of |least - truth| as a "
    "fraction of the bottom's level, times this curve's level";
constexpr const char* kMinimumPointMethod =
    "chi2 (Greenhall edf, flicker FM) at the minimum combined with the spread of points within "
    "an octave (too few points about the bottom to fit its shape)";
constexpr const char* kTauMethod =
    "drawn about the bottom's shape (AVAR = a/tau + b + c tau fitted within 2 octaves, vertex "
    "sqrt(a/c)): the points within 2 octaves drawn 4000 times with their chi-square spreads "
    "(Greenhall edf of the shape's shares) and the shape's correlations; u(ln tau) is the 68.27 % "
    "quantile of |ln tau(least point) - ln vertex| over the draws (the minimum wanders over a "
    "flat bottom and cannot pass the curve's end); the value's u is tau x u(ln tau), first "
    "order: for u(ln tau) above ~0.3 the interval tau exp(+-k u(ln tau)) is the better one, "
    "wider above than below; coverage on ln tau over 200 simulated records of each of four "
    "mixtures (one with its minimum 0.75 octave from the curve's end): 1-sigma 69-79 %, 2-sigma "
    "93-99.5 %";
constexpr const char* kArwMethod =
    "weighted fit of AVAR x tau = N^2 + b/tau + c tau over the clean points of the -1/2 line "
    "(b: quantization or the sensor filter's deficit, c: flicker's rise), sandwich covariance "
    "with the white-noise correlations of the points (Greenhall edf); on simulated gyros "
    "(plain, "
    "Gauss-Markov, 20 Hz filtered white) the 1-sigma interval covered the truth in 68-70 %";
constexpr const char* kRrwNone =
    "none: the +1/2 line read-off's chi-square error does not cover its bias from flicker noise "
    "(covered the truth in 5-42 % of simulated records); fit_rate_random_walk carries the noise "
    "model's uncertainty";
constexpr const char* kBiasOffsetNone =
    "none: the mean of the analysed samples, exact as the soak's mean; as the unit's bias, its "
    "soak-to-soak spread sigma_A(T) at the record's length T is not measurable from one record: "
    "the rate random walk that rules it shows only beyond T/9 (noise models fitted to 87-min "
    "simulated records left K out in most seeds and put sigma_A(T) 2-3x low)";
constexpr const char* kNotMeasured = "none: not measured";
constexpr const char* kUpperBoundOnly = "none: upper bound only";
constexpr const char* kExactCount = "none: a count of samples, exact";
constexpr const char* kFitMethod =
    "parametric bootstrap of the noise-model fit (replicates drawn from the moments' covariance "
    "and refitted), Akaike-weighted over the plausible models with the selection uncertainty";
constexpr const char* kModelTermMethod =
    "parametric bootstrap of the noise-model fit (replicates drawn from the moments' covariance "
    "and refitted with the selected model)";
constexpr const char* kNoBootstrapSigma = "none: the noise-model fit gave no sigma";

// A NaN value is not measurable: said so, whatever else was set.
void QualifyMissing(pb::Measurement* m) {
  if (!std::isnan(m->value())) return;
  m->set_qualifier(pb::NOT_MEASURABLE);
  m->clear_uncertainty();
  if (!m->model_inadequate()) m->set_uncertainty_method(kNotMeasured);
}

allan::SensorKind Sensor(pb::AxisKind kind) {
  return kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
}

// A base-unit value in the measurement's datasheet unit.
double Datasheet(NoiseTerm term, pb::AxisKind kind, double base) {
  return allan::ToDatasheetUnits(term, Sensor(kind), base).value;
}

}  // namespace

std::vector<pb::Measurement> MeasureAxis(const std::string& axis, pb::AxisKind kind,
                                         const allan::Curve& curve, double mean_rate,
                                         bool tau_uncertainty) {
  const bool gyro = kind != pb::ACCEL;
  std::vector<pb::Measurement> out;

  // The curve minimum and IEEE 952's B = minimum / 0.664.
  const std::optional<allan::CurveMinimum> min = allan::FindCurveMinimum(curve);
  const bool unresolved = min && min->m == curve.points.back().m;
  std::string min_note = min ? "" : "no curve";
  if (unresolved) {
    min_note = "minimum at the longest tau: the curve has not turned up yet (upper bound)";
  }
  const double nan = allan::kNaN;
  out.push_back(Make(axis, kBiasInstability,
                     min ? Datasheet(NoiseTerm::kBiasInstability, kind, min->dev) : nan, kind,
                     min_note));
  out.push_back(
      Make(axis, kBiasInstabilityIeee,
           min ? Datasheet(NoiseTerm::kBiasInstability, kind, min->bias_instability_ieee) : nan,
           kind, min_note));
  // Their 1-sigma uncertainty: the spread of the least of the bottom's
  // noisy points (allan::MinimumSelectionSpread), else the minimum point's
  // chi-square spread and how far it lies below its neighbours.
  const std::optional<double> drawn =
      min ? allan::MinimumSelectionSpread(curve, *min) : std::nullopt;
  const char* minimum_method = drawn ? kMinimumMethod : kMinimumPointMethod;
  if (const double u = drawn ? *drawn
                       : min ? allan::MinimumPointSpread(curve, *min)
                             : nan;
      std::isfinite(u)) {
    const double ratio = min->bias_instability_ieee / min->dev;
    out[out.size() - 2].set_uncertainty(Datasheet(NoiseTerm::kBiasInstability, kind, u));
    out.back().set_uncertainty(Datasheet(NoiseTerm::kBiasInstability, kind, u * ratio));
  }
  out.push_back(Make(axis, kTauAtMinimum, min ? min->tau_s : nan, kind, min_note));
  // Its standard uncertainty: how far the least point wanders from the
  // bottom's vertex (the value stays the point B was read at, an archived
  // point of the curve).
  std::string tau_none;
  if (min && !unresolved && !tau_uncertainty) {
    tau_none =
        "none: worked out in the final result (and at the looks when the plan judges it), not on "
        "live updates";
  } else if (min && !unresolved) {
    const allan::MinimumTauSpread v = allan::MinimumTauSelectionSpread(curve, *min);
    if (v.resolved) {
      out.back().set_uncertainty(min->tau_s * v.u_ln_tau);
      out.back().set_note("the bottom's vertex at " + Num(v.vertex_s) + " s (" +
                          std::to_string(v.points) + " points drawn, " + Num(v.tau_lo_s) + "-" +
                          Num(v.tau_hi_s) + " s); u(ln tau) " + Num(v.u_ln_tau));
    } else {
      tau_none = "none: no standard uncertainty for the minimum's tau from this curve: " + v.why;
    }
  }
  for (size_t i = out.size() - 3; i < out.size(); ++i) {
    pb::Measurement& m = out[i];
    if (unresolved) m.set_qualifier(pb::MINIMUM_NOT_RESOLVED);
    if (m.has_uncertainty()) {
      m.set_uncertainty_method(m.name() == kTauAtMinimum ? std::string(kTauMethod)
                               : i + 2 == out.size()     ? std::string(minimum_method) +
                                                           "; divided by 0.664 like the value"
                                                     : minimum_method);
    } else if (m.name() == kTauAtMinimum && !tau_none.empty()) {
      m.set_uncertainty_method(tau_none);
    } else if (m.name() == kTauAtMinimum && unresolved) {
      m.set_uncertainty_method("none: the minimum is at the longest tau (not resolved)");
    } else {
      m.set_uncertainty_method("none: no Greenhall edf at the minimum's point");
    }
    QualifyMissing(&m);
  }

  // Slope-line read-offs: N at tau = 1 s on -1/2, K at tau = 3 s on +1/2.
  const allan::SlopeReadoff n = allan::ReadSlopeLine(curve, NoiseTerm::kAngleRandomWalk);
  out.push_back(Make(axis, gyro ? kAngleRandomWalk : kVelocityRandomWalk,
                     Datasheet(NoiseTerm::kAngleRandomWalk, kind, n.value), kind,
                     !n.upper_bound_only      ? ""
                     : n.points_on_slope == 0 ? "upper bound only: no point on the -1/2 slope"
                     : n.points_in_fit == 0
                         ? "upper bound only: no point on the -1/2 slope to both neighbours"
                         : "upper bound only: the -1/2 line's fit gives no positive white-noise "
                           "level"));
  const allan::SlopeReadoff k = allan::ReadSlopeLine(curve, NoiseTerm::kRateRandomWalk);
  out.push_back(Make(axis, kRateRandomWalk, Datasheet(NoiseTerm::kRateRandomWalk, kind, k.value),
                     kind,
                     k.upper_bound_only ? "upper bound only: no point on the +1/2 slope" : ""));
  out.push_back(
      Make(axis, kBiasOffset, Datasheet(NoiseTerm::kBiasInstability, kind, mean_rate), kind));
  // The read-offs: an upper bound where the curve never shows the slope.
  pb::Measurement& arw = out[out.size() - 3];
  if (!n.upper_bound_only && std::isfinite(n.uncertainty)) {
    arw.set_uncertainty(Datasheet(NoiseTerm::kAngleRandomWalk, kind, n.uncertainty));
    std::string method = kArwMethod;
    char detail[96];
    if (n.line_terms == 1) {
      std::snprintf(detail, sizeof detail,
                    "; %d point%s over a short span: N^2 alone (a weighted mean)", n.points_in_fit,
                    n.points_in_fit == 1 ? "" : "s");
      method += detail;
    }
    if (n.birge_ratio > 1) {
      std::snprintf(detail, sizeof detail,
                    "; scaled by the Birge ratio %.3g (the points scatter more)", n.birge_ratio);
      method += detail;
    }
    arw.set_uncertainty_method(method);
  } else {
    arw.set_uncertainty_method(n.upper_bound_only ? kUpperBoundOnly
                                                  : "none: no Greenhall edf at the line's points");
  }
  out[out.size() - 2].set_uncertainty_method(k.upper_bound_only ? kUpperBoundOnly : kRrwNone);
  out.back().set_uncertainty_method(kBiasOffsetNone);
  for (const auto& [m, bound_only] :
       {std::pair{&out[out.size() - 3], n.upper_bound_only},
        std::pair{&out[out.size() - 2], k.upper_bound_only}, std::pair{&out.back(), false}}) {
    if (bound_only) m->set_qualifier(pb::UPPER_BOUND);
    QualifyMissing(m);
  }

  return out;
}

std::vector<pb::Measurement> MeasureNoiseModel(const std::string& axis, pb::AxisKind kind,
                                               const allan::Curve& curve,
                                               const NoiseModelOptions& options) {
  const bool gyro = kind != pb::ACCEL;
  const std::string_view judged[] = {kFitQuantization,
                                     gyro ? kFitAngleRandomWalk : kFitVelocityRandomWalk,
                                     kFitBiasInstability, kFitRateRandomWalk, kFitRateRamp};
  std::vector<pb::Measurement> out;
  allan::GmwmOptions fit_options;
  fit_options.stop = allan::StopRule::kNone;  // the curve is already cut by the plan's rule
  fit_options.min_tau_s = options.min_tau_s;
  std::string range_note = options.min_tau_s > 0 ? "; fitted at tau >= " + Num(options.min_tau_s) +
                                                       " s (" + options.range_reason + ")"
                                                 : "";
  if (!options.long_taus.empty()) {
    const allan::Theo1Moment& last = options.long_taus.back();
    range_note +=
        "; Theo1 moments to " +
        Num(0.75 * static_cast<double>(last.m * last.block) * curve.tau0_s) + " s in the fit" +
        (last.block > 1 ? " (of the means of " + std::to_string(last.block) + " samples)" : "");
  } else if (!options.long_tau_note.empty()) {
    range_note += "; " + options.long_tau_note;
  }
  const Result<allan::CompositeFit> fit =
      allan::FitCompositeModel(curve, fit_options, options.long_taus);
  if (!fit.ok()) {
    for (std::string_view name : judged) {
      out.push_back(
          Make(axis, name, allan::kNaN, kind, "no noise model: " + fit.status().message()));
    }
    out.push_back(Make(axis, kNoiseModelPValue, allan::kNaN, kind,
                       "no noise model: " + fit.status().message()));
    for (pb::Measurement& m : out) QualifyMissing(&m);
    return out;
  }
  const allan::SensorKind sensor = Sensor(kind);
  const std::vector<allan::ModelQuantity> quantities = allan::DescribeCompositeFit(*fit, sensor);
  auto quantity = [&](std::string_view name) -> const allan::ModelQuantity* {
    for (const allan::ModelQuantity& q : quantities) {
      if (q.name == name) return &q;
    }
    return nullptr;
  };
  // The model behind every value, and the runners-up (AICc differences and
  // Akaike weights), as the p-value's note.
  char head[160];
  std::snprintf(head, sizeof head, "model %s, J %.3g on %d dof, %s at the %g level",
                fit->model.Name().c_str(), fit->objective, fit->dof,
                fit->adequate ? "adequate" : kInadequateModelMark.data(),  // a literal: terminated
                fit_options.adequacy_level);
  std::string model_note = head + range_note;
  if (!fit->adequate) model_note += "; largest misfits " + allan::LargestResiduals(*fit);
  for (size_t i = 1; i < fit->candidates.size() && i < 4; ++i) {
    const allan::ModelCandidate& c = fit->candidates[i];
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s %s (criterion %+.2g, weight %.2g)",
                  i == 1 ? "; runners-up" : ",", c.name.c_str(), c.criterion - fit->criterion,
                  c.weight);
    model_note += buf;
  }
  char inadequate_head[200];
  std::snprintf(inadequate_head, sizeof inadequate_head,
                "not measurable: noise model inadequate (%s, J-test p = %.2g < %g; largest misfits ",
                fit->model.Name().c_str(), fit->p_value, fit_options.adequacy_level);
  const std::string inadequate =
      inadequate_head + (fit->adequate ? std::string() : allan::LargestResiduals(*fit)) + ")";
  const bool withhold = !fit->adequate && !options.judge_inadequate_values;

  // name -> the quantity the judged measurement reports.
  const std::pair<std::string_view, std::string_view> source[] = {
      {kFitQuantization, "quantization"},
      {kFitAngleRandomWalk, "angle_random_walk"},
      {kFitVelocityRandomWalk, "velocity_random_walk"},
      {kFitBiasInstability, "bias_instability_ieee"},
      {kFitRateRandomWalk, "rate_random_walk"},
      {kFitRateRamp, "rate_ramp"}};
  for (std::string_view name : judged) {
    const allan::ModelQuantity* q = nullptr;
    for (const auto& [n, from] : source) {
      if (n == name) q = quantity(from);
    }
    pb::Measurement m = Make(axis, name, allan::kNaN, kind);
    if (q == nullptr || (q->absent && !std::isfinite(q->upper_bound))) {
      m.set_note(q == nullptr ? "not in the model's report" : q->note);
    } else if (q->absent) {
      // What the data allow of a term the model leaves out, judged as such.
      m.set_value(q->upper_bound);
      m.set_note("upper bound (95 %): the term is not in the selected model " + fit->model.Name());
      m.set_qualifier(pb::UPPER_BOUND);
      m.set_uncertainty_method(std::string(kUpperBoundOnly) +
                               " (95 %, where the profile of the fit objective rises by 5.412)");
    } else {
      m.set_value(q->value);
      if (std::isfinite(q->sigma)) m.set_uncertainty(q->sigma);
      m.set_uncertainty_method(std::isfinite(q->sigma) ? kFitMethod : kNoBootstrapSigma);
      m.set_note(q->note);
      // K of a model without flicker reads high (the random walk absorbs an
      // unresolved flicker floor): the midpoint down to K with the flicker
      // allowed at 1 sigma, the span rectangular in the u (the note says so).
      if (name == kFitRateRandomWalk && fit->rate_random_walk_half_span > 0) {
        m.set_uncertainty_method(std::string(kFitMethod) +
                                 ", in quadrature with the span to K under the flicker the data "
                                 "allow at 1 sigma (rectangular: half-span / sqrt 3)");
      }
      // A model curve whose minimum over the analysed taus is at their edge
      // (typically a model that left the rate random walk out, so it never
      // turns up). Where the data bound the random walk, the value is the
      // midpoint up to the minimum with the random walk allowed at 1 sigma
      // and the u holds the half-span (the model's own note says so;
      // fit_coverage_bench: 73.5 / 98.0 % and 73.5 / 97.5 % at 1 / 2 sigma
      // where the bare minimum gave 67.0 / 92.0 and 64.0 / 93.5 %). Else it
      // is the model's minimum over those taus, reading low (mean z -0.5 to
      // -1.7 simulated).
      if (name == kFitBiasInstability && fit->minimum_at_edge) {
        if (fit->edge_half_span > 0) {
          m.set_uncertainty_method(
              std::string(kFitMethod) +
              ", in quadrature with half the rise of the minimum under the random walk the data "
              "allow at 1 sigma");
        } else {
          m.set_note(
              "the model curve's minimum over the analysed taus is at their edge (it has not "
              "turned up there): the value reads low there (simulated: mean z -0.5 to -1.7)");
        }
      }
    }
    if (!fit->adequate) {
      m.set_model_inadequate(true);
      if (withhold) {
        m.set_value(allan::kNaN);
        m.clear_uncertainty();
        m.set_note(inadequate);
        m.set_uncertainty_method("none: not measurable (noise model inadequate)");
      } else {
        // Judged as the plan asks, but never taken for a sound figure.
        if (std::isfinite(m.value())) m.set_qualifier(pb::MODEL_INADEQUATE);
        char judged_anyway[120];
        std::snprintf(judged_anyway, sizeof judged_anyway,
                      "; judged although the model is inadequate (J-test p = %.2g)", fit->p_value);
        m.set_note(m.note() + judged_anyway);
      }
    }
    if (!range_note.empty()) m.set_note(m.note() + range_note);
    QualifyMissing(&m);
    out.push_back(std::move(m));
  }
  pb::Measurement p = Make(axis, kNoiseModelPValue, fit->p_value, kind, model_note);
  p.set_uncertainty_method("none: a test statistic (the J test's p-value)");
  QualifyMissing(&p);
  out.push_back(std::move(p));

  // The selected model itself, for plots and audits (not judged).
  for (const allan::ModelQuantity& q : allan::DescribeModelTerms(*fit, sensor)) {
    pb::Measurement m;
    m.set_axis(axis);
    m.set_name(std::string(kModelParameterPrefix) + q.name);
    m.set_value(q.value);
    m.set_unit(q.unit);
    if (std::isfinite(q.sigma)) m.set_uncertainty(q.sigma);
    m.set_uncertainty_method(std::isfinite(q.sigma) ? kModelTermMethod : kNoBootstrapSigma);
    if (!fit->adequate) m.set_qualifier(pb::MODEL_INADEQUATE);
    m.set_note(fit->model.Name());
    QualifyMissing(&m);
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<pb::Measurement> MeasureRun(double duration_s, int64_t samples, int64_t gap_samples,
                                        int64_t invalid_samples, int num_axes) {
  std::vector<pb::Measurement> out;
  const double n = samples > 0 ? static_cast<double>(samples) : allan::kNaN;
  out.push_back(Make("", kDuration, duration_s, pb::GYRO));
  out.push_back(Make("", kGapFraction, static_cast<double>(gap_samples) / n, pb::GYRO));
  out.push_back(Make("", kInvalidFraction,
                     static_cast<double>(invalid_samples) / (n * std::max(num_axes, 1)), pb::GYRO));
  out[0].set_uncertainty_method("none: a count of samples times the nominal period, exact");
  out[1].set_uncertainty_method(kExactCount);
  out[2].set_uncertainty_method(kExactCount);
  for (pb::Measurement& m : out) QualifyMissing(&m);
  return out;
}

std::vector<pb::Measurement> MeasureTiming(double nominal_rate_hz, double measured_rate_hz,
                                           double rate_sigma_hz, double jitter_rms_s) {
  std::vector<pb::Measurement> out;
  pb::Measurement rate = Make("", kMeasuredRate, measured_rate_hz, pb::GYRO);
  pb::Measurement error =
      Make("", kRateError, (measured_rate_hz / nominal_rate_hz - 1.0) * 1e6, pb::GYRO);
  if (std::isfinite(rate_sigma_hz)) {
    rate.set_uncertainty(rate_sigma_hz);
    error.set_uncertainty(rate_sigma_hz / nominal_rate_hz * 1e6);
    rate.set_uncertainty_method(
        "the line under each second's least-late arrival (device counter against host clock; "
        "the lower convex hull's edge above the arrivals' mean counter): the least-squares "
        "standard error of its slope from those arrivals' scatter about it, a busy spell's "
        "seconds (beyond 5 robust sigma above the line) left out; the host clock's own error "
        "not included");
    error.set_uncertainty_method("measured_rate's standard error, relative to the nominal rate");
  } else {
    rate.set_uncertainty_method("none: too few arrival windows for a standard error");
    error.set_uncertainty_method("none: too few arrival windows for a standard error");
  }
  out.push_back(std::move(rate));
  out.push_back(std::move(error));
  out.push_back(Make("", kTimingJitter, jitter_rms_s * 1e3, pb::GYRO));
  out.back().set_uncertainty_method(
      "none: a statistic of the arrivals (RMS lateness), not an estimate of a quantity");
  for (pb::Measurement& m : out) QualifyMissing(&m);
  return out;
}

void TemperatureReadings::Add(double temperature_c, double t_s, double w) {
  if (count == 0) lowest_c = highest_c = temperature_c;
  lowest_c = std::min(lowest_c, temperature_c);
  highest_c = std::max(highest_c, temperature_c);
  ++count;
  weight += w;
  const double dt = t_s - mean_t_s;
  const double dc = temperature_c - mean_c;
  mean_t_s += dt * w / weight;
  mean_c += dc * w / weight;
  s_tt += w * dt * (t_s - mean_t_s);
  s_tc += w * dt * (temperature_c - mean_c);
  s_cc += w * dc * (temperature_c - mean_c);
}

std::vector<pb::Measurement> MeasureTemperature(const TemperatureReadings& r) {
  std::vector<pb::Measurement> out;
  if (r.count == 0) return out;
  const std::string readings =
      std::to_string(r.count) + " batch reading" + (r.count == 1 ? "" : "s");
  out.push_back(Make("", kTemperatureMean, r.mean_c, pb::GYRO));
  out.back().set_uncertainty_method("none: a summary of the unit's own readings (" + readings +
                                    "); their accuracy is the unit's sensor's");
  out.push_back(Make("", kTemperatureRange, r.highest_c - r.lowest_c, pb::GYRO));
  out.back().set_uncertainty_method("none: a statistic of the readings (" + readings + ")");
  double slope = allan::kNaN;
  double se = allan::kNaN;
  std::string note;
  if (r.count >= 3 && r.s_tt > 0) {
    slope = r.s_tc / r.s_tt;
    const double residual = std::max(r.s_cc - r.s_tc * r.s_tc / r.s_tt, 0.0);
    se = std::sqrt(residual / (static_cast<double>(r.count - 2) * r.s_tt));
  } else {
    note = "not measurable: " + readings + ", a slope needs 3";
  }
  out.push_back(Make("", kTemperatureSlope, slope * 3600, pb::GYRO, note));
  if (std::isfinite(se)) {
    out.back().set_uncertainty(se * 3600);
    out.back().set_uncertainty_method(
        "standard error of the weighted least-squares slope (" + readings +
        ", residuals taken independent: drift with structure makes it optimistic)");
  } else {
    out.back().set_uncertainty_method("none: no slope");
  }
  for (pb::Measurement& m : out) QualifyMissing(&m);
  return out;
}

bool MinimumSettled(const allan::Curve& curve, double horizon_m, std::string* why) {
  auto say = [&](std::string text) {
    if (why) *why = std::move(text);
    return false;
  };
  if (curve.points.size() < 4) return say("too few curve points");
  allan::GmwmOptions options;
  options.bootstrap_replicates = 0;
  options.absent_term_bounds = false;
  const auto fit = allan::FitCompositeModel(curve, options);
  if (!fit.ok()) return say("no noise model: " + fit.status().message());
  if (!fit->adequate) return say("noise model inadequate (J-test p " + Num(fit->p_value) + ")");
  const double last_m = static_cast<double>(curve.points.back().m);
  const double top = std::max(horizon_m, last_m);
  // The model on a fine log grid up to the horizon.
  double best_m = 1, best = fit->model.Avar(1, curve.tau0_s);
  const int steps = static_cast<int>(std::ceil(std::log2(top) * 32));
  for (int i = 1; i <= steps; ++i) {
    const double m = std::exp2(std::log2(top) * i / steps);
    const double v = fit->model.Avar(m, curve.tau0_s);
    if (v < best) {
      best = v;
      best_m = m;
    }
  }
  if (best_m > last_m / 2) {
    return say("the noise model's minimum up to the horizon lies at tau " +
               Num(best_m * curve.tau0_s) + " s, not well inside the measured " +
               Num(last_m * curve.tau0_s) + " s");
  }
  if (why) why->clear();
  return true;
}

double MinimumSideEvidence(const allan::Curve& curve, double bound_s) {
  const std::vector<allan::CurvePoint>& p = curve.points;
  auto sigma = [](const allan::CurvePoint& q) {
    return std::isfinite(q.lo) && std::isfinite(q.hi) ? 0.5 * (q.hi - q.lo) : allan::kNaN;
  };
  size_t at = p.size();
  for (size_t i = 0; i < p.size(); ++i) {
    if (std::isfinite(p[i].dev) && (at == p.size() || p[i].dev < p[at].dev)) at = i;
  }
  if (at == p.size() || !std::isfinite(sigma(p[at]))) return 0;
  const double tau_m = p[at].tau_s, dev_m = p[at].dev, u_m = sigma(p[at]);
  const bool above = tau_m > bound_s;
  double best = 0;
  for (const allan::CurvePoint& q : p) {
    const bool between =
        above ? (q.tau_s >= bound_s && q.tau_s < tau_m) : (q.tau_s > tau_m && q.tau_s <= bound_s);
    if (!between || !std::isfinite(q.dev) || !std::isfinite(sigma(q))) continue;
    best = std::max(best, (q.dev - dev_m) / std::hypot(sigma(q), u_m));
  }
  return above ? best : -best;
}

double WhiteNoiseBelowEvidence(const allan::Curve& curve, pb::AxisKind kind, double bound,
                               std::string* source) {
  const double lo_tau = std::max(0.1, 8 * curve.tau0_s), hi_tau = 1.5;
  double best = -INFINITY;
  int count = 0;
  for (const allan::CurvePoint& p : curve.points) {
    const bool octave = p.m > 0 && (p.m & (p.m - 1)) == 0;
    if (!octave || p.tau_s < lo_tau || p.tau_s > hi_tau) continue;
    if (!std::isfinite(p.dev) || !std::isfinite(p.lo) || !std::isfinite(p.hi)) continue;
    ++count;
    const double root = std::sqrt(p.tau_s);
    const double ceiling = Datasheet(NoiseTerm::kAngleRandomWalk, kind, p.dev * root);
    const double sigma = Datasheet(NoiseTerm::kAngleRandomWalk, kind, 0.5 * (p.hi - p.lo) * root);
    if (!(sigma > 0)) continue;
    const double z = (bound - ceiling) / sigma;
    if (z > best) {
      best = z;
      if (source) {
        *source = "ceiling sigma(" + Num(p.tau_s) + " s) sqrt(tau) = " + Num(ceiling) + " ± " +
                  Num(sigma);
      }
    }
  }
  if (count == 0 || !std::isfinite(best)) return allan::kNaN;
  // Bonferroni over the points: p = count * P(Z >= best).
  const double p = std::min(0.5, count * 0.5 * std::erfc(best / std::sqrt(2.0)));
  if (!(p > 1e-300)) return best;  // beyond any level in use
  return boost::math::quantile(boost::math::complement(boost::math::normal(), p));
}

}  // namespace imuqual::judge
