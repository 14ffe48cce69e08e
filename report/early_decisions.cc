#include "report/early_decisions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "analyze/judge/early_decision.h"
#include "analyze/judge/measurements.h"
#include "store/query.h"

namespace imuqual::report {

Result<EarlyDecisionSummary> QueryEarlyDecisions(store::Archive& archive, const std::string& lot,
                                                 const std::string& run_prefix) {
  auto found = store::QueryDecisionTimes(archive, lot, run_prefix);
  if (!found.ok()) return found.status();
  EarlyDecisionSummary out;
  std::vector<double> ratios;
  for (store::DecisionTimeRow& row : *found) {
    DecidedRun r;
    r.unit = std::move(row.unit);
    r.run_id = std::move(row.run_id);
    r.verdict = std::move(row.verdict);
    r.start_utime = row.start_utime;
    pb::TestPlan plan;
    if (!plan.ParseFromString(row.plan) || !plan.has_early_decision()) {
      return Status::Corruption(
          "run " + r.run_id + ": has a decision time, but its archived plan has no early_decision");
    }
    r.horizon_s = judge::MakeLookSchedule(plan).horizon_s;
    r.decision_time_s = row.decision_time_s;
    r.note = std::move(row.note);
    const bool decided = std::isfinite(r.decision_time_s);
    out.decided += decided;
    out.horizon_total_s += r.horizon_s;
    if (decided) out.saved_s += std::max(0.0, r.horizon_s - r.decision_time_s);
    ratios.push_back(decided && r.horizon_s > 0 ? r.decision_time_s / r.horizon_s : 1.0);
    out.runs.push_back(std::move(r));
  }
  if (!ratios.empty()) {
    std::sort(ratios.begin(), ratios.end());
    const size_t n = ratios.size();
    out.median_ratio = n % 2 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
  }
  return out;
}

std::string DecisionTimeText(double seconds) {
  if (std::isnan(seconds)) return "full soak";
  const long s = std::lround(std::max(0.0, seconds));
  char buf[32];
  if (s < 60) {
    std::snprintf(buf, sizeof buf, "%lds", s);
  } else if (s < 3600) {
    if (s % 60 == 0) {
      std::snprintf(buf, sizeof buf, "%ldm", s / 60);
    } else {
      std::snprintf(buf, sizeof buf, "%ldm%02lds", s / 60, s % 60);
    }
  } else {
    const long m = std::lround(static_cast<double>(s) / 60.0);
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", m / 60, m % 60);
  }
  return buf;
}

std::string EarlyDecisionLine(const EarlyDecisionSummary& s) {
  if (s.runs.empty()) return "";
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "early decisions: %d of %zu runs decided; soak time saved %g s (%s) of %g s "
      "(%.0f %%); median decided / full soak %.2f",
      s.decided, s.runs.size(), s.saved_s, DecisionTimeText(s.saved_s).c_str(), s.horizon_total_s,
      s.horizon_total_s > 0 ? 100.0 * s.saved_s / s.horizon_total_s : 0.0, s.median_ratio);
  return buf;
}

TableWriter LooksTable(const std::vector<judge::Look>& looks) {
  TableWriter t({"look", "time_s", "z_bound", "axis", "measurement", "value", "uncertainty",
                 "decision", "why"});
  for (const judge::Look& look : looks) {
    for (const judge::LookEntry& e : look.entries) {
      t.AddRow({Cell::Int(look.index + 1), Cell::Real(look.time_s), Cell::Real(look.z),
                Cell::Text(e.axis), Cell::Text(e.name), Cell::Real(e.value),
                Cell::Real(e.uncertainty), Cell::Text(judge::DecisionName(e.decision)),
                Cell::Text(e.why)});
    }
    t.AddRow({Cell::Int(look.index + 1), Cell::Real(look.time_s), Cell::Real(look.z),
              Cell::Text("*"), Cell::Text("unit"), Cell::Real(allan::kNaN), Cell::Real(allan::kNaN),
              Cell::Text(judge::DecisionName(look.unit)), Cell::Text(look.note)});
  }
  return t;
}

}  // namespace imuqual::report
