// Control charts from the archive: one judged measurement's values on each
// unit's final run, subgrouped by lot, ISO week or month (of the run's
// start, UTC), optionally one station's; and the chart as a table.
#ifndef IMUQUAL_REPORT_CONTROL_CHART_VIEW_H_
#define IMUQUAL_REPORT_CONTROL_CHART_VIEW_H_

#include <optional>
#include <string>
#include <vector>

#include "analyze/judge/control_chart.h"
#include "analyze/judge/statistics.h"
#include "report/table_writer.h"
#include "store/query.h"

namespace imuqual::report {

enum class ChartBy { kLot, kWeek, kMonth };
// "lot", "week", "month".
Result<ChartBy> ParseChartBy(const std::string& text);

// The subgroups of `rows` (oldest first: a lot by its first unit's start),
// only `station`'s runs when it is not "".
std::vector<judge::Subgroup> ChartSubgroups(const std::vector<store::RunValueRow>& rows,
                                            ChartBy by, const std::string& station);

// One plan's values: a chart mixes no two plans (their limits, and so
// each subgroup's capability, may differ), so Cpk history is per plan.
struct PlanChoice {
  std::string sha256, name;  // the plan charted
  size_t kept = 0;           // its values
  size_t left_out = 0;       // values of other plans
  size_t other_plans = 0;
};
// Keeps the rows judged by `plan`: a plan name or a prefix of its digest
// (at least 8 hex digits), or "" for the plan of the newest row. NotFound
// names the plans there are when none matches; InvalidArgument when a name
// matches plans of two digests.
Result<PlanChoice> KeepOnePlan(store::Archive& archive, const std::string& plan,
                               std::vector<store::RunValueRow>* rows);

// "2026-W48" (ISO 8601 week of the UTC date) and "2026-11".
std::string IsoWeekLabel(int64_t utime);
std::string MonthLabel(int64_t utime);

// A row per subgroup: n, mean with its limits, sd with its limits, the
// rules it completes, and its process capability against the measurement's
// limits (Cpk, Cpu or Cpl with its 95 % interval, judge::Summarize; none
// from fewer than 10 values): the capability history.
TableWriter ControlChartTable(const judge::ControlChart& chart,
                              const std::vector<judge::Subgroup>& subgroups,
                              std::optional<double> low, std::optional<double> high);

// The X-bar chart drawn (SVG, linear axes): each subgroup's mean joined by
// a line, its control limits as steps (they depend on its n), the centre
// line, the plan's limit when it is in range, and the subgroups that
// complete a rule ringed in red and named in their tooltip. `title` names
// the measurement, axis and unit.
std::string ControlChartSvg(const judge::ControlChart& chart, const std::string& title,
                            std::optional<double> low, std::optional<double> high);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_CONTROL_CHART_VIEW_H_
