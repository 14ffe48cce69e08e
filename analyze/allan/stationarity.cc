#include "analyze/allan/stationarity.h"

#include <Eigen/Dense>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <string>

#include "analyze/allan/bounded_memo.h"
#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {

namespace {

constexpr double kPi = std::numbers::pi;

// A candidate regressor in d: wa at `a`, and wb at `b` when b >= 0 (indices
// into d, the differenced bin means). A step at the boundary before bin k is
// +1 at k-1; one inside bin k moves that bin's mean by part of it, so a step
// at its middle is +1/2 at k-1 and k (a step between boundaries would
// otherwise read as two steps, each half of it, at the boundaries around
// it); a burst is +1 at k-1 and -1 at k+w-1.
struct Candidate {
  EventKind kind;
  int k = 0;  // first bin after the boundary / the bin holding the step / first bin of the burst
  int w = 0;  // burst length, bins (1 for a step)
  int a = 0;
  int b = -1;
  double wa = 1;
  double wb = -1;
  double offset = 0;  // the event's time: (k + offset) bins
};

// One axis's GLS problem on the present differences. A candidate's z, size
// and sigma are g'P r / sqrt(g'P g - g'P X M X'P g) and its two parts: the
// denominator depends on the nuisances only, so it is worked out once per
// candidate (Prepare) and a record costs its residual v = P r and two
// products per candidate; records drawn from the model come in blocks (one
// triangular solve for the block).
class AxisGls {
 public:
  // mean: the bin means (NaN where a bin is missing); structure[L]: the
  // phase structure function D(L b), L = 0..bins. The differences are those
  // of consecutive present bins, so a level change across missing bins is
  // one of them: d_j = ybar_{q} - ybar_{p} (p, q present, none between) =
  // (x((q+1) b) - x(q b) - x((p+1) b) + x(p b)) / b, and two of them
  // covary as -1/(2 b^2) sum_{u,v} a_u a'_v D(|t_u - t'_v|) over their
  // four phase points each (for adjacent bins the c = (1, -2, 1) form).
  // with_ramp: a rate ramp is a nuisance (its regressor is q - p).
  AxisGls(const std::vector<double>& mean, const std::vector<double>& structure, double b,
          bool with_ramp, const std::vector<Candidate>& candidates)
      : candidates_(&candidates) {
    std::vector<int> present;
    for (size_t i = 0; i < mean.size(); ++i) {
      if (std::isfinite(mean[i])) present.push_back(static_cast<int>(i));
    }
    // Difference j joins present bins present[j] and present[j + 1]; the
    // boundary after bin i (difference index i of adjacent bins) lies in
    // difference index_[i].
    const int n = std::max(0, static_cast<int>(present.size()) - 1);
    from_.assign(present.begin(), present.end() - (present.empty() ? 0 : 1));
    to_.assign(present.begin() + (present.empty() ? 0 : 1), present.end());
    index_.assign(mean.size() > 0 ? mean.size() - 1 : 0, -1);
    for (int j = 0; j < n; ++j) {
      for (int i = from_[j]; i < to_[j]; ++i) index_[i] = j;
    }
    Eigen::MatrixXd c(n, n);
    const auto points = [&](int j, int t[4], double w[4]) {
      t[0] = to_[j] + 1, t[1] = to_[j], t[2] = from_[j] + 1, t[3] = from_[j];
      w[0] = 1, w[1] = -1, w[2] = -1, w[3] = 1;
    };
    for (int i = 0; i < n; ++i) {
      int ti[4], tj[4];
      double wi[4], wj[4];
      points(i, ti, wi);
      for (int j = 0; j <= i; ++j) {
        points(j, tj, wj);
        double sum = 0;
        for (int u = 0; u < 4; ++u) {
          for (int v = 0; v < 4; ++v) sum += wi[u] * wj[v] * structure[std::abs(ti[u] - tj[v])];
        }
        c(i, j) = c(j, i) = -sum / (2 * b * b);
      }
    }
    Eigen::LLT<Eigen::MatrixXd> llt(c);
    ok_ = llt.info() == Eigen::Success;
    if (!ok_) return;
    p_ = llt.solve(Eigen::MatrixXd::Identity(n, n));
    chol_ = llt.matrixL();
    d_.resize(n);
    for (int j = 0; j < n; ++j) d_(j) = mean[to_[j]] - mean[from_[j]];
    if (with_ramp) {
      Eigen::VectorXd span(n);
      for (int j = 0; j < n; ++j) span(j) = to_[j] - from_[j];
      x_.push_back(span);
    }
    Refit();
  }
  // Whether a step candidate lies in missing bins (its difference joins
  // bins with missing ones between): then its boundary is anywhere from the
  // end of bin *from to the start of bin *to, which it sets.
  bool StepInGap(const Candidate& c, int* from, int* to) const {
    const int j = Map(c.a);
    if (c.kind != EventKind::kStep || j < 0 || (c.b >= 0 && Map(c.b) != j)) return false;
    if (to_[j] - from_[j] < 2) return false;
    *from = from_[j];
    *to = to_[j];
    return true;
  }
  bool ok() const { return ok_; }

  // Adds candidate `i` (an accepted event) as a nuisance regressor and
  // refits, unless it is not identifiable here (its difference is missing
  // on this axis, or it repeats the nuisances, e.g. a second event in the
  // same gap): then this axis has no estimate of it (Amplitude: NaN).
  void AddNuisance(size_t i) {
    if (!(prepared_[i].inv_sd > 0)) {
      event_column_.push_back(-1);
      return;
    }
    event_column_.push_back(static_cast<int>(x_.size()));
    x_.push_back(Sparse((*candidates_)[i]));
    Refit();
  }

