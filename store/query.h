// Read-only queries over an archive for the imuqual CLI and reports. All
// parameters are bound, never spliced into SQL.
#ifndef IMUQUAL_STORE_QUERY_H_
#define IMUQUAL_STORE_QUERY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"
#include "imuqual/record.pb.h"
#include "store/archive.h"

namespace imuqual::store {

// What travels with a headline value (table measurements): its 1-sigma
// uncertainty (NaN: none), what kind of value it is, its outcome against its
// limit and the note (why it is not measurable, an upper bound, ...).
struct ValueMarks {
  double uncertainty = allan::kNaN;
  pb::Qualifier qualifier = pb::QUALIFIER_NONE;
  pb::Outcome outcome = pb::OUTCOME_UNSET;
  std::string note;
};

// One run and axis with its headline figures (view axis_results).
struct AxisRow {
  std::string lot, unit, run_id, state, axis, kind;
  int64_t start_utime = 0;
  double random_walk = allan::kNaN;  // ARW deg/sqrt(h) (gyro) or VRW m/s/sqrt(h) (accel)
  double bias_instability = allan::kNaN;       // curve minimum, deg/h or ug
  double bias_instability_ieee = allan::kNaN;  // minimum / 0.664
  double tau_min_s = allan::kNaN;
  double rate_random_walk = allan::kNaN;       // deg/h/sqrt(h) or ug/sqrt(h)
  int64_t samples = 0, gap_samples = 0, invalid_samples = 0;
  std::string axis_verdict;  // "" if not judged
  std::string run_verdict;
  int64_t run_key = 0;
  // The marks of each headline value above (measurements of this run and axis).
  ValueMarks random_walk_marks, bias_instability_marks, bias_instability_ieee_marks, tau_min_marks,
      rate_random_walk_marks;
  // Why the axis is not PASS: the run's reasons that name the axis
  // ("gx: bias_instability ..."), one per line; "" if none.
  std::string axis_notes;
  // Early decisions (the run's plan had early_decision and the run is
  // judged): its run-level decision_time, s of analysed device time, NaN
  // when the unit was pending at every look (a full soak).
  bool has_decision_time = false;
  double decision_time_s = allan::kNaN;
  // Who and where: the run's station, slot and operator ("" if not recorded).
  std::string station, slot, operator_name;
};

struct AxisRowFilter {
  std::string lot;              // required
  std::string run_prefix;       // "" = any; else run ids starting with it
  // Only each unit's final run in the lot (view final_runs: its latest
  // judged run, else its latest run).
  bool latest_per_unit = true;
};

Result<std::vector<AxisRow>> QueryAxisRows(Archive& archive, const AxisRowFilter& filter);

// One lot (view lot_overview): the units counted by their final run (the
// latest judged one, else the latest; store/SCHEMA.md, Yields).
struct LotRow {
  std::string lot;
  int64_t runs = 0, units = 0, pass = 0, marginal = 0, fail = 0, unjudged = 0;
  int64_t inconclusive = 0, aborted = 0, error = 0;
  // (pass + marginal) / (pass + marginal + fail) over the final runs; NaN
  // when no unit's final run is one of those.
  double yield = allan::kNaN;
  // The same over each unit's first judged run.
  double first_pass_yield = allan::kNaN;
  int64_t retests = 0;            // runs beyond each unit's first
  int64_t retest_candidates = 0;  // units whose final run is INCONCLUSIVE
  int64_t first_start_utime = 0, last_start_utime = 0;
};

// Every lot, newest first; `only`: that lot's row alone (none if absent).
Result<std::vector<LotRow>> QueryLots(Archive& archive,
                                      const std::optional<std::string>& only = std::nullopt);

// The runs of one unit (serial) across lots, oldest first, per axis.
Result<std::vector<AxisRow>> QueryUnitHistory(Archive& archive, const std::string& serial);

// One judged value of a lot's latest runs (long form, for statistics).
struct MeasurementRow {
  std::string unit, run_id, axis, kind, name, value_unit, note;
  double value = allan::kNaN;
  double uncertainty = allan::kNaN;
  std::optional<double> low, high, marginal_low, marginal_high;
  pb::Outcome outcome = pb::OUTCOME_UNSET;
  pb::Qualifier qualifier = pb::QUALIFIER_NONE;
  std::string uncertainty_method;
  pb::Limit::DecisionRule decision_rule = pb::Limit::RULE_DEFAULT;  // none applied
  double guard_band = allan::kNaN;
};
// Every measurement of each unit's final run in `lot` when that run is
// judged (view lot_measurements): ABORTED, ERROR and unjudged runs' partial
// values say nothing about the lot.
Result<std::vector<MeasurementRow>> QueryLotMeasurements(Archive& archive, const std::string& lot);

// A run's identity and outcome (table runs).
struct RunRow {
  std::string run_id, unit, lot, station, slot, state, verdict, reasons, operator_name;
  int64_t start_utime = 0;
};
struct RunFilter {
  std::string lot, station, unit;  // "" = any
  std::string unit_prefix;         // "" = any; else serials starting with it
  int64_t since_utime = 0;         // runs started at or after
  std::string verdict;             // an outcome's text (store/outcome.h), "none" (not judged) or "" = any
  int64_t limit = 1000;
};
Result<std::vector<RunRow>> QueryRuns(Archive& archive, const RunFilter& filter);

// A run followed by a later run of the same unit in its lot (view
// retest_reasons): why the unit was tested again.
struct RetestRow {
  std::string unit, run_id, state, verdict, reasons, next_run_id;
};
Result<std::vector<RetestRow>> QueryRetestReasons(Archive& archive, const std::string& lot);

// Run reasons (FAIL/MARGINAL explanations) by run id, for the runs given.
Result<std::vector<std::pair<std::string, std::string>>> QueryReasons(
    Archive& archive, const std::vector<std::string>& run_ids);

// One judged run with its run-level decision_time measurement (early
// decisions): the runs of `lot` whose verdict is PASS, MARGINAL, FAIL or
// INCONCLUSIVE and whose id starts with `run_prefix` ("" = any), oldest
// first, each with its archived plan (serialized pb::TestPlan).
struct DecisionTimeRow {
  std::string unit, run_id, verdict, plan, note;
  int64_t start_utime = 0;
  double decision_time_s = allan::kNaN;  // NaN: pending at every look
};
Result<std::vector<DecisionTimeRow>> QueryDecisionTimes(Archive& archive, const std::string& lot,
                                                        const std::string& run_prefix);

// Where a run stands now, for the station's summary of runs an earlier
// station process left open. Absent runs are left out.
struct RunStatusRow {
  std::string run_id, state, verdict, reasons;  // verdict "" when not judged
  bool finalized = false;
};
Result<std::vector<RunStatusRow>> QueryRunStatus(Archive& archive,
                                                 const std::vector<std::string>& run_ids);

// The runs of `station` not finalized yet (a station process that stopped
// mid-soak left them open), by run id.
Result<std::vector<std::string>> QueryOpenRunIds(Archive& archive, const std::string& station);

// What changes whenever anything a lot report shows changes: the lot's run
// count, newest run key, result and finalisation times and verdicts. ""
// while a run of the lot is still open (nothing to cache) or the lot has no
// run. A cache key, not a checksum.
Result<std::string> QueryLotFingerprint(Archive& archive, const std::string& lot);

// Every value of every judged run (PASS, MARGINAL, FAIL, INCONCLUSIVE) of
// `lot`, retests and every station included, with the run's station and
// operator: what a measurement system analysis of golden units reads.
// Ordered by serial, station, start.
struct RunValueRow {
  std::string lot, unit, station, operator_name, run_id, axis, name, value_unit;
  std::string plan_sha256;  // the plan the run was judged by
  int64_t start_utime = 0;
  double value = allan::kNaN;
  std::optional<double> low, high;
};
Result<std::vector<RunValueRow>> QueryRunValues(Archive& archive, const std::string& lot);

// One judged measurement over the whole archive: its value on each unit's
// final run in each lot (view lot_measurements: judged runs only, a retested
// unit once), with the run's station, oldest first. For control charts
// across lots, weeks and months. `axis` "" = run-level values.
Result<std::vector<RunValueRow>> QueryMeasurementHistory(Archive& archive, const std::string& name,
                                                         const std::string& axis);

// The serialized test plan (pb::TestPlan) of the runs whose plan has this
// digest; NotFound when no run has it.
Result<std::string> QueryPlanByDigest(Archive& archive, const std::string& plan_sha256);

// Every run's identity, start and verdict ("" not judged), oldest first:
// what yield trends per week, month, station or lot count.
struct RunVerdictRow {
  std::string run_id, lot, unit, station, verdict;
  int64_t start_utime = 0;
};
Result<std::vector<RunVerdictRow>> QueryRunVerdicts(Archive& archive);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_QUERY_H_
