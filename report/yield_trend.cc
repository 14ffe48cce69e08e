#include "report/yield_trend.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "report/control_chart_view.h"

namespace imuqual::report {
namespace {

bool Judged(const std::string& v) {
  return v == "PASS" || v == "MARGINAL" || v == "FAIL" || v == "INCONCLUSIVE";
}

}  // namespace

Result<YieldBy> ParseYieldBy(const std::string& text) {
  if (text == "week") return YieldBy::kWeek;
  if (text == "month") return YieldBy::kMonth;
  if (text == "station") return YieldBy::kStation;
  if (text == "lot") return YieldBy::kLot;
  return Status::InvalidArgument("--by " + text + ": week, month, station or lot");
}

void WilsonInterval(int64_t k, int64_t n, double* low, double* high) {
  if (n <= 0) {
    *low = *high = allan::kNaN;
    return;
  }
  constexpr double z = 1.959963984540054;
  const double N = static_cast<double>(n), p = static_cast<double>(k) / N;
  const double centre = (p + z * z / (2 * N)) / (1 + z * z / N);
  const double half = z * std::sqrt(p * (1 - p) / N + z * z / (4 * N * N)) / (1 + z * z / N);
  *low = std::max(0.0, centre - half);
  *high = std::min(1.0, centre + half);
}

std::vector<YieldRow> YieldTrend(const std::vector<store::RunVerdictRow>& runs, YieldBy by) {
  // The runs of each unit of each lot, oldest first (runs come so).
  std::map<std::pair<std::string, std::string>, std::vector<const store::RunVerdictRow*>> units;
  std::vector<std::pair<std::string, std::string>> order;
  for (const store::RunVerdictRow& r : runs) {
    auto& list = units[{r.lot, r.unit}];
    if (list.empty()) order.push_back({r.lot, r.unit});
    list.push_back(&r);
  }
  std::vector<YieldRow> rows;
  std::map<std::string, size_t> index;
  for (const auto& key : order) {
    const auto& list = units[key];
    const store::RunVerdictRow* first_judged = nullptr;
    const store::RunVerdictRow* final = list.back();
    for (const store::RunVerdictRow* r : list) {
      if (Judged(r->verdict)) {
        if (!first_judged) first_judged = r;
        final = r;  // the latest judged
      }
    }
    const store::RunVerdictRow& first = *list.front();
    const std::string group = by == YieldBy::kWeek    ? IsoWeekLabel(first.start_utime)
                              : by == YieldBy::kMonth ? MonthLabel(first.start_utime)
                              : by == YieldBy::kStation ? first.station
                                                        : first.lot;
    auto it = index.find(group);
    if (it == index.end()) {
      it = index.emplace(group, rows.size()).first;
      rows.push_back({});
      rows.back().group = group;
    }
    YieldRow& y = rows[it->second];
    ++y.units;
    y.runs += static_cast<int64_t>(list.size());
    const std::string& v = final->verdict;
    (v == "PASS"           ? y.pass
     : v == "MARGINAL"     ? y.marginal
     : v == "FAIL"         ? y.fail
     : v == "INCONCLUSIVE" ? y.inconclusive
                           : y.other) += 1;
    if (first_judged) {
      ++y.first_judged;
      y.first_passed += first_judged->verdict == "PASS" || first_judged->verdict == "MARGINAL";
    }
  }
  for (YieldRow& y : rows) {
    const int64_t judged = y.pass + y.marginal + y.fail;
    if (judged > 0) y.final_yield = static_cast<double>(y.pass + y.marginal) / judged;
    WilsonInterval(y.pass + y.marginal, judged, &y.final_low, &y.final_high);
    if (y.first_judged > 0) {
      y.first_pass_yield = static_cast<double>(y.first_passed) / y.first_judged;
    }
    WilsonInterval(y.first_passed, y.first_judged, &y.first_pass_low, &y.first_pass_high);
  }
  if (by == YieldBy::kStation || by == YieldBy::kLot) {
    std::sort(rows.begin(), rows.end(),
              [](const YieldRow& a, const YieldRow& b) { return a.group < b.group; });
  }
  return rows;
}

TableWriter YieldTable(const std::vector<YieldRow>& rows) {
  TableWriter t({"group", "units", "runs", "pass", "marginal", "fail", "inconclusive", "other",
                 "first_pass_yield", "first_pass_low_95", "first_pass_high_95", "final_yield",
                 "final_low_95", "final_high_95"});
  for (const YieldRow& y : rows) {
    t.AddRow({Cell::Text(y.group), Cell::Int(y.units), Cell::Int(y.runs), Cell::Int(y.pass),
              Cell::Int(y.marginal), Cell::Int(y.fail), Cell::Int(y.inconclusive),
              Cell::Int(y.other), Cell::Real(y.first_pass_yield), Cell::Real(y.first_pass_low),
              Cell::Real(y.first_pass_high), Cell::Real(y.final_yield), Cell::Real(y.final_low),
              Cell::Real(y.final_high)});
  }
  return t;
}

}  // namespace imuqual::report