  // z, size and sigma of candidate `i` given the nuisances, for the record
  // whose residual is v (the data's: Residual()); NaN when the candidate
  // touches a missing difference or is not identifiable.
  double Z(size_t i, const double* v) const {
    const Prepared& t = prepared_[i];
    if (!(t.inv_sd > 0)) return kNaN;
    return (t.wa * v[t.ia] + (t.ib >= 0 ? t.wb * v[t.ib] : 0.0)) * t.inv_sd;
  }
  void Test(size_t i, double* z, double* size, double* sigma) const {
    *z = Z(i, v_.data());
    const double inv_sd = prepared_[i].inv_sd;
    *size = *z * inv_sd;
    *sigma = std::isfinite(*z) ? inv_sd : kNaN;
  }
  const double* Residual() const { return v_.data(); }

  // The residuals of `count` records of the model (differences drawn with
  // its covariance at the present positions, the nuisances fitted to each):
  // column j of the result is record j's v. With d = L e (C = L L'), P d =
  // L^-T e.
  template <typename Rng>
  Eigen::MatrixXd DrawResiduals(Rng& rng, int count) const {
    std::normal_distribution<double> gauss;
    Eigen::MatrixXd e(d_.size(), count);
    for (Eigen::Index j = 0; j < e.cols(); ++j) {
      for (Eigen::Index i = 0; i < e.rows(); ++i) e(i, j) = gauss(rng);
    }
    chol_.transpose().triangularView<Eigen::Upper>().solveInPlace(e);
    if (!x_.empty()) e -= px_ * (m_ * (xmat_.transpose() * e));
    return e;
  }

  // The joint estimate of accepted event j's amplitude and its 1-sigma.
  void Amplitude(size_t j, double* value, double* sigma) const {
    const int i = event_column_[j];
    *value = *sigma = kNaN;
    if (i < 0) return;
    *value = beta_(i);
    *sigma = std::sqrt(m_(i, i));
  }

 private:
  struct Prepared {
    int ia = -1, ib = -1;
    double wa = 0, wb = 0;
    double inv_sd = kNaN;  // 1 / sqrt(g'P g - g'P X M X'P g)
  };
  int Map(int i) const { return i >= 0 && i < static_cast<int>(index_.size()) ? index_[i] : -1; }
  Eigen::VectorXd Sparse(const Candidate& c) const {
    Eigen::VectorXd g = Eigen::VectorXd::Zero(d_.size());
    if (Map(c.a) >= 0) g(Map(c.a)) += c.wa;
    if (c.b >= 0 && Map(c.b) >= 0) g(Map(c.b)) += c.wb;
    return g;
  }
  void Refit() {
    const int n = static_cast<int>(d_.size()), q = static_cast<int>(x_.size());
    xmat_.resize(n, q);
    for (int j = 0; j < q; ++j) xmat_.col(j) = x_[j];
    px_ = p_ * xmat_;
    if (q == 0) {
      m_ = Eigen::MatrixXd(0, 0);
      beta_ = Eigen::VectorXd(0);
      v_ = p_ * d_;
    } else {
      m_ = (xmat_.transpose() * px_).ldlt().solve(Eigen::MatrixXd::Identity(q, q));
      beta_ = m_ * (px_.transpose() * d_);
      v_ = p_ * (d_ - xmat_ * beta_);
    }
    Prepare();
  }
  // Each candidate's denominator under the present nuisances.
  void Prepare() {
    const int q = static_cast<int>(x_.size());
    prepared_.assign(candidates_->size(), Prepared{});
    Eigen::VectorXd gpx(q);
    for (size_t i = 0; i < candidates_->size(); ++i) {
      const Candidate& c = (*candidates_)[i];
      const int ia = Map(c.a), ib = c.b >= 0 ? Map(c.b) : -2;
      if (ia < 0 || ib == -1) continue;
      double gpg = c.wa * c.wa * p_(ia, ia);
      // Without nuisances px_ has no columns (and no storage: a row of it
      // would offset a null pointer), and gpx is not used.
      if (q > 0) gpx = c.wa * px_.row(ia).transpose();
      if (ib >= 0) {
        gpg += c.wb * c.wb * p_(ib, ib) + 2 * c.wa * c.wb * p_(ia, ib);
        if (q > 0) gpx += c.wb * px_.row(ib).transpose();
      }
      const double den2 = q == 0 ? gpg : gpg - gpx.dot(m_ * gpx);
      if (!(den2 > 1e-12 * gpg)) continue;
      prepared_[i] = {ia, ib >= 0 ? ib : -1, c.wa, c.wb, 1 / std::sqrt(den2)};
    }
  }

  const std::vector<Candidate>* candidates_;
  bool ok_ = false;
  std::vector<int> event_column_;  // per accepted event: its column of X, -1 for none
  Eigen::MatrixXd chol_;
  std::vector<int> from_, to_, index_;
  Eigen::MatrixXd p_, px_, m_, xmat_;
  Eigen::VectorXd d_, beta_, v_;
  std::vector<Eigen::VectorXd> x_;
  std::vector<Prepared> prepared_;
};

// The smallest p-values of the records drawn to calibrate a scan, by what
// they depend on (models, bins, missing bins, draws), and the noise-level
// scan's null distributions by bin count, for the process.
BoundedMemo<std::string, std::vector<double>>& Calibrations() {
  static BoundedMemo<std::string, std::vector<double>> memo(32);
  return memo;
}

double TwoSidedNormal(double z) { return std::erfc(std::fabs(z) / std::numbers::sqrt2); }

}  // namespace

