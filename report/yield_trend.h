// Yields over time and across stations: each unit of each lot counted once,
// in the group of its first run (the week or month it started, UTC; the
// station it was first tested on; its lot): its first judged run for the
// first-pass yield, its final run (its latest judged run, else its latest:
// store/SCHEMA.md, Yields) for the final yield; each yield with its 95 %
// Wilson score interval.
#ifndef IMUQUAL_REPORT_YIELD_TREND_H_
#define IMUQUAL_REPORT_YIELD_TREND_H_

#include <string>
#include <vector>

#include "common/status.h"
#include "report/table_writer.h"
#include "store/query.h"

namespace imuqual::report {

enum class YieldBy { kWeek, kMonth, kStation, kLot };
Result<YieldBy> ParseYieldBy(const std::string& text);  // week, month, station, lot

struct YieldRow {
  std::string group;
  int64_t units = 0, runs = 0;
  int64_t pass = 0, marginal = 0, fail = 0, inconclusive = 0, other = 0;  // by final run
  int64_t first_judged = 0, first_passed = 0;  // units with a judged run; of them, passed first
  double first_pass_yield = allan::kNaN, first_pass_low = allan::kNaN, first_pass_high = allan::kNaN;
  double final_yield = allan::kNaN, final_low = allan::kNaN, final_high = allan::kNaN;
};

// Groups in order of their first unit (stations and lots by name).
std::vector<YieldRow> YieldTrend(const std::vector<store::RunVerdictRow>& runs, YieldBy by);

// Wilson's 95 % score interval of k successes in n (NaN for n = 0).
void WilsonInterval(int64_t k, int64_t n, double* low, double* high);

TableWriter YieldTable(const std::vector<YieldRow>& rows);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_YIELD_TREND_H_
