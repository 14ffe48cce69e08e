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

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_CONTROL_CHART_VIEW_H_
