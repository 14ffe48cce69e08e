#include "analyze/allan/confidence.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <vector>

#include "analyze/allan/long_tau.h"
#include "analyze/allan/noise_id.h"

namespace imuqual::allan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
constexpr int kMaxGammaIterations = 100000;

// log of the common factor x^a e^{-x} / Gamma(a) of both incomplete gamma
// expansions.
double LogGammaPrefactor(double a, double x) { return a * std::log(x) - x - std::lgamma(a); }

// P(a, x) by its power series, for x < a + 1:
//   P = x^a e^{-x} / Gamma(a) * sum_{n>=0} x^n / (a (a+1) ... (a+n)).
double GammaPSeries(double a, double x) {
  double term = 1.0 / a;
  double sum = term;
  for (int n = 1; n < kMaxGammaIterations; ++n) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * kEpsilon) break;
  }
  return sum * std::exp(LogGammaPrefactor(a, x));
}

// Q(a, x) = 1 - P(a, x) by its continued fraction, for x >= a + 1:
//   Q = x^a e^{-x} / Gamma(a) * 1/(x+1-a - 1(1-a)/(x+3-a - 2(2-a)/(x+5-a - ...))),
// evaluated with the modified Lentz method.
double GammaQContinuedFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / kTiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < kMaxGammaIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < kEpsilon) break;
  }
  return h * std::exp(LogGammaPrefactor(a, x));
}

double RegularizedGammaQ(double a, double x) {
  if (x <= 0.0) return 1.0;
  if (x < a + 1.0) return 1.0 - GammaPSeries(a, x);
  return GammaQContinuedFraction(a, x);
}

// Standard normal quantile, Abramowitz & Stegun 26.2.23 (|error| < 4.5e-4);
// only a starting point for Chi2Inv.
double ApproximateNormalQuantile(double p) {
  const double tail = std::min(p, 1.0 - p);
  const double t = std::sqrt(-2.0 * std::log(tail));
  const double z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) /
                           (1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t * t * t);
  return p < 0.5 ? -z : z;
}

double Binomial(int n, int k) {
  if (k < 0 || k > n) return 0.0;
  double result = 1.0;
  for (int i = 1; i <= k; ++i) result = result * (n - k + i) / i;
  return result;
}

// ---- Greenhall & Riley (2003) ----

// sw(t) for power-law alpha (signs are irrelevant: only ratios of squares
// are used; log terms are 0 at t = 0).
double Sw(double t, int alpha) {
  const double a = std::fabs(t);
  const double log_a = a > 0.0 ? std::log(a) : 0.0;
  switch (alpha) {
    case 2:
      return -a;
    case 1:
      return t * t * log_a;
    case 0:
      return a * a * a;
    case -1:
      return -std::pow(t, 4) * log_a;
    case -2:
      return -std::pow(a, 5);
    case -3:
      return std::pow(t, 6) * log_a;
    case -4:
      return std::pow(a, 7);
    default:
      return std::nan("");
  }
}

// sx(t, F) = F^2 [2 sw(t) - sw(t - 1/F) - sw(t + 1/F)];  sx(t, inf) = sw_{alpha+2}(t).
double Sx(double t, double f, int alpha) {
  if (std::isinf(f)) return Sw(t, alpha + 2);
  return f * f * (2.0 * Sw(t, alpha) - Sw(t - 1.0 / f, alpha) - Sw(t + 1.0 / f, alpha));
}

// sz(t, F) = sum_{k=-d}^{d} (-1)^k C(2d, d+k) sx(t + k, F).
double Sz(double t, double f, int alpha, int d) {
  double sum = 0.0;
  for (int k = -d; k <= d; ++k) {
    const double sign = (k % 2 == 0) ? 1.0 : -1.0;
    sum += sign * Binomial(2 * d, d + k) * Sx(t + k, f, alpha);
  }
  return sum;
}

