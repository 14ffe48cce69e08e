// Power-law noise identification at one averaging factor by the lag-1
// autocorrelation method (Riley & Greenhall, EFTF 2004; ALGORITHMS.md §2).
//
// With phase x and averaging factor m:
//   1. decimate: z_k = x_{km}, k = 0..ceil(N/m)-1 (at least 30 points);
//   2. remove a least-squares quadratic in k from z;
//   3. d = 0; loop: r1 = sum_k (z_k - zbar)(z_{k+1} - zbar) / sum_k (z_k - zbar)^2,
//      delta = r1 / (1 + r1); stop if delta < 0.25 or d >= dmax, otherwise
//      z = first difference of z, d = d + 1;
//   4. alpha = -round(2 delta) - 2d + 2 (round half to even), the exponent of
//      the rate PSD S_y(f) ~ f^alpha: 2 white PM, 1 flicker PM, 0 white FM
//      (angle random walk), -1 flicker FM (bias instability), -2 random-walk
//      FM (rate random walk), -3 and -4 beyond; clamped to [-4, 2].
// Use dmax = 2 for the Allan family and 3 for the Hadamard family.
//
// Gaps: the series is taken from the longest gap-free span of the record, so
// no interpolated phase enters the autocorrelation. Pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_NOISE_ID_H_
#define IMUQUAL_ANALYZE_ALLAN_NOISE_ID_H_

#include <cstdint>
#include <optional>

#include "analyze/allan/phase.h"

namespace imuqual::allan {

struct NoiseId {
  int alpha;        // identified integer power-law exponent (see above)
  double rho1;      // lag-1 autocorrelation r1 of the final (differenced) series
  int differences;  // d, the number of differences taken
};

// Minimum decimated series length for the lag-1 method.
inline constexpr int64_t kMinNoiseIdPoints = 30;

// nullopt when fewer than kMinNoiseIdPoints decimated points exist, m < 1,
// dmax < 0, or the detrended series is identically zero (no noise to identify).
std::optional<NoiseId> IdentifyNoiseLag1(const PhaseRecord& phase, int64_t m, int dmax);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_NOISE_ID_H_
