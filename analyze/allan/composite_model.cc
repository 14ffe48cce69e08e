#include "analyze/allan/composite_model.h"

#include <algorithm>
#include <array>
#include <boost/math/special_functions/digamma.hpp>
#include <cmath>
#include <complex>
#include <numbers>

namespace imuqual::allan {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kFlickerAvarFactor = 2.0 * std::numbers::ln2 / std::numbers::pi;

// sinh(x) - x for x >= 0, by its series below 1 (no cancellation).
double SinhMinusX(double x) {
  if (x >= 1.0) return std::sinh(x) - x;
  double term = x * x * x / 6.0, sum = 0;
  for (int n = 3; term > 1e-18 * sum || sum == 0; n += 2) {
    sum += term;
    term *= x * x / ((n + 1.0) * (n + 2.0));
    if (term == 0) break;
  }
  return sum;
}

// G(y) = 2y - 3 + 4 e^-y - e^-2y = sum_{n>=3} (-1)^n (4 - 2^n) y^n / n!, y >= 0.
// With u = e^-y - 1, G = 2 (y + u) - u^2: one expm1, relative error about
// 3 eps / y (the y^2 parts cancel); below 0.2 the series (at most a dozen
// terms) keeps it at a few eps.
double GaussMarkovG(double y) {
  if (y >= 0.2) {
    const double u = std::expm1(-y);
    return 2.0 * (y + u) - u * u;
  }
  double power = y * y * y / 6.0;  // y^n / n!
  double two_n = 8.0, sum = 0;
  for (int n = 3; n < 60; ++n) {
    const double term = ((n % 2 == 0) ? 1.0 : -1.0) * (4.0 - two_n) * power;
    sum += term;
    if (std::fabs(term) <= 1e-18 * std::fabs(sum)) break;
    power *= y / (n + 1.0);
    two_n *= 2.0;
  }
  return sum;
}

double GaussMarkovAvar(double sigma, double t_s, double m, double tau0_s) {
  const double x = tau0_s / t_s;
  if (x > 30.0) return sigma * sigma / m;  // e^-30: white to double precision
  const double sh = std::sinh(0.5 * x);
  const double f = (2.0 * m * SinhMinusX(x) + GaussMarkovG(m * x)) / (4.0 * sh * sh);
  return sigma * sigma * f / (m * m);
}

}  // namespace

std::string_view TermKindName(TermKind kind) {
  switch (kind) {
    case TermKind::kQuantization:
      return "quantization";
    case TermKind::kWhite:
      return "white";
    case TermKind::kFlicker:
      return "flicker";
    case TermKind::kRandomWalk:
      return "random_walk";
    case TermKind::kDrift:
      return "drift";
    case TermKind::kGaussMarkov:
      return "gauss_markov";
    case TermKind::kSinusoid:
      return "sinusoid";
  }
  return "";
}

std::string_view TermKindSymbol(TermKind kind) {
  switch (kind) {
    case TermKind::kQuantization:
      return "Q";
    case TermKind::kWhite:
      return "N";
    case TermKind::kFlicker:
      return "B";
    case TermKind::kRandomWalk:
      return "K";
    case TermKind::kDrift:
      return "R";
    case TermKind::kGaussMarkov:
      return "GM";
    case TermKind::kSinusoid:
      return "S";
  }
  return "";
}

double TermAvar(const ModelTerm& t, double m, double tau0_s) {
  const double tau = m * tau0_s;
  const double s2 = t.scale * t.scale;
  switch (t.kind) {
    case TermKind::kQuantization:
      return 3.0 * s2 / (tau * tau);
    case TermKind::kWhite:
      return s2 / tau;
    case TermKind::kFlicker:
      return kFlickerAvarFactor * s2;
    case TermKind::kRandomWalk:
      return s2 * tau0_s * (2.0 * m * m + 1.0) / (6.0 * m);
    case TermKind::kDrift:
      return 0.5 * s2 * tau * tau;
    case TermKind::kGaussMarkov:
      return GaussMarkovAvar(t.scale, t.correlation_time_s, m, tau0_s);
    case TermKind::kSinusoid: {
      const double f = t.frequency_hz * tau0_s;
      const double s = std::sin(kPi * f * m), d = std::sin(kPi * f);
      return s2 * s * s * s * s / (m * m * d * d);
    }
  }
  return 0;
}

