// Control charts of a judged measurement over a production's history: an
// X-bar chart and an S chart of subgroups (a lot, or the units tested in a
// week or a month), with limits from the pooled within-subgroup spread and
// the usual run rules flagged. Pure.
//
// sigma = s_pooled / c4(N - k + 1), s_pooled^2 = sum (n_i - 1) s_i^2 /
// sum (n_i - 1) over subgroups of >= 2 values (N values, k such subgroups);
// the centre line is the grand mean of all values. Per subgroup i:
//   X-bar: centre +- 3 sigma / sqrt(n_i)
//   S:     c4(n_i) sigma, limits sigma (c4(n_i) +- 3 sqrt(1 - c4(n_i)^2)),
//          the lower one at least 0
// Run rules on the X-bar chart (Western Electric, zones in units of the
// subgroup's own sigma / sqrt(n_i)): "beyond 3 sigma" (one point), "2 of 3
// beyond 2 sigma" (same side), "4 of 5 beyond 1 sigma" (same side), "8 on
// one side" (of the centre), and Nelson's "6 trending" (steadily rising or
// falling); on the S chart "beyond 3 sigma". A rule is flagged at the
// subgroup that completes it.
#ifndef IMUQUAL_ANALYZE_JUDGE_CONTROL_CHART_H_
#define IMUQUAL_ANALYZE_JUDGE_CONTROL_CHART_H_

#include <limits>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::judge {

struct Subgroup {
  std::string label;           // the lot, or the week / month
  std::vector<double> values;  // finite
};

struct ChartPoint {
  std::string label;
  int n = 0;
  double mean = std::numeric_limits<double>::quiet_NaN();
  double sd = std::numeric_limits<double>::quiet_NaN();  // NaN for n < 2
  double mean_lcl = 0, mean_ucl = 0;                      // X-bar limits
  double sd_centre = std::numeric_limits<double>::quiet_NaN(), sd_lcl = 0, sd_ucl = 0;
  std::vector<std::string> mean_rules, sd_rules;  // rules this subgroup completes
};

struct ControlChart {
  int baseline = 0;  // subgroups the limits come from (all of them when 0 was asked)
  double centre = std::numeric_limits<double>::quiet_NaN();  // grand mean
  double sigma = std::numeric_limits<double>::quiet_NaN();   // within-subgroup sd
  int values = 0;
  std::vector<ChartPoint> points;  // in the subgroups' order
  int flagged = 0;                 // points with any rule
};

// c4(n): E[s] / sigma for n normal values (n >= 2).
double C4(int n);

// `baseline` > 0: the centre line and sigma from the first `baseline`
// subgroups only (a reference period: later subgroups are judged against
// it); 0: from every subgroup (a retrospective chart, whose limits a shift
// inside it also moves). InvalidArgument when fewer than 2 of those
// subgroups have >= 2 values (no spread to set limits from), or a subgroup
// is empty.
Result<ControlChart> MakeControlChart(const std::vector<Subgroup>& subgroups, int baseline = 0);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_CONTROL_CHART_H_
