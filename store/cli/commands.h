// The imuqual subcommands. Each returns the process exit code and prints
// its own one-line error on failure.
#ifndef IMUQUAL_STORE_CLI_COMMANDS_H_
#define IMUQUAL_STORE_CLI_COMMANDS_H_

#include <string>

#include "store/cli/station_runner.h"
#include "store/cli/table_writer.h"

namespace imuqual::cli {

// imuqual run: a simulated station end to end, then the result table.
int RunCommand(const StationRunOptions& options);

// imuqual lots: every lot in the archive with counts and yield.
int LotsCommand(const std::string& db_path, Format format);

// imuqual lot LOT: per unit and axis results of a lot (each unit's latest
// run unless all_runs).
int LotCommand(const std::string& db_path, const std::string& lot, Format format, bool all_runs);

}  // namespace imuqual::cli

#endif  // IMUQUAL_STORE_CLI_COMMANDS_H_
