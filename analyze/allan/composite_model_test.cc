#include "analyze/allan/composite_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/curve.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

// The brute-force references are summed in long double (64-bit mantissa on
// x86-64, 2^11 times finer than double).
using Real = long double;
constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr Real kPiL = std::numbers::pi_v<Real>;
constexpr double kPi = std::numbers::pi;

// The closed forms are a handful of double operations without cancellation
// (the Gauss-Markov form by construction, series for small arguments): a few
// ulps. 1e-12 leaves three orders of margin and still catches any wrong term.
constexpr double kClosedFormRelTol = 1e-12;
// A sinusoid's closed form takes sin(pi f' m) of an argument rounded in double
// (two products, ~2 eps theta): the value sin^4(theta) then moves by
// 4 |sin^3 cos| x 2 eps theta. This factor is that 8 with a 2x margin.
constexpr double kSinusoidArgumentFactor = 16.0;
// The brute force's only errors are the roundings of each weighted term (the
// sum is compensated, the weights are exact integers): at most ~2 long-double
// ulps of |gamma_k| <= A^2 each, with weights whose magnitudes total 2 m^2, so
// after the division by m^2 at most ~4 ulps of A^2; this floor is twice that.
// It matters only where the exact AVAR is ~0 (f' = 1/2 at even m).
constexpr double kBruteForceAbsTol = 8 * std::numeric_limits<Real>::epsilon();

// Neumaier's compensated sum: the error is that of the final rounding plus
// O(n eps^2), whatever the cancellation between the terms.
class CompensatedSum {
 public:
  void Add(Real v) {
    const Real t = sum_ + v;
    compensation_ += std::fabs(sum_) >= std::fabs(v) ? (sum_ - t) + v : (v - t) + sum_;
    sum_ = t;
  }
  Real value() const { return sum_ + compensation_; }

 private:
  Real sum_ = 0, compensation_ = 0;
};

// AVAR(m) = Var(ybar_A) - Cov(ybar_A, ybar_B) of two adjacent blocks of m
// samples, from the autocovariance gamma_k:
//   (1/m^2) [m g_0 + 2 sum_{k=1}^{m-1} (m-k) g_k] - (1/m^2) sum_{k=1}^{2m-1} min(k, 2m-k) g_k,
// with the integer weights exact, one compensated sum and one division at the
// end. The weights sum to zero (m + m(m-1) - m^2), so adding a constant to
// every gamma_k leaves the result unchanged: callers pass gamma_k - gamma_0
// where gamma_0 would dominate the sum.
Real BruteForceAvar(const std::function<Real(int64_t)>& gamma, int64_t m) {
  CompensatedSum sum;  // Var(ybar_A) - Cov(ybar_A, ybar_B), times m^2
  sum.Add(m * gamma(0));
  for (int64_t k = 1; k < m; ++k) sum.Add(2 * (m - k) * gamma(k));
  for (int64_t k = 1; k < 2 * m; ++k) sum.Add(-std::min(k, 2 * m - k) * gamma(k));
  return sum.value() / (static_cast<Real>(m) * m);
}

// sin(pi f k) for a double f and 0 <= k < 2^11: f k is exact in a 64-bit
// mantissa, so the reduction to (-1/2, 1/2] loses nothing.
Real SinPi(double f, int64_t k) {
  const Real fk = static_cast<Real>(f) * k;
  return std::sin(kPiL * (fk - std::round(fk)));
}

constexpr int64_t kAveragingFactors[] = {1, 2, 3, 4, 7, 16, 100, 1000};
constexpr double kTau0 = 0.01;  // 100 Hz

ModelTerm Term(TermKind kind, double scale, double correlation_time_s = 0,
               double frequency_hz = 0) {
  ModelTerm t;
  t.kind = kind;
  t.scale = scale;
  t.correlation_time_s = correlation_time_s;
  t.frequency_hz = frequency_hz;
  return t;
}

double RelativeError(double value, Real truth) {
  return static_cast<double>(std::fabs((value - truth) / truth));
}

// ---------------------------------------------------------------------------
// Closed forms against the brute-force sum over the autocovariance.

TEST(CompositeModelTest, BruteForceWeightsSumToZero) {
  for (int64_t m : kAveragingFactors) {
    EXPECT_EQ(BruteForceAvar([](int64_t) { return Real{1}; }, m), 0) << "m " << m;
  }
}

TEST(CompositeModelTest, WhiteMatchesBruteForce) {
  const double n = 0.005;  // deg/sqrt(s): per-sample variance N^2/tau0
  const ModelTerm white = Term(TermKind::kWhite, n);
  const Real sigma2 = static_cast<Real>(n) * n / kTau0;
  for (int64_t m : kAveragingFactors) {
    const Real want = BruteForceAvar([&](int64_t k) { return k == 0 ? sigma2 : Real{0}; }, m);
    EXPECT_LE(RelativeError(TermAvar(white, static_cast<double>(m), kTau0), want),
              kClosedFormRelTol)
        << "m " << m;
  }
}

