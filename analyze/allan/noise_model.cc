#include "analyze/allan/noise_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <random>
#include <string>
#include <tuple>

#include "analyze/allan/bounded_memo.h"
#include "analyze/allan/confidence.h"
#include "analyze/allan/fit_rows.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

constexpr int kTerms = 5;
constexpr double kBiasAvarFactor = 2.0 * std::numbers::ln2 / std::numbers::pi;  // 2 ln2/pi

// Local slope of ln sigma against ln tau at each point: to both neighbours
// (central), or to the one neighbour at the ends. NaN with one point.
std::vector<double> LocalDevSlopes(const std::vector<double>& tau, const std::vector<double>& dev) {
  const size_t n = tau.size();
  std::vector<double> slope(n, kNaN);
  if (n < 2) return slope;
  for (size_t i = 0; i < n; ++i) {
    const size_t a = i == 0 ? 0 : i - 1;
    const size_t b = i + 1 == n ? n - 1 : i + 1;
    slope[i] = std::log(dev[b] / dev[a]) / std::log(tau[b] / tau[a]);
  }
  return slope;
}

struct SubsetSolution {
  unsigned mask = 0;
  std::array<double, kTerms> coef{};  // c_t = coef_t^2, 0 outside the mask
  Eigen::MatrixXd covariance;         // of the active c_t, in mask order
  double ssr = kNaN;
};

// Exact NNLS of min ||W (A c - b)||^2, c >= 0, by enumeration of active sets.
std::optional<SubsetSolution> SolveNnls(const Eigen::MatrixXd& weighted_a,
                                        const Eigen::VectorXd& weighted_b) {
  const int rows = static_cast<int>(weighted_a.rows());
  // Column scaling: the basis spans many decades; unit-norm columns keep the
  // QR well conditioned. c = x / scale.
  Eigen::VectorXd scale(kTerms);
  for (int t = 0; t < kTerms; ++t) scale(t) = weighted_a.col(t).norm();
  std::optional<SubsetSolution> best;
  for (unsigned mask = 1; mask < (1u << kTerms); ++mask) {
    std::vector<int> cols;
    for (int t = 0; t < kTerms; ++t) {
      if (mask & (1u << t)) cols.push_back(t);
    }
    const int k = static_cast<int>(cols.size());
    const bool zero_column =
        std::any_of(cols.begin(), cols.end(), [&](int t) { return !(scale(t) > 0); });
    if (k > rows || zero_column) continue;
    Eigen::MatrixXd a(rows, k);
    for (int i = 0; i < k; ++i) a.col(i) = weighted_a.col(cols[i]) / scale(cols[i]);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
    if (qr.rank() < k) continue;
    const Eigen::VectorXd x = qr.solve(weighted_b);
    if ((x.array() < 0).any()) continue;
    const double ssr = (a * x - weighted_b).squaredNorm();
    if (best.has_value() && !(ssr < best->ssr)) continue;
    SubsetSolution s;
    s.mask = mask;
    s.ssr = ssr;
    // Cov(x) = (a'a)^-1 for unit-variance weighted rows; c = x / scale.
    const Eigen::MatrixXd cov_x = (a.transpose() * a).inverse();
    s.covariance.resize(k, k);
    for (int i = 0; i < k; ++i) {
      s.coef[cols[i]] = x(i) / scale(cols[i]);
      for (int j = 0; j < k; ++j) {
        s.covariance(i, j) = cov_x(i, j) / (scale(cols[i]) * scale(cols[j]));
      }
    }
    best = std::move(s);
  }
  return best;
}

double ModelAvar(const std::array<double, kTerms>& coef, double tau_s) {
  double v = 0;
  for (int t = 0; t < kTerms; ++t) v += coef[t] * NoiseTermAvarBasis(kNoiseTerms[t], tau_s);
  return v;
}

// The term that contributes most to the model at tau_s.
NoiseTerm DominantTerm(const std::array<double, kTerms>& coef, double tau_s) {
  int best = 1;
  double best_v = -1;
  for (int t = 0; t < kTerms; ++t) {
    const double v = coef[t] * NoiseTermAvarBasis(kNoiseTerms[t], tau_s);
    if (v > best_v) {
      best_v = v;
      best = t;
    }
  }
  return kNoiseTerms[best];
}

}  // namespace

std::string_view NoiseTermName(NoiseTerm t) {
  switch (t) {
    case NoiseTerm::kQuantization:
      return "quantization";
    case NoiseTerm::kAngleRandomWalk:
      return "angle_random_walk";
    case NoiseTerm::kBiasInstability:
      return "bias_instability";
    case NoiseTerm::kRateRandomWalk:
      return "rate_random_walk";
    case NoiseTerm::kRateRamp:
      return "rate_ramp";
  }
  return "";
}

double NoiseTermAvarBasis(NoiseTerm t, double tau_s) {
  switch (t) {
    case NoiseTerm::kQuantization:
      return 3.0 / (tau_s * tau_s);
    case NoiseTerm::kAngleRandomWalk:
      return 1.0 / tau_s;
    case NoiseTerm::kBiasInstability:
      return kBiasAvarFactor;
    case NoiseTerm::kRateRandomWalk:
      return tau_s / 3.0;
    case NoiseTerm::kRateRamp:
      return tau_s * tau_s / 2.0;
  }
  return kNaN;
}

