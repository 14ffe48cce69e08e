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
  std::vector<std::string> reasons;         // one per FAIL / MARGINAL, in measurement order
};

// PASS inside [low, high] and inside the marginal band, MARGINAL inside
// [low, high] but outside [marginal_low, marginal_high], FAIL outside
// [low, high] or when the value is NaN (not measured).
pb::Outcome Evaluate(const pb::Limit& limit, double value);

// The limit of `plan` that applies to measurement `name` on an axis (or run
// level when axis is nullptr): an axis-specific limit beats an axis-kind
// limit, which beats one for every kind. nullptr if none.
const pb::Limit* FindLimit(const pb::TestPlan& plan, const std::string& name, const AxisDesc* axis);

// Fills limits and outcome of every measurement from the plan, adds a FAIL
// "not measured" entry for each limit with no measurement, applies the
// plan's min_duration_s to the "duration" measurement when no explicit limit
// exists, judges a value withheld because its noise model is inadequate
// (model_inadequate, NaN) as the plan's on_inadequate_model says (MARGINAL by
// default) with the note as its reason, and returns the verdict: FAIL if any FAIL, else MARGINAL if any
// MARGINAL, else PASS (UNSET if no measurement had a limit).
Judgement Judge(const pb::TestPlan& plan, const std::vector<AxisDesc>& axes,
                std::vector<pb::Measurement>* measurements);

// "PASS", "MARGINAL", "FAIL", "-".
const char* OutcomeName(pb::Outcome outcome);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_JUDGE_H_
