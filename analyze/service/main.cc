// imuqual-analyze: Allan analysis of every run on a station bus (or one
// shard of the units). Flags -> options -> AnalyzeService -> exit code.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "analyze/service/analyze_service.h"
#include "analyze/judge/plan_file.h"
#include "common/bus_flags.h"
#include "common/command_line.h"
#include "common/log.h"
#include "common/process_status.h"
#include "common/shutdown.h"
#include "common/version.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  analyze::AnalyzeOptions opt;
  std::string shard = "0/1";
  CLI::App app{"imuqual-analyze: Allan curves, noise terms and verdicts for every run on a bus"};
  app.set_version_flag("--version", kSoftwareVersion);
  app.add_option(
         "--inject-result-drop", opt.inject_result_drop,
         "fault injection: drop this fraction of final curves and results when first published")
      ->capture_default_str();
  app.add_option("--station", opt.station,
                 "serve only this station's runs (run_t.station); others on the bus are ignored")
      ->capture_default_str();
  app.add_option("--lcm-url", opt.lcm_url, "station bus, e.g. udpm://239.255.76.67:7701?ttl=0")
      ->required();
  app.add_option("--shard", shard, "K/N: analyse only the units of shard K of N")
      ->capture_default_str();
  app.add_option("--density", opt.density, "streaming averaging factors per octave (power of 2)")
      ->capture_default_str();
  app.add_option("--interim-period", opt.interim_period_s, "seconds between interim results")
      ->capture_default_str();
  app.add_option("--queue", opt.queue_capacity, "batches waiting for the worker")
      ->capture_default_str();
  app.add_option("--give-up", opt.hole_give_up_s, "seconds before a lost batch becomes a gap")
      ->capture_default_str();
  app.add_option("--stale-after", opt.stale_after_s,
                 "seconds without any announcement before a running run is ended as incomplete")
      ->capture_default_str();
  std::vector<std::string> accept_plans;
  app.add_option("--accept-plan", accept_plans,
                 "a plan this station runs (file or builtin:NAME), repeatable: a run announced "
                 "with any other plan is refused (default: any plan whose digest holds)");
  BusSecurityFiles bus_files;
  AddBusSecurityFlags(app, &bus_files, /*signs=*/true, /*replays=*/true);
  SetLogProgramName("imuqual-analyze");
  if (const auto code = ParseCommandLine(app, argc, argv)) return *code;
  for (const std::string& spec : accept_plans) {
    auto plan = judge::LoadPlan(spec);
    if (!plan.ok()) {
      LogError("--accept-plan " + spec + ": " + plan.status().message());
      return 2;
    }
    opt.accepted_plans.push_back(std::move(*plan));
  }
  if (auto security = bus_files.Load(BusRole::kAnalyze); security.ok()) {
    opt.security = std::move(*security);
  } else {
    LogError(security.status().message());
    return 2;
  }

  InstallShutdownHandlers();
  if (std::sscanf(shard.c_str(), "%d/%d", &opt.shard_index, &opt.shard_count) != 2) {
    LogError("--shard must be K/N, e.g. 0/3, got '" + shard + "'");
    return 2;
  }
  auto service = analyze::AnalyzeService::Create(opt);
  if (!service.ok()) {
    LogError(service.status().message());
    return 2;
  }
  Status st = (*service)->Run();
  // Its CPU, for the station benchmark (as acquire and store report theirs).
  char cpu[64];
  std::snprintf(cpu, sizeof cpu, "stopped; cpu %.2f s", ProcessCpuSeconds());
  LogInfo(cpu);
  if (!st.ok()) {
    LogError(st.message());
    return 1;
  }
  return 0;
}
