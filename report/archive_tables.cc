#include "report/archive_tables.h"

#include <cmath>

#include "analyze/allan/curve.h"
#include "common/clock.h"
#include "report/marks.h"

namespace imuqual::report {
namespace {

double Pick(bool take, double v) { return take ? v : allan::kNaN; }

// A text cell, linked when `link` is set.
Cell Named(const std::string& text, const std::function<std::string(const std::string&)>& link) {
  return link ? Cell::Text(text).Linked(link(text)) : Cell::Text(text);
}

}  // namespace

TableWriter LotAxisTable(const std::vector<store::AxisRow>& rows) {
  TableWriter t({"lot", "serial", "run_id", "axis", "kind", "arw_deg_rt_hr", "vrw_m_s_rt_hr",
                 "bias_instability_deg_hr", "bias_instability_ieee_deg_hr", "bias_instability_ug",
                 "bias_instability_ieee_ug", "tau_min_s", "rrw_deg_hr_rt_hr", "rrw_ug_rt_hr",
                 "samples", "gap_samples", "invalid_samples", "verdict", "run_verdict", "state",
                 // The marks (after the columns programs already read): each value's
                 // 1-sigma uncertainty in its column's unit, its qualifier, and why
                 // the axis is not PASS.
                 "random_walk_uncertainty", "random_walk_qualifier", "bias_instability_uncertainty",
                 "bias_instability_qualifier", "tau_min_s_uncertainty", "tau_min_s_qualifier",
                 "rate_random_walk_uncertainty", "rate_random_walk_qualifier", "axis_reasons",
                 // Early decisions: the run's decision time, s (empty: none, or a full soak).
                 "decision_time_s",
                 // Who and where ("" if not recorded).
                 "station", "slot", "operator"});
  for (const store::AxisRow& r : rows) {
    const bool gyro = r.kind != "accel";
    t.AddRow({Cell::Text(r.lot),
              Cell::Text(r.unit),
              Cell::Text(r.run_id),
              Cell::Text(r.axis),
              Cell::Text(r.kind),
              Cell::Real(Pick(gyro, r.random_walk)),
              Cell::Real(Pick(!gyro, r.random_walk)),
              Cell::Real(Pick(gyro, r.bias_instability)),
              Cell::Real(Pick(gyro, r.bias_instability_ieee)),
              Cell::Real(Pick(!gyro, r.bias_instability)),
              Cell::Real(Pick(!gyro, r.bias_instability_ieee)),
              Cell::Real(r.tau_min_s),
              Cell::Real(Pick(gyro, r.rate_random_walk)),
              Cell::Real(Pick(!gyro, r.rate_random_walk)),
              Cell::Int(r.samples),
              Cell::Int(r.gap_samples),
              Cell::Int(r.invalid_samples),
              Cell::Text(r.axis_verdict),
              Cell::Text(r.run_verdict),
              Cell::Text(r.state),
              Cell::Real(r.random_walk_marks.uncertainty),
              Cell::Text(QualifierWord(r.random_walk_marks.qualifier, r.random_walk)),
              Cell::Real(r.bias_instability_marks.uncertainty),
              Cell::Text(QualifierWord(r.bias_instability_marks.qualifier, r.bias_instability)),
              Cell::Real(r.tau_min_marks.uncertainty),
              Cell::Text(QualifierWord(r.tau_min_marks.qualifier, r.tau_min_s)),
              Cell::Real(r.rate_random_walk_marks.uncertainty),
              Cell::Text(QualifierWord(r.rate_random_walk_marks.qualifier, r.rate_random_walk)),
              Cell::Text(r.axis_notes),
              Cell::Real(r.decision_time_s),
              Cell::Text(r.station),
              Cell::Text(r.slot),
              Cell::Text(r.operator_name)});
  }
  return t;
}

TableWriter LotsTable(const std::vector<store::LotRow>& lots, bool for_people,
                      const TableLinks& links) {
  // Each unit counted once, by its final run (its latest judged run, else
  // its latest): yield (the final yield) and first_pass_yield count PASS and
  // MARGINAL against PASS, MARGINAL and FAIL; INCONCLUSIVE units are retest
  // candidates, ABORTED and ERROR runs say nothing about a unit.
  TableWriter t({"lot", "runs", "units", "pass", "marginal", "fail", "inconclusive", "aborted",
                 "error", "unjudged", "first_pass_yield", "yield", "retests", "first_start",
                 "last_start"});
  auto yield = [for_people](double v) {
    return for_people && std::isnan(v) ? Cell::Text("n/m") : Cell::Real(v);
  };
  for (const store::LotRow& l : lots) {
    t.AddRow({Named(l.lot, links.lot), Cell::Int(l.runs), Cell::Int(l.units), Cell::Int(l.pass),
              Cell::Int(l.marginal), Cell::Int(l.fail), Cell::Int(l.inconclusive),
              Cell::Int(l.aborted), Cell::Int(l.error), Cell::Int(l.unjudged),
              yield(l.first_pass_yield), yield(l.yield), Cell::Int(l.retests),
              Cell::Text(FormatUtimeIso(l.first_start_utime)),
              Cell::Text(FormatUtimeIso(l.last_start_utime))});
  }
  return t;
}

TableWriter RunsTable(const std::vector<store::RunRow>& rows, const TableLinks& links) {
  // New columns go last: programs may read the earlier ones by position.
  TableWriter t({"run_id", "serial", "lot", "station", "slot", "start", "state", "verdict",
                 "reason", "operator"});
  for (const store::RunRow& r : rows) {
    t.AddRow({Named(r.run_id, links.run), Named(r.unit, links.serial), Named(r.lot, links.lot),
              Cell::Text(r.station), Cell::Text(r.slot), Cell::Text(FormatUtimeIso(r.start_utime)),
              Cell::Text(r.state), Cell::Text(r.verdict.empty() ? "-" : r.verdict),
              Cell::Text(r.reasons.substr(0, r.reasons.find('\n'))), Cell::Text(r.operator_name)});
  }
  return t;
}

TableWriter ComparisonTable(const std::vector<Comparison>& rows) {
  TableWriter t({"axis", "measurement", "unit", "n_a", "mean_a", "sd_a", "yield_a", "n_b", "mean_b",
                 "sd_b", "yield_b", "mean_change", "p_mean", "p_sd", "p_yield", "significant",
                 "mean_differs", "sd_differs", "yield_differs"});
  for (const Comparison& c : rows) {
    std::string sig;
    for (auto [flag, what] : {std::pair{c.mean_significant, "mean"},
                              {c.spread_significant, "sd"},
                              {c.yield_significant, "yield"}}) {
      if (!flag) continue;
      if (!sig.empty()) sig += ',';
      sig += what;
    }
    const judge::Summary& x = c.a.summary;
    const judge::Summary& y = c.b.summary;
    t.AddRow({Cell::Text(c.a.axis.empty() ? "(run)" : c.a.axis), Cell::Text(c.a.name),
              Cell::Text(c.a.unit), Cell::Int(x.n), Cell::Real(x.mean), Cell::Real(x.sd),
              Cell::Real(x.yield), Cell::Int(y.n), Cell::Real(y.mean), Cell::Real(y.sd),
              Cell::Real(y.yield), Cell::Real(c.mean_change), Cell::Real(c.mean.p_value),
              Cell::Real(c.spread.p_value), Cell::Real(c.yield.p_value),
              Cell::Text(sig.empty() ? "none" : sig), Cell::Bool(c.mean_significant),
              Cell::Bool(c.spread_significant), Cell::Bool(c.yield_significant)});
  }
  return t;
}

Result<std::vector<MeasurementStats>> LotStatistics(store::Archive& archive,
                                                    const std::string& lot) {
  auto rows = store::QueryLotMeasurements(archive, lot);
  if (!rows.ok()) return rows.status();
  if (rows->empty()) return Status::NotFound("no lot '" + lot + "' (imuqual lots lists them)");
  return ComputeLotStatistics(*rows);
}

}  // namespace imuqual::report
