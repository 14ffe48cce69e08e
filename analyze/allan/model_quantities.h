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
#include "common/status.h"

namespace imuqual::allan {

struct ModelQuantity {
  std::string name;
  bool figure = false;  // a datasheet figure (else a term parameter)
  double value = kNaN;
  double sigma = kNaN;
  std::string unit;
  std::string note;
  // A term the selected model leaves out: `absent`, value 0, no sigma, and
  // the 95 % upper bound the data allow (NaN if none could be stated).
  bool absent = false;
  double upper_bound = kNaN;
};

std::vector<ModelQuantity> DescribeCompositeFit(const CompositeFit& fit,
                                                std::optional<SensorKind> kind);

// The selected model itself, term by term, with the model's own parameter
// values (not averaged) and their bootstrap sigmas: quantization,
// white_noise, flicker_floor, rate_random_walk, rate_ramp,
// gauss_markov_<i>_sigma / _correlation_time, sinusoid_<i>_amplitude /
// _frequency. What the archive keeps to draw the model again.
std::vector<ModelQuantity> DescribeModelTerms(const CompositeFit& fit,
                                              std::optional<SensorKind> kind);

// The inverse of DescribeModelTerms: the model from its named parameters
// (name, value in `unit`); names it does not know are ignored. Errors: a
// unit that is not the parameter's, a negative or non-finite value, a
// Gauss-Markov term or sinusoid with one of its two parameters missing.
Result<CompositeModel> ModelFromTerms(const std::vector<ModelQuantity>& terms,
                                      std::optional<SensorKind> kind);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_MODEL_QUANTITIES_H_
