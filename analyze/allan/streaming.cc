#include "analyze/allan/streaming.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <string>

#include "analyze/allan/confidence.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

// Points per block at level 0; level j uses max(kBlock0 >> j, kLanes). Large
// enough to amortise the per-block bookkeeping, small enough that the whole
// cascade stays well under 64 KiB with C = 8.
constexpr int kBlock0 = 256;

bool IsPowerOfTwo(int64_t v) { return v > 0 && (v & (v - 1)) == 0; }

// Sum of squared second differences over one gap-free block, for every c:
//   sum[ci][p mod kLanes] += ((u_p - u_{p-c}) - (u_{p-c} - u_{p-2c}))^2,
// p = 0..count-1, c = c_first + ci. `phase` points at the block's first point
// and has at least 2 (c_first + c_count - 1) valid points before it. Each
// (c, lane) sum adds its points in increasing p, exactly as the gap path does.
//
// An AVX2 clone (picked at load time where the CPU has it) doubles the vector
// width. Each lane's sum sees the same operations in the same order in either
// clone, and neither uses FMA, so the results are bit-identical.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__) && \
    !defined(IMUQUAL_ALLAN_NO_KERNEL_CLONES)
#define IMUQUAL_ALLAN_KERNEL_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define IMUQUAL_ALLAN_KERNEL_CLONES
#endif

template <int kLanes>
IMUQUAL_ALLAN_KERNEL_CLONES void AccumulateGapFree(const double* phase, int count, int c_first,
                                                   int c_count, double* sum) {
  for (int ci = 0; ci < c_count; ++ci) {
    const int c = c_first + ci;
    const double* x0 = phase;
    const double* x1 = phase - c;
    const double* x2 = phase - 2 * c;
    double acc[kLanes];
    for (int l = 0; l < kLanes; ++l) acc[l] = sum[ci * kLanes + l];
    for (int p = 0; p < count; p += kLanes) {
      for (int l = 0; l < kLanes; ++l) {
        const double d = (x0[p + l] - x1[p + l]) - (x1[p + l] - x2[p + l]);
        acc[l] += d * d;
      }
    }
    for (int l = 0; l < kLanes; ++l) sum[ci * kLanes + l] = acc[l];
  }
}

// Least-squares slope of ys against xs.
double Slope(const std::vector<double>& xs, const std::vector<double>& ys) {
  const double n = static_cast<double>(xs.size());
  double mx = 0, my = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    mx += xs[i];
    my += ys[i];
  }
  mx /= n;
  my /= n;
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    sxy += (xs[i] - mx) * (ys[i] - my);
    sxx += (xs[i] - mx) * (xs[i] - mx);
  }
  return sxx > 0 ? sxy / sxx : kNaN;
}

// One tracked averaging factor's point before its interval.
struct Tracked {
  CurvePoint point;
  int c = 0;
  int64_t stride = 1;
};

// The point of m = c 2^j from the sum of its n valid terms' squared second
// differences: AVAR(m) = sum d^2 / (2 m^2 n), d in rate x samples.
Tracked TrackedPoint(int64_t m, int c, size_t j, double sum, int64_t n, double tau0_s) {
  const double md = static_cast<double>(m);
  Tracked t;
  t.point.m = m;
  t.point.tau_s = md * tau0_s;
  t.point.dev = std::sqrt(sum / (2.0 * md * md * static_cast<double>(n)));
  t.point.n = n;
  t.point.stride = int64_t{1} << j;
  t.c = c;
  t.stride = t.point.stride;
  return t;
}

