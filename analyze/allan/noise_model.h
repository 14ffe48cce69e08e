// IEEE Std 952 (Annex C) noise model of a gyro or accelerometer and its
// estimation from an Allan deviation curve (ALGORITHMS.md §3):
//
//   sigma^2(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2
//
// Q quantization, N angle (velocity) random walk, B bias instability, K rate
// random walk, R rate ramp. Base units (tau in s, rate in deg/s or m/s^2):
//   gyro:  Q deg, N deg/sqrt(s), B deg/s, K deg/s/sqrt(s), R deg/s^2;
//   accel: Q m/s, N m/s/sqrt(s), B m/s^2, K m/s^2/sqrt(s), R m/s^3.
// units.h converts them to datasheet units.
//
// Two estimators:
//  - FitNoiseModel: weighted non-negative least squares on AVAR with
//    iteratively re-weighted passes (the recommended one; gives uncertainties);
//  - ReadSlopeLine / FindCurveMinimum: the IEEE 952 slope-line read-offs.
// All functions are pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_NOISE_MODEL_H_
#define IMUQUAL_ANALYZE_ALLAN_NOISE_MODEL_H_

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/curve.h"
#include "common/status.h"

namespace imuqual::allan {

enum class NoiseTerm {
  kQuantization,
  kAngleRandomWalk,
  kBiasInstability,
  kRateRandomWalk,
  kRateRamp
};
inline constexpr std::array<NoiseTerm, 5> kNoiseTerms = {
    NoiseTerm::kQuantization, NoiseTerm::kAngleRandomWalk, NoiseTerm::kBiasInstability,
    NoiseTerm::kRateRandomWalk, NoiseTerm::kRateRamp};

// "quantization", "angle_random_walk", "bias_instability", "rate_random_walk",
// "rate_ramp".
std::string_view NoiseTermName(NoiseTerm t);

// sqrt(2 ln2 / pi) = 0.664: the flat AVAR level of bias instability is
// (2 ln2/pi) B^2, so B = sigma_min / 0.664 (IEEE convention).
inline constexpr double kBiasInstabilityFactor = 0.66428247026796006;

// AVAR basis function of a term at tau_s: sigma^2 = sum_t coef_t^2 basis_t(tau):
// 3/tau^2, 1/tau, 2 ln2/pi, tau/3, tau^2/2.
double NoiseTermAvarBasis(NoiseTerm t, double tau_s);

// Power-law exponent alpha (ALGORITHMS.md §2, model-based identification) of
// the noise a term produces: Q 2, N 0, B -1, K -2, R -2 (a ramp is a drift,
// not a power law; -2 keeps AVAR edf defined).
int NoiseTermAlpha(NoiseTerm t);

struct TermEstimate {
  double value = kNaN;  // coefficient in base units (0 when the fit left it out)
  double sigma = kNaN;  // 1-sigma uncertainty of value (NaN when not active)
  bool active = false;  // in the fit's non-negative active set
};

// Per-point diagnostics of the final pass.
struct FitPoint {
  int64_t m = 0;
  double tau_s = kNaN;
  double avar = kNaN;        // measured AVAR (dev^2)
  double model_avar = kNaN;  // fitted model at tau_s
  double edf = kNaN;         // nu used for the weight
  int alpha = 0;             // noise exponent behind that nu
};

struct NoiseFit {
  TermEstimate q, n, b, k, r;
  int points_used = 0;
  int irls_passes = 0;         // re-weighted passes done after the first
  double weighted_ssr = kNaN;  // sum_j w_j^2 (avar_j - model_j)^2 of the last pass
  std::vector<FitPoint> points;

