#include "analyze/allan/tau_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/estimators.h"
#include "analyze/allan/long_tau.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {
namespace {

using Kind = TauGridSpec::Kind;
using M = std::vector<int64_t>;

constexpr Deviation kAllDeviations[] = {
    Deviation::kAdev,   Deviation::kOadev, Deviation::kMdev,    Deviation::kTdev,
    Deviation::kHdev,   Deviation::kOhdev, Deviation::kTotdev,  Deviation::kTheo1,
    Deviation::kTheoBr, Deviation::kTheoH, Deviation::kMtotdev, Deviation::kTtotdev,
    Deviation::kHtotdev};

// Whether the estimator has a point at m at all (long_tau.h: Theo1 and TheoBR
// at even m, TheoH's Allan part below floor((N-1)/5) and its even Theo part).
bool HasPoint(Deviation dev, int64_t m, int64_t n_phase) {
  if (dev == Deviation::kTheo1 || dev == Deviation::kTheoBr) return m % 2 == 0;
  if (dev == Deviation::kTheoH) return TheoHHasPoint(m, n_phase);
  return true;
}

TauGridSpec Grid(std::string_view text) {
  Result<TauGridSpec> grid = ParseTauGrid(text);
  EXPECT_TRUE(grid.ok()) << text << ": " << grid.status().ToString();
  return grid.ok() ? *grid : TauGridSpec{};
}

// The raw grid clipped to 0 < m < N: TOTDEV has no upper limit of its own
// (n = N - 2 for every m < N), so with kNone it shows the whole grid.
M RawGrid(std::string_view text, int64_t n_phase, double tau0 = 1.0) {
  return AveragingFactors(Grid(text), tau0, n_phase, Deviation::kTotdev, StopRule::kNone);
}

TEST(ParseTauGrid, NamedGrids) {
  EXPECT_EQ(Grid("octave").kind, Kind::kOctave);
  EXPECT_EQ(Grid("decade").kind, Kind::kDecade);
  EXPECT_EQ(Grid("all").kind, Kind::kAll);
  EXPECT_EQ(Grid(" octave ").kind, Kind::kOctave);
  const TauGridSpec log10 = Grid("log10");
  EXPECT_EQ(log10.kind, Kind::kLogDense);
  EXPECT_EQ(log10.points_per_decade, 10);
  EXPECT_EQ(Grid("log3").points_per_decade, 3);
}

TEST(ParseTauGrid, ExplicitTaus) {
  const TauGridSpec grid = Grid("1,2,5.5");
  EXPECT_EQ(grid.kind, Kind::kExplicit);
  EXPECT_EQ(grid.tau_s, (std::vector<double>{1, 2, 5.5}));
  EXPECT_EQ(Grid(" 0.01 , 1e3 ").tau_s, (std::vector<double>{0.01, 1000}));
  EXPECT_EQ(Grid("7").tau_s, (std::vector<double>{7}));
}

TEST(ParseTauGrid, ErrorsNameTheBadText) {
  for (const std::string text :
       {"", "octaves", "log", "log0", "logx", "1,,2", "1,-2", "1,x", "0", "nan", "inf", "1;2"}) {
    const Result<TauGridSpec> grid = ParseTauGrid(text);
    EXPECT_FALSE(grid.ok()) << "'" << text << "' accepted";
    if (!grid.ok()) {
      EXPECT_EQ(grid.status().code(), Status::Code::kInvalidArgument);
      EXPECT_NE(grid.status().message().find("'" + text + "'"), std::string::npos)
          << grid.status().message();
    }
  }
  EXPECT_NE(ParseTauGrid("1,x").status().message().find("'x'"), std::string::npos);
}

TEST(ParseTauGrid, NameRoundTrips) {
  for (const std::string text : {"octave", "decade", "all", "log7", "1,2,5.5"}) {
    EXPECT_EQ(TauGridName(Grid(text)), text);
  }
}

TEST(AveragingFactors, ReferenceGridExamples) {
  // tests/reference/NOTES.md, "Tau grids".
  EXPECT_EQ(RawGrid("octave", 10001),
            (M{1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192}));
  EXPECT_EQ(RawGrid("decade", 10001),
            (M{1, 2, 4, 10, 20, 40, 100, 200, 400, 1000, 2000, 4000, 10000}));
  EXPECT_EQ(RawGrid("octave", 1001), (M{1, 2, 4, 8, 16, 32, 64, 128, 256, 512}));
  EXPECT_EQ(RawGrid("decade", 1001), (M{1, 2, 4, 10, 20, 40, 100, 200, 400, 1000}));
  EXPECT_EQ(RawGrid("octave", 10), (M{1, 2, 4, 8}));
  EXPECT_EQ(RawGrid("decade", 10), (M{1, 2, 4}));
  // Exact powers: N = 1024 keeps m = 1024 out (m < N) but includes 512.
  EXPECT_EQ(RawGrid("octave", 1024).back(), 512);
  EXPECT_EQ(RawGrid("decade", 1000).back(), 400);
  EXPECT_EQ(RawGrid("all", 6), (M{1, 2, 3, 4, 5}));
}

TEST(AveragingFactors, LogDenseFollowsRoundedLogspace) {
  // round(logspace(0, log10 N, floor(P log10 N))), clipped to m < N and
  // de-duplicated (values worked out independently for these N and P).
  EXPECT_EQ(RawGrid("log5", 1001), (M{1, 2, 3, 4, 7, 12, 19, 32, 52, 85, 139, 228, 373, 611}));
  EXPECT_EQ(RawGrid("log10", 10001),
            (M{1,   2,   3,   4,    5,    7,    8,    11,   13,   17,   22,   27,
               35,  44,  55,  70,   89,   113,  143,  180,  229,  289,  367,  464,
               588, 744, 943, 1194, 1512, 1915, 2425, 3071, 3889, 4924, 6236, 7897}));
}

TEST(AveragingFactors, ExplicitTausRoundToTheNearestM) {
  // tau0 = 0.01 s: 0.5 s -> 50, 1.004 s -> 100 (duplicate), 0.001 s -> 0
  // (dropped), 1e9 s -> beyond the record (dropped).
  EXPECT_EQ(RawGrid("0.5,1,1.004,0.001,1e9,0.026", 100001, 0.01), (M{3, 50, 100}));
}

TEST(AveragingFactors, PerEstimatorLimitsAreExactlyWhereNDropsToOne) {
  // GIVEN records of every small length (and a few past TheoBR's 90 points),
  // WHEN every m is evaluated, THEN a point survives (n > 1) exactly when
  // m <= MaxAveragingFactor and the estimator has a point at m.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  std::vector<int64_t> lengths;
  for (int64_t n_phase = 2; n_phase <= 40; ++n_phase) lengths.push_back(n_phase);
  for (int64_t n_phase : {89, 90, 91, 120}) lengths.push_back(n_phase);
  for (int64_t n_phase : lengths) {
    std::vector<double> x(static_cast<size_t>(n_phase));
    for (double& v : x) v = normal(rng);
    const PhaseRecord phase = PhaseFromPhase(x, 1.0);
    for (Deviation dev : kAllDeviations) {
      for (int64_t m = 1; m < n_phase; ++m) {
        const bool kept = ComputeDeviationAt(phase, dev, m).n > 1;
        EXPECT_EQ(kept, m <= MaxAveragingFactor(dev, n_phase) && HasPoint(dev, m, n_phase))
            << DeviationName(dev) << " N=" << n_phase << " m=" << m;
      }
    }
  }
}

TEST(AveragingFactors, LargestMKeptMatchesTheReferenceTable) {
  // NOTES.md: largest m with taus='all' at N = 10, 1001, 10001.
  struct Case {
    Deviation dev;
    int64_t n_phase;
    int64_t m_max;
  };
  const Case cases[] = {
      {Deviation::kAdev, 10001, 3333},  {Deviation::kOadev, 10001, 4999},
      {Deviation::kMdev, 10001, 3333},  {Deviation::kHdev, 10001, 2500},
      {Deviation::kOhdev, 10001, 3333}, {Deviation::kTotdev, 10001, 10000},
      {Deviation::kOadev, 10, 4},       {Deviation::kAdev, 10, 3},
  };
  for (const Case& c : cases) {
    const M m = AveragingFactors(Grid("all"), 1.0, c.n_phase, c.dev, StopRule::kNone);
    ASSERT_FALSE(m.empty());
    EXPECT_EQ(m.back(), c.m_max) << DeviationName(c.dev) << " N=" << c.n_phase;
    EXPECT_EQ(static_cast<int64_t>(m.size()), c.m_max);
  }
}

TEST(AveragingFactors, StopRules) {
  const TauGridSpec octave = Grid("octave");
  // bins9: m <= floor((N-1)/9) = 1111 for N = 10001.
  EXPECT_EQ(AveragingFactors(octave, 1.0, 10001, Deviation::kOadev, StopRule::kBins9).back(), 1024);
  EXPECT_EQ(AveragingFactors(Grid("all"), 1.0, 10001, Deviation::kOadev, StopRule::kBins9).back(),
            1111);
  // Stable32 ratios on PHASE.DAT (N = 1001), as in its octave tables.
  EXPECT_EQ(AveragingFactors(octave, 1.0, 1001, Deviation::kAdev, StopRule::kStable32).back(), 128);
  EXPECT_EQ(AveragingFactors(octave, 1.0, 1001, Deviation::kOadev, StopRule::kStable32).back(),
            128);
  EXPECT_EQ(AveragingFactors(octave, 1.0, 1001, Deviation::kTotdev, StopRule::kStable32).back(),
            256);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kAdev, 1001), 200);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kHdev, 1001), 200);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kMdev, 1001), 250);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kOhdev, 1001), 250);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kTotdev, 1001), 500);
  // kNone: only the per-estimator limit.
  EXPECT_EQ(AveragingFactors(octave, 1.0, 10001, Deviation::kOadev, StopRule::kNone).back(), 4096);
}

