// Estimation of a composite noise model (composite_model.h) from an Allan
// variance curve, in the manner of the generalized method of wavelet moments
// (Guerrier, Skaloud, Stebler & Victoria-Feser, JASA 108(502), 2013;
// ALGORITHMS.md §3b). The Haar wavelet variance at scale 2m is AVAR(m)/2, so
// octave AVARs are wavelet variances up to a constant.
//
// Data: the curve's points (ADEV or OADEV), thinned to about one per octave,
// up to the stop rule. Moments y_j = ln(avar_j) - b_j, where
// b_j = psi(nu_j/2) - ln(nu_j/2) is the mean of ln(chi2_nu/nu), so that y_j is
// unbiased for ln AVAR_j whatever the edf nu_j (no weighting by the noisy
// value, hence none of the downward bias of weighted least squares on AVAR).
//
// Objective: J(theta) = (y - ln nu(theta))' Sigma^-1 (y - ln nu(theta)),
// theta = log scales, log correlation times, logit frequencies (every scale
// positive by construction). Sigma = Var(ln avar_hat) is fixed before the
// candidates are compared, never re-weighted by the model being fitted:
//  pass 1  Sigma diagonal, trigamma(nu_j/2), nu_j from the curve's own noise
//          identification (lag-1 ACF) or, without it, from the local slope of
//          the measured curve (Greenhall edf with the point's real stride);
//  pass 2  Sigma from the pass-1 selected model (a smoother of the measured
//          curve): diagonal from Greenhall's edf with the alpha of the
//          pilot's local slope, correlations between points from the pilot's
//          spectrum, rho_ab = I_ab / sqrt(I_aa I_bb),
//          I_ab = int_0^1/2 S(f)^2 H_a(f) H_b(f) df, H_m = sin^4(pi f m) /
//          (m^2 sin^2(pi f)) (the asymptotic covariance of the squared Allan
//          differences of a Gaussian process). Neighbouring octave AVARs of
//          white noise correlate by ~0.5, of a random walk by ~0.9.
// Parameters: each term's scale relative to the curve's mean deviation (in
// log), a correlation time relative to tau0 (in log), a frequency as a logit
// of Nyquist: the search is the same whatever unit the record is read in.
// Starts: the model is linear in the squared scales, so for given
// correlation times and frequencies the scales that minimize the linearized
// objective (non-negative least squares) start every estimation (variable
// projection).
// Model selection: forward-backward search from the best subset of the IEEE
// 952 terms (Q, N, B, K, R), adding one Gauss-Markov term (from the minima of
// the linearized objective over a grid of correlation times, 2 per octave,
// and an even spread), one sinusoid (an even spread of frequencies) or a
// missing IEEE term while the criterion improves, and dropping any term whose
// removal improves it; after each step every correlation time and frequency
// of the model is searched again over its grid, the others held. Criterion: corrected Akaike on the objective,
//   AICc = J + 2k + 2k(k+1)/(p-k-1)   (k parameters, p points),
// the GMWM information criterion with Sigma^-1 weights plus the small-sample
// correction (16 points do not carry 12 parameters), except that a
// one-parameter IEEE term costs 3.84 instead of 2 (see GmwmOptions). The eight best
// candidates of pass 1 are re-estimated in pass 2 (from their pass-1
// parameters and from scales re-solved under the full covariance, the better
// kept), and the search goes on from the best of them.
// Adequacy: with Sigma^-1 weights J is asymptotically chi-square with p - k
// degrees of freedom (Hansen's J test); p-value below the level: inadequate.
// Uncertainty: a parametric bootstrap in the moments (replicates drawn with
// Sigma's correlations and each point's ln chi-square distribution, refitted
// with the candidate's model); every sigma is the standard deviation of its
// quantity over the replicates. The delta method, (G' Sigma^-1 G)^-1, gave
// sigmas of K 1.4x too small on simulated five-term records (nonlinearity).
// Absent terms: an IEEE 952 term the selected model leaves out is not "0":
// its 95 % upper bound is the scale at which the profile of J (the selected
// model refitted with the term held fixed) rises by 5.412 (the nominal 99 %
// level, which covers 95 % given that the selection left the term out).
// Model averaging: the datasheet figures and the IEEE 952 term parameters
// are Akaike-weighted averages over the candidates within 10 of the best
// criterion, with the unconditional variance (selection uncertainty
// included); Gauss-Markov and sinusoid parameters are the selected model's.
// All functions are pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_GMWM_H_
#define IMUQUAL_ANALYZE_ALLAN_GMWM_H_

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "analyze/allan/composite_model.h"
#include "analyze/allan/curve.h"
#include "analyze/allan/long_tau.h"
#include "common/status.h"

