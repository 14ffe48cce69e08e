#include "store/plant_shipper.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "common/log.h"
#include "store/archive.h"

namespace imuqual::store {

struct PlantShipper::Impl {
  ShipperOptions options;
  mutable std::mutex mu;
  std::condition_variable wake;
  bool notified = false;
  bool stopping = false;
  Counters counters;
  std::thread worker;
  std::unique_ptr<Archive> plant;    // reconnected after a failure
  std::unique_ptr<Archive> station;  // reopened after a failure
  std::string last_problem;          // logged once until it changes

  // One sync; the delay before the next one.
  double ShipOnce(double backoff_s) {
    auto problem = [&](const std::string& what, bool refusal) {
      std::lock_guard<std::mutex> lock(mu);
      (refusal ? counters.refusals : counters.failures) += 1;
      if (what != last_problem) {
        LogError("plant " + options.plant_url + ": " + what +
                 (refusal ? "" : " (the station keeps everything; shipping is tried again)"));
        last_problem = what;
      }
    };
    if (!station) {
      auto s = Archive::Open(options.station_db, Archive::Mode::kRead);
      if (!s.ok()) {
        problem(s.status().message(), false);
        return backoff_s;
      }
      station = std::move(*s);
    }
    if (!plant) {
      auto p = Archive::Open(options.plant_url, Archive::Mode::kWrite);
      if (!p.ok()) {
        problem(p.status().message(), false);
        return backoff_s;
      }
      plant = std::move(*p);
    }
    auto report = SyncToPlant(*station, *plant, options.sync);
    if (!report.ok()) {
      problem(report.status().message(), false);
      plant.reset();  // a new connection next time
      station.reset();
      return backoff_s;
    }
    {
      std::lock_guard<std::mutex> lock(mu);
      ++counters.syncs;
      counters.runs_shipped += report->runs_shipped;
    }
    if (report->runs_shipped > 0) {
      LogInfo("shipped " + std::to_string(report->runs_shipped) + " run(s) to the plant " +
              plant->path() + " (chain entries " + std::to_string(report->shipped_after) + " of " +
              std::to_string(report->station_entries) + ")");
    }
    if (!report->refusal.empty()) {
      problem("refused: " + report->refusal, true);
      return options.period_s;
    }
    if (report->behind) problem("the station archive is behind the plant (a restored backup?)", true);
    if (report->refusal.empty() && !report->behind) last_problem.clear();
    return 0;  // shipped: back to the normal period
  }

  void Run() {
    double backoff = 1;
    for (;;) {
      const double failed_wait = ShipOnce(backoff);
      if (failed_wait > 0 && failed_wait == backoff) {
        backoff = std::min(options.max_backoff_s, backoff * 2);
      } else {
        backoff = 1;
      }
      const double wait_s = failed_wait > 0 ? failed_wait : options.period_s;
      std::unique_lock<std::mutex> lock(mu);
      wake.wait_for(lock, std::chrono::duration<double>(wait_s),
                    [&] { return notified || stopping; });
      if (stopping) break;
      notified = false;
    }
    (void)ShipOnce(0);  // the runs finalised just before shutdown
  }
};

Result<std::unique_ptr<PlantShipper>> PlantShipper::Start(const ShipperOptions& options) {
  if (!IsPostgresUrl(options.plant_url)) {
    return Status::InvalidArgument("--sync-to " + options.plant_url +
                                   ": the plant archive must be a postgresql:// URL");
  }
  if (!(options.period_s > 0)) return Status::InvalidArgument("the sync period must be > 0 s");
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  Impl* raw = impl.get();
  impl->worker = std::thread([raw] { raw->Run(); });
  return std::unique_ptr<PlantShipper>(new PlantShipper(std::move(impl)));
}

PlantShipper::PlantShipper(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

PlantShipper::~PlantShipper() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->stopping = true;
  }
  impl_->wake.notify_all();
  if (impl_->worker.joinable()) impl_->worker.join();
}

void PlantShipper::Notify() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->notified = true;
  }
  impl_->wake.notify_all();
}

PlantShipper::Counters PlantShipper::counters() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->counters;
}

}  // namespace imuqual::store