int NoiseTermAlpha(NoiseTerm t) {
  switch (t) {
    case NoiseTerm::kQuantization:
      return 2;
    case NoiseTerm::kAngleRandomWalk:
      return 0;
    case NoiseTerm::kBiasInstability:
      return -1;
    case NoiseTerm::kRateRandomWalk:
    case NoiseTerm::kRateRamp:
      return -2;
  }
  return 0;
}

const TermEstimate& NoiseFit::term(NoiseTerm t) const {
  switch (t) {
    case NoiseTerm::kQuantization:
      return q;
    case NoiseTerm::kAngleRandomWalk:
      return n;
    case NoiseTerm::kBiasInstability:
      return b;
    case NoiseTerm::kRateRandomWalk:
      return k;
    case NoiseTerm::kRateRamp:
      return r;
  }
  return n;
}

double NoiseFit::ModelDeviation(double tau_s) const {
  double v = 0;
  for (NoiseTerm t : kNoiseTerms) {
    const TermEstimate& e = term(t);
    if (e.active && std::isfinite(e.value)) v += e.value * e.value * NoiseTermAvarBasis(t, tau_s);
  }
  return std::sqrt(v);
}

Status FitOptions::Validate() const {
  if (irls_passes < 0 || irls_passes > 20) {
    return Status::InvalidArgument("irls_passes must be in [0, 20], got " +
                                   std::to_string(irls_passes));
  }
  return Status::Ok();
}

Result<NoiseFit> FitNoiseModel(const Curve& curve, const FitOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (curve.deviation != Deviation::kOadev && curve.deviation != Deviation::kAdev) {
    return Status::InvalidArgument("noise model fit needs an ADEV or OADEV curve, got " +
                                   std::string(DeviationName(curve.deviation)));
  }
  // 1. Usable points, ascending m, optionally thinned to about one per octave.
  const std::vector<FitRow> rows = UsableFitRows(curve, options.stop, options.thin_to_octaves);
  const int num_rows = static_cast<int>(rows.size());
  if (num_rows < 2) {
    return Status::InvalidArgument("noise model fit needs at least 2 usable curve points, got " +
                                   std::to_string(num_rows));
  }

  NoiseFit fit;
  fit.points.resize(num_rows);
  std::optional<SubsetSolution> solution;
  for (int pass = 0; pass <= options.irls_passes; ++pass) {
    // 2. Weights: w_j = sqrt(nu_j / 2) / ref_j.
    Eigen::MatrixXd a(num_rows, kTerms);
    Eigen::VectorXd b(num_rows);
    for (int j = 0; j < num_rows; ++j) {
      const FitRow& row = rows[j];
      FitPoint& fp = fit.points[j];
      double ref = row.avar;
      if (pass == 0) {
        fp.alpha = AlphaFromAvarSlope(row.local_slope);
        fp.edf = std::isfinite(row.point_edf) && row.point_edf > 0 ? row.point_edf
                                                                   : FitRowEdf(fp.alpha, row);
      } else {
        const double model = ModelAvar(solution->coef, row.tau_s);
        if (model > 0) ref = model;
        fp.alpha = NoiseTermAlpha(DominantTerm(solution->coef, row.tau_s));
        fp.edf = FitRowEdf(fp.alpha, row);
      }
      const double w = std::sqrt(fp.edf / 2.0) / ref;
      for (int t = 0; t < kTerms; ++t) a(j, t) = w * NoiseTermAvarBasis(kNoiseTerms[t], row.tau_s);
      b(j) = w * row.avar;
    }
    // 3.-5.
    std::optional<SubsetSolution> next = SolveNnls(a, b);
    if (!next.has_value()) {
      if (!solution.has_value()) {
        return Status::InvalidArgument("noise model fit: no non-negative solution");
      }
      break;
    }
    solution = std::move(next);
    fit.irls_passes = pass;
  }

  fit.points_used = num_rows;
  fit.weighted_ssr = solution->ssr;
  int active_index = 0;
  for (int t = 0; t < kTerms; ++t) {
    TermEstimate* terms[kTerms] = {&fit.q, &fit.n, &fit.b, &fit.k, &fit.r};
    TermEstimate& e = *terms[t];
    e.active = (solution->mask >> t) & 1u;
    if (!e.active) {
      e.value = 0.0;
      continue;
    }
    const double c = solution->coef[t];
    const double var_c = solution->covariance(active_index, active_index);
    ++active_index;
    e.value = std::sqrt(c);
    // c = coef^2, so sd(coef) = sd(c) / (2 coef).
    e.sigma = std::sqrt(std::max(var_c, 0.0)) / (2.0 * e.value);
  }
  for (int j = 0; j < num_rows; ++j) {
    fit.points[j].m = rows[j].m;
    fit.points[j].tau_s = rows[j].tau_s;
    fit.points[j].avar = rows[j].avar;
    fit.points[j].model_avar = ModelAvar(solution->coef, rows[j].tau_s);
  }
  return fit;
}

