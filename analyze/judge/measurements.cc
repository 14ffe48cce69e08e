#include "analyze/judge/measurements.h"

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
      {kFitAngleRandomWalk, false, "deg/sqrt(h)", "",
       "angle random walk: -1/2 asymptote of the composite noise model at 1 s"},
      {kFitVelocityRandomWalk, false, "", "m/s/sqrt(h)",
       "velocity random walk: -1/2 asymptote of the composite noise model at 1 s"},
      {kFitBiasInstability, false, "deg/h", "ug", "minimum of the composite noise model curve"},
      {kFitBiasInstabilityIeee, false, "deg/h", "ug",
       "IEEE 952 B from the model: model-curve minimum / 0.664"},
      {kFitTauAtMinimum, false, "s", "s", "averaging time at the model-curve minimum"},
      {kFitRateRandomWalk, false, "deg/h/sqrt(h)", "ug/sqrt(h)",
       "rate random walk K of the composite noise model (0 when not selected)"},
      {kFitQuantization, false, "deg", "m/s", "quantization noise Q of the model"},
      {kFitWhiteNoise, false, "deg/sqrt(h)", "m/s/sqrt(h)",
       "white noise term N of the model (without filtered white noise)"},
      {kFitFlickerFloor, false, "deg/h", "ug", "flicker floor B of the model (IEEE 952 B term)"},
      {kFitRateRamp, false, "deg/h^2", "ug/h", "rate ramp R of the model"},
      {"fit_gauss_markov_1_sigma", false, "deg/h", "ug", "Gauss-Markov term 1: sigma"},
      {"fit_gauss_markov_1_correlation_time", false, "s", "s",
       "Gauss-Markov term 1 (shortest): correlation time"},
      {"fit_gauss_markov_2_sigma", false, "deg/h", "ug", "Gauss-Markov term 2: sigma"},
      {"fit_gauss_markov_2_correlation_time", false, "s", "s",
       "Gauss-Markov term 2: correlation time"},
      {"fit_gauss_markov_3_sigma", false, "deg/h", "ug", "Gauss-Markov term 3: sigma"},
      {"fit_gauss_markov_3_correlation_time", false, "s", "s",
       "Gauss-Markov term 3: correlation time"},
      {"fit_sinusoid_1_amplitude", false, "deg/h", "ug", "spectral line 1 (lowest): amplitude"},
      {"fit_sinusoid_1_frequency", false, "Hz", "Hz", "spectral line 1: frequency"},
      {"fit_sinusoid_2_amplitude", false, "deg/h", "ug", "spectral line 2: amplitude"},
      {"fit_sinusoid_2_frequency", false, "Hz", "Hz", "spectral line 2: frequency"},
      {kFitModelPValue, false, "1", "1",
       "J-test p-value of the selected noise model (below the level: inadequate)"},
      {kGapFraction, true, "1", "1", "fraction of samples that never arrived"},
      {kInvalidFraction, true, "1", "1", "fraction of samples flagged invalid, NaN or saturated"},
      {kDuration, true, "s", "s", "analysed duration after warm-up"},
      {kMeasuredRate, true, "Hz", "Hz",
       "device sample rate measured from its counter against the host clock"},
      {kRateError, true, "ppm", "ppm", "measured rate relative to the nominal rate"},
      {kTimingJitter, true, "ms", "ms",
       "RMS lateness of sample arrivals over the least-late of each second (host latency)"},
  };
  return kCatalog;
}

const MeasurementDef* FindMeasurement(std::string_view name) {
  for (const MeasurementDef& def : MeasurementCatalog()) {
    if (def.name == name) return &def;
  }
  return nullptr;
}

std::string_view UnitFor(const MeasurementDef& def, pb::AxisKind kind) {
  if (def.run_level) return def.gyro_unit;
  return kind == pb::ACCEL ? def.accel_unit : def.gyro_unit;
}

}  // namespace imuqual::judge
