// Store-and-forward to the plant archive (imuqual-store --sync-to): a
// worker thread that ships the station's archive (store/plant_sync.h)
// whenever a run is finalised and every `period_s` otherwise, so the plant
// catches up by itself after being away. The station never waits for the
// plant: its archive is the record; a plant gone, or refusing, is logged
// (each new cause once) and tried again with back-off.
#ifndef IMUQUAL_STORE_PLANT_SHIPPER_H_
#define IMUQUAL_STORE_PLANT_SHIPPER_H_

#include <memory>
#include <string>

#include "common/status.h"
#include "store/plant_sync.h"

namespace imuqual::store {

struct ShipperOptions {
  std::string station_db;  // the station's archive file
  std::string plant_url;   // postgresql://...
  double period_s = 10;    // at least this often
  double max_backoff_s = 60;
  SyncOptions sync;
};

class PlantShipper {
 public:
  // Starts the worker (connections are made by it, not here: a plant down
  // at start is only logged).
  static Result<std::unique_ptr<PlantShipper>> Start(const ShipperOptions& options);
  // Ships once more (what was finalised last), then stops the worker.
  ~PlantShipper();
  // A run was finalised: ship soon.
  void Notify();

  // For tests and the log: syncs done, runs shipped, failures.
  struct Counters {
    int64_t syncs = 0, runs_shipped = 0, failures = 0, refusals = 0;
  };
  Counters counters() const;

 private:
  struct Impl;
  explicit PlantShipper(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_PLANT_SHIPPER_H_