// Quantization is white phase noise e_k of variance Q^2: the rate
// y_k = (e_{k+1} - e_k)/tau0 has gamma_0 = 2Q^2/tau0^2, gamma_{+-1} = -Q^2/tau0^2.
TEST(CompositeModelTest, QuantizationMatchesBruteForce) {
  const double q = 3e-5;  // deg
  const ModelTerm quantization = Term(TermKind::kQuantization, q);
  const Real q2 = static_cast<Real>(q) * q / (static_cast<Real>(kTau0) * kTau0);
  for (int64_t m : kAveragingFactors) {
    const Real want =
        BruteForceAvar([&](int64_t k) { return k == 0 ? 2 * q2 : (k == 1 ? -q2 : Real{0}); }, m);
    EXPECT_LE(RelativeError(TermAvar(quantization, static_cast<double>(m), kTau0), want),
              kClosedFormRelTol)
        << "m " << m;
  }
}

// AR(1), gamma_k = sigma^2 phi^k, phi = exp(-tau0/T), from T = tau0/40 (past
// the closed form's white cut-off x = tau0/T > 30) to 1e6 tau0 (phi = 1 - 1e-6,
// AVAR(1) = 1e-6 sigma^2), through the series switch points x = 1 and m x = 1.
// The reference sums gamma_k - gamma_0 = sigma^2 expm1(-k x), which carries no
// cancellation, so it is accurate to long-double round-off for every T.
TEST(CompositeModelTest, GaussMarkovMatchesBruteForce) {
  const double sigma = 0.02;
  const double t_over_tau0[] = {1.0 / 40, 1.0 / 30, 0.1,  0.5, 0.99, 1.0, 1.01,
                                3.0,      10.0,     99.0, 100, 1e3,  1e4, 1e6};
  for (double ratio : t_over_tau0) {
    const double t_s = ratio * kTau0;
    const ModelTerm gm = Term(TermKind::kGaussMarkov, sigma, t_s);
    const Real x = static_cast<Real>(kTau0 / t_s);  // the closed form's x, as it rounds it
    const Real sigma2 = static_cast<Real>(sigma) * sigma;
    for (int64_t m : kAveragingFactors) {
      const Real want = BruteForceAvar([&](int64_t k) { return sigma2 * std::expm1(-k * x); }, m);
      EXPECT_LE(RelativeError(TermAvar(gm, static_cast<double>(m), kTau0), want), kClosedFormRelTol)
          << "T/tau0 " << ratio << " m " << m;
    }
  }
}

// A sinusoid A sin(2 pi f t + U), U uniform, f' = f tau0 cycles per sample:
// gamma_k = (A^2/2) cos(2 pi f' k); the reference sums
// gamma_k - gamma_0 = -A^2 sin^2(pi f' k).
TEST(CompositeModelTest, SinusoidMatchesBruteForce) {
  const double amplitude = 0.1;
  const double f_cycles[] = {1e-4, 0.0123, 0.1, 0.25, 1.0 / 3, 0.4321, 0.49, 0.5};
  for (double fc : f_cycles) {
    const ModelTerm sine = Term(TermKind::kSinusoid, amplitude, 0, fc / kTau0);
    const double f = sine.frequency_hz * kTau0;  // f' as the closed form computes it
    const Real a2 = static_cast<Real>(amplitude) * amplitude;
    for (int64_t m : kAveragingFactors) {
      const Real want = BruteForceAvar(
          [&](int64_t k) {
            const Real s = SinPi(f, k);
            return -a2 * s * s;
          },
          m);
      const double got = TermAvar(sine, static_cast<double>(m), kTau0);
      const double theta = kPi * f * m, d = std::sin(kPi * f), s = std::sin(theta);
      const double argument_error = kSinusoidArgumentFactor * kEps * theta *
                                    std::fabs(s * s * s * std::cos(theta)) * amplitude * amplitude /
                                    (static_cast<double>(m) * m * d * d);
      const double tol = kClosedFormRelTol * static_cast<double>(std::fabs(want)) + argument_error +
                         kBruteForceAbsTol * amplitude * amplitude;
      EXPECT_NEAR(got, static_cast<double>(want), tol) << "f' " << f << " m " << m;
    }
  }
}

// y_k = y_0 + w_1 + ... + w_k with Var(w) = K^2 tau0. ybar_B - ybar_A is a
// fixed combination sum_j c_j w_j (y_0 cancels): c_j counts, over the samples
// of B minus those of A, the ones at or after step j, divided by m. Then
// AVAR = K^2 tau0 sum_j c_j^2 / 2, summed exactly in integers.
TEST(CompositeModelTest, RandomWalkMatchesIncrementWeights) {
  const double k_rw = 4e-5;  // deg/s/sqrt(s)
  const ModelTerm walk = Term(TermKind::kRandomWalk, k_rw);
  for (int64_t m : kAveragingFactors) {
    std::vector<int64_t> count(2 * m, 0);  // count[j] = m c_j, j = 1..2m-1
    for (int64_t k = 0; k < 2 * m; ++k) {
      for (int64_t j = 1; j <= k; ++j) count[j] += k < m ? -1 : 1;
    }
    int64_t sum_squares = 0;
    for (int64_t c : count) sum_squares += c * c;
    const Real want =
        static_cast<Real>(k_rw) * k_rw * kTau0 * sum_squares / (2 * static_cast<Real>(m) * m);
    const double got = TermAvar(walk, static_cast<double>(m), kTau0);
    EXPECT_LE(RelativeError(got, want), kClosedFormRelTol) << "m " << m;
    EXPECT_LE(RelativeError(got, static_cast<Real>(k_rw) * k_rw * kTau0 *
                                     (2 * static_cast<Real>(m) * m + 1) / (6 * m)),
              kClosedFormRelTol)
        << "m " << m;
  }
}

