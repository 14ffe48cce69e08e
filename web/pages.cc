#include "web/pages.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/clock.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "report/allan_plots.h"
#include "report/archive_tables.h"
#include "report/control_chart_view.h"
#include "report/dynamic_allan_plot.h"
#include "report/marks.h"
#include "report/msa_view.h"
#include "report/report.h"
#include "report/table_writer.h"
#include "report/time_series.h"
#include "report/yield_trend.h"
#include "store/outcome.h"
#include "store/query.h"

namespace imuqual::web {
using report::Cell;
using report::Format;
using report::TableWriter;

namespace {

using report::Cell;
using report::Format;
using report::TableWriter;

constexpr char kStyle[] = R"css(
body { margin: 0; font: 14px/1.45 system-ui, sans-serif; color: #1d2329; }
.alert { background: #fde8e8; border-left: 4px solid #c0392b; padding: 6px 10px; }
nav { background: #1d2329; color: #fff; padding: 8px 16px; display: flex; gap: 18px;
      align-items: center; flex-wrap: wrap; }
nav a { color: #fff; text-decoration: none; font-weight: 600; }
nav form { margin-left: auto; }
main { padding: 12px 16px 40px; max-width: 1400px; }
h1 { font-size: 20px; margin: 8px 0 12px; }
h2 { font-size: 16px; margin: 22px 0 8px; }
table.data { border-collapse: collapse; margin: 6px 0; }
table.data th, table.data td { border-bottom: 1px solid #dde2e6; padding: 3px 9px;
                               text-align: left; vertical-align: top; }
table.data th { background: #f3f5f7; position: sticky; top: 0; }
table.data td.num { text-align: right; font-variant-numeric: tabular-nums; }
table.data tr.sig td { background: #fff3cd; font-weight: 600; }
dl { display: grid; grid-template-columns: max-content auto; gap: 2px 14px; }
dt { color: #5b6670; }
.verdict { font-weight: 700; }
.FAIL, .ERROR { color: #b3261e; } .MARGINAL { color: #9a6700; }
.INCONCLUSIVE, .ABORTED { color: #5a32a3; } .PASS { color: #1a7f37; }
.note { color: #5b6670; font-size: 12.5px; }
figure { margin: 8px 0; } svg { max-width: 100%; height: auto; }
)css";

}  // namespace

// The site's navigation, on every page (a served lot report too).
std::string SiteNavigation() {
  return "<nav class=\"site\"><a href=\"/\">imuqual: lots</a><a "
         "href=\"/compare\">compare lots</a><a href=\"/yields\">yields</a><a "
         "href=\"/chart\">control charts</a><a href=\"/msa\">station agreement</a><a "
         "href=\"/live\">live station</a>"
         "<form action=\"/unit\" method=\"get\"><label>serial <input name=\"serial\" "
         "size=\"16\"></label> <button>find</button></form></nav>\n";
}

std::string PageHtml(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
         "<link rel=\"icon\" href=\"data:,\">\n<title>" +
         HtmlEscape(title) + " - imuqual</title>\n<style>" + kStyle +
         "</style>\n</head>\n<body>\n" + SiteNavigation() + "<main>\n" + body +
         "</main>\n</body>\n</html>\n";
}

namespace {

// URL path segment: every byte but unreserved ones percent-encoded.
std::string PathSegment(const std::string& s) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

// "/prefix/NAME", or "/prefix?key=NAME" for a name that is a dot segment
// ("." or "..", valid identifiers), which a browser would resolve away.
std::string NameLink(const std::string& prefix, const std::string& key, const std::string& name) {
  if (name == "." || name == "..") return prefix + "?" + key + "=" + PathSegment(name);
  return prefix + "/" + PathSegment(name);
}

// The pages' links: a lot to its report, a run to its page, a unit to its history.
report::TableLinks Links() {
  report::TableLinks l;
  l.lot = [](const std::string& lot) { return NameLink("/lot", "name", lot); };
  l.run = [](const std::string& run) { return NameLink("/run", "id", run); };
  l.serial = [](const std::string& serial) { return NameLink("/unit", "serial", serial); };
  return l;
}

Page NotFound(const std::string& what) {
  return {404, "text/html; charset=utf-8",
          PageHtml("not found", "<h1>Not found</h1>\n<p>" + HtmlEscape(what) + "</p>\n")};
}

Page Failed(const Status& st) {
  return {500, "text/html; charset=utf-8",
          PageHtml("error", "<h1>The archive could not be read</h1>\n<p>" +
                                HtmlEscape(st.message()) + "</p>\n")};
}

Page Json(const std::string& body) { return {200, "application/json; charset=utf-8", body}; }

// "/prefix/NAME" -> NAME, the rest of the (decoded) path whole: a lot or a
// serial may contain '/'. Names only select rows of the archive; no path
// ever reaches the file system.
bool Under(const std::string& path, const std::string& prefix, std::string* rest) {
  if (path.rfind(prefix, 0) != 0 || path.size() == prefix.size()) return false;
  *rest = path.substr(prefix.size());
  return true;
}

std::string Param(const std::map<std::string, std::string>& q, const std::string& name) {
  auto it = q.find(name);
  return it == q.end() ? "" : it->second;
}

Page Home(store::Archive& archive, const std::string& label) {
  auto lots = store::QueryLots(archive);
  if (!lots.ok()) return Failed(lots.status());
  const TableWriter linked = report::LotsTable(*lots, /*for_people=*/true, Links());
  std::string body = "<h1>Lots in " + HtmlEscape(label) + "</h1>\n";
  body += lots->empty() ? "<p>No run archived yet.</p>\n" : linked.Render(Format::kHtml);
  body +=
      "<p class=\"note\">Units by their final run (latest judged, else latest); yield = (pass + "
      "marginal) / (pass + marginal + fail); n/m: not measurable, no judged unit. JSON: "
      "<a href=\"/api/lots\">/api/lots</a>.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("lots", body)};
}

Page UnitHistory(store::Archive& archive, const std::string& serial) {
  store::RunFilter f;
  f.unit = serial;
  f.limit = std::numeric_limits<int64_t>::max();
  auto runs = store::QueryRuns(archive, f);
  if (!runs.ok()) return Failed(runs.status());
  if (runs->empty()) {
    // Not a whole serial: the units whose serial starts with it (a line
    // types the start of a serial, or its lot's prefix).
    store::RunFilter starting;
    starting.unit_prefix = serial;
    starting.limit = 5000;
    auto some = store::QueryRuns(archive, starting);
    if (!some.ok()) return Failed(some.status());
    std::set<std::string> serials;
    for (const store::RunRow& r : *some) serials.insert(r.unit);
    if (serials.size() == 1) return UnitHistory(archive, *serials.begin());
    if (serials.empty()) {
      return NotFound("no unit with serial '" + serial + "' or starting with it in the archive");
    }
    std::string body = "<h1>" + std::to_string(serials.size()) + " units whose serial starts with " +
                       HtmlEscape(serial) + "</h1>\n<ul>\n";
    for (const std::string& s : serials) {
      body += "<li><a href=\"" + HtmlEscape(NameLink("/unit", "serial", s)) + "\">" +
              HtmlEscape(s) + "</a></li>\n";
    }
    body += "</ul>\n";
    return {200, "text/html; charset=utf-8", PageHtml("units " + serial + "...", body)};
  }
  const TableWriter t = report::RunsTable(*runs, Links());
  const std::string body = "<h1>Unit " + HtmlEscape(serial) + ": " + std::to_string(runs->size()) +
                           (runs->size() == 1 ? " run" : " runs") + ", newest first</h1>\n" +
                           t.Render(Format::kHtml);
  return {200, "text/html; charset=utf-8", PageHtml("unit " + serial, body)};
}

// `rounded`: value and uncertainty as a person reads them (u to two
// significant digits, the value to match: "409.6 ± 283" is "410", "280"), for
// the page; the JSON keeps the archived numbers.
TableWriter MeasurementTable(const std::vector<pb::Measurement>& ms, bool rounded = false) {
  TableWriter t({"axis", "measurement", "value", "uncertainty", "unit", "low", "high",
                 "marginal_low", "marginal_high", "qualifier", "outcome", "note"},
                6);
  auto opt = [](bool has, double v) { return Cell::Real(has ? v : std::nan("")); };
  for (const pb::Measurement& m : ms) {
    Cell value = Cell::Real(m.value()), u = opt(m.has_uncertainty(), m.uncertainty());
    if (rounded && m.has_uncertainty() && std::isfinite(m.value()) &&
        std::isfinite(m.uncertainty()) && m.uncertainty() > 0) {
      const auto [v_text, u_text] = report::QuotedWithUncertainty(m.value(), m.uncertainty());
      value = Cell::RealShown(m.value(), v_text);
      u = Cell::RealShown(m.uncertainty(), u_text);
    }
    t.AddRow({Cell::Text(m.axis().empty() ? "(run)" : m.axis()), Cell::Text(m.name()),
              std::move(value), std::move(u), Cell::Text(m.unit()), opt(m.has_low(), m.low()),
              opt(m.has_high(), m.high()), opt(m.has_marginal_low(), m.marginal_low()),
              opt(m.has_marginal_high(), m.marginal_high()),
              Cell::Text(report::QualifierWord(m.qualifier(), m.value())),
              Cell::Text(m.outcome() == pb::OUTCOME_UNSET ? "not_judged"
                                                          : store::OutcomeText(m.outcome())),
              Cell::Text(m.note())});
  }
  return t;
}

Page RunPage(store::Archive& archive, const std::string& run_id, bool json) {
  auto key = archive.FindRunKey(run_id);
  if (!key.ok()) return Failed(key.status());
  if (!key->has_value()) return NotFound("no run '" + run_id + "' in the archive");
  auto info = archive.LoadRun(run_id);
  if (!info.ok()) return Failed(info.status());
  auto result = archive.LoadResult(**key);
  if (!result.ok()) return Failed(result.status());
  const std::vector<pb::Measurement> none;
  const std::vector<pb::Measurement>& ms = *result ? (*result)->measurements : none;
  if (json) return Json(MeasurementTable(ms).Render(Format::kJson));
  const store::RunInfo& r = *info;
  const std::string verdict = *result && !(*result)->verdict.empty() ? (*result)->verdict : "";
  std::string body = "<h1>Run " + HtmlEscape(run_id) + "</h1>\n<dl>\n";
  auto field = [&](const char* name, const std::string& value_html) {
    body += "<dt>" + std::string(name) + "</dt><dd>" + value_html + "</dd>\n";
  };
  field("unit", "<a href=\"" + HtmlEscape(NameLink("/unit", "serial", r.serial)) + "\">" +
                    HtmlEscape(r.serial) + "</a>");
  field("lot", "<a href=\"" + HtmlEscape(NameLink("/lot", "name", r.lot)) + "\">" +
                   HtmlEscape(r.lot) + "</a>");
  field("station / slot", HtmlEscape(r.station) + " / " + HtmlEscape(r.slot));
  field("operator", r.operator_name.empty() ? "(not recorded)" : HtmlEscape(r.operator_name));
  field("source", HtmlEscape(r.source));
  field("start", HtmlEscape(FormatUtimeIso(r.start_utime)));
  field("state",
        HtmlEscape(r.state) + (r.end_reason.empty() ? "" : ": " + HtmlEscape(r.end_reason)));
  field("verdict", verdict.empty() ? "not judged"
                                   : "<span class=\"verdict " + HtmlEscape(verdict) + "\">" +
                                         HtmlEscape(verdict) + "</span>");
  field("software", HtmlEscape(r.software_version));
  body += "</dl>\n";
  if (*result && !(*result)->reasons.empty()) {
    body += "<h2>Reasons</h2>\n<ul>\n";
    for (const std::string& why : (*result)->reasons) body += "<li>" + HtmlEscape(why) + "</li>\n";
    body += "</ul>\n";
  }
  // As a test engineer reads a run: the verdict and its reasons, the judged
  // measurements (failing first), the plots, and only then every
  // measurement archived.
  std::vector<pb::Measurement> judged;
  for (const pb::Measurement& m : ms) {
    if (m.outcome() != pb::OUTCOME_UNSET) judged.push_back(m);
  }
  std::stable_sort(judged.begin(), judged.end(),
                   [](const pb::Measurement& a, const pb::Measurement& b) {
                     return store::AttentionRank(a.outcome()) > store::AttentionRank(b.outcome());
                   });
  if (!judged.empty()) {
    body += "<section id=\"judged\">\n<h2>Judged measurements, failing first</h2>\n" +
            MeasurementTable(judged, true).Render(Format::kHtml) + "</section>\n";
  }
  auto plots = report::LoadRunPlotData(archive, run_id);
  if (plots.ok()) {
    const std::vector<report::AllanPlot> allan = report::RunAllanPlots(*plots, "");
    if (!allan.empty()) body += "<h2>Allan deviation</h2>\n";
    for (const report::AllanPlot& p : allan) body += "<figure>" + p.svg + "</figure>\n";
  }
  auto series = report::RunTimeSeriesSvg(archive, run_id);
  if (series.ok()) body += "<h2>Raw samples against time</h2>\n<figure>" + *series + "</figure>\n";
  auto davar = report::RunDynamicAllanSvgs(archive, run_id);
  if (davar.ok()) {
    body += "<h2>Dynamic Allan deviation</h2>\n";
    for (const std::string& svg : *davar) body += "<figure>" + svg + "</figure>\n";
    body +=
        "<p class=\"note\">Each axis: the Allan deviation of each quarter of the record after the "
        "warm-up, "
        "every sixteenth, early blue to late red. A stationary record draws one bundle; a curve "
        "apart from it is a stretch with a step, a ramp or a burst.</p>\n";
  } else if (davar.status().code() != Status::Code::kNotFound) {
    body += "<p class=\"note\">Dynamic Allan deviation not drawn: " +
            HtmlEscape(davar.status().message()) + "</p>\n";
  }
  body += "<section id=\"measurements\">\n<h2>Every measurement archived</h2>\n";
  body += ms.empty() ? "<p>No measurement archived (not judged yet).</p>\n"
                     : MeasurementTable(ms, true).Render(Format::kHtml);
  body += "</section>\n";
  body += "<p class=\"note\">JSON: <a href=\"" + HtmlEscape(NameLink("/api/run", "id", run_id)) +
          "\">/api/run/" + HtmlEscape(run_id) + "</a>.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("run " + run_id, body)};
}

// Two lots side by side: every measurement's n, mean, sd and yield in each,
// with the tests of `imuqual compare` (alpha 0.05, Holm over all tests).
// The comparison as a person reads it, narrow enough for 1400 px: per
// measurement the two lots' n, mean +- sd and yield, the change of the mean,
// the three p-values and what differs; the significant rows first, marked
// (class "sig").
std::string ComparisonHtml(const std::vector<report::Comparison>& rows) {
  std::vector<const report::Comparison*> order;
  for (const report::Comparison& c : rows) order.push_back(&c);
  auto differs = [](const report::Comparison* c) {
    return c->mean_significant || c->spread_significant || c->yield_significant;
  };
  std::stable_sort(order.begin(), order.end(), [&](const auto* x, const auto* y) {
    return differs(x) && !differs(y);
  });
  auto num = [](double v) {
    if (!std::isfinite(v)) return std::string("&ndash;");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return std::string(buf);
  };
  auto lot_cell = [&](const judge::Summary& x) {
    return "<td class=\"num\">" + std::to_string(x.n) + "</td><td class=\"num\">" + num(x.mean) +
           " &plusmn; " + num(x.sd) + "</td>";
  };
  std::string out =
      "<table class=\"data compare\"><thead><tr><th>axis</th><th>measurement</th><th>unit</th>"
      "<th>n a</th><th>mean &plusmn; sd a</th><th>n b</th><th>mean &plusmn; sd b</th>"
      "<th>yield a / b</th><th>mean change</th><th>p mean / sd / yield</th><th>differs</th>"
      "</tr></thead><tbody>\n";
  for (const report::Comparison* c : order) {
    std::string what;
    for (auto [flag, name] : {std::pair{c->mean_significant, "mean"},
                              {c->spread_significant, "sd"},
                              {c->yield_significant, "yield"}}) {
      if (flag) what += (what.empty() ? "" : ", ") + std::string(name);
    }
    out += std::string("<tr") + (differs(c) ? " class=\"sig\"" : "") + "><td>" +
           HtmlEscape(c->a.axis.empty() ? "(run)" : c->a.axis) + "</td><td>" +
           HtmlEscape(c->a.name) + "</td><td>" + HtmlEscape(c->a.unit) + "</td>" +
           lot_cell(c->a.summary) + lot_cell(c->b.summary) + "<td class=\"num\">" +
           num(c->a.summary.yield) + " / " + num(c->b.summary.yield) + "</td><td class=\"num\">" +
           (std::isfinite(c->mean_change) ? num(100 * c->mean_change) + " %" : "&ndash;") +
           "</td><td class=\"num\">" + num(c->mean.p_value) + " / " + num(c->spread.p_value) +
           " / " + num(c->yield.p_value) + "</td><td>" + (what.empty() ? "no" : what) +
           "</td></tr>\n";
  }
  return out + "</tbody></table>\n";
}

Page Compare(store::Archive& archive, const std::string& lot_a, const std::string& lot_b,
             bool json) {
  std::string body =
      "<h1>Compare two lots</h1>\n<form action=\"/compare\" method=\"get\"><label>lot a "
      "<input name=\"a\" value=\"" +
      HtmlEscape(lot_a) + "\"></label> <label>lot b <input name=\"b\" value=\"" +
      HtmlEscape(lot_b) + "\"></label> <button>compare</button></form>\n";
  if (lot_a.empty() || lot_b.empty()) {
    if (json) return {404, "application/json", "{\"error\": \"give a and b\"}\n"};
    return {200, "text/html; charset=utf-8", PageHtml("compare", body)};
  }
  auto a = report::LotStatistics(archive, lot_a);
  auto b = a.ok() ? report::LotStatistics(archive, lot_b) : a;
  if (!a.ok() || !b.ok()) {
    const Status& st = a.ok() ? b.status() : a.status();
    if (st.code() != Status::Code::kNotFound) return Failed(st);
    if (json) return {404, "application/json", "{\"error\": \"no such lot\"}\n"};
    return NotFound(st.message());
  }
  constexpr double kAlpha = 0.05;
  const std::vector<report::Comparison> rows = report::CompareLots(*a, *b, kAlpha);
  const TableWriter t = report::ComparisonTable(rows);
  if (json) return Json(t.Render(Format::kJson));
  int significant = 0;
  for (const report::Comparison& c : rows) {
    significant += c.mean_significant || c.spread_significant || c.yield_significant;
  }
  body += "<p>" + HtmlEscape(lot_a) + " (a) against " + HtmlEscape(lot_b) +
          " (b): each unit by its latest run; Welch t (mean), F (sd), Fisher exact (yield); "
          "significant at 0.05 family-wise (Holm, " +
          std::to_string(3 * rows.size()) + " tests): <strong>" + std::to_string(significant) +
          " of " + std::to_string(rows.size()) +
          " measurements differ</strong>, listed first and marked. Every column: <a href=\"" +
          HtmlEscape("/api/compare?a=" + PathSegment(lot_a) + "&b=" + PathSegment(lot_b)) +
          "\">/api/compare</a>.</p>\n" + ComparisonHtml(rows);
  return {200, "text/html; charset=utf-8", PageHtml("compare " + lot_a + " and " + lot_b, body)};
}

// Yields per week, month, station or lot (imuqual yields).
Page Yields(store::Archive& archive, const std::string& by_text, bool json) {
  const std::string by_name = by_text.empty() ? "week" : by_text;
  auto by = report::ParseYieldBy(by_name);
  if (!by.ok()) return NotFound(by.status().message());
  auto runs = store::QueryRunVerdicts(archive);
  if (!runs.ok()) return Failed(runs.status());
  const TableWriter t = report::YieldTable(report::YieldTrend(*runs, *by));
  if (json) return Json(t.Render(Format::kJson));
  std::string body = "<h1>Yields by " + HtmlEscape(by_name) + "</h1>\n<p>";
  for (const char* b : {"week", "month", "station", "lot"}) {
    body += std::string("<a href=\"/yields?by=") + b + "\">" + b + "</a> ";
  }
  body += "</p>\n" + (runs->empty() ? std::string("<p>No run archived yet.</p>\n")
                                     : t.Render(Format::kHtml)) +
          "<p class=\"note\">Each unit of each lot once, in the group of its first run: first-pass "
          "yield = units whose first judged run passed (PASS or MARGINAL) / units with a judged "
          "run; final yield by each unit's final run over PASS, MARGINAL and FAIL; 95 % Wilson "
          "intervals. JSON: <a href=\"/api/yields?by=" +
          HtmlEscape(by_name) + "\">/api/yields</a>.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("yields by " + by_name, body)};
}

// A control chart of one measurement (imuqual chart).
Page Chart(store::Archive& archive, const std::map<std::string, std::string>& query, bool json) {
  const std::string measurement = Param(query, "measurement"), axis = Param(query, "axis");
  const std::string by_name = Param(query, "by").empty() ? "lot" : Param(query, "by");
  const std::string station = Param(query, "station");
  const std::string baseline_text = Param(query, "baseline");
  std::string body =
      "<h1>Control chart</h1>\n<form action=\"/chart\" method=\"get\"><label>measurement "
      "<input name=\"measurement\" value=\"" +
      HtmlEscape(measurement.empty() ? "bias_instability" : measurement) +
      "\"></label> <label>axis <input name=\"axis\" size=\"4\" value=\"" + HtmlEscape(axis) +
      "\"></label> <label>by <input name=\"by\" size=\"6\" value=\"" + HtmlEscape(by_name) +
      "\"></label> <label>station <input name=\"station\" size=\"10\" value=\"" +
      HtmlEscape(station) + "\"></label> <label>plan <input name=\"plan\" size=\"12\" value=\"" +
      HtmlEscape(Param(query, "plan")) +
      "\"></label> <label>baseline <input name=\"baseline\" size=\"4\" value=\"" +
      HtmlEscape(baseline_text) + "\"></label> <button>chart</button></form>\n";
  if (measurement.empty()) {
    if (json) return {404, "application/json", "{\"error\": \"give measurement and axis\"}\n"};
    return {200, "text/html; charset=utf-8", PageHtml("control chart", body)};
  }
  auto by = report::ParseChartBy(by_name);
  if (!by.ok()) return NotFound(by.status().message());
  int baseline = 0;
  if (!baseline_text.empty()) {
    char* end = nullptr;
    const long v = std::strtol(baseline_text.c_str(), &end, 10);
    if (end == baseline_text.c_str() || *end != '\0' || v < 2 || v > 1000000) {
      return NotFound("baseline: a number of subgroups >= 2");
    }
    baseline = static_cast<int>(v);
  }
  auto rows = store::QueryMeasurementHistory(archive, measurement, axis);
  if (!rows.ok()) return Failed(rows.status());
  auto plan = report::KeepOnePlan(archive, Param(query, "plan"), &*rows);
  if (!plan.ok()) return NotFound(plan.status().message());
  const std::vector<judge::Subgroup> groups = report::ChartSubgroups(*rows, *by, station);
  auto chart = judge::MakeControlChart(groups, baseline);
  if (!chart.ok()) {
    if (json) return {404, "application/json", "{\"error\": \"not enough values\"}\n"};
    return NotFound(measurement + " " + axis + ": " +
                    (rows->empty() ? "no judged value" : chart.status().message()));
  }
  const std::optional<double> low = rows->empty() ? std::nullopt : rows->front().low;
  const std::optional<double> high = rows->empty() ? std::nullopt : rows->front().high;
  const TableWriter t = report::ControlChartTable(*chart, groups, low, high);
  if (json) return Json(t.Render(Format::kJson));
  body += "<p>" + HtmlEscape(measurement) + " " + HtmlEscape(axis) + " (" +
          HtmlEscape(rows->front().value_unit) + ") by " + HtmlEscape(by_name) +
          (station.empty() ? "" : " at " + HtmlEscape(station)) + ": centre " +
          ShortestReal(chart->centre) + ", sigma " + ShortestReal(chart->sigma) +
          " (within subgroups; limits from " + std::to_string(chart->baseline) + " of " +
          std::to_string(chart->points.size()) + " subgroups); <strong>" +
          std::to_string(chart->flagged) + " subgroups flagged</strong>. Plan " +
          HtmlEscape(plan->name) + " (" + HtmlEscape(plan->sha256.substr(0, 12)) + ")" +
          (plan->left_out == 0
               ? std::string()
               : "; " + std::to_string(plan->left_out) + " values of " +
                     std::to_string(plan->other_plans) +
                     " other plan(s) not charted (choose one with plan=)") +
          ".</p>\n<figure>" +
          report::ControlChartSvg(*chart,
                                  measurement + " " + axis + " (" + rows->front().value_unit +
                                      ") by " + by_name +
                                      (station.empty() ? "" : " at " + station),
                                  low, high) +
          "</figure>\n" + t.Render(Format::kHtml) +
          "<p class=\"note\">X-bar limits: centre +- 3 sigma / sqrt(n); S limits: sigma (c4 +- 3 "
          "sqrt(1 - c4^2)). Rules: beyond 3 sigma, 2 of 3 beyond 2 sigma, 4 of 5 beyond 1 sigma, "
          "8 on one side, 6 trending (mean); beyond 3 sigma (sd). Cpk/Cpu/Cpl against the "
          "plan's limits with its 95 % interval, none from fewer than 10 values.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("control chart " + measurement, body)};
}

// Station agreement on golden units (imuqual msa).
Page Msa(store::Archive& archive, const std::map<std::string, std::string>& query, bool json) {
  const std::string lot = Param(query, "lot");
  report::MsaSelection selection;
  selection.measurement = Param(query, "measurement");
  selection.axis = Param(query, "axis");
  const std::string by_text = Param(query, "by").empty() ? "station" : Param(query, "by");
  auto by = report::ParseAppraiser(by_text);
  if (!by.ok()) return NotFound(by.status().message());
  selection.appraiser = *by;
  std::string body =
      "<h1>Station agreement (MSA)</h1>\n<form action=\"/msa\" method=\"get\"><label>golden "
      "lot <input name=\"lot\" value=\"" +
      HtmlEscape(lot) + "\"></label> <label>measurement <input name=\"measurement\" value=\"" +
      HtmlEscape(selection.measurement) + "\"></label> <label>axis <input name=\"axis\" "
      "size=\"4\" value=\"" +
      HtmlEscape(selection.axis) + "\"></label> <label>by <input name=\"by\" size=\"14\" value=\"" +
      HtmlEscape(by_text) + "\"></label> <button>analyse</button></form>\n";
  if (lot.empty()) {
    if (json) return {404, "application/json", "{\"error\": \"give lot\"}\n"};
    return {200, "text/html; charset=utf-8", PageHtml("station agreement", body)};
  }
  auto rows = store::QueryRunValues(archive, lot);
  if (!rows.ok()) return Failed(rows.status());
  if (rows->empty()) return NotFound("no judged run of lot '" + lot + "'");
  const std::vector<report::MsaOutcome> outcomes = report::StudyStations(*rows, selection);
  const TableWriter studies = report::MsaTable(outcomes, *by);
  const TableWriter offsets = report::MsaOffsetsTable(outcomes, *by);
  if (json) {
    return Json("{\"studies\": " + studies.Render(Format::kJson) + ", \"offsets\": " +
                offsets.Render(Format::kJson) + "}\n");
  }
  std::vector<std::string> drifting;
  for (const report::MsaOutcome& o : outcomes) {
    for (const judge::StationOffset& s : o.result.offsets) {
      if (s.differs) drifting.push_back(s.station + " (" + o.axis + " " + o.measurement + ")");
    }
  }
  body += drifting.empty()
              ? "<p>No station's offset differs from the fleet at 95 %.</p>\n"
              : "<p class=\"alert\"><strong>Out of agreement:</strong> " +
                    HtmlEscape([&] {
                      std::string list;
                      for (const std::string& d : drifting) list += (list.empty() ? "" : ", ") + d;
                      return list;
                    }()) +
                    "</p>\n";
  body += "<h2>Studies</h2>\n" + studies.Render(Format::kHtml) + "<h2>Each " +
          HtmlEscape(by_text) + " against the fleet</h2>\n" + offsets.Render(Format::kHtml) +
          "<p class=\"note\">AIAG ANOVA method: each golden unit a part, each station an "
          "appraiser, each judged soak a trial (balanced: as many as every unit has on every "
          "station). %GRR of the tolerance: 6 GRR / (USL - LSL), or 3 GRR / |limit - mean| with "
          "one limit; under 10 % acceptable, 10-30 % may be, above 30 % not. Offsets: a "
          "station's mean less the fleet's, 95 % interval.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("station agreement " + lot, body)};
}

}  // namespace

Page Route(store::Archive& archive, const std::string& archive_label, const std::string& path,
           const std::map<std::string, std::string>& query) {
  std::string rest;
  if (path == "/") return Home(archive, archive_label);
  if (path == "/lot" || Under(path, "/lot/", &rest)) {
    if (path == "/lot") rest = Param(query, "name");
    if (rest.empty()) return NotFound("give a lot: /lot/LOT or /lot?name=LOT");
    report::LotReportOptions options;
    options.section_url = [lot = rest](const std::string& part) {
      return "/lot-section?name=" + PathSegment(lot) + "&part=" + part;
    };
    options.site_navigation = SiteNavigation();
    auto html = report::BuildLotReportHtml(archive, rest, archive_label, options);
    if (!html.ok()) {
      return html.status().code() == Status::Code::kNotFound ? NotFound(html.status().message())
                                                             : Failed(html.status());
    }
    return {200, "text/html; charset=utf-8", *html};
  }
  if (path == "/lot-section") {
    // A lot page's deferred section, fetched by its script.
    auto data = report::LoadLotReport(archive, Param(query, "name"));
    if (!data.ok()) {
      return data.status().code() == Status::Code::kNotFound ? NotFound(data.status().message())
                                                             : Failed(data.status());
    }
    auto section = report::RenderLotSection(*data, Param(query, "part"));
    if (!section.ok()) return NotFound(section.status().message());
    return {200, "text/html; charset=utf-8", *section};
  }
  if (path == "/unit") {
    const std::string serial = Param(query, "serial");
    if (serial.empty()) return NotFound("give a serial: /unit?serial=SERIAL");
    return UnitHistory(archive, serial);
  }
  if (Under(path, "/unit/", &rest)) return UnitHistory(archive, rest);
  if (path == "/compare") return Compare(archive, Param(query, "a"), Param(query, "b"), false);
  if (path == "/api/compare") return Compare(archive, Param(query, "a"), Param(query, "b"), true);
  if (Under(path, "/run/", &rest)) return RunPage(archive, rest, /*json=*/false);
  if (path == "/run") {
    const std::string id = Param(query, "id");
    if (id.empty()) return NotFound("give a run: /run/RUN_ID or /run?id=RUN_ID");
    return RunPage(archive, id, /*json=*/false);
  }
  if (path == "/api/lots") {
    auto lots = store::QueryLots(archive);
    if (!lots.ok()) return Failed(lots.status());
    return Json(report::LotsTable(*lots, /*for_people=*/false).Render(Format::kJson));
  }
  if (path == "/api/lot" || Under(path, "/api/lot/", &rest)) {
    if (path == "/api/lot") rest = Param(query, "name");
    store::AxisRowFilter filter;
    filter.lot = rest;
    auto rows = store::QueryAxisRows(archive, filter);
    if (!rows.ok()) return Failed(rows.status());
    if (rows->empty()) return {404, "application/json", "{\"error\": \"no such lot\"}\n"};
    return Json(report::LotAxisTable(*rows).Render(Format::kJson));
  }
  if (path == "/yields" || path == "/api/yields") {
    return Yields(archive, Param(query, "by"), path == "/api/yields");
  }
  if (path == "/chart" || path == "/api/chart") return Chart(archive, query, path == "/api/chart");
  if (path == "/msa" || path == "/api/msa") return Msa(archive, query, path == "/api/msa");
  if (path == "/api/runs") {
    store::RunFilter f;
    f.lot = Param(query, "lot");
    f.unit = Param(query, "serial");
    auto runs = store::QueryRuns(archive, f);
    if (!runs.ok()) return Failed(runs.status());
    return Json(report::RunsTable(*runs).Render(Format::kJson));
  }
  if (path == "/api/run" || Under(path, "/api/run/", &rest)) {
    if (path == "/api/run") rest = Param(query, "id");
    Page p = RunPage(archive, rest, /*json=*/true);
    if (p.status == 404) return {404, "application/json", "{\"error\": \"no such run\"}\n"};
    return p;
  }
  return NotFound("no page at " + path);
}

}  // namespace imuqual::web
