#include "analyze/allan/gmwm.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <boost/math/special_functions/digamma.hpp>
#include <boost/math/special_functions/gamma.hpp>
#include <boost/math/special_functions/trigamma.hpp>
#include <cassert>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <unsupported/Eigen/NonLinearOptimization>

#include "analyze/allan/confidence.h"
#include "analyze/allan/fit_rows.h"
#include "analyze/allan/noise_model.h"

namespace imuqual::allan {
namespace {

std::string FormatG(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

constexpr double kPi = std::numbers::pi;
constexpr std::array<TermKind, 5> kIeeeKinds = {TermKind::kQuantization, TermKind::kWhite,
                                                TermKind::kFlicker, TermKind::kRandomWalk,
                                                TermKind::kDrift};
// The IEEE terms that rise or stay flat towards the curve's long end (the
// ones the search swaps for each other).
constexpr std::array<TermKind, 3> kLongTauKinds = {TermKind::kFlicker, TermKind::kRandomWalk,
                                                   TermKind::kDrift};
// A new Gauss-Markov term starts from this many minima of the linearized J
// over its grid of correlation times (besides an even spread; Search).
constexpr size_t kGaussMarkovStarts = 3;
// Candidates of pass 1 re-estimated under the full covariance.
constexpr int kPass2Candidates = 8;
// Model averaging: candidates within this criterion distance of the best
// (weight >= e^-5 of the best's), at most kMaxAveraged of them.
constexpr double kAveragingSpan = 10;
constexpr size_t kMaxAveraged = 4;
// Bounds on a Gauss-Markov correlation time, relative to tau0 and to the
// record: beyond them the term is white noise or a random walk to the data.
constexpr double kMinCorrelationTimeFactor = 0.1;
constexpr double kMaxCorrelationTimeFactor = 100.0;

// E[Theo1(m)] of a unit-scale Gauss-Markov term against u = ln(T / tau0),
// tabulated once per Theo1 point (16 nodes per octave over the correlation
// times the fit allows) and interpolated in ln E by Catmull-Rom cubics (C1,
// so the Jacobian's forward differences stay consistent): the exact value
// costs ~1500 long-double evaluations (TermExpectedTheo1), which every
// evaluation of every Gauss-Markov term would otherwise pay. E is analytic
// in u; the interpolation's error is at most 1e-6 of it (measured against
// the exact value over the range at m = 1366 to 480000), far below any
// moment's sd.
class GaussMarkovTheo1Table {
 public:
  static constexpr int kPerOctave = 16;
  // m counts means of `block` samples (TermExpectedTheo1OfMeans).
  GaussMarkovTheo1Table(int64_t m, int64_t block, double tau0_s, double u_min, double u_max)
      : step_(std::numbers::ln2 / kPerOctave), u0_(u_min - 2 * step_) {
    const int n = static_cast<int>(std::ceil((u_max + 2 * step_ - u0_) / step_)) + 1;
    ln_.resize(n);
    for (int i = 0; i < n; ++i) {
      const ModelTerm t{TermKind::kGaussMarkov, 1.0, tau0_s * std::exp(u0_ + i * step_)};
      ln_[i] = std::log(TermExpectedTheo1OfMeans(t, m, tau0_s, block));
    }
  }
  double At(double u) const {
    if (std::isnan(u)) return kNaN;  // a trial step's NaN parameter: a NaN model, as TermAvar's
    const double at = std::clamp((u - u0_) / step_, 1.0, static_cast<double>(ln_.size()) - 2.0);
    const int i = std::min(static_cast<int>(at), static_cast<int>(ln_.size()) - 3);
    const double t = at - i, p0 = ln_[i - 1], p1 = ln_[i], p2 = ln_[i + 1], p3 = ln_[i + 2];
    const double v =
        p1 +
        0.5 * t * (p2 - p0 + t * (2 * p0 - 5 * p1 + 4 * p2 - p3 + t * (3 * (p1 - p2) + p3 - p0)));
    return std::exp(v);
  }

 private:
  double step_, u0_;
  std::vector<double> ln_;
};

// The moments, their covariance and the bounds of one estimation pass.
struct Problem {
  double tau0_s = 0;
  std::vector<double> m;  // averaging factors
  Eigen::VectorXd y;      // ln avar_j - b_j
  Eigen::VectorXd edf;
  Eigen::MatrixXd sigma;     // Var(ln avar_hat)
  Eigen::MatrixXd whitener;  // L^-1, Sigma = L L'
  // theta is in the data's own units, so that the search does not depend on
  // the unit the curve is read in (g or m/s^2) nor on the sample rate: a
  // term's scale is exp(theta + ln_ref), ln_ref the mean log deviation of
  // the curve; a correlation time is tau0 exp(theta), clamped to
  // [ln_t_min, ln_t_max]. Levenberg-Marquardt's step bound and its relative
  // step test scale with |theta|: in absolute logs (ln 1e-6 = -14 for one
  // unit, -11.7 for another) the same record took different paths and ended
  // in different minima.
  double ln_ref = 0;
  double ln_t_min = 0, ln_t_max = 0;
  double penalty = 2;         // per parameter of a two-parameter term in the criterion
  double single_penalty = 2;  // per one-parameter term
  // AVAR of a term held fixed outside the fitted parameters (the profile of
  // an absent term's upper bound); empty: none.
  Eigen::VectorXd fixed_avar;
  // Which points are Theo1 moments (FitCompositeModel's long_taus): a term's
  // value there is E[Theo1(m)], not AVAR(m). theo1_unit[i][j]: the IEEE 952
  // kind kIeeeKinds[i] at unit scale at point j (0 at AVAR points), computed
  // once; Gauss-Markov terms and sinusoids are computed per evaluation.
  std::vector<char> theo1;
  // Per point, the samples behind each of the record's points that a Theo1
  // moment was computed on (Theo1Moment::block; 1 at AVAR points).
  std::vector<int64_t> block;
  std::array<std::vector<double>, 5> theo1_unit;
  // Per point, the Gauss-Markov table (null at AVAR points); shared by the
  // passes and the profiles' copies of a problem.
  std::vector<std::shared_ptr<const GaussMarkovTheo1Table>> gm_theo1;
  // The search's problems: a candidate with a term the fitted points cannot
  // tell from another kind (Identified) is not a candidate. Off for a
  // bootstrap replicate's refit and a profile, which stay with the model.
  bool identified_only = false;

  int points() const { return static_cast<int>(m.size()); }
};

// The index of an IEEE 952 kind in kIeeeKinds, -1 for the others.
int IeeeIndex(TermKind kind) {
  for (size_t i = 0; i < kIeeeKinds.size(); ++i) {
    if (kIeeeKinds[i] == kind) return static_cast<int>(i);
  }
  return -1;
}

// A term's E[Theo1] at Theo1 point j.
double Theo1TermMoment(const ModelTerm& term, const Problem& p, int j) {
  const int i = IeeeIndex(term.kind);
  if (i >= 0) return term.scale * term.scale * p.theo1_unit[i][j];
  if (term.kind == TermKind::kGaussMarkov) {
    return term.scale * term.scale *
           p.gm_theo1[j]->At(std::log(term.correlation_time_s / p.tau0_s));
  }
  return TermExpectedTheo1OfMeans(term, static_cast<int64_t>(p.m[j]) / p.block[j], p.tau0_s,
                                  p.block[j]);
}

// A term's model value at point j: AVAR(m_j), or E[Theo1(m_j)] at a Theo1
// point.
double TermMoment(const ModelTerm& term, const Problem& p, int j) {
  return p.theo1[j] ? Theo1TermMoment(term, p, j) : TermAvar(term, p.m[j], p.tau0_s);
}

Problem MakeProblem(const std::vector<FitRow>& rows, const std::vector<char>& theo1,
                    const std::vector<int64_t>& block, double tau0_s, int64_t n_phase,
                    const Eigen::VectorXd& edf, const Eigen::MatrixXd& correlation,
                    const GmwmOptions& options, const Problem* same_points = nullptr) {
  Problem p;
  p.theo1 = theo1;
  p.block = block;
  p.penalty = options.parameter_penalty;
  p.single_penalty = options.single_term_penalty;
  p.identified_only = true;
  p.tau0_s = tau0_s;
  const int n = static_cast<int>(rows.size());
  p.y.resize(n);
  p.edf = edf;
  p.sigma.resize(n, n);
  Eigen::VectorXd sd(n);
  for (int j = 0; j < n; ++j) {
    p.m.push_back(static_cast<double>(rows[j].m));
    const double half = edf(j) / 2.0;
    // ln(chi2_nu / nu) has mean psi(nu/2) - ln(nu/2) and variance psi'(nu/2).
    p.y(j) = std::log(rows[j].avar) - (boost::math::digamma(half) - std::log(half));
    sd(j) = std::sqrt(boost::math::trigamma(half));
    p.ln_ref += 0.5 * std::log(rows[j].avar) / n;
  }
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) p.sigma(a, b) = correlation(a, b) * sd(a) * sd(b);
  }
  Eigen::LLT<Eigen::MatrixXd> llt(p.sigma);
  if (llt.info() != Eigen::Success) {
    // Numerically indefinite correlations: fall back to the diagonal.
    p.sigma = sd.array().square().matrix().asDiagonal();
    llt.compute(p.sigma);
  }
  const Eigen::MatrixXd l = llt.matrixL();
  p.whitener = l.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
  p.ln_t_min = std::log(kMinCorrelationTimeFactor);
  p.ln_t_max = std::log(kMaxCorrelationTimeFactor * static_cast<double>(n_phase));
  if (same_points != nullptr) {  // the same rows: the same tables
    p.theo1_unit = same_points->theo1_unit;
    p.gm_theo1 = same_points->gm_theo1;
    return p;
  }
  p.gm_theo1.resize(n);
  for (size_t i = 0; i < kIeeeKinds.size(); ++i) p.theo1_unit[i].assign(n, 0.0);
  for (int j = 0; j < n; ++j) {
    if (!theo1[j]) continue;
    for (size_t i = 0; i < kIeeeKinds.size(); ++i) {
      p.theo1_unit[i][j] = TermExpectedTheo1OfMeans(ModelTerm{kIeeeKinds[i], 1.0},
                                                    rows[j].m / block[j], tau0_s, block[j]);
    }
    p.gm_theo1[j] = std::make_shared<const GaussMarkovTheo1Table>(rows[j].m / block[j], block[j],
                                                                  tau0_s, p.ln_t_min, p.ln_t_max);
  }
  return p;
}

int ParameterCount(TermKind kind) {
  return kind == TermKind::kGaussMarkov || kind == TermKind::kSinusoid ? 2 : 1;
}

int ParameterCount(const std::vector<TermKind>& kinds) {
  int k = 0;
  for (TermKind kind : kinds) k += ParameterCount(kind);
  return k;
}

double Sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// The term of kind `kind` whose parameters start at theta(i).
ModelTerm ToTerm(TermKind kind, const Eigen::VectorXd& theta, int i, const Problem& p) {
  ModelTerm t;
  t.kind = kind;
  t.scale = std::exp(theta(i) + p.ln_ref);
  if (kind == TermKind::kGaussMarkov) {
    t.correlation_time_s = p.tau0_s * std::exp(std::clamp(theta(i + 1), p.ln_t_min, p.ln_t_max));
  } else if (kind == TermKind::kSinusoid) {
    t.frequency_hz = 0.5 / p.tau0_s * Sigmoid(theta(i + 1));
  }
  return t;
}

CompositeModel ToModel(const std::vector<TermKind>& kinds, const Eigen::VectorXd& theta,
                       const Problem& p) {
  CompositeModel model;
  model.terms.reserve(kinds.size());
  int i = 0;
  for (TermKind kind : kinds) {
    model.terms.push_back(ToTerm(kind, theta, i, p));
    i += ParameterCount(kind);
  }
  return model;
}

// ln(AVAR of the model + the fixed term) at the problem's points, from the
// model's AVAR at each point.
double LogAvar(double model_avar, const Problem& p, int j) {
  const double fixed = p.fixed_avar.size() > 0 ? p.fixed_avar(j) : 0.0;
  return std::log(std::max(model_avar + fixed, 1e-300));
}

Eigen::VectorXd LogModel(const CompositeModel& model, const Problem& p) {
  const ModelEvaluator ev(model, p.tau0_s);
  Eigen::VectorXd v(p.points());
  for (int j = 0; j < p.points(); ++j) {
    double value = 0;
    if (p.theo1[j]) {
      for (const ModelTerm& t : model.terms) value += Theo1TermMoment(t, p, j);
    } else {
      value = ev.Avar(p.m[j]);
    }
    v(j) = LogAvar(value, p, j);
  }
  return v;
}

// The whitened residuals r(theta) = L^-1 (y - ln nu(theta)) of one estimation
// and their Jacobian, as Eigen's Levenberg-Marquardt asks for them. The
// minimizer asks again for points it has evaluated, so the functor remembers
// the last evaluations and each term's AVAR at the points for its last
// parameters: a remembered value is the value the evaluation would compute
// again, bit for bit (the same function of the same bits), and each point's
// AVAR is still the sum of the terms in model order.
// Jacobian: dr/dtheta_i = -L^-1 diag(1 / nu) dnu/dtheta_i. A term's AVAR is
// its squared scale times a shape, so d/d(log scale) = 2 AVAR_t exactly; a
// correlation time's or frequency's column is a forward difference of that
// term alone (step 1e-6 in theta; 0 where a correlation time is clamped).
// The memory is per estimation, never shared.
class ResidualFunctor {
 public:
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  ResidualFunctor(const Problem* problem, const std::vector<TermKind>* kinds, int n_in)
      : problem_(problem), kinds_(kinds), n_in_(n_in) {
    assert(kinds->size() <= kMaxTerms);
    const int n = problem->points();
    ev_.Resize(kinds->size(), problem->tau0_s);
    slots_.resize(kinds->size());
    for (TermSlots& t : slots_) {
      for (Slot& s : t.slot) s.avar.resize(n);
    }
    log_avar_.resize(n);
    diff_.resize(n);
  }

