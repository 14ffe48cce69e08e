// Sequential (early) decisions: deciding each judged measurement of a unit
// as soon as the data allow, with the error over all looks controlled. Pure.
//
// Looks. At analysed device times t_k = min_duration_s + k * look_period_s
// (k = 0, 1, ..., t_k < horizon_s; plan EarlyDecision) the analysis measures
// the unit as usual and asks, for every bound of every judged limit, whether
// the truth is confirmed on one side of it. Information grows with the
// record, so look k sits at the information fraction f_k = t_k / horizon_s.
//
// Error control (group-sequential, Lan & DeMets 1983). Each bound is a
// one-sided test at level alpha = risk / (number of bounds tested for the
// unit: every low and high of every judged measurement of every axis)
// (Bonferroni over bounds, so the plan's risk holds per unit). The
// level is spent over the looks by the Pocock-type function
//   alpha(f) = alpha * ln(1 + (e - 1) f),
// which spends a quarter of it by f = 1/6 (a decision can come early; an
// O'Brien-Fleming-type function would spend almost nothing there), and the
// boundary z_k of look k is the exact one for a Brownian statistic
// Z_k = S(f_k) / sqrt(f_k): P(Z_j < z_j for j < k, Z_k >= z_k) =
// alpha(f_k) - alpha(f_{k-1}) under the null, computed by recursive
// numerical integration (Armitage, McPherson & Rowe 1969; Jennison &
// Turnbull 2000, ch. 19). Estimates of a longer record of the same unit are
// correlated with the earlier ones as sqrt(t_j / t_k), as such a statistic
// is (an Allan variance averages its terms over the record), which is the
// assumption; the benchmark `decide` measures the resulting error rates.
// What the spending leaves at the horizon is not used: a unit still pending
// there gets the full-length verdict of the plan's decision rule.
//
// The decisions are on the pass/fail limits (low, high) of each judged
// measurement. A marginal band is a flag (judge.h reads it simply); the
// plan's early_decision.marginal_flags says how a decided unit gets it:
//   FLAGS_AT_DECISION        read on the record analysed at the decision;
//   FLAGS_AGREE_FULL_LENGTH  the unit also waits until each flag would read
//     the same on the full-length record with 99 % probability: |v - M| >=
//     2.326 u sqrt(1 - f_k) at each marginal bound M (what the full record's
//     value can still differ from this one's, under the same Brownian
//     model), or, for tau_at_minimum, the curve's evidence puts the truth on
//     the value's side of M by 2.326; MARGINAL as soon as one flag is
//     settled so (the others cannot change the verdict), PASS once every
//     flag is settled clear;
//   FLAGS_DECIDED            each marginal bound decided like a limit at the
//     plan's risk (counted in the Bonferroni split).
// A bound B of a
// measurement with value v and 1-sigma uncertainty u is confirmed at look k
// with the truth above it when (v - B) / u >= z_k, below it when
// (B - v) / u >= z_k. What more data can still change is respected:
//   * a curve minimum (bias_instability(_ieee)) read on the points measured
//     so far can only go down with a longer record: "below a bound" needs
//     nothing more, "above" needs the minimum settled (an adequate noise
//     model, fitted at the look, puts the minimum of the curve up to the
//     horizon's longest tau well inside the measured range; measure.h
//     MinimumSettled) and resolved;
//   * tau_at_minimum is decided from the curve as well as from its value's
//     spread, whichever says more: the minimum lies above tau B when a point
//     at tau in [B, tau_min) is confirmed above the minimum (z of the
//     difference over the quadrature sum of their 1-sigma chi-square errors,
//     conservative for positively correlated estimates), below B when one at
//     tau in (tau_min, B] is; a sum of power-law noises is convex in log-log,
//     so no point beyond can undo it (measure.h MinimumSideEvidence). On a
//     flat bottom the rising side's points are too noisy one by one, and the
//     value and its uncertainty (tau x u(ln tau) from the bottom's vertex,
//     measure.cc; none where no rising line is seen, so pending) decide. More data can only move a
//     minimum to longer taus: "below" needs it resolved and settled, "above"
//     does not;
//   * a value qualified as an upper bound (or a minimum not resolved)
//     confirms only "below";
//   * values without a finite uncertainty, not measurable or withheld stay
//     pending; the noise-model measurements (fit_*, noise_model_p_value) are
//     fitted on the full record only, so a plan limiting them never decides
//     a unit PASS early;
//   * record-quality fractions (gap_fraction, invalid_fraction) and the
//     duration describe the record, not the unit: they neither decide nor
//     block a decision; they are judged on the record analysed when the run
//     ends (the duration against early_decision.min_duration_s).
// A measurement is decided FAIL when a limit is confirmed on its failing
// side, PASS when every limit is confirmed on its passing side. A unit is
// decided FAIL as soon as one measurement is, and PASS when every measurement
// that decides is. A decision is final. The error of a decided measurement
// (its truth on the failing side of a limit it was decided to pass, or the
// other way round) is one tail of one bound's test, so per unit it is at
// most the risk.
#ifndef IMUQUAL_ANALYZE_JUDGE_EARLY_DECISION_H_
#define IMUQUAL_ANALYZE_JUDGE_EARLY_DECISION_H_

#include <functional>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "analyze/judge/judge.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::judge {

// The Pocock-type spending function: alpha * ln(1 + (e - 1) f), f clamped
// to [0, 1].
double SpentAlpha(double fraction, double alpha);

// One-sided group-sequential boundaries z_k for looks at the increasing
// information fractions `fractions` (each in (0, 1]) spending `alpha` as
// SpentAlpha does. Errors: fractions not increasing or outside (0, 1],
// alpha outside (0, 0.5).
Result<std::vector<double>> SequentialBounds(std::span<const double> fractions, double alpha);

