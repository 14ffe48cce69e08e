#include "store/query.h"

namespace imuqual::store {

Result<std::vector<AxisRow>> QueryAxisRows(Archive& archive, const AxisRowFilter& filter) {
  if (filter.lot.empty()) return Status::InvalidArgument("a lot is required");
  // a.lot = ?1 reaches the runs index through the view (its GROUP BY starts
  // with the lot); the other conditions filter that lot's rows.
  auto s = archive.db().Prepare(R"sql(
SELECT a.lot, a.unit, a.run_id, a.start_utime, a.state, a.axis, a.kind, a.random_walk,
       a.bias_instability, a.bias_instability_ieee, a.tau_min_s, a.rate_random_walk,
       COALESCE(a.samples, 0), COALESCE(a.gap_samples, 0), COALESCE(a.invalid_samples, 0),
       COALESCE(a.axis_verdict, ''), COALESCE(a.run_verdict, '')
FROM axis_results a
WHERE a.lot = ?1
  AND substr(a.run_id, 1, length(?2)) = ?2
  AND (?3 = 0 OR a.run_id IN (SELECT run_id FROM latest_runs WHERE lot = ?1))
ORDER BY a.unit, a.start_utime, a.run_id, a.axis_index)sql");
  if (!s.ok()) return s.status();
  s->Bind(1, filter.lot).Bind(2, filter.run_prefix).Bind(3, filter.latest_per_unit ? 1 : 0);
  std::vector<AxisRow> rows;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    AxisRow r;
    r.lot = s->Text(0);
    r.unit = s->Text(1);
    r.run_id = s->Text(2);
    r.start_utime = s->Int(3);
    r.state = s->Text(4);
    r.axis = s->Text(5);
    r.kind = s->Text(6);
    r.random_walk = s->Real(7);
    r.bias_instability = s->Real(8);
    r.bias_instability_ieee = s->Real(9);
    r.tau_min_s = s->Real(10);
    r.rate_random_walk = s->Real(11);
    r.samples = s->Int(12);
    r.gap_samples = s->Int(13);
    r.invalid_samples = s->Int(14);
    r.axis_verdict = s->Text(15);
    r.run_verdict = s->Text(16);
    rows.push_back(std::move(r));
  }
  return rows;
}

Result<std::vector<LotRow>> QueryLots(Archive& archive) {
  auto s = archive.db().Prepare(
      "SELECT lot, runs, units, pass, marginal, fail, unjudged, yield, first_start_utime, "
      "last_start_utime FROM lot_overview ORDER BY last_start_utime DESC, lot");
  if (!s.ok()) return s.status();
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

}  // namespace imuqual::store
