#include "analyze/service/run_analyzer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <thread>

#include "analyze/allan/confidence.h"
#include "analyze/allan/tau_grid.h"
#include "analyze/judge/measure.h"
#include "analyze/judge/measurements.h"
#include "analyze/judge/plan.h"
#include "analyze/judge/stationarity_measure.h"
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

// The plan an interim look judges by: what is measured so far, not the run's
// length, the noise model nor the stationarity scan (both at the end).
pb::TestPlan ProvisionalPlan(const pb::TestPlan& plan) {
  pb::TestPlan provisional = plan;
  provisional.set_min_duration_s(0);
  auto* limits = provisional.mutable_limits();
  limits->erase(std::remove_if(limits->begin(), limits->end(),
                               [](const pb::Limit& l) {
                                 return l.measurement() == judge::kDuration ||
                                        l.measurement() == judge::kStationarityEvents ||
                                        judge::FromNoiseModel(l.measurement());
                               }),
                limits->end());
  return provisional;
}

// The run-level record of early decisions: when the unit was decided
// (analysed device time), or NaN when it stayed pending at every look.
pb::Measurement DecisionTime(const judge::EarlyDecider& d, const pb::TestPlan& plan) {
  pb::Measurement m;
  m.set_name(std::string(judge::kDecisionTime));
  m.set_unit("s");
  m.set_uncertainty_method("none: exact (device sample counter)");
  const judge::LookSchedule& s = d.schedule();
  char buf[256];
  if (d.unit_decision() == judge::Decision::kPending) {
    m.set_value(std::nan(""));
    m.set_qualifier(pb::NOT_MEASURABLE);
    std::snprintf(buf, sizeof buf,
                  "pending at every one of %zu looks (%g..%g s): full-length verdict",
                  s.times_s.size(), s.times_s.empty() ? 0.0 : s.times_s.front(),
                  s.times_s.empty() ? 0.0 : s.times_s.back());
  } else {
    m.set_value(d.decided_time_s());
    const judge::Look& look = d.looks().back();
    std::snprintf(buf, sizeof buf,
                  "decided %s at look %d of %zu (z %.3g; risk %g per unit, Pocock-type "
                  "spending over %g s)",
                  judge::DecisionName(d.unit_decision()), look.index + 1, s.times_s.size(), look.z,
                  plan.early_decision().risk(), s.horizon_s);
  }
  m.set_note(buf);
  return m;
}

// Runs work(0) .. work(count - 1), each once, on up to as many threads as
// the machine has cores (this one included); returns when all are done.
// Each call must touch only its own outputs.
void ForEachInParallel(size_t count, const std::function<void(size_t)>& work) {
  const size_t cores = std::max<size_t>(std::thread::hardware_concurrency(), 1);
  const size_t threads = std::min(count, cores);
  std::atomic<size_t> next{0};
  const auto take = [&] {
    for (size_t i = next++; i < count; i = next++) work(i);
  };
  std::vector<std::thread> helpers;
  for (size_t t = 1; t < threads; ++t) helpers.emplace_back(take);
  take();
  for (std::thread& t : helpers) t.join();
}

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
  if (a.desc_.plan.has_stationarity() || a.desc_.plan.noise_model_long_taus()) {
    // Base bins of a second (at least a sample): the scan's bins are whole
    // multiples of them, chosen once the record's length is known; their
    // means are the record Theo1 runs on for the noise model's long taus.
    const int64_t base = std::max<int64_t>(1, std::llround(a.desc_.nominal_rate_hz));
    a.bins_.assign(a.desc_.axes.size(), allan::BinAccumulator(base));
  }
  a.sum_.assign(a.desc_.axes.size(), 0.0);
  a.count_.assign(a.desc_.axes.size(), 0);
  if (a.desc_.plan.has_stationarity() &&
      a.desc_.plan.stationarity().on_event() == pb::Stationarity::JUDGE_LONGEST_SEGMENT) {
    a.mark_every_ = std::max<int64_t>(1, std::llround(a.desc_.nominal_rate_hz));
    for (const allan::StreamingAllan& e : a.engines_) {
      a.marks_.push_back({e.Mark()});
      a.mark_sums_.push_back({SumMark{}});
    }
  }
  a.invalid_samples_.assign(a.desc_.axes.size(), 0);
  a.clock_ = DeviceClockFit(a.desc_.nominal_rate_hz);
  a.invalid_scratch_.resize(a.desc_.axes.size());
  for (const judge::AxisDesc& axis : a.desc_.axes) {
    a.out_of_range_at_.push_back(judge::OutOfRangeAt(a.desc_.plan, axis.kind));
  }
  if (a.desc_.plan.has_early_decision()) {
    auto decider = judge::EarlyDecider::Create(a.desc_.plan);
    if (!decider.ok()) return decider.status();
    a.decider_ = std::move(*decider);
    for (double t : a.decider_->schedule().times_s) {
      a.look_samples_.push_back(std::llround(t * a.desc_.nominal_rate_hz));
    }
  }
  return a;
}

