// The store process: archives everything a station produces into SQLite.
// Handlers only decode and enqueue (bounded queue, drops counted); one
// writer thread applies what is queued in batched transactions (WAL,
// synchronous=NORMAL), then acknowledges what is committed, so a batch is
// acknowledged only once it is durable. Missing batches are requested again
// (resend_t) and, when they never come, recorded as gaps.
//
// Recovery: a store started late or restarted mid-run learns runs from their
// heartbeats and from its own archive (runs not finalized), resumes from
// what is archived and asks for the rest. When a run's acquire goes silent,
// the store marks a running run incomplete, stops waiting for its missing
// batches (gaps), and takes over: it re-announces the run (run_t, announcer
// "store") and answers resend requests from the archive, so an analyze
// process that restarts can still finish the run. It also answers requests
// for batches acquire no longer retains.
#ifndef IMUQUAL_STORE_STORE_SERVICE_H_
#define IMUQUAL_STORE_STORE_SERVICE_H_

#include <memory>
#include <string>

#include "common/status.h"

namespace imuqual::store {

struct StoreOptions {
  std::string lcm_url;
  std::string db_path;
  int queue_capacity = 100000;    // messages waiting for the writer
  int max_transaction = 4000;     // messages per transaction at most
  double hole_give_up_s = 30.0;   // a batch not resent by then is a gap
  double stale_after_s = 10.0;    // acquire silent this long: it is gone
  double heartbeat_s = 1.0;       // re-announcement period of runs the store took over
  // The station whose runs this store archives (run_t.station); other
  // stations' runs on the same bus are ignored and counted. "": every run.
  std::string station;
  Status Validate() const;
};

class StoreService {
 public:
  // Opens (creating or migrating) the archive: a bad file fails here, before
  // anything is received.
  static Result<std::unique_ptr<StoreService>> Create(const StoreOptions& options);
  ~StoreService();
  // Runs until shutdown is requested; then drains the queue and commits.
  Status Run();

 private:
  struct Impl;
  explicit StoreService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_STORE_SERVICE_H_
