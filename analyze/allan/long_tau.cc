#include "analyze/allan/long_tau.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <complex>
#include <unsupported/Eigen/FFT>

#include "analyze/allan/estimators.h"
#include "analyze/allan/lane_sum.h"

namespace imuqual::allan {
namespace {

// Sums of squared terms: kChunk at a time into kLanes accumulators (lane_sum.h).
using lanes::kChunk;
using lanes::kLanes;
using lanes::SumLanes;

// ---------------------------------------------------------------------------
// FFT helpers (Eigen's FFT module, real transforms of power-of-two length).

int64_t FftLength(int64_t at_least) {
  int64_t n = 1;
  while (n < at_least) n <<= 1;
  return n;
}

class RealFft {
 public:
  RealFft() { fft_.SetFlag(Eigen::FFT<double>::HalfSpectrum); }

  // Spectrum of v zero-padded to `length` (length/2 + 1 bins).
  std::vector<std::complex<double>> Forward(std::span<const double> v, int64_t length) {
    std::vector<double> padded(static_cast<size_t>(length), 0.0);
    std::copy(v.begin(), v.end(), padded.begin());
    std::vector<std::complex<double>> spectrum;
    fft_.fwd(spectrum, padded);
    return spectrum;
  }

  // The real signal of `length` samples with the given half spectrum.
  std::vector<double> Inverse(const std::vector<std::complex<double>>& spectrum, int64_t length) {
    std::vector<double> out;
    fft_.inv(out, spectrum, static_cast<Eigen::Index>(length));
    return out;
  }

