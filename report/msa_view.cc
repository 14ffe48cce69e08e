#include "report/msa_view.h"

#include <algorithm>
#include <map>
#include <set>
#include <tuple>

namespace imuqual::report {
namespace {

bool Selected(const store::RunValueRow& r, const MsaSelection& s) {
  if (!std::isfinite(r.value)) return false;
  if (!s.axis.empty() && r.axis != s.axis) return false;
  if (!s.measurement.empty()) return r.name == s.measurement;
  // Judged values only: those with a limit; a unit's own noise-model
  // parameters and its decision time are not the station's measurement.
  return (r.low || r.high) && !r.name.starts_with("model_") && r.name != "decision_time";
}

}  // namespace

Result<Appraiser> ParseAppraiser(const std::string& text) {
  if (text == "station") return Appraiser::kStation;
  if (text == "operator") return Appraiser::kOperator;
  if (text == "station-operator") return Appraiser::kStationOperator;
  return Status::InvalidArgument("appraiser '" + text +
                                 "': station, operator or station-operator");
}

std::string AppraiserName(Appraiser a) {
  return a == Appraiser::kStation    ? "station"
         : a == Appraiser::kOperator ? "operator"
                                     : "station-operator";
}

std::vector<MsaOutcome> StudyStations(const std::vector<store::RunValueRow>& rows,
                                      const MsaSelection& selection) {
  const std::string who = AppraiserName(selection.appraiser);
  auto appraiser_of = [&](const store::RunValueRow& r) {
    switch (selection.appraiser) {
      case Appraiser::kStation: return r.station;
      case Appraiser::kOperator: return r.operator_name;
      case Appraiser::kStationOperator: return r.station + "/" + r.operator_name;
    }
    return r.station;
  };
  // (axis, name) -> unit -> appraiser -> values in run order.
  using Cells = std::map<std::string, std::map<std::string, std::vector<double>>>;
  std::map<std::pair<std::string, std::string>, Cells> by_measurement;
  std::map<std::pair<std::string, std::string>, const store::RunValueRow*> first;
  std::vector<const store::RunValueRow*> ordered;
  for (const store::RunValueRow& r : rows) ordered.push_back(&r);
  std::stable_sort(ordered.begin(), ordered.end(), [](const auto* a, const auto* b) {
    return a->start_utime < b->start_utime;
  });
  for (const store::RunValueRow* r : ordered) {
    if (!Selected(*r, selection)) continue;
    const auto key = std::make_pair(r->axis, r->name);
    by_measurement[key][r->unit][appraiser_of(*r)].push_back(r->value);
    if (!first.count(key)) first[key] = r;
  }
  std::vector<MsaOutcome> out;
  for (const auto& [key, units] : by_measurement) {
    MsaOutcome o;
    o.axis = key.first;
    o.measurement = key.second;
    o.unit = first[key]->value_unit;
    std::set<std::string> stations;
    for (const auto& [unit, cells] : units) {
      for (const auto& [station, values] : cells) stations.insert(station);
    }
    // Trials: as many as every unit has on every station (or as asked).
    size_t fewest = SIZE_MAX;
    std::string where;
    for (const auto& [unit, cells] : units) {
      for (const std::string& station : stations) {
        auto it = cells.find(station);
        const size_t n = it == cells.end() ? 0 : it->second.size();
        if (n < fewest) {
          fewest = n;
          where = "unit " + unit + " has " + std::to_string(n) + " judged run(s) by " + who + " " +
                  station;
        }
      }
    }
    size_t trials = selection.trials > 0 ? static_cast<size_t>(selection.trials) : fewest;
    if (fewest == 0) {
      o.why_not = where + ": every golden unit must be soaked by every " + who;
    } else if (fewest < trials) {
      o.why_not = where + ", fewer than --trials " + std::to_string(selection.trials);
    } else if (trials < 2) {
      o.why_not = where + ": each unit must be soaked at least twice by every " + who;
    } else if (stations.size() < 2) {
      o.why_not = "one " + who + " only (" + *stations.begin() + "): nothing to compare";
    }
    if (o.why_not.empty()) {
      judge::MsaStudy study;
      study.stations.assign(stations.begin(), stations.end());
      for (const auto& [unit, cells] : units) {
        study.parts.push_back(unit);
        std::vector<std::vector<double>> per_station;
        for (const std::string& station : study.stations) {
          const std::vector<double>& v = cells.at(station);
          per_station.emplace_back(v.begin(), v.begin() + static_cast<long>(trials));
        }
        study.values.push_back(std::move(per_station));
      }
      study.low = first[key]->low;
      study.high = first[key]->high;
      auto result = judge::AnalyzeMsa(study);
      if (result.ok()) {
        o.result = std::move(*result);
      } else {
        o.why_not = result.status().message();
      }
    }
    out.push_back(std::move(o));
  }
  return out;
}

TableWriter MsaTable(const std::vector<MsaOutcome>& outcomes, Appraiser appraiser) {
  TableWriter t({"axis", "measurement", "unit", "units", AppraiserName(appraiser) + "s", "trials", "mean", "ev", "av",
                 "interaction", "grr", "pv", "tv", "percent_grr_tv", "percent_grr_tolerance",
                 "tolerance_basis", "ndc", "interaction_p", "interaction_pooled", "verdict",
                 "not_analysed"});
  for (const MsaOutcome& o : outcomes) {
    const judge::MsaResult& m = o.result;
    const bool done = o.why_not.empty();
    t.AddRow({Cell::Text(o.axis), Cell::Text(o.measurement), Cell::Text(o.unit),
              Cell::Int(m.parts), Cell::Int(m.stations), Cell::Int(m.trials), Cell::Real(m.mean),
              Cell::Real(m.ev), Cell::Real(m.av), Cell::Real(m.interaction), Cell::Real(m.grr),
              Cell::Real(m.pv), Cell::Real(m.tv), Cell::Real(m.percent_grr_tv),
              Cell::Real(m.percent_grr_tolerance), Cell::Text(m.tolerance_basis),
              done ? Cell::Int(m.ndc) : Cell::Text(""), Cell::Real(m.p_interaction),
              done ? Cell::Bool(m.interaction_pooled) : Cell::Text(""), Cell::Text(m.verdict),
              Cell::Text(o.why_not)});
  }
  return t;
}

TableWriter MsaOffsetsTable(const std::vector<MsaOutcome>& outcomes, Appraiser appraiser) {
  TableWriter t({"axis", "measurement", "unit", AppraiserName(appraiser), "offset", "offset_percent", "low_95",
                 "high_95", "differs"});
  for (const MsaOutcome& o : outcomes) {
    if (!o.why_not.empty()) continue;
    for (const judge::StationOffset& s : o.result.offsets) {
      const double pct = o.result.mean != 0 ? 100 * s.offset / o.result.mean : allan::kNaN;
      t.AddRow({Cell::Text(o.axis), Cell::Text(o.measurement), Cell::Text(o.unit),
                Cell::Text(s.station), Cell::Real(s.offset), Cell::Real(pct), Cell::Real(s.low),
                Cell::Real(s.high), Cell::Bool(s.differs)});
    }
  }
  return t;
}

}  // namespace imuqual::report