// sz(j/S, F) for j = 0, 1, 2, ...: every basic sum of the same (S, F, alpha,
// d) reads the same values, and few combinations recur (a streaming curve's
// points have S = c in [C, 2C), and F = inf once m (d + 1) > kJmax), while
// each value costs fifteen sw evaluations. Each thread keeps the values it
// computed, up to kMaxEntries combinations (then it starts again): a value
// read here is the value Sz returns for the same arguments, bit for bit.
class SzValues {
 public:
  // sz(j/S, F) for j = 0..count-1.
  const double* Get(double s, double f, int alpha, int d, int count) {
    const Key key{Bits(s), Bits(f), alpha, d};
    auto it = entries_.find(key);
    if (it == entries_.end()) {
      if (entries_.size() >= kMaxEntries) entries_.clear();
      it = entries_.emplace(key, std::vector<double>()).first;
    }
    std::vector<double>& v = it->second;
    for (int j = static_cast<int>(v.size()); j < count; ++j) v.push_back(Sz(j / s, f, alpha, d));
    return v.data();
  }

 private:
  static constexpr size_t kMaxEntries = 1024;
  static uint64_t Bits(double v) {
    uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
  }
  struct Key {
    uint64_t s, f;
    int alpha, d;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      uint64_t h = k.s * 0x9e3779b97f4a7c15ULL;
      h ^= k.f + 0x7f4a7c159e3779b9ULL + (h << 6) + (h >> 2);
      h ^= static_cast<uint64_t>(k.alpha + 8) * 31 + static_cast<uint64_t>(k.d);
      return static_cast<size_t>(h);
    }
  };
  std::unordered_map<Key, std::vector<double>, KeyHash> entries_;
};

// sz(j/S, F) for j = 0..count-1, from this thread's SzValues.
const double* SzAt(double S, double f, int alpha, int d, int count) {
  thread_local SzValues values;
  return values.Get(S, f, alpha, d, count);
}

// BS = sz[0]^2 + (1 - J/M) sz[J]^2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz[j]^2, sz
// holding J + 1 values.
double BasicSumOf(const double* sz, double J, double M) {
  const double sz0 = sz[0];
  const double szj = sz[static_cast<int>(J)];
  double sum = sz0 * sz0 + (1.0 - J / M) * szj * szj;
  for (int j = 1; j < J; ++j) sum += 2.0 * (1.0 - j / M) * sz[j] * sz[j];
  return sum;
}

// BS(J, M, S, F) = sz(0)^2 + (1 - J/M) sz(J/S)^2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)^2.
// J is a whole number >= 1 (j/S and J/S are then the same quotients).
double BasicSum(double J, double M, double S, double f, int alpha, int d) {
  return BasicSumOf(SzAt(S, f, alpha, d, static_cast<int>(J) + 1), J, M);
}

struct TableEntry {
  double a0;
  double a1;
};
constexpr double kMissing = -1.0;

// Greenhall & Riley Tables 1 (modified, "T1") and 2 (unmodified, "T2"): rows
// alpha = 2, 1, 0, -1, -2, -3, -4; columns d = 1, 2, 3.
constexpr std::array<std::array<TableEntry, 3>, 7> kTable1 = {{
    {{{2.0 / 3, 1.0 / 3}, {7.0 / 9, 1.0 / 2}, {22.0 / 25, 2.0 / 3}}},
    {{{0.840, 0.345}, {0.997, 0.616}, {1.141, 0.843}}},
    {{{1.079, 0.368}, {1.033, 0.607}, {1.184, 0.848}}},
    {{{kMissing, 0}, {1.048, 0.534}, {1.180, 0.816}}},
    {{{kMissing, 0}, {1.302, 0.535}, {1.175, 0.777}}},
    {{{kMissing, 0}, {kMissing, 0}, {1.194, 0.703}}},
    {{{kMissing, 0}, {kMissing, 0}, {1.489, 0.702}}},
}};
constexpr std::array<std::array<TableEntry, 3>, 7> kTable2 = {{
    {{{3.0 / 2, 1.0 / 2}, {35.0 / 18, 1.0}, {231.0 / 100, 3.0 / 2}}},
    {{{78.6, 25.2}, {790.0, 410.0}, {9950.0, 6520.0}}},
    {{{2.0 / 3, 1.0 / 6}, {2.0 / 3, 1.0 / 3}, {7.0 / 9, 1.0 / 2}}},
    {{{kMissing, 0}, {0.852, 0.375}, {0.997, 0.617}}},
    {{{kMissing, 0}, {1.079, 0.368}, {1.033, 0.607}}},
    {{{kMissing, 0}, {kMissing, 0}, {1.053, 0.553}}},
    {{{kMissing, 0}, {kMissing, 0}, {1.302, 0.535}}},
}};
// Table 3 (alpha = 1, unmodified): (b0, b1) for d = 1, 2, 3.
constexpr std::array<TableEntry, 3> kTable3 = {{{6.0, 4.0}, {15.23, 12.0}, {47.8, 40.0}}};

