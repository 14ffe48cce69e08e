#include "cli/commands.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>

#include "common/clock.h"
#include "common/exit_codes.h"
#include "common/log.h"
#include "common/text_util.h"
#include "report/archive_tables.h"
#include "report/early_decisions.h"
#include "report/marks.h"
#include "report/report.h"
#include "store/outcome.h"
#include "store/query.h"

namespace imuqual::cli {
using report::BuildLotReportHtml;
using report::Cell;
using report::DecisionTimeText;
using report::EarlyDecisionLine;
using report::Format;
using report::LotAxisTable;
using report::LotsTable;
using report::MarkedValue;
using report::MarkLegend;
using report::QueryEarlyDecisions;
using report::StationOperatorLines;
using report::TableWriter;
using station::RunStation;
using station::StationRunOptions;

namespace {

// `text` as lines of at most `width` columns, broken at spaces (a word
// longer than a line stays whole); its leading indent kept, the lines after
// the first indented two more.
std::string WordWrapped(const std::string& text, size_t width) {
  const size_t indent = std::min(text.find_first_not_of(' '), text.size());
  const std::string more(indent + 2, ' ');
  std::string out, line = text.substr(0, indent);
  bool words = false;  // on `line` after its indent
  size_t from = indent;
  while (from < text.size()) {
    size_t end = text.find(' ', from);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(from, end - from);
    from = end + 1;
    if (words && report::DisplayWidth(line) + 1 + report::DisplayWidth(word) > width) {
      out += line + "\n";
      line = more + word;
    } else {
      line += (words ? " " : "") + word;
    }
    words = true;
  }
  return out + line + "\n";
}

// Each line of `text` WordWrapped.
std::string LinesWrapped(const std::string& text, size_t width) {
  std::string out;
  size_t from = 0;
  while (from < text.size()) {
    size_t end = text.find('\n', from);
    if (end == std::string::npos) end = text.size();
    out += WordWrapped(text.substr(from, end - from), width);
    from = end + 1;
  }
  return out;
}

// The table people read; `by_slot` (a station's final table): in slot
// order, the slot first.
// Each value with its marks (marks.h); "± u" where the value has an
// uncertainty (not on B (IEEE), the minimum / 0.664, for room). When a run
// used early decisions, when its unit was decided ("full soak": pending at
// every look).
//
// `width`: the screen's columns (ScreenColumns). A table wider leaves out
// whole columns, never cuts one: counts that are 0 on every axis first, then
// the IEEE figure (minimum / 0.664), tau at the minimum, the run's start, the
// counts that are not all 0, the rate random walk; a line under it names
// what was left out.
std::string PeopleTable(const std::vector<store::AxisRow>& unsorted, bool by_slot,
                        bool with_runs = false, size_t width = std::numeric_limits<size_t>::max()) {
  // A station's table in fixture order, with the slot first.
  std::vector<store::AxisRow> rows = unsorted;
  if (by_slot) {
    std::stable_sort(rows.begin(), rows.end(),
                     [](const store::AxisRow& a, const store::AxisRow& b) {
                       return NaturalLess(a.slot, b.slot);
                     });
  }
  const bool early = std::any_of(rows.begin(), rows.end(),
                                 [](const store::AxisRow& r) { return r.has_decision_time; });
  // Units in the headers when every row is of one kind; a mixed table names
  // both figures and leaves the units to the lines under it.
  bool any_gyro = false, any_accel = false;
  for (const store::AxisRow& r : rows) (r.kind == "accel" ? any_accel : any_gyro) = true;
  const bool mixed = any_gyro && any_accel;
  const auto per_kind = [&](const char* both, const char* accel, const char* gyro) {
    return std::string(mixed ? both : any_accel ? accel : gyro);
  };
  const std::string ieee = per_kind("BI (IEEE)", "BI (IEEE) ug", "BI (IEEE) deg/h");
  const std::string rrw = per_kind("RRW/AcRW", "AcRW ug/sqrt(h)", "RRW deg/h/sqrt(h)");
  std::vector<std::string> columns = {"serial",
                                      "axis",
                                      per_kind("ARW/VRW", "VRW m/s/sqrt(h)", "ARW deg/sqrt(h)"),
                                      per_kind("BI", "BI ug", "BI deg/h"),
                                      ieee,
                                      "tau min s",
                                      rrw,
                                      "gap samples",
                                      "invalid samples",
                                      "axis",
                                      "unit verdict"};
  if (by_slot) columns.insert(columns.begin(), "slot");
  // Every run of a unit (a retest too): which run, and when it started.
  if (with_runs) columns.insert(columns.begin() + (by_slot ? 2 : 1), {"run", "started (UTC)"});
  if (early) columns.push_back("decided at");
  TableWriter t(columns);
  MarkLegend legend;
  for (const store::AxisRow& r : rows) {
    auto marked = [&](double v, const store::ValueMarks& m, const char* name, bool with_u) {
      legend.Add(m, r.unit, r.axis, name, v);
      return Cell::NumText(MarkedValue(v, m, 4, with_u));
    };
    std::vector<Cell> row = {
        Cell::Text(r.unit),
        Cell::Text(r.axis),
        marked(r.random_walk, r.random_walk_marks, "random walk", true),
        marked(r.bias_instability, r.bias_instability_marks, "bias_instability", true),
        marked(r.bias_instability_ieee, r.bias_instability_ieee_marks, "bias_instability_ieee",
               false),
        marked(r.tau_min_s, r.tau_min_marks, "tau_at_minimum", true),
        marked(r.rate_random_walk, r.rate_random_walk_marks, "rate_random_walk", true),
        Cell::Int(r.gap_samples),
        Cell::Int(r.invalid_samples),
        Cell::Text(r.axis_verdict.empty() ? "-" : r.axis_verdict),
        Cell::Text(r.run_verdict.empty() ? "-" : r.run_verdict)};
    if (early) {
      row.push_back(Cell::Text(r.has_decision_time ? DecisionTimeText(r.decision_time_s) : ""));
    }
    if (with_runs) {
      row.insert(row.begin() + 1, {Cell::Text(r.run_id), Cell::Text(FormatUtimeIso(r.start_utime))});
    }
    if (by_slot) row.insert(row.begin(), Cell::Text(r.slot));
    t.AddRow(std::move(row));
  }
  bool gaps = false, invalid = false;
  for (const store::AxisRow& r : rows) {
    gaps |= r.gap_samples != 0;
    invalid |= r.invalid_samples != 0;
  }
  std::vector<std::string> drop;
  if (!gaps) drop.push_back("gap samples");
  if (!invalid) drop.push_back("invalid samples");
  for (const char* c : {ieee.c_str(), "tau min s", "started (UTC)"}) drop.push_back(c);
  if (gaps) drop.push_back("gap samples");
  if (invalid) drop.push_back("invalid samples");
  drop.push_back(rrw);
  std::vector<std::string> left_out;
  std::string out = t.RenderTableWithin(width, drop, &left_out);
  if (!left_out.empty()) {
    std::string names;
    for (const std::string& c : left_out) {
      names += (names.empty() ? "" : ", ") + c;
      if ((c == "gap samples" && !gaps) || (c == "invalid samples" && !invalid))
        names += " (0 on every axis)";
    }
    out += WordWrapped("left out for " + std::to_string(width) + " columns: " + names +
                           "; a wider screen shows every column",
                       width);
  }
  std::string notes = StationOperatorLines(rows) + legend.Render();
  if (any_gyro || rows.empty()) {
    notes +=
        "gyro units: ARW deg/sqrt(h), bias instability BI deg/h (curve minimum; IEEE B = "
        "minimum/0.664), rate random walk RRW deg/h/sqrt(h)\n";
  }
  if (any_accel) {
    notes +=
        "accel units: VRW m/s/sqrt(h), bias instability BI ug (curve minimum; IEEE B = "
        "minimum/0.664), acceleration random walk AcRW ug/sqrt(h)\n";
  }
  return out + LinesWrapped(notes, width);
}

Result<std::unique_ptr<store::Archive>> OpenForReading(const std::string& db_path) {
  return store::Archive::Open(db_path, store::Archive::Mode::kRead);
}

// The columns a table for people may take: the terminal's when standard
// output is one, else COLUMNS when set (a pipe to a pager, a test), else no
// bound (a file or a log keeps every column).
size_t ScreenColumns() {
  struct winsize ws {};
  if (::isatty(STDOUT_FILENO) && ::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0)
    return ws.ws_col;
  if (const char* env = std::getenv("COLUMNS"); env != nullptr) {
    char* end = nullptr;
    const long n = std::strtol(env, &end, 10);
    if (end != env && *end == '\0' && n > 0) return static_cast<size_t>(n);
  }
  return std::numeric_limits<size_t>::max();
}

std::string YieldText(double yield) {
  if (std::isnan(yield)) return "not measurable: no judged unit";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100 * yield);
  return buf;
}

// Run verdicts counted: "3 PASS, 0 MARGINAL, 1 FAIL, 1 ABORTED" (PASS,
// MARGINAL and FAIL always, the other outcomes and the runs not judged when
// there are any).
std::string VerdictCounts(const std::map<std::string, int>& counts) {
  std::string out;
  for (pb::Outcome o :
       {pb::PASS, pb::MARGINAL, pb::FAIL, pb::INCONCLUSIVE, pb::ABORTED, pb::ERROR}) {
    const std::string text = store::OutcomeText(o);
    auto it = counts.find(text);
    const int n = it == counts.end() ? 0 : it->second;
    if (n == 0 && !store::CountsInYield(o)) continue;
    out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + text;
  }
  auto none = counts.find("");
  if (none != counts.end() && none->second > 0) {
    out += (out.empty() ? "" : ", ") + std::to_string(none->second) + " not judged";
  }
  return out;
}

// "reasons:" and one line per reason of the runs given (every run of `rows`
// when `run_ids` is empty), each after its unit (the verdict is in the
// table): "  U3: gx: bias_instability ...". `by_slot`: in the order of the
// station's table (slot, naturally: 2 before 10), each after its slot too.
std::string ReasonLines(store::Archive& archive, const std::vector<store::AxisRow>& rows,
                        std::vector<std::string> run_ids, bool by_slot = false) {
  std::map<std::string, const store::AxisRow*> run_of;
  const bool every_run = run_ids.empty();
  for (const store::AxisRow& r : rows) {
    if (run_of.emplace(r.run_id, &r).second && every_run) run_ids.push_back(r.run_id);
  }
  auto reasons = store::QueryReasons(archive, run_ids);
  if (!reasons.ok() || reasons->empty()) return "";
  if (by_slot) {
    auto slot_of = [&](const std::string& run_id) {
      auto it = run_of.find(run_id);
      return it == run_of.end() ? std::string() : it->second->slot;
    };
    std::stable_sort(reasons->begin(), reasons->end(), [&](const auto& a, const auto& b) {
      return NaturalLess(slot_of(a.first), slot_of(b.first));
    });
  }
  std::string out = "\nreasons:\n";
  for (const auto& [run_id, text] : *reasons) {
    auto it = run_of.find(run_id);
    std::string who = it == run_of.end() ? run_id : it->second->unit;
    if (by_slot && it != run_of.end() && !it->second->slot.empty()) {
      who = "slot " + it->second->slot + " " + who;
    }
    size_t start = 0;
    while (start < text.size()) {
      const size_t end = text.find('\n', start);
      out += "  " + who + ": " + text.substr(start, end - start) + "\n";
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
  return out;
}

}  // namespace

// The lot's yields and why units were tested again (commands.h).
std::string LotYieldLines(store::Archive& archive, const std::string& lot) {
  auto lots = store::QueryLots(archive);
  if (!lots.ok()) return "";
  std::string out;
  for (const store::LotRow& l : *lots) {
    if (l.lot != lot) continue;
    std::map<std::string, int> counts = {{"PASS", static_cast<int>(l.pass)},
                                         {"MARGINAL", static_cast<int>(l.marginal)},
                                         {"FAIL", static_cast<int>(l.fail)},
                                         {"INCONCLUSIVE", static_cast<int>(l.inconclusive)},
                                         {"ABORTED", static_cast<int>(l.aborted)},
                                         {"ERROR", static_cast<int>(l.error)},
                                         {"", static_cast<int>(l.unjudged)}};
    out += "\n" + std::to_string(l.units) + " units by their final run: " + VerdictCounts(counts) +
           "\nfirst-pass yield " + YieldText(l.first_pass_yield) + ", final yield " +
           YieldText(l.yield) + " (PASS + MARGINAL over PASS, MARGINAL and FAIL); " +
           std::to_string(l.retests) + " retest(s), " + std::to_string(l.retest_candidates) +
           " retest candidate(s) (INCONCLUSIVE)\n";
  }
  auto retests = store::QueryRetestReasons(archive, lot);
  if (retests.ok() && !retests->empty()) {
    out += "tested again after:\n";
    for (const store::RetestRow& r : *retests) {
      const std::string verdict = r.verdict.empty() ? "not judged (" + r.state + ")" : r.verdict;
      out += "  " + r.unit + " run " + r.run_id + ": " + verdict;
      const std::string first = r.reasons.substr(0, r.reasons.find('\n'));
      if (!first.empty()) out += ": " + first;
      out += "\n";
    }
  }
  return out;
}

int RunCommand(const StationRunOptions& options) {
  auto run = RunStation(options);
  if (!run.ok()) {
    LogError(run.status().message());
    // The archive could not be written (the store stopped on it): 4 and
    // nothing else is; bad options, plan, source or archive file (refused
    // before any run, a file that is not there too): 2.
    switch (run.status().code()) {
      case Status::Code::kResourceExhausted: return kRunExitArchiveUnwritable;
      case Status::Code::kInvalidArgument:
      case Status::Code::kNotFound: return kRunExitUsage;
      default: return kRunExitError;
    }
  }
  auto archive = OpenForReading(options.db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  store::AxisRowFilter filter;
  filter.lot = options.lot;
  filter.run_prefix = run->run_prefix + "-";
  filter.latest_per_unit = false;
  auto rows = store::QueryAxisRows(**archive, filter);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kRunExitError;
  }
  // As wide as the screen (a terminal's lines wrap mid-number otherwise).
  const size_t width = ScreenColumns();
  std::printf("%s", PeopleTable(*rows, /*by_slot=*/true, false, width).c_str());
  std::map<std::string, std::string> unit_of;
  std::map<std::string, int> verdicts;
  int passed = 0, counted = 0;  // the yield: judged units only
  for (const store::AxisRow& r : *rows) {
    if (!unit_of.emplace(r.run_id, r.unit).second) continue;
    ++verdicts[r.run_verdict];
    const pb::Outcome v = store::OutcomeFromText(r.run_verdict);
    counted += store::CountsInYield(v);
    passed += v == pb::PASS || v == pb::MARGINAL;
  }
  std::printf(
      "%s",
      LinesWrapped(ReasonLines(**archive, *rows, run->run_ids, /*by_slot=*/true), width).c_str());
  for (const std::string& skipped : run->skipped) {
    std::printf("%s", WordWrapped("not run (--skip-failed-slots): " + skipped, width).c_str());
  }
  const std::string tally =
      "\n" + std::to_string(unit_of.size()) + " units: " + VerdictCounts(verdicts) +
      (run->interrupted ? " (interrupted: runs aborted)" : "") + "\nyield " +
      YieldText(counted > 0 ? static_cast<double>(passed) / counted : allan::kNaN) +
      (counted > 0 ? " (" + std::to_string(counted) + " unit" + (counted == 1 ? "" : "s") +
                         " judged PASS, MARGINAL or FAIL; " + std::to_string(passed) +
                         " of them PASS or MARGINAL)"
                   : "") +
      "\n";
  std::printf("%s", LinesWrapped(tally, width).c_str());
  auto early = QueryEarlyDecisions(**archive, options.lot, run->run_prefix + "-");
  if (early.ok() && !early->runs.empty())
    std::printf("%s", WordWrapped(EarlyDecisionLine(*early), width).c_str());
  std::printf("%s",
              WordWrapped("lot " + options.lot + " archived in " + options.db_path + " (runs " +
                              run->run_prefix + "-*; process log " + run->log_path + ")",
                          width)
                  .c_str());
  if (run->restarts > 0) {
    std::printf("%s", WordWrapped("store/analyze restarted " + std::to_string(run->restarts) +
                                      " time(s) during the soak; see the process log",
                                  width)
                          .c_str());
  }
  if (!run->left_open.empty()) {
    // Runs an earlier station process left open (a crash): judged now.
    std::printf("%zu run(s) left open by an earlier station process:\n", run->left_open.size());
    auto status = store::QueryRunStatus(**archive, run->left_open);
    if (!status.ok()) LogError("runs left open not read: " + status.status().message());
    for (const store::RunStatusRow& r : status.ok() ? *status : std::vector<store::RunStatusRow>{}) {
      std::printf("  %s: %s, %s%s%s\n", r.run_id.c_str(), r.state.c_str(),
                  r.verdict.empty() ? "not judged" : r.verdict.c_str(), r.reasons.empty() ? "" : ": ",
                  r.reasons.substr(0, r.reasons.find('\n')).c_str());
      if (!r.finalized) std::printf("    (not finished yet: the next station run settles it)\n");
    }
  }
  if (!run->run_ids.empty()) {
    std::string report = options.report_path;
    if (report.empty()) {
      const std::string& db = options.db_path;
      const bool dot_db = db.size() > 3 && db.compare(db.size() - 3, 3, ".db") == 0;
      report = (dot_db ? db.substr(0, db.size() - 3) : db) + "-" + options.lot + ".html";
    }
    auto html = BuildLotReportHtml(**archive, options.lot, options.db_path);
    const Status st = html.ok() ? WriteStringToFile(report, *html) : html.status();
    if (st.ok()) {
      std::printf("report: %s\n", report.c_str());
    } else {
      LogError("report not written: " + st.message());
    }
  }
  if (!run->failure.empty()) {
    LogError(run->failure);
    return kRunExitSourceFailed;
  }
  if (run->interrupted) return kRunExitInterrupted;
  const bool units_failed = verdicts["FAIL"] > 0 || verdicts["INCONCLUSIVE"] > 0;
  return options.fail_exit && units_failed ? kRunExitUnitsFailed : kRunExitOk;
}

int LotsCommand(const std::string& db_path, Format format) {
  auto archive = OpenForReading(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto lots = store::QueryLots(**archive);
  if (!lots.ok()) {
    LogError(lots.status().message());
    return kExitError;
  }
  bool unmeasurable = false;
  for (const store::LotRow& l : *lots)
    unmeasurable |= std::isnan(l.yield) || std::isnan(l.first_pass_yield);
  const TableWriter t = LotsTable(*lots, /*for_people=*/format == Format::kTable);
  std::printf("%s", t.Render(format).c_str());
  if (format == Format::kTable) {
    std::printf(
        "units by their final run (latest judged, else latest); yield = (pass + marginal) / "
        "(pass + marginal + fail); first_pass_yield = units whose first judged run passed / units "
        "with a judged run\n");
    if (unmeasurable) std::printf("n/m: not measurable: no judged unit\n");
  }
  return 0;
}

int LotCommand(const std::string& db_path, const std::string& lot, Format format, bool all_runs) {
  auto archive = OpenForReading(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  store::AxisRowFilter filter;
  filter.lot = lot;
  filter.latest_per_unit = !all_runs;
  auto rows = store::QueryAxisRows(**archive, filter);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitError;
  }
  if (rows->empty()) {
    LogError("no lot '" + lot + "' in " + db_path + " (imuqual lots lists them)");
    return kExitUsage;
  }
  if (format == Format::kTable) {
    const size_t width = ScreenColumns();
    std::printf("%s",
                PeopleTable(*rows, /*by_slot=*/false, /*with_runs=*/all_runs, width).c_str());
    std::printf("%s", LinesWrapped(ReasonLines(**archive, *rows, {}), width).c_str());
    if (!all_runs) std::printf("%s", LinesWrapped(LotYieldLines(**archive, lot), width).c_str());
    auto early = QueryEarlyDecisions(**archive, lot);
    if (!early.ok()) {
      LogError(early.status().message());
      return kExitError;
    }
    if (!early->runs.empty())
      std::printf("%s", WordWrapped(EarlyDecisionLine(*early), width).c_str());
  } else {
    std::printf("%s", LotAxisTable(*rows).Render(format).c_str());
  }
  return 0;
}

}  // namespace imuqual::cli
