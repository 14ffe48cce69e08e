#include "store/query.h"

#include <algorithm>
#include <functional>
#include <map>

#include "store/outcome.h"

namespace imuqual::store {

namespace {

constexpr char kAxisColumns[] = R"sql(
SELECT a.lot, a.serial, a.run_id, a.start_utime, a.state, a.axis, a.kind, a.random_walk,
       a.bias_instability, a.bias_instability_ieee, a.tau_min_s, a.rate_random_walk,
       COALESCE(a.samples, 0), COALESCE(a.gap_samples, 0), COALESCE(a.invalid_samples, 0),
       COALESCE(a.axis_verdict, ''), COALESCE(a.run_verdict, ''), a.run_key
FROM axis_results a)sql";

// The marks of the headline values, and the run's decision time (early
// decisions): every measurement of the rows' runs. With `lot`, all the
// lot's at once (two queries, whatever the number of runs: a plant across
// the network); without, one run at a time (a range read of the primary key).
Status FillMarks(Archive& archive, std::vector<AxisRow>* rows, const std::string& lot = "") {
  // Each run's rows, [begin, end) (a run's rows are adjacent).
  std::map<int64_t, std::pair<size_t, size_t>> ranges;
  for (size_t i = 0; i < rows->size(); ++i) {
    auto [it, fresh] = ranges.try_emplace((*rows)[i].run_key, i, i + 1);
    if (!fresh) it->second.second = i + 1;
  }
  const std::string measurement_sql = R"sql(
SELECT m.run_key, m.axis, m.name, m.uncertainty, COALESCE(m.qualifier, ''), COALESCE(m.outcome, ''),
       COALESCE(m.note, ''), m.uncertainty_method IS NULL, m.value
FROM measurements m)sql";
  const std::string run_sql =
      "SELECT run_key, COALESCE(reasons, ''), station, slot, operator FROM runs r";
  auto s = archive.db().Prepare(measurement_sql + (lot.empty() ? " WHERE m.run_key = ?1"
                                                               : " JOIN runs r USING (run_key) "
                                                                 "WHERE r.lot = ?1"));
  if (!s.ok()) return s.status();
  auto reasons = archive.db().Prepare(run_sql + (lot.empty() ? " WHERE run_key = ?1"
                                                             : " WHERE lot = ?1"));
  if (!reasons.ok()) return reasons.status();
  auto mark = [&](Stmt& q) {
    auto range = ranges.find(q.Int(0));
    if (range == ranges.end()) return;
    const std::string axis = q.Text(1), name = q.Text(2);
    ValueMarks m;
    m.uncertainty = q.Real(3);
    m.qualifier = QualifierFromText(q.Text(4));
    m.outcome = OutcomeFromText(q.Text(5));
    m.note = q.Text(6);
    // Archived before schema 6 (no qualifier, no uncertainty method): the
    // note said "upper bound".
    if (m.qualifier == pb::QUALIFIER_NONE && q.Int(7) != 0 && m.note.starts_with("upper bound")) {
      m.qualifier = pb::UPPER_BOUND;
    }
    for (size_t i = range->second.first; i < range->second.second; ++i) {
      AxisRow& r = (*rows)[i];
      if (axis.empty() && name == "decision_time") {
        r.has_decision_time = true;
        r.decision_time_s = q.Real(8);
      }
      if (r.axis != axis) continue;
      if (name == "angle_random_walk" || name == "velocity_random_walk") r.random_walk_marks = m;
      if (name == "bias_instability") r.bias_instability_marks = m;
      if (name == "bias_instability_ieee") r.bias_instability_ieee_marks = m;
      if (name == "tau_at_minimum") r.tau_min_marks = m;
      if (name == "rate_random_walk") r.rate_random_walk_marks = m;
    }
  };
  // The run's station, slot, operator, and its reasons that name the axis
  // ("gx: bias_instability ...").
  auto run_fields = [&](Stmt& q) {
    auto range = ranges.find(q.Int(0));
    if (range == ranges.end()) return;
    const std::string text = q.Text(1), station = q.Text(2), slot = q.Text(3),
                      operator_name = q.Text(4);
    for (size_t i = range->second.first; i < range->second.second; ++i) {
      AxisRow& r = (*rows)[i];
      r.station = station;
      r.slot = slot;
      r.operator_name = operator_name;
      const std::string prefix = r.axis + ": ";
      size_t start = 0;
      while (start < text.size()) {
        const size_t stop = text.find('\n', start);
        const std::string line = text.substr(start, stop - start);
        if (line.starts_with(prefix)) r.axis_notes += (r.axis_notes.empty() ? "" : "\n") + line;
        if (stop == std::string::npos) break;
        start = stop + 1;
      }
    }
  };
  auto each = [](Stmt& q, const std::function<void(Stmt&)>& fn) -> Status {
    for (;;) {
      auto row = q.Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      fn(q);
    }
    q.Reset();
    return Status::Ok();
  };
  if (!lot.empty()) {
    s->Bind(1, lot);
    IMUQUAL_RETURN_IF_ERROR(each(*s, mark));
    reasons->Bind(1, lot);
    return each(*reasons, run_fields);
  }
  for (const auto& [key, range] : ranges) {
    s->Bind(1, key);
    IMUQUAL_RETURN_IF_ERROR(each(*s, mark));
    reasons->Bind(1, key);
    IMUQUAL_RETURN_IF_ERROR(each(*reasons, run_fields));
  }
  return Status::Ok();
}

