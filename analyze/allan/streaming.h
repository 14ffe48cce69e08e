// Bounded-memory streaming overlapping Allan deviation (ALGORITHMS.md §4,
// "Bounded-memory cascade").
//
// Rate samples y_k (any rate unit: deg/s, m/s^2, ...) arrive in batches. The
// engine integrates them to phase in units of "rate x samples",
//   u_0 = 0,  u_{k+1} = u_k + (y_k - yref)        (the phase x = tau0 * u),
// and keeps a cascade of 2x decimated copies u^(j)_k = u_{k 2^j}, one level per
// octave. For m = c 2^j it accumulates the overlapping Allan terms
//   (u^(j)_k - 2 u^(j)_{k-c} + u^(j)_{k-2c})^2,
// which is the overlapping estimator restricted to a stride of 2^j samples:
//   level 0:   c in [1, 2C)  (m < 2C, full overlap, stride 1),
//   level j>0: c in [C, 2C)  (m = c 2^j, stride 2^j = m/c, Greenhall S = c).
// AVAR(m) = sum d^2 / (2 m^2 n); tau0 cancels.
//
// Gaps: invalid samples (flagged, NaN, Inf) and missing samples (AppendMissing)
// add nothing to the phase and increment a prefix count G of invalid samples
// stored beside every phase point. A term is valid iff G at its last point
// equals G at its first point, i.e. no invalid sample lies under its window.
// Only valid terms are summed and counted (ALGORITHMS.md §5).
//
// Determinism: every sum is accumulated in an order fixed by the absolute
// sample index (blocks aligned to absolute indices, lanes by index mod 8), and
// the reference rate is buffered until it is known, so the output is
// bit-identical whatever the batch boundaries.
//
// Cost: O(C) work per sample (2C - 1 terms at level 0 plus a geometric tail of
// C terms per level, each level seeing half the samples of the one below);
// state is a fixed number of bytes set by the options (StateBytes()), about
// 45 KiB with C = 8 and 28 levels, independent of the record length.
//
// Thread-safety: thread-compatible (const methods may run concurrently; a
// non-const call needs exclusive access). One engine per sensor axis.
#ifndef IMUQUAL_ANALYZE_ALLAN_STREAMING_H_
#define IMUQUAL_ANALYZE_ALLAN_STREAMING_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "analyze/allan/curve.h"
#include "common/status.h"

namespace imuqual::allan {

struct StreamingOptions {
  // Nominal sample interval, s. Must be finite and > 0.
  double tau0_s = 1.0;
  // C, a power of two in [1, 64]: m < 2C at full overlap; beyond, m = c 2^j
  // with c in [C, 2C) at stride 2^j = m/c. Points per octave on the dense grid.
  int density = 8;
  // Largest averaging factor tracked (bounds the number of levels), in
  // [1, 2^40].
  int64_t max_m = int64_t{1} << 30;
  // Rate subtracted before integrating (the input's unit). Any constant gives
  // the same variances in exact arithmetic; a value near the mean keeps the
  // phase small. Default: the mean of the first 64 valid samples (the samples
  // before it is known are buffered, so results never depend on batching).
  std::optional<double> reference_rate;

  // Ok, or InvalidArgument naming the offending field.
  Status Validate() const;
};

// The terms an engine has accumulated up to a moment (StreamingAllan::Mark):
// for each tracked averaging factor, in the engine's order (level by level,
// c within a level), the sum of squared second differences and the count of
// the valid terms whose last phase point is at or before the mark; entries
// past the last factor with terms are left out (zero). Two marks of one
// engine give the curve of the stretch between them (SegmentOadev).
struct StreamMark {
  int64_t samples = 0;  // samples appended before the mark
  int64_t invalid = 0;  // of them invalid or missing
  std::vector<double> sum;
  std::vector<int64_t> terms;
};

// Which tracked averaging factors Oadev() reports.
enum class StreamGrid {
  kOctave,  // m = 2^k only
  kDense,   // every tracked m: 1..2C-1, then C per octave
};

class StreamingAllan {
 public:
  // Number of valid samples averaged for the default reference rate.
  static constexpr int kReferenceSamples = 64;
  // Clusters (valid samples / m) a point needs for its own noise
  // identification; the lag-1 method's minimum, kMinNoiseIdPoints.
  static constexpr int64_t kMinNoiseIdClusters = 30;

  // Precondition: options.Validate().ok() (asserted).
  explicit StreamingAllan(const StreamingOptions& options);

  // Appends consecutive rate samples. `invalid` is empty or has the same
  // length as `rate`; a non-zero entry marks the sample invalid. NaN and +-Inf
  // samples are invalid too. The spans are only read during the call.
  void Append(std::span<const float> rate, std::span<const uint8_t> invalid = {});
  void Append(std::span<const double> rate, std::span<const uint8_t> invalid = {});

  // Appends `count` >= 0 samples that never arrived (a gap in the device
  // sample counter). Costs about as much as appending `count` invalid samples
  // (O(count), roughly a nanosecond each): reject implausible counter jumps
  // before calling.
  void AppendMissing(int64_t count);

  // All samples so far (M), including invalid and missing ones.
  int64_t samples() const { return samples_; }
  // Invalid plus missing samples so far.
  int64_t invalid_samples() const { return invalid_ + missing_; }
  // Missing samples alone (AppendMissing).
  int64_t missing_samples() const { return missing_; }
  // The reference rate in use; nullopt while it is still being collected.
  std::optional<double> reference_rate() const;