// Places `count` missing samples on the timeline: warm-up first, then gaps.
void RunAnalyzer::Push(int64_t count_missing) {
  const int64_t warm = std::min(count_missing, warmup_target_ - warmup_seen_);
  warmup_seen_ += std::max<int64_t>(warm, 0);
  int64_t rest = count_missing - std::max<int64_t>(warm, 0);
  while (rest > 0) {
    if (decided()) {
      after_decision_ += rest;
      return;
    }
    const int64_t n = std::min(rest, UntilStop());
    for (allan::StreamingAllan& e : engines_) e.AppendMissing(n);
    for (allan::BinAccumulator& b : bins_) b.AppendMissing(n);
    gap_samples_ += n;
    rest -= n;
    AtStop();
  }
}

int64_t RunAnalyzer::UntilLook() const {
  if (!decider_ || next_look_ >= look_samples_.size()) return INT64_MAX;
  return std::max<int64_t>(look_samples_[next_look_] - engines_.front().samples(), 0);
}

int64_t RunAnalyzer::UntilStop() const {
  int64_t until = UntilLook();
  if (mark_every_ > 0) {
    const int64_t since = engines_.front().samples() - marks_.front().back().samples;
    until = std::min(until, std::max<int64_t>(mark_every_ - since, 0));
  }
  return until;
}

void RunAnalyzer::AtStop() {
  if (mark_every_ > 0 &&
      engines_.front().samples() - marks_.front().back().samples >= mark_every_) {
    for (size_t a = 0; a < engines_.size(); ++a) {
      marks_[a].push_back(engines_[a].Mark());
      mark_sums_[a].push_back({sum_[a], count_[a]});
    }
    if (marks_.front().size() > kMaxMarks) {
      // Every other mark (those at odd multiples of the spacing) goes.
      mark_every_ *= 2;
      for (size_t a = 0; a < engines_.size(); ++a) {
        size_t kept = 0;
        for (size_t k = 0; k < marks_[a].size(); ++k) {
          if (marks_[a][k].samples % mark_every_ != 0) continue;
          marks_[a][kept] = std::move(marks_[a][k]);
          mark_sums_[a][kept] = mark_sums_[a][k];
          ++kept;
        }
        marks_[a].resize(kept);
        mark_sums_[a].resize(kept);
      }
    }
  }
  LookIfDue();
}

