#include "report/control_chart_view.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <set>

#include "common/text_util.h"

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

namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string Label(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

}  // namespace

std::string ControlChartSvg(const judge::ControlChart& chart, const std::string& title,
                            std::optional<double> low, std::optional<double> high) {
  constexpr double kWidth = 900, kHeight = 360, kLeft = 70, kRight = 20, kTop = 34,
                   kBottom = 70;
  const size_t n = chart.points.size();
  // The value range: the means and their limits, and a plan limit near them.
  double lo = chart.centre, hi = chart.centre;
  for (const judge::ChartPoint& p : chart.points) {
    for (double v : {p.mean, p.mean_lcl, p.mean_ucl}) {
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
  }
  const double span0 = hi - lo > 0 ? hi - lo : std::max(std::fabs(hi), 1.0);
  for (std::optional<double> limit : {low, high}) {
    if (limit && *limit > lo - span0 && *limit < hi + span0) {
      lo = std::min(lo, *limit), hi = std::max(hi, *limit);
    }
  }
  const double pad = (hi - lo > 0 ? hi - lo : std::max(std::fabs(hi), 1.0)) * 0.08;
  lo -= pad;
  hi += pad;
  const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
  auto x = [&](double i) { return kLeft + (n <= 1 ? plot_w / 2 : plot_w * i / (n - 1)); };
  auto y = [&](double v) { return kTop + plot_h * (hi - v) / (hi - lo); };
  const double step = n <= 1 ? plot_w : plot_w / (n - 1);
  std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Num(kWidth) +
                    "\" height=\"" + Num(kHeight) + "\" viewBox=\"0 0 " + Num(kWidth) + " " +
                    Num(kHeight) +
                    "\" font-family=\"sans-serif\" font-size=\"12\" role=\"img\" aria-label=\"" +
                    HtmlEscape("X-bar chart: " + title) + "\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"" +
         Num(kLeft + plot_w / 2) + "\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">" +
         HtmlEscape("X-bar chart: " + title) + "</text>\n";
  svg += "<rect x=\"" + Num(kLeft) + "\" y=\"" + Num(kTop) + "\" width=\"" + Num(plot_w) +
         "\" height=\"" + Num(plot_h) + "\" fill=\"none\" stroke=\"#333333\"/>\n";
  // Value ticks: five.
  for (int k = 0; k <= 4; ++k) {
    const double v = lo + (hi - lo) * k / 4;
    svg += "<line x1=\"" + Num(kLeft) + "\" y1=\"" + Num(y(v)) + "\" x2=\"" + Num(kLeft + plot_w) +
           "\" y2=\"" + Num(y(v)) + "\" stroke=\"#eeeeee\"/>\n<text x=\"" + Num(kLeft - 6) +
           "\" y=\"" + Num(y(v) + 4) + "\" text-anchor=\"end\">" + Label(v) + "</text>\n";
  }
  // Centre line and the plan's limits.
  svg += "<line data-line=\"centre\" x1=\"" + Num(kLeft) + "\" y1=\"" + Num(y(chart.centre)) +
         "\" x2=\"" + Num(kLeft + plot_w) + "\" y2=\"" + Num(y(chart.centre)) +
         "\" stroke=\"#1a7f37\"/>\n";
  for (std::optional<double> limit : {low, high}) {
    if (!limit || *limit < lo || *limit > hi) continue;
    svg += "<line data-line=\"plan-limit\" x1=\"" + Num(kLeft) + "\" y1=\"" + Num(y(*limit)) +
           "\" x2=\"" + Num(kLeft + plot_w) + "\" y2=\"" + Num(y(*limit)) +
           "\" stroke=\"#c11f2b\" stroke-dasharray=\"8 4\"/>\n<text x=\"" +
           Num(kLeft + plot_w - 4) + "\" y=\"" + Num(y(*limit) - 4) +
           "\" text-anchor=\"end\" fill=\"#c11f2b\">plan limit " + Label(*limit) + "</text>\n";
  }
  // Control limits as steps, each subgroup's over its own slot.
  std::string ucl, lcl, means;
  for (size_t i = 0; i < n; ++i) {
    const judge::ChartPoint& p = chart.points[i];
    const double a = std::max(kLeft, x(static_cast<double>(i)) - step / 2);
    const double b = std::min(kLeft + plot_w, x(static_cast<double>(i)) + step / 2);
    ucl += Num(a) + "," + Num(y(p.mean_ucl)) + " " + Num(b) + "," + Num(y(p.mean_ucl)) + " ";
    lcl += Num(a) + "," + Num(y(p.mean_lcl)) + " " + Num(b) + "," + Num(y(p.mean_lcl)) + " ";
    if (std::isfinite(p.mean)) means += Num(x(static_cast<double>(i))) + "," + Num(y(p.mean)) + " ";
  }
  for (const std::string* line : {&ucl, &lcl}) {
    svg += "<polyline data-line=\"" + std::string(line == &ucl ? "ucl" : "lcl") + "\" points=\"" +
           *line + "\" fill=\"none\" stroke=\"#8a5a00\" stroke-dasharray=\"4 3\"/>\n";
  }
  svg += "<polyline data-line=\"means\" points=\"" + means +
         "\" fill=\"none\" stroke=\"#0969da\" stroke-width=\"1.5\"/>\n";
  // The points; a flagged one ringed in red, its rules in its tooltip.
  const size_t label_every = std::max<size_t>(1, (n + 11) / 12);
  for (size_t i = 0; i < n; ++i) {
    const judge::ChartPoint& p = chart.points[i];
    std::string rules;
    for (const auto* list : {&p.mean_rules, &p.sd_rules}) {
      for (const std::string& r : *list) rules += (rules.empty() ? "" : ", ") + r;
    }
    if (std::isfinite(p.mean)) {
      svg += "<circle data-subgroup=\"" + HtmlEscape(p.label) + "\"" +
             (rules.empty() ? "" : " data-flagged=\"true\"") + " cx=\"" +
             Num(x(static_cast<double>(i))) + "\" cy=\"" + Num(y(p.mean)) + "\" r=\"" +
             (rules.empty() ? "3" : "5.5") + "\" fill=\"" + (rules.empty() ? "#0969da" : "white") +
             "\" stroke=\"" + (rules.empty() ? "#0969da" : "#c11f2b") + "\" stroke-width=\"2\"><title>" +
             HtmlEscape(p.label + ": mean " + Label(p.mean) + " (n " + std::to_string(p.n) + ")" +
                        (rules.empty() ? "" : "; " + rules)) +
             "</title></circle>\n";
    }
    if (i % label_every == 0) {
      svg += "<text transform=\"translate(" + Num(x(static_cast<double>(i))) + "," +
             Num(kTop + plot_h + 12) + ") rotate(35)\" font-size=\"10.5\">" + HtmlEscape(p.label) +
             "</text>\n";
    }
  }
  svg += "<text x=\"" + Num(kLeft) + "\" y=\"" + Num(kHeight - 6) +
         "\" font-size=\"11\" fill=\"#555555\">green: centre; amber dashed: control limits "
         "(3 sigma / sqrt(n)); red dashed: the plan's limit; red rings: subgroups a rule "
         "flags</text>\n</svg>\n";
  return svg;
}

}  // namespace imuqual::report
