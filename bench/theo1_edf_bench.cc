// Theo1's sampling distribution against NIST SP1065's edf (Theo1Edf), over
// the whole reach of Theo1 (effective factor r = 0.75 m up to 0.75 N): for
// each power-law noise (alpha 2 .. -2) and fraction c = r / N, Monte Carlo
// over seeded records of the edf that the fit's moments use, from the
// variance of ln Theo1 (psi'(nu/2)) and from its mean offset against the
// exact expectation (psi(nu/2) - ln(nu/2)).
// Prints "theo1_edf alpha c sp1065 mc_var mc_mean" lines.
#include <boost/math/special_functions/digamma.hpp>
#include <boost/math/special_functions/trigamma.hpp>
#include <boost/math/tools/roots.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/long_tau.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/power_law_testing.h"

namespace {

using imuqual::allan::testing::Flicker;
using imuqual::allan::testing::Integrate;
using imuqual::allan::testing::White;

// Phase of power-law noise alpha (rate PSD ~ f^alpha).
std::vector<double> Phase(int alpha, int64_t n, uint64_t seed) {
  switch (alpha) {
    case 2:
      return White(n, seed);
    case 1:
      return Flicker(n, seed);
    case 0:
      return Integrate(White(n, seed));
    case -1:
      return Integrate(Flicker(n, seed));
    default:
      return Integrate(Integrate(White(n, seed)));
  }
}

// The edf nu in [0.01, 1e6] at which `increasing(nu)` reaches `target`
// (bisection in ln nu).
template <typename F>
double EdfWhere(F increasing, double target) {
  double lo = 0.01, hi = 1e6;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    (increasing(mid) < target ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

}  // namespace

int main(int argc, char** argv) {
  const int64_t n = argc > 1 ? std::atoll(argv[1]) : 2048;
  const int records = argc > 2 ? std::atoi(argv[2]) : 1000;
  const std::vector<double> fractions = {0.02, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35,
                                         0.4,  0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75};
  std::vector<int> alphas = {2, 1, 0, -1, -2};
  if (argc > 3) alphas.assign(1, std::atoi(argv[3]));
  std::vector<int64_t> m_list;
  for (double c : fractions) {
    int64_t m = 2 * std::llround(c * static_cast<double>(n) / 0.75 / 2);
    m = std::min(m, n % 2 == 0 ? n - 2 : n - 1);
    m_list.push_back(m);
  }
  for (int alpha : alphas) {
    std::vector<std::vector<double>> logs(m_list.size()), values(m_list.size());
    for (int r = 0; r < records; ++r) {
      const std::vector<double> x = Phase(alpha, n, 1000000 * (alpha + 3) + r);
      const std::vector<double> sums = imuqual::allan::Theo1Sums(x, m_list);
      for (size_t q = 0; q < m_list.size(); ++q) {
        logs[q].push_back(std::log(sums[q]));
        values[q].push_back(sums[q]);
      }
    }
    for (size_t q = 0; q < m_list.size(); ++q) {
      double mean = 0, var = 0, vmean = 0;
      for (double v : logs[q]) mean += v / records;
      for (double v : logs[q]) var += (v - mean) * (v - mean) / (records - 1);
      for (double v : values[q]) vmean += v / records;
      const double offset = mean - std::log(vmean);  // E ln - ln E (sample mean for E)
      // Var ln(chi2_nu / nu) = psi'(nu/2), E = psi(nu/2) - ln(nu/2).
      const double nu_var =
          EdfWhere([](double nu) { return -boost::math::trigamma(nu / 2); }, -var);
      const double nu_mean = EdfWhere(
          [](double nu) { return boost::math::digamma(nu / 2) - std::log(nu / 2); }, offset);
      const auto sp = imuqual::allan::Theo1Edf(alpha, m_list[q], n);
      std::printf("theo1_edf alpha %+d m %lld r/N %.3f sp1065 %.2f mc_var %.2f mc_mean %.2f\n",
                  alpha, static_cast<long long>(m_list[q]), 0.75 * m_list[q] / n, sp ? *sp : NAN,
                  nu_var, nu_mean);
    }
  }
  return 0;
}
