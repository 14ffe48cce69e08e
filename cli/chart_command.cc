#include "cli/chart_command.h"

#include <cstdio>

#include "common/command_line.h"
#include "common/log.h"
#include "common/strings.h"
#include "report/control_chart_view.h"
#include "store/archive.h"
#include "store/query.h"

namespace imuqual::cli {
namespace {
constexpr int kExitFailed = 1, kExitUsage = 2, kExitFlagged = 3;
}  // namespace

CLI::App* AddChartCommand(CLI::App& app, ChartOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "chart",
      "a control chart (X-bar and S) of one judged measurement across lots, weeks or months, "
      "with its limits, the run rules flagged and each subgroup's Cpk against the plan's limits");
  cmd->add_option("--db", o->db_path, "archive file or postgresql://... (the plant)")->required();
  cmd->add_option("--measurement", o->measurement, "e.g. bias_instability")->required();
  cmd->add_option("--axis", o->axis, "e.g. gx ('' for run-level values)")->required();
  cmd->add_option("--by", o->by, "subgroups: lot, week or month (ISO week, UTC)")
      ->capture_default_str();
  cmd->add_option("--station", o->station, "one station's runs only");
  cmd->add_option("--plan", o->plan,
                  "the plan whose values are charted: its name or a digest prefix (default: the "
                  "newest run's plan; a chart never mixes plans, so capability is per plan)");
  cmd->add_option("--baseline", o->baseline,
                  "the limits from the first N subgroups (a reference period; later ones are "
                  "judged against it); default: from all (a retrospective chart)")
      ->check(CLI::Range(2, 1000000));
  cmd->add_option("--format", o->format, "table, csv or json")->capture_default_str();
  cmd->footer(
      "Each unit counts once per lot, by its final judged run. Limits: the grand mean +- 3 "
      "sigma / sqrt(n) (X-bar), sigma (c4 +- 3 sqrt(1 - c4^2)) (S), sigma from the pooled "
      "within-subgroup spread. Run rules (X-bar): beyond 3 sigma, 2 of 3 beyond 2 sigma, 4 of 5 "
      "beyond 1 sigma (same side), 8 on one side, 6 trending; (S) beyond 3 sigma.\n"
      "Exit 0 in control, 3 a rule flagged, 1 the archive could not be read, 2 usage.\n"
      "Example:\n  imuqual chart --db plant-url --measurement bias_instability --axis gx --by week");
  return cmd;
}

int ChartCommand(const ChartOptions& o) {
  auto format = report::ParseFormat(o.format);
  auto by = report::ParseChartBy(o.by);
  for (const Status& st : {format.status(), by.status()}) {
    if (!st.ok()) {
      LogError(st.message());
      return kExitUsage;
    }
  }
  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto rows = store::QueryMeasurementHistory(**archive, o.measurement, o.axis);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitFailed;
  }
  auto plan = report::KeepOnePlan(**archive, o.plan, &*rows);
  if (!plan.ok()) {
    LogError(plan.status().message());
    return kExitUsage;
  }
  const std::vector<judge::Subgroup> groups = report::ChartSubgroups(*rows, *by, o.station);
  auto chart = judge::MakeControlChart(groups, o.baseline);
  if (!chart.ok()) {
    LogError(o.measurement + (o.axis.empty() ? "" : " on " + o.axis) +
             (o.station.empty() ? "" : " at " + o.station) + " in " + (*archive)->path() + ": " +
             (rows->empty() ? "no judged value" : chart.status().message()));
    return kExitUsage;
  }
  const std::string unit = rows->empty() ? "" : rows->front().value_unit;
  if (*format == report::Format::kTable) {
    std::printf("%s%s (%s) by %s%s: centre %s, sigma %s (within subgroups; limits from %d of "
                "%zu subgroups), %d values, %d subgroups flagged\n",
                o.measurement.c_str(), o.axis.empty() ? "" : (" " + o.axis).c_str(), unit.c_str(),
                o.by.c_str(), o.station.empty() ? "" : (" at " + o.station).c_str(),
                ShortestReal(chart->centre).c_str(), ShortestReal(chart->sigma).c_str(),
                chart->baseline, chart->points.size(), chart->values, chart->flagged);
    std::printf("plan %s (%s)%s\n", plan->name.c_str(), plan->sha256.substr(0, 12).c_str(),
                plan->left_out == 0
                    ? ""
                    : ("; " + std::to_string(plan->left_out) + " values of " +
                       std::to_string(plan->other_plans) + " other plan(s) not charted (--plan)")
                          .c_str());
  }
  const std::optional<double> low = rows->empty() ? std::nullopt : rows->front().low;
  const std::optional<double> high = rows->empty() ? std::nullopt : rows->front().high;
  std::printf("%s", report::ControlChartTable(*chart, groups, low, high).Render(*format).c_str());
  return chart->flagged > 0 ? kExitFlagged : 0;
}

}  // namespace imuqual::cli