  int inputs() const { return n_in_; }
  int values() const { return problem_->points(); }

  int operator()(const Eigen::VectorXd& theta, Eigen::VectorXd& r) const {
    // Newest first: the point just accepted is the last one evaluated.
    for (int i = 1; i <= kMemo; ++i) {
      const Evaluation& e = memo_[(next_memo_ + kMemo - i) % kMemo];
      if (e.theta.size() == theta.size() && SameBits(e.theta.data(), theta.data(), theta.size())) {
        r = e.r;
        return 0;
      }
    }
    const Problem& p = *problem_;
    LogAvarFromTerms(theta);
    diff_ = p.y - log_avar_;
    r.noalias() = p.whitener * diff_;
    Evaluation& e = memo_[next_memo_];
    next_memo_ = (next_memo_ + 1) % kMemo;
    e.theta = theta;
    e.r = r;
    return 0;
  }

  int df(const Eigen::VectorXd& theta, Eigen::MatrixXd& jac) const {
    constexpr double kStep = 1e-6;
    const Problem& p = *problem_;
    const int n = p.points();
    LogAvarFromTerms(theta);
    d_.resize(n, n_in_);
    int offset = 0;
    for (size_t t = 0; t < kinds_->size(); ++t) {
      const TermKind kind = (*kinds_)[t];
      const std::vector<double>& avar = current_[t]->avar;
      for (int j = 0; j < n; ++j) d_(j, offset) = 2.0 * avar[j] / total_[j];
      if (ParameterCount(kind) == 2) {
        const double second = theta(offset + 1);
        const bool clamped = kind == TermKind::kGaussMarkov &&
                             (second < p.ln_t_min || second + kStep > p.ln_t_max);
        if (clamped) {
          d_.col(offset + 1).setZero();
        } else {
          Eigen::VectorXd moved = theta;
          moved(offset + 1) += kStep;
          const double h = moved(offset + 1) - second;  // the step as represented
          const ModelTerm term = ToTerm(kind, moved, offset, p);
          step_ev_.Resize(1, p.tau0_s);
          step_ev_.SetTerm(0, term);
          for (int j = 0; j < n; ++j) {
            const double v =
                p.theo1[j] ? Theo1TermMoment(term, p, j) : step_ev_.TermAvar(0, p.m[j]);
            d_(j, offset + 1) = (v - avar[j]) / (h * total_[j]);
          }
        }
      }
      offset += ParameterCount(kind);
    }
    jac.noalias() = -p.whitener * d_;
    return 0;
  }

 private:
  static constexpr int kSlots = 3;  // the point, a perturbed parameter, a trial step
  static constexpr int kMemo = 16;  // more than a Jacobian's evaluations
  static constexpr size_t kMaxTerms = 16;

  static bool SameBits(const double* a, const double* b, int64_t count) {
    for (int64_t i = 0; i < count; ++i) {
      uint64_t x, y;
      std::memcpy(&x, a + i, sizeof x);
      std::memcpy(&y, b + i, sizeof y);
      if (x != y) return false;
    }
    return true;
  }

  // log_avar_ = ln(AVAR of the model + the fixed term) at every point, each
  // term's AVAR from its slots or computed.
  void LogAvarFromTerms(const Eigen::VectorXd& theta) const {
    const Problem& p = *problem_;
    const int n = p.points();
    ++clock_;
    int offset = 0;
    for (size_t t = 0; t < kinds_->size(); ++t) {
      const TermKind kind = (*kinds_)[t];
      const int width = ParameterCount(kind);
      TermSlots& ts = slots_[t];
      Slot* found = nullptr;
      for (Slot& s : ts.slot) {
        if (s.used > 0 && SameBits(s.key.data(), theta.data() + offset, width)) found = &s;
      }
      if (found == nullptr) {
        found = &ts.slot[0];
        for (Slot& s : ts.slot) {
          if (s.used < found->used) found = &s;
        }
        std::copy(theta.data() + offset, theta.data() + offset + width, found->key.begin());
        const ModelTerm term = ToTerm(kind, theta, offset, p);
        ev_.SetTerm(t, term);
        for (int j = 0; j < n; ++j) {
          found->avar[j] = p.theo1[j] ? Theo1TermMoment(term, p, j) : ev_.TermAvar(t, p.m[j]);
        }
      }
      found->used = clock_;
      current_[t] = found;
      offset += width;
    }
    total_.resize(n);
    for (int j = 0; j < n; ++j) {
      double v = 0;  // ModelEvaluator::Avar: the terms in order
      for (size_t t = 0; t < kinds_->size(); ++t) v += current_[t]->avar[j];
      log_avar_(j) = LogAvar(v, p, j);
      const double fixed = p.fixed_avar.size() > 0 ? p.fixed_avar(j) : 0.0;
      total_[j] = std::max(v + fixed, 1e-300);  // nu, as LogAvar takes it
    }
  }

  struct Slot {
    std::array<double, 2> key{};  // the term's parameters (1 or 2)
    std::vector<double> avar;     // its AVAR at every point
    uint64_t used = 0;            // 0: empty; else the evaluation that last used it
  };
  struct TermSlots {
    std::array<Slot, kSlots> slot;
  };
  struct Evaluation {
    Eigen::VectorXd theta;
    Eigen::VectorXd r;
  };

