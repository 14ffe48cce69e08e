// Early decisions as the archive holds them: the run-level decision_time
// measurement of every judged run whose plan had early_decision (analysed
// device time of the deciding look, s; NaN with the note "pending at every
// one of N looks" for a unit that soaked its full length), and the soak
// time they saved a lot. For `imuqual lot`, the station's table and the
// report. Read-only; bound parameters only.
#ifndef IMUQUAL_REPORT_EARLY_DECISIONS_H_
#define IMUQUAL_REPORT_EARLY_DECISIONS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "analyze/judge/early_decision.h"
#include "common/status.h"
#include "report/table_writer.h"
#include "store/archive.h"

namespace imuqual::report {

struct DecidedRun {
  std::string unit, run_id, verdict;
  int64_t start_utime = 0;
  double decision_time_s = allan::kNaN;  // NaN: pending at every look (a full soak)
  double horizon_s = 0;  // the full-length soak the decisions were spread over (s analysed)
  std::string note;      // the decision_time measurement's note
};

struct EarlyDecisionSummary {
  // Every run of the lot judged on its unit (PASS, MARGINAL, FAIL,
  // INCONCLUSIVE; retests included: they took station time too) with early
  // decisions, oldest first. Empty: the lot did not use them.
  std::vector<DecidedRun> runs;
  int decided = 0;             // runs decided before their horizon
  double horizon_total_s = 0;  // the soak time without early decisions: sum of horizons
  // Sum over the runs of horizon - decision time (a full soak saves none), s.
  double saved_s = 0;
  // The median over the runs of decision time / horizon (a full soak: 1).
  double median_ratio = allan::kNaN;
};

// The runs of `lot` (whose run id starts with `run_prefix`, if given: one
// station run's).
Result<EarlyDecisionSummary> QueryEarlyDecisions(store::Archive& archive, const std::string& lot,
                                                 const std::string& run_prefix = "");

// When a unit was decided, for tables and the console: "45s", "2m40s",
// "14m", "1h05m" (rounded to the second, hours to the minute); "full soak"
// for NaN (pending at every look).
std::string DecisionTimeText(double seconds);

// The lot's line under `imuqual lot`, e.g. "early decisions: 2 of 3 runs
// decided; soak time saved 780 s (13m) of 1800 s (43 %); median decided /
// full soak 0.43"; "" when no run of the lot used early decisions.
std::string EarlyDecisionLine(const EarlyDecisionSummary& summary);

// Every look of a run's early decisions, one row per look and judged
// measurement (look, analysed time, boundary z, axis, measurement, value,
// uncertainty, decision, why), then per look a unit row (axis "*", the
// unit's decision and, for a unit whose limits are decided but whose
// marginal flags are not, why it still waits). For `imuqual reanalyze
// --looks`: the archive keeps the raw samples and the deciding evidence
// (each decided measurement's note, decision_time); every look is
// recomputed from the samples by the same analysis (`reanalyze --check`
// proves that analysis reproduces the archived measurements, notes and
// verdict bit for bit; the looks themselves are not archived).
TableWriter LooksTable(const std::vector<judge::Look>& looks);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_EARLY_DECISIONS_H_