void RunAnalyzer::LookIfDue() {
  if (!decider_ || decided() || next_look_ >= look_samples_.size()) return;
  if (engines_.front().samples() < look_samples_[next_look_]) return;
  std::vector<allan::Curve> dense;  // per axis, no intervals: what was measured
  std::vector<pb::Measurement> measurements = MeasureNow(false, nullptr, &dense);
  judge::Judge(ProvisionalPlan(desc_.plan), desc_.axes, &measurements);
  // The longest tau the full-length record would show.
  const double horizon_samples = decider_->schedule().horizon_s * desc_.nominal_rate_hz;
  const allan::StopRule stop =
      allan::ParseStopRule(judge::PlanStopRule(desc_.plan)).value_or(allan::StopRule::kBins9);
  const double horizon_m = static_cast<double>(allan::StopRuleMaxAveragingFactor(
      stop, allan::Deviation::kOadev, static_cast<int64_t>(horizon_samples) + 1));
  const auto settled = [&](const std::string& axis) {
    for (size_t a = 0; a < desc_.axes.size(); ++a) {
      if (desc_.axes[a].name == axis) return judge::MinimumSettled(dense[a], horizon_m);
    }
    return false;
  };
  // Evidence read off each axis's curve with its chi-square intervals
  // (computed once per axis and look, when asked): tau_at_minimum from the
  // curve's shape and its spread, whichever says more; the white-noise
  // read-offs' "below" from the ceilings sigma(tau) sqrt(tau) >= N (measure.h;
  // no ceiling is trusted for being low), "above" from the -1/2 line's
  // read-off and its uncertainty.
  std::vector<std::optional<allan::Curve>> with_intervals(desc_.axes.size());
  const auto curve_of = [&](const std::string& axis) -> const allan::Curve* {
    for (size_t a = 0; a < desc_.axes.size(); ++a) {
      if (desc_.axes[a].name != axis) continue;
      if (!with_intervals[a]) {
        with_intervals[a] = engines_[a].Oadev(allan::StreamGrid::kDense, stop,
                                              allan::CiMethod::kChi2, allan::kOneSigmaConfidence);
      }
      return &*with_intervals[a];
    }
    return nullptr;
  };
  const auto kind_of = [&](const std::string& axis) {
    for (const judge::AxisDesc& a : desc_.axes) {
      if (a.name == axis) return a.kind;
    }
    return pb::GYRO;
  };
  const auto evidence = [&](const pb::Measurement& m, double bound) {
    judge::SideEvidence ev;
    const allan::Curve* curve = curve_of(m.axis());
    if (curve == nullptr) return ev;
    if (m.name() == judge::kTauAtMinimum) {
      const double c = judge::MinimumSideEvidence(*curve, bound);
      // The value's own spread on ln tau, as the judge guards it (none
      // without a u: then the curve's evidence alone).
      const double z = judge::SigmasAbove(m, bound);
      const double above = std::isnan(z) ? -INFINITY : z;
      const double below = std::isnan(z) ? -INFINITY : -z;
      ev.above = std::max(c, above);
      ev.above_source = c >= above ? "curve evidence" : "tau spread";
      ev.below = std::max(-c, below);
      ev.below_source = -c >= below ? "curve evidence" : "tau spread";
    } else if (m.name() == judge::kAngleRandomWalk || m.name() == judge::kVelocityRandomWalk) {
      std::string source;
      const double z = judge::WhiteNoiseBelowEvidence(*curve, kind_of(m.axis()), bound, &source);
      // Never from the read-off along the -1/2 line (biased low).
      ev.below = std::isfinite(z) ? z : -INFINITY;
      ev.below_source = source;
    }
    return ev;
  };
  decider_->Evaluate(static_cast<int>(next_look_), measurements, settled, evidence);
  ++next_look_;
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
  const bool decided_at_start = decided();
  if (first_counter_ < 0) {
    first_counter_ = batch.first_sample;
    next_counter_ = batch.first_sample;
  }
  Push(batch.first_sample - next_counter_);

  // Warm-up samples of this batch are skipped.
  const int64_t skip =
      std::clamp<int64_t>(warmup_target_ - warmup_seen_, 0, static_cast<int64_t>(n));
  warmup_seen_ += skip;
  for (size_t a = 0; a < axes; ++a) {
    invalid_scratch_[a].assign(n, 0);
    for (const BatchView::Flag& f : batch.flags) {
      if (static_cast<size_t>(f.axis) == a && (f.bits & kUnusableFlags)) {
        invalid_scratch_[a][f.sample] = 1;
      }
    }
    if (std::isfinite(out_of_range_at_[a])) {
      for (size_t i = 0; i < n; ++i) {
        if (judge::OutOfRange(batch.samples[a][i], out_of_range_at_[a])) invalid_scratch_[a][i] = 1;
      }
    }
  }
  // The kept samples in pieces that end at the looks (early decisions), so
  // each look sees the same record whatever the batch boundaries.
  const int64_t analysed_before = engines_.front().samples();
  size_t pos = static_cast<size_t>(skip);
  while (pos < n) {
    if (decided()) {
      after_decision_ += static_cast<int64_t>(n - pos);
      break;
    }
    const size_t len =
        static_cast<size_t>(std::min<int64_t>(static_cast<int64_t>(n - pos), UntilStop()));
    for (size_t a = 0; a < axes; ++a) {
      const std::span<const float> values = batch.samples[a].subspan(pos, len);
      const std::span<const uint8_t> invalid =
          std::span<const uint8_t>(invalid_scratch_[a]).subspan(pos, len);
      engines_[a].Append(values, invalid);
      if (!bins_.empty()) bins_[a].Append(values, invalid);
      for (size_t i = 0; i < len; ++i) {
        if (invalid[i] || !std::isfinite(values[i])) {
          ++invalid_samples_[a];
        } else {
          sum_[a] += values[i];
          ++count_[a];
        }
      }
    }
    pos += len;
    AtStop();
  }
  next_counter_ = batch.first_sample + static_cast<int64_t>(n);
  // The batch's temperature, weighted by the samples it contributed to the
  // analysis, at their middle (device time from the analysed start).
  const int64_t analysed = engines_.front().samples() - analysed_before;
  if (batch.temperature_c && std::isfinite(*batch.temperature_c) && analysed > 0) {
    temperature_.Add(
        *batch.temperature_c,
        (static_cast<double>(analysed_before) + 0.5 * static_cast<double>(analysed)) * tau0_s_,
        static_cast<double>(analysed));
  }
  // The device clock from the batches analysed (none after the decision).
  if (batch.sample_utime > 0 && !decided_at_start)
    clock_.Add(batch.first_sample, batch.sample_utime);
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

std::vector<pb::Measurement> RunAnalyzer::MeasureNow(
    bool final, std::vector<std::pair<std::string, allan::Curve>>* curves,
    std::vector<allan::Curve>* dense_curves) const {
  std::vector<pb::Measurement> out;
  const pb::TestPlan& plan = desc_.plan;
  const allan::StopRule stop =
      allan::ParseStopRule(judge::PlanStopRule(plan)).value_or(allan::StopRule::kBins9);
  const allan::StreamGrid grid = plan.grid().kind() == pb::TauGrid::OCTAVE
                                     ? allan::StreamGrid::kOctave
                                     : allan::StreamGrid::kDense;
  // The measurements read the dense points without intervals (the noise
  // model weighs them by its own edf, gmwm.h); the intervals are computed
  // only for the curve published.
  const size_t axes = desc_.axes.size();
  std::vector<allan::Curve> dense_of(axes);
  for (size_t a = 0; a < axes; ++a) {
    dense_of[a] = engines_[a].Oadev(allan::StreamGrid::kDense, stop, allan::CiMethod::kNone);
  }
  // The final result of a plan with stationarity: each axis's whole-record
  // curve with its intervals, and the scan (the reference check reads the
  // curves); with JUDGE_LONGEST_SEGMENT, the stretch each axis is judged on.
  std::vector<allan::Curve> whole_ci;
  std::vector<pb::Measurement> stationarity;
  std::vector<std::optional<allan::Curve>> segment_ci(axes);
  std::vector<double> means(axes);
  for (size_t a = 0; a < axes; ++a) {
    means[a] = count_[a] > 0 ? sum_[a] / static_cast<double>(count_[a]) : allan::kNaN;
  }
  if (final && plan.has_stationarity()) {
    for (const allan::StreamingAllan& e : engines_) {
      whole_ci.push_back(e.Oadev(allan::StreamGrid::kDense, stop, allan::CiMethod::kChi2,
                                 allan::kOneSigmaConfidence));
    }
    int64_t bin_samples = judge::StationarityBinSamples(plan, engines_.front().samples(), tau0_s_);
    std::vector<judge::StationarityAxis> scan_axes(axes);
    for (size_t a = 0; a < axes; ++a) {
      scan_axes[a].axis = desc_.axes[a];
      scan_axes[a].bin_means = bins_[a].Means(&bin_samples);
      scan_axes[a].mean_square = bins_[a].MeanSquareDifferences(bin_samples);
      scan_axes[a].curve = &whole_ci[a];
    }
    std::vector<judge::EventCuts> cuts;
    stationarity = judge::MeasureStationarity(plan, scan_axes,
                                              static_cast<double>(bin_samples) * tau0_s_, tau0_s_,
                                              marks_.empty() ? nullptr : &cuts);
    for (size_t a = 0; a < axes && !marks_.empty(); ++a) {
      bool scanned = false;
      for (const pb::Measurement& m : stationarity) {
        scanned |= m.axis() == desc_.axes[a].name && m.name() == judge::kStationarityEvents &&
                   std::isfinite(m.value());
      }
      for (pb::Measurement& m :
           JudgeOnSegment(a, cuts[a], scanned, stop, &dense_of[a], &segment_ci[a], &means[a])) {
        stationarity.push_back(std::move(m));
      }
    }
  }
  // The noise model once the run has ended (a fit costs 20-500 ms per axis;
  // interim looks judge the read-offs only), every axis on its own thread.
  std::vector<std::vector<pb::Measurement>> model_of(axes);
  if (final) {
    judge::NoiseModelOptions model_options;
    model_options.judge_inadequate_values =
        plan.on_inadequate_model() == pb::TestPlan::JUDGE_INADEQUATE_VALUE;
    ForEachInParallel(axes, [&](size_t a) {
      judge::NoiseModelOptions axis_options = model_options;
      if (const pb::NoiseModelRange* r = judge::NoiseModelRangeFor(plan, desc_.axes[a].kind)) {
        axis_options.min_tau_s = r->min_tau_s();
        axis_options.range_reason = r->reason();
      }
      if (plan.noise_model_long_taus() && !dense_of[a].points.empty()) {
        axis_options.long_taus = LongTauMoments(a, dense_of[a].points.back().tau_s, stationarity,
                                                &axis_options.long_tau_note);
      }
      model_of[a] = judge::MeasureNoiseModel(desc_.axes[a].name, desc_.axes[a].kind, dense_of[a],
                                             axis_options);
    });
  }
  for (size_t a = 0; a < axes; ++a) {
    const allan::StreamingAllan& e = engines_[a];
    // The judged curve is the dense grid (every tracked averaging factor, a
    // superset of the octave grid): the final result publishes it, so the
    // archive holds every point a measurement was read from (an axis judged
    // on a stretch: that stretch's curve). Interim looks publish the plan's
    // grid. Both with chi-square intervals (Greenhall edf, noise identified
    // from the local slope; the long-tau rule in streaming.h).
    allan::Curve& dense = dense_of[a];
    if (curves) {
      if (segment_ci[a]) {
        curves->emplace_back(desc_.axes[a].name, std::move(*segment_ci[a]));
      } else if (!whole_ci.empty()) {
        curves->emplace_back(desc_.axes[a].name, whole_ci[a]);
      } else {
        curves->emplace_back(desc_.axes[a].name,
                             e.Oadev(final ? allan::StreamGrid::kDense : grid, stop,
                                     allan::CiMethod::kChi2, allan::kOneSigmaConfidence));
      }
    }
    // tau_at_minimum's u in the final result, and at a look when the plan
    // judges it on this axis (a live update every few seconds would refit
    // every axis's bottom).
    const bool tau_u = final || (dense_curves != nullptr &&
                                 judge::FindLimit(desc_.plan, std::string(judge::kTauAtMinimum),
                                                  &desc_.axes[a]) != nullptr);
    for (pb::Measurement& m :
         judge::MeasureAxis(desc_.axes[a].name, desc_.axes[a].kind, dense, means[a], tau_u)) {
      out.push_back(std::move(m));
    }
    for (pb::Measurement& m : model_of[a]) out.push_back(std::move(m));
    if (dense_curves) dense_curves->push_back(std::move(dense));
  }
  for (pb::Measurement& m : stationarity) out.push_back(std::move(m));
  const int64_t samples = engines_.front().samples();
  int64_t invalid = 0;
  for (int64_t n : invalid_samples_) invalid += n;
  for (pb::Measurement& m :
       judge::MeasureRun(static_cast<double>(samples) * tau0_s_, samples, gap_samples_, invalid,
                         static_cast<int>(desc_.axes.size()))) {
    out.push_back(std::move(m));
  }
  for (pb::Measurement& m : judge::MeasureTemperature(temperature_)) out.push_back(std::move(m));
  // Timing truth once the counter spans a few seconds of arrivals.
  if (clock_.Usable(kMinClockSpanS * desc_.nominal_rate_hz)) {
    for (pb::Measurement& m : judge::MeasureTiming(desc_.nominal_rate_hz, clock_.RateHz(),
                                                   clock_.RateSigmaHz(), clock_.JitterRmsS())) {
      out.push_back(std::move(m));
    }
  }
  return out;
}

std::vector<allan::Theo1Moment> RunAnalyzer::LongTauMoments(
    size_t a, double last_tau_s, const std::vector<pb::Measurement>& stationarity,
    std::string* note) const {
  // An axis judged on a stretch: its one-second means inside that stretch.
  int64_t begin = 0, end = INT64_MAX;
  for (const pb::Measurement& m : stationarity) {
    if (m.axis() != desc_.axes[a].name || !std::isfinite(m.value())) continue;
    if (m.name() == judge::kJudgedSegmentStart) begin = std::llround(m.value() / tau0_s_);
    if (m.name() == judge::kJudgedSegmentEnd) end = std::llround(m.value() / tau0_s_);
  }
  const allan::PhaseRecord means = bins_[a].MeansPhase(tau0_s_, begin, end);
  std::vector<allan::Theo1Moment> moments =
      allan::Theo1MomentsBeyond(means, last_tau_s, bins_[a].base_samples());
  if (moments.empty()) {
    // A mean with an invalid or missing sample is a gap in the means' record.
    const int64_t span = std::max<int64_t>(allan::LongestValidSpan(means).size() - 1, 0);
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "no Theo1 moments: the longest stretch of whole valid means (%.0f s) reaches no "
                  "octave beyond the curve's last tau %.4g s",
                  static_cast<double>(span) * means.tau0_s, last_tau_s);
    *note = buf;
  }
  return moments;
}

