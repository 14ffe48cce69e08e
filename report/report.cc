#include "report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <future>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <tuple>
#include <vector>

#include "analyze/allan/model_quantities.h"
#include "analyze/judge/measurements.h"
#include "common/clock.h"
#include "common/log.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "common/version.h"
#include "report/allan_plots.h"
#include "report/dynamic_allan_plot.h"
#include "report/early_decisions.h"
#include "report/lot_model_view.h"
#include "report/lot_statistics.h"
#include "report/marks.h"
#include "report/time_series.h"
#include "store/outcome.h"
#include "store/query.h"

namespace imuqual::report {
namespace {

// Appends every part to *out (no temporaries of "literal" + std::string).
template <typename... Parts>
void Add(std::string* out, const Parts&... parts) {
  (out->append(parts), ...);
}

std::string Esc(std::string_view s) { return HtmlEscape(s); }

// ` name="value"`, the value escaped.
std::string Attr(std::string_view name, std::string_view value) {
  std::string out = " ";
  Add(&out, name, "=\"", Esc(value), "\"");
  return out;
}

// Full precision for programs: the shortest text that reads back exactly;
// "" for none.
std::string Exact(double v) { return std::isfinite(v) ? ShortestReal(v) : ""; }

// A number printf wrote ("-1.234e-05", "0.81") as HTML: a real minus sign,
// 1.234&times;10<sup>&minus;5</sup>.
std::string HtmlNumber(std::string_view printed) {
  std::string out;
  if (!printed.empty() && printed.front() == '-') {
    out = "&minus;";
    printed.remove_prefix(1);
  }
  const size_t e = printed.find('e');
  if (e == std::string_view::npos) return out + std::string(printed);
  const int exponent = std::stoi(std::string(printed.substr(e + 1)));
  Add(&out, std::string(printed.substr(0, e)), "&times;10<sup>", exponent < 0 ? "&minus;" : "",
      std::to_string(std::abs(exponent)), "</sup>");
  return out;
}

// Four significant digits for people, as HTML: 1.234&times;10<sup>-5</sup>,
// a real minus sign, an en dash for none.
std::string Human(double v) {
  if (!std::isfinite(v)) return "&ndash;";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return HtmlNumber(buf);
}

std::string Percent(double fraction) {
  if (!std::isfinite(fraction)) return "&ndash;";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f&nbsp;%%", 100 * fraction);
  return buf;
}

// Datasheet typography of a stored unit: deg/sqrt(h) -> °/√h, ug -> µg,
// ^2 -> ², the dimensionless "1" -> "" (escaped HTML).
std::string PrettyUnit(std::string_view unit) {
  if (unit == "1") return "";
  std::string u(unit);
  auto replace = [&u](std::string_view from, std::string_view to) {
    for (size_t pos = u.find(from); pos != std::string::npos; pos = u.find(from, pos + to.size())) {
      u.replace(pos, from.size(), to);
    }
  };
  replace("sqrt(h)", "\u221Ah");
  replace("deg", "\u00B0");
  replace("ug", "\u00B5g");
  replace("^2", "\u00B2");
  return Esc(u);
}

std::string IsoTime(int64_t utime) {
  std::string t = FormatUtimeIso(utime);  // 2026-11-21T11:05:00Z
  if (t.size() == 20 && t[10] == 'T' && t[19] == 'Z') {
    t[10] = ' ';
    t.resize(19);
    t += " UTC";
  }
  return t;
}

int Severity(std::string_view verdict) { return store::OutcomeSeverity(verdict); }

std::string OutcomeName(pb::Outcome o) { return store::OutcomeText(o); }

// Whether the stationarity scan found an event (a level step, burst or
// noise level change) on any of the run's axes.
bool HasStationarityEvent(const RunPlotData& r) {
  for (const AxisPlotData& a : r.axes) {
    for (const pb::Measurement& m : a.measurements) {
      if (m.name() == judge::kStationarityEvents && m.value() >= 1) return true;
    }
  }
  return false;
}

// The runs whose units need a look, worst first (store::AttentionRank),
// then the units that pass but whose record shows a stationarity event (a
// level step, burst or noise level change under a plan's qualifier-only
// stationarity: the verdict stands, but the time series shows where).
std::vector<const RunPlotData*> NeedALook(const std::vector<RunPlotData>& runs) {
  auto rank = [](const RunPlotData* r) {
    const int attention = store::AttentionRank(store::OutcomeFromText(r->verdict));
    return attention > 0 ? 2 * attention : HasStationarityEvent(*r) ? 1 : 0;
  };
  std::vector<const RunPlotData*> flagged;
  for (const RunPlotData& r : runs) {
    if (rank(&r) > 0) flagged.push_back(&r);
  }
  std::stable_sort(flagged.begin(), flagged.end(),
                   [&](const auto* a, const auto* b) { return rank(a) > rank(b); });
  return flagged;
}

// A verdict as a badge, each outcome its own class ("not judged" for none):
// INCONCLUSIVE (retest), ABORTED and ERROR (nothing said about the unit)
// are not coloured as a FAIL.
std::string Badge(std::string_view verdict) {
  const bool known = store::OutcomeFromText(verdict) != pb::OUTCOME_UNSET;
  std::string out = "<span class=\"badge v-";
  Add(&out, known ? Esc(verdict) : std::string("none"), "\">",
      verdict.empty() ? "not judged" : Esc(verdict), "</span>");
  return out;
}

// A verdict cell; sorts by severity.
std::string VerdictCell(std::string_view verdict, std::string_view field) {
  std::string out = "<td class=\"verdict\"";
  Add(&out, Attr("data-field", field), Attr("data-sort", std::to_string(Severity(verdict))), ">",
      Badge(verdict), "</td>");
  return out;
}

// Measurement names people read, in catalogue order.
struct Label {
  std::string_view name, text;
};
constexpr Label kLabels[] = {
    {judge::kBiasInstability, "Bias instability (curve minimum)"},
    {judge::kBiasInstabilityIeee, "Bias instability B (IEEE 952, min/0.664)"},
    {judge::kTauAtMinimum, "\u03C4 at the curve minimum"},
    {judge::kAngleRandomWalk, "Angle random walk N (\u03C4 = 1 s)"},
    {judge::kVelocityRandomWalk, "Velocity random walk N (\u03C4 = 1 s)"},
    {judge::kRateRandomWalk, "Rate random walk K (\u03C4 = 3 s)"},
    {judge::kBiasOffset, "Bias offset (mean output)"},
    {judge::kFitQuantization, "Model: quantization Q"},
    {judge::kFitAngleRandomWalk, "Model: angle random walk (\u22121/2 asymptote at 1 s)"},
    {judge::kFitVelocityRandomWalk, "Model: velocity random walk (\u22121/2 asymptote at 1 s)"},
    {judge::kFitBiasInstability, "Model: bias instability (model minimum / 0.664)"},
    {judge::kFitRateRandomWalk, "Model: rate random walk K"},
    {judge::kFitRateRamp, "Model: rate ramp R"},
    {judge::kNoiseModelPValue, "Model: goodness of fit (J-test p-value)"},
    {judge::kGapFraction, "Gap fraction"},
    {judge::kInvalidFraction, "Invalid fraction"},
    {judge::kDuration, "Analysed duration"},
    {judge::kDecisionTime, "Decision time (early decisions)"},
};

size_t LabelIndex(std::string_view name) {
  for (size_t i = 0; i < std::size(kLabels); ++i) {
    if (kLabels[i].name == name) return i;
  }
  return std::size(kLabels);
}

std::string MeasurementTitle(std::string_view name) {
  const size_t i = LabelIndex(name);
  return i < std::size(kLabels) ? Esc(kLabels[i].text) : Esc(name);
}

// "≤ 20", "2 – 120", "≥ 0.1", plus the marginal band's edges; "" for none.
std::string LimitText(const std::optional<double>& low, const std::optional<double>& high,
                      const std::optional<double>& marginal_low,
                      const std::optional<double>& marginal_high) {
  std::string out;
  if (low && high) {
    Add(&out, Human(*low), "&ndash;", Human(*high));
  } else if (high) {
    Add(&out, "&le;&nbsp;", Human(*high));
  } else if (low) {
    Add(&out, "&ge;&nbsp;", Human(*low));
  }
  if (marginal_low || marginal_high) {
    out += out.empty() ? "marginal " : " (marginal ";
    if (marginal_low) Add(&out, "&lt;&nbsp;", Human(*marginal_low));
    if (marginal_low && marginal_high) out += ", ";
    if (marginal_high) Add(&out, "&gt;&nbsp;", Human(*marginal_high));
    if (low || high) out += ")";
  }
  return out;
}

// A numeric cell: rounded text, exact data-v, optional data-m and outcome.
std::string NumCell(double v, std::string_view key_attr, std::string_view key,
                    std::string_view outcome = "") {
  std::string out = "<td class=\"num";
  if (!outcome.empty() && outcome != "PASS") Add(&out, " o-", outcome);
  out += "\"";
  Add(&out, Attr(key_attr, key), Attr("data-v", Exact(v)));
  if (!outcome.empty()) out += Attr("data-outcome", outcome);
  Add(&out, ">", Human(v), "</td>");
  return out;
}

// A unit's value with its marks (report/marks.h), the number in its own
// element (class "v", to 4 digits; data-v exact) and the marks outside it:
// "≤ " before an upper bound, † (minimum not resolved) or ‡ (inadequate
// model) after the number, "± u" after that (data-u exact), "n/m" for a value
// not measurable with its note as the cell's title. data-q: the qualifier
// (QualifierWord).
std::string ValueCell(double v, std::string_view key, std::string_view outcome,
                      const store::ValueMarks& m) {
  std::string out = "<td class=\"num";
  if (!outcome.empty() && outcome != "PASS") Add(&out, " o-", outcome);
  out += "\"";
  Add(&out, Attr("data-m", key), Attr("data-v", Exact(v)), Attr("data-u", Exact(m.uncertainty)),
      Attr("data-q", QualifierWord(m.qualifier, v)));
  if (!outcome.empty()) out += Attr("data-outcome", outcome);
  if (!m.note.empty()) out += Attr("title", m.note);
  out += ">";
  if (m.qualifier == pb::NOT_MEASURABLE) {
    Add(&out, "<span class=\"v nm\">n/m</span></td>");
    return out;
  }
  const bool finite = std::isfinite(v);
  if (finite && m.qualifier == pb::UPPER_BOUND) out += "<span class=\"mk\">&le;&nbsp;</span>";
  // With its uncertainty the value is quoted as a measurement is (GUM
  // 7.2.6): u to two significant digits, the value to u's last digit.
  const bool with_u = finite && m.qualifier != pb::UPPER_BOUND && std::isfinite(m.uncertainty);
  const bool quoted = with_u && m.uncertainty > 0;
  const auto [number, u] =
      quoted ? QuotedWithUncertainty(v, m.uncertainty) : std::pair<std::string, std::string>{};
  Add(&out, "<span class=\"v\">", quoted ? HtmlNumber(number) : Human(v), "</span>");
  if (finite && m.qualifier == pb::MINIMUM_NOT_RESOLVED)
    out += "<span class=\"mk\">&dagger;</span>";
  if (finite && m.qualifier == pb::MODEL_INADEQUATE) out += "<span class=\"mk\">&Dagger;</span>";
  if (with_u) {
    Add(&out, "<small class=\"pm\"> &plusmn;&nbsp;", quoted ? HtmlNumber(u) : Human(m.uncertainty),
        "</small>");
  }
  out += "</td>";
  return out;
}

std::string IntCell(int64_t v, std::string_view key_attr, std::string_view key) {
  std::string out = "<td class=\"num\"";
  Add(&out, Attr(key_attr, key), Attr("data-v", std::to_string(v)), ">", std::to_string(v),
      "</td>");
  return out;
}

using ReportData = LotReportData;

// ---- sections -------------------------------------------------------------

void Header(const ReportData& d, const std::string& archive_label, std::string* out) {
  const store::LotRow& l = d.lot;
  std::vector<std::string> plans, stations, operators, versions;
  std::string description;
  auto add_unique = [](std::vector<std::string>* v, const std::string& s) {
    if (!s.empty() && std::find(v->begin(), v->end(), s) == v->end()) v->push_back(s);
  };
  for (const RunPlotData& r : d.runs) {
    add_unique(&plans, r.plan.name());
    add_unique(&stations, r.info.station);
    add_unique(&operators, r.info.operator_name);
    add_unique(&versions, r.info.software_version);
    if (description.empty()) description = r.plan.description();
  }
  auto joined = [](const std::vector<std::string>& v) {
    return v.empty() ? std::string("&ndash;") : Esc(Join(v, ", "));
  };
  const char* banner = l.fail > 0                        ? "v-FAIL"
                       : l.marginal + l.inconclusive > 0 ? "v-MARGINAL"
                       : l.pass > 0                      ? "v-PASS"
                                                         : "v-none";
  Add(out, "<header class=\"top\">\n<p class=\"eyebrow\">IMU end-of-line qualification &middot; ",
      "Allan variance (IEEE Std 952)</p>\n<h1>Lot <span data-field=\"lot\"", Attr("data-v", l.lot),
      ">", Esc(l.lot), "</span></h1>\n");
  Add(out, "<p class=\"banner ", banner, "\">Final yield <strong data-field=\"yield\"",
      Attr("data-v", Exact(l.yield)), ">",
      std::isfinite(l.yield) ? Percent(l.yield) : std::string("not measurable"), "</strong>: ");
  if (l.pass + l.marginal + l.fail > 0) {
    Add(out, std::to_string(l.pass + l.marginal), " of ",
        std::to_string(l.pass + l.marginal + l.fail), " judged units pass");
  } else {
    *out += "no judged unit";
  }
  *out += "</p>\n</header>\n";

  Add(out, "<section id=\"summary\" aria-label=\"Lot summary\">\n<dl class=\"facts\">\n");
  auto fact = [out](std::string_view title, std::string_view field, const std::string& v,
                    const std::string& html, const char* cls = "") {
    Add(out, "<div class=\"fact ", cls, "\"><dt>", title, "</dt><dd", Attr("data-field", field),
        Attr("data-v", v), ">", html, "</dd></div>\n");
  };
  std::string plan_html = joined(plans);
  if (!description.empty()) Add(&plan_html, "<small>", Esc(description), "</small>");
  fact("Test plan", "plan", Join(plans, ", "), plan_html, "wide");
  fact("Units", "units", std::to_string(l.units), std::to_string(l.units));
  fact("Runs (with retests)", "runs", std::to_string(l.runs), std::to_string(l.runs));
  fact("PASS", "pass", std::to_string(l.pass), std::to_string(l.pass), "c-PASS");
  fact("MARGINAL", "marginal", std::to_string(l.marginal), std::to_string(l.marginal),
       "c-MARGINAL");
  fact("FAIL", "fail", std::to_string(l.fail), std::to_string(l.fail), "c-FAIL");
  fact("INCONCLUSIVE", "inconclusive", std::to_string(l.inconclusive),
       std::to_string(l.inconclusive), "c-INCONCLUSIVE");
  if (l.aborted > 0) {
    fact("ABORTED", "aborted", std::to_string(l.aborted), std::to_string(l.aborted), "c-ABORTED");
  }
  if (l.error > 0) {
    fact("ERROR", "error", std::to_string(l.error), std::to_string(l.error), "c-ERROR");
  }
  if (l.unjudged > 0) {
    fact("Not judged", "unjudged", std::to_string(l.unjudged), std::to_string(l.unjudged));
  }
  fact("First start", "first_start", std::to_string(l.first_start_utime),
       Esc(IsoTime(l.first_start_utime)));
  fact("Last start", "last_start", std::to_string(l.last_start_utime),
       Esc(IsoTime(l.last_start_utime)));
  fact("Station", "stations", Join(stations, ", "), joined(stations));
  fact("Operator", "operators", Join(operators, ", "),
       operators.empty() ? std::string("not recorded") : joined(operators));
  fact("Software", "software", Join(versions, ", "), joined(versions));
  *out += "</dl>\n";

  // The lot at a glance: one bar, a segment per verdict.
  const double units = static_cast<double>(std::max<int64_t>(l.units, 1));
  *out += "<div class=\"bar\" role=\"img\" aria-label=\"verdicts of the units\">";
  const std::pair<const char*, int64_t> parts[] = {
      {"PASS", l.pass},    {"MARGINAL", l.marginal}, {"INCONCLUSIVE", l.inconclusive},
      {"FAIL", l.fail},    {"ABORTED", l.aborted},   {"ERROR", l.error},
      {"none", l.unjudged}};
  for (const auto& [name, count] : parts) {
    if (count <= 0) continue;
    char width[32];
    std::snprintf(width, sizeof width, "%.3f%%", 100.0 * static_cast<double>(count) / units);
    Add(out, "<span class=\"seg v-", name, "\" style=\"width:", width, "\" title=\"",
        std::to_string(count), " ", name, "\">", std::to_string(count), "</span>");
  }
  Add(out,
      "</div>\n<p class=\"note\">Each unit by its final run in the lot: its latest judged "
      "run (PASS, MARGINAL, FAIL, INCONCLUSIVE), else its latest. Archive ",
      Esc(archive_label), ".</p>\n</section>\n");
}

// First-pass and final yield, retests and why each was made.
void Yields(const ReportData& d, std::string* out) {
  const store::LotRow& l = d.lot;
  auto yield = [](double v) {
    return std::isfinite(v) ? Percent(v) : std::string("not measurable: no judged unit");
  };
  Add(out, "<section id=\"yield\">\n<h2>Yield and retests</h2>\n<dl class=\"facts\">\n",
      "<div class=\"fact\"><dt>First-pass yield</dt><dd data-field=\"first_pass_yield\"",
      Attr("data-v", Exact(l.first_pass_yield)), ">", yield(l.first_pass_yield), "</dd></div>\n",
      "<div class=\"fact\"><dt>Final yield</dt><dd data-field=\"final_yield\"",
      Attr("data-v", Exact(l.yield)), ">", yield(l.yield), "</dd></div>\n",
      "<div class=\"fact\"><dt>Retests</dt><dd data-field=\"retests\"",
      Attr("data-v", std::to_string(l.retests)), ">", std::to_string(l.retests), "</dd></div>\n",
      "<div class=\"fact c-INCONCLUSIVE\"><dt>Retest candidates</dt>",
      "<dd data-field=\"retest_candidates\"", Attr("data-v", std::to_string(l.retest_candidates)),
      ">", std::to_string(l.retest_candidates), "</dd></div>\n</dl>\n");
  if (!d.retests.empty()) {
    *out += "<ul class=\"reasons retests\">\n";
    for (const store::RetestRow& r : d.retests) {
      Add(out, "<li", Attr("data-serial", r.unit), Attr("data-run", r.run_id),
          Attr("data-verdict", r.verdict), Attr("data-next-run", r.next_run_id),
          "><div class=\"who\">", Badge(r.verdict), " <strong>", Esc(r.unit),
          "</strong> <span class=\"run\">run ", Esc(r.run_id), " (", Esc(r.state),
          "), tested again in ", Esc(r.next_run_id), "</span></div>\n<ul>");
      size_t start = 0;
      bool any = false;
      while (start < r.reasons.size()) {
        const size_t end = r.reasons.find('\n', start);
        Add(out, "<li>", Esc(r.reasons.substr(start, end - start)), "</li>");
        any = true;
        if (end == std::string::npos) break;
        start = end + 1;
      }
      if (!any) *out += "<li>(no reason recorded)</li>";
      *out += "</ul></li>\n";
    }
    *out += "</ul>\n";
  }
  *out +=
      "<p class=\"note\">Final yield: units whose final run is PASS or MARGINAL among those "
      "whose final run is PASS, MARGINAL or FAIL. First-pass yield: units whose first judged "
      "run is PASS or MARGINAL among all units with a judged run. An INCONCLUSIVE unit (a value "
      "within the guard band of a limit) is a "
      "retest candidate, neither a pass nor a loss; ABORTED and ERROR runs say nothing about "
      "the unit and never count. Retests: runs beyond each unit's first.</p>\n</section>\n";
}

// Lots whose runs used early decisions: when each run's unit was decided
// and the soak time that saved (horizon - decision time over the runs).
void EarlyDecisions(const ReportData& d, std::string* out) {
  const EarlyDecisionSummary& e = d.early;
  if (e.runs.empty()) return;
  auto fact = [out](std::string_view title, std::string_view field, const std::string& v,
                    const std::string& html) {
    Add(out, "<div class=\"fact\"><dt>", title, "</dt><dd", Attr("data-field", field),
        Attr("data-v", v), ">", html, "</dd></div>\n");
  };
  *out += "<section id=\"early-decisions\">\n<h2>Early decisions</h2>\n<dl class=\"facts\">\n";
  fact("Runs decided early", "runs_decided", std::to_string(e.decided),
       std::to_string(e.decided) + " of " + std::to_string(e.runs.size()));
  fact("Soak time saved", "soak_saved_s", Exact(e.saved_s),
       Esc(DecisionTimeText(e.saved_s)) + " <small>of " + Esc(DecisionTimeText(e.horizon_total_s)) +
           " (" + Percent(e.horizon_total_s > 0 ? e.saved_s / e.horizon_total_s : 0.0) +
           ")</small>");
  fact("Median decided / full soak", "median_decision_ratio", Exact(e.median_ratio),
       Human(e.median_ratio));
  *out +=
      "</dl>\n<div class=\"scroll\"><table class=\"sortable early\">\n<caption>Runs with early "
      "decisions</caption>\n<thead><tr><th scope=\"col\">Unit</th><th scope=\"col\">Run</th>"
      "<th scope=\"col\">Verdict</th><th scope=\"col\" class=\"num\">Decided at "
      "<span class=\"u\">[s]</span></th><th scope=\"col\" class=\"num\">Full soak "
      "<span class=\"u\">[s]</span></th><th scope=\"col\" class=\"num\">Decided / full</th>"
      "<th scope=\"col\">Decision</th></tr></thead>\n<tbody>\n";
  for (const DecidedRun& r : e.runs) {
    const bool decided = std::isfinite(r.decision_time_s);
    const double ratio = decided && r.horizon_s > 0 ? r.decision_time_s / r.horizon_s : 1.0;
    Add(out, "<tr", Attr("data-run", r.run_id),
        Attr("data-decision-time", Exact(r.decision_time_s)), Attr("data-serial", r.unit),
        "><td class=\"unit\">", Esc(r.unit), "</td><td>", Esc(r.run_id), "</td>",
        VerdictCell(r.verdict, "run_verdict"), "<td class=\"num\"",
        Attr("data-v", Exact(r.decision_time_s)), ">",
        decided ? Human(r.decision_time_s) : std::string("full soak"), "</td>",
        NumCell(r.horizon_s, "data-field", "horizon_s"),
        NumCell(ratio, "data-field", "decided_ratio"), "<td>", Esc(r.note), "</td></tr>\n");
  }
  *out +=
      "</tbody></table></div>\n<p class=\"note\">A plan's early_decision looks at the unit "
      "every look period of analysed device time and decides each judged measurement as soon as "
      "its data confirm the side of each limit, at the plan's risk over all looks "
      "(group-sequential bounds); the run then ends, each decided measurement judged by its "
      "decision. A unit "
      "still pending at the last look soaks its full length (its horizon) and gets the "
      "full-length verdict. Soak time saved: the sum over the runs of the horizon less the "
      "decision time (retests included; the warm-up is not counted).</p>\n</section>\n";
}

void Attention(const ReportData& d, const std::map<std::string, std::string>& plot_anchor,
               std::string* out) {
  const std::vector<const RunPlotData*> flagged = NeedALook(d.runs);
  *out +=
      "<section id=\"attention\">\n<h2>Units that fail, are marginal or inconclusive, were "
      "not measured to the end, or whose record shows a stationarity event</h2>\n";
  if (flagged.empty()) {
    *out += "<p class=\"ok\">Every judged unit passes without a marginal value.</p>\n</section>\n";
    return;
  }
  *out += "<ul class=\"reasons\">\n";
  for (const RunPlotData* r : flagged) {
    Add(out, "<li", Attr("data-serial", r->info.serial), Attr("data-run", r->info.run_id),
        Attr("data-verdict", r->verdict), "><div class=\"who\">", Badge(r->verdict), " <strong>",
        Esc(r->info.serial), "</strong> <span class=\"run\">run ", Esc(r->info.run_id), "</span>");
    auto it = plot_anchor.find(r->info.run_id);
    if (it != plot_anchor.end()) Add(out, " <a href=\"#", it->second, "\">plot</a>");
    *out += "</div>\n<ul>";
    for (const std::string& reason : r->reasons) Add(out, "<li>", Esc(reason), "</li>");
    if (r->reasons.empty()) *out += "<li>(no reason recorded)</li>";
    *out += "</ul></li>\n";
  }
  *out += "</ul>\n</section>\n";
}

// The per unit and axis table of one axis kind.
void UnitTable(const ReportData& d, const std::string& kind, std::string* out) {
  const bool accel = kind == "accel";
  const pb::AxisKind pkind = accel ? pb::ACCEL : pb::GYRO;
  struct Column {
    std::string_view measurement;  // catalogued name (units, limits, outcome)
    std::string_view key;          // data-m
    const char* title;
    double store::AxisRow::*field;
    store::ValueMarks store::AxisRow::*marks;
  };
  const Column columns[] = {
      {accel ? judge::kVelocityRandomWalk : judge::kAngleRandomWalk, "random_walk",
       accel ? "VRW" : "ARW", &store::AxisRow::random_walk, &store::AxisRow::random_walk_marks},
      {judge::kBiasInstability, "bias_instability", "Bias instability",
       &store::AxisRow::bias_instability, &store::AxisRow::bias_instability_marks},
      {judge::kBiasInstabilityIeee, "bias_instability_ieee", "B (IEEE)",
       &store::AxisRow::bias_instability_ieee, &store::AxisRow::bias_instability_ieee_marks},
      {judge::kTauAtMinimum, "tau_min_s", "\u03C4 at min.", &store::AxisRow::tau_min_s,
       &store::AxisRow::tau_min_marks},
      {judge::kRateRandomWalk, "rate_random_walk", "RRW", &store::AxisRow::rate_random_walk,
       &store::AxisRow::rate_random_walk_marks},
  };
  Add(out, "<div class=\"scroll\"><table class=\"sortable results\"", Attr("data-kind", kind),
      ">\n<caption>", accel ? "Accelerometer" : "Gyro", " axes</caption>\n<thead><tr>",
      "<th scope=\"col\">Unit</th><th scope=\"col\">Axis</th>");
  for (const Column& c : columns) {
    const judge::MeasurementDef* def = judge::FindMeasurement(c.measurement);
    const std::string unit = def ? PrettyUnit(judge::UnitFor(*def, pkind)) : "";
    // The limit under the header when every row has the same one.
    std::set<std::tuple<std::optional<double>, std::optional<double>, std::optional<double>,
                        std::optional<double>>>
        limits;
    for (const store::MeasurementRow& m : d.measurements) {
      if (m.kind == kind && m.name == c.measurement) {
        limits.emplace(m.low, m.high, m.marginal_low, m.marginal_high);
      }
    }
    std::string limit;
    if (limits.size() == 1) {
      const auto& [lo, hi, mlo, mhi] = *limits.begin();
      limit = LimitText(lo, hi, mlo, mhi);
    } else if (limits.size() > 1) {
      limit = "limits vary";
    }
    Add(out, "<th scope=\"col\" class=\"num\">", c.title);
    if (!unit.empty()) Add(out, " <span class=\"u\">[", unit, "]</span>");
    if (!limit.empty()) Add(out, "<span class=\"lim\">", limit, "</span>");
    *out += "</th>";
  }
  *out +=
      "<th scope=\"col\" class=\"num\">Gap samples</th><th scope=\"col\">Axis verdict</th>"
      "<th scope=\"col\">Unit verdict</th></tr></thead>\n<tbody>\n";
  std::string previous_run;
  std::set<pb::Qualifier> used;
  std::vector<std::string> not_measurable;
  bool any_uncertainty = false;
  for (const store::AxisRow& r : d.rows) {
    if (r.kind != kind) continue;
    *out += r.run_id != previous_run ? "<tr class=\"unit-start\"" : "<tr";
    previous_run = r.run_id;
    Add(out, Attr("data-run", r.run_id), Attr("data-serial", r.unit), Attr("data-axis", r.axis),
        "><td class=\"unit\" title=\"run ", Esc(r.run_id), "\">", Esc(r.unit), "</td><td>",
        Esc(r.axis), "</td>");
    for (const Column& c : columns) {
      auto it = d.by_key.find({r.run_id, r.axis, std::string(c.measurement)});
      const std::string outcome = it != d.by_key.end() ? OutcomeName(it->second->outcome) : "";
      *out += ValueCell(r.*c.field, c.key, outcome, r.*c.marks);
      const store::ValueMarks& m = r.*c.marks;
      if (m.qualifier != pb::QUALIFIER_NONE) used.insert(m.qualifier);
      if (m.qualifier == pb::NOT_MEASURABLE) {
        not_measurable.push_back(Esc(r.unit + " " + r.axis + " " + std::string(c.measurement)) +
                                 ": " + Esc(m.note.empty() ? "no reason recorded" : m.note));
      }
      any_uncertainty |= std::isfinite(m.uncertainty);
    }
    *out += IntCell(r.gap_samples, "data-m", "gap_samples");
    *out += VerdictCell(r.axis_verdict, "axis_verdict");
    *out += VerdictCell(r.run_verdict, "run_verdict");
    *out += "</tr>\n";
  }
  *out += "</tbody></table></div>\n";
  // The legend of the marks this table uses.
  std::string legend;
  if (any_uncertainty) {
    legend += "<li><span class=\"mk\">&plusmn;&nbsp;u</span> the value's 1-sigma uncertainty</li>";
  }
  const std::pair<pb::Qualifier, const char*> marks[] = {{pb::UPPER_BOUND, "&le;"},
                                                         {pb::MINIMUM_NOT_RESOLVED, "&dagger;"},
                                                         {pb::MODEL_INADEQUATE, "&Dagger;"}};
  for (const auto& [q, mark] : marks) {
    if (!used.count(q)) continue;
    Add(&legend, "<li", Attr("data-q", store::QualifierText(q)), "><span class=\"mk\">", mark,
        "</span> ", Esc(QualifierExplanation(q)), "</li>");
  }
  for (const std::string& line : not_measurable) {
    Add(&legend,
        "<li data-q=\"not_measurable\"><span class=\"mk\">n/m</span> not measurable: ", line,
        "</li>");
  }
  if (!legend.empty())
    Add(out, "<ul class=\"legend\"", Attr("data-kind", kind), ">", legend, "</ul>\n");
}

void Results(const ReportData& d, std::string* out) {
  *out += "<section id=\"results\">\n<h2>Results per unit and axis</h2>\n";
  std::vector<std::string> kinds;
  for (const store::AxisRow& r : d.rows) {
    if (std::find(kinds.begin(), kinds.end(), r.kind) == kinds.end()) kinds.push_back(r.kind);
  }
  for (const std::string& kind : kinds) UnitTable(d, kind, out);
  *out +=
      "<p class=\"note\">A value is coloured when its own limit judged it MARGINAL, "
      "INCONCLUSIVE (within the guard band of a limit: a retest candidate) or FAIL; "
      "&plusmn; is its 1-sigma uncertainty, and its marks are explained under each table. "
      "Axis verdict: the worst outcome of the axis's measurements; unit verdict: the run's, "
      "which also includes run-level measurements (duration, gaps). Click a column header to "
      "sort.</p>\n</section>\n";
}

// `judged`: the rows have limits, and the table shows them with the yield
// and capability (columns that would be empty for the other rows).
void StatisticsTable(const std::vector<const MeasurementStats*>& rows, const char* caption,
                     bool judged, std::string* out) {
  if (rows.empty()) return;
  Add(out, "<div class=\"scroll\"><table class=\"sortable stats\">\n<caption>", caption,
      "</caption>\n<thead><tr><th scope=\"col\">Measurement</th><th scope=\"col\">Axis</th>"
      "<th scope=\"col\">Unit</th><th scope=\"col\" class=\"num\">n</th>"
      "<th scope=\"col\" class=\"num\">Mean</th><th scope=\"col\" class=\"num\">SD</th>"
      "<th scope=\"col\" class=\"num\">Min</th><th scope=\"col\" class=\"num\">Max</th>");
  if (judged) {
    *out +=
        "<th scope=\"col\" class=\"num\">Low limit</th><th scope=\"col\" class=\"num\">High "
        "limit</th><th scope=\"col\" class=\"num\">Yield</th><th scope=\"col\" "
        "class=\"num\">Capability</th>";
  }
  *out += "</tr></thead>\n<tbody>\n";
  for (const MeasurementStats* s : rows) {
    const judge::Summary& m = s->summary;
    Add(out, "<tr", Attr("data-axis", s->axis), Attr("data-name", s->name),
        Attr("data-unit", s->unit), "><td", Attr("data-sort", std::to_string(LabelIndex(s->name))),
        ">", MeasurementTitle(s->name), " <code>", Esc(s->name), "</code></td><td>",
        s->axis.empty() ? std::string("run") : Esc(s->axis), "</td><td>", PrettyUnit(s->unit),
        "</td>");
    *out += IntCell(m.n, "data-stat", "n");
    *out += NumCell(m.mean, "data-stat", "mean");
    *out += NumCell(m.sd, "data-stat", "sd");
    *out += NumCell(m.min, "data-stat", "min");
    *out += NumCell(m.max, "data-stat", "max");
    if (!judged) {
      *out += "</tr>\n";
      continue;
    }
    *out += NumCell(s->low ? *s->low : allan::kNaN, "data-stat", "low");
    *out += NumCell(s->high ? *s->high : allan::kNaN, "data-stat", "high");
    // Yield: the percentage and passed/judged.
    const char* yield_class = !std::isfinite(m.yield) ? "" : m.yield < 1 ? " o-FAIL" : "";
    Add(out, "<td class=\"num", yield_class, "\" data-stat=\"yield\"",
        Attr("data-v", Exact(m.yield)), Attr("data-passed", std::to_string(m.passed)),
        Attr("data-judged", std::to_string(m.judged)), ">", Percent(m.yield));
    if (m.judged > 0) {
      Add(out, " <small>(", std::to_string(m.passed), "/", std::to_string(m.judged), ")</small>");
    }
    *out += "</td>";
    // Capability against the customary 1.33 (4 sigma) and 1.0 (3 sigma).
    const char* cap_class = !std::isfinite(m.capability) ? ""
                            : m.capability < 1.0         ? " cap-bad"
                            : m.capability < 1.33        ? " cap-warn"
                                                         : " cap-ok";
    Add(out, "<td class=\"num", cap_class, "\" data-stat=\"capability\"",
        Attr("data-v", Exact(m.capability)), Attr("data-kind", m.capability_kind),
        Attr("data-lo", Exact(m.capability_low)), Attr("data-hi", Exact(m.capability_high)));
    if (std::isfinite(m.capability)) {
      Add(out, "><small>", m.capability_kind, "</small> ", Human(m.capability), " <small>[",
          Human(m.capability_low), ", ", Human(m.capability_high), "]</small>");
    } else if (!m.capability_kind.empty() && m.n < judge::kMinCapabilityN) {
      Add(out,
          Attr("title", "not measurable: " + std::to_string(m.n) + " values, fewer than " +
                            std::to_string(judge::kMinCapabilityN)),
          "><small>n&nbsp;&lt;&nbsp;", std::to_string(judge::kMinCapabilityN), "</small>");
    } else {
      Add(out, ">", Human(m.capability));
    }
    *out += "</td></tr>\n";
  }
  *out += "</tbody></table></div>\n";
}

void Statistics(const ReportData& d, std::string* out) {
  // Catalogue order, then the axes in order of appearance (stable).
  std::vector<const MeasurementStats*> sorted;
  for (const MeasurementStats& s : d.stats) sorted.push_back(&s);
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto* a, const auto* b) {
    return LabelIndex(a->name) < LabelIndex(b->name);
  });
  std::vector<const MeasurementStats*> judged, other;
  for (const MeasurementStats* s : sorted) (s->low || s->high ? judged : other).push_back(s);
  *out += "<section id=\"statistics\">\n<h2>Lot statistics</h2>\n";
  StatisticsTable(judged, "Measurements with limits", true, out);
  StatisticsTable(other, "Other measurements (no limits)", false, out);
  *out +=
      "<p class=\"note\">SD: sample standard deviation (n&nbsp;&minus;&nbsp;1). Yield: PASS or "
      "MARGINAL among the judged values. Capability: Cpk&nbsp;=&nbsp;min(USL&nbsp;&minus;&nbsp;"
      "mean, mean&nbsp;&minus;&nbsp;LSL)&nbsp;/&nbsp;3&nbsp;SD with both limits, Cpu or Cpl with "
      "one, with its 95&nbsp;% interval in brackets (Bissell's approximation, for normally "
      "distributed values); none from fewer than " +
      std::to_string(judge::kMinCapabilityN) +
      " values; green from 1.33, amber from 1.0, red below.</p>\n</section>\n";
}