// The curve of `tracked` (increasing m, within the stop rule) over a record
// of `samples` samples, `invalid` of them invalid or missing: the points on
// `grid` with their intervals per `ci` (StreamingAllan::Oadev).
Curve CurveOfTracked(std::vector<Tracked> tracked, double tau0_s, int64_t samples,
                     int64_t invalid, StreamGrid grid, CiMethod ci, double confidence) {
  Curve curve;
  curve.deviation = Deviation::kOadev;
  curve.tau0_s = tau0_s;
  curve.n_phase = samples + 1;
  curve.invalid_rate_samples = invalid;
  curve.ci = ci;
  // The simple band is 1 sigma whatever the level asked for.
  curve.confidence = ci == CiMethod::kSimple ? kOneSigmaConfidence : confidence;
  constexpr int64_t kMinNoiseIdClusters = StreamingAllan::kMinNoiseIdClusters;
  const int64_t valid_samples = samples - invalid;
  // Noise identification for the chi-square interval: the local slope of
  // ln AVAR against ln m over one octave either side, at every tracked point
  // with at least kMinNoiseIdPoints clusters; beyond (the long-tau end, where
  // the slope of a few noisy points says little) the alpha of the nearest
  // identified point, the shorter tau on a tie (alpha_inherited).
  std::vector<std::optional<int>> alphas(tracked.size());
  if (ci == CiMethod::kChi2) {
    // ln m and ln AVAR of every tracked point, taken once.
    std::vector<double> ln_m(tracked.size()), ln_avar(tracked.size());
    for (size_t u = 0; u < tracked.size(); ++u) {
      ln_m[u] = std::log(static_cast<double>(tracked[u].point.m));
      if (tracked[u].point.dev > 0) ln_avar[u] = 2.0 * std::log(tracked[u].point.dev);
    }
    std::vector<double> log_m, log_avar;
    for (size_t i = 0; i < tracked.size(); ++i) {
      const CurvePoint& point = tracked[i].point;
      if (valid_samples / point.m < kMinNoiseIdClusters) continue;
      log_m.clear();
      log_avar.clear();
      const double center = ln_m[i];
      for (size_t u = 0; u < tracked.size(); ++u) {
        const double lm = ln_m[u];
        if (std::fabs(lm - center) > std::log(2.0) * (1 + 1e-9) || !(tracked[u].point.dev > 0)) {
          continue;
        }
        log_m.push_back(lm);
        log_avar.push_back(ln_avar[u]);
      }
      const double mu = log_m.size() >= 2 ? Slope(log_m, log_avar) : kNaN;
      if (std::isfinite(mu))
        alphas[i] = static_cast<int>(std::clamp(std::lround(-mu - 1.0), -2L, 1L));
    }
  }
  for (size_t i = 0; i < tracked.size(); ++i) {
    const Tracked& t = tracked[i];
    if (grid == StreamGrid::kOctave && !IsPowerOfTwo(t.point.m)) continue;
    CurvePoint point = t.point;
    if (ci == CiMethod::kSimple) {
      const int64_t clusters = valid_samples / point.m;
      if (clusters >= 2) {
        const double f = SimpleErrorFraction(clusters);
        point.lo = point.dev * (1.0 - f);
        point.hi = point.dev * (1.0 + f);
        point.edf = static_cast<double>(clusters - 1);
      }
    } else if (ci == CiMethod::kChi2) {
      const std::optional<int> alpha = NearestIdentifiedAlpha(alphas, i);
      if (alpha) {
        const int64_t n_eff = (point.n - 1) * t.stride + 2 * point.m + 1;
        const std::optional<double> edf =
            GreenhallEdf(*alpha, /*d=*/2, point.m, n_eff, /*F=*/static_cast<double>(point.m),
                         /*S=*/static_cast<double>(t.c));
        if (edf.has_value() && std::isfinite(*edf) && *edf > 0) {
          const auto [lo, hi] = Chi2Interval(point.dev, *edf, confidence);
          point.lo = lo;
          point.hi = hi;
          point.edf = *edf;
          point.alpha = *alpha;
          point.alpha_inherited = !alphas[i].has_value();
        }
      }
    }
    curve.points.push_back(point);
  }
  return curve;
}

}  // namespace

Status StreamingOptions::Validate() const {
  if (!std::isfinite(tau0_s) || tau0_s <= 0) {
    return Status::InvalidArgument("tau0_s must be finite and > 0, got " + std::to_string(tau0_s));
  }
  if (density < 1 || density > 64 || !IsPowerOfTwo(density)) {
    return Status::InvalidArgument("density must be a power of two in [1, 64], got " +
                                   std::to_string(density));
  }
  if (max_m < 1 || max_m > (int64_t{1} << 40)) {
    return Status::InvalidArgument("max_m must be in [1, 2^40], got " + std::to_string(max_m));
  }
  if (reference_rate.has_value() && !std::isfinite(*reference_rate)) {
    return Status::InvalidArgument("reference_rate must be finite");
  }
  return Status::Ok();
}

