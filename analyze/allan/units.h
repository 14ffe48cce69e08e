// Unit conversions for IEEE 952 noise coefficients (ALGORITHMS.md §3 "Units").
//
// The fit works in base units: time in s, rate in deg/s (gyro) or m/s^2
// (accelerometer). Datasheets use hours and micro-g; Kalibr-style YAML uses
// rad. Every function name states the unit it takes and the unit it returns.
// All functions are pure, constexpr where possible and thread-safe.
//
// The sqrt(2) trap: IEEE 952's N^2 is a two-sided PSD level (for white samples
// N = sd(y) sqrt(tau0)). A one-sided amplitude spectral density, as a spectrum
// analyser or many datasheets' "noise density" quote it, is sqrt(2) N. The
// conversions below keep IEEE's two-sided convention unless the name says
// "OneSided".
#ifndef IMUQUAL_ANALYZE_ALLAN_UNITS_H_
#define IMUQUAL_ANALYZE_ALLAN_UNITS_H_

#include <numbers>
#include <span>
#include <string_view>

#include "analyze/allan/noise_model.h"

namespace imuqual::allan {

inline constexpr double kSecondsPerHour = 3600.0;
inline constexpr double kStandardGravityMetersPerSecSq = 9.80665;  // 1 g, m/s^2
inline constexpr double kMicroGInMetersPerSecSq = 9.80665e-6;      // 1 ug, m/s^2
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;

// --- Gyro, base -> datasheet ---------------------------------------------
// Angle random walk: N [deg/sqrt(h)] = 60 N [deg/sqrt(s)] (sqrt(3600 s/h)).
constexpr double DegPerRootSecToDegPerRootHour(double n) { return 60.0 * n; }
// The same N as a rate noise density: deg/sqrt(s) = deg/s/sqrt(Hz), and
// 1 deg/s = 3600 deg/h, so N [deg/h/sqrt(Hz)] = 3600 N [deg/sqrt(s)].
constexpr double DegPerRootSecToDegPerHourPerRootHz(double n) { return kSecondsPerHour * n; }
// Bias instability: B [deg/h] = 3600 B [deg/s].
constexpr double DegPerSecToDegPerHour(double b) { return kSecondsPerHour * b; }
// Rate random walk: K [deg/h/sqrt(h)] = 3600^1.5 K [deg/s/sqrt(s)] = 216000 K.
constexpr double DegPerSecPerRootSecToDegPerHourPerRootHour(double k) { return 216000.0 * k; }
// Rate ramp: R [deg/h^2] = 3600^2 R [deg/s^2] = 1.296e7 R.
constexpr double DegPerSecSqToDegPerHourSq(double r) { return 1.296e7 * r; }

// --- Gyro, datasheet -> base (the inverses) ---------------------------------
constexpr double DegPerRootHourToDegPerRootSec(double n) { return n / 60.0; }
constexpr double DegPerHourPerRootHzToDegPerRootSec(double n) { return n / kSecondsPerHour; }
constexpr double DegPerHourToDegPerSec(double b) { return b / kSecondsPerHour; }
constexpr double DegPerHourPerRootHourToDegPerSecPerRootSec(double k) { return k / 216000.0; }
constexpr double DegPerHourSqToDegPerSecSq(double r) { return r / 1.296e7; }

// --- Accelerometer ---------------------------------------------------------
// Velocity random walk: N [m/s/sqrt(h)] = 60 N [m/s^2/sqrt(Hz)] (= m/s/sqrt(s)).
constexpr double MetersPerSecSqPerRootHzToMetersPerSecPerRootHour(double n) { return 60.0 * n; }
constexpr double MetersPerSecPerRootHourToMetersPerSecSqPerRootHz(double n) { return n / 60.0; }
// Bias instability in micro-g: B [ug] = B [m/s^2] / 9.80665e-6.
constexpr double MetersPerSecSqToMicroG(double b) { return b / kMicroGInMetersPerSecSq; }
constexpr double MicroGToMetersPerSecSq(double b) { return b * kMicroGInMetersPerSecSq; }
// Noise density: 1 ug/sqrt(Hz) = 9.80665e-6 m/s^2/sqrt(Hz).
constexpr double MicroGPerRootHzToMetersPerSecSqPerRootHz(double n) {
  return n * kMicroGInMetersPerSecSq;
}
constexpr double MetersPerSecSqPerRootHzToMicroGPerRootHz(double n) {
  return n / kMicroGInMetersPerSecSq;
}

// --- Kalibr / allan_variance_ros YAML (rad units) ----------------------------
// gyroscope_noise_density [rad/s/sqrt(Hz)] = N [deg/sqrt(s)] x pi/180.
constexpr double DegPerRootSecToRadPerSecPerRootHz(double n) { return n * kRadPerDeg; }
// gyroscope_random_walk [rad/s^2/sqrt(Hz)] = K [deg/s/sqrt(s)] x pi/180.
constexpr double DegPerSecPerRootSecToRadPerSecSqPerRootHz(double k) { return k * kRadPerDeg; }
// Bias in rad/s.
constexpr double DegPerSecToRadPerSec(double b) { return b * kRadPerDeg; }
// (accelerometer_noise_density and accelerometer_random_walk are N and K in
// m/s^2/sqrt(Hz) and m/s^3/sqrt(Hz): the base units, no conversion.)

// --- Spectral conventions -----------------------------------------------------
// One-sided ASD = sqrt(2) x IEEE 952's two-sided N (same unit).
inline constexpr double kSqrt2 = std::numbers::sqrt2;
constexpr double TwoSidedNoiseDensityToOneSidedAsd(double n) { return kSqrt2 * n; }
constexpr double OneSidedAsdToTwoSidedNoiseDensity(double asd) { return asd / kSqrt2; }
// White rate samples of standard deviation sd (rate unit) at interval tau0_s:
// N = sd sqrt(tau0) (rate unit x sqrt(s)).
double WhiteRateStdDevToNoiseDensity(double sd, double tau0_s);

// --- Datasheet presentation ---------------------------------------------------
enum class SensorKind { kGyro, kAccelerometer };

// A fitted term converted to the unit datasheets quote it in.
struct DatasheetValue {
  double value = kNaN;
  std::string_view unit;  // static string, e.g. "deg/sqrt(h)"
};

// The base unit of `term` for `kind` (see TermEstimate), e.g. "deg/sqrt(s)".
std::string_view BaseUnit(NoiseTerm term, SensorKind kind);

// Converts a term from its base unit to the datasheet unit:
//   gyro:  Q deg, N deg/sqrt(h), B deg/h, K deg/h/sqrt(h), R deg/h^2;
//   accel: Q m/s, N m/s/sqrt(h), B ug, K ug/sqrt(h), R ug/h.
DatasheetValue ToDatasheetUnits(NoiseTerm term, SensorKind kind, double base_value);

// --- Sensor output units ------------------------------------------------------
// The factor from a sensor's output unit to the base unit of its kind (deg/s
// for a gyro, m/s^2 for an accelerometer): gyro "deg/s", "rad/s", "mrad/s",
// "deg/h", "rpm"; accelerometer "m/s^2" (or "m/s2"), "g" (9.80665 m/s^2),
// "mg", "ug". NaN for a name that is not a unit of that kind.
double OutputUnitToBase(std::string_view unit, SensorKind kind);
// The names OutputUnitToBase knows for `kind`, comma separated.
std::string_view OutputUnitNames(SensorKind kind);

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_UNITS_H_
