// Verdicts: applies a plan's limits to measured values (OpenHTF-style
// measurements: name, value, unit, limits, outcome) and derives the run's
// verdict with human-readable reasons. Pure.
#ifndef IMUQUAL_ANALYZE_JUDGE_JUDGE_H_
#define IMUQUAL_ANALYZE_JUDGE_JUDGE_H_

#include <string>
#include <vector>

#include "imuqual/plan.pb.h"
#include "imuqual/record.pb.h"

namespace imuqual::judge {

struct AxisDesc {
  std::string name;
  pb::AxisKind kind = pb::GYRO;
};

struct Judgement {
  pb::Outcome verdict = pb::OUTCOME_UNSET;  // UNSET: nothing was judged
  std::vector<std::string> reasons;  // one per FAIL / INCONCLUSIVE / MARGINAL, in measurement order
};

// guard_k when neither the limit nor the plan sets one: w = 2 u.
inline constexpr double kDefaultGuardK = 2.0;

// Simple acceptance: PASS inside [low, high] and inside the marginal band,
// MARGINAL inside [low, high] but outside [marginal_low, marginal_high], FAIL
// outside [low, high] or when the value is NaN (not measured).
pb::Outcome Evaluate(const pb::Limit& limit, double value);

// The decision rule a limit applies: its own, else the plan's
// default_decision_rule, else SIMPLE (never RULE_DEFAULT).
pb::Limit::DecisionRule ResolvedRule(const pb::TestPlan& plan, const pb::Limit& limit);
// Its guard_k: its own, else the plan's default_guard_k, else kDefaultGuardK.
double ResolvedGuardK(const pb::TestPlan& plan, const pb::Limit& limit);

// Whether `m` is guarded on the log scale: tau_at_minimum, whose u is
// tau x u(ln tau) (measure.cc), is judged as ln tau against ln bound with
// the band w / tau = guard_k u(ln tau), i.e. over [tau / f, tau f] with
// f = exp(w / tau): wider above than below, as its spread is.
bool GuardedOnLogScale(const pb::Measurement& m);

// How many of its uncertainties `m`'s value lies above `bound` on the scale
// it is guarded on (negative: below); NaN without a positive uncertainty.
double SigmasAbove(const pb::Measurement& m, double bound);

// Judges one measurement against `limit` of `plan` (ISO 14253-1 /
// JCGM 106:2012 decision rules), at each of low and high, with the guard
// band w = guard_k * u (u: the measurement's 1-sigma uncertainty):
//   SIMPLE              FAIL outside [low, high] (limits inclusive).
//   GUARDED             INCONCLUSIVE while |value - bound| < w; else simple.
//   GUARDED_ACCEPTANCE  FAIL outside; INCONCLUSIVE inside by less than w;
//                       passes the bound only at least w inside.
//   GUARDED_REJECTION   FAIL only at least w outside; INCONCLUSIVE outside by
//                       less than w; inside: passes the bound.
// Marginal limits are always simple (MARGINAL when no bound says FAIL or
// INCONCLUSIVE). A guarded rule on a value without a finite uncertainty is
// applied as SIMPLE, recorded so, and the note says "no uncertainty: simple
// acceptance". A value qualified UPPER_BOUND (the truth lies at or below it)
// passes a high bound it does not exceed whatever the rule; above it, it is
// INCONCLUSIVE under a guarded rule ("only an upper bound") and FAIL under
// SIMPLE; below a low bound it FAILs, above one it is INCONCLUSIVE under a
// guarded rule (nothing shows the truth is above). NaN values FAIL (not
// measured), or, withheld for an inadequate noise model (model_inadequate),
// as the plan's on_inadequate_model says. Sets the limits, outcome,
// decision_rule (as applied) and guard_band (only when w > 0 was used);
// `reason` gets why the outcome is not PASS ("" for PASS).
void JudgeMeasurement(const pb::TestPlan& plan, const pb::Limit& limit, pb::Measurement* m,
                      std::string* reason);

// The limit of `plan` that applies to measurement `name` on an axis (or run
// level when axis is nullptr): an axis-specific limit beats an axis-kind
// limit, which beats one for every kind. nullptr if none.
const pb::Limit* FindLimit(const pb::TestPlan& plan, const std::string& name, const AxisDesc* axis);

// Fills limits and outcome of every measurement from the plan, adds a FAIL
// "not measured" entry for each limit with no measurement, applies the
// plan's min_duration_s to the "duration" measurement when no explicit limit
// exists, judges a value withheld because its noise model is inadequate
// (model_inadequate, NaN) as the plan's on_inadequate_model says (MARGINAL by
// default) with the note as its reason, applies each limit's decision rule
// (JudgeMeasurement), and returns the verdict: FAIL if any FAIL, else
// INCONCLUSIVE if any INCONCLUSIVE, else MARGINAL if any MARGINAL, else PASS
// (UNSET if no measurement had a limit). Unjudged measurements get
// OUTCOME_UNSET and decision_rule RULE_DEFAULT.
Judgement Judge(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                std::vector<pb::Measurement>* measurements);

// An interim look at a run still soaking (the plan already stripped of what
// only the full record judges): Judge, then every judged value that more
// data can still move to the other side of a bound reads INCONCLUSIVE, with
// a reason "pending: ..." (the console and the live page show it as
// "pending", never a "fail?" that a longer record turns into a pass):
//   - a value whose distance to a low or high bound is below guard_k * u
//     (its resolved guard_k, whatever the limit's rule: the final judgement
//     applies the rule; an interim one only says what is not settled);
//   - a curve minimum not resolved yet (MINIMUM_NOT_RESOLVED: the curve's
//     lowest point is its last so far, the noisiest) that does not pass.
// Everything else keeps its outcome and reason.
Judgement JudgeInterim(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                       std::vector<pb::Measurement>* measurements);

// The verdict of judged measurements: FAIL if any FAILs, else INCONCLUSIVE if
// any is, else MARGINAL if any is, else PASS; UNSET when none was judged
// (every outcome OUTCOME_UNSET).
pb::Outcome VerdictOf(const std::vector<pb::Measurement>& measurements);

// "PASS", "MARGINAL", "FAIL", "INCONCLUSIVE", "ABORTED", "ERROR", "-".
const char* OutcomeName(pb::Outcome outcome);

// The disposition a verdict gives the unit: accepted (PASS or MARGINAL, a
// flag) or not (FAIL; INCONCLUSIVE and the rest are no acceptance either).
inline bool Accepted(pb::Outcome outcome) { return outcome == pb::PASS || outcome == pb::MARGINAL; }

// "simple", "guarded", "guarded acceptance", "guarded rejection", "default".
const char* DecisionRuleName(pb::Limit::DecisionRule rule);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_JUDGE_H_