  const TermEstimate& term(NoiseTerm t) const;
  // sqrt(3Q^2/tau^2 + N^2/tau + (2ln2/pi)B^2 + K^2 tau/3 + R^2 tau^2/2) over
  // the active terms, rate unit; tau_s > 0.
  double ModelDeviation(double tau_s) const;
};

struct FitOptions {
  // Re-weighted passes after the first, in [0, 20]. Pass 1 weights by the
  // measured AVAR; later passes by the previous model (removes the bias of
  // weighting by a noisy value). 2-5 is plenty.
  int irls_passes = 3;
  // Points with m beyond the rule are ignored (kBins9: m <= floor(M/9),
  // M = n_phase - 1; kStable32: m <= floor(N/4) OADEV, floor(N/5) ADEV).
  StopRule stop = StopRule::kBins9;
  // Keep about one point per octave (greedily: the first point, then each point
  // with m >= 2 x the last kept m). Neighbouring AVARs of a dense grid are
  // strongly correlated, and the fit treats the points as independent.
  bool thin_to_octaves = true;

  // Ok, or InvalidArgument naming the offending field.
  Status Validate() const;
};

// Weighted NNLS with IRLS over an OADEV or ADEV curve (ALGORITHMS.md §3):
//  1. rows j: A_jt = basis_t(tau_j), b_j = dev_j^2; unknowns c_t = coef_t^2 >= 0;
//  2. row weight w_j = sqrt(nu_j/2)/ref_j, since Var(avar_hat) = 2 avar^2/nu.
//     Pass 1: ref_j = avar_hat_j, nu_j = the point's edf when present, else the
//     Greenhall edf for the alpha of the local slope. Later passes: ref_j =
//     model_j and nu_j = Greenhall (d = 2, F = m, S = m for OADEV, 1 for ADEV)
//     with the alpha of the term that dominates the model at tau_j. N for
//     Greenhall is the span of the valid terms, min(n_phase, (n-1) s + 2m + 1)
//     and S = m/s, with s the point's stride (CurvePoint::stride; when unknown
//     1 for OADEV, m for ADEV), so streaming curves get their real edf;
//  3. columns of W A scaled to unit norm, solved by column-pivoting QR;
//  4. exact NNLS: all 31 non-empty subsets, those with a negative coefficient
//     discarded, the smallest weighted SSR kept;
//  5. covariance (A' W A)^-1 on the active set; sd(coef) = sd(coef^2)/(2 coef).
// The covariance ignores the correlation of neighbouring AVARs, so it
// understates the error: in simulations the scatter of the estimates was 1.0
// to 1.8 times the reported sigma, depending on the term (octave thinning
// keeps it at that).
// Errors: unsupported deviation, fewer than 2 usable points, bad options.
Result<NoiseFit> FitNoiseModel(const Curve& curve, const FitOptions& options = {});

// IEEE 952 slope-line read-off. The local log-log slope at a point is the
// slope to its neighbours (central; one-sided at the ends). Points within +-0.1
// of the term's slope s (Q -1, N -1/2, B 0, K +1/2, R +1) are on the slope.
// Each term is non-negative, so each tangent line bounds it from above:
//   Q <= min sigma_j tau_j/sqrt(3), N <= min sigma_j sqrt(tau_j),
//   K <= min sigma_j sqrt(3/tau_j), R <= min sigma_j sqrt(2)/tau_j,
//   B <= sigma_min/0.664
// (tangent_bound; taken over the points from the first one on the slope on:
// a real part's anti-alias filter makes the shortest taus flatter than -1/2
// and puts them below the ARW line, where they bound nothing).
//
// N (the -1/2 line, read at tau = 1 s): the points on the slope that are also
// within +-0.2 of it to each neighbour (where the curve turns, a filter's
// flat top beside a decimation edge, the central slope can read -1/2) are
// fitted as AVAR x tau = N^2 + b/tau + c tau: b/tau takes quantization noise
// or a band-limiting filter's deficit (first-order or FIR-filtered white
// noise is q/tau - b'/tau^2 beyond the filter), c tau the rise of flicker or
// a Gauss-Markov bump; with fewer than 5 such points, or over less than a
// factor 4 in tau (the three columns then nearly fit one another), N^2 alone
// (a weighted mean). Points without an edf are left out (none has one: equal
// weights and no uncertainty). Weighted least squares (weights from the fitted line and the
// points' Greenhall edf for white FM); uncertainty: the sandwich covariance
// with the white-noise correlations between the points' AVARs, times the
// Birge ratio sqrt(SSR / E[SSR]) when the points scatter more than that (a
// real curve is not exactly three terms; birge_ratio on the record).
// Measured (acquire/bias_instability_coverage_test.cc, 87-min simulated
// gyros, 200 records each): 1-sigma coverage 70.0 % (white + flicker + RRW),
// 70.0 % (with a Gauss-Markov bump), 68.0 % (white noise through a
// first-order 20 Hz filter), 2-sigma 98.0 / 97.5 / 96.5 %, mean z -0.04 /
// -0.22 / +0.09. No cap: the
// old mean line capped at the tangent bound read 0.5-0.75 sigma low, and 8 %
// low (-5 sigma) on filtered white noise. No clean point, or a non-positive
// N^2: value = tangent_bound and upper_bound_only.
//
// Q, K, R: the line ln sigma = c + s ln tau with c = mean(ln sigma_j - s ln
// tau_j) over the points on the slope, read at tau = sqrt(3) (Q), 3 (K),
// sqrt(2) (R), capped at the tangent bound (on a curve where a neighbouring
// term lifts the slope points, the mean line can exceed it). B =
// sigma_min/0.664 (the tangent bound).
// When no point has the slope, value = tangent_bound and upper_bound_only.
// Points with a non-positive or non-finite dev are ignored; an empty curve
// gives NaN values with upper_bound_only = true.
//
// uncertainty (1-sigma, NaN for B and for upper_bound_only) of Q, K, R:
// value x the mean over the points on the slope of 1/sqrt(2 edf_j), edf_j the
// Greenhall edf (d = 2, F = m, S = m/stride, N from the point's valid terms)
// for the term's own noise (NoiseTermAlpha): the chi-square error of points
// whose errors are correlated (their mean error, not divided by sqrt(n)). It
// does not cover the read-off's systematic errors: K's covered 5 % (41 %) of
// simulated records that had a +1/2 slope at all (flicker lifts the short
// +1/2 stretch of such records): it is not a usable uncertainty for K, whose
// estimate is the noise model's.
struct SlopeReadoff {
  double value = kNaN;
  bool upper_bound_only = false;
  int points_on_slope = 0;
  double tangent_bound = kNaN;
  double uncertainty = kNaN;
  // N only: the points of the line fit, its terms (3: N^2, b/tau, c tau; 1:
  // N^2 alone) and its Birge ratio (NaN without a degree of freedom).
  int points_in_fit = 0;
  int line_terms = 0;
  double birge_ratio = kNaN;
};
SlopeReadoff ReadSlopeLine(const Curve& curve, NoiseTerm term);

// The Greenhall edf (d = 2, F = m, S = m/stride) of an overlapping Allan
// point for noise alpha, with N the gap-free record that gives its valid
// terms (capped at curve_n_phase when > 0). NaN when undefined.
double PointEdf(const CurvePoint& point, int64_t curve_n_phase, int alpha);
// The same for a mixture of power-law noises with their shares of the
// point's AVAR (GreenhallMixtureEdf: the noises' cross terms in).
double PointMixtureEdf(const CurvePoint& point, int64_t curve_n_phase,
                       std::span<const PowerLawShare> shares);

// The curve's minimum (the convention of many datasheets, and of the seed's
// "bias instability") and min/0.664 (IEEE 952's B), both in the rate unit.
// nullopt when no point has a positive finite dev.
struct CurveMinimum {
  double dev = kNaN;
  double tau_s = kNaN;
  int64_t m = 0;
  double bias_instability_ieee = kNaN;  // dev / sqrt(2 ln2/pi)
};
std::optional<CurveMinimum> FindCurveMinimum(const Curve& curve);

// The 1-sigma standard uncertainty of `min`, a minimum of `curve` (a deviation,
// the bias-instability reading), in the curve's unit: MinimumSelectionSpread
// where the bottom's shape can be fitted, else MinimumPointSpread.
double MinimumUncertainty(const Curve& curve, const CurveMinimum& min);

// The fallback: the point's chi-square spread, dev / sqrt(2 edf) (Greenhall
// edf, d = 2, F = m, S = m / stride, N from its valid terms, flicker FM: the
// noise whose Allan deviation is flat), combined with how far the point lies
// below the points within an octave of it. NaN when the edf is not defined
// at that point.
double MinimumPointSpread(const Curve& curve, const CurveMinimum& min);

// The standard uncertainty of a curve's minimum as a reading of the truth's
// minimum (the bias-instability reading): the curve's minimum is the least
// of the correlated noisy points of its bottom, so it scatters and lies low.
// The points within an octave of `min` are drawn (4000 draws from a fixed
// seed: a pure function of the curve) about the bottom's shape
// (FitBottomShape), each AVAR as chi-square / edf (Wilson-Hilferty; the edf
// of the shape's white + flicker + random-walk mixture, PointMixtureEdf:
// the terms' cross terms in) with flicker FM's correlations between
// overlapping AVAR estimates. u = level x r, level the
// mean of those points, r half the 95.45 % quantile of |least - truth| /
// level over the draws (each with its own level; the truth is the shape's
// minimum over the points fitted): the +-2u interval is calibrated, the
// +-1u one covers at least 68.3 %. None when the shape cannot be fitted.
std::optional<double> MinimumSelectionSpread(const Curve& curve, const CurveMinimum& min);

// The bottom's own shape: AVAR = a / tau + b + c tau (white noise, flicker
// and a random walk; a, b, c >= 0) fitted by weighted least squares to the
// points within two octaves of `min` (weights edf / (2 AVAR^2), flicker FM's
// Greenhall edf, AVAR first the points' own and then the first fit's, so
// that a point reading low by chance does not weigh more; no correlations: a
// cheap fit whose shape, not its uncertainty, is used). None with fewer than
// 3 points.
struct BottomShape {
  double a = 0, b = 0, c = 0;
  double Dev(double tau_s) const { return std::sqrt(a / tau_s + b + c * tau_s); }
};
std::optional<BottomShape> FitBottomShape(const Curve& curve, const CurveMinimum& min);

// The standard uncertainty of the minimum's tau as a reading of the truth's
// (the value is the curve's minimum point, where B is read): the points
// within two octaves of `min` are drawn about the bottom's shape as in
// MinimumSelectionSpread (4000 draws, fixed seed; the shape's own
// white + flicker + random-walk correlations), and u(ln tau) is the 68.27 %
// quantile of |ln tau(least point) - ln vertex| over the draws, vertex =
// sqrt(a / c) (a flat bottom's minimum wanders near-uniformly, so half the
// 95.45 % quantile would under-cover at 1 sigma; the 2-sigma coverage is
// measured). A record that ends near the vertex cannot put its minimum
// beyond the last point, and the draws say so. Not resolved, with the
// reason, when the minimum is the curve's longest tau (the curve has not
// turned up), the shape cannot be fitted, has no rising or no falling line
// (no vertex to read) or puts its vertex more than an octave outside the
// points drawn.
struct MinimumTauSpread {
  bool resolved = false;
  std::string why;
  double u_ln_tau = kNaN;
  double vertex_s = kNaN;  // sqrt(a / c) of the shape
  int points = 0;
  double tau_lo_s = kNaN, tau_hi_s = kNaN;  // the points drawn
};
MinimumTauSpread MinimumTauSelectionSpread(const Curve& curve, const CurveMinimum& min);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_NOISE_MODEL_H_
