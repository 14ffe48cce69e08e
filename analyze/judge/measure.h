// Measurements of a run from its Allan curves, in the units datasheets use
// (see measurements.h): the curve minimum (seed convention) and min/0.664
// (IEEE 952), the tau of the minimum, ARW/VRW on the -1/2 line at 1 s, RRW on
// the +1/2 line at 3 s (flagged "upper bound only" where the curve never
// shows that slope), the mean output, the noise model's terms, and run-level
// data quality. Pure.
#ifndef IMUQUAL_ANALYZE_JUDGE_MEASURE_H_
#define IMUQUAL_ANALYZE_JUDGE_MEASURE_H_

#include <string>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/long_tau.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::judge {

// `curve`: OADEV of the axis in deg/s (gyro) or m/s^2 (accel), preferably
// on a dense grid (more points near the minimum and on the slopes).
// `mean_rate`: mean output over the analysed record, same unit.
// `tau_uncertainty`: fit the bottom's vertex for tau_at_minimum's u (tens of
// ms per axis); false for a live view republished every few seconds (and a
// look whose plan does not judge it), whose tau then says it has none there.
std::vector<pb::Measurement> MeasureAxis(const std::string& axis, pb::AxisKind kind,
                                         const allan::Curve& curve, double mean_rate,
                                         bool tau_uncertainty = true);

struct NoiseModelOptions {
  // Report the values of an inadequate model (the plan's
  // JUDGE_INADEQUATE_VALUE) instead of withholding them as not measurable.
  bool judge_inadequate_values = false;
  // The plan's noise-model range (plan.proto NoiseModelRange): points below
  // min_tau_s are not fitted, and every model value's note says so with the
  // reason.
  double min_tau_s = 0;
  std::string range_reason;
  // Theo1 beyond the curve's last tau (allan::Theo1MomentsBeyond of the
  // whole record), fitted as moments beside the curve's points (gmwm.h):
  // the model and its minimum then reach 0.3 of the record (allan::kTheo1MomentReach). Empty: none.
  std::vector<allan::Theo1Moment> long_taus;
  // Where the plan asked for them and there are none: why (every model
  // value's note says so).
  std::string long_tau_note;
};

// The composite noise model of an axis (analyze/allan/gmwm.h: GMWM fit,
// model selection, J test, bootstrap sigmas) and what is read off it: the
// judged fit_* measurements and noise_model_p_value (measurements.h), then
// every parameter of the selected model as an unjudged "model_<parameter>".
// A term the model leaves out is reported as its 95 % upper bound, with a
// note saying so. When the model fails its J test, every judged value is
// withheld (NaN, "not measurable: noise model inadequate (...)") and flagged
// model_inadequate, unless `options` asks to keep it. Costs 50-500 ms on an
// octave grid (the bootstrap and the search): call it once a run has ended.
std::vector<pb::Measurement> MeasureNoiseModel(const std::string& axis, pb::AxisKind kind,
                                               const allan::Curve& curve,
                                               const NoiseModelOptions& options = {});

// Run-level: analysed duration, fraction of samples that never arrived
// (per axis), fraction of invalid samples (over all axes).
std::vector<pb::Measurement> MeasureRun(double duration_s, int64_t samples, int64_t gap_samples,
                                        int64_t invalid_samples, int num_axes);

// Run-level timing truth: the device's measured sample rate (with its
// 1-sigma uncertainty), its error against the nominal rate in ppm, and the
// arrival jitter (seconds in, reported in ms).
std::vector<pb::Measurement> MeasureTiming(double nominal_rate_hz, double measured_rate_hz,
                                           double rate_sigma_hz, double jitter_rms_s);

// The temperature readings of a run's analysed batches: a reading in deg C
// at device time t_s (s from the analysed start, the middle of the samples
// it covers), weighted by those samples. Running weighted moments (West
// 1979): bounded memory, no cancellation over long runs.
struct TemperatureReadings {
  int64_t count = 0;
  double weight = 0;
  double mean_t_s = 0;
  double mean_c = 0;
  double s_tt = 0;  // sum w (t - mean_t)^2
  double s_tc = 0;  // sum w (t - mean_t)(c - mean_c)
  double s_cc = 0;  // sum w (c - mean_c)^2
  double lowest_c = 0;
  double highest_c = 0;
  // weight > 0, both values finite (the caller's precondition).
  void Add(double temperature_c, double t_s, double weight);
};

// temperature_mean (the weighted mean), temperature_range (highest minus
// lowest reading) and temperature_slope (weighted least-squares slope, deg
// C/h, with its standard error: residuals taken independent, so drift with
// structure makes it optimistic; the method says so). Nothing when no
// batch carried a temperature; the slope is not measurable below 3 readings.
std::vector<pb::Measurement> MeasureTemperature(const TemperatureReadings& readings);

// Whether the minimum of an axis's Allan curve `curve` (OADEV, dense or
// octave, base units) measured so far is settled: a longer record, whose
// curve would reach `horizon_m` (averaging factor), would not find a lower
// minimum at the taus not yet measured. Fits the composite noise model
// (gmwm.h; no bootstrap) and asks that it be adequate (J test) and that its
// minimum over m in [1, horizon_m] lie at least an octave inside the
// curve's last point: well inside what was measured, the model rising from
// there to the horizon. `why` says what failed. Costs one
// fit (tens of ms). For early decisions (early_decision.h).
bool MinimumSettled(const allan::Curve& curve, double horizon_m, std::string* why = nullptr);

// The evidence, as a z, that the minimum of `curve` (OADEV with 1-sigma
// chi-square intervals lo/hi on its points) lies above tau `bound_s`
// (positive) or below it (negative): with the minimum point (tau_m, d_m), the
// largest (d_j - d_m) / sqrt(u_j^2 + u_m^2) over the points j with tau_j in
// [bound_s, tau_m) (minimum above the bound) or in (tau_m, bound_s] (below),
// u = (hi - lo) / 2. For a curve convex in log-log (a sum of power-law
// noises) a point confirmed above the minimum bounds where the minimum can
// be. 0 when no point lies between the bound and the minimum, or no point
// carries an interval.
double MinimumSideEvidence(const allan::Curve& curve, double bound_s);

// The evidence, as a z, that the white-noise term (ARW / VRW) lies below
// `bound` (datasheet units): sigma(tau) sqrt(tau) >= N at every tau where the
// white noise is not band-limited (every other term adds to the Allan
// variance), so each octave point of `curve` (OADEV with 1-sigma chi-square
// intervals) with tau in [max(0.1 s, 8 tau0), 1.5 s] is a ceiling on N; the
// best of them, its p-value multiplied by their number (Bonferroni: no point
// is trusted for being low, unlike a read-off along the -1/2 line). NaN when
// no point qualifies; `source` names the point used.
double WhiteNoiseBelowEvidence(const allan::Curve& curve, pb::AxisKind kind, double bound,
                               std::string* source = nullptr);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_MEASURE_H_