  const Problem* problem_;
  const std::vector<TermKind>* kinds_;
  int n_in_;
  mutable ModelEvaluator ev_;
  mutable std::vector<TermSlots> slots_;
  mutable std::array<const Slot*, kMaxTerms> current_{};
  mutable uint64_t clock_ = 0;
  mutable Eigen::VectorXd log_avar_, diff_;
  mutable std::vector<double> total_;  // nu at every point (the last evaluation)
  mutable Eigen::MatrixXd d_;          // d nu / d theta / nu
  mutable ModelEvaluator step_ev_;     // a term at a moved parameter (df)
  mutable std::array<Evaluation, kMemo> memo_;
  mutable int next_memo_ = 0;
};

struct Candidate {
  std::vector<TermKind> kinds;
  Eigen::VectorXd theta;
  double objective = std::numeric_limits<double>::infinity();
  double criterion = std::numeric_limits<double>::infinity();
  // 0: the lowest minimum of J found for the model; k: its (k+1)-th lowest
  // distinct one (SameMinimum), a rival of its own in the model average.
  int minimum_rank = 0;
};

// Hansen's J test: P(chi2 with `dof` degrees of freedom > objective).
double JTestPValue(double objective, int dof) {
  return 1.0 - RegularizedGammaP(dof / 2.0, objective / 2.0);
}

double Criterion(double objective, const std::vector<TermKind>& kinds, int points, double penalty,
                 double single_penalty) {
  const int k = ParameterCount(kinds);
  const int denom = points - k - 1;
  if (denom <= 0) return std::numeric_limits<double>::infinity();
  double cost = 0;
  for (TermKind kind : kinds) {
    cost += ParameterCount(kind) == 1 ? single_penalty : penalty * ParameterCount(kind);
  }
  return objective + cost + 2.0 * k * (k + 1.0) / denom;
}

// Whether every term of a candidate is the kind it is named to the fitted
// points: a Gauss-Markov term whose correlation time lies more than two
// octaves below the shortest fitted tau is white noise there, and more than
// two octaves beyond the longest a random walk; a sinusoid above a cycle per
// shortest fitted tau shows only through the zeros of its sin^4 at the
// points (a free value for the first point or two: a tau^-2 term), and one
// below a cycle per eight longest taus a drift (the correlation times and the
// slow lines an octave beyond the range the search's grids cover; the fast
// lines at the grid's top, SinusoidBandTop).
bool Identified(const std::vector<TermKind>& kinds, const Eigen::VectorXd& theta,
                const Problem& p) {
  // A Theo1 point's tau is 0.75 m (rows' tau_s).
  const double tau_first = p.m.front() * p.tau0_s;
  const double tau_last = (p.theo1.back() ? 0.75 : 1.0) * p.m.back() * p.tau0_s;
  int i = 0;
  for (TermKind kind : kinds) {
    const ModelTerm t = ToTerm(kind, theta, i, p);
    if (kind == TermKind::kGaussMarkov &&
        (t.correlation_time_s < tau_first / 4 || t.correlation_time_s > 4 * tau_last)) {
      return false;
    }
    if (kind == TermKind::kSinusoid &&
        (t.frequency_hz * tau_first > 1 || t.frequency_hz * tau_last < 0.125)) {
      return false;
    }
    i += ParameterCount(kind);
  }
  return true;
}

// `tolerance`: LM's relative step tolerance in theta (1e-7: estimates; a
// profile's J needs far less).
Candidate Estimate(const std::vector<TermKind>& kinds, Eigen::VectorXd theta, const Problem& p,
                   double tolerance = 1e-7) {
  Candidate c;
  c.kinds = kinds;
  const int k = ParameterCount(kinds);
  if (k + 2 > p.points()) return c;
  ResidualFunctor diff(&p, &kinds, k);
  Eigen::LevenbergMarquardt<ResidualFunctor> lm(diff);
  lm.parameters.maxfev = 400 * (k + 1);
  lm.parameters.xtol = tolerance;
  lm.parameters.ftol = tolerance * 1e-3;
  lm.minimize(theta);
  Eigen::VectorXd r;
  diff(theta, r);  // the functor LM used: its last evaluations are remembered
  if (!r.allFinite()) return c;
  c.theta = theta;
  c.objective = r.squaredNorm();
  c.criterion = Criterion(c.objective, kinds, p.points(), p.penalty, p.single_penalty);
  if (p.identified_only && !Identified(kinds, theta, p)) {
    c.criterion = std::numeric_limits<double>::infinity();
  }
  return c;
}

std::string NameOf(const std::vector<TermKind>& kinds, const Eigen::VectorXd& theta,
                   const Problem& p) {
  return ToModel(kinds, theta, p).Name();
}

// The parameters (theta, see Problem) a new term of kind `kind` starts from:
// an IEEE 952 term's scale a fraction below the measured curve's tangent
// bound (ALGORITHMS.md §3); a Gauss-Markov term's or a sinusoid's scale at
// the shortest tau's level, its second parameter 0 (the search sets it with
// WithSecond; LinearStart re-solves every scale).
std::vector<double> StartParameters(TermKind kind, const std::vector<FitRow>& rows,
                                    const Problem& p) {
  double bound = std::numeric_limits<double>::infinity();
  for (const FitRow& r : rows) {
    const double t = r.tau_s, v = r.avar;
    switch (kind) {
      case TermKind::kQuantization:
        bound = std::min(bound, std::sqrt(v * t * t / 3.0));
        break;
      case TermKind::kWhite:
        bound = std::min(bound, std::sqrt(v * t));
        break;
      case TermKind::kFlicker:
        bound = std::min(bound, std::sqrt(v) / kBiasInstabilityFactor);
        break;
      case TermKind::kRandomWalk:
        bound = std::min(bound, std::sqrt(3.0 * v / t));
        break;
      case TermKind::kDrift:
        bound = std::min(bound, std::sqrt(2.0 * v) / t);
        break;
      case TermKind::kGaussMarkov:
      case TermKind::kSinusoid:
        break;
    }
  }
  if (kind == TermKind::kGaussMarkov) {
    return {std::log(std::sqrt(rows.front().avar)) - p.ln_ref, 0.0};
  }
  if (kind == TermKind::kSinusoid) {
    return {std::log(0.3 * std::sqrt(2.0 * rows.front().avar)) - p.ln_ref, 0.0};
  }
  return {std::log(0.5 * bound) - p.ln_ref};
}

Eigen::VectorXd Append(const Eigen::VectorXd& theta, const std::vector<double>& extra) {
  Eigen::VectorXd out(theta.size() + static_cast<int>(extra.size()));
  out << theta, Eigen::Map<const Eigen::VectorXd>(extra.data(), extra.size());
  return out;
}

// theta without the parameters of term i.
Eigen::VectorXd Without(const std::vector<TermKind>& kinds, const Eigen::VectorXd& theta, int i) {
  int offset = 0;
  for (int t = 0; t < i; ++t) offset += ParameterCount(kinds[t]);
  const int width = ParameterCount(kinds[i]);
  Eigen::VectorXd out(theta.size() - width);
  out << theta.head(offset), theta.tail(theta.size() - offset - width);
  return out;
}

// Non-negative least squares, min |a x - b| with x >= 0 (Lawson & Hanson,
// "Solving Least Squares Problems", 1974, ch. 23), on unit-norm columns.
Eigen::VectorXd Nnls(const Eigen::MatrixXd& a_in, const Eigen::VectorXd& b) {
  const int k = static_cast<int>(a_in.cols());
  Eigen::VectorXd norm(k);
  Eigen::MatrixXd a = a_in;
  for (int t = 0; t < k; ++t) {
    norm(t) = a.col(t).norm();
    if (norm(t) > 0) a.col(t) /= norm(t);
  }
  Eigen::VectorXd x = Eigen::VectorXd::Zero(k);
  std::vector<bool> passive(k, false);
  const double tol = 1e-12 * std::max(1.0, (a.transpose() * b).cwiseAbs().maxCoeff());
  auto solve_passive = [&](Eigen::VectorXd* z) {
    std::vector<int> idx;
    for (int t = 0; t < k; ++t) {
      if (passive[t]) idx.push_back(t);
    }
    Eigen::MatrixXd sub(a.rows(), static_cast<int>(idx.size()));
    for (size_t i = 0; i < idx.size(); ++i) sub.col(static_cast<int>(i)) = a.col(idx[i]);
    const Eigen::VectorXd zs = sub.colPivHouseholderQr().solve(b);
    z->setZero(k);
    for (size_t i = 0; i < idx.size(); ++i) (*z)(idx[i]) = zs(static_cast<int>(i));
  };
  for (int outer = 0; outer < 3 * k; ++outer) {
    const Eigen::VectorXd w = a.transpose() * (b - a * x);
    int enter = -1;
    double best = tol;
    for (int t = 0; t < k; ++t) {
      if (!passive[t] && norm(t) > 0 && w(t) > best) {
        best = w(t);
        enter = t;
      }
    }
    if (enter < 0) break;
    passive[enter] = true;
    Eigen::VectorXd z;
    for (int inner = 0; inner < 3 * k; ++inner) {
      solve_passive(&z);
      bool feasible = true;
      double alpha = 1;
      for (int t = 0; t < k; ++t) {
        if (passive[t] && !(z(t) > 0)) {
          feasible = false;
          const double d = x(t) - z(t);
          if (d > 0) alpha = std::min(alpha, x(t) / d);
        }
      }
      if (feasible) break;
      x += alpha * (z - x);
      for (int t = 0; t < k; ++t) {
        if (passive[t] && !(x(t) > tol)) {
          passive[t] = false;
          x(t) = 0;
        }
      }
    }
    if (z.size() == k) {
      for (int t = 0; t < k; ++t) x(t) = passive[t] ? std::max(0.0, z(t)) : 0.0;
    }
  }
  for (int t = 0; t < k; ++t) x(t) = norm(t) > 0 ? x(t) / norm(t) : 0.0;
  return x;
}

// Scales for the terms `kinds` with their other parameters (correlation
// times, frequencies) as in theta: the model is linear in the squared
// scales, AVAR_j = sum_t s_t^2 shape_t(m_j), and to first order
// ln(model / e^y) = model / e^y - 1, so the squared scales that minimize
// |W (model / e^y - 1)| with s^2 >= 0 (Nnls) start Levenberg-Marquardt near
// the minimum over the scales (variable projection, Golub & Pereyra 1973).
// A scale Nnls sets to 0 starts 1e-3 below the term's reach (where the term
// alone meets the curve). Returns theta with the scales replaced;
// *objective: the linearized J.
Eigen::VectorXd LinearStart(const std::vector<TermKind>& kinds, Eigen::VectorXd theta,
                            const Problem& p, double* objective = nullptr) {
  const int n = p.points(), k = static_cast<int>(kinds.size());
  Eigen::MatrixXd shape(n, k);
  std::vector<int> offset(k);
  for (int t = 0, i = 0; t < k; ++t) {
    offset[t] = i;
    ModelTerm term = ToTerm(kinds[t], theta, i, p);
    term.scale = 1;
    for (int j = 0; j < n; ++j) shape(j, t) = TermMoment(term, p, j);
    i += ParameterCount(kinds[t]);
  }
  const Eigen::VectorXd inv = (-p.y.array()).exp();
  const Eigen::MatrixXd a = p.whitener * (inv.asDiagonal() * shape);
  const Eigen::VectorXd b = p.whitener * Eigen::VectorXd::Ones(n);
  if (!a.allFinite() || !b.allFinite()) return theta;
  const Eigen::VectorXd c = Nnls(a, b);
  if (objective != nullptr) *objective = (a * c - b).squaredNorm();
  for (int t = 0; t < k; ++t) {
    double reach = std::numeric_limits<double>::infinity();
    for (int j = 0; j < n; ++j) {
      if (shape(j, t) > 0) reach = std::min(reach, std::exp(p.y(j)) / shape(j, t));
    }
    double c2 = c(t);
    if (std::isfinite(reach)) c2 = std::max(c2, 1e-6 * reach);  // (1e-3 in scale)
    if (c2 > 0 && std::isfinite(c2)) theta(offset[t]) = 0.5 * std::log(c2) - p.ln_ref;
  }
  return theta;
}

// The offset in theta of term `term`'s parameters.
int OffsetOf(const std::vector<TermKind>& kinds, size_t term) {
  int offset = 0;
  for (size_t t = 0; t < term; ++t) offset += ParameterCount(kinds[t]);
  return offset;
}

// theta with term `term`'s second parameter set to `value` (a Gauss-Markov
// correlation time in s, a sinusoid's frequency in cycles per sample).
Eigen::VectorXd WithSecond(const std::vector<TermKind>& kinds, Eigen::VectorXd theta, size_t term,
                           double value, const Problem& p) {
  const int i = OffsetOf(kinds, term) + 1;
  if (kinds[term] == TermKind::kGaussMarkov) {
    theta(i) = std::log(value / p.tau0_s);
  } else {
    const double f = std::clamp(value * 2.0, 1e-9, 1 - 1e-9);  // of Nyquist
    theta(i) = std::log(f / (1 - f));
  }
  return theta;
}

// theta with terms `a`'s and `b`'s second parameters set to `x` and `y`.
Eigen::VectorXd WithPair(const std::vector<TermKind>& kinds, const Eigen::VectorXd& theta, size_t a,
                         double x, size_t b, double y, const Problem& p) {
  return WithSecond(kinds, WithSecond(kinds, theta, a, x, p), b, y, p);
}

// Up to `count` values of term `term`'s second parameter among `grid`: the
// local minima of the linearized J over the grid (LinearStart, every scale
// re-solved at each value), best first, each with its start theta.
std::vector<Eigen::VectorXd> GridStarts(const std::vector<TermKind>& kinds,
                                        const Eigen::VectorXd& theta, size_t term,
                                        const std::vector<double>& grid, size_t count,
                                        const Problem& p) {
  std::vector<double> j(grid.size(), std::numeric_limits<double>::infinity());
  std::vector<Eigen::VectorXd> start(grid.size());
  for (size_t g = 0; g < grid.size(); ++g) {
    start[g] = LinearStart(kinds, WithSecond(kinds, theta, term, grid[g], p), p, &j[g]);
    if (!std::isfinite(j[g])) j[g] = std::numeric_limits<double>::infinity();
  }
  std::vector<size_t> minima;
  for (size_t g = 0; g < grid.size(); ++g) {
    const bool left = g == 0 || j[g] <= j[g - 1], right = g + 1 == grid.size() || j[g] <= j[g + 1];
    if (left && right && std::isfinite(j[g])) minima.push_back(g);
  }
  std::sort(minima.begin(), minima.end(), [&](size_t a, size_t b) { return j[a] < j[b]; });
  std::vector<Eigen::VectorXd> out;
  for (size_t i = 0; i < minima.size() && out.size() < count; ++i) out.push_back(start[minima[i]]);
  return out;
}

// Whether two estimates of one model lie in the same minimum of J: their
// correlation times within 10 % and their frequencies within 10 % and 0.005
// cycles per sample (half the search's grid step near Nyquist, where the
// grid is linear; below 0.05 it is 4 per octave), each kind sorted.
bool SameMinimum(const Candidate& a, const Candidate& b, const Problem& p) {
  auto nonlinear = [&](const Candidate& c) {
    std::vector<double> ln_t, f;
    for (const ModelTerm& t : ToModel(c.kinds, c.theta, p).terms) {
      if (t.kind == TermKind::kGaussMarkov) ln_t.push_back(std::log(t.correlation_time_s));
      if (t.kind == TermKind::kSinusoid) f.push_back(t.frequency_hz * p.tau0_s);
    }
    std::sort(ln_t.begin(), ln_t.end());
    std::sort(f.begin(), f.end());
    return std::pair{ln_t, f};
  };
  const auto [ta, fa] = nonlinear(a);
  const auto [tb, fb] = nonlinear(b);
  if (ta.size() != tb.size() || fa.size() != fb.size()) return false;
  for (size_t i = 0; i < ta.size(); ++i) {
    if (std::abs(ta[i] - tb[i]) > 0.1) return false;
  }
  for (size_t i = 0; i < fa.size(); ++i) {
    if (std::abs(fa[i] - fb[i]) > 0.005 || std::abs(std::log(fa[i] / fb[i])) > 0.1) return false;
  }
  return true;
}

// Whether `large` is `small` in disguise: `small`'s terms plus terms
// collapsed to nothing (or, with `same_size`, as many terms: the same model
// with a free correlation time or frequency), J equal to `rel_tol`.
bool CollapsedInto(const Candidate& large, const Candidate& small, bool same_size, double rel_tol) {
  if (std::abs(large.objective - small.objective) > rel_tol * (1 + small.objective)) return false;
  if (same_size && small.kinds.size() == large.kinds.size()) return true;
  if (small.kinds.size() >= large.kinds.size()) return false;
  std::vector<TermKind> a = small.kinds, b = large.kinds;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  return std::includes(b.begin(), b.end(), a.begin(), a.end());
}

// The best few distinct minima of J found for each model name (Search).
using Minima = std::map<std::string, std::vector<Candidate>>;
constexpr size_t kMinimaPerModel = 3;

// `c` into `list`, the kMinimaPerModel lowest distinct minima of one model,
// lowest first: the entries `c` lies in the same minimum with are merged
// with it into the best of them (the relation is not transitive: replacing
// one entry by `c` could otherwise leave two entries of one minimum).
void AddMinimum(std::vector<Candidate>* list, const Candidate& c, const Problem& p) {
  Candidate kept = c;
  std::erase_if(*list, [&](const Candidate& m) {
    if (!SameMinimum(m, c, p)) return false;
    if (m.objective < kept.objective) kept = m;
    return true;
  });
  list->push_back(std::move(kept));
  std::sort(list->begin(), list->end(),
            [](const Candidate& a, const Candidate& b) { return a.objective < b.objective; });
  if (list->size() > kMinimaPerModel) list->resize(kMinimaPerModel);
}

// Estimates of a model with two sinusoids `a` and `b` from every pair of
// frequencies of `grid`, the `count` best of distinct minima (SameMinimum),
// best first. At each pair every Gauss-Markov term's correlation time is
// re-chosen first, the best of the linearized J over the points of
// `gm_grid` within a factor 2 of its value (4-5 points; scales re-solved,
// LinearStart), then the whole model is estimated coarsely (to a relative
// step of 1e-2). Searched one at a time, the other held, two lines stay in
// the pair they started from: on the octave points a pair of lines has
// near-equivalent pairs elsewhere (the ADIS16405 z gyro's 6.7 and 23.0 Hz
// against 17.6 and 28.4 Hz with the Gauss-Markov term's correlation time
// moved from 0.0067 to 0.010 s: J 11.4 against 9.4), and the linearized J
// with the correlation times held does not see them. Without the
// correlation times re-chosen, on 60 twins of that record a grid of full
// estimates over every pair of frequencies found a lower J than the search
// in 8 (by up to 3.6); with them in none (within a factor 4 as well, at
// twice the cost). The stored-curve test (six real axes in seven units)
// takes 14 s instead of 10.
std::vector<Candidate> PairStarts(const Candidate& c, size_t a, size_t b,
                                  const std::vector<double>& grid, size_t count, const Problem& p,
                                  const std::vector<double>& gm_grid) {
  constexpr double kScreenTolerance = 1e-2;
  constexpr double kCorrelationTimeSpan = 2.1;
  // Each Gauss-Markov term's grid points near its correlation time now.
  const CompositeModel now = ToModel(c.kinds, c.theta, p);
  std::vector<std::pair<size_t, std::vector<double>>> near;
  for (size_t g = 0; g < c.kinds.size(); ++g) {
    if (c.kinds[g] != TermKind::kGaussMarkov) continue;
    std::vector<double> times;
    for (double t : gm_grid) {
      if (std::abs(std::log(t / now.terms[g].correlation_time_s)) <=
          std::log(kCorrelationTimeSpan)) {
        times.push_back(t);
      }
    }
    near.emplace_back(g, std::move(times));
  }
  std::vector<Candidate> screened;
  for (size_t x = 0; x < grid.size(); ++x) {
    for (size_t y = x + 1; y < grid.size(); ++y) {
      Eigen::VectorXd th = WithPair(c.kinds, c.theta, a, grid[x], b, grid[y], p);
      for (const auto& [g, times] : near) {
        const std::vector<Eigen::VectorXd> best_time = GridStarts(c.kinds, th, g, times, 1, p);
        if (!best_time.empty()) th = best_time.front();
      }
      Candidate e = Estimate(c.kinds, LinearStart(c.kinds, th, p), p, kScreenTolerance);
      if (std::isfinite(e.criterion)) screened.push_back(std::move(e));  // candidates only
    }
  }
  std::sort(screened.begin(), screened.end(),
            [](const Candidate& l, const Candidate& r) { return l.objective < r.objective; });
  std::vector<Candidate> out;
  for (const Candidate& e : screened) {
    if (out.size() >= count) break;
    if (std::none_of(out.begin(), out.end(),
                     [&](const Candidate& o) { return SameMinimum(o, e, p); })) {
      out.push_back(e);
    }
  }
  return out;
}

// The highest frequency (cycles per sample) a line of the model may have: a
// cycle per shortest fitted tau (Identified), at most Nyquist.
double SinusoidBandTop(const std::vector<FitRow>& rows) {
  return std::min(0.5, 1.0 / static_cast<double>(rows.front().m));
}

// The frequencies (cycles per sample) a sinusoid is searched over, up to
// SinusoidBandTop: every 0.01 from Nyquist down to 0.05 (the octave points'
// sin^4(pi f m) turns fast in f there), then 4 per octave down to a cycle
// per 4 longest averaging times.
std::vector<double> SinusoidGrid(const std::vector<FitRow>& rows) {
  std::vector<double> grid;
  const double f_hi = SinusoidBandTop(rows);
  for (double f = 0.49; f > 0.0499; f -= 0.01) {
    if (f <= f_hi) grid.push_back(f);
  }
  const double f_lo = 1.0 / (static_cast<double>(rows.back().m) * 4.0);
  for (double f = 0.05 / std::pow(2.0, 0.25); f > f_lo; f /= std::pow(2.0, 0.25)) {
    if (f <= f_hi) grid.push_back(f);
  }
  return grid;
}

// The range of correlation times a Gauss-Markov term is searched over: the
// analysed taus and an octave beyond at each end.
std::pair<double, double> CorrelationTimeRange(const std::vector<FitRow>& rows) {
  return {rows.front().tau_s / 2, rows.back().tau_s * 2};
}

// The correlation times a Gauss-Markov term is searched over: 2 per octave
// over CorrelationTimeRange.
std::vector<double> CorrelationTimeGrid(const std::vector<FitRow>& rows) {
  std::vector<double> grid;
  const auto [tau_lo, tau_hi] = CorrelationTimeRange(rows);
  for (double t = tau_lo; t <= tau_hi; t *= std::numbers::sqrt2) grid.push_back(t);
  return grid;
}

// The least J of a grid of full estimates of `best` from every pair of
// values of its two sinusoids' frequencies (SinusoidGrid) and of each pair
// of its Gauss-Markov terms' correlation times (CorrelationTimeGrid), its
// other parameters started where the search left them (the estimates that
// are candidates); NaN when `best` has neither two sinusoids nor two
// Gauss-Markov terms.
// GmwmOptions::check_pair_search: how often the search misses.
double PairGridObjective(const Candidate& best, const Problem& p, const std::vector<FitRow>& rows) {
  std::vector<size_t> lines, gms;
  for (size_t t = 0; t < best.kinds.size(); ++t) {
    if (best.kinds[t] == TermKind::kSinusoid) lines.push_back(t);
    if (best.kinds[t] == TermKind::kGaussMarkov) gms.push_back(t);
  }
  double least = kNaN;
  auto grid_over = [&](size_t first, size_t second, const std::vector<double>& grid) {
    for (size_t x = 0; x < grid.size(); ++x) {
      for (size_t y = x + 1; y < grid.size(); ++y) {
        const Eigen::VectorXd th =
            WithPair(best.kinds, best.theta, first, grid[x], second, grid[y], p);
        const Candidate c = Estimate(best.kinds, LinearStart(best.kinds, th, p), p);
        if (!std::isfinite(c.criterion)) continue;         // not a candidate (Identified)
        if (!(c.objective >= least)) least = c.objective;  // NaN least: the first
      }
    }
  };
  if (lines.size() == 2) grid_over(lines[0], lines[1], SinusoidGrid(rows));
  const std::vector<double> times = CorrelationTimeGrid(rows);
  for (size_t i = 0; i < gms.size(); ++i) {
    for (size_t k = i + 1; k < gms.size(); ++k) grid_over(gms[i], gms[k], times);
  }
  return least;
}

// The candidate search of one pass, from `start` (or, without one, from the
// best subset of the IEEE 952 terms); every estimated model lands in *seen
// (best objective per model name) and, given `minima`, in the distinct
// minima of its name (the kMinimaPerModel lowest); given `refined`, the
// names of the models whose correlation times and frequencies it searched
// over their grids (the ones it stood on) land there.
Candidate Search(const Problem& p, const std::vector<FitRow>& rows, const GmwmOptions& options,
                 std::map<std::string, Candidate>* seen, const Candidate* start = nullptr,
                 Minima* minima = nullptr, std::set<std::string>* refined = nullptr) {
  auto record = [&](const Candidate& c) {
    if (!std::isfinite(c.criterion)) return;
    const std::string name = NameOf(c.kinds, c.theta, p);
    auto it = seen->find(name);
    if (it == seen->end() || c.objective < it->second.objective) (*seen)[name] = c;
    if (minima != nullptr) AddMinimum(&(*minima)[name], c, p);
  };
  Candidate current;
  if (start != nullptr) current = *start;
  // 1. Every non-empty subset of the IEEE 952 terms.
  for (unsigned mask = 1; start == nullptr && mask < (1u << kIeeeKinds.size()); ++mask) {
    std::vector<TermKind> kinds;
    Eigen::VectorXd theta(0);
    for (size_t t = 0; t < kIeeeKinds.size(); ++t) {
      if (!(mask & (1u << t))) continue;
      kinds.push_back(kIeeeKinds[t]);
      theta = Append(theta, StartParameters(kIeeeKinds[t], rows, p));
    }
    const Candidate c = Estimate(kinds, LinearStart(kinds, theta, p), p);
    record(c);
    if (c.criterion < current.criterion) current = c;
  }
  if (!std::isfinite(current.criterion)) return current;
  // 2. Forward-backward.
  const auto [tau_lo, tau_hi] = CorrelationTimeRange(rows);
  const std::vector<double> gm_grid = CorrelationTimeGrid(rows);
  const std::vector<double> sinusoid_grid = SinusoidGrid(rows);
  // A new line's starts spread over the band the fitted points resolve (up to
  // Nyquist over every point).
  std::vector<double> gm_spread, sinusoid_spread;
  const double band_scale = SinusoidBandTop(rows) / 0.5;
  for (double f : {0.05, 0.15, 0.245, 0.4}) sinusoid_spread.push_back(f * band_scale);
  for (int i = 0; i < 5; ++i) {
    gm_spread.push_back(tau_lo * std::pow(tau_hi / tau_lo, (i + 0.5) / 5));
  }
  // Each correlation time and frequency of the model searched again over
  // its grid, the others held (the scales re-solved): a term added early
  // can sit in a local minimum that a later term moved away from.
  std::set<std::string> paired;  // models whose two lines were searched as a pair
  // The pair search's grid: every other frequency of sinusoid_grid (a line's
  // minimum in J is as wide as the shortest taus' response, ~0.06 cycles
  // per sample at 16 samples; the estimate then finds its bottom).
  std::vector<double> pair_grid;
  for (size_t i = 0; i < sinusoid_grid.size(); i += 2) pair_grid.push_back(sinusoid_grid[i]);
  auto refine = [&] {
    if (refined != nullptr) refined->insert(NameOf(current.kinds, current.theta, p));
    for (size_t t = 0; t < current.kinds.size(); ++t) {
      const TermKind kind = current.kinds[t];
      if (kind != TermKind::kGaussMarkov && kind != TermKind::kSinusoid) continue;
      const bool gm = kind == TermKind::kGaussMarkov;
      for (const Eigen::VectorXd& start : GridStarts(current.kinds, current.theta, t,
                                                     gm ? gm_grid : sinusoid_grid, 2, p)) {
        const Candidate c = Estimate(current.kinds, start, p);
        record(c);
        if (c.criterion < current.criterion - 1e-9) current = c;
      }
    }
    std::vector<size_t> lines;
    for (size_t t = 0; t < current.kinds.size(); ++t) {
      if (current.kinds[t] == TermKind::kSinusoid) lines.push_back(t);
    }
    // Once per model in a search (1225 coarse estimates).
    if (lines.size() == 2 && paired.insert(NameOf(current.kinds, current.theta, p)).second) {
      for (const Candidate& screened :
           PairStarts(current, lines[0], lines[1], pair_grid, 3, p, gm_grid)) {
        const Candidate c = Estimate(current.kinds, screened.theta, p);
        record(c);
        if (c.criterion < current.criterion - 1e-9) current = c;
      }
    }
  };
  if (start != nullptr) refine();
  for (int step = 0; step < 16; ++step) {
    Candidate best_move;
    auto consider = [&](const std::vector<TermKind>& kinds, const Eigen::VectorXd& start) {
      const Candidate c = Estimate(kinds, start, p);
      record(c);
      if (c.criterion < best_move.criterion) best_move = c;
    };
    auto propose = [&](TermKind kind) {
      std::vector<TermKind> kinds = current.kinds;
      kinds.push_back(kind);
      const Eigen::VectorXd theta = Append(current.theta, StartParameters(kind, rows, p));
      if (kind == TermKind::kGaussMarkov) {
        // Correlation times: the minima of the linearized J over the grid,
        // and times spread evenly whatever the linearization says.
        for (const Eigen::VectorXd& start :
             GridStarts(kinds, theta, kinds.size() - 1, gm_grid, kGaussMarkovStarts, p)) {
          consider(kinds, start);
        }
        for (double t : gm_spread) {
          consider(kinds, LinearStart(kinds, WithSecond(kinds, theta, kinds.size() - 1, t, p), p));
        }
      } else if (kind == TermKind::kSinusoid) {
        // Frequencies: a fixed spread only. The octave points alias a line's
        // frequency, and the best of a fine grid of frequencies lowers J by
        // more than a line's cost on pure noise: starting from the grid's
        // minima made a spurious line the selected model in up to 1 record
        // of 10 (simulated white + two Gauss-Markov terms).
        for (double f : sinusoid_spread) {
          consider(kinds, LinearStart(kinds, WithSecond(kinds, theta, kinds.size() - 1, f, p), p));
        }
      } else {
        consider(kinds, LinearStart(kinds, theta, p));
      }
    };
    for (TermKind kind : kIeeeKinds) {
      if (std::find(current.kinds.begin(), current.kinds.end(), kind) == current.kinds.end()) {
        propose(kind);
      }
    }
    const CompositeModel model = ToModel(current.kinds, current.theta, p);
    if (model.CountOf(TermKind::kGaussMarkov) < options.max_gauss_markov) {
      propose(TermKind::kGaussMarkov);
    }
    if (model.CountOf(TermKind::kSinusoid) < options.max_sinusoids) {
      propose(TermKind::kSinusoid);
    }
    // Where no term added helps: swaps of one long-tau IEEE term for one the
    // model lacks, the rest kept. A rate random walk and a rate ramp (or a
    // flicker floor) that compete for the curve's rising end are otherwise
    // never exchanged: adding the second costs a parameter, and the model
    // with only it lies a step beyond. Tried only where the search would
    // stop, so one call of Search ends where it did without them or lower,
    // having seen every model it saw (the fit as a whole can still end
    // elsewhere: pass 2's problem comes from pass 1's pilot and starts from
    // pass 1's eight best). On 200 twins of each ADIS16405 accelerometer (13
    // points from 0.16 s; bench/twin_agreement_bench.cc) the selected
    // model's criterion was higher without the swaps in 10 / 51 / 58 and
    // lower in 2 / 12 / 4 (ax / ay / az); az's twins of N+B+K+2S selected it
    // in 108 with them and 75 without, most of the rest then ending at
    // N+B+R+2S with their curve minimum 3 sigma low. Swaps among all five
    // terms went further (white noise for quantization, then neither) and
    // reached models whose white asymptote is a fast Gauss-Markov term's, 7
    // sigma off on 8 of 200 az twins: not taken.
    if (!(best_move.criterion < current.criterion - 1e-9)) {
      for (size_t i = 0; i < current.kinds.size(); ++i) {
        const TermKind out = current.kinds[i];
        if (std::find(kLongTauKinds.begin(), kLongTauKinds.end(), out) == kLongTauKinds.end()) {
          continue;
        }
        // The model without the term as well: a swapped-in term that
        // collapses to nothing leaves that model, and a candidate is known
        // to be it (and dropped as a rival, FitCompositeModel) only when
        // the model itself was estimated.
        const Eigen::VectorXd without = Without(current.kinds, current.theta, static_cast<int>(i));
        if (current.kinds.size() > 1) {
          std::vector<TermKind> kinds = current.kinds;
          kinds.erase(kinds.begin() + static_cast<long>(i));
          consider(kinds, LinearStart(kinds, without, p));
        }
        for (TermKind in : kLongTauKinds) {
          if (std::find(current.kinds.begin(), current.kinds.end(), in) != current.kinds.end()) {
            continue;
          }
          std::vector<TermKind> kinds = current.kinds;
          kinds.erase(kinds.begin() + static_cast<long>(i));
          kinds.push_back(in);
          consider(kinds, LinearStart(kinds, Append(without, StartParameters(in, rows, p)), p));
        }
      }
    }
    if (!(best_move.criterion < current.criterion - 1e-9)) break;
    current = best_move;
    // Backward: drop any term whose removal improves the criterion.
    for (bool improved = true; improved && current.kinds.size() > 1;) {
      improved = false;
      for (size_t i = 0; i < current.kinds.size(); ++i) {
        std::vector<TermKind> kinds = current.kinds;
        kinds.erase(kinds.begin() + static_cast<long>(i));
        const Candidate c = Estimate(
            kinds, LinearStart(kinds, Without(current.kinds, current.theta, static_cast<int>(i)), p),
            p);
        record(c);
        if (c.criterion < current.criterion - 1e-9) {
          current = c;
          improved = true;
          break;
        }
      }
    }
    refine();
  }
  return current;
}

// A standard normal deviate from a 64-bit generator (Box-Muller), identical
// on every platform (std::normal_distribution is not).
double StandardNormal(std::mt19937_64& rng) {
  constexpr double kTwoPow53 = 9007199254740992.0;
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) / kTwoPow53;
  const double u2 = static_cast<double>(rng() >> 11) / kTwoPow53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

// The bootstrap's quantiles in double precision (Boost's default promotes
// to long double: twice the time, for digits no replicate needs).
constexpr auto kDoublePolicy =
    boost::math::policies::policy<boost::math::policies::promote_double<false>>();

// The bootstrap's draws in the moments, replicates x points: row r is
// replicate r's deviation of each ln avar from its model value (see
// FitCompositeModel). Seeded, so the first k rows are the same whatever the
// number of rows: every candidate's bootstrap on the same problem shares
// them (a candidate with k replicates uses the first k).
Eigen::MatrixXd BootstrapNoise(const Problem& p, int replicates) {
  const int n = p.points();
  const Eigen::VectorXd sd = p.sigma.diagonal().array().sqrt();
  const Eigen::MatrixXd corr =
      sd.cwiseInverse().asDiagonal() * p.sigma * sd.cwiseInverse().asDiagonal();
  Eigen::LLT<Eigen::MatrixXd> llt(corr);
  const Eigen::MatrixXd l = llt.info() == Eigen::Success ? Eigen::MatrixXd(llt.matrixL())
                                                         : Eigen::MatrixXd::Identity(n, n);
  std::mt19937_64 rng(0x1dca5e5eedULL);
  Eigen::MatrixXd noise(replicates, n);
  // The mean of ln(chi2_nu / nu) at each point, the same in every replicate.
  std::vector<double> mean(n);
  for (int j = 0; j < n; ++j) {
    const double half = p.edf(j) / 2.0;
    mean[j] = boost::math::digamma(half) - std::log(half);
  }
  Eigen::VectorXd e(n);
  for (int r = 0; r < replicates; ++r) {
    for (int j = 0; j < n; ++j) e(j) = StandardNormal(rng);
    const Eigen::VectorXd z = l * e;
    for (int j = 0; j < n; ++j) {
      const double u = std::clamp(0.5 * std::erfc(-z(j) / std::numbers::sqrt2), 1e-12, 1 - 1e-12);
      const double half = p.edf(j) / 2.0;
      // ln(chi2_nu / nu) - its mean, chi2_nu = 2 Gamma(nu/2) quantile.
      noise(r, j) = std::log(boost::math::gamma_p_inv(half, u, kDoublePolicy) / half) - mean[j];
    }
  }
  return noise;
}

// A replicate's refit stops at a relative step of 1e-5 in theta: its
// quantities move by ~1e-5 of themselves, far below the spread it measures.
constexpr double kBootstrapTolerance = 1e-5;

// The standard deviation of each of `count` quantities over bootstrap
// replicates of the moments (see FitCompositeModel); NaN where fewer than 10
// replicates could be refitted.
// `noise`: BootstrapNoise(p, k) with k >= replicates.
template <typename Quantities>
std::vector<double> BootstrapSigmas(const Candidate& best, const Problem& p, int replicates,
                                    const Eigen::MatrixXd& noise, size_t count,
                                    Quantities quantities) {
  const int n = p.points();
  const Eigen::VectorXd base = LogModel(ToModel(best.kinds, best.theta, p), p);
  Problem replicate = p;
  replicate.identified_only = false;
  std::vector<double> sum(count, 0.0), sum2(count, 0.0);
  std::vector<int> used(count, 0);
  for (int r = 0; r < replicates; ++r) {
    for (int j = 0; j < n; ++j) replicate.y(j) = base(j) + noise(r, j);
    const Candidate c = Estimate(best.kinds, best.theta, replicate, kBootstrapTolerance);
    if (!std::isfinite(c.criterion)) continue;
    const std::vector<double> q = quantities(c.theta);
    for (size_t i = 0; i < count; ++i) {
      if (!std::isfinite(q[i])) continue;
      sum[i] += q[i];
      sum2[i] += q[i] * q[i];
      ++used[i];
    }
  }
  std::vector<double> out(count, kNaN);
  for (size_t i = 0; i < count; ++i) {
    if (used[i] < 10) continue;
    const double mean = sum[i] / used[i];
    out[i] = std::sqrt(std::max(0.0, (sum2[i] - used[i] * mean * mean) / (used[i] - 1)));
  }
  return out;
}

// d ln AVAR / d ln m of the model at m.
double ModelAvarSlope(const ModelEvaluator& model, double m) {
  constexpr double kStep = 1.1;
  return std::log(model.Avar(m * kStep) / model.Avar(m / kStep)) / (2.0 * std::log(kStep));
}

// Mean over theta of sin^4(theta) sin^4(r theta).
double MeanFastFactor(double r) {
  constexpr int kPeriods = 64, kPerPeriod = 64;
  double sum = 0;
  const int n = kPeriods * kPerPeriod;
  for (int i = 0; i < n; ++i) {
    const double th = kPi * (i + 0.5) / kPerPeriod;
    const double a = std::sin(th), b = std::sin(r * th);
    sum += a * a * a * a * b * b * b * b;
  }
  return sum / n;
}

// int_lo^hi g(f) df by the midpoint rule with at least `n` intervals.
template <typename F>
double Midpoint(F g, double lo, double hi, double step) {
  if (!(hi > lo)) return 0;
  const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / step)));
  const double h = (hi - lo) / n;
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += g(lo + (i + 0.5) * h);
  return sum * h;
}

