// imuqual-store: archives a station bus into SQLite. Flags -> options ->
// StoreService -> exit code (0 ok, 1 failed, 2 bad options or archive file,
// 4 the archive could not be written: what it holds is all that was
// acknowledged).
#include <CLI/CLI.hpp>

#include "analyze/judge/plan_file.h"
#include "common/bus_flags.h"
#include "common/command_line.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/version.h"
#include "store/store_service.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  store::StoreOptions opt;
  CLI::App app{"imuqual-store: archive raw samples, curves and results of a station in SQLite"};
  app.set_version_flag("--version", kSoftwareVersion);
  app.add_option("--station", opt.station,
                 "serve only this station's runs (run_t.station); others on the bus are ignored")
      ->capture_default_str();
  app.add_option("--lcm-url", opt.lcm_url, "station bus, e.g. udpm://239.255.76.67:7701?ttl=0")
      ->required();
  app.add_option("--db", opt.db_path, "archive file (created if missing)")->required();
  app.add_option("--queue", opt.queue_capacity, "messages waiting for the writer")
      ->capture_default_str();
  app.add_option("--give-up", opt.hole_give_up_s, "seconds before a lost batch becomes a gap")
      ->capture_default_str();
  app.add_option("--stale-after", opt.stale_after_s,
                 "seconds of acquire silence before a run is taken over (incomplete if running)")
      ->capture_default_str();
  app.add_option("--max-unwritten-mb", opt.max_unwritten_mb,
                 "MB of batches held while the archive cannot write (full disk); beyond, acquire "
                 "keeps them")
      ->capture_default_str();
  app.add_option("--write-give-up", opt.write_give_up_s,
                 "seconds of failing writes after which the store stops (exit 4)")
      ->capture_default_str();
  std::vector<std::string> accept_plans;
  app.add_option("--accept-plan", accept_plans,
                 "a plan this station runs (file or builtin:NAME), repeatable: a run announced "
                 "with any other plan is refused (default: any plan whose digest holds)");
  app.add_option("--resend-budget-mb", opt.resend_budget_mb_s,
                 "MB/s resent to one requester at most (0: 64 on one host, 4 beyond it); the rest "
                 "of its requests is dropped and counted (resends_throttled)")
      ->capture_default_str();
  app.add_option("--sync-to", opt.sync_to,
                 "the plant archive (postgresql://...): ship every finalised run there as it is "
                 "finalised and at least every --sync-period (store-and-forward: a plant away is "
                 "caught up when it is back)");
  app.add_option("--sync-period", opt.sync_period_s, "seconds between shipments at most")
      ->capture_default_str();
  BusSecurityFiles bus_files;
  AddBusSecurityFlags(app, &bus_files, /*signs=*/true, /*replays=*/true);
  SetLogProgramName("imuqual-store");
  if (const auto code = ParseCommandLine(app, argc, argv)) return *code;
  for (const std::string& spec : accept_plans) {
    auto plan = judge::LoadPlan(spec);
    if (!plan.ok()) {
      LogError("--accept-plan " + spec + ": " + plan.status().message());
      return 2;
    }
    opt.accepted_plans.push_back(std::move(*plan));
  }
  if (auto security = bus_files.Load(BusRole::kStore); security.ok()) {
    opt.security = std::move(*security);
  } else {
    LogError(security.status().message());
    return 2;
  }

  InstallShutdownHandlers();
  auto service = store::StoreService::Create(opt);
  if (!service.ok()) {
    LogError(service.status().message());
    return 2;
  }
  Status st = (*service)->Run();
  if (!st.ok()) {
    LogError(st.message());
    return st.code() == Status::Code::kIoError ? store::kStoreExitUnwritable : 1;
  }
  return 0;
}
