#include "analyze/judge/measurements.h"

#include <cmath>
#include <string>

namespace imuqual::judge {

const std::vector<MeasurementDef>& MeasurementCatalog() {
  static const std::vector<MeasurementDef> kCatalog = {
      {kBiasInstability, false, "deg/h", "ug",
       "minimum of the Allan deviation curve (the seed note's and most datasheets' convention)"},
      {kBiasInstabilityIeee, false, "deg/h", "ug",
       "IEEE 952 bias instability B = curve minimum / 0.664"},
      {kTauAtMinimum, false, "s", "s", "averaging time at the curve minimum"},
      {kAngleRandomWalk, false, "deg/sqrt(h)", "",
       "angle random walk N, read at tau = 1 s on the -1/2 slope line"},
      {kVelocityRandomWalk, false, "", "m/s/sqrt(h)",
       "velocity random walk N, read at tau = 1 s on the -1/2 slope line"},
      {kRateRandomWalk, false, "deg/h/sqrt(h)", "ug/sqrt(h)",
       "rate random walk K, read at tau = 3 s on the +1/2 slope line"},
      {kBiasOffset, false, "deg/h", "ug", "mean output over the analysed record"},
      {kFitQuantization, false, "deg", "m/s", "quantization noise Q (noise model)"},
      {kFitAngleRandomWalk, false, "deg/sqrt(h)", "",
       "angle random walk: the noise model's -1/2 asymptote at 1 s"},
      {kFitVelocityRandomWalk, false, "", "m/s/sqrt(h)",
       "velocity random walk: the noise model's -1/2 asymptote at 1 s"},
      {kFitBiasInstability, false, "deg/h", "ug",
       "bias instability: minimum of the noise model's curve / 0.664"},
      {kFitRateRandomWalk, false, "deg/h/sqrt(h)", "ug/sqrt(h)",
       "rate random walk K (noise model)"},
      {kFitRateRamp, false, "deg/h^2", "ug/h", "rate ramp R (noise model)"},
      {kNoiseModelPValue, false, "1", "1",
       "goodness-of-fit p-value of the noise model (J test); the note names the model"},
      {kGapFraction, true, "1", "1", "fraction of samples that never arrived"},
      {kInvalidFraction, true, "1", "1", "fraction of samples flagged invalid, NaN or saturated"},
      {kDuration, true, "s", "s", "analysed duration after warm-up"},
      {kStationarityEvents, false, "1", "1",
       "level steps and bursts the stationarity scan found on the axis (plans with "
       "stationarity; not measurable when the record was too short to scan)"},
      {kJudgedSegment, false, "s", "s",
       "data (valid samples, s) in the stretch the axis was judged on: the stretch without a "
       "found event that holds the most (plans whose stationarity judges the longest segment; "
       "the whole record where none was found)"},
      {kDecisionTime, true, "s", "s",
       "analysed device time at which early decisions decided the unit (plans with "
       "early_decision; not measurable when it stayed pending to the end)"},
      {kMeasuredRate, true, "Hz", "Hz",
       "device sample rate measured from its counter against the host clock"},
      {kRateError, true, "ppm", "ppm", "measured rate relative to the nominal rate"},
      {kTimingJitter, true, "ms", "ms",
       "RMS lateness of sample arrivals over the least-late of each second (host latency)"},
      {kTemperatureMean, true, "deg C", "deg C",
       "unit temperature over the analysed record, mean weighted by samples"},
      {kTemperatureRange, true, "deg C", "deg C",
       "highest minus lowest batch temperature over the analysed record"},
      {kTemperatureSlope, true, "deg C/h", "deg C/h",
       "least-squares slope of the batch temperatures against device time"},
  };
  return kCatalog;
}

bool FromNoiseModel(std::string_view name) {
  return name.starts_with("fit_") || name == kNoiseModelPValue;
}

bool NoiseModelAdequate(const pb::Measurement& p_value) {
  return std::isfinite(p_value.value()) &&
         p_value.note().find(kInadequateModelMark) == std::string::npos;
}

const MeasurementDef* FindMeasurement(std::string_view name) {
  for (const MeasurementDef& def : MeasurementCatalog()) {
    if (def.name == name) return &def;
  }
  return nullptr;
}

pb::Measurement NewMeasurement(std::string_view axis, std::string_view name, double value,
                               std::string_view unit, std::string_view note) {
  pb::Measurement m;
  m.set_axis(std::string(axis));
  m.set_name(std::string(name));
  m.set_value(value);
  m.set_unit(std::string(unit));
  m.set_note(std::string(note));
  return m;
}

std::string_view UnitFor(const MeasurementDef& def, pb::AxisKind kind) {
  if (def.run_level) return def.gyro_unit;
  return kind == pb::ACCEL ? def.accel_unit : def.gyro_unit;
}

}  // namespace imuqual::judge