double TermPsd(const ModelTerm& t, double f, double tau0_s) {
  const double s2 = t.scale * t.scale;
  switch (t.kind) {
    case TermKind::kQuantization: {
      const double sin_pf = std::sin(kPi * f);
      return s2 / (tau0_s * tau0_s) * 4.0 * sin_pf * sin_pf;
    }
    case TermKind::kWhite:
      return s2 / tau0_s;
    case TermKind::kFlicker:
      return s2 / (2.0 * kPi * f);
    case TermKind::kRandomWalk: {
      const double sin_pf = std::sin(kPi * f);
      return s2 * tau0_s / (4.0 * sin_pf * sin_pf);
    }
    case TermKind::kGaussMarkov: {
      const double phi = std::exp(-tau0_s / t.correlation_time_s);
      const double innovation = s2 * (1.0 - phi * phi);
      return innovation / (1.0 - 2.0 * phi * std::cos(2.0 * kPi * f) + phi * phi);
    }
    case TermKind::kDrift:
    case TermKind::kSinusoid:
      return 0;
  }
  return 0;
}

namespace {

// A Gauss-Markov term's Var(u_k) / (tau0 sigma)^2 from its phase structure
// function D(n) = tau0^2 sigma^2 [n coth(x/2) - (1 - e^-nx) / (2 sinh^2(x/2))],
// x = tau0 / T (the geometric sums of sigma^2 phi^|j|). For T >> tau0 both
// parts are ~2n/x and D ~ n^2, and the four D's cancel again to ~x n^3:
// long double keeps ~eps_ld / (x n)^2 (1e-10 at x n = 4e-5).
struct GaussMarkovPair {
  using Long = long double;
  explicit GaussMarkovPair(double x_in)
      : x(x_in),
        half_over_sh2(1 / (2 * std::sinh(x / 2) * std::sinh(x / 2))),
        coth(1 / std::tanh(x / 2)) {}
  Long D(Long n) const { return n * coth + std::expm1(-n * x) * half_over_sh2; }
  double Variance(double m, double k) const {
    const Long mm = m, kk = k;
    return static_cast<double>(2 * D(kk) + 2 * D(mm - kk) - D(mm) - D(mm - 2 * kk));
  }
  Long x, half_over_sh2, coth;
};

// TermTheo1PairVariance at real m and k (the closed forms are smooth in k;
// SmoothSum samples them between integers). `half`: k == m / 2, where the
// quantization's two middle points coincide.
double PairVariance(const ModelTerm& t, double m, double k, bool half, double tau0_s) {
  const double s2 = t.scale * t.scale;
  const double tau0_2 = tau0_s * tau0_s;
  switch (t.kind) {
    case TermKind::kQuantization:
      return (half ? 6.0 : 4.0) * s2;
    case TermKind::kWhite:
      return 2.0 * s2 * tau0_s * k;
    case TermKind::kFlicker: {
      // -1/2 sum c_a c_b D = sum c_a c_b G over the four points, G(s) = C s^2
      // ln s (the ln tau0 part cancels: the coefficients remove a line).
      // In long double: for k << m the four terms (~m^2 ln m) cancel to
      // ~k^2 ln(m/k), losing ~m^2 / k^2 of the precision.
      using Long = long double;
      const double c = kFlickerAvarFactor / (4.0 * std::numbers::ln2) * s2 * tau0_2;
      auto g = [](Long d) { return d > 0 ? d * d * std::log(d) : Long{0}; };
      const Long mm = m, kk = k;
      return 2.0 * c * static_cast<double>(g(mm) + g(mm - 2 * kk) - 2 * g(mm - kk) - 2 * g(kk));
    }
    case TermKind::kRandomWalk:
      return s2 * tau0_2 * tau0_s * k * k * (3.0 * m - 4.0 * k) / 3.0 +
             2.0 * (s2 * tau0_2 / 6.0) * tau0_s * k;
    case TermKind::kDrift: {
      const double v = t.scale * tau0_2 * k * (m - k);
      return v * v;
    }
    case TermKind::kGaussMarkov:
      return tau0_2 * s2 * GaussMarkovPair(tau0_s / t.correlation_time_s).Variance(m, k);
    case TermKind::kSinusoid: {
      const double f = t.frequency_hz * tau0_s;
      const double a = std::sin(kPi * f * k), b = std::sin(kPi * f * (m - k)),
                   s = std::sin(kPi * f);
      return 2.0 * tau0_2 * s2 * a * a * b * b / (s * s);
    }
  }
  return 0;
}

// sum_{k=1}^{n} g(k) for a g that is smooth in k away from both ends on the
// scale of a few hundred: the first and last kExact terms exactly, the rest
// by the Euler-Maclaurin midpoint rule,
//   sum_{k=a}^{b} g(k) = int_{a-1/2}^{b+1/2} g - (g'(b+1/2) - g'(a-1/2)) / 24 + ...,
// the integral by 8-point Gauss-Legendre on panels growing by 10 % away from
// each end (g's features sit at k ~ 0 and at k ~ n, where m - 2k -> 0).
// About 1500 evaluations of g for any n; every term for n <= 8 kExact.
template <typename G>
double SmoothSum(G g, int64_t n) {
  constexpr int64_t kExact = 256;
  double sum = 0;
  if (n <= 8 * kExact) {
    for (int64_t k = 1; k <= n; ++k) sum += g(static_cast<double>(k));
    return sum;
  }
  for (int64_t k = 1; k <= kExact; ++k) sum += g(static_cast<double>(k));
  for (int64_t k = n - kExact + 1; k <= n; ++k) sum += g(static_cast<double>(k));
  static constexpr std::array<double, 4> kNode = {0.1834346424956498, 0.5255324099163290,
                                                  0.7966664774136267, 0.9602898564975363};
  static constexpr std::array<double, 4> kWeight = {0.3626837833783620, 0.3137066458778873,
                                                    0.2223810344533745, 0.1012285362903763};
  auto panel = [&](double a, double b) {
    const double c = 0.5 * (a + b), h = 0.5 * (b - a);
    double s = 0;
    for (int i = 0; i < 4; ++i) s += kWeight[i] * (g(c - h * kNode[i]) + g(c + h * kNode[i]));
    return s * h;
  };
  const double lo = static_cast<double>(kExact) + 0.5;
  const double hi = static_cast<double>(n - kExact) + 0.5;
  const double mid = 0.5 * (lo + hi), top = static_cast<double>(n) + 0.5;
  for (double t = lo; t < mid;) {
    const double next = std::min(mid, 1.1 * t);
    sum += panel(t, next);
    t = next;
  }
  for (double d = top - hi; d < top - mid;) {  // distance from the upper end
    const double next = std::min(top - mid, 1.1 * d);
    sum += panel(top - next, top - d);
    d = next;
  }
  auto slope = [&](double x) { return g(x + 0.5) - g(x - 0.5); };
  return sum - (slope(hi) - slope(lo)) / 24.0;
}

// sum_{k=1}^{n} e^{i c k} / k. Where n |1 - e^{ic}| >= 30: -ln(1 - e^{ic})
// minus the tail sum_{k>n} z^k / k, summed by parts (Abel) into
// sum_j D^{j+1} z^{N+j} (-1)^j j! / (N (N+1) ... (N+j)), N = n + 1,
// D = 1 / (1 - z): each term is ~ j / 30 of the last, so a dozen reach
// 1e-12. Elsewhere e^{ick} / k is smooth in k (a period >= n / 5) and
// SmoothSum sums it.
std::complex<double> LogSeriesPartial(double c, int64_t n) {
  c = std::remainder(c, 2 * kPi);
  const double nn = static_cast<double>(n);
  if (nn * 2 * std::abs(std::sin(c / 2)) >= 30) {
    const std::complex<double> z = std::polar(1.0, c);
    const std::complex<double> d = 1.0 / (1.0 - z);
    const double big_n = nn + 1;
    std::complex<double> term = d * std::polar(1.0, std::remainder(c * big_n, 2 * kPi)) / big_n;
    std::complex<double> tail = term;
    for (int j = 1; j < 40 && std::abs(term) > 1e-17 * std::abs(tail); ++j) {
      term *= -d * z * static_cast<double>(j) / (big_n + j);
      tail += term;
    }
    return -std::log(1.0 - z) - tail;
  }
  const double re = SmoothSum([&](double k) { return std::cos(c * k) / k; }, n);
  const double im = SmoothSum([&](double k) { return std::sin(c * k) / k; }, n);
  return {re, im};
}

double Harmonic(int64_t n) {
  return n <= 64 ? SmoothSum([](double k) { return 1 / k; }, n)
                 : boost::math::digamma(static_cast<double>(n) + 1) + std::numbers::egamma;
}

}  // namespace

