// Composite stochastic model of a sensor's rate output and its exact
// discrete-time Allan variance (ALGORITHMS.md §3b).
//
// The rate samples y_k (interval tau0) are a sum of independent terms. For a
// stationary term with autocovariance gamma_k, AVAR of two adjacent blocks A,
// B of m samples is Var(ybar_A) - Cov(ybar_A, ybar_B) with
//   Var(ybar_A)          = (1/m^2) [m gamma_0 + 2 sum_{k=1}^{m-1} (m-k) gamma_k],
//   Cov(ybar_A, ybar_B)  = (1/m^2) sum_{k=1}^{2m-1} min(k, 2m-k) gamma_k.
// Closed forms per term, tau = m tau0 (m may be fractional only for drawing):
//   white        N [u sqrt(s)]   N^2 / tau                      (variance N^2/tau0 per sample)
//   quantization Q [u s]         3 Q^2 / tau^2                  (white phase noise, variance Q^2)
//   flicker      B [u]           (2 ln2/pi) B^2                 (IEEE 952 floor; no exact
//                                                                discrete closed form exists)
//   random walk  K [u/sqrt(s)]   K^2 tau0 (2 m^2 + 1) / (6 m)   (increment variance K^2 tau0)
//   drift        R [u/s]         R^2 tau^2 / 2
//   Gauss-Markov sigma [u], T [s]: AR(1) y_k = phi y_{k-1} + e_k, phi = exp(-x),
//                x = tau0/T, gamma_k = sigma^2 phi^k. The geometric sums give
//                  AVAR = sigma^2 F / m^2,
//                  F = [2 m (sinh x - x) + G(m x)] / (4 sinh^2(x/2)),
//                  G(y) = 2y - 3 + 4 e^-y - e^-2y,
//                a form with no cancellation (series for small arguments);
//                its limits are sigma^2/m (T << tau0: white) and
//                (2 sigma^2/T) tau/3 (T >> tau: a random walk).
//   sinusoid     A [u], f [Hz]   A^2 sin^4(pi f' m) / (m^2 sin^2(pi f')), f' = f tau0
//                                (random phase; f' = 1/4 gives AVAR(1) = AVAR(2) = A^2/2,
//                                 AVAR(4) = 0).
// u is the rate unit (deg/s or m/s^2). All functions are pure and thread-safe.
#ifndef IMUQUAL_ANALYZE_ALLAN_COMPOSITE_MODEL_H_
#define IMUQUAL_ANALYZE_ALLAN_COMPOSITE_MODEL_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "analyze/allan/curve.h"