// int_lo^hi g(f) df on a logarithmic grid (g smooth in ln f).
template <typename F>
double LogMidpoint(F g, double lo, double hi, int per_octave) {
  if (!(hi > lo)) return 0;
  const int n = std::max(1, static_cast<int>(std::ceil(per_octave * std::log2(hi / lo))));
  const double step = std::log(hi / lo) / n;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double f = lo * std::exp((i + 0.5) * step);
    sum += g(f) * f;
  }
  return sum * step;
}

// The spectrum on the midpoint grid of one of SpectralOverlap's integrals,
// at the points Midpoint (linear) or LogMidpoint (logarithmic) would take:
// each point's f, sin(pi f) and the model's PSD, and, on a linear grid of a
// factor m, sin^4(pi f m). Integrals whose grid depends on one factor alone
// are shared by every pair with that factor (the values are the ones the
// integrand would compute, so the sums are the same).
struct SpectrumGrid {
  bool empty = true;  // !(hi > lo): the integral is 0
  double step = 0;    // h (linear) or the step in ln f (logarithmic)
  std::vector<double> f, sin_pi_f, psd, sin4_m;
};

double Sin4(double x) {
  const double s = std::sin(x);
  return s * s * s * s;
}

SpectrumGrid LinearSpectrumGrid(const ModelEvaluator& model, double lo, double hi, double step,
                                double m) {
  SpectrumGrid g;
  if (!(hi > lo)) return g;
  g.empty = false;
  const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / step)));
  g.step = (hi - lo) / n;
  for (int i = 0; i < n; ++i) {
    const double f = lo + (i + 0.5) * g.step;
    const double d = std::sin(kPi * f);
    g.f.push_back(f);
    g.sin_pi_f.push_back(d);
    g.psd.push_back(model.Psd(f, d));
    g.sin4_m.push_back(Sin4(kPi * f * m));
  }
  return g;
}

