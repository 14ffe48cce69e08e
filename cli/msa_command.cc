#include "cli/msa_command.h"

#include <cstdio>

#include "common/command_line.h"
#include "common/log.h"
#include "store/archive.h"
#include "store/query.h"

namespace imuqual::cli {
namespace {
constexpr int kExitFailed = 1, kExitUsage = 2, kExitDisagree = 3;
}  // namespace

CLI::App* AddMsaCommand(CLI::App& app, MsaOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "msa",
      "do the stations agree? a lot of golden units soaked on every station: repeatability, "
      "reproducibility, %GRR and ndc per judged measurement (AIAG ANOVA method), and each "
      "station's offset from the fleet with its 95 % interval");
  cmd->add_option("--db", o->db_path, "archive file or postgresql://... (the plant)")->required();
  cmd->add_option("--lot", o->lot, "the golden units' lot")->required();
  cmd->add_option("--measurement", o->selection.measurement,
                  "one measurement (default: every measurement with a limit)");
  cmd->add_option("--axis", o->selection.axis, "one axis (default: every axis)");
  cmd->add_option("--trials", o->selection.trials,
                  "soaks of each unit on each station to use, oldest first (default: as many as "
                  "every unit has on every station)")
      ->check(CLI::Range(2, 1000));
  cmd->add_option("--by", o->by,
                  "the appraisers: station (between stations), operator (between operators) or "
                  "station-operator (each pair)")
      ->capture_default_str();
  cmd->add_option("--format", o->format, "table, csv or json")->capture_default_str();
  cmd->footer(
      "Each golden unit is a part, each station (or operator: --by) an appraiser, each judged soak a trial; the "
      "study must be balanced (every unit on every station, the same number of soaks). "
      "%GRR against the tolerance: 6 GRR / (USL - LSL), or with one limit 3 GRR / |limit - "
      "mean|; < 10 % acceptable, 10-30 % may be acceptable, > 30 % unacceptable. An interaction "
      "with p > 0.25 is pooled into repeatability (AIAG).\n"
      "Exit 0 the stations agree, 3 a station's offset interval excludes 0 or a study is "
      "unacceptable, 1 the archive could not be read, 2 usage or no study possible.\n"
      "Example:\n  imuqual msa --db 'postgresql://imuqual_read@plant-db/imuqual' --lot GOLDEN-2026 "
      "--measurement bias_instability");
  return cmd;
}

int MsaCommand(const MsaOptions& options) {
  MsaOptions o = options;
  auto format = report::ParseFormat(o.format);
  auto by = report::ParseAppraiser(o.by);
  for (const Status& st : {format.status(), by.status()}) {
    if (!st.ok()) {
      LogError(st.message());
      return kExitUsage;
    }
  }
  o.selection.appraiser = *by;
  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto rows = store::QueryRunValues(**archive, o.lot);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitFailed;
  }
  if (rows->empty()) {
    LogError("no judged run of lot '" + o.lot + "' in " + (*archive)->path());
    return kExitUsage;
  }
  const std::vector<report::MsaOutcome> outcomes = report::StudyStations(*rows, o.selection);
  if (outcomes.empty()) {
    LogError("lot '" + o.lot + "' has no " +
             (o.selection.measurement.empty() ? std::string("measurement with a limit")
                                              : "measurement " + o.selection.measurement) +
             (o.selection.axis.empty() ? "" : " on axis " + o.selection.axis));
    return kExitUsage;
  }
  bool analysed = false, disagree = false;
  for (const report::MsaOutcome& out : outcomes) {
    if (!out.why_not.empty()) continue;
    analysed = true;
    disagree = disagree || out.result.verdict == "unacceptable";
    for (const judge::StationOffset& s : out.result.offsets) disagree = disagree || s.differs;
  }
  const report::TableWriter studies = report::MsaTable(outcomes, *by);
  const report::TableWriter offsets = report::MsaOffsetsTable(outcomes, *by);
  if (*format == report::Format::kJson) {
    std::printf("{\"studies\": %s, \"offsets\": %s}\n",
                studies.Render(*format).c_str(), offsets.Render(*format).c_str());
  } else {
    std::printf("%s", studies.Render(*format).c_str());
    if (*format == report::Format::kTable) std::printf("\nstation offsets from the fleet:\n");
    if (*format == report::Format::kCsv) std::printf("\n");
    std::printf("%s", offsets.Render(*format).c_str());
  }
  if (!analysed) {
    LogError("no study possible: " + outcomes.front().why_not);
    return kExitUsage;
  }
  return disagree ? kExitDisagree : 0;
}

}  // namespace imuqual::cli
