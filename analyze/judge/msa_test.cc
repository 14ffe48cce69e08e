// The MSA ANOVA: exact on a study whose components are known without noise,
// refuses unbalanced studies by name, and over 200 simulated studies of 10
// golden units on 4 stations with known offsets recovers each station's
// offset within its 95 % interval about 95 % of the time.
#include "analyze/judge/msa.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace imuqual::judge {
namespace {

MsaStudy Empty(int parts, int stations) {
  MsaStudy s;
  for (int i = 0; i < parts; ++i) s.parts.push_back("U" + std::to_string(i));
  for (int j = 0; j < stations; ++j) s.stations.push_back("st-" + std::to_string(j));
  s.values.assign(parts, std::vector<std::vector<double>>(stations));
  return s;
}

TEST(MsaTest, ComponentsOfANoiselessStudyAreExact) {
  // value = part + station offset, the same in both trials: no
  // repeatability, no interaction; stations -1 and +1.
  MsaStudy s = Empty(3, 2);
  const double part[] = {10, 20, 30}, station[] = {-1, 1};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 2; ++j) s.values[i][j] = {part[i] + station[j], part[i] + station[j]};
  }
  s.low = 0;
  s.high = 60;
  auto m = AnalyzeMsa(s);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_DOUBLE_EQ(m->mean, 20);
  EXPECT_DOUBLE_EQ(m->ev, 0);
  EXPECT_DOUBLE_EQ(m->interaction, 0);
  EXPECT_TRUE(m->interaction_pooled);
  // Sample variance of the station means: ((-1)^2 + 1^2) / (2 - 1) = 2.
  EXPECT_NEAR(m->av, std::sqrt(2.0), 1e-12);
  // Of the part means: (100 + 0 + 100) / 2 = 100.
  EXPECT_NEAR(m->pv, 10, 1e-12);
  EXPECT_NEAR(m->grr, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(m->percent_grr_tolerance, 100 * 6 * std::sqrt(2.0) / 60, 1e-9);
  EXPECT_EQ(m->tolerance_basis, "USL - LSL");
  EXPECT_EQ(m->ndc, static_cast<int>(std::floor(1.41 * 10 / std::sqrt(2.0))));
  ASSERT_EQ(m->offsets.size(), 2u);
  EXPECT_DOUBLE_EQ(m->offsets[0].offset, -1);
  EXPECT_DOUBLE_EQ(m->offsets[1].offset, 1);
}

TEST(MsaTest, AnUnbalancedOrTooSmallStudyIsRefusedByName) {
  MsaStudy s = Empty(2, 2);
  s.values = {{{1, 2}, {1, 2}}, {{1, 2}, {1}}};
  auto m = AnalyzeMsa(s);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("unit U1 on st-1: 1 trials, others 2"), std::string::npos)
      << m.status().message();
  EXPECT_FALSE(AnalyzeMsa(Empty(1, 2)).ok());
  EXPECT_FALSE(AnalyzeMsa(Empty(2, 1)).ok());
}

TEST(MsaTest, InjectedStationOffsetsAreRecoveredWithinTheirIntervals) {
  // 10 golden units (part sd 5), 4 stations offset by +2, -1, 0, +0.5,
  // 3 trials each (repeatability sd 1), a small unit-by-station interaction
  // (sd 0.3). 200 studies.
  const double offsets[] = {2, -1, 0, 0.5};
  const double mean_offset = (2 - 1 + 0 + 0.5) / 4;
  std::mt19937_64 rng(20261128);
  std::normal_distribution<double> unit(0, 5), repeat(0, 1), inter(0, 0.3);
  int covered = 0, intervals = 0, flagged_plus_two = 0;
  double grr_sum = 0;
  constexpr int kStudies = 200;
  for (int k = 0; k < kStudies; ++k) {
    MsaStudy s = Empty(10, 4);
    for (int i = 0; i < 10; ++i) {
      const double part = 100 + unit(rng);
      for (int j = 0; j < 4; ++j) {
        const double cell = part + offsets[j] + inter(rng);
        for (int t = 0; t < 3; ++t) s.values[i][j].push_back(cell + repeat(rng));
      }
    }
    auto m = AnalyzeMsa(s);
    ASSERT_TRUE(m.ok());
    for (int j = 0; j < 4; ++j) {
      const double truth = offsets[j] - mean_offset;
      covered += m->offsets[j].low <= truth && truth <= m->offsets[j].high;
      ++intervals;
    }
    flagged_plus_two += m->offsets[0].differs;
    grr_sum += m->grr;
  }
  const double coverage = static_cast<double>(covered) / intervals;
  std::printf("offset intervals: coverage %.3f of %d (95 %% nominal); mean GRR %.3f\n", coverage,
              intervals, grr_sum / kStudies);
  EXPECT_GE(coverage, 0.90) << "95 % intervals cover the injected offsets " << coverage;
  EXPECT_LE(coverage, 0.99) << "intervals too wide: " << coverage;
  // The station reading 2 high (1.625 above the fleet, ~8 standard errors)
  // is named every time.
  EXPECT_EQ(flagged_plus_two, kStudies);
  // GRR: sqrt(repeat^2 + interaction^2 + var of the offsets (sample, n-1)).
  double var_off = 0;
  for (double o : offsets) var_off += (o - mean_offset) * (o - mean_offset) / 3;
  const double grr_true = std::sqrt(1 + 0.09 + var_off);
  EXPECT_NEAR(grr_sum / kStudies, grr_true, 0.15 * grr_true);
}

}  // namespace
}  // namespace imuqual::judge
