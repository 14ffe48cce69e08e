// Long-tau estimators over a whole PhaseRecord: Howe's Theo1 family (Theo1,
// TheoBR, TheoH) and the total estimators MTOT, TTOT and HTOT. They reach
// averaging times the Allan family cannot (Theo1 up to tau ~ 0.75 T, the TOT
// family up to T/3) with more degrees of freedom at long tau. Callers usually
// reach them through ComputeDeviation (estimators.h); the Deviation names are
// "theo1", "theobr", "theoh", "mtotdev", "ttotdev" and "htotdev".
//
// Phase x_0..x_{N-1}, tau0, 0-based sums (ALGORITHMS.md conventions).
//
// Theo1 (Howe & Peppler 2003, Howe & Tasset 2004; NIST SP1065 eq. 30), m even,
// 2 <= m <= N-1:
//   Theo1(m) = 1/(0.75 (N-m) (m tau0)^2) sum_{a=0}^{N-m-1} sum_{k=1}^{m/2} (1/k) u_k(a)^2,
//   u_k(a) = (x_{a+m} - x_{a+m-k}) - (x_{a+k} - x_a),
// i.e. the phase increment over the last k samples of [a, a+m] against the
// one over the first k samples, for every k up to half the span (SP1065's
// delta = m/2 - k). n = (N-m) m/2 inner terms, as the reference counts them.
// SP1065 reports a Theo1 point at the *effective* averaging time
// tau = 0.75 m tau0, where Theo1 has the Allan variance's response for white
// FM. The other noises leave a bias that depends on r = 0.75 m (Howe & Tasset
// 2004, Table 1): E[AVAR(r tau0)] / E[Theo1(m)] = a + b r^-c with
// (a, b, c) = (0.09, 0.74, 0.40) WPM, (0.14, 0.82, 0.30) FPM, (1, 0, 0) WFM,
// (1.87, -1.05, 0.79) FFM, (2.70, -1.53, 0.85) RWFM; SP1065 recommends
// m >= 10. allantools 2024.06, the reference in tests/reference/ (NOTES.md),
// computes the same value with no bias correction but labels it tau = m tau0.
//
// **This library reports the effective tau 0.75 m tau0** for Theo1, TheoBR
// and the Theo part of TheoH (CurvePoint::m keeps Theo1's m), so these curves
// share one tau axis with OADEV. TheoTau::kNominal gives allantools' label.
//
// TheoBR, bias-removed Theo1 (Howe, Taylor & Tasset, FCS 2006; SP1065):
//   TheoBR(m) = [1/(n'+1) sum_{i=0}^{n'} OAVAR(9+3i) / Theo1(12+4i)] Theo1(m),
//   n' = floor(0.1 N/3 - 3),
// the mean ratio of OAVAR to Theo1 at the same effective tau ((9+3i) tau0 =
// 0.75 (12+4i) tau0) over the long-tau half of the Allan range, which
// removes Theo1's bias without knowing the noise type. Needs N >= 90.
// The ratio is one number for the whole curve: on a curve whose noise type
// changes it removes the bias of the noise that dominates its range and
// leaves the rest. A gyro's long-tau end is such a curve (white or flicker
// noise turning into rate random walk, whose Theo1 bias is 2.7 where white
// FM's is 1): on white + random-walk FM with the minimum at N/4, TheoBR^2
// averaged 0.57 of OAVAR at the same tau at 0.375 N (long_tau_test), i.e. it
// reads the deviation 25 % low exactly where a minimum is judged. This is why
// plans judge OADEV (whose estimates are unbiased for every noise type) and
// extrapolate with the noise model rather than read a minimum off TheoH.
// The noise model knows Theo1's bias at every tau for its mix of terms
// (CompositeModel::Theo1BiasFactor, Howe & Tasset's Table 1 for pure power
// laws): on the same records Theo1 times the true model's factor (1.77 at
// m = 2048) read 0.977 +- 0.055 of OAVAR where TheoBR read 0.573.
//
// TheoH, the hybrid (same paper; SP1065): OADEV at short tau, TheoBR at long
// tau,
//   TheoH(m) = OAVAR(m)    for m tau0 < k,
//            = TheoBR(m)   for 0.75 m tau0 >= k, m even, m <= N-1,
// k = floor(0.2 (N-1)) tau0, the largest multiple of tau0 not above 20 % of the
// record length T = (N-1) tau0. Averaging factors with k <= m tau0 and
// 0.75 m tau0 < k give no point (TheoHIsAllanPoint, TheoHHasPoint).
//
// MTOT (Howe & Vernotte; SP1065 eq. 27), m <= (N-1)/3, n = N - 3m + 1: for each
// run x_i..x_{i+3m-1}, remove the line through the means of its first and
// last floor(3m/2) points (slope = (mean2 - mean1)/d, d = 3m/2 for even m and
// (3m+1)/2 for odd m), extend it by uninverted even reflection to 9m points
// x* = [reverse, run, reverse], and average the 6m squared second differences
// of m-point sums s_j = sum_{t=j}^{j+m-1} x*_t over j = 0..6m-1:
//   MTOT(m) = 1/(2 (m tau0)^2 n) sum_i [1/(6m) sum_j ((s_j - 2 s_{j+m} + s_{j+2m})/m)^2].
// TTOT (SP1065 eq. 28) = tau/sqrt(3) MTOT (phase units, rate unit * s; the
// reference notes that SP1065 prints tau^3 there by mistake).
// HTOT (Howe et al., PTTI 2000; SP1065), m <= (N-2)/3, n = N - 3m: the same
// construction on runs of 3m rate samples y_i = (x_{i+1} - x_i)/tau0, with the
// line through the half means removed, and the Hadamard second difference of
// m-sample means averaged with weight 1/6:
//   HTOT(m) = 1/n sum_i [1/(6 * 6m) sum_j ((s_j - 2 s_{j+m} + s_{j+2m})/m)^2];
// at m = 1 it is OHDEV (Stable32 and the reference do this for consistency).
// No bias correction is applied to any of them (as the reference and Stable32
// print them): they keep the noise-dependent bias against MVAR/HVAR that
// SP1065's bias tables describe.
//
// Gaps: these estimators need a continuous record (the reflections, the
// detrending and Theo1's nested intervals span up to the whole record), so
// with invalid samples they are computed on the longest gap-free span
// (LongestValidSpan), as TOTDEV is; n and the curve's reach are that span's.
// TheoH takes both parts from that span, so its two halves stay consistent.
//
// Cost and exactness (one core of the machine in tests/reference/NOTES.md):
//   - MTOT, TTOT and HTOT cost O(m) per run, O((N - 3m) m) per m, as the
//     reference does: a 1e4-point octave curve takes about a second, a
//     1e5-point one to m = 8192 (the bins9 limit) about 35 s; the cost grows
//     as N m.
//   - Theo1 costs (N - m) m/2 terms per m when summed directly. Above
//     kTheo1DirectTermBudget terms it is computed exactly by an
//     O(N log N + m log^2 m) reformulation (long_tau.cc) that agrees with the
//     direct sum to ~1e-12 relative: the octave curve of 1e6 points
//     (m = 2..2^19) takes about 1.2 s.
//   - TheoBR and TheoH's Theo part need Theo1 at every m = 12 + 4i (~N/30 of
//     them, one O((0.14 N)^2) sweep) and OADEV at every m = 9 + 3i (~N^2/30
//     terms): 0.3 s for 1e5 points, about 35 s for 1e6.
// All functions are pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_LONG_TAU_H_
#define IMUQUAL_ANALYZE_ALLAN_LONG_TAU_H_

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {

// True for theo1, theobr, theoh, mtotdev, ttotdev and htotdev.
bool IsLongTauDeviation(Deviation dev);

// True for theo1, theobr and theoh (even m, effective tau 0.75 m tau0).
bool IsTheoDeviation(Deviation dev);

// How Theo1, TheoBR and TheoH points report their averaging time.
enum class TheoTau {
  kEffective,  // tau = 0.75 m tau0 (SP1065; this library's default)
  kNominal,    // tau = m tau0 (allantools 2024.06, for comparison with it)
};

// The fraction of the record length T = (N-1) tau0 below which TheoH is the
// Allan deviation (SP1065: "k is the largest tau <= 20% T").
inline constexpr double kTheoHAllanFraction = 0.2;

// k/tau0 of TheoH for a span of n_phase points: floor(0.2 (n_phase - 1)).
int64_t TheoHSwitchFactor(int64_t n_phase);
// Whether TheoH at m is the OADEV point (m < k/tau0).
bool TheoHIsAllanPoint(int64_t m, int64_t n_phase);
// Whether TheoH has a point at m: an Allan point, or an even m <= n_phase - 1
// with 0.75 m >= k/tau0.
bool TheoHHasPoint(int64_t m, int64_t n_phase);

// The averaging factor at which a point's tau lies, in units of tau0:
// 0.75 m for Theo1, TheoBR and the Theo part of TheoH, m otherwise. Used by
// the stop rules (tau_grid.h) and noise identification (confidence.h).
double EffectiveAveragingFactor(Deviation dev, int64_t m, int64_t n_phase);

// One point per entry of m_list (in order) of a long-tau estimator, without
// dropping: n = 0 and dev = NaN where the estimator has no term (m out of
// range, odd m for Theo1/TheoBR, a TheoH gap factor, TheoBR on fewer than 90
// points). Precondition: IsLongTauDeviation(dev).
std::vector<CurvePoint> LongTauPoints(const PhaseRecord& phase, Deviation dev,
                                      std::span<const int64_t> m_list,
                                      TheoTau tau = TheoTau::kEffective);

// A Theo1 estimate beyond a curve's fitted taus, for a noise-model fit
// (gmwm.h's FitCompositeModel) that follows the model where OADEV does not
// reach (up to 0.3 of the record instead of the stop rule's T/9). Its
// moment is ln Theo1 with Theo1's edf (Theo1EdfMeasured at the model's local
// slope), and the model's value
// there is E[Theo1(m)] under the model (CompositeModel::ExpectedTheo1), not
// AVAR: Theo1's bias against AVAR depends on the noise (1 for white FM, 2.7
// for a random walk), and the model knows its own mix at every tau.
struct Theo1Moment {
  int64_t m = 0;        // even, in [2, n_phase - 1]
  double theo1 = kNaN;  // Theo1(m), the rate unit squared
  int64_t n_phase = 0;  // phase points the estimate spans; 0: the curve's
  // Theo1 of the record of the means of `block` consecutive curve samples
  // (every block-th phase point: what a station keeps instead of the
  // samples); m and n_phase count means, the effective tau is
  // 0.75 m block tau0. Its expectation under a model is exact
  // (TermExpectedTheo1OfMeans); its correlations with the curve's points are
  // taken as the samples' Theo1's at m block (the means change the phase
  // only above 1 / (2 block tau0), far above the moment's band).
  int64_t block = 1;
};

// Factors for Theo1 beyond a fit's last tau: even m at effective taus
// 0.75 m tau0 from twice `last_tau_s`, by octaves, while m <= n - 1 and
// 0.75 m <= max_fraction n.
std::vector<int64_t> Theo1OctavesBeyond(double last_tau_s, double tau0_s, int64_t n_phase,
                                        double max_fraction = 0.75);

// The reach of the fit's Theo1 moments, r = 0.75 m <= 0.3 N. Beyond it
// Theo1's edf falls below ~3.5 for a random walk and ln Theo1 is far from
// the Gaussian the fit's J and bootstrap assume (its left tail is long): one
// low point kept the walk out of the model and its minimum low. Measured
// (fit_coverage_bench --long-taus, 87-min records): fit_bias_instability's
// 2-sigma coverage on white + flicker + RRW was 92.5 % with a moment at
// 0.44 N and 96.5 % with the moments to 0.3 N.
inline constexpr double kTheo1MomentReach = 0.3;

// Theo1 of the record at Theo1OctavesBeyond(last_tau_s, ..., kTheo1MomentReach)
// (on the longest gap-free span, whose length each moment carries). `block`:
// the phase is that of the means of `block` samples of the curve the
// moments go with (phase.tau0_s = block times the curve's tau0).
std::vector<Theo1Moment> Theo1MomentsBeyond(const PhaseRecord& phase, double last_tau_s,
                                            int64_t block = 1);

// ---------------------------------------------------------------------------
// The Theo1 machinery, exposed for tests and benchmarks.

// Theo1 by direct summation only while (N - m) m/2 <= this many terms.
inline constexpr int64_t kTheo1DirectTermBudget = int64_t{1} << 25;

enum class Theo1Method {
  kAuto,    // direct within kTheo1DirectTermBudget, otherwise fast
  kDirect,  // the double sum as written, O((N - m) m)
  kFast,    // the reformulation of long_tau.cc, O(N log N + m log^2 m)
};

// The unnormalised Theo1 double sums S(m) = sum_a sum_k (1/k) u_k(a)^2 of a
// gap-free phase series x (so Theo1(m) = S(m) / (0.75 (N-m) (m tau0)^2)), one
// per entry of m_list; NaN for odd m or m outside [2, N-1].
std::vector<double> Theo1Sums(std::span<const double> x, std::span<const int64_t> m_list,
                              Theo1Method method = Theo1Method::kAuto);

// TheoBR's bias-removal ratio 1/(n'+1) sum_{i=0}^{n'} OAVAR(9+3i)/Theo1(12+4i)
// of a gap-free phase series (the ratio is independent of tau0); nullopt for
// fewer than 90 points. kDirect sums every Theo1 directly, kFast uses the batch
// form of the reformulation for all 12 + 4i at once, kAuto the direct sums while
// they stay within kTheo1DirectTermBudget terms in total.
std::optional<double> TheoBrRatio(std::span<const double> x,
                                  Theo1Method method = Theo1Method::kAuto);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_LONG_TAU_H_