std::string_view EventKindName(EventKind kind) {
  return kind == EventKind::kStep ? "step" : "burst";
}

Status StationarityOptions::Validate() const {
  if (!(bin_s >= 0) || !std::isfinite(bin_s)) {
    return Status::InvalidArgument("stationarity bin_s must be >= 0 (0: automatic)");
  }
  if (min_bins < 16) return Status::InvalidArgument("stationarity min_bins must be >= 16");
  if (!(false_alarm > 0 && false_alarm < 0.5)) {
    return Status::InvalidArgument("stationarity false_alarm must be in (0, 0.5)");
  }
  if (max_events < 1) return Status::InvalidArgument("stationarity max_events must be >= 1");
  if (passes < 1) return Status::InvalidArgument("stationarity passes must be >= 1");
  return Status::Ok();
}

std::vector<double> BinMeans(std::span<const double> rate, int64_t bin_samples, int bins) {
  std::vector<double> mean(static_cast<size_t>(std::max(bins, 0)), kNaN);
  for (int bin = 0; bin < bins; ++bin) {
    double sum = 0;
    int64_t count = 0;
    for (int64_t i = bin * bin_samples;
         i < (bin + 1) * bin_samples && i < static_cast<int64_t>(rate.size()); ++i) {
      const double v = rate[static_cast<size_t>(i)];
      if (std::isfinite(v)) {
        sum += v;
        ++count;
      }
    }
    if (2 * count >= bin_samples) mean[static_cast<size_t>(bin)] = sum / static_cast<double>(count);
  }
  return mean;
}

int BinsWithData(std::span<const double> means) {
  return static_cast<int>(
      std::count_if(means.begin(), means.end(), [](double v) { return std::isfinite(v); }));
}

BinAccumulator::BinAccumulator(int64_t base_samples) : base_(std::max<int64_t>(base_samples, 1)) {}

void BinAccumulator::Append(std::span<const float> values, std::span<const uint8_t> invalid) {
  // Span by span: the samples up to the end of the present base bin.
  size_t i = 0;
  while (i < values.size()) {
    const size_t bin = static_cast<size_t>(samples_ / base_);
    if (bin >= sum_.size()) {
      sum_.resize(bin + 1, 0);
      valid_.resize(bin + 1, 0);
      square_.resize(bin + 1, 0);
      diffs_.resize(bin + 1, 0);
    }
    const size_t end = std::min(values.size(), i + static_cast<size_t>(base_ - samples_ % base_));
    double sum = 0, square = 0;
    int64_t valid = 0, diffs = 0;
    samples_ += static_cast<int64_t>(end - i);
    for (; i < end; ++i) {
      if (!(i < invalid.size() && invalid[i]) && std::isfinite(values[i])) {
        const double v = values[i];
        sum += v;
        ++valid;
        if (has_last_) {
          square += (v - last_) * (v - last_);
          ++diffs;
        }
        has_last_ = true;
        last_ = v;
      } else {
        has_last_ = false;
      }
    }
    sum_[bin] += sum;
    valid_[bin] += valid;
    square_[bin] += square;
    diffs_[bin] += diffs;
    if (sum_.size() > static_cast<size_t>(kMaxBaseBins)) Merge();
  }
}

void BinAccumulator::AppendMissing(int64_t count) {
  if (count <= 0) return;
  samples_ += count;
  has_last_ = false;
  const size_t bins = static_cast<size_t>((samples_ + base_ - 1) / base_);
  sum_.resize(bins, 0);
  valid_.resize(bins, 0);
  square_.resize(bins, 0);
  diffs_.resize(bins, 0);
  while (sum_.size() > static_cast<size_t>(kMaxBaseBins)) Merge();
}

void BinAccumulator::Merge() {
  const size_t half = (sum_.size() + 1) / 2;
  const auto merge = [half](auto& v) {
    for (size_t i = 0; i < half; ++i) {
      v[i] = v[2 * i] + (2 * i + 1 < v.size() ? v[2 * i + 1] : 0);
    }
    v.resize(half);
  };
  merge(sum_);
  merge(valid_);
  merge(square_);
  merge(diffs_);
  base_ *= 2;
}

int64_t BinAccumulator::BaseBinsPer(int64_t bin_samples) const {
  return std::max<int64_t>(
      1, std::llround(static_cast<double>(bin_samples) / static_cast<double>(base_)));
}

std::vector<double> BinAccumulator::Pooled(const std::vector<double>& num,
                                           const std::vector<int64_t>& den, int64_t per) const {
  const int64_t bins = samples_ / (per * base_);
  std::vector<double> out(static_cast<size_t>(bins), kNaN);
  for (int64_t k = 0; k < bins; ++k) {
    double sum = 0;
    int64_t count = 0;
    for (int64_t j = k * per; j < (k + 1) * per; ++j) {
      sum += num[static_cast<size_t>(j)];
      count += den[static_cast<size_t>(j)];
    }
    if (2 * count >= per * base_) out[static_cast<size_t>(k)] = sum / static_cast<double>(count);
  }
  return out;
}

std::vector<double> BinAccumulator::Means(int64_t* bin_samples) const {
  const int64_t per = BaseBinsPer(*bin_samples);
  *bin_samples = per * base_;
  return Pooled(sum_, valid_, per);
}

std::vector<double> BinAccumulator::MeanSquareDifferences(int64_t bin_samples) const {
  return Pooled(square_, diffs_, BaseBinsPer(bin_samples));
}

