#include "analyze/allan/estimators.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "analyze/allan/lane_sum.h"
#include "analyze/allan/long_tau.h"

// The summation kernels are compiled for AVX2 and for the baseline ISA; the
// dynamic loader picks one per machine (function multi-versioning). FMA is
// deliberately not enabled, so both versions round every operation the same
// way and give bit-identical sums (the compiler never reorders lanes).
#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__) && !defined(__clang__)
#define IMUQUAL_VECTOR_KERNEL __attribute__((target_clones("avx2", "default")))
#else
#define IMUQUAL_VECTOR_KERNEL
#endif

namespace imuqual::allan {
namespace {

// Terms are summed in chunks of kChunk into kLanes independent accumulators
// (the compiler maps the lanes onto SIMD registers); each chunk's sum is then
// added to the total. Rounding error grows with the number of chunks, not of
// terms, and the order of summation is fixed, so results are reproducible.
using lanes::kChunk;
using lanes::kLanes;
using lanes::SumLanes;

// MVAR's inner sum is updated by a running recurrence; it is recomputed
// exactly at the start of every block of max(kMvarMinBlock, 8m) terms to bound
// the drift of the recurrence (the exact sum costs m terms, <= 1/8 of the
// block).
constexpr int64_t kMvarMinBlock = 4096;
// Independent recurrence chains run side by side (one SIMD lane each), their
// steps computed kMvarTile at a time.
constexpr int kMvarChains = 4;
constexpr int64_t kMvarTile = 256;

// sum_{i=begin}^{end-1} d_i^2 over one piece (at most kChunk terms), with
//   d_i = (x_{i+2m} - x_{i+m}) - (x_{i+m} - x_i),
// the second difference x_{i+2m} - 2x_{i+m} + x_i written as a difference of
// first differences (each first difference of nearby phases is nearly exact).
IMUQUAL_VECTOR_KERNEL
double SecondDifferencePiece(const double* x, int64_t m, int64_t begin, int64_t end) {
  const double* x0 = x + begin;
  const double* x1 = x0 + m;
  const double* x2 = x1 + m;
  const int64_t count = end - begin;
  double acc[kLanes] = {};
  int64_t i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    for (int k = 0; k < kLanes; ++k) {
      const double d = (x2[i + k] - x1[i + k]) - (x1[i + k] - x0[i + k]);
      acc[k] += d * d;
    }
  }
  for (; i < count; ++i) {
    const double d = (x2[i] - x1[i]) - (x1[i] - x0[i]);
    acc[0] += d * d;
  }
  return SumLanes(acc);
}

// The same for t_i = (x_{i+3m} - x_i) - 3 (x_{i+2m} - x_{i+m}), the third
// difference x_{i+3m} - 3x_{i+2m} + 3x_{i+m} - x_i.
IMUQUAL_VECTOR_KERNEL
double ThirdDifferencePiece(const double* x, int64_t m, int64_t begin, int64_t end) {
  const double* x0 = x + begin;
  const double* x1 = x0 + m;
  const double* x2 = x1 + m;
  const double* x3 = x2 + m;
  const int64_t count = end - begin;
  double acc[kLanes] = {};
  int64_t i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    for (int k = 0; k < kLanes; ++k) {
      const double t = (x3[i + k] - x0[i + k]) - 3.0 * (x2[i + k] - x1[i + k]);
      acc[k] += t * t;
    }
  }
  for (; i < count; ++i) {
    const double t = (x3[i] - x0[i]) - 3.0 * (x2[i] - x1[i]);
    acc[0] += t * t;
  }
  return SumLanes(acc);
}

// Calls piece(b, e) for the pieces of [begin, end) cut at multiples of kChunk,
// in increasing order. Cutting at absolute positions (not relative to begin)
// makes every sum independent of how the range was reached, so a sweep over
// many m at once and a sweep over one m give bit-identical results.
template <typename Piece>
void ForEachPiece(int64_t begin, int64_t end, Piece&& piece) {
  while (begin < end) {
    const int64_t piece_end = std::min(end, (begin / kChunk + 1) * kChunk);
    piece(begin, piece_end);
    begin = piece_end;
  }
}

// The valid term starts for one m, visited in increasing order. Term i in
// [0, last_start] is valid when no invalid rate sample lies in its window
// y_i..y_{i+window-1}; between consecutive invalid samples g' < g the valid
// starts are [g' + 1, g - window].
class ValidRuns {
 public:
  ValidRuns(std::span<const int64_t> gaps, int64_t last_start, int64_t window)
      : gaps_(gaps), last_start_(last_start), window_(window) {}