 private:
  Eigen::FFT<double> fft_;
};

// Linear autocorrelation r_l = sum_t v_t v_{t+l}, l = 0..max_lag (max_lag <
// v.size()). Circular correlation of length >= size + max_lag has no wrap-around
// at these lags.
std::vector<double> Autocorrelation(RealFft& fft, std::span<const double> v, int64_t max_lag) {
  const int64_t length = FftLength(static_cast<int64_t>(v.size()) + max_lag);
  std::vector<std::complex<double>> spectrum = fft.Forward(v, length);
  for (std::complex<double>& s : spectrum) s = std::norm(s);
  std::vector<double> r = fft.Inverse(spectrum, length);
  r.resize(static_cast<size_t>(max_lag + 1));
  return r;
}

// ---------------------------------------------------------------------------
// Theo1.
//
// Write h = m/2, A = N-1-m, and y'_t = x_{t+1} - x_t - ybar (the increments
// with their mean ybar = (x_{N-1} - x_0)/(N-1) removed; u_k is unchanged by a
// linear trend in x). With e_a(i) = y'_{a+m-1-i} - y'_{a+i},
//   u_k(a) = sum_{i<k} e_a(i),
//   S(m)   = sum_{a=0}^{A} sum_{k=1}^{h} (1/k) u_k(a)^2
//          = sum_a sum_{i,j<h} w(max(i,j)) e_a(i) e_a(j),   w(M) = sum_{k=M+1}^{h} 1/k.
// Direct summation costs (A+1) h terms. The fast form extends y' by zeros
// (x by its end values) and sums over every window a in Z that touches the
// record, which makes the sum translation invariant:
//   S_inf = 2 sum_{i,j<h} w(max(i,j)) [r(|i-j|) - r(m-1-i-j)],
// r the autocorrelation of y' (one FFT for all m). The windows outside
// [0, A] are m-1 partial windows at each end; at the start, with the anchored
// phase Y_n = x_n - x_0 - n ybar (Y_n = 0 for n <= 0),
//   E(m) = sum_{n=1}^{m-1} sum_{k=1}^{h} (1/k) [Y_n - Y_{n-k} - Y_{n-m+k}]^2
//        = H_h sum_n Y_n^2 + sum_k (1/k) [P2(m-1-k) + P2(k-1)]
//          - 2 sum_k (1/k) [c(k) + c(m-k)] + 2 sum_k (1/k) sum_{p<k} Y_p Y_{p+m-2k},
// P2 the prefix sums of Y^2, c the autocorrelation of Y_0..Y_{m-1}. The last
// sum runs over the triangle {p <= q, p + q < m} with a weight depending on
// q - p only; it is evaluated by divide and conquer (a square by FFT, two
// half-size triangles), O(m log^2 m). The end is the start of the reversed
// record. S(m) = S_inf - E_start(m) - E_end(m), all in increments of the
// phase, so no term carries the phase's own (possibly large) level.

// w(M) = sum_{k=M+1}^{h} 1/k for M = 0..h-1, summed from the small end.
std::vector<double> HarmonicTails(int64_t h) {
  std::vector<double> w(static_cast<size_t>(h));
  double sum = 0.0;
  for (int64_t k = h; k >= 1; --k) {
    sum += 1.0 / static_cast<double>(k);
    w[k - 1] = sum;
  }
  return w;
}

// Suffix sums W(M) = sum_{u=M}^{h-1} w(u), M = 0..h (W(h) = 0).
std::vector<double> SuffixSums(const std::vector<double>& w) {
  std::vector<double> s(w.size() + 1, 0.0);
  for (size_t u = w.size(); u-- > 0;) s[u] = s[u + 1] + w[u];
  return s;
}

// S(m) by direct summation over a gap-free series x of n points.
double Theo1SumDirect(const double* x, int64_t n, int64_t m) {
  const int64_t h = m / 2;
  const int64_t count = n - m;
  double total = 0.0;
  for (int64_t k = 1; k <= h; ++k) {
    const double* x0 = x;
    const double* xk = x + k;
    const double* xmk = x + m - k;
    const double* xm = x + m;
    double sum_k = 0.0;
    for (int64_t chunk = 0; chunk < count; chunk += kChunk) {
      const int64_t end = std::min(count, chunk + kChunk);
      double acc[kLanes] = {};
      int64_t a = chunk;
      for (; a + kLanes <= end; a += kLanes) {
        for (int l = 0; l < kLanes; ++l) {
          const double u = (xm[a + l] - xmk[a + l]) - (xk[a + l] - x0[a + l]);
          acc[l] += u * u;
        }
      }
      for (; a < end; ++a) {
        const double u = (xm[a] - xmk[a]) - (xk[a] - x0[a]);
        acc[0] += u * u;
      }
      sum_k += SumLanes(acc);
    }
    total += sum_k / static_cast<double>(k);
  }
  return total;
}

// S_inf(m) from the autocorrelation r of y' (r.size() >= m).
double Theo1AllWindows(const std::vector<double>& r, int64_t m) {
  const int64_t h = m / 2;
  const std::vector<double> w = HarmonicTails(h);
  const std::vector<double> tail = SuffixSums(w);
  // sum_{|i-j| = l} w(max(i,j)) = (1 or 2) W(l).
  double same = r[0] * tail[0];
  for (int64_t l = 1; l < h; ++l) same += 2.0 * r[l] * tail[l];
  // sum_{i+j = s} w(max(i,j)), s = m-1-l: max runs over ceil(s/2)..min(h-1, s),
  // each value twice except s/2.
  double cross = 0.0;
  for (int64_t l = 1; l <= m - 1; ++l) {
    const int64_t s = m - 1 - l;
    const int64_t lo = (s + 1) / 2;
    const int64_t hi = std::min(h - 1, s);
    double weight = 2.0 * (tail[lo] - tail[hi + 1]);
    if (s % 2 == 0) weight -= w[s / 2];
    cross += r[l] * weight;
  }
  return 2.0 * (same - cross);
}

// Triangle sums  sum_{i <= j, i + j < n} g(j - i) z_i z_j  with g(d) = 0 for
// d < 0 or d >= g.size(), by divide and conquer.
class TriangleSum {
 public:
  TriangleSum(RealFft& fft, std::span<const double> z, std::span<const double> g)
      : fft_(fft), z_(z), g_(g) {}

  double Sum(int64_t n) { return Triangle(0, 0, n); }

 private:
  // Below this side a triangle or square is summed directly.
  static constexpr int64_t kDirectSide = 48;

