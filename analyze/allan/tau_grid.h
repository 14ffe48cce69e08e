// Tau grids (which averaging factors m to evaluate) and stop rules (how far
// along tau a reported curve goes).
//
// Grids follow the reference implementation (tests/reference/NOTES.md) for N
// phase points:
//   octave    m = 2^k,            k = 0..floor(log2 N)
//   decade    m = {1, 2, 4} 10^k, k = 0..floor(log10 N)
//   all       m = 1..N
//   log-dense m = round(10^(k L / (P' - 1))), k = 0..P'-1, L = log10 N,
//             P' = floor(P L) points for P points per decade (ALGORITHMS.md §1)
//   explicit  m = round(tau / tau0) for each requested tau
// Every list is then clipped to 0 < m < N, made unique and sorted. Pure and
// thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_TAU_GRID_H_
#define IMUQUAL_ANALYZE_ALLAN_TAU_GRID_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "analyze/allan/curve.h"
#include "common/status.h"

namespace imuqual::allan {

struct TauGridSpec {
  enum class Kind { kOctave, kDecade, kLogDense, kAll, kExplicit };
  Kind kind = Kind::kOctave;
  int points_per_decade = 10;  // kLogDense only, >= 1
  std::vector<double> tau_s;   // kExplicit only: averaging times, s (> 0)
};

// Parses "octave", "decade", "all", "logP" (P points per decade, e.g. "log10")
// or a comma-separated list of taus in seconds ("1,2,5.5"; spaces allowed).
// The error names the text that could not be read.
Result<TauGridSpec> ParseTauGrid(std::string_view text);

// The canonical text of a grid (inverse of ParseTauGrid up to number format).
std::string TauGridName(const TauGridSpec& grid);

// Largest m whose estimator has more than one term in a gap-free record of
// n_phase points (the reference implementation drops rows with n <= 1):
//   adev floor((N-1)/3), oadev floor((N-2)/2), mdev/tdev floor((N-1)/3),
//   hdev floor((N-1)/4), ohdev floor((N-2)/3), totdev N-1 (needs N >= 4),
//   theo1 N-1, theobr N-1 (needs N >= 90), theoh N-1 (below 90 points only
//   its Allan part, floor((N-1)/5) - 1), mtotdev/ttotdev floor((N-1)/3),
//   htotdev floor((N-2)/3); theo1, theobr and theoh's Theo part only at even m.
// Returns 0 when no m qualifies.
int64_t MaxAveragingFactor(Deviation dev, int64_t n_phase);

// Largest averaging factor the stop rule allows (before the per-estimator
// limit above), in units of tau0: it bounds m, and 0.75 m for the Theo family
// (theo1, theobr and theoh's Theo points are reported at tau = 0.75 m tau0):
//   kBins9    floor(M/9), M = N-1 rate samples (at least 9 clusters of tau);
//   kStable32 floor(N/r), r = 5 adev/hdev, 4 oadev/mdev/tdev/ohdev, 2 totdev,
//             3 mtotdev/ttotdev/htotdev (Riley's table gives 2 for MTOT and
//             TTOT; Stable32 runs stop at 3), 1 theo1/theobr/theoh;
//   kNone     no limit (returns N).
// With kBins9 the long-tau estimators stop where the Allan family does;
// kStable32 or kNone lets them reach as far as they can.
int64_t StopRuleMaxAveragingFactor(StopRule stop, Deviation dev, int64_t n_phase);

// Averaging factors for a record of n_phase phase points at interval tau0_s:
// the grid clipped to 0 < m < n_phase, unique, ascending, then limited by
// MaxAveragingFactor and StopRuleMaxAveragingFactor (on
// EffectiveAveragingFactor for the Theo family), keeping only the m at which
// the estimator has a point (even m for theo1/theobr; theoh's Allan part
// m < floor(0.2 (N-1)) and its even Theo part 0.75 m >= floor(0.2 (N-1))).
// The grid's m are Theo1's m for the Theo family (an octave grid gives
// tau = 0.75 * 2^k tau0). Explicit taus that are not finite and positive are
// ignored. Precondition: tau0_s > 0.
std::vector<int64_t> AveragingFactors(const TauGridSpec& grid, double tau0_s, int64_t n_phase,
                                      Deviation dev, StopRule stop);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_TAU_GRID_H_
