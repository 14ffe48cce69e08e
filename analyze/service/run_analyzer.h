// The analysis of one run: batches in seq order in, Allan curves, measurements
// and a verdict out. No LCM, no SQLite, no clock: the analyze process feeds it
// live batches, re-analysis feeds it archived chunks, and both get the same
// bits (the streaming engine is independent of batch boundaries).
//
// Timeline: the device sample counter. A batch whose counter starts past the
// expected one is preceded by a gap of that many missing samples; one that
// starts before it (counter went backwards or a batch overlaps) is rejected.
// The plan's warm-up is discarded by counter. NaN samples, samples flagged
// invalid or saturated and samples at or beyond the plan's sensor_range are
// gaps, never zeros. Not thread-safe.
#ifndef IMUQUAL_ANALYZE_SERVICE_RUN_ANALYZER_H_
#define IMUQUAL_ANALYZE_SERVICE_RUN_ANALYZER_H_

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/stationarity.h"
#include "analyze/allan/streaming.h"
#include "analyze/judge/early_decision.h"
#include "analyze/judge/judge.h"
#include "analyze/judge/measure.h"
#include "analyze/judge/stationarity_measure.h"
#include "analyze/service/device_clock.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::analyze {

struct RunDescription {
  std::string run_id;
  std::string serial;
  std::vector<judge::AxisDesc> axes;
  double nominal_rate_hz = 0;
  pb::TestPlan plan;
};

// One batch as received: samples[a] has num_samples values of axis a.
struct BatchView {
  int64_t seq = 0;
  int64_t first_sample = 0;  // device counter of the first sample
  int64_t sample_utime = 0;  // host arrival time of the first sample, us (0: none)
  double nominal_rate_hz = 0;
  std::optional<double> temperature_c;  // the unit's temperature during the batch, deg C
  std::vector<std::span<const float>> samples;
  struct Flag {
    int sample;
    int axis;
    int bits;
  };
  std::vector<Flag> flags;
};

struct AnalyzerOptions {
  int density = 8;  // streaming engine: averaging factors per octave (C)
};

// How a run ended when it did not end normally: the verdict that replaces
// the judgement (ABORTED: stopped by the operator; ERROR: its source or the
// station failed, or it went silent) and why. verdict UNSET: ended normally.
struct RunEnding {
  pb::Outcome verdict = pb::OUTCOME_UNSET;
  std::string reason;
};

struct RunOutcome {
  // Per axis: interim, the plan's grid; final, the judged dense curve (every
  // point the measurements were read from), both with chi-square intervals.
  std::vector<std::pair<std::string, allan::Curve>> curves;
  std::vector<pb::Measurement> measurements;  // judged
  judge::Judgement judgement;
  int64_t samples = 0;                        // per axis, after warm-up, including gaps
  int64_t gap_samples = 0;                    // per axis
  int64_t invalid_samples = 0;                // over all axes
  std::vector<int64_t> axis_invalid_samples;  // per axis, in the description's order
  int64_t warmup_samples = 0;
  // Early decisions (plans with early_decision; nullopt otherwise): the
  // unit's decision so far, when it was made, and every look's evidence.
  struct Early {
    judge::Decision unit = judge::Decision::kPending;
    double decided_at_s = 0;  // analysed device time (when decided)
    int looks_done = 0;
    int looks_planned = 0;
    std::vector<judge::Look> looks;  // every look so far; in the final outcome only
  };
  std::optional<Early> early;
  // Samples per axis that arrived after the decision (archived, not analysed).
  int64_t samples_after_decision = 0;
};

class RunAnalyzer {
 public:
  // The description must have at least one axis and a positive rate.
  static Result<RunAnalyzer> Create(RunDescription description, AnalyzerOptions options = {});

  // Adds the next batch in seq order (missing seqs are simply skipped: the
  // device counter tells how many samples they held). A batch that does not
  // fit the run (axes, rate, counter going backwards) is rejected with an
  // error naming why, and changes nothing.
  Status AddBatch(const BatchView& batch);

  // Ends the record. The source announced the device counter range
  // [first_sample, end_sample) it published; what the processed batches did
  // not reach at either end (lost first or last batches) counts as gap
  // samples (placed at the end of the record: no term spans them either
  // way). A negative bound means unknown.
  void Finish(int64_t first_sample, int64_t end_sample);

  // Curves, measurements and verdict as of now. `final` judges the run
  // (durations, missing measurements). Every measurement is judged as
  // usual, but the verdict says whether the run can be judged at all: an
  // `ending` (the run did not end normally) makes it ABORTED or ERROR with
  // its reason first, never FAIL; a final analysis that refused an absurd
  // announced range (Finish) is ERROR with that reason (ERROR wins over
  // ABORTED; both reasons are kept). The final outcome fits each axis's
  // noise model on its own thread, up to one per core, and returns when all
  // are done (the same values as one after another: the fits share nothing).
  RunOutcome Outcome(bool final, const RunEnding& ending = {}) const;

  const RunDescription& description() const { return desc_; }
  int64_t next_counter() const { return next_counter_; }
  // True once early decisions decided the unit: later samples are counted,
  // not analysed, and the run may end.
  bool decided() const {
    return decider_ && decider_->unit_decision() != judge::Decision::kPending;
  }
  // Early decisions as of now, without computing an Outcome: the decider
  // (its looks, the unit's decision; nullptr for a plan without
  // early_decision) and how many looks were evaluated.
  const judge::EarlyDecider* decider() const { return decider_ ? &*decider_ : nullptr; }
  int looks_done() const { return static_cast<int>(next_look_); }
  // The device counter just after the last sample the analysis used (warm-up
  // and gaps included; once decided, where it stopped), -1 before the first
  // batch. Before Finish (which may place a lost start before the first batch).
  int64_t analysed_end_counter() const {
    return first_counter_ < 0 ? -1 : first_counter_ + warmup_seen_ + engines_.front().samples();
  }
  int64_t batches_accepted() const { return batches_; }

