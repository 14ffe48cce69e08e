// The quantities a composite noise fit reports (gmwm.h), each in the unit
// datasheets use, with its 1-sigma uncertainty: the datasheet figures read off
// the model curve and the parameters of every selected term. One list serves
// the offline `analyze` output (table, CSV, JSON). Pure and thread-safe.
//
// Names and units (gyro / accelerometer; base units without a sensor kind):
//  figures     angle_random_walk (velocity_random_walk for accel)  deg/sqrt(h) / m/s/sqrt(h)
//              bias_instability       model-curve minimum            deg/h / ug
//              bias_instability_ieee  minimum / 0.664                deg/h / ug
//              tau_at_minimum                                        s
//              rate_random_walk       K                              deg/h/sqrt(h) / ug/sqrt(h)
//  parameters  white_noise (N), quantization (Q), flicker_floor (B), rate_ramp (R),
//              gauss_markov_<i>_sigma, gauss_markov_<i>_correlation_time (s),
//              sinusoid_<i>_amplitude, sinusoid_<i>_frequency (Hz), i = 1, 2, ...
//              in order of increasing correlation time / frequency.
#ifndef IMUQUAL_ANALYZE_ALLAN_MODEL_QUANTITIES_H_
#define IMUQUAL_ANALYZE_ALLAN_MODEL_QUANTITIES_H_

#include <optional>
#include <string>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/units.h"

namespace imuqual::allan {

struct ModelQuantity {
  std::string name;
  bool figure = false;  // a datasheet figure (else a term parameter)
  double value = kNaN;
  double sigma = kNaN;
  std::string unit;
  std::string note;
};

std::vector<ModelQuantity> DescribeCompositeFit(const CompositeFit& fit,
                                                std::optional<SensorKind> kind);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_MODEL_QUANTITIES_H_
