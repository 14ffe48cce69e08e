// imuqual: the operator's and engineer's tool. Runs a station, answers lot
// queries. Subcommand flags -> command functions -> exit code.
#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/shutdown.h"
#include "store/cli/analyze_command.h"
#include "store/cli/commands.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  SetLogProgramName("imuqual");
  CLI::App app{"imuqual: IMU end-of-line qualification station (Allan deviation, IEEE 952)"};
  app.require_subcommand(1);

  cli::StationRunOptions run;
  bool quiet = false;
  CLI::App* run_cmd = app.add_subcommand("run", "run a simulated multi-unit soak end to end");
  run_cmd->add_option("--sim", run.sim_units, "number of simulated units")->required();
  run_cmd->add_option("--duration", run.duration_s, "simulated seconds of data per unit")->required();
  run_cmd->add_option("--rate", run.rate_hz, "sample rate in Hz (default: the profile's)");
  run_cmd->add_option("--lot", run.lot, "production lot name")->required();
  run_cmd->add_option("--db", run.db_path, "archive file (created if missing)")->required();
  run_cmd->add_option("--plan", run.plan_spec, "test plan: .textproto file or builtin:NAME");
  run_cmd->add_option("--profile", run.profile, "simulated lot profile: vg700, tactical, fog")
      ->capture_default_str();
  run_cmd->add_option("--lcm-url", run.lcm_url, "station bus (default: a private port, ttl=0)");
  run_cmd->add_option("--station", run.station, "station id")->capture_default_str();
  run_cmd->add_option("--operator", run.operator_name, "operator name");
  run_cmd->add_option("--inject-drop", run.inject_drop, "fault injection: drop this fraction of batches")
      ->capture_default_str();
  run_cmd->add_option("--stall-timeout", run.stall_timeout_s, "seconds without progress before giving up")
      ->capture_default_str();
  run_cmd->add_option("--pace", run.pace, "0: as fast as the station goes, 1: real time, k: k x real time")
      ->capture_default_str();
  run_cmd->add_flag("--quiet", quiet, "no progress line");

  std::string db, format = "table", lot;
  bool all_runs = false;
  CLI::App* lots_cmd = app.add_subcommand("lots", "list the lots in an archive");
  lots_cmd->add_option("--db", db, "archive file")->required();
  lots_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();

  CLI::App* lot_cmd = app.add_subcommand("lot", "per-unit, per-axis results of one lot");
  lot_cmd->add_option("lot", lot, "lot name")->required();
  lot_cmd->add_option("--db", db, "archive file")->required();
  lot_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();
  lot_cmd->add_flag("--all-runs", all_runs, "every run, not only each unit's latest");

  cli::AnalyzeFileOptions an;
  CLI::App* analyze_cmd = app.add_subcommand("analyze", "offline Allan analysis of a recorded series");
  analyze_cmd->add_option("file", an.path, "one value per line, or CSV with a header")->required();
  analyze_cmd->add_option("--column", an.column, "CSV column to analyse");
  analyze_cmd->add_option("--rate", an.rate_hz, "sample rate in Hz")->capture_default_str();
  analyze_cmd->add_option("--type", an.type, "rate or phase")->capture_default_str();
  analyze_cmd->add_option("--dev", an.devs, "estimators: adev,oadev,mdev,tdev,hdev,ohdev,totdev")
      ->capture_default_str();
  analyze_cmd->add_option("--grid", an.grid, "octave, decade, all, logN (N per decade), or taus 1,2,5")
      ->capture_default_str();
  analyze_cmd->add_option("--stop", an.stop, "bins9, stable32 or none")->capture_default_str();
  analyze_cmd->add_option("--ci", an.ci, "none, simple (1/sqrt(2(K-1))) or chi2 (Greenhall edf)")
      ->capture_default_str();
  analyze_cmd->add_option("--confidence", an.confidence, "chi2 interval level")->capture_default_str();
  analyze_cmd->add_flag("--fit", an.fit, "IEEE 952 fit (Q, N, B, K, R) and slope-line read-offs");
  analyze_cmd->add_option("--kind", an.kind, "gyro or accel: datasheet units for the fit");
  analyze_cmd->add_option("--format", an.format, "table, csv or json")->capture_default_str();
  analyze_cmd->add_option("--plot", an.plot_path, "write an SVG plot of the curves");

  CLI11_PARSE(app, argc, argv);
  if (analyze_cmd->parsed()) return cli::AnalyzeFileCommand(an);

  auto fmt = cli::ParseFormat(format);
  if (!fmt.ok()) {
    LogError(fmt.status().message());
    return 2;
  }
  if (run_cmd->parsed()) {
    InstallShutdownHandlers();
    run.show_progress = !quiet;
    return cli::RunCommand(run);
  }
  if (lots_cmd->parsed()) return cli::LotsCommand(db, *fmt);
  if (lot_cmd->parsed()) return cli::LotCommand(db, lot, *fmt, all_runs);
  return 2;
}
