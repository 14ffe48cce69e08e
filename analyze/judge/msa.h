// Measurement system analysis of a station fleet: do the stations agree?
// Golden units (parts) soaked on every station (appraisers), each several
// times (trials), one judged measurement at a time; the AIAG MSA manual's
// ANOVA method (crossed design, 4th ed., chapter III-B): the two-way
// analysis of variance with interaction gives the variance components
//   repeatability  EV^2  = MS_error                       (within a station)
//   reproducibility AV^2 = (MS_station - MS_interaction) / (parts trials)
//   interaction   INT^2  = (MS_interaction - MS_error) / trials
//   part variation PV^2  = (MS_part - MS_interaction) / (stations trials)
// (negative estimates taken as 0), GRR^2 = EV^2 + AV^2 + INT^2, TV^2 = GRR^2
// + PV^2; %GRR against the total variation and against the tolerance
// (100 * 6 GRR / (USL - LSL); with one limit, 100 * 3 GRR / |limit - mean|),
// and the number of distinct categories ndc = floor(1.41 PV / GRR). As the
// manual says, an interaction whose F-test has p > 0.25 is pooled into the
// error term (MS_error then the pooled mean square).
//
// Beyond the manual: each station's offset, its mean over the golden units
// less the mean of all stations, with a 95 % interval (stations fixed,
// units random: the offset's variance is (1 - 1/stations) MS_interaction /
// (parts trials), on the interaction's degrees of freedom, or the pooled
// error's when pooled), so a station reading high is named with how sure
// that is. Pure.
#ifndef IMUQUAL_ANALYZE_JUDGE_MSA_H_
#define IMUQUAL_ANALYZE_JUDGE_MSA_H_

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::judge {

inline constexpr double kMsaNaN = std::numeric_limits<double>::quiet_NaN();

// values[part][station][trial]: a balanced study (every cell the same
// number of trials, >= 2; >= 2 parts, >= 2 stations).
struct MsaStudy {
  std::vector<std::string> parts, stations;
  std::vector<std::vector<std::vector<double>>> values;
  std::optional<double> low, high;  // the measurement's limits (tolerance)
};

struct StationOffset {
  std::string station;
  double offset = kMsaNaN;  // station mean - mean of all stations
  double low = kMsaNaN, high = kMsaNaN;  // its 95 % interval
  bool differs = false;     // the interval excludes 0
};

struct MsaResult {
  int parts = 0, stations = 0, trials = 0;
  double mean = kMsaNaN;
  // The ANOVA table: degrees of freedom, mean squares, F and p of parts,
  // stations and interaction against their error terms.
  double df_part = 0, df_station = 0, df_interaction = 0, df_error = 0;
  double ms_part = kMsaNaN, ms_station = kMsaNaN, ms_interaction = kMsaNaN, ms_error = kMsaNaN;
  double p_interaction = kMsaNaN;
  bool interaction_pooled = false;  // p_interaction > 0.25: pooled into the error
  // Standard deviations of the components.
  double ev = kMsaNaN, av = kMsaNaN, interaction = kMsaNaN, grr = kMsaNaN, pv = kMsaNaN,
         tv = kMsaNaN;
  double percent_grr_tv = kMsaNaN;         // 100 GRR / TV
  double percent_grr_tolerance = kMsaNaN;  // see above; NaN without limits
  std::string tolerance_basis;             // "USL - LSL", "USL - mean", "mean - LSL" or ""
  int ndc = 0;
  // AIAG's reading of %GRR (tolerance if known, else total variation):
  // "acceptable" (< 10 %), "may be acceptable" (10-30 %), "unacceptable".
  std::string verdict;
  std::vector<StationOffset> offsets;
};

// InvalidArgument naming what is unbalanced or too small.
Result<MsaResult> AnalyzeMsa(const MsaStudy& study);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_MSA_H_