// 1/nu from a table: (a0 - a1/r)/r.
std::optional<double> TableInverseEdf(const std::array<std::array<TableEntry, 3>, 7>& table,
                                      int alpha, int d, double r) {
  const TableEntry entry = table[2 - alpha][d - 1];
  if (entry.a0 == kMissing) return std::nullopt;
  return (entry.a0 - entry.a1 / r) / r;
}

std::optional<double> GreenhallInverseEdf(int alpha, int d, double m, double n, double f,
                                          double s) {
  constexpr double kJmax = 100.0;
  const double L = m / f + m * d;
  if (n < L) return std::nullopt;
  const double M = 1.0 + std::floor(s * (n - L) / m);
  const double J = std::min(M, std::floor((d + 1) * s));
  const double r = M / s;

  if (f == 1.0) {  // Case 1: modified variances (and m = 1), all alpha.
    if (J <= kJmax)
      return BasicSum(J, M, s, 1.0, alpha, d) / (M * std::pow(Sz(0, 1.0, alpha, d), 2));
    if (r >= d + 1) return TableInverseEdf(kTable1, alpha, d, r);
    const double m_prime = kJmax / r;
    return BasicSum(kJmax, kJmax, m_prime, 1.0, alpha, d) /
           (kJmax * std::pow(Sz(0, 1.0, alpha, d), 2));
  }
  if (alpha <= 0) {  // Case 2: unmodified, alpha <= 0.
    if (J <= kJmax) {
      const double f_prime = m * (d + 1) <= kJmax ? f : kInf;
      return BasicSum(J, M, s, f_prime, alpha, d) / (M * std::pow(Sz(0, f_prime, alpha, d), 2));
    }
    if (r >= d + 1) return TableInverseEdf(kTable2, alpha, d, r);
    const double m_prime = kJmax / r;
    return BasicSum(kJmax, kJmax, m_prime, kInf, alpha, d) /
           (kJmax * std::pow(Sz(0, kInf, alpha, d), 2));
  }
  if (alpha == 1) {  // Case 3: unmodified, flicker PM.
    if (J <= kJmax) return BasicSum(J, M, s, f, alpha, d) / (M * std::pow(Sz(0, f, alpha, d), 2));
    const TableEntry b = kTable3[d - 1];
    const double log_factor = std::pow(b.a0 + b.a1 * std::log(m), 2);
    if (r >= d + 1) {
      const std::optional<double> inverse = TableInverseEdf(kTable2, alpha, d, r);
      if (!inverse) return std::nullopt;
      return *inverse / log_factor;
    }
    const double m_prime = kJmax / r;
    return BasicSum(kJmax, kJmax, m_prime, m_prime, alpha, d) / (kJmax * log_factor);
  }
  // Case 4: unmodified, white PM (alpha = 2).
  const double K = std::ceil(r);
  const double c2d = Binomial(2 * d, d);
  if (K <= d) {
    double sum = 0.0;
    for (int k = 1; k < K; ++k) sum += (1.0 - k / r) * std::pow(Binomial(2 * d, d - k), 2);
    return (1.0 + 2.0 * sum / (c2d * c2d)) / M;
  }
  const double a0 = Binomial(4 * d, 2 * d) / (c2d * c2d);
  const double a1 = d / 2.0;
  return (a0 - a1 / r) / M;
}

}  // namespace