std::vector<pb::Measurement> RunAnalyzer::JudgeOnSegment(size_t a, const judge::EventCuts& cuts,
                                                         bool scanned, allan::StopRule stop,
                                                         allan::Curve* dense,
                                                         std::optional<allan::Curve>* with_ci,
                                                         double* mean) const {
  const allan::StreamingAllan& engine = engines_[a];
  const double length_s = static_cast<double>(engine.samples()) * tau0_s_;
  const judge::AxisDesc& axis = desc_.axes[a];
  const auto number = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return std::string(buf);
  };
  pb::Measurement m;
  m.set_axis(axis.name);
  m.set_name(std::string(judge::kJudgedSegment));
  m.set_unit("s");
  m.set_uncertainty_method("none: exact (device sample counter)");
  pb::Measurement start = m;
  start.set_name(std::string(judge::kJudgedSegmentStart));
  start.set_note("where the judged stretch starts, s from the end of the warm-up");
  start.set_value(0);
  pb::Measurement end = start;
  end.set_name(std::string(judge::kJudgedSegmentEnd));
  end.set_note("where the judged stretch ends, s from the end of the warm-up");
  end.set_value(length_s);
  const double valid_s = static_cast<double>(engine.samples() - engine.invalid_samples()) * tau0_s_;
  if (cuts.empty()) {
    m.set_value(valid_s);
    m.set_note(std::string(judge::kWholeRecordNote) + ", 0-" + number(length_s) + " s (" +
               number(valid_s) + " s of data): " +
               (scanned ? "no event found on the axis"
                        : "not scanned (see stationarity_events), so no stretch was chosen"));
    return {m, start, end};
  }
  // The marks and the record's end.
  std::vector<allan::StreamMark> marks = marks_[a];
  std::vector<SumMark> sums = mark_sums_[a];
  if (marks.back().samples < engine.samples()) {
    marks.push_back(engine.Mark());
    sums.push_back({sum_[a], count_[a]});
  }
  const auto data = [&](size_t k) { return marks[k].samples - marks[k].invalid; };
  // Of the stretches no cut touches, each with its ends on the marks
  // (rounded inward), the one with the most data (valid samples: a stretch
  // that is mostly missing is not long), the earliest of equal ones.
  size_t from = 0, to = 0;
  for (const allan::Segment& stretch : allan::UncutStretches(cuts, length_s)) {
    size_t f = 0;
    while (f + 1 < marks.size() &&
           static_cast<double>(marks[f].samples) * tau0_s_ < stretch.begin_s - 1e-9) {
      ++f;
    }
    size_t t = marks.size() - 1;
    while (t > f && static_cast<double>(marks[t].samples) * tau0_s_ > stretch.end_s + 1e-9) --t;
    if (t > f && data(t) - data(f) > data(to) - data(from)) {
      from = f;
      to = t;
    }
  }
  std::string touched;
  for (const auto& [lo, hi] : cuts) {
    touched += (touched.empty() ? "" : ", ") + number(std::max(lo, 0.0)) + "-" +
               number(std::min(hi, length_s)) + " s";
  }
  const std::string cut_text = "cut at " + touched +
                               " (each found event and a scan bin either side); its ends on the "
                               "analysis's marks (every " +
                               number(static_cast<double>(mark_every_) * tau0_s_) +
                               " s, rounded inward)";
  if (to <= from) {
    m.set_value(0);
    m.set_note(
        "no stretch: the events leave no stretch between two of the analysis's marks with "
        "data in it (" +
        cut_text + ")");
    *dense = allan::Curve{};
    dense->tau0_s = tau0_s_;
    *with_ci = *dense;
    *mean = allan::kNaN;
    end.set_value(0);
    return {m, start, end};
  }
  const double begin_s = static_cast<double>(marks[from].samples) * tau0_s_;
  const double end_s = static_cast<double>(marks[to].samples) * tau0_s_;
  const double stretch_data_s = static_cast<double>(data(to) - data(from)) * tau0_s_;
  m.set_value(stretch_data_s);
  start.set_value(begin_s);
  end.set_value(end_s);
  m.set_note("the stretch " + number(begin_s) + "-" + number(end_s) + " s of the " +
             number(length_s) + " s record (" + number(stretch_data_s) +
             " s of data), of those no found event touches the one with the most data, " +
             cut_text + "; the curve, the read-offs and the noise model are of that stretch");
  *dense = engine.SegmentOadev(marks, from, to, allan::StreamGrid::kDense, stop,
                               allan::CiMethod::kNone);
  *with_ci = engine.SegmentOadev(marks, from, to, allan::StreamGrid::kDense, stop,
                                 allan::CiMethod::kChi2, allan::kOneSigmaConfidence);
  const int64_t count = sums[to].count - sums[from].count;
  *mean = count > 0 ? (sums[to].sum - sums[from].sum) / static_cast<double>(count) : allan::kNaN;
  return {m, start, end};
}

