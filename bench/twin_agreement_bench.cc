// Do a record's model figures and its read-offs agree? Both come from the
// same record, so their errors are correlated and neither u alone is the u of
// their difference. This bench fits the noise model to a recorded series (as
// `imuqual analyze --fit` does: octave OADEV, chi-square edf, from
// --fit-min-tau), then simulates twins of the record from the fitted model
// (same rate and length, each term as the simulator draws it, the output
// rounded to --lsb), reads each twin as the record was read, and prints the
// twins' distribution of (read-off - model) for the curve minimum and for
// N: its mean (the two estimators' relative bias under the model), its
// standard deviation (the u of the difference), and the record's own
// difference as z against them.
//
// Usage: twin_agreement_bench CSV --column NAME --rate HZ [--scale S]
//          [--fit-min-tau T] [--lsb L] [--twins N] [--threads T] [--each] [--pair-check]
// --each prints every twin's number (its seed's index), selected model, its
// curve minimum's z, with --pair-check its J and the pair grid's, the
// selected model's terms ({N 0.0045 S 0.0068@0.57Hz GM 0.003/0.12s ...}:
// scale, a line's frequency, a Gauss-Markov term's correlation time) and its
// first four candidates (J, criterion, averaging weight). The summary gives
// the model's z of the minimum and of N by the model each twin selected.
// --pair-check estimates each twin's selected model, where it has two
// sinusoids or two Gauss-Markov terms, from every pair of the search's
// frequencies and of its correlation times (seconds per twin) and counts
// the twins where that grid found a lower J than the search.
// --lsb adds the rounding to the twins; leave it out where the record's
// rounding is already in its fitted white noise (it would count twice).
// CSV: a header line, comma-separated values; the column's values times S.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "acquire/imu_simulator.h"
#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/noise_model.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual {
namespace {

struct Reading {
  double readoff_min = NAN, readoff_min_u = NAN, model_min = NAN, model_min_u = NAN;
  double readoff_n = NAN, readoff_n_u = NAN, model_n = NAN, model_n_u = NAN;
  std::string model, candidates;  // the selected model; the first four candidates
  std::string terms;              // the selected model's terms with their values
  bool adequate = false;
  // With --pair-check: J of the selected model and the least J of its grid
  // of full estimates over every pair of frequencies and of correlation
  // times (NaN: neither two lines nor two Gauss-Markov terms).
  double objective = NAN, pair_grid_objective = NAN;
};

Reading Read(const std::vector<double>& rate, double tau0, double fit_min_tau, bool pair_check,
             allan::CompositeFit* fit_out = nullptr) {
  Reading r;
  const allan::PhaseRecord phase = allan::PhaseFromRate(rate, tau0);
  const std::vector<int64_t> m = allan::AveragingFactors(
      allan::TauGridSpec{}, tau0, phase.size(), allan::Deviation::kOadev, allan::StopRule::kBins9);
  allan::Curve curve = allan::ComputeDeviation(phase, allan::Deviation::kOadev, m);
  allan::AttachConfidence(phase, allan::CiMethod::kChi2, allan::kOneSigmaConfidence, &curve);
  if (const auto min = allan::FindCurveMinimum(curve)) {
    r.readoff_min = min->dev;
    r.readoff_min_u = allan::MinimumUncertainty(curve, *min);
  }
  const allan::SlopeReadoff n = allan::ReadSlopeLine(curve, allan::NoiseTerm::kAngleRandomWalk);
  r.readoff_n = n.value;
  r.readoff_n_u = n.uncertainty;
  allan::GmwmOptions fo;
  fo.stop = allan::StopRule::kNone;
  fo.min_tau_s = fit_min_tau;
  fo.check_pair_search = pair_check;
  auto fit = allan::FitCompositeModel(curve, fo);
  if (!fit.ok()) return r;
  r.model_min = fit->curve_minimum.value;
  r.model_min_u = fit->curve_minimum.sigma;
  r.model_n = fit->white_asymptote.value;
  r.model_n_u = fit->white_asymptote.sigma;
  r.model = fit->model.Name();
  for (const allan::ModelTerm& t : fit->model.terms) {
    char b[96];
    int at = std::snprintf(b, sizeof b, "%s%s %.4g", r.terms.empty() ? "" : " ",
                           std::string(allan::TermKindSymbol(t.kind)).c_str(), t.scale);
    if (t.kind == allan::TermKind::kGaussMarkov) {
      std::snprintf(b + at, sizeof b - at, "/%.4gs", t.correlation_time_s);
    } else if (t.kind == allan::TermKind::kSinusoid) {
      std::snprintf(b + at, sizeof b - at, "@%.4gHz", t.frequency_hz);
    }
    r.terms += b;
  }
  r.adequate = fit->adequate;
  r.objective = fit->objective;
  r.pair_grid_objective = fit->pair_grid_objective;
  for (size_t i = 0; i < fit->candidates.size() && i < 4; ++i) {
    char b[160];
    std::snprintf(b, sizeof b, "%s%s J %.1f crit %.1f w %.2f", i == 0 ? "" : "; ",
                  fit->candidates[i].name.c_str(), fit->candidates[i].objective,
                  fit->candidates[i].criterion, fit->candidates[i].weight);
    r.candidates += b;
  }
  if (fit_out != nullptr) *fit_out = *fit;
  return r;
}

// The simulator's truth for one axis from the fitted model's terms.
pb::SimTruth TwinTruth(const allan::CompositeModel& model, double rate_hz, double lsb,
                       uint64_t seed) {
  pb::SimTruth truth;
  truth.set_seed(seed);
  truth.set_actual_rate_hz(rate_hz);
  pb::AxisTruth* axis = truth.add_axes();
  axis->set_axis("x");
  axis->set_rate_lsb(lsb);
  for (const allan::ModelTerm& t : model.terms) {
    switch (t.kind) {
      case allan::TermKind::kQuantization:
        axis->set_quantization(t.scale);
        break;
      case allan::TermKind::kWhite:
        axis->set_random_walk(t.scale);
        break;
      case allan::TermKind::kFlicker:
        axis->set_bias_instability(t.scale);
        break;
      case allan::TermKind::kRandomWalk:
        axis->set_rate_random_walk(t.scale);
        break;
      case allan::TermKind::kDrift:
        axis->set_rate_ramp(t.scale);
        break;
      case allan::TermKind::kGaussMarkov: {
        pb::GaussMarkov* g = axis->add_gauss_markov();
        g->set_sigma(t.scale);
        g->set_correlation_time_s(t.correlation_time_s);
        break;
      }
      case allan::TermKind::kSinusoid: {
        pb::Sinusoid* s = axis->add_sinusoids();
        s->set_amplitude(t.scale);
        s->set_frequency_hz(t.frequency_hz);
        break;
      }
    }
  }
  return truth;
}

struct Stats {
  double n = 0, sum = 0, sum2 = 0;
  void Add(double x) {
    if (!std::isfinite(x)) return;
    ++n;
    sum += x;
    sum2 += x * x;
  }
  double Mean() const { return sum / n; }
  double Sd() const { return std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1))); }
  double Rms() const { return std::sqrt(sum2 / n); }
};