double SimpleErrorFraction(int64_t clusters) {
  if (clusters < 2) return std::nan("");
  return 1.0 / std::sqrt(2.0 * static_cast<double>(clusters - 1));
}

double RegularizedGammaP(double a, double x) {
  if (!(a > 0.0) || !(x >= 0.0)) return std::nan("");
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  if (x < a + 1.0) return GammaPSeries(a, x);
  return 1.0 - GammaQContinuedFraction(a, x);
}

// Newton's method on g(x) = P(nu/2, x/2) - p (or q - Q(nu/2, x/2) with
// q = 1 - p for p > 1/2, so that the smaller tail is matched without
// cancellation), g' = chi-square density, kept inside a bracket that shrinks
// with every evaluation; a step leaving the bracket is replaced by bisection.
// Start: Wilson-Hilferty x0 = nu (1 - 2/(9nu) + z sqrt(2/(9nu)))^3, or for a
// far lower tail the leading term of the series, x0 = 2 (p Gamma(a+1))^{1/a}.
double Chi2Inv(double p, double nu) {
  if (std::isnan(p) || !(nu > 0.0)) return std::nan("");
  if (p <= 0.0) return 0.0;
  if (p >= 1.0) return kInf;
  const double a = 0.5 * nu;
  const bool upper = p > 0.5;
  const double target = upper ? 1.0 - p : p;
  const auto g = [&](double x) {
    return upper ? target - RegularizedGammaQ(a, 0.5 * x) : RegularizedGammaP(a, 0.5 * x) - target;
  };
  const double log_gamma_a = std::lgamma(a);
  const auto density = [&](double x) {
    return 0.5 * std::exp((a - 1.0) * std::log(0.5 * x) - 0.5 * x - log_gamma_a);
  };

  const double h = 2.0 / (9.0 * nu);
  double x = nu * std::pow(1.0 - h + ApproximateNormalQuantile(p) * std::sqrt(h), 3);
  if (!(x > 0.0) || !std::isfinite(x)) x = 2.0 * std::exp((std::log(p) + std::lgamma(a + 1.0)) / a);
  double lo = 0.0;
  double hi = kInf;
  for (int iteration = 0; iteration < 500; ++iteration) {
    const double gx = g(x);
    if (gx == 0.0) return x;
    if (gx < 0.0) {
      lo = x;
    } else {
      hi = x;
    }
    double next = x - gx / density(x);
    if (!(next > lo && next < hi)) next = std::isinf(hi) ? 2.0 * x : 0.5 * (lo + hi);
    if (std::fabs(next - x) <= 4.0 * kEpsilon * x) return next;
    x = next;
  }
  return x;
}

std::optional<double> GreenhallEdf(int alpha, int d, int64_t m, int64_t n_phase, double F,
                                   double S) {
  if (d < 1 || d > 3 || alpha < -4 || alpha > 2 || alpha + 2 * d <= 1) return std::nullopt;
  if (m < 1 || !(F > 0.0) || !(S > 0.0)) return std::nullopt;
  const std::optional<double> inverse =
      GreenhallInverseEdf(alpha, d, static_cast<double>(m), static_cast<double>(n_phase), F, S);
  if (!inverse || !(*inverse > 0.0) || !std::isfinite(*inverse)) return std::nullopt;
  return 1.0 / *inverse;
}

