// Test-only generators of power-law noise for the statistical tests and
// benchmarks of the estimators (noise identification, Theo1's edf): white
// Gaussian samples, their running sum, and flicker (1/f) noise.
// Header-only; not part of the imuqual_allan library.
#ifndef IMUQUAL_ANALYZE_ALLAN_POWER_LAW_TESTING_H_
#define IMUQUAL_ANALYZE_ALLAN_POWER_LAW_TESTING_H_

#include <cstdint>
#include <random>
#include <vector>

namespace imuqual::allan::testing {

inline std::vector<double> White(int64_t count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<double> out(static_cast<size_t>(count));
  for (double& v : out) v = normal(rng);
  return out;
}

inline std::vector<double> Integrate(const std::vector<double>& in) {
  std::vector<double> out(in.size());
  double sum = 0;
  for (size_t k = 0; k < in.size(); ++k) out[k] = sum += in[k];
  return out;
}

// Flicker (1/f) noise by fractional integration of white noise (Kasdin &
// Walter 1992): v_t = sum_k h_k w_{t-k}, h_0 = 1, h_k = h_{k-1} (k - 1/2)/k.
// O(count^2).
inline std::vector<double> Flicker(int64_t count, uint64_t seed) {
  const std::vector<double> w = White(count, seed);
  std::vector<double> h(static_cast<size_t>(count));
  h[0] = 1;
  for (int64_t k = 1; k < count; ++k) h[k] = h[k - 1] * (static_cast<double>(k) - 0.5) / k;
  std::vector<double> out(static_cast<size_t>(count), 0.0);
  for (int64_t t = 0; t < count; ++t) {
    double sum = 0;
    for (int64_t k = 0; k <= t; ++k) sum += h[k] * w[t - k];
    out[t] = sum;
  }
  return out;
}

}  // namespace imuqual::allan::testing

#endif  // IMUQUAL_ANALYZE_ALLAN_POWER_LAW_TESTING_H_
