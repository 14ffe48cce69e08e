// Exact batch estimators of the Allan family over a whole PhaseRecord.
//
// With phase x_0..x_{N-1}, tau = m tau0 and 0-based sums (ALGORITHMS.md §1):
//   AVAR   1/(2 tau^2 n) sum_{i = 0, m, 2m, ..} (x_{i+2m} - 2x_{i+m} + x_i)^2,
//          n = floor((N-1)/m) - 1
//   OAVAR  the same over every i = 0..N-2m-1,                      n = N - 2m
//   MVAR   1/(2 m^2 tau^2 n) sum_{j=0}^{N-3m} [sum_{i=j}^{j+m-1}
//          (x_{i+2m} - 2x_{i+m} + x_i)]^2,                         n = N - 3m + 1
//   TVAR   tau^2/3 MVAR (TDEV is in phase units: rate unit * s)
//   HVAR   1/(6 tau^2 n) sum_{i = 0, m, 2m, ..}
//          (x_{i+3m} - 3x_{i+2m} + 3x_{i+m} - x_i)^2,              n = floor((N-1)/m) - 2
//   OHVAR  the same over every i = 0..N-3m-1,                      n = N - 3m
//   TOTVAR 1/(2 tau^2 (N-2)) sum_{i=1}^{N-2} (x*_{i-m} - 2x*_i + x*_{i+m})^2,
//          x* the record reflected about both end points:
//          x*_{-j} = 2x_0 - x_j, x*_{N-1+j} = 2x_{N-1} - x_{N-1-j}, n = N - 2
// and dev = sqrt(var). These are the reference implementation's conventions
// (tests/reference/NOTES.md), which match NIST SP1065 and Stable32.
// ComputeDeviation also computes the long-tau estimators Theo1, TheoBR, TheoH,
// MTOTDEV, TTOTDEV and HTOTDEV (long_tau.h: formulas, the effective tau
// 0.75 m tau0 of the Theo family, gaps and cost).
//
// Gaps: a term is skipped when any rate sample inside its window is invalid
// (OAVAR/AVAR term i: y_i..y_{i+2m-1}; OHVAR/HVAR: y_i..y_{i+3m-1}; MVAR term
// j: y_j..y_{j+3m-2}) and n counts the valid terms only, so the result is the
// pool of the per-segment sums. TOTVAR needs a continuous record: with gaps it
// is computed on the longest gap-free span (its n is then that span's N - 2).
//
// Cost: O(N) per m (O(N/m) for the non-overlapped AVAR/HVAR), three or four
// loads per term, no allocation per m. ComputeDeviation evaluates all m of
// OAVAR/OHVAR in one tiled sweep so the record is read from memory about once
// rather than once per m; the result for an m is bit-identical to evaluating
// it alone. All functions are pure and thread-safe; the record is only read.
#ifndef IMUQUAL_ANALYZE_ALLAN_ESTIMATORS_H_
#define IMUQUAL_ANALYZE_ALLAN_ESTIMATORS_H_

#include <cstdint>
#include <span>

#include "analyze/allan/curve.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {

// Exact computation at each m of m_list, in the order given. Points with
// n <= 1 (including m out of range) are dropped, as the reference does. Fills
// m, tau_s = m tau0, dev and n of each point; lo/hi/edf/alpha stay empty
// (see AttachConfidence). The curve's n_phase and invalid_rate_samples
// describe the record.
Curve ComputeDeviation(const PhaseRecord& phase, Deviation dev, std::span<const int64_t> m_list);

// One point of ComputeDeviation, without dropping: n = 0 and dev = NaN when
// no valid term exists (m < 1 or too large for the record).
CurvePoint ComputeDeviationAt(const PhaseRecord& phase, Deviation dev, int64_t m);

// OAVAR at one m using only the terms i = 0, s, 2s, ... (s = stride >= 1):
// s = 1 is OADEV, s = m is ADEV. Gap-aware like the rest. Used to check the
// streaming engine's strided estimates. n = 0 and dev = NaN when no valid term
// exists.
CurvePoint OverlappingAllanStrided(const PhaseRecord& phase, int64_t m, int64_t stride);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_ESTIMATORS_H_
