#include "report/lot_statistics.h"

#include <cmath>
#include <map>

#include "analyze/judge/measurements.h"
#include "store/outcome.h"

namespace imuqual::report {

std::vector<MeasurementStats> ComputeLotStatistics(const std::vector<store::MeasurementRow>& rows) {
  struct Group {
    MeasurementStats stats;
    std::vector<double> values;
    std::vector<pb::Outcome> outcomes;
  };
  std::vector<Group> groups;
  std::map<std::pair<std::string, std::string>, size_t> index;
  for (const store::MeasurementRow& r : rows) {
    // The parameters of each unit's own noise model: units with different
    // models have no common "gauss_markov_1" to average.
    if (r.name.starts_with(judge::kModelParameterPrefix)) continue;
    // Each unit's own stationarity events (event_1 of one unit is not
    // event_1 of another).
    if (r.name.starts_with(judge::kEventPrefix)) continue;
    auto [it, inserted] = index.try_emplace({r.axis, r.name}, groups.size());
    if (inserted) {
      Group g;
      g.stats.axis = r.axis;
      g.stats.kind = r.kind;
      g.stats.name = r.name;
      g.stats.unit = r.value_unit;
      groups.push_back(std::move(g));
    }
    Group& g = groups[it->second];
    if (!g.stats.low && r.low) g.stats.low = r.low;
    if (!g.stats.high && r.high) g.stats.high = r.high;
    g.values.push_back(r.value);
    // A yield counts PASS and MARGINAL against PASS, MARGINAL and FAIL: an
    // INCONCLUSIVE value (a retest candidate) is neither (as lot_statistics).
    g.outcomes.push_back(store::CountsInYield(r.outcome) ? r.outcome : pb::OUTCOME_UNSET);
  }
  std::vector<MeasurementStats> out;
  for (Group& g : groups) {
    g.stats.summary = judge::Summarize(g.values, g.outcomes, g.stats.low, g.stats.high);
    out.push_back(std::move(g.stats));
  }
  return out;
}

std::vector<Comparison> CompareLots(const std::vector<MeasurementStats>& a,
                                    const std::vector<MeasurementStats>& b, double alpha) {
  std::map<std::pair<std::string, std::string>, const MeasurementStats*> in_b;
  for (const MeasurementStats& s : b) in_b[{s.axis, s.name}] = &s;
  std::vector<Comparison> out;
  for (const MeasurementStats& s : a) {
    auto it = in_b.find({s.axis, s.name});
    if (it == in_b.end()) continue;
    Comparison c;
    c.a = s;
    c.b = *it->second;
    c.mean = judge::WelchTTest(c.a.summary, c.b.summary);
    c.spread = judge::VarianceFTest(c.a.summary, c.b.summary);
    c.yield = judge::FisherExactTest(c.a.summary.passed, c.a.summary.judged, c.b.summary.passed,
                                     c.b.summary.judged);
    if (std::isfinite(c.a.summary.mean) && c.a.summary.mean != 0) {
      c.mean_change = (c.b.summary.mean - c.a.summary.mean) / std::abs(c.a.summary.mean);
    }
    out.push_back(std::move(c));
  }
  // Holm over the whole family of tests.
  std::vector<double> p;
  for (const Comparison& c : out) {
    p.push_back(c.mean.p_value);
    p.push_back(c.spread.p_value);
    p.push_back(c.yield.p_value);
  }
  const std::vector<bool> sig = judge::HolmSignificant(p, alpha);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].mean_significant = sig[3 * i];
    out[i].spread_significant = sig[3 * i + 1];
    out[i].yield_significant = sig[3 * i + 2];
  }
  return out;
}

}  // namespace imuqual::report