// y_k = R tau0 k: the block means differ by exactly R tau, AVAR = R^2 tau^2/2.
TEST(CompositeModelTest, DriftIsHalfTheSquaredStep) {
  const double r = 2e-6;  // deg/s^2
  const ModelTerm drift = Term(TermKind::kDrift, r);
  for (int64_t m : kAveragingFactors) {
    Real mean_a = 0, mean_b = 0;
    for (int64_t k = 0; k < m; ++k) {
      mean_a += static_cast<Real>(r) * kTau0 * k;
      mean_b += static_cast<Real>(r) * kTau0 * (k + m);
    }
    const Real step = (mean_b - mean_a) / m;
    const double tau = m * kTau0;
    EXPECT_LE(RelativeError(r * tau, step), kClosedFormRelTol) << "m " << m;
    const double got = TermAvar(drift, static_cast<double>(m), kTau0);
    EXPECT_DOUBLE_EQ(got, 0.5 * r * r * tau * tau) << "m " << m;
    EXPECT_LE(RelativeError(got, step * step / 2), kClosedFormRelTol) << "m " << m;
  }
}

// A line at a quarter of the sampling rate repeats every 4 samples with zero
// mean: a 4-sample average removes it, 1- and 2-sample averages keep A^2/2.
TEST(CompositeModelTest, QuarterRateSinusoid) {
  // sin^4 and sin^2 of multiples of pi/4 in double: a few ulps of 1.
  constexpr double kAbsTol = 1e-15;
  const double tau0 = 1.0;  // f' = 0.25 exactly
  const ModelTerm sine = Term(TermKind::kSinusoid, 1.0, 0, 0.25);
  EXPECT_NEAR(TermAvar(sine, 1, tau0), 0.5, kAbsTol);
  EXPECT_NEAR(TermAvar(sine, 2, tau0), 0.5, kAbsTol);
  EXPECT_NEAR(TermAvar(sine, 4, tau0), 0.0, kAbsTol);
  EXPECT_NEAR(TermAvar(sine, 8, tau0), 0.0, kAbsTol);
}

// ---------------------------------------------------------------------------
// Limits of the Gauss-Markov term.

// T << tau0: phi = e^{-x} -> 0 and AVAR m / sigma^2 lies between 1 - phi
// (m = 1) and its long-tau limit (1 + phi)/(1 - phi), so it is white sigma^2/m
// within 2 phi/(1 - phi).
TEST(CompositeModelTest, GaussMarkovShortCorrelationIsWhite) {
  const double sigma = 0.02;
  for (double ratio : {0.1, 1.0 / 25, 1.0 / 40, 1e-3}) {
    const ModelTerm gm = Term(TermKind::kGaussMarkov, sigma, ratio * kTau0);
    const double phi = std::exp(-1 / ratio);
    for (int64_t m : kAveragingFactors) {
      const double white = sigma * sigma / static_cast<double>(m);
      EXPECT_NEAR(TermAvar(gm, static_cast<double>(m), kTau0), white,
                  (2 * phi / (1 - phi) + kClosedFormRelTol) * white)
          << "T/tau0 " << ratio << " m " << m;
    }
  }
}

// T >> tau: over the averaging time the process is a random walk of
// increment variance sigma^2 (1 - phi^2) ~ 2 sigma^2 tau0/T, AVAR ~ (2 sigma^2/T) tau/3.
// The leading corrections are +1/(2 m^2) (discrete sampling, (2m^2 + 1)/(2m^2))
// and -3 tau/(4T) (the decay of the correlation); the tolerance is their sum
// with the second rounded up to tau/T for the higher orders.
TEST(CompositeModelTest, GaussMarkovLongCorrelationIsRandomWalk) {
  const double sigma = 0.02;
  for (double ratio : {1e5, 1e6}) {
    const double t_s = ratio * kTau0;
    const ModelTerm gm = Term(TermKind::kGaussMarkov, sigma, t_s);
    for (int64_t m : {1, 4, 16, 100, 1000}) {
      const double tau = m * kTau0;
      const double walk = 2 * sigma * sigma / t_s * tau / 3;
      const double tol = 1.0 / (2.0 * m * m) + tau / t_s;
      EXPECT_NEAR(TermAvar(gm, static_cast<double>(m), kTau0), walk, tol * walk)
          << "T/tau0 " << ratio << " m " << m;
    }
  }
}

