// What `imuqual run` shows while a soak runs: a snapshot of the station
// (filled from the bus by the station runner) and its rendering as screen
// lines. Pure: no I/O, so what an operator sees can be tested as text.
//
// On a terminal the screen holds, top to bottom: the station header, the
// progress bar (elapsed vs planned over every unit, wall time, estimated
// time left), the processes (up, restarts), one row per unit and axis
// (slot, unit, the unit's verdict and its first reason, state,
// elapsed/planned, axis, the axis's verdict, the live bias-instability
// estimate of the streaming engine, samples, gap samples, the axis's
// invalid samples; provisional
// verdicts are lower case with a '?', final ones upper case) and a notice
// line. When the rows do not fit the screen, one row per unit with the axes
// side by side, the units needing attention first, a legend for the marks,
// and when even those do not fit, a count of the rest.
//
// A unit whose plan has early decisions shows no provisional verdict that a
// look may overturn: until it is decided its verdict reads "PENDING look
// k/K" and each axis "pending" (a measurement of it still pending at the
// last look) or "pass" (every one decided); once decided, "decided PASS at
// 14m" (analysed device time) and its slot "slot free" (the run ends there:
// the unit can come out); its final verdict in capitals once judged.
#ifndef IMUQUAL_STATION_STATION_CONSOLE_H_
#define IMUQUAL_STATION_STATION_CONSOLE_H_

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace imuqual::station {

struct ConsoleAxis {
  std::string name;
  double bias_instability = std::numeric_limits<double>::quiet_NaN();  // live estimate
  std::string unit;  // of bias_instability, e.g. "deg/h"
  // Its marks as measurement_t gives them: 1-sigma uncertainty (NaN: none)
  // and qualifier (measurement_t.QUALIFIER_*): shown "10.2 ± 0.8", "≤ 10.2",
  // "10.2†" (minimum not resolved), "10.2‡" (inadequate model), "n/m".
  double bias_instability_uncertainty = std::numeric_limits<double>::quiet_NaN();
  int8_t bias_instability_qualifier = 0;
  // The worst measurement outcome of the axis (measurement_t.OUTCOME_*;
  // FAIL > INCONCLUSIVE > MARGINAL > PASS, store::OutcomeSeverity).
  int8_t outcome = 0;
  // The plan's limits on the axis's bias_instability (the curve minimum, in
  // `unit`'s datasheet unit: deg/h, ug), NaN where the plan has none: the
  // live page draws them on the axis's curve.
  double limit_high = std::numeric_limits<double>::quiet_NaN();
  double marginal_high = std::numeric_limits<double>::quiet_NaN();
  // Samples of this axis after the warm-up read as invalid so far (NaN,
  // inf, an empty or non-numeric cell, a sample its source flagged, one out
  // of the plan's sensor_range): judged by a plan's invalid_fraction, shown
  // so that an operator sees them as they come.
  int64_t invalid_samples = 0;
};

struct ConsoleUnit {
  std::string slot, serial, run_id;  // run_id "" until the run is announced
  double elapsed_s = 0;              // device time published
  double planned_s = 0;              // device time announced as planned (0: not known)
  int64_t samples = 0;               // samples published per axis
  int64_t gap_samples = 0;           // samples the analysis found missing
  int8_t state = 0;                  // run_t.STATE_* (0: not announced yet)
  bool archived = false;             // the store has committed the whole run
  bool final_result = false;         // the verdict is final
  int8_t verdict = 0;                // measurement_t.OUTCOME_*
  std::vector<ConsoleAxis> axes;
  // Early decisions (its plan's early_decision; looks_planned 0 without):
  // the looks done so far, the unit's decision (decision_t.STATE_*; 0
  // before the first look), when it was decided (s of analysed device
  // time), and what is still pending at the last look ("axis: name: why").
  int looks_planned = 0;
  int looks_done = 0;
  int8_t decision = 0;
  double decided_at_s = 0;
  std::vector<std::string> pending;
  // Why the verdict is not PASS (the judgement's first reason), "" if none.
  std::string reason;
  // Wall seconds since the unit's published samples last grew (0: they just
  // did, or the unit is not paced by its device); a running unit silent
  // kConsoleSilentS or more shows "no data M:SS".
  double silent_s = 0;
  // Its serial device is gone (or was just reopened) and acquire is
  // reconnecting: shown "reconnecting M:SS" (M:SS silent) instead of "no data".
  bool reconnecting = false;
  // Its run ended because its source failed (not the operator's stop).
  bool source_failed = false;
};

struct ConsoleProcess {
  std::string name;  // "store", "analyze", "acquire"
  int running = 0;   // processes of this kind alive
  int expected = 1;
  int restarts = 0;
  std::string problem;  // last unhealthy message, "" when healthy
  // Messages its bus refused: forged (no or a wrong MAC, a role that may not
  // say it, a missing or wrong signature) and replayed (README, "Trust").
  int64_t unauthenticated = 0, replayed = 0;
};

struct ConsoleModel {
  std::string station, lot, plan, operator_name, bus, archive;
  double planned_s = 0;  // per unit; 0: unknown (recordings run to their end)
  double wall_s = 0;     // since the soak started
  std::vector<ConsoleUnit> units;
  std::vector<ConsoleProcess> processes;
  std::string notice;  // e.g. "interrupted: aborting the runs"
};

// A unit's planned device time: its own announced one, else the station's
// (0: not known).
double UnitPlannedS(const ConsoleModel& model, const ConsoleUnit& unit);

// Fraction of the soak done, 0..1: device time over planned time of every
// unit (archived runs and decided units count as done), or archived runs
// when unplanned.
double ConsoleProgress(const ConsoleModel& model);

// A running unit whose samples stopped this long shows "no data M:SS".
inline constexpr double kConsoleSilentS = 5.0;

// The screen, one string per line, each at most `width` columns, at most
// `height` lines. Each row starts with what an operator acts on: slot,
// unit, verdict and a short reason, then the state and the numbers (a
// narrow terminal cuts numbers, never the verdict); a legend explains the
// marks. `color`: verdicts and states in colour and bold (ANSI; the caller
// decides: a terminal, and NO_COLOR not set).
std::vector<std::string> RenderConsole(const ConsoleModel& model, int width, int height,
                                       bool color = false);

// The final verdicts so far, e.g. "final: 3 PASS, 0 MARGINAL, 1 FAIL, 1
// ABORTED; yield 75% of 4 judged units" (the yield over PASS, MARGINAL and
// FAIL units only); "" while no run has its final result.
std::string ConsoleTally(const ConsoleModel& model);

// One line for a log or a pipe (no terminal): progress, samples, runs archived.
std::string ConsoleSummaryLine(const ConsoleModel& model);

// A unit's cells as the console shows them (the same words on the live web
// page): verdict ("pass?", "FAIL", "PENDING look 2/4"), short reason, state
// ("running", "no data 0:07", "done"), elapsed / planned, and per axis its
// verdict and live bias instability with marks and unit ("-" when none).
struct ConsoleAxisCells {
  std::string name, verdict, bias_instability;
  int64_t invalid_samples = 0;
  double limit_high = std::numeric_limits<double>::quiet_NaN();
  double marginal_high = std::numeric_limits<double>::quiet_NaN();
};
struct ConsoleUnitCells {
  std::string verdict, reason, state, elapsed;
  // FAIL > ERROR > ABORTED > INCONCLUSIVE > MARGINAL > the rest: a silent
  // unit or a failed source ranks as ERROR (store::AttentionRank).
  int attention = 0;
  std::vector<ConsoleAxisCells> axes;
};
ConsoleUnitCells DescribeUnit(const ConsoleModel& model, const ConsoleUnit& unit,
                              size_t reason_width = 200);

// The process line: "store 1/1 (1 restart)  analyze 2/2  acquire 1/1"; a
// process whose bus refused messages says how many: "store up (refused 4
// unauthenticated, 2 replayed)".
std::string ConsoleProcessesLine(const ConsoleModel& model);

// "1:02:03" (h:mm:ss) or "2:03" (m:ss).
std::string FormatDuration(double seconds);

}  // namespace imuqual::station

#endif  // IMUQUAL_STATION_STATION_CONSOLE_H_