namespace imuqual::allan {

struct GmwmOptions {
  // Points with m beyond the rule are ignored (see FitOptions).
  StopRule stop = StopRule::kBins9;
  // Keep about one point per octave: denser grids add little information and
  // much correlation.
  bool thin_to_octaves = true;
  // Points with tau below this are not fitted, >= 0 (0: every point). Below
  // a sensor's own output filter (a decimation FIR, a low-pass) the curve is
  // shaped by that filter, not by the noise the datasheet figures describe;
  // the record says which taus the model was asked to follow.
  double min_tau_s = 0;
  int max_gauss_markov = 3;  // in [0, 3]
  int max_sinusoids = 2;     // in [0, 2]
  // A model whose J-test p-value is below this level is inadequate, in (0, 1).
  double adequacy_level = 0.01;
  // Criterion J + penalties + 2k(k+1)/(p-k-1): `parameter_penalty` per
  // parameter of a two-parameter term (Gauss-Markov, sinusoid) and
  // `single_term_penalty` per one-parameter term (Q, N, B, K, R), each in
  // [0, 20]. 2 and 2 are AICc: in simulations it kept a spurious Q or B in
  // 10-15 % of records (a one-parameter term that lowers J by 2 has a 16 %
  // chance of being noise); 3.84, the chi2(1) 95 % point, makes such a term
  // pass a 5 % likelihood-ratio test to enter and keeps the truth's model in
  // 90-95 % of records. 3 per parameter for the two-parameter terms too
  // dropped a real second Gauss-Markov term on the real ADIS16405 x gyro (3
  // of 16 points outside their 95 % interval), so they keep AIC's 2.
  double parameter_penalty = 2;
  double single_term_penalty = 3.84;
  // Bootstrap replicates behind every sigma, in [0, 5000]; 0: no sigmas.
  int bootstrap_replicates = 100;
  // Gauss-Markov terms with a correlation time below this fraction of 1 s are
  // filtered white noise for the datasheet ARW (they join the -1/2 asymptote).
  double fast_gauss_markov_fraction = 0.1;
  // Compute the 95 % upper bound of every IEEE 952 term the selected model
  // leaves out (about 12 refits of the selected model per term).
  bool absent_term_bounds = true;
  // The rise of J that bounds an absent term, > 0: 5.412 is the one-sided
  // 99 % likelihood-ratio level; among records whose selection left the
  // term out it covers the truth in >= 95 % (the nominal 95 %, 2.706,
  // covered in 84-91 % there: those records' long-tau points came out low).
  double absent_term_bound_delta_j = 5.412;
  // Check the search (slow: ~5000 full estimates, seconds per fit): where the
  // selected model has two sinusoids or two or more Gauss-Markov terms,
  // estimate it from every pair of the search's frequencies and from every
  // pair of correlation times of each pair of its Gauss-Markov terms, and
  // report the least J (pair_grid_objective).
  bool check_pair_search = false;

