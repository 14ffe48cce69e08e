// Constructive and statistical tests of the composite noise-model fit
// (analyze/allan/gmwm.h) through the simulator: records made from known
// composite truths, their exact octave OADEV with chi-square intervals (what
// `imuqual analyze --fit` fits), and
//  - model selection: the truth's terms are the selected model in >= 90 % of
//    seeds, for white + RRW + Gauss-Markov, white + quantization + flicker + RRW, two Gauss-Markov
//    terms a decade apart, and a ramp;
//  - recovery: every true term lies within its reported uncertainty;
//  - calibration over 200 seeds: the 1-sigma intervals of N (ARW) and K (RRW)
//    cover the truth in 60-76 % of seeds, the 2-sigma ones in >= 90 %, and the
//    mean z lies within +-0.3, for the five-term model and with a
//    Gauss-Markov term present; the J test's false-alarm rate at its 1 %
//    level stays small.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "acquire/coverage_records.h"
#include "acquire/imu_simulator.h"
#include "acquire/lot_profile.h"
#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual {
namespace {

using allan::CompositeFit;
using allan::TermKind;

constexpr double kRateHz = 100.0;
// 2^19 samples at 100 Hz (87 min): 16 octave points under the 9-bin rule.
constexpr int kSamples = 1 << 19;

pb::AxisTruth Axis() {
  pb::AxisTruth a;
  a.set_axis("x");
  a.set_bias(0.15);  // removed by the analysis (phase from rate - mean)
  return a;
}

void AddGaussMarkov(pb::AxisTruth* a, double sigma, double t_s) {
  pb::GaussMarkov* g = a->add_gauss_markov();
  g->set_sigma(sigma);
  g->set_correlation_time_s(t_s);
}

// The octave OADEV with chi-square intervals of a simulated record, its
// values multiplied by `unit` (the same record read in another unit).
allan::Curve SimulatedCurve(const pb::AxisTruth& axis, uint64_t seed, double unit = 1.0) {
  pb::SimTruth truth;
  truth.set_seed(seed);
  truth.set_actual_rate_hz(kRateHz);
  *truth.add_axes() = axis;
  auto sim = sim::ImuSimulator::Create(truth);
  if (!sim.ok()) {
    ADD_FAILURE() << sim.status().message();
    return {};  // no points: the fit says so
  }
  std::vector<std::vector<float>> out(1);
  out[0].reserve(kSamples);
  sim->Generate(kSamples, out);
  std::vector<double> rate(out[0].begin(), out[0].end());
  for (double& v : rate) v *= unit;
  const allan::PhaseRecord phase = allan::PhaseFromRate(rate, 1.0 / kRateHz);
  const std::vector<int64_t> m =
      allan::AveragingFactors(allan::TauGridSpec{}, phase.tau0_s, phase.size(),
                              allan::Deviation::kOadev, allan::StopRule::kBins9);
  allan::Curve curve = allan::ComputeDeviation(phase, allan::Deviation::kOadev, m);
  allan::AttachConfidence(phase, allan::CiMethod::kChi2, allan::kOneSigmaConfidence, &curve);
  return curve;
}

Result<CompositeFit> FitSimulated(const pb::AxisTruth& axis, uint64_t seed,
                                  const allan::GmwmOptions& options = {}) {
  return allan::FitCompositeModel(SimulatedCurve(axis, seed), options);
}

// The selected model's term of `kind` (the i-th by correlation time), or null.
const allan::FittedTerm* Term(const CompositeFit& fit, TermKind kind, int i = 0) {
  std::vector<const allan::FittedTerm*> found;
  for (const allan::FittedTerm& t : fit.terms) {
    if (t.term.kind == kind) found.push_back(&t);
  }
  std::sort(found.begin(), found.end(), [](auto* a, auto* b) {
    return a->term.correlation_time_s < b->term.correlation_time_s;
  });
  return i < static_cast<int>(found.size()) ? found[i] : nullptr;
}

struct Scenario {
  std::string name;
  pb::AxisTruth truth;
  std::string expected_model;
};

// Every truth below is identifiable from an 87 min record: each term dominates
// the Allan variance over some span of the analysed taus (a term buried under
// the others everywhere cannot be selected by any method, and is reported as
// absent, i.e. 0 with no sigma).
std::vector<Scenario> SelectionScenarios() {
  std::vector<Scenario> out;
  {  // White + RRW + one Gauss-Markov bump (sigma 0.01 deg/s, T 10 s); K above
     // the bump's tail beyond ~60 s. (With T = 30 s the sum of the bump and
     // the random walk over 87 min is matched within the noise by one longer
     // Gauss-Markov term in ~1 seed of 5: not identifiable from that record.)
    pb::AxisTruth a = Axis();
    a.set_random_walk(0.005);
    a.set_rate_random_walk(1.5e-3);
    AddGaussMarkov(&a, 0.01, 10);
    out.push_back({"white+rrw+gm", a, "N+K+GM"});
  }
  {  // IEEE 952 without drift: quantization, white, flicker, RRW.
    pb::AxisTruth a = Axis();
    a.set_quantization(2e-4);
    a.set_random_walk(0.005);
    a.set_bias_instability(0.002);
    a.set_rate_random_walk(3e-4);
    out.push_back({"q+white+flicker+rrw", a, "Q+N+B+K"});
  }
  {  // Two Gauss-Markov terms a decade apart on white noise.
    pb::AxisTruth a = Axis();
    a.set_random_walk(0.005);
    AddGaussMarkov(&a, 0.005, 2);
    AddGaussMarkov(&a, 0.005, 20);
    out.push_back({"white+2gm", a, "N+2GM"});
  }
  {  // A rate ramp on white noise and a flicker floor.
    pb::AxisTruth a = Axis();
    a.set_random_walk(0.005);
    a.set_bias_instability(0.002);
    a.set_rate_ramp(3e-5);
    out.push_back({"white+flicker+ramp", a, "N+B+R"});
  }
  return out;
}

// |estimate - truth| / sigma for a recovered parameter; a missing term is an
// infinite z.
double Z(double estimate, double sigma, double truth) {
  if (!std::isfinite(estimate) || !(sigma > 0)) return INFINITY;
  return (estimate - truth) / sigma;
}

// The right model in >= 90 % of seeds (the issue's acceptance). With plain
// AICc a spurious Q or B stayed in up to 15 % of the white+RRW+GM records;
// the 3.84 entry cost of a one-parameter term (gmwm.h) brought every
// scenario to 90-95 %. What remains: a random walk taken for a ramp (their
// AVARs differ only over the last octaves of an 87 min record) and an extra
// term in 1 seed of 20.
constexpr double kMinRightModelFraction = 0.90;
constexpr int kSelectionSeeds = 60;
// A true parameter outside 5 reported sigmas has probability 6e-7 per
// parameter for Gaussian errors; the correlation times of two Gauss-Markov
// terms a decade apart are nonlinear enough in the data to reach 4.7 (1 of
// 40 seeds), and a sigma wrong by a factor 2 would still show.
constexpr double kRecoveryZ = 5.0;

TEST(CompositeFitTest, SelectsTheTruthsTermsAndRecoversThemWithinTheirSigmas) {
  for (const Scenario& s : SelectionScenarios()) {
    int right = 0, adequate = 0, fitted = 0;
    std::map<std::string, int> selected;
    for (int seed = 1; seed <= kSelectionSeeds; ++seed) {
      auto fit = FitSimulated(s.truth, 1000 * seed + 7);
      ASSERT_TRUE(fit.ok()) << s.name << ": " << fit.status().message();
      ++fitted;
      ++selected[fit->model.Name()];
      adequate += fit->adequate;
      if (fit->model.Name() != s.expected_model) continue;
      ++right;
      // GIVEN the right model, THEN each true parameter is within kRecoveryZ sigmas.
      const pb::AxisTruth& t = s.truth;
      auto check = [&](const allan::FittedTerm* term, double truth, const char* what) {
        ASSERT_NE(term, nullptr) << s.name << " " << what;
        EXPECT_LT(std::fabs(Z(term->term.scale, term->scale_sigma, truth)), kRecoveryZ)
            << s.name << " seed " << seed << " " << what << " " << term->term.scale << " +- "
            << term->scale_sigma << " truth " << truth;
      };
      if (t.quantization() > 0) check(Term(*fit, TermKind::kQuantization), t.quantization(), "Q");
      if (t.random_walk() > 0) check(Term(*fit, TermKind::kWhite), t.random_walk(), "N");
      if (t.bias_instability() > 0) {
        check(Term(*fit, TermKind::kFlicker), t.bias_instability(), "B");
      }
      if (t.rate_random_walk() > 0) {
        check(Term(*fit, TermKind::kRandomWalk), t.rate_random_walk(), "K");
      }
      if (t.rate_ramp() > 0) check(Term(*fit, TermKind::kDrift), t.rate_ramp(), "R");
      for (int i = 0; i < t.gauss_markov_size(); ++i) {
        const allan::FittedTerm* gm = Term(*fit, TermKind::kGaussMarkov, i);
        check(gm, t.gauss_markov(i).sigma(), "GM sigma");
        EXPECT_LT(std::fabs(Z(gm->term.correlation_time_s, gm->correlation_time_sigma_s,
                              t.gauss_markov(i).correlation_time_s())),
                  kRecoveryZ)
            << s.name << " seed " << seed << " GM T " << gm->term.correlation_time_s << " +- "
            << gm->correlation_time_sigma_s;
      }
    }
    std::string seen;
    for (const auto& [name, n] : selected) seen += " " + name + ":" + std::to_string(n);
    std::printf("%-22s right model %d/%d, adequate %d/%d; selected%s\n", s.name.c_str(), right,
                fitted, adequate, fitted, seen.c_str());
    EXPECT_GE(right, kMinRightModelFraction * fitted) << s.name << ": selected" << seen;
  }
}

struct Coverage {
  int n = 0, in1 = 0, in2 = 0, missing = 0;
  double sum_z = 0, sum_z2 = 0;
  void Add(double z) {
    ++n;
    if (!std::isfinite(z))
      ++missing;
    else
      sum_z2 += z * z;
    if (std::fabs(z) <= 1) ++in1;
    if (std::fabs(z) <= 2) ++in2;
    if (std::isfinite(z)) sum_z += z;
  }
  double f1() const { return static_cast<double>(in1) / n; }
  double f2() const { return static_cast<double>(in2) / n; }
  double mean_z() const { return sum_z / n; }
  double rms_z() const { return std::sqrt(sum_z2 / std::max(1, n - missing)); }
};

// Acceptance: 1-sigma coverage 60-76 %, 2-sigma >= 90 %, |mean z| <= 0.3,
// over >= 200 seeds (the binomial sd of a 68 % coverage over 200 seeds is
// 3.3 %, so 60-76 % is a +-2.4 sd window).
constexpr int kCalibrationSeeds = 200;
constexpr double kMinCoverage1 = 0.60, kMaxCoverage1 = 0.76, kMinCoverage2 = 0.90;
constexpr double kMaxMeanZ = 0.3;
// With a right model the J test rejects at its 1 % level; allow 5 % over 200
// seeds (10 of 200: the model's covariance is itself estimated).
constexpr double kMaxFalseInadequate = 0.05;

TEST(CompositeFitTest, UncertaintiesOfArwAndRrwAreCalibrated) {
  struct Case {
    std::string name;
    pb::AxisTruth truth;
  };
  std::vector<Case> cases;
  {  // Each term dominates somewhere: Q below 0.02 s, N to 5 s, B 5-30 s, K
     // beyond (with B never above the others, it is dropped in ~1 seed of 10
     // and K absorbs it: model-selection error, not calibration).
    pb::AxisTruth a = Axis();
    a.set_quantization(5e-5);
    a.set_random_walk(0.002);
    a.set_bias_instability(0.0014);
    a.set_rate_random_walk(3e-4);
    cases.push_back({"five-term (Q+N+B+K)", a});
  }
  cases.push_back({"white+rrw+gm", SelectionScenarios()[0].truth});
  for (const Case& c : cases) {
    Coverage n_cov, k_cov;
    int inadequate = 0;
    for (int seed = 1; seed <= kCalibrationSeeds; ++seed) {
      auto fit = FitSimulated(c.truth, 77 * seed + 3);
      ASSERT_TRUE(fit.ok()) << c.name << ": " << fit.status().message();
      inadequate += !fit->adequate;
      n_cov.Add(Z(fit->white_asymptote.value, fit->white_asymptote.sigma, c.truth.random_walk()));
      k_cov.Add(
          Z(fit->rate_random_walk.value, fit->rate_random_walk.sigma, c.truth.rate_random_walk()));
    }
    std::printf(
        "%-22s N: 1-sigma %.3f 2-sigma %.3f mean z %+.3f rms z %.2f missing %d | K: 1-sigma %.3f "
        "2-sigma %.3f mean z %+.3f rms z %.2f missing %d | inadequate %d/%d\n",
        c.name.c_str(), n_cov.f1(), n_cov.f2(), n_cov.mean_z(), n_cov.rms_z(), n_cov.missing,
        k_cov.f1(), k_cov.f2(), k_cov.mean_z(), k_cov.rms_z(), k_cov.missing, inadequate,
        kCalibrationSeeds);
    for (const auto& [what, cov] : {std::pair{"N", n_cov}, std::pair{"K", k_cov}}) {
      EXPECT_GE(cov.f1(), kMinCoverage1) << c.name << " " << what;
      EXPECT_LE(cov.f1(), kMaxCoverage1) << c.name << " " << what;
      EXPECT_GE(cov.f2(), kMinCoverage2) << c.name << " " << what;
      EXPECT_LE(std::fabs(cov.mean_z()), kMaxMeanZ) << c.name << " " << what;
    }
    EXPECT_LE(inadequate, kMaxFalseInadequate * kCalibrationSeeds) << c.name;
  }
}

// A term the selection leaves out is reported as an upper bound. The records
// where that happens are those whose long-tau points came out low, so a bound
// at its nominal level covers less often than nominal among them: with the
// nominal 95 % (dJ 2.706) 84-91 % were measured, hence the default 99 %
// (dJ 5.412), which covers in >= 95 % of them. Asserted: >= 90 % over the
// seeds where the random walk (at the edge of what 87 min resolve: selected in
// a third and in two thirds of the seeds) is left out.
constexpr double kMinBoundCoverage = 0.90;

TEST(CompositeFitTest, UpperBoundsOfTermsLeftOutCoverTheTruth) {
  pb::AxisTruth a = Axis();
  a.set_random_walk(0.005);
  a.set_bias_instability(0.002);
  for (double k : {1.2e-4, 1.8e-4}) {
    a.set_rate_random_walk(k);
    allan::GmwmOptions o;
    o.bootstrap_replicates = 0;  // the bound does not use them
    int absent = 0, covered = 0;
    double ratio_sum = 0;
    for (int seed = 1; seed <= 100; ++seed) {
      auto fit = FitSimulated(a, 31 * seed + 5, o);
      ASSERT_TRUE(fit.ok()) << fit.status().message();
      if (fit->model.CountOf(TermKind::kRandomWalk) > 0) continue;
      ++absent;
      covered += fit->rate_random_walk.upper_bound >= k;
      ratio_sum += fit->rate_random_walk.upper_bound / k;
    }
    std::printf(
        "K %g: left out in %d/100 seeds, its bound covers the truth in %d, mean bound / "
        "truth %.2f\n",
        k, absent, covered, ratio_sum / absent);
    ASSERT_GT(absent, 20) << k;  // not vacuous
    EXPECT_GE(covered, kMinBoundCoverage * absent) << k;
  }
}

// The same record read in another unit (g or m/s^2, deg/s or rad/s) is the
// same fit: the same model, the same J, every figure in proportion (to
// 1e-4). (These simulated records also fitted alike under the search in
// absolute logs; allan_gmwm_real_curve_test holds the real curves that did
// not.)
TEST(CompositeFitTest, TheFitDoesNotDependOnTheUnitTheRecordIsReadIn) {
  // Axes like the public ADIS16405 recording's (band-limited white, LSB
  // steps, Gauss-Markov, a line on gz).
  const auto profile = sim::LotProfileByName("mems-real");
  ASSERT_TRUE(profile.ok());
  for (const auto& axis : profile->axes) {
    if (axis.name != "gz" && axis.name != "ax") continue;
    const pb::AxisTruth& a = axis.typical;
    allan::GmwmOptions options;
    options.bootstrap_replicates = 20;
    for (uint64_t seed : {11u, 12u}) {
      auto base = allan::FitCompositeModel(SimulatedCurve(a, seed), options);
      ASSERT_TRUE(base.ok()) << base.status().message();
      for (double unit : {0.5, 3.0, 1 / 9.80665, 1 / 57.29577951308232, 1e-4}) {
        auto fit = allan::FitCompositeModel(SimulatedCurve(a, seed, unit), options);
        ASSERT_TRUE(fit.ok()) << fit.status().message();
        EXPECT_EQ(fit->model.Name(), base->model.Name())
            << axis.name << " seed " << seed << " unit " << unit;
        EXPECT_NEAR(fit->objective, base->objective, 1e-6 * (1 + base->objective))
            << axis.name << " seed " << seed << " unit " << unit;
        // The input differs in its last bits and the search stops within a
        // relative step of 1e-7: figures agree to a few 1e-6.
        EXPECT_NEAR(fit->curve_minimum.value / unit, base->curve_minimum.value,
                    1e-4 * base->curve_minimum.value)
            << "seed " << seed << " unit " << unit;
        EXPECT_NEAR(fit->white_asymptote.sigma / unit, base->white_asymptote.sigma,
                    2e-2 * base->white_asymptote.sigma)
            << "seed " << seed << " unit " << unit;
      }
    }
  }
}

// A term swapped into a model that collapses to nothing leaves the smaller
// model, which is not a rival of itself: on these records of the
// Gauss-Markov mixture (fit_coverage_bench's seeds 451 and 488) the swaps
// once gave N+K+GM, N+B+GM and N+R+GM, each N+GM with a dead third term at
// one criterion, and a rate random walk of exactly 0 with u 0 "averaged
// over the plausible models". Every term of the selected model is alive and
// every IEEE figure it carries has a u.
TEST(CompositeFitTest, ATermCollapsedToNothingIsTheSmallerModel) {
  const pb::AxisTruth gm = sim::PlainMixtures()[1].truth;
  for (int s : {451, 488}) {
    auto curve = sim::StationCurve(gm, 0xc0fe + 7919ull * s, kSamples, kRateHz);
    ASSERT_TRUE(curve.ok()) << curve.status().message();
    allan::GmwmOptions options;
    options.stop = allan::StopRule::kNone;
    auto fit = allan::FitCompositeModel(*curve, options);
    ASSERT_TRUE(fit.ok()) << fit.status().message();
    for (const allan::FittedTerm& t : fit->terms) {
      EXPECT_GT(t.term.scale, 0) << "seed " << s << " " << fit->model.Name();
    }
    constexpr TermKind kIeee[] = {TermKind::kQuantization, TermKind::kWhite, TermKind::kFlicker,
                                  TermKind::kRandomWalk, TermKind::kDrift};
    for (size_t i = 0; i < fit->ieee_terms.size(); ++i) {
      if (fit->model.CountOf(kIeee[i]) == 0) continue;  // absent: reported as 0 with no sigma
      EXPECT_GT(fit->ieee_terms[i].value, 0)
          << "seed " << s << " term " << i << " " << fit->model.Name();
      EXPECT_GT(fit->ieee_terms[i].sigma, 0)
          << "seed " << s << " term " << i << " " << fit->model.Name();
    }
    // And the drop rule holds among the candidates listed: no candidate is
    // a smaller listed one plus a dead term (the same J). (The failure above
    // was the smaller model missing from the list, which this cannot see.)
    for (const allan::ModelCandidate& a : fit->candidates) {
      for (const allan::ModelCandidate& b : fit->candidates) {
        if (a.parameters >= b.parameters) continue;
        bool nested = true;
        for (const allan::ModelTerm& t : a.model.terms) {
          nested = nested && b.model.CountOf(t.kind) >= a.model.CountOf(t.kind);
        }
        if (nested) {
          EXPECT_GT(std::abs(a.objective - b.objective), 1e-9 * (1 + a.objective))
              << "seed " << s << ": " << b.name << " is " << a.name;
        }
      }
    }
  }
}

}  // namespace
}  // namespace imuqual