 private:
  RunAnalyzer(RunDescription description, AnalyzerOptions options);
  void Push(int64_t count_missing);
  // Analysed samples left before the next look (INT64_MAX: no more looks).
  int64_t UntilLook() const;
  // Runs the look due now (early decisions), if one is.
  void LookIfDue();
  // Analysed samples left before the next mark or look; the mark and the
  // look due now, if any.
  int64_t UntilStop() const;
  void AtStop();
  // Every measurement of the record as analysed so far (the noise model
  // only when `final`); the judged curves into `curves` if given, and the
  // dense curves the measurements were read from (no intervals), one per
  // axis in order, into `dense_curves` if given.
  std::vector<pb::Measurement> MeasureNow(bool final,
                                          std::vector<std::pair<std::string, allan::Curve>>* curves,
                                          std::vector<allan::Curve>* dense_curves = nullptr) const;

  // The Theo1 moments of axis a beyond `last_tau_s` (plans with
  // noise_model_long_taus), from its one-second means over the stretch the
  // axis is judged on (`stationarity`'s judged_segment_start and _end, the
  // whole record without them). When there are none, why into `note`.
  std::vector<allan::Theo1Moment> LongTauMoments(size_t a, double last_tau_s,
                                                 const std::vector<pb::Measurement>& stationarity,
                                                 std::string* note) const;

  // Axis a judged on the stretch that none of `cuts` touches with the most
  // data (plans that judge the longest stationary segment; `scanned`: the
  // scan ran on the axis): that stretch's dense curve without intervals into
  // `dense`, with them into `with_ci`, its mean into `mean` (all left alone
  // when no event cut the record), and the axis's judged_segment and
  // judged_segment_start and judged_segment_end measurements.
  std::vector<pb::Measurement> JudgeOnSegment(size_t a, const judge::EventCuts& cuts, bool scanned,
                                              allan::StopRule stop, allan::Curve* dense,
                                              std::optional<allan::Curve>* with_ci,
                                              double* mean) const;

  RunDescription desc_;
  AnalyzerOptions options_;
  double tau0_s_ = 0;
  int64_t warmup_target_ = 0;  // samples to discard
  int64_t first_counter_ = -1;
  int64_t next_counter_ = -1;
  int64_t warmup_seen_ = 0;
  int64_t gap_samples_ = 0;
  std::string absurd_range_;  // why the announced range was not analysed, if it was absurd
  std::vector<int64_t> invalid_samples_;  // per axis, after warm-up
  int64_t batches_ = 0;
  std::vector<allan::StreamingAllan> engines_;
  // Bin sums per axis for the stationarity scan and the noise model's long
  // taus (plans with stationarity or noise_model_long_taus).
  std::vector<allan::BinAccumulator> bins_;
  std::vector<double> sum_;  // per axis, valid samples after warm-up
  std::vector<int64_t> count_;
  std::vector<std::vector<uint8_t>> invalid_scratch_;  // per axis
  std::vector<double> out_of_range_at_;                // per axis: |sample| >= it is invalid
  // Marks of every axis's engine and of its valid samples' sum and count,
  // every mark_every_ analysed samples from the first (plans that judge the
  // longest stationary segment; none otherwise): the curve and the mean of
  // a stretch between two marks. The spacing (a second of samples at
  // first) doubles, every other mark dropped, when there would be more than
  // kMaxMarks: at most 513 marks of a few kB per axis, a second apart in a
  // record of up to 512 s, between 1/512 and 1/256 of a longer one.
  struct SumMark {
    double sum = 0;
    int64_t count = 0;
  };
  static constexpr size_t kMaxMarks = 512;
  std::vector<std::vector<allan::StreamMark>> marks_;  // per axis
  std::vector<std::vector<SumMark>> mark_sums_;        // per axis
  int64_t mark_every_ = 0;
  std::optional<judge::EarlyDecider> decider_;
  std::vector<int64_t> look_samples_;  // analysed samples at each look
  size_t next_look_ = 0;
  int64_t after_decision_ = 0;
  DeviceClockFit clock_{1.0};               // reset in Create with the nominal rate
  judge::TemperatureReadings temperature_;  // batches analysed that carried one
};

// How a run that ended in `state` ("running", "complete", "aborted",
// "incomplete") with the announced end `reason` ended: aborted by the
// operator (reason kShutdownEndReason, or none) is ABORTED, "run aborted
// before completion (...)"; aborted for any other reason (its source failed,
// the station stopped it) is ERROR, "run aborted by a failure: ..."; an
// incomplete run (its source went silent) is ERROR, "run incomplete: ...".
// Verdict UNSET when it ended normally: complete, with or without a reason
// (a run its unit's early decision ended says "decided PASS at T s (early
// decision)").
RunEnding EndingForRunState(const std::string& state, const std::string& reason = "");
// The same (the name archived re-analysis calls).
inline RunEnding FailureForRunState(const std::string& state, const std::string& reason = "") {
  return EndingForRunState(state, reason);
}

}  // namespace imuqual::analyze

#endif  // IMUQUAL_ANALYZE_SERVICE_RUN_ANALYZER_H_