TEST(AveragingFactors, LongTauOctaveGridsMatchTheReferenceFiles) {
  // The last rows of tests/reference/results/*_{theo1,mtotdev,htotdev}_octave.csv.
  const TauGridSpec octave = Grid("octave");
  EXPECT_EQ(AveragingFactors(octave, 1.0, 10001, Deviation::kTheo1, StopRule::kNone),
            (M{2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192}));
  EXPECT_EQ(AveragingFactors(octave, 1.0, 1001, Deviation::kTheo1, StopRule::kNone).back(), 512);
  for (Deviation dev : {Deviation::kMtotdev, Deviation::kTtotdev, Deviation::kHtotdev}) {
    EXPECT_EQ(AveragingFactors(octave, 1.0, 10001, dev, StopRule::kNone).back(), 2048);
    EXPECT_EQ(AveragingFactors(octave, 1.0, 1001, dev, StopRule::kNone).back(), 256);
  }
}

TEST(AveragingFactors, TheoFamilyHasEvenFactorsAndStopsOnItsEffectiveTau) {
  const TauGridSpec all = Grid("all");
  const M theo1 = AveragingFactors(all, 1.0, 1001, Deviation::kTheo1, StopRule::kNone);
  ASSERT_EQ(theo1.size(), 500u);  // 2, 4, ..., 1000
  for (int64_t m : theo1) EXPECT_EQ(m % 2, 0);
  // bins9 bounds the effective tau 0.75 m tau0 by floor((N-1)/9) tau0 = 1111 tau0.
  EXPECT_EQ(AveragingFactors(all, 1.0, 10001, Deviation::kTheo1, StopRule::kBins9).back(), 1480);
  EXPECT_EQ(
      AveragingFactors(Grid("octave"), 1.0, 10001, Deviation::kTheoBr, StopRule::kBins9).back(),
      1024);
  // TheoH: the Allan part m < floor(0.2 (N-1)) = 200, then even m with
  // 0.75 m >= 200, i.e. from 268; nothing in between.
  const M theoh = AveragingFactors(all, 1.0, 1001, Deviation::kTheoH, StopRule::kNone);
  const auto first_theo = std::find(theoh.begin(), theoh.end(), 268);
  ASSERT_NE(first_theo, theoh.end());
  EXPECT_EQ(*(first_theo - 1), 199);
  EXPECT_EQ(first_theo - theoh.begin(), 199);
  EXPECT_EQ(theoh.end() - first_theo, (1000 - 268) / 2 + 1);
  // Stable32 stop ratios: 1 for the Theo family, 3 for the TOT family.
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kTheoH, 1001), 1001);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kMtotdev, 1001), 333);
  EXPECT_EQ(StopRuleMaxAveragingFactor(StopRule::kStable32, Deviation::kHtotdev, 1001), 333);
}

