#include "analyze/allan/estimators.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

namespace imuqual::allan {
namespace {

// Terms are summed in chunks of kChunk into kLanes independent accumulators
// (the compiler maps the lanes onto SIMD registers); each chunk's sum is then
// added to the total. Rounding error grows with the number of chunks, not of
// terms, and the order of summation is fixed, so results are reproducible.
constexpr int64_t kChunk = 2048;
constexpr int kLanes = 8;

// MVAR's inner sum is updated by a running recurrence; it is recomputed
// exactly at the start of every block of max(kMvarMinBlock, 8m) terms to bound
// the drift of the recurrence (the exact sum costs m terms, <= 1/8 of the
// block).
constexpr int64_t kMvarMinBlock = 4096;
// Independent recurrence chains run side by side to hide the add latency.
constexpr int kMvarChains = 4;

double SumLanes(const double (&acc)[kLanes]) {
  double a = 0.0;
  double b = 0.0;
  for (int k = 0; k < kLanes; k += 2) {
    a += acc[k];
    b += acc[k + 1];
  }
  return a + b;
}

// sum_{i=begin}^{end-1} d_i^2, d_i = (x_{i+2m} - x_{i+m}) - (x_{i+m} - x_i),
// the second difference x_{i+2m} - 2x_{i+m} + x_i written as a difference of
// first differences (each first difference of nearby phases is nearly exact).
double SumSquaredSecondDifferences(const double* x, int64_t m, int64_t begin, int64_t end) {
  const double* x0 = x;
  const double* x1 = x + m;
  const double* x2 = x + 2 * m;
  double total = 0.0;
  for (int64_t chunk = begin; chunk < end; chunk += kChunk) {
    const int64_t chunk_end = std::min(end, chunk + kChunk);
    double acc[kLanes] = {};
    int64_t i = chunk;
    for (; i + kLanes <= chunk_end; i += kLanes) {
      for (int k = 0; k < kLanes; ++k) {
        const double d = (x2[i + k] - x1[i + k]) - (x1[i + k] - x0[i + k]);
        acc[k] += d * d;
      }
    }
    for (; i < chunk_end; ++i) {
      const double d = (x2[i] - x1[i]) - (x1[i] - x0[i]);
      acc[0] += d * d;
    }
    total += SumLanes(acc);
  }
  return total;
}

// sum_{i=begin}^{end-1} t_i^2, t_i = (x_{i+3m} - x_i) - 3 (x_{i+2m} - x_{i+m}),
// the third difference x_{i+3m} - 3x_{i+2m} + 3x_{i+m} - x_i.
double SumSquaredThirdDifferences(const double* x, int64_t m, int64_t begin, int64_t end) {
  const double* x0 = x;
  const double* x1 = x + m;
  const double* x2 = x + 2 * m;
  const double* x3 = x + 3 * m;
  double total = 0.0;
  for (int64_t chunk = begin; chunk < end; chunk += kChunk) {
    const int64_t chunk_end = std::min(end, chunk + kChunk);
    double acc[kLanes] = {};
    int64_t i = chunk;
    for (; i + kLanes <= chunk_end; i += kLanes) {
      for (int k = 0; k < kLanes; ++k) {
        const double t = (x3[i + k] - x0[i + k]) - 3.0 * (x2[i + k] - x1[i + k]);
        acc[k] += t * t;
      }
    }
    for (; i < chunk_end; ++i) {
      const double t = (x3[i] - x0[i]) - 3.0 * (x2[i] - x1[i]);
      acc[0] += t * t;
    }
    total += SumLanes(acc);
  }
  return total;
}

// Strided versions: only i = first, first + stride, ... < end, where first is
// the smallest multiple of stride >= begin. *count receives the number of terms.
int64_t FirstMultipleAtLeast(int64_t begin, int64_t stride) {
  return (begin + stride - 1) / stride * stride;
}

double SumSquaredSecondDifferencesStrided(const double* x, int64_t m, int64_t stride,
                                          int64_t begin, int64_t end, int64_t* count) {
  double total = 0.0;
  int64_t terms = 0;
  int64_t i = FirstMultipleAtLeast(begin, stride);
  while (i < end) {
    double chunk_sum = 0.0;
    for (int64_t k = 0; k < kChunk && i < end; ++k, i += stride) {
      const double d = (x[i + 2 * m] - x[i + m]) - (x[i + m] - x[i]);
      chunk_sum += d * d;
      ++terms;
    }
    total += chunk_sum;
  }
  *count = terms;
  return total;
}

double SumSquaredThirdDifferencesStrided(const double* x, int64_t m, int64_t stride, int64_t begin,
                                         int64_t end, int64_t* count) {
  double total = 0.0;
  int64_t terms = 0;
  int64_t i = FirstMultipleAtLeast(begin, stride);
  while (i < end) {
    double chunk_sum = 0.0;
    for (int64_t k = 0; k < kChunk && i < end; ++k, i += stride) {
      const double t = (x[i + 3 * m] - x[i]) - 3.0 * (x[i + 2 * m] - x[i + m]);
      chunk_sum += t * t;
      ++terms;
    }
    total += chunk_sum;
  }
  *count = terms;
  return total;
}

// MVAR inner sum computed directly:
//   s_j = sum_{i=j}^{j+m-1} (x_{i+2m} - 2x_{i+m} + x_i).
double MvarInnerSum(const double* x, int64_t m, int64_t j) {
  const double* x0 = x + j;
  const double* x1 = x0 + m;
  const double* x2 = x1 + m;
  double total = 0.0;
  for (int64_t chunk = 0; chunk < m; chunk += kChunk) {
    const int64_t chunk_end = std::min(m, chunk + kChunk);
    double acc[kLanes] = {};
    int64_t i = chunk;
    for (; i + kLanes <= chunk_end; i += kLanes) {
      for (int k = 0; k < kLanes; ++k) {
        acc[k] += (x2[i + k] - x1[i + k]) - (x1[i + k] - x0[i + k]);
      }
    }
    for (; i < chunk_end; ++i) acc[0] += (x2[i] - x1[i]) - (x1[i] - x0[i]);
    total += SumLanes(acc);
  }
  return total;
}

// s_{j+1} - s_j = x_{j+3m} - 3x_{j+2m} + 3x_{j+m} - x_j.
inline double MvarStep(const double* x, int64_t m, int64_t j) {
  return (x[j + 3 * m] - x[j]) - 3.0 * (x[j + 2 * m] - x[j + m]);
}

// sum_{j=begin}^{end-1} s_j^2. Each block of terms starts from an exact s_j
// and follows the recurrence; kMvarChains blocks are processed side by side.
// Precondition: x_{j+3m-1} exists for every j < end.
double SumSquaredMvarSums(const double* x, int64_t m, int64_t begin, int64_t end) {
  const int64_t block = std::max(kMvarMinBlock, 8 * m);
  double total = 0.0;
  int64_t j0 = begin;
  while (end - j0 >= kMvarChains * block) {
    double s[kMvarChains];
    for (int c = 0; c < kMvarChains; ++c) s[c] = MvarInnerSum(x, m, j0 + c * block);
    for (int64_t chunk = 0; chunk < block; chunk += kChunk) {
      const int64_t chunk_end = std::min(block, chunk + kChunk);
      double acc[kMvarChains] = {};
      for (int64_t k = chunk; k < chunk_end; ++k) {
        for (int c = 0; c < kMvarChains; ++c) {
          acc[c] += s[c] * s[c];
          // The step after a block's last term is not needed (and would read
          // past the record for the last block).
          if (k + 1 < block) s[c] += MvarStep(x, m, j0 + c * block + k);
        }
      }
      for (int c = 0; c < kMvarChains; ++c) total += acc[c];
    }
    j0 += kMvarChains * block;
  }
  while (j0 < end) {
    const int64_t length = std::min(block, end - j0);
    double s = MvarInnerSum(x, m, j0);
    for (int64_t chunk = 0; chunk < length; chunk += kChunk) {
      const int64_t chunk_end = std::min(length, chunk + kChunk);
      double acc = 0.0;
      for (int64_t k = chunk; k < chunk_end; ++k) {
        acc += s * s;
        if (k + 1 < length) s += MvarStep(x, m, j0 + k);
      }
      total += acc;
    }
    j0 += length;
  }
  return total;
}

// Calls run(begin, end) for each maximal range [begin, end) of term starts i in
// [0, last_start] whose window of rate samples y_i..y_{i+window-1} holds no
// invalid sample. `gaps` are the ascending indices of the invalid samples.
template <typename Run>
void ForEachValidRun(std::span<const int64_t> gaps, int64_t last_start, int64_t window, Run&& run) {
  int64_t begin = 0;
  for (int64_t g : gaps) {
    if (begin > last_start) return;
    const int64_t end = std::min(g - window + 1, last_start + 1);
    if (end > begin) run(begin, end);
    begin = std::max(begin, g + 1);
  }
  if (begin <= last_start) run(begin, last_start + 1);
}

struct TermSum {
  double sum = 0.0;  // sum of squared terms
  int64_t n = 0;     // number of valid terms
};

// What every estimator needs to know about the record, computed once.
struct RecordView {
  const double* x = nullptr;
  int64_t n_phase = 0;
  std::vector<int64_t> gaps;  // ascending indices of invalid rate samples
  PhaseSpan longest;          // longest gap-free span (TOTVAR)
};

RecordView MakeView(const PhaseRecord& phase) {
  assert(phase.invalid_prefix.empty() || phase.invalid_prefix.size() == phase.x.size());
  RecordView view;
  view.x = phase.x.data();
  view.n_phase = phase.size();
  view.gaps = InvalidRateIndices(phase);
  view.longest = LongestValidSpan(phase);
  return view;
}

// Second-difference terms (x_{i+2m} - 2x_{i+m} + x_i)^2, i = 0, s, 2s, ...
TermSum SecondDifferenceTerms(const RecordView& view, int64_t m, int64_t stride) {
  TermSum terms;
  const int64_t last_start = view.n_phase - 1 - 2 * m;
  if (m < 1 || stride < 1 || last_start < 0) return terms;
  ForEachValidRun(view.gaps, last_start, 2 * m, [&](int64_t begin, int64_t end) {
    if (stride == 1) {
      terms.sum += SumSquaredSecondDifferences(view.x, m, begin, end);
      terms.n += end - begin;
    } else {
      int64_t count = 0;
      terms.sum += SumSquaredSecondDifferencesStrided(view.x, m, stride, begin, end, &count);
      terms.n += count;
    }
  });
  return terms;
}

// Third-difference terms (x_{i+3m} - 3x_{i+2m} + 3x_{i+m} - x_i)^2.
TermSum ThirdDifferenceTerms(const RecordView& view, int64_t m, int64_t stride) {
  TermSum terms;
  const int64_t last_start = view.n_phase - 1 - 3 * m;
  if (m < 1 || stride < 1 || last_start < 0) return terms;
  ForEachValidRun(view.gaps, last_start, 3 * m, [&](int64_t begin, int64_t end) {
    if (stride == 1) {
      terms.sum += SumSquaredThirdDifferences(view.x, m, begin, end);
      terms.n += end - begin;
    } else {
      int64_t count = 0;
      terms.sum += SumSquaredThirdDifferencesStrided(view.x, m, stride, begin, end, &count);
      terms.n += count;
    }
  });
  return terms;
}

// MVAR terms s_j^2, j = 0..N-3m; term j uses x_j..x_{j+3m-1}.
TermSum ModifiedTerms(const RecordView& view, int64_t m) {
  TermSum terms;
  const int64_t last_start = view.n_phase - 3 * m;
  if (m < 1 || last_start < 0) return terms;
  ForEachValidRun(view.gaps, last_start, 3 * m - 1, [&](int64_t begin, int64_t end) {
    terms.sum += SumSquaredMvarSums(view.x, m, begin, end);
    terms.n += end - begin;
  });
  return terms;
}

// TOTVAR terms over the longest gap-free span x_a..x_{a+N-1}:
// (x*_{i-m} - 2x*_i + x*_{i+m})^2 for i = 1..N-2, x* reflected at both ends.
// Where i - m >= 0 and i + m <= N-1 no reflection is needed and the
// second-difference kernel runs on the record itself.
TermSum TotalTerms(const RecordView& view, int64_t m) {
  TermSum terms;
  const double* x = view.x + view.longest.begin;
  const int64_t n = view.longest.size();
  if (m < 1 || n < 3 || m > n - 1) return terms;
  const auto extended = [x, n](int64_t j) {
    if (j < 0) return 2.0 * x[0] - x[-j];
    if (j > n - 1) return 2.0 * x[n - 1] - x[2 * (n - 1) - j];
    return x[j];
  };
  const auto edge_terms = [&](int64_t first, int64_t last) {
    double sum = 0.0;
    for (int64_t i = first; i <= last; ++i) {
      const double d = (extended(i + m) - extended(i)) - (extended(i) - extended(i - m));
      sum += d * d;
    }
    return sum;
  };
  const int64_t inner_first = m;
  const int64_t inner_last = n - 1 - m;
  if (inner_first <= inner_last) {
    terms.sum += edge_terms(1, inner_first - 1);
    terms.sum += SumSquaredSecondDifferences(x, m, inner_first - m, inner_last - m + 1);
    terms.sum += edge_terms(inner_last + 1, n - 2);
  } else {
    terms.sum += edge_terms(1, n - 2);
  }
  terms.n = n - 2;
  return terms;
}

CurvePoint PointAt(const RecordView& view, double tau0_s, Deviation dev, int64_t m) {
  CurvePoint point;
  point.m = m;
  point.tau_s = static_cast<double>(m) * tau0_s;
  const double tau = point.tau_s;
  TermSum terms;
  // Divisor k of sum/(k n) in var = sum / (k n tau^2) (MVAR: m^2 tau^2).
  double k = 2.0;
  switch (dev) {
    case Deviation::kAdev:
      terms = SecondDifferenceTerms(view, m, m);
      break;
    case Deviation::kOadev:
      terms = SecondDifferenceTerms(view, m, 1);
      break;
    case Deviation::kMdev:
    case Deviation::kTdev:
      terms = ModifiedTerms(view, m);
      break;
    case Deviation::kHdev:
      terms = ThirdDifferenceTerms(view, m, m);
      k = 6.0;
      break;
    case Deviation::kOhdev:
      terms = ThirdDifferenceTerms(view, m, 1);
      k = 6.0;
      break;
    case Deviation::kTotdev:
      terms = TotalTerms(view, m);
      break;
  }
  point.n = terms.n;
  if (terms.n < 1) return point;
  // dev = sqrt(sum / (k n)) / tau, MDEV with an extra 1/m, TDEV = tau/sqrt(3) MDEV.
  const double rms = std::sqrt(terms.sum / (k * static_cast<double>(terms.n)));
  switch (dev) {
    case Deviation::kMdev:
      point.dev = rms / (static_cast<double>(m) * tau);
      break;
    case Deviation::kTdev:
      point.dev = rms / (static_cast<double>(m) * std::sqrt(3.0));
      break;
    default:
      point.dev = rms / tau;
      break;
  }
  return point;
}

}  // namespace

Curve ComputeDeviation(const PhaseRecord& phase, Deviation dev, std::span<const int64_t> m_list) {
  Curve curve;
  curve.deviation = dev;
  curve.tau0_s = phase.tau0_s;
  curve.n_phase = phase.size();
  curve.invalid_rate_samples = phase.invalid_count();
  const RecordView view = MakeView(phase);
  curve.points.reserve(m_list.size());
  for (int64_t m : m_list) {
    CurvePoint point = PointAt(view, phase.tau0_s, dev, m);
    if (point.n > 1) curve.points.push_back(point);
  }
  return curve;
}

CurvePoint ComputeDeviationAt(const PhaseRecord& phase, Deviation dev, int64_t m) {
  return PointAt(MakeView(phase), phase.tau0_s, dev, m);
}

CurvePoint OverlappingAllanStrided(const PhaseRecord& phase, int64_t m, int64_t stride) {
  const RecordView view = MakeView(phase);
  CurvePoint point;
  point.m = m;
  point.tau_s = static_cast<double>(m) * phase.tau0_s;
  const TermSum terms = SecondDifferenceTerms(view, m, stride);
  point.n = terms.n;
  if (terms.n >= 1) {
    point.dev = std::sqrt(terms.sum / (2.0 * static_cast<double>(terms.n))) / point.tau_s;
  }
  return point;
}

}  // namespace imuqual::allan