double TermTheo1PairVariance(const ModelTerm& t, int64_t m, int64_t k, double tau0_s) {
  return PairVariance(t, static_cast<double>(m), static_cast<double>(k), 2 * k == m, tau0_s);
}

double Theo1SinusoidSum(double f, int64_t m) {
  const int64_t n = m / 2;
  const double a = kPi * f;
  if (static_cast<double>(n) * 2 * std::abs(std::sin(a)) < 30) {
    // a m < ~30: the summand's period in k is >= m / 10, smooth.
    const double md = static_cast<double>(m);
    return SmoothSum(
        [&](double k) {
          const double s = std::sin(a * k), r = std::sin(a * (md - k));
          return s * s * r * r / k;
        },
        n);
  }
  // 4 sin^2(ak) sin^2(a(m-k)) = 1 - cos 2ak - cos 2a(m-k) + cos(2am)/2 +
  // cos 2a(2k-m) / 2, each a partial sum of the log series.
  const double h = Harmonic(n);
  const std::complex<double> e2 = LogSeriesPartial(2 * a, n), e4 = LogSeriesPartial(4 * a, n);
  const std::complex<double> rot =
      std::polar(1.0, std::remainder(2 * a * static_cast<double>(m), 2 * kPi));
  const double four = h * (1 + 0.5 * rot.real()) - e2.real() - (rot * std::conj(e2)).real() +
                      0.5 * (std::conj(rot) * e4).real();
  return 0.25 * four;
}