std::optional<double> GreenhallMixtureEdf(std::span<const PowerLawShare> shares, int d, int64_t m,
                                          int64_t n_phase, double S) {
  if (d < 1 || d > 3 || m < 1 || !(S > 0.0) || shares.empty()) return std::nullopt;
  double total = 0;
  for (const PowerLawShare& p : shares) {
    if (p.alpha < -4 || p.alpha > 0 || p.alpha + 2 * d <= 1 || !(p.share >= 0)) return std::nullopt;
    total += p.share;
  }
  if (!(total > 0) || !std::isfinite(total)) return std::nullopt;
  constexpr double kJmax = 100.0;
  const double md = static_cast<double>(m), F = md;
  const double L = md / F + md * d;
  if (static_cast<double>(n_phase) < L) return std::nullopt;
  const double M = 1.0 + std::floor(S * (static_cast<double>(n_phase) - L) / md);
  double J = std::min(M, std::floor((d + 1) * S));
  if (J < 1) return std::nullopt;
  double m_count = M, s = S, f = md * (d + 1) <= kJmax ? F : kInf;
  if (J > kJmax) {
    // The same r = M / S on a lag grid of at most kJmax steps.
    const double r = M / S;
    s = r >= d + 1 ? kJmax / (d + 1) : kJmax / r;
    m_count = r * s;
    J = kJmax;
    f = kInf;
  }
  // The mixture's sz at lag j / s, each noise's scaled to its share.
  const int count = static_cast<int>(J) + 1;
  std::vector<double> sz(count, 0.0);
  for (const PowerLawShare& p : shares) {
    if (!(p.share > 0)) continue;
    const double* own = SzAt(s, f, p.alpha, d, count);
    if (!(own[0] != 0) || !std::isfinite(own[0])) return std::nullopt;
    for (int j = 0; j < count; ++j) sz[j] += p.share / total * own[j] / own[0];
  }
  const double inverse = BasicSumOf(sz.data(), J, m_count) / (m_count * sz[0] * sz[0]);
  if (!(inverse > 0.0) || !std::isfinite(inverse)) return std::nullopt;
  return 1.0 / inverse;
}

std::optional<double> TotalDeviationEdf(int alpha, int64_t m, int64_t n_phase) {
  if (m < 1) return std::nullopt;
  double b = 0.0;
  double c = 0.0;
  switch (alpha) {
    case 0:
      b = 1.50;
      c = 0.0;
      break;
    case -1:
      b = 1.17;
      c = 0.22;
      break;
    case -2:
      b = 0.93;
      c = 0.36;
      break;
    default: {
      const double md = static_cast<double>(m);
      return GreenhallEdf(alpha, 2, m, n_phase, md, md);
    }
  }
  const double edf = b * static_cast<double>(n_phase) / static_cast<double>(m) - c;
  if (!(edf > 0.0)) return std::nullopt;
  return edf;
}

std::optional<double> Theo1Edf(int alpha, int64_t m, int64_t n_phase) {
  if (m < 2 || m > n_phase - 1) return std::nullopt;
  const double n = static_cast<double>(n_phase);
  const double r = 0.75 * static_cast<double>(m);
  double edf = 0.0;
  switch (alpha) {
    case 2:
      edf = 0.86 * (n + 1.0) * (n - 4.0 * r / 3.0) / (n - r) * (r / (r + 1.14));
      break;
    case 1:
      edf = (4.798 * n * n - 6.374 * n * r + 12.387 * r) / (std::sqrt(r + 36.6) * (n - r)) *
            (r / (r + 0.3));
      break;
    case 0: {
      const double r15 = r * std::sqrt(r);
      edf = ((4.1 * n + 0.8) / r - (3.1 * n + 6.5) / n) * (r15 / (r15 + 5.2));
      break;
    }
    case -1:
      edf = (2.0 * n * n - 1.3 * n * r - 3.5 * r) / (n * r) * (r * r * r / (r * r * r + 2.3));
      break;
    case -2: {
      const double a = 4.4 * n - 1.0;
      edf = (4.4 * n - 2.0) / (2.9 * r) *
            ((a * a - 8.6 * r * a + 11.4 * r * r) / ((4.4 * n - 3.0) * (4.4 * n - 3.0)));
      break;
    }
    default:
      return std::nullopt;
  }
  if (!(edf > 0.0) || !std::isfinite(edf)) return std::nullopt;
  return edf;
}

