// The acquire process's work: one run per unit, batches of consecutive
// samples published on IMUQUAL5_RAW.<serial>, the run announced and
// re-announced (heartbeat) on IMUQUAL5_RUN, resend requests answered from a
// retention window.
//
// Flow control: a time-warped source (simulator, file replay) is read only
// as fast as the awaited consumers (store, analyze) acknowledge, keeping at
// most `window_batches` unacknowledged batches in flight per run, so a
// station never overruns its own bus. Device-paced sources (serial) are
// never held back. Batches the store has acknowledged (archived) are kept
// for the window plus retention_s of data per run (older ones are served by
// the store from its archive; run_t.retained_first_seq says where acquire's
// memory starts); the others until the store's acknowledgement covers them,
// within retention_mb (acquire/retention.h). An acknowledgement counts only
// from the role it names (the seal says who sent it) and only for batches
// published.
//
// Resend requests are answered within a budget per requesting role (the
// role the request's seal names; common/resend_budget.h): 64 MB/s on one
// host, 4 MB/s beyond it; the rest is dropped and counted.
//
// Early decisions: a run whose unit the analysis decided PASS or FAIL
// (decision_t on IMUQUAL5_DECISION.<serial>, of the run's current judgement
// round as the store announces it) needs no more samples: its source is
// stopped and the run ends COMPLETE with end_reason "decided PASS at T s
// (early decision)". Every batch published up to then stays published and
// retained as usual; the other units go on.
//
// Threading: Run() is single-threaded; handlers only record acks and
// store announcements and queue resend requests and decisions for the loop.
#ifndef IMUQUAL_ACQUIRE_ACQUIRE_SERVICE_H_
#define IMUQUAL_ACQUIRE_ACQUIRE_SERVICE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "acquire/source.h"
#include "common/bus_seal.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"
#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {

struct AcquireOptions {
  std::string lcm_url;                // station bus
  BusSecurity security;               // keys and choices on the bus (role: acquire)
  std::string lot;                    // production lot of every unit here
  std::string station = "station";    // station id
  std::string operator_name;
  std::string run_prefix;             // run id = <run_prefix>-<serial>; "" = the UTC start time
  pb::TestPlan plan;                  // carried with every run; its axes (if any) must match
  std::vector<std::string> await;     // consumer roles whose acks gate time-warped sources
  int window_batches = 64;            // unacknowledged batches in flight per run
  int batch_samples = 0;              // samples per batch; 0 = the most that fit batch_bytes
  int batch_bytes = 0;                // message budget; 0 = on one host (ttl=0) 8 KB, 16 KB when
                                      // time-warped (pace 0); else one datagram
  double heartbeat_s = 1.0;           // run_t period
  // At most this many run_t heartbeats a second (each signed with role
  // keys, checked by every listener): with more runs the period grows (64
  // runs: 2 s). A run's changes of state are announced at once regardless.
  double heartbeat_runs_per_s = 32.0;
  double retention_s = 120.0;  // seconds of acknowledged data kept for resends (plus the window)
  int retention_mb = 512;      // memory for retained batches over all runs; unacknowledged
                               // ones are kept up to it (beyond: dropped, warned, a gap)
  double pace = 0.0;                  // 0: as fast as acknowledged; 1: real time; k: k x real time
  double consumer_timeout_s = 120.0;  // no ack progress this long while waiting: fail (well
                                      // beyond the consumers' 30 s give-up on a lost batch)
  double linger_s = 60.0;             // after the last batch, wait this long for final acks
  double resend_budget_mb_s = 0;      // resent per requester, MB/s; 0: 64 on one host, 4 beyond
  double inject_drop = 0.0;           // fault injection: drop this fraction of first publications
  // Test only (fault injection): flip one random bit of this fraction of the
  // datagrams sent (first publications and resends), after the checksum was
  // computed; the retained copy stays intact. Consumers must catch each one.
  double inject_bitflip = 0.0;
  uint64_t inject_seed = 1;
  // Checks every field; the error names it.
  Status Validate() const;
};

// Moves a source block into a batch: first_sample, num_samples, samples,
// the flagged samples, the temperature and sample_utime.
void MoveBlockIntoBatch(SampleBlock&& block, imuqual::rate_batch_t* msg);

struct UnitSpec {
  std::string serial;
  std::string slot;
  std::unique_ptr<SampleSource> source;
};

class AcquireService {
 public:
  // Validates options and units (serials, plan axes against source axes).
  static Result<std::unique_ptr<AcquireService>> Create(AcquireOptions options,
                                                        std::vector<UnitSpec> units);
  ~AcquireService();

  // Publishes until every source has ended and every awaited consumer has
  // acknowledged every batch (or linger_s passed), or shutdown is requested
  // (runs are then announced aborted). Fails if the bus cannot be opened, a
  // source fails, or awaited consumers stop acknowledging.
  Status Run();

  // Run ids, in unit order (valid after Create).
  std::vector<std::string> run_ids() const;

 private:
  struct Impl;
  explicit AcquireService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_ACQUIRE_SERVICE_H_