// A plot; `attributes` (already escaped) on the figure, `caption_html`
// (already escaped) under it, if any.
void Figure(const AllanPlot& plot, const std::string& attributes, const std::string& caption_html,
            std::string* out) {
  Add(out, "<figure", attributes, ">\n", plot.svg);
  if (!caption_html.empty()) Add(out, "<figcaption>", caption_html, "</figcaption>\n");
  *out += "</figure>\n";
}

constexpr char kStyle[] = R"css(
:root { --ink: #1f2328; --muted: #59636e; --line: #d1d9e0; --zebra: #f6f8fa;
  --pass: #1a7f37; --pass-bg: #dafbe1; --marg: #8a5a00; --marg-bg: #fff1c2;
  --fail: #c11f2b; --fail-bg: #ffe3e0; --inc: #5a32a3; --inc-bg: #efe6ff;
  --err: #7d4e00; --err-bg: #fbefd5; }
* { box-sizing: border-box; }
body { margin: 0; color: var(--ink); background: #fff;
  font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 1720px; margin: 0 auto; padding: 0 24px 48px; }
header.top { padding: 28px 0 8px; border-bottom: 1px solid var(--line); margin-bottom: 16px; }
.eyebrow { margin: 0; color: var(--muted); text-transform: uppercase; letter-spacing: .06em; font-size: 12px; }
h1 { margin: 4px 0 10px; font-size: 30px; }
h2 { margin: 36px 0 12px; font-size: 20px; border-bottom: 1px solid var(--line); padding-bottom: 4px; }
.banner { display: inline-block; margin: 0 0 8px; padding: 6px 14px; border-radius: 6px; font-size: 16px; }
.banner.v-PASS { background: var(--pass-bg); color: var(--pass); }
.banner.v-MARGINAL { background: var(--marg-bg); color: var(--marg); }
.banner.v-FAIL { background: var(--fail-bg); color: var(--fail); }
.banner.v-none { background: var(--zebra); color: var(--muted); }
nav { margin: 12px 0; color: var(--muted); }
nav a { margin-right: 14px; }
nav.site { margin: 0; background: #1d2329; color: #fff; padding: 8px 16px; display: flex;
           gap: 18px; align-items: center; flex-wrap: wrap; font: 14px/1.45 system-ui, sans-serif; }
nav.site a { margin-right: 0; color: #fff; text-decoration: none; font-weight: 600; }
nav.site form { margin-left: auto; }
a { color: #0969da; }
.facts { display: grid; grid-template-columns: repeat(auto-fill, minmax(150px, 1fr)); gap: 10px; margin: 0; }
.fact { border: 1px solid var(--line); border-radius: 6px; padding: 8px 12px; }
.fact.wide { grid-column: span 2; }
.fact dt { color: var(--muted); font-size: 12px; }
.fact dd { margin: 2px 0 0; font-size: 17px; font-weight: 600; font-variant-numeric: tabular-nums;
          overflow-wrap: anywhere; }
.fact dd small { display: block; font-size: 12px; font-weight: 400; color: var(--muted); }
.fact.c-PASS dd { color: var(--pass); } .fact.c-MARGINAL dd { color: var(--marg); }
.fact.c-FAIL dd { color: var(--fail); }
.fact.c-INCONCLUSIVE dd { color: var(--inc); } .fact.c-ERROR dd { color: var(--err); }
.bar { display: flex; height: 22px; margin: 14px 0 4px; border-radius: 4px; overflow: hidden;
  border: 1px solid var(--line); font-size: 12px; font-weight: 600; }
.seg { display: flex; align-items: center; justify-content: center; min-width: 1.6em; }
.seg.v-PASS { background: var(--pass-bg); color: var(--pass); }
.seg.v-MARGINAL { background: var(--marg-bg); color: var(--marg); }
.seg.v-FAIL { background: var(--fail-bg); color: var(--fail); }
.seg.v-INCONCLUSIVE { background: var(--inc-bg); color: var(--inc); }
.seg.v-ABORTED { background: #eaeef2; color: var(--ink); }
.seg.v-ERROR { background: var(--err-bg); color: var(--err); }
.seg.v-none { background: var(--zebra); color: var(--muted); }
.note { color: var(--muted); font-size: 12.5px; max-width: 110ch; }
.ok { color: var(--pass); font-weight: 600; }
.badge { display: inline-block; min-width: 5.6em; text-align: center; padding: 1px 8px; border-radius: 10px;
  font-size: 12px; font-weight: 700; letter-spacing: .02em; }
.badge.v-PASS { background: var(--pass-bg); color: var(--pass); }
.badge.v-MARGINAL { background: var(--marg-bg); color: var(--marg); }
.badge.v-FAIL { background: var(--fail-bg); color: var(--fail); }
.badge.v-INCONCLUSIVE { background: var(--inc-bg); color: var(--inc); }
.badge.v-ABORTED { background: var(--zebra); color: var(--ink); border: 1px dashed var(--muted); }
.badge.v-ERROR { background: var(--err-bg); color: var(--err); border: 1px solid var(--err); }
.badge.v-none { background: var(--zebra); color: var(--muted); font-weight: 400; }
ul.reasons { list-style: none; padding: 0; margin: 0; display: grid;
  grid-template-columns: repeat(auto-fill, minmax(380px, 1fr)); gap: 10px; }
ul.reasons > li { border: 1px solid var(--line); border-radius: 6px; padding: 8px 12px; }
ul.reasons > li[data-verdict="FAIL"] { border-left: 4px solid var(--fail); }
ul.reasons > li[data-verdict="MARGINAL"] { border-left: 4px solid #d4a72c; }
ul.reasons > li[data-verdict="INCONCLUSIVE"] { border-left: 4px solid var(--inc); }
ul.reasons > li[data-verdict="ABORTED"] { border-left: 4px dashed var(--muted); }
ul.reasons > li[data-verdict="ERROR"] { border-left: 4px solid var(--err); }
ul.reasons ul { margin: 6px 0 0; padding-left: 18px; }
.run { color: var(--muted); font-size: 12px; font-family: ui-monospace, SFMono-Regular, Menlo, monospace; }
.scroll { overflow-x: auto; margin-bottom: 18px; }
table { border-collapse: collapse; font-variant-numeric: tabular-nums; }
caption { text-align: left; font-weight: 600; padding: 4px 0 6px; }
th, td { padding: 4px 10px; border-bottom: 1px solid var(--line); white-space: nowrap; }
thead th { position: sticky; top: 0; background: #eef1f4; text-align: left; vertical-align: bottom;
  font-weight: 600; cursor: pointer; user-select: none; }
thead th:focus { outline: 2px solid #0969da; outline-offset: -2px; }
thead th[aria-sort="ascending"]::after { content: " \25B2"; font-size: 10px; }
thead th[aria-sort="descending"]::after { content: " \25BC"; font-size: 10px; }
th .u { font-weight: 400; color: var(--muted); }
th .lim { display: block; font-weight: 400; font-size: 11.5px; color: var(--muted); }
.num { text-align: right; }
tbody tr:nth-child(even) { background: var(--zebra); }
tbody tr:hover { background: #eaf2fb; }
table.results:not([data-sorted]) tr.unit-start:not(:first-child) td { border-top: 2px solid #b6c2cf; }
td.o-MARGINAL { background: var(--marg-bg); color: var(--marg); font-weight: 600; }
td.o-FAIL { background: var(--fail-bg); color: var(--fail); font-weight: 700; }
td.o-INCONCLUSIVE { background: var(--inc-bg); color: var(--inc); font-weight: 600; }
td .mk { color: var(--muted); font-weight: 400; }
td.num small.pm { color: var(--muted); font-weight: 400; }
ul.legend { list-style: none; padding-left: 0; margin: 4px 0 14px; color: var(--muted); font-size: 12.5px; }
ul.legend .mk { display: inline-block; min-width: 2.2em; color: var(--ink); }
td.cap-ok { color: var(--pass); } td.cap-warn { color: var(--marg); font-weight: 600; }
td.cap-bad { color: var(--fail); font-weight: 700; }
td small { color: var(--muted); font-weight: 400; }
td.num.o-FAIL small { color: inherit; }
td code { color: var(--muted); font-size: 11px; }
td.unit { font-weight: 600; }
.plots { display: flex; flex-wrap: wrap; gap: 16px; }
figure { margin: 0; border: 1px solid var(--line); border-radius: 6px; padding: 8px;
  flex: 0 1 820px; min-width: 0; }
figure svg { width: 100%; height: auto; display: block; }
figcaption { color: var(--muted); font-size: 12.5px; padding: 4px 4px 0; }
footer { margin-top: 40px; border-top: 1px solid var(--line); padding-top: 10px; color: var(--muted); font-size: 12.5px; }
@media print {
  main { max-width: none; padding: 0; }
  thead th { position: static; }
  figure, tr, ul.reasons > li { break-inside: avoid; }
  nav { display: none; }
}
)css";

// Sortable tables: a click (or Enter) on a header sorts by that column,
// again to reverse. Cells sort by data-sort, else data-v (number; empty
// last), else their text.
constexpr char kScript[] = R"js(
(function () {
  'use strict';
  function key(row, col) {
    var cell = row.cells[col];
    var s = cell.getAttribute('data-sort');
    if (s === null) s = cell.getAttribute('data-v');
    if (s !== null) return s === '' ? null : Number(s);
    return cell.textContent.trim();
  }
  function sortBy(table, col, th) {
    var ascending = th.getAttribute('aria-sort') !== 'ascending';
    Array.prototype.forEach.call(th.parentNode.cells, function (c) {
      c.setAttribute('aria-sort', 'none');
    });
    th.setAttribute('aria-sort', ascending ? 'ascending' : 'descending');
    table.setAttribute('data-sorted', '');
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    rows.sort(function (a, b) {
      var x = key(a, col), y = key(b, col);
      if (x === null || y === null) return x === y ? 0 : (x === null ? 1 : -1);
      var c = (typeof x === 'number' && typeof y === 'number')
          ? x - y : String(x).localeCompare(String(y), undefined, {numeric: true});
      return ascending ? c : -c;
    });
    rows.forEach(function (r) { body.appendChild(r); });
  }
  // A section a served page leaves to be fetched (noise models, plots):
  // its place holds a note until it arrives.
  document.querySelectorAll('section[data-src]').forEach(function (section) {
    fetch(section.getAttribute('data-src'), {credentials: 'same-origin'})
      .then(function (r) {
        if (!r.ok) throw new Error('status ' + r.status);
        return r.text();
      })
      .then(function (html) {
        if (html.trim() === '') section.remove(); else section.outerHTML = html;
      })
      .catch(function (e) {
        var note = section.querySelector('p');
        if (note) note.textContent = 'This section could not be loaded (' + e.message + '): reload the page.';
        section.removeAttribute('aria-busy');
      });
  });
  document.querySelectorAll('table.sortable').forEach(function (table) {
    var head = table.tHead.rows[0];
    Array.prototype.forEach.call(head.cells, function (th, col) {
      th.setAttribute('tabindex', '0');
      th.setAttribute('aria-sort', 'none');
      th.addEventListener('click', function () { sortBy(table, col, th); });
      th.addEventListener('keydown', function (e) {
        if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); sortBy(table, col, th); }
      });
    });
  });
})();
)js";

// The lot noise model of each axis (lot_model_view.h): the model, its
// figures with their sigmas, the spread between units, and the
// units inconsistent with their lot.
void LotModelSection(const std::vector<AxisLotModel>& models, std::string* out) {
  *out +=
      "<section id=\"lot-model\">\n<h2>Lot noise model</h2>\n<div class=\"scroll\"><table "
      "class=\"lot-model\">\n<thead><tr><th scope=\"col\">Axis</th><th scope=\"col\" "
      "class=\"num\">Units</th><th scope=\"col\">Model</th><th scope=\"col\" "
      "class=\"num\">J-test p</th><th scope=\"col\" class=\"num\">Random walk "
      "(ARW/VRW)</th><th scope=\"col\" class=\"num\">Bias instability (min/0.664)</th><th "
      "scope=\"col\" class=\"num\">Rate random walk</th><th scope=\"col\" "
      "class=\"num\">Spread short/long &tau;</th><th scope=\"col\">Inconsistent "
      "units</th></tr></thead>\n<tbody>\n";
  for (const AxisLotModel& m : models) {
    Add(out, "<tr", Attr("data-axis", m.axis), "><td>", Esc(m.axis), "</td><td class=\"num\">",
        std::to_string(m.curves), "</td>");
    if (!m.model.ok()) {
      Add(out, "<td colspan=\"7\" class=\"note\">not measurable: ", Esc(m.model.status().message()),
          "</td></tr>\n");
      continue;
    }
    const allan::LotModel& lm = *m.model;
    const std::vector<allan::ModelQuantity> q = allan::DescribeCompositeFit(
        lm.fit, m.kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro);
    auto figure = [&](const std::string& name, const char* key) {
      for (const allan::ModelQuantity& x : q) {
        if (x.name != name) continue;
        const bool absent = x.absent;
        if (!lm.fit.adequate) return std::string("<td class=\"num\">&ndash;</td>");
        std::string cell = "<td class=\"num\"" + Attr("data-m", key) +
                           Attr("data-v", Exact(absent ? x.upper_bound : x.value)) + ">";
        if (absent) {
          Add(&cell,
              std::isfinite(x.upper_bound) ? "&le;&nbsp;" + Human(x.upper_bound) : "&ndash;");
        } else {
          if (std::isfinite(x.sigma) && x.sigma > 0) {
            const auto [number, u] = QuotedWithUncertainty(x.value, x.sigma);
            Add(&cell, HtmlNumber(number), " &plusmn; ", HtmlNumber(u));
          } else {
            Add(&cell, Human(x.value), " &plusmn; ", Human(x.sigma));
          }
        }
        Add(&cell, " ", PrettyUnit(x.unit), "</td>");
        return cell;
      }
      return std::string("<td class=\"num\">&ndash;</td>");
    };
    char p_value[32];
    std::snprintf(p_value, sizeof p_value, "%.3g", lm.fit.p_value);
    Add(out, "<td>", Esc(lm.fit.model.Name()), lm.fit.adequate ? "" : " (inadequate)");
    if (!lm.left_out.empty()) {
      Add(out, "<br><span class=\"note\">", Esc(LeftOutNote(lm).substr(2)), "</span>");
    }
    Add(out, "</td><td class=\"num\">", p_value, "</td>",
        figure(m.kind == pb::ACCEL ? "velocity_random_walk" : "angle_random_walk", "random_walk"),
        figure("bias_instability_ieee", "bias_instability"),
        figure("rate_random_walk", "rate_random_walk"));
    char spread[64];
    std::snprintf(spread, sizeof spread, "&times;%.3g / &times;%.3g",
                  lm.points.front().spread_factor, lm.points.back().spread_factor);
    Add(out, "<td class=\"num\">", spread, "</td><td>");
    bool any = false;
    for (const allan::UnitConsistency& c : lm.consistency) {
      if (c.consistent) continue;
      char why[96];
      std::snprintf(why, sizeof why, " (&times;%.3g at %.3g&nbsp;s, p&nbsp;%.2g)", c.worst_factor,
                    c.worst_tau_s, c.p_value);
      Add(out, any ? "; " : "", "<span class=\"o-FAIL\">", Esc(c.unit), "</span>", why);
      any = true;
    }
    Add(out, any ? "" : "none", "</td></tr>\n");
  }
  *out +=
      "</tbody></table></div>\n<p class=\"note\">The units' Allan variances pooled per octave "
      "(multi-signal wavelet variance) and the composite noise model fitted to them as one long "
      "record; &plusmn; is the 1-sigma precision of that lot-mean model from these records (the "
      "spread of the production is the next column), &le; a 95&nbsp;% upper bound for a term the "
      "model leaves out; an inadequate model (J-test p below 1&nbsp;%) gives no figures. "
      "Spread: the units' 1-sigma factor on the deviation at the shortest and longest pooled "
      "&tau;. A unit is inconsistent when at some &tau; it lies outside the other units' "
      "prediction interval (Student t, Bonferroni over the &tau;s, 1&nbsp;%); the model is "
      "fitted to the units consistent with their lot, those left out named (unless fewer than "
      "half are consistent: then every unit is pooled).</p>\n</section>\n";
}

}  // namespace

Result<LotReportData> LoadLotReport(store::Archive& archive, const std::string& lot,
                                    LotReportLoad load) {
  const bool all = load == LotReportLoad::kAll;
  LotReportData d;
  auto lots = store::QueryLots(archive, lot);
  if (!lots.ok()) return lots.status();
  auto lot_row = std::find_if(lots->begin(), lots->end(),
                              [&](const store::LotRow& l) { return l.lot == lot; });
  if (lot_row == lots->end()) {
    return Status::NotFound("no lot '" + lot + "' in " + archive.path() +
                            " (imuqual lots lists them)");
  }
  d.lot = *lot_row;
  store::AxisRowFilter filter;
  filter.lot = lot;
  auto rows = store::QueryAxisRows(archive, filter);
  if (!rows.ok()) return rows.status();
  d.rows = std::move(*rows);
  auto measurements = store::QueryLotMeasurements(archive, lot);
  if (!measurements.ok()) return measurements.status();
  d.measurements = std::move(*measurements);
  for (const store::MeasurementRow& m : d.measurements) d.by_key[{m.run_id, m.axis, m.name}] = &m;
  d.stats = ComputeLotStatistics(d.measurements);
  auto retests = store::QueryRetestReasons(archive, lot);
  if (!retests.ok()) return retests.status();
  d.retests = std::move(*retests);
  auto early = QueryEarlyDecisions(archive, lot);
  if (!early.ok()) return early.status();
  d.early = std::move(*early);
  // Every run of the lot at once (four queries, not four per unit).
  // The first view shows each run's verdict and reasons, not its
  // measurements (the lot's final ones come from the query above) or curves.
  auto lot_runs =
      archive.LoadLotRuns(lot, all ? store::LotRunParts::kAll : store::LotRunParts::kRuns);
  if (!lot_runs.ok()) return lot_runs.status();
  std::map<std::string, store::LotRunRecord*> by_id;
  for (store::LotRunRecord& r : *lot_runs) by_id[r.info.run_id] = &r;
  for (const store::AxisRow& r : d.rows) {
    if (!d.runs.empty() && d.runs.back().info.run_id == r.run_id) continue;
    auto it = by_id.find(r.run_id);
    if (it == by_id.end()) {
      return Status::Corruption("run " + r.run_id + " of lot " + lot + " vanished while read");
    }
    store::LotRunRecord& run = *it->second;
    d.runs.push_back(MakeRunPlotData(std::move(run.info), run.result, run.curves));
  }
  // The raw samples of the units the report shows on their own.
  for (const RunPlotData* r : all ? NeedALook(d.runs) : std::vector<const RunPlotData*>()) {
    auto series = RunTimeSeriesSvg(archive, r->info.run_id);
    d.series[r->info.run_id] = series.ok() ? LotReportData::Series{*series, Status::Ok()}
                                           : LotReportData::Series{"", series.status()};
    auto davar = RunDynamicAllanSvgs(archive, r->info.run_id);
    d.davar[r->info.run_id] = davar.ok() ? LotReportData::DynamicAllanPlots{*davar, Status::Ok()}
                                         : LotReportData::DynamicAllanPlots{{}, davar.status()};
  }
  return d;
}

Result<std::string> BuildLotReportHtml(store::Archive& archive, const std::string& lot,
                                       const std::string& archive_label,
                                       const LotReportOptions& options) {
  auto d = LoadLotReport(archive, lot,
                         options.section_url ? LotReportLoad::kFirstView : LotReportLoad::kAll);
  if (!d.ok()) return d.status();
  return RenderLotReportHtml(*d, archive_label, options);
}

std::string RenderLotModelSection(const LotReportData& d) {
  std::string html;
  LotModelSection(ComputeLotModels(d.runs), &html);
  return html;
}

namespace {

// The figure id of each flagged unit's first plot (the attention list links
// to it): unit-plot-1, ... over the flagged units' plots in order, one plot
// per kind of axis (as RunAllanPlots draws them).
std::map<std::string, std::string> PlotAnchors(const LotReportData& d) {
  std::map<std::string, std::string> anchors;
  int index = 0;
  for (const RunPlotData* r : NeedALook(d.runs)) {
    std::set<int> kinds;
    for (const AxisPlotData& a : r->axes) kinds.insert(static_cast<int>(a.kind));
    if (kinds.empty()) continue;
    anchors[r->info.run_id] = "unit-plot-" + std::to_string(index + 1);
    index += static_cast<int>(kinds.size());
  }
  return anchors;
}

std::string LotPlotsSection(const LotReportData& d) {
  const std::vector<AllanPlot> lot_plots = LotAllanPlots(d.lot.lot, d.runs, "");
  std::string html = "<section id=\"lot-plots\">\n<h2>Allan deviation: the lot, per axis</h2>\n";
  if (lot_plots.empty()) {
    html += "<p class=\"note\">No Allan curve stored for this lot.</p>\n";
  } else {
    html += "<div class=\"plots\">\n";
    for (const AllanPlot& p : lot_plots) Figure(p, "", "", &html);
    html += "</div>\n";
  }
  html +=
      "<p class=\"note\">Every unit's overlapping Allan deviation on one axis; units whose axis is "
      "judged FAIL, INCONCLUSIVE or MARGINAL are drawn bold, each in its own shade of red, violet "
      "or amber (named in the legend), with their confidence band, and ringed at their curve "
      "minimum; hovering over "
      "a curve names its unit, verdict and minimum. Left axis in datasheet units (deg/h, "
      "&micro;g), right axis in the curve's own unit (deg/s, m/s<sup>2</sup>). Dashed lines: the "
      "plan's limits (red) and marginal band edges "
      "(amber); bias instability against the curve minimum, random walks as the "
      "&minus;&frac12; and +&frac12; slope lines they are read from.</p>\n</section>\n";
  return html;
}

// "" when no unit needs a look.
std::string UnitPlotsSection(const LotReportData& d) {
  std::string unit_figures;
  int figure_index = 0;
  for (const RunPlotData* r : NeedALook(d.runs)) {
    const std::vector<AllanPlot> plots = RunAllanPlots(*r, "");
    for (size_t i = 0; i < plots.size(); ++i) {
      const std::string id = "unit-plot-" + std::to_string(++figure_index);
      std::string caption;
      Add(&caption, Badge(r->verdict), " <strong>", Esc(r->info.serial), "</strong>");
      for (size_t k = 0; k < r->reasons.size(); ++k) {
        Add(&caption, k == 0 ? ": " : "; ", Esc(r->reasons[k]));
      }
      Figure(plots[i], Attr("id", id) + Attr("data-run", r->info.run_id), caption, &unit_figures);
    }
    // Its raw samples against time: where a step, a drift or a burst shows.
    const auto series = d.series.find(r->info.run_id);
    if (series == d.series.end()) continue;
    // A plot that could not be drawn (a damaged chunk) costs that plot only,
    // not the lot's report, and says why.
    const auto not_drawn = [&](const char* kind, const char* what, const Status& status) {
      if (status.code() == Status::Code::kNotFound) return;
      Add(&unit_figures, "<figure", Attr("data-run", r->info.run_id), Attr("data-plot", kind),
          "><figcaption><strong>", Esc(r->info.serial), "</strong>: ", what, ": ",
          Esc(status.message()), "</figcaption></figure>\n");
    };
    if (series->second.status.ok()) {
      AllanPlot plot{"series", "raw samples", series->second.svg};
      Figure(plot, Attr("data-run", r->info.run_id) + Attr("data-plot", "series"),
             "<strong>" + Esc(r->info.serial) + "</strong>: raw samples against time",
             &unit_figures);
    } else {
      not_drawn("series", "raw samples not plotted", series->second.status);
    }
    // Then each axis's dynamic Allan deviation: which stretch of the record
    // the curve's shape comes from.
    const auto davar = d.davar.find(r->info.run_id);
    if (davar == d.davar.end()) continue;
    if (!davar->second.status.ok()) {
      not_drawn("davar", "dynamic Allan deviation not drawn", davar->second.status);
      continue;
    }
    for (const std::string& svg : davar->second.svgs) {
      AllanPlot plot{"davar", "dynamic Allan deviation", svg};
      Figure(plot, Attr("data-run", r->info.run_id) + Attr("data-plot", "davar"),
             "<strong>" + Esc(r->info.serial) + "</strong>: dynamic Allan deviation",
             &unit_figures);
    }
  }
  if (unit_figures.empty()) return "";
  std::string html;
  Add(&html,
      "<section id=\"unit-plots\">\n<h2>Units that need a look: Allan deviation and raw "
      "samples</h2>\n",
      "<div class=\"plots\">\n", unit_figures, "</div>\n",
      "<p class=\"note\">Each axis with its confidence band, its composite noise model "
      "(dashed) and its curve minimum (ringed); then the unit's raw samples against device "
      "time (deg/s, m/s<sup>2</sup> and &deg;C; bin means with their min/max envelope), and "
      "each axis's dynamic Allan deviation (the curve of each quarter of the record after the "
      "warm-up, "
      "early blue to late red: a curve apart from the others is a non-stationary "
      "stretch).</p>\n"
      "</section>\n");
  return html;
}

// A section's place on a served page: a note until the page's script
// fetches it.
std::string DeferredSection(const std::string& id, const std::string& heading,
                            const std::string& note, const std::string& url) {
  std::string html;
  Add(&html, "<section", Attr("id", id), Attr("data-src", url), " aria-busy=\"true\">\n<h2>",
      heading, "</h2>\n<p class=\"note\">", note, "&hellip;</p>\n<noscript><p><a",
      Attr("href", url), ">", heading, "</a> on a page of its own.</p></noscript>\n</section>\n");
  return html;
}

}  // namespace

Result<std::string> RenderLotSection(const LotReportData& d, const std::string& part) {
  if (part == "lot-model") return RenderLotModelSection(d);
  if (part == "lot-plots") return LotPlotsSection(d);
  if (part == "unit-plots") return UnitPlotsSection(d);
  return Status::NotFound("no report section '" + part +
                          "' (lot-model, lot-plots or unit-plots)");
}

std::string RenderLotReportHtml(const LotReportData& d, const std::string& archive_label,
                                const LotReportOptions& options) {
  const std::string& lot = d.lot.lot;
  const bool inline_sections = !options.section_url;
  // The lot noise models (a fit per axis, the slowest part) meanwhile, or
  // fetched by the page's script with the plots.
  std::future<std::string> lot_models;
  if (inline_sections) {
    lot_models = std::async(std::launch::async, [&d] { return RenderLotModelSection(d); });
  }
  const bool any_flagged = !NeedALook(d.runs).empty();
  const std::map<std::string, std::string> plot_anchor = PlotAnchors(d);

  std::string html;
  html.reserve(1 << 20);
  Add(&html, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n",
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n",
      "<meta name=\"generator\"", Attr("content", kSoftwareVersion), ">\n", "<title>Lot ", Esc(lot),
      ": IMU qualification report</title>\n", "<link rel=\"icon\" href=\"data:,\">\n<style>",
      kStyle, "</style>\n</head>\n<body>\n");
  html += options.site_navigation;
  html += "<main>\n";
  Header(d, archive_label, &html);
  // The units to look at come first, where the lot's headline leaves off:
  // on a 1400 x 1000 screen the first failing unit is in view.
  html +=
      "<nav aria-label=\"Contents\"><a href=\"#attention\">Units to look at</a>"
      "<a href=\"#yield\">Yield and retests</a>";
  if (!d.early.runs.empty()) html += "<a href=\"#early-decisions\">Early decisions</a>";
  html +=
      "<a href=\"#results\">Results per unit</a><a href=\"#statistics\">Lot statistics</a>"
      "<a href=\"#lot-model\">Lot noise model</a>"
      "<a href=\"#lot-plots\">Lot Allan plots</a>";
  if (any_flagged) html += "<a href=\"#unit-plots\">Unit plots</a>";
  html += "</nav>\n";
  Attention(d, plot_anchor, &html);
  Yields(d, &html);
  EarlyDecisions(d, &html);
  Results(d, &html);
  Statistics(d, &html);
  if (inline_sections) {
    html += lot_models.get();
    html += LotPlotsSection(d);
    html += UnitPlotsSection(d);
  } else {
    html += DeferredSection("lot-model", "Lot noise model",
                            "Fitting the lot noise model of each axis",
                            options.section_url("lot-model"));
    html += DeferredSection("lot-plots", "Allan deviation: the lot, per axis",
                            "Drawing every unit's curve", options.section_url("lot-plots"));
    if (any_flagged) {
      html += DeferredSection(
          "unit-plots", "Units that need a look: Allan deviation and raw samples",
          "Drawing each flagged unit's curves and raw samples", options.section_url("unit-plots"));
    }
  }
  Add(&html,
      "<footer>Bias instability is the minimum of the overlapping Allan deviation curve "
      "(the datasheet convention); IEEE 952's B is that minimum / 0.664. ARW/VRW are read "
      "at &tau; = 1&nbsp;s on the &minus;&frac12; slope line, RRW at &tau; = 3&nbsp;s on "
      "the +&frac12; line. Generated by ",
      Esc(kSoftwareVersion), " on ", Esc(IsoTime(NowUtime())), ".</footer>\n</main>\n<script>",
      kScript, "</script>\n</body>\n</html>\n");
  return html;
}

std::string_view LotReportScript() { return kScript; }

}  // namespace imuqual::report