StreamingAllan::StreamingAllan(const StreamingOptions& options) : options_(options) {
  assert(options_.Validate().ok());
  const int c_big = options_.density;
  history_ = std::max(4 * c_big, kLanes);
  // Level 0 tracks m = 1..min(2C - 1, max_m); level j > 0 tracks m = c 2^j
  // for c in [C, 2C) with m <= max_m, so it exists iff C 2^j <= max_m.
  int num_levels = 1;
  while (num_levels < 62 && (int64_t{c_big} << num_levels) <= options_.max_m) ++num_levels;
  levels_.resize(num_levels);
  for (int j = 0; j < num_levels; ++j) {
    Level& level = levels_[j];
    if (j == 0) {
      level.c_first = 1;
      level.c_count = static_cast<int>(std::min<int64_t>(2 * c_big - 1, options_.max_m));
    } else {
      level.c_first = c_big;
      const int64_t c_last = std::min<int64_t>(2 * c_big - 1, options_.max_m >> j);
      level.c_count = static_cast<int>(c_last - c_big + 1);
    }
    level.block = std::max(kBlock0 >> std::min(j, 30), kLanes);
    level.phase.assign(history_ + level.block, 0.0);
    // G = -1 before the first point: no term reaches back before the record.
    level.invalid_before.assign(history_ + level.block, -1);
    level.sum.assign(static_cast<size_t>(level.c_count) * kLanes, 0.0);
    level.terms.assign(level.c_count, 0);
  }
  yref_ = options_.reference_rate;
  // u_0 = 0 whatever the reference.
  PushPoint(0, 0.0, 0);
}

std::optional<double> StreamingAllan::reference_rate() const { return yref_; }

void StreamingAllan::Append(std::span<const float> rate, std::span<const uint8_t> invalid) {
  AppendImpl(rate, invalid);
}

void StreamingAllan::Append(std::span<const double> rate, std::span<const uint8_t> invalid) {
  AppendImpl(rate, invalid);
}

template <typename Sample>
void StreamingAllan::AppendImpl(std::span<const Sample> rate, std::span<const uint8_t> invalid) {
  assert(invalid.empty() || invalid.size() == rate.size());
  const size_t n = rate.size();
  const bool flags = !invalid.empty();
  size_t i = 0;
  samples_ += static_cast<int64_t>(n);
  // Until the reference is known, samples are buffered one by one.
  for (; i < n && !yref_.has_value(); ++i) {
    const double y = static_cast<double>(rate[i]);
    const bool valid = std::isfinite(y) && !(flags && invalid[i] != 0);
    invalid_ += valid ? 0 : 1;
    BufferForReference(y, valid);
  }
  if (i == n) return;
  // Fast path: integrate straight into level 0's block.
  const double yref = *yref_;
  Level& level0 = levels_[0];
  double phase = phase_;
  int64_t invalid_before = invalid_before_;
  while (i < n) {
    const int take = static_cast<int>(std::min<size_t>(level0.block - level0.fill, n - i));
    double* x = level0.phase.data() + history_ + level0.fill;
    int64_t* g = level0.invalid_before.data() + history_ + level0.fill;
    const int64_t g_start = invalid_before;
    for (int t = 0; t < take; ++t) {
      const double y = static_cast<double>(rate[i + t]);
      // y - y is 0 for finite y and NaN for NaN or Inf.
      const bool valid = (y - y == 0.0) && !(flags && invalid[i + t] != 0);
      phase += valid ? (y - yref) : 0.0;
      invalid_before += valid ? 0 : 1;
      x[t] = phase;
      g[t] = invalid_before;
    }
    invalid_ += invalid_before - g_start;
    i += take;
    level0.fill += take;
    if (level0.fill == level0.block) ProcessBlock(0, level0.block, /*complete=*/true);
  }
  phase_ = phase;
  invalid_before_ = invalid_before;
}

void StreamingAllan::AppendMissing(int64_t count) {
  assert(count >= 0);
  if (count <= 0) return;
  samples_ += count;
  missing_ += count;
  if (!yref_.has_value()) {
    pending_invalid_run_[pending_valid_] += count;
    return;
  }
  PushInvalidRun(count);
}

void StreamingAllan::BufferForReference(double rate, bool valid) {
  if (!valid) {
    ++pending_invalid_run_[pending_valid_];
    return;
  }
  pending_rate_[pending_valid_++] = rate;
  if (pending_valid_ == kReferenceSamples) ResolveReference();
}

void StreamingAllan::ResolveReference() {
  // yref = (1/V) sum of the V buffered valid samples, in arrival order.
  double sum = 0.0;
  for (int i = 0; i < pending_valid_; ++i) sum += pending_rate_[i];
  yref_ = pending_valid_ > 0 ? sum / pending_valid_ : 0.0;
  for (int i = 0; i < pending_valid_; ++i) {
    PushInvalidRun(pending_invalid_run_[i]);
    PushSample(pending_rate_[i], /*valid=*/true);
  }
  PushInvalidRun(pending_invalid_run_[pending_valid_]);
  pending_valid_ = 0;
  pending_invalid_run_.fill(0);
}