SpectrumGrid LogSpectrumGrid(const ModelEvaluator& model, double lo, double hi, int per_octave) {
  SpectrumGrid g;
  if (!(hi > lo)) return g;
  g.empty = false;
  const int n = std::max(1, static_cast<int>(std::ceil(per_octave * std::log2(hi / lo))));
  g.step = std::log(hi / lo) / n;
  for (int i = 0; i < n; ++i) {
    const double f = lo * std::exp((i + 0.5) * g.step);
    const double d = std::sin(kPi * f);
    g.f.push_back(f);
    g.sin_pi_f.push_back(d);
    g.psd.push_back(model.Psd(f, d));
  }
  return g;
}

constexpr double kOverlapFine = 8;     // samples per period of the fastest factor
constexpr double kOverlapCycles = 32;  // periods before a factor counts as fast

// The first integral's grid of SpectralOverlap(., m_b) and its last one's of
// SpectralOverlap(m_a, .), for m_b = m_a = m.
SpectrumGrid FirstOverlapGrid(const ModelEvaluator& model, double m) {
  return LinearSpectrumGrid(model, 0, std::min(0.5, kOverlapCycles / m), 1 / (kOverlapFine * m), m);
}
SpectrumGrid LastOverlapGrid(const ModelEvaluator& model, double m) {
  return LogSpectrumGrid(model, std::min(0.5, kOverlapCycles / m), 0.5, 16);
}

// I_ab = int_0^1/2 S(f)^2 H_a(f) H_b(f) df, m_a <= m_b. H_m = sin^4(pi f m) W_m,
// W_m = 1/(m^2 sin^2(pi f)). Where a sin^4 factor oscillates much faster than
// the rest of the integrand it is replaced by its mean (3/8, or the joint mean
// of both factors), which keeps every pair to a few thousand evaluations.
// `first`: FirstOverlapGrid(model, mb); `last`: LastOverlapGrid(model, ma);
// `mean_fast(r)`: MeanFastFactor(r).
template <typename MeanFast>
double SpectralOverlap(const ModelEvaluator& model, double ma, double mb, const SpectrumGrid& first,
                       const SpectrumGrid& last, MeanFast mean_fast) {
  auto s2w_of = [&](double s, double d) { return s * s / (ma * ma * mb * mb * d * d * d * d); };
  auto s2w = [&](double f) {
    const double d = std::sin(kPi * f), s = model.Psd(f, d);
    return s2w_of(s, d);
  };
  const double f1 = std::min(0.5, kOverlapCycles / mb);
  const double f2 = std::min(0.5, kOverlapCycles / ma);
  // Midpoint(s2w(f) sin^4(pi f ma) sin^4(pi f mb), 0, f1, 1 / (kFine mb)).
  double total = 0;
  if (!first.empty) {
    double sum = 0;
    for (size_t i = 0; i < first.f.size(); ++i) {
      const double f = first.f[i];
      sum += s2w_of(first.psd[i], first.sin_pi_f[i]) * Sin4(kPi * f * ma) * first.sin4_m[i];
    }
    total = sum * first.step;
  }
  const double r = mb / ma;
  if (r >= 8) {
    total += Midpoint([&](double f) { return s2w(f) * Sin4(kPi * f * ma) * 0.375; }, f1, f2,
                      1 / (kOverlapFine * ma));
  } else {
    total += Midpoint([&](double f) { return s2w(f) * Sin4(kPi * f * ma) * Sin4(kPi * f * mb); },
                      f1, f2, 1 / (kOverlapFine * mb));
  }
  const double mean = r >= 8 ? 0.375 * 0.375 : mean_fast(r);
  // LogMidpoint(s2w(f) mean, f2, 0.5, 16).
  if (!last.empty) {
    double sum = 0;
    for (size_t i = 0; i < last.f.size(); ++i) {
      sum += s2w_of(last.psd[i], last.sin_pi_f[i]) * mean * last.f[i];
    }
    total += sum * last.step;
  }
  return total;
}

// Spectral windows of the moments: a point's expectation is
// int_0^1/2 4 S(f) W(f) df, S the two-sided PSD, with
//   AVAR(m)       W_A(f) = 4 sin^4(pi f m) / (m^2 sin^2(pi f)),
//   E[Theo1(m)]   W_T(f) = 8 P_m(f) / (0.75 m^2 sin^2(pi f)),
// P_m = Theo1SinusoidSum (W is the moment of a unit-amplitude sinusoid at f,
// times 4). Their asymptotic covariance is I_ab = int S^2 W_a W_b df, as for
// the AVAR pairs above. Above ~32 / m both windows oscillate in f with
// period ~1/m about a slowly varying mean; there they are replaced by the
// mean over that fast phase (the mean square for a point with itself).
// 4 P_m = A0 + Re(e^{i 2 pi f m} C) + O(1 / (m sin(pi f))) (the partial
// sums of the log series at their limits -ln(1 - e^{ic})), so
//   mean 4 P = A0 = H + ln(2 sin(pi f)),  mean (4 P)^2 = A0^2 + |C|^2 / 2,
//   C = H / 2 + conj ln(1 - e^{2 i pi f}) - conj ln(1 - e^{4 i pi f}) / 2,
// H the harmonic number H_{m/2}; sin^4 has mean 3/8 and sin^8 35/128. The
// means of products of two different points' fast parts vanish: a Theo1
// point's factor is beyond 2.67 times every AVAR point's (twice its tau)
// and Theo1 points are octaves apart, so no two fast phases coincide.
struct Window {
  double m = 0;
  bool theo1 = false;
  double harmonic = 0;  // H_{m/2} (Theo1)
};

double WindowAt(const Window& w, double f, double sin_pi_f) {
  const double d2 = sin_pi_f * sin_pi_f;
  if (!w.theo1) return 4 * Sin4(kPi * f * w.m) / (w.m * w.m * d2);
  return 8 * Theo1SinusoidSum(f, static_cast<int64_t>(w.m)) / (0.75 * w.m * w.m * d2);
}