double TermExpectedTheo1(const ModelTerm& t, int64_t m, double tau0_s) {
  const int64_t n = m / 2;
  const double md = static_cast<double>(m), nd = static_cast<double>(n);
  const double s2 = t.scale * t.scale, tau0_3 = tau0_s * tau0_s * tau0_s;
  double sum = 0;  // sum_{k=1}^{m/2} Var(u_k) / k
  switch (t.kind) {
    case TermKind::kQuantization:
      sum = s2 * (4 * Harmonic(n) + 2 / nd);
      break;
    case TermKind::kWhite:
      sum = 2 * s2 * tau0_s * nd;
      break;
    case TermKind::kRandomWalk: {
      // sum k (3m - 4k) / 3 + 1 / 3 (the discrete walk's white part)
      const double s1 = nd * (nd + 1) / 2, sq = nd * (nd + 1) * (2 * nd + 1) / 6;
      sum = s2 * tau0_3 * (3 * md * s1 - 4 * sq + nd) / 3;
      break;
    }
    case TermKind::kDrift: {
      const double s1 = nd * (nd + 1) / 2, sq = nd * (nd + 1) * (2 * nd + 1) / 6;
      sum = s2 * tau0_3 * tau0_s * (md * md * s1 - 2 * md * sq + s1 * s1);
      break;
    }
    case TermKind::kSinusoid: {
      const double f = t.frequency_hz * tau0_s, s = std::sin(kPi * f);
      sum = 2 * tau0_s * tau0_s * s2 * Theo1SinusoidSum(f, m) / (s * s);
      break;
    }
    case TermKind::kFlicker:
      sum = SmoothSum([&](double k) { return PairVariance(t, md, k, false, tau0_s) / k; }, n);
      break;
    case TermKind::kGaussMarkov: {
      const GaussMarkovPair pair(tau0_s / t.correlation_time_s);
      sum = tau0_s * tau0_s * s2 * SmoothSum([&](double k) { return pair.Variance(md, k) / k; }, n);
      break;
    }
  }
  return sum / (0.75 * md * md * tau0_s * tau0_s);
}

