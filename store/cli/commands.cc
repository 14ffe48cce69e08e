#include "store/cli/commands.h"

#include <cstdio>
#include <map>

#include "common/clock.h"
#include "common/log.h"
#include "common/text_util.h"
#include "store/cli/report.h"
#include "store/query.h"

namespace imuqual::cli {
namespace {

constexpr int kExitError = 1;
constexpr int kExitUsage = 2;

double Pick(bool take, double v) { return take ? v : allan::kNaN; }

// The machine-readable per-axis table (CSV/JSON): one column per quantity
// and unit, so gyro and accelerometer rows never share a column.
TableWriter MachineTable(const std::vector<store::AxisRow>& rows) {
  TableWriter t({"lot", "unit", "run_id", "axis", "kind", "arw_deg_rt_hr", "vrw_m_s_rt_hr",
                 "bias_instability_deg_hr", "bias_instability_ieee_deg_hr", "bias_instability_ug",
                 "bias_instability_ieee_ug", "tau_min_s", "rrw_deg_hr_rt_hr", "rrw_ug_rt_hr",
                 "samples", "gap_samples", "invalid_samples", "verdict", "run_verdict", "state"});
  for (const store::AxisRow& r : rows) {
    const bool gyro = r.kind != "accel";
    t.AddRow({Cell::Text(r.lot), Cell::Text(r.unit), Cell::Text(r.run_id), Cell::Text(r.axis),
              Cell::Text(r.kind), Cell::Real(Pick(gyro, r.random_walk)),
              Cell::Real(Pick(!gyro, r.random_walk)), Cell::Real(Pick(gyro, r.bias_instability)),
              Cell::Real(Pick(gyro, r.bias_instability_ieee)),
              Cell::Real(Pick(!gyro, r.bias_instability)),
              Cell::Real(Pick(!gyro, r.bias_instability_ieee)), Cell::Real(r.tau_min_s),
              Cell::Real(Pick(gyro, r.rate_random_walk)), Cell::Real(Pick(!gyro, r.rate_random_walk)),
              Cell::Int(r.samples), Cell::Int(r.gap_samples), Cell::Int(r.invalid_samples),
              Cell::Text(r.axis_verdict), Cell::Text(r.run_verdict), Cell::Text(r.state)});
  }
  return t;
}

// The table people read.
std::string PeopleTable(const std::vector<store::AxisRow>& rows) {
  TableWriter t({"unit", "axis", "ARW/VRW", "bias inst.", "BI (IEEE)", "tau min s", "RRW",
                 "gap samples", "axis", "unit verdict"});
  bool any_accel = false;
  for (const store::AxisRow& r : rows) {
    any_accel |= r.kind == "accel";
    t.AddRow({Cell::Text(r.unit), Cell::Text(r.axis), Cell::Real(r.random_walk),
              Cell::Real(r.bias_instability), Cell::Real(r.bias_instability_ieee),
              Cell::Real(r.tau_min_s), Cell::Real(r.rate_random_walk), Cell::Int(r.gap_samples),
              Cell::Text(r.axis_verdict.empty() ? "-" : r.axis_verdict),
              Cell::Text(r.run_verdict.empty() ? "-" : r.run_verdict)});
  }
  std::string out = t.Render(Format::kTable);
  out += "gyro units: ARW deg/sqrt(h), bias instability deg/h (curve minimum; IEEE B = minimum/0.664), "
         "RRW deg/h/sqrt(h)\n";
  if (any_accel) {
    out += "accel units: VRW m/s/sqrt(h), bias instability ug (curve minimum; IEEE B = minimum/0.664), "
           "RRW ug/sqrt(h)\n";
  }
  return out;
}

Result<std::unique_ptr<store::Archive>> OpenForReading(const std::string& db_path) {
  return store::Archive::Open(db_path, store::Archive::Mode::kRead);
}

}  // namespace

int RunCommand(const StationRunOptions& options) {
  auto run = RunStation(options);
  if (!run.ok()) {
    LogError(run.status().message());
    // Bad options, plan, source or archive file: refused before any run.
    if (run.status().code() == Status::Code::kIoError) return kRunExitArchiveUnwritable;
    return run.status().code() == Status::Code::kInvalidArgument ? kRunExitUsage : kRunExitError;
  }
  auto archive = OpenForReading(options.db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return kRunExitError;
  }
  store::AxisRowFilter filter;
  filter.lot = options.lot;
  filter.run_prefix = run->run_prefix + "-";
  filter.latest_per_unit = false;
  auto rows = store::QueryAxisRows(**archive, filter);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kRunExitError;
  }
  std::printf("%s", PeopleTable(*rows).c_str());
  std::map<std::string, std::string> unit_of;
  std::map<std::string, int> verdicts;
  for (const store::AxisRow& r : *rows) {
    if (unit_of.emplace(r.run_id, r.unit).second) ++verdicts[r.run_verdict.empty() ? "-" : r.run_verdict];
  }
  auto reasons = store::QueryReasons(**archive, run->run_ids);
  if (reasons.ok() && !reasons->empty()) {
    std::printf("\nreasons:\n");
    for (const auto& [run_id, text] : *reasons) {
      size_t start = 0;
      while (start < text.size()) {
        const size_t end = text.find('\n', start);
        std::printf("  %s: %s\n", unit_of[run_id].c_str(),
                    text.substr(start, end - start).c_str());
        if (end == std::string::npos) break;
        start = end + 1;
      }
    }
  }
  std::printf("\n%zu units: %d PASS, %d MARGINAL, %d FAIL%s%s\n", unit_of.size(), verdicts["PASS"],
              verdicts["MARGINAL"], verdicts["FAIL"],
              verdicts["-"] > 0 ? (", " + std::to_string(verdicts["-"]) + " not judged (no limits)").c_str()
                                : "",
              run->interrupted ? " (interrupted: runs aborted)" : "");
  std::printf("lot %s archived in %s (runs %s-*; process log %s)\n", options.lot.c_str(),
              options.db_path.c_str(), run->run_prefix.c_str(), run->log_path.c_str());
  if (run->restarts > 0) {
    std::printf("store/analyze restarted %d time(s) during the soak; see the process log\n", run->restarts);
  }
  if (!run->run_ids.empty()) {
    std::string report = options.report_path;
    if (report.empty()) {
      const std::string& db = options.db_path;
      const bool dot_db = db.size() > 3 && db.compare(db.size() - 3, 3, ".db") == 0;
      report = (dot_db ? db.substr(0, db.size() - 3) : db) + "-" + options.lot + ".html";
    }
    auto html = BuildLotReportHtml(**archive, options.lot, options.db_path);
    const Status st = html.ok() ? WriteStringToFile(report, *html) : html.status();
    if (st.ok()) {
      std::printf("report: %s\n", report.c_str());
    } else {
      LogError("report not written: " + st.message());
    }
  }
  if (!run->failure.empty()) {
    LogError(run->failure);
    return kRunExitSourceFailed;
  }
  return run->interrupted ? kRunExitInterrupted : kRunExitOk;
}