PhaseRecord BinAccumulator::MeansPhase(double tau0_s, int64_t begin, int64_t end) const {
  const int64_t first = (std::max<int64_t>(begin, 0) + base_ - 1) / base_;
  const int64_t last = std::min(end, samples_) / base_;  // whole bins before it
  std::vector<double> means;
  std::vector<uint8_t> invalid;
  for (int64_t k = first; k < last; ++k) {
    const size_t i = static_cast<size_t>(k);
    const bool whole = valid_[i] == base_;
    means.push_back(whole ? sum_[i] / static_cast<double>(base_) : kNaN);
    invalid.push_back(whole ? 0 : 1);
  }
  return PhaseFromRate(std::span<const double>(means), tau0_s * static_cast<double>(base_),
                       invalid);
}

std::vector<double> BinMeanSquareDifferences(std::span<const double> rate, int64_t bin_samples,
                                             int bins) {
  std::vector<double> out(static_cast<size_t>(std::max(bins, 0)), kNaN);
  for (int bin = 0; bin < bins; ++bin) {
    double square = 0;
    int64_t diffs = 0;
    for (int64_t i = std::max<int64_t>(1, bin * bin_samples);
         i < (bin + 1) * bin_samples && i < static_cast<int64_t>(rate.size()); ++i) {
      const double a = rate[static_cast<size_t>(i - 1)], b = rate[static_cast<size_t>(i)];
      if (std::isfinite(a) && std::isfinite(b)) {
        square += (b - a) * (b - a);
        ++diffs;
      }
    }
    if (2 * diffs >= bin_samples)
      out[static_cast<size_t>(bin)] = square / static_cast<double>(diffs);
  }
  return out;
}

namespace {
// The CUSUM statistic of x (above), its boundary and s: max_k |S_k| / (s
// sqrt(n)), s^2 from successive differences; the statistic NaN when s is 0.
struct Cusum {
  double statistic = kNaN;
  int k = 0;  // the boundary of the largest |S_k| (0: none)
  double s = kNaN;
};
Cusum CusumOf(const std::vector<double>& x) {
  Cusum out;
  const int n = static_cast<int>(x.size());
  double mean = 0;
  for (double v : x) mean += v;
  mean /= n;
  double ss = 0;
  for (int i = 0; i + 1 < n; ++i) ss += (x[i + 1] - x[i]) * (x[i + 1] - x[i]);
  out.s = std::sqrt(ss / (2.0 * (n - 1)));
  if (!(out.s > 0)) return out;
  double cusum = 0, best = 0;
  for (int k = 1; k < n; ++k) {
    cusum += x[k - 1] - mean;
    if (std::fabs(cusum) > best) {
      best = std::fabs(cusum);
      out.k = k;
    }
  }
  out.statistic = best / (out.s * std::sqrt(static_cast<double>(n)));
  return out;
}

// The statistic's null distribution for n independent Gaussian x, drawn
// (sorted), cached for the process with the scans' calibrations.
std::shared_ptr<const std::vector<double>> CusumNull(int n) {
  const std::string key = "noise level null|" + std::to_string(n);
  if (auto cached = Calibrations().Find(key)) return cached;
  std::vector<double> drawn(kNoiseLevelDraws);
  std::mt19937_64 rng(0x5eedc05u + static_cast<uint64_t>(n));
  std::normal_distribution<double> gauss;
  std::vector<double> x(n);
  for (double& t : drawn) {
    for (double& v : x) v = gauss(rng);
    t = CusumOf(x).statistic;
  }
  std::sort(drawn.begin(), drawn.end());
  return Calibrations().Put(key, std::move(drawn));
}
}  // namespace

Result<NoiseLevelChange> ScanNoiseLevel(std::span<const double> mean_square, double bin_s,
                                        double false_alarm, double tolerance, int min_bins) {
  if (!(false_alarm > 0 && false_alarm < 0.5)) {
    return Status::InvalidArgument("noise level scan: false_alarm must be in (0, 0.5)");
  }
  if (!(tolerance >= 0) || !std::isfinite(tolerance)) {
    return Status::InvalidArgument("noise level scan: the tolerance must be >= 0");
  }
  if (!(bin_s > 0) || !std::isfinite(bin_s)) {
    return Status::InvalidArgument("noise level scan: bin_s must be positive");
  }
  NoiseLevelChange out;
  // A bin whose successive samples never differ (a frozen or stuck output)
  // is the largest change there is: it reads at a millionth of the least
  // power of the others (an amplitude a thousandth), not left out.
  double least = std::numeric_limits<double>::infinity();
  int frozen = 0;
  for (double v : mean_square) {
    if (std::isfinite(v) && v > 0) least = std::min(least, v);
    if (v == 0) ++frozen;
  }
  std::vector<double> x;
  std::vector<int> at;
  for (size_t i = 0; i < mean_square.size(); ++i) {
    const double v = mean_square[i];
    if (!std::isfinite(v) || v < 0 || (v == 0 && !std::isfinite(least))) continue;
    x.push_back(std::log(v > 0 ? v : 1e-6 * least));
    at.push_back(static_cast<int>(i));
  }
  const int n = static_cast<int>(x.size());
  out.bins = n;
  if (frozen > 0 && std::isfinite(least)) {
    out.note = std::to_string(frozen) + (frozen == 1 ? " bin" : " bins") +
               " without a difference between successive samples (a frozen output), read at a "
               "thousandth of the least amplitude of the others";
  }
  if (n < std::max(min_bins, 4)) {
    out.note = "too few bins with a noise level to scan (" + std::to_string(n) + ", " +
               std::to_string(std::max(min_bins, 4)) + " needed)";
    return out;
  }
  const Cusum cusum = CusumOf(x);
  out.statistic = cusum.statistic;
  if (!std::isfinite(out.statistic)) {
    out.note = "the noise level does not vary from bin to bin (quantized to one value?)";
    return out;
  }
  out.scanned = true;
  // Held while read: another scan may empty the cache meanwhile.
  const std::shared_ptr<const std::vector<double>> null = CusumNull(n);
  const auto above = null->end() - std::lower_bound(null->begin(), null->end(), out.statistic);
  out.p = static_cast<double>(1 + above) / static_cast<double>(null->size() + 1);
  const int k_best = cusum.k;
  if (k_best == 0) return out;
  double before = 0, after = 0;
  for (int i = 0; i < n; ++i) (i < k_best ? before : after) += x[i];
  before /= k_best;
  after /= n - k_best;
  const double log_ratio = (after - before) / 2;
  out.ratio = std::exp(log_ratio);
  out.ratio_sigma = out.ratio * cusum.s * std::sqrt(1.0 / k_best + 1.0 / (n - k_best)) / 2;
  out.time_s = at[k_best] * bin_s;
  out.significant = out.p < false_alarm;
  out.beyond_tolerance = std::fabs(log_ratio) > std::log1p(tolerance);
  return out;
}