// tau, T >> tau0: the continuous-time first-order Markov AVAR
//   (q_c T_c)^2/tau [1 - T_c/(2 tau) (3 - 4 e^{-tau/T_c} + e^{-2 tau/T_c})],
// q_c^2 = 2 sigma^2/T_c. The discrete form differs by at most
// 0.85 (1/m^2 + x^2/6), x = tau0/T: 1/(2 m^2) for tau << T, x^2/12 for
// tau >> T, a bump of 0.91/m^2 at tau = T (scanned with 50-digit arithmetic
// over tau/T in [1e-3, 1e5]); the tolerance is 1/m^2 + x^2/6. The continuous
// form cancels for tau << T, so it is evaluated in long double with tau/T >= 0.01.
TEST(CompositeModelTest, GaussMarkovMatchesContinuousMarkov) {
  const double sigma = 0.02;
  for (double ratio : {1e2, 1e3, 1e4}) {
    const double t_s = ratio * kTau0;
    const ModelTerm gm = Term(TermKind::kGaussMarkov, sigma, t_s);
    const double x = kTau0 / t_s;
    for (double m : {100.0, 1e3, 1e4, 1e5, 1e6}) {
      const Real tau = static_cast<Real>(m) * kTau0, tc = t_s;
      if (tau / tc < 0.01) continue;
      const Real qc2 = 2 * static_cast<Real>(sigma) * sigma / tc;
      const Real want =
          qc2 * tc * tc / tau *
          (1 - tc / (2 * tau) * (3 - 4 * std::exp(-tau / tc) + std::exp(-2 * tau / tc)));
      const double tol = 1 / (m * m) + x * x / 6;
      EXPECT_LE(RelativeError(TermAvar(gm, m, kTau0), want), tol)
          << "T/tau0 " << ratio << " m " << m;
    }
  }
}

// ---------------------------------------------------------------------------
// Monte Carlo: a simulated composite against the model's deviation.

struct CompositeTruth {
  double n = 0.005;        // white, deg/sqrt(s): per-sample sd n/sqrt(tau0) = 0.05 deg/s
  double gm_sigma = 0.02;  // Gauss-Markov sd, deg/s
  double gm_t_s = 0.16;    // its correlation time, 16 tau0
  double k = 0.015;        // random walk, deg/s/sqrt(s)

  CompositeModel Model() const {
    return CompositeModel{{Term(TermKind::kWhite, n),
                           Term(TermKind::kGaussMarkov, gm_sigma, gm_t_s),
                           Term(TermKind::kRandomWalk, k)}};
  }
};

std::vector<double> SimulateComposite(const CompositeTruth& t, double tau0, int64_t count,
                                      uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double phi = std::exp(-tau0 / t.gm_t_s);
  const double gm_innovation = t.gm_sigma * std::sqrt(1 - phi * phi);
  double gm = t.gm_sigma * gauss(rng);  // started stationary
  double walk = 0;
  std::vector<double> rate(count);
  for (double& y : rate) {
    gm = phi * gm + gm_innovation * gauss(rng);
    walk += t.k * std::sqrt(tau0) * gauss(rng);
    y = t.n / std::sqrt(tau0) * gauss(rng) + gm + walk;
  }
  return rate;
}

// GIVEN 2^20 samples (about 3 h at 100 Hz) of white + Gauss-Markov (T = 16
// tau0) + random walk, WHEN the OADEV is computed on the octave grid, THEN at
// m = 1 (white), 16 (Gauss-Markov) and 256 (random walk) it lies within its
// sampling error of the model's deviation.
TEST(CompositeModelTest, SimulatedCompositeMatchesModelDeviation) {
  // The relative sd of an OADEV with nu edf is 1/sqrt(2 nu). nu is Greenhall's
  // full-overlap edf for random-walk FM (alpha = -2), the smallest of the
  // three terms' alphas (nu = 8.0e5, 6.1e4, 3.8e3 at m = 1, 16, 256). Over
  // 1200 other seeds the z-scores had means within 0.04 of 0, rms 0.83-1.09
  // and max |z| 4.0; five sds keep a margin for another standard library's
  // normal_distribution (the seed fixes the draws only for one).
  constexpr double kSamplingSigmas = 5.0;
  constexpr int64_t kSamples = int64_t{1} << 20;
  const CompositeTruth truth;
  const std::vector<double> rate = SimulateComposite(truth, kTau0, kSamples, 20240611);
  const PhaseRecord phase = PhaseFromRate(rate, kTau0);
  const Curve curve = ComputeDeviation(
      phase, Deviation::kOadev,
      AveragingFactors(TauGridSpec{}, kTau0, phase.size(), Deviation::kOadev, StopRule::kBins9));
  const CompositeModel model = truth.Model();
  int checked = 0;
  for (const CurvePoint& p : curve.points) {
    if (p.m != 1 && p.m != 16 && p.m != 256) continue;
    ++checked;
    const std::optional<double> nu = GreenhallEdf(-2, 2, p.m, phase.size(), p.m, p.m);
    ASSERT_TRUE(nu.has_value());
    const double want = model.Deviation(static_cast<double>(p.m), kTau0);
    const double rel_sd = 1 / std::sqrt(2 * *nu);
    EXPECT_NEAR(p.dev, want, kSamplingSigmas * rel_sd * want) << "m " << p.m << " nu " << *nu;
  }
  EXPECT_EQ(checked, 3);
}

