// Confidence intervals on deviation curves (ALGORITHMS.md §2).
//
// Two methods:
//   simple  IEEE 952 Annex C: relative error of the deviation 1/sqrt(2(K-1))
//           with K = floor(valid rate samples / m) non-overlapping clusters,
//           reported as the 1-sigma band dev (1 -+ 1/sqrt(2(K-1))).
//   chi2    NIST SP1065 eq. 45 with the equivalent degrees of freedom nu of
//           Greenhall & Riley (PTTI 2003) for the noise type identified at
//           each m by the lag-1 autocorrelation (noise_id.h):
//             var_lo = nu var / chi2inv(1 - p, nu),
//             var_hi = nu var / chi2inv(p, nu),     p = (1 - CL)/2.
//
// Functions are pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_
#define IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "analyze/allan/curve.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {

// Two-sided confidence level of a 1-sigma interval, erf(1/sqrt(2)).
inline constexpr double kOneSigmaConfidence = 0.6826894921370859;

// 1/sqrt(2(K-1)) for K clusters; NaN if K < 2.
double SimpleErrorFraction(int64_t clusters);

// Regularized lower incomplete gamma function P(a, x) = gamma(a, x)/Gamma(a),
// a > 0, x >= 0 (NaN otherwise). Relative accuracy about 1e-13.
double RegularizedGammaP(double a, double x);

// Inverse CDF of the chi-square distribution with nu > 0 (non-integer allowed)
// degrees of freedom: the x with P(nu/2, x/2) = p. 0 for p <= 0, +Inf for
// p >= 1, NaN for nu <= 0 or NaN arguments. Relative accuracy about 1e-12.
double Chi2Inv(double p, double nu);

// Greenhall & Riley (2003) equivalent degrees of freedom of a variance based
// on d-th differences (d = 2 Allan family, 3 Hadamard family, 1 first
// difference) of n_phase phase points at averaging factor m, for power-law
// noise alpha in -4..2:
//   F = m for an unmodified variance, 1 for a modified one (MVAR);
//   S = m for a fully overlapped estimator, 1 for a non-overlapped one; in
//       general the estimator's stride is m/S samples (any S in [1, m]).
// Case 1 (F = 1, which includes m = 1) and cases 2-4 (F = m, by alpha) as in
// ALGORITHMS.md §2, with J = min(M, floor((d+1) S)). nullopt when the edf is
// not defined: alpha + 2d <= 1, alpha or d out of range, n_phase < L = m/F +
// m d, or non-positive m, F, S.
std::optional<double> GreenhallEdf(int alpha, int d, int64_t m, int64_t n_phase, double F,
                                   double S);

// TOTVAR edf nu = b N/m - c (NIST SP1065 Table 7): (b, c) = (1.50, 0) white FM
// (alpha 0), (1.17, 0.22) flicker FM (-1), (0.93, 0.36) random-walk FM (-2).
// Other alphas: the OAVAR Greenhall edf (d = 2, F = S = m), a lower bound
// because TOTVAR has at least the edf of OAVAR. nullopt when undefined.
std::optional<double> TotalDeviationEdf(int alpha, int64_t m, int64_t n_phase);

// The edf behind a point of `dev` at averaging factor m for noise alpha:
// Greenhall with d = 2 (3 for hdev/ohdev), F = m (1 for mdev/tdev), S = m for
// the overlapped estimators (1 for adev/hdev); TotalDeviationEdf for totdev.
std::optional<double> DeviationEdf(Deviation dev, int alpha, int64_t m, int64_t n_phase);

// (lo, hi) bounds on dev for the given edf and two-sided confidence level in
// (0, 1) (SP1065 eq. 45). (NaN, NaN) when edf is not finite and positive,
// dev is not finite, or the level is outside (0, 1).
std::pair<double, double> Chi2Interval(double dev, double edf, double confidence);

// The long-tau rule's alpha for point i of a curve whose points' own
// identifications are `alphas` (in tau order): its own, else the nearest
// identified point's, the shorter tau on a tie; nullopt when no point is
// identified.
std::optional<int> NearestIdentifiedAlpha(const std::vector<std::optional<int>>& alphas, size_t i);

// Fills lo, hi, edf and alpha of every point of *curve, which was computed
// from `phase` (ComputeDeviation), and sets curve->ci and curve->confidence.
//   kNone    clears them.
//   kSimple  K = floor(valid rate samples / m), lo/hi = dev (1 -+
//            SimpleErrorFraction(K)), edf = K - 1; no alpha. This is a 1-sigma
//            band whatever `confidence` says, and curve->confidence is set to
//            kOneSigmaConfidence.
//   kChi2    per point: alpha from IdentifyNoiseLag1 (dmax 2, or 3 for the
//            Hadamard family). The long-tau rule: a point with fewer than 30
//            decimated points (not identifiable by the lag-1 method) takes the
//            alpha of the nearest identified point of the curve (the shorter
//            tau on a tie) and is marked alpha_inherited; only a curve with no
//            identified point at all leaves it without alpha and interval. A
//            point whose alpha has no defined edf (e.g. alpha = -3 for the
//            Allan family) keeps its alpha but gets no interval. Otherwise
//            edf = DeviationEdf and (lo, hi) = Chi2Interval at `confidence`.
// Gaps (ALGORITHMS.md §5 item 5): with invalid samples the Greenhall N is the
// gap-free record length that would give the point's valid term count n
// (oadev n + 2m, ohdev n + 3m, mdev/tdev n + 3m - 1, adev (n+1)m + 1, hdev
// (n+2)m + 1), capped at the record length; totdev uses its longest gap-free
// span. Without gaps N = curve->n_phase, as the reference does.
void AttachConfidence(const PhaseRecord& phase, CiMethod method, double confidence, Curve* curve);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_