double TermExpectedTheo1OfMeans(const ModelTerm& t, int64_t m, double tau0_s, int64_t block) {
  if (block <= 1) return TermExpectedTheo1(t, m, tau0_s);
  const double b = static_cast<double>(block), wide = b * tau0_s;
  // E[Theo1] is linear in the phase structure function: a white part of
  // variance v (possibly negative) adds v times the unit white term's.
  const auto white = [&](double v) {
    return v * TermExpectedTheo1(ModelTerm{TermKind::kWhite, 1.0}, m, wide);
  };
  switch (t.kind) {
    case TermKind::kQuantization:
    case TermKind::kWhite:
    case TermKind::kFlicker:
    case TermKind::kDrift:
      return TermExpectedTheo1(t, m, wide);
    case TermKind::kRandomWalk:
      // The walk's cubic kernel is the same; its discrete white part is
      // K^2 tau0^2 / 6 of the samples, not of the means.
      return TermExpectedTheo1(t, m, wide) +
             white(t.scale * t.scale * (tau0_s * tau0_s - wide * wide) / 6);
    case TermKind::kGaussMarkov: {
      // The samples' phase structure D at distances k b, summed as
      // TermExpectedTheo1 sums it (an AR(1) of the means plus a white part
      // would be the same in exact arithmetic, but the two cancel to many
      // digits where T << b tau0 or T >> m b tau0).
      const GaussMarkovPair pair(tau0_s / t.correlation_time_s);
      const double md = static_cast<double>(m);
      const double sum =
          tau0_s * tau0_s * t.scale * t.scale *
          SmoothSum([&](double k) { return pair.Variance(md * b, k * b) / k; }, m / 2);
      return sum / (0.75 * md * md * wide * wide);
    }
    case TermKind::kSinusoid: {
      // Sampled every b-th phase point: the means' sinusoid has amplitude
      // A |sin(pi f b)| / (b |sin(pi f)|) (f in cycles per sample) at b f,
      // folded into (0, 1/2] cycles per mean; none at multiples of 1/b.
      const double f = t.frequency_hz * tau0_s;
      double g = b * f - std::floor(b * f);
      if (g > 0.5) g = 1 - g;
      // |sin(pi b f)| = |sin(pi g)|, the form TermExpectedTheo1 divides by.
      const double amplitude = t.scale * std::abs(std::sin(kPi * g) / (b * std::sin(kPi * f)));
      if (!(g > 1e-12) || !(amplitude > 0)) return 0;
      return TermExpectedTheo1(ModelTerm{TermKind::kSinusoid, amplitude, 0, g / wide}, m, wide);
    }
  }
  return 0;
}

double CompositeModel::ExpectedTheo1(int64_t m, double tau0_s) const {
  double v = 0;
  for (const ModelTerm& t : terms) v += TermExpectedTheo1(t, m, tau0_s);
  return v;
}

double CompositeModel::Theo1BiasFactor(int64_t m, double tau0_s) const {
  return Avar(0.75 * static_cast<double>(m), tau0_s) / ExpectedTheo1(m, tau0_s);
}

double CompositeModel::Avar(double m, double tau0_s) const {
  double v = 0;
  for (const ModelTerm& t : terms) v += TermAvar(t, m, tau0_s);
  return v;
}

double CompositeModel::Deviation(double m, double tau0_s) const {
  return std::sqrt(Avar(m, tau0_s));
}

double CompositeModel::Psd(double f, double tau0_s) const {
  double s = 0;
  for (const ModelTerm& t : terms) s += TermPsd(t, f, tau0_s);
  return s;
}

ModelEvaluator::ModelEvaluator(const CompositeModel& model, double tau0_s) { Reset(model, tau0_s); }

void ModelEvaluator::Reset(const CompositeModel& model, double tau0_s) {
  Resize(model.terms.size(), tau0_s);
  for (size_t i = 0; i < model.terms.size(); ++i) SetTerm(i, model.terms[i]);
}

void ModelEvaluator::Resize(size_t terms, double tau0_s) {
  tau0_s_ = tau0_s;
  terms_.resize(terms);
}

