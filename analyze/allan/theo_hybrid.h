// TheoH of a record analysed in bounded memory: the streaming engine's OADEV
// (streaming.h) at short tau and TheoBR on block means (block_means.h) at long
// tau, so that a plan can judge the long-tau end of a soak (the curve minimum,
// the +1/2 slope) out to 0.75 of the record length, where OADEV stops at
// 1/9 (bins9) or 1/4 (stable32) of it.
//
// TheoH (Howe, Taylor & Tasset 2006; NIST SP1065; long_tau.h) with the record
// of N = M + 1 phase points and k = floor(0.2 (N - 1)) tau0:
//   - the Allan points: every point of the OADEV curve with m tau0 < k, as
//     the engine computed them (exact to the engine's strides);
//   - the Theo points: TheoBR(m) = ratio x Theo1(m) at even m with
//     0.75 m tau0 >= k, computed on the block means (B samples per block):
//     Theo1 and the bias-removal ratio's OAVAR/Theo1 terms taken every B
//     samples at m = m' B. m keeps Theo1's factor in samples of the record
//     (tau = 0.75 m tau0), stride = B, n = the block record's (N' - m') m'/2
//     terms (N' its longest gap-free span), as TheoPointEdf reads them.
// Theo1's inner sum over k = 1..m/2 is then taken at k = B, 2B, ..., each
// weighted as the B lags it stands for: for white FM the expectation is
// unchanged (E u_k^2 is linear in k), for the other noises the difference is
// of order 1/m' relative, and TheoBR's ratio, computed on the same block
// record, removes the common part of it. With the default capacity m' is at
// least a few hundred at the switch (0.2 T / (0.75 B) with T/B >= 2048), so
// the block points agree with exact TheoBR to well inside their chi-square
// spread (theo_hybrid_test.cc measures it).
//
// Intervals: when `oadev` carries chi-square intervals, every Theo point takes
// the alpha of the nearest identified Allan point (the long-tau rule of
// confidence.h: no Theo point has the 30 clusters the lag-1 method needs),
// marked alpha_inherited, and gets edf = TheoPointEdf and the chi-square
// interval at the curve's confidence. Otherwise the Theo points carry none.
//
// Pure; the block means are only read.
#ifndef IMUQUAL_ANALYZE_ALLAN_THEO_HYBRID_H_
#define IMUQUAL_ANALYZE_ALLAN_THEO_HYBRID_H_

#include "analyze/allan/block_means.h"
#include "analyze/allan/curve.h"

namespace imuqual::allan {

// Theo points per octave on the long-tau part (the streaming engine's dense
// grid has 8).
inline constexpr int kTheoHybridPointsPerOctave = 8;

// TheoH as above. `oadev`: the record's OADEV curve (n_phase = samples + 1,
// any grid, with or without intervals); `blocks`: the same record's block
// means. The result has deviation kTheoH, oadev's tau0, n_phase, ci and
// confidence. Without Theo points (a record of fewer than 90 blocks, or no
// even factor between the switch and the block record's end) it is the
// Allan part alone.
Curve StreamingTheoH(const Curve& oadev, const BlockMeans& blocks,
                     int points_per_octave = kTheoHybridPointsPerOctave);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_THEO_HYBRID_H_
