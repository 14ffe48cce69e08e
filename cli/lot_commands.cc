#include "cli/lot_commands.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "analyze/judge/measurements.h"
#include "cli/commands.h"
#include "common/clock.h"
#include "common/exit_codes.h"
#include "common/log.h"
#include "report/archive_tables.h"
#include "report/early_decisions.h"
#include "report/lot_model_view.h"
#include "report/lot_statistics.h"
#include "report/marks.h"
#include "store/outcome.h"

namespace imuqual::cli {
using report::AddLotModelRows;
using report::AxisLotModel;
using report::Cell;
using report::CompareLots;
using report::Comparison;
using report::ComparisonTable;
using report::ComputeLotModels;
using report::DecisionTimeText;
using report::Format;
using report::InconsistentUnitsTable;
using report::LoadLatestRuns;
using report::LotModelTable;
using report::LotStatistics;
using report::MarkedValue;
using report::MarkLegend;
using report::MeasurementStats;
using report::QualifierWord;
using report::RunsTable;
using report::StationOperatorLines;
using report::TableWriter;

namespace {

Result<std::unique_ptr<store::Archive>> OpenArchive(const std::string& db_path) {
  return store::Archive::Open(db_path, store::Archive::Mode::kRead);
}

Cell Opt(const std::optional<double>& v) { return Cell::Real(v ? *v : allan::kNaN); }

}  // namespace

Result<int64_t> ParseUtcTime(const std::string& text) {
  std::tm tm{};
  const char* end = strptime(text.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm);
  if (end == nullptr || *end != '\0') {
    tm = {};
    end = strptime(text.c_str(), "%Y-%m-%d", &tm);
    if (end == nullptr || *end != '\0') {
      return Status::InvalidArgument("'" + text +
                                     "' is not a date (2026-11-21) or UTC time "
                                     "(2026-11-21T08:00:00Z)");
    }
  }
  return static_cast<int64_t>(timegm(&tm)) * 1000000;
}

int LotStatsCommand(const std::string& db_path, const std::string& lot, Format format) {
  auto archive = OpenArchive(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto stats = LotStatistics(**archive, lot);
  if (!stats.ok()) {
    LogError(stats.status().message() + " in " + db_path);
    return stats.status().code() == Status::Code::kNotFound ? kExitUsage : kExitError;
  }
  TableWriter t({"axis", "measurement", "unit", "n", "mean", "sd", "min", "max", "judged", "yield",
                 "capability", "capability_kind", "low", "high", "capability_low_95",
                 "capability_high_95"});
  for (const MeasurementStats& s : *stats) {
    const judge::Summary& m = s.summary;
    t.AddRow({Cell::Text(s.axis.empty() ? "(run)" : s.axis), Cell::Text(s.name), Cell::Text(s.unit),
              Cell::Int(m.n), Cell::Real(m.mean), Cell::Real(m.sd), Cell::Real(m.min),
              Cell::Real(m.max), Cell::Int(m.judged), Cell::Real(m.yield), Cell::Real(m.capability),
              Cell::Text(m.capability_kind), Opt(s.low), Opt(s.high), Cell::Real(m.capability_low),
              Cell::Real(m.capability_high)});
  }
  if (format == Format::kTable) {
    std::printf(
        "lot %s: statistics over each unit's final run (its latest judged run, else its "
        "latest); yield = (PASS + MARGINAL) / (PASS + MARGINAL + FAIL) values\n",
        lot.c_str());
  }
  std::printf("%s", t.Render(format).c_str());
  if (format == Format::kTable) {
    // Two figures of one curve sit on adjacent rows; a limit belongs to one.
    const bool both = std::any_of(stats->begin(), stats->end(), [](const MeasurementStats& s) {
      return s.name == judge::kBiasInstabilityIeee;
    });
    if (both) {
      std::printf(
          "bias_instability is the Allan curve's minimum (the datasheet figure, what a plan's "
          "limit on it judges); bias_instability_ieee is IEEE 952's B = minimum / 0.664, for "
          "reference: compare a limit with the row it stands on\n");
    }
    std::printf("%s", LotYieldLines(**archive, lot).c_str());
    return LotModelCommand(db_path, lot, format);
  }
  return 0;
}

int LotModelCommand(const std::string& db_path, const std::string& lot, Format format) {
  auto archive = OpenArchive(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto runs = LoadLatestRuns(**archive, lot);
  if (!runs.ok()) {
    LogError(runs.status().message() + " in " + db_path);
    return runs.status().code() == Status::Code::kNotFound ? kExitUsage : kExitError;
  }
  const std::vector<AxisLotModel> models = ComputeLotModels(*runs);
  TableWriter t = LotModelTable(false);
  AddLotModelRows("", models, &t);
  if (format != Format::kTable) {
    std::printf("%s", t.Render(format).c_str());
    return 0;
  }
  std::printf(
      "\nlot noise model per axis (the units' Allan variances pooled, a composite model fitted; "
      "sigmas: the precision of the lot-mean model; spread: the units' 1-sigma factor on the "
      "deviation)\n%s",
      t.Render(format).c_str());
  const TableWriter flagged = InconsistentUnitsTable(models);
  std::printf(
      "\nunits inconsistent with their lot (outside the others' prediction interval at "
      "some tau; Student t, Bonferroni, 1 %%)\n%s",
      flagged.rows() == 0 ? "none\n" : flagged.Render(format).c_str());
  return 0;
}

int CompareCommand(const std::string& db_path, const std::string& lot_a, const std::string& lot_b,
                   double alpha, Format format) {
  if (!(alpha > 0 && alpha < 1)) {
    LogError("--alpha must be in (0, 1)");
    return kExitUsage;
  }
  auto archive = OpenArchive(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto a = LotStatistics(**archive, lot_a);
  auto b = a.ok() ? LotStatistics(**archive, lot_b) : a;
  if (!a.ok() || !b.ok()) {
    const Status& st = a.ok() ? b.status() : a.status();
    LogError(st.message() + " in " + db_path);
    return st.code() == Status::Code::kNotFound ? kExitUsage : kExitError;
  }
  const std::vector<Comparison> rows = CompareLots(*a, *b, alpha);
  const TableWriter t = ComparisonTable(rows);
  if (format == Format::kTable) {
    std::printf(
        "%s (a) vs %s (b): each unit's latest run; Welch t (mean), F (sd), Fisher exact "
        "(yield); significant at %g family-wise (Holm, %zu tests)\n",
        lot_a.c_str(), lot_b.c_str(), alpha, 3 * rows.size());
  }
  std::printf("%s", t.Render(format).c_str());
  if (format == Format::kTable) {
    TableWriter models = LotModelTable(true);
    for (const std::string& lot : {lot_a, lot_b}) {
      auto runs = LoadLatestRuns(**archive, lot);
      if (!runs.ok()) {
        LogError(runs.status().message());
        return kExitError;
      }
      AddLotModelRows(lot, ComputeLotModels(*runs), &models);
    }
    std::printf("\nlot noise models per axis (sigmas: the precision of each lot-mean model)\n%s",
                models.Render(format).c_str());
  }
  return 0;
}

int UnitCommand(const std::string& db_path, const std::string& serial, Format format) {
  auto archive = OpenArchive(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto rows = store::QueryUnitHistory(**archive, serial);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitError;
  }
  if (rows->empty()) {
    LogError("no unit '" + serial + "' in " + db_path);
    return kExitUsage;
  }
  // For people each value carries its marks (marks.h) and "± u"; programs
  // get the numbers, then each value's uncertainty and qualifier.
  const bool people = format == Format::kTable;
  std::vector<std::string> columns = {"run_id",
                                      "lot",
                                      "start",
                                      "state",
                                      "axis",
                                      "kind",
                                      "random_walk",
                                      "bias_instability",
                                      "bias_instability_ieee",
                                      "tau_min_s",
                                      "rate_random_walk",
                                      "gap_samples",
                                      "axis_verdict",
                                      "run_verdict"};
  if (!people) {
    for (const char* c : {"random_walk", "bias_instability", "tau_min_s", "rate_random_walk"}) {
      columns.push_back(std::string(c) + "_uncertainty");
      columns.push_back(std::string(c) + "_qualifier");
    }
    columns.push_back("axis_reasons");
  }
  // Early decisions: when the run's unit was decided (people: only when a
  // run used them; "full soak" when it was pending at every look).
  const bool early = std::any_of(rows->begin(), rows->end(),
                                 [](const store::AxisRow& r) { return r.has_decision_time; });
  if (!people) {
    columns.push_back("decision_time_s");
    for (const char* c : {"station", "slot", "operator"}) columns.push_back(c);
  } else if (early) {
    columns.push_back("decided at");
  }
  TableWriter t(columns);
  MarkLegend legend;
  for (const store::AxisRow& r : *rows) {
    auto value = [&](double v, const store::ValueMarks& m, const char* name, bool with_u) {
      if (!people) return Cell::Real(v);
      legend.Add(m, r.run_id, r.axis, name, v);
      return Cell::NumText(MarkedValue(v, m, 4, with_u));
    };
    std::vector<Cell> row = {
        Cell::Text(r.run_id),
        Cell::Text(r.lot),
        Cell::Text(FormatUtimeIso(r.start_utime)),
        Cell::Text(r.state),
        Cell::Text(r.axis),
        Cell::Text(r.kind),
        value(r.random_walk, r.random_walk_marks, "random walk", true),
        value(r.bias_instability, r.bias_instability_marks, "bias_instability", true),
        value(r.bias_instability_ieee, r.bias_instability_ieee_marks, "bias_instability_ieee",
              false),
        value(r.tau_min_s, r.tau_min_marks, "tau_at_minimum", true),
        value(r.rate_random_walk, r.rate_random_walk_marks, "rate_random_walk", true),
        Cell::Int(r.gap_samples),
        Cell::Text(r.axis_verdict.empty() ? "-" : r.axis_verdict),
        Cell::Text(r.run_verdict.empty() ? "-" : r.run_verdict)};
    if (!people) {
      for (const auto& [m, v] : {std::pair{&r.random_walk_marks, r.random_walk},
                                 std::pair{&r.bias_instability_marks, r.bias_instability},
                                 std::pair{&r.tau_min_marks, r.tau_min_s},
                                 std::pair{&r.rate_random_walk_marks, r.rate_random_walk}}) {
        row.push_back(Cell::Real(m->uncertainty));
        row.push_back(Cell::Text(QualifierWord(m->qualifier, v)));
      }
      row.push_back(Cell::Text(r.axis_notes));
      row.push_back(Cell::Real(r.decision_time_s));
      for (const std::string* c : {&r.station, &r.slot, &r.operator_name}) {
        row.push_back(Cell::Text(*c));
      }
    } else if (early) {
      row.push_back(Cell::Text(r.has_decision_time ? DecisionTimeText(r.decision_time_s) : ""));
    }
    t.AddRow(std::move(row));
  }
  std::printf("%s", t.Render(format).c_str());
  if (people) {
    std::printf("%s%s", StationOperatorLines(*rows).c_str(), legend.Render().c_str());
    // Why an axis is not PASS (INCONCLUSIVE: a retest candidate).
    std::string why;
    for (const store::AxisRow& r : *rows) {
      size_t start = 0;
      while (start < r.axis_notes.size()) {
        const size_t end = r.axis_notes.find('\n', start);
        why += "  " + r.run_id + " " + r.axis_notes.substr(start, end - start) + "\n";
        if (end == std::string::npos) break;
        start = end + 1;
      }
    }
    if (!why.empty()) std::printf("\nreasons:\n%s", why.c_str());
  }
  return 0;
}

int RunsCommand(const std::string& db_path, store::RunFilter filter, const std::string& since,
                Format format) {
  if (!since.empty()) {
    auto t = ParseUtcTime(since);
    if (!t.ok()) {
      LogError("--since: " + t.status().message());
      return kExitUsage;
    }
    filter.since_utime = *t;
  }
  // Verdicts are named in any case (--outcome fail is --verdict FAIL).
  std::transform(filter.verdict.begin(), filter.verdict.end(), filter.verdict.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  if (filter.verdict == "NONE") filter.verdict = "none";
  if (!filter.verdict.empty() && filter.verdict != "none" &&
      store::OutcomeFromText(filter.verdict) == pb::OUTCOME_UNSET) {
    LogError("--verdict must be PASS, MARGINAL, FAIL, INCONCLUSIVE, ABORTED, ERROR or none (in any "
             "case), not '" + filter.verdict + "'");
    return kExitUsage;
  }
  if (filter.limit < 1) {
    LogError("--limit must be >= 1");
    return kExitUsage;
  }
  auto archive = OpenArchive(db_path);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return ExitCodeOf(archive.status());
  }
  auto rows = store::QueryRuns(**archive, filter);
  if (!rows.ok()) {
    LogError(rows.status().message());
    return kExitError;
  }
  const TableWriter t = RunsTable(*rows);
  std::printf("%s", t.Render(format).c_str());
  return 0;
}

}  // namespace imuqual::cli