// ---------------------------------------------------------------------------
// Correlation of AVAR estimates (gmwm.h).

TEST(CompositeModelTest, AvarCorrelationOfOctaveNeighbours) {
  const CompositeModel white{{Term(TermKind::kWhite, 0.005)}};
  const CompositeModel walk{{Term(TermKind::kRandomWalk, 4e-5)}};
  for (int64_t m : {16, 64, 256, 1024}) {
    const double rho_white = AvarCorrelation(white, kTau0, m, 2 * m);
    const double rho_walk = AvarCorrelation(walk, kTau0, m, 2 * m);
    // Asymptotic theory: ~0.5 for white noise, ~0.9 for a random walk (0.530
    // and 0.887 from m = 16 on).
    EXPECT_GT(rho_white, 0.4) << "m " << m;
    EXPECT_LT(rho_white, 0.65) << "m " << m;
    EXPECT_GT(rho_walk, 0.85) << "m " << m;
    EXPECT_LT(rho_walk, 0.95) << "m " << m;
    EXPECT_EQ(AvarCorrelation(white, kTau0, 2 * m, m), rho_white) << "m " << m;
    EXPECT_EQ(AvarCorrelation(walk, kTau0, 2 * m, m), rho_walk) << "m " << m;
    EXPECT_EQ(AvarCorrelation(white, kTau0, m, m), 1.0) << "m " << m;
    EXPECT_EQ(AvarCorrelation(walk, kTau0, m, m), 1.0) << "m " << m;
  }
}

// GIVEN 300 seeded white-noise records of 2^14 samples, WHEN ln OAVAR is
// computed at m = 16 and 32 on each, THEN the correlation across records
// matches AvarCorrelation.
TEST(CompositeModelTest, AvarCorrelationMatchesMonteCarloForWhiteNoise) {
  // Sampling sd of a Pearson r over n pairs is ~(1 - rho^2)/sqrt(n) = 0.043
  // at rho = 0.5, n = 300; 0.12 is ~2.8 of those. The theory is asymptotic
  // (end effects of O(m/N) = 0.2%) and for AVAR rather than ln AVAR, which
  // differ by O(relative sd^2) = O(1e-3) at ~1500 edf.
  constexpr double kCorrelationAbsTol = 0.12;
  constexpr int kRecords = 300;
  constexpr int64_t kSamples = int64_t{1} << 14;
  const double tau0 = 1.0;
  const CompositeModel white{{Term(TermKind::kWhite, 1.0)}};
  std::mt19937_64 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const std::vector<int64_t> m_list = {16, 32};
  std::vector<double> rate(kSamples);
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int r = 0; r < kRecords; ++r) {
    for (double& y : rate) y = gauss(rng);
    const Curve c = ComputeDeviation(PhaseFromRate(rate, tau0), Deviation::kOadev, m_list);
    ASSERT_EQ(c.points.size(), 2u);
    const double a = 2 * std::log(c.points[0].dev), b = 2 * std::log(c.points[1].dev);
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
  }
  const double n = kRecords;
  const double cov = sab / n - sa / n * sb / n;
  const double rho = cov / std::sqrt((saa / n - sa / n * sa / n) * (sbb / n - sb / n * sb / n));
  const double model_rho = AvarCorrelation(white, tau0, 16, 32);
  EXPECT_NEAR(rho, model_rho, kCorrelationAbsTol);
}

// ---------------------------------------------------------------------------

// A model with every kind of term, a Gauss-Markov term of each regime (a
// correlation time near tau0 with the series branches, a long one, and one
// below tau0 / 30 that is white to double precision) and two sinusoids.
CompositeModel EveryKindOfTerm() {
  CompositeModel model;
  model.terms = {{TermKind::kQuantization, 2e-4},
                 {TermKind::kWhite, 3e-3},
                 {TermKind::kFlicker, 5e-4},
                 {TermKind::kRandomWalk, 7e-5},
                 {TermKind::kDrift, 1e-6},
                 {TermKind::kGaussMarkov, 2e-3, 0.004},
                 {TermKind::kGaussMarkov, 4e-4, 250.0},
                 {TermKind::kGaussMarkov, 1e-3, 1e-5},
                 {TermKind::kSinusoid, 1e-3, 0, 24.7},
                 {TermKind::kSinusoid, 5e-4, 0, 0.013}};
  return model;
}

