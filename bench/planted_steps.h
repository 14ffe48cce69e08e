// What the benchmarks that plant level steps in simulated records
// (stationarity_bench, segment_bench) size them by.
#ifndef IMUQUAL_BENCH_PLANTED_STEPS_H_
#define IMUQUAL_BENCH_PLANTED_STEPS_H_

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "analyze/allan/stationarity.h"

namespace imuqual::bench {

// The standard deviation of a record's bin means over bins of `bin_s`
// (whole bins only): a planted step is a multiple of it.
inline double BinMeanSd(std::span<const double> y, double tau0_s, double bin_s) {
  const int64_t per = std::llround(bin_s / tau0_s);
  const std::vector<double> means =
      allan::BinMeans(y, per, static_cast<int>(static_cast<int64_t>(y.size()) / per));
  double m = 0;
  for (double v : means) m += v;
  m /= static_cast<double>(means.size());
  double v2 = 0;
  for (double v : means) v2 += (v - m) * (v - m);
  return std::sqrt(v2 / static_cast<double>(means.size() - 1));
}

}  // namespace imuqual::bench

#endif  // IMUQUAL_BENCH_PLANTED_STEPS_H_
