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
  std::map<int64_t, int64_t> sum_n, stride;
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
      sum_n[p.m] += p.n;
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

  // The pooled curve: K records of one process in the fit's eyes, so each
  // point carries the terms (and the edf) of all of them.
  Curve pooled;
  pooled.deviation = first.deviation;
  pooled.tau0_s = first.tau0_s;
  pooled.n_phase = 0;
  for (const UnitCurve& u : units) pooled.n_phase += u.curve.n_phase;
  std::vector<std::vector<double>> log_avar;  // [point][unit]
  for (int64_t m : ms) {
    const std::vector<double>& v = avar[m];
    double mean = 0;
    for (double x : v) mean += x / k;
    CurvePoint p;
    p.m = m;
    p.tau_s = static_cast<double>(m) * first.tau0_s;
    p.dev = std::sqrt(mean);
    p.n = sum_n[m];
    p.stride = stride[m];  // the terms of every unit, as spaced in each
    pooled.points.push_back(p);
    std::vector<double> logs;
    for (double x : v) logs.push_back(std::log(x));
    log_avar.push_back(logs);
  }

  GmwmOptions fit_options = options.fit;
  fit_options.stop = StopRule::kNone;  // every unit's curve is already cut
  auto fit = FitCompositeModel(pooled, fit_options);
  if (!fit.ok()) return fit.status();

  LotModel lot;
  lot.units = k;
  lot.fit = *fit;
  for (size_t j = 0; j < ms.size(); ++j) {
    double mean = 0, ss = 0;
    for (double x : log_avar[j]) mean += x / k;
    for (double x : log_avar[j]) ss += (x - mean) * (x - mean);
    LotPoint lp;
    lp.m = ms[j];
    lp.tau_s = pooled.points[j].tau_s;
    lp.mean_dev = pooled.points[j].dev;
    lp.model_dev = lot.fit.ModelDeviation(lp.tau_s);
    lp.spread_factor = std::exp(0.5 * std::sqrt(ss / (k - 1)));
    lot.points.push_back(lp);
  }

  // Each unit against the others' prediction interval, tau by tau.
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
        c.worst_tau_s = lot.points[j].tau_s;
        c.worst_factor = std::exp(0.5 * (log_avar[j][u] - mean));
      }
    }
    const double p_one = 2 * boost::math::cdf(boost::math::complement(t_dist, std::fabs(worst_t)));
    c.p_value = std::min(1.0, p_one * static_cast<double>(ms.size()));
    c.consistent = !(c.p_value < options.consistency_level);
    lot.consistency.push_back(c);
  }
  return lot;
}

}  // namespace imuqual::allan