double PhaseStructureFunction(const CompositeModel& model, double tau0_s, double s) {
  if (!(s > 0)) return 0;
  double d = 0;
  for (const ModelTerm& t : model.terms) {
    const double v = t.scale * t.scale;
    switch (t.kind) {
      case TermKind::kQuantization:
        d += 2 * v;
        break;
      case TermKind::kWhite:
        d += v * s;
        break;
      case TermKind::kFlicker:
        d += -(v / kPi) * s * s * std::log(s);
        break;
      case TermKind::kRandomWalk:
        d += -(v / 6) * s * s * s;
        break;
      case TermKind::kDrift:  // deterministic: the constant of d
        break;
      case TermKind::kGaussMarkov: {
        const double big_t = t.correlation_time_s;
        const double x = tau0_s / big_t;
        // sigma^2 tau0 (1 + phi) / (1 - phi) = sigma^2 tau0 / tanh(x / 2).
        const double white = v * tau0_s / std::tanh(x / 2);
        d += white * (s - big_t * (-std::expm1(-s / big_t)));
        break;
      }
      case TermKind::kSinusoid: {
        const double w = 2 * kPi * t.frequency_hz;
        // 1 - cos(w s) = 2 sin^2(w s / 2), without cancellation.
        const double h = std::sin(w * s / 2);
        d += v * 2 * h * h / (w * w);
        break;
      }
    }
  }
  return d;
}

Result<StationarityScan> ScanStationarity(const std::vector<std::span<const double>>& axes,
                                          const std::vector<CompositeModel>& models, double tau0_s,
                                          const StationarityOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (axes.empty()) return Status::InvalidArgument("stationarity scan needs at least one axis");
  if (models.size() != axes.size()) {
    return Status::InvalidArgument("stationarity scan needs one noise model per axis");
  }
  if (!(tau0_s > 0) || !std::isfinite(tau0_s)) {
    return Status::InvalidArgument("stationarity scan needs a positive sample interval");
  }
  const size_t n = axes.front().size();
  for (const auto& a : axes) {
    if (a.size() != n) {
      return Status::InvalidArgument("stationarity scan: the axes' records differ in length");
    }
  }
  const double length_s = static_cast<double>(n) * tau0_s;
  const int64_t bin_samples = std::max<int64_t>(
      1, std::llround((options.bin_s > 0 ? options.bin_s : length_s / 300.0) / tau0_s));
  const double b = static_cast<double>(bin_samples) * tau0_s;
  const int bins = static_cast<int>(static_cast<int64_t>(n) / bin_samples);
  std::vector<std::vector<double>> means;
  for (const auto& a : axes) means.push_back(BinMeans(a, bin_samples, bins));
  return ScanBinMeans(means, models, tau0_s, b, options);
}

