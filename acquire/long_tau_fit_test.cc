// The noise-model fit with Theo1 moments beyond the Allan range (gmwm.h's
// long_taus): the moments' correlations and Theo1's edf against Monte Carlo,
// and the fit on records whose rate random walk lies beyond the stop rule's
// T/9, where OADEV alone cannot see it.
#include <gtest/gtest.h>

#include <boost/math/special_functions/digamma.hpp>
#include <boost/math/special_functions/trigamma.hpp>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/confidence.h"
#include "analyze/allan/estimators.h"
#include "analyze/allan/gmwm.h"
#include "analyze/allan/long_tau.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual {
namespace {

using allan::CompositeModel;
using allan::ModelTerm;
using allan::TermKind;

constexpr double kTau0 = 1.0;
constexpr int64_t kSamples = 8192;

// White rate noise N = 1 plus a rate random walk K (increments K sqrt(tau0)).
allan::PhaseRecord WhiteAndWalk(double k, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<double> rate(kSamples);
  double walk = 0;
  for (double& v : rate) {
    walk += k * std::sqrt(kTau0) * g(rng);
    v = g(rng) / std::sqrt(kTau0) + walk;
  }
  return allan::PhaseFromRate(rate, kTau0);
}

CompositeModel Truth(double k) {
  return CompositeModel{{ModelTerm{TermKind::kWhite, 1.0}, ModelTerm{TermKind::kRandomWalk, k}}};
}

TEST(LongTauFitTest, MomentCorrelationsAndTheo1EdfMatchMonteCarlo) {
  // GIVEN 400 records of 8192 samples each of white rate noise, a rate
  // random walk, and both with the Allan minimum at 1024 s (beyond T/9),
  // WHEN ln OAVAR at octaves to 512 s and ln Theo1 at the three octaves
  // beyond (m 1366, 2730, 5462: r = 0.125, 0.25, 0.5 N) are computed,
  // THEN every correlation with a Theo1 moment is the model's
  // (MomentCorrelationMatrix) within 0.15 (the Monte Carlo's se is <= 0.05;
  // the windows' covariance is asymptotic, and the largest difference, 0.14,
  // is white noise's between the two longest points, where the record's
  // ends matter),
  // and for the pure noises the spread and mean of ln Theo1 are those of
  // ln(chi2_nu / nu) with the fit's edf; for the mixture the edf of the
  // model's dominant noise is conservative (sd at most 1.1 of the stated).
  const std::vector<int64_t> am = {1, 4, 16, 64, 256, 512};
  const std::vector<int64_t> tm = allan::Theo1OctavesBeyond(512, kTau0, kSamples);
  ASSERT_EQ(tm, (std::vector<int64_t>{1366, 2730, 5462}));
  std::vector<int64_t> all = am;
  all.insert(all.end(), tm.begin(), tm.end());
  std::vector<char> theo1(all.size(), 0);
  for (size_t j = am.size(); j < all.size(); ++j) theo1[j] = 1;
  const size_t n = all.size();
  constexpr int kRecords = 400;
  struct Case {
    const char* name;
    double k;
    bool pure;
  };
  for (const Case& c : {Case{"white", 1e-5, true}, Case{"random walk", 0.3, true},
                        Case{"white + walk", std::sqrt(3.0) / 1024, false}}) {
    SCOPED_TRACE(c.name);
    const CompositeModel truth = Truth(c.k);
    std::vector<std::vector<double>> v(n);
    for (int s = 0; s < kRecords; ++s) {
      const allan::PhaseRecord phase = WhiteAndWalk(c.k, 5000 + s);
      const allan::Curve a = allan::ComputeDeviation(phase, allan::Deviation::kOadev, am);
      const allan::Curve t = allan::ComputeDeviation(phase, allan::Deviation::kTheo1, tm);
      for (size_t j = 0; j < am.size(); ++j) v[j].push_back(2 * std::log(a.points[j].dev));
      for (size_t j = 0; j < tm.size(); ++j) {
        v[am.size() + j].push_back(2 * std::log(t.points[j].dev));
      }
    }
    std::vector<double> mean(n, 0.0), sd(n, 0.0);
    for (size_t j = 0; j < n; ++j) {
      for (double x : v[j]) mean[j] += x / kRecords;
      for (double x : v[j]) sd[j] += (x - mean[j]) * (x - mean[j]) / (kRecords - 1);
      sd[j] = std::sqrt(sd[j]);
    }
    const std::vector<double> model = allan::MomentCorrelationMatrix(truth, kTau0, all, theo1);
    for (size_t a = 0; a < n; ++a) {
      for (size_t b = a + 1; b < n; ++b) {
        if (!theo1[a] && !theo1[b]) continue;
        double r = 0;
        for (int s = 0; s < kRecords; ++s) r += (v[a][s] - mean[a]) * (v[b][s] - mean[b]);
        r /= (kRecords - 1) * sd[a] * sd[b];
        EXPECT_NEAR(r, model[a * n + b], 0.15) << "m " << all[a] << " with m " << all[b];
      }
    }
    for (size_t j = am.size(); j < n; ++j) {
      const double edf = *allan::Theo1MomentEdf(truth, kTau0, all[j], kSamples);
      const double stated_sd = std::sqrt(boost::math::trigamma(edf / 2));
      const double offset = mean[j] - std::log(truth.ExpectedTheo1(all[j], kTau0));
      const double stated_offset = boost::math::digamma(edf / 2) - std::log(edf / 2);
      std::printf("%s m %lld: sd of ln Theo1 %.3f (stated %.3f), E ln - ln E %+.3f (%+.3f)\n",
                  c.name, static_cast<long long>(all[j]), sd[j], stated_sd, offset, stated_offset);
      if (c.pure) {
        EXPECT_NEAR(sd[j], stated_sd, 0.15 * stated_sd) << "m " << all[j];
        EXPECT_NEAR(offset, stated_offset, 3 * sd[j] / std::sqrt(kRecords) + 0.03)
            << "m " << all[j];
      } else {
        EXPECT_LE(sd[j], 1.1 * stated_sd) << "m " << all[j];
      }
    }
  }
}

TEST(LongTauFitTest, BadTheo1MomentsAreOneLineErrors) {
  const allan::PhaseRecord phase = WhiteAndWalk(0.001, 1);
  const std::vector<int64_t> m =
      allan::AveragingFactors(allan::TauGridSpec{}, phase.tau0_s, phase.size(),
                              allan::Deviation::kOadev, allan::StopRule::kBins9);
  const allan::Curve curve = allan::ComputeDeviation(phase, allan::Deviation::kOadev, m);
  struct Bad {
    allan::Theo1Moment moment;
    std::string error;
  };
  for (const Bad& b :
       {Bad{{1367, 1e-3, 0}, "Theo1 moment at m 1367: m must be even in [2, 8192]"},
        Bad{{9000, 1e-3, 0}, "Theo1 moment at m 9000: m must be even in [2, 8192]"},
        Bad{{1366, 0.0, 0}, "Theo1 moment at m 1366: Theo1 must be positive and finite, got 0"},
        Bad{{1366, std::nan(""), 0},
            "Theo1 moment at m 1366: Theo1 must be positive and finite, got nan"},
        Bad{{1366, 1e-3, 0, 0}, "Theo1 moment at m 1366: block must be at least 1, got 0"},
        Bad{{1366, 1e-3, 0, 8}, "Theo1 moment at m 1366: m must be even in [2, 1024]"},
        Bad{{600, 1e-3, 0},
            "Theo1 moment at m 600: its tau 450 s must lie beyond the last fitted tau 512 s"}}) {
    const std::vector<allan::Theo1Moment> moments = {b.moment};
    auto fit = allan::FitCompositeModel(curve, {}, moments);
    ASSERT_FALSE(fit.ok());
    EXPECT_EQ(fit.status().message(), b.error);
  }
}

// Every `block`-th point of a phase record: the phase of its means of
// `block` samples (what a station keeps, BinAccumulator::MeansPhase).
allan::PhaseRecord PhaseOfMeans(const allan::PhaseRecord& phase, int64_t block) {
  allan::PhaseRecord out;
  out.tau0_s = phase.tau0_s * static_cast<double>(block);
  for (int64_t i = 0; i < phase.size(); i += block) out.x.push_back(phase.x[i]);
  return out;
}

TEST(LongTauFitTest, Theo1MomentsSeeARandomWalkBeyondTheAllanRange) {
  // GIVEN 24 records of 8192 s of white rate noise and a rate random walk
  // whose Allan minimum (0.0442 at 1024 s) lies beyond T/9 = 910 s,
  // WHEN the model is fitted to OADEV alone, with the Theo1 moments at the
  // octaves beyond (1024 and 2048 s: the moments' reach is 0.3 T), and with
  // the same moments of the record's 8-sample means (block 8: what a
  // station keeps),
  // THEN OADEV alone rarely selects a long-tau term and reads the minimum at
  // the edge, high (mean z ~ +1, covering the truth at 1 sigma in a few
  // records), while with the moments the model reaches the walk in part of
  // the records, the minimum's mean z is near 0 and its 1-sigma coverage
  // rises; the means' moments do about as well as the samples'. (A record
  // of 8 minimum-lengths carries one or two sigmas of evidence for the
  // walk: the selection cannot always see it.)
  const double k = std::sqrt(3.0) / 1024;
  const double true_min = std::sqrt(Truth(k).Avar(1024, kTau0));
  constexpr int kRecords = 24;
  constexpr int64_t kBlock = 8;
  int long_terms[3] = {0, 0, 0}, covered[3] = {0, 0, 0}, covered2[3] = {0, 0, 0};
  double mean_z[3] = {0, 0, 0};
  for (int s = 0; s < kRecords; ++s) {
    const allan::PhaseRecord phase = WhiteAndWalk(k, 500 + s);
    const std::vector<int64_t> m =
        allan::AveragingFactors(allan::TauGridSpec{}, phase.tau0_s, phase.size(),
                                allan::Deviation::kOadev, allan::StopRule::kBins9);
    allan::Curve curve = allan::ComputeDeviation(phase, allan::Deviation::kOadev, m);
    allan::AttachConfidence(phase, allan::CiMethod::kChi2, allan::kOneSigmaConfidence, &curve);
    const std::vector<allan::Theo1Moment> moments[3] = {
        {},
        allan::Theo1MomentsBeyond(phase, curve.points.back().tau_s),
        allan::Theo1MomentsBeyond(PhaseOfMeans(phase, kBlock), curve.points.back().tau_s, kBlock)};
    ASSERT_EQ(moments[1].size(), 2u);
    ASSERT_EQ(moments[2].size(), 2u);
    for (int with = 0; with < 3; ++with) {
      if (with == 2) {
        // The same effective taus, but for m's rounding to an even count
        // of means (m counts means).
        for (size_t j = 0; j < 2; ++j) {
          EXPECT_LE(std::abs(moments[2][j].m * kBlock - moments[1][j].m), 2 * kBlock);
        }
      }
      auto fit = allan::FitCompositeModel(curve, {}, moments[with]);
      ASSERT_TRUE(fit.ok()) << fit.status().message();
      EXPECT_EQ(fit->points.size(), curve.points.size() + moments[with].size());
      EXPECT_EQ(fit->points.back().theo1, with > 0);
      long_terms[with] +=
          fit->model.CountOf(TermKind::kRandomWalk) > 0 || fit->model.CountOf(TermKind::kDrift) > 0;
      const double z = (fit->curve_minimum.value - true_min) / fit->curve_minimum.sigma;
      mean_z[with] += z / kRecords;
      covered[with] += std::abs(z) < 1;
      covered2[with] += std::abs(z) < 2;
    }
  }
  std::printf(
      "walk beyond T/9: K or R selected %d / %d / %d of %d records (OADEV / with Theo1 / with "
      "Theo1 of %lld-sample means); minimum's mean z %+.2f / %+.2f / %+.2f, 1-sigma coverage "
      "%d / %d / %d, 2-sigma %d / %d / %d\n",
      long_terms[0], long_terms[1], long_terms[2], kRecords, static_cast<long long>(kBlock),
      mean_z[0], mean_z[1], mean_z[2], covered[0], covered[1], covered[2], covered2[0], covered2[1],
      covered2[2]);
  EXPECT_LE(long_terms[0], 4);
  EXPECT_GT(mean_z[0], 0.5);
  for (int with = 1; with < 3; ++with) {
    EXPECT_GE(long_terms[with], long_terms[0] + 6) << with;
    EXPECT_LT(std::abs(mean_z[with]), 0.75) << with;
    EXPECT_GE(covered[with], covered[0] + 6) << with;
  }
}

}  // namespace
}  // namespace imuqual
