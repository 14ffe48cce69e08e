// Lot analytics on the command line: one lot's statistics, two lots side by
// side with significance, one unit's history, and run listings.
#ifndef IMUQUAL_CLI_LOT_COMMANDS_H_
#define IMUQUAL_CLI_LOT_COMMANDS_H_

#include <string>

#include "report/table_writer.h"
#include "store/query.h"

namespace imuqual::cli {

// imuqual lot LOT --stats: per axis and measurement n, mean, sd, min, max,
// yield and capability against the plan's limits (each unit's latest run);
// as a table, followed by the lot noise model of each axis and the units
// inconsistent with it (lot_model_view.h).
int LotStatsCommand(const std::string& db_path, const std::string& lot, report::Format format);

// imuqual lot LOT --model: the lot noise model of each axis (one row per
// axis), then, as a table, the units inconsistent with their lot.
int LotModelCommand(const std::string& db_path, const std::string& lot, report::Format format);

// imuqual compare LOT_A LOT_B: the statistics side by side; Welch's t-test on
// means, the F-test on spreads, Fisher's exact test on yields, significance
// by Holm's procedure at `alpha` over every test of the comparison. As a
// table, followed by both lots' noise models per axis.
int CompareCommand(const std::string& db_path, const std::string& lot_a, const std::string& lot_b,
                   double alpha, report::Format format);

// imuqual unit SERIAL: every run of the unit, across lots, per axis.
int UnitCommand(const std::string& db_path, const std::string& serial, report::Format format);

// imuqual runs: runs matching the filter, newest first. `since` is a date
// ("2026-11-21") or a time ("2026-11-21T08:00:00Z"), UTC; "" for all.
int RunsCommand(const std::string& db_path, store::RunFilter filter, const std::string& since,
                report::Format format);

// "2026-11-21" or "2026-11-21T08:00:00Z" (UTC) -> us since the epoch.
Result<int64_t> ParseUtcTime(const std::string& text);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_LOT_COMMANDS_H_