int Fail(const std::string& why) {
  std::fprintf(stderr, "twin_agreement_bench: %s\n", why.c_str());
  return 2;
}

}  // namespace
}  // namespace imuqual

int main(int argc, char** argv) {
  using namespace imuqual;
  if (argc < 2) return Fail("usage: twin_agreement_bench CSV --column NAME --rate HZ [...]");
  std::string path = argv[1], column;
  double rate_hz = 0, scale = 1, fit_min_tau = 0, lsb = 0;
  int twins = 200, threads = 2;
  bool each = false, pair_check = false;
  for (int i = 2; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--each" || flag == "--pair-check") {
      (flag == "--each" ? each : pair_check) = true;
      --i;  // no value
      continue;
    }
    if (i + 1 >= argc) return Fail(flag + " needs a value");
    const char* v = argv[i + 1];
    if (flag == "--column") {
      column = v;
    } else if (flag == "--rate") {
      rate_hz = std::atof(v);
    } else if (flag == "--scale") {
      scale = std::atof(v);
    } else if (flag == "--fit-min-tau") {
      fit_min_tau = std::atof(v);
    } else if (flag == "--lsb") {
      lsb = std::atof(v);
    } else if (flag == "--twins") {
      twins = std::atoi(v);
    } else if (flag == "--threads") {
      threads = std::atoi(v);
    } else {
      return Fail("unknown option " + flag);
    }
  }
  if (column.empty() || !(rate_hz > 0) || twins < 2 || threads < 1) {
    return Fail("--column, --rate > 0, --twins >= 2 and --threads >= 1 are needed");
  }
  if (!(std::isfinite(scale) && scale != 0) || !(lsb >= 0) || !(fit_min_tau >= 0)) {
    return Fail("--scale must be finite and non-zero, --lsb and --fit-min-tau >= 0");
  }
  std::ifstream in(path);
  if (!in) return Fail("cannot read " + path);
  std::string line;
  std::getline(in, line);
  int col = -1, at = 0;
  {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::stringstream header(line);
    std::string name;
    while (std::getline(header, name, ',')) {
      if (name == column) col = at;
      ++at;
    }
  }
  if (col < 0) return Fail("no column " + column + " in " + path);
  std::vector<double> rate;
  for (int64_t row_number = 2; std::getline(in, line); ++row_number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::stringstream row(line);
    std::string cell;
    int c = 0;
    while (c <= col && std::getline(row, cell, ',')) {
      if (c++ < col) continue;
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (cell.empty() || end == cell.c_str() || *end != '\0' || !std::isfinite(v)) {
        return Fail(path + " row " + std::to_string(row_number) + ": " + column +
                    " is not a number (\"" + cell + "\")");
      }
      rate.push_back(v * scale);
    }
    if (c <= col) {
      return Fail(path + " row " + std::to_string(row_number) + " has no " + column + " cell");
    }
  }
  if (rate.size() < 1000) return Fail(path + ": fewer than 1000 samples of " + column);
  const double tau0 = 1 / rate_hz;
  allan::CompositeFit fit;
  const Reading real = Read(rate, tau0, fit_min_tau, /*pair_check=*/false, &fit);
  if (real.model.empty()) return Fail("the record's fit failed");
  std::printf(
      "# record: %zu samples, model %s (%s), curve minimum read-off %.6g +- %.3g, model "
      "%.6g +- %.3g; N read-off %.6g +- %.3g, model %.6g +- %.3g\n",
      rate.size(), real.model.c_str(), real.adequate ? "adequate" : "INADEQUATE", real.readoff_min,
      real.readoff_min_u, real.model_min, real.model_min_u, real.readoff_n, real.readoff_n_u,
      real.model_n, real.model_n_u);
  // The twins' truth: the selected model's own N and deviation minimum over
  // the fitted taus, as the fit computes them (the record's figures are
  // model-averaged; the twins are drawn from the selected model alone).
  const double tau_lo = fit.points.front().tau_s, tau_hi = fit.points.back().tau_s;
  const allan::ModelCurveFigures truth = allan::ModelFiguresOver(fit.model, tau0, tau_lo, tau_hi);
  const double truth_n = truth.white_asymptote, truth_min = truth.curve_minimum;
  std::printf("# twins' truth: N %.6g, curve minimum %.6g over %.3g-%.3g s\n", truth_n, truth_min,
              tau_lo, tau_hi);
  // The simulator refuses a truth it cannot draw (a line at Nyquist, say):
  // here, once, rather than in a worker.
  if (auto sim = sim::ImuSimulator::Create(TwinTruth(fit.model, rate_hz, lsb, 0)); !sim.ok()) {
    return Fail("the model cannot be simulated: " + sim.status().message());
  }
  std::vector<Reading> out(twins);
  std::atomic<int> next{0};
  const auto work = [&] {
    for (int s = next++; s < twins; s = next++) {
      auto sim = sim::ImuSimulator::Create(TwinTruth(fit.model, rate_hz, lsb, 0x7a1 + 7919ull * s));
      std::vector<std::vector<float>> samples(1);
      sim->Generate(static_cast<int>(rate.size()), samples);
      out[s] = Read(std::vector<double>(samples[0].begin(), samples[0].end()), tau0, fit_min_tau,
                    pair_check);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();
  // The truth of every twin is the record's model: its minimum and N.
  Stats d_min, d_n, e_ro, e_mo, cross, z_ro, z_mo, ze_n_ro, ze_n_mo;
  // The model's z of the minimum and of N by the model each twin selected:
  // whether a u fails everywhere or where the selection differs.
  std::map<std::string, std::pair<Stats, Stats>> by_model;
  int same_model = 0, used = 0;
  for (size_t s = 0; s < out.size(); ++s) {
    const Reading& r = out[s];
    // A twin whose fit or read-offs failed counts in no statistic.
    if (r.model.empty() || !std::isfinite(r.readoff_min) || !std::isfinite(r.model_min) ||
        !std::isfinite(r.readoff_n) || !std::isfinite(r.model_n)) {
      continue;
    }
    ++used;
    if (each) {
      std::printf("# twin %zu %s %s min %.4g +- %.3g (z %+.2f) N z %+.2f", s, r.model.c_str(),
                  r.adequate ? "ok" : "INADEQUATE", r.model_min, r.model_min_u,
                  (r.model_min - truth_min) / r.model_min_u, (r.model_n - truth_n) / r.model_n_u);
      if (pair_check) std::printf(" J %.3f pair grid %.3f", r.objective, r.pair_grid_objective);
      std::printf(" {%s} [%s]\n", r.terms.c_str(), r.candidates.c_str());
    }
    d_min.Add(r.readoff_min - r.model_min);
    d_n.Add(r.readoff_n - r.model_n);
    e_ro.Add(r.readoff_min - truth_min);
    e_mo.Add(r.model_min - truth_min);
    cross.Add((r.readoff_min - truth_min) * (r.model_min - truth_min));
    z_ro.Add((r.readoff_min - truth_min) / r.readoff_min_u);
    z_mo.Add((r.model_min - truth_min) / r.model_min_u);
    ze_n_ro.Add((r.readoff_n - truth_n) / r.readoff_n_u);
    ze_n_mo.Add((r.model_n - truth_n) / r.model_n_u);
    by_model[r.model].first.Add((r.model_min - truth_min) / r.model_min_u);
    by_model[r.model].second.Add((r.model_n - truth_n) / r.model_n_u);
    same_model += r.model == real.model;
  }
  const double corr =
      (cross.sum - cross.n * e_ro.Mean() * e_mo.Mean()) / (cross.n - 1) / (e_ro.Sd() * e_mo.Sd());
  std::printf(
      "# %d twins of %s (lsb %g), %d read (fit and read-offs defined), %d fitted with the "
      "record's model\n",
      twins, real.model.c_str(), lsb, used, same_model);
  if (used < 2) return Fail("fewer than 2 twins could be read");
  std::printf(
      "# curve minimum: read-off error mean %+.3g sd %.3g (z rms %.2f), model error "
      "mean %+.3g sd %.3g (z rms %.2f), correlation %.2f\n",
      e_ro.Mean(), e_ro.Sd(), z_ro.Rms(), e_mo.Mean(), e_mo.Sd(), z_mo.Rms(), corr);
  const double zr_min = (real.readoff_min - real.model_min - d_min.Mean()) / d_min.Sd();
  const double zr_n = (real.readoff_n - real.model_n - d_n.Mean()) / d_n.Sd();
  std::printf("twin_minimum_difference_mean %.6g\ntwin_minimum_difference_sd %.6g\n", d_min.Mean(),
              d_min.Sd());
  std::printf("record_minimum_difference %.6g\nrecord_minimum_difference_z %.2f\n",
              real.readoff_min - real.model_min, zr_min);
  std::printf("# N: read-off z rms %.2f, model z rms %.2f\n", ze_n_ro.Rms(), ze_n_mo.Rms());
  for (const auto& [model, z] : by_model) {
    std::printf(
        "# selected %s in %.0f: model minimum z mean %+.2f rms %.2f, model N z mean %+.2f rms "
        "%.2f\n",
        model.c_str(), z.first.n, z.first.Mean(), z.first.Rms(), z.second.Mean(), z.second.Rms());
  }
  std::printf("twin_n_difference_mean %.6g\ntwin_n_difference_sd %.6g\n", d_n.Mean(), d_n.Sd());
  std::printf("record_n_difference %.6g\nrecord_n_difference_z %.2f\n",
              real.readoff_n - real.model_n, zr_n);
  if (pair_check) {
    // The pair search against a grid of full estimates: a miss is a twin
    // whose grid found a J lower than the search's (by more than 1e-3).
    int with_pair = 0, misses = 0, large = 0;
    double worst = 0;
    for (const Reading& r : out) {
      if (!std::isfinite(r.pair_grid_objective) || !std::isfinite(r.objective)) continue;
      ++with_pair;
      const double gain = r.objective - r.pair_grid_objective;
      misses += gain > 1e-3;
      large += gain > 0.5;
      worst = std::max(worst, gain);
    }
    std::printf(
        "# pair search: %d twins selected a model with two lines or two Gauss-Markov terms; the "
        "grid found a lower J in %d (by more than 0.5 in %d, at most %.3g)\n",
        with_pair, misses, large, worst);
    std::printf("pair_search_misses %d\npair_search_checked %d\n", misses, with_pair);
  }
  return 0;
}
