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
// Functions are pure and thread-safe. GreenhallEdf and Chi2Interval keep, per
// thread, values they computed before (sz terms, chi-square factors) and
// read them again: the same doubles as computing them anew.
#ifndef IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_
#define IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_

#include <cstdint>
#include <optional>
#include <span>
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

// The same for an unmodified estimate (F = m) of a mixture of independent
// power-law noises, alpha in -4..0, each with its share of the estimate's
// expectation (shares >= 0, summing to 1 or not: they are normalised). The
// estimate's terms are correlated as the mixture's own structure function
// says (the sum of each noise's sz scaled to its share), so its variance
// carries the noises' cross terms: it is not a combination of the noises'
// edfs. Where Greenhall & Riley read a table (J > 100 with r = M/S >= d + 1)
// the basic sum is taken on a coarser lag grid with the same r (S' = 100 /
// (d + 1)), as their r < d + 1 case does. nullopt as GreenhallEdf, or when
// no share is positive.
struct PowerLawShare {
  int alpha = 0;
  double share = 0;
};
std::optional<double> GreenhallMixtureEdf(std::span<const PowerLawShare> shares, int d, int64_t m,
                                          int64_t n_phase, double S);

// TOTVAR edf nu = b N/m - c (NIST SP1065 Table 7): (b, c) = (1.50, 0) white FM
// (alpha 0), (1.17, 0.22) flicker FM (-1), (0.93, 0.36) random-walk FM (-2).
// Other alphas: the OAVAR Greenhall edf (d = 2, F = S = m), a lower bound
// because TOTVAR has at least the edf of OAVAR. nullopt when undefined.
std::optional<double> TotalDeviationEdf(int alpha, int64_t m, int64_t n_phase);

// Theo1 edf (Howe & Peppler, EFTF/FCS 2003, as tabulated in NIST SP1065) for
// even m on N = n_phase points, with r = 0.75 m the effective averaging factor:
//   alpha  2 (WPM)  0.86 (N+1)(N - 4r/3)/(N - r) * r/(r + 1.14)
//   alpha  1 (FPM)  (4.798 N^2 - 6.374 N r + 12.387 r)/(sqrt(r + 36.6) (N - r)) * r/(r + 0.3)
//   alpha  0 (WFM)  [(4.1 N + 0.8)/r - (3.1 N + 6.5)/N] * r^1.5/(r^1.5 + 5.2)
//   alpha -1 (FFM)  (2 N^2 - 1.3 N r - 3.5 r)/(N r) * r^3/(r^3 + 2.3)
//   alpha -2 (RWFM) (4.4 N - 2)/(2.9 r) * [a^2 - 8.6 r a + 11.4 r^2]/(4.4 N - 3)^2, a = 4.4 N - 1
// TheoBR and TheoH's Theo points use it too: the bias removal is one scale
// factor for the whole curve, which leaves the chi-square shape unchanged.
// nullopt for other alphas, m outside [2, N-1], or a non-positive value.
std::optional<double> Theo1Edf(int alpha, int64_t m, int64_t n_phase);

// Theo1's edf as measured (Monte Carlo) where SP1065's formulas do not hold:
// for white, flicker and random-walk FM (alpha 0, -1, -2) at r = 0.75 m >=
// 0.1 N, the edf nu whose psi(nu/2) - ln(nu/2) is the mean of ln(Theo1 /
// E[Theo1]) (the bias a fit's log moment removes; the variance of ln Theo1
// is at most psi'(nu/2)), linear in r / N between a table's points 0.05
// apart; Theo1Edf elsewhere. SP1065's random-walk formula gives 0.5 at r =
// N/2 where Theo1 has 1.9 and none beyond r = 0.63 N; its white-FM one is
// 25-45 % low beyond r = N/4 (theo1_edf_bench prints both). The noise-model
// fit's Theo1 moments, the long-tau check and the theo1, theobr and theoh
// curves' intervals (DeviationEdf) use this.
std::optional<double> Theo1EdfMeasured(int alpha, int64_t m, int64_t n_phase);

// MTOT edf nu = b N/m - c (SP1065 MTOT edf table): (b, c) = (1.90, 2.10) WPM,
// (1.20, 1.40) FPM, (1.10, 1.20) WFM, (0.85, 0.50) FFM, (0.75, 0.31) RWFM.
// TTOT is tau/sqrt(3) MTOT, a fixed scale, so it has the same edf. nullopt for
// alpha outside [-2, 2] or a non-positive value.
std::optional<double> ModifiedTotalEdf(int alpha, int64_t m, int64_t n_phase);

// HTOT edf nu = (N/m) / (b0 + b1 m/N) for m >= 16 (Howe et al., PTTI 2000 and
// SP1065 HTOT edf table): (b0, b1) = (0.559, 1.004) WFM, (0.868, 1.140) FFM,
// (0.938, 1.696) RWFM, (0.974, 2.554) FWFM, (1.276, 3.149) RRFM. Below m = 16
// (where HTOT starts as OHDEV at m = 1) and for the phase noises, which the
// table does not cover, the OHVAR Greenhall edf (d = 3, F = S = m), as
// Stable32 falls back to the Hadamard edf there. nullopt when undefined.
std::optional<double> HadamardTotalEdf(int alpha, int64_t m, int64_t n_phase);

// The edf behind a point of `dev` at averaging factor m for noise alpha:
// Greenhall with d = 2 (3 for hdev/ohdev), F = m (1 for mdev/tdev), S = m for
// the overlapped estimators (1 for adev/hdev); TotalDeviationEdf for totdev;
// Theo1EdfMeasured for theo1, theobr and theoh's Theo points (the OADEV Greenhall edf
// at its Allan points, TheoHIsAllanPoint with N = n_phase);
// ModifiedTotalEdf for mtotdev and ttotdev; HadamardTotalEdf for htotdev.
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
// The long-tau estimators (long_tau.h): N is their longest gap-free span (the
// record itself when gap-free), K counts that span's rate samples, and both K
// and the noise identification use the point's tau in samples,
// EffectiveAveragingFactor (0.75 m, rounded for the lag-1 method, at the Theo
// points); htotdev identifies with dmax 3 like the Hadamard family.
void AttachConfidence(const PhaseRecord& phase, CiMethod method, double confidence, Curve* curve);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_CONFIDENCE_H_
