#include "analyze/judge/measure.h"

#include <algorithm>
#include <cmath>

#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

using allan::NoiseTerm;

pb::Measurement Make(const std::string& axis, std::string_view name, double value,
                     pb::AxisKind kind, const std::string& note = "") {
  pb::Measurement m;
  m.set_axis(axis);
  m.set_name(std::string(name));
  m.set_value(value);
  m.set_unit(std::string(UnitFor(*FindMeasurement(name), kind)));
  m.set_note(note);
  return m;
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
                                         const allan::Curve& curve, double mean_rate) {
  const bool gyro = kind != pb::ACCEL;
  std::vector<pb::Measurement> out;

  // The curve minimum and IEEE 952's B = minimum / 0.664.
  const std::optional<allan::CurveMinimum> min = allan::FindCurveMinimum(curve);
  std::string min_note = min ? "" : "no curve";
  if (min && min->m == curve.points.back().m) {
    min_note = "minimum at the longest tau: the curve has not turned up yet (upper bound)";
  }
  const double nan = allan::kNaN;
  out.push_back(Make(axis, kBiasInstability,
                     min ? Datasheet(NoiseTerm::kBiasInstability, kind, min->dev) : nan, kind,
                     min_note));
  out.push_back(Make(axis, kBiasInstabilityIeee,
                     min ? Datasheet(NoiseTerm::kBiasInstability, kind, min->bias_instability_ieee)
                         : nan,
                     kind, min_note));
  out.push_back(Make(axis, kTauAtMinimum, min ? min->tau_s : nan, kind, min_note));

  // Slope-line read-offs: N at tau = 1 s on -1/2, K at tau = 3 s on +1/2.
  const allan::SlopeReadoff n = allan::ReadSlopeLine(curve, NoiseTerm::kAngleRandomWalk);
  out.push_back(Make(axis, gyro ? kAngleRandomWalk : kVelocityRandomWalk,
                     Datasheet(NoiseTerm::kAngleRandomWalk, kind, n.value), kind,
                     n.upper_bound_only ? "upper bound only: no point on the -1/2 slope" : ""));
  const allan::SlopeReadoff k = allan::ReadSlopeLine(curve, NoiseTerm::kRateRandomWalk);
  out.push_back(Make(axis, kRateRandomWalk, Datasheet(NoiseTerm::kRateRandomWalk, kind, k.value),
                     kind, k.upper_bound_only ? "upper bound only: no point on the +1/2 slope" : ""));
  out.push_back(Make(axis, kBiasOffset, Datasheet(NoiseTerm::kBiasInstability, kind, mean_rate),
                     kind));

  // The weighted NNLS fit of all five terms, with uncertainties.
  const std::pair<NoiseTerm, std::string_view> fitted[] = {
      {NoiseTerm::kQuantization, kFitQuantization},
      {NoiseTerm::kAngleRandomWalk, gyro ? kFitAngleRandomWalk : kFitVelocityRandomWalk},
      {NoiseTerm::kBiasInstability, kFitBiasInstability},
      {NoiseTerm::kRateRandomWalk, kFitRateRandomWalk},
      {NoiseTerm::kRateRamp, kFitRateRamp}};
  allan::FitOptions options;
  options.stop = allan::StopRule::kNone;  // the curve is already cut by the plan's rule
  const Result<allan::NoiseFit> fit = allan::FitNoiseModel(curve, options);
  for (const auto& [term, name] : fitted) {
    if (!fit.ok()) {
      out.push_back(Make(axis, name, nan, kind, "no fit: " + fit.status().message()));
      continue;
    }
    const allan::TermEstimate& t = fit->term(term);
    pb::Measurement m = Make(axis, name, Datasheet(term, kind, t.value), kind,
                             t.active ? "" : "not in the fitted model (0 fits best)");
    if (t.active && std::isfinite(t.sigma)) m.set_uncertainty(Datasheet(term, kind, t.sigma));
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
  }
  out.push_back(std::move(rate));
  out.push_back(std::move(error));
  out.push_back(Make("", kTimingJitter, jitter_rms_s * 1e3, pb::GYRO));
  return out;
}

}  // namespace imuqual::judge
