#include "analyze/judge/control_chart.h"

#include <algorithm>
#include <cmath>

namespace imuqual::judge {
namespace {

// Where a point lies in units of its own sigma of the mean, signed.
double Zone(const ControlChart& c, const ChartPoint& p) {
  const double s = c.sigma / std::sqrt(static_cast<double>(p.n));
  return s > 0 ? (p.mean - c.centre) / s : 0;
}

// Whether at least `need` of the last `window` points up to i lie beyond
// `k` sigma on one side (both sides tried).
bool BeyondOnOneSide(const std::vector<double>& z, size_t i, size_t window, size_t need,
                     double k) {
  if (i + 1 < window) return false;
  for (int side : {1, -1}) {
    size_t count = 0;
    for (size_t j = i + 1 - window; j <= i; ++j) count += side * z[j] > k;
    // The rule completes at i only if point i is one of them.
    if (count >= need && side * z[i] > k) return true;
  }
  return false;
}

}  // namespace

double C4(int n) {
  if (n < 2) return std::numeric_limits<double>::quiet_NaN();
  const double m = static_cast<double>(n);
  return std::sqrt(2 / (m - 1)) * std::exp(std::lgamma(m / 2) - std::lgamma((m - 1) / 2));
}

Result<ControlChart> MakeControlChart(const std::vector<Subgroup>& subgroups, int baseline) {
  ControlChart c;
  const size_t reference =
      baseline > 0 ? std::min(subgroups.size(), static_cast<size_t>(baseline)) : subgroups.size();
  c.baseline = static_cast<int>(reference);
  double sum = 0, ss = 0, dof = 0;
  int spread_groups = 0, reference_values = 0;
  for (const Subgroup& g : subgroups) {
    const bool in_reference = c.points.size() < reference;
    if (g.values.empty()) return Status::InvalidArgument("subgroup " + g.label + " has no value");
    ChartPoint p;
    p.label = g.label;
    p.n = static_cast<int>(g.values.size());
    double s = 0;
    for (double v : g.values) {
      if (!std::isfinite(v)) return Status::InvalidArgument("subgroup " + g.label + ": a value that is not a number");
      s += v;
    }
    p.mean = s / p.n;
    c.values += p.n;
    if (in_reference) {
      sum += s;
      reference_values += p.n;
    }
    if (p.n >= 2) {
      double dev = 0;
      for (double v : g.values) dev += (v - p.mean) * (v - p.mean);
      p.sd = std::sqrt(dev / (p.n - 1));
      if (in_reference) {
        ss += dev;
        dof += p.n - 1;
        ++spread_groups;
      }
    }
    c.points.push_back(std::move(p));
  }
  if (spread_groups < 2) {
    return Status::InvalidArgument(
        "a control chart needs at least 2 subgroups of 2 or more values" +
        std::string(reference < subgroups.size() ? " in its baseline" : "") + " (" +
        std::to_string(spread_groups) + " here): no within-subgroup spread to set limits from");
  }
  c.centre = sum / reference_values;
  c.sigma = std::sqrt(ss / dof) / C4(static_cast<int>(dof) + 1);
  std::vector<double> z;
  for (ChartPoint& p : c.points) {
    const double se = c.sigma / std::sqrt(static_cast<double>(p.n));
    p.mean_lcl = c.centre - 3 * se;
    p.mean_ucl = c.centre + 3 * se;
    if (p.n >= 2) {
      const double c4 = C4(p.n);
      p.sd_centre = c4 * c.sigma;
      p.sd_lcl = std::max(0.0, c.sigma * (c4 - 3 * std::sqrt(1 - c4 * c4)));
      p.sd_ucl = c.sigma * (c4 + 3 * std::sqrt(1 - c4 * c4));
      if (p.sd > p.sd_ucl || p.sd < p.sd_lcl) p.sd_rules.push_back("beyond 3 sigma");
    }
    z.push_back(Zone(c, p));
  }
  for (size_t i = 0; i < c.points.size(); ++i) {
    ChartPoint& p = c.points[i];
    if (std::abs(z[i]) > 3) p.mean_rules.push_back("beyond 3 sigma");
    if (BeyondOnOneSide(z, i, 3, 2, 2)) p.mean_rules.push_back("2 of 3 beyond 2 sigma");
    if (BeyondOnOneSide(z, i, 5, 4, 1)) p.mean_rules.push_back("4 of 5 beyond 1 sigma");
    if (i + 1 >= 8) {
      bool above = true, below = true;
      for (size_t j = i + 1 - 8; j <= i; ++j) {
        above = above && z[j] > 0;
        below = below && z[j] < 0;
      }
      if (above || below) p.mean_rules.push_back("8 on one side");
    }
    if (i + 1 >= 6) {
      bool rising = true, falling = true;
      for (size_t j = i + 1 - 5; j <= i; ++j) {
        rising = rising && c.points[j].mean > c.points[j - 1].mean;
        falling = falling && c.points[j].mean < c.points[j - 1].mean;
      }
      if (rising || falling) p.mean_rules.push_back("6 trending");
    }
    c.flagged += !p.mean_rules.empty() || !p.sd_rules.empty();
  }
  return c;
}

}  // namespace imuqual::judge