Result<std::vector<AxisRow>> ReadAxisRows(Stmt& s) {
  std::vector<AxisRow> rows;
  for (;;) {
    auto row = s.Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    AxisRow r;
    r.lot = s.Text(0);
    r.unit = s.Text(1);
    r.run_id = s.Text(2);
    r.start_utime = s.Int(3);
    r.state = s.Text(4);
    r.axis = s.Text(5);
    r.kind = s.Text(6);
    r.random_walk = s.Real(7);
    r.bias_instability = s.Real(8);
    r.bias_instability_ieee = s.Real(9);
    r.tau_min_s = s.Real(10);
    r.rate_random_walk = s.Real(11);
    r.samples = s.Int(12);
    r.gap_samples = s.Int(13);
    r.invalid_samples = s.Int(14);
    r.axis_verdict = s.Text(15);
    r.run_verdict = s.Text(16);
    r.run_key = s.Int(17);
    rows.push_back(std::move(r));
  }
}

}  // namespace

Result<std::vector<AxisRow>> QueryAxisRows(Archive& archive, const AxisRowFilter& filter) {
  if (filter.lot.empty()) return Status::InvalidArgument("a lot is required");
  // a.lot = ?1 reaches the runs index through the view (its GROUP BY starts
  // with the lot); the other conditions filter that lot's rows.
  auto s = archive.db().Prepare(std::string(kAxisColumns) + R"sql(
WHERE a.lot = ?1
  AND substr(a.run_id, 1, length(?2)) = ?2
  AND (?3 = 0 OR a.run_id IN (SELECT run_id FROM final_runs WHERE lot = ?1))
ORDER BY a.serial, a.start_utime, a.run_id, a.axis_index)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, filter.lot).Bind(2, filter.run_prefix).Bind(3, filter.latest_per_unit ? 1 : 0);
  auto rows = ReadAxisRows(*s);
  if (!rows.ok()) return rows.status();
  Status st = FillMarks(archive, &*rows, filter.lot);
  if (!st.ok()) return st;
  return rows;
}

Result<std::vector<AxisRow>> QueryUnitHistory(Archive& archive, const std::string& serial) {
  auto runs = archive.db().Prepare(
      "SELECT run_key FROM runs WHERE serial = ? ORDER BY start_utime, run_id");
  if (!runs.ok()) return runs.status();
  runs->Bind(1, serial);
  std::vector<int64_t> keys;
  for (;;) {
    auto row = runs->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    keys.push_back(runs->Int(0));
  }
  // One run at a time: an equality on the view's grouping column reaches the
  // primary key, where IN (subquery) would aggregate the whole archive.
  auto s = archive.db().Prepare(std::string(kAxisColumns) +
                                " WHERE a.run_key = ?1 ORDER BY a.axis_index");
  if (!s.ok()) return s.status();
  std::vector<AxisRow> rows;
  for (int64_t key : keys) {
    s->Bind(1, key);
    auto part = ReadAxisRows(*s);
    s->Reset();
    if (!part.ok()) return part.status();
    rows.insert(rows.end(), part->begin(), part->end());
  }
  Status st = FillMarks(archive, &rows);
  if (!st.ok()) return st;
  return rows;
}

