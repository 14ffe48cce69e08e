#include "analyze/allan/units.h"

#include <cmath>

namespace imuqual::allan {

double WhiteRateStdDevToNoiseDensity(double sd, double tau0_s) { return sd * std::sqrt(tau0_s); }

std::string_view BaseUnit(NoiseTerm term, SensorKind kind) {
  const bool gyro = kind == SensorKind::kGyro;
  switch (term) {
    case NoiseTerm::kQuantization:
      return gyro ? "deg" : "m/s";
    case NoiseTerm::kAngleRandomWalk:
      return gyro ? "deg/sqrt(s)" : "m/s/sqrt(s)";
    case NoiseTerm::kBiasInstability:
      return gyro ? "deg/s" : "m/s^2";
    case NoiseTerm::kRateRandomWalk:
      return gyro ? "deg/s/sqrt(s)" : "m/s^2/sqrt(s)";
    case NoiseTerm::kRateRamp:
      return gyro ? "deg/s^2" : "m/s^3";
  }
  return "";
}

DatasheetValue ToDatasheetUnits(NoiseTerm term, SensorKind kind, double base_value) {
  if (kind == SensorKind::kGyro) {
    switch (term) {
      case NoiseTerm::kQuantization:
        return {base_value, "deg"};
      case NoiseTerm::kAngleRandomWalk:
        return {DegPerRootSecToDegPerRootHour(base_value), "deg/sqrt(h)"};
      case NoiseTerm::kBiasInstability:
        return {DegPerSecToDegPerHour(base_value), "deg/h"};
      case NoiseTerm::kRateRandomWalk:
        return {DegPerSecPerRootSecToDegPerHourPerRootHour(base_value), "deg/h/sqrt(h)"};
      case NoiseTerm::kRateRamp:
        return {DegPerSecSqToDegPerHourSq(base_value), "deg/h^2"};
    }
  }
  switch (term) {
    case NoiseTerm::kAngleRandomWalk:
      return {MetersPerSecSqPerRootHzToMetersPerSecPerRootHour(base_value), "m/s/sqrt(h)"};
    case NoiseTerm::kBiasInstability:
      return {MetersPerSecSqToMicroG(base_value), "ug"};
    case NoiseTerm::kRateRandomWalk:
      // m/s^2/sqrt(s) -> ug/sqrt(h): 1/sqrt(s) = 60/sqrt(h).
      return {MetersPerSecSqToMicroG(base_value) * 60.0, "ug/sqrt(h)"};
    case NoiseTerm::kRateRamp:
      // m/s^3 -> ug/h.
      return {MetersPerSecSqToMicroG(base_value) * kSecondsPerHour, "ug/h"};
    default:
      return {base_value, BaseUnit(term, kind)};
  }
}

double OutputUnitToBase(std::string_view unit, SensorKind kind) {
  if (kind == SensorKind::kGyro) {
    if (unit == "deg/s") return 1.0;
    if (unit == "rad/s") return 1.0 / kRadPerDeg;
    if (unit == "mrad/s") return 1e-3 / kRadPerDeg;
    if (unit == "deg/h") return 1.0 / kSecondsPerHour;
    if (unit == "rpm") return 6.0;  // 360 deg per 60 s
    return kNaN;
  }
  if (unit == "m/s^2" || unit == "m/s2") return 1.0;
  if (unit == "g") return kStandardGravityMetersPerSecSq;
  if (unit == "mg") return 1e-3 * kStandardGravityMetersPerSecSq;
  if (unit == "ug") return kMicroGInMetersPerSecSq;
  return kNaN;
}

std::string_view OutputUnitNames(SensorKind kind) {
  return kind == SensorKind::kGyro ? "deg/s, rad/s, mrad/s, deg/h, rpm" : "m/s^2, g, mg, ug";
}

}  // namespace imuqual::allan