void StreamingAllan::PushSample(double rate, bool valid) {
  phase_ += valid ? (rate - *yref_) : 0.0;
  invalid_before_ += valid ? 0 : 1;
  PushPoint(0, phase_, invalid_before_);
}

void StreamingAllan::PushInvalidRun(int64_t count) {
  Level& level0 = levels_[0];
  while (count > 0) {
    const int take = static_cast<int>(std::min<int64_t>(level0.block - level0.fill, count));
    double* x = level0.phase.data() + history_ + level0.fill;
    int64_t* g = level0.invalid_before.data() + history_ + level0.fill;
    const double phase = phase_;
    const int64_t g_start = invalid_before_;
    for (int t = 0; t < take; ++t) {
      x[t] = phase;
      g[t] = g_start + t + 1;
    }
    invalid_before_ = g_start + take;
    count -= take;
    level0.fill += take;
    if (level0.fill == level0.block) ProcessBlock(0, level0.block, /*complete=*/true);
  }
}

void StreamingAllan::PushPoint(size_t j, double phase, int64_t invalid_before) {
  Level& level = levels_[j];
  level.phase[history_ + level.fill] = phase;
  level.invalid_before[history_ + level.fill] = invalid_before;
  if (++level.fill == level.block) ProcessBlock(j, level.block, /*complete=*/true);
}

void StreamingAllan::PushEvenPoints(size_t j, const double* phase, const int64_t* invalid_before,
                                    int count) {
  Level& level = levels_[j];
  int p = 0;
  while (p < count) {
    const int take = std::min(level.block - level.fill, (count - p + 1) / 2);
    double* x = level.phase.data() + history_ + level.fill;
    int64_t* g = level.invalid_before.data() + history_ + level.fill;
    for (int t = 0; t < take; ++t) {
      x[t] = phase[p + 2 * t];
      g[t] = invalid_before[p + 2 * t];
    }
    p += 2 * take;
    level.fill += take;
    if (level.fill == level.block) ProcessBlock(j, level.block, /*complete=*/true);
  }
}

void StreamingAllan::ProcessBlock(size_t j, int count, bool complete) {
  Level& level = levels_[j];
  const double* x = level.phase.data() + history_;
  const int64_t* g = level.invalid_before.data() + history_;
  // G is non-decreasing, so equal ends mean no invalid sample under any term.
  const bool gap_free = count == level.block && g[-history_] == g[count - 1];
  // Every sample under the block invalid (a long gap): no term is valid.
  const bool all_gap = g[count - 1] - g[-1] == (int64_t{count} << j);
  if (all_gap) {
    // Nothing to accumulate.
  } else if (gap_free) {
    AccumulateGapFree<kLanes>(x, count, level.c_first, level.c_count, level.sum.data());
    for (int64_t& t : level.terms) t += count;
  } else {
    for (int p = 0; p < count; ++p) {
      // An invalid sample between points p-1 and p lies under every term
      // ending at p.
      if (g[p] != g[p - 1]) continue;
      const int lane = p % kLanes;
      for (int ci = 0; ci < level.c_count; ++ci) {
        const int c = level.c_first + ci;
        // Valid iff no invalid sample in the window; G(p - 2c) only falls as
        // c grows, so the first invalid c ends the scan.
        if (g[p - 2 * c] != g[p]) break;
        const double d = (x[p] - x[p - c]) - (x[p - c] - x[p - 2 * c]);
        level.sum[ci * kLanes + lane] += d * d;
        ++level.terms[ci];
      }
    }
  }
  if (!complete) return;
  if (j + 1 < levels_.size()) PushEvenPoints(j + 1, x, g, count);
  // Slide: the last `history_` points become the history of the next block.
  std::memmove(level.phase.data(), level.phase.data() + count, history_ * sizeof(double));
  std::memmove(level.invalid_before.data(), level.invalid_before.data() + count,
               history_ * sizeof(int64_t));
  level.fill = 0;
}

void StreamingAllan::Flush() {
  if (!yref_.has_value()) ResolveReference();
  for (size_t j = 0; j < levels_.size(); ++j) {
    Level& level = levels_[j];
    const int fill = level.fill;
    if (fill == 0) continue;
    ProcessBlock(j, fill, /*complete=*/false);
    // The even points of the partial block belong to level j + 1 too.
    if (j + 1 < levels_.size()) {
      PushEvenPoints(j + 1, level.phase.data() + history_, level.invalid_before.data() + history_,
                     fill);
    }
    level.fill = 0;
  }
}