Result<std::vector<MeasurementRow>> QueryLotMeasurements(Archive& archive, const std::string& lot) {
  auto s = archive.db().Prepare(R"sql(
SELECT l.serial, l.run_id, m.axis, COALESCE(ra.kind, ''), m.name, m.value, m.uncertainty, m.unit,
       m.low, m.high, m.marginal_low, m.marginal_high, COALESCE(m.outcome, ''), m.note,
       COALESCE(m.qualifier, ''), COALESCE(m.uncertainty_method, ''),
       COALESCE(m.decision_rule, ''), m.guard_band
FROM final_runs l
JOIN measurements m ON m.run_key = l.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis
WHERE l.lot = ?1 AND l.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
ORDER BY l.serial, COALESCE(ra.axis_index, -1), m.name)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, lot);
  std::vector<MeasurementRow> rows;
  auto opt = [&](int col) { return s->IsNull(col) ? std::nullopt : std::optional<double>(s->Real(col)); };
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    MeasurementRow r;
    r.unit = s->Text(0);
    r.run_id = s->Text(1);
    r.axis = s->Text(2);
    r.kind = s->Text(3);
    r.name = s->Text(4);
    r.value = s->Real(5);
    r.uncertainty = s->Real(6);
    r.value_unit = s->Text(7);
    r.low = opt(8);
    r.high = opt(9);
    r.marginal_low = opt(10);
    r.marginal_high = opt(11);
    r.outcome = OutcomeFromText(s->Text(12));
    r.note = s->Text(13);
    r.qualifier = QualifierFromText(s->Text(14));
    r.uncertainty_method = s->Text(15);
    r.decision_rule = DecisionRuleFromText(s->Text(16));
    r.guard_band = s->Real(17);
    rows.push_back(std::move(r));
  }
}

Result<std::vector<RunRow>> QueryRuns(Archive& archive, const RunFilter& f) {
  auto s = archive.db().Prepare(R"sql(
SELECT run_id, serial, lot, station, slot, state, COALESCE(verdict, ''), COALESCE(reasons, ''),
       start_utime, operator
FROM runs
WHERE (?1 = '' OR lot = ?1) AND (?2 = '' OR station = ?2) AND (?3 = '' OR serial = ?3)
  AND start_utime >= ?4
  AND (?5 = '' OR (?5 = 'none' AND verdict IS NULL) OR verdict = ?5)
  AND (?7 = '' OR substr(serial, 1, length(?7)) = ?7)
ORDER BY start_utime DESC, run_id
LIMIT ?6)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, f.lot).Bind(2, f.station).Bind(3, f.unit).Bind(4, f.since_utime).Bind(5, f.verdict);
  s->Bind(6, f.limit).Bind(7, f.unit_prefix);
  std::vector<RunRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    RunRow r;
    r.run_id = s->Text(0);
    r.unit = s->Text(1);
    r.lot = s->Text(2);
    r.station = s->Text(3);
    r.slot = s->Text(4);
    r.state = s->Text(5);
    r.verdict = s->Text(6);
    r.reasons = s->Text(7);
    r.start_utime = s->Int(8);
    r.operator_name = s->Text(9);
    rows.push_back(std::move(r));
  }
}

Result<std::vector<LotRow>> QueryLots(Archive& archive, const std::optional<std::string>& only) {
  auto s = archive.db().Prepare(
      std::string("SELECT lot, runs, units, pass, marginal, fail, unjudged, final_yield, "
                  "first_start_utime, last_start_utime, inconclusive, aborted, error, "
                  "first_pass_yield, retests, retest_candidates FROM lot_overview ") +
      (only ? "WHERE lot = ? " : "") + "ORDER BY last_start_utime DESC, lot");
  if (!s.ok()) return s.status();
  if (only) s->Bind(1, *only);
  std::vector<LotRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    LotRow r;
    r.lot = s->Text(0);
    r.runs = s->Int(1);
    r.units = s->Int(2);
    r.pass = s->Int(3);
    r.marginal = s->Int(4);
    r.fail = s->Int(5);
    r.unjudged = s->Int(6);
    r.yield = s->Real(7);
    r.first_start_utime = s->Int(8);
    r.last_start_utime = s->Int(9);
    r.inconclusive = s->Int(10);
    r.aborted = s->Int(11);
    r.error = s->Int(12);
    r.first_pass_yield = s->Real(13);
    r.retests = s->Int(14);
    r.retest_candidates = s->Int(15);
    rows.push_back(std::move(r));
  }
  return rows;
}

