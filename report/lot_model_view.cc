#include "report/lot_model_view.h"

#include <algorithm>
#include <cstdio>
#include <future>
#include <map>

#include "analyze/allan/model_quantities.h"
#include "common/strings.h"
#include "store/query.h"

namespace imuqual::report {
namespace {

allan::SensorKind Sensor(pb::AxisKind kind) {
  return kind == pb::ACCEL ? allan::SensorKind::kAccelerometer : allan::SensorKind::kGyro;
}

const allan::ModelQuantity* Quantity(const std::vector<allan::ModelQuantity>& q,
                                     const std::string& name) {
  for (const allan::ModelQuantity& x : q) {
    if (x.name == name) return &x;
  }
  return nullptr;
}

}  // namespace

Result<std::vector<RunPlotData>> LoadLatestRuns(store::Archive& archive, const std::string& lot) {
  store::AxisRowFilter filter;
  filter.lot = lot;
  auto rows = store::QueryAxisRows(archive, filter);
  if (!rows.ok()) return rows.status();
  if (rows->empty()) return Status::NotFound("no lot '" + lot + "' (imuqual lots lists them)");
  std::vector<RunPlotData> runs;
  for (const store::AxisRow& r : *rows) {
    if (!runs.empty() && runs.back().info.run_id == r.run_id) continue;
    auto run = LoadRunPlotData(archive, r.run_id);
    if (!run.ok()) return run.status();
    runs.push_back(std::move(*run));
  }
  return runs;
}

std::vector<AxisLotModel> ComputeLotModels(const std::vector<RunPlotData>& runs) {
  std::vector<AxisLotModel> out;
  std::map<std::string, std::vector<allan::UnitCurve>> curves;
  for (const RunPlotData& r : runs) {
    for (const AxisPlotData& a : r.axes) {
      auto it = std::find_if(out.begin(), out.end(),
                             [&](const AxisLotModel& m) { return m.axis == a.axis; });
      if (it == out.end()) {
        out.push_back({a.axis, a.kind});
        it = out.end() - 1;
      }
      if (!a.curve) continue;
      ++it->curves;
      curves[a.axis].push_back({r.info.serial, *a.curve});
    }
  }
  // One fit per axis, each on its own thread (they share nothing, and each
  // bootstrap has its own fixed seed: the same figures as one by one).
  std::vector<std::future<Result<allan::LotModel>>> fits;
  for (const AxisLotModel& m : out) {
    const std::vector<allan::UnitCurve>* axis_curves = &curves[m.axis];
    fits.push_back(
        std::async(std::launch::async, [axis_curves] { return allan::FitLotModel(*axis_curves); }));
  }
  for (size_t i = 0; i < out.size(); ++i) out[i].model = fits[i].get();
  return out;
}

TableWriter LotModelTable(bool with_lot) {
  std::vector<std::string> columns = {"axis",
                                      "units",
                                      "pooled_units",
                                      "model",
                                      "adequate",
                                      "p_value",
                                      "random_walk",
                                      "random_walk_sigma",
                                      "bias_instability",
                                      "bias_instability_sigma",
                                      "rate_random_walk",
                                      "rate_random_walk_sigma",
                                      "rate_random_walk_note",
                                      "spread_short_tau",
                                      "spread_long_tau",
                                      "inconsistent_units",
                                      "note"};
  if (with_lot) columns.insert(columns.begin(), "lot");
  return TableWriter(columns, 4);
}

std::string LeftOutNote(const allan::LotModel& lm) {
  if (lm.left_out.empty()) return "";
  std::string out = "; model of " + std::to_string(lm.units) + " units, left out as inconsistent "
                    "with their lot: " + Join(lm.left_out, " ");
  if (!lm.all_units_model.empty()) {
    char buf[120];
    std::snprintf(buf, sizeof buf, " (every unit pooled: %s, J-test p = %.2g)",
                  lm.all_units_model.c_str(), lm.all_units_p_value);
    out += buf;
  }
  return out;
}

void AddLotModelRows(const std::string& lot, const std::vector<AxisLotModel>& models,
                     TableWriter* table) {
  for (const AxisLotModel& m : models) {
    std::vector<Cell> row;
    if (!lot.empty()) row.push_back(Cell::Text(lot));
    row.push_back(Cell::Text(m.axis));
    row.push_back(Cell::Int(m.curves));
    if (!m.model.ok()) {
      const Cell none = Cell::Real(allan::kNaN);
      for (const Cell& c : {Cell::Text("-"), Cell::Text("-"), Cell::Text("-"), none, none, none, none, none, none,
                            none, Cell::Text("-"), none, none, Cell::Text("-"),
                            Cell::Text("not measurable: " + m.model.status().message())}) {
        row.push_back(c);
      }
      table->AddRow(std::move(row));
      continue;
    }
    const allan::LotModel& lm = *m.model;
    const std::vector<allan::ModelQuantity> q = allan::DescribeCompositeFit(lm.fit, Sensor(m.kind));
    const allan::ModelQuantity* rw =
        Quantity(q, m.kind == pb::ACCEL ? "velocity_random_walk" : "angle_random_walk");
    const allan::ModelQuantity* bi = Quantity(q, "bias_instability_ieee");
    const allan::ModelQuantity* k = Quantity(q, "rate_random_walk");
    std::string flagged;
    for (const allan::UnitConsistency& c : lm.consistency) {
      if (c.consistent) continue;
      if (!flagged.empty()) flagged += " ";
      flagged += c.unit;
    }
    row.push_back(Cell::Int(lm.units));
    row.push_back(Cell::Text(lm.fit.model.Name()));
    row.push_back(Cell::Text(lm.fit.adequate ? "yes" : "no"));
    row.push_back(Cell::Real(lm.fit.p_value));
    for (const allan::ModelQuantity* x : {rw, bi}) {
      row.push_back(Cell::Real(lm.fit.adequate ? x->value : allan::kNaN));
      row.push_back(Cell::Real(lm.fit.adequate ? x->sigma : allan::kNaN));
    }
    // K left out of the model: its upper bound, or nothing where none exists.
    const bool k_absent = k->absent;
    const bool k_bound = k_absent && std::isfinite(k->upper_bound);
    row.push_back(Cell::Real(!lm.fit.adequate || (k_absent && !k_bound) ? allan::kNaN
                             : k_bound                                  ? k->upper_bound
                                                                        : k->value));
    row.push_back(Cell::Real(lm.fit.adequate ? k->sigma : allan::kNaN));
    row.push_back(Cell::Text(k_bound    ? "upper bound (95 %)"
                             : k_absent ? "not in the model; no bound from the analysed taus"
                                        : "-"));
    row.push_back(Cell::Real(lm.points.front().spread_factor));
    row.push_back(Cell::Real(lm.points.back().spread_factor));
    row.push_back(Cell::Text(flagged.empty() ? "-" : flagged));
    std::string unit = rw->unit + ", " + bi->unit + ", " + k->unit;
    std::string note = lm.fit.adequate ? "units: " + unit
                                       : "not measurable: lot model inadequate (J-test p < 0.01)";
    note += LeftOutNote(lm);
    row.push_back(Cell::Text(note));
    table->AddRow(std::move(row));
  }
}

TableWriter InconsistentUnitsTable(const std::vector<AxisLotModel>& models) {
  TableWriter t({"axis", "serial", "p_value", "worst_tau_s", "deviation_vs_others"}, 4);
  for (const AxisLotModel& m : models) {
    if (!m.model.ok()) continue;
    for (const allan::UnitConsistency& c : m.model->consistency) {
      if (c.consistent) continue;
      t.AddRow({Cell::Text(m.axis), Cell::Text(c.unit), Cell::Real(c.p_value),
                Cell::Real(c.worst_tau_s), Cell::Real(c.worst_factor)});
    }
  }
  return t;
}

}  // namespace imuqual::report
