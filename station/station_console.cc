#include "station/station_console.h"

#include <algorithm>
#include <limits>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <utility>

#include "imuqual/decision_t.hpp"
#include "imuqual/measurement_t.hpp"
#include "imuqual/run_t.hpp"
#include "report/early_decisions.h"
#include "report/marks.h"
#include "report/table_writer.h"
#include "store/outcome.h"

namespace imuqual::station {
using report::Cell;
using report::DecisionTimeText;
using report::DisplayWidth;
using report::Format;
using report::kMinimumNotResolvedMark;
using report::kModelInadequateMark;
using report::MarkedValue;
using report::TableWriter;

namespace {

using imuqual::decision_t;
using imuqual::measurement_t;
using imuqual::run_t;

constexpr int kHeaderLines = 5;        // station, bus, progress, processes, blank
constexpr int kTableFrame = 2;         // column names and rule
constexpr int kNoticeLines = 2;        // blank, notice
constexpr size_t kReasonColumns = 24;  // the short reason beside the verdict

std::string Printf(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string Si(double v) {
  if (v >= 1e9) return Printf("%.2fG", v / 1e9);
  if (v >= 1e6) return Printf("%.2fM", v / 1e6);
  if (v >= 1e4) return Printf("%.1fk", v / 1e3);
  return Printf("%.0f", v);
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Provisional verdicts read "pass?", "marginal?", "fail?", and "pending"
// where more data can still move a value across a bound (the analysis's
// interim INCONCLUSIVE, judge::JudgeInterim); final ones "PASS",
// "INCONCLUSIVE", "ABORTED", "ERROR"; "-" when nothing is judged.
std::string VerdictText(int8_t outcome, bool final_result) {
  const std::string word = store::OutcomeText(store::OutcomeFromNumber(outcome));
  if (word.empty()) return final_result ? "-" : "";
  if (final_result) return word;
  return store::OutcomeFromNumber(outcome) == pb::INCONCLUSIVE ? "pending" : Lower(word) + "?";
}

// A value's mark in the per-unit table: '!' FAIL, '?' INCONCLUSIVE, '~' MARGINAL.
const char* OutcomeMark(int8_t outcome) {
  switch (store::OutcomeFromNumber(outcome)) {
    case pb::FAIL:
      return "!";
    case pb::INCONCLUSIVE:
      return "?";
    case pb::MARGINAL:
      return "~";
    default:
      return "";
  }
}

// Early decisions: the plan has them, and the unit is decided (PASS or FAIL).
bool Early(const ConsoleUnit& u) { return u.looks_planned > 0; }
bool Decided(const ConsoleUnit& u) {
  return u.decision == decision_t::STATE_PASS || u.decision == decision_t::STATE_FAIL;
}
// Provisional outcomes are shown unless a look may still overturn them: an
// early-decision unit not decided yet shows its decisions instead.
bool ShowsProvisional(const ConsoleUnit& u) { return !Early(u) || Decided(u); }

// The unit's verdict as shown: final, provisional, or (early decisions)
// "PENDING look k/K", "decided PASS at 14m".
std::string UnitVerdictText(const ConsoleUnit& u) {
  if (u.final_result || !Early(u)) return VerdictText(u.verdict, u.final_result);
  if (Decided(u)) {
    return std::string("decided ") + (u.decision == decision_t::STATE_FAIL ? "FAIL" : "PASS") +
           " at " + DecisionTimeText(u.decided_at_s);
  }
  return "PENDING look " + std::to_string(u.looks_done) + "/" + std::to_string(u.looks_planned);
}

// An axis's verdict as shown; an early-decision unit not decided yet: the
// axis "pending" while a measurement of it is pending at the last look,
// "pass" once every one is decided (none is decided FAIL before the unit
// is), nothing before the first look or without a judged measurement.
std::string AxisVerdictText(const ConsoleUnit& u, const ConsoleAxis& x) {
  if (u.final_result || ShowsProvisional(u)) return VerdictText(x.outcome, u.final_result);
  const std::string prefix = x.name + ": ";
  for (const std::string& p : u.pending) {
    if (p.starts_with(prefix)) return "pending";
  }
  return u.looks_done > 0 && x.outcome != 0 ? "pass" : "";
}

// The verdict the unit ranks by: an early-decision unit's decision, not its
// provisional outcome.
int8_t RankedVerdict(const ConsoleUnit& u) {
  if (u.final_result || !Early(u)) return u.verdict;
  if (u.decision == decision_t::STATE_FAIL) return measurement_t::OUTCOME_FAIL;
  if (u.decision == decision_t::STATE_PASS) return measurement_t::OUTCOME_PASS;
  return measurement_t::OUTCOME_UNSET;
}

std::string StateText(const ConsoleUnit& u) {
  if (u.state == 0) return u.silent_s >= kConsoleSilentS ? "no data" : "waiting";
  if (u.archived && u.final_result) return u.source_failed ? "source failed" : "done";
  if (Early(u) && Decided(u)) return "slot free";
  if (u.source_failed) return "source failed";
  switch (u.state) {
    case run_t::STATE_RUNNING:
      if (u.reconnecting) return "reconnecting " + FormatDuration(u.silent_s);
      if (u.silent_s >= kConsoleSilentS) return "no data " + FormatDuration(u.silent_s);
      return "running";
    case run_t::STATE_COMPLETE:
      return "finishing";
    case run_t::STATE_ABORTED:
      return "aborted";
    case run_t::STATE_INCOMPLETE:
      return "incomplete";
    default:
      return "?";
  }
}

std::string ElapsedText(const ConsoleModel& m, const ConsoleUnit& u) {
  if (u.state == 0) return "";
  const double planned_s = UnitPlannedS(m, u);
  std::string out = FormatDuration(u.elapsed_s);
  if (planned_s > 0) out += " / " + FormatDuration(planned_s);
  return out;
}

std::string Bar(double fraction, int width) {
  const int full = std::clamp(static_cast<int>(std::floor(fraction * width)), 0, width);
  std::string bar(static_cast<size_t>(width) + 2, '.');
  bar.front() = '[';
  bar.back() = ']';
  std::fill_n(bar.begin() + 1, full, '#');
  return bar;
}

// FAIL first, then ERROR, ABORTED, INCONCLUSIVE, MARGINAL, then the rest
// (store::AttentionRank); slot order within each.
int AttentionRank(const ConsoleUnit& u) {
  // A failed source or a silent unit needs the operator as an ERROR does.
  if (u.source_failed || u.silent_s >= kConsoleSilentS || u.reconnecting) {
    return std::max(store::AttentionRank(pb::ERROR),
                    store::AttentionRank(store::OutcomeFromNumber(RankedVerdict(u))));
  }
  return store::AttentionRank(store::OutcomeFromNumber(RankedVerdict(u)));
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start < text.size()) {
    const size_t end = text.find('\n', start);
    out.push_back(text.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

pb::Qualifier QualifierOf(const ConsoleAxis& x) {
  const int q = x.bias_instability_qualifier;
  return pb::Qualifier_IsValid(q) ? static_cast<pb::Qualifier>(q) : pb::QUALIFIER_NONE;
}

// The live bias instability with its marks (marks.h); "" before there is
// one. A provisional value not measurable yet (no curve so far) is not
// there yet; only a final one reads "n/m".
std::string LiveValue(const ConsoleAxis& x, int digits, bool with_uncertainty, bool final_result) {
  const pb::Qualifier q = QualifierOf(x);
  if (std::isnan(x.bias_instability) && (q != pb::NOT_MEASURABLE || !final_result)) return "";
  return MarkedValue(x.bias_instability, q, x.bias_instability_uncertainty, digits,
                     with_uncertainty);
}

// The first reason, cut to `width` columns ("..." when cut).
std::string ShortReason(const ConsoleUnit& u, size_t width) {
  // Nothing a later look may overturn (an early-decision unit not decided).
  if (!u.final_result && !ShowsProvisional(u)) return "";
  if (u.reason.empty() || RankedVerdict(u) == measurement_t::OUTCOME_PASS) return "";
  if (DisplayWidth(u.reason) <= width) return u.reason;
  // Whole words only ("x: bias_instability 3..." read as a value of 3), and
  // a value without a dangling "±" whose uncertainty did not fit.
  std::vector<std::string> words;
  for (size_t at = 0; at < u.reason.size();) {
    const size_t end = std::min(u.reason.find(' ', at), u.reason.size());
    words.push_back(u.reason.substr(at, end - at));
    at = end + 1;
  }
  std::string out;
  for (const std::string& w : words) {
    const std::string next = out.empty() ? w : out + " " + w;
    if (DisplayWidth(next) + 3 > width) break;
    out = next;
  }
  for (const char* tail : {" \u00b1", ","}) {
    if (out.ends_with(tail)) out.resize(out.size() - std::string_view(tail).size());
  }
  return out + "...";
}

// The reason column's width once a table is fitted (FitTable) with its
// reasons cut to kReasonColumns: the column's width then (`why_now`, the
// widest cut reason or the header) plus what a screen of `width` columns
// leaves beside the table, up to the longest reason.
size_t ReasonWidth(const std::vector<std::string>& fitted, int width, size_t why_now,
                   size_t longest) {
  size_t widest = 0;
  for (const std::string& l : fitted) widest = std::max(widest, DisplayWidth(l));
  const size_t spare = static_cast<int>(widest) < width ? static_cast<size_t>(width) - widest : 0;
  return std::min(std::max(longest, why_now), why_now + spare);
}

// The "why" column's width with every reason cut to kReasonColumns.
size_t WhyWidthNow(const ConsoleModel& m) {
  size_t out = 3;  // "why"
  for (const ConsoleUnit& u : m.units) out = std::max(out, DisplayWidth(ShortReason(u, kReasonColumns)));
  return out;
}

// One line explaining the marks shown ("" when none is). `verdict_marks`:
// the per-unit table's marks on the values too.
std::string MarksLine(const ConsoleModel& m, bool verdict_marks = false, bool values_shown = true) {
  std::set<pb::Qualifier> used;
  for (const ConsoleUnit& u : m.units) {
    if (!values_shown) break;  // no value on screen: no value's mark to explain
    for (const ConsoleAxis& x : u.axes) {
      if (!LiveValue(x, 3, false, u.final_result).empty()) used.insert(QualifierOf(x));
    }
  }
  std::string out;
  if (used.count(pb::UPPER_BOUND))
    out += std::string(out.empty() ? "" : "   ") + "\u2264 upper bound";
  if (used.count(pb::MINIMUM_NOT_RESOLVED)) {
    out += std::string(out.empty() ? "" : "   ") + kMinimumNotResolvedMark +
           " minimum at the last point: the true minimum may lie lower";
  }
  if (used.count(pb::MODEL_INADEQUATE)) {
    out += std::string(out.empty() ? "" : "   ") + kModelInadequateMark +
           " noise model failed its fit";
  }
  if (used.count(pb::NOT_MEASURABLE))
    out += std::string(out.empty() ? "" : "   ") + "n/m not measurable";
  if (verdict_marks && values_shown) {
    out = "BI value: ! fail  ~ marginal  ? inconclusive" + (out.empty() ? "" : "   " + out);
  }
  const bool provisional = std::any_of(m.units.begin(), m.units.end(), [](const ConsoleUnit& u) {
    return !u.final_result && ShowsProvisional(u) && u.verdict != 0;
  });
  if (provisional) {
    out += std::string(out.empty() ? "" : "   ") +
           "pass? fail?: provisional  pending: may still change side";
  }
  return out;
}

// The widest reason a unit would show whole.
size_t LongestReason(const ConsoleModel& m) {
  size_t out = 0;
  for (const ConsoleUnit& u : m.units) {
    out = std::max(out, DisplayWidth(ShortReason(u, std::numeric_limits<size_t>::max())));
  }
  return out;
}

// A table of text cells as it is about to be shown.
struct TextTable {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
};

// `table` rendered no wider than `width` columns: while it is wider, the next
// column of `drop_order` (least important first) is left out whole, so that
// a number is shown whole or not at all (cutting the lines at the screen's
// edge showed 30.2 deg/h as "3"), and a column left out that fits again is
// taken back (TableWriter::RenderTableWithin). `shown` gets the columns kept.
std::vector<std::string> FitTable(const TextTable& table, int width,
                                  const std::vector<std::string>& drop_order,
                                  std::set<std::string>* shown) {
  TableWriter t(table.columns, 3);
  for (const std::vector<std::string>& row : table.rows) {
    std::vector<Cell> cells;
    for (const std::string& text : row) cells.push_back(Cell::Text(text));
    t.AddRow(std::move(cells));
  }
  std::vector<std::string> left_out;
  std::vector<std::string> lines =
      Lines(t.RenderTableWithin(static_cast<size_t>(std::max(0, width)), drop_order, &left_out));
  if (shown) {
    for (const std::string& c : table.columns) {
      if (std::find(left_out.begin(), left_out.end(), c) == left_out.end()) shown->insert(c);
    }
  }
  return lines;
}

// The columns a narrow screen leaves out first: the counts, then the
// elapsed time, the live values, the state, the reason; the slot, the unit,
// its verdict and (per axis) the axis and its verdict stay.
const std::vector<std::string>& DropOrder() {
  static const std::vector<std::string> kOrder = {
      "gaps", "samples", "invalid", "elapsed / planned", "BI (live)", "state", "why", "slot"};
  return kOrder;
}

// A unit's invalid samples in one cell: "0", or the axes that have any,
// "x 3 z 12".
std::string InvalidByAxis(const ConsoleUnit& u) {
  std::string out;
  for (const ConsoleAxis& x : u.axes) {
    if (x.invalid_samples == 0) continue;
    out += (out.empty() ? "" : " ") + x.name + " " + std::to_string(x.invalid_samples);
  }
  return out.empty() ? "0" : out;
}

// One row per unit and axis, no wider than `width`. The room left goes to
// the reasons (a second rendering with wider reasons, `must_keep` the first
// one's columns: if the wider reasons would cost a column, the first stands,
// and the call returns nothing).
std::vector<std::string> AxisRows(const ConsoleModel& m, int width,
                                  size_t reason_width = kReasonColumns,
                                  const std::set<std::string>* must_keep = nullptr) {
  TextTable t{{"slot", "serial", "verdict", "why", "state", "elapsed / planned", "axis",
               "axis verdict", "BI (live)", "samples", "gaps", "invalid"},
              {}};
  // Units that need the line first, slot order within (as the live page).
  std::vector<const ConsoleUnit*> order;
  for (const ConsoleUnit& u : m.units) order.push_back(&u);
  std::stable_sort(order.begin(), order.end(), [](const ConsoleUnit* a, const ConsoleUnit* b) {
    return AttentionRank(*a) > AttentionRank(*b);
  });
  for (const ConsoleUnit* unit : order) {
    const ConsoleUnit& u = *unit;
    const std::string samples = u.state == 0 ? "" : Si(static_cast<double>(u.samples));
    const std::string gaps = u.state == 0 ? "" : std::to_string(u.gap_samples);
    if (u.axes.empty()) {
      t.rows.push_back({u.slot, u.serial, UnitVerdictText(u), ShortReason(u, reason_width),
                        StateText(u), ElapsedText(m, u), "", "", "", samples, gaps, ""});
      continue;
    }
    for (size_t a = 0; a < u.axes.size(); ++a) {
      const ConsoleAxis& x = u.axes[a];
      const bool first = a == 0;
      const std::string value = LiveValue(x, 3, true, u.final_result);
      t.rows.push_back({first ? u.slot : "", first ? u.serial : "", first ? UnitVerdictText(u) : "",
                        first ? ShortReason(u, reason_width) : "", first ? StateText(u) : "",
                        first ? ElapsedText(m, u) : "", x.name, AxisVerdictText(u, x),
                        value.empty() ? "-" : value + " " + x.unit, first ? samples : "",
                        first ? gaps : "", u.state == 0 ? "" : std::to_string(x.invalid_samples)});
    }
  }
  std::set<std::string> shown;
  std::vector<std::string> lines = FitTable(t, width, DropOrder(), &shown);
  if (must_keep != nullptr && shown != *must_keep) return {};
  if (must_keep == nullptr && shown.count("why")) {
    const size_t wider = ReasonWidth(lines, width, WhyWidthNow(m), LongestReason(m));
    if (wider > reason_width) {
      std::vector<std::string> again = AxisRows(m, width, wider, &shown);
      if (!again.empty()) return again;
    }
  }
  const std::string marks = MarksLine(m, false, shown.count("BI (live)") > 0);
  if (!marks.empty()) lines.push_back(marks);
  return lines;
}

// One row per unit, the axes' live bias instability side by side ('!' FAIL,
// '~' MARGINAL); at most `max_units` units; those needing attention first
// (this table is shown when the per-axis one does not fit).
std::vector<std::string> UnitRows(const ConsoleModel& m, int max_units, int width,
                                  bool* values_shown, size_t reason_width = kReasonColumns,
                                  const std::set<std::string>* must_keep = nullptr) {
  std::vector<std::string> axis_names;
  for (const ConsoleUnit& u : m.units) {
    for (const ConsoleAxis& x : u.axes) {
      if (std::find(axis_names.begin(), axis_names.end(), x.name) == axis_names.end()) {
        axis_names.push_back(x.name);
      }
    }
  }
  std::vector<std::string> columns = {"slot", "serial", "verdict",
                                      "why",  "state",  "elapsed / planned"};
  for (const std::string& a : axis_names) columns.push_back(a);
  columns.push_back("samples");
  columns.push_back("gaps");
  columns.push_back("invalid");
  std::vector<const ConsoleUnit*> shown;
  for (const ConsoleUnit& u : m.units) shown.push_back(&u);
  std::stable_sort(shown.begin(), shown.end(), [](const ConsoleUnit* a, const ConsoleUnit* b) {
    return AttentionRank(*a) > AttentionRank(*b);
  });
  const bool cut = static_cast<int>(shown.size()) > max_units;
  if (cut) shown.resize(static_cast<size_t>(std::max(0, max_units - 1)));
  TextTable t{columns, {}};
  for (const ConsoleUnit* u : shown) {
    std::vector<std::string> row = {u->slot,       u->serial,         UnitVerdictText(*u),
                                    ShortReason(*u, reason_width), StateText(*u),
                                    ElapsedText(m, *u)};
    for (const std::string& name : axis_names) {
      std::string text;
      for (const ConsoleAxis& x : u->axes) {
        if (x.name != name || LiveValue(x, 3, false, u->final_result).empty()) continue;
        text = LiveValue(x, 3, false, u->final_result) +
               (u->final_result || ShowsProvisional(*u) ? OutcomeMark(x.outcome) : "");
      }
      row.push_back(text);
    }
    row.push_back(u->state == 0 ? "" : Si(static_cast<double>(u->samples)));
    row.push_back(u->state == 0 ? "" : std::to_string(u->gap_samples));
    row.push_back(u->state == 0 ? "" : InvalidByAxis(*u));
    t.rows.push_back(std::move(row));
  }
  // The axes' values go after the counts and the elapsed time, the last
  // axis first.
  std::vector<std::string> drop = {"gaps", "samples", "invalid", "elapsed / planned"};
  for (auto it = axis_names.rbegin(); it != axis_names.rend(); ++it) drop.push_back(*it);
  for (const char* c : {"state", "why", "slot"}) drop.push_back(c);
  std::set<std::string> kept;
  std::vector<std::string> lines = FitTable(t, width, drop, &kept);
  if (must_keep != nullptr && kept != *must_keep) return {};
  if (must_keep == nullptr && kept.count("why")) {
    const size_t wider = ReasonWidth(lines, width, WhyWidthNow(m), LongestReason(m));
    if (wider > reason_width) {
      std::vector<std::string> again = UnitRows(m, max_units, width, values_shown, wider, &kept);
      if (!again.empty()) return again;
    }
  }
  *values_shown = std::any_of(axis_names.begin(), axis_names.end(),
                              [&](const std::string& a) { return kept.count(a) > 0; });
  if (cut) {
    const size_t hidden = m.units.size() - shown.size();
    int pass = 0, pending = 0, other = 0;
    for (const ConsoleUnit& u : m.units) {
      if (std::find(shown.begin(), shown.end(), &u) != shown.end()) continue;
      const int8_t verdict = RankedVerdict(u);
      if (verdict == measurement_t::OUTCOME_PASS) {
        ++pass;
      } else if (verdict == measurement_t::OUTCOME_UNSET) {
        ++pending;
      } else {
        ++other;
      }
    }
    lines.push_back("... " + std::to_string(hidden) + " more units (" + std::to_string(pass) +
                    " pass, " + (other > 0 ? std::to_string(other) + " other, " : "") +
                    std::to_string(pending) + " not judged yet)");
  }
  return lines;
}

}  // namespace

std::string ConsoleTally(const ConsoleModel& m) {
  int counts[7] = {};
  int finals = 0;
  for (const ConsoleUnit& u : m.units) {
    if (!u.final_result) continue;
    ++finals;
    ++counts[store::OutcomeFromNumber(u.verdict)];
  }
  if (finals == 0) return "";
  // "final" only once every unit is: before that the tally is the final
  // verdicts so far, said as such (the last units may still fail).
  const int units = static_cast<int>(m.units.size());
  std::string out = finals == units ? "final:"
                                    : "so far (" + std::to_string(finals) + " of " +
                                          std::to_string(units) + " units final):";
  for (pb::Outcome o :
       {pb::PASS, pb::MARGINAL, pb::FAIL, pb::INCONCLUSIVE, pb::ABORTED, pb::ERROR}) {
    if (counts[o] == 0 && !store::CountsInYield(o)) continue;
    out += " " + std::to_string(counts[o]) + " " + store::OutcomeText(o) + ",";
  }
  if (counts[pb::OUTCOME_UNSET] > 0)
    out += " " + std::to_string(counts[pb::OUTCOME_UNSET]) + " not judged,";
  out.back() = ';';
  const int judged = counts[pb::PASS] + counts[pb::MARGINAL] + counts[pb::FAIL];
  if (judged == 0) return out + " yield not measurable: no judged unit";
  return out + Printf(" yield %.0f%%", 100.0 * (counts[pb::PASS] + counts[pb::MARGINAL]) / judged) +
         " of " + std::to_string(judged) + " judged unit" + (judged == 1 ? "" : "s");
}

std::string FormatDuration(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  }
  return buf;
}

double UnitPlannedS(const ConsoleModel& m, const ConsoleUnit& u) {
  return u.planned_s > 0 ? u.planned_s : m.planned_s;
}

double ConsoleProgress(const ConsoleModel& m) {
  if (m.units.empty()) return 0;
  double done = 0;
  for (const ConsoleUnit& u : m.units) {
    if (u.archived || (Early(u) && Decided(u))) {
      done += 1;
    } else if (const double planned = UnitPlannedS(m, u); planned > 0) {
      done += std::min(u.elapsed_s / planned, 0.999);
    }
  }
  return std::clamp(done / static_cast<double>(m.units.size()), 0.0, 1.0);
}

std::string ConsoleSummaryLine(const ConsoleModel& m) {
  double samples = 0;
  int archived = 0;
  for (const ConsoleUnit& u : m.units) {
    samples +=
        static_cast<double>(u.samples) * static_cast<double>(std::max<size_t>(1, u.axes.size()));
    archived += u.archived;
  }
  const double f = ConsoleProgress(m);
  return Bar(f, 30) + Printf(" %3.0f%%", 100 * f) + "  " + Si(samples) + " values  runs archived " +
         std::to_string(archived) + "/" + std::to_string(m.units.size()) + "  " +
         FormatDuration(m.wall_s);
}

// ANSI colour and bold for a verdict or state word at the start of a cell
// (zero display width, so the cut lines stay in width).
const char* ColourOf(std::string_view cell) {
  static const std::pair<const char*, const char*> kWords[] = {
      {"FAIL", "\x1b[1;31m"},         {"fail?", "\x1b[31m"},
      {"ERROR", "\x1b[1;31m"},        {"source failed", "\x1b[1;31m"},
      {"MARGINAL", "\x1b[1;33m"},     {"marginal?", "\x1b[33m"},
      {"INCONCLUSIVE", "\x1b[1;35m"}, {"pending", "\x1b[35m"},
      {"ABORTED", "\x1b[1;35m"},      {"no data", "\x1b[1;33m"},
      {"reconnecting", "\x1b[1;33m"}, {"PASS", "\x1b[1;32m"},
      {"pass?", "\x1b[32m"}};
  for (const auto& [word, code] : kWords) {
    if (cell.rfind(word, 0) == 0) return code;
  }
  return nullptr;
}

// Colours the verdict and state cells of the table that starts at
// lines[first] (its header, then the dashes that give each column's
// extent): only columns `verdict`, `state` and `axis verdict`, so that a
// serial, a reason or a lot that happens to read "PASS" stays plain.
void ColorizeTable(std::vector<std::string>* lines, size_t first) {
  if (first + 1 >= lines->size()) return;
  const std::string& header = (*lines)[first];
  const std::string& dashes = (*lines)[first + 1];
  if (dashes.empty() || dashes.find_first_not_of("- ") != std::string::npos) return;
  std::vector<std::pair<size_t, size_t>> spans;  // display columns of the coloured columns
  for (size_t at = dashes.find('-'); at != std::string::npos;) {
    const size_t end = std::min(dashes.find(' ', at), dashes.size());
    std::string name = header.size() > at ? header.substr(at, end - at) : "";
    name.erase(name.find_last_not_of(' ') + 1);
    if (name == "verdict" || name == "state" || name == "axis verdict") spans.emplace_back(at, end);
    at = dashes.find('-', end);
  }
  for (size_t i = first + 2; i < lines->size(); ++i) {
    std::string& line = (*lines)[i];
    if (line.empty()) break;  // the end of the table
    // The rule's columns are display columns; a reason with "±" before them
    // shifts the bytes: map each column to its byte offset in this line.
    std::vector<size_t> byte_of;  // display column -> byte offset
    for (size_t b = 0; b < line.size(); ++b) {
      if ((static_cast<unsigned char>(line[b]) & 0xC0) != 0x80) byte_of.push_back(b);
    }
    byte_of.push_back(line.size());
    // Right to left, so that the earlier offsets stay valid.
    for (auto it = spans.rbegin(); it != spans.rend(); ++it) {
      const auto [col, col_end] = *it;
      if (col >= byte_of.size() - 1) continue;
      const size_t at = byte_of[col];
      const size_t end = byte_of[std::min(col_end, byte_of.size() - 1)];
      const std::string_view cell(line.data() + at, end - at);
      const char* code = ColourOf(cell);
      if (code == nullptr || (at > 0 && line[at - 1] != ' ')) continue;
      const size_t text_end = cell.find_last_not_of(' ') + 1;
      line.insert(at + text_end, "\x1b[0m");
      line.insert(at, code);
    }
  }
}

std::string ConsoleProcessesLine(const ConsoleModel& m) {
  std::string procs;
  for (const ConsoleProcess& p : m.processes) {
    procs += "  " + p.name + " ";
    procs += p.expected > 1 ? std::to_string(p.running) + "/" + std::to_string(p.expected)
                            : std::string(p.running > 0 ? "up" : "down");
    if (p.restarts > 0) procs += " (restarted " + std::to_string(p.restarts) + "x)";
    if (p.unauthenticated > 0 || p.replayed > 0) {
      procs += " (refused ";
      if (p.unauthenticated > 0) procs += std::to_string(p.unauthenticated) + " unauthenticated";
      if (p.unauthenticated > 0 && p.replayed > 0) procs += ", ";
      if (p.replayed > 0) procs += std::to_string(p.replayed) + " replayed";
      procs += ")";
    }
    if (!p.problem.empty()) procs += " [" + p.problem + "]";
  }
  return procs;
}

ConsoleUnitCells DescribeUnit(const ConsoleModel& m, const ConsoleUnit& u, size_t reason_width) {
  ConsoleUnitCells c;
  c.verdict = UnitVerdictText(u);
  c.reason = ShortReason(u, reason_width);
  c.state = StateText(u);
  c.elapsed = ElapsedText(m, u);
  c.attention = AttentionRank(u);
  for (const ConsoleAxis& x : u.axes) {
    const std::string value = LiveValue(x, 3, true, u.final_result);
    c.axes.push_back({x.name, AxisVerdictText(u, x), value.empty() ? "-" : value + " " + x.unit,
                      x.invalid_samples, x.limit_high, x.marginal_high});
  }
  return c;
}

std::vector<std::string> RenderConsole(const ConsoleModel& m, int width, int height, bool color) {
  std::vector<std::string> out;
  std::string title = "imuqual station " + m.station + "   lot " + m.lot + "   plan " + m.plan;
  if (!m.operator_name.empty()) title += "   operator " + m.operator_name;
  out.push_back(title);
  out.push_back("bus " + m.bus + "   archive " + m.archive);
  const double f = ConsoleProgress(m);
  int archived = 0;
  for (const ConsoleUnit& u : m.units) archived += u.archived;
  std::string progress =
      Bar(f, 30) + Printf(" %3.0f%%", 100 * f) + "   elapsed " + FormatDuration(m.wall_s);
  if (f > 0.01 && f < 1) progress += "   left ~" + FormatDuration(m.wall_s * (1 - f) / f);
  progress += "   runs archived " + std::to_string(archived) + "/" + std::to_string(m.units.size());
  out.push_back(progress);
  out.push_back("processes:" + ConsoleProcessesLine(m));
  out.push_back("");

  size_t axis_rows = 0;
  for (const ConsoleUnit& u : m.units) axis_rows += std::max<size_t>(1, u.axes.size());
  const int room = height - kHeaderLines - kTableFrame - kNoticeLines;
  const bool per_axis = static_cast<int>(axis_rows) + (MarksLine(m).empty() ? 0 : 1) <= room;
  const int legend = MarksLine(m, !per_axis).empty() ? 0 : 1;
  bool values_shown = true;
  std::vector<std::string> table = per_axis ? AxisRows(m, width)
                                            : UnitRows(m, std::max(1, room - legend), width,
                                                       &values_shown);
  if (!per_axis) {
    const std::string marks = MarksLine(m, true, values_shown);
    if (!marks.empty()) table.push_back(marks);
  }
  out.insert(out.end(), table.begin(), table.end());
  const std::string tally = ConsoleTally(m);
  if (!tally.empty() && static_cast<int>(out.size()) + kNoticeLines < height) out.push_back(tally);
  out.push_back("");
  out.push_back(m.notice.empty() ? "Ctrl-C: stop the soak (runs are archived as aborted)"
                                 : m.notice);
  if (static_cast<int>(out.size()) > height) out.resize(static_cast<size_t>(std::max(0, height)));
  for (std::string& line : out) {
    // Cut at `width` columns, never inside a UTF-8 character.
    if (static_cast<int>(DisplayWidth(line)) <= width) continue;
    size_t bytes = 0;
    for (int columns = 0; bytes < line.size(); ++bytes) {
      if ((static_cast<unsigned char>(line[bytes]) & 0xC0) == 0x80) continue;
      if (columns++ == std::max(0, width)) break;
    }
    line.resize(bytes);
  }
  if (color) ColorizeTable(&out, kHeaderLines);
  return out;
}

}  // namespace imuqual::station