namespace imuqual::allan {

enum class TermKind {
  kQuantization,  // Q
  kWhite,         // N: angle / velocity random walk
  kFlicker,       // B: flicker floor (bias instability)
  kRandomWalk,    // K: rate random walk
  kDrift,         // R: rate ramp
  kGaussMarkov,   // first-order Gauss-Markov (sigma, T)
  kSinusoid,      // spectral line (amplitude, frequency)
};

// "quantization", "white", "flicker", "random_walk", "drift", "gauss_markov",
// "sinusoid"; and the short symbols "Q", "N", "B", "K", "R", "GM", "S".
std::string_view TermKindName(TermKind kind);
std::string_view TermKindSymbol(TermKind kind);

struct ModelTerm {
  TermKind kind = TermKind::kWhite;
  // Q [u s], N [u sqrt(s)], B [u], K [u/sqrt(s)], R [u/s], Gauss-Markov
  // stationary sigma [u], sinusoid amplitude [u]. Non-negative.
  double scale = 0;
  double correlation_time_s = 0;  // Gauss-Markov only, > 0
  double frequency_hz = 0;        // sinusoid only, in (0, Nyquist]
};

// AVAR of one term at averaging factor m >= 1 (fractional m allowed: the
// same closed form, used to draw the model between grid points).
double TermAvar(const ModelTerm& term, double m, double tau0_s);

// Two-sided power spectral density of a term's rate samples at frequency f in
// cycles per sample (0 < f <= 1/2), in u^2 per (cycle/sample), so that the
// sample variance is the integral over [-1/2, 1/2]. Drift and sinusoids are
// deterministic here and return 0. Used for the covariance of AVAR estimates.
double TermPsd(const ModelTerm& term, double f_cycles, double tau0_s);

// Theo1 under the model (ALGORITHMS.md's Theo1; long_tau.h). Theo1 sums,
// for k = 1..m/2, (1/k) u_k^2 with u_k = x_i - x_{i+k} - x_{i+m-k} + x_{i+m}
// of the phase x (x_n = tau0 sum_{j<n} y_j), so
//   E[Theo1(m)] = 1 / (0.75 (m tau0)^2) sum_{k=1}^{m/2} Var(u_k) / k.
// u_k removes a constant and a line, so Var(u_k) is finite for every term,
// the random walk and flicker too; per term, with d = distances in samples:
//   quantization  Q^2 (4, or 6 at k = m/2 where two points coincide)
//   white         2 N^2 tau0 k                   (phase structure N^2 tau0 d)
//   flicker       kernel (B^2 / 2 pi) s^2 ln s, s = d tau0 (the generalized
//                 covariance whose second difference gives the flicker
//                 floor; continuous time, no exact discrete form exists)
//   random walk   K^2 tau0^3 k^2 (3m - 4k) / 3 (kernel K^2 s^3 / 12) plus
//                 the discrete walk's white part, N^2 = K^2 tau0^2 / 6
//   drift         (R tau0^2 k (m - k))^2
//   Gauss-Markov  2 D(k) + 2 D(m-k) - D(m) - D(m-2k), D(d) = tau0^2 sigma^2
//                 [d (1+phi)/(1-phi) - 2 phi (1 - phi^d) / (1-phi)^2]
//   sinusoid      2 tau0^2 A^2 sin^2(pi f' k) sin^2(pi f' (m-k)) / sin^2(pi f')
// At k = m/2, u_k is the second difference at m/2, so Var(u_{m/2}) =
// 2 (m tau0 / 2)^2 AVAR(m/2) for every term (the test holds each kernel to
// TermAvar so). The ratio AVAR(0.75 m) / E[Theo1(m)] is Howe & Tasset's bias
// of Theo1 for any mix of terms (their Table 1 for pure power laws), which
// TheoBR can only estimate with one ratio for the whole curve. `m` even >= 2.
double TermTheo1PairVariance(const ModelTerm& term, int64_t m, int64_t k, double tau0_s);

// E[Theo1(m)] of one term, the sum over k above without visiting every k:
// closed forms for quantization, white noise, the random walk and drift;
// flicker and Gauss-Markov summed exactly for the 256 k nearest each end and
// by quadrature between (smooth there; ~1500 evaluations for any m); a
// sinusoid through Theo1SinusoidSum. Within 1e-10 of the sum over every k
// (1.2e-11 the largest seen; composite_model_test). `m` even >= 2.
double TermExpectedTheo1(const ModelTerm& term, int64_t m, double tau0_s);

// E[Theo1(m)] of one term for the record of the means of `block`
// consecutive samples (interval block tau0; its phase is every block-th
// point of the samples' phase), m even >= 2 counting means: the sum above
// over the distances k block only. Q, N, B and R are the same term at
// interval block tau0; the random walk is too, less the white part
// K^2 ((block tau0)^2 - tau0^2) / 6 (the samples' discrete walk); a
// sinusoid is the means' sinusoid (amplitude A |sin(pi f' b)| / (b
// |sin(pi f')|)) at its frequency folded into the means' band, none at a
// multiple of their rate; Gauss-Markov is summed over the distances k block
// as TermExpectedTheo1 sums it. block 1: TermExpectedTheo1.
double TermExpectedTheo1OfMeans(const ModelTerm& term, int64_t m, double tau0_s, int64_t block);

// sum_{k=1}^{m/2} sin^2(pi f k) sin^2(pi f (m-k)) / k, f in cycles per sample
// in (0, 1/2]: Theo1's response to a sampled sinusoid (and, over f, Theo1's
// spectral window). Where m f is large, a closed form in the partial sums of
// the log series sum e^{ick} / k, whose tails are summed by parts; else the
// smooth quadrature above.
double Theo1SinusoidSum(double f_cycles, int64_t m);

struct CompositeModel {
  std::vector<ModelTerm> terms;