std::optional<double> Theo1EdfMeasured(int alpha, int64_t m, int64_t n_phase) {
  if (m < 2 || m > n_phase - 1) return std::nullopt;
  // r / N = 0.10, 0.15, ..., 0.75 (theo1_edf_bench, 4000 records of 4096
  // points per noise; 2048 points gave the same to a few percent: for these
  // noises Theo1's distribution at r = c N depends on c alone).
  static constexpr std::array<double, 14> kWhiteFm = {
      40.51, 27.12, 20.30, 16.00, 13.08, 11.10, 9.68, 8.51, 7.31, 6.22, 5.23, 4.36, 3.59, 2.97};
  static constexpr std::array<double, 14> kFlickerFm = {17.79, 11.05, 8.04, 6.33, 5.20, 4.38, 3.75,
                                                        3.24,  2.84,  2.48, 2.18, 1.93, 1.74, 1.65};
  static constexpr std::array<double, 14> kRandomWalkFm = {
      11.77, 7.60, 5.58, 4.33, 3.50, 2.90, 2.48, 2.15, 1.89, 1.68, 1.52, 1.39, 1.30, 1.26};
  const double c = 0.75 * static_cast<double>(m) / static_cast<double>(n_phase);
  if (alpha > 0 || alpha < -2 || c < 0.1) return Theo1Edf(alpha, m, n_phase);
  const std::array<double, 14>& t = alpha == 0    ? kWhiteFm
                                    : alpha == -1 ? kFlickerFm
                                                  : kRandomWalkFm;
  const double at = std::min((c - 0.1) / 0.05, 13.0);
  const int i = std::min(static_cast<int>(at), 12);
  return t[i] + (at - i) * (t[i + 1] - t[i]);
}

std::optional<double> ModifiedTotalEdf(int alpha, int64_t m, int64_t n_phase) {
  if (m < 1) return std::nullopt;
  static constexpr std::array<std::array<double, 2>, 5> kBc = {{
      {0.75, 0.31},  // alpha -2
      {0.85, 0.50},  // alpha -1
      {1.10, 1.20},  // alpha 0
      {1.20, 1.40},  // alpha 1
      {1.90, 2.10},  // alpha 2
  }};
  if (alpha < -2 || alpha > 2) return std::nullopt;
  const auto [b, c] = kBc[alpha + 2];
  const double edf = b * static_cast<double>(n_phase) / static_cast<double>(m) - c;
  if (!(edf > 0.0)) return std::nullopt;
  return edf;
}

std::optional<double> HadamardTotalEdf(int alpha, int64_t m, int64_t n_phase) {
  if (m < 1) return std::nullopt;
  static constexpr std::array<std::array<double, 2>, 5> kB01 = {{
      {1.276, 3.149},  // alpha -4
      {0.974, 2.554},  // alpha -3
      {0.938, 1.696},  // alpha -2
      {0.868, 1.140},  // alpha -1
      {0.559, 1.004},  // alpha 0
  }};
  const double md = static_cast<double>(m);
  if (m < 16 || alpha < -4 || alpha > 0) return GreenhallEdf(alpha, 3, m, n_phase, md, md);
  const auto [b0, b1] = kB01[alpha + 4];
  const double ratio = static_cast<double>(n_phase) / md;  // T/tau
  const double edf = ratio / (b0 + b1 / ratio);
  if (!(edf > 0.0) || !std::isfinite(edf)) return std::nullopt;
  return edf;
}