// The window's mean over its fast phase at f, or its mean square.
double WindowMean(const Window& w, double f, double sin_pi_f, bool square) {
  const double d2 = sin_pi_f * sin_pi_f;
  if (!w.theo1) {
    const double base = 4 / (w.m * w.m * d2);
    return square ? base * base * 35.0 / 128.0 : base * 3.0 / 8.0;
  }
  const double a0 = w.harmonic + std::log(2 * sin_pi_f);
  double four = a0;
  if (square) {
    const std::complex<double> e2 = std::polar(1.0, 2 * kPi * f);
    const std::complex<double> e4 = std::polar(1.0, 4 * kPi * f);
    const std::complex<double> c =
        0.5 * w.harmonic + std::conj(std::log(1.0 - e2)) - 0.5 * std::conj(std::log(1.0 - e4));
    four = std::sqrt(a0 * a0 + 0.5 * std::norm(c));
  }
  const double base = 8 * (four / 4) / (0.75 * w.m * w.m * d2);
  return square ? base * base : base;
}

// I_ab for windows a and b (the same window for a point with itself): exact
// windows on a linear grid to 32 / m_hi (8 per 1 / m_hi), the faster
// window's mean with the slower one exact to 32 / m_lo, both means beyond
// (16 per octave).
double WindowOverlap(const ModelEvaluator& model, const Window& a, const Window& b, bool same) {
  const Window& hi = a.m >= b.m ? a : b;
  const Window& lo = a.m >= b.m ? b : a;
  auto s2 = [&](double f, double d) {
    const double s = model.Psd(f, d);
    return s * s;
  };
  const double f1 = std::min(0.5, kOverlapCycles / hi.m);
  const double f2 = same ? f1 : std::min(0.5, kOverlapCycles / lo.m);
  double total = Midpoint(
      [&](double f) {
        const double d = std::sin(kPi * f);
        const double wa = WindowAt(a, f, d);
        return s2(f, d) * wa * (same ? wa : WindowAt(b, f, d));
      },
      0, f1, 1 / (kOverlapFine * hi.m));
  if (!same) {
    total += Midpoint(
        [&](double f) {
          const double d = std::sin(kPi * f);
          return s2(f, d) * WindowMean(hi, f, d, false) * WindowAt(lo, f, d);
        },
        f1, f2, 1 / (kOverlapFine * lo.m));
  }
  total += LogMidpoint(
      [&](double f) {
        const double d = std::sin(kPi * f);
        return s2(f, d) * (same ? WindowMean(a, f, d, true)
                                : WindowMean(a, f, d, false) * WindowMean(b, f, d, false));
      },
      f2, 0.5, 16);
  return total;
}

// Value of each datasheet figure for a parameter vector.
struct Figures {
  double white_asymptote = kNaN;
  double curve_minimum = kNaN;
  double tau_at_minimum = kNaN;
  bool has_white_region = false;
  bool minimum_at_edge = false;
};

// The log-tau grid on which ComputeFigures looks for the model's minimum:
// ln tau from ln tau_lo to ln tau_hi in kGrid steps, and each point's
// averaging factor, the same for every model of one fit.
struct MinimumGrid {
  static constexpr int kGrid = 240;
  MinimumGrid(double tau0_s, double tau_lo, double tau_hi)
      : tau0_s(tau0_s), a(std::log(tau_lo)), b(std::log(tau_hi)) {
    for (int i = 0; i <= kGrid; ++i) m[i] = std::exp(x(i)) / tau0_s;
  }
  double x(int i) const { return a + (b - a) * i / kGrid; }

  double tau0_s, a, b;
  std::array<double, kGrid + 1> m;  // exp(x(i)) / tau0
};

// `white_region`: whether to look for a white-noise region (has_white_region;
// the bootstrap's replicates do not read it).
Figures ComputeFigures(const CompositeModel& model, const MinimumGrid& grid,
                       const GmwmOptions& options, bool white_region = true) {
  const double tau0_s = grid.tau0_s;
  Figures f;
  double white2 = 0;
  for (const ModelTerm& t : model.terms) {
    if (t.kind == TermKind::kWhite) white2 += t.scale * t.scale;
    if (t.kind == TermKind::kGaussMarkov &&
        t.correlation_time_s < options.fast_gauss_markov_fraction * 1.0) {
      const double phi = std::exp(-tau0_s / t.correlation_time_s);
      white2 += t.scale * t.scale * tau0_s * (1 + phi) / (1 - phi);
    }
  }
  f.white_asymptote = std::sqrt(white2);
  // Minimum of the model deviation: a log grid, then golden-section refinement.
  constexpr int kGrid = MinimumGrid::kGrid;
  const ModelEvaluator ev(model, tau0_s);
  // CompositeModel::Deviation at m = tau / tau0.
  auto dev = [&](double ln_tau) { return std::sqrt(ev.Avar(std::exp(ln_tau) / tau0_s)); };
  const double a = grid.a, b = grid.b;
  int best = 0;
  double best_dev = std::numeric_limits<double>::infinity(), prev = kNaN;
  for (int i = 0; i <= kGrid; ++i) {
    const double d = std::sqrt(ev.Avar(grid.m[i]));  // dev(grid.x(i))
    if (d < best_dev) {
      best_dev = d;
      best = i;
    }
    if (white_region && i > 0) {
      const double slope = std::log(d / prev) / ((b - a) / kGrid);
      if (std::fabs(slope + 0.5) <= 0.1) f.has_white_region = true;
    }
    prev = d;
  }
  double lo = a + (b - a) * std::max(0, best - 1) / kGrid;
  double hi = a + (b - a) * std::min(kGrid, best + 1) / kGrid;
  const double g = (std::sqrt(5.0) - 1) / 2;
  for (int it = 0; it < 60; ++it) {
    const double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    if (dev(x1) < dev(x2)) {
      hi = x2;
    } else {
      lo = x1;
    }
  }
  const double x = 0.5 * (lo + hi);
  f.curve_minimum = dev(x);
  f.tau_at_minimum = std::exp(x);
  f.minimum_at_edge = best == 0 || best == kGrid;
  return f;
}

// The best candidate re-estimated with a term of `kind` at `scale` fixed
// beside its own terms (the profile of J in that term).
Candidate WithFixedTerm(const Candidate& best, TermKind kind, const Problem& p, double scale) {
  constexpr double kProfileTolerance = 1e-5;  // J to ~1e-3, far below any delta_j used
  CompositeModel term;
  term.terms.push_back(ModelTerm{kind, scale});
  Problem fixed = p;
  fixed.identified_only = false;
  fixed.fixed_avar.resize(p.points());
  for (int j = 0; j < p.points(); ++j) fixed.fixed_avar(j) = TermMoment(term.terms[0], p, j);
  return Estimate(best.kinds, best.theta, fixed, kProfileTolerance);
}

// The largest scale of an IEEE 952 term the selected model leaves out that
// the data still allow: the profile of J over the term's scale s (the
// selected model's own parameters refitted with the term held at s), and the
// bound where J(s) - J(0) = delta_j (likelihood-ratio; see GmwmOptions). Bisection on ln s
// between a scale the data do not notice and 2 to 16 times the scale at
// which the term alone reaches the measured curve. NaN if the profile never rises that
// far (the term is indistinguishable from the model's own terms everywhere).
double AbsentTermUpperBound(const Candidate& best, TermKind kind, const Problem& p,
                            const std::vector<FitRow>& rows, double delta_j) {
  // A term 1000x below the curve everywhere changes J by ~1e-6: the bracket
  // starts there; 9 bisections of its ~7.6 in ln s leave ~1.5 %.
  constexpr int kBisections = 9;
  const ModelTerm unit{kind, 1.0};
  Eigen::VectorXd unit_avar(p.points());
  double reach = std::numeric_limits<double>::infinity();  // term alone = curve
  for (int j = 0; j < p.points(); ++j) {
    unit_avar(j) = TermMoment(unit, p, j);
    if (unit_avar(j) > 0) reach = std::min(reach, std::sqrt(rows[j].avar / unit_avar(j)));
  }
  if (!std::isfinite(reach) || reach <= 0) return kNaN;
  auto rise = [&](double scale) {
    return WithFixedTerm(best, kind, p, scale).objective - best.objective;
  };
  // Up to 16x the reach: beyond, the term would dwarf the measured curve and
  // the data bound nothing a reader could use.
  double lo = std::log(reach / 1000), hi = std::log(2 * reach);
  for (int i = 0; i < 3 && !(rise(std::exp(hi)) > delta_j); ++i) hi += std::log(2.0);
  if (!(rise(std::exp(hi)) > delta_j)) return kNaN;
  for (int i = 0; i < kBisections; ++i) {
    const double mid = 0.5 * (lo + hi);
    (rise(std::exp(mid)) > delta_j ? hi : lo) = mid;
  }
  return std::exp(hi);
}

// The phase points of the record of the means of `block` samples of a
// record with n_phase phase points (whole means only).
int64_t MeansPhasePoints(int64_t n_phase, int64_t block) { return (n_phase - 1) / block + 1; }

// The Theo1 moments as fit rows after the curve's (tau = 0.75 m tau0, avar =
// Theo1, local slope to the previous row), each checked: m even in [2, N-1],
// Theo1 positive and finite, tau beyond the curve's last fitted tau and
// beyond the previous moment's.
Status AppendTheo1Rows(std::span<const Theo1Moment> long_taus, const Curve& curve,
                       std::vector<FitRow>* rows) {
  for (const Theo1Moment& t : long_taus) {
    const std::string at = "Theo1 moment at m " + std::to_string(t.m);
    if (t.block < 1) {
      return Status::InvalidArgument(at + ": block must be at least 1, got " +
                                     std::to_string(t.block));
    }
    const int64_t n_phase = t.n_phase > 0 ? t.n_phase : MeansPhasePoints(curve.n_phase, t.block);
    if (t.m < 2 || t.m % 2 != 0 || t.m > n_phase - 1) {
      return Status::InvalidArgument(at + ": m must be even in [2, " + std::to_string(n_phase - 1) +
                                     "]");
    }
    if (!(t.theo1 > 0 && std::isfinite(t.theo1))) {
      return Status::InvalidArgument(at + ": Theo1 must be positive and finite, got " +
                                     FormatG(t.theo1));
    }
    FitRow r;
    r.m = t.m * t.block;  // the curve's samples
    r.tau_s = 0.75 * static_cast<double>(r.m) * curve.tau0_s;
    r.avar = t.theo1;
    r.n_eff = n_phase * t.block;
    if (!(r.tau_s > rows->back().tau_s)) {
      return Status::InvalidArgument(at + ": its tau " + FormatG(r.tau_s) +
                                     " s must lie beyond the last fitted tau " +
                                     FormatG(rows->back().tau_s) + " s");
    }
    r.local_slope = std::log(r.avar / rows->back().avar) / std::log(r.tau_s / rows->back().tau_s);
    rows->push_back(r);
  }
  return Status::Ok();
}

}  // namespace

Status GmwmOptions::Validate() const {
  if (max_gauss_markov < 0 || max_gauss_markov > 3) {
    return Status::InvalidArgument("max_gauss_markov must be in [0, 3], got " +
                                   std::to_string(max_gauss_markov));
  }
  if (max_sinusoids < 0 || max_sinusoids > 2) {
    return Status::InvalidArgument("max_sinusoids must be in [0, 2], got " +
                                   std::to_string(max_sinusoids));
  }
  if (!(adequacy_level > 0 && adequacy_level < 1)) {
    return Status::InvalidArgument("adequacy_level must be in (0, 1)");
  }
  if (bootstrap_replicates < 0 || bootstrap_replicates > 5000) {
    return Status::InvalidArgument("bootstrap_replicates must be in [0, 5000], got " +
                                   std::to_string(bootstrap_replicates));
  }
  if (!(parameter_penalty >= 0 && parameter_penalty <= 20)) {
    return Status::InvalidArgument("parameter_penalty must be in [0, 20]");
  }
  if (!(single_term_penalty >= 0 && single_term_penalty <= 20)) {
    return Status::InvalidArgument("single_term_penalty must be in [0, 20]");
  }
  if (!(fast_gauss_markov_fraction >= 0 && fast_gauss_markov_fraction <= 1)) {
    return Status::InvalidArgument("fast_gauss_markov_fraction must be in [0, 1]");
  }
  if (!(min_tau_s >= 0 && std::isfinite(min_tau_s))) {
    return Status::InvalidArgument("min_tau_s must be finite and >= 0");
  }
  if (!(absent_term_bound_delta_j > 0 && absent_term_bound_delta_j <= 100)) {
    return Status::InvalidArgument("absent_term_bound_delta_j must be in (0, 100]");
  }
  return Status::Ok();
}

ModelCurveFigures ModelFiguresOver(const CompositeModel& model, double tau0_s, double tau_lo_s,
                                   double tau_hi_s, const GmwmOptions& options) {
  const Figures f = ComputeFigures(model, MinimumGrid(tau0_s, tau_lo_s, tau_hi_s), options,
                                   /*white_region=*/false);
  return {f.white_asymptote, f.curve_minimum, f.tau_at_minimum};
}

double AvarCorrelation(const CompositeModel& model, double tau0_s, int64_t m_a, int64_t m_b) {
  return AvarCorrelationMatrix(model, tau0_s, {m_a, m_b})[1];
}