  // Ok, or InvalidArgument naming the offending field.
  Status Validate() const;
};

// A term of the selected model with 1-sigma uncertainties (NaN where the
// parameter does not apply).
struct FittedTerm {
  ModelTerm term;
  double scale_sigma = kNaN;
  double correlation_time_sigma_s = kNaN;
  double frequency_sigma_hz = kNaN;
};

// A figure read off the model curve with the IEEE 952 rules.
struct ModelFigure {
  double value = kNaN;
  double sigma = kNaN;  // 1-sigma (bootstrap)
  // IEEE 952 terms the selected model leaves out (value 0): the 95 % upper
  // bound the data allow (profile of J, see above); NaN when not computed or
  // not bounded by the analysed taus.
  double upper_bound = kNaN;
};

struct ModelCandidate {
  std::string name;
  int parameters = 0;
  double objective = kNaN;  // J in the final pass
  double criterion = kNaN;  // J + penalty k + 2k(k+1)/(p-k-1)
  double p_value = kNaN;
  double weight = 0;  // Akaike weight in the model average (0: not averaged)
  CompositeModel model;  // its terms as fitted (no sigmas)
};

struct GmwmPoint {
  int64_t m = 0;
  double tau_s = kNaN;
  double avar = kNaN;        // measured
  double model_avar = kNaN;  // selected model
  double edf = kNaN;         // final pass
  double z = kNaN;           // (y - ln model) / sd, the point's standardized residual
  // A Theo1 moment: tau_s is 0.75 m tau0, avar the measured Theo1 and
  // model_avar the model's E[Theo1(m)].
  bool theo1 = false;
};

struct CompositeFit {
  double tau0_s = kNaN;
  CompositeModel model;
  std::vector<FittedTerm> terms;  // the model's terms, same order
  int points_used = 0;
  int parameters = 0;
  double objective = kNaN;  // J
  int dof = 0;              // points - parameters
  double p_value = kNaN;
  bool adequate = false;
  double criterion = kNaN;                 // AICc of the selected model
  std::vector<ModelCandidate> candidates;  // best first, the selected one first
  std::vector<GmwmPoint> points;

  // Datasheet figures from the model (base units: u sqrt(s), u, s, u/sqrt(s)):
  //  white_asymptote: the -1/2 asymptote at 1 s, sqrt(N^2 + sum over fast
  //    Gauss-Markov terms of their long-term white level sigma^2 tau0
  //    (1+phi)/(1-phi)); has_white_region: the model's local slope comes
  //    within +-0.1 of -1/2 somewhere over the analysed taus.
  //  curve_minimum / tau_at_minimum: the minimum of the model deviation over
  //    the analysed taus; minimum_at_edge when it sits at either end. Where
  //    it sits at the edge and the model has no random walk, curve_minimum
  //    is the midpoint between that minimum and the one with the random walk
  //    the data allow at 1 sigma (edge_rate_random_walk, K; the profile of J
  //    rising by 1), and its sigma includes the half-span (edge_half_span).
  //  bias_instability_ieee = curve_minimum / 0.664.
  //  rate_random_walk: K of the random walk term (0 when not selected).
  //  The figures are model-averaged (see above).
  ModelFigure white_asymptote;
  bool has_white_region = false;
  ModelFigure curve_minimum;
  ModelFigure tau_at_minimum;
  bool minimum_at_edge = false;
  double edge_rate_random_walk = kNaN;  // K [u/sqrt(s)], where used (above)
  double edge_half_span = 0;            // [u], added to curve_minimum
  // Where the model has a random walk and no flicker term: the flicker the
  // data allow at 1 sigma (B [u]), and half the fall of the selected
  // model's K with it fixed beside the model's terms, as a fraction of that
  // K applied to the model-averaged K [u/sqrt(s)], taken off
  // rate_random_walk (and ieee_terms[3]), whose sigma includes it / sqrt(3).
  double flicker_for_rate_random_walk = kNaN;
  // With GmwmOptions::check_pair_search: the least J of the selected model
  // estimated from every pair of frequencies and of correlation times (NaN
  // without two sinusoids or two Gauss-Markov terms). Below `objective`:
  // the search missed that minimum.
  double pair_grid_objective = kNaN;
  double rate_random_walk_half_span = 0;
  ModelFigure bias_instability_ieee;
  ModelFigure rate_random_walk;
  // Q, N, B, K, R, model-averaged where the selected model has the term, else
  // 0 with a NaN sigma and the 95 % upper bound the data allow.
  std::array<ModelFigure, 5> ieee_terms;

