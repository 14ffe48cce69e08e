// Types shared by every part of the Allan analysis core (imuqual::allan).
// The core is pure: no LCM, SQLite, clock or files. It takes spans of samples
// and returns values.
//
// Conventions (ALGORITHMS.md): rate samples y_0..y_{M-1} at interval tau0;
// phase x_0..x_{N-1} with N = M + 1, x_0 = 0, x_{k+1} = x_k + tau0 (y_k - yref).
// Averaging factor m, tau = m tau0. "dev" = sqrt("var").
#ifndef IMUQUAL_ANALYZE_ALLAN_CURVE_H_
#define IMUQUAL_ANALYZE_ALLAN_CURVE_H_

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imuqual::allan {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The statistic a curve holds.
enum class Deviation {
  kAdev,    // non-overlapping Allan deviation (stride m)
  kOadev,   // fully overlapping Allan deviation
  kMdev,    // modified Allan deviation
  kTdev,    // time deviation, tau/sqrt(3) * MDEV (units of phase)
  kHdev,    // Hadamard deviation (stride m)
  kOhdev,   // overlapping Hadamard deviation
  kTotdev,  // total deviation (reflected extension)
  // Long-tau estimators (long_tau.h):
  kTheo1,    // Theo1 (Howe), reported at the effective tau 0.75 m tau0
  kTheoBr,   // bias-removed Theo1
  kTheoH,    // hybrid: OADEV at short tau, TheoBR at long tau
  kMtotdev,  // modified total deviation
  kTtotdev,  // time total deviation, tau/sqrt(3) * MTOTDEV (units of phase)
  kHtotdev,  // Hadamard total deviation
};

// "adev", "oadev", ... and back. Parse returns nullopt for unknown names.
std::string_view DeviationName(Deviation d);
std::optional<Deviation> ParseDeviation(std::string_view name);

// How far along tau a reported curve goes.
enum class StopRule {
  kBins9,     // the seed's rule: m <= floor(M/9), at least 9 clusters (default)
  kStable32,  // Stable32 stop ratios: m <= floor(N/r), r = 5, 4, 2 by estimator
  kNone,      // every m with n > 1 (the reference implementation's behaviour)
};
std::string_view StopRuleName(StopRule s);
std::optional<StopRule> ParseStopRule(std::string_view name);

// Confidence interval method attached to a curve.
enum class CiMethod {
  kNone,
  kSimple,  // seed / IEEE 952: dev * (1 -+ 1/sqrt(2(K-1))), K non-overlapping clusters
  kChi2,    // chi-square with Greenhall edf and lag-1 ACF noise identification
};
std::string_view CiMethodName(CiMethod c);
std::optional<CiMethod> ParseCiMethod(std::string_view name);

// One point of a deviation curve.
struct CurvePoint {
  int64_t m = 0;          // averaging factor, tau = m * tau0 (Theo1/TheoBR and TheoH's
                          // Theo points: tau = 0.75 m tau0, long_tau.h)
  double tau_s = 0;       // averaging time, s
  double dev = kNaN;      // deviation, in the input's rate unit (TDEV, TTOTDEV: rate unit * s)
  int64_t n = 0;          // terms in the estimator's outer sum (valid terms only)
  int64_t stride = 0;     // terms are taken every `stride` samples: 1 fully overlapped,
                          // m non-overlapped, m/c in the streaming cascade; 0 unknown
  double lo = kNaN;       // lower confidence bound on dev (NaN: none)
  double hi = kNaN;       // upper confidence bound on dev (NaN: none)
  double edf = kNaN;      // degrees of freedom behind lo/hi (NaN: none)
  std::optional<int> alpha;  // identified power-law exponent, if any (chi2 CI)
  // alpha was not identified at this point (too few points for the lag-1
  // method at the long-tau end) but taken from the nearest identified point.
  bool alpha_inherited = false;
};

// A deviation curve over a grid of averaging factors.
struct Curve {
  Deviation deviation = Deviation::kOadev;
  double tau0_s = 1.0;
  int64_t n_phase = 0;        // phase points N behind the curve (M + 1 for rate input)
  int64_t invalid_rate_samples = 0;  // gaps/invalid samples inside the record
  CiMethod ci = CiMethod::kNone;
  double confidence = 0.682689492137086;  // level of lo/hi
  std::vector<CurvePoint> points;
};

}  // namespace imuqual::allan

#endif  // IMUQUAL_ANALYZE_ALLAN_CURVE_H_
