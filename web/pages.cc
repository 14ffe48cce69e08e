#include "web/pages.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/clock.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "report/allan_plots.h"
#include "report/archive_tables.h"
#include "report/marks.h"
#include "report/report.h"
#include "report/table_writer.h"
#include "report/time_series.h"
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
dl { display: grid; grid-template-columns: max-content auto; gap: 2px 14px; }
dt { color: #5b6670; }
.verdict { font-weight: 700; }
.FAIL, .ERROR { color: #b3261e; } .MARGINAL { color: #9a6700; }
.INCONCLUSIVE, .ABORTED { color: #5a32a3; } .PASS { color: #1a7f37; }
.note { color: #5b6670; font-size: 12.5px; }
figure { margin: 8px 0; } svg { max-width: 100%; height: auto; }
)css";

}  // namespace

std::string PageHtml(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
         "<link rel=\"icon\" href=\"data:,\">\n<title>" +
         HtmlEscape(title) + " - imuqual</title>\n<style>" + kStyle +
         "</style>\n</head>\n<body>\n<nav><a href=\"/\">imuqual: lots</a><a "
         "href=\"/compare\">compare lots</a><a href=\"/live\">live station</a>"
         "<form action=\"/unit\" method=\"get\"><label>serial <input name=\"serial\" "
         "size=\"16\"></label> <button>find</button></form></nav>\n<main>\n" +
         body + "</main>\n</body>\n</html>\n";
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
  if (runs->empty()) return NotFound("no unit with serial '" + serial + "' in the archive");
  const TableWriter t = report::RunsTable(*runs, Links());
  const std::string body = "<h1>Unit " + HtmlEscape(serial) + ": " + std::to_string(runs->size()) +
                           (runs->size() == 1 ? " run" : " runs") + ", newest first</h1>\n" +
                           t.Render(Format::kHtml);
  return {200, "text/html; charset=utf-8", PageHtml("unit " + serial, body)};
}

TableWriter MeasurementTable(const std::vector<pb::Measurement>& ms) {
  TableWriter t({"axis", "measurement", "value", "uncertainty", "unit", "low", "high",
                 "marginal_low", "marginal_high", "qualifier", "outcome", "note"},
                6);
  auto opt = [](bool has, double v) { return Cell::Real(has ? v : std::nan("")); };
  for (const pb::Measurement& m : ms) {
    t.AddRow({Cell::Text(m.axis().empty() ? "(run)" : m.axis()), Cell::Text(m.name()),
              Cell::Real(m.value()), opt(m.has_uncertainty(), m.uncertainty()),
              Cell::Text(m.unit()), opt(m.has_low(), m.low()), opt(m.has_high(), m.high()),
              opt(m.has_marginal_low(), m.marginal_low()),
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
  body += "<h2>Measurements</h2>\n";
  body += ms.empty() ? "<p>No measurement archived (not judged yet).</p>\n"
                     : MeasurementTable(ms).Render(Format::kHtml);
  auto plots = report::LoadRunPlotData(archive, run_id);
  if (plots.ok()) {
    const std::vector<report::AllanPlot> allan = report::RunAllanPlots(*plots, "");
    if (!allan.empty()) body += "<h2>Allan deviation</h2>\n";
    for (const report::AllanPlot& p : allan) body += "<figure>" + p.svg + "</figure>\n";
  }
  auto series = report::RunTimeSeriesSvg(archive, run_id);
  if (series.ok()) body += "<h2>Raw samples against time</h2>\n<figure>" + *series + "</figure>\n";
  body += "<p class=\"note\">JSON: <a href=\"" + HtmlEscape(NameLink("/api/run", "id", run_id)) +
          "\">/api/run/" + HtmlEscape(run_id) + "</a>.</p>\n";
  return {200, "text/html; charset=utf-8", PageHtml("run " + run_id, body)};
}

// Two lots side by side: every measurement's n, mean, sd and yield in each,
// with the tests of `imuqual compare` (alpha 0.05, Holm over all tests).
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
  body += "<p>" + HtmlEscape(lot_a) + " (a) against " + HtmlEscape(lot_b) +
          " (b): each unit by its latest run; Welch t (mean), F (sd), Fisher exact (yield); "
          "significant at 0.05 family-wise (Holm, " +
          std::to_string(3 * rows.size()) + " tests).</p>\n" + t.Render(Format::kHtml);
  return {200, "text/html; charset=utf-8", PageHtml("compare " + lot_a + " and " + lot_b, body)};
}

}  // namespace

Page Route(store::Archive& archive, const std::string& archive_label, const std::string& path,
           const std::map<std::string, std::string>& query) {
  std::string rest;
  if (path == "/") return Home(archive, archive_label);
  if (path == "/lot" || Under(path, "/lot/", &rest)) {
    if (path == "/lot") rest = Param(query, "name");
    if (rest.empty()) return NotFound("give a lot: /lot/LOT or /lot?name=LOT");
    auto html = report::BuildLotReportHtml(archive, rest, archive_label);
    if (!html.ok()) {
      return html.status().code() == Status::Code::kNotFound ? NotFound(html.status().message())
                                                             : Failed(html.status());
    }
    return {200, "text/html; charset=utf-8", *html};
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
