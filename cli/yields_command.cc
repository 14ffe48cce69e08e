#include "cli/yields_command.h"

#include <cstdio>

#include "common/command_line.h"
#include "common/log.h"
#include "report/yield_trend.h"
#include "store/archive.h"
#include "store/query.h"

namespace imuqual::cli {

CLI::App* AddYieldsCommand(CLI::App& app, YieldsOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "yields", "first-pass and final yields per week, month, station or lot, with 95 % intervals");
  cmd->add_option("--db", o->db_path, "archive file or postgresql://... (the plant)")->required();
  cmd->add_option("--by", o->by, "week (ISO, UTC), month, station or lot")->capture_default_str();
  cmd->add_option("--format", o->format, "table, csv or json")->capture_default_str();
  cmd->footer(
      "Each unit of each lot counts once, in the group of its first run: first-pass yield = "
      "units whose first judged run is PASS or MARGINAL / units with a judged run; final yield = "
      "units whose final run (latest judged, else latest) is PASS or MARGINAL / PASS, MARGINAL "
      "or FAIL (INCONCLUSIVE, ABORTED, ERROR and unjudged are neither). Intervals: Wilson's "
      "score, 95 %.\nExample:\n  imuqual yields --db plant-url --by station");
  return cmd;
}

int YieldsCommand(const YieldsOptions& o) {
  auto format = report::ParseFormat(o.format);
  auto by = report::ParseYieldBy(o.by);
  for (const Status& st : {format.status(), by.status()}) {
    if (!st.ok()) {
      LogError(st.message());
      return 2;
    }
  }
  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto runs = store::QueryRunVerdicts(**archive);
  if (!runs.ok()) {
    LogError(runs.status().message());
    return 1;
  }
  if (runs->empty()) {
    LogError("no run in " + (*archive)->path());
    return 2;
  }
  std::printf("%s", report::YieldTable(report::YieldTrend(*runs, *by)).Render(*format).c_str());
  return 0;
}

}  // namespace imuqual::cli