TEST(ModelEvaluatorTest, EqualsTheModelBitForBit) {
  // GIVEN every kind of term at 100 Hz
  const CompositeModel model = EveryKindOfTerm();
  constexpr double kTau0 = 0.01;
  const ModelEvaluator ev(model, kTau0);
  ASSERT_EQ(ev.size(), model.terms.size());
  // WHEN evaluated at whole and fractional averaging factors from 1 to 1e7
  // and at frequencies across (0, 1/2]
  // THEN every term's AVAR, the sum and the PSD are the same doubles.
  for (double m = 1; m < 1e7; m *= 1.37) {
    for (double mm : {std::floor(m), m}) {
      for (size_t i = 0; i < model.terms.size(); ++i) {
        EXPECT_EQ(ev.TermAvar(i, mm), TermAvar(model.terms[i], mm, kTau0)) << i << " " << mm;
      }
      EXPECT_EQ(ev.Avar(mm), model.Avar(mm, kTau0)) << mm;
    }
  }
  for (double f = 1e-6; f <= 0.5; f *= 1.11) {
    EXPECT_EQ(ev.Psd(f, std::sin(kPi * f)), model.Psd(f, kTau0)) << f;
  }
  EXPECT_EQ(ev.Psd(0.5, std::sin(kPi * 0.5)), model.Psd(0.5, kTau0));
}

TEST(ModelEvaluatorTest, TermsSetOneByOneEqualAFreshEvaluator) {
  // GIVEN an evaluator prepared for one model, then given another model's
  // terms one at a time (the fit's per-term updates)
  const CompositeModel model = EveryKindOfTerm();
  CompositeModel other = model;
  for (ModelTerm& t : other.terms) t.scale *= 1.5;
  other.terms[5].correlation_time_s = 0.02;
  other.terms[8].frequency_hz = 3.0;
  ModelEvaluator ev(model, 0.005);
  for (size_t i = 0; i < other.terms.size(); ++i) ev.SetTerm(i, other.terms[i]);
  // THEN it evaluates the other model exactly.
  for (double m = 1; m < 1e6; m *= 2.3) EXPECT_EQ(ev.Avar(m), other.Avar(m, 0.005)) << m;
}

// ---------------------------------------------------------------------------
// Theo1 under the model.

// Var(u_k) of a stationary rate term from its autocovariance: u_k / tau0 is
// the sum of the k rate samples before i+m minus the k from i, so Var(u_k) =
// tau0^2 sum_a sum_b w_a w_b gamma(a - b), summed by lag with exact weights.
Real BruteForcePairVariance(const std::function<Real(int64_t)>& gamma, int64_t m, int64_t k,
                            double tau0) {
  std::vector<int> w(static_cast<size_t>(m), 0);
  for (int64_t j = 0; j < k; ++j) w[j] -= 1;
  for (int64_t j = m - k; j < m; ++j) w[j] += 1;
  CompensatedSum sum;
  for (int64_t lag = 0; lag < m; ++lag) {
    int64_t weight = 0;
    for (int64_t a = 0; a + lag < m; ++a) weight += w[a] * w[a + lag];
    if (weight != 0) sum.Add((lag == 0 ? 1 : 2) * weight * gamma(lag));
  }
  return sum.value() * static_cast<Real>(tau0) * tau0;
}

TEST(CompositeModelTest, Theo1PairVarianceOfStationaryTermsMatchesBruteForce) {
  // GIVEN white noise, a Gauss-Markov term (short and long correlation) and a
  // random-phase sinusoid, THEN Var(u_k) from the closed forms equals the sum
  // over the autocovariance for every k of several m.
  struct Case {
    ModelTerm term;
    std::function<Real(int64_t)> gamma;
  };
  const double n = 0.02, sigma = 0.3, a = 0.5;
  const std::vector<Case> cases = {
      {Term(TermKind::kWhite, n),
       [&](int64_t j) { return j == 0 ? static_cast<Real>(n) * n / kTau0 : 0; }},
      {Term(TermKind::kGaussMarkov, sigma, 0.05),
       [&](int64_t j) {
         return static_cast<Real>(sigma) * sigma * std::exp(-Real(j) * kTau0 / 0.05L);
       }},
      {Term(TermKind::kGaussMarkov, sigma, 20.0),
       [&](int64_t j) {
         return static_cast<Real>(sigma) * sigma * std::exp(-Real(j) * kTau0 / 20.0L);
       }},
      {Term(TermKind::kSinusoid, a, 0, 3.7), [&](int64_t j) {
         return static_cast<Real>(a) * a / 2 * std::cos(2 * kPiL * 3.7L * kTau0 * j);
       }}};
  for (const Case& c : cases) {
    for (int64_t m : {2, 8, 50, 400}) {
      for (int64_t k : {int64_t{1}, m / 4 + 1, m / 2}) {
        if (k < 1 || 2 * k > m) continue;
        const Real truth = BruteForcePairVariance(c.gamma, m, k, kTau0);
        EXPECT_LE(RelativeError(TermTheo1PairVariance(c.term, m, k, kTau0), truth), 1e-9)
            << TermKindName(c.term.kind) << " m " << m << " k " << k;
      }
    }
  }
}