// The probability, for a Brownian statistic under the null, that some look
// crosses its boundary (the error actually spent by `bounds`), by the same
// recursive integration. For checks.
double CrossingProbability(std::span<const double> fractions, std::span<const double> bounds);

// The looks of a plan with early_decision: analysed device times, s.
struct LookSchedule {
  std::vector<double> times_s;
  std::vector<double> fractions;  // times_s / horizon_s
  double horizon_s = 0;
  double risk = 0;
};
// Empty (no looks) when the plan has no early_decision. At most kMaxLooks
// (a plan asking for more is refused by ValidatePlan; a plan that bypassed
// it, e.g. forged on the bus, gets the first kMaxLooks).
inline constexpr int kMaxLooks = 1000;
inline constexpr double kDefaultLookPeriodS = 60.0;  // early_decision.look_period_s unset
LookSchedule MakeLookSchedule(const pb::TestPlan& plan);

enum class Decision { kPending, kPass, kFail };
// "PENDING", "PASS", "FAIL".
const char* DecisionName(Decision d);

// What one measurement showed at one look: the evidence archived.
struct LookEntry {
  std::string axis;
  std::string name;
  double value = 0;
  double uncertainty = 0;  // NaN: none
  Decision decision = Decision::kPending;
  std::string why;  // the bound that decided it, or why it is still pending
};

struct Look {
  int index = 0;      // 0-based
  double time_s = 0;  // analysed device time
  double fraction = 0;
  double z = 0;  // the boundary of this look
  Decision unit = Decision::kPending;
  std::vector<LookEntry> entries;  // the measurements that decide, in order
  std::string note;                // why a unit whose limits are all decided still waits
};

// Whether the curve minimum of `axis` is settled (see above): asked only
// when a decision needs it, at most once per axis and look.
using SettledQuery = std::function<bool(const std::string& axis)>;
// Evidence read off the curve that the truth of a measurement lies above /
// below `bound`, as z (NaN: none; the value and uncertainty decide that
// direction), and where it came from (said in the evidence archived).
struct SideEvidence {
  double above = std::numeric_limits<double>::quiet_NaN();
  double below = std::numeric_limits<double>::quiet_NaN();
  std::string above_source;
  std::string below_source;
};
using BoundEvidence = std::function<SideEvidence(const pb::Measurement& m, double bound)>;

class EarlyDecider {
 public:
  // Errors: the plan has no early_decision (or an invalid one).
  static Result<EarlyDecider> Create(const pb::TestPlan& plan);

  // The look `index` of the schedule, on `measurements` judged against the
  // plan (limits set, as judge::Judge leaves them). Returns the look's
  // evidence; once the unit is decided further calls change nothing.
  Look Evaluate(int index, const std::vector<pb::Measurement>& measurements,
                const SettledQuery& settled, const BoundEvidence& evidence = nullptr);

  const LookSchedule& schedule() const { return schedule_; }
  Decision unit_decision() const { return unit_; }
  // The look that decided the unit (-1: none yet).
  int decided_look() const { return decided_look_; }
  double decided_time_s() const {
    return decided_look_ < 0 ? 0.0 : schedule_.times_s[decided_look_];
  }
  // Every look evaluated so far, in order.
  const std::vector<Look>& looks() const { return looks_; }
  // Each measurement's decision, keyed "axis/name" (kPending if none).
  Decision MeasurementDecision(const std::string& axis, const std::string& name) const;
  // Applies the decision to the final judgement of the record analysed up
  // to the deciding look: each decided measurement takes its decision as its
  // outcome with a note saying when and by which bound; returns the reasons.
  void ApplyTo(std::vector<pb::Measurement>* measurements) const;

  // What a MARGINAL flag on the record is: "MARGINAL flag read at the
  // decision (840 s); the full-length record may read it otherwise"
  // (FLAGS_AT_DECISION), "... settled to agree with the full-length record"
  // (FLAGS_AGREE_FULL_LENGTH), "... decided at the decision (840 s) at the
  // plan's risk" (FLAGS_DECIDED), or "MARGINAL flag read on the full-length
  // record" for a unit pending at every look. ApplyTo and JudgeDecided add
  // it to every MARGINAL measurement's note and reason.
  std::string FlagProvenance() const;

  // True for the measurements that decide (not record quality, duration or
  // temperature: properties of the record as analysed).
  static bool Decides(const pb::Measurement& m);

 private:
  explicit EarlyDecider(LookSchedule schedule) : schedule_(std::move(schedule)) {}

  LookSchedule schedule_;
  std::vector<double> bounds_;  // z per look, once the number of bounds is known
  double alpha_per_bound_ = 0;
  Decision unit_ = Decision::kPending;
  int decided_look_ = -1;
  std::vector<Look> looks_;
  struct Decided {
    std::string key;
    Decision decision;
    std::string why;
    int look;
    bool marginal = false;  // decided in the marginal band (FLAGS_DECIDED)
  };
  std::vector<Decided> decided_;
  pb::EarlyDecision::MarginalFlags flags_ = pb::EarlyDecision::FLAGS_AT_DECISION;
};

// The final judgement of a run with early decisions, on the record analysed
// (up to the deciding look when the unit was decided): judge::Judge with the
// duration judged against early_decision.min_duration_s when decided, then
// each decided measurement takes its decision as its outcome (note and reason
// say when and by which bound). Without a decision: judge::Judge unchanged.
Judgement JudgeDecided(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                       const EarlyDecider& decider, std::vector<pb::Measurement>* measurements);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_EARLY_DECISION_H_
