// imuqual: the operator's and engineer's tool. Runs a station, answers lot
// queries. Subcommand flags -> command functions -> exit code.
#include <CLI/CLI.hpp>
#include <algorithm>

#include "acquire/source_spec.h"
#include "cli/commands.h"
#include "cli/export_command.h"
#include "cli/keygen_command.h"
#include "cli/chart_command.h"
#include "cli/msa_command.h"
#include "cli/sync_command.h"
#include "cli/yields_command.h"
#include "cli/lot_commands.h"
#include "cli/plot_command.h"
#include "cli/report_command.h"
#include "cli/serve_command.h"
#include "cli/verify_command.h"
#include "common/bus_flags.h"
#include "common/command_line.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "common/version.h"
#include "offline/analyze_command.h"
#include "offline/plan_soak_command.h"
#include "offline/reanalyze_command.h"
#include "station/station_config.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  SetLogProgramName("imuqual");
  CLI::App app{"imuqual: IMU end-of-line qualification station (Allan deviation, IEEE 952)"};
  app.set_version_flag("--version", kSoftwareVersion);
  app.require_subcommand(1);

  station::StationRunOptions run;
  bool quiet = false;
  std::string station_file;
  CLI::App* run_cmd =
      app.add_subcommand("run", "run a station on this host: a multi-unit soak end to end");
  run_cmd->add_option(
      "--station", station_file,
      "station configuration (protobuf text: station id, bus, slots with unit serials "
      "and sources, plan, lot, operator, duration, archive); replaces --sim/--unit/--lot/--db/"
      "--plan/--duration/--rate/--operator/--lcm-url");
  run_cmd->add_option("--sim", run.sim_units, "number of simulated units");
  run_cmd->add_option("--unit", run.units,
                      "SERIAL=SOURCE, repeatable: sim:, csv:, serial:, archive: or bag: "
                      "(every key and an example of each below)");
  run_cmd->add_option("--duration", run.duration_s,
                      "seconds of data per unit (simulated units; serial units record this long)");
  double rate_hz = 0;  // given or not: run.rate_hz
  run_cmd->add_option("--rate", rate_hz, "sample rate in Hz, > 0 (default: the profile's)");
  run_cmd->add_option("--lot", run.lot, "production lot name");
  run_cmd->add_option("--db", run.db_path, "archive file (created if missing)");
  run_cmd->add_option("--plan", run.plan_spec, "test plan: .textproto file or builtin:NAME");
  run_cmd
      ->add_option("--profile", run.profile,
                   "simulated lot profile: vg700, tactical, fog, mems-lab, mems-real")
      ->capture_default_str();
  run_cmd->add_option("--lcm-url", run.lcm_url, "station bus (default: a private port, ttl=0)");
  run_cmd->add_option("--station-id", run.station, "station id")->capture_default_str();
  run_cmd
      ->add_option("--key-file", run.key_file,
                   "the station key (imuqual keygen): every process gets it, every message "
                   "carries a MAC; needed for a bus beyond this host")
      ->check(CLI::ExistingFile);
  run_cmd
      ->add_option("--trust", run.trust_file,
                   "the roles' public keys in one file: verdict-bearing messages must be signed "
                   "by their role (with --sign-key for each role)")
      ->check(CLI::ExistingFile);
  std::vector<std::string> sign_keys;
  run_cmd->add_option("--sign-key", sign_keys,
                      "ROLE=FILE, repeatable: a role's signing key (acquire, analyze, store), "
                      "given to that process only; the store's also signs the archive's runs");
  run_cmd->add_option("--sync-to", run.sync_to,
                      "the plant archive (postgresql://...): the store ships every finalised run "
                      "there as it is finalised");
  run_cmd->add_flag("--insecure-bus", run.insecure_bus,
                    "run on a bus beyond this host without a station key (unauthenticated; "
                    "every run records it)");
  run_cmd->add_option("--operator", run.operator_name, "operator name");
  run_cmd
      ->add_option("--inject-drop", run.inject_drop,
                   "fault injection: drop this fraction of batches")
      ->capture_default_str();
  run_cmd
      ->add_option("--stall-timeout", run.stall_timeout_s,
                   "seconds without progress before giving up")
      ->capture_default_str();
  run_cmd
      ->add_option("--archive-timeout", run.archive_timeout_s,
                   "seconds the archive may fail every write (a full disk) before the station "
                   "stops with exit code 4")
      ->capture_default_str();
  run_cmd
      ->add_option("--give-up", run.give_up_s,
                   "seconds before a batch that never arrived becomes a gap")
      ->capture_default_str();
  run_cmd
      ->add_option("--pace", run.pace,
                   "0: as fast as the station goes, 1: real time, k: k x real time")
      ->capture_default_str();
  run_cmd
      ->add_option("--analyze-shards", run.analyze_shards, "analyze processes splitting the units")
      ->capture_default_str();
  run_cmd->add_option("--report", run.report_path,
                      "HTML report written at the end (default: beside the archive)");
  run_cmd->add_flag("--quiet", quiet, "no live console or progress line");
  run_cmd->add_flag("--short-soak", run.short_soak,
                    "run although the soak is shorter than the plan's warm-up + minimum duration "
                    "(its runs are judged too short: FAIL)");
  run_cmd->add_flag("--skip-failed-slots", run.skip_failed_slots,
                    "pre-flight: run without the units whose source cannot be opened (each "
                    "named) instead of stopping");
  run_cmd->add_flag("--fail-exit", run.fail_exit,
                    "exit 5 when a unit is judged FAIL or INCONCLUSIVE (for scripts and line "
                    "controllers; without it a FAIL verdict is a result and the exit is 0)");
  run_cmd->footer(std::string(acquire::kSourceSpecHelp) +
                  "\n\nExamples:\n"
                  "  imuqual run --sim 8 --lot L1 --db station.db --plan builtin:vg700ca "
                  "--duration 3720\n"
                  "  imuqual run --station station.textproto --operator ana\n\n" +
                  cli::kRunExitCodesHelp);

  std::string db, format = "table", lot;
  bool all_runs = false, stats = false, lot_model = false;
  CLI::App* lots_cmd = app.add_subcommand("lots", "list the lots in an archive");
  lots_cmd->add_option("--db", db, "archive file")->required();
  lots_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();

  CLI::App* lot_cmd = app.add_subcommand("lot", "per-unit, per-axis results of one lot");
  lot_cmd->add_option("lot", lot, "lot name")->required();
  lot_cmd->add_option("--db", db, "archive file")->required();
  lot_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();
  lot_cmd->add_flag(
      "--all-runs", all_runs,
      "every run, not only each unit's final one (its latest judged run, else its latest)");
  lot_cmd->add_flag("--stats", stats,
                    "per axis and measurement: n, mean, sd, min, max, yield, Cpk/Cpu/Cpl (and, as "
                    "a table, the lot noise model)");
  lot_cmd->add_flag("--model", lot_model,
                    "the lot noise model per axis: the units' curves pooled, a composite model "
                    "fitted, the units inconsistent with it");

  std::string lot_b;
  double alpha = 0.05;
  CLI::App* compare_cmd = app.add_subcommand("compare", "two lots side by side, with significance");
  compare_cmd->add_option("lot_a", lot, "first lot")->required();
  compare_cmd->add_option("lot_b", lot_b, "second lot")->required();
  compare_cmd->add_option("--db", db, "archive file")->required();
  compare_cmd->add_option("--alpha", alpha, "family-wise significance level (Holm)")
      ->capture_default_str();
  compare_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();

  std::string serial;
  CLI::App* unit_cmd = app.add_subcommand("unit", "the history of one unit across runs and lots");
  unit_cmd->add_option("serial", serial, "unit serial number")->required();
  unit_cmd->add_option("--db", db, "archive file")->required();
  unit_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();

  store::RunFilter run_filter;
  std::string since;
  CLI::App* runs_cmd = app.add_subcommand("runs", "list runs, newest first");
  runs_cmd->add_option("--db", db, "archive file")->required();
  runs_cmd->add_option("--lot", run_filter.lot, "only this lot");
  runs_cmd->add_option("--station", run_filter.station, "only this station");
  runs_cmd->add_option("--unit", run_filter.unit, "only this unit serial");
  runs_cmd->add_option("--since", since,
                       "started at or after (2026-11-21 or 2026-11-21T08:00:00Z)");
  runs_cmd->add_option("--verdict,--outcome", run_filter.verdict,
                       "PASS, MARGINAL, FAIL, INCONCLUSIVE, ABORTED, ERROR or none");
  runs_cmd->add_option("--limit", run_filter.limit, "at most this many")->capture_default_str();
  runs_cmd->add_option("--format", format, "table, csv or json")->capture_default_str();

  cli::ExportOptions ex;
  CLI::App* export_cmd =
      app.add_subcommand("export", "run records, measurements, curves, Kalibr YAML or raw samples");
  export_cmd->add_option("--db", ex.db_path, "archive file")->required();
  export_cmd->add_option("--lot", ex.lot, "every run of this lot");
  export_cmd->add_option("--run", ex.run_id, "this run");
  export_cmd
      ->add_option("--format,--as", ex.as,
                   "json (run records), measurements (CSV), curves (CSV), kalibr (YAML), "
                   "samples (CSV of one --run's raw samples: sample, device_time_s, "
                   "arrival_utime, <axis>_deg_s|_m_s2, temperature_c, flags); --as is the "
                   "former name")
      ->capture_default_str();
  export_cmd->add_option("-o,--output", ex.output,
                         "file (default: standard output); kalibr of a lot: a directory, DIR/");
  export_cmd->add_option("--rostopic", ex.rostopic, "kalibr: the IMU topic")->capture_default_str();
  export_cmd->add_flag("--upper-bounds", ex.kalibr_upper_bounds,
                       "kalibr: export a term the noise model only bounds (its 95 % upper bound)");

  offline::AnalyzeFileOptions an;
  CLI::App* analyze_cmd =
      app.add_subcommand("analyze", "offline Allan analysis of a recorded series");
  analyze_cmd->add_option("file", an.path, "one value per line, or CSV with a header")->required();
  analyze_cmd->add_option("--column", an.column, "CSV column to analyse");
  analyze_cmd->add_option("--rate", an.rate_hz,
                          "sample rate in Hz, required: analyze does not assume one (e.g. "
                          "--rate 100)");
  analyze_cmd->add_option("--type", an.type, "rate or phase")->capture_default_str();
  analyze_cmd
      ->add_option("--dev", an.devs,
                   "estimators: adev,oadev,mdev,tdev,hdev,ohdev,totdev; long tau: theo1, "
                   "theobr (bias-removed), theoh (oadev then theobr), mtotdev, ttotdev, htotdev. "
                   "theo1/theobr/theoh report tau = 0.75 m tau0 (m even); the long-tau "
                   "estimators reach past T/9 only with --stop stable32 or none; with gaps they "
                   "use the longest gap-free span")
      ->capture_default_str();
  analyze_cmd
      ->add_option("--grid", an.grid, "octave, decade, all, logN (N per decade), or taus 1,2,5")
      ->capture_default_str();
  analyze_cmd->add_option("--stop", an.stop, "bins9, stable32 or none")->capture_default_str();
  analyze_cmd->add_option("--ci", an.ci, "none, simple (1/sqrt(2(K-1))) or chi2 (Greenhall edf)")
      ->capture_default_str();
  analyze_cmd->add_option("--confidence", an.confidence, "chi2 interval level")
      ->capture_default_str();
  analyze_cmd->add_flag("--fit", an.fit,
                        "composite noise model (white, quantization, flicker, RRW, drift, "
                        "Gauss-Markov, sinusoids; selected, tested for fit, with sigmas) beside "
                        "the slope-line read-offs");
  analyze_cmd->add_option("--fit-min-tau", an.fit_min_tau_s,
                          "with --fit: leave the curve points below this tau (s, at most 1) out "
                          "of the fit, where the sensor's own output filter shapes the curve "
                          "(the report says so); e.g. --fit-min-tau 0.16")
      ->capture_default_str();
  analyze_cmd->add_flag("--long-tau-check", an.long_tau_check,
                        "with --fit: Theo1 at octaves beyond the fitted curve's last tau (to "
                        "0.75 of the record) against what the model expects of it, with Theo1's "
                        "edf: whether the model holds where OADEV does not reach");
  analyze_cmd->add_flag("--fit-long-taus", an.fit_long_taus,
                        "with --fit: Theo1 at octaves beyond the curve's last tau (to 0.3 of "
                        "the record) joins the fit as moments, each against what the model "
                        "expects of Theo1 there: the model and its minimum follow the record "
                        "beyond the Allan range");
  analyze_cmd->add_option("--stationarity", an.stationarity_level,
                          "scan the series for level steps and bursts at this false-alarm level "
                          "per record (calibrated on the series' own noise model), e.g. 0.01");
  analyze_cmd->add_option("--stationarity-plan", an.stationarity_plan,
                          "with --stationarity and --kind: scan against this plan's reference "
                          "noise model (builtin:NAME or a .textproto) instead of the series' own");
  analyze_cmd->add_flag("--judge-longest-segment", an.judge_longest_segment,
                        "with --stationarity: the curves, the fit and the read-offs are those of "
                        "the longest stretch (most valid data) that no found event touches, a "
                        "scan bin either side of each (as a plan's JUDGE_LONGEST_SEGMENT)");
  analyze_cmd->add_option("--kind", an.kind, "gyro or accel: datasheet units for the fit");
  analyze_cmd->add_option("--unit", an.unit,
                          "the values' unit, with --kind: gyro deg/s (default), rad/s, mrad/s, "
                          "deg/h, rpm; accel m/s^2 (default), g, mg, ug");
  analyze_cmd->add_option("--scale", an.scale, "multiply every value (e.g. an LSB) before --unit")
      ->capture_default_str();
  analyze_cmd->add_option("--format", an.format, "table, csv or json")->capture_default_str();
  analyze_cmd->add_option("--plot", an.plot_path, "write an SVG plot of the curves");
  analyze_cmd->add_option("--davar", an.davar_path,
                          "write an SVG plot of the dynamic Allan deviation: the OADEV of "
                          "windows sliding along the record (a step, a ramp or a burst shows as "
                          "the windows that hold it standing apart)");
  analyze_cmd->add_option("--davar-window", an.davar_window_s,
                          "with --davar: the window, s (default a quarter of the record; a "
                          "window starts every quarter window)");

  offline::ReanalyzeOptions re;
  CLI::App* reanalyze_cmd = app.add_subcommand("reanalyze", "analyse an archived run again");
  reanalyze_cmd->add_option("run", re.run_id, "run id")->required();
  reanalyze_cmd->add_option("--db", re.db_path, "archive file")->required();
  CLI::Option* exact_flag = reanalyze_cmd->add_flag(
      "--exact", re.exact,
      "exact batch estimators over every archived sample (any grid, stop, CI)");
  reanalyze_cmd
      ->add_flag("--check", re.check,
                 "live mode: verify the run's checksums and that it equals the archived result "
                 "(every curve point, measurement and the verdict); prints the check's result "
                 "only (one line per difference), not the curves")
      ->excludes(exact_flag);
  // Options only the exact mode honours are refused without it, never ignored.
  reanalyze_cmd
      ->add_option("--dev", re.devs,
                   "--exact: estimators (as for analyze, the long-tau ones included)")
      ->capture_default_str()
      ->needs(exact_flag);
  reanalyze_cmd->add_option("--grid", re.grid, "--exact: tau grid")
      ->capture_default_str()
      ->needs(exact_flag);
  reanalyze_cmd->add_option("--stop", re.stop, "--exact: bins9, stable32 or none")
      ->capture_default_str()
      ->needs(exact_flag);
  reanalyze_cmd->add_option("--ci", re.ci, "--exact: none, simple or chi2")
      ->capture_default_str()
      ->needs(exact_flag);
  reanalyze_cmd
      ->add_flag("--looks", re.looks,
                 "live mode: every look of the run's early decisions (evidence, decisions, what "
                 "was pending) instead of the curves")
      ->excludes(exact_flag);
  reanalyze_cmd->add_option("--format", re.format, "table, csv or json")->capture_default_str();

  cli::VerifyOptions verify;
  CLI::App* verify_cmd = cli::AddVerifyCommand(app, &verify);

  cli::YieldsOptions yields;
  CLI::App* yields_cmd = cli::AddYieldsCommand(app, &yields);

  cli::ChartOptions chart;
  CLI::App* chart_cmd = cli::AddChartCommand(app, &chart);

  cli::MsaOptions msa;
  CLI::App* msa_cmd = cli::AddMsaCommand(app, &msa);

  cli::SyncOptions sync;
  CLI::App* sync_cmd = cli::AddSyncCommand(app, &sync);

  cli::KeygenOptions keygen;
  CLI::App* keygen_cmd = app.add_subcommand(
      "keygen",
      "make a station key (MACs on the bus) or, with --role, a role's signing key pair "
      "(signatures on the bus and on the archive's records)");
  keygen_cmd->add_option("--out", keygen.out, "key file to create (never overwritten; mode 0600)")
      ->required();
  keygen_cmd
      ->add_option("--role", keygen.role,
                   "acquire, analyze or store: a signing key pair (FILE and FILE.pub) instead of "
                   "the station key")
      ->check(CLI::IsMember({"acquire", "analyze", "store"}));
  keygen_cmd->footer(
      "Examples:\n  imuqual keygen --out station.key\n  imuqual keygen --role store --out "
      "store.key   # store.key and store.key.pub\n  cat acquire.key.pub analyze.key.pub "
      "store.key.pub > station.trust");

  offline::PlanSoakOptions soak;
  CLI::App* soak_cmd = app.add_subcommand(
      "plan-soak",
      "predict, by simulating records through the station's analysis, how long a plan with "
      "early_decision soaks a unit before deciding it, and the distribution over a lot");
  soak_cmd->add_option("--plan", soak.plan, "builtin:NAME or a plan .textproto with early_decision")
      ->required();
  soak_cmd->add_option("--model", soak.model,
                       "a typical unit's noise model: CSV axis,name,value,unit (model term "
                       "names and datasheet units, as the archive's model_* rows)");
  soak_cmd->add_option("--lot", soak.lot,
                       "a past lot whose units' noise models to use (with --db)");
  soak_cmd->add_option("--db", soak.db, "archive file of --lot");
  soak_cmd->add_option("--profile", soak.profile, "a simulator lot profile (e.g. vg700)");
  soak_cmd->add_option("--records", soak.records, "records to simulate")->capture_default_str();
  soak_cmd->add_option("--seed", soak.seed, "first seed")->capture_default_str();
  soak_cmd->add_option("--threads", soak.threads, "worker threads")->capture_default_str();

  cli::PlotOptions plot;
  CLI::App* plot_cmd = app.add_subcommand("plot",
                                          "SVG Allan deviation plots: one run (axes of a kind "
                                          "overlaid) or a lot (units overlaid per axis); "
                                          "--series: a run's raw samples against time");
  plot_cmd->add_option("--db", plot.db_path, "archive file")->required();
  plot_cmd->add_option("--run", plot.run_id,
                       "plot this run: its axes overlaid, one plot per axis kind");
  plot_cmd->add_option("--lot", plot.lot, "overlay every unit of this lot, one plot per axis");
  plot_cmd->add_option("--axis", plot.axis, "only this axis");
  plot_cmd->add_flag("--series", plot.series,
                     "with --run: the raw samples against time (rate per axis and temperature, "
                     "bin mean with its min/max envelope) instead of the Allan plots");
  plot_cmd
      ->add_option("-o,--output", plot.output,
                   "SVG file; several plots go to FILE-<kind or axis>.svg beside it; - for "
                   "standard output (one plot)")
      ->required();

  cli::ReportOptions report;
  CLI::App* report_cmd = app.add_subcommand("report", "self-contained HTML report of a lot");
  report_cmd->add_option("--db", report.db_path, "archive file")->required();
  report_cmd->add_option("--lot", report.lot, "lot name")->required();
  report_cmd->add_option("-o,--output", report.output, "HTML file to write; - for standard output")
      ->required();

  cli::ServeCommandOptions serve;
  CLI::App* serve_cmd = app.add_subcommand(
      "serve",
      "the archive in a browser: lots, lot reports, units, runs, JSON API, and with --bus the live "
      "station (read-only)");
  serve_cmd->add_option("--db", serve.db_path, "archive file")->required();
  serve_cmd->add_option("--listen", serve.listen, "ADDR:PORT, [IPV6]:PORT or PORT to listen on")
      ->capture_default_str();
  serve_cmd->add_option("--token", serve.token,
                        "required on a non-loopback address: Authorization: Bearer TOKEN or "
                        "?token=TOKEN (visible to local users in ps: prefer --token-file)");
  serve_cmd->add_option("--token-file", serve.token_file, "a file whose first line is the token");
  serve_cmd->add_flag("--new-token", serve.new_token,
                      "make a new random token and write it to --token-file (created 0600, "
                      "never overwritten)");
  serve_cmd->add_option("--tls-cert", serve.tls_cert,
                        "HTTPS: PEM certificate chain (with --tls-key; TLS 1.2 or 1.3)");
  serve_cmd->add_option("--tls-key", serve.tls_key, "HTTPS: the certificate's PEM private key");
  serve_cmd->add_flag("--insecure-http", serve.insecure_http,
                      "plain HTTP on a non-loopback address (the token crosses the network in "
                      "clear)");
  serve_cmd->add_option("--bus", serve.bus_url,
                        "a station's bus (the LCM URL its console shows): the live page /live");
  AddBusSecurityFlags(*serve_cmd, &serve.bus_security, /*signs=*/false, /*replays=*/false);

  // `imuqual help [COMMAND]` is `imuqual [COMMAND] --help` (git's and
  // cargo's habit).
  if (argc > 1 && std::string(argv[1]) == "help") {
    std::vector<char*> args = {argv[0]};
    if (argc > 2) {
      bool known = false;
      for (const CLI::App* sub : app.get_subcommands({}))
        known = known || sub->get_name() == argv[2];
      if (!known) {
        LogError(std::string("help: unknown command '") + argv[2] + "'; imuqual help lists them");
        return kExitUsage;
      }
      args.push_back(argv[2]);
    }
    static char help_flag[] = "--help";
    args.push_back(help_flag);
    return ParseCommandLine(app, static_cast<int>(args.size()), args.data()).value_or(kExitOk);
  }
  // A mistyped command is named, with the closest one, not "A subcommand is
  // required".
  if (argc > 1 && argv[1][0] != '-') {
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
    if (std::find(names.begin(), names.end(), argv[1]) == names.end()) {
      std::string message = "unknown command '";
      message += argv[1];
      message += "'";
      if (const std::string close = ClosestName(argv[1], names); !close.empty()) {
        message += " (did you mean '";
        message += close;
        message += "'?)";
      }
      message += "; imuqual --help lists them";
      LogError(message);
      return kExitUsage;
    }
  }
  if (const auto code = ParseCommandLine(app, argc, argv)) return *code;
  if (plot_cmd->parsed()) return cli::PlotCommand(plot);
  if (soak_cmd->parsed()) return offline::PlanSoakCommand(soak);
  if (report_cmd->parsed()) return cli::ReportCommand(report);
  if (serve_cmd->parsed()) return cli::ServeCommand(serve);
  if (reanalyze_cmd->parsed()) return offline::ReanalyzeCommand(re);
  if (verify_cmd->parsed()) return cli::VerifyCommand(verify);
  if (keygen_cmd->parsed()) return cli::KeygenCommand(keygen);
  if (sync_cmd->parsed()) return cli::SyncCommand(sync);
  if (msa_cmd->parsed()) return cli::MsaCommand(msa);
  if (chart_cmd->parsed()) return cli::ChartCommand(chart);
  if (yields_cmd->parsed()) return cli::YieldsCommand(yields);
  if (analyze_cmd->parsed()) {
    an.rate_given = analyze_cmd->count("--rate") > 0;
    return offline::AnalyzeFileCommand(an);
  }

  auto fmt = report::ParseFormat(format);
  if (!fmt.ok()) {
    LogError(fmt.status().message());
    return 2;
  }
  if (run_cmd->parsed()) {
    if (run_cmd->count("--rate") > 0) run.rate_hz = rate_hz;
    for (const std::string& spec : sign_keys) {
      const size_t eq = spec.find('=');
      const std::string role = spec.substr(0, eq);
      std::string* slot = role == "acquire"   ? &run.acquire_sign_key
                          : role == "analyze" ? &run.analyze_sign_key
                          : role == "store"   ? &run.store_sign_key
                                              : nullptr;
      if (eq == std::string::npos || slot == nullptr || eq + 1 == spec.size()) {
        LogError("--sign-key " + spec + ": must be ROLE=FILE with ROLE acquire, analyze or store");
        return 2;
      }
      *slot = spec.substr(eq + 1);
    }
    if (!station_file.empty()) {
      for (const char* flag : {"--sim", "--unit", "--lot", "--db", "--plan", "--duration", "--rate",
                               "--operator", "--lcm-url", "--station-id", "--profile",
                               "--key-file", "--trust", "--sign-key", "--insecure-bus",
                               "--sync-to"}) {
        if (run_cmd->count(flag) > 0) {
          LogError(std::string("--station ") + station_file +
                   " holds the station's setup: do not also give " + flag);
          return 2;
        }
      }
      std::vector<int> slot_lines;
      auto config = station::LoadStationConfig(station_file, &slot_lines);
      if (!config.ok()) {
        LogError(config.status().message());
        return 2;
      }
      station::StationRunOptions from_file =
          station::StationRunFromConfig(*config, station_file, slot_lines);
      // What the command line may still set: pacing, fault injection, patience, shards, report.
      if (run_cmd->count("--pace") > 0) from_file.pace = run.pace;
      if (run_cmd->count("--analyze-shards") > 0) from_file.analyze_shards = run.analyze_shards;
      if (run_cmd->count("--report") > 0) from_file.report_path = run.report_path;
      from_file.inject_drop = run.inject_drop;
      from_file.skip_failed_slots = run.skip_failed_slots;
      from_file.short_soak = run.short_soak;
      from_file.fail_exit = run.fail_exit;
      from_file.stall_timeout_s = run.stall_timeout_s;
      run = std::move(from_file);
    } else if (run.lot.empty() || run.db_path.empty()) {
      LogError(
          "run: give --station FILE, or --lot and --db (with --sim N and/or --unit SERIAL=SOURCE)");
      return 2;
    }
    InstallShutdownHandlers();
    run.show_progress = !quiet;
    return cli::RunCommand(run);
  }
  if (lots_cmd->parsed()) return cli::LotsCommand(db, *fmt);
  if (lot_cmd->parsed()) {
    if (lot_model) return cli::LotModelCommand(db, lot, *fmt);
    return stats ? cli::LotStatsCommand(db, lot, *fmt) : cli::LotCommand(db, lot, *fmt, all_runs);
  }
  if (compare_cmd->parsed()) return cli::CompareCommand(db, lot, lot_b, alpha, *fmt);
  if (unit_cmd->parsed()) return cli::UnitCommand(db, serial, *fmt);
  if (runs_cmd->parsed()) return cli::RunsCommand(db, run_filter, since, *fmt);
  if (export_cmd->parsed()) return cli::ExportCommand(ex);
  return 2;
}
