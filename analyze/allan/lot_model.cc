#include "analyze/allan/lot_model.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <map>

namespace imuqual::allan {
namespace {

bool PowerOfTwo(int64_t m) { return m > 0 && (m & (m - 1)) == 0; }

}  // namespace

Status LotModelOptions::Validate() const {
  IMUQUAL_RETURN_IF_ERROR(fit.Validate());
  if (!(consistency_level > 0 && consistency_level < 1)) {
    return Status::InvalidArgument("consistency_level must be in (0, 1)");
  }
  if (min_units < 4) return Status::InvalidArgument("min_units must be at least 4");
  return Status::Ok();
}

Result<LotModel> FitLotModel(const std::vector<UnitCurve>& units, const LotModelOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  const int k = static_cast<int>(units.size());
  if (k < options.min_units) {
    return Status::InvalidArgument("a lot model needs at least " +
                                   std::to_string(options.min_units) + " units with a curve, got " +
                                   std::to_string(k));
  }
  const Curve& first = units.front().curve;
  // The octave averaging factors every unit has, with each unit's AVAR.
  std::map<int64_t, std::vector<double>> avar;  // m -> per unit
  std::map<int64_t, std::vector<int64_t>> n_of;  // m -> per unit
  std::map<int64_t, int64_t> stride;
  for (int u = 0; u < k; ++u) {
    const Curve& c = units[u].curve;
    if (c.deviation != first.deviation || c.tau0_s != first.tau0_s) {
      return Status::InvalidArgument("unit " + units[u].unit +
                                     ": its curve's kind or tau0 differs from the lot's");
    }
    for (const CurvePoint& p : c.points) {
      if (!PowerOfTwo(p.m) || !(p.dev > 0) || !std::isfinite(p.dev) || p.n < 2) continue;
      std::vector<double>& v = avar[p.m];
      if (static_cast<int>(v.size()) != u) continue;  // a duplicate m, or missing in a unit before
      v.push_back(p.dev * p.dev);
      n_of[p.m].push_back(p.n);
      if (u == 0) stride[p.m] = p.stride;
    }
  }
  std::vector<int64_t> ms;
  for (const auto& [m, v] : avar) {
    if (static_cast<int>(v.size()) == k) ms.push_back(m);
  }
  if (ms.size() < 4) {
    return Status::InvalidArgument("the units' curves share " + std::to_string(ms.size()) +
                                   " octave points; a lot model needs at least 4");
  }

  std::vector<std::vector<double>> log_avar;  // [point][unit]
  for (int64_t m : ms) {
    std::vector<double> logs;
    for (double x : avar[m]) logs.push_back(std::log(x));
    log_avar.push_back(logs);
  }

  // Each unit against the others' prediction interval, tau by tau.
  LotModel lot;
  const boost::math::students_t t_dist(k - 2);
  const double inflation = std::sqrt(1.0 + 1.0 / (k - 1));
  for (int u = 0; u < k; ++u) {
    UnitConsistency c;
    c.unit = units[u].unit;
    double worst_t = 0;
    for (size_t j = 0; j < ms.size(); ++j) {
      double mean = 0, ss = 0;
      for (int o = 0; o < k; ++o) {
        if (o != u) mean += log_avar[j][o] / (k - 1);
      }
      for (int o = 0; o < k; ++o) {
        if (o != u) ss += (log_avar[j][o] - mean) * (log_avar[j][o] - mean);
      }
      const double sd = std::sqrt(ss / (k - 2));
      if (!(sd > 0)) continue;
      const double t = (log_avar[j][u] - mean) / (sd * inflation);
      if (std::fabs(t) > std::fabs(worst_t)) {
        worst_t = t;
        c.worst_tau_s = static_cast<double>(ms[j]) * first.tau0_s;
        c.worst_factor = std::exp(0.5 * (log_avar[j][u] - mean));
      }
    }
    const double p_one = 2 * boost::math::cdf(boost::math::complement(t_dist, std::fabs(worst_t)));
    c.p_value = std::min(1.0, p_one * static_cast<double>(ms.size()));
    c.consistent = !(c.p_value < options.consistency_level);
    lot.consistency.push_back(c);
  }

  // The pooled curve of a set of units: K records of one process in the
  // fit's eyes, so each point carries the terms (and the edf) of all of them.
  auto pooled_of = [&](const std::vector<int>& members) {
    Curve pooled;
    pooled.deviation = first.deviation;
    pooled.tau0_s = first.tau0_s;
    pooled.n_phase = 0;
    for (int u : members) pooled.n_phase += units[u].curve.n_phase;
    for (int64_t m : ms) {
      double mean = 0;
      int64_t n = 0;
      for (int u : members) mean += avar[m][u] / static_cast<double>(members.size());
      for (int u : members) n += n_of[m][u];
      CurvePoint p;
      p.m = m;
      p.tau_s = static_cast<double>(m) * first.tau0_s;
      p.dev = std::sqrt(mean);
      p.n = n;
      p.stride = stride[m];  // the terms of every unit, as spaced in each
      pooled.points.push_back(p);
    }
    return pooled;
  };
  GmwmOptions fit_options = options.fit;
  fit_options.stop = StopRule::kNone;  // every unit's curve is already cut

  // The lot model describes the units that belong to the lot: a unit the
  // others' spread does not cover (a planted failure, a damaged part) would
  // make the pooled curve a mixture no single model of the family follows,
  // and the lot model "inadequate" for the lot's own process. It is fitted
  // to the consistent units, the others named, unless fewer than half (or
  // fewer than 2) are consistent: then the lot has no majority to model and
  // every unit is pooled.
  std::vector<int> all(k), members;
  for (int u = 0; u < k; ++u) {
    all[u] = u;
    if (lot.consistency[u].consistent) members.push_back(u);
  }
  if (static_cast<int>(members.size()) * 2 < k || members.size() < 2) members = all;
  const Curve pooled = pooled_of(members);
  auto fit = FitCompositeModel(pooled, fit_options);
  if (!fit.ok()) return fit.status();
  lot.units = static_cast<int>(members.size());
  lot.fit = *fit;
  for (int u = 0; u < k; ++u) {
    if (std::find(members.begin(), members.end(), u) == members.end()) {
      lot.left_out.push_back(units[u].unit);
    }
  }
  if (!lot.left_out.empty()) {
    GmwmOptions quick = fit_options;  // the model, J and p only
    quick.bootstrap_replicates = 0;
    quick.absent_term_bounds = false;
    if (auto every = FitCompositeModel(pooled_of(all), quick); every.ok()) {
      lot.all_units_model = every->model.Name();
      lot.all_units_objective = every->objective;
      lot.all_units_p_value = every->p_value;
    }
  }
  const double km = static_cast<double>(members.size());
  for (size_t j = 0; j < ms.size(); ++j) {
    double mean = 0, ss = 0;
    for (int u : members) mean += log_avar[j][u] / km;
    for (int u : members) ss += (log_avar[j][u] - mean) * (log_avar[j][u] - mean);
    LotPoint lp;
    lp.m = ms[j];
    lp.tau_s = pooled.points[j].tau_s;
    lp.mean_dev = pooled.points[j].dev;
    lp.model_dev = lot.fit.ModelDeviation(lp.tau_s);
    lp.spread_factor = km > 1 ? std::exp(0.5 * std::sqrt(ss / (km - 1))) : kNaN;
    lot.points.push_back(lp);
  }
  return lot;
}

}  // namespace imuqual::allan