std::optional<double> DeviationEdf(Deviation dev, int alpha, int64_t m, int64_t n_phase) {
  const double md = static_cast<double>(m);
  switch (dev) {
    case Deviation::kAdev:
      return GreenhallEdf(alpha, 2, m, n_phase, md, 1.0);
    case Deviation::kOadev:
      return GreenhallEdf(alpha, 2, m, n_phase, md, md);
    case Deviation::kMdev:
    case Deviation::kTdev:
      return GreenhallEdf(alpha, 2, m, n_phase, 1.0, md);
    case Deviation::kHdev:
      return GreenhallEdf(alpha, 3, m, n_phase, md, 1.0);
    case Deviation::kOhdev:
      return GreenhallEdf(alpha, 3, m, n_phase, md, md);
    case Deviation::kTotdev:
      return TotalDeviationEdf(alpha, m, n_phase);
    case Deviation::kTheo1:
    case Deviation::kTheoBr:
      return Theo1EdfMeasured(alpha, m, n_phase);
    case Deviation::kTheoH:
      return TheoHIsAllanPoint(m, n_phase) ? GreenhallEdf(alpha, 2, m, n_phase, md, md)
                                           : Theo1EdfMeasured(alpha, m, n_phase);
    case Deviation::kMtotdev:
    case Deviation::kTtotdev:
      return ModifiedTotalEdf(alpha, m, n_phase);
    case Deviation::kHtotdev:
      return HadamardTotalEdf(alpha, m, n_phase);
  }
  return std::nullopt;
}

std::pair<double, double> Chi2Interval(double dev, double edf, double confidence) {
  const double nan = std::nan("");
  if (!std::isfinite(dev) || !std::isfinite(edf) || !(edf > 0.0) || !(confidence > 0.0) ||
      !(confidence < 1.0)) {
    return {nan, nan};
  }
  // The factors sqrt(edf / chi2inv) depend on (edf, confidence) alone; each
  // thread keeps the last kMaxFactors it computed (every axis of a station
  // has the same edf at the same m, and each costs two Chi2Inv iterations).
  // A kept factor is the one computed again, bit for bit.
  struct Key {
    uint64_t edf, confidence;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return static_cast<size_t>(k.edf * 0x9e3779b97f4a7c15ULL ^ k.confidence);
    }
  };
  constexpr size_t kMaxFactors = 4096;
  thread_local std::unordered_map<Key, std::pair<double, double>, KeyHash> factors;
  Key key;
  std::memcpy(&key.edf, &edf, sizeof edf);
  std::memcpy(&key.confidence, &confidence, sizeof confidence);
  auto it = factors.find(key);
  if (it == factors.end()) {
    if (factors.size() >= kMaxFactors) factors.clear();
    const double p = 0.5 * (1.0 - confidence);
    it = factors
             .emplace(key, std::pair{std::sqrt(edf / Chi2Inv(1.0 - p, edf)),
                                     std::sqrt(edf / Chi2Inv(p, edf))})
             .first;
  }
  const double lo = dev * it->second.first;
  const double hi = dev * it->second.second;
  return {lo, hi};
}

namespace {

// The gap-free record length that gives `n` terms of `dev` at m (the inverse
// of the term counts in estimators.h), capped at n_phase.
int64_t EquivalentPhaseLength(Deviation dev, int64_t m, int64_t n, int64_t n_phase) {
  int64_t length = n_phase;
  switch (dev) {
    case Deviation::kAdev:
      length = (n + 1) * m + 1;
      break;
    case Deviation::kOadev:
      length = n + 2 * m;
      break;
    case Deviation::kMdev:
    case Deviation::kTdev:
      length = n + 3 * m - 1;
      break;
    case Deviation::kHdev:
      length = (n + 2) * m + 1;
      break;
    case Deviation::kOhdev:
      length = n + 3 * m;
      break;
    case Deviation::kTotdev:
      length = n + 2;
      break;
    default:  // the long-tau estimators use the longest gap-free span (AttachConfidence)
      break;
  }
  return std::min(length, n_phase);
}

void ClearInterval(CurvePoint* point) {
  point->lo = kNaN;
  point->hi = kNaN;
  point->edf = kNaN;
  point->alpha.reset();
  point->alpha_inherited = false;
}

}  // namespace