TEST(CompositeModelTest, Theo1PairVarianceAtHalfMIsTheSecondDifference) {
  // u_{m/2} = x_i - 2 x_{i+m/2} + x_{i+m}: for every kind of term its
  // variance is 2 (m tau0 / 2)^2 AVAR(m/2), which holds each kernel
  // (flicker's and the random walk's generalized covariances among them) to
  // the AVAR closed forms.
  for (const ModelTerm& t : EveryKindOfTerm().terms) {
    for (int64_t m : {2, 4, 16, 200, 4000}) {
      const double half = 0.5 * static_cast<double>(m) * kTau0;
      const double avar = TermAvar(t, static_cast<double>(m / 2), kTau0);
      EXPECT_NEAR(TermTheo1PairVariance(t, m, m / 2, kTau0), 2 * half * half * avar,
                  1e-9 * 2 * half * half * avar + 1e-300)
          << TermKindName(t.kind) << " m " << m;
    }
  }
}

TEST(CompositeModelTest, Theo1ExpectationWithoutEveryKEqualsTheSumOverEveryK) {
  // GIVEN every kind of term, Gauss-Markov terms from far below tau0 to far
  // beyond the record, and sinusoids from m f << 1 through m f ~ 30 (where
  // the closed form takes over) to near Nyquist, THEN TermExpectedTheo1
  // equals the sum of TermTheo1PairVariance / k over every k to 1e-10 (the largest
  // error seen is 1.2e-11).
  CompositeModel model = EveryKindOfTerm();
  for (double t : {2e-3, 0.3, 40.0, 1e5})
    model.terms.push_back(Term(TermKind::kGaussMarkov, 1e-3, t));
  for (double f : {1e-4, 0.002, 0.031, 0.37, 11.0, 49.9, 50.0}) {
    model.terms.push_back(Term(TermKind::kSinusoid, 1e-3, 0, f));
  }
  for (int64_t m : {2, 6, 512, 4098, 9000, 131072, 500002}) {
    for (const ModelTerm& t : model.terms) {
      CompensatedSum sum;
      for (int64_t k = 1; 2 * k <= m; ++k) {
        sum.Add(TermTheo1PairVariance(t, m, k, kTau0) / static_cast<Real>(k));
      }
      const double md = static_cast<double>(m);
      const Real truth = sum.value() / (0.75 * md * md * kTau0 * kTau0);
      EXPECT_LE(RelativeError(TermExpectedTheo1(t, m, kTau0), truth), 1e-10)
          << TermKindName(t.kind) << " " << t.correlation_time_s << " " << t.frequency_hz << " m "
          << m;
    }
  }
}

TEST(CompositeModelTest, Theo1OfMeansIsTheSumOverMultiplesOfTheBlock) {
  // GIVEN every kind of term (Gauss-Markov from below tau0 to far beyond the
  // record; sinusoids below and above the means' Nyquist, one at a multiple
  // of their rate), THEN the means' E[Theo1(m)] equals the sum of the
  // samples' TermTheo1PairVariance at distances k b over k = 1..m/2, weighed
  // 1/k, to 1e-9 (the largest error seen is 2.8e-11).
  CompositeModel model = EveryKindOfTerm();
  for (double t : {2e-3, 0.3, 40.0, 1e5})
    model.terms.push_back(Term(TermKind::kGaussMarkov, 1e-3, t));
  for (double f : {1e-4, 0.031, 0.37, 11.0, 10.0, 49.9}) {
    model.terms.push_back(Term(TermKind::kSinusoid, 1e-3, 0, f));
  }
  for (int64_t b : {1, 2, 7, 100}) {
    for (int64_t m : {2, 10, 512, 4098}) {
      for (const ModelTerm& t : model.terms) {
        CompensatedSum sum;
        for (int64_t k = 1; 2 * k <= m; ++k) {
          sum.Add(TermTheo1PairVariance(t, m * b, k * b, kTau0) / static_cast<Real>(k));
        }
        const double md = static_cast<double>(m * b);
        const Real truth = sum.value() / (0.75 * md * md * kTau0 * kTau0);
        const double got = TermExpectedTheo1OfMeans(t, m, kTau0, b);
        if (std::abs(truth) < 1e-30) {
          EXPECT_LE(std::abs(got), 1e-30) << TermKindName(t.kind) << " " << t.frequency_hz;
          continue;
        }
        EXPECT_LE(RelativeError(got, truth), 1e-9)
            << TermKindName(t.kind) << " T " << t.correlation_time_s << " f " << t.frequency_hz
            << " m " << m << " block " << b;
      }
    }
  }
}

