// `imuqual run`: a whole station on one host. Starts imuqual-store and one
// or more imuqual-analyze shards, waits until they report on the bus, starts
// imuqual-acquire, supervises them (a store or analyze process that dies is
// restarted and catches up from the source's retention and the archive),
// shows the soak live (station_console.h) on a terminal, follows the runs to
// the end (every run archived with its final result), stops the processes
// cleanly and reports. Ctrl-C aborts the runs: what was measured is archived
// and judged. Its own LCM URL (a unique port, ttl=0) keeps it off every
// other station. Unless paced, nothing waits for the wall clock: a 2-hour
// simulated soak runs as fast as the processes acknowledge each other.
#ifndef IMUQUAL_STATION_STATION_RUNNER_H_
#define IMUQUAL_STATION_STATION_RUNNER_H_

#include <optional>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::station {

struct StationRunOptions {
  int sim_units = 0;               // simulated units
  std::vector<std::string> units;  // more units as SERIAL=SOURCE (csv:FILE,..., sim:PROFILE,...)
  std::vector<std::string> slots;  // fixture positions of `units`, in order ("" = numbered)
  // Where each of `units` was configured, "FILE:LINE" of its slot in a
  // station file (empty, or "" for one: the command line); pre-flight
  // problems are located there.
  std::vector<std::string> unit_locations;
  // Pre-flight (preflight.h): run without the units whose source cannot be
  // opened (each named on stderr and in the result) rather than stop.
  bool skip_failed_slots = false;
  // Pre-flight: a soak shorter than the plan's warm-up + minimum duration is
  // run anyway (its runs FAIL as too short) instead of being refused.
  bool short_soak = false;
  // --fail-exit: exit kRunExitUnitsFailed when a unit is judged FAIL or
  // INCONCLUSIVE (and the station itself ended normally).
  bool fail_exit = false;
  std::string profile = "vg700";  // simulated lot profile
  double duration_s = 0;          // simulated seconds per unit
  std::optional<double> rate_hz;  // Hz, > 0; none: the profile's rate
  std::string lot;
  std::string db_path;
  std::string plan_spec;  // file or builtin:NAME; "" = the profile's default
  std::string lcm_url;    // "" = a fresh port on 239.255.76.67, ttl=0
  std::string station = "station-1";
  int analyze_shards = 1;   // analyze processes splitting the units
  std::string report_path;  // HTML report at the end; "" = <db without .db>-<lot>.html
  std::string operator_name;
  double inject_drop = 0;         // fault injection in acquire
  double pace = 0;                // 0: as fast as acknowledged; 1: real time; k: k x real time
  double stale_after_s = 10;      // store: acquire silent this long ends its runs as incomplete
  double stall_timeout_s = 120;   // no progress this long: give up
  double archive_timeout_s = 90;  // store: the archive failing every write this long ends the
                                  // station (IoError, exit 4); below acquire's 120 s ack timeout
  double give_up_s = 30;          // store: a batch that never arrived is a gap after this
  bool show_progress = true;      // live console on a terminal, else a progress line (stderr)
  int max_restarts = 5;           // a store/analyze process dying more often in a minute: give up
  // Trust (common/bus_seal.h): the station key and the roles' public keys
  // go to every process, each role's signing key to its own process only.
  std::string key_file;    // "" = no station key (this host only, ttl=0, or insecure_bus)
  std::string trust_file;  // "" = roles not signed
  std::string acquire_sign_key, analyze_sign_key, store_sign_key;
  bool insecure_bus = false;  // a bus beyond this host without a key, by choice
  std::string sync_to;        // the plant archive the store ships to ("" = none)
  Status Validate() const;
};

struct StationRunResult {
  std::string run_prefix;  // every run id of this station run starts with it
  std::vector<std::string> run_ids;
  std::string log_path;      // the processes' output
  bool interrupted = false;  // Ctrl-C: runs were aborted
  std::string failure;       // the source failed; runs were archived as they ended
  int restarts = 0;          // store/analyze processes restarted
  // Runs of this station an earlier station process left open (a crash),
  // found when the archive was opened: judged (ERROR) during this run.
  std::vector<std::string> left_open;
  // Units left out by --skip-failed-slots, one line each: slot, unit, why.
  std::vector<std::string> skipped;
};

Result<StationRunResult> RunStation(const StationRunOptions& options);

}  // namespace imuqual::station

#endif  // IMUQUAL_STATION_STATION_RUNNER_H_