namespace {

// The correlations between the overlapping AVAR estimates at averaging
// factors m of a process of one noise term (white noise for the -1/2 line):
// they depend on the factors alone (not on the term's level, tau0 or the
// record's length), so each pair is computed once per process.
std::vector<double> TermAvarCorrelations(TermKind kind, const std::vector<int64_t>& m) {
  static std::mutex mu;
  static std::map<std::tuple<TermKind, int64_t, int64_t>, double> known;
  const size_t n = m.size();
  auto key = [&](int64_t a, int64_t b) { return std::tuple{kind, std::min(a, b), std::max(a, b)}; };
  std::vector<double> out(n * n, 1.0);
  std::vector<int64_t> missing;
  {
    std::lock_guard<std::mutex> lock(mu);
    for (size_t j = 0; j < n; ++j) {
      for (size_t k = j + 1; k < n; ++k) {
        if (m[j] == m[k]) continue;
        const auto it = known.find(key(m[j], m[k]));
        if (it == known.end()) {
          missing.push_back(m[j]);
          missing.push_back(m[k]);
        } else {
          out[j * n + k] = out[k * n + j] = it->second;
        }
      }
    }
  }
  if (missing.empty()) return out;
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  CompositeModel model;
  model.terms.push_back({kind, 1.0});
  const std::vector<double> r = AvarCorrelationMatrix(model, 1.0, missing);
  const size_t k = missing.size();
  std::lock_guard<std::mutex> lock(mu);
  for (size_t a = 0; a < k; ++a) {
    for (size_t b = a + 1; b < k; ++b) known[key(missing[a], missing[b])] = r[a * k + b];
  }
  for (size_t j = 0; j < n; ++j) {
    for (size_t q = j + 1; q < n; ++q) {
      if (m[j] != m[q]) out[j * n + q] = out[q * n + j] = known.at(key(m[j], m[q]));
    }
  }
  return out;
}

// Weighted least squares of AVARs y (correlation matrix rho, relative
// variances 2/edf) on the columns of x: weights 1/var with var = fitted^2 x
// 2/edf (three passes from the measured values), the sandwich covariance of
// the coefficients with the points' correlations (a generalised least-squares
// fit would trust the differences of points correlated > 0.9 and, where the
// columns do not describe the curve exactly, land beside it), and the Birge
// ratio sqrt(SSR / E[SSR]) (NaN without a degree of freedom).
struct AvarFit {
  Eigen::VectorXd beta;
  Eigen::MatrixXd cov;
  double birge = kNaN;
};
AvarFit FitAvars(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                 const Eigen::VectorXd& two_over_edf, const Eigen::MatrixXd& rho) {
  const int k = static_cast<int>(y.size()), cols = static_cast<int>(x.cols());
  AvarFit out;
  Eigen::VectorXd fitted = y;
  for (int pass = 0; pass < 3; ++pass) {
    const Eigen::VectorXd sd =
        (fitted.cwiseMax(y.minCoeff() * 1e-3).array().square() * two_over_edf.array()).sqrt();
    const Eigen::VectorXd w = sd.array().square().inverse();
    const Eigen::MatrixXd xtw = x.transpose() * w.asDiagonal();
    const Eigen::MatrixXd bread = (xtw * x).inverse();
    out.beta = bread * (xtw * y);
    fitted = x * out.beta;
    const Eigen::MatrixXd sigma = sd.asDiagonal() * rho * sd.asDiagonal();
    out.cov = bread * (xtw * sigma * xtw.transpose()) * bread;
    if (k > cols) {
      const Eigen::MatrixXd residual_maker = Eigen::MatrixXd::Identity(k, k) - x * bread * xtw;
      const Eigen::VectorXd res = y - fitted;
      const double expected =
          (w.asDiagonal() * residual_maker * sigma * residual_maker.transpose()).trace();
      out.birge = std::sqrt(res.dot(w.asDiagonal() * res) / expected);
    }
  }
  return out;
}

// The -1/2 line's white-noise level from the points in `idx` (ascending tau):
// a weighted least-squares fit of AVAR x tau = N^2 + b/tau + c tau, where
// b/tau takes quantization noise (b > 0) or a band-limiting filter's deficit
// (b < 0: first-order or FIR filtered white noise is q/tau - b'/tau^2 beyond
// the filter's length) and c tau a flicker or Gauss-Markov rise; with fewer
// than five points, or over less than a factor 4 in tau, N^2 alone (a
// weighted mean). Points without an edf are left out. Weights 1/var from the
// fitted line, var = line^2 x 2/edf (Greenhall edf, white FM), FitAvars with
// the white-noise correlations of the points' AVARs; the uncertainty is
// inflated by the Birge ratio when the points scatter more than their errors
// say (a real part's curve is not exactly the three terms).
struct WhiteLineFit {
  double n_squared = kNaN;
  double u_n_squared = kNaN;
  double birge = kNaN;
  int points = 0;
  int terms = 0;
};
WhiteLineFit FitWhiteLine(const std::vector<const CurvePoint*>& pts,
                          const std::vector<size_t>& line, const std::vector<double>& tau,
                          const std::vector<double>& dev, int64_t n_phase) {
  WhiteLineFit out;
  // The points with an edf; a curve without its points' counts at all (a
  // model curve, a table without n) is fitted with equal relative weights
  // and has no uncertainty.
  const int alpha = NoiseTermAlpha(NoiseTerm::kAngleRandomWalk);
  std::vector<size_t> idx;
  std::vector<double> edfs;
  for (size_t i : line) {
    const double edf = PointEdf(*pts[i], n_phase, alpha);
    if (std::isfinite(edf) && edf > 0) {
      idx.push_back(i);
      edfs.push_back(edf);
    }
  }
  const bool have_edf = !idx.empty();
  if (!have_edf) idx = line;
  const int k = static_cast<int>(idx.size());
  if (k == 0) return out;
  const double tau_lo = tau[idx.front()], tau_hi = tau[idx.back()];
  // b/tau and c tau only over a span that can tell them from N^2 (an octave
  // either side): on a short span the three columns nearly fit one another.
  const int cols = k >= 5 && tau_hi >= 4 * tau_lo ? 3 : 1;
  std::vector<int64_t> m(k);
  Eigen::VectorXd y(k), two_over_edf(k);
  Eigen::MatrixXd x(k, cols);
  for (int j = 0; j < k; ++j) {
    const size_t i = idx[j];
    m[j] = pts[i]->m;
    two_over_edf(j) = have_edf ? 2 / edfs[j] : 1.0;
    y(j) = dev[i] * dev[i] * tau[i];
    x(j, 0) = 1;
    if (cols == 3) {
      x(j, 1) = tau_lo / tau[i];  // scaled to [0, 1]: a well-conditioned fit
      x(j, 2) = tau[i] / tau_hi;
    }
  }
  std::vector<double> r;
  if (have_edf) {
    r = TermAvarCorrelations(TermKind::kWhite, m);
  } else {
    r.assign(static_cast<size_t>(k) * k, 0.0);
    for (int j = 0; j < k; ++j) r[static_cast<size_t>(j) * k + j] = 1.0;
  }
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
      rho(r.data(), k, k);
  const AvarFit f = FitAvars(x, y, two_over_edf, rho);
  out.birge = f.birge;
  const Eigen::VectorXd& beta = f.beta;
  const Eigen::MatrixXd& cov = f.cov;
  if (!beta.allFinite() || !(cov(0, 0) >= 0)) return out;
  out.n_squared = beta(0);
  if (have_edf) {
    out.u_n_squared = std::sqrt(cov(0, 0)) * (out.birge > 1 ? out.birge : 1.0);
  } else {
    out.birge = kNaN;
  }
  out.points = k;
  out.terms = cols;
  return out;
}

}  // namespace

