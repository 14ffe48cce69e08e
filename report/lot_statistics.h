// Lot statistics: per axis and measurement, the summary (n, mean, sd, min,
// max, yield, capability against the plan's limits) of a lot's latest runs,
// and the side-by-side comparison of two lots with significance tests.
#ifndef IMUQUAL_REPORT_LOT_STATISTICS_H_
#define IMUQUAL_REPORT_LOT_STATISTICS_H_

#include <optional>
#include <string>
#include <vector>

#include "analyze/judge/statistics.h"
#include "store/query.h"

namespace imuqual::report {

struct MeasurementStats {
  std::string axis;  // "" for run-level measurements
  std::string kind;  // "gyro", "accel" or ""
  std::string name;
  std::string unit;
  std::optional<double> low, high;  // the plan's limits (as recorded with the values)
  judge::Summary summary;
};

// One row per (axis, measurement) present in `rows`, in the rows' order of
// first appearance.
std::vector<MeasurementStats> ComputeLotStatistics(const std::vector<store::MeasurementRow>& rows);

struct Comparison {
  MeasurementStats a, b;
  judge::TestResult mean, spread, yield;  // Welch t, variance F, Fisher exact
  double mean_change = std::numeric_limits<double>::quiet_NaN();  // (mean_b - mean_a) / |mean_a|
  bool mean_significant = false, spread_significant = false, yield_significant = false;
};

// Rows present in both lots; significance by Holm's procedure over every
// p-value of the comparison at family-wise level `alpha`.
std::vector<Comparison> CompareLots(const std::vector<MeasurementStats>& a,
                                    const std::vector<MeasurementStats>& b, double alpha);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_LOT_STATISTICS_H_