std::vector<double> AvarCorrelationMatrix(const CompositeModel& model, double tau0_s,
                                          const std::vector<int64_t>& m) {
  const size_t n = m.size();
  const ModelEvaluator ev(model, tau0_s);
  // The grids that depend on one factor, and MeanFastFactor per ratio
  // (octave neighbours share a handful of ratios; each costs 8192 sines).
  std::vector<SpectrumGrid> first(n), last(n);
  for (size_t j = 0; j < n; ++j) {
    first[j] = FirstOverlapGrid(ev, static_cast<double>(m[j]));
    last[j] = LastOverlapGrid(ev, static_cast<double>(m[j]));
  }
  std::map<double, double> mean_fast_of;
  auto mean_fast = [&](double r) {
    auto it = mean_fast_of.find(r);
    if (it == mean_fast_of.end()) it = mean_fast_of.emplace(r, MeanFastFactor(r)).first;
    return it->second;
  };
  std::vector<double> self(n), out(n * n, 0.0);
  for (size_t j = 0; j < n; ++j) {
    const double mj = static_cast<double>(m[j]);
    self[j] = SpectralOverlap(ev, mj, mj, first[j], last[j], mean_fast);
    out[j * n + j] = 1.0;
  }
  for (size_t j = 0; j < n; ++j) {
    for (size_t k = j + 1; k < n; ++k) {
      const size_t a = m[j] <= m[k] ? j : k, b = m[j] <= m[k] ? k : j;
      const double lo = static_cast<double>(std::min(m[j], m[k]));
      const double hi = static_cast<double>(std::max(m[j], m[k]));
      const double r =
          SpectralOverlap(ev, lo, hi, first[b], last[a], mean_fast) / std::sqrt(self[j] * self[k]);
      out[j * n + k] = out[k * n + j] = std::isfinite(r) ? std::clamp(r, -1.0, 1.0) : 0.0;
    }
  }
  return out;
}

std::optional<double> Theo1MomentEdf(int alpha, int64_t m, int64_t n_phase) {
  const std::optional<double> e = Theo1EdfMeasured(alpha, m, n_phase);
  return e ? e : Theo1EdfMeasured(0, m, n_phase);
}

std::optional<double> Theo1MomentEdf(const CompositeModel& model, double tau0_s, int64_t m,
                                     int64_t n_phase) {
  const ModelEvaluator ev(model, tau0_s);
  const int alpha = AlphaFromAvarSlope(ModelAvarSlope(ev, 0.75 * static_cast<double>(m)));
  return Theo1MomentEdf(alpha, m, n_phase);
}

std::vector<double> MomentCorrelationMatrix(const CompositeModel& model, double tau0_s,
                                            const std::vector<int64_t>& m,
                                            const std::vector<char>& theo1) {
  const size_t n = m.size();
  std::vector<int64_t> avar_m;
  std::vector<size_t> avar_at;
  for (size_t j = 0; j < n; ++j) {
    if (!theo1[j]) {
      avar_m.push_back(m[j]);
      avar_at.push_back(j);
    }
  }
  std::vector<double> out(n * n, 0.0);
  const std::vector<double> avar = AvarCorrelationMatrix(model, tau0_s, avar_m);
  for (size_t a = 0; a < avar_at.size(); ++a) {
    for (size_t b = 0; b < avar_at.size(); ++b) {
      out[avar_at[a] * n + avar_at[b]] = avar[a * avar_at.size() + b];
    }
  }
  if (avar_at.size() == n) return out;
  const ModelEvaluator ev(model, tau0_s);
  std::vector<Window> w(n);
  std::vector<double> self(n);
  for (size_t j = 0; j < n; ++j) {
    w[j].m = static_cast<double>(m[j]);
    w[j].theo1 = theo1[j] != 0;
    if (w[j].theo1) {
      w[j].harmonic =
          boost::math::digamma(static_cast<double>(m[j] / 2) + 1) + std::numbers::egamma;
    }
    self[j] = WindowOverlap(ev, w[j], w[j], true);
    out[j * n + j] = 1.0;
  }
  for (size_t j = 0; j < n; ++j) {
    for (size_t k = j + 1; k < n; ++k) {
      if (!theo1[j] && !theo1[k]) continue;
      const double r = WindowOverlap(ev, w[j], w[k], false) / std::sqrt(self[j] * self[k]);
      out[j * n + k] = out[k * n + j] = std::isfinite(r) ? std::clamp(r, -1.0, 1.0) : 0.0;
    }
  }
  return out;
}

std::string LargestResiduals(const CompositeFit& fit, int count) {
  std::vector<const GmwmPoint*> order;
  for (const GmwmPoint& p : fit.points) {
    if (std::isfinite(p.z)) order.push_back(&p);
  }
  std::stable_sort(order.begin(), order.end(), [](const GmwmPoint* a, const GmwmPoint* b) {
    return std::abs(a->z) > std::abs(b->z);
  });
  std::string out;
  for (size_t i = 0; i < order.size() && static_cast<int>(i) < count; ++i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%.3g s (z %+.1f)", i == 0 ? "" : ", ", order[i]->tau_s,
                  order[i]->z);
    out += buf;
  }
  return out;
}