TEST(CompositeModelTest, Theo1BiasFollowsHoweAndTasset) {
  // White rate noise (white FM): Theo1 is unbiased, E[Theo1(m)] = AVAR(0.75 m).
  const CompositeModel white{{Term(TermKind::kWhite, 0.02)}};
  for (int64_t m : {2, 10, 64, 1000}) {
    EXPECT_NEAR(white.Theo1BiasFactor(m, kTau0), 1.0, 1e-12) << m;
  }
  // Howe & Tasset (EFTF 2004, Table 1): AVAR(r tau0) / E[Theo1(m)] = a + b
  // r^-c, r = 0.75 m, for white PM (Q), flicker FM (B) and random-walk FM (K),
  // within their two-digit fit's 4 % (as long_tau_test holds the estimator).
  struct Row {
    TermKind kind;
    double a, b, c;
  };
  for (const Row& row :
       {Row{TermKind::kQuantization, 0.09, 0.74, 0.40}, Row{TermKind::kFlicker, 1.87, -1.05, 0.79},
        Row{TermKind::kRandomWalk, 2.70, -1.53, 0.85}}) {
    const CompositeModel model{{Term(row.kind, 0.01)}};
    for (int64_t m : {16, 64, 256, 2048}) {
      const double r = 0.75 * static_cast<double>(m);
      const double table = row.a + row.b * std::pow(r, -row.c);
      EXPECT_NEAR(model.Theo1BiasFactor(m, kTau0), table, 0.04 * table)
          << TermKindName(row.kind) << " m " << m;
    }
  }
  // A gyro's curve: white noise turning into rate random walk. Where they
  // cross the factor lies between 1 and 2.7 and depends on tau, which one
  // ratio for the whole curve (TheoBR) cannot follow.
  const CompositeModel gyro{{Term(TermKind::kWhite, 1.0), Term(TermKind::kRandomWalk, 0.01)}};
  const double at_cross = gyro.Theo1BiasFactor(600, 1.0);
  const double beyond = gyro.Theo1BiasFactor(20000, 1.0);
  EXPECT_GT(at_cross, 1.2);
  EXPECT_LT(at_cross, beyond);
  EXPECT_LT(beyond, 2.7);
}

TEST(CompositeModelTest, NameListsTermsInFixedOrder) {
  const CompositeModel model{{Term(TermKind::kSinusoid, 0.01, 0, 3.0),
                              Term(TermKind::kGaussMarkov, 0.02, 10.0),
                              Term(TermKind::kWhite, 0.005), Term(TermKind::kFlicker, 1e-3),
                              Term(TermKind::kGaussMarkov, 0.01, 100.0)}};
  EXPECT_EQ(model.Name(), "N+B+2GM+S");
  EXPECT_EQ(model.CountOf(TermKind::kGaussMarkov), 2);
  EXPECT_EQ(model.CountOf(TermKind::kRandomWalk), 0);
  EXPECT_EQ(CompositeModel{}.Name(), "none");
  const CompositeModel all{{Term(TermKind::kSinusoid, 1), Term(TermKind::kGaussMarkov, 1, 1),
                            Term(TermKind::kDrift, 1), Term(TermKind::kRandomWalk, 1),
                            Term(TermKind::kFlicker, 1), Term(TermKind::kWhite, 1),
                            Term(TermKind::kQuantization, 1)}};
  EXPECT_EQ(all.Name(), "Q+N+B+K+R+GM+S");
}

// A model's own figures: N + K has its -1/2 asymptote at N and its minimum
// where N^2 / tau = K^2 tau / 3 (tau* = sqrt(3) N / K, minimum
// sqrt(2 N K / sqrt 3)); a Gauss-Markov term fast against 1 s joins the
// asymptote as white noise (sigma^2 tau0 (1 + phi) / (1 - phi)), a slow one
// does not; the minimum is searched only inside the taus given.
TEST(CompositeModelTest, ModelFiguresOverItsTaus) {
  const double tau0 = 0.01, n = 0.004, k = 1e-4;
  CompositeModel m;
  m.terms = {{TermKind::kWhite, n}, {TermKind::kRandomWalk, k}};
  const ModelCurveFigures f = ModelFiguresOver(m, tau0, 0.01, 1e4);
  EXPECT_DOUBLE_EQ(f.white_asymptote, n);
  EXPECT_NEAR(f.tau_at_minimum, std::sqrt(3.0) * n / k, 1e-3 * std::sqrt(3.0) * n / k);
  EXPECT_NEAR(f.curve_minimum, std::sqrt(2 * n * k / std::sqrt(3.0)), 1e-4 * f.curve_minimum);
  EXPECT_NEAR(f.curve_minimum, m.Deviation(f.tau_at_minimum / tau0, tau0), 1e-12);
  // Inside a range that ends before tau*: the minimum is at its end.
  const ModelCurveFigures short_range = ModelFiguresOver(m, tau0, 0.01, 10.0);
  EXPECT_NEAR(short_range.tau_at_minimum, 10.0, 1e-6);
  ModelTerm fast{TermKind::kGaussMarkov, 0.05};
  fast.correlation_time_s = 0.02;
  ModelTerm slow = fast;
  slow.correlation_time_s = 50;
  m.terms.push_back(fast);
  m.terms.push_back(slow);
  const double phi = std::exp(-tau0 / 0.02);
  EXPECT_NEAR(ModelFiguresOver(m, tau0, 0.01, 1e4).white_asymptote,
              std::sqrt(n * n + 0.05 * 0.05 * tau0 * (1 + phi) / (1 - phi)), 1e-15);
}

}  // namespace
}  // namespace imuqual::allan
