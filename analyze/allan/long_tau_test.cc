#include "analyze/allan/long_tau.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

// Two double evaluations of the same sums in a different order, or against a
// long-double brute force: a few hundred ulps of accumulated rounding, plus
// the fast Theo1 form's cancellation between its all-window sum and its edge
// windows (bounded by (N + m)/(N - m), under 1e3 at the factors tested).
constexpr double kSameSumRelTol = 1e-11;

double RelativeError(double value, double expected) {
  return std::fabs(value - expected) / std::fabs(expected);
}

std::vector<double> White(int64_t count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<double> out(static_cast<size_t>(count));
  for (double& v : out) v = normal(rng);
  return out;
}

std::vector<double> Integrate(const std::vector<double>& in) {
  std::vector<double> out(in.size());
  double sum = 0;
  for (size_t k = 0; k < in.size(); ++k) out[k] = sum += in[k];
  return out;
}

// Flicker (1/f) noise by fractional integration of white noise (Kasdin &
// Walter 1992): v_t = sum_k h_k w_{t-k}, h_0 = 1, h_k = h_{k-1} (k - 1/2)/k.
std::vector<double> Flicker(int64_t count, uint64_t seed) {
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

// A phase record of n_rate rate samples with rate PSD S_y(f) ~ f^alpha:
// 2 white PM, 0 white FM, -1 flicker FM, -2 random-walk FM. `offset` is added
// to the phase (a large level shows whether any step loses digits to it).
PhaseRecord PowerLawPhase(int alpha, int64_t n_rate, uint64_t seed, double tau0_s = 1.0,
                          double offset = 0.0) {
  std::vector<double> x;
  switch (alpha) {
    case 2:
      x = White(n_rate + 1, seed);
      break;
    case 0:
      x = Integrate(White(n_rate + 1, seed));
      break;
    case -1:
      x = Integrate(Flicker(n_rate + 1, seed));
      break;
    default:
      x = Integrate(Integrate(White(n_rate + 1, seed)));
      break;
  }
  for (double& v : x) v = v * tau0_s + offset;
  return PhaseFromPhase(x, tau0_s);
}

// ---------------------------------------------------------------------------
// Brute force, in long double, written straight from the definitions.

// allantools' loop: sum_{i<N-m} sum_{d<m/2} (x_i - x_{i-d+m/2} + x_{i+m} - x_{i+d+m/2})^2 / (m/2 -
// d).
long double Theo1SumBrute(const std::vector<double>& x, int64_t m) {
  const int64_t n = static_cast<int64_t>(x.size());
  const int64_t h = m / 2;
  long double total = 0;
  for (int64_t i = 0; i < n - m; ++i) {
    for (int64_t d = 0; d < h; ++d) {
      const long double v = static_cast<long double>(x[i]) - x[i - d + h] + x[i + m] - x[i + d + h];
      total += v * v / static_cast<long double>(h - d);
    }
  }
  return total;
}

// The run's 9m-point reflected extension, then 6m second differences of
// m-point sums, each sum formed afresh.
long double TotalRunBrute(const double* v, int64_t m, bool centre_trend) {
  const int64_t length = 3 * m;
  const int64_t half = length / 2;
  long double sum1 = 0, sum2 = 0;
  for (int64_t t = 0; t < half; ++t) sum1 += v[t];
  for (int64_t t = length - half; t < length; ++t) sum2 += v[t];
  const long double distance = length % 2 == 1 ? half + 1 : 0.5L * length;
  const long double slope = (sum2 / half - sum1 / half) / distance;
  const long double origin = centre_trend ? half : 0;
  std::vector<long double> run(static_cast<size_t>(length));
  for (int64_t t = 0; t < length; ++t) run[t] = v[t] - slope * (t - origin);
  std::vector<long double> ext;
  for (int64_t t = length - 1; t >= 0; --t) ext.push_back(run[t]);
  for (int64_t t = 0; t < length; ++t) ext.push_back(run[t]);
  for (int64_t t = length - 1; t >= 0; --t) ext.push_back(run[t]);
  long double total = 0;
  for (int64_t j = 0; j < 6 * m; ++j) {
    long double s[3] = {0, 0, 0};
    for (int b = 0; b < 3; ++b) {
      for (int64_t t = 0; t < m; ++t) s[b] += ext[j + b * m + t];
    }
    const long double d = (s[0] - 2 * s[1] + s[2]) / m;
    total += d * d;
  }
  return total / (6 * m);
}

double MtotBrute(const std::vector<double>& x, int64_t m, double tau0) {
  const int64_t runs = static_cast<int64_t>(x.size()) - 3 * m + 1;
  long double total = 0;
  for (int64_t i = 0; i < runs; ++i) total += TotalRunBrute(x.data() + i, m, false);
  const long double tau = m * static_cast<long double>(tau0);
  return static_cast<double>(std::sqrt(total / (2 * tau * tau * runs)));
}

double HtotBrute(const std::vector<double>& x, int64_t m, double tau0) {
  std::vector<double> y;
  for (size_t t = 0; t + 1 < x.size(); ++t) y.push_back((x[t + 1] - x[t]) / tau0);
  const int64_t runs = static_cast<int64_t>(y.size()) - 3 * m + 1;
  long double total = 0;
  for (int64_t i = 0; i < runs; ++i) total += TotalRunBrute(y.data() + i, m, true);
  return static_cast<double>(std::sqrt(total / (6 * runs)));
}

// ---------------------------------------------------------------------------
// Theo1: direct, fast and brute force agree.

TEST(Theo1Sums, DirectAndFastMatchBruteForceOnEveryNoiseType) {
  // Odd and even record lengths, factors from 2 to N-1, and a phase level of
  // 1e6 (a million times the typical increment) on top.
  for (int alpha : {2, 0, -1, -2}) {
    for (int64_t n_rate : {600, 1001}) {
      const PhaseRecord phase = PowerLawPhase(alpha, n_rate, 100 + alpha, 1.0, 1e6);
      const int64_t n = phase.size();
      std::vector<int64_t> m_list;
      for (int64_t m : {2, 4, 10, 64, 128, 300, 500}) m_list.push_back(m);
      m_list.push_back(n % 2 == 1 ? n - 1 : n - 2);
      const std::vector<double> direct = Theo1Sums(phase.x, m_list, Theo1Method::kDirect);
      const std::vector<double> fast = Theo1Sums(phase.x, m_list, Theo1Method::kFast);
      for (size_t q = 0; q < m_list.size(); ++q) {
        SCOPED_TRACE("alpha " + std::to_string(alpha) + " N " + std::to_string(n) + " m " +
                     std::to_string(m_list[q]));
        const double brute = static_cast<double>(Theo1SumBrute(phase.x, m_list[q]));
        EXPECT_LE(RelativeError(direct[q], brute), kSameSumRelTol) << direct[q] << " " << brute;
        EXPECT_LE(RelativeError(fast[q], brute), kSameSumRelTol) << fast[q] << " " << brute;
      }
    }
  }
}

TEST(Theo1Sums, OddAndOutOfRangeFactorsHaveNoSum) {
  const PhaseRecord phase = PowerLawPhase(0, 100, 7);
  const std::vector<int64_t> m_list = {0, 1, 3, 100, 101, 102, -2};
  for (Theo1Method method : {Theo1Method::kDirect, Theo1Method::kFast, Theo1Method::kAuto}) {
    const std::vector<double> sums = Theo1Sums(phase.x, m_list, method);
    ASSERT_EQ(sums.size(), m_list.size());
    EXPECT_TRUE(std::isnan(sums[0]) && std::isnan(sums[1]) && std::isnan(sums[2]));
    EXPECT_TRUE(std::isfinite(sums[3]));  // m = N - 1
    EXPECT_TRUE(std::isnan(sums[4]) && std::isnan(sums[5]) && std::isnan(sums[6]));
  }
}

TEST(TheoBrRatio, BatchFormMatchesDirectSums) {
  for (int alpha : {2, 0, -2}) {
    const PhaseRecord phase = PowerLawPhase(alpha, 2999, 300 + alpha, 1.0, 1e5);
    const std::optional<double> direct = TheoBrRatio(phase.x, Theo1Method::kDirect);
    const std::optional<double> fast = TheoBrRatio(phase.x, Theo1Method::kFast);
    ASSERT_TRUE(direct && fast);
    EXPECT_LE(RelativeError(*fast, *direct), kSameSumRelTol) << alpha;
  }
}

// ---------------------------------------------------------------------------
// MTOT, TTOT, HTOT against brute force.

TEST(TotalEstimators, MatchBruteForce) {
  for (int alpha : {2, 0, -2}) {
    const PhaseRecord phase = PowerLawPhase(alpha, 400, 40 + alpha, 0.5, 1e4);
    for (int64_t m : {1, 2, 3, 5, 8, 33, 100, 133}) {
      SCOPED_TRACE("alpha " + std::to_string(alpha) + " m " + std::to_string(m));
      const CurvePoint mtot = ComputeDeviationAt(phase, Deviation::kMtotdev, m);
      const CurvePoint ttot = ComputeDeviationAt(phase, Deviation::kTtotdev, m);
      const double expected = MtotBrute(phase.x, m, 0.5);
      EXPECT_EQ(mtot.n, phase.size() - 3 * m + 1);
      EXPECT_EQ(ttot.n, mtot.n);
      EXPECT_LE(RelativeError(mtot.dev, expected), kSameSumRelTol);
      EXPECT_LE(RelativeError(ttot.dev, expected * m * 0.5 / std::sqrt(3.0)), kSameSumRelTol);
      const CurvePoint htot = ComputeDeviationAt(phase, Deviation::kHtotdev, m);
      EXPECT_EQ(htot.n, phase.size() - 3 * m);
      if (m == 1) {
        // HTOT at m = 1 is OHDEV.
        EXPECT_EQ(htot.dev, ComputeDeviationAt(phase, Deviation::kOhdev, 1).dev);
      } else {
        EXPECT_LE(RelativeError(htot.dev, HtotBrute(phase.x, m, 0.5)), kSameSumRelTol);
      }
    }
  }
}

}  // namespace
}  // namespace imuqual::allan