Result<CompositeFit> FitCompositeModel(const Curve& curve, const GmwmOptions& options,
                                       std::span<const Theo1Moment> long_taus) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (curve.deviation != Deviation::kOadev && curve.deviation != Deviation::kAdev) {
    return Status::InvalidArgument("noise model fit needs an ADEV or OADEV curve, got " +
                                   std::string(DeviationName(curve.deviation)));
  }
  std::vector<FitRow> rows = UsableFitRows(curve, options.stop, options.thin_to_octaves);
  std::erase_if(rows, [&](const FitRow& r) { return r.tau_s < options.min_tau_s * (1 - 1e-9); });
  const int n_avar = static_cast<int>(rows.size());
  if (n_avar < 4) {
    return Status::InvalidArgument(
        "noise model fit needs at least 4 usable curve points, got " + std::to_string(n_avar) +
        (options.min_tau_s > 0 ? " at or above tau " + FormatG(options.min_tau_s) + " s" : ""));
  }
  const double tau0 = curve.tau0_s;
  IMUQUAL_RETURN_IF_ERROR(AppendTheo1Rows(long_taus, curve, &rows));
  const int n = static_cast<int>(rows.size());
  std::vector<char> theo1(n, 0);
  std::vector<int64_t> theo1_n(n, 0);  // phase points (of means) behind each Theo1 row
  std::vector<int64_t> block(n, 1);
  for (int j = n_avar; j < n; ++j) {
    theo1[j] = 1;
    const Theo1Moment& t = long_taus[j - n_avar];
    block[j] = t.block;
    theo1_n[j] = t.n_phase > 0 ? t.n_phase : MeansPhasePoints(curve.n_phase, t.block);
  }
  auto theo1_edf = [&](int alpha, int j) {
    return Theo1MomentEdf(alpha, rows[j].m / block[j], theo1_n[j]).value_or(1.0);
  };

  // Pass 1: diagonal covariance from the data's own noise identification.
  Eigen::VectorXd edf1(n);
  for (int j = 0; j < n; ++j) {
    const FitRow& r = rows[j];
    if (theo1[j]) {
      edf1(j) = theo1_edf(AlphaFromAvarSlope(r.local_slope), j);
      continue;
    }
    edf1(j) = r.identified && std::isfinite(r.point_edf) && r.point_edf > 0
                  ? r.point_edf
                  : FitRowEdf(AlphaFromAvarSlope(r.local_slope), r);
  }
  const Problem p1 = MakeProblem(rows, theo1, block, tau0, curve.n_phase, edf1,
                                 Eigen::MatrixXd::Identity(n, n), options);
  std::map<std::string, Candidate> seen1;
  Minima minima1;
  const Candidate pilot = Search(p1, rows, options, &seen1, nullptr, &minima1);
  if (!std::isfinite(pilot.criterion)) {
    return Status::InvalidArgument("noise model fit: no candidate model could be estimated");
  }

  // Pass 2: the covariance of the pilot, full.
  const CompositeModel pilot_model = ToModel(pilot.kinds, pilot.theta, p1);
  const ModelEvaluator pilot_evaluator(pilot_model, tau0);
  Eigen::VectorXd edf2(n);
  std::vector<int64_t> ms;
  for (int j = 0; j < n; ++j) {
    // A Theo1 point's noise is the model's at its effective tau, 0.75 m.
    const double at = theo1[j] ? 0.75 * p1.m[j] : p1.m[j];
    const int alpha = AlphaFromAvarSlope(ModelAvarSlope(pilot_evaluator, at));
    edf2(j) = theo1[j] ? theo1_edf(alpha, j) : FitRowEdf(alpha, rows[j]);
    ms.push_back(rows[j].m);
  }
  const std::vector<double> corr_values = MomentCorrelationMatrix(pilot_model, tau0, ms, theo1);
  const Eigen::MatrixXd corr = Eigen::Map<const Eigen::MatrixXd>(corr_values.data(), n, n);
  const Problem p2 = MakeProblem(rows, theo1, block, tau0, curve.n_phase, edf2, corr, options, &p1);
  std::vector<Candidate> pass1(seen1.size());
  std::transform(seen1.begin(), seen1.end(), pass1.begin(),
                 [](const auto& kv) { return kv.second; });
  std::sort(pass1.begin(), pass1.end(),
            [](const Candidate& a, const Candidate& b) { return a.criterion < b.criterion; });
  std::map<std::string, Candidate> seen2;
  Minima minima2;
  Candidate best2;
  // Pass 1's best kPass2Candidates that are still candidates under the full
  // covariance (an estimate can move a term out of what the points identify).
  for (size_t i = 0, survived = 0;
       i < pass1.size() && static_cast<int>(survived) < kPass2Candidates; ++i) {
    // From each of pass 1's distinct minima of the model, and from each
    // with its scales re-solved under the full covariance (its minimum can
    // lie elsewhere): the best of them.
    Candidate c;
    std::vector<Candidate> starts = {pass1[i]};
    for (const Candidate& m : minima1[NameOf(pass1[i].kinds, pass1[i].theta, p1)]) {
      if (!SameMinimum(m, pass1[i], p1)) starts.push_back(m);
    }
    for (const Candidate& s : starts) {
      Candidate from_s;
      for (const Candidate& e : {Estimate(s.kinds, s.theta, p2),
                                 Estimate(s.kinds, LinearStart(s.kinds, s.theta, p2), p2)}) {
        if (std::isfinite(e.criterion) && e.objective < from_s.objective) from_s = e;
      }
      if (!std::isfinite(from_s.criterion)) continue;
      AddMinimum(&minima2[NameOf(from_s.kinds, from_s.theta, p2)], from_s, p2);
      if (from_s.objective < c.objective) c = from_s;
    }
    if (!std::isfinite(c.criterion)) continue;
    ++survived;
    seen2[NameOf(c.kinds, c.theta, p2)] = c;
    if (c.criterion < best2.criterion) best2 = c;
  }
  if (!std::isfinite(best2.criterion)) {
    return Status::InvalidArgument("noise model fit: no candidate survived the full covariance");
  }
  // The full covariance weighs the points differently (the long taus of a
  // random walk carry less independent information): search on from there.
  std::set<std::string> refined;
  Search(p2, rows, options, &seen2, &best2, &minima2, &refined);
  // The candidates of pass 2. A candidate that is a smaller one plus a term
  // collapsed to nothing (its J the smaller one's to 1e-9) is that smaller
  // model, not a rival: kept, it took Akaike weight twice over and its
  // bootstrap, flat along the dead term, gave sigmas that moved with the
  // input's last bits.
  auto candidates_of_pass2 = [&] {
    std::vector<Candidate> all(seen2.size());
    std::transform(seen2.begin(), seen2.end(), all.begin(),
                   [](const auto& kv) { return kv.second; });
    // Decided on the whole list first (erasing while testing against the
    // list would test against moved-from candidates).
    std::vector<bool> drop(all.size(), false);
    for (size_t i = 0; i < all.size(); ++i) {
      for (const Candidate& d : all) {
        if (CollapsedInto(all[i], d, /*same_size=*/false, 1e-9)) drop[i] = true;
      }
    }
    std::vector<Candidate> kept;
    for (size_t i = 0; i < all.size(); ++i) {
      if (!drop[i]) kept.push_back(std::move(all[i]));
    }
    return kept;
  };
  // A model that fits comes before one that does not: the criterion ranks
  // the adequate candidates, and an inadequate one is selected only when no
  // candidate is adequate. On short curves the small-sample term of AICc
  // (2k(k+1)/(p-k-1): 21 for 6 parameters on 11 points) otherwise chose a
  // model the J test rejects over an adequate one with a parameter more (the
  // real ADIS16405 x accelerometer above 0.64 s: N+B+R+S, p = 1e-4, over
  // N+B+R+GM+S, p = 0.035), and a rejected model's figures are withheld.
  auto adequate = [&](const Candidate& c) {
    return JTestPValue(c.objective, n - ParameterCount(c.kinds)) >= options.adequacy_level;
  };
  auto before = [&](const Candidate& a, const Candidate& b) {
    const bool fa = adequate(a), fb = adequate(b);
    return fa != fb ? fa : a.criterion < b.criterion;
  };
  // The selected model searched as the search's own models are: where the
  // search only estimated it from a start and went on elsewhere (an
  // adequate model a term larger than the inadequate one the criterion
  // preferred), its correlation times and frequencies were never searched
  // over their grids. The search goes on from it (at most twice: each time
  // from a model it has not stood on). On the ADIS16405 z accelerometer
  // from 0.16 s this lowers the selected N+B+K+2S's J from 8.54 to 8.43;
  // on 24 twins of its x accelerometer over every point it removed one of
  // the five twins where a grid of full estimates over pairs of correlation
  // times beat the search (check_pair_search). The other four (B+K+3GM+2S,
  // B+R+3GM+2S: 14 parameters on 17 points, J lower by 0.5-1.1) are reached
  // only by full estimates from those pairs: screening the pairs by the
  // linearized J or by coarse estimates ranked them nowhere near the top.
  std::vector<Candidate> pass2 = candidates_of_pass2();
  for (int round = 0; round < 2; ++round) {
    const Candidate top = *std::min_element(pass2.begin(), pass2.end(), before);
    if (refined.contains(NameOf(top.kinds, top.theta, p2))) break;
    Search(p2, rows, options, &seen2, &top, &minima2, &refined);
    pass2 = candidates_of_pass2();
  }
  // The selected model's other minima of J, where the search found distinct
  // ones, are rivals of their own: where two pairs of lines (or correlation
  // times) fit the octave points nearly as well, the figures that depend on
  // which (the white asymptote of a fast Gauss-Markov term beside lines
  // near Nyquist) are averaged over both and their spread joins the u. On
  // 200 twins of the ADIS16405 z gyro the model's white asymptote took one
  // pair or the other from record to record: z rms 2.3 against its u from
  // one minimum, 1.15 with the others. Only the selected model's: the other
  // candidates' minima changed nothing but 2 of 144 records' rate random
  // walk (1000 simulated white + flicker + RRW records).
  {
    const Candidate top = *std::min_element(pass2.begin(), pass2.end(), before);
    const auto it = minima2.find(NameOf(top.kinds, top.theta, p2));
    int rank = 0;
    for (const Candidate& m : it == minima2.end() ? std::vector<Candidate>{} : it->second) {
      // Not the candidate itself, nor a copy of it or of a model within it
      // (a term collapsed to nothing, its correlation time or frequency
      // free: the same J).
      auto copy_of = [&](const Candidate& d) {
        return CollapsedInto(m, d, /*same_size=*/true, 1e-6);
      };
      if (SameMinimum(m, top, p2) || std::any_of(pass2.begin(), pass2.end(), copy_of)) continue;
      Candidate alt = m;
      alt.minimum_rank = ++rank;
      pass2.push_back(std::move(alt));
    }
  }
  std::sort(pass2.begin(), pass2.end(), before);
  const Candidate& best = pass2.front();
  CompositeFit fit;
  fit.tau0_s = tau0;
  fit.model = ToModel(best.kinds, best.theta, p2);
  fit.points_used = n;
  fit.parameters = ParameterCount(best.kinds);
  fit.objective = best.objective;
  fit.dof = n - fit.parameters;
  fit.p_value = JTestPValue(fit.objective, fit.dof);
  fit.adequate = fit.p_value >= options.adequacy_level;
  fit.criterion = best.criterion;
  if (options.check_pair_search) fit.pair_grid_objective = PairGridObjective(best, p2, rows);
  for (const Candidate& c : pass2) {
    ModelCandidate mc;
    mc.name = NameOf(c.kinds, c.theta, p2);
    if (c.minimum_rank > 0) {
      mc.name += c.minimum_rank == 1 ? " (2nd minimum)" : " (3rd minimum)";
    }
    mc.parameters = ParameterCount(c.kinds);
    mc.objective = c.objective;
    mc.criterion = c.criterion;
    mc.p_value = JTestPValue(c.objective, n - mc.parameters);
    mc.model = ToModel(c.kinds, c.theta, p2);
    fit.candidates.push_back(mc);
  }

  // Uncertainty: a parametric bootstrap in the moments. Each replicate is
  // y* = ln nu(theta_hat) + x, x with the correlations of Sigma and, at every
  // point, the distribution of ln(chi2_nu/nu) - b (a Gaussian copula), refitted
  // with the candidate's model from theta_hat; a sigma is the standard
  // deviation of its quantity over the replicates. Unlike the delta method this
  // keeps the nonlinearity of the figures in the parameters and the skew of
  // short records' moments. Seeded: the same curve gives the same sigmas.
  //
  // Selection uncertainty: the figures and the IEEE 952 term parameters are
  // averaged over the plausible candidates (criterion within kAveragingSpan of
  // the best; Akaike weights w ~ exp(-delta/2)), with the unconditional
  // variance sum w (sigma^2 + (value - mean)^2) (Burnham & Anderson). Where
  // the record cannot tell a flicker floor from a rate random walk, both
  // candidates carry weight and the sigmas say how unsure the split is,
  // instead of one model's confident, biased value.
  const double tau_lo = rows.front().tau_s, tau_hi = rows.back().tau_s;
  const MinimumGrid grid(tau0, tau_lo, tau_hi);
  constexpr int kShared = 8;  // Q, N, B, K, R scales (0 if absent); ARW, minimum, its tau
  auto shared = [&](const CompositeModel& m, std::vector<double>* q) {
    for (TermKind k : kIeeeKinds) {
      double v = 0;
      for (const ModelTerm& t : m.terms) {
        if (t.kind == k) v = t.scale;
      }
      q->push_back(v);
    }
    const Figures f = ComputeFigures(m, grid, options, /*white_region=*/false);
    for (double v : {f.white_asymptote, f.curve_minimum, f.tau_at_minimum}) q->push_back(v);
  };
  auto own = [&](const Eigen::VectorXd& theta) {  // the selected model: its terms first
    const CompositeModel m = ToModel(best.kinds, theta, p2);
    std::vector<double> q;
    for (const ModelTerm& t : m.terms) {
      q.push_back(t.scale);
      if (t.kind == TermKind::kGaussMarkov) q.push_back(t.correlation_time_s);
      if (t.kind == TermKind::kSinusoid) q.push_back(t.frequency_hz);
    }
    shared(m, &q);
    return q;
  };
  const std::vector<double> q_best = own(best.theta);
  // One set of draws for every candidate's bootstrap (the same seed gave each
  // the same draws when each drew its own).
  const Eigen::MatrixXd noise = BootstrapNoise(p2, options.bootstrap_replicates);
  const std::vector<double> sd_best =
      BootstrapSigmas(best, p2, options.bootstrap_replicates, noise, q_best.size(), own);
  const size_t own_count = q_best.size() - kShared;
  size_t qi = 0;
  for (const ModelTerm& t : fit.model.terms) {
    FittedTerm ft;
    ft.term = t;
    ft.scale_sigma = sd_best[qi++];
    if (t.kind == TermKind::kGaussMarkov) ft.correlation_time_sigma_s = sd_best[qi++];
    if (t.kind == TermKind::kSinusoid) ft.frequency_sigma_hz = sd_best[qi++];
    fit.terms.push_back(ft);
  }
  // Model averaging of the shared quantities.
  std::vector<double> mean(kShared, 0.0), second(kShared, 0.0);
  double weight_sum = 0;
  // At most kMaxAveraged models; the selected model's other minima come on
  // top (they do not take the place of another model).
  for (size_t c = 0, models = 0; c < pass2.size() && models < kMaxAveraged; ++c) {
    const double delta = pass2[c].criterion - best.criterion;
    if (delta > kAveragingSpan || adequate(pass2[c]) != adequate(best)) break;
    models += pass2[c].minimum_rank == 0;
    const double w = std::exp(-0.5 * delta);
    std::vector<double> q, sd;
    if (c == 0) {
      q.assign(q_best.begin() + own_count, q_best.end());
      sd.assign(sd_best.begin() + own_count, sd_best.end());
    } else {
      const Candidate& cand = pass2[c];
      auto of = [&](const Eigen::VectorXd& theta) {
        std::vector<double> out;
        shared(ToModel(cand.kinds, theta, p2), &out);
        return out;
      };
      q = of(cand.theta);
      sd = BootstrapSigmas(cand, p2, options.bootstrap_replicates / 2, noise, kShared, of);
    }
    fit.candidates[c].weight = w;
    weight_sum += w;
    for (int i = 0; i < kShared; ++i) {
      mean[i] += w * q[i];
      second[i] += w * (sd[i] * sd[i] + q[i] * q[i]);  // E[x^2] within the candidate
    }
  }
  std::vector<ModelFigure> avg(kShared);
  for (int i = 0; i < kShared; ++i) {
    const double mu = mean[i] / weight_sum;
    avg[i] = {mu, std::sqrt(std::max(0.0, second[i] / weight_sum - mu * mu))};
  }
  for (ModelCandidate& c : fit.candidates) c.weight /= weight_sum;
  // A term the selected model does not have is reported absent (0, no
  // sigma), not as the tiny average of the runners-up that have it: that
  // would be a confident "almost 0" the selection does not support.
  for (int i = 0; i < 5; ++i) {
    fit.ieee_terms[i] = fit.model.CountOf(kIeeeKinds[i]) > 0 ? avg[i] : ModelFigure{0.0, kNaN};
    if (options.absent_term_bounds && fit.model.CountOf(kIeeeKinds[i]) == 0) {
      fit.ieee_terms[i].upper_bound =
          AbsentTermUpperBound(best, kIeeeKinds[i], p2, rows, options.absent_term_bound_delta_j);
    }
  }
  // The rate random walk of a model without flicker noise: where the record
  // cannot resolve the flicker floor, the random walk absorbs it and reads
  // high (simulated white + flicker + stronger RRW: +12 %, mean z +0.7 where
  // the model was N+K). The flicker the data allow at 1 sigma (the profile of
  // J rising by 1) bounds how far K may fall: K is the midpoint of that span,
  // and the span, taken as rectangular (half-width / sqrt 3), joins its u
  // (fit_coverage_bench: 1 / 2 sigma 76.0 / 97.3 % there, where 64.0 / 90.0
  // % without; the half-width itself over-covered, 80.7 % at 1 sigma).
  if (fit.model.CountOf(TermKind::kRandomWalk) > 0 && fit.model.CountOf(TermKind::kFlicker) == 0) {
    const double b = AbsentTermUpperBound(best, TermKind::kFlicker, p2, rows, 1.0);
    if (std::isfinite(b) && b > 0) {
      const Candidate with_b = WithFixedTerm(best, TermKind::kFlicker, p2, b);
      auto k_of = [&](const Eigen::VectorXd& theta) {
        double k2 = 0;
        for (const ModelTerm& t : ToModel(best.kinds, theta, p2).terms) {
          if (t.kind == TermKind::kRandomWalk) k2 += t.scale * t.scale;
        }
        return std::sqrt(k2);
      };
      const double k_best = k_of(best.theta);
      const double half = 0.5 * (k_best - k_of(with_b.theta));
      if (std::isfinite(with_b.criterion) && half > 0 && k_best > 0) {
        // The span as a fraction of the selected model's K, applied to the
        // model-averaged K: candidates without a random walk pull the
        // average below the selected K, and the span in absolute terms took
        // it below 0 (a 2 h FOG record: -0.0044 deg/h/sqrt(h)).
        ModelFigure& k = fit.ieee_terms[3];
        const double span = half * k.value / k_best;
        k.value -= span;
        k.sigma = std::hypot(k.sigma, span / std::sqrt(3.0));
        fit.flicker_for_rate_random_walk = b;
        fit.rate_random_walk_half_span = span;
      }
    }
  }
  const Figures f0 = ComputeFigures(fit.model, grid, options);
  fit.white_asymptote = avg[5];
  fit.curve_minimum = avg[6];
  fit.tau_at_minimum = avg[7];
  fit.rate_random_walk = fit.ieee_terms[3];
  fit.has_white_region = f0.has_white_region;
  fit.minimum_at_edge = f0.minimum_at_edge;
  // A model without the rate random walk whose curve has not turned up by the
  // longest analysed tau: its minimum there reads low against a truth whose
  // random walk the record cannot resolve (mean z -0.5 to -1.7 simulated).
  // The random walk the data allow at 1 sigma (the profile of J rising by 1)
  // bounds how far the minimum may rise: the value is the midpoint of that
  // span and its half-width joins the u in quadrature (fit_coverage_bench:
  // 73.5 / 98.0 % at 1 / 2 sigma on white + flicker + RRW records, where 67.0
  // / 92.0 % without).
  if (f0.minimum_at_edge && fit.model.CountOf(TermKind::kRandomWalk) == 0) {
    const double k = AbsentTermUpperBound(best, TermKind::kRandomWalk, p2, rows, 1.0);
    if (std::isfinite(k) && k > 0) {
      CompositeModel with_k = fit.model;
      with_k.terms.push_back(ModelTerm{TermKind::kRandomWalk, k});
      const double half =
          0.5 * (ComputeFigures(with_k, grid, options).curve_minimum - f0.curve_minimum);
      if (half > 0) {
        fit.edge_rate_random_walk = k;
        fit.edge_half_span = half;
        fit.curve_minimum.value += half;
        fit.curve_minimum.sigma = std::hypot(fit.curve_minimum.sigma, half);
      }
    }
  }
  fit.bias_instability_ieee = {fit.curve_minimum.value / kBiasInstabilityFactor,
                               fit.curve_minimum.sigma / kBiasInstabilityFactor};

  const Eigen::VectorXd model_log = LogModel(fit.model, p2);
  for (int j = 0; j < n; ++j) {
    GmwmPoint pt;
    pt.m = rows[j].m;
    pt.tau_s = rows[j].tau_s;
    pt.avar = rows[j].avar;
    pt.model_avar = std::exp(model_log(j));
    pt.edf = edf2(j);
    pt.z = (p2.y(j) - model_log(j)) / std::sqrt(p2.sigma(j, j));
    pt.theo1 = theo1[j] != 0;
    fit.points.push_back(pt);
  }
  return fit;
}

}  // namespace imuqual::allan
