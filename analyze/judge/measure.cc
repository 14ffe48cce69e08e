#include "analyze/judge/measure.h"

#include <algorithm>
#include <cmath>

#include "analyze/allan/noise_model.h"
#include "analyze/allan/units.h"
#include "analyze/judge/measurements.h"

namespace imuqual::judge {
namespace {

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

}  // namespace

std::vector<pb::Measurement> MeasureAxis(const std::string& axis, pb::AxisKind kind,
                                         const allan::Curve& curve, double mean_rate) {
  using namespace allan;
  const bool gyro = kind != pb::ACCEL;
  // Rate-unit (deg/s or m/s^2) value -> datasheet unit (deg/h or ug).
  auto bias_unit = [&](double v) {
    return gyro ? DegPerSecToDegPerHour(v) : MetersPerSecSqToMicroG(v);
  };
  std::vector<pb::Measurement> out;

  const std::optional<CurveMinimum> min = FindCurveMinimum(curve);
  std::string min_note;
  if (min && !curve.points.empty() && min->m == curve.points.back().m) {
    min_note = "minimum at the longest tau: the curve has not turned up yet (upper bound)";
  }
  out.push_back(Make(axis, kBiasInstability, min ? bias_unit(min->dev) : kNaN, kind,
                     min ? min_note : "no curve"));
  out.push_back(Make(axis, kBiasInstabilityIeee,
                     min ? bias_unit(min->bias_instability_ieee) : kNaN, kind,
                     min ? min_note : "no curve"));
  out.push_back(Make(axis, kTauAtMinimum, min ? min->tau_s : kNaN, kind, min ? min_note : ""));

  const SlopeReadoff n = ReadSlopeLine(curve, NoiseTerm::kAngleRandomWalk);
  const std::string n_note = n.upper_bound_only ? "upper bound only: no point on the -1/2 slope"
                                                : "";
  // N [deg/sqrt(s)] -> deg/sqrt(h); N [m/s^2/sqrt(Hz) = m/s/sqrt(s)] -> m/s/sqrt(h).
  if (gyro) {
    out.push_back(Make(axis, kAngleRandomWalk, DegPerRootSecToDegPerRootHour(n.value), kind, n_note));
  } else {
    out.push_back(Make(axis, kVelocityRandomWalk,
                       MetersPerSecSqPerRootHzToMetersPerSecPerRootHour(n.value), kind, n_note));
  }

  const SlopeReadoff k = ReadSlopeLine(curve, NoiseTerm::kRateRandomWalk);
  const std::string k_note = k.upper_bound_only ? "upper bound only: no point on the +1/2 slope"
                                                : "";
  // K [deg/s/sqrt(s)] -> deg/h/sqrt(h); K [m/s^2/sqrt(s)] -> ug/sqrt(h) (x 60 / 1 ug).
  const double k_value = gyro ? DegPerSecPerRootSecToDegPerHourPerRootHour(k.value)
                              : MetersPerSecSqToMicroG(k.value) * 60.0;
  out.push_back(Make(axis, kRateRandomWalk, k_value, kind, k_note));

  out.push_back(Make(axis, kBiasOffset, bias_unit(mean_rate), kind));
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

}  // namespace imuqual::judge
