// The imuqual subcommands. Each returns the process exit code and prints
// its own one-line error on failure.
#ifndef IMUQUAL_CLI_COMMANDS_H_
#define IMUQUAL_CLI_COMMANDS_H_

#include <string>

#include "report/table_writer.h"
#include "station/station_runner.h"

namespace imuqual::store {
class Archive;
}  // namespace imuqual::store

namespace imuqual::cli {

// Exit codes of `imuqual run` (README "Exit codes", `imuqual run --help`).
// A unit that FAILs its plan is a result, not an error: the station still
// exits 0, unless --fail-exit asks for kRunExitUnitsFailed.
inline constexpr int kRunExitOk = 0;                 // every run ended normally and was judged
inline constexpr int kRunExitError = 1;              // the station failed (process, archive, stall)
inline constexpr int kRunExitUsage = 2;              // bad options, station file, plan, source
                                                     // or archive file: nothing was run
inline constexpr int kRunExitSourceFailed = 3;       // a unit's source failed (bad data, device
                                                     // gone): its run archived as ERROR; every
                                                     // other unit finished, judged and archived
inline constexpr int kRunExitArchiveUnwritable = 4;  // the archive could not be written (a
                                                     // full disk): what was acknowledged is
                                                     // archived, the runs are not finished
inline constexpr int kRunExitUnitsFailed = 5;    // --fail-exit: the station ended normally and a
                                                 // unit was judged FAIL or INCONCLUSIVE
inline constexpr int kRunExitInterrupted = 130;  // Ctrl-C: runs aborted, archived and judged
inline constexpr char kRunExitCodesHelp[] =
    "Exit codes: 0 every run ended normally and was judged (a FAIL verdict is a result); "
    "1 the station failed (a process, the archive, no progress); 2 bad options, station "
    "file, plan, source or archive file (nothing was run); 3 a unit's source failed (bad "
    "data, a device gone): its run is archived as ERROR with the reason, every other unit "
    "finished and was judged and archived; 4 the archive could not be written (a full disk) "
    "for --archive-timeout: everything acknowledged is archived, the runs are not finished; "
    "5 (only with --fail-exit) the station ended normally and a unit was judged FAIL or "
    "INCONCLUSIVE; 130 interrupted (Ctrl-C, a hang-up, SIGTERM): the runs were aborted, "
    "archived and judged.";

// A lot's counts by final run, first-pass and final yield, retests and
// retest candidates, and why units were tested again: lines under `imuqual
// lot` and `imuqual lot --stats`; "" for an unknown lot.
std::string LotYieldLines(store::Archive& archive, const std::string& lot);

// imuqual run: a station end to end, then the result table. Returns one of
// the kRunExit* codes.
int RunCommand(const station::StationRunOptions& options);

// imuqual lots: every lot in the archive with counts and yield.
int LotsCommand(const std::string& db_path, report::Format format);

// imuqual lot LOT: per unit and axis results of a lot (each unit's latest
// run unless all_runs).
int LotCommand(const std::string& db_path, const std::string& lot, report::Format format,
               bool all_runs);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_COMMANDS_H_
