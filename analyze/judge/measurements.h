// The catalogue of measurements a run can produce and a plan can limit, with
// the unit each carries per axis kind (the units datasheets use). A plan
// limit must name a catalogued measurement in its unit.
#ifndef IMUQUAL_ANALYZE_JUDGE_MEASUREMENTS_H_
#define IMUQUAL_ANALYZE_JUDGE_MEASUREMENTS_H_

#include <string_view>
#include <vector>

#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::judge {

struct MeasurementDef {
  std::string_view name;
  bool run_level;               // true: one value per run (axis ""), else per axis
  std::string_view gyro_unit;   // "" = not defined for gyro axes
  std::string_view accel_unit;  // "" = not defined for accelerometer axes
  std::string_view description;
};

// Measurement names.
inline constexpr std::string_view kBiasInstability = "bias_instability";
inline constexpr std::string_view kBiasInstabilityIeee = "bias_instability_ieee";
inline constexpr std::string_view kTauAtMinimum = "tau_at_minimum";
inline constexpr std::string_view kAngleRandomWalk = "angle_random_walk";
inline constexpr std::string_view kVelocityRandomWalk = "velocity_random_walk";
inline constexpr std::string_view kRateRandomWalk = "rate_random_walk";
inline constexpr std::string_view kBiasOffset = "bias_offset";
// From the axis's composite noise model (analyze/allan/gmwm.h), fitted once
// the run has ended, with 1-sigma uncertainties (bootstrap, model-averaged):
// the IEEE 952 terms Q, N (the model's -1/2 asymptote at 1 s), K and R, and
// the bias instability of the model curve (its minimum / 0.664). A term the
// selected model leaves out is reported as its 95 % upper bound (note "upper
// bound"). noise_model_p_value: the model's goodness-of-fit p-value, its note
// the selected model and the runners-up.
inline constexpr std::string_view kFitQuantization = "fit_quantization";
inline constexpr std::string_view kFitAngleRandomWalk = "fit_angle_random_walk";
inline constexpr std::string_view kFitVelocityRandomWalk = "fit_velocity_random_walk";
inline constexpr std::string_view kFitBiasInstability = "fit_bias_instability";
inline constexpr std::string_view kFitRateRandomWalk = "fit_rate_random_walk";
inline constexpr std::string_view kFitRateRamp = "fit_rate_ramp";
inline constexpr std::string_view kNoiseModelPValue = "noise_model_p_value";
// The word a noise_model_p_value note carries when the model failed its J test.
inline constexpr std::string_view kInadequateModelMark = "INADEQUATE";
// Not catalogued (never limited, archived for plots and audits): every
// parameter of the selected model as "model_<parameter>" (model_quantities.h
// names), in datasheet units.
inline constexpr std::string_view kModelParameterPrefix = "model_";
inline constexpr std::string_view kGapFraction = "gap_fraction";
inline constexpr std::string_view kInvalidFraction = "invalid_fraction";
inline constexpr std::string_view kDuration = "duration";
// Timing truth: the device's clock against the host's (runs whose batches
// carry arrival times).
inline constexpr std::string_view kMeasuredRate = "measured_rate";
inline constexpr std::string_view kRateError = "rate_error";
inline constexpr std::string_view kTimingJitter = "timing_jitter";
// The unit's temperature over the analysed record (units whose source
// reports one): the sample-weighted mean, the range of the batch readings
// and the least-squares slope against device time. A plan says "at constant
// temperature" by limiting them.
inline constexpr std::string_view kTemperatureMean = "temperature_mean";
inline constexpr std::string_view kTemperatureRange = "temperature_range";
inline constexpr std::string_view kTemperatureSlope = "temperature_slope";
// Early decisions (early_decision.h): the analysed device time at which the
// unit was decided; NaN, not measurable, when it stayed pending to the end.
inline constexpr std::string_view kDecisionTime = "decision_time";

// The stationarity scan (plans with `stationarity`, stationarity_measure.h):
// the level steps, bursts and noise level changes found on an axis. Not catalogued (archived for
// the record, the plots and audits; a plan judges the count): each event k
// of the axis as "event_<k>" (its size, after - before, in bias_offset's
// unit, with its 1-sigma), "event_<k>_time" (s from the end of the warm-up:
// a step's bin boundary or the middle of the bin holding it, a burst's
// start) and, for a burst, "event_<k>_end".
inline constexpr std::string_view kStationarityEvents = "stationarity_events";
// Plans whose stationarity judges the longest segment (JUDGE_LONGEST_SEGMENT):
// the data (valid samples, s) in the stretch an axis was judged on, every
// axis of such a plan: the stretch without a found event that holds the
// most data, or the whole record where no event cut it (its note starts
// with kWholeRecordNote: none found, or the record was not scanned); the
// note says where it lies and why.
inline constexpr std::string_view kJudgedSegment = "judged_segment";
inline constexpr std::string_view kWholeRecordNote = "the whole record";
// Not catalogued: where that stretch starts and ends, s from the end of the
// warm-up (with gaps in it, end - start exceeds its data).
inline constexpr std::string_view kJudgedSegmentStart = "judged_segment_start";
inline constexpr std::string_view kJudgedSegmentEnd = "judged_segment_end";
// Whether a judged_segment row judged the whole record (no event cut it, or
// the record was not scanned).
inline bool JudgedWholeRecord(const pb::Measurement& judged_segment) {
  return judged_segment.note().starts_with(kWholeRecordNote);
}
// Where it lies, in words: its note up to the first comma ("the stretch
// 0-1192 s of the 2400 s record (1192 s of data)", "the whole record").
inline std::string JudgedStretchText(const pb::Measurement& judged_segment) {
  return judged_segment.note().substr(0, judged_segment.note().find(','));
}
inline constexpr std::string_view kEventPrefix = "event_";
// The unit of a noise-level change's event_<k> (the short-tau noise
// amplitude after over before), which has no _end.
inline constexpr std::string_view kNoiseLevelRatioUnit = "ratio";

const std::vector<MeasurementDef>& MeasurementCatalog();
// True for the measurements read off the noise model (fit_*,
// noise_model_p_value): they exist only once the run has ended.
bool FromNoiseModel(std::string_view name);
// Whether an (archived) noise_model_p_value row says its model fits: a
// p-value, and no kInadequateModelMark in its note.
bool NoiseModelAdequate(const pb::Measurement& p_value);
// nullptr if `name` is not catalogued.
const MeasurementDef* FindMeasurement(std::string_view name);
// The unit of `def` on an axis of `kind` ("" if not defined there). Run-level
// measurements use gyro_unit whatever the kind.
std::string_view UnitFor(const MeasurementDef& def, pb::AxisKind kind);
// A measurement row with its axis ("" for run level), name, value, unit and
// note; uncertainty and qualifier are the caller's.
pb::Measurement NewMeasurement(std::string_view axis, std::string_view name, double value,
                               std::string_view unit, std::string_view note = "");

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_MEASUREMENTS_H_
