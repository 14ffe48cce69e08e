// Lot statistics for qualification: per-measurement summaries with yield and
// process capability against the plan's limits, and the tests that say
// whether two lots differ (means: Welch's t-test; spreads: the F-test on
// variances; yields: Fisher's exact test), with Holm's step-down correction
// across the many comparisons a lot comparison makes. Pure.
#ifndef IMUQUAL_ANALYZE_JUDGE_STATISTICS_H_
#define IMUQUAL_ANALYZE_JUDGE_STATISTICS_H_

#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "imuqual/record.pb.h"

namespace imuqual::judge {

struct Summary {
  int64_t n = 0;     // finite values
  double mean = std::numeric_limits<double>::quiet_NaN();
  double sd = std::numeric_limits<double>::quiet_NaN();  // sample sd (n - 1)
  double min = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
  int64_t judged = 0;    // values judged PASS, MARGINAL or FAIL
  int64_t passed = 0;    // PASS or MARGINAL
  int64_t marginal = 0;
  int64_t inconclusive = 0;  // INCONCLUSIVE (retest candidates): not in `judged`
  double yield = std::numeric_limits<double>::quiet_NaN();  // passed / judged
  // Process capability against the limits: Cpk = min(USL - mean, mean - LSL) / 3 sd
  // with both limits, Cpu = (USL - mean) / 3 sd with an upper one only,
  // Cpl = (mean - LSL) / 3 sd with a lower one only; with its 95 % confidence
  // interval (Bissell's normal approximation, for normally distributed
  // values: Cpk -+ 1.96 sqrt(1 / (9 n) + Cpk^2 / (2 (n - 1)))). NaN without
  // limits or sd, and below kMinCapabilityN values (capability_kind then
  // still says which index the limits call for).
  double capability = std::numeric_limits<double>::quiet_NaN();
  double capability_low = std::numeric_limits<double>::quiet_NaN();
  double capability_high = std::numeric_limits<double>::quiet_NaN();
  std::string capability_kind;  // "Cpk", "Cpu", "Cpl" or ""
};

// Fewer values give no capability index: at n = 10 a Cpk of 1.33 is already
// only known to within [0.68, 1.98] (95 %); at n = 2 it says nothing.
inline constexpr int64_t kMinCapabilityN = 10;

// `outcomes` parallel to `values` (or empty); NaN values are not counted.
Summary Summarize(std::span<const double> values, std::span<const pb::Outcome> outcomes,
                  std::optional<double> low, std::optional<double> high);

struct TestResult {
  double statistic = std::numeric_limits<double>::quiet_NaN();
  double p_value = std::numeric_limits<double>::quiet_NaN();  // two-sided; NaN: not testable
};

// Welch's unequal-variance t-test of equal means (needs n >= 2 on both sides).
TestResult WelchTTest(const Summary& a, const Summary& b);
// F-test of equal variances, two-sided (needs n >= 2 and sd > 0 on both sides).
TestResult VarianceFTest(const Summary& a, const Summary& b);
// Fisher's exact test of equal pass rates, two-sided; the statistic is the
// difference of the rates.
TestResult FisherExactTest(int64_t passed_a, int64_t n_a, int64_t passed_b, int64_t n_b);

// Holm's step-down procedure: which of the p-values are significant at
// family-wise level alpha. NaN p-values are never significant.
std::vector<bool> HolmSignificant(std::span<const double> p_values, double alpha);

}  // namespace imuqual::judge

#endif  // IMUQUAL_ANALYZE_JUDGE_STATISTICS_H_