SlopeReadoff ReadSlopeLine(const Curve& curve, NoiseTerm term) {
  SlopeReadoff out;
  std::vector<double> tau, dev;
  std::vector<const CurvePoint*> used;
  for (const CurvePoint& p : curve.points) {
    if (std::isfinite(p.dev) && p.dev > 0 && std::isfinite(p.tau_s) && p.tau_s > 0) {
      tau.push_back(p.tau_s);
      dev.push_back(p.dev);
      used.push_back(&p);
    }
  }
  if (tau.empty()) {
    out.upper_bound_only = true;
    return out;
  }
  // Slope s, read-off tau, and the tangent bound min_j sigma_j (tau_read/tau_j)^s
  // (the line of slope s through a point, read at tau_read).
  double slope = 0, tau_read = 1;
  switch (term) {
    case NoiseTerm::kQuantization:
      slope = -1.0;
      tau_read = std::sqrt(3.0);
      break;
    case NoiseTerm::kAngleRandomWalk:
      slope = -0.5;
      tau_read = 1.0;
      break;
    case NoiseTerm::kBiasInstability:
      slope = 0.0;
      break;
    case NoiseTerm::kRateRandomWalk:
      slope = 0.5;
      tau_read = 3.0;
      break;
    case NoiseTerm::kRateRamp:
      slope = 1.0;
      tau_read = std::sqrt(2.0);
      break;
  }
  const std::vector<double> local = LocalDevSlopes(tau, dev);
  // The tangent bound holds for sums of non-negative IEEE 952 terms. A real
  // part's internal filter pulls the shortest taus below the -1/2 line (the
  // curve is flatter there), so points before the first one on the slope do
  // not bound the term.
  size_t first_on_slope = 0;
  while (first_on_slope < tau.size() && std::fabs(local[first_on_slope] - slope) > 0.1) {
    ++first_on_slope;
  }
  if (first_on_slope == tau.size()) first_on_slope = 0;
  double bound = std::numeric_limits<double>::infinity();
  double intercept_sum = 0;
  // The read-off's relative statistical error: the mean over the points on
  // the slope of each point's chi-square relative error 1/sqrt(2 edf), with
  // the Greenhall edf of the term's own noise (the line averages correlated
  // points, so no 1/sqrt(n): a bound for fully correlated errors).
  double rel_error_sum = 0;
  int rel_error_points = 0;
  for (size_t i = 0; i < tau.size(); ++i) {
    if (i >= first_on_slope) bound = std::min(bound, dev[i] * std::pow(tau_read / tau[i], slope));
    if (std::fabs(local[i] - slope) <= 0.1) {
      ++out.points_on_slope;
      intercept_sum += std::log(dev[i]) - slope * std::log(tau[i]);
      const double edf = PointEdf(*used[i], curve.n_phase, NoiseTermAlpha(term));
      if (std::isfinite(edf)) {
        rel_error_sum += 1 / std::sqrt(2 * edf);
        ++rel_error_points;
      }
    }
  }
  if (term == NoiseTerm::kBiasInstability) {
    // B = sigma_min / 0.664: the flat level (2 ln2/pi) B^2 is the minimum.
    out.tangent_bound = bound / kBiasInstabilityFactor;
    out.value = out.tangent_bound;
  } else if (term == NoiseTerm::kAngleRandomWalk) {
    out.tangent_bound = bound;
    // The line's points: on the slope to both neighbours too, so that a
    // point where the curve turns (a filter's flat top beside a steep
    // decimation edge averages to -1/2) is not read as white noise.
    std::vector<size_t> line;
    for (size_t i = 0; i < tau.size(); ++i) {
      auto one_sided = [&](size_t a, size_t b) {
        return std::fabs(std::log(dev[b] / dev[a]) / std::log(tau[b] / tau[a]) - slope) <= 0.2;
      };
      if (std::fabs(local[i] - slope) <= 0.1 && (i == 0 || one_sided(i - 1, i)) &&
          (i + 1 == tau.size() || one_sided(i, i + 1))) {
        line.push_back(i);
      }
    }
    const WhiteLineFit fit = FitWhiteLine(used, line, tau, dev, curve.n_phase);
    out.points_in_fit = fit.points;
    out.line_terms = fit.terms;
    out.birge_ratio = fit.birge;
    if (fit.n_squared > 0) {
      out.value = std::sqrt(fit.n_squared);
      out.uncertainty = fit.u_n_squared / (2 * out.value);
    } else {
      out.value = kNaN;  // no white-noise level in the line: the tangent bound only
    }
  } else {
    out.tangent_bound = bound;
    if (out.points_on_slope > 0) {
      const double c = intercept_sum / out.points_on_slope;
      // No non-negative model lies above a tangent line, so cap the read-off.
      out.value = std::min(std::exp(c + slope * std::log(tau_read)), bound);
      if (rel_error_points == out.points_on_slope) {
        out.uncertainty = out.value * rel_error_sum / rel_error_points;
      }
    }
  }
  if (out.points_on_slope == 0 || !std::isfinite(out.value)) {
    out.value = out.tangent_bound;
    out.uncertainty = kNaN;
    out.upper_bound_only = true;
  }
  return out;
}