Result<StationarityScan> ScanBinMeans(const std::vector<std::vector<double>>& means,
                                      const std::vector<CompositeModel>& models, double tau0_s,
                                      double bin_s, const StationarityOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  if (means.empty()) return Status::InvalidArgument("stationarity scan needs at least one axis");
  if (models.size() != means.size()) {
    return Status::InvalidArgument("stationarity scan needs one noise model per axis");
  }
  if (!(tau0_s > 0) || !std::isfinite(tau0_s) || !(bin_s >= tau0_s) || !std::isfinite(bin_s)) {
    return Status::InvalidArgument(
        "stationarity scan needs a positive sample interval and bins of at least one sample");
  }
  for (const auto& m : means) {
    if (m.size() != means.front().size()) {
      return Status::InvalidArgument("stationarity scan: the axes' records differ in length");
    }
  }
  const int num_axes = static_cast<int>(means.size());
  StationarityScan scan;
  scan.false_alarm = options.false_alarm;
  const double b = bin_s;
  scan.bin_s = b;
  const int bins = static_cast<int>(means.front().size());
  scan.bins = bins;
  if (bins > kMaxScanBins) {
    scan.note = "too many bins for a stationarity scan (" + std::to_string(bins) + " of " +
                std::to_string(b) + " s, at most " + std::to_string(kMaxScanBins) +
                "): take longer bins";
    return scan;
  }
  if (bins < options.min_bins) {
    char text[160];
    std::snprintf(text, sizeof text,
                  "record too short for a stationarity scan (%d bins of %g s, %d needed)", bins, b,
                  options.min_bins);
    scan.note = text;
    return scan;
  }
  // Each axis needs as many bins with data: an axis missing most of its
  // record would give the joint test nothing at most candidates.
  for (int a = 0; a < num_axes; ++a) {
    const int present = BinsWithData(means[a]);
    if (present < options.min_bins) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "axis %d has data in %d of its %d bins of %g s (%d needed for a stationarity "
                    "scan)",
                    a + 1, present, bins, b, options.min_bins);
      scan.note = text;
      return scan;
    }
  }

  // The candidates: every boundary, bursts of 1, 2, 4, ... bins up to a
  // ninth of the record (the longest tau a fitted model has seen).
  std::vector<Candidate> candidates;
  for (int k = 1; k < bins; ++k) candidates.push_back({EventKind::kStep, k, 1, k - 1, -1});
  for (int k = 1; k + 1 < bins; ++k) {
    candidates.push_back({EventKind::kStep, k, 1, k - 1, k, 0.5, 0.5, 0.5});
  }
  for (int w = 1; 9 * w <= bins; w *= 2) {
    for (int k = 1; k + w < bins; ++k) {
      candidates.push_back({EventKind::kBurst, k, w, k - 1, k + w - 1});
    }
  }
  scan.tests = static_cast<int>(candidates.size());

  // Per axis: the differences of consecutive present bin means and the GLS
  // problem.
  std::vector<AxisGls> gls;
  for (int a = 0; a < num_axes; ++a) {
    std::vector<double> structure(bins + 1);
    for (int lag = 0; lag <= bins; ++lag) {
      structure[lag] = PhaseStructureFunction(models[a], tau0_s, lag * b);
    }
    gls.emplace_back(means[a], structure, b, models[a].CountOf(TermKind::kDrift) > 0, candidates);
    if (!gls.back().ok()) {
      return Status::InvalidArgument("stationarity scan: the noise model " + models[a].Name() +
                                     " of axis " + std::to_string(a + 1) +
                                     " gives no positive definite covariance at bins of " +
                                     std::to_string(b) + " s");
    }
  }
  scan.scanned = true;

  // The strongest candidate of each family: the largest |z| of any axis,
  // and (more than one axis) the joint test at one candidate: the sum of z^2
  // over the axes with data there, chi-square with as many degrees of
  // freedom as those axes (an axis missing part of its record leaves the
  // others' joint test standing at the candidates it misses). The smallest
  // joint p is the smallest over the axis counts of each count's largest sum.
  std::vector<boost::math::chi_squared> joint;
  for (int k = 1; k <= num_axes; ++k) joint.emplace_back(k);
  constexpr size_t kNone = static_cast<size_t>(-1);
  struct Strongest {
    double axis_z = 0;
    size_t axis_candidate = kNone;
    int axis = -1;
    std::vector<double> joint_sum;        // per count of axes with data (2..)
    std::vector<size_t> joint_candidate;  // its candidate
    double AxisP() const { return axis_candidate != kNone ? TwoSidedNormal(axis_z) : 1.0; }
    // The smallest joint p and its candidate.
    double JointP(const std::vector<boost::math::chi_squared>& dist, size_t* at) const {
      double p = 1.0;
      *at = kNone;
      for (size_t k = 2; k < joint_candidate.size(); ++k) {
        if (joint_candidate[k] == kNone) continue;
        const double q = boost::math::cdf(boost::math::complement(dist[k - 1], joint_sum[k]));
        if (*at == kNone || q < p) {
          p = q;
          *at = joint_candidate[k];
        }
      }
      return p;
    }
  };
  // v[a]: axis a's residual (the data's, or a drawn record's).
  const auto strongest = [&](const std::vector<const double*>& v) {
    Strongest s;
    s.joint_sum.assign(num_axes + 1, 0.0);
    s.joint_candidate.assign(num_axes + 1, kNone);
    for (size_t c = 0; c < candidates.size(); ++c) {
      int present = 0;
      double sum = 0;
      for (int a = 0; a < num_axes; ++a) {
        const double z = gls[a].Z(c, v[a]);
        if (!std::isfinite(z)) continue;
        ++present;
        sum += z * z;
        if (std::fabs(z) > s.axis_z) {
          s.axis_z = std::fabs(z);
          s.axis_candidate = c;
          s.axis = a;
        }
      }
      if (present > 1 && sum > s.joint_sum[present]) {
        s.joint_sum[present] = sum;
        s.joint_candidate[present] = c;
      }
    }
    return s;
  };
  const auto data_residuals = [&]() {
    std::vector<const double*> v;
    for (const AxisGls& g : gls) v.push_back(g.Residual());
    return v;
  };
  // The threshold, calibrated on records drawn from the models (each axis
  // its own, independent, with the same bins missing): the smallest p of a
  // record is compared with the r-th smallest of M drawn records', r =
  // floor((M + 1) alpha), so that a record of the models reports an event
  // with probability r / (M + 1) <= alpha, whatever the correlations between
  // the candidates (Bonferroni over them is only a bound, well above the
  // rate when neighbouring candidates correlate). Later events (with the
  // earlier ones as nuisances) are held to the same p.
  // The draws depend on the models, the bins and which of them are missing,
  // not on the data: a station's runs under one plan's reference models
  // share them (Calibrations).
  const int draws = static_cast<int>(std::ceil(10 / options.false_alarm)) - 1;
  std::string key;
  const auto put = [&key](double v) { key.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(tau0_s);
  put(b);
  put(static_cast<double>(draws));
  put(static_cast<double>(bins));
  put(static_cast<double>(num_axes));
  for (int a = 0; a < num_axes; ++a) {
    put(static_cast<double>(models[a].terms.size()));
    for (const ModelTerm& t : models[a].terms) {
      put(static_cast<double>(static_cast<int>(t.kind)));
      put(t.scale);
      put(t.correlation_time_s);
      put(t.frequency_hz);
    }
    key += '|';
    for (double v : means[a]) key += std::isfinite(v) ? '1' : '0';
    key += '|';
  }
  std::shared_ptr<const std::vector<double>> cached = Calibrations().Find(key);
  if (cached == nullptr) {
    std::vector<double> drawn;
    drawn.reserve(draws);
    std::mt19937_64 rng(0x5eed5ca9);
    constexpr int kBlock = 64;
    std::vector<Eigen::MatrixXd> block(num_axes);
    std::vector<const double*> v(num_axes);
    for (int first = 0; first < draws; first += kBlock) {
      const int count = std::min(kBlock, draws - first);
      for (int a = 0; a < num_axes; ++a) block[a] = gls[a].DrawResiduals(rng, count);
      for (int j = 0; j < count; ++j) {
        for (int a = 0; a < num_axes; ++a) v[a] = block[a].col(j).data();
        const Strongest s = strongest(v);
        size_t at = kNone;
        drawn.push_back(std::min(s.AxisP(), s.JointP(joint, &at)));
      }
    }
    std::sort(drawn.begin(), drawn.end());
    cached = Calibrations().Put(key, std::move(drawn));
  }
  const std::vector<double>& drawn_p = *cached;
  const int rank = std::max(1, static_cast<int>(std::floor((draws + 1) * options.false_alarm)));
  const double p_threshold = drawn_p[rank - 1];
  scan.threshold_p = p_threshold;

  std::vector<StationarityEvent> events;
  std::vector<double> size(num_axes), sigma(num_axes);
  for (int round = 0; round < options.max_events; ++round) {
    const Strongest s = strongest(data_residuals());
    size_t joint_candidate = kNone;
    const double axis_p = s.AxisP(), joint_p = s.JointP(joint, &joint_candidate);
    const bool best_joint = joint_p < axis_p;
    const double best_p = std::min(axis_p, joint_p);
    const size_t best_index = best_joint ? joint_candidate : s.axis_candidate;
    if (best_index == kNone || !(best_p < p_threshold)) break;
    const Candidate* best = &candidates[best_index];
    const int best_axis = best_joint ? -1 : s.axis;
    std::vector<double> best_z(num_axes);
    for (int a = 0; a < num_axes; ++a) gls[a].Test(best_index, &best_z[a], &size[a], &sigma[a]);
    const double adjusted =
        static_cast<double>(
            1 + (std::upper_bound(drawn_p.begin(), drawn_p.end(), best_p) - drawn_p.begin())) /
        (draws + 1);
    StationarityEvent e;
    e.kind = best->kind;
    e.time_s = (best->k + best->offset) * b;
    e.window_s = best->w * b;
    e.joint = best_joint;
    e.p_adjusted = std::min(1.0, adjusted);
    e.axes.resize(num_axes);
    int loudest = 0;
    bool any = false;
    for (int a = 0; a < num_axes; ++a) {
      EventAxis& ea = e.axes[a];
      ea.z = best_z[a];
      if (std::isfinite(ea.z) &&
          (!std::isfinite(best_z[loudest]) || std::fabs(ea.z) > std::fabs(best_z[loudest]))) {
        loudest = a;
      }
      ea.named = best_joint ? std::isfinite(ea.z) && TwoSidedNormal(ea.z) < 0.01 : a == best_axis;
      any = any || ea.named;
      int from = 0, to = 0;
      if (gls[a].StepInGap(*best, &from, &to)) {
        ea.gap_from_s = (from + 1) * b;
        ea.gap_to_s = to * b;
      }
    }
    if (!any) e.axes[loudest].named = true;
    for (AxisGls& g : gls) g.AddNuisance(best_index);
    events.push_back(std::move(e));
  }
  // Sizes from the joint estimate with every event.
  for (size_t j = 0; j < events.size(); ++j) {
    for (int a = 0; a < num_axes; ++a) {
      gls[a].Amplitude(j, &events[j].axes[a].size, &events[j].axes[a].sigma);
    }
  }
  scan.events = std::move(events);
  scan.passes = 1;
  for (const CompositeModel& m : models) scan.models.push_back(m.Name());
  return scan;
}