Curve StreamingAllan::Oadev(StreamGrid grid, StopRule stop, CiMethod ci, double confidence) const {
  const StreamMark all = Mark();
  const int64_t m_stop =
      std::min(options_.max_m, StopRuleMaxAveragingFactor(stop, Deviation::kOadev, samples_ + 1));
  // Every tracked point within the stop rule, in increasing m.
  std::vector<Tracked> tracked;
  size_t index = 0;
  for (size_t j = 0; j < levels_.size(); ++j) {
    const Level& level = levels_[j];
    for (int ci_index = 0; ci_index < level.c_count; ++ci_index, ++index) {
      const int c = level.c_first + ci_index;
      const int64_t m = int64_t{c} << j;
      const int64_t n = index < all.terms.size() ? all.terms[index] : 0;
      if (m > m_stop || n <= 1) continue;
      tracked.push_back(TrackedPoint(m, c, j, all.sum[index], n, options_.tau0_s));
    }
  }
  return CurveOfTracked(std::move(tracked), options_.tau0_s, samples_, invalid_samples(), grid, ci,
                        confidence);
}

StreamMark StreamingAllan::Mark() const {
  StreamingAllan flushed = *this;
  flushed.Flush();
  StreamMark mark;
  mark.samples = samples_;
  mark.invalid = invalid_samples();
  for (const Level& level : flushed.levels_) {
    for (int ci_index = 0; ci_index < level.c_count; ++ci_index) {
      double sum = 0.0;
      for (int l = 0; l < kLanes; ++l) sum += level.sum[ci_index * kLanes + l];
      mark.sum.push_back(sum);
      mark.terms.push_back(level.terms[ci_index]);
    }
  }
  size_t keep = mark.terms.size();
  while (keep > 0 && mark.terms[keep - 1] == 0) --keep;
  mark.sum.resize(keep);
  mark.terms.resize(keep);
  mark.sum.shrink_to_fit();
  mark.terms.shrink_to_fit();
  return mark;
}

Curve StreamingAllan::SegmentOadev(std::span<const StreamMark> marks, size_t from, size_t to,
                                   StreamGrid grid, StopRule stop, CiMethod ci,
                                   double confidence) const {
  assert(from < to && to < marks.size());
  const StreamMark& first = marks[from];
  const StreamMark& last = marks[to];
  const int64_t samples = last.samples - first.samples;
  const int64_t invalid = last.invalid - first.invalid;
  const int64_t m_stop =
      std::min(options_.max_m, StopRuleMaxAveragingFactor(stop, Deviation::kOadev, samples + 1));
  const auto at = [](const StreamMark& mark, size_t k) {
    return k < mark.terms.size() ? std::pair{mark.sum[k], mark.terms[k]}
                                 : std::pair{0.0, int64_t{0}};
  };
  std::vector<Tracked> tracked;
  size_t index = 0;
  size_t cut = from;  // the mark whose terms are taken away, for the current m
  for (size_t j = 0; j < levels_.size(); ++j) {
    const Level& level = levels_[j];
    for (int ci_index = 0; ci_index < level.c_count; ++ci_index, ++index) {
      const int c = level.c_first + ci_index;
      const int64_t m = int64_t{c} << j;
      if (m > m_stop) continue;
      // A term of m ending at phase point p spans samples [p - 2m, p): it
      // lies in the stretch iff p >= first.samples + 2m.
      while (cut < to && marks[cut].samples < first.samples + 2 * m - 1) ++cut;
      if (cut >= to) continue;
      const auto [sum_end, n_end] = at(last, index);
      const auto [sum_cut, n_cut] = at(marks[cut], index);
      const int64_t n = n_end - n_cut;
      if (n <= 1) continue;
      tracked.push_back(
          TrackedPoint(m, c, j, std::max(sum_end - sum_cut, 0.0), n, options_.tau0_s));
    }
  }
  return CurveOfTracked(std::move(tracked), options_.tau0_s, samples, invalid, grid, ci,
                        confidence);
}

size_t StreamingAllan::StateBytes() const {
  size_t bytes = sizeof(*this) + levels_.capacity() * sizeof(Level);
  for (const Level& level : levels_) {
    bytes += level.phase.capacity() * sizeof(double);
    bytes += level.invalid_before.capacity() * sizeof(int64_t);
    bytes += level.sum.capacity() * sizeof(double);
    bytes += level.terms.capacity() * sizeof(int64_t);
  }
  return bytes;
}

}  // namespace imuqual::allan