  double Avar(double m, double tau0_s) const;
  double Deviation(double m, double tau0_s) const;
  double Psd(double f_cycles, double tau0_s) const;
  // Compact name in a fixed term order, e.g. "N+B+K+2GM+S".
  std::string Name() const;
  int CountOf(TermKind kind) const;
  // E[Theo1(m)] (above), m even >= 2: the sum of TermExpectedTheo1.
  double ExpectedTheo1(int64_t m, double tau0_s) const;
  // AVAR(0.75 m) / E[Theo1(m)]: multiplies a Theo1 estimate at m into an
  // estimate of AVAR at its effective tau 0.75 m tau0 without TheoBR's
  // one-ratio assumption (a model bias removal).
  double Theo1BiasFactor(int64_t m, double tau0_s) const;
};

// A model prepared for evaluation at many averaging factors or frequencies
// (a fit evaluates each candidate at every curve point, a model minimum on a
// grid of taus, a covariance on thousands of frequencies): what a term's AVAR
// or PSD needs that depends on neither m nor f is computed once here (its
// scale squared, a Gauss-Markov term's sinh(x/2), sinh(x) - x and phi, a
// sinusoid's sin(pi f')). Every value equals TermAvar, CompositeModel::Avar,
// TermPsd or CompositeModel::Psd of the same model bit for bit: the same
// operations on the same operands in the same order, only some of them done
// before the loop. Keeps no reference to the model; thread-compatible.
class ModelEvaluator {
 public:
  ModelEvaluator() = default;
  ModelEvaluator(const CompositeModel& model, double tau0_s);
  // Rebuilds for another model, reusing the storage.
  void Reset(const CompositeModel& model, double tau0_s);
  // Term by term: Resize(n, tau0_s), then SetTerm(i, term) for every i (a
  // term may be set again later, the others kept).
  void Resize(size_t terms, double tau0_s);
  void SetTerm(size_t i, const ModelTerm& term);

  size_t size() const { return terms_.size(); }
  // == TermAvar(model.terms[i], m, tau0_s).
  double TermAvar(size_t i, double m) const;
  // == model.Avar(m, tau0_s): the terms summed in order from 0.
  double Avar(double m) const;
  // == model.Psd(f_cycles, tau0_s), given s = sin(pi f_cycles) (the
  // quantization and random-walk terms use it; callers that need it too
  // compute it once).
  double Psd(double f_cycles, double sin_pi_f) const;

 private:
  struct Term {
    TermKind kind = TermKind::kWhite;
    double s2 = 0;       // scale^2
    double a = 0;        // AVAR: 3 s2 (Q), kFlicker s2 (B), s2 tau0 (K), s2/2 (R), GM sinh(x) - x,
                         // sinusoid pi f'
    double b = 0;        // AVAR: GM 4 sinh^2(x/2), sinusoid sin(pi f')
    double x = 0;        // GM tau0 / T
    bool white = false;  // GM x > 30: sigma^2 / m
    double psd = 0;      // PSD: Q 4 s2/tau0^2, N s2/tau0, K s2 tau0, GM innovation
    double phi = 0;      // PSD: GM phi
  };
  double tau0_s_ = 0;
  std::vector<Term> terms_;
};

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_COMPOSITE_MODEL_H_
