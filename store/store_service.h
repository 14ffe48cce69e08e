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
//
// Settled records: a run's identity and plan are fixed at its first
// announcement (a later one that differs is refused and counted); a run
// whose plan is not one the station accepts, or whose names are not
// identifiers, is refused and never archived; a judgement the store has
// finalized is never replaced by a message (only by a new judgement round
// the store itself opens); before that, a final result of the same round
// replaces an earlier one only if it covers more of the run (a later last
// batch, or fewer gaps), and one that disagrees on the same data is refused
// and counted (results_conflicting).
//
// Signing: with the store role's signing key (security.signing_key, also
// its key on the bus), each run is signed when it
// is finalised, on the writer thread in the finalising transaction, from
// digests kept as the chunks are written (its samples are not read again).
//
// Write failures (a full disk): a batch that arrived but could not be
// written is held in memory (bounded, max_unwritten_mb) and written again
// with back-off before anything newer; it is neither acknowledged nor taken
// for one that never arrived, and the holes the store waits for are not
// given up while it cannot write. A held batch dropped at the memory bound
// stays unacknowledged, so acquire still retains it and resends it once the
// archive writes again; only if that fails too is it a gap, with the reason
// "store_write" (cause: the write error), and the run's result says so.
// An archive that cannot write for write_give_up_s ends Run() with an
// IoError naming the error and what is not archived (none of it acknowledged).
#ifndef IMUQUAL_STORE_STORE_SERVICE_H_
#define IMUQUAL_STORE_STORE_SERVICE_H_

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/bus_seal.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::store {

// imuqual-store's exit code when the archive could not be written (a full
// disk): everything acknowledged is archived, the rest is not.
inline constexpr int kStoreExitUnwritable = 4;

struct StoreOptions {
  std::string lcm_url;
  // Keys and choices on the bus (role: store). Its signing key (imuqual
  // keygen --role store, kept outside the archive) also signs each
  // finalised run's record and each judgement round opened again in the
  // archive's chain (store/chain.h); without one the chain's entries are
  // unsigned (verify lists such runs as unsigned).
  BusSecurity security;
  std::string db_path;
  int queue_capacity = 100000;    // messages waiting for the writer
  int max_transaction = 4000;     // messages per transaction at most
  double hole_give_up_s = 30.0;   // a batch not resent by then is a gap
  double stale_after_s = 10.0;    // acquire silent this long: it is gone
  double heartbeat_s = 1.0;       // re-announcement period of runs the store took over
  // The station whose runs this store archives (run_t.station); other
  // stations' runs on the same bus are ignored and counted. "": every run.
  std::string station;
  // The plans this station runs (their files): a run announced with any
  // other plan is refused, never archived (judge/run_admission.h). Empty:
  // any plan whose digest holds (said in the log at start).
  std::vector<pb::TestPlan> accepted_plans;
  double resend_budget_mb_s = 0;  // resent per requester, MB/s; 0: 64 on one host, 4 beyond
  int max_unwritten_mb = 256;     // batches held while the archive cannot write (MB of samples);
                               // beyond, the newest are left unacknowledged for acquire to resend
  double write_give_up_s = 300;  // the archive failing every write this long: Run() fails
  // Store-and-forward to the plant archive (store/plant_shipper.h): a
  // postgresql:// URL, or "" for none. Shipped when a run is finalised and
  // at least every sync_period_s.
  std::string sync_to;
  double sync_period_s = 10;
  // Test seam: called before each COMMIT; a non-ok Status fails the
  // transaction as a full disk would (empty: none).
  std::function<Status()> before_commit;
  Status Validate() const;
};

class StoreService {
 public:
  // Opens (creating or migrating) the archive: a bad file fails here, before
  // anything is received.
  static Result<std::unique_ptr<StoreService>> Create(const StoreOptions& options);
  ~StoreService();
  // Runs until shutdown is requested; then drains the queue and commits.
  // IoError when the archive could not be written for write_give_up_s, or
  // batches received were still unwritten at the end (none acknowledged).
  Status Run();

 private:
  struct Impl;
  explicit StoreService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_STORE_SERVICE_H_