  // Overlapping Allan deviation at the tracked m on `grid` allowed by `stop`
  // (kBins9: m <= floor(M/9); kStable32: m <= floor((M+1)/4); kNone: no
  // limit), keeping only points with n > 1 valid terms and m <= max_m.
  // Points carry m, tau_s = m tau0, dev (rate unit), n = valid terms.
  // Confidence per `ci` at level `confidence` in (0, 1):
  //  - kSimple: K = floor(valid samples / m) clusters, dev (1 -+ 1/sqrt(2(K-1))),
  //    edf = K - 1 (none when K < 2). A 1-sigma band whatever `confidence`
  //    says; the curve's confidence is then the 1-sigma level.
  //  - kChi2: chi-square interval with the Greenhall edf for d = 2, F = m and
  //    the engine's stride factor S (m below 2C, c beyond), on the phase points
  //    the valid terms span, N_eff = (n - 1) m/S + 2m + 1 (the record length
  //    when there is no gap; the heuristic of ALGORITHMS.md §5 otherwise).
  //    alpha comes from the local slope mu of log AVAR against log tau (least
  //    squares over the tracked points within one octave either side):
  //    alpha = clamp(round(-mu - 1), -2, 1), at every tracked point with at
  //    least kMinNoiseIdClusters = 30 clusters (valid samples / m). The
  //    long-tau rule: a point with fewer takes the alpha of the nearest
  //    identified tracked point (the shorter tau on a tie) and is marked
  //    alpha_inherited. The clamp at 1 is deliberate:
  //    a slope cannot tell white (alpha 2) from flicker (alpha 1) phase noise,
  //    and alpha = 1 has the smaller edf, so the interval errs wide; below -2
  //    (rate ramp) AVAR-type edf are not defined and -2 is used, as in
  //    ALGORITHMS.md §2. No interval (NaN lo/hi/edf, no alpha) when fewer than
  //    two neighbouring points give a slope anywhere on the curve or the edf
  //    is undefined.
  Curve Oadev(StreamGrid grid, StopRule stop, CiMethod ci,
              double confidence = 0.682689492137086) const;

  // The terms accumulated so far (see StreamMark). Costs a copy of the
  // engine's state and the terms of its partial blocks (microseconds).
  StreamMark Mark() const;

  // The overlapping Allan deviation of the samples between two marks of this
  // engine, [marks[from].samples, marks[to].samples), from the terms that lie
  // wholly inside that stretch: for averaging factor m, the terms that end
  // by marks[to] less those that end by the first mark at or after
  // marks[from].samples + 2m - 1 (every term reaching back before the
  // stretch, and those up to that mark: a term wholly inside is never
  // counted twice nor across the boundary, so each point is the unbiased
  // estimator on fewer terms, exact when the marks fall at term ends).
  // Marks in increasing samples; from < to. Grid, stop rule (on the
  // stretch's length) and intervals as Oadev(), on the stretch's own
  // samples, invalid samples and terms.
  Curve SegmentOadev(std::span<const StreamMark> marks, size_t from, size_t to, StreamGrid grid,
                     StopRule stop, CiMethod ci,
                     double confidence = 0.682689492137086) const;

  // Bytes of state held by this engine (object plus heap), bounded by the
  // options whatever the record length.
  size_t StateBytes() const;

  const StreamingOptions& options() const { return options_; }

 private:
  static constexpr int kLanes = 8;  // independent partial sums per c

  // One octave of the cascade. Buffers hold `history` older points followed by
  // the current block of `block` points; the block starts at a level index
  // that is a multiple of `block`.
  struct Level {
    int c_first = 0;                      // first tracked c (1 at level 0, C beyond)
    int c_count = 0;                      // tracked c values: c_first .. c_first + c_count - 1
    int block = 0;                        // points per block (multiple of kLanes)
    int fill = 0;                         // points in the current block
    std::vector<double> phase;            // u^(j), history + block
    std::vector<int64_t> invalid_before;  // G at each point, history + block
    std::vector<double> sum;              // [c - c_first][lane] sums of d^2
    std::vector<int64_t> terms;           // [c - c_first] valid terms
  };

  template <typename Sample>
  void AppendImpl(std::span<const Sample> rate, std::span<const uint8_t> invalid);
  // Feeds one sample with a known reference rate.
  void PushSample(double rate, bool valid);
  // Adds a run of `count` invalid phase points to level 0.
  void PushInvalidRun(int64_t count);
  // Buffers a sample while the reference rate is unknown.
  void BufferForReference(double rate, bool valid);
  // Fixes yref from the buffered samples (mean of the valid ones, 0 if none)
  // and replays them.
  void ResolveReference();
  // Appends one point to level `j`, processing the block when it fills.
  void PushPoint(size_t j, double phase, int64_t invalid_before);
  // Appends points 0, 2, 4, .. < count of phase/invalid_before to level j.
  void PushEvenPoints(size_t j, const double* phase, const int64_t* invalid_before, int count);
  // Accumulates the terms of the first `count` points of level j's block, then
  // (if `complete`) hands the even points to level j + 1 and slides history.
  void ProcessBlock(size_t j, int count, bool complete);
  // Processes every partial block, top-down to the last level (used on a copy).
  void Flush();

  StreamingOptions options_;
  int history_ = 0;  // points kept before each block: 4C
  std::vector<Level> levels_;

  // Level-0 phase state.
  double phase_ = 0.0;
  int64_t invalid_before_ = 0;
  std::optional<double> yref_;

  // Counters.
  int64_t samples_ = 0;
  int64_t invalid_ = 0;
  int64_t missing_ = 0;

  // Samples held while the default reference rate is collected: the valid
  // values in order, and before each (and at the end) the run of invalid
  // samples that preceded it.
  std::array<double, kReferenceSamples> pending_rate_{};
  std::array<int64_t, kReferenceSamples + 1> pending_invalid_run_{};
  int pending_valid_ = 0;
};

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_STREAMING_H_