namespace {

// The gap-free record that gives the point's valid terms, capped at the
// record.
int64_t PointPhaseCount(const CurvePoint& p, int64_t curve_n_phase) {
  int64_t n_phase = (p.n - 1) * p.stride + 2 * p.m + 1;
  if (curve_n_phase > 0) n_phase = std::min(n_phase, curve_n_phase);
  return n_phase;
}

}  // namespace

double PointEdf(const CurvePoint& p, int64_t curve_n_phase, int alpha) {
  if (p.n < 1 || p.stride < 1 || p.m < 1) return kNaN;
  const std::optional<double> edf =
      GreenhallEdf(alpha, 2, p.m, PointPhaseCount(p, curve_n_phase), static_cast<double>(p.m),
                   static_cast<double>(p.m) / p.stride);
  return edf && *edf > 0 ? *edf : kNaN;
}

double PointMixtureEdf(const CurvePoint& p, int64_t curve_n_phase,
                       std::span<const PowerLawShare> shares) {
  if (p.n < 1 || p.stride < 1 || p.m < 1) return kNaN;
  const std::optional<double> edf = GreenhallMixtureEdf(
      shares, 2, p.m, PointPhaseCount(p, curve_n_phase), static_cast<double>(p.m) / p.stride);
  return edf && *edf > 0 ? *edf : kNaN;
}

std::optional<CurveMinimum> FindCurveMinimum(const Curve& curve) {
  std::optional<CurveMinimum> best;
  for (const CurvePoint& p : curve.points) {
    if (!(std::isfinite(p.dev) && p.dev > 0)) continue;
    if (best.has_value() && !(p.dev < best->dev)) continue;
    CurveMinimum c;
    c.dev = p.dev;
    c.tau_s = p.tau_s;
    c.m = p.m;
    c.bias_instability_ieee = p.dev / kBiasInstabilityFactor;
    best = c;
  }
  return best;
}

namespace {

// The correlations of the AVAR estimates at factors m of white noise,
// flicker and a random walk with AVAR a / tau + b + c tau. They depend on
// the terms' ratios alone, so a / b and c / b are rounded to a quarter of a
// binary order (19 %: the correlations change little over it) and the
// matrix of the rounded model kept (at most 1024, ~8 kB each; computing one
// takes ~20 ms, and a station measures every axis of every unit at each
// look). The value depends only on the arguments, never on what was kept
// before.
std::vector<double> LocalModelCorrelations(double a, double b, double c, double tau0_s,
                                           const std::vector<int64_t>& m) {
  const auto quarter = [&](double v) { return std::lround(4 * std::log2(v / b)); };
  const long qa = quarter(a), qc = quarter(c);
  using Key = std::tuple<long, long, double, std::vector<int64_t>>;
  static BoundedMemo<Key, std::vector<double>> known(1024);
  Key key{qa, qc, tau0_s, m};
  if (const auto hit = known.Find(key)) return *hit;
  CompositeModel local;
  local.terms.push_back({TermKind::kWhite, std::sqrt(std::exp2(qa / 4.0))});
  local.terms.push_back(
      {TermKind::kFlicker, std::sqrt(std::numbers::pi / (2 * std::numbers::ln2))});
  local.terms.push_back({TermKind::kRandomWalk, std::sqrt(3 * std::exp2(qc / 4.0))});
  return *known.Put(std::move(key), AvarCorrelationMatrix(local, tau0_s, m));
}

}  // namespace

