#include "analyze/allan/tau_grid.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/estimators.h"
#include "analyze/allan/phase.h"

namespace imuqual::allan {
namespace {

using Kind = TauGridSpec::Kind;
using M = std::vector<int64_t>;

constexpr Deviation kAllDeviations[] = {Deviation::kAdev,  Deviation::kOadev, Deviation::kMdev,
                                        Deviation::kTdev,  Deviation::kHdev,  Deviation::kOhdev,
                                        Deviation::kTotdev};

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
  // GIVEN records of every small length, WHEN every m is evaluated, THEN a
  // point survives (n > 1) exactly when m <= MaxAveragingFactor.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  for (int64_t n_phase = 2; n_phase <= 40; ++n_phase) {
    std::vector<double> x(static_cast<size_t>(n_phase));
    for (double& v : x) v = normal(rng);
    const PhaseRecord phase = PhaseFromPhase(x, 1.0);
    for (Deviation dev : kAllDeviations) {
      for (int64_t m = 1; m < n_phase; ++m) {
        const bool kept = ComputeDeviationAt(phase, dev, m).n > 1;
        EXPECT_EQ(kept, m <= MaxAveragingFactor(dev, n_phase))
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
  EXPECT_EQ(StopRuleName(StopRule::kBins9), "bins9");
  EXPECT_EQ(CiMethodName(CiMethod::kChi2), "chi2");
  EXPECT_FALSE(ParseDeviation("allan").has_value());
  EXPECT_FALSE(ParseStopRule("9bins").has_value());
  EXPECT_FALSE(ParseCiMethod("CHI2").has_value());
}

}  // namespace
}  // namespace imuqual::allan
