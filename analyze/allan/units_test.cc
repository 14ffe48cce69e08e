#include "analyze/allan/units.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace imuqual::allan {
namespace {

// The worked example of ALGORITHMS.md §3 quotes 3-4 significant figures.
constexpr double kQuotedFiguresRelTol = 2e-3;
// Exact factors (60, 3600, ...) must round-trip to the last bit or so.
constexpr double kRoundTripRelTol = 1e-15;

struct Conversion {
  std::string name;
  double (*convert)(double);
  double (*inverse)(double);  // nullptr when there is none
  double input;
  double expected;
};

class WorkedExampleConversionTest : public ::testing::TestWithParam<Conversion> {};

TEST_P(WorkedExampleConversionTest, MatchesQuotedValueAndRoundTrips) {
  const Conversion& c = GetParam();
  const double out = c.convert(c.input);
  EXPECT_NEAR(out, c.expected, kQuotedFiguresRelTol * std::fabs(c.expected)) << c.name;
  if (c.inverse != nullptr) {
    EXPECT_NEAR(c.inverse(out), c.input, kRoundTripRelTol * std::fabs(c.input)) << c.name;
  }
}

// ALGORITHMS.md §3 "Units" and "Worked example", item 6 and the true values.
INSTANTIATE_TEST_SUITE_P(
    AlgorithmsNote, WorkedExampleConversionTest,
    ::testing::Values(
        // N = 0.005 deg/sqrt(s) = 0.30 deg/sqrt(h) = 18 deg/h/sqrt(Hz) = 8.727e-5 rad/s/sqrt(Hz).
        Conversion{"arw_deg_per_root_hour", DegPerRootSecToDegPerRootHour,
                   DegPerRootHourToDegPerRootSec, 0.005, 0.30},
        Conversion{"arw_deg_per_hour_per_root_hz", DegPerRootSecToDegPerHourPerRootHz,
                   DegPerHourPerRootHzToDegPerRootSec, 0.005, 18.0},
        Conversion{"kalibr_gyroscope_noise_density", DegPerRootSecToRadPerSecPerRootHz, nullptr,
                   0.005, 8.727e-5},
        // B = 5 deg/h = 1.3889e-3 deg/s = 2.424e-5 rad/s.
        Conversion{"bias_deg_per_hour", DegPerSecToDegPerHour, DegPerHourToDegPerSec, 1.3889e-3,
                   5.0},
        Conversion{"bias_rad_per_s", DegPerSecToRadPerSec, nullptr, 5.0 / 3600.0, 2.424e-5},
        // K = 4e-5 deg/s^1.5 = 8.640 deg/h/sqrt(h) = 6.98e-7 rad/s^2/sqrt(Hz).
        Conversion{"rrw_deg_per_hour_per_root_hour", DegPerSecPerRootSecToDegPerHourPerRootHour,
                   DegPerHourPerRootHourToDegPerSecPerRootSec, 4e-5, 8.640},
        Conversion{"kalibr_gyroscope_random_walk", DegPerSecPerRootSecToRadPerSecSqPerRootHz,
                   nullptr, 4e-5, 6.98e-7},
        // R [deg/h^2] = 1.296e7 R [deg/s^2].
        Conversion{"ramp_deg_per_hour_sq", DegPerSecSqToDegPerHourSq, DegPerHourSqToDegPerSecSq,
                   1e-7, 1.296},
        // Accelerometer at 100 ug/sqrt(Hz): VRW = 0.0588 m/s/sqrt(h).
        Conversion{"vrw_from_micro_g",
                   [](double ug) {
                     return MetersPerSecSqPerRootHzToMetersPerSecPerRootHour(
                         MicroGPerRootHzToMetersPerSecSqPerRootHz(ug));
                   },
                   nullptr, 100.0, 0.0588},
        Conversion{"vrw_m_per_s_per_root_hour", MetersPerSecSqPerRootHzToMetersPerSecPerRootHour,
                   MetersPerSecPerRootHourToMetersPerSecSqPerRootHz, 9.80665e-4, 0.0588},
        // B in ug = B / 9.80665e-6.
        Conversion{"accel_bias_micro_g", MetersPerSecSqToMicroG, MicroGToMetersPerSecSq, 9.80665e-5,
                   10.0},
        Conversion{"noise_density_micro_g", MetersPerSecSqPerRootHzToMicroGPerRootHz,
                   MicroGPerRootHzToMetersPerSecSqPerRootHz, 9.80665e-4, 100.0},
        // One-sided ASD = sqrt(2) N.
        Conversion{"one_sided_asd", TwoSidedNoiseDensityToOneSidedAsd,
                   OneSidedAsdToTwoSidedNoiseDensity, 0.005, 0.0070711}),
    [](const ::testing::TestParamInfo<Conversion>& info) { return info.param.name; });

TEST(UnitsTest, WhiteNoiseDensityIsStdDevTimesRootTau0) {
  // 100 Hz samples with sd 0.05 deg/s: N = 0.05 x sqrt(0.01) = 0.005 deg/sqrt(s).
  EXPECT_NEAR(WhiteRateStdDevToNoiseDensity(0.05, 0.01), 0.005, kRoundTripRelTol * 0.005);
}

TEST(UnitsTest, DatasheetUnitsForGyroAndAccelerometer) {
  struct Row {
    NoiseTerm term;
    SensorKind kind;
    double base;
    double expected;
    std::string_view unit;
  };
  const Row rows[] = {
      {NoiseTerm::kQuantization, SensorKind::kGyro, 5e-5, 5e-5, "deg"},
      {NoiseTerm::kAngleRandomWalk, SensorKind::kGyro, 0.005, 0.30, "deg/sqrt(h)"},
      {NoiseTerm::kBiasInstability, SensorKind::kGyro, 1.3889e-3, 5.0, "deg/h"},
      {NoiseTerm::kRateRandomWalk, SensorKind::kGyro, 4e-5, 8.640, "deg/h/sqrt(h)"},
      {NoiseTerm::kRateRamp, SensorKind::kGyro, 1e-7, 1.296, "deg/h^2"},
      {NoiseTerm::kAngleRandomWalk, SensorKind::kAccelerometer, 9.80665e-4, 0.0588, "m/s/sqrt(h)"},
      {NoiseTerm::kBiasInstability, SensorKind::kAccelerometer, 9.80665e-5, 10.0, "ug"},
      {NoiseTerm::kRateRandomWalk, SensorKind::kAccelerometer, 9.80665e-6, 60.0, "ug/sqrt(h)"},
      {NoiseTerm::kRateRamp, SensorKind::kAccelerometer, 9.80665e-6, 3600.0, "ug/h"},
  };
  for (const Row& row : rows) {
    const DatasheetValue v = ToDatasheetUnits(row.term, row.kind, row.base);
    EXPECT_NEAR(v.value, row.expected, kQuotedFiguresRelTol * row.expected)
        << NoiseTermName(row.term);
    EXPECT_EQ(v.unit, row.unit) << NoiseTermName(row.term);
  }
  EXPECT_EQ(BaseUnit(NoiseTerm::kAngleRandomWalk, SensorKind::kGyro), "deg/sqrt(s)");
  EXPECT_EQ(BaseUnit(NoiseTerm::kRateRamp, SensorKind::kAccelerometer), "m/s^3");
}

}  // namespace
}  // namespace imuqual::allan
