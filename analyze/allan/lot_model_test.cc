// The lot model (lot_model.h) on simulated lots: white noise and a rate
// random walk per unit, the units spread around the lot's values, one unit
// planted with a five times larger random walk.
#include "analyze/allan/lot_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "analyze/allan/estimators.h"
#include "analyze/allan/phase.h"
#include "analyze/allan/tau_grid.h"

namespace imuqual::allan {
namespace {

constexpr double kTau0 = 0.01;
constexpr int kSamples = 1 << 18;    // 44 min at 100 Hz: 15 octave points
constexpr double kN = 0.005;         // deg/s sqrt(s)
constexpr double kK = 2e-4;          // deg/s/sqrt(s)
constexpr double kUnitSpread = 0.1;  // lognormal sd of each unit's N and K

Curve SimulatedCurve(double n, double k, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::vector<double> rate(kSamples);
  double walk = 0;
  for (double& r : rate) {
    walk += k * std::sqrt(kTau0) * g(rng);
    r = n / std::sqrt(kTau0) * g(rng) + walk;
  }
  const PhaseRecord phase = PhaseFromRate(rate, kTau0);
  const std::vector<int64_t> m =
      AveragingFactors(TauGridSpec{}, kTau0, phase.size(), Deviation::kOadev, StopRule::kBins9);
  return ComputeDeviation(phase, Deviation::kOadev, m);
}

struct Lot {
  std::vector<UnitCurve> units;
  double mean_n_squared = 0;          // over every unit
  double typical_mean_n_squared = 0;  // over every unit but the planted one
};

Lot SimulatedLot(int count, int planted, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, kUnitSpread);
  Lot lot;
  for (int u = 0; u < count; ++u) {
    const double n = kN * std::exp(g(rng));
    const double k = kK * std::exp(g(rng)) * (u == planted ? 5.0 : 1.0);
    char name[16];
    std::snprintf(name, sizeof name, "U%d", u + 1);
    lot.units.push_back({name, SimulatedCurve(n, k, seed * 100 + u)});
    lot.mean_n_squared += n * n / count;
    if (u != planted) lot.typical_mean_n_squared += n * n / (planted >= 0 ? count - 1 : count);
  }
  return lot;
}

TEST(LotModelTest, PoolsTheUnitsAndFlagsThePlantedOne) {
  // GIVEN a lot of 10 units, unit 4 with a five-fold random walk.
  const Lot lot = SimulatedLot(10, 3, 7);
  // WHEN the lot model is fitted.
  const Result<LotModel> model = FitLotModel(lot.units);
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  // THEN the model is of the 9 units that belong to the lot, the planted
  // one named as left out (and the all-units fit kept for the record); its
  // white noise is those units' rms N within its stated uncertainty (3
  // sigma), and the model has a random walk.
  EXPECT_EQ(model->units, 9);
  EXPECT_EQ(model->left_out, std::vector<std::string>{"U4"});
  EXPECT_FALSE(model->all_units_model.empty());
  EXPECT_TRUE(std::isfinite(model->all_units_p_value));
  EXPECT_NEAR(model->fit.white_asymptote.value, std::sqrt(lot.typical_mean_n_squared),
              3 * model->fit.white_asymptote.sigma);
  EXPECT_GT(model->fit.model.CountOf(TermKind::kRandomWalk), 0) << model->fit.model.Name();
  // The spread factor reflects the 10 % unit spread at short tau (plus the
  // estimation noise): between 1.02 and 1.3.
  EXPECT_GT(model->points.front().spread_factor, 1.02);
  EXPECT_LT(model->points.front().spread_factor, 1.3);
  // Only the planted unit is flagged, where its random walk shows.
  ASSERT_EQ(model->consistency.size(), 10u);
  for (const UnitConsistency& c : model->consistency) {
    if (c.unit == "U4") {
      EXPECT_FALSE(c.consistent) << c.p_value;
      EXPECT_GT(c.worst_factor, 2.0);
      EXPECT_GT(c.worst_tau_s, 10.0);
    } else {
      EXPECT_TRUE(c.consistent) << c.unit << " p " << c.p_value;
    }
  }
}

// A lot of typical units only: every unit pooled, none left out.
TEST(LotModelTest, AHomogeneousLotPoolsEveryUnit) {
  const Lot lot = SimulatedLot(8, -1, 11);
  const Result<LotModel> model = FitLotModel(lot.units);
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  EXPECT_EQ(model->units, 8);
  EXPECT_TRUE(model->left_out.empty());
  EXPECT_TRUE(model->all_units_model.empty());
  EXPECT_TRUE(model->fit.adequate) << model->fit.model.Name() << " p " << model->fit.p_value;
  EXPECT_NEAR(model->fit.white_asymptote.value, std::sqrt(lot.mean_n_squared),
              3 * model->fit.white_asymptote.sigma);
}

TEST(LotModelTest, RefusesWhatCannotMakeALotModel) {
  Lot lot = SimulatedLot(4, -1, 9);
  std::vector<UnitCurve> three(lot.units.begin(), lot.units.begin() + 3);
  EXPECT_FALSE(FitLotModel(three).ok());
  std::vector<UnitCurve> mixed = lot.units;
  mixed[2].curve.tau0_s = 0.005;
  const Result<LotModel> r = FitLotModel(mixed);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("U3"), std::string::npos) << r.status().message();
  LotModelOptions bad;
  bad.consistency_level = 0;
  EXPECT_FALSE(FitLotModel(lot.units, bad).ok());
  EXPECT_TRUE(FitLotModel(lot.units).ok());
}

}  // namespace
}  // namespace imuqual::allan