  // Calls visit(b, e) for each non-empty intersection of a valid run with
  // [lo, hi). Successive calls must cover increasing, non-overlapping ranges.
  template <typename Visit>
  void VisitRange(int64_t lo, int64_t hi, Visit&& visit) {
    while (run_ <= gaps_.size()) {
      const int64_t begin = run_ == 0 ? 0 : gaps_[run_ - 1] + 1;
      const int64_t end = run_ < gaps_.size() ? std::min(gaps_[run_] - window_ + 1, last_start_ + 1)
                                              : last_start_ + 1;
      if (end <= lo) {
        ++run_;
        continue;
      }
      if (begin >= hi) return;
      const int64_t visit_begin = std::max(begin, lo);
      const int64_t visit_end = std::min(end, hi);
      if (visit_end > visit_begin) visit(visit_begin, visit_end);
      if (end > hi) return;
      ++run_;
    }
  }

 private:
  std::span<const int64_t> gaps_;
  int64_t last_start_;
  int64_t window_;
  size_t run_ = 0;
};

// Strided versions: only i = first, first + stride, ... < end, where first is
// the smallest multiple of stride >= begin. *count receives the number of terms.
int64_t FirstMultipleAtLeast(int64_t begin, int64_t stride) {
  return (begin + stride - 1) / stride * stride;
}