RunOutcome RunAnalyzer::Outcome(bool final, const RunEnding& ending) const {
  RunOutcome out;
  const pb::TestPlan& plan = desc_.plan;
  out.measurements = MeasureNow(final, &out.curves);
  out.samples = engines_.front().samples();
  out.gap_samples = gap_samples_;
  out.axis_invalid_samples = invalid_samples_;
  for (int64_t n : invalid_samples_) out.invalid_samples += n;
  out.warmup_samples = warmup_seen_;
  out.samples_after_decision = after_decision_;
  if (decider_) {
    RunOutcome::Early early;
    early.unit = decider_->unit_decision();
    early.decided_at_s = decider_->decided_time_s();
    early.looks_done = static_cast<int>(next_look_);
    early.looks_planned = static_cast<int>(look_samples_.size());
    // Every look's evidence with the final outcome only (an interim one is
    // computed every interim period: the decider() accessor has them).
    if (final) early.looks = decider_->looks();
    out.early = std::move(early);
    if (final) out.measurements.push_back(DecisionTime(*decider_, desc_.plan));
  }
  if (final) {
    out.judgement = decider_ ? judge::JudgeDecided(plan, desc_.axes, *decider_, &out.measurements)
                             : judge::Judge(plan, desc_.axes, &out.measurements);
  } else {
    // Provisional: judge what is measured so far, not the run's length nor
    // the noise model (fitted at the end); what more data can still move
    // across a bound reads pending (INCONCLUSIVE), not a side.
    out.judgement = judge::JudgeInterim(ProvisionalPlan(plan), desc_.axes, &out.measurements);
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
