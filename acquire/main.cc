// imuqual-acquire: publishes the samples of units under test on a station
// bus. Flags -> options -> AcquireService -> exit code.
#include <CLI/CLI.hpp>
#include <cmath>

#include "acquire/acquire_service.h"
#include "acquire/source_spec.h"
#include "acquire/units.h"
#include "analyze/judge/plan_file.h"
#include "common/bus_flags.h"
#include "common/command_line.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "common/version.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  acquire::AcquireOptions opt;
  acquire::SimLotSpec sim;
  std::string plan_spec, await;
  CLI::App app{"imuqual-acquire: publish IMU samples of units under test on a station LCM bus"};
  app.footer(acquire::kSourceSpecHelp);
  app.set_version_flag("--version", kSoftwareVersion);
  app.add_option("--lcm-url", opt.lcm_url, "station bus, e.g. udpm://239.255.76.67:7701?ttl=0")
      ->required();
  app.add_option("--lot", opt.lot, "production lot of the units")->required();
  app.add_option("--station", opt.station, "station id")->capture_default_str();
  app.add_option("--operator", opt.operator_name, "operator name");
  app.add_option("--run-prefix", opt.run_prefix, "run id prefix (default: the UTC start time)");
  std::vector<std::string> unit_args;
  app.add_option("--sim", sim.count, "number of simulated units");
  std::vector<std::string> source_args, slot_args;
  app.add_option("--unit", unit_args,
                 "a unit: SERIAL=SOURCE, or SERIAL with the next --source; repeatable");
  app.add_option("--source", source_args,
                 "the source of the --unit SERIAL before it: sim:, csv:, serial:, archive: or "
                 "bag: (every key and an example of each below)");
  app.add_option("--slot", slot_args,
                 "fixture position of each --unit, in order (default: 1, 2, ... after the simulated units)");
  app.add_option("--profile", sim.profile,
                 "simulated lot profile: vg700, tactical, fog, mems-lab, mems-real")
      ->capture_default_str();
  app.add_option("--duration", sim.duration_s,
                 "seconds of data per unit (simulated units; serial units record this long)");
  CLI::Option* rate_opt =
      app.add_option("--rate", sim.rate_hz, "sample rate in Hz, > 0 (default: the profile's)");
  app.add_option("--seed", sim.seed, "lot seed (default: from the lot name)");
  app.add_option("--plan", plan_spec, "test plan: a .textproto file or builtin:NAME");
  app.add_option("--await", await, "consumers whose acks gate the data, e.g. store,analyze");
  app.add_option("--window", opt.window_batches, "unacknowledged batches in flight per run")
      ->capture_default_str();
  app.add_option("--batch-bytes", opt.batch_bytes,
                 "message budget per batch (0: when the bus stays on this host, ttl=0, 8 KB, 16 KB if time-warped; "
                 "else one 1400-byte datagram)")
      ->capture_default_str();
  app.add_option("--batch-samples", opt.batch_samples, "samples per batch (0: fit --batch-bytes)")
      ->capture_default_str();
  app.add_option("--pace", opt.pace, "0: as fast as acknowledged, 1: real time, k: k x")
      ->capture_default_str();
  app.add_option("--retention-mb", opt.retention_mb,
                 "MB of batches kept over all runs; unacknowledged ones up to it, beyond: dropped "
                 "with a warning")
      ->capture_default_str();
  app.add_option("--retention", opt.retention_s, "seconds of batches kept for resends")
      ->capture_default_str();
  app.add_option("--linger", opt.linger_s, "seconds to wait for final acks")->capture_default_str();
  app.add_option("--consumer-timeout", opt.consumer_timeout_s,
                 "seconds without acks before giving up")
      ->capture_default_str();
  app.add_option("--inject-drop", opt.inject_drop, "fault injection: drop this fraction of batches")
      ->capture_default_str();
  app.add_option("--inject-bitflip", opt.inject_bitflip,
                 "fault injection (tests): flip one bit in this fraction of sent batches")
      ->capture_default_str();
  app.add_option("--inject-seed", opt.inject_seed, "seed of the injected drops and bit flips")
      ->capture_default_str();
  app.add_option("--resend-budget-mb", opt.resend_budget_mb_s,
                 "MB/s resent to one requester at most (0: 64 on one host, 4 beyond it); the rest "
                 "of its requests is dropped and counted (resends_throttled)")
      ->capture_default_str();
  BusSecurityFiles bus_files;
  AddBusSecurityFlags(app, &bus_files, /*signs=*/true, /*replays=*/false);
  SetLogProgramName("imuqual-acquire");
  if (const auto code = ParseCommandLine(app, argc, argv)) return *code;
  if (auto security = bus_files.Load(BusRole::kAcquire); security.ok()) {
    opt.security = std::move(*security);
  } else {
    LogError(security.status().message());
    return 2;
  }

  // sim.rate_hz = 0 means "the profile's": a given --rate must be a rate.
  if (rate_opt->count() > 0 && !(sim.rate_hz > 0 && std::isfinite(sim.rate_hz))) {
    LogError("--rate " + rate_opt->as<std::string>() + ": must be a positive, finite rate in Hz");
    return 2;
  }
  InstallShutdownHandlers();
  if (!plan_spec.empty()) {
    auto plan = judge::LoadPlan(plan_spec);
    if (!plan.ok()) {
      LogError(plan.status().message());
      return 2;
    }
    opt.plan = *plan;
    if (plan->require_operator() && IsBlank(opt.operator_name)) {
      LogError("plan " + plan->name() + " requires an operator: give --operator NAME");
      return kExitUsage;
    }
  } else if (sim.profile == "vg700" && sim.count > 0 && unit_args.empty()) {
    opt.plan = *judge::LoadPlan("builtin:vg700ca");  // the simulated lot's own plan
  }
  if (!await.empty()) opt.await = Split(await, ',');
  sim.lot = opt.lot;
  // --unit SERIAL --source SPEC pairs, in order, become SERIAL=SPEC.
  {
    size_t next_source = 0;
    for (std::string& u : unit_args) {
      if (u.find('=') != std::string::npos) continue;
      if (next_source == source_args.size()) {
        LogError("--unit " + u + " has no --source (give --unit SERIAL --source SPEC or SERIAL=SPEC)");
        return 2;
      }
      u += "=" + source_args[next_source++];
    }
    if (next_source != source_args.size()) {
      LogError("--source " + source_args[next_source] + " follows no --unit SERIAL");
      return 2;
    }
  }
  if (sim.count == 0 && unit_args.empty()) {
    LogError("no units: give --sim N and/or --unit SERIAL=SOURCE");
    return 2;
  }
  std::vector<acquire::UnitSpec> units;
  if (sim.count > 0) {
    auto simulated = acquire::MakeSimUnits(sim);
    if (!simulated.ok()) {
      LogError(simulated.status().message());
      return 2;
    }
    units = std::move(*simulated);
  }
  acquire::SourceDefaults defaults;
  defaults.plan = opt.plan;
  defaults.lot = opt.lot;
  defaults.duration_s = sim.duration_s;
  defaults.rate_hz = sim.rate_hz;
  defaults.seed = sim.seed;
  auto named = acquire::MakeNamedUnits(unit_args, defaults, static_cast<int>(units.size()) + 1);
  if (!named.ok()) {
    LogError(named.status().message());
    return 2;
  }
  if (!slot_args.empty() && slot_args.size() != named->size()) {
    LogError("--slot given " + std::to_string(slot_args.size()) + " times for " +
             std::to_string(named->size()) + " --unit");
    return 2;
  }
  for (size_t i = 0; i < named->size(); ++i) {
    if (!slot_args.empty()) (*named)[i].slot = slot_args[i];
    units.push_back(std::move((*named)[i]));
  }
  auto service = acquire::AcquireService::Create(std::move(opt), std::move(units));
  if (!service.ok()) {
    LogError(service.status().message());
    return 2;
  }
  Status st = (*service)->Run();
  if (!st.ok()) {
    LogError(st.message());
    return 1;
  }
  return ShutdownRequested() ? 130 : 0;
}
