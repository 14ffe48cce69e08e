#include "analyze/service/run_analyzer.h"

#include <algorithm>
#include <cmath>

#include "analyze/allan/confidence.h"
#include "analyze/judge/measure.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "common/shutdown.h"

namespace imuqual::analyze {
namespace {

// rate_batch_t FLAG_SATURATED | FLAG_INVALID: the sample is not a measurement.
constexpr int kUnusableFlags = 1 | 2;
// A counter jump beyond a day of samples is a corrupt counter, not a gap
// (a real unit that stops for a day ends its run).
constexpr double kAbsurdGapSeconds = 86400.0;
// The device clock is measured once arrivals span this much device time.
constexpr double kMinClockSpanS = 2.0;

}  // namespace

RunAnalyzer::RunAnalyzer(RunDescription description, AnalyzerOptions options)
    : desc_(std::move(description)), options_(options) {}

Result<RunAnalyzer> RunAnalyzer::Create(RunDescription description, AnalyzerOptions options) {
  if (description.axes.empty()) return Status::InvalidArgument("run has no axes");
  if (!(description.nominal_rate_hz > 0) || !std::isfinite(description.nominal_rate_hz)) {
    return Status::InvalidArgument("run rate must be positive");
  }
  RunAnalyzer a(std::move(description), options);
  a.tau0_s_ = 1.0 / a.desc_.nominal_rate_hz;
  a.warmup_target_ = std::llround(a.desc_.plan.warmup_s() * a.desc_.nominal_rate_hz);
  allan::StreamingOptions so;
  so.tau0_s = a.tau0_s_;
  so.density = options.density;
  IMUQUAL_RETURN_IF_ERROR(so.Validate());
  for (size_t i = 0; i < a.desc_.axes.size(); ++i) a.engines_.emplace_back(so);
  a.sum_.assign(a.desc_.axes.size(), 0.0);
  a.count_.assign(a.desc_.axes.size(), 0);
  a.invalid_samples_.assign(a.desc_.axes.size(), 0);
  a.clock_ = DeviceClockFit(a.desc_.nominal_rate_hz);
  return a;
}

// Places `count` missing samples on the timeline: warm-up first, then gaps.
void RunAnalyzer::Push(int64_t count_missing) {
  const int64_t warm = std::min(count_missing, warmup_target_ - warmup_seen_);
  warmup_seen_ += std::max<int64_t>(warm, 0);
  const int64_t rest = count_missing - std::max<int64_t>(warm, 0);
  if (rest <= 0) return;
  for (allan::StreamingAllan& e : engines_) e.AppendMissing(rest);
  gap_samples_ += rest;
}

Status RunAnalyzer::AddBatch(const BatchView& batch) {
  const size_t axes = desc_.axes.size();
  if (batch.samples.size() != axes) {
    return Status::InvalidArgument("batch has " + std::to_string(batch.samples.size()) +
                                   " axes, the run " + std::to_string(axes));
  }
  const size_t n = batch.samples[0].size();
  for (const auto& s : batch.samples) {
    if (s.size() != n) return Status::InvalidArgument("batch axes differ in length");
  }
  if (!(std::abs(batch.nominal_rate_hz / desc_.nominal_rate_hz - 1.0) < 1e-9)) {
    return Status::InvalidArgument("batch claims " + std::to_string(batch.nominal_rate_hz) +
                                   " Hz, the run is at " + std::to_string(desc_.nominal_rate_hz) +
                                   " Hz");
  }
  for (const BatchView::Flag& f : batch.flags) {
    if (f.sample < 0 || static_cast<size_t>(f.sample) >= n || f.axis < 0 ||
        static_cast<size_t>(f.axis) >= axes) {
      return Status::InvalidArgument("batch flag points outside the batch");
    }
  }
  if (next_counter_ >= 0 && batch.first_sample < next_counter_) {
    return Status::InvalidArgument("device counter went backwards (expected " +
                                   std::to_string(next_counter_) + ", batch starts at " +
                                   std::to_string(batch.first_sample) + ")");
  }
  if (next_counter_ >= 0 &&
      static_cast<double>(batch.first_sample - next_counter_) * tau0_s_ > kAbsurdGapSeconds) {
    return Status::InvalidArgument("device counter jumped by " +
                                   std::to_string(batch.first_sample - next_counter_) + " samples");
  }
  if (first_counter_ < 0) {
    first_counter_ = batch.first_sample;
    next_counter_ = batch.first_sample;
  }
  Push(batch.first_sample - next_counter_);

  // Warm-up samples of this batch are skipped.
  const int64_t skip =
      std::clamp<int64_t>(warmup_target_ - warmup_seen_, 0, static_cast<int64_t>(n));
  warmup_seen_ += skip;
  const size_t keep = n - static_cast<size_t>(skip);
  if (keep > 0) {
    for (size_t a = 0; a < axes; ++a) {
      invalid_scratch_.assign(n, 0);
      for (const BatchView::Flag& f : batch.flags) {
        if (static_cast<size_t>(f.axis) == a && (f.bits & kUnusableFlags)) {
          invalid_scratch_[f.sample] = 1;
        }
      }
      const std::span<const float> values = batch.samples[a].subspan(skip);
      const std::span<const uint8_t> invalid =
          std::span<const uint8_t>(invalid_scratch_).subspan(skip);
      engines_[a].Append(values, invalid);
      for (size_t i = 0; i < keep; ++i) {
        if (invalid[i] || !std::isfinite(values[i])) {
          ++invalid_samples_[a];
        } else {
          sum_[a] += values[i];
          ++count_[a];
        }
      }
    }
  }
  next_counter_ = batch.first_sample + static_cast<int64_t>(n);
  if (batch.sample_utime > 0) clock_.Add(batch.first_sample, batch.sample_utime);
  ++batches_;
  return Status::Ok();
}

void RunAnalyzer::Finish(int64_t first_sample, int64_t end_sample) {
  // The announced range beyond the batches is missing data, unless it is
  // absurd (a day or more: a broken or lying announcement), which would
  // only cost hours of analysing nothing: then it is refused, with a reason.
  auto missing = [&](int64_t from, int64_t to, const char* where) {
    if (to <= from) return;
    if (static_cast<double>(to - from) * tau0_s_ > kAbsurdGapSeconds) {
      absurd_range_ = "the announced sample range " + std::to_string(first_sample) + ".." +
                      std::to_string(end_sample) + " lies " + std::to_string(to - from) +
                      " samples " + where + " the data received; not analysed as a gap";
      return;
    }
    Push(to - from);
  };
  if (first_counter_ < 0) {
    // Nothing arrived: the whole announced range is missing.
    if (first_sample >= 0) missing(first_sample, end_sample, "beyond");
    return;
  }
  if (first_sample >= 0) missing(first_sample, first_counter_, "before");
  missing(next_counter_, end_sample, "beyond");
}

RunEnding EndingForRunState(const std::string& state, const std::string& reason) {
  const std::string why = reason.empty() ? "" : " (" + reason + ")";
  if (state == "aborted" && (reason.empty() || reason == kShutdownEndReason)) {
    return {pb::ABORTED, "run aborted before completion" + why};
  }
  if (state == "aborted") return {pb::ERROR, "run aborted by a failure: " + reason};
  if (state == "incomplete") {
    return {pb::ERROR, "run incomplete: its source went silent before ending it" + why};
  }
  return {};
}

RunOutcome RunAnalyzer::Outcome(bool final, const RunEnding& ending) const {
  RunOutcome out;
  const pb::TestPlan& plan = desc_.plan;
  const allan::StopRule stop =
      allan::ParseStopRule(judge::PlanStopRule(plan)).value_or(allan::StopRule::kBins9);
  const allan::StreamGrid grid = plan.grid().kind() == pb::TauGrid::OCTAVE
                                     ? allan::StreamGrid::kOctave
                                     : allan::StreamGrid::kDense;
  for (size_t a = 0; a < desc_.axes.size(); ++a) {
    const allan::StreamingAllan& e = engines_[a];
    // The judged curve is the dense grid (every tracked averaging factor, a
    // superset of the octave grid): the final result publishes it, so the
    // archive holds every point a measurement was read from. Interim looks
    // publish the plan's grid. Both with chi-square intervals (Greenhall edf,
    // noise identified from the local slope; the long-tau rule in
    // streaming.h).
    // The measurements read the dense points without intervals (the noise
    // model weighs them by its own edf, gmwm.h); the intervals are computed
    // only for the curve published.
    const allan::Curve dense = e.Oadev(allan::StreamGrid::kDense, stop, allan::CiMethod::kNone);
    out.curves.emplace_back(desc_.axes[a].name,
                            e.Oadev(final ? allan::StreamGrid::kDense : grid, stop,
                                    allan::CiMethod::kChi2, allan::kOneSigmaConfidence));
    const double mean = count_[a] > 0 ? sum_[a] / static_cast<double>(count_[a]) : allan::kNaN;
    for (pb::Measurement& m :
         judge::MeasureAxis(desc_.axes[a].name, desc_.axes[a].kind, dense, mean)) {
      out.measurements.push_back(std::move(m));
    }
    // The noise model once the run has ended (a fit costs 50-500 ms per axis;
    // interim looks judge the read-offs only).
    if (final) {
      judge::NoiseModelOptions model_options;
      model_options.judge_inadequate_values =
          plan.on_inadequate_model() == pb::TestPlan::JUDGE_INADEQUATE_VALUE;
      for (pb::Measurement& m :
           judge::MeasureNoiseModel(desc_.axes[a].name, desc_.axes[a].kind, dense, model_options)) {
        out.measurements.push_back(std::move(m));
      }
    }
  }
  out.samples = engines_.front().samples();
  out.gap_samples = gap_samples_;
  out.axis_invalid_samples = invalid_samples_;
  for (int64_t n : invalid_samples_) out.invalid_samples += n;
  out.warmup_samples = warmup_seen_;
  for (pb::Measurement& m :
       judge::MeasureRun(static_cast<double>(out.samples) * tau0_s_, out.samples, out.gap_samples,
                         out.invalid_samples, static_cast<int>(desc_.axes.size()))) {
    out.measurements.push_back(std::move(m));
  }
  // Timing truth once the counter spans a few seconds of arrivals.
  if (clock_.Usable(kMinClockSpanS * desc_.nominal_rate_hz)) {
    for (pb::Measurement& m : judge::MeasureTiming(desc_.nominal_rate_hz, clock_.RateHz(),
                                                   clock_.RateSigmaHz(), clock_.JitterRmsS())) {
      out.measurements.push_back(std::move(m));
    }
  }
  if (final) {
    out.judgement = judge::Judge(plan, desc_.axes, &out.measurements);
  } else {
    // Provisional: judge what is measured so far, not the run's length nor
    // the noise model (fitted at the end).
    pb::TestPlan provisional = plan;
    provisional.set_min_duration_s(0);
    auto* limits = provisional.mutable_limits();
    limits->erase(std::remove_if(limits->begin(), limits->end(),
                                 [](const pb::Limit& l) {
                                   return l.measurement() == "duration" ||
                                          judge::FromNoiseModel(l.measurement());
                                 }),
                  limits->end());
    out.judgement = judge::Judge(provisional, desc_.axes, &out.measurements);
  }
  // The run's verdict says first whether it can be judged at all.
  if (ending.verdict != pb::OUTCOME_UNSET) {
    out.judgement.verdict = ending.verdict;
    out.judgement.reasons.insert(out.judgement.reasons.begin(), ending.reason);
  }
  if (!absurd_range_.empty()) {
    out.judgement.verdict = pb::ERROR;
    out.judgement.reasons.insert(out.judgement.reasons.begin(), absurd_range_);
  }
  return out;
}

}  // namespace imuqual::analyze
