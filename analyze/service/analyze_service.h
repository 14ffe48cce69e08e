// The analyze process: learns runs from run_t heartbeats, takes each run's
// batches (its shard of the units), puts them in seq order (holding the
// out-of-order ones, requesting resends of holes, giving a hole up as a gap
// after a deadline), feeds a RunAnalyzer per run, acknowledges progress for
// flow control, publishes interim curves and provisional verdicts while the
// run goes on and the final curves and unit_result_t when it ends. A run
// whose plan has early_decision gets its decision_t after every look, at
// once when its unit is decided, and the decided state again every
// interim period until the run ends (acquire stops a decided unit's
// source on it; a lost message must not leave the unit soaking). The
// batches that arrive after the decision are acknowledged and counted, not
// analysed.
//
// Threading: the bus thread's handlers only decode, filter by shard and
// enqueue into a bounded queue (drops counted); one worker thread does the
// analysis and publishes. Shutdown drains the queue, then joins.
#ifndef IMUQUAL_ANALYZE_SERVICE_ANALYZE_SERVICE_H_
#define IMUQUAL_ANALYZE_SERVICE_ANALYZE_SERVICE_H_

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/bus_seal.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::analyze {

struct AnalyzeOptions {
  std::string lcm_url;
  BusSecurity security;             // keys and choices on the bus (role: analyze)
  int shard_index = 0;              // this process takes units whose serial hashes to
  int shard_count = 1;              //   shard_index modulo shard_count
  int density = 8;                  // streaming engine: averaging factors per octave
  double interim_period_s = 2.0;    // wall seconds between interim publications per run
  // At most this many runs' interim publications (6 curves and a result,
  // each signed with role keys) a second: with more active runs each run's
  // period grows (64 runs: 4 s), so the bus and every listener's signature
  // checks stay bounded however many units soak.
  double interim_runs_per_s = 16.0;
  int queue_capacity = 50000;       // batches waiting for the worker
  double hole_give_up_s = 30.0;     // a missing batch not resent by then is a gap
  double stale_after_s = 15.0;      // a running run not announced this long is incomplete
  // The station whose runs this process analyses (run_t.station); other
  // stations' runs on the same bus are ignored and counted. "": every run.
  std::string station;
  // The plans this station runs (their files; a run carries one completed
  // from its source). A run announced with any other plan is refused,
  // never analysed (judge/run_admission.h). Empty: any plan whose digest
  // holds (said in the log at start).
  std::vector<pb::TestPlan> accepted_plans;
  // Fault injection (tests): drop this fraction of the final curves and
  // results the first time they are published, in [0, 1).
  double inject_result_drop = 0.0;
  Status Validate() const;
};

class AnalyzeService {
 public:
  static Result<std::unique_ptr<AnalyzeService>> Create(const AnalyzeOptions& options);
  ~AnalyzeService();
  // Runs until shutdown is requested. Fails if the bus cannot be opened.
  Status Run();

 private:
  struct Impl;
  explicit AnalyzeService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Whether `serial` belongs to shard k of n (FNV-1a of the serial, mod n).
bool InShard(std::string_view serial, int shard_index, int shard_count);

}  // namespace imuqual::analyze

#endif  // IMUQUAL_ANALYZE_SERVICE_ANALYZE_SERVICE_H_