Result<std::vector<std::pair<std::string, std::string>>> QueryReasons(
    Archive& archive, const std::vector<std::string>& run_ids) {
  auto s = archive.db().Prepare("SELECT COALESCE(reasons, '') FROM runs WHERE run_id = ?");
  if (!s.ok()) return s.status();
  std::vector<std::pair<std::string, std::string>> out;
  for (const std::string& id : run_ids) {
    s->Bind(1, id);
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (*row && !s->Text(0).empty()) out.emplace_back(id, s->Text(0));
    s->Reset();
  }
  return out;
}

Result<std::vector<RetestRow>> QueryRetestReasons(Archive& archive, const std::string& lot) {
  auto s = archive.db().Prepare(
      "SELECT serial, run_id, state, COALESCE(verdict, ''), COALESCE(reasons, ''), "
      "COALESCE(next_run_id, '') FROM retest_reasons WHERE lot = ? ORDER BY serial, start_utime, "
      "run_id");
  if (!s.ok()) return s.status();
  s->Bind(1, lot);
  std::vector<RetestRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    RetestRow r;
    r.unit = s->Text(0);
    r.run_id = s->Text(1);
    r.state = s->Text(2);
    r.verdict = s->Text(3);
    r.reasons = s->Text(4);
    r.next_run_id = s->Text(5);
    rows.push_back(std::move(r));
  }
}

Result<std::vector<DecisionTimeRow>> QueryDecisionTimes(Archive& archive, const std::string& lot,
                                                        const std::string& run_prefix) {
  auto s = archive.db().Prepare(R"sql(
SELECT r.serial, r.run_id, r.verdict, r.start_utime, r.plan, m.value, m.note
FROM runs r
JOIN measurements m ON m.run_key = r.run_key AND m.axis = '' AND m.name = 'decision_time'
WHERE r.lot = ?1 AND r.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
  AND substr(r.run_id, 1, length(?2)) = ?2
ORDER BY r.start_utime, r.run_id)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, lot).Bind(2, run_prefix);
  std::vector<DecisionTimeRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    DecisionTimeRow r;
    r.unit = s->Text(0);
    r.run_id = s->Text(1);
    r.verdict = s->Text(2);
    r.start_utime = s->Int(3);
    const std::vector<uint8_t> plan = s->Blob(4);
    r.plan.assign(plan.begin(), plan.end());
    r.decision_time_s = s->Real(5);
    r.note = s->Text(6);
    rows.push_back(std::move(r));
  }
}

Result<std::vector<RunStatusRow>> QueryRunStatus(Archive& archive,
                                                 const std::vector<std::string>& run_ids) {
  auto s = archive.db().Prepare(
      "SELECT state, COALESCE(verdict, ''), COALESCE(reasons, ''), finalized_utime IS NOT NULL "
      "FROM runs WHERE run_id = ?1");
  if (!s.ok()) return s.status();
  std::vector<RunStatusRow> rows;
  for (const std::string& id : run_ids) {
    s->Bind(1, id);
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (*row) rows.push_back({id, s->Text(0), s->Text(1), s->Text(2), s->Int(3) != 0});
    s->Reset();
  }
  return rows;
}

Result<std::vector<std::string>> QueryOpenRunIds(Archive& archive, const std::string& station) {
  auto s = archive.db().Prepare(
      "SELECT run_id FROM runs WHERE station = ?1 AND finalized_utime IS NULL ORDER BY run_id");
  if (!s.ok()) return s.status();
  s->Bind(1, station);
  std::vector<std::string> ids;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return ids;
    ids.push_back(s->Text(0));
  }
}

Result<std::string> QueryLotFingerprint(Archive& archive, const std::string& lot) {
  auto s = archive.db().Prepare(
      "SELECT run_key, finalized_utime IS NULL, COALESCE(result_utime, 0), "
      "COALESCE(finalized_utime, 0), COALESCE(verdict, '-') FROM runs WHERE lot = ?1 "
      "ORDER BY run_key");
  if (!s.ok()) return s.status();
  s->Bind(1, lot);
  int64_t runs = 0, newest = 0;
  std::string times, verdicts;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    if (s->Int(1) != 0) return std::string();  // a run still open
    ++runs;
    newest = std::max(newest, s->Int(0));
    times += std::to_string(s->Int(2)) + "," + std::to_string(s->Int(3)) + ";";
    verdicts += (verdicts.empty() ? "" : ",") + s->Text(4);
  }
  if (runs == 0) return std::string();
  return std::to_string(runs) + "/" + std::to_string(newest) + "/" + times + "/" + verdicts;
}

