// Test plans: parsing protobuf text format and validating it once, up front,
// with errors that name the source line and the field
// ("vg.textproto:14: limits[1].unit: 'deg/hr' is not the unit of
// bias_instability on gyro axes (deg/h)"). Pure: takes text, not files.
#ifndef IMUQUAL_ANALYZE_JUDGE_PLAN_H_
#define IMUQUAL_ANALYZE_JUDGE_PLAN_H_

#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::judge {

// Parses and validates a plan. `source_name` prefixes every error (a file
// name, or "builtin:vg700ca").
Result<pb::TestPlan> ParsePlanText(std::string_view text, std::string_view source_name);

// Checks a plan that did not come from text (e.g. decoded from run_t): every
// field's range, limits against the measurement catalogue and the plan's
// axes. The error names the field.
Status ValidatePlan(const pb::TestPlan& plan);

// The plan's noise-model range for an axis kind: its own, else the one for
// every kind, else nullptr (every point is fitted).
const pb::NoiseModelRange* NoiseModelRangeFor(const pb::TestPlan& plan, pb::AxisKind kind);

// The magnitude at which a sample of an axis of `kind` is out of the
// sensor's range (plan sensor_range), in the samples' unit (deg/s, m/s^2);
// +infinity when the plan gives no range for the kind.
double OutOfRangeAt(const pb::TestPlan& plan, pb::AxisKind kind);
// Whether a sample (float32, as batches and the archive hold it) is out of
// range at `at` (OutOfRangeAt): compared in float, so that a sample pinned
// at full scale counts whatever the rounding of full_scale x g.
inline bool OutOfRange(float sample, double at) {
  return std::fabs(sample) >= static_cast<float>(at);
}

// Built-in plans (the files in plans/, compiled in): "vg700ca", "tactical",
// "fog". The default plan of `imuqual run` is "vg700ca".
std::vector<std::string> BuiltinPlanNames();
Result<pb::TestPlan> BuiltinPlan(std::string_view name);

// The plan a run carries: `plan` completed where it is silent from the
// unit's source (its nominal rate and axes), as acquire announces it.
pb::TestPlan CompletedPlan(const pb::TestPlan& plan, double source_rate_hz,
                           const std::vector<pb::Axis>& source_axes);

// Whether `announced` is `accepted` completed where `accepted` is silent
// (CompletedPlan with the announced rate and axes): the plan a station that
// accepts `accepted` may analyse and archive.
bool IsCompletionOf(const pb::TestPlan& announced, const pb::TestPlan& accepted);

// The stop rule named by the plan ("" means the default, bins9).
std::string_view PlanStopRule(const pb::TestPlan& plan);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_PLAN_H_
