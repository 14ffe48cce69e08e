#include "analyze/allan/theo_hybrid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <tuple>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/long_tau.h"

namespace imuqual::allan {
namespace {

// Even block factors m' from the first whose effective tau 0.75 m' B tau0
// reaches the switch k (in samples) to the block record's last, log-spaced.
std::vector<int64_t> TheoBlockFactors(int64_t switch_samples, int64_t block, int64_t n_blocks_phase,
                                      int per_octave) {
  // Smallest m' with 0.75 m' B >= k, i.e. 3 m' B >= 4 k; even, at least 2.
  int64_t first = (4 * switch_samples + 3 * block - 1) / (3 * block);
  first = std::max<int64_t>(first + (first % 2), 2);
  int64_t last = n_blocks_phase - 1;
  last -= last % 2;
  std::vector<int64_t> out;
  if (last < first) return out;
  for (int i = 0;; ++i) {
    const double target =
        static_cast<double>(first) * std::exp2(static_cast<double>(i) / per_octave);
    int64_t m = 2 * std::llround(target / 2);
    if (m > last) break;
    if (out.empty() || m > out.back()) out.push_back(m);
  }
  if (out.empty() || out.back() != last) out.push_back(last);
  return out;
}

}  // namespace

Curve StreamingTheoH(const Curve& oadev, const BlockMeans& blocks, int points_per_octave) {
  Curve out;
  out.deviation = Deviation::kTheoH;
  out.tau0_s = oadev.tau0_s;
  out.n_phase = oadev.n_phase;
  out.invalid_rate_samples = oadev.invalid_rate_samples;
  out.ci = oadev.ci;
  out.confidence = oadev.confidence;
  const int64_t switch_samples = TheoHSwitchFactor(oadev.n_phase);
  for (const CurvePoint& p : oadev.points) {
    if (p.m < switch_samples) out.points.push_back(p);
  }
  const size_t allan_points = out.points.size();

  const PhaseRecord phase = blocks.Phase();
  const int64_t block = blocks.block_samples();
  const std::vector<int64_t> factors =
      TheoBlockFactors(switch_samples, block, phase.size(), std::max(points_per_octave, 1));
  if (factors.empty() || phase.size() < 90) return out;
  for (CurvePoint p : ComputeDeviation(phase, Deviation::kTheoBr, factors).points) {
    if (!(std::isfinite(p.dev) && p.dev > 0)) continue;
    p.m *= block;
    p.stride = block;
    p.tau_s = 0.75 * static_cast<double>(p.m) * oadev.tau0_s;
    out.points.push_back(p);
  }

  if (oadev.ci != CiMethod::kChi2) return out;
  std::vector<std::optional<int>> own(out.points.size());
  for (size_t i = 0; i < allan_points; ++i) {
    if (!out.points[i].alpha_inherited) own[i] = out.points[i].alpha;
  }
  for (size_t i = allan_points; i < out.points.size(); ++i) {
    CurvePoint& p = out.points[i];
    const std::optional<int> alpha = NearestIdentifiedAlpha(own, i);
    if (!alpha) continue;
    p.alpha = *alpha;
    p.alpha_inherited = true;
    const double edf = TheoPointEdf(p, *alpha);
    if (!std::isfinite(edf)) continue;
    p.edf = edf;
    std::tie(p.lo, p.hi) = Chi2Interval(p.dev, edf, out.confidence);
  }
  return out;
}

}  // namespace imuqual::allan
