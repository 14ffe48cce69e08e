#include "analyze/judge/statistics.h"

#include <algorithm>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <numeric>

#include "analyze/judge/judge.h"

namespace imuqual::judge {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// log of the hypergeometric probability of k passes in sample a.
double LogHypergeometric(int64_t k, int64_t n_a, int64_t passes, int64_t n) {
  auto log_choose = [](int64_t nn, int64_t kk) {
    return std::lgamma(static_cast<double>(nn) + 1) - std::lgamma(static_cast<double>(kk) + 1) -
           std::lgamma(static_cast<double>(nn - kk) + 1);
  };
  return log_choose(passes, k) + log_choose(n - passes, n_a - k) - log_choose(n, n_a);
}

}  // namespace

Summary Summarize(std::span<const double> values, std::span<const pb::Outcome> outcomes,
                  std::optional<double> low, std::optional<double> high) {
  Summary s;
  double sum = 0;
  for (size_t i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (i < outcomes.size() && outcomes[i] == pb::INCONCLUSIVE) ++s.inconclusive;
    // Yield counts PASS and MARGINAL against PASS, MARGINAL and FAIL: an
    // INCONCLUSIVE value is neither a pass nor a loss (and ABORTED / ERROR
    // are no measurement's outcome).
    if (i < outcomes.size() && (Accepted(outcomes[i]) || outcomes[i] == pb::FAIL)) {
      ++s.judged;
      if (Accepted(outcomes[i])) ++s.passed;
      if (outcomes[i] == pb::MARGINAL) ++s.marginal;
    }
    if (!std::isfinite(v)) continue;
    ++s.n;
    sum += v;
    s.min = s.n == 1 ? v : std::min(s.min, v);
    s.max = s.n == 1 ? v : std::max(s.max, v);
  }
  if (s.judged > 0) s.yield = static_cast<double>(s.passed) / static_cast<double>(s.judged);
  if (s.n == 0) return s;
  s.mean = sum / static_cast<double>(s.n);
  if (s.n >= 2) {
    double ss = 0;  // two-pass: no cancellation
    for (double v : values) {
      if (std::isfinite(v)) ss += (v - s.mean) * (v - s.mean);
    }
    s.sd = std::sqrt(ss / static_cast<double>(s.n - 1));
  }
  s.capability_kind = high && low ? "Cpk" : high ? "Cpu" : low ? "Cpl" : "";
  if (std::isfinite(s.sd) && s.sd > 0 && s.n >= kMinCapabilityN) {
    const double upper = high ? (*high - s.mean) / (3 * s.sd) : kNaN;
    const double lower = low ? (s.mean - *low) / (3 * s.sd) : kNaN;
    s.capability = high && low ? std::min(upper, lower) : high ? upper : lower;
    if (std::isfinite(s.capability)) {
      const double n = static_cast<double>(s.n);
      const double half = 1.959963984540054 *
                          std::sqrt(1 / (9 * n) + s.capability * s.capability / (2 * (n - 1)));
      s.capability_low = s.capability - half;
      s.capability_high = s.capability + half;
    }
  }
  return s;
}

// t = (ma - mb) / sqrt(va/na + vb/nb), Welch-Satterthwaite degrees of freedom
// df = (va/na + vb/nb)^2 / ((va/na)^2/(na-1) + (vb/nb)^2/(nb-1)).
TestResult WelchTTest(const Summary& a, const Summary& b) {
  TestResult r;
  if (a.n < 2 || b.n < 2) return r;
  const double qa = a.sd * a.sd / static_cast<double>(a.n);
  const double qb = b.sd * b.sd / static_cast<double>(b.n);
  if (!(qa + qb > 0)) return r;
  r.statistic = (a.mean - b.mean) / std::sqrt(qa + qb);
  const double df = (qa + qb) * (qa + qb) /
                    (qa * qa / static_cast<double>(a.n - 1) + qb * qb / static_cast<double>(b.n - 1));
  const boost::math::students_t dist(df);
  r.p_value = 2 * boost::math::cdf(boost::math::complement(dist, std::abs(r.statistic)));
  return r;
}

// F = va / vb with (na - 1, nb - 1) degrees of freedom; p = 2 min(P(F), 1 - P(F)).
TestResult VarianceFTest(const Summary& a, const Summary& b) {
  TestResult r;
  if (a.n < 2 || b.n < 2 || !(a.sd > 0) || !(b.sd > 0)) return r;
  r.statistic = a.sd * a.sd / (b.sd * b.sd);
  const boost::math::fisher_f dist(static_cast<double>(a.n - 1), static_cast<double>(b.n - 1));
  const double lower = boost::math::cdf(dist, r.statistic);
  r.p_value = std::min(1.0, 2 * std::min(lower, 1 - lower));
  return r;
}

// Two-sided: the total probability, under the hypergeometric law with the
// margins fixed, of every table no more likely than the one observed.
TestResult FisherExactTest(int64_t passed_a, int64_t n_a, int64_t passed_b, int64_t n_b) {
  TestResult r;
  if (n_a < 1 || n_b < 1 || passed_a < 0 || passed_b < 0 || passed_a > n_a || passed_b > n_b) {
    return r;
  }
  r.statistic = static_cast<double>(passed_a) / static_cast<double>(n_a) -
                static_cast<double>(passed_b) / static_cast<double>(n_b);
  const int64_t n = n_a + n_b, passes = passed_a + passed_b;
  const double observed = LogHypergeometric(passed_a, n_a, passes, n);
  const int64_t k_min = std::max<int64_t>(0, passes - n_b), k_max = std::min(passes, n_a);
  constexpr double kRelativeTolerance = 1e-7;  // ties in floating point count as equal
  double p = 0;
  for (int64_t k = k_min; k <= k_max; ++k) {
    const double lp = LogHypergeometric(k, n_a, passes, n);
    if (lp <= observed + kRelativeTolerance) p += std::exp(lp);
  }
  r.p_value = std::min(1.0, p);
  return r;
}

std::vector<bool> HolmSignificant(std::span<const double> p_values, double alpha) {
  std::vector<size_t> order;
  for (size_t i = 0; i < p_values.size(); ++i) {
    if (std::isfinite(p_values[i])) order.push_back(i);
  }
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return p_values[x] < p_values[y]; });
  std::vector<bool> significant(p_values.size(), false);
  const size_t m = order.size();
  for (size_t rank = 0; rank < m; ++rank) {
    if (p_values[order[rank]] > alpha / static_cast<double>(m - rank)) break;
    significant[order[rank]] = true;
  }
  return significant;
}

}  // namespace imuqual::judge