double SumSquaredSecondDifferencesStrided(const double* x, int64_t m, int64_t stride, int64_t begin,
                                          int64_t end, int64_t* count) {
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
IMUQUAL_VECTOR_KERNEL
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

// sum_{j=begin}^{begin+count-1} s_j^2 along one recurrence chain from an
// exact s_begin. Precondition: x_{j+3m-1} exists for every summed j.
double MvarChain(const double* x, int64_t m, int64_t begin, int64_t count) {
  double s = MvarInnerSum(x, m, begin);
  double total = 0.0;
  for (int64_t chunk = 0; chunk < count; chunk += kChunk) {
    const int64_t chunk_end = std::min(count, chunk + kChunk);
    double acc = 0.0;
    for (int64_t k = chunk; k < chunk_end; ++k) {
      acc += s * s;
      if (k + 1 < count) s += MvarStep(x, m, begin + k);
    }
    total += acc;
  }
  return total;
}

// steps[k][c] = s_{j+1} - s_j at j = start[c] + k for k < count, except the
// step after a chain's last term (k = last_k), which is not needed and may lie
// past the record: it is stored as 0.
IMUQUAL_VECTOR_KERNEL
void MvarChainSteps(const double* x, int64_t m, const int64_t (&start)[kMvarChains], int64_t count,
                    int64_t last_k, double (*steps)[kMvarChains]) {
  const int64_t computed = std::min(count, last_k);
  for (int c = 0; c < kMvarChains; ++c) {
    const double* x0 = x + start[c];
    const double* x1 = x0 + m;
    const double* x2 = x1 + m;
    const double* x3 = x2 + m;
    for (int64_t k = 0; k < computed; ++k) steps[k][c] = (x3[k] - x0[k]) - 3.0 * (x2[k] - x1[k]);
    for (int64_t k = computed; k < count; ++k) steps[k][c] = 0.0;
  }
}

// sum_{j=begin}^{end-1} s_j^2. The run is cut into groups of up to
// kMvarChains blocks; each block follows the recurrence from an exact s_j
// (bounding its drift), and the kMvarChains blocks of a group advance side by
// side (one SIMD lane each), with their steps computed a tile at a time.
// Precondition: x_{j+3m-1} exists for every j < end.
double SumSquaredMvarSums(const double* x, int64_t m, int64_t begin, int64_t end) {
  const int64_t block = std::max(kMvarMinBlock, 8 * m);
  double total = 0.0;
  double steps[kMvarTile][kMvarChains];
  for (int64_t j0 = begin; j0 < end;) {
    const int64_t group = std::min(end - j0, kMvarChains * block);
    const int64_t length = group / kMvarChains;  // terms per chain
    if (length < kMvarTile) {
      total += MvarChain(x, m, j0, group);
      j0 += group;
      continue;
    }
    int64_t start[kMvarChains];
    double s[kMvarChains];
    for (int c = 0; c < kMvarChains; ++c) {
      start[c] = j0 + c * length;
      s[c] = MvarInnerSum(x, m, start[c]);
    }
    for (int64_t k0 = 0; k0 < length; k0 += kMvarTile) {
      const int64_t tile = std::min(kMvarTile, length - k0);
      int64_t tile_start[kMvarChains];
      for (int c = 0; c < kMvarChains; ++c) tile_start[c] = start[c] + k0;
      MvarChainSteps(x, m, tile_start, tile, length - 1 - k0, steps);
      double acc[kMvarChains] = {};
      for (int64_t k = 0; k < tile; ++k) {
        for (int c = 0; c < kMvarChains; ++c) {
          acc[c] += s[c] * s[c];
          s[c] += steps[k][c];
        }
      }
      total += (acc[0] + acc[1]) + (acc[2] + acc[3]);
    }
    // The group's last (group mod kMvarChains) terms.
    const int64_t rest = group - kMvarChains * length;
    if (rest > 0) total += MvarChain(x, m, j0 + kMvarChains * length, rest);
    j0 += group;
  }
  return total;
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

// Fully overlapped difference terms of the given order (2: OAVAR, 3: OHVAR)
// for every m of m_list (each >= 1), in one sweep: the term starts are cut into
// tiles of kChunk and each tile is finished for every m before the next, so
// the tile's phases are reused from cache instead of being read from memory
// once per m. The result for one m does not depend on which other m are swept
// with it (see ForEachPiece).
std::vector<TermSum> OverlappingTerms(const RecordView& view, int order,
                                      std::span<const int64_t> m_list) {
  std::vector<TermSum> terms(m_list.size());
  std::vector<ValidRuns> runs;
  runs.reserve(m_list.size());
  int64_t sweep_end = 0;
  for (int64_t m : m_list) {
    const int64_t last_start = view.n_phase - 1 - order * m;
    runs.emplace_back(view.gaps, last_start, order * m);
    sweep_end = std::max(sweep_end, last_start + 1);
  }
  for (int64_t tile = 0; tile < sweep_end; tile += kChunk) {
    for (size_t q = 0; q < m_list.size(); ++q) {
      const int64_t m = m_list[q];
      TermSum& t = terms[q];
      runs[q].VisitRange(tile, tile + kChunk, [&](int64_t begin, int64_t end) {
        t.sum += order == 2 ? SecondDifferencePiece(view.x, m, begin, end)
                            : ThirdDifferencePiece(view.x, m, begin, end);
        t.n += end - begin;
      });
    }
  }
  return terms;
}

// Difference terms of the given order at starts i = 0, s, 2s, ... (s >= 2).
TermSum StridedTerms(const RecordView& view, int order, int64_t m, int64_t stride) {
  TermSum terms;
  const int64_t last_start = view.n_phase - 1 - order * m;
  if (last_start < 0) return terms;
  ValidRuns runs(view.gaps, last_start, order * m);
  runs.VisitRange(0, last_start + 1, [&](int64_t begin, int64_t end) {
    int64_t count = 0;
    terms.sum += order == 2
                     ? SumSquaredSecondDifferencesStrided(view.x, m, stride, begin, end, &count)
                     : SumSquaredThirdDifferencesStrided(view.x, m, stride, begin, end, &count);
    terms.n += count;
  });
  return terms;
}

// Difference terms of the given order with stride s at one m.
TermSum DifferenceTerms(const RecordView& view, int order, int64_t m, int64_t stride) {
  if (m < 1 || stride < 1 || view.n_phase - 1 - order * m < 0) return {};
  if (stride == 1) return OverlappingTerms(view, order, std::span<const int64_t>(&m, 1))[0];
  return StridedTerms(view, order, m, stride);
}

// MVAR terms s_j^2, j = 0..N-3m; term j uses x_j..x_{j+3m-1}.
TermSum ModifiedTerms(const RecordView& view, int64_t m) {
  TermSum terms;
  const int64_t last_start = view.n_phase - 3 * m;
  if (m < 1 || last_start < 0) return terms;
  ValidRuns runs(view.gaps, last_start, 3 * m - 1);
  runs.VisitRange(0, last_start + 1, [&](int64_t begin, int64_t end) {
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
    // Interior term i is the plain second difference starting at i - m.
    ForEachPiece(0, inner_last - inner_first + 1, [&](int64_t begin, int64_t end) {
      terms.sum += SecondDifferencePiece(x, m, begin, end);
    });
    terms.sum += edge_terms(inner_last + 1, n - 2);
  } else {
    terms.sum += edge_terms(1, n - 2);
  }
  terms.n = n - 2;
  return terms;
}

TermSum TermsAt(const RecordView& view, Deviation dev, int64_t m) {
  switch (dev) {
    case Deviation::kAdev:
      return DifferenceTerms(view, 2, m, m);
    case Deviation::kOadev:
      return DifferenceTerms(view, 2, m, 1);
    case Deviation::kMdev:
    case Deviation::kTdev:
      return ModifiedTerms(view, m);
    case Deviation::kHdev:
      return DifferenceTerms(view, 3, m, m);
    case Deviation::kOhdev:
      return DifferenceTerms(view, 3, m, 1);
    case Deviation::kTotdev:
      return TotalTerms(view, m);
    default:  // the long-tau estimators (long_tau.h)
      return {};
  }
}

// Samples between consecutive terms: m for the non-overlapped estimators,
// 1 for the overlapped ones (TOTDEV included: every point of the extension).
int64_t Stride(Deviation dev, int64_t m) {
  return dev == Deviation::kAdev || dev == Deviation::kHdev ? m : 1;
}

// dev from the sum of squared terms:
//   AVAR, OAVAR, TOTVAR  sqrt(sum / (2n)) / tau
//   HVAR, OHVAR          sqrt(sum / (6n)) / tau
//   MVAR                 sqrt(sum / (2n)) / (m tau)
//   TVAR                 tau / sqrt(3) MDEV = sqrt(sum / (2n)) / (m sqrt(3))
CurvePoint MakePoint(Deviation dev, int64_t m, double tau0_s, const TermSum& terms,
                     int64_t stride) {
  CurvePoint point;
  point.m = m;
  point.stride = stride;
  point.tau_s = static_cast<double>(m) * tau0_s;
  point.n = terms.n;
  if (terms.n < 1) return point;
  const bool hadamard = dev == Deviation::kHdev || dev == Deviation::kOhdev;
  const double rms = std::sqrt(terms.sum / ((hadamard ? 6.0 : 2.0) * static_cast<double>(terms.n)));
  switch (dev) {
    case Deviation::kMdev:
      point.dev = rms / (static_cast<double>(m) * point.tau_s);
      break;
    case Deviation::kTdev:
      point.dev = rms / (static_cast<double>(m) * std::sqrt(3.0));
      break;
    default:
      point.dev = rms / point.tau_s;
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
  if (IsLongTauDeviation(dev)) {
    for (const CurvePoint& point : LongTauPoints(phase, dev, m_list)) {
      if (point.n > 1) curve.points.push_back(point);
    }
    return curve;
  }
  const RecordView view = MakeView(phase);

  std::vector<TermSum> terms(m_list.size());
  if (dev == Deviation::kOadev || dev == Deviation::kOhdev) {
    // All m share one sweep (see OverlappingTerms).
    const int order = dev == Deviation::kOadev ? 2 : 3;
    std::vector<int64_t> swept_m;
    std::vector<size_t> swept_index;
    for (size_t q = 0; q < m_list.size(); ++q) {
      if (m_list[q] < 1 || view.n_phase - 1 - order * m_list[q] < 0) continue;
      swept_m.push_back(m_list[q]);
      swept_index.push_back(q);
    }
    const std::vector<TermSum> swept = OverlappingTerms(view, order, swept_m);
    for (size_t k = 0; k < swept.size(); ++k) terms[swept_index[k]] = swept[k];
  } else {
    for (size_t q = 0; q < m_list.size(); ++q) terms[q] = TermsAt(view, dev, m_list[q]);
  }

  curve.points.reserve(m_list.size());
  for (size_t q = 0; q < m_list.size(); ++q) {
    if (terms[q].n > 1) {
      curve.points.push_back(MakePoint(dev, m_list[q], phase.tau0_s, terms[q], Stride(dev, m_list[q])));
    }
  }
  return curve;
}

CurvePoint ComputeDeviationAt(const PhaseRecord& phase, Deviation dev, int64_t m) {
  if (IsLongTauDeviation(dev)) return LongTauPoints(phase, dev, std::span<const int64_t>(&m, 1))[0];
  return MakePoint(dev, m, phase.tau0_s, TermsAt(MakeView(phase), dev, m), Stride(dev, m));
}

CurvePoint OverlappingAllanStrided(const PhaseRecord& phase, int64_t m, int64_t stride) {
  return MakePoint(Deviation::kOadev, m, phase.tau0_s,
                   DifferenceTerms(MakeView(phase), 2, m, stride), stride);
}

}  // namespace imuqual::allan
