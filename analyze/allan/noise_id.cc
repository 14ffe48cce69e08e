#include "analyze/allan/noise_id.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace imuqual::allan {
namespace {

// |delta| beyond this maps outside alpha in [-4, 2] anyway; the bound keeps
// the integer conversion defined.
constexpr double kMaxAbsDelta = 8.0;

// Removes the least-squares quadratic a + b k + c k^2 from z. On the symmetric
// abscissa u_k = (2k - (n-1)) / (n-1) in [-1, 1], the polynomials 1, u and
// u^2 - mean(u^2) are mutually orthogonal, so the fit is three independent
// projections (applied to the running residual, i.e. modified Gram-Schmidt).
// The basis is evaluated where it is used, not stored: the first points of a
// curve identify over the whole record.
void RemoveQuadratic(std::vector<double>* z) {
  const size_t n = z->size();
  const double half_span = 0.5 * static_cast<double>(n - 1);
  const auto u = [half_span](size_t k) { return (static_cast<double>(k) - half_span) / half_span; };
  double mean_u2 = 0.0;
  for (size_t k = 0; k < n; ++k) mean_u2 += u(k) * u(k);
  mean_u2 /= static_cast<double>(n);
  const auto project_out = [z, n](auto basis) {
    double zb = 0.0;
    double bb = 0.0;
    for (size_t k = 0; k < n; ++k) {
      zb += (*z)[k] * basis(k);
      bb += basis(k) * basis(k);
    }
    const double coefficient = zb / bb;
    for (size_t k = 0; k < n; ++k) (*z)[k] -= coefficient * basis(k);
  };
  project_out([](size_t) { return 1.0; });
  project_out(u);
  project_out([&u, mean_u2](size_t k) { return u(k) * u(k) - mean_u2; });
}

// r1 = sum_{k<n-1} (z_k - zbar)(z_{k+1} - zbar) / sum_k (z_k - zbar)^2;
// NaN when the series has no variance.
double Lag1Autocorrelation(const std::vector<double>& z) {
  double mean = 0.0;
  for (double v : z) mean += v;
  mean /= static_cast<double>(z.size());
  double numerator = 0.0;
  double denominator = 0.0;
  for (size_t k = 0; k < z.size(); ++k) {
    const double centred = z[k] - mean;
    denominator += centred * centred;
    if (k + 1 < z.size()) numerator += centred * (z[k + 1] - mean);
  }
  if (!(denominator > 0.0)) return std::nan("");
  return numerator / denominator;
}

}  // namespace

std::optional<NoiseId> IdentifyNoiseLag1(const PhaseRecord& phase, int64_t m, int dmax) {
  if (m < 1 || dmax < 0) return std::nullopt;
  const PhaseSpan span = LongestValidSpan(phase);
  const int64_t count = (span.size() + m - 1) / m;
  if (count < kMinNoiseIdPoints) return std::nullopt;

  std::vector<double> z;
  z.reserve(static_cast<size_t>(count));
  for (int64_t k = 0; k < count; ++k) z.push_back(phase.x[span.begin + k * m]);
  RemoveQuadratic(&z);

  int d = 0;
  while (true) {
    const double r1 = Lag1Autocorrelation(z);
    if (!std::isfinite(r1)) return std::nullopt;
    // r1 >= -1 for any series; r1 = -1 would make delta -inf.
    const double delta = r1 > -1.0 ? r1 / (1.0 + r1) : -kMaxAbsDelta;
    if (delta < 0.25 || d >= dmax) {
      // nearbyint rounds half to even in the default rounding mode.
      const double rounded = std::nearbyint(2.0 * std::max(delta, -kMaxAbsDelta));
      const int alpha = std::clamp(-static_cast<int>(rounded) - 2 * d + 2, -4, 2);
      return NoiseId{alpha, r1, d};
    }
    for (size_t k = 0; k + 1 < z.size(); ++k) z[k] = z[k + 1] - z[k];
    z.pop_back();
    ++d;
  }
}

}  // namespace imuqual::allan