  double G(int64_t d) const { return d < 0 || d >= static_cast<int64_t>(g_.size()) ? 0.0 : g_[d]; }

  // {(i, j): i >= i0, j >= j0, (i - i0) + (j - j0) < s}: a square of side
  // ceil(s/2) and the two triangles of side s - ceil(s/2) beside it.
  double Triangle(int64_t i0, int64_t j0, int64_t s) {
    if (s <= 0 || j0 + s - 1 - i0 < 0) return 0.0;  // empty, or every lag negative
    if (s <= kDirectSide) {
      double sum = 0.0;
      for (int64_t i = i0; i < i0 + s; ++i) {
        for (int64_t j = std::max(j0, i); j < j0 + s - (i - i0); ++j)
          sum += G(j - i) * z_[i] * z_[j];
      }
      return sum;
    }
    const int64_t half = (s + 1) / 2;
    return Square(i0, j0, half) + Triangle(i0 + half, j0, s - half) +
           Triangle(i0, j0 + half, s - half);
  }

  // sum_{i, j < s} g(j0 - i0 + j - i) z_{i0+i} z_{j0+j}.
  double Square(int64_t i0, int64_t j0, int64_t s) {
    const int64_t delta = j0 - i0;
    if (delta + s - 1 < 0 || delta - (s - 1) >= static_cast<int64_t>(g_.size())) return 0.0;
    if (s <= kDirectSide) {
      double sum = 0.0;
      for (int64_t i = 0; i < s; ++i) {
        double row = 0.0;
        for (int64_t j = 0; j < s; ++j) row += G(delta + j - i) * z_[j0 + j];
        sum += z_[i0 + i] * row;
      }
      return sum;
    }
    // c_t = sum_i a_i b_{t-i} with a = z[i0..i0+s), b_t = g(delta - (s-1) + t),
    // t < 2s-1; the sum needs c_{s-1+j}, j < s. A circular length >= 2s
    // aliases only c_t with t >= 2s onto t <= s-3.
    const int64_t length = FftLength(2 * s);
    std::vector<double> b(static_cast<size_t>(2 * s - 1));
    for (int64_t t = 0; t < 2 * s - 1; ++t) b[t] = G(delta - (s - 1) + t);
    std::vector<std::complex<double>> fa = fft_.Forward(z_.subspan(i0, s), length);
    const std::vector<std::complex<double>> fb = fft_.Forward(b, length);
    for (size_t f = 0; f < fa.size(); ++f) fa[f] *= fb[f];
    const std::vector<double> c = fft_.Inverse(fa, length);
    double sum = 0.0;
    for (int64_t j = 0; j < s; ++j) sum += z_[j0 + j] * c[s - 1 + j];
    return sum;
  }

