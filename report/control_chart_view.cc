#include "report/control_chart_view.h"

#include <ctime>
#include <map>
#include <set>

namespace imuqual::report {

Result<ChartBy> ParseChartBy(const std::string& text) {
  if (text == "lot") return ChartBy::kLot;
  if (text == "week") return ChartBy::kWeek;
  if (text == "month") return ChartBy::kMonth;
  return Status::InvalidArgument("--by " + text + ": lot, week or month");
}

namespace {
// The UTC date of `utime` (us) through strftime's `format`.
std::string UtcLabel(int64_t utime, const char* format) {
  const std::time_t t = static_cast<std::time_t>(utime / 1'000'000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}
}  // namespace

std::string IsoWeekLabel(int64_t utime) { return UtcLabel(utime, "%G-W%V"); }
std::string MonthLabel(int64_t utime) { return UtcLabel(utime, "%Y-%m"); }

Result<PlanChoice> KeepOnePlan(store::Archive& archive, const std::string& plan,
                               std::vector<store::RunValueRow>* rows) {
  // Each digest's plan name, read once.
  std::map<std::string, std::string> names;
  for (const store::RunValueRow& r : *rows) {
    if (names.count(r.plan_sha256)) continue;
    std::string name = "(no plan recorded)";
    if (!r.plan_sha256.empty()) {
      auto bytes = store::QueryPlanByDigest(archive, r.plan_sha256);
      if (!bytes.ok()) return bytes.status();
      pb::TestPlan p;
      name = p.ParseFromString(*bytes) && !p.name().empty() ? p.name() : "(unnamed plan)";
    }
    names[r.plan_sha256] = name;
  }
  PlanChoice choice;
  if (rows->empty()) return choice;
  if (plan.empty()) {
    choice.sha256 = rows->back().plan_sha256;  // oldest first: the newest run's plan
  } else {
    std::set<std::string> matches;
    for (const auto& [sha, name] : names) {
      const bool by_digest = plan.size() >= 8 && sha.compare(0, plan.size(), plan) == 0;
      if (name == plan || by_digest) matches.insert(sha);
    }
    if (matches.empty()) {
      std::string there;
      for (const auto& [sha, name] : names) {
        there += (there.empty() ? "" : ", ") + name + " (" + sha.substr(0, 12) + ")";
      }
      return Status::NotFound("no value judged by plan '" + plan + "'; plans here: " + there);
    }
    if (matches.size() > 1) {
      return Status::InvalidArgument("plan '" + plan + "' names " +
                                     std::to_string(matches.size()) +
                                     " plans of different digests: give a digest prefix");
    }
    choice.sha256 = *matches.begin();
  }
  choice.name = names[choice.sha256];
  choice.other_plans = names.size() - 1;
  std::vector<store::RunValueRow> kept;
  for (store::RunValueRow& r : *rows) {
    if (r.plan_sha256 == choice.sha256) kept.push_back(std::move(r));
  }
  choice.kept = kept.size();
  choice.left_out = rows->size() - kept.size();
  *rows = std::move(kept);
  return choice;
}

std::vector<judge::Subgroup> ChartSubgroups(const std::vector<store::RunValueRow>& rows, ChartBy by,
                                            const std::string& station) {
  std::vector<judge::Subgroup> groups;
  std::map<std::string, size_t> index;  // label -> position (first seen, rows oldest first)
  for (const store::RunValueRow& r : rows) {
    if (!station.empty() && r.station != station) continue;
    if (!std::isfinite(r.value)) continue;
    const std::string label = by == ChartBy::kLot    ? r.lot
                              : by == ChartBy::kWeek ? IsoWeekLabel(r.start_utime)
                                                     : MonthLabel(r.start_utime);
    auto it = index.find(label);
    if (it == index.end()) {
      it = index.emplace(label, groups.size()).first;
      groups.push_back({label, {}});
    }
    groups[it->second].values.push_back(r.value);
  }
  return groups;
}

TableWriter ControlChartTable(const judge::ControlChart& c,
                              const std::vector<judge::Subgroup>& subgroups,
                              std::optional<double> low, std::optional<double> high) {
  TableWriter t({"subgroup", "n", "mean", "mean_lcl", "mean_ucl", "sd", "sd_lcl", "sd_ucl",
                 "rules", "capability_kind", "capability", "capability_low_95",
                 "capability_high_95"});
  for (size_t i = 0; i < c.points.size(); ++i) {
    const judge::ChartPoint& p = c.points[i];
    const judge::Summary cap = i < subgroups.size()
                                   ? judge::Summarize(subgroups[i].values, {}, low, high)
                                   : judge::Summary();
    std::string rules;
    for (const std::string& r : p.mean_rules) rules += (rules.empty() ? "mean: " : "; ") + r;
    for (const std::string& r : p.sd_rules) rules += (rules.empty() ? "" : "; ") + ("sd: " + r);
    t.AddRow({Cell::Text(p.label), Cell::Int(p.n), Cell::Real(p.mean), Cell::Real(p.mean_lcl),
              Cell::Real(p.mean_ucl), Cell::Real(p.sd),
              Cell::Real(p.n >= 2 ? p.sd_lcl : allan::kNaN),
              Cell::Real(p.n >= 2 ? p.sd_ucl : allan::kNaN), Cell::Text(rules),
              Cell::Text(cap.capability_kind), Cell::Real(cap.capability),
              Cell::Real(cap.capability_low), Cell::Real(cap.capability_high)});
  }
  return t;
}

}  // namespace imuqual::report