Result<CompositeModel> FitModelForScan(std::span<const double> rate, double tau0_s,
                                       bool most_wander) {
  const PhaseRecord phase = PhaseFromRate(rate, tau0_s);
  const std::vector<int64_t> m =
      AveragingFactors(TauGridSpec{}, tau0_s, phase.size(), Deviation::kOadev, StopRule::kBins9);
  Curve curve = ComputeDeviation(phase, Deviation::kOadev, m);
  AttachConfidence(phase, CiMethod::kChi2, kOneSigmaConfidence, &curve);
  return FitModelForScan(curve, most_wander);
}

Result<CompositeModel> FitModelForScan(const Curve& curve, bool most_wander) {
  const double tau0_s = curve.tau0_s;
  GmwmOptions options;
  options.stop = StopRule::kNone;
  options.bootstrap_replicates = 0;
  options.absent_term_bounds = false;
  auto fit = FitCompositeModel(curve, options);
  if (!fit.ok()) return fit.status();
  if (!most_wander) return fit->model;
  // The selected model is the most parsimonious one the curve allows; the
  // scan's lags reach the whole record, beyond the fitted taus, where a
  // flicker floor or random walk the selection left out still moves the bin
  // means (and the scan would read that wander as events). So among the
  // candidates the J test accepts, the one with the most variance at a third
  // of the record.
  // (A ramp is not variance here: the scan fits it as the constant of the
  // differenced bin means.)
  const double long_m = static_cast<double>(std::max<int64_t>(curve.n_phase - 1, 1)) / 3;
  const auto random_avar = [&](const CompositeModel& m) {
    double v = 0;
    for (const ModelTerm& t : m.terms) {
      if (t.kind != TermKind::kDrift) v += TermAvar(t, long_m, tau0_s);
    }
    return v;
  };
  const CompositeModel* chosen = &fit->model;
  double most = random_avar(fit->model);
  for (const ModelCandidate& c : fit->candidates) {
    if (!(c.p_value >= options.adequacy_level) || c.model.terms.empty()) continue;
    const double v = random_avar(c.model);
    if (v > most) {
      most = v;
      chosen = &c.model;
    }
  }
  return *chosen;
}