  RealFft& fft_;
  std::span<const double> z_;
  std::span<const double> g_;
};

// E(m) of the partial windows at the start of a record whose anchored phase
// is y[0..m) (y[0] = 0), for one m.
double Theo1StartWindows(RealFft& fft, std::span<const double> y, int64_t m) {
  const int64_t h = m / 2;
  std::vector<double> squares(static_cast<size_t>(m));  // prefix sums of Y^2
  double running = 0.0;
  for (int64_t n = 0; n < m; ++n) squares[n] = running += y[n] * y[n];
  double harmonic = 0.0;
  double prefix_terms = 0.0;
  for (int64_t k = 1; k <= h; ++k) {
    const double inv_k = 1.0 / static_cast<double>(k);
    harmonic += inv_k;
    prefix_terms += inv_k * (squares[m - 1 - k] + squares[k - 1]);
  }
  const std::vector<double> c = Autocorrelation(fft, y.first(m), m - 1);
  double lag_terms = 0.0;
  for (int64_t k = 1; k <= h; ++k) lag_terms += (c[k] + c[m - k]) / static_cast<double>(k);
  // sum_{p <= q, p + q < m, q - p = m - 2k} Y_p Y_q / k: p and q have the same
  // parity, so it splits into two triangles of half the side over the even and
  // the odd points, with weight 1/(h - d) at index distance d.
  std::vector<double> g(static_cast<size_t>(h));
  for (int64_t d = 0; d < h; ++d) g[d] = 1.0 / static_cast<double>(h - d);
  double triangle = 0.0;
  for (int parity = 0; parity < 2; ++parity) {
    std::vector<double> z;
    z.reserve(static_cast<size_t>(h));
    for (int64_t p = parity; p < m; p += 2) z.push_back(y[p]);
    triangle += TriangleSum(fft, z, g).Sum(h - parity);
  }
  return harmonic * squares[m - 1] + prefix_terms - 2.0 * lag_terms + 2.0 * triangle;
}

// What the fast form needs from a gap-free series, computed once.
struct Theo1Increments {
  std::vector<double> start;  // anchored phase from the start: Y_n, n = 0..N-1
  std::vector<double> end;    // the same from the end of the reversed record
  std::vector<double> acf;    // autocorrelation of y', lags 0..max_lag
};

Theo1Increments MakeIncrements(RealFft& fft, const double* x, int64_t n, int64_t max_lag) {
  Theo1Increments inc;
  const double mean_step = (x[n - 1] - x[0]) / static_cast<double>(n - 1);
  inc.start.resize(static_cast<size_t>(n));
  inc.end.resize(static_cast<size_t>(n));
  for (int64_t k = 0; k < n; ++k) {
    inc.start[k] = (x[k] - x[0]) - mean_step * static_cast<double>(k);
    inc.end[k] = (x[n - 1] - x[n - 1 - k]) - mean_step * static_cast<double>(k);
  }
  std::vector<double> steps(static_cast<size_t>(n - 1));
  for (int64_t t = 0; t + 1 < n; ++t) steps[t] = (x[t + 1] - x[t]) - mean_step;
  inc.acf = Autocorrelation(fft, steps, max_lag);
  return inc;
}

bool ValidTheo1Factor(int64_t m, int64_t n) { return m >= 2 && m % 2 == 0 && m <= n - 1; }

double DirectCost(int64_t m, int64_t n) {
  return static_cast<double>(n - m) * static_cast<double>(m / 2);
}

// The batch form for TheoBR: E_start(m) for every m of an ascending list of
// even factors, by one sweep over the upper index j of the lag products
// p_l(j) = sum_{t=l}^{j} Y_t Y_{t-l} (kept for every lag l <= j): m reads
// c(l) = p_l(m-1) at j = m-1 and each triangle term p_{m-2k}(m-k-1) at
// j = m-k-1. O(M^2) for the largest factor M, however many factors.
std::vector<double> Theo1StartWindowsBatch(std::span<const double> y,
                                           std::span<const int64_t> m_list) {
  const int64_t top = m_list.back();
  std::vector<double> squares(static_cast<size_t>(top));
  double running = 0.0;
  for (int64_t n = 0; n < top; ++n) squares[n] = running += y[n] * y[n];
  std::vector<double> inverse(static_cast<size_t>(top / 2 + 1), 0.0);
  for (int64_t k = 1; k <= top / 2; ++k) inverse[k] = 1.0 / static_cast<double>(k);

  std::vector<double> lag_terms(m_list.size(), 0.0);
  std::vector<double> triangle(m_list.size(), 0.0);
  std::vector<double> products(static_cast<size_t>(top), 0.0);
  for (int64_t j = 0; j < top; ++j) {
    const double yj = y[j];
    const double* back = y.data() + j;
    for (int64_t l = 0; l <= j; ++l) products[l] += yj * back[-l];
    // Factors m in [j+2, 2j+2] take p_{2j+2-m}(j) / (m-1-j).
    auto first = std::lower_bound(m_list.begin(), m_list.end(), j + 2);
    for (auto it = first; it != m_list.end() && *it <= 2 * j + 2; ++it) {
      const int64_t m = *it;
      triangle[it - m_list.begin()] += products[2 * j + 2 - m] * inverse[m - 1 - j];
    }
    auto at = std::lower_bound(m_list.begin(), m_list.end(), j + 1);
    if (at != m_list.end() && *at == j + 1) {
      const int64_t m = j + 1;
      double sum = 0.0;
      for (int64_t k = 1; k <= m / 2; ++k) sum += (products[k] + products[m - k]) * inverse[k];
      lag_terms[at - m_list.begin()] = sum;
    }
  }
  std::vector<double> result(m_list.size());
  for (size_t q = 0; q < m_list.size(); ++q) {
    const int64_t m = m_list[q];
    double harmonic = 0.0;
    double prefix_terms = 0.0;
    for (int64_t k = 1; k <= m / 2; ++k) {
      harmonic += inverse[k];
      prefix_terms += inverse[k] * (squares[m - 1 - k] + squares[k - 1]);
    }
    result[q] = harmonic * squares[m - 1] + prefix_terms - 2.0 * lag_terms[q] + 2.0 * triangle[q];
  }
  return result;
}

// S(m) for an ascending list of valid factors by the batch form.
std::vector<double> Theo1SumsBatch(const double* x, int64_t n, std::span<const int64_t> m_list) {
  RealFft fft;
  const int64_t top = m_list.back();
  const Theo1Increments inc = MakeIncrements(fft, x, n, top - 1);
  const std::vector<double> start = Theo1StartWindowsBatch(inc.start, m_list);
  const std::vector<double> end = Theo1StartWindowsBatch(inc.end, m_list);
  std::vector<double> sums(m_list.size());
  for (size_t q = 0; q < m_list.size(); ++q) {
    sums[q] = Theo1AllWindows(inc.acf, m_list[q]) - start[q] - end[q];
  }
  return sums;
}

// ---------------------------------------------------------------------------
// MTOT and HTOT: one run of 3m values v, detrended by its half means, extended
// to 9m values by uninverted even reflection, and the mean square of the 6m
// second differences of m-value sums (divided by m).

double TotalRunMeanSquare(const double* v, int64_t m, bool centre_trend,
                          std::vector<double>* prefix) {
  const int64_t length = 3 * m;
  const int64_t half = length / 2;          // values in each half
  const int64_t second = (length + 1) / 2;  // first index of the second half
  double sum1 = 0.0;
  double sum2 = 0.0;
  for (int64_t t = 0; t < half; ++t) sum1 += v[t];
  for (int64_t t = second; t < length; ++t) sum2 += v[t];
  const double mean1 = sum1 / static_cast<double>(half);
  const double mean2 = sum2 / static_cast<double>(half);
  // Distance between the half means' centres: 3m/2 (even 3m) or (3m+1)/2.
  const double distance = length % 2 == 1 ? static_cast<double>(half + 1) : 0.5 * length;
  const double slope = (mean2 - mean1) / distance;
  // The line is removed about index 0 (MTOT) or floor(3m/2) (HTOT), as the
  // reference does; mean1 is removed as well (a constant cancels in every
  // second difference) so the sums stay at the scale of the fluctuations.
  const double origin = centre_trend ? static_cast<double>(half) : 0.0;
  const auto detrended = [&](int64_t t) {
    return (v[t] - mean1) - slope * (static_cast<double>(t) - origin);
  };
  // Prefix sums of x* = [reverse(run), run, reverse(run)].
  std::vector<double>& p = *prefix;
  p.assign(static_cast<size_t>(9 * m + 1), 0.0);
  for (int64_t t = 0; t < 9 * m; ++t) {
    const int64_t r = t < length       ? length - 1 - t
                      : t < 2 * length ? t - length
                                       : 3 * length - 1 - t;
    p[t + 1] = p[t] + detrended(r);
  }
  const double inv_m = 1.0 / static_cast<double>(m);
  double sum = 0.0;
  for (int64_t j = 0; j < 6 * m; ++j) {
    const double d = ((p[j + 3 * m] - p[j]) - 3.0 * (p[j + 2 * m] - p[j + m])) * inv_m;
    sum += d * d;
  }
  return sum / static_cast<double>(6 * m);
}

// MTOT variance of a gap-free phase series at m (1 <= m <= (n-1)/3).
double MtotVariance(const double* x, int64_t n, int64_t m, double tau0_s) {
  const int64_t runs = n - 3 * m + 1;
  std::vector<double> prefix;
  double total = 0.0;
  for (int64_t i = 0; i < runs; ++i) total += TotalRunMeanSquare(x + i, m, false, &prefix);
  const double tau = static_cast<double>(m) * tau0_s;
  return total / (2.0 * tau * tau * static_cast<double>(runs));
}

// HTOT variance of rate samples y[0..count) at m (2 <= m <= count/3).
double HtotVariance(const std::vector<double>& y, int64_t m) {
  const int64_t runs = static_cast<int64_t>(y.size()) - 3 * m + 1;
  std::vector<double> prefix;
  double total = 0.0;
  for (int64_t i = 0; i < runs; ++i) total += TotalRunMeanSquare(y.data() + i, m, true, &prefix);
  return total / (6.0 * static_cast<double>(runs));
}

// ---------------------------------------------------------------------------
// Points.

CurvePoint EmptyPoint(int64_t m, double tau_s) {
  CurvePoint point;
  point.m = m;
  point.tau_s = tau_s;
  point.stride = 1;
  return point;
}

double TheoTauS(int64_t m, double tau0_s, TheoTau tau) {
  const double nominal = static_cast<double>(m) * tau0_s;
  return tau == TheoTau::kEffective ? 0.75 * nominal : nominal;
}

// Theo1 points (times `ratio`, TheoBR's bias removal, when given).
void TheoPoints(const double* x, int64_t n, double tau0_s, std::span<const int64_t> m_list,
                double ratio, TheoTau tau, std::vector<CurvePoint>* points) {
  std::vector<int64_t> valid;
  for (int64_t m : m_list) {
    if (ValidTheo1Factor(m, n)) valid.push_back(m);
  }
  const std::vector<double> sums = Theo1Sums(std::span<const double>(x, n), valid);
  size_t next = 0;
  for (int64_t m : m_list) {
    CurvePoint point = EmptyPoint(m, TheoTauS(m, tau0_s, tau));
    if (ValidTheo1Factor(m, n)) {
      const double span_s = static_cast<double>(m) * tau0_s;
      const double variance =
          ratio * sums[next++] / (0.75 * static_cast<double>(n - m) * span_s * span_s);
      point.n = (n - m) * (m / 2);
      point.dev = std::sqrt(variance);
    }
    points->push_back(point);
  }
}

}  // namespace

bool IsLongTauDeviation(Deviation dev) {
  switch (dev) {
    case Deviation::kTheo1:
    case Deviation::kTheoBr:
    case Deviation::kTheoH:
    case Deviation::kMtotdev:
    case Deviation::kTtotdev:
    case Deviation::kHtotdev:
      return true;
    default:
      return false;
  }
}

bool IsTheoDeviation(Deviation dev) {
  return dev == Deviation::kTheo1 || dev == Deviation::kTheoBr || dev == Deviation::kTheoH;
}

int64_t TheoHSwitchFactor(int64_t n_phase) { return std::max<int64_t>(n_phase - 1, 0) / 5; }

bool TheoHIsAllanPoint(int64_t m, int64_t n_phase) {
  return m >= 1 && m < TheoHSwitchFactor(n_phase);
}

bool TheoHHasPoint(int64_t m, int64_t n_phase) {
  if (TheoHIsAllanPoint(m, n_phase)) return true;
  return ValidTheo1Factor(m, n_phase) && 3 * m >= 4 * TheoHSwitchFactor(n_phase);
}

double EffectiveAveragingFactor(Deviation dev, int64_t m, int64_t n_phase) {
  const double md = static_cast<double>(m);
  if (dev == Deviation::kTheo1 || dev == Deviation::kTheoBr) return 0.75 * md;
  if (dev == Deviation::kTheoH && !TheoHIsAllanPoint(m, n_phase)) return 0.75 * md;
  return md;
}

std::vector<double> Theo1Sums(std::span<const double> x, std::span<const int64_t> m_list,
                              Theo1Method method) {
  const int64_t n = static_cast<int64_t>(x.size());
  std::vector<double> sums(m_list.size(), kNaN);
  const auto use_fast = [&](int64_t m) {
    return method == Theo1Method::kFast ||
           (method == Theo1Method::kAuto &&
            DirectCost(m, n) > static_cast<double>(kTheo1DirectTermBudget));
  };
  int64_t fast_top = 0;
  for (int64_t m : m_list) {
    if (ValidTheo1Factor(m, n) && use_fast(m)) fast_top = std::max(fast_top, m);
  }
  RealFft fft;
  Theo1Increments inc;
  if (fast_top > 0) inc = MakeIncrements(fft, x.data(), n, fast_top - 1);
  for (size_t q = 0; q < m_list.size(); ++q) {
    const int64_t m = m_list[q];
    if (!ValidTheo1Factor(m, n)) continue;
    if (!use_fast(m)) {
      sums[q] = Theo1SumDirect(x.data(), n, m);
      continue;
    }
    sums[q] = Theo1AllWindows(inc.acf, m) - Theo1StartWindows(fft, inc.start, m) -
              Theo1StartWindows(fft, inc.end, m);
  }
  return sums;
}

std::optional<double> TheoBrRatio(std::span<const double> x, Theo1Method method) {
  const int64_t n = static_cast<int64_t>(x.size());
  // n' = floor(0.1 N/3 - 3), in integers.
  const int64_t last = n / 30 - 3;
  if (last < 0) return std::nullopt;
  std::vector<int64_t> theo_m;
  std::vector<int64_t> allan_m;
  double direct_cost = 0.0;
  for (int64_t i = 0; i <= last; ++i) {
    theo_m.push_back(12 + 4 * i);
    allan_m.push_back(9 + 3 * i);
    direct_cost += DirectCost(theo_m.back(), n);
  }
  const bool direct =
      method == Theo1Method::kDirect ||
      (method == Theo1Method::kAuto && direct_cost <= static_cast<double>(kTheo1DirectTermBudget));
  const std::vector<double> sums =
      direct ? Theo1Sums(x, theo_m, Theo1Method::kDirect) : Theo1SumsBatch(x.data(), n, theo_m);
  const PhaseRecord record = PhaseFromPhase(x, 1.0);
  const Curve allan = ComputeDeviation(record, Deviation::kOadev, allan_m);
  if (allan.points.size() != allan_m.size()) return std::nullopt;
  double ratio_sum = 0.0;
  for (int64_t i = 0; i <= last; ++i) {
    const double m = static_cast<double>(theo_m[i]);
    const double theo1 = sums[i] / (0.75 * static_cast<double>(n - theo_m[i]) * m * m);
    const double avar = allan.points[i].dev * allan.points[i].dev;
    ratio_sum += avar / theo1;
  }
  return ratio_sum / static_cast<double>(last + 1);
}

std::vector<CurvePoint> LongTauPoints(const PhaseRecord& phase, Deviation dev,
                                      std::span<const int64_t> m_list, TheoTau tau) {
  assert(IsLongTauDeviation(dev));
  const PhaseSpan span = LongestValidSpan(phase);
  const double* x = phase.x.data() + span.begin;
  const int64_t n = span.size();
  const double tau0_s = phase.tau0_s;
  std::vector<CurvePoint> points;
  points.reserve(m_list.size());
  switch (dev) {
    case Deviation::kTheo1:
      TheoPoints(x, n, tau0_s, m_list, 1.0, tau, &points);
      break;
    case Deviation::kTheoBr: {
      const std::optional<double> ratio = TheoBrRatio(std::span<const double>(x, n));
      if (!ratio) {
        for (int64_t m : m_list) points.push_back(EmptyPoint(m, TheoTauS(m, tau0_s, tau)));
        break;
      }
      TheoPoints(x, n, tau0_s, m_list, *ratio, tau, &points);
      break;
    }
    case Deviation::kTheoH: {
      // OADEV of the span at the Allan points, TheoBR at the others.
      std::vector<int64_t> allan_m;
      std::vector<int64_t> theo_m;
      for (int64_t m : m_list) {
        if (TheoHIsAllanPoint(m, n)) {
          allan_m.push_back(m);
        } else if (TheoHHasPoint(m, n)) {
          theo_m.push_back(m);
        }
      }
      PhaseRecord record;
      record.tau0_s = tau0_s;
      record.x.assign(x, x + n);
      std::vector<CurvePoint> allan;
      for (int64_t m : allan_m) allan.push_back(ComputeDeviationAt(record, Deviation::kOadev, m));
      std::vector<CurvePoint> theo;
      const std::optional<double> ratio =
          theo_m.empty() ? std::nullopt : TheoBrRatio(std::span<const double>(x, n));
      if (ratio) TheoPoints(x, n, tau0_s, theo_m, *ratio, tau, &theo);
      size_t next_allan = 0;
      size_t next_theo = 0;
      for (int64_t m : m_list) {
        if (TheoHIsAllanPoint(m, n)) {
          CurvePoint point = allan[next_allan++];
          point.stride = 1;
          points.push_back(point);
        } else if (TheoHHasPoint(m, n) && ratio) {
          points.push_back(theo[next_theo++]);
        } else {
          points.push_back(EmptyPoint(m, TheoTauS(m, tau0_s, tau)));
        }
      }
      break;
    }
    case Deviation::kMtotdev:
    case Deviation::kTtotdev:
      for (int64_t m : m_list) {
        CurvePoint point = EmptyPoint(m, static_cast<double>(m) * tau0_s);
        if (m >= 1 && 3 * m <= n) {  // at least one run of 3m points
          const double mtot = std::sqrt(MtotVariance(x, n, m, tau0_s));
          point.n = n - 3 * m + 1;
          point.dev = dev == Deviation::kMtotdev ? mtot : point.tau_s * mtot / std::sqrt(3.0);
        }
        points.push_back(point);
      }
      break;
    case Deviation::kHtotdev: {
      // Rate samples of the span; m = 1 is OHDEV.
      std::vector<double> rate(static_cast<size_t>(std::max<int64_t>(n - 1, 0)));
      for (int64_t t = 0; t + 1 < n; ++t) rate[t] = (x[t + 1] - x[t]) / tau0_s;
      PhaseRecord record;
      record.tau0_s = tau0_s;
      record.x.assign(x, x + n);
      for (int64_t m : m_list) {
        CurvePoint point = EmptyPoint(m, static_cast<double>(m) * tau0_s);
        if (m == 1) {
          point = ComputeDeviationAt(record, Deviation::kOhdev, 1);
          point.stride = 1;
        } else if (m >= 2 && 3 * m <= n - 1) {  // at least one run of 3m rate samples
          point.n = n - 3 * m;
          point.dev = std::sqrt(HtotVariance(rate, m));
        }
        points.push_back(point);
      }
      break;
    }
    default:
      break;
  }
  return points;
}

std::vector<int64_t> Theo1OctavesBeyond(double last_tau_s, double tau0_s, int64_t n_phase,
                                        double max_fraction) {
  std::vector<int64_t> out;
  for (double tau = 2 * last_tau_s;; tau *= 2) {
    const int64_t m = 2 * std::llround(tau / (0.75 * tau0_s) / 2);
    if (m < 2 || m > n_phase - 1 || 0.75 * static_cast<double>(m) > max_fraction * n_phase) break;
    if (out.empty() || m > out.back()) out.push_back(m);
  }
  return out;
}

std::vector<Theo1Moment> Theo1MomentsBeyond(const PhaseRecord& phase, double last_tau_s,
                                            int64_t block) {
  const int64_t n = LongestValidSpan(phase).size();
  const std::vector<int64_t> m = Theo1OctavesBeyond(last_tau_s, phase.tau0_s, n, kTheo1MomentReach);
  std::vector<Theo1Moment> out;
  for (const CurvePoint& p : LongTauPoints(phase, Deviation::kTheo1, m)) {
    if (std::isfinite(p.dev) && p.dev > 0) out.push_back({p.m, p.dev * p.dev, n, block});
  }
  return out;
}

}  // namespace imuqual::allan