namespace {
// Rows of lot, serial, station, operator, run_id, start_utime, axis, name,
// value, unit, low, high.
Result<std::vector<RunValueRow>> ReadRunValues(Stmt& s) {
  std::vector<RunValueRow> rows;
  auto opt = [&](int col) { return s.IsNull(col) ? std::nullopt : std::optional<double>(s.Real(col)); };
  for (;;) {
    auto row = s.Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    RunValueRow r;
    r.lot = s.Text(0);
    r.unit = s.Text(1);
    r.station = s.Text(2);
    r.operator_name = s.Text(3);
    r.run_id = s.Text(4);
    r.start_utime = s.Int(5);
    r.axis = s.Text(6);
    r.name = s.Text(7);
    r.value = s.Real(8);
    r.value_unit = s.Text(9);
    r.low = opt(10);
    r.high = opt(11);
    r.plan_sha256 = s.Text(12);
    rows.push_back(std::move(r));
  }
}
}  // namespace

Result<std::vector<RunValueRow>> QueryRunValues(Archive& archive, const std::string& lot) {
  auto s = archive.db().Prepare(R"sql(
SELECT r.lot, r.serial, r.station, r.operator, r.run_id, r.start_utime, m.axis, m.name, m.value,
       m.unit, m.low, m.high, r.plan_sha256
FROM runs r
JOIN measurements m ON m.run_key = r.run_key
WHERE r.lot = ?1 AND r.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
ORDER BY r.serial, r.station, r.start_utime, r.run_id, m.axis, m.name)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, lot);
  return ReadRunValues(*s);
}

Result<std::vector<RunValueRow>> QueryMeasurementHistory(Archive& archive, const std::string& name,
                                                         const std::string& axis) {
  // Each unit's final run in each lot that is judged (as lot_measurements
  // has it: its latest judged run): a judged run with no later judged run of
  // its unit in its lot. An anti-join over the archive at once (the view's
  // subquery would run once per value, 10^5 at a plant; the plant's indexes
  // measurements_values and runs_final answer it from the indexes alone).
  auto s = archive.db().Prepare(R"sql(
SELECT r.lot, r.serial, r.station, r.operator, r.run_id, r.start_utime, m.axis, m.name, m.value,
       m.unit, m.low, m.high, r.plan_sha256
FROM measurements m
JOIN runs r ON r.run_key = m.run_key
WHERE m.name = ?1 AND m.axis = ?2 AND m.value IS NOT NULL
  AND r.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
  AND NOT EXISTS (SELECT 1 FROM runs x
                  WHERE x.lot = r.lot AND x.serial = r.serial
                    AND x.verdict IN ('PASS', 'MARGINAL', 'FAIL', 'INCONCLUSIVE')
                    AND (x.start_utime > r.start_utime
                         OR (x.start_utime = r.start_utime AND x.run_key > r.run_key)))
ORDER BY r.start_utime, r.run_id)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, name).Bind(2, axis);
  return ReadRunValues(*s);
}

Result<std::string> QueryPlanByDigest(Archive& archive, const std::string& plan_sha256) {
  auto s = archive.db().Prepare("SELECT plan FROM runs WHERE plan_sha256 = ?1 LIMIT 1");
  if (!s.ok()) return s.status();
  s->Bind(1, plan_sha256);
  auto row = s->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::NotFound("no run judged by plan " + plan_sha256);
  const std::vector<uint8_t> plan = s->Blob(0);
  return std::string(plan.begin(), plan.end());
}

Result<std::vector<RunVerdictRow>> QueryRunVerdicts(Archive& archive) {
  auto s = archive.db().Prepare(
      "SELECT run_id, lot, serial, station, COALESCE(verdict, ''), start_utime FROM runs "
      "ORDER BY start_utime, run_id");
  if (!s.ok()) return s.status();
  std::vector<RunVerdictRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) return rows;
    rows.push_back({s->Text(0), s->Text(1), s->Text(2), s->Text(3), s->Text(4), s->Int(5)});
  }
}

}  // namespace imuqual::store
