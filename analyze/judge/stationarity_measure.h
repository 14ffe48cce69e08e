// The stationarity scan of a run as measurements (plans with
// `stationarity`, plan.proto): the axes of each kind scanned together
// (analyze/allan/stationarity.h) against the plan's reference model of the
// kind, else against the model fitted to the axis's own record (the
// adequate candidate with the most wander: FitModelForScan), and what was
// found, per axis:
//   stationarity_events  the number of events named on the axis (judged by
//                        a limit on it, else by the plan's on_event);
//                        the note lists them and says what the scan was
//                        (bins, model and its source, false-alarm level,
//                        and whether the unit's curve shows noise above
//                        the reference, for which the rate is not bounded)
//   event_<k>            the event's size (after - before; a burst: its
//                        departure), bias_offset's unit, with its 1-sigma;
//                        a noise level change: the short-tau noise
//                        amplitude after over before (unit "ratio")
//   event_<k>_time       s from the end of the warm-up (a step's bin boundary
//                        or the middle of the bin holding it, or the start
//                        of the missing stretch it fell in; a burst's
//                        start; a noise level change's boundary)
//   event_<k>_end        a burst's end
// Each axis's noise level is scanned on its own when the axis has its bins'
// mean square differences and the plan's noise_level_tolerance is not
// negative (allan::ScanNoiseLevel, at false_alarm / the group's axes each;
// an event only when the change is beyond the tolerance), after the level
// scan and only when that was made. Pure.
#ifndef IMUQUAL_ANALYZE_JUDGE_STATIONARITY_MEASURE_H_
#define IMUQUAL_ANALYZE_JUDGE_STATIONARITY_MEASURE_H_

#include <string>
#include <utility>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/allan/curve.h"
#include "analyze/judge/judge.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::judge {

// A composite model from a message with the IEEE 952 fields in base units,
// as pb::ReferenceNoiseModel and pb::AxisTruth have them: quantization,
// random_walk, bias_instability, rate_random_walk, rate_ramp (its
// magnitude), gauss_markov and sinusoids; a term of scale 0 is absent.
template <typename Terms>
allan::CompositeModel CompositeModelOf(const Terms& r) {
  using allan::TermKind;
  allan::CompositeModel m;
  auto add = [&](TermKind kind, double scale, double t = 0, double f = 0) {
    if (scale > 0) m.terms.push_back({kind, scale, t, f});
  };
  add(TermKind::kQuantization, r.quantization());
  add(TermKind::kWhite, r.random_walk());
  add(TermKind::kFlicker, r.bias_instability());
  add(TermKind::kRandomWalk, r.rate_random_walk());
  add(TermKind::kDrift, r.rate_ramp() < 0 ? -r.rate_ramp() : r.rate_ramp());
  for (const auto& g : r.gauss_markov()) {
    add(TermKind::kGaussMarkov, g.sigma(), g.correlation_time_s());
  }
  for (const auto& l : r.sinusoids()) add(TermKind::kSinusoid, l.amplitude(), 0, l.frequency_hz());
  return m;
}

// The plan's reference model as a composite model (base units).
inline allan::CompositeModel ReferenceModel(const pb::ReferenceNoiseModel& reference) {
  return CompositeModelOf(reference);
}

// The plan's reference model of an axis kind, nullptr if it has none.
const pb::ReferenceNoiseModel* ReferenceModelFor(const pb::TestPlan& plan, pb::AxisKind kind);

// One axis's record as the scan reads it.
struct StationarityAxis {
  AxisDesc axis;
  std::vector<double>
      bin_means;  // deg/s or m/s^2; NaN: a bin with fewer than half its samples valid
  const allan::Curve* curve = nullptr;  // the record's OADEV (chi-square 1-sigma intervals)
  // Per bin, the mean square difference of successive valid samples
  // (allan::BinMeanSquareDifferences); empty: the noise level is not
  // scanned.
  std::vector<double> mean_square;
};

// A plan's noise_level_tolerance of 0.
inline constexpr double kDefaultNoiseLevelTolerance = 0.05;

// The scan's measurements of every axis (above), in the axes' order; every
// axis gets its stationarity_events, not measurable (NaN, the note says why)
// when the record is too short or no model could be had. `bin_s`: the bins'
// length, `tau0_s` the samples' interval. Does nothing without the plan's
// stationarity block. `cuts`, if given, gets per axis (in the axes' order)
// the stretches [from_s, to_s] its events touch, s from the end of the
// warm-up, a bin either side (the scan places an event to within its bins):
// a step's or a noise level change's time, a burst from start to end, a
// step in missing data its missing stretch.
using EventCuts = std::vector<std::pair<double, double>>;
std::vector<pb::Measurement> MeasureStationarity(const pb::TestPlan& plan,
                                                 const std::vector<StationarityAxis>& axes,
                                                 double bin_s, double tau0_s,
                                                 std::vector<EventCuts>* cuts = nullptr);

// The bins a plan's scan wants for an analysed record of `samples` at
// `tau0_s`: the plan's bin_s, else the record's length / 300, in samples.
int64_t StationarityBinSamples(const pb::TestPlan& plan, int64_t samples, double tau0_s);

// What a found event does under the plan's on_event when no limit judges
// stationarity_events: the outcome of a count (PASS for none; a not
// measurable count is INCONCLUSIVE) and, for QUALIFIER_ONLY and for events
// under JUDGE_LONGEST_SEGMENT (the limits judge the stretch without them),
// UNSET.
pb::Outcome StationarityOutcome(const pb::TestPlan& plan, double events);

// A stationarity_events measurement's events as its note lists them ("1
// event: level step +167 ± 12 deg/h at 3132 s"), without the scan's
// description.
std::string StationarityEventSummary(const pb::Measurement& events);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_STATIONARITY_MEASURE_H_
