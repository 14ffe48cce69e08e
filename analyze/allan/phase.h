// The phase record every exact estimator works on, and its construction from
// rate (gyro deg/s, accelerometer m/s^2, fractional frequency) or phase samples.
//
// Rate samples y_0..y_{M-1} at interval tau0 become phase (integrated angle or
// velocity) x_0..x_{N-1}, N = M + 1:
//   x_0 = 0,  x_{k+1} = tau0 * sum_{j<=k} (y_j - yref),
// with yref the mean of the valid rate samples. Any constant yref leaves every
// deviation unchanged (second and third differences cancel it); removing the
// mean keeps |x| small, so the differences lose no digits (ALGORITHMS.md §4).
// The running sum is scaled by tau0 after accumulation, which is the rounding
// of the reference implementation's freq->phase conversion for gap-free data.
//
// Gaps (ALGORITHMS.md §5): a rate sample that is NaN, +-Inf or flagged invalid
// contributes 0 to the running sum and is counted in a prefix count. Every
// estimator term whose window touches an invalid rate sample is skipped, so 0
// is never used as a gap *marker*: 0 is a valid rate.
//
// Functions here are pure and thread-safe; a PhaseRecord is a plain value.
#ifndef IMUQUAL_ANALYZE_ALLAN_PHASE_H_
#define IMUQUAL_ANALYZE_ALLAN_PHASE_H_

#include <cstdint>
#include <span>
#include <vector>

namespace imuqual::allan {

struct PhaseRecord {
  double tau0_s = 1.0;    // sample interval, s
  std::vector<double> x;  // phase x_0..x_{N-1}, rate unit * s
  // Validity prefix count: empty when every rate sample is valid; otherwise
  // size N, invalid_prefix[k] = number of invalid rate samples among
  // y_0..y_{k-1}. A window of rate samples y_a..y_{b-1} is valid iff
  // invalid_prefix[b] == invalid_prefix[a].
  std::vector<int64_t> invalid_prefix;

  // Number of invalid rate samples in the record.
  int64_t invalid_count() const { return invalid_prefix.empty() ? 0 : invalid_prefix.back(); }
  // Number of phase points N.
  int64_t size() const { return static_cast<int64_t>(x.size()); }
};

// Rate -> phase as described above. Precondition: `invalid` is empty or has
// one flag per rate sample (non-zero = invalid: saturated, outlier, placeholder
// for a dropped sample); samples without a flag are judged by value only. An
// empty `rate` gives an empty record (no phase points).
PhaseRecord PhaseFromRate(std::span<const double> rate, double tau0_s,
                          std::span<const uint8_t> invalid = {});
PhaseRecord PhaseFromRate(std::span<const float> rate, double tau0_s,
                          std::span<const uint8_t> invalid = {});

// Phase samples used as they are (no offset removed). A NaN or +-Inf phase
// point is a gap: it invalidates the rate samples on both sides of it
// (y_{k-1} and y_k), which is how a phase gap turns into rate gaps, and its
// value is replaced by the nearest earlier finite phase (or the next one at the
// start) so that running sums stay finite. Terms that touch it are skipped.
PhaseRecord PhaseFromPhase(std::span<const double> phase, double tau0_s);

// The longest run of phase points x_a..x_{b-1} (b - a points) with no invalid
// rate sample between them, as [a, b). Ties go to the earliest run. For a
// gap-free record this is [0, N).
struct PhaseSpan {
  int64_t begin = 0;
  int64_t end = 0;
  int64_t size() const { return end - begin; }
};
PhaseSpan LongestValidSpan(const PhaseRecord& phase);

// Indices k (ascending) of the invalid rate samples y_k; empty when gap-free.
std::vector<int64_t> InvalidRateIndices(const PhaseRecord& phase);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_PHASE_H_