void ModelEvaluator::SetTerm(size_t i, const ModelTerm& t) {
  const double tau0_s = tau0_s_;
  Term& e = terms_[i];
  e = Term{};
  e.kind = t.kind;
  e.s2 = t.scale * t.scale;
  // Each constant is the leading subexpression of TermAvar / TermPsd as
  // written there (C++ evaluates a * b * c as (a * b) * c).
  switch (t.kind) {
    case TermKind::kQuantization:
      e.a = 3.0 * e.s2;
      e.psd = e.s2 / (tau0_s * tau0_s) * 4.0;
      break;
    case TermKind::kWhite:
      e.psd = e.s2 / tau0_s;
      break;
    case TermKind::kFlicker:
      e.a = kFlickerAvarFactor * e.s2;
      break;
    case TermKind::kRandomWalk:
      e.a = e.s2 * tau0_s;
      e.psd = e.s2 * tau0_s;
      break;
    case TermKind::kDrift:
      e.a = 0.5 * e.s2;
      break;
    case TermKind::kGaussMarkov: {
      e.x = tau0_s / t.correlation_time_s;
      e.white = e.x > 30.0;
      if (!e.white) {
        const double sh = std::sinh(0.5 * e.x);
        e.a = SinhMinusX(e.x);
        e.b = 4.0 * sh * sh;
      }
      e.phi = std::exp(-tau0_s / t.correlation_time_s);
      e.psd = e.s2 * (1.0 - e.phi * e.phi);
      break;
    }
    case TermKind::kSinusoid: {
      const double f = t.frequency_hz * tau0_s;
      e.a = kPi * f;
      e.b = std::sin(kPi * f);
      break;
    }
  }
}

double ModelEvaluator::TermAvar(size_t i, double m) const {
  const Term& e = terms_[i];
  switch (e.kind) {
    case TermKind::kQuantization: {
      const double tau = m * tau0_s_;
      return e.a / (tau * tau);
    }
    case TermKind::kWhite:
      return e.s2 / (m * tau0_s_);
    case TermKind::kFlicker:
      return e.a;
    case TermKind::kRandomWalk:
      return e.a * (2.0 * m * m + 1.0) / (6.0 * m);
    case TermKind::kDrift: {
      const double tau = m * tau0_s_;
      return e.a * tau * tau;
    }
    case TermKind::kGaussMarkov: {
      // GaussMarkovAvar with sigma^2 = s2.
      if (e.white) return e.s2 / m;
      const double f = (2.0 * m * e.a + GaussMarkovG(m * e.x)) / e.b;
      return e.s2 * f / (m * m);
    }
    case TermKind::kSinusoid: {
      const double s = std::sin(e.a * m), d = e.b;
      return e.s2 * s * s * s * s / (m * m * d * d);
    }
  }
  return 0;
}

double ModelEvaluator::Avar(double m) const {
  double v = 0;
  for (size_t i = 0; i < terms_.size(); ++i) v += TermAvar(i, m);
  return v;
}

double ModelEvaluator::Psd(double f, double sin_pi_f) const {
  double s = 0;
  for (const Term& e : terms_) {
    switch (e.kind) {
      case TermKind::kQuantization:
        s += e.psd * sin_pi_f * sin_pi_f;
        break;
      case TermKind::kWhite:
        s += e.psd;
        break;
      case TermKind::kFlicker:
        s += e.s2 / (2.0 * kPi * f);
        break;
      case TermKind::kRandomWalk:
        s += e.psd / (4.0 * sin_pi_f * sin_pi_f);
        break;
      case TermKind::kGaussMarkov:
        s += e.psd / (1.0 - 2.0 * e.phi * std::cos(2.0 * kPi * f) + e.phi * e.phi);
        break;
      case TermKind::kDrift:
      case TermKind::kSinusoid:
        s += 0;
        break;
    }
  }
  return s;
}

int CompositeModel::CountOf(TermKind kind) const {
  int n = 0;
  for (const ModelTerm& t : terms) n += t.kind == kind;
  return n;
}

std::string CompositeModel::Name() const {
  static constexpr std::array<TermKind, 7> kOrder = {
      TermKind::kQuantization, TermKind::kWhite,       TermKind::kFlicker, TermKind::kRandomWalk,
      TermKind::kDrift,        TermKind::kGaussMarkov, TermKind::kSinusoid};
  std::string name;
  for (TermKind kind : kOrder) {
    const int n = CountOf(kind);
    if (n == 0) continue;
    if (!name.empty()) name += "+";
    if (n > 1) name += std::to_string(n);
    name += TermKindSymbol(kind);
  }
  return name.empty() ? "none" : name;
}

}  // namespace imuqual::allan
