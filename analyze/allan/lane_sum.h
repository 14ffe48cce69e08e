// Internal to the estimators (estimators.cc, long_tau.cc): sums of squared
// terms are accumulated kChunk terms at a time into kLanes independent
// accumulators (the compiler maps the lanes onto SIMD registers), and each
// chunk's lanes are folded in a fixed order, so that rounding grows with the
// number of chunks rather than of terms and every build sums alike.
#ifndef IMUQUAL_ANALYZE_ALLAN_LANE_SUM_H_
#define IMUQUAL_ANALYZE_ALLAN_LANE_SUM_H_

#include <cstdint>

namespace imuqual::allan::lanes {

constexpr int64_t kChunk = 2048;
constexpr int kLanes = 8;

// The lanes folded pairwise in a fixed order.
inline double SumLanes(const double (&acc)[kLanes]) {
  double a = 0.0;
  double b = 0.0;
  for (int k = 0; k < kLanes; k += 2) {
    a += acc[k];
    b += acc[k + 1];
  }
  return a + b;
}

}  // namespace imuqual::allan::lanes

#endif  // IMUQUAL_ANALYZE_ALLAN_LANE_SUM_H_