double MinimumUncertainty(const Curve& curve, const CurveMinimum& min) {
  if (const std::optional<double> u = MinimumSelectionSpread(curve, min); u.has_value()) return *u;
  return MinimumPointSpread(curve, min);
}

double MinimumPointSpread(const Curve& curve, const CurveMinimum& min) {
  const CurvePoint* at = nullptr;
  for (const CurvePoint& p : curve.points) {
    if (p.m == min.m) at = &p;
  }
  if (at == nullptr) return kNaN;
  const double edf = PointEdf(*at, curve.n_phase, /*alpha=*/-1);
  if (!std::isfinite(edf)) return kNaN;
  // The point's chi-square spread and how far it lies below the points
  // within an octave of it on either side (the flat bottom it was picked
  // from).
  const double statistical = min.dev / std::sqrt(2 * edf);
  double sum = 0;
  int count = 0;
  for (const CurvePoint& p : curve.points) {
    if (p.tau_s >= min.tau_s / 2 && p.tau_s <= min.tau_s * 2 && std::isfinite(p.dev)) {
      sum += p.dev;
      ++count;
    }
  }
  const double selection = count > 0 ? sum / count - min.dev : 0.0;
  return std::hypot(statistical, selection);
}

namespace {

// The points within two octaves of `min` that have an edf, ascending tau.
std::vector<const CurvePoint*> BottomPoints(const Curve& curve, const CurveMinimum& min) {
  std::vector<const CurvePoint*> out;
  for (const CurvePoint& p : curve.points) {
    if (!(std::isfinite(p.dev) && p.dev > 0 && p.tau_s >= min.tau_s / 4 &&
          p.tau_s <= min.tau_s * 4)) {
      continue;
    }
    const double edf = PointEdf(p, curve.n_phase, /*alpha=*/-1);
    if (std::isfinite(edf) && edf > 0) out.push_back(&p);
  }
  return out;
}

// Standard normal deviates from a fixed seed (Box-Muller over a 64-bit
// Mersenne twister, bit-exact everywhere: the spread is a pure function of
// the curve, so re-analysis reproduces it bit for bit).
class FixedNormals {
 public:
  double Next() {
    if (have_) {
      have_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
    const double r = std::sqrt(-2 * std::log(u1));
    spare_ = r * std::sin(2 * std::numbers::pi * u2);
    have_ = true;
    return r * std::cos(2 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 rng_{0x1EEE952};
  double spare_ = 0;
  bool have_ = false;
};

// AVAR = a / tau + b + c tau, a, b, c >= 0, by weighted least squares: AVAR_j
// has variance ~2 AVAR_j^2 / edf_j, and the fit weighs each by its inverse.
// The best of the non-negative fits over every subset of the three lines
// (the unconstrained optimum when it is non-negative; else on a face).
std::optional<BottomShape> FitShape(const std::vector<double>& tau, const std::vector<double>& avar,
                                    const std::vector<double>& edf, double tau_ref,
                                    const std::optional<BottomShape>& weights_from = std::nullopt) {
  const int k = static_cast<int>(tau.size());
  if (k < 3) return std::nullopt;
  std::optional<BottomShape> best;
  double best_chi2 = INFINITY;
  for (int subset = 1; subset < 8; ++subset) {
    std::vector<int> cols;
    for (int c = 0; c < 3; ++c) {
      if (subset & (1 << c)) cols.push_back(c);
    }
    const int n = static_cast<int>(cols.size());
    Eigen::MatrixXd x(k, n);
    Eigen::VectorXd y(k), w(k);
    for (int j = 0; j < k; ++j) {
      // Columns scaled to 1 at the reference tau.
      const double col[3] = {tau_ref / tau[j], 1.0, tau[j] / tau_ref};
      for (int c = 0; c < n; ++c) x(j, c) = col[cols[c]];
      y(j) = avar[j];
      const double expected =
          weights_from ? weights_from->Dev(tau[j]) * weights_from->Dev(tau[j]) : avar[j];
      w(j) = expected > 0 ? edf[j] / (2 * expected * expected) : 0.0;
    }
    const Eigen::MatrixXd xw = w.asDiagonal() * x;
    const Eigen::VectorXd beta = (x.transpose() * xw).ldlt().solve(xw.transpose() * y);
    if (!beta.allFinite() || (beta.array() < 0).any()) continue;
    const double chi2 = (w.array() * (y - x * beta).array().square()).sum();
    if (!(chi2 < best_chi2)) continue;
    best_chi2 = chi2;
    BottomShape b;
    for (int c = 0; c < n; ++c) {
      const double v = beta(c);
      if (cols[c] == 0) b.a = v * tau_ref;
      if (cols[c] == 1) b.b = v;
      if (cols[c] == 2) b.c = v / tau_ref;
    }
    best = b;
  }
  return best;
}

// What a bottom's draws are for: the minimum's value or its tau.
enum class BottomDrawsFor { kValue, kTau };

// Noisy copies of a bottom's points about its shape: each point's AVAR /
// its expectation is chi-square / edf (its cube root nearly normal:
// Wilson-Hilferty).
// - For the minimum's value, the edf is the mixture's (GreenhallMixtureEdf
//   of the shape's white, flicker and random-walk shares: their cross terms
//   in) and the normals are correlated as flicker FM's overlapping AVAR
//   estimates (the noise that makes a bottom flat; a random walk's or the
//   shape's own correlations gave the same figures). The shares' weighted
//   inverse edfs, used before, overstate a point's variance where two terms
//   share it (by Jensen above even fully correlated terms' bound; at a V's
//   vertex 1.2-1.4 times the variance measured over 200 simulated records,
//   which the mixture's edf matches within 10 %), and the steeper bottoms'
//   1-sigma coverage was 78.5 / 79.0 % with them.
// - For the minimum's tau, the edf is the shares' weighted inverse edfs and
//   the correlations the shape's own white + flicker + random walk's: the
//   calibration whose coverage was measured (flicker's correlations made its
//   u wider than measured; with the mixture's edf the 2-sigma coverage of a
//   minimum near the curve's end fell to 92.1 % over 356 records).
// Fixed seed: a pure function.
class BottomDraws {
 public:
  BottomDraws(const Curve& curve, const std::vector<const CurvePoint*>& pts,
              const BottomShape& shape, BottomDrawsFor purpose)
      : k_(static_cast<int>(pts.size())), mu_(k_), h_(k_), z_(k_) {
    if (k_ < 1) return;
    std::vector<int64_t> m(k_);
    for (int j = 0; j < k_; ++j) {
      const double t = pts[j]->tau_s;
      m[j] = pts[j]->m;
      mu_(j) = shape.Dev(t);
      const double share[3] = {shape.a / t, shape.b, shape.c * t};
      double edf = kNaN;
      if (purpose == BottomDrawsFor::kValue) {
        const PowerLawShare shares[3] = {{0, share[0]}, {-1, share[1]}, {-2, share[2]}};
        edf = PointMixtureEdf(*pts[j], curve.n_phase, shares);
      } else {
        double inverse_edf = 0;
        for (int term = 0; term < 3; ++term) {
          if (!(share[term] > 0)) continue;
          const double e = PointEdf(*pts[j], curve.n_phase, -term);
          inverse_edf += share[term] / (mu_(j) * mu_(j)) / (std::isfinite(e) && e > 0 ? e : kNaN);
        }
        edf = 1 / inverse_edf;
      }
      h_(j) = 2 / (9 * edf);
    }
    if (!mu_.allFinite() || !h_.allFinite() || !(mu_.minCoeff() > 0)) return;
    const double floor = 1e-6 * mu_.minCoeff() * mu_.minCoeff();
    const std::vector<double> r =
        purpose == BottomDrawsFor::kTau
            ? LocalModelCorrelations(std::max(shape.a, floor), std::max(shape.b, floor),
                                     std::max(shape.c, floor), curve.tau0_s, m)
            : TermAvarCorrelations(TermKind::kFlicker, m);
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        rho(r.data(), k_, k_);
    // A correlation matrix of many close factors is near singular: a little
    // ridge keeps its factor real (it decorrelates by at most 1e-9).
    Eigen::LDLT<Eigen::MatrixXd> ldlt(rho + 1e-9 * Eigen::MatrixXd::Identity(k_, k_));
    if (ldlt.info() != Eigen::Success) return;
    root_ = ldlt.transpositionsP().transpose() * Eigen::MatrixXd(ldlt.matrixL()) *
            ldlt.vectorD().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    ok_ = true;
  }
  bool ok() const { return ok_; }
  // The shape's deviations at the points.
  const Eigen::VectorXd& expected() const { return mu_; }
  // One draw of the points' deviations into *dev (0 for a draw at or below
  // zero).
  void Draw(Eigen::VectorXd* dev) {
    for (int j = 0; j < k_; ++j) z_(j) = normals_.Next();
    const Eigen::VectorXd g = root_ * z_;
    dev->resize(k_);
    for (int j = 0; j < k_; ++j) {
      const double w = 1 - h_(j) + g(j) * std::sqrt(h_(j));
      (*dev)(j) = w > 0 ? mu_(j) * w * std::sqrt(w) : 0.0;
    }
  }

 private:
  int k_;
  Eigen::VectorXd mu_, h_, z_;
  Eigen::MatrixXd root_;
  FixedNormals normals_;
  bool ok_ = false;
};

constexpr int kBottomDraws = 4000;

}  // namespace

std::optional<double> MinimumSelectionSpread(const Curve& curve, const CurveMinimum& min) {
  const std::optional<BottomShape> shape = FitBottomShape(curve, min);
  if (!shape) return std::nullopt;
  std::vector<const CurvePoint*> pts = BottomPoints(curve, min);
  std::erase_if(pts, [&](const CurvePoint* p) {
    return p->tau_s < min.tau_s / 2 || p->tau_s > min.tau_s * 2;
  });
  const int k = static_cast<int>(pts.size());
  if (k < 1) return std::nullopt;
  // The points within an octave of the minimum (those it is picked from),
  // each about its expectation (the bottom's shape).
  BottomDraws draws(curve, pts, *shape, BottomDrawsFor::kValue);
  if (!draws.ok()) return std::nullopt;
  // The truth's minimum over the points' span: the shape's vertex when it
  // lies inside, else its lower end.
  double truth = draws.expected().minCoeff();
  if (shape->a > 0 && shape->c > 0) {
    const double vertex = std::sqrt(shape->a / shape->c);
    if (vertex > pts.front()->tau_s && vertex < pts.back()->tau_s) {
      truth = std::min(truth, shape->Dev(vertex));
    }
  }
  // The curve's minimum is the least of these correlated points: it
  // scatters and lies low. A record whose bottom reads low gets a smaller u
  // as well as a larger error, so u is read as a fraction of the bottom's
  // level (the mean of these points): u = level x r, with r set so that
  // +-2u covers the truth in 95.45 % of the draws (half that quantile of
  // |least - truth| / level, each draw with its own level). The +-1u
  // interval then covers at least the normal 68.3 %: the tail is heavier.
  Eigen::VectorXd dev;
  std::vector<double> miss;
  miss.reserve(kBottomDraws);
  for (int d = 0; d < kBottomDraws; ++d) {
    draws.Draw(&dev);
    const double least = dev.minCoeff(), level = dev.mean();
    // A draw at or below zero: no reading, as far from the truth as can be.
    miss.push_back(level > 0 ? std::abs(least - truth) / level : INFINITY);
  }
  const auto q = miss.begin() + static_cast<std::ptrdiff_t>(0.9545 * kBottomDraws);
  std::nth_element(miss.begin(), q, miss.end());
  if (!std::isfinite(*q)) return std::nullopt;
  double level = 0;
  for (const CurvePoint* p : pts) level += p->dev / k;
  return level * *q / 2;
}

MinimumTauSpread MinimumTauSelectionSpread(const Curve& curve, const CurveMinimum& min) {
  MinimumTauSpread out;
  if (!curve.points.empty() && min.m == curve.points.back().m) {
    out.why = "the minimum is at the longest tau (not resolved)";
    return out;
  }
  const std::optional<BottomShape> shape = FitBottomShape(curve, min);
  if (!shape) {
    out.why = "fewer than 3 points within 2 octaves of the minimum";
    return out;
  }
  if (!(shape->c > 0)) {
    out.why = "the bottom shows no rising (random-walk) line";
    return out;
  }
  if (!(shape->a > 0)) {
    out.why = "the bottom shows no falling (white-noise) line";
    return out;
  }
  const std::vector<const CurvePoint*> pts = BottomPoints(curve, min);
  BottomDraws draws(curve, pts, *shape, BottomDrawsFor::kTau);
  if (!draws.ok()) {
    out.why = "the bottom's points have no edf";
    return out;
  }
  out.vertex_s = std::sqrt(shape->a / shape->c);
  out.points = static_cast<int>(pts.size());
  out.tau_lo_s = pts.front()->tau_s;
  out.tau_hi_s = pts.back()->tau_s;
  if (out.vertex_s < out.tau_lo_s / 2 || out.vertex_s > out.tau_hi_s * 2) {
    char why[160];
    std::snprintf(why, sizeof why,
                  "the bottom's vertex (%.3g s) lies more than an octave outside its points "
                  "(%.3g-%.3g s): the curve does not show where the minimum is",
                  out.vertex_s, out.tau_lo_s, out.tau_hi_s);
    out.why = why;
    return out;
  }
  // The curve's minimum is at the least of the noisy points: on a flat
  // bottom it wanders far from the vertex, and where the record ends near
  // the vertex it cannot reach beyond the last point. Its error on ln tau
  // against the shape's vertex, over the draws.
  const double ln_vertex = std::log(out.vertex_s);
  Eigen::VectorXd dev;
  std::vector<double> miss;
  miss.reserve(kBottomDraws);
  for (int d = 0; d < kBottomDraws; ++d) {
    draws.Draw(&dev);
    Eigen::Index at = 0;
    dev.minCoeff(&at);
    miss.push_back(std::abs(std::log(pts[at]->tau_s) - ln_vertex));
  }
  // u(ln tau) is the 68.27 % quantile of that error: the wander is near
  // uniform over a flat bottom (half the 95.45 % quantile would under-cover
  // at 1 sigma), and the 2-sigma coverage is measured, not assumed.
  const auto q = miss.begin() + static_cast<std::ptrdiff_t>(0.6827 * kBottomDraws);
  std::nth_element(miss.begin(), q, miss.end());
  out.u_ln_tau = *q;
  out.resolved = out.u_ln_tau > 0 && std::isfinite(out.u_ln_tau);
  if (!out.resolved) out.why = "the drawn minimum never moves from the vertex";
  return out;
}

std::optional<BottomShape> FitBottomShape(const Curve& curve, const CurveMinimum& min) {
  std::vector<double> tau, avar, edf;
  for (const CurvePoint* p : BottomPoints(curve, min)) {
    tau.push_back(p->tau_s);
    avar.push_back(p->dev * p->dev);
    edf.push_back(PointEdf(*p, curve.n_phase, -1));
  }
  // Weighed first by the points themselves, then by the first fit's values
  // (a point that reads low by chance would otherwise weigh more, and flatten
  // the shape).
  const std::optional<BottomShape> first = FitShape(tau, avar, edf, min.tau_s);
  if (!first) return first;
  const std::optional<BottomShape> second = FitShape(tau, avar, edf, min.tau_s, first);
  return second ? second : first;
}

}  // namespace imuqual::allan