TEST(AveragingFactors, DegenerateRecords) {
  EXPECT_TRUE(AveragingFactors(Grid("octave"), 1.0, 0, Deviation::kOadev, StopRule::kNone).empty());
  EXPECT_TRUE(AveragingFactors(Grid("octave"), 1.0, 3, Deviation::kOadev, StopRule::kNone).empty());
  EXPECT_TRUE(
      AveragingFactors(Grid("octave"), 0.0, 1000, Deviation::kOadev, StopRule::kNone).empty());
  EXPECT_TRUE(
      AveragingFactors(Grid("octave"), 1.0, 100, Deviation::kOadev, StopRule::kBins9).size() ==
      4u);  // m <= 11: 1, 2, 4, 8
}

TEST(Names, RoundTripAndRejectUnknown) {
  for (Deviation dev : kAllDeviations) EXPECT_EQ(ParseDeviation(DeviationName(dev)), dev);
  for (StopRule stop : {StopRule::kBins9, StopRule::kStable32, StopRule::kNone}) {
    EXPECT_EQ(ParseStopRule(StopRuleName(stop)), stop);
  }
  for (CiMethod ci : {CiMethod::kNone, CiMethod::kSimple, CiMethod::kChi2}) {
    EXPECT_EQ(ParseCiMethod(CiMethodName(ci)), ci);
  }
  EXPECT_EQ(DeviationName(Deviation::kOadev), "oadev");
  EXPECT_EQ(DeviationName(Deviation::kTotdev), "totdev");
  EXPECT_EQ(DeviationName(Deviation::kTheo1), "theo1");
  EXPECT_EQ(DeviationName(Deviation::kTheoBr), "theobr");
  EXPECT_EQ(DeviationName(Deviation::kTheoH), "theoh");
  EXPECT_EQ(DeviationName(Deviation::kMtotdev), "mtotdev");
  EXPECT_EQ(DeviationName(Deviation::kTtotdev), "ttotdev");
  EXPECT_EQ(DeviationName(Deviation::kHtotdev), "htotdev");
  EXPECT_EQ(StopRuleName(StopRule::kBins9), "bins9");
  EXPECT_EQ(CiMethodName(CiMethod::kChi2), "chi2");
  EXPECT_FALSE(ParseDeviation("allan").has_value());
  EXPECT_FALSE(ParseStopRule("9bins").has_value());
  EXPECT_FALSE(ParseCiMethod("CHI2").has_value());
}

}  // namespace
}  // namespace imuqual::allan