  double ModelDeviation(double tau_s) const { return model.Deviation(tau_s / tau0_s, tau0_s); }
};

// Where a model misses the curve, for a record that must say where and why
// a model is inadequate: the (at most `count`) points with the largest
// standardized residuals, largest first, as "2.56 s (z -1.8), 81.9 s (z
// -1.7)". The J test weighs the residuals with their correlations, so an
// inadequate model can have no single |z| above 2: the misfit is then in the
// curve's shape across neighbouring points.
std::string LargestResiduals(const CompositeFit& fit, int count = 3);

// The edf of a Theo1 moment at m on n_phase points for noise alpha as the
// fit takes it: Theo1EdfMeasured, white FM's where alpha has none; nullopt
// when neither has one.
std::optional<double> Theo1MomentEdf(int alpha, int64_t m, int64_t n_phase);
// The same for the noise of `model` at the moment's effective tau: alpha
// from the model's AVAR slope at 0.75 m (AlphaFromAvarSlope), as the fit's
// second pass weighs its moments and the long-tau check judges Theo1.
std::optional<double> Theo1MomentEdf(const CompositeModel& model, double tau0_s, int64_t m,
                                     int64_t n_phase);

// Errors: not an ADEV/OADEV curve, fewer than 4 usable points (at or above
// min_tau_s), bad options or Theo1 moments (naming which), no candidate
// could be estimated. `long_taus` (ascending tau, beyond the curve's last
// fitted point) join the curve's points as moments (above); the figures'
// taus then reach the longest of them.
Result<CompositeFit> FitCompositeModel(const Curve& curve, const GmwmOptions& options = {},
                                       std::span<const Theo1Moment> long_taus = {});

// One model's own datasheet figures over the taus [tau_lo_s, tau_hi_s], as
// FitCompositeModel computes them for each candidate before averaging: the
// -1/2 asymptote at 1 s (white noise and every Gauss-Markov term faster than
// options.fast_gauss_markov_fraction of 1 s) and the model deviation's
// minimum and its tau. (A fit's own figures are averaged over its plausible
// candidates; this is the figures of a model taken as the truth, e.g. of
// records simulated from it.)
struct ModelCurveFigures {
  double white_asymptote = kNaN;
  double curve_minimum = kNaN;
  double tau_at_minimum = kNaN;
};
ModelCurveFigures ModelFiguresOver(const CompositeModel& model, double tau0_s, double tau_lo_s,
                                   double tau_hi_s, const GmwmOptions& options = {});

// Correlation between the AVAR estimates at averaging factors m_a and m_b of
// a Gaussian process with the model's spectrum (see above); 1 when
// m_a == m_b. Exposed for tests.
double AvarCorrelation(const CompositeModel& model, double tau0_s, int64_t m_a, int64_t m_b);
// The same for every pair of averaging factors: n x n, row-major, unit
// diagonal (the pass-2 covariance's correlations).
std::vector<double> AvarCorrelationMatrix(const CompositeModel& model, double tau0_s,
                                          const std::vector<int64_t>& m);
// The same for moments some of which are Theo1 estimates (theo1[j] != 0),
// as FitCompositeModel weighs them with long_taus: AVAR pairs as above,
// pairs with a Theo1 point from the spectral windows of both (gmwm.cc).
std::vector<double> MomentCorrelationMatrix(const CompositeModel& model, double tau0_s,
                                            const std::vector<int64_t>& m,
                                            const std::vector<char>& theo1);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_GMWM_H_