std::optional<int> NearestIdentifiedAlpha(const std::vector<std::optional<int>>& alphas, size_t i) {
  if (i < alphas.size() && alphas[i]) return alphas[i];
  for (size_t d = 1; d < alphas.size(); ++d) {
    if (i >= d && i - d < alphas.size() && alphas[i - d]) return alphas[i - d];
    if (i + d < alphas.size() && alphas[i + d]) return alphas[i + d];
  }
  return std::nullopt;
}

void AttachConfidence(const PhaseRecord& phase, CiMethod method, double confidence, Curve* curve) {
  curve->ci = method;
  curve->confidence = method == CiMethod::kSimple ? kOneSigmaConfidence : confidence;
  const Deviation dev = curve->deviation;
  // The long-tau estimators use the longest gap-free span (long_tau.h).
  const bool long_tau = IsLongTauDeviation(dev);
  const int64_t span_phase = LongestValidSpan(phase).size();
  const int64_t valid_rate_samples =
      long_tau ? std::max<int64_t>(span_phase - 1, 0)
               : std::max<int64_t>(phase.size() - 1, 0) - phase.invalid_count();
  const bool has_gaps = phase.invalid_count() > 0;
  const int dmax =
      (dev == Deviation::kHdev || dev == Deviation::kOhdev || dev == Deviation::kHtotdev) ? 3 : 2;
  const auto cluster_factor = [&](const CurvePoint& point) {
    return EffectiveAveragingFactor(dev, point.m, long_tau ? span_phase : phase.size());
  };
  for (CurvePoint& point : curve->points) ClearInterval(&point);
  if (method == CiMethod::kChi2) {
    // Each point's own lag-1 identification, then the long-tau rule (a point
    // too short to identify takes its nearest identified neighbour's alpha,
    // the shorter tau on a tie, as Stable32 carries the last identified noise
    // type to the end of a curve).
    std::vector<std::optional<int>> own;
    for (const CurvePoint& point : curve->points) {
      const int64_t id_m = std::max<int64_t>(1, std::llround(cluster_factor(point)));
      const std::optional<NoiseId> id =
          point.m < 1 ? std::nullopt : IdentifyNoiseLag1(phase, id_m, dmax);
      own.push_back(id ? std::optional<int>(id->alpha) : std::nullopt);
    }
    for (size_t i = 0; i < curve->points.size(); ++i) {
      CurvePoint& point = curve->points[i];
      if (point.m < 1) continue;
      point.alpha = NearestIdentifiedAlpha(own, i);
      point.alpha_inherited = point.alpha.has_value() && !own[i].has_value();
    }
  }
  for (CurvePoint& point : curve->points) {
    if (point.m < 1) continue;
    switch (method) {
      case CiMethod::kNone:
        break;
      case CiMethod::kSimple: {
        // K clusters of the point's tau: of 0.75 m samples for the Theo points.
        const double factor = cluster_factor(point);
        const int64_t clusters = factor == static_cast<double>(point.m)
                                     ? valid_rate_samples / point.m
                                     : static_cast<int64_t>(std::floor(
                                           static_cast<double>(valid_rate_samples) / factor));
        if (clusters < 2) break;
        const double fraction = SimpleErrorFraction(clusters);
        point.lo = point.dev * (1.0 - fraction);
        point.hi = point.dev * (1.0 + fraction);
        point.edf = static_cast<double>(clusters - 1);
        break;
      }
      case CiMethod::kChi2: {
        if (!point.alpha) break;
        const int64_t n_phase = long_tau ? span_phase
                                : has_gaps
                                    ? EquivalentPhaseLength(dev, point.m, point.n, phase.size())
                                    : phase.size();
        const std::optional<double> edf = DeviationEdf(dev, *point.alpha, point.m, n_phase);
        if (!edf) break;
        const auto [lo, hi] = Chi2Interval(point.dev, *edf, confidence);
        if (std::isnan(lo) || std::isnan(hi)) break;
        point.edf = *edf;
        point.lo = lo;
        point.hi = hi;
        break;
      }
    }
  }
}

}  // namespace imuqual::allan