int LotsCommand(const std::string& db_path, Format format) {
  auto archive = OpenForReading(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return kExitError;
  }
  auto lots = store::QueryLots(**archive);
  if (!lots.ok()) {
    LogError(lots.status().message());
    return kExitError;
  }
  TableWriter t({"lot", "runs", "units", "pass", "marginal", "fail", "unjudged", "yield",
                 "first_start", "last_start"});
  for (const store::LotRow& l : *lots) {
    t.AddRow({Cell::Text(l.lot), Cell::Int(l.runs), Cell::Int(l.units), Cell::Int(l.pass),
              Cell::Int(l.marginal), Cell::Int(l.fail), Cell::Int(l.unjudged), Cell::Real(l.yield),
              Cell::Text(FormatUtimeIso(l.first_start_utime)),
              Cell::Text(FormatUtimeIso(l.last_start_utime))});
  }
  std::printf("%s", t.Render(format).c_str());
  return 0;
}

int LotCommand(const std::string& db_path, const std::string& lot, Format format, bool all_runs) {
  auto archive = OpenForReading(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return kExitError;
  }
  store::AxisRowFilter filter;
  filter.lot = lot;
  filter.latest_per_unit = !all_runs;
  auto rows = store::QueryAxisRows(**archive, filter);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitError;
  }
  if (rows->empty()) {
    LogError("no lot '" + lot + "' in " + db_path + " (imuqual lots lists them)");
    return kExitUsage;
  }
  if (format == Format::kTable) {
    std::printf("%s", PeopleTable(*rows).c_str());
  } else {
    std::printf("%s", MachineTable(*rows).Render(format).c_str());
  }
  return 0;
}

}  // namespace imuqual::cli