void RemoveEvents(const StationarityScan& scan, int axis, double tau0_s, std::span<double> rate) {
  const auto sample = [&](double t_s) {
    return static_cast<size_t>(
        std::clamp<double>(std::llround(t_s / tau0_s), 0.0, static_cast<double>(rate.size())));
  };
  for (const StationarityEvent& e : scan.events) {
    const double size = e.axes[static_cast<size_t>(axis)].size;
    if (!std::isfinite(size)) continue;
    const size_t to = e.kind == EventKind::kStep ? rate.size() : sample(e.time_s + e.window_s);
    for (size_t i = sample(e.time_s); i < to; ++i) rate[i] -= size;
  }
}

Result<StationarityScan> ScanStationarityRefitting(const std::vector<std::span<const double>>& axes,
                                                   double tau0_s,
                                                   const StationarityOptions& options,
                                                   const StationarityModelFit& fit) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  std::vector<CompositeModel> models;
  for (const auto& a : axes) {
    auto m = fit(a, tau0_s);
    if (!m.ok()) return m.status();
    models.push_back(*m);
  }
  auto scan = ScanStationarity(axes, models, tau0_s, options);
  if (!scan.ok()) return scan;
  int passes = 1;
  auto same = [](const StationarityScan& x, const StationarityScan& y) {
    if (x.events.size() != y.events.size()) return false;
    for (size_t i = 0; i < x.events.size(); ++i) {
      if (x.events[i].kind != y.events[i].kind || x.events[i].time_s != y.events[i].time_s ||
          x.events[i].window_s != y.events[i].window_s) {
        return false;
      }
    }
    return true;
  };
  while (!scan->events.empty() && passes < options.passes) {
    for (size_t a = 0; a < axes.size(); ++a) {
      std::vector<double> corrected(axes[a].begin(), axes[a].end());
      RemoveEvents(*scan, static_cast<int>(a), tau0_s, corrected);
      auto m = fit(corrected, tau0_s);
      if (!m.ok()) return m.status();
      models[a] = *m;
    }
    auto next = ScanStationarity(axes, models, tau0_s, options);
    if (!next.ok()) return next;
    ++passes;
    const bool settled = same(*scan, *next);
    scan = std::move(next);
    if (settled) break;
  }
  scan->passes = passes;
  return scan;
}

std::pair<double, double> EventCut(const StationarityEvent& e, const EventAxis& a,
                                   double margin_s) {
  if (std::isfinite(a.gap_from_s)) return {a.gap_from_s - margin_s, a.gap_to_s + margin_s};
  if (e.kind == EventKind::kStep) return {e.time_s - margin_s, e.time_s + margin_s};
  return {e.time_s - margin_s, e.time_s + e.window_s + margin_s};
}

Segment LongestStationarySegment(const StationarityScan& scan, double length_s, int axis) {
  static const EventAxis kNoAxis;  // an event no axis names: its time and window
  std::vector<std::pair<double, double>> cuts;
  for (const StationarityEvent& e : scan.events) {
    // The axis's entry; for all axes, the first that names the event.
    const EventAxis* on = nullptr;
    for (size_t a = 0; a < e.axes.size() && on == nullptr; ++a) {
      if ((axis < 0 || static_cast<int>(a) == axis) && e.axes[a].named) on = &e.axes[a];
    }
    if (on == nullptr && axis < 0) on = &kNoAxis;
    if (on != nullptr) cuts.push_back(EventCut(e, *on, 0));
  }
  return LongestUncutStretch(std::move(cuts), length_s);
}

std::vector<Segment> UncutStretches(std::vector<std::pair<double, double>> cuts, double length_s) {
  std::sort(cuts.begin(), cuts.end());
  std::vector<Segment> out;
  double from = 0;
  for (const auto& [lo, hi] : cuts) {
    const double end = std::min(lo, length_s);
    if (end > from) out.push_back({from, end});
    from = std::clamp(hi, from, length_s);
  }
  if (length_s > from) out.push_back({from, length_s});
  return out;
}

Segment LongestUncutStretch(std::vector<std::pair<double, double>> cuts, double length_s) {
  Segment best{0, 0};
  for (const Segment& s : UncutStretches(std::move(cuts), length_s)) {
    if (s.end_s - s.begin_s > best.end_s - best.begin_s) best = s;
  }
  return best;
}

}  // namespace imuqual::allan
